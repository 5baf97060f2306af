"""Measured head-related impulse responses (HRIRs): the NAO robot head and the KEMAR dummy head.

An :class:`HRIRSet` holds the impulse responses from ``D`` measured directions to ``M``
microphones (ears), ``irs (D, M, L)``, with the directions in the ARRAY frame of
:mod:`avtrack.audio.arrays`: x forward (the face), y left, z up; azimuth counter-clockwise from
x in (-180, 180], elevation up from the horizontal plane, both in degrees.

Loaders
-------
- :func:`load_nao_hrir` -- the four top microphones of a NAO head, 72 azimuths in the
  horizontal plane, 48 kHz (``nao/HRIR_NAO_48kHz_-175_5_180_degrees.mat`` of the shared data).
- :func:`load_sofa` -- any SOFA ``SimpleFreeFieldHRIR`` file, e.g. the MIT KEMAR set
  (``hrtf/mit_kemar_normal_pinna.sofa``, Gardner & Martin 1995), read with h5py.
- :func:`builtin_hrir` -- ``"nao"`` or ``"kemar"`` from the shared data, cached.

NAO azimuth convention (worked out from the data, checked in ``tests/audio/test_hrtf.py``)
-----------------------------------------------------------------------------------------
The file's third axis is azimuth -175, -170, ..., 180 degrees. We compared the inter-microphone
delays (phase slope of the cross-spectrum below 3 kHz, every pair, every azimuth) with the
far-field delays of the nao4 geometry under every channel order and both azimuth senses. The
signs agree best (82 % of pair-azimuth cases) when azimuth 0 faces the front pair of
microphones, azimuth is counter-clockwise (+90 = left) and the file's channels are rear-left,
rear-right, front-left, front-right, i.e. LOCATA mics 5, 8, 12, 11 (taking the file's order as
5, 8, 11, 12 gives 68 %, every other order at most 69 %). The head is mirror-symmetric left /
right, so "clockwise with channels 8, 5, 11, 12" fits equally well (its mirror image); we take
the counter-clockwise reading (the convention of the project, of SOFA and of the LOCATA
geometry) and **reorder the channels to the nao4 order 5, 8, 11, 12**, so that
``load_nao_hrir(...).irs[:, m]`` is microphone ``m`` of ``builtin_array("nao4")``. The
disagreements are mostly for sources behind the head, where it shadows the microphones; for lateral
sources the left microphones lead (the tests check azimuths 60-105 degrees either side, and
the front pair leading for sources within 30 degrees of the front).

The delays are smaller than the LOCATA prototype's geometry gives: a least-squares fit of the
delays gives an effective horizontal layout of about +-2.4 cm (rear pair), +-1.4 cm (front
pair) and 2.1 cm front-to-back, against +-2.5 cm, +-2.8 cm and 6.8 cm for the LOCATA positions:
the measured head's top microphones sit closer together than the prototype's. A localizer fed
HRIR-rendered nao4 audio should therefore use the HRIRs (not the LOCATA positions) as its
steering model.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import numpy as np
import scipy.io
import scipy.signal

from avtrack.errors import InputError
from avtrack.io.doa import wrap_azimuth

NAO_HRIR_FILE = "nao/HRIR_NAO_48kHz_-175_5_180_degrees.mat"
KEMAR_SOFA_FILE = "hrtf/mit_kemar_normal_pinna.sofa"
BUILTIN_HRIRS = ("nao", "kemar")

# the file's channels are LOCATA mics (5, 8, 12, 11); this permutation gives nao4's (5, 8, 11, 12)
_NAO_CHANNELS_TO_NAO4 = (0, 1, 3, 2)


def direction_vectors(az_deg: np.ndarray, el_deg: np.ndarray) -> np.ndarray:
    """Unit vectors ``(N, 3)`` of directions given by azimuth and elevation (degrees)."""
    az = np.deg2rad(np.asarray(az_deg, dtype=float))
    el = np.deg2rad(np.asarray(el_deg, dtype=float))
    # u = (cos el cos az, cos el sin az, sin el)
    return np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=-1)


@dataclass(frozen=True, eq=False)
class HRIRSet:
    """Head-related impulse responses measured from ``D`` directions to ``M`` microphones.

    Attributes
    ----------
    azimuths_deg : ndarray (D,)
        Direction azimuths in the array frame, counter-clockwise from x (forward), wrapped to
        (-180, 180].
    elevations_deg : ndarray (D,)
        Direction elevations in [-90, 90], positive up.
    irs : ndarray (D, M, L)
        Impulse response from direction ``d`` to microphone ``m``.
    fs : int
        Sampling rate of ``irs`` in Hz.
    source : str
        Where the set came from: ``"nao"`` or ``"kemar"`` (built-ins), a SOFA file path, or
        ``""`` (built in memory). Used to write array JSON files.
    """

    azimuths_deg: np.ndarray
    elevations_deg: np.ndarray
    irs: np.ndarray
    fs: int
    source: str = ""

    def __post_init__(self) -> None:
        irs = np.array(self.irs, dtype=float)
        if irs.ndim != 3 or min(irs.shape) == 0:
            raise ValueError(f"HRIRSet: irs must have shape (D, M, L) > 0, got {irs.shape}")
        if not np.all(np.isfinite(irs)):
            raise ValueError("HRIRSet: irs must be finite")
        n_dirs = irs.shape[0]
        az = np.array(self.azimuths_deg, dtype=float).reshape(-1)
        el = np.array(self.elevations_deg, dtype=float).reshape(-1)
        if az.shape != (n_dirs,) or el.shape != (n_dirs,):
            raise ValueError(
                f"HRIRSet: azimuths_deg and elevations_deg must have shape ({n_dirs},) like "
                f"irs' first axis, got {az.shape} and {el.shape}"
            )
        if not (np.all(np.isfinite(az)) and np.all(np.isfinite(el))):
            raise ValueError("HRIRSet: azimuths_deg and elevations_deg must be finite")
        if np.any(np.abs(el) > 90.0):
            raise ValueError(f"HRIRSet: elevations_deg must be in [-90, 90], got {el.min()}..")
        fs = self.fs
        if isinstance(fs, bool) or not float(fs).is_integer() or fs <= 0:
            raise ValueError(f"HRIRSet: fs must be a positive integer (Hz), got {fs!r}")
        az = wrap_azimuth(az)
        for arr in (az, el, irs):
            arr.setflags(write=False)
        object.__setattr__(self, "azimuths_deg", az)
        object.__setattr__(self, "elevations_deg", el)
        object.__setattr__(self, "irs", irs)
        object.__setattr__(self, "fs", int(fs))
        object.__setattr__(self, "source", str(self.source))

    @property
    def n_directions(self) -> int:
        """``D``, the number of measured directions."""
        return self.irs.shape[0]

    @property
    def n_mics(self) -> int:
        """``M``, the number of microphones (ears)."""
        return self.irs.shape[1]

    @property
    def length(self) -> int:
        """``L``, the impulse-response length in samples."""
        return self.irs.shape[2]

    @functools.cached_property
    def _unit_vectors(self) -> np.ndarray:
        return direction_vectors(self.azimuths_deg, self.elevations_deg)

    def nearest_index(
        self, azimuth_deg: np.ndarray | float, elevation_deg: np.ndarray | float = 0.0
    ) -> np.ndarray:
        """Index of the measured direction nearest (great-circle) to each query direction.

        Parameters
        ----------
        azimuth_deg, elevation_deg : float or ndarray (N,)
            Query directions in degrees (any azimuth; it wraps).

        Returns
        -------
        ndarray of int, the broadcast shape of the inputs
        """
        az, el = np.broadcast_arrays(
            np.asarray(azimuth_deg, dtype=float), np.asarray(elevation_deg, dtype=float)
        )
        if not (np.all(np.isfinite(az)) and np.all(np.isfinite(el))):
            raise ValueError("HRIRSet.nearest: azimuth_deg and elevation_deg must be finite")
        u = direction_vectors(az.reshape(-1), el.reshape(-1))  # (N, 3)
        # the largest cosine is the smallest great-circle angle
        return np.argmax(u @ self._unit_vectors.T, axis=1).reshape(az.shape)

    def nearest(self, azimuth_deg: float, elevation_deg: float = 0.0) -> np.ndarray:
        """Impulse responses ``(M, L)`` of the measured direction nearest to the given one."""
        return self.irs[int(self.nearest_index(float(azimuth_deg), float(elevation_deg)))]

    def resampled(self, fs: int) -> HRIRSet:
        """The same set at another sampling rate (polyphase, :func:`scipy.signal.resample_poly`).

        The length becomes ``ceil(L * fs / self.fs)``.
        """
        if isinstance(fs, bool) or not float(fs).is_integer() or fs <= 0:
            raise ValueError(f"HRIRSet.resampled: fs must be a positive integer, got {fs!r}")
        fs = int(fs)
        if fs == self.fs:
            return self
        ratio = Fraction(fs, self.fs)
        irs = scipy.signal.resample_poly(
            self.irs, ratio.numerator, ratio.denominator, axis=2, padtype="constant"
        )
        return HRIRSet(self.azimuths_deg, self.elevations_deg, irs, fs, self.source)


def load_nao_hrir(path: str | Path | None = None) -> HRIRSet:
    """The measured NAO-head HRIRs of the four top microphones, in nao4 order.

    Parameters
    ----------
    path : str or Path, optional
        The MATLAB file with variable ``HRIR_NAO`` of shape ``(32, 4, 72)`` (taps, mics,
        azimuths -175:5:180 degrees) at 48 kHz. Default: the shared-data copy.

    Returns
    -------
    HRIRSet
        ``D = 72`` horizontal directions (elevation 0), ``M = 4`` microphones in the order of
        ``builtin_array("nao4")`` (LOCATA mics 5, 8, 11, 12), ``L = 32``, ``fs = 48000``.
        See the module docstring for the azimuth convention and the channel reordering.
    """
    if path is None:
        from avtrack.io.datasets import find_shared_data

        path = find_shared_data() / NAO_HRIR_FILE
    path = Path(path)
    try:
        mat = scipy.io.loadmat(path)
    except (OSError, ValueError, NotImplementedError, scipy.io.matlab.MatReadError) as exc:
        raise InputError(f"cannot read the NAO HRIR file: {exc}", path) from None
    if "HRIR_NAO" not in mat:
        raise InputError("no variable 'HRIR_NAO' in the NAO HRIR file", path)
    h = np.asarray(mat["HRIR_NAO"], dtype=float)
    if h.ndim != 3 or h.shape[1] != 4 or h.shape[2] != 72:
        raise InputError(f"HRIR_NAO: expected shape (taps, 4, 72), got {h.shape}", path)
    if not np.all(np.isfinite(h)):
        raise InputError("HRIR_NAO contains NaN or infinite values", path)
    az = -175.0 + 5.0 * np.arange(72)
    irs = np.transpose(h, (2, 1, 0))[:, list(_NAO_CHANNELS_TO_NAO4), :]  # (72, 4, taps)
    return HRIRSet(az, np.zeros(72), irs, 48000, source="nao")


def _sofa_array(f, name: str, path: Path) -> np.ndarray:
    if name not in f:
        raise InputError(f"SOFA variable {name!r} is missing", path)
    return np.asarray(f[name][()], dtype=float)


def load_sofa(path: str | Path) -> HRIRSet:
    """Read a SOFA ``SimpleFreeFieldHRIR`` file (netCDF4 / HDF5) with h5py.

    Uses ``Data.IR (D, R, N)``, ``Data.SamplingRate``, ``Data.Delay`` (integer delays in
    samples, prepended as zeros) and ``SourcePosition`` (spherical ``(azimuth, elevation,
    distance)`` in degrees, or cartesian). SOFA's azimuth is counter-clockwise from the
    listener's view direction (+x) with elevation up, which is the array frame of this project;
    azimuths are only wrapped from [0, 360) to (-180, 180]. Files whose ``ListenerView`` is not
    +x or ``ListenerUp`` not +z are refused.

    Returns
    -------
    HRIRSet
        ``irs (D, R, N)``: receiver ``r`` is SOFA receiver ``r`` (for KEMAR: 0 = left ear at
        y = +0.09 m, 1 = right ear).
    """
    import h5py

    path = Path(path)
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise InputError(f"cannot open the SOFA file: {exc}", path) from None
    with f:
        conv = f.attrs.get("SOFAConventions", b"")
        conv = conv.decode() if isinstance(conv, bytes) else str(conv)
        if conv not in ("SimpleFreeFieldHRIR", ""):
            raise InputError(f"SOFAConventions {conv!r} is not SimpleFreeFieldHRIR", path)
        ir = _sofa_array(f, "Data.IR", path)
        fs_arr = _sofa_array(f, "Data.SamplingRate", path).reshape(-1)
        src = _sofa_array(f, "SourcePosition", path)
        src_type = f["SourcePosition"].attrs.get("Type", b"spherical")
        src_type = src_type.decode() if isinstance(src_type, bytes) else str(src_type)
        delay = _sofa_array(f, "Data.Delay", path) if "Data.Delay" in f else np.zeros((1, 1))
        view = _sofa_array(f, "ListenerView", path) if "ListenerView" in f else None
        up = _sofa_array(f, "ListenerUp", path) if "ListenerUp" in f else None
    if ir.ndim != 3 or min(ir.shape) == 0:
        raise InputError(f"Data.IR: expected shape (M, R, N), got {ir.shape}", path)
    n_dirs = ir.shape[0]
    if fs_arr.size != 1 or not (fs_arr[0] > 0 and float(fs_arr[0]).is_integer()):
        raise InputError(f"Data.SamplingRate: expected one integer rate, got {fs_arr}", path)
    if src.ndim != 2 or src.shape[1] != 3 or src.shape[0] not in (1, n_dirs):
        raise InputError(f"SourcePosition: expected shape ({n_dirs}, 3), got {src.shape}", path)
    for name, vec, ref in (("ListenerView", view, (1, 0, 0)), ("ListenerUp", up, (0, 0, 1))):
        if vec is None:
            continue
        v = vec.reshape(-1, 3)
        norm = np.linalg.norm(v, axis=1, keepdims=True)
        if v.shape[0] != 1 or not np.allclose(v / np.maximum(norm, 1e-12), ref, atol=1e-6):
            raise InputError(f"{name} {vec.tolist()} is not {list(ref)}: unsupported", path)
    if src_type.lower().startswith("cartesian"):
        x, y, z = src.T
        az = np.rad2deg(np.arctan2(y, x))
        el = np.rad2deg(np.arctan2(z, np.hypot(x, y)))
    else:
        az, el = src[:, 0], src[:, 1]
    az = np.broadcast_to(az, (n_dirs,))
    el = np.broadcast_to(el, (n_dirs,))
    d = np.broadcast_to(np.rint(delay).astype(int), (n_dirs, ir.shape[1]))
    if np.any(d < 0) or not np.allclose(delay, np.rint(delay)):
        raise InputError("Data.Delay must hold non-negative integer sample delays", path)
    if np.any(d > 0):
        out = np.zeros((n_dirs, ir.shape[1], ir.shape[2] + int(d.max())))
        for i in range(n_dirs):
            for r in range(ir.shape[1]):
                out[i, r, d[i, r] : d[i, r] + ir.shape[2]] = ir[i, r]
        ir = out
    if not np.all(np.isfinite(ir)):
        raise InputError("Data.IR contains NaN or infinite values", path)
    return HRIRSet(az, el, ir, int(fs_arr[0]), source=str(path))


@functools.lru_cache(maxsize=4)
def builtin_hrir(name: str) -> HRIRSet:
    """A built-in HRIR set from the shared data: ``"nao"`` or ``"kemar"`` (cached).

    Raises
    ------
    InputError
        When the shared data folder (or the file in it) is absent.
    ValueError
        For another name.
    """
    if name not in BUILTIN_HRIRS:
        raise ValueError(f"builtin_hrir: name must be one of {BUILTIN_HRIRS}, got {name!r}")
    from avtrack.io.datasets import find_shared_data

    try:
        root = find_shared_data()
    except InputError as exc:
        raise InputError(f"the {name!r} HRIRs need the shared data: {exc}") from None
    rel = NAO_HRIR_FILE if name == "nao" else KEMAR_SOFA_FILE
    path = root / rel
    if not path.is_file():
        raise InputError(f"the {name!r} HRIRs need {rel} in the shared data", path)
    hrir = load_nao_hrir(path) if name == "nao" else load_sofa(path)
    return HRIRSet(hrir.azimuths_deg, hrir.elevations_deg, hrir.irs, hrir.fs, source=name)
