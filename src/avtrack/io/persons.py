"""``persons.csv``: every tracked person at every video frame, seen by the camera or not.

Header ``frame,time_s,id,azimuth_deg,elevation_deg,x,y,in_view,speaking``: 1-based video frame,
its time ``(frame - 1) / fps``, the person id, the direction from the microphone array (degrees,
azimuth counter-clockwise from the array's x axis in (-180, 180], elevation up), the image
position of that direction in pixels (both empty when it is outside the image), whether the
person is in the camera's field of view (0/1), and the probability that the person speaks.
Written by ``avtrack track-av``; read by ``avtrack eval persons``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from avtrack.errors import InputError
from avtrack.io.base import parse_finite

#: Header of ``persons.csv``.
PERSONS_HEADER = "frame,time_s,id,azimuth_deg,elevation_deg,x,y,in_view,speaking"


@dataclass(frozen=True)
class PersonsTable:
    """Every tracked person at every frame (the rows of ``persons.csv``).

    Attributes
    ----------
    frames : ndarray (K,) int
        1-based video frame (time ``(frame - 1) / fps``).
    ids : ndarray (K,) int
    azimuth_deg, elevation_deg : ndarray (K,)
    pixels : ndarray (K, 2)
        Image position; NaN when the direction is outside the image.
    in_view : ndarray (K,) bool
    speaking : ndarray (K,) float
        Speaking probability.
    fps : float
    side : ndarray (K,) int, optional
        -1 / +1: left / right of the camera's optical axis (for drawing persons out of the
        image; not written to the CSV).
    """

    frames: np.ndarray
    ids: np.ndarray
    azimuth_deg: np.ndarray
    elevation_deg: np.ndarray
    pixels: np.ndarray
    in_view: np.ndarray
    speaking: np.ndarray
    fps: float
    side: np.ndarray | None = None

    def __len__(self) -> int:
        return int(self.frames.shape[0])

    def to_csv(self) -> str:
        """The table as ``persons.csv`` text (header :data:`PERSONS_HEADER`)."""
        lines = [PERSONS_HEADER]
        for f, i, a, e, (x, y), v, s in zip(
            self.frames.tolist(), self.ids.tolist(), self.azimuth_deg.tolist(),
            self.elevation_deg.tolist(), self.pixels.tolist(), self.in_view.tolist(),
            self.speaking.tolist(), strict=True,
        ):
            xs = "" if not np.isfinite(x) else f"{x:.1f}"
            ys = "" if not np.isfinite(y) else f"{y:.1f}"
            lines.append(
                f"{f},{(f - 1) / self.fps:.4f},{i},{a:.2f},{e:.2f},{xs},{ys},{int(v)},{s:.3f}"
            )
        return "\n".join(lines) + "\n"




def read_persons_csv(path: str | Path, fps: float | None = None) -> PersonsTable:
    """Read a ``persons.csv`` file.

    Parameters
    ----------
    path : str or Path
    fps : float, optional
        Frame rate (default: from the first two distinct frames' times, else 25).

    Raises
    ------
    InputError
        Missing or empty file, another header, a row without 9 fields, a frame < 1 or an id
        < 0 that is not an integer, a non-finite number, an azimuth outside (-180, 180], an
        elevation outside [-90, 90], only one of x and y, ``in_view`` other than 0/1, a
        speaking probability outside [0, 1].
    """
    path = Path(path)
    if not path.is_file():
        raise InputError("file not found" if not path.exists() else "not a regular file", path)
    try:
        lines = path.read_text(encoding="utf-8-sig").splitlines()
    except UnicodeDecodeError:
        raise InputError("not a text file (cannot decode as UTF-8)", path) from None
    if not lines:
        raise InputError(f"empty file, expected the header {PERSONS_HEADER!r}", path)
    if lines[0].strip() != PERSONS_HEADER:
        raise InputError(f"header must be {PERSONS_HEADER!r}, got {lines[0].strip()!r}", path, 1)
    rows: list[tuple] = []
    for row, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        p = [x.strip() for x in line.split(",")]
        if len(p) != 9:
            raise InputError(f"expected 9 comma-separated values ({PERSONS_HEADER}), got "
                             f"{len(p)}", path, row)
        try:
            frame, pid = int(p[0]), int(p[2])
        except ValueError:
            raise InputError("frame and id must be integers", path, row) from None
        if frame < 1 or pid < 0:
            raise InputError(f"frame must be >= 1 and id >= 0, got {frame}, {pid}", path, row)
        t = parse_finite(p[1], "time_s", path, row)
        az = parse_finite(p[3], "azimuth_deg", path, row)
        el = parse_finite(p[4], "elevation_deg", path, row)
        if not -180.0 < az <= 180.0:
            raise InputError(f"azimuth_deg must be in (-180, 180], got {p[3]}", path, row)
        if not -90.0 <= el <= 90.0:
            raise InputError(f"elevation_deg must be in [-90, 90], got {p[4]}", path, row)
        if (p[5] == "") != (p[6] == ""):
            raise InputError("x and y must both be given or both be empty", path, row)
        x = float("nan") if p[5] == "" else parse_finite(p[5], "x", path, row)
        y = float("nan") if p[6] == "" else parse_finite(p[6], "y", path, row)
        if p[7] not in ("0", "1"):
            raise InputError(f"in_view must be 0 or 1, got {p[7]!r}", path, row)
        s = parse_finite(p[8], "speaking", path, row)
        if not 0.0 <= s <= 1.0:
            raise InputError(f"speaking must be a probability in [0, 1], got {p[8]}", path, row)
        rows.append((frame, t, pid, az, el, x, y, p[7] == "1", s))
    if fps is None:
        fps = 25.0
        by_frame = {r[0]: r[1] for r in rows}
        frames = sorted(by_frame)
        if len(frames) >= 2 and by_frame[frames[1]] > by_frame[frames[0]]:
            fps = (frames[1] - frames[0]) / (by_frame[frames[1]] - by_frame[frames[0]])
    if not rows:
        return PersonsTable(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0),
                            np.zeros(0), np.zeros((0, 2)), np.zeros(0, bool), np.zeros(0),
                            float(fps))
    a = list(zip(*rows, strict=True))
    return PersonsTable(
        np.array(a[0], np.int64), np.array(a[2], np.int64), np.array(a[3]), np.array(a[4]),
        np.column_stack([a[5], a[6]]), np.array(a[7], bool), np.array(a[8]), float(fps),
    )
