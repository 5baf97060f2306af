"""Microphone arrays: geometry, built-in arrays, JSON files and far-field steering delays.

Positions are in metres in the ARRAY frame: x forward, y left, z up. Directions are given by
an azimuth counter-clockwise from x in (-180, 180] and an elevation up from the xy plane, in
degrees (the convention of the DOA / track CSV files).

Built-in arrays (:data:`BUILTIN_ARRAYS`, :func:`builtin_array`)
---------------------------------------------------------------
- ``nao12`` -- the 12 microphones of the LOCATA "benchmark2" NAO head, LOCATA order.
- ``nao8`` -- LOCATA mics 1, 3, 4, 5, 8, 10, 11, 12 (the thesis's 8-mic configuration).
- ``nao4`` -- LOCATA mics 5, 8, 11, 12: the quasi-planar top of the head (rear-left,
  rear-right, front-right, front-left).
- ``nao4-hrir`` -- the nao4 positions with ``kind="hrtf"`` and the measured NAO HRIRs
  (:func:`avtrack.audio.hrtf.load_nao_hrir`); the same as ``builtin_array("nao4", hrir=True)``.
  HRIRs were measured for these four microphones only.
- ``av163`` -- two horizontal 8-mic circular arrays of radius 10 cm, 0.8 m apart (AV16.3):
  mics 1-8 on the ring centred at (0, +0.4, 0), mics 9-16 on the ring centred at (0, -0.4, 0),
  each ring's first mic at azimuth 0 from its centre and the others counter-clockwise every
  45 degrees.
- ``respeaker4`` -- the ReSpeaker USB 4-mic array: a square of side 45.7 mm, microphone k
  at azimuth 45 + 90 k degrees from the centre, 5 mm above the board.
- ``kemar`` -- a binaural dummy head: the two ``ReceiverPosition`` of the MIT KEMAR SOFA file
  (left ear (0, +0.09, 0), right ear (0, -0.09, 0)), ``kind="hrtf"`` with the KEMAR HRIRs.
  ``builtin_array("kemar", hrir=False)`` gives the two ear positions as a free-field pair.

The ``*-hrir`` / ``kemar`` arrays read the shared data (:func:`avtrack.io.datasets.
find_shared_data`) and raise :class:`~avtrack.errors.InputError` when it is absent.

JSON files (:func:`load_array`, :func:`write_array_json`)::

    {"name": "my-array", "positions": [[x, y, z], ...], "kind": "free-field"}
    {"name": "head", "positions": [[0, 0.09, 0], [0, -0.09, 0]], "kind": "hrtf",
     "hrir": {"builtin": "kemar"}}            # or {"sofa": "path/to/file.sofa"}

A relative SOFA path is resolved against the JSON file's folder.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from avtrack.audio.hrtf import (
    BUILTIN_HRIRS,
    KEMAR_SOFA_FILE,
    HRIRSet,
    builtin_hrir,
    direction_vectors,
    load_sofa,
)
from avtrack.errors import InputError
from avtrack.io.base import atomic_write

SPEED_OF_SOUND = 343.0
"""Speed of sound in m/s used throughout the audio and simulation stages."""

KINDS = ("free-field", "hrtf")

# LOCATA "benchmark2" NAO head, mics 1..12, metres (x, y, z)
NAO12_POSITIONS = np.array(
    [
        (-0.028, 0.030, -0.040),
        (0.006, 0.057, 0.000),
        (0.022, 0.022, -0.046),
        (-0.055, -0.024, -0.025),
        (-0.031, 0.023, 0.042),
        (-0.032, 0.011, 0.046),
        (-0.025, -0.003, 0.051),
        (-0.036, -0.027, 0.038),
        (-0.035, -0.043, 0.025),
        (0.029, -0.048, -0.012),
        (0.034, -0.030, 0.037),
        (0.035, 0.025, 0.039),
    ]
)
NAO4_MICS = (5, 8, 11, 12)
NAO8_MICS = (1, 3, 4, 5, 8, 10, 11, 12)
AV163_RADIUS = 0.10
AV163_CENTRES = ((0.0, 0.4, 0.0), (0.0, -0.4, 0.0))

BUILTIN_ARRAYS = ("nao4", "nao8", "nao12", "nao4-hrir", "av163", "kemar", "respeaker4")

#: ``respeaker4`` positions (metres): a 45.7 mm square, microphones counter-clockwise from +x+y.
RESPEAKER4_POSITIONS = 0.02285 * np.array(
    [[1.0, 1.0, 0.0], [-1.0, 1.0, 0.0], [-1.0, -1.0, 0.0], [1.0, -1.0, 0.0]]
) + np.array([0.0, 0.0, 0.005])


@dataclass(frozen=True, eq=False)
class MicArray:
    """A microphone array (or a head with ears) in its own frame.

    Attributes
    ----------
    name : str
        A label (the built-in name, or the JSON ``name``).
    positions : ndarray (n_mics, 3)
        Microphone positions in metres, array frame (x forward, y left, z up). For an
        ``"hrtf"`` array they are where the microphones / ears are on the head, centred on the
        HRIR measurement origin.
    kind : {"free-field", "hrtf"}
        ``"free-field"``: omnidirectional microphones in free space (the simulator uses
        propagation delays and 1/r attenuation to each position). ``"hrtf"``: microphones on a
        head whose response is ``hrir``.
    hrir : HRIRSet or None
        Measured responses with ``hrir.n_mics == n_mics``; required for ``kind == "hrtf"``,
        must be None otherwise.
    """

    name: str
    positions: np.ndarray
    kind: str = "free-field"
    hrir: HRIRSet | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"MicArray: name must be a non-empty string, got {self.name!r}")
        pos = np.array(self.positions, dtype=float)
        if pos.ndim != 2 or pos.shape[1] != 3 or pos.shape[0] < 1:
            raise ValueError(
                f"MicArray: positions must have shape (n_mics, 3), got {np.shape(self.positions)}"
            )
        if not np.all(np.isfinite(pos)):
            raise ValueError("MicArray: positions must be finite")
        if self.kind not in KINDS:
            raise ValueError(f"MicArray: kind must be one of {KINDS}, got {self.kind!r}")
        if self.kind == "hrtf":
            if not isinstance(self.hrir, HRIRSet):
                raise ValueError("MicArray: kind 'hrtf' needs hrir (an HRIRSet), got None")
            if self.hrir.n_mics != pos.shape[0]:
                raise ValueError(
                    f"MicArray: hrir has {self.hrir.n_mics} microphones but positions has "
                    f"{pos.shape[0]}"
                )
        elif self.hrir is not None:
            raise ValueError("MicArray: hrir must be None for a 'free-field' array")
        pos.setflags(write=False)
        object.__setattr__(self, "positions", pos)

    @property
    def n_mics(self) -> int:
        """Number of microphones ``M``."""
        return self.positions.shape[0]

    @property
    def centre(self) -> np.ndarray:
        """``(3,)`` mean of the positions (the reference point of :func:`steering_delays`)."""
        return self.positions.mean(axis=0)

    @property
    def radius(self) -> float:
        """Largest distance of a microphone from :attr:`centre`, metres."""
        return float(np.max(np.linalg.norm(self.positions - self.centre, axis=1)))

    def to_json(self) -> dict[str, Any]:
        """The JSON object of :func:`load_array` (``hrir`` as a built-in name or a SOFA path).

        Raises
        ------
        ValueError
            For an ``"hrtf"`` array whose HRIR set has no ``source`` to refer to.
        """
        out: dict[str, Any] = {
            "name": self.name,
            "positions": [[float(v) for v in p] for p in self.positions],
            "kind": self.kind,
        }
        if self.hrir is not None:
            src = self.hrir.source
            if src in BUILTIN_HRIRS:
                out["hrir"] = {"builtin": src}
            elif src:
                out["hrir"] = {"sofa": src}
            else:
                raise ValueError(
                    "MicArray.to_json: the HRIR set has no source (built-in name or SOFA path)"
                )
        return out

    @classmethod
    def from_json(cls, d: Mapping[str, Any], path: str | Path | None = None) -> MicArray:
        """Build an array from the JSON object of :func:`load_array`.

        Parameters
        ----------
        d : mapping
            ``{"name", "positions", "kind", optional "hrir"}``.
        path : str or Path, optional
            The file ``d`` came from: named in errors, and the base of a relative SOFA path.

        Raises
        ------
        InputError
            Naming the file and the field, for any missing or malformed field.
        """
        if not isinstance(d, Mapping):
            raise InputError(f"expected a JSON object, got {type(d).__name__}", path)
        unknown = set(d) - {"name", "positions", "kind", "hrir"}
        if unknown:
            raise InputError(f"unknown field(s) {sorted(unknown)}", path)
        name = d.get("name")
        if not isinstance(name, str) or not name:
            raise InputError(f"field 'name': expected a non-empty string, got {name!r}", path)
        if "positions" not in d:
            raise InputError("field 'positions' is missing", path)
        pos = _parse_positions(d["positions"], path)
        kind = d.get("kind", "free-field")
        if kind not in KINDS:
            raise InputError(f"field 'kind': expected one of {KINDS}, got {kind!r}", path)
        hrir = None
        if kind == "hrtf":
            if "hrir" not in d:
                raise InputError("field 'hrir' is required when kind is 'hrtf'", path)
            hrir = _parse_hrir(d["hrir"], path)
            if hrir.n_mics != pos.shape[0]:
                raise InputError(
                    f"field 'hrir': the HRIRs have {hrir.n_mics} microphones but 'positions' "
                    f"has {pos.shape[0]}",
                    path,
                )
        elif d.get("hrir") is not None:
            raise InputError("field 'hrir' is only allowed when kind is 'hrtf'", path)
        return cls(name, pos, kind, hrir)


def _parse_positions(value: Any, path: str | Path | None) -> np.ndarray:
    msg = "field 'positions': expected a non-empty list of [x, y, z] numbers (metres)"
    if not isinstance(value, list) or not value:
        raise InputError(f"{msg}, got {value!r:.80}", path)
    for i, p in enumerate(value):
        ok = isinstance(p, list) and len(p) == 3
        ok = ok and all(isinstance(v, int | float) and not isinstance(v, bool) for v in p)
        if not ok or not all(math.isfinite(v) for v in p):
            raise InputError(f"{msg}; entry {i} is {p!r:.80}", path)
    return np.array(value, dtype=float)


def _parse_hrir(value: Any, path: str | Path | None) -> HRIRSet:
    if not isinstance(value, Mapping) or len(value) != 1 or not {"builtin", "sofa"} & set(value):
        raise InputError(
            f'field \'hrir\': expected {{"builtin": "nao"|"kemar"}} or {{"sofa": PATH}}, '
            f"got {value!r:.80}",
            path,
        )
    if "builtin" in value:
        name = value["builtin"]
        if name not in BUILTIN_HRIRS:
            raise InputError(
                f"field 'hrir.builtin': expected one of {BUILTIN_HRIRS}, got {name!r}", path
            )
        return builtin_hrir(name)
    sofa = value["sofa"]
    if not isinstance(sofa, str) or not sofa:
        raise InputError(f"field 'hrir.sofa': expected a file path, got {sofa!r}", path)
    sofa_path = Path(sofa)
    if not sofa_path.is_absolute() and path is not None:
        sofa_path = Path(path).parent / sofa_path
    if not sofa_path.is_file():
        raise InputError(f"field 'hrir.sofa': no such file {sofa_path}", path)
    return load_sofa(sofa_path)


def _av163_positions() -> np.ndarray:
    phi = np.deg2rad(45.0 * np.arange(8))
    ring = AV163_RADIUS * np.stack([np.cos(phi), np.sin(phi), np.zeros(8)], axis=1)
    return np.concatenate([ring + np.array(c) for c in AV163_CENTRES])


def builtin_array(name: str, hrir: bool | None = None) -> MicArray:
    """A built-in array by name (see the module docstring for the list).

    Parameters
    ----------
    name : str
        One of :data:`BUILTIN_ARRAYS`.
    hrir : bool, optional
        Force the kind: True gives ``kind="hrtf"`` (only ``nao4`` and ``kemar`` have measured
        HRIRs), False gives ``"free-field"``. Default: ``"hrtf"`` for ``kemar`` and
        ``nao4-hrir``, ``"free-field"`` for the others.

    Raises
    ------
    ValueError
        For an unknown name, or ``hrir=True`` for an array without measured HRIRs.
    InputError
        When the HRIRs (or the KEMAR geometry) are needed and the shared data is absent.
    """
    if name not in BUILTIN_ARRAYS:
        raise ValueError(f"builtin_array: name must be one of {BUILTIN_ARRAYS}, got {name!r}")
    if hrir is not None and not isinstance(hrir, bool):
        raise ValueError(f"builtin_array: hrir must be True, False or None, got {hrir!r}")
    if name == "nao4-hrir":
        if hrir is False:
            raise ValueError("builtin_array: 'nao4-hrir' with hrir=False; use 'nao4'")
        name, hrir = "nao4", True
    if name == "kemar":
        hset = builtin_hrir("kemar")
        from avtrack.io.datasets import find_shared_data

        pos = _sofa_receivers(find_shared_data() / KEMAR_SOFA_FILE)
        if hrir is False:
            return MicArray("kemar", pos)
        return MicArray("kemar", pos, "hrtf", hset)
    if hrir and name != "nao4":
        raise ValueError(
            f"builtin_array: no measured HRIRs for {name!r}; HRIR rendering exists for 'nao4' "
            "(the NAO head's four top microphones) and 'kemar' only"
        )
    if name == "av163":
        return MicArray("av163", _av163_positions())
    if name == "respeaker4":
        return MicArray("respeaker4", RESPEAKER4_POSITIONS)
    mics = {"nao4": NAO4_MICS, "nao8": NAO8_MICS, "nao12": tuple(range(1, 13))}[name]
    pos = NAO12_POSITIONS[[m - 1 for m in mics]]
    if hrir:
        return MicArray("nao4-hrir", pos, "hrtf", builtin_hrir("nao"))
    return MicArray(name, pos)


def _sofa_receivers(path: Path) -> np.ndarray:
    import h5py

    try:
        with h5py.File(path, "r") as f:
            rec = np.asarray(f["ReceiverPosition"][()], dtype=float)
    except (OSError, KeyError) as exc:
        raise InputError(f"cannot read ReceiverPosition: {exc}", path) from None
    rec = rec.reshape(rec.shape[0], 3)
    return rec


def load_array(spec: str | Path) -> MicArray:
    """A built-in array name (:data:`BUILTIN_ARRAYS`) or a JSON array file.

    Raises
    ------
    InputError
        When ``spec`` is neither a built-in name nor a readable, valid JSON array file.
    """
    if isinstance(spec, str) and spec in BUILTIN_ARRAYS:
        return builtin_array(spec)
    path = Path(spec)
    if not path.is_file():
        raise InputError(
            f"not a built-in array ({', '.join(BUILTIN_ARRAYS)}) nor an existing JSON file",
            path,
        )
    try:
        d = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read the array file: {exc}", path) from None
    except json.JSONDecodeError as exc:
        raise InputError(f"invalid JSON: {exc}", path) from None
    array = MicArray.from_json(d, path)
    check_aperture(array, path)
    return array


#: Apertures (largest distance between two microphones, metres) an array file may have:
#: below, the microphones are at one point (no phase differences to localize from); above, the
#: positions are almost surely in centimetres or millimetres, not metres.
APERTURE_RANGE_M = (1e-3, 5.0)


def check_aperture(array: MicArray, path=None) -> None:
    """InputError for an array whose microphones coincide or whose size looks like
    centimetres or millimetres (see :data:`APERTURE_RANGE_M`)."""
    pos = np.asarray(array.positions, dtype=float)
    if array.n_mics < 2:
        return
    aperture = float(np.max(np.linalg.norm(pos[:, None, :] - pos[None, :, :], axis=2)))
    lo, hi = APERTURE_RANGE_M
    if aperture < lo:
        raise InputError(f"all {array.n_mics} microphones are at one point (aperture "
                         f"{aperture * 1e3:.2g} mm): directions cannot be heard", path)
    if aperture > hi:
        raise InputError(f"the microphones are {aperture:g} apart: positions are in metres "
                         f"(are these centimetres or millimetres?)", path)


def write_array_json(path: str | Path, array: MicArray) -> None:
    """Write ``array.to_json()`` to ``path`` atomically (indented JSON)."""
    d = array.to_json()
    with atomic_write(path, "w") as fh:
        json.dump(d, fh, indent=2)
        fh.write("\n")


def steering_delays(
    array: MicArray, azimuth_deg: np.ndarray | float, elevation_deg: np.ndarray | float = 0.0
) -> np.ndarray:
    """Far-field propagation delays of a plane wave, relative to the array centre.

    For a source in the unit direction ``u`` (azimuth, elevation), microphone ``m`` at
    ``p_m`` hears the wave ``tau_m = -(p_m - p̄) · u / c`` seconds after the centre ``p̄``
    (the mean of the positions), ``c`` = :data:`SPEED_OF_SOUND`.

    Parameters
    ----------
    array : MicArray
    azimuth_deg, elevation_deg : float or ndarray (N,)
        Directions in the array frame, degrees.

    Returns
    -------
    ndarray (n_mics,) for scalar directions, (N, n_mics) otherwise
        Delays in seconds; negative means the microphone hears the wave before the centre.
    """
    az = np.asarray(azimuth_deg, dtype=float)
    el = np.asarray(elevation_deg, dtype=float)
    if not (np.all(np.isfinite(az)) and np.all(np.isfinite(el))):
        raise ValueError("steering_delays: azimuth_deg and elevation_deg must be finite")
    az, el = np.broadcast_arrays(az, el)
    u = direction_vectors(az, el)  # (..., 3)
    rel = array.positions - array.centre  # (M, 3)
    return -(u @ rel.T) / SPEED_OF_SOUND  # tau_m = -(p_m - p̄)·u / c
