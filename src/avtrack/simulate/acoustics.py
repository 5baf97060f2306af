"""Acoustic rendering of moving talkers and noise in a shoebox room.

Frames
------
The ROOM frame has its origin in a corner of the shoebox ``[0, Lx] x [0, Ly] x [0, Lz]``
(metres, z up). The array sits at :class:`ArrayPose` ``position`` with its ARRAY frame
(x forward, y left, z up; see :mod:`avtrack.audio.arrays`) turned by ``yaw_deg`` about z:
a point ``p`` of the array frame is at ``position + R(yaw) p`` in the room.

Room impulse responses: a hybrid image-source / diffuse-tail model
------------------------------------------------------------------
One full image-source RIR at T60 = 0.4 s (``pyroomacoustics.ShoeBox.compute_rir``, order 53)
costs 0.1-0.2 s, far too much to redo every 5 cm of a walking talker. The RIR is therefore
split at a mixing time ``t_mix`` (``early_s``, 50 ms by default, later if a source is farther
than ~14 m) in the spirit of Lehmann & Johansson, "Diffuse reverberation model for efficient
image-source simulation of room impulse responses", IEEE TASLP 18(6), 2010:

- **Early part** (direct path and every image arriving before ``t_mix``, recomputed for every
  source position in ~0.1 ms): the Allen & Berkley image-source method, vectorised in NumPy.
  In each axis an image is at ``(1 - 2q) s + 2 m L`` and has met the walls
  ``|m - q| + |m|`` times (``q`` in {0, 1}, ``m`` integer); its amplitude is
  ``beta^n / d`` (pyroomacoustics's scale, no ``4 pi``), ``beta = sqrt(1 - alpha)`` with the
  absorption ``alpha`` and the order limit of :func:`pyroomacoustics.inverse_sabine`, ``d``
  the image-microphone distance. Each image is a Hann-windowed sinc fractional delay (33 taps,
  the window centred on the true delay so inter-microphone delays are exact). For an
  ``"hrtf"`` array each image is instead placed at its distance from the array-frame origin
  and filtered by the measured HRIR of its direction of arrival (nearest measured direction,
  in the array frame), the HRIRs resampled to the room rate and scaled to unit diffuse-field
  energy (mean over directions and microphones of ``sum h^2`` = 1).
- **Late tail** (after ``t_mix``, drawn once per source and render): spatially diffuse noise
  (:func:`diffuse_noise`: sinc coherence between free-field microphones, the HRIR set's
  diffuse-field cross-spectra for a head) under the envelope ``sigma(t)^2 = K 10^(-6 t/T60)``
  of the requested T60 (Polack's model). ``K`` continues the image-source energy that arrives
  in the 20 ms before the cross-over (at the source's first position), so the two parts join
  without a step. The late field of a room is diffuse and nearly position-independent, so one
  tail per source suffices; its fine structure does not follow the source, which is the
  approximation made. Early images fade out and the tail fades in with energy-complementary
  cos / sin ramps over ``t_mix +- 5 ms``.
- As in pyroomacoustics, a 2nd-order Butterworth high-pass at 10 Hz removes the
  low-frequency offset that image-source RIRs build up (all images are positive). It is
  applied to each rendered source image (the same, by linearity, as to every RIR).

Against the full pyroomacoustics RIR (same absorption and order) the first 40 ms coincide
(energy within 0.1 dB), the direct-to-reverberant ratio is within 1 dB (0.3-0.8 dB lower in a
6 x 5 x 3 m room at T60 = 0.3-0.6 s) and the Schroeder T30 is within 3 % of the requested T60,
where the pure image-source RIR with Sabine absorption runs 1-13 % long.

Time-varying rendering (:func:`render`)
---------------------------------------
A source's RIR is recomputed at *update points*: every ``step_m`` of path length along its
piecewise-linear trajectory (so it never moves more than ``step_m`` between two RIRs), plus the
first and last sample. Between two update points ``n_b < n_{b+1}`` the signal is split with the
complementary linear ramps ``w_b(n) = (n_{b+1} - n) / (n_{b+1} - n_b)`` and ``1 - w_b(n)``, and
each part is convolved with the early RIR of its end point (FFT overlap-add in blocks of about
1000 samples). The ramps sum to one, so a static source gives exactly the one-shot convolution
with its RIR, and an impulse emitted at an update point gets exactly that point's RIR. Blocks
where the signal is zero are skipped. The tail is convolved once with the whole signal
(:func:`scipy.signal.oaconvolve`). Sample 0 of a source signal is emitted at t = 0.

Noise
-----
:func:`diffuse_noise` (spherically isotropic field, Habets, Cohen & Gannot, "Generating
nonstationary multisensor signals under a spatial coherence constraint", JASA 124(5), 2008;
written here, pyroomacoustics has no such generator), :func:`point_noise` (a static source
fixed to the array, e.g. a robot's fan), :func:`fan_noise` (a synthetic fan spectrum),
:func:`fan_noise_image` (the two together) and :func:`mix_at_snr`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TypedDict, Unpack

import numpy as np
import pyroomacoustics as pra
import scipy.fft
import scipy.signal

from avtrack.audio.arrays import SPEED_OF_SOUND, MicArray
from avtrack.audio.hrtf import HRIRSet
from avtrack.io.doa import wrap_azimuth

SINC_HALF = 16
"""Half length of the fractional-delay kernel (33 taps)."""
TAPER_S = 0.005
"""Half width of the early / late cross-over ramp, seconds."""
CALIBRATION_S = 0.02
"""Length of the window before the cross-over whose image energy sets the tail level."""
TAIL_DB = 65.0
"""The tail is cut where its envelope has decayed by this many dB."""
HIGHPASS_HZ = 10.0
"""Cut-off of the 2nd-order Butterworth high-pass removing the image-source low-frequency
offset (the value pyroomacoustics uses)."""


@functools.lru_cache(maxsize=8)
def _highpass(fs: int) -> tuple[np.ndarray, int]:
    """High-pass ``sos`` and the number of samples after which its impulse response is below
    1e-9 of its peak."""
    sos = scipy.signal.butter(2, HIGHPASS_HZ, "highpass", fs=fs, output="sos")
    radius = float(np.max(np.abs(scipy.signal.sos2zpk(sos)[1])))  # slowest pole
    return sos, math.ceil(math.log(1e-9) / math.log(radius))


# --------------------------------------------------------------------------- data types


def _finite_float(owner: str, name: str, value: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{owner}: {name} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"{owner}: {name} must be finite, got {value!r}")
    return v


@dataclass(frozen=True, eq=False)
class Room:
    """A shoebox room.

    Attributes
    ----------
    dims : ndarray (3,)
        ``(Lx, Ly, Lz)`` in metres, each > 0.
    t60 : float
        Reverberation time in seconds; 0 means anechoic (free field: direct path only).
    fs : int
        Sampling rate of every signal rendered in this room, Hz.
    """

    dims: np.ndarray
    t60: float
    fs: int = 16000

    def __post_init__(self) -> None:
        dims = np.array(self.dims, dtype=float).reshape(-1)
        if dims.shape != (3,) or not np.all(np.isfinite(dims)) or np.any(dims <= 0):
            raise ValueError(f"Room: dims must be 3 finite lengths > 0 (m), got {self.dims!r}")
        dims.setflags(write=False)
        object.__setattr__(self, "dims", dims)
        t60 = _finite_float("Room", "t60", self.t60)
        if t60 < 0:
            raise ValueError(f"Room: t60 must be >= 0 seconds, got {t60!r}")
        object.__setattr__(self, "t60", t60)
        fs = self.fs
        if isinstance(fs, bool) or not float(fs).is_integer() or fs <= 0:
            raise ValueError(f"Room: fs must be a positive integer (Hz), got {fs!r}")
        object.__setattr__(self, "fs", int(fs))
        if t60 > 0:
            try:
                pra.inverse_sabine(t60, dims, c=SPEED_OF_SOUND)
            except ValueError:
                raise ValueError(
                    f"Room: t60 = {t60} s is too short for a {dims.tolist()} m room "
                    "(Sabine's formula needs an absorption above 1)"
                ) from None

    @functools.cached_property
    def _sabine(self) -> tuple[float, int]:
        if self.t60 == 0:
            return 1.0, 0
        alpha, order = pra.inverse_sabine(self.t60, self.dims, c=SPEED_OF_SOUND)
        return float(alpha), int(order)

    @property
    def absorption(self) -> float:
        """Energy absorption coefficient of every wall (:func:`pyroomacoustics.inverse_sabine`;
        1 when anechoic)."""
        return self._sabine[0]

    @property
    def max_order(self) -> int:
        """Image-source order limit from :func:`pyroomacoustics.inverse_sabine` (0 if
        anechoic)."""
        return self._sabine[1]

    @property
    def volume(self) -> float:
        """Room volume, m^3."""
        return float(np.prod(self.dims))

    def contains(self, points: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """``(N,)`` bool: whether each room-frame point ``(N, 3)`` is inside, ``margin`` metres
        away from every wall."""
        p = np.atleast_2d(np.asarray(points, dtype=float))
        return np.all((p > margin) & (p < self.dims - margin), axis=1)


@dataclass(frozen=True, eq=False)
class ArrayPose:
    """Where the array is in the room.

    Attributes
    ----------
    position : ndarray (3,)
        Room-frame position of the array-frame origin, metres.
    yaw_deg : float
        Rotation of the array frame about the room's z axis, degrees counter-clockwise
        (0: the array's x axis along the room's x axis).
    """

    position: np.ndarray
    yaw_deg: float = 0.0

    def __post_init__(self) -> None:
        pos = np.array(self.position, dtype=float).reshape(-1)
        if pos.shape != (3,) or not np.all(np.isfinite(pos)):
            raise ValueError(
                f"ArrayPose: position must be 3 finite numbers, got {self.position!r}"
            )
        pos.setflags(write=False)
        object.__setattr__(self, "position", pos)
        object.__setattr__(self, "yaw_deg", _finite_float("ArrayPose", "yaw_deg", self.yaw_deg))

    @property
    def rotation(self) -> np.ndarray:
        """``(3, 3)`` rotation ``R`` with ``room = position + R @ array``."""
        c, s = math.cos(math.radians(self.yaw_deg)), math.sin(math.radians(self.yaw_deg))
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _as_points(points: np.ndarray, name: str) -> np.ndarray:
    p = np.asarray(points, dtype=float)
    if p.ndim == 1 and p.shape[0] == 3:
        p = p[None, :]
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3), got {np.shape(points)}")
    if not np.all(np.isfinite(p)):
        raise ValueError(f"{name} must be finite")
    return p


def room_to_array(pose: ArrayPose, points: np.ndarray) -> np.ndarray:
    """Room-frame points ``(N, 3)`` in the array frame: ``R^T (p - position)``, ``(N, 3)``."""
    p = _as_points(points, "points")
    return (p - pose.position) @ pose.rotation  # rows: R^T (p - c)


def array_to_room(pose: ArrayPose, points: np.ndarray) -> np.ndarray:
    """Array-frame points ``(N, 3)`` in the room frame: ``position + R p``, ``(N, 3)``."""
    p = _as_points(points, "points")
    return p @ pose.rotation.T + pose.position


def azimuth_elevation(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Directions of array-frame points ``(N, 3)`` seen from the array-frame origin.

    Returns
    -------
    az_deg : ndarray (N,)
        Counter-clockwise from x, in (-180, 180].
    el_deg : ndarray (N,)
        Up from the xy plane, in [-90, 90].
    """
    p = _as_points(points, "points")
    az = wrap_azimuth(np.rad2deg(np.arctan2(p[:, 1], p[:, 0])))
    el = np.rad2deg(np.arctan2(p[:, 2], np.hypot(p[:, 0], p[:, 1])))
    return az, el


@dataclass(frozen=True, eq=False)
class MovingSource:
    """A talker (or any sound source) moving along a piecewise-linear path.

    Attributes
    ----------
    signal : ndarray (n_samples,)
        The dry source signal at the room's sampling rate; sample 0 is emitted at t = 0.
    times : ndarray (K,)
        Strictly increasing knot times in seconds (K = 1: a static source).
    positions : ndarray (K, 3)
        Room-frame positions at the knots. Before ``times[0]`` the source stays at
        ``positions[0]``, after ``times[-1]`` at ``positions[-1]``.
    """

    signal: np.ndarray
    times: np.ndarray
    positions: np.ndarray

    def __post_init__(self) -> None:
        sig = np.array(self.signal, dtype=float)
        if sig.ndim != 1 or sig.size == 0:
            raise ValueError(f"MovingSource: signal must be 1-D and non-empty, got {sig.shape}")
        if not np.all(np.isfinite(sig)):
            raise ValueError("MovingSource: signal contains NaN or infinite values")
        times = np.array(self.times, dtype=float).reshape(-1)
        if times.size == 0 or not np.all(np.isfinite(times)):
            raise ValueError(f"MovingSource: times must be finite and non-empty, got {times!r}")
        if np.any(np.diff(times) <= 0):
            raise ValueError("MovingSource: times must be strictly increasing")
        pos = np.array(self.positions, dtype=float)
        if pos.ndim == 1 and pos.shape == (3,):
            pos = pos[None, :]
        if pos.shape != (times.size, 3) or not np.all(np.isfinite(pos)):
            raise ValueError(
                f"MovingSource: positions must be finite with shape ({times.size}, 3), got "
                f"{np.shape(self.positions)}"
            )
        for arr in (sig, times, pos):
            arr.setflags(write=False)
        object.__setattr__(self, "signal", sig)
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "positions", pos)

    @classmethod
    def static(cls, signal: np.ndarray, position: Sequence[float] | np.ndarray) -> MovingSource:
        """A source that does not move."""
        return cls(signal, np.zeros(1), np.asarray(position, dtype=float).reshape(1, 3))

    def position_at(self, t: np.ndarray) -> np.ndarray:
        """Positions ``(N, 3)`` at times ``t (N,)`` seconds (held constant outside the knots)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return np.stack([np.interp(t, self.times, self.positions[:, d]) for d in range(3)], 1)


# --------------------------------------------------------------------------- image sources


_TAPS = np.arange(-SINC_HALF, SINC_HALF + 2)  # kernel taps k relative to floor(delay)
_SIGN = -((-1.0) ** _TAPS)  # sin(pi (k - f)) = -(-1)^k sin(pi f)
_WIN = np.pi / (SINC_HALF + 1)
_COS_K, _SIN_K = np.cos(_WIN * _TAPS), np.sin(_WIN * _TAPS)


def _fractional_delay(frac: np.ndarray) -> np.ndarray:
    """Hann-windowed sinc taps at ``k - frac``, ``k`` in :data:`_TAPS`, for fractional delays
    ``frac`` in [0, 1); shape ``frac.shape + (len(_TAPS),)``.

    ``h_k = w(k - f) sinc(k - f)`` with ``w(x) = (1 + cos(pi x / (H + 1))) / 2``, zero from
    ``|x| = H + 1`` on. The trigonometric functions are expanded around the integer taps
    (``sin(pi (k - f)) = -(-1)^k sin(pi f)``, ``cos(a (k - f)) = cos(a k) cos(a f) +
    sin(a k) sin(a f)``) so that only ``sin``/``cos`` of ``f`` are evaluated.
    """
    f = frac[..., None]
    x = _TAPS - f
    with np.errstate(divide="ignore", invalid="ignore"):
        sinc = _SIGN * np.sin(np.pi * f) / (np.pi * x)
    if np.any(frac == 0.0):
        sinc = np.where(x == 0.0, 1.0, sinc)  # the integer-delay tap
    window = 0.5 + 0.5 * (_COS_K * np.cos(_WIN * f) + _SIN_K * np.sin(_WIN * f))
    return window * sinc


@functools.lru_cache(maxsize=8)
def _prepared_hrir(hrir: HRIRSet, fs: int) -> tuple[np.ndarray, np.ndarray]:
    """HRIRs at ``fs`` scaled to unit diffuse-field energy ``(D, M, L)``, and the measured
    directions' unit vectors ``(D, 3)``."""
    from avtrack.audio.hrtf import direction_vectors

    irs = hrir.resampled(fs).irs
    # mean over directions and mics of sum_t h^2 = 1
    irs = irs / math.sqrt(float(np.mean(np.sum(irs**2, axis=2))))
    return irs, direction_vectors(hrir.azimuths_deg, hrir.elevations_deg)


class _Acoustics:
    """Everything about one (room, array, pose) that does not depend on the source: the image
    lattice, the microphones in the room, the HRIRs at the room rate."""

    def __init__(self, room: Room, array: MicArray, pose: ArrayPose, t_mix: float) -> None:
        self.room, self.array, self.pose = room, array, pose
        self.fs = room.fs
        self.t_mix = t_mix
        self.t_early = t_mix + TAPER_S if room.t60 > 0 else t_mix  # last early arrival, s
        self.pad = SINC_HALF  # early RIR index j <-> time (j - pad) / fs
        self.mics = array_to_room(pose, array.positions)  # (M, 3)
        self.hrtf = array.kind == "hrtf"
        self.centre = pose.position if self.hrtf else self.mics.mean(axis=0)
        self.reach = (self.array.radius if not self.hrtf else 0.0) + SPEED_OF_SOUND * self.t_early
        self.n_early = math.ceil(self.t_early * self.fs) + 2 * SINC_HALF + 2
        self.beta = math.sqrt(max(0.0, 1.0 - room.absorption))
        if self.hrtf and array.hrir is not None:
            self.hrirs, self.hrir_dirs = _prepared_hrir(array.hrir, self.fs)
            self.n_rir = self.n_early + self.hrirs.shape[2] - 1
        else:
            self.n_rir = self.n_early
        self.nfft = int(2 ** math.ceil(math.log2(2 * self.n_rir)))
        self.block = self.nfft - self.n_rir + 1
        if self.hrtf:
            self.hrir_f = np.fft.rfft(self.hrirs, self.nfft, axis=2)  # (D, M, F)
        # image lattice, per axis: sign (1 - 2q), offset 2 m L, reflection count |m - q| + |m|
        self.axes = []
        for a in range(3):
            length = float(room.dims[a])
            m_max = math.ceil((self.reach + length) / (2 * length)) + 1
            if room.max_order == 0:
                m_max = 0
            m = np.repeat(np.arange(-m_max, m_max + 1), 2)
            q = np.tile([0, 1], 2 * m_max + 1)
            self.axes.append((1.0 - 2.0 * q, 2.0 * m * length, np.abs(m - q) + np.abs(m)))
        n_ref = (
            self.axes[0][2][:, None, None]
            + self.axes[1][2][None, :, None]
            + self.axes[2][2][None, None, :]
        )
        self.order_ok = n_ref <= room.max_order
        self.n_ref = n_ref

    def images(self, src: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Images of ``src (3,)`` that can arrive before the end of the early part.

        Returns
        -------
        positions : ndarray (I, 3)
        n_reflections : ndarray (I,)
        """
        coords = [sgn * src[a] + off for a, (sgn, off, _) in enumerate(self.axes)]
        d2 = (
            (coords[0] - self.centre[0])[:, None, None] ** 2
            + (coords[1] - self.centre[1])[None, :, None] ** 2
            + (coords[2] - self.centre[2])[None, None, :] ** 2
        )
        ix, iy, iz = np.nonzero((d2 <= self.reach**2) & self.order_ok)
        pos = np.stack([coords[0][ix], coords[1][iy], coords[2][iz]], axis=1)
        return pos, self.n_ref[ix, iy, iz]

    def _arrivals(self, src: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Delays ``(I, M')`` in seconds, amplitudes ``(I, M')`` (taper included), for a head
        the HRIR direction indices ``(I,)`` (``M' = M`` free-field, 1 for a head), and the
        reflection counts ``(I,)``."""
        img, n_ref = self.images(src)
        if self.hrtf:
            rel = img - self.centre
            dist = np.linalg.norm(rel, axis=1)[:, None]  # (I, 1)
            u = (rel @ self.pose.rotation) / np.maximum(dist, 1e-12)  # array-frame directions
            dirs = np.argmax(u @ self.hrir_dirs.T, axis=1)  # nearest measured direction
        else:
            dist = np.linalg.norm(img[:, None, :] - self.mics[None, :, :], axis=2)  # (I, M)
            dirs = np.zeros(0, dtype=int)
        if np.any(dist < 0.01):
            raise ValueError("a source is closer than 1 cm to a microphone (or the head centre)")
        delay = dist / SPEED_OF_SOUND
        amp = self.beta ** n_ref[:, None] / dist  # beta^n / d, as pyroomacoustics
        if self.room.t60 > 0:
            amp = amp * _fade_out(delay, self.t_mix)
        return delay, amp, dirs, n_ref

    def _trains(self, src: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Image impulse trains ``(C, n_early)`` (index ``j`` is time ``(j - pad) / fs``): one
        row per microphone (free-field) or per HRIR direction used (head), and those
        directions ``(C,)`` (empty for free-field)."""
        delay, amp, dirs, _ = self._arrivals(src)
        tau = delay * self.fs + self.pad  # arrival in samples on the index axis
        n0 = np.floor(tau)
        val = amp[..., None] * _fractional_delay(tau - n0)  # (I, M', T)
        idx = n0.astype(int)[..., None] + _TAPS
        ok = (idx >= 0) & (idx < self.n_early)
        if self.hrtf:
            used, rows = np.unique(dirs, return_inverse=True)
            rows = np.broadcast_to(rows[:, None, None], idx.shape)
        else:
            used = np.zeros(0, dtype=int)
            rows = np.broadcast_to(np.arange(delay.shape[1])[None, :, None], idx.shape)
        n_rows = used.size if self.hrtf else delay.shape[1]
        trains = np.bincount(
            (rows * self.n_early + idx)[ok], val[ok], minlength=n_rows * self.n_early
        ).reshape(n_rows, self.n_early)
        return trains, used

    def early_spectrum(self, src: np.ndarray) -> np.ndarray:
        """``rfft`` of the early RIR at ``nfft`` points, ``(M, nfft // 2 + 1)``."""
        trains, used = self._trains(src)
        spec = np.fft.rfft(trains, self.nfft, axis=1)
        if not self.hrtf:
            return spec
        # H_m(f) = sum_u S_u(f) HRIR_{u,m}(f): each image filtered by its direction's HRIR
        return np.einsum("uf,umf->mf", spec, self.hrir_f[used])

    def early_time(self, src: np.ndarray) -> np.ndarray:
        """Early RIR ``(M, n_rir)``; index ``j`` is time ``(j - pad) / fs``."""
        if not self.hrtf:
            return self._trains(src)[0]
        return np.fft.irfft(self.early_spectrum(src), self.nfft, axis=1)[:, : self.n_rir]

    def tail(self, src: np.ndarray, rng: np.random.Generator) -> tuple[int, np.ndarray]:
        """Late tail ``(M, n_tail)`` starting at sample ``start`` (time ``start / fs``)."""
        room, fs = self.room, self.fs
        if room.t60 == 0:
            return 0, np.zeros((self.array.n_mics, 0))
        t0 = self.t_mix - TAPER_S
        t_end = max(room.t60 * TAIL_DB / 60.0, self.t_mix + TAPER_S + 0.01)
        start = math.floor(t0 * fs)
        t = (start + np.arange(math.ceil(t_end * fs) - start)) / fs
        decay = 10.0 ** (-6.0 * t / room.t60)  # energy envelope of the tail, 60 dB per T60
        # level: the energy of the reflections arriving in [t0 - CALIBRATION_S, t0], per mic
        delay, amp, _, n_ref = self._arrivals(src)
        lo = max(t0 - CALIBRATION_S, 0.0)
        sel = (delay >= lo) & (delay < t0) & (n_ref[:, None] > 0)
        a = math.log(10.0) * 6.0 / room.t60
        window_decay = (math.exp(-a * lo) - math.exp(-a * t0)) / a  # int_lo^t0 decay dt
        energy = float(np.sum(amp[sel] ** 2)) / delay.shape[1]
        n_img = int(np.count_nonzero(sel)) / delay.shape[1]
        if n_img >= 8:
            level = energy / (fs * window_decay)
        else:  # few images (huge room, short t_mix): the diffuse-field value 4 pi c / (V fs)
            level = 4.0 * np.pi * SPEED_OF_SOUND / (room.volume * fs)
        noise = diffuse_noise(self.array, t.size, fs, rng)
        noise /= np.sqrt(np.mean(noise**2))
        env = np.sqrt(level * decay) * _fade_in(t, self.t_mix)
        return start, noise * env


def _ramp(t: np.ndarray, t_mix: float) -> np.ndarray:
    return np.clip((t - (t_mix - TAPER_S)) / (2 * TAPER_S), 0.0, 1.0) * (np.pi / 2)


def _fade_out(t: np.ndarray, t_mix: float) -> np.ndarray:
    """Weight of the early images: 1 before ``t_mix - TAPER_S``, cos ramp to 0 after."""
    return np.cos(_ramp(t, t_mix))


def _fade_in(t: np.ndarray, t_mix: float) -> np.ndarray:
    """Weight of the tail: sin ramp, energy-complementary to :func:`_fade_out`."""
    return np.sin(_ramp(t, t_mix))


# --------------------------------------------------------------------------- rendering


def _check_scene(
    room: Room, array: MicArray, pose: ArrayPose, sources: Sequence[MovingSource]
) -> None:
    if not isinstance(room, Room):
        raise ValueError(f"room must be a Room, got {type(room).__name__}")
    if not isinstance(array, MicArray):
        raise ValueError(f"array must be a MicArray, got {type(array).__name__}")
    if not isinstance(pose, ArrayPose):
        raise ValueError(f"pose must be an ArrayPose, got {type(pose).__name__}")
    mics = array_to_room(pose, array.positions)
    if not np.all(room.contains(mics)):
        raise ValueError(
            f"pose: the array's microphones must be inside the {room.dims.tolist()} m room, got "
            f"{np.round(mics, 3).tolist()}"
        )
    for k, s in enumerate(sources):
        if not isinstance(s, MovingSource):
            raise ValueError(f"sources[{k}] must be a MovingSource, got {type(s).__name__}")
        if not np.all(room.contains(s.positions)):
            raise ValueError(
                f"sources[{k}].positions: every knot must be inside the "
                f"{room.dims.tolist()} m room"
            )


def _mixing_time(array: MicArray, pose: ArrayPose, src: MovingSource, early_s: float) -> float:
    d_max = float(np.max(np.linalg.norm(src.positions - pose.position, axis=1)))
    # the direct path must arrive well before the cross-over
    return max(early_s, (d_max + array.radius) / SPEED_OF_SOUND + 2 * TAPER_S + 0.002)


def _update_points(src: MovingSource, n: int, fs: int, step_m: float) -> np.ndarray:
    """Update samples ``(B + 1,)``: 0, every ``step_m`` of path length, and ``n``."""
    t_end = n / fs
    inside = (src.times > 0) & (src.times < t_end)
    tk = np.concatenate([[0.0], src.times[inside], [t_end]])
    pk = src.position_at(tk)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pk, axis=0), axis=1))])
    targets = step_m * np.arange(1, math.floor(arc[-1] / step_m) + 1)
    # first knot segment where the arc length reaches each target (strictly increasing there)
    seg = np.clip(np.searchsorted(arc, targets, side="left"), 1, len(arc) - 1)
    frac = (targets - arc[seg - 1]) / np.maximum(arc[seg] - arc[seg - 1], 1e-300)
    t_up = tk[seg - 1] + frac * (tk[seg] - tk[seg - 1])
    samples = np.rint(np.concatenate([[0.0], t_up * fs, [n]])).astype(int)
    return np.unique(np.clip(samples, 0, n))


def _render_source(
    acou: _Acoustics, src: MovingSource, step_m: float, rng: np.random.Generator, n_out: int
) -> np.ndarray:
    fs, pad, nfft, block = acou.fs, acou.pad, acou.nfft, acou.block
    x = src.signal
    n = x.size
    buf = np.zeros((acou.array.n_mics, max(n + nfft, n_out) + pad))  # index = time + pad
    ups = _update_points(src, n, fs, step_m)
    pos = src.position_at(ups / fs)
    cache: dict[int, np.ndarray] = {}

    def spectrum(b: int) -> np.ndarray:
        if b not in cache:
            if b > 0 and np.array_equal(pos[b], pos[b - 1]) and (b - 1) in cache:
                cache[b] = cache[b - 1]
            else:
                cache[b] = acou.early_spectrum(pos[b])
            for old in [k for k in cache if k < b - 1]:
                del cache[old]
        return cache[b]

    for b in range(len(ups) - 1):
        u0, u1 = int(ups[b]), int(ups[b + 1])
        same = np.array_equal(pos[b], pos[b + 1])
        for s in range(u0, u1, block):
            e = min(s + block, u1)
            xc = x[s:e]
            if not np.any(xc):
                continue
            if same:
                y_f = np.fft.rfft(xc, nfft)[None, :] * spectrum(b)
            else:
                r = (np.arange(s, e) - u0) / (u1 - u0)  # ramp towards update point b + 1
                xf = np.fft.rfft(np.stack([xc * (1.0 - r), xc * r]), nfft, axis=1)
                y_f = xf[0][None, :] * spectrum(b) + xf[1][None, :] * spectrum(b + 1)
            y = np.fft.irfft(y_f, nfft, axis=1)
            buf[:, s : s + nfft] += y
    start, tail = acou.tail(pos[0], rng)
    if tail.shape[1] and np.any(x):
        y = scipy.signal.oaconvolve(x[None, :], tail, axes=1)
        lo = start + pad
        hi = min(lo + y.shape[1], buf.shape[1])
        if hi > lo:
            buf[:, lo:hi] += y[:, : hi - lo]
    out = np.zeros((acou.array.n_mics, n_out))
    m = min(n_out, buf.shape[1] - pad)
    out[:, :m] = buf[:, pad : pad + m]
    # remove the image-source low-frequency offset (linear, time-invariant: the same as
    # high-passing every RIR)
    return scipy.signal.sosfilt(_highpass(fs)[0], out, axis=1)


def _rng(rng: np.random.Generator | int) -> np.random.Generator:
    if isinstance(rng, np.random.Generator):
        return rng
    if isinstance(rng, int | np.integer) and not isinstance(rng, bool):
        return np.random.default_rng(int(rng))
    raise ValueError(f"rng must be a numpy Generator or an int seed, got {rng!r}")


class RenderOptions(TypedDict, total=False):
    """The keyword options of :func:`render_images` (and :func:`render`)."""

    early_s: float
    n_samples: int | None
    rng: np.random.Generator | int


def render(
    room: Room,
    array: MicArray,
    pose: ArrayPose,
    sources: MovingSource | Sequence[MovingSource],
    step_m: float = 0.05,
    **options: Unpack[RenderOptions],
) -> np.ndarray:
    """Microphone signals of moving sources in a reverberant room (see the module docstring):
    the sum of :func:`render_images`, with the same parameters.

    Returns
    -------
    mix : ndarray (n_mics, n_samples)
        Sum of the source images (each high-passed at 10 Hz, see the module docstring).
    """
    return render_images(room, array, pose, sources, step_m, **options).sum(axis=0)


def render_images(
    room: Room,
    array: MicArray,
    pose: ArrayPose,
    sources: MovingSource | Sequence[MovingSource],
    step_m: float = 0.05,
    *,
    early_s: float = 0.05,
    n_samples: int | None = None,
    rng: np.random.Generator | int = 0,
) -> np.ndarray:
    """Each moving source's image at the microphones in a reverberant room (see the module
    docstring); :func:`render` gives their sum.

    Parameters
    ----------
    room : Room
    array : MicArray
        Free-field (image-source method to every microphone) or hrtf (HRIR per image).
    pose : ArrayPose
        The array in the room; every microphone must be inside.
    sources : MovingSource or sequence of MovingSource
        Signals at ``room.fs``; every trajectory knot must be inside the room.
    step_m : float
        A source's RIR is recomputed every ``step_m`` metres of its path (> 0).
    early_s : float
        Cross-over from image sources to the diffuse tail, seconds after emission (> 0); made
        later automatically for sources so far away that their direct path would arrive after
        it.
    n_samples : int, optional
        Output length; default the longest source signal (reverberation beyond is cut).
    rng : numpy Generator or int
        Randomness of the diffuse tails (drawn per source, in order).

    Returns
    -------
    images : ndarray (n_sources, n_mics, n_samples)
        Each source's image, high-passed at 10 Hz (see the module docstring).
    """
    if isinstance(sources, MovingSource):
        sources = [sources]
    sources = list(sources)
    if not sources:
        raise ValueError("sources: expected at least one MovingSource, got none")
    _check_scene(room, array, pose, sources)
    step_m = _finite_float("render", "step_m", step_m)
    if step_m <= 0:
        raise ValueError(f"render: step_m must be > 0 metres, got {step_m!r}")
    early_s = _finite_float("render", "early_s", early_s)
    if early_s <= 2 * TAPER_S:
        raise ValueError(f"render: early_s must be > {2 * TAPER_S} s, got {early_s!r}")
    if n_samples is None:
        n_samples = max(s.signal.size for s in sources)
    if isinstance(n_samples, bool) or not float(n_samples).is_integer() or n_samples < 1:
        raise ValueError(f"render: n_samples must be a positive integer, got {n_samples!r}")
    gen = _rng(rng)
    images = np.zeros((len(sources), array.n_mics, int(n_samples)))
    for k, src in enumerate(sources):
        t_mix = _mixing_time(array, pose, src, early_s)
        acou = _Acoustics(room, array, pose, t_mix)
        images[k] = _render_source(acou, src, step_m, gen, int(n_samples))
    return images


def room_impulse_response(
    room: Room,
    array: MicArray,
    pose: ArrayPose,
    position: Sequence[float] | np.ndarray,
    *,
    early_s: float = 0.05,
    rng: np.random.Generator | int = 0,
) -> np.ndarray:
    """The RIR :func:`render` uses for a static source at ``position``.

    Early part, diffuse tail and the 10 Hz high-pass (whose response is kept until it has
    decayed below 1e-9 of its peak, ~0.47 s at 16 kHz). With the same ``rng``,
    ``render(room, array, pose, MovingSource.static(x, position))`` equals
    ``scipy.signal.oaconvolve(x[None], rir, axes=1)`` cut to ``len(x)`` (taps before time 0,
    present only for a source within ~35 cm of a microphone, are dropped here).

    Returns
    -------
    ndarray (n_mics, n_taps)
        Tap ``j`` is time ``j / room.fs`` after emission.
    """
    src = MovingSource.static(np.zeros(1), position)
    _check_scene(room, array, pose, [src])
    early_s = _finite_float("room_impulse_response", "early_s", early_s)
    if early_s <= 2 * TAPER_S:
        raise ValueError(f"early_s must be > {2 * TAPER_S} s, got {early_s!r}")
    acou = _Acoustics(room, array, pose, _mixing_time(array, pose, src, early_s))
    p = src.positions[0]
    early = acou.early_time(p)[:, acou.pad :]
    start, tail = acou.tail(p, _rng(rng))
    sos, n_hp = _highpass(room.fs)
    n = max(early.shape[1], start + tail.shape[1]) + n_hp
    out = np.zeros((array.n_mics, n))
    out[:, : early.shape[1]] += early
    out[:, start : start + tail.shape[1]] += tail
    return scipy.signal.sosfilt(sos, out, axis=1)


# --------------------------------------------------------------------------- noise


@functools.lru_cache(maxsize=16)
def _diffuse_mixing(array: MicArray, fs: int, nfft: int) -> np.ndarray:
    """``A (F, M, M)`` with ``A A^H`` the diffuse-field cross-spectral matrix per STFT bin."""
    f = np.fft.rfftfreq(nfft, 1.0 / fs)
    if array.kind == "hrtf" and array.hrir is not None:
        irs, _ = _prepared_hrir(array.hrir, fs)
        h = np.fft.rfft(irs, max(nfft, irs.shape[2]), axis=2)
        if h.shape[2] != f.size:  # HRIR longer than the frame: interpolate the spectra
            f_h = np.fft.rfftfreq(max(nfft, irs.shape[2]), 1.0 / fs)
            h = np.stack(
                [
                    np.interp(f, f_h, h[..., i].real) + 1j * np.interp(f, f_h, h[..., i].imag)
                    for i in np.ndindex(h.shape[:2])
                ]
            ).reshape(*h.shape[:2], f.size)
        # Phi(f) = mean_d h_d(f) h_d(f)^H: a field from every measured direction
        phi = np.einsum("dif,djf->fij", h, h.conj()) / h.shape[0]
    else:
        d = np.linalg.norm(array.positions[:, None, :] - array.positions[None, :, :], axis=2)
        # Gamma_ij(f) = sin(k d_ij) / (k d_ij), k = 2 pi f / c  (spherically isotropic field)
        phi = np.sinc(2.0 * f[:, None, None] * d[None, :, :] / SPEED_OF_SOUND).astype(complex)
    w, v = np.linalg.eigh(phi)
    return v * np.sqrt(np.clip(w, 0.0, None))[:, None, :]  # A = V sqrt(Lambda)


def diffuse_noise(
    array: MicArray,
    n_samples: int,
    fs: int,
    rng: np.random.Generator | int,
    signal: np.ndarray | None = None,
) -> np.ndarray:
    """Spatially diffuse noise at the microphones (Habets, Cohen & Gannot 2008).

    ``M`` mutually independent channels are mixed in the STFT domain (Hann frames of ~64 ms,
    50 % overlap) by ``A(f)`` with ``A(f) A(f)^H = Phi(f)``, ``A = V Lambda^{1/2}`` from the
    eigen-decomposition of the target cross-spectral matrix: for a free-field array the
    spherically isotropic coherence ``Phi_ij(f) = sinc(2 f d_ij / c)``; for an hrtf array
    ``Phi(f) = mean_d h_d(f) h_d(f)^H`` over the measured HRIR directions (a horizontal-only
    field for the NAO set). pyroomacoustics has no such generator; this is written here.

    Parameters
    ----------
    array : MicArray
    n_samples : int
    fs : int
        Sampling rate, Hz.
    rng : numpy Generator or int
    signal : ndarray (n,), optional
        A mono noise recording (e.g. babble, a fan) giving the spectrum and its time
        structure: the independent inputs are ``M`` segments of it starting at evenly spaced
        (circular) offsets after a random start. Default: white Gaussian noise.

    Returns
    -------
    ndarray (n_mics, n_samples)
        Scaled to a mean power (over channels and samples) of 1.
    """
    if not isinstance(array, MicArray):
        raise ValueError(f"diffuse_noise: array must be a MicArray, got {type(array).__name__}")
    for name, v in (("n_samples", n_samples), ("fs", fs)):
        if isinstance(v, bool) or not float(v).is_integer() or v < 1:
            raise ValueError(f"diffuse_noise: {name} must be a positive integer, got {v!r}")
    n_samples, fs = int(n_samples), int(fs)
    gen = _rng(rng)
    m = array.n_mics
    nfft = max(int(2 ** round(math.log2(0.064 * fs))), 16)  # ~64 ms frames
    n_gen = max(n_samples, 2 * nfft)  # at least two frames; cut to n_samples at the end
    if signal is None:
        inputs = gen.standard_normal((m, n_gen))
    else:
        sig = np.asarray(signal, dtype=float)
        if sig.ndim != 1 or sig.size < 2 or not np.all(np.isfinite(sig)) or not np.any(sig):
            raise ValueError(
                "diffuse_noise: signal must be a finite, non-silent 1-D array, got shape "
                f"{sig.shape}"
            )
        start = int(gen.integers(sig.size))
        offsets = start + (np.arange(m) * sig.size) // m
        inputs = sig[(offsets[:, None] + np.arange(n_gen)[None, :]) % sig.size]
    _, _, spec = scipy.signal.stft(inputs, fs, nperseg=nfft, boundary="even", padded=True)
    a = _diffuse_mixing(array, fs, nfft)  # (F, M, M)
    mixed = np.einsum("fij,jft->ift", a, spec)  # X_out(f, t) = A(f) X_in(f, t)
    _, out = scipy.signal.istft(mixed, fs, nperseg=nfft, boundary=True)
    out = np.asarray(out[:, :n_samples], dtype=float)
    if out.shape[1] < n_samples:
        out = np.pad(out, ((0, 0), (0, n_samples - out.shape[1])))
    power = float(np.mean(out**2))
    return out / math.sqrt(power) if power > 0 else out


def fan_noise(
    n_samples: int,
    fs: int,
    rng: np.random.Generator | int,
    *,
    hum_hz: float = 140.0,
    n_harmonics: int = 4,
    hum_db: float = -6.0,
) -> np.ndarray:
    """A stationary fan-like noise: low-passed broadband noise plus blade-pass hums.

    Broadband part: white noise through a 2nd-order Butterworth low-pass at 800 Hz plus a
    white floor 25 dB below (the hiss above). Tonal part: harmonics ``k * hum_hz``,
    ``k = 1..n_harmonics``, amplitudes ``1 / k``, each with a slowly wandering frequency
    (+-0.5 %) and a random phase; its power is ``hum_db`` relative to the broadband part.

    Returns
    -------
    ndarray (n_samples,)
        Unit RMS.
    """
    for name, v, low in (
        ("n_samples", n_samples, 1),
        ("fs", fs, 1),
        ("n_harmonics", n_harmonics, 0),
    ):
        if isinstance(v, bool) or not float(v).is_integer() or v < low:
            raise ValueError(f"fan_noise: {name} must be an integer >= {low}, got {v!r}")
    hum_hz = _finite_float("fan_noise", "hum_hz", hum_hz)
    hum_db = _finite_float("fan_noise", "hum_db", hum_db)
    n_samples, fs = int(n_samples), int(fs)
    if n_harmonics > 0 and not 0 < hum_hz * n_harmonics < fs / 2:
        raise ValueError(
            f"fan_noise: hum_hz * n_harmonics must be in (0, fs / 2), got {hum_hz} * {n_harmonics}"
        )
    gen = _rng(rng)
    sos = scipy.signal.butter(2, min(800.0, 0.45 * fs), fs=fs, output="sos")
    broad = scipy.signal.sosfilt(sos, gen.standard_normal(n_samples))
    broad /= np.sqrt(np.mean(broad**2))
    broad += 10 ** (-25 / 20) * gen.standard_normal(n_samples)
    broad /= np.sqrt(np.mean(broad**2))
    hum = np.zeros(n_samples)
    if n_harmonics > 0:
        # slow frequency wander: a random walk smoothed over ~0.5 s, scaled to +-0.5 %
        walk = np.cumsum(gen.standard_normal(n_samples)) / math.sqrt(fs)
        walk -= np.linspace(walk[0], walk[-1], n_samples)
        walk /= max(float(np.max(np.abs(walk))), 1e-12)
        inst = hum_hz * (1.0 + 0.005 * walk)
        phase = 2 * np.pi * np.cumsum(inst) / fs
        for k in range(1, int(n_harmonics) + 1):
            hum += np.sin(k * phase + gen.uniform(0, 2 * np.pi)) / k
        hum *= 10 ** (hum_db / 20) / np.sqrt(np.mean(hum**2))
    out = broad + hum
    return out / np.sqrt(np.mean(out**2))


def point_noise(
    room: Room,
    array: MicArray,
    pose: ArrayPose,
    signal: np.ndarray,
    offset: Sequence[float] | np.ndarray = (-0.10, 0.0, 0.0),
    *,
    early_s: float = 0.05,
    rng: np.random.Generator | int = 0,
) -> np.ndarray:
    """A static noise source fixed to the array (e.g. a robot's fan), rendered like a talker.

    Parameters
    ----------
    signal : ndarray (n_samples,)
        The noise at ``room.fs`` (e.g. :func:`fan_noise`).
    offset : (3,)
        Source position relative to the array centre (mean of the microphone positions), in
        the array frame, metres. Default 10 cm behind it.

    Returns
    -------
    ndarray (n_mics, n_samples)
    """
    off = np.asarray(offset, dtype=float).reshape(-1)
    if off.shape != (3,) or not np.all(np.isfinite(off)):
        raise ValueError(f"point_noise: offset must be 3 finite numbers, got {offset!r}")
    pos = array_to_room(pose, array.centre + off)[0]
    if not room.contains(pos)[0]:
        raise ValueError(f"point_noise: the noise source {pos.tolist()} is outside the room")
    src = MovingSource.static(signal, pos)
    return np.asarray(render(room, array, pose, src, early_s=early_s, rng=rng))


def fan_noise_image(
    room: Room,
    array: MicArray,
    pose: ArrayPose,
    n_samples: int,
    fs: int,
    rng: np.random.Generator | int,
    offset: Sequence[float] | np.ndarray = (-0.10, 0.0, 0.0),
) -> np.ndarray:
    """A robot's fan at the microphones: :func:`fan_noise` rendered by :func:`point_noise`.

    Parameters
    ----------
    fs : int
        Must equal ``room.fs`` (stated so that callers cannot mix rates silently).
    rng : numpy Generator or int
        Draws the fan signal, then the tail of its room response.
    offset : (3,)
        Fan position relative to the array centre, array frame; default 10 cm behind.

    Returns
    -------
    ndarray (n_mics, n_samples)
    """
    if not isinstance(room, Room):
        raise ValueError(f"fan_noise_image: room must be a Room, got {type(room).__name__}")
    if fs != room.fs:
        raise ValueError(f"fan_noise_image: fs ({fs!r}) must equal room.fs ({room.fs})")
    gen = _rng(rng)
    return point_noise(room, array, pose, fan_noise(n_samples, fs, gen), offset, rng=gen)


def speech_activity(
    speech_image: np.ndarray, frame: int = 320, threshold_db: float = 30.0
) -> np.ndarray:
    """Samples where the speech image is active: a simple energy detector.

    A frame of ``frame`` samples is active when its energy summed over channels is within
    ``threshold_db`` dB of the loudest frame.

    Returns
    -------
    ndarray of bool (n_samples,)
    """
    s = np.atleast_2d(np.asarray(speech_image, dtype=float))
    n = s.shape[1]
    n_frames = -(-n // frame)
    e = np.zeros(n_frames * frame)
    e[:n] = np.sum(s**2, axis=0)
    fe = e.reshape(n_frames, frame).sum(axis=1)
    if not np.any(fe > 0):
        return np.zeros(n, dtype=bool)
    active = fe >= fe.max() * 10 ** (-threshold_db / 10)
    return np.repeat(active, frame)[:n]


def mix_at_snr(
    speech_image: np.ndarray,
    noise: np.ndarray,
    snr_db: float,
    active: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Add noise scaled to a given signal-to-noise ratio.

    ``SNR = 10 log10( sum_m mean_{n in A} s_m[n]^2 / sum_m mean_{n in A} v_m[n]^2 )``: speech
    and noise power summed over the channels and averaged over the speech-active samples ``A``
    (the convention of the localization literature: the SNR of the speech while it is there;
    for stationary noise the noise term equals its whole-signal power).

    Parameters
    ----------
    speech_image : ndarray (n_mics, n_samples)
        The (reverberant) speech at the microphones.
    noise : ndarray (n_mics, n_samples)
    snr_db : float
    active : ndarray of bool (n_samples,), optional
        Speech-active samples; default :func:`speech_activity` of ``speech_image``.

    Returns
    -------
    mix : ndarray (n_mics, n_samples)
        ``speech_image + noise_scaled``.
    noise_scaled : ndarray (n_mics, n_samples)
    """
    s = np.asarray(speech_image, dtype=float)
    v = np.asarray(noise, dtype=float)
    if s.ndim != 2 or s.shape[1] == 0:
        raise ValueError(f"mix_at_snr: speech_image must be (n_mics, n_samples), got {s.shape}")
    if v.shape != s.shape:
        raise ValueError(f"mix_at_snr: noise must have shape {s.shape} like speech, got {v.shape}")
    if not (np.all(np.isfinite(s)) and np.all(np.isfinite(v))):
        raise ValueError("mix_at_snr: speech_image and noise must be finite")
    snr_db = _finite_float("mix_at_snr", "snr_db", snr_db)
    if active is None:
        act = speech_activity(s)
    else:
        act = np.asarray(active)
        if act.shape != (s.shape[1],) or act.dtype != bool:
            raise ValueError(f"mix_at_snr: active must be a bool array ({s.shape[1]},)")
    if not np.any(act):
        raise ValueError("mix_at_snr: speech_image is silent (no active samples)")
    p_s = float(np.sum(np.mean(s[:, act] ** 2, axis=1)))
    p_v = float(np.sum(np.mean(v[:, act] ** 2, axis=1)))
    if p_s == 0:
        raise ValueError("mix_at_snr: speech_image is silent")
    if p_v == 0:
        raise ValueError("mix_at_snr: noise is silent over the speech-active samples")
    gain = math.sqrt(p_s / (p_v * 10 ** (snr_db / 10)))  # p_s / (g^2 p_v) = 10^(snr/10)
    noise_scaled = gain * v
    return s + noise_scaled, noise_scaled


# --------------------------------------------------------------------------- analysis


def measure_t60(rir: np.ndarray, fs: int, decay_db: float = 30.0) -> float | np.ndarray:
    """Reverberation time from Schroeder's backward-integrated energy decay curve.

    ``EDC(t) = sum_{tau >= t} h(tau)^2``; a least-squares line is fitted to ``10 log10 EDC``
    between -5 dB and ``-(5 + decay_db)`` dB and extrapolated to -60 dB
    (``decay_db = 30``: T30, 20: T20).

    Parameters
    ----------
    rir : ndarray (n_taps,) or (n_channels, n_taps)
    fs : int
    decay_db : float
        Fitted range below -5 dB, in (0, 55].

    Returns
    -------
    float, or ndarray (n_channels,) for a 2-D ``rir``
    """
    h = np.asarray(rir, dtype=float)
    if h.ndim == 2:
        return np.array([measure_t60(ch, fs, decay_db) for ch in h])
    if h.ndim != 1 or h.size < 2 or not np.all(np.isfinite(h)):
        raise ValueError(f"measure_t60: rir must be a finite 1-D or 2-D array, got {h.shape}")
    if isinstance(fs, bool) or not float(fs).is_integer() or fs <= 0:
        raise ValueError(f"measure_t60: fs must be a positive integer, got {fs!r}")
    decay_db = _finite_float("measure_t60", "decay_db", decay_db)
    if not 0 < decay_db <= 55:
        raise ValueError(f"measure_t60: decay_db must be in (0, 55], got {decay_db}")
    edc = np.cumsum(h[::-1] ** 2)[::-1]
    if edc[0] <= 0:
        raise ValueError("measure_t60: rir is all zeros")
    with np.errstate(divide="ignore"):
        edc_db = 10 * np.log10(edc / edc[0])
    lo, hi = -5.0, -5.0 - decay_db
    i0 = int(np.argmax(edc_db <= lo))
    if not np.any(edc_db <= hi):
        raise ValueError(f"measure_t60: the decay curve never reaches {hi} dB (rir too short)")
    i1 = int(np.argmax(edc_db <= hi))
    t = np.arange(i0, i1 + 1) / fs
    slope, _ = np.polyfit(t, edc_db[i0 : i1 + 1], 1)  # dB per second
    return float(-60.0 / slope)
