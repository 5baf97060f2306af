"""SRP-PHAT: steered response power with the phase transform (thesis §5.5.1 baseline [37]).

For each STFT frame, the PHAT-weighted cross-spectra of all microphone pairs are steered to
every candidate direction and summed over pairs and frequencies:

.. math::

    P_t(\\theta_d) = \\frac{1}{|\\mathcal P| |\\mathcal F|} \\sum_{f \\in \\mathcal F}
        \\sum_{(i, j) \\in \\mathcal P} \\mathrm{Re}\\left(
        \\frac{x^i_{t,f} x^{j*}_{t,f}}{|x^i_{t,f}| |x^j_{t,f}|}\\, a^{i*}_f(\\theta_d)
        a^j_f(\\theta_d)\\right) \\in [-1, 1],

with the PHAT steering vectors ``a = h / |h|`` of :func:`avtrack.localize.grid.steering_phases`
(pure delays for free-field arrays, measured HRTF phases for ``"hrtf"`` arrays). This is
pyroomacoustics' ``SRP`` cost without its constant offset and factor 2 (checked in the tests).
As in the thesis, the frame-wise map is recursively smoothed,
``S_t = (1 - alpha) S_{t-1} + alpha P_t`` with ``alpha = 0.065``.

The heat map is ``S_t`` measured against what the recording itself gives, so that one
threshold carries over between arrays and rooms: how high ``S_t`` rises depends on the
array's aperture (a small array's beams are wide, the whole map lifts with every source) and on
the room, while its contrast against the noise does not. The heat map is the contrast of each
candidate above the frame's median, in units of the recording's noise contrast:

.. math::

    H_t(\\theta_d) = \\frac{\\max(S_t(\\theta_d) - \\mathrm{med}_{d'} S_t(\\theta_{d'}), 0)}
        {\\max(\\min_{t - W < u \\le t} c_u,\\ \\epsilon \\max_{u \\le t} c_u)},
    \\qquad c_u = \\max_d S_u(\\theta_d) - \\mathrm{med}_d S_u(\\theta_d),

the denominator a minimum-statistics noise floor (R. Martin, "Noise power spectral density
estimation based on optimal smoothing and minimum statistics", IEEE TSAP 9(5), 2001) of the
frame's contrast over the last ``W`` seconds, kept above a fraction ``epsilon`` of the largest
contrast heard so far (a recording without noise has no floor to measure). A peak of 3 stands
three times above the noise's own peaks; the default threshold is 2.5. ``relative=False``
gives the thesis's map, ``max(S_t, 0)``.
"""

from __future__ import annotations

import collections
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import scipy.signal

from avtrack.localize.base import Localizer, register_localizer
from avtrack.localize.grid import steering_phases, transfer_functions

_TINY = 1e-12


@dataclass(frozen=True)
class SRPConfig:
    """Parameters of :class:`SRPPHAT`.

    Attributes
    ----------
    smoothing : float
        ``alpha`` of the recursive smoothing in (0, 1] (0.065 in the thesis; 1: none).
    freq_range_hz : (float, float)
        Bins with ``lo <= f <= hi`` are used (default: all but 0 Hz).
    relative : bool
        The heat map in units of the recording's noise contrast (module docstring; default);
        False: ``max(S_t, 0)`` as in the thesis.
    floor_window_s : float
        ``W``, the span of the minimum statistics, seconds (long enough to hold a pause).
    floor_fraction : float
        ``epsilon``: the floor is at least this fraction of the largest contrast so far.
    """

    smoothing: float = 0.065
    freq_range_hz: tuple[float, float] = (1.0, 1e9)
    relative: bool = True
    floor_window_s: float = 3.0
    floor_fraction: float = 0.05

    def __post_init__(self) -> None:
        if not isinstance(self.relative, bool):
            raise ValueError(f"SRPConfig: relative must be true or false, got {self.relative!r}")
        w = self.floor_window_s
        if isinstance(w, bool) or not (isinstance(w, int | float) and np.isfinite(w) and w > 0):
            raise ValueError(f"SRPConfig: floor_window_s must be a number > 0, got {w!r}")
        e = self.floor_fraction
        if isinstance(e, bool) or not (isinstance(e, int | float) and 0 < e <= 1):
            raise ValueError(f"SRPConfig: floor_fraction must be in (0, 1], got {e!r}")
        a = self.smoothing
        if not (isinstance(a, int | float) and not isinstance(a, bool) and 0 < a <= 1):
            raise ValueError(f"SRPConfig: smoothing must be in (0, 1], got {a!r}")
        fr = tuple(self.freq_range_hz)
        if len(fr) != 2 or not fr[0] <= fr[1]:
            raise ValueError(f"SRPConfig: freq_range_hz must be (lo, hi), lo <= hi, got {fr!r}")
        object.__setattr__(self, "freq_range_hz", (float(fr[0]), float(fr[1])))


def srp_phat(spec: np.ndarray, steering: np.ndarray) -> np.ndarray:
    """Frame-wise SRP-PHAT maps.

    Parameters
    ----------
    spec : ndarray (n_mics, n_freqs, n_frames), complex
    steering : ndarray (n_mics, n_freqs, D), complex
        PHAT steering vectors of the same bins.

    Returns
    -------
    ndarray (n_frames, D)
        ``P_t(theta_d)`` of the module docstring, in [-1, 1].
    """
    m_, f_, t_ = spec.shape
    mag = np.abs(spec)
    px = np.divide(spec, mag, out=np.zeros_like(spec), where=mag > 0)  # PHAT weighting
    i, j = np.triu_indices(m_, k=1)
    cross = (px[i] * px[j].conj()).reshape(i.size * f_, t_)  # (P F, T)
    steer = (steering[i].conj() * steering[j]).reshape(i.size * f_, -1)  # (P F, D)
    # Re(c s) = Re c Re s - Im c Im s, as two real matrix products
    power = cross.real.T @ steer.real - cross.imag.T @ steer.imag
    return power / (i.size * f_)


@register_localizer("srp-phat")
class SRPPHAT(Localizer):
    """SRP-PHAT with recursive smoothing over frames (see the module docstring)."""

    Config: ClassVar[type] = SRPConfig
    default_threshold: ClassVar[float] = 2.5
    profile_reduce: ClassVar[str] = "max"

    def _setup(self) -> None:
        freqs = self.stft_config.freqs_hz
        lo, hi = self.config.freq_range_hz
        self._bins = np.flatnonzero((freqs >= lo) & (freqs <= hi))
        h = transfer_functions(self.array, self.grid, freqs[self._bins], self.fs)
        self._steering = steering_phases(h)

    def _reset_state(self) -> None:
        self._state = np.zeros(self.grid.size)  # S_{t-1}
        self._contrasts: collections.deque[tuple[int, float]] = collections.deque()
        self._frame = 0  # frames seen
        self._loudest = 0.0  # max_u c_u

    def _relative(self, smoothed: np.ndarray) -> np.ndarray:
        """``H_t`` of the module docstring for consecutive frames ``(T, D)``."""
        excess = smoothed - np.median(smoothed, axis=1, keepdims=True)
        contrast = excess.max(axis=1)  # c_t
        window = max(1, round(self.config.floor_window_s / self.stft_config.frame_period_s))
        floors = np.empty(contrast.size)
        q = self._contrasts  # (frame, c) with increasing c: the sliding minimum
        # S_t starts from 0: its first 1/alpha frames are a ramp, not the noise's contrast
        warmup = math.ceil(1.0 / self.config.smoothing)
        for t, c in enumerate(contrast):
            n = self._frame + t
            if n < warmup:
                q.clear()  # the ramp's latest value stands in until it ends
            while q and q[-1][1] >= c:
                q.pop()
            q.append((n, float(c)))
            while len(q) > 1 and q[0][0] <= n - window:
                q.popleft()
            self._loudest = max(self._loudest, float(c))
            floors[t] = max(q[0][1], self.config.floor_fraction * self._loudest, _TINY)
        self._frame += contrast.size
        return np.maximum(excess, 0.0) / floors[:, None]

    def _process_stft(self, spec: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        t_ = spec.shape[2]
        n_obs = np.full(t_, self._bins.size, dtype=np.int64)
        if self._bins.size == 0:
            return np.zeros((t_, self.grid.size)), n_obs
        power = srp_phat(spec[:, self._bins, :], self._steering)
        a = self.config.smoothing
        # S_t = (1 - alpha) S_{t-1} + alpha P_t, all frames at once
        smoothed, _ = scipy.signal.lfilter(
            [a], [1.0, a - 1.0], power, axis=0, zi=((1.0 - a) * self._state)[None, :]
        )
        self._state = smoothed[-1].copy()
        if self.config.relative:
            return self._relative(smoothed), n_obs
        return np.maximum(smoothed, 0.0), n_obs
