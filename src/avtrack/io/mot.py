"""MOTChallenge text files: detections, ground truth and tracker results.

One row per box: ``frame, id, left, top, width, height, conf, x, y, z`` (MOT15) or
``frame, id, left, top, width, height, flag, class, visibility`` (MOT16/17 ground truth).
Frames are 1-based; boxes are in pixels with (left, top) the top-left corner.

Readers validate every row and raise :class:`~avtrack.errors.InputError` naming the file and
the 1-based row. An empty file is valid and yields zero rows (a sequence in which nothing was
detected); a missing file is an error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np

from avtrack.errors import InputError
from avtrack.io.base import atomic_write, check_frame_span

Kind = Literal["det", "gt", "result"]


@dataclass(frozen=True)
class MOTData:
    """Rows of a MOTChallenge file, sorted by frame.

    Attributes
    ----------
    frames : ndarray (K,) int
        1-based frame number of each row.
    ids : ndarray (K,) int
        Track / ground-truth identity (-1 for detections).
    boxes : ndarray (K, 4) float
        ``(left, top, width, height)`` in pixels; width and height > 0.
    scores : ndarray (K,) float
        Column 7: detection confidence, result confidence, or the ground-truth "consider" flag.
    extra : ndarray (K, E) float
        Remaining columns (8 onwards), NaN-padded to a common width; E may be 0.
    """

    frames: np.ndarray
    ids: np.ndarray
    boxes: np.ndarray
    scores: np.ndarray
    extra: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))

    def __post_init__(self) -> None:
        k = np.asarray(self.frames).shape[0]
        object.__setattr__(self, "frames", np.asarray(self.frames, dtype=np.int64).reshape(k))
        object.__setattr__(self, "ids", np.asarray(self.ids, dtype=np.int64).reshape(k))
        object.__setattr__(self, "boxes", np.asarray(self.boxes, dtype=float).reshape(k, 4))
        object.__setattr__(self, "scores", np.asarray(self.scores, dtype=float).reshape(k))
        extra = np.asarray(self.extra, dtype=float)
        if extra.size == 0:
            extra = np.zeros((k, 0))
        if extra.ndim != 2 or extra.shape[0] != k:
            raise ValueError(f"MOTData: extra must have shape ({k}, E), got {extra.shape}")
        object.__setattr__(self, "extra", extra)
        if k and not np.all(np.isfinite(self.boxes)):
            raise ValueError("MOTData: boxes must be finite")
        if k and np.any(self.boxes[:, 2:] <= 0):
            raise ValueError("MOTData: box width and height must be > 0")
        if k and np.any(self.frames < 1):
            raise ValueError("MOTData: frame numbers must be >= 1")
        if k and np.any(np.diff(self.frames) < 0):
            raise ValueError("MOTData: rows must be sorted by frame")

    def __len__(self) -> int:
        return int(self.frames.shape[0])

    @property
    def n_frames(self) -> int:
        """Last frame number (0 for an empty file)."""
        return int(self.frames.max()) if len(self) else 0

    def frame_slices(self, n_frames: int | None = None) -> list[slice]:
        """Row slice of each frame 1..n_frames (rows are sorted by frame)."""
        n = self.n_frames if n_frames is None else n_frames
        starts = np.searchsorted(self.frames, np.arange(1, n + 2), side="left")
        return [slice(int(starts[i]), int(starts[i + 1])) for i in range(n)]

    def select(self, mask: np.ndarray) -> MOTData:
        """Rows where ``mask`` is True, as a new MOTData."""
        return MOTData(
            self.frames[mask], self.ids[mask], self.boxes[mask], self.scores[mask],
            self.extra[mask],
        )


#: Largest frame number / id accepted (ids and frames are stored as int64; beyond 2**53 a
#: float no longer holds every integer).
MAX_INDEX = 2**53


def _parse_row(text: str, path: Path, row: int) -> list[float]:
    parts = [p.strip() for p in (text.split(",") if "," in text else text.split())]
    if parts and parts[-1] == "":
        parts = parts[:-1]  # tolerate a trailing comma
    if len(parts) < 6:
        raise InputError(
            f"expected at least 6 comma-separated values (frame,id,left,top,width,height), "
            f"got {len(parts)}: {text.strip()!r}", path, row,
        )
    values = []
    for col, p in enumerate(parts, start=1):
        try:
            v = float(p)
        except ValueError:
            raise InputError(f"column {col} is not a number: {p!r}", path, row) from None
        values.append(v)
    frame, tid, left, top, w, h = values[:6]
    for name, v in (("frame", frame), ("left", left), ("top", top), ("width", w),
                    ("height", h)):
        if not math.isfinite(v):
            raise InputError(f"{name} is {v}, expected a finite number", path, row)
    if not math.isfinite(tid) or tid != int(tid) or abs(tid) > MAX_INDEX:
        raise InputError(f"id (column 2) must be an integer, got {parts[1]!r}", path, row)
    if frame != int(frame) or not 1 <= frame <= MAX_INDEX:
        raise InputError(
            f"frame must be an integer >= 1, got {parts[0]!r} (at most 2**53)", path, row
        )
    if w <= 0 or h <= 0:
        raise InputError(f"box width and height must be > 0, got {w:g} x {h:g}", path, row)
    if len(values) > 6 and math.isnan(values[6]):
        raise InputError("confidence (column 7) is NaN", path, row)
    return values


def read_mot(path: str | Path, kind: Kind = "det") -> MOTData:
    """Read a MOTChallenge detection, ground-truth or result file.

    Parameters
    ----------
    path : str or Path
        The text file.
    kind : {"det", "gt", "result"}
        For ``"det"`` the frame numbers must be non-decreasing (as every detector writes
        them) and a decreasing frame is an error naming the row. Ground truth and results are
        commonly sorted by identity, so for those the rows are stably sorted by frame.

    Returns
    -------
    MOTData

    Raises
    ------
    InputError
        Missing file, or a row with too few columns, a non-number, a NaN/inf coordinate, a
        non-positive box size, a non-integer or < 1 frame, (det) a decreasing frame, or a
        frame far past what the file's rows can describe
        (:func:`~avtrack.io.base.check_frame_span`).
    """
    if kind not in ("det", "gt", "result"):
        raise ValueError(f"read_mot: kind must be 'det', 'gt' or 'result', got {kind!r}")
    path = Path(path)
    if not path.is_file():
        raise InputError("file not found" if not path.exists() else "not a regular file",
                         path)
    try:
        text = path.read_text()
    except UnicodeDecodeError:
        raise InputError("not a text file (cannot decode as UTF-8)", path) from None
    rows: list[list[float]] = []
    last_frame = 0.0
    for i, line in enumerate(text.splitlines(), start=1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        values = _parse_row(line, path, i)
        if kind == "det" and values[0] < last_frame:
            raise InputError(
                f"frame numbers must not decrease (frame {int(values[0])} after "
                f"{int(last_frame)})", path, i,
            )
        last_frame = values[0]
        rows.append(values)
    if not rows:
        return MOTData(np.zeros(0), np.zeros(0), np.zeros((0, 4)), np.zeros(0))
    check_frame_span(max(r[0] for r in rows), len(rows), path)
    width = max(len(r) for r in rows)
    arr = np.full((len(rows), max(width, 7)), np.nan)
    for i, r in enumerate(rows):
        arr[i, : len(r)] = r
    if width < 7:
        arr[:, 6] = 1.0
    order = np.argsort(arr[:, 0], kind="stable")
    arr = arr[order]
    ids = np.nan_to_num(arr[:, 1], nan=-1.0)
    return MOTData(arr[:, 0], ids, arr[:, 2:6], arr[:, 6], arr[:, 7:])


def write_mot(path: str | Path, data: MOTData) -> None:
    """Write rows atomically as ``frame,id,left,top,width,height,conf,<extra>``.

    ``<extra>`` is ``data.extra``'s columns when it has any (e.g. the ``class,visibility`` of
    MOT16 ground truth, or ``x,y,z`` of MOT15), else ``-1,-1,-1`` (the MOTChallenge result
    format). The file is written to a temporary name and renamed, so an interrupted run never
    leaves a half-written file.
    """
    extra = data.extra if data.extra.shape[1] else None
    with atomic_write(path) as fh:
        for k, (f, i, b, s) in enumerate(
            zip(data.frames, data.ids, data.boxes, data.scores, strict=True)
        ):
            tail = "-1,-1,-1" if extra is None else ",".join(f"{v:.6g}" for v in extra[k])
            fh.write(f"{f},{i},{b[0]:.2f},{b[1]:.2f},{b[2]:.2f},{b[3]:.2f},{s:.4g},{tail}\n")
