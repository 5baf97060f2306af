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
``S_t = (1 - alpha) S_{t-1} + alpha P_t`` with ``alpha = 0.065``; the heat map is
``max(S_t, 0)``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import scipy.signal

from avtrack.localize.base import Localizer, register_localizer
from avtrack.localize.grid import steering_phases, transfer_functions


@dataclass(frozen=True)
class SRPConfig:
    """Parameters of :class:`SRPPHAT`.

    Attributes
    ----------
    smoothing : float
        ``alpha`` of the recursive smoothing in (0, 1] (0.065 in the thesis; 1: none).
    freq_range_hz : (float, float)
        Bins with ``lo <= f <= hi`` are used (default: all but 0 Hz).
    """

    smoothing: float = 0.065
    freq_range_hz: tuple[float, float] = (1.0, 1e9)

    def __post_init__(self) -> None:
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
    default_threshold: ClassVar[float] = 0.3

    def _setup(self) -> None:
        freqs = self.stft_config.freqs_hz
        lo, hi = self.config.freq_range_hz
        self._bins = np.flatnonzero((freqs >= lo) & (freqs <= hi))
        h = transfer_functions(self.array, self.grid, freqs[self._bins], self.fs)
        self._steering = steering_phases(h)

    def _reset_state(self) -> None:
        self._state = np.zeros(self.grid.size)  # S_{t-1}

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
        return np.maximum(smoothed, 0.0), n_obs
