"""LOCATA challenge recordings (Evers et al., "The LOCATA Challenge: Acoustic Source
Localization and Tracking", IEEE/ACM TASLP 2020; data at doi:10.5281/zenodo.3630470).

Published layout, one folder per recording and array::

    <root>/<split>/task<N>/recording<M>/<array>/      array in benchmark2, dicit, dummy, eigenmike
        audio_array_<array>.wav                        the array's M channels
        audio_array_timestamps_<array>.txt             (optional here) one row per audio sample
        audio_source_<talker>.wav                      (development set) source signals
        audio_source_timestamps_<talker>.txt
        position_array_<array>.txt                     array pose (+ microphones) over time
        position_source_<talker>.txt                   (development set) talker poses
        VAD_<array>_<talker>.txt                       (final release) voice activity per sample
        required_time.txt                              the times at which estimates are due

Text files are tab-separated with one header row, as read by the organisers' MATLAB tools
(``sap_locata_io``: ``load_data.m``, ``struct2position.m``, ``struct2time.m``):

- every timed table starts with ``year month day hour minute second`` (``second`` with a
  fraction);
- ``position_*``: then ``x y z`` (metres, OptiTrack world frame), ``ref_vec_x ref_vec_y
  ref_vec_z`` and ``rotation_11 ... rotation_33`` (row ``i``, column ``j`` of the
  local-to-world rotation); ``position_array_*`` adds ``mic<k>_x mic<k>_y mic<k>_z`` for
  ``k = 1..M`` in WAV channel order;
- ``required_time.txt``: the time columns and ``valid_flag`` (0/1);
- ``VAD_<array>_<talker>.txt``: a single column ``VAD`` (0/1), one row per sample of the array
  audio.

All times here are seconds relative to the first row of ``required_time.txt``. The organisers'
``get_truth.m`` pairs the rows of the position files with those of ``required_time.txt`` and
computes the direction of a source in the array frame as ``v = R' (h - p)`` (``R`` the array
rotation, ``p`` its position, ``h`` the source position); :func:`locata_source_azimuths` does
the same. LOCATA's own azimuth is ``atan2(v_y, v_x) - 90°`` (0° along the array's +y axis,
``mycart2sph.m``); avtrack's is ``atan2(v_y, v_x)`` (counter-clockwise from +x), the default.

Optical-tracking dropouts may appear as NaN positions in the published tables; they are kept
(``allow_nan_positions=True``) and give NaN azimuths. Time columns, flags, VAD and audio must
be finite.

:func:`load_locata_tracks` reads the azimuth / voice-activity tracks of the shared
``nao/<name>-speakerPosition.mat`` and ``-speakerVAD.mat`` files (8 ms frames).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from datetime import date
from pathlib import Path
from typing import Literal

import numpy as np
import scipy.io
import soundfile as sf

from avtrack.errors import InputError
from avtrack.io.doa import wrap_azimuth

TIME_COLUMNS = ("year", "month", "day", "hour", "minute", "second")
POSE_COLUMNS = (
    "x",
    "y",
    "z",
    "ref_vec_x",
    "ref_vec_y",
    "ref_vec_z",
    *(f"rotation_{i}{j}" for i in range(1, 4) for j in range(1, 4)),
)
TRACK_FRAME_S = 0.008


# --------------------------------------------------------------------------- data types


@dataclass(frozen=True)
class LOCATAPose:
    """Position and orientation of an array or a source over time.

    Attributes
    ----------
    times : ndarray (T,)
        Seconds relative to the recording's origin (first row of ``required_time.txt``).
    position : ndarray (T, 3)
        Reference point in metres, world frame (NaN during tracking dropouts).
    ref_vec : ndarray (T, 3)
        Reference vector (world frame).
    rotation : ndarray (T, 3, 3)
        Local-to-world rotation ``rotation[t, i - 1, j - 1] = rotation_ij``.
    mics : ndarray (T, M, 3) or None
        Microphone positions in metres, world frame, WAV channel order (arrays only).
    """

    times: np.ndarray
    position: np.ndarray
    ref_vec: np.ndarray
    rotation: np.ndarray
    mics: np.ndarray | None = None

    def __post_init__(self) -> None:
        t = np.asarray(self.times).shape[0]
        for name, shape in (
            ("times", (t,)),
            ("position", (t, 3)),
            ("ref_vec", (t, 3)),
            ("rotation", (t, 3, 3)),
        ):
            arr = np.asarray(getattr(self, name), dtype=float)
            if arr.shape != shape:
                raise ValueError(f"LOCATAPose: {name} must have shape {shape}, got {arr.shape}")
            object.__setattr__(self, name, arr)
        if not np.all(np.isfinite(self.times)):
            raise ValueError("LOCATAPose: times must be finite")
        if self.mics is not None:
            mics = np.asarray(self.mics, dtype=float)
            if mics.ndim != 3 or mics.shape[0] != t or mics.shape[2] != 3:
                raise ValueError(f"LOCATAPose: mics must have shape ({t}, M, 3), got {mics.shape}")
            object.__setattr__(self, "mics", mics)

    def __len__(self) -> int:
        return int(self.times.shape[0])


@dataclass(frozen=True)
class LOCATARecording:
    """One LOCATA recording seen by one array.

    Attributes
    ----------
    folder : Path
        The ``<array>`` folder.
    array_name : str
    audio : ndarray (M, n)
        Array signals, channel k = microphone k.
    fs : int
        Sample rate in Hz.
    array : LOCATAPose
        Array pose with microphone positions.
    source_names : tuple of S str
        Talker / loudspeaker names, in natural order (``position_source_<name>.txt``).
    sources : tuple of S LOCATAPose
    vad : ndarray (S, n) bool or None
        Voice activity of each source per array-audio sample (``VAD_<array>_<name>.txt``),
        None when the recording has no VAD files.
    required_times : ndarray (R,)
        Times (s) at which estimates are required.
    required_valid : ndarray (R,) bool
        ``valid_flag`` of each required time.
    audio_times : ndarray (n,) or None
        Time of each audio sample (``audio_array_timestamps_<array>.txt``), when present.
    origin : tuple
        ``(year, month, day, hour, minute, second)`` of time 0.
    """

    folder: Path
    array_name: str
    audio: np.ndarray
    fs: int
    array: LOCATAPose
    source_names: tuple[str, ...]
    sources: tuple[LOCATAPose, ...]
    vad: np.ndarray | None
    required_times: np.ndarray
    required_valid: np.ndarray
    audio_times: np.ndarray | None = None
    origin: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        audio = np.asarray(self.audio)
        if audio.ndim != 2:
            raise ValueError(f"LOCATARecording: audio must have shape (M, n), got {audio.shape}")
        if self.array.mics is not None and self.array.mics.shape[1] != audio.shape[0]:
            raise ValueError(
                f"LOCATARecording: {self.array.mics.shape[1]} microphone "
                f"positions for {audio.shape[0]} audio channels"
            )
        if len(self.source_names) != len(self.sources):
            raise ValueError("LOCATARecording: source_names and sources differ in length")
        if self.vad is not None:
            vad = np.asarray(self.vad, dtype=bool)
            if vad.shape != (len(self.sources), audio.shape[1]):
                raise ValueError(
                    f"LOCATARecording: vad must have shape "
                    f"({len(self.sources)}, {audio.shape[1]}), got {vad.shape}"
                )
            object.__setattr__(self, "vad", vad)
        if int(self.fs) <= 0:
            raise ValueError(f"LOCATARecording: fs must be > 0, got {self.fs}")
        object.__setattr__(self, "fs", int(self.fs))
        req = np.asarray(self.required_times, dtype=float)
        valid = np.asarray(self.required_valid, dtype=bool)
        if valid.shape != req.shape or req.ndim != 1:
            raise ValueError(
                "LOCATARecording: required_times and required_valid must be 1-D of equal length"
            )
        object.__setattr__(self, "required_times", req)
        object.__setattr__(self, "required_valid", valid)

    @property
    def n_mics(self) -> int:
        return int(self.audio.shape[0])

    @property
    def n_sources(self) -> int:
        return len(self.sources)


@dataclass(frozen=True)
class LOCATATracks:
    """Azimuth and voice-activity tracks of several talkers on a regular frame grid.

    Attributes
    ----------
    times : ndarray (T,)
        Frame times in seconds, ``k * frame_s``.
    azimuth_deg : ndarray (T, S)
        Azimuth of each talker, degrees in [-180, 180].
    vad : ndarray (T, S) bool
        Talker active.
    """

    times: np.ndarray
    azimuth_deg: np.ndarray
    vad: np.ndarray

    def __post_init__(self) -> None:
        az = np.asarray(self.azimuth_deg, dtype=float)
        vad = np.asarray(self.vad, dtype=bool)
        times = np.asarray(self.times, dtype=float)
        if az.ndim != 2 or vad.shape != az.shape or times.shape != (az.shape[0],):
            raise ValueError(
                f"LOCATATracks: need times (T,), azimuth_deg and vad (T, S); got "
                f"{times.shape}, {az.shape}, {vad.shape}"
            )
        if not np.all(np.isfinite(az)) or np.any(np.abs(az) > 180):
            raise ValueError("LOCATATracks: azimuth_deg must be finite, in [-180, 180]")
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "azimuth_deg", az)
        object.__setattr__(self, "vad", vad)

    @property
    def n_sources(self) -> int:
        return int(self.azimuth_deg.shape[1])


# --------------------------------------------------------------------------- text tables


def _natural_key(name: str) -> tuple:
    return tuple(int(p) if p.isdigit() else p for p in re.split(r"(\d+)", name))


def _require_file(path: Path) -> None:
    if not path.is_file():
        raise InputError("file not found" if not path.exists() else "not a regular file", path)


@dataclass(frozen=True)
class _Table:
    """A parsed LOCATA text table; ``lines[r]`` is the 1-based file line of row ``r``."""

    path: Path
    columns: tuple[str, ...]
    values: np.ndarray
    lines: np.ndarray

    def get(self, wanted: tuple[str, ...]) -> np.ndarray:
        missing = [c for c in wanted if c not in self.columns]
        if missing:
            raise InputError(
                f"missing column(s) {missing} (header has {list(self.columns)})", self.path, 1
            )
        return self.values[:, [self.columns.index(c) for c in wanted]]

    def error(self, message: str, row: int) -> InputError:
        return InputError(message, self.path, int(self.lines[row]))

    def finite(self, values: np.ndarray, names: tuple[str, ...]) -> None:
        bad = ~np.isfinite(values)
        if np.any(bad):
            r, c = np.argwhere(bad)[0]
            raise self.error(f"{names[c]} is {values[r, c]}, expected a finite number", r)

    def binary(self, name: str) -> np.ndarray:
        values = self.get((name,))[:, 0]
        bad = ~np.isin(values, (0.0, 1.0))
        if np.any(bad):
            r = int(np.argmax(bad))
            raise self.error(f"{name} must be 0 or 1, got {values[r]}", r)
        return values.astype(bool)

    def seconds(self, origin: tuple[float, ...] | None = None) -> np.ndarray:
        """Seconds of each row's calendar time from ``origin`` (default: the first row)."""
        cal = self.get(TIME_COLUMNS)
        self.finite(cal, TIME_COLUMNS)
        whole = cal[:, :5]
        bad = np.any(whole != np.rint(whole), axis=1)
        if np.any(bad):
            raise self.error(
                "year, month, day, hour and minute must be integers", int(np.argmax(bad))
            )
        out_of_range = np.any((cal[:, :5] < 0) | (cal[:, :5] > 9999), axis=1)
        if np.any(out_of_range):
            raise self.error(
                "year, month, day, hour and minute must lie in [0, 9999]",
                int(np.argmax(out_of_range)),
            )
        origin = tuple(float(v) for v in cal[0]) if origin is None else origin
        dates, inverse = np.unique(cal[:, :3].astype(np.int64), axis=0, return_inverse=True)
        inverse = inverse.ravel()
        ordinals = np.empty(len(dates))
        for k, (y, m, d) in enumerate(dates):
            try:
                ordinals[k] = date(int(y), int(m), int(d)).toordinal()
            except ValueError as exc:
                row = int(np.argmax(inverse == k))
                raise self.error(f"invalid date {y}-{m}-{d}: {exc}", row) from None
        day0 = date(*(int(v) for v in origin[:3])).toordinal()
        # seconds = 86400 (day - day0) + 3600 (h - h0) + 60 (min - min0) + (s - s0)
        return (
            (ordinals[inverse] - day0) * 86400.0
            + (cal[:, 3] - origin[3]) * 3600.0
            + (cal[:, 4] - origin[4]) * 60.0
            + (cal[:, 5] - origin[5])
        )


def _read_table(path: Path) -> _Table:
    """A LOCATA text table: tab- (or white-space) separated numbers under one header row.

    Raises
    ------
    InputError
        Missing file, no header, no data rows, duplicate column names, or a row with the wrong
        number of values or a non-number (naming the 1-based line).
    """
    _require_file(path)
    try:
        text = path.read_text()
    except UnicodeDecodeError:
        raise InputError("not a text file (cannot decode as UTF-8)", path) from None
    lines = text.splitlines()
    if not lines or not lines[0].strip():
        raise InputError("empty file: expected a header row", path)
    columns = tuple(lines[0].split())
    if len(set(columns)) != len(columns):
        raise InputError(f"duplicate column names in the header: {columns}", path, 1)
    body = [(i, ln.split()) for i, ln in enumerate(lines[1:], start=2) if ln.strip()]
    if not body:
        raise InputError("no data rows under the header", path)
    numbers = np.array([i for i, _ in body])
    try:  # fast path
        values = np.array([parts for _, parts in body], dtype=float)
        if values.ndim == 2 and values.shape[1] == len(columns):
            return _Table(path, columns, values, numbers)
    except ValueError:
        pass
    for i, parts in body:  # locate the bad row
        if len(parts) != len(columns):
            raise InputError(
                f"expected {len(columns)} values (one per header column), got {len(parts)}",
                path,
                i,
            )
        for col, p in zip(columns, parts, strict=True):
            try:
                float(p)
            except ValueError:
                raise InputError(f"column {col!r} is not a number: {p!r}", path, i) from None
    raise InputError("malformed table", path)  # pragma: no cover - unreachable


def _read_pose(
    path: Path, origin: tuple[float, ...], n_mics: int | None, allow_nan: bool
) -> LOCATAPose:
    table = _read_table(path)
    times = table.seconds(origin)
    pose = table.get(POSE_COLUMNS)
    mics = None
    if n_mics is not None:
        pattern = re.compile(r"mic(\d+)_[xyz]")
        have = sorted({int(m.group(1)) for c in table.columns if (m := pattern.fullmatch(c))})
        if have != list(range(1, n_mics + 1)):
            raise InputError(
                f"microphone columns mic1_x ... mic{n_mics}_z expected for the {n_mics} audio "
                f"channels, found microphones {have}",
                path,
                1,
            )
        names = tuple(f"mic{k}_{a}" for k in range(1, n_mics + 1) for a in "xyz")
        mics = table.get(names)
        if not allow_nan:
            table.finite(mics, names)
        mics = mics.reshape(-1, n_mics, 3)
    if not allow_nan:
        table.finite(pose, POSE_COLUMNS)
    return LOCATAPose(times, pose[:, :3], pose[:, 3:6], pose[:, 6:].reshape(-1, 3, 3), mics)


# --------------------------------------------------------------------------- readers


def _read_audio(wav: Path, array: str, fs: int | None) -> tuple[np.ndarray, int]:
    """The array's signals ``(n_channels, n_samples)`` and their sample rate (checked against
    ``fs`` when given)."""
    if not wav.is_file():
        found = sorted(p.name for p in wav.parent.glob("audio_array_*.wav"))
        raise InputError(f"file not found (array {array!r}; array audio here: {found})", wav)
    try:
        audio, rate = sf.read(wav, dtype="float64", always_2d=True)
    except (RuntimeError, sf.LibsndfileError) as exc:
        raise InputError(f"cannot read as audio: {exc}", wav) from None
    if fs is not None and rate != fs:
        raise InputError(f"sample rate is {rate} Hz, expected {fs} Hz", wav)
    audio = audio.T
    if not np.all(np.isfinite(audio)):
        raise InputError("audio holds NaN or inf samples", wav)
    return audio, rate


def _audio_times(
    ts_path: Path, origin: tuple[float, ...], n: int, wav: Path
) -> np.ndarray | None:
    """The time of every audio sample in seconds from ``origin`` ``(n_samples,)``, or None
    without a timestamp file."""
    audio_times = None
    if ts_path.is_file():
        audio_times = _read_table(ts_path).seconds(origin)
        if len(audio_times) != n:
            raise InputError(
                f"{len(audio_times)} timestamps for {n} audio samples of {wav.name}", ts_path
            )
    return audio_times


def _read_vad(vad_paths: list[Path], n: int, wav: Path) -> np.ndarray | None:
    """The sources' voice activity ``(n_sources, n_samples)`` bool, or None without VAD
    files (which must then be there for every source or none)."""
    vad = None
    if any(p.is_file() for p in vad_paths):
        rows = []
        for p in vad_paths:
            if not p.is_file():
                raise InputError("file not found (the other sources have VAD files)", p)
            v = _read_table(p).binary("VAD")
            if len(v) != n:
                raise InputError(f"{len(v)} VAD rows for {n} audio samples of {wav.name}", p)
            rows.append(v)
        vad = np.array(rows)
    return vad


def load_locata_recording(
    folder: str | Path,
    array: str | None = None,
    *,
    fs: int | None = None,
    allow_nan_positions: bool = True,
) -> LOCATARecording:
    """Read one LOCATA ``<task>/<recording>/<array>/`` folder.

    Parameters
    ----------
    folder : str or Path
        The array folder.
    array : str, optional
        Array name in the file names; the folder's name by default.
    fs : int, optional
        Expected sample rate; a WAV at another rate is an error.
    allow_nan_positions : bool
        Keep NaN positions / orientations (tracking dropouts); False makes them an error.

    Returns
    -------
    LOCATARecording

    Raises
    ------
    InputError
        A missing ``audio_array_<array>.wav``, ``position_array_<array>.txt`` or
        ``required_time.txt``; a malformed row or missing column (file and row named); a
        sample rate other than ``fs``; microphone columns that do not match the WAV channels;
        a VAD or timestamp file whose length is not the number of audio samples; VAD files for
        only some sources.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(
            "recording folder not found" if not folder.exists() else "not a folder", folder
        )
    array = folder.name if array is None else array

    required = _read_table(folder / "required_time.txt")
    required_times = required.seconds()
    origin = tuple(float(v) for v in required.get(TIME_COLUMNS)[0])
    required_valid = required.binary("valid_flag")

    wav = folder / f"audio_array_{array}.wav"
    audio, rate = _read_audio(wav, array, fs)
    n = audio.shape[1]

    array_pose = _read_pose(
        folder / f"position_array_{array}.txt", origin, audio.shape[0], allow_nan_positions
    )

    ts_path = folder / f"audio_array_timestamps_{array}.txt"
    audio_times = _audio_times(ts_path, origin, n, wav)
    names = sorted(
        (
            m.group(1)
            for p in folder.glob("position_source_*.txt")
            if (m := re.fullmatch(r"position_source_(.+)\.txt", p.name))
        ),
        key=_natural_key,
    )
    sources = tuple(
        _read_pose(folder / f"position_source_{s}.txt", origin, None, allow_nan_positions)
        for s in names
    )

    vad = _read_vad([folder / f"VAD_{array}_{s}.txt" for s in names], n, wav)

    return LOCATARecording(
        folder=folder,
        array_name=array,
        audio=audio,
        fs=int(rate),
        array=array_pose,
        source_names=tuple(names),
        sources=sources,
        vad=vad,
        required_times=required_times,
        required_valid=required_valid,
        audio_times=audio_times,
        origin=origin,
    )


def locata_source_azimuths(
    rec: LOCATARecording, convention: Literal["avtrack", "locata"] = "avtrack"
) -> tuple[np.ndarray, np.ndarray]:
    """Azimuth of every source in the array frame, at the array pose times.

    ``v = R_t' (h_t - p_t)`` (``get_truth.m``), azimuth ``atan2(v_y, v_x)``. Where a source
    table is not sampled at the array's times, its position is linearly interpolated onto them
    (NaN outside its time span).

    Parameters
    ----------
    rec : LOCATARecording
    convention : {"avtrack", "locata"}
        ``"avtrack"``: counter-clockwise from the array's +x axis; ``"locata"``: the challenge's
        ``atan2(v_y, v_x) - 90°`` (0° along +y). Both in (-180, 180].

    Returns
    -------
    times : ndarray (T,)
        The array pose times (s).
    azimuth : ndarray (T, S)
        Degrees; NaN where a position is missing.
    """
    if convention not in ("avtrack", "locata"):
        raise ValueError(f"convention must be 'avtrack' or 'locata', got {convention!r}")
    times = rec.array.times
    out = np.full((len(times), rec.n_sources), np.nan)
    for s, src in enumerate(rec.sources):
        if len(src) == len(times) and np.allclose(src.times, times, rtol=0, atol=1e-9):
            h = src.position
        else:
            h = np.column_stack(
                [
                    np.interp(times, src.times, src.position[:, k], left=np.nan, right=np.nan)
                    for k in range(3)
                ]
            )
        v = np.einsum("tji,tj->ti", rec.array.rotation, h - rec.array.position)  # R' (h - p)
        out[:, s] = np.degrees(np.arctan2(v[:, 1], v[:, 0]))
    if convention == "locata":
        out = out - 90.0
    return times, wrap_azimuth(out)


def load_locata_tracks(
    folder: str | Path, name: str = "LOCATA", frame_s: float = TRACK_FRAME_S
) -> LOCATATracks:
    """Talker azimuth and voice-activity tracks ``<name>-speakerPosition.mat`` /
    ``<name>-speakerVAD.mat`` (variables ``speakerPosition`` and ``speakerVAD``, T × S).

    Parameters
    ----------
    folder : str or Path
        The folder holding the two files, or a folder with a ``nao/`` subfolder holding them
        (the shared data root).
    name : str
        ``"LOCATA"`` (task 6, recording 3: 7875 × 2) or ``"Kinovis-MST"`` (4908 × 2).
    frame_s : float
        Frame period; the shared tracks use 8 ms.

    Returns
    -------
    LOCATATracks

    Raises
    ------
    InputError
        Missing file or variable, shapes that differ between the two files, a NaN or
        out-of-range azimuth, a VAD value other than 0/1.
    """
    if not frame_s > 0:
        raise ValueError(f"frame_s must be > 0, got {frame_s}")
    folder = Path(folder)
    if not (folder / f"{name}-speakerPosition.mat").exists() and (folder / "nao").is_dir():
        folder = folder / "nao"
    arrays = {}
    for suffix, var in (("speakerPosition", "speakerPosition"), ("speakerVAD", "speakerVAD")):
        path = folder / f"{name}-{suffix}.mat"
        _require_file(path)
        try:
            mat = scipy.io.loadmat(path)
        except Exception as exc:  # scipy raises several types for a damaged file
            raise InputError(f"cannot read as a MATLAB file: {exc}", path) from None
        if var not in mat:
            raise InputError(f"no variable {var!r}", path)
        arr = np.asarray(mat[var], dtype=float)
        if arr.ndim != 2:
            raise InputError(f"{var} must be a T × S matrix, got shape {arr.shape}", path)
        arrays[var] = (arr, path)
    az, az_path = arrays["speakerPosition"]
    vad, vad_path = arrays["speakerVAD"]
    if az.shape != vad.shape:
        raise InputError(
            f"speakerVAD is {vad.shape[0]} × {vad.shape[1]} but speakerPosition is "
            f"{az.shape[0]} × {az.shape[1]}",
            vad_path,
        )
    bad = ~np.isfinite(az) | (np.abs(az) > 180)
    if np.any(bad):
        r, c = np.argwhere(bad)[0]
        raise InputError(
            f"speakerPosition row {r + 1}, talker {c + 1}: {az[r, c]} is not an "
            f"azimuth in [-180, 180] degrees",
            az_path,
        )
    bad = ~np.isin(vad, (0.0, 1.0))
    if np.any(bad):
        r, c = np.argwhere(bad)[0]
        raise InputError(
            f"speakerVAD row {r + 1}, talker {c + 1}: {vad[r, c]} is not 0 or 1", vad_path
        )
    return LOCATATracks(np.arange(az.shape[0]) * frame_s, az, vad.astype(bool))
