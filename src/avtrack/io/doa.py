"""DOA / acoustic-track CSV files.

Header exactly ``frame,time_s,id,azimuth_deg,elevation_deg,weight,active``, then one row per
estimate: the frame index, its time in seconds, the track id (-1 for frame-wise peaks), the
azimuth in the array frame (degrees counter-clockwise from the x axis, in (−180, 180]), the
elevation (degrees, [−90, 90]), a weight, and whether the estimate is active (``1``/``0``).

:func:`read_doa_csv` raises :class:`~avtrack.errors.InputError` naming the file and the 1-based
row (the header is row 1); :func:`write_doa_csv` writes atomically with 4-decimal times and
3-decimal angles.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, overload

import numpy as np

from avtrack.errors import InputError
from avtrack.io.base import atomic_write, check_frame_span, field_count_error, parse_finite

DOA_HEADER = "frame,time_s,id,azimuth_deg,elevation_deg,weight,active"
_COLUMNS = DOA_HEADER.split(",")
_FIELDS = ("frames", "time_s", "ids", "azimuth_deg", "elevation_deg", "weight", "active")
_TRUE = frozenset({"1", "true"})
_FALSE = frozenset({"0", "false"})


@overload
def wrap_azimuth(deg: float) -> float: ...
@overload
def wrap_azimuth(deg: np.ndarray) -> np.ndarray: ...
def wrap_azimuth(deg: float | np.ndarray) -> float | np.ndarray:
    """Angles in degrees wrapped to (−180, 180] (−180 maps to 180).

    Parameters
    ----------
    deg : float or ndarray
        Finite angles; NaN stays NaN.

    Returns
    -------
    float or ndarray
        Same shape as ``deg``.
    """
    a = np.asarray(deg, dtype=float)
    w = np.mod(a + 180.0, 360.0) - 180.0  # in [-180, 180)
    w = np.where(w <= -180.0, w + 360.0, w)
    return float(w) if np.ndim(deg) == 0 else w


@dataclass(frozen=True, eq=False)
class DOATable:
    """Rows of a DOA / track CSV, as columns.

    Attributes
    ----------
    frames : ndarray (K,) int
        Frame index, >= 0.
    time_s : ndarray (K,) float
        Time of the frame, seconds, >= 0.
    ids : ndarray (K,) int
        Track id, -1 for frame-wise peaks.
    azimuth_deg : ndarray (K,) float
        Azimuth in degrees, wrapped to (−180, 180] on construction.
    elevation_deg : ndarray (K,) float
        Elevation in degrees, [−90, 90].
    weight : ndarray (K,) float
        Finite weight (peak power, posterior weight, ...).
    active : ndarray (K,) bool
    """

    frames: np.ndarray
    time_s: np.ndarray
    ids: np.ndarray
    azimuth_deg: np.ndarray
    elevation_deg: np.ndarray
    weight: np.ndarray
    active: np.ndarray

    def __post_init__(self) -> None:
        k = np.shape(self.frames)[0] if np.ndim(self.frames) else -1
        for name in _FIELDS:
            if np.ndim(getattr(self, name)) != 1 or np.shape(getattr(self, name))[0] != k:
                raise ValueError(
                    f"DOATable: {name} must have shape (K,) like frames "
                    f"({max(k, 0)},), got {np.shape(getattr(self, name))}"
                )
        for name in ("frames", "ids"):
            v = np.asarray(getattr(self, name))
            if v.dtype == bool or not np.issubdtype(v.dtype, np.number):
                raise ValueError(f"DOATable: {name} must be integers, got dtype {v.dtype}")
            if k and not (np.all(np.isfinite(v)) and np.all(v == np.round(v))):
                raise ValueError(f"DOATable: {name} must be integers")
            object.__setattr__(self, name, v.astype(np.int64))
        if k and self.frames.min() < 0:
            raise ValueError("DOATable: frames must be >= 0")
        if k and self.ids.min() < -1:
            raise ValueError("DOATable: ids must be >= -1 (-1 for frame-wise peaks)")
        for name in ("time_s", "azimuth_deg", "elevation_deg", "weight"):
            v = np.asarray(getattr(self, name), dtype=float)
            if not np.all(np.isfinite(v)):
                raise ValueError(f"DOATable: {name} must be finite (no NaN or inf)")
            object.__setattr__(self, name, v)
        if k and self.time_s.min() < 0:
            raise ValueError("DOATable: time_s must be >= 0")
        if k and np.abs(self.elevation_deg).max() > 90:
            raise ValueError("DOATable: elevation_deg must be in [-90, 90]")
        object.__setattr__(self, "azimuth_deg", np.asarray(wrap_azimuth(self.azimuth_deg)))
        act = np.asarray(self.active)
        if act.dtype != bool:
            if not np.issubdtype(act.dtype, np.number) or not np.all((act == 0) | (act == 1)):
                raise ValueError("DOATable: active must be bool or 0/1")
            act = act != 0
        object.__setattr__(self, "active", act)

    def __len__(self) -> int:
        return int(self.frames.shape[0])

    @classmethod
    def empty(cls) -> DOATable:
        """A table with no rows."""
        z = np.zeros(0)
        return cls(z.astype(np.int64), z, z.astype(np.int64), z, z, z, z.astype(bool))

    @classmethod
    def concatenate(cls, parts: list[DOATable]) -> DOATable:
        """The rows of ``parts``, one table after the other."""
        if not parts:
            return cls.empty()
        return cls(*(np.concatenate([getattr(p, name) for p in parts]) for name in _FIELDS))

    def select(self, mask: np.ndarray) -> DOATable:
        """Rows where ``mask`` is True (or at the given indices), as a new table."""
        return DOATable(*(getattr(self, name)[mask] for name in _FIELDS))


def format_doa_row(
    frame: int, time_s: float, track_id: int, azimuth_deg: float, elevation_deg: float,
    weight: float, active: bool,
) -> str:
    """One CSV line (with its newline) as :func:`write_doa_csv` writes it: angles rounded to 3
    decimals (an azimuth that rounds to −180 is written as 180), the time to 4 decimals, the
    weight with 6 significant digits."""
    az = wrap_azimuth(round(float(azimuth_deg), 3))
    el = round(float(elevation_deg), 3)
    return f"{frame},{time_s:.4f},{track_id},{az:.3f},{el:.3f},{weight:.6g},{int(active)}\n"


def _doa_rows(table: DOATable) -> list[str]:
    return [
        format_doa_row(*row)
        for row in zip(
            table.frames.tolist(), table.time_s.tolist(), table.ids.tolist(),
            table.azimuth_deg.tolist(), table.elevation_deg.tolist(), table.weight.tolist(),
            table.active.tolist(), strict=True,
        )
    ]


class DOACsvWriter:
    """A DOA / track CSV written as its rows are produced, atomically: the header, then the
    rows of each :meth:`write` in order, in a temporary file renamed onto ``path`` when the
    ``with`` block ends without an error (:func:`~avtrack.io.base.atomic_write`).

    Examples
    --------
    >>> with DOACsvWriter("doa.csv") as out:
    ...     for table in tables:       # DOATable chunks, in frame order
    ...         out.write(table)
    """

    def __init__(self, path: str | Path) -> None:
        self.path = path
        self.rows = 0
        self._cm = atomic_write(path)
        self._fh: Any = None

    def __enter__(self) -> DOACsvWriter:
        self._fh = self._cm.__enter__()
        self._fh.write(DOA_HEADER + "\n")
        return self

    def write(self, table: DOATable) -> None:
        """Append the rows of ``table``."""
        if not isinstance(table, DOATable):
            raise TypeError(f"DOACsvWriter.write: expected a DOATable, got {type(table).__name__}")
        if self._fh is None:
            raise ValueError("DOACsvWriter.write: use the writer in a 'with' block")
        self._fh.writelines(_doa_rows(table))
        self.rows += len(table)

    def __exit__(self, *exc: Any) -> bool | None:
        self._fh = None
        return self._cm.__exit__(*exc)


def write_doa_csv(path: str | Path, table: DOATable) -> None:
    """Write ``table`` atomically: header, then one row per estimate in table order
    (:func:`format_doa_row`)."""
    if not isinstance(table, DOATable):
        raise TypeError(f"write_doa_csv: table must be a DOATable, got {type(table).__name__}")
    with DOACsvWriter(path) as out:
        out.write(table)


def _parse_int(text: str, name: str, path: Path, row: int) -> int:
    try:
        return int(text)
    except ValueError:
        raise InputError(f"{name} must be an integer, got {text!r}", path, row) from None



def read_doa_csv(path: str | Path) -> DOATable:
    """Read a DOA / track CSV.

    Returns
    -------
    DOATable
        Rows in file order; a file with only the header gives an empty table.

    Raises
    ------
    InputError
        Missing or empty file, a header other than ``frame,time_s,id,azimuth_deg,
        elevation_deg,weight,active``, a row without 7 fields, a non-integer frame or id, a
        non-number / NaN / inf value, a negative frame or time, an id < -1, an azimuth outside
        (−180, 180], an elevation outside [−90, 90], or an ``active`` other than 0/1.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError("file not found" if not path.exists() else "not a regular file", path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError:
        raise InputError("not a text file (cannot decode as UTF-8)", path) from None
    lines = text.splitlines()
    if not lines:
        raise InputError(f"empty file, expected the header {DOA_HEADER!r}", path)
    header = lines[0].strip()
    if header != DOA_HEADER:
        raise InputError(f"header must be {DOA_HEADER!r}, got {header!r}", path, 1)
    cols: list[list[float]] = [[] for _ in _COLUMNS]
    for row, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        parts = [p.strip() for p in line.split(",")]
        if len(parts) != len(_COLUMNS):
            raise field_count_error(
                f"{len(_COLUMNS)} comma-separated values ({DOA_HEADER})", len(parts), path, row
            )
        frame = _parse_int(parts[0], "frame", path, row)
        time_s = parse_finite(parts[1], "time_s", path, row)
        tid = _parse_int(parts[2], "id", path, row)
        az = parse_finite(parts[3], "azimuth_deg", path, row)
        el = parse_finite(parts[4], "elevation_deg", path, row)
        weight = parse_finite(parts[5], "weight", path, row)
        on = parts[6].lower()
        if frame < 0:
            raise InputError(f"frame must be >= 0, got {frame}", path, row)
        if time_s < 0:
            raise InputError(f"time_s must be >= 0, got {parts[1]}", path, row)
        if tid < -1:
            raise InputError(f"id must be >= -1 (-1 for frame-wise peaks), got {tid}", path, row)
        if not -180.0 < az <= 180.0:
            raise InputError(f"azimuth_deg must be in (-180, 180], got {parts[3]}", path, row)
        if not -90.0 <= el <= 90.0:
            raise InputError(f"elevation_deg must be in [-90, 90], got {parts[4]}", path, row)
        if on not in _TRUE | _FALSE:
            raise InputError(f"active must be 1 or 0, got {parts[6]!r}", path, row)
        for c, v in zip(cols, (frame, time_s, tid, az, el, weight, on in _TRUE), strict=True):
            c.append(v)
    if not cols[0]:
        return DOATable.empty()
    check_frame_span(max(cols[0]), len(cols[0]), path)
    check_frame_span(max(cols[1]), len(cols[0]), path, "time_s")
    return DOATable(
        np.array(cols[0], dtype=np.int64),
        np.array(cols[1]),
        np.array(cols[2], dtype=np.int64),
        np.array(cols[3]),
        np.array(cols[4]),
        np.array(cols[5]),
        np.array(cols[6], dtype=bool),
    )


def azimuths_per_frame(table: DOATable, fps: float, n_frames: int) -> list[np.ndarray]:
    """The active rows' azimuths of each video frame ``0 .. n_frames - 1`` (a row belongs to
    the frame nearest its time): list of ``n_frames`` sorted, de-duplicated arrays."""
    out: list[list[float]] = [[] for _ in range(n_frames)]
    idx = np.floor(table.time_s * fps + 0.5).astype(np.int64)
    for k, a, on in zip(idx.tolist(), table.azimuth_deg.tolist(), table.active.tolist(),
                        strict=True):
        if on and 0 <= k < n_frames:
            out[k].append(a)
    return [np.unique(np.asarray(v, dtype=float)) for v in out]


def directions_per_frame(
    table: DOATable, fps: float, n_frames: int
) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The active rows' azimuths and elevations of each video frame ``0 .. n_frames - 1`` (a
    row belongs to the frame nearest its time): two lists of ``n_frames`` arrays, in row
    order."""
    az: list[list[float]] = [[] for _ in range(n_frames)]
    el: list[list[float]] = [[] for _ in range(n_frames)]
    idx = np.floor(table.time_s * fps + 0.5).astype(np.int64)
    for k, a, e, on in zip(idx.tolist(), table.azimuth_deg.tolist(),
                           table.elevation_deg.tolist(), table.active.tolist(), strict=True):
        if on and 0 <= k < n_frames:
            az[k].append(a)
            el[k].append(e)
    return ([np.asarray(v, dtype=float) for v in az], [np.asarray(v, dtype=float) for v in el])
