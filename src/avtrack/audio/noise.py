"""Noise PSD by minimum statistics, speech/noise bin classification and inter-frame spectral
subtraction (thesis §5.2.2 "Noise reduction", eq. 5.10; refs. [76, 81] of the thesis).

The cross- and auto-PSDs are recursive averages of periodograms (thesis eq. 5.10)

.. math::

    \\phi_{t,f} = \\beta \\phi_{t-1,f} + (1 - \\beta)\\, \\mathbf{x}_{t,f} x^{1*}_{t,f},

:func:`recursive_average`. The noise level at each frequency is the minimum of the reference
auto-PSD over a sliding window of about one second, times a bias compensation factor
(minimum statistics, R. Martin, *IEEE TSAP* 2001; the window is searched in sub-windows as in
that paper), :class:`MinimumStatistics`. A time-frequency bin is a *speech* bin when the
reference auto-PSD exceeds ``speech_ratio`` times the noise level and a *noise* bin when it is
below ``noise_ratio`` times it (bins in between are neither). Speech bins are cleaned by
inter-frame spectral subtraction: the PSDs of the latest noise bin at the same frequency are
subtracted, :class:`NoiseTracker`.

Shapes: a PSD frame is ``(n_freqs, ...)`` (any trailing axes: channels, lags).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np


def recursive_average(previous: np.ndarray, periodogram: np.ndarray, beta: float) -> np.ndarray:
    """One step of recursive PSD averaging (thesis eq. 5.10), returned as a new array.

    Parameters
    ----------
    previous, periodogram : ndarray, same shape
        ``phi_{t-1}`` and the instantaneous (cross-)periodogram at ``t``.
    beta : float in [0, 1)
        Smoothing factor.
    """
    return beta * previous + (1.0 - beta) * periodogram  # eq. 5.10


@dataclass(frozen=True)
class NoiseConfig:
    """Parameters of the noise estimation and speech/noise classification.

    Attributes
    ----------
    window_frames : int
        Length of the minimum-statistics search window in frames (125 = 1 s at 8 ms hop).
    n_subwindows : int
        The window is searched in ``n_subwindows`` sub-windows of
        ``window_frames // n_subwindows`` frames (Martin 2001).
    bias : float or None
        Noise PSD = ``bias`` x the minimum (compensates the minimum's downward bias). None:
        computed for the PSD smoothing factor and window (:func:`minimum_bias`), so that the
        noise PSD is the mean noise power.
    speech_ratio : float
        A bin is a speech bin when the reference auto-PSD is above ``speech_ratio`` x noise.
    noise_ratio : float
        A bin is a noise bin when the reference auto-PSD is below ``noise_ratio`` x noise;
        ``noise_ratio <= speech_ratio``.
    """

    window_frames: int = 125
    n_subwindows: int = 5
    bias: float | None = None
    speech_ratio: float = 3.0
    noise_ratio: float = 1.5

    def __post_init__(self) -> None:
        for name in ("window_frames", "n_subwindows"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | np.integer) or v < 1:
                raise ValueError(f"NoiseConfig: {name} must be a positive integer, got {v!r}")
        if self.n_subwindows > self.window_frames:
            raise ValueError(
                f"NoiseConfig: n_subwindows must be <= window_frames ({self.window_frames}), "
                f"got {self.n_subwindows}"
            )
        for name in ("bias", "speech_ratio", "noise_ratio"):
            v = getattr(self, name)
            if name == "bias" and v is None:
                continue
            if not (isinstance(v, int | float) and np.isfinite(v) and v > 0):
                raise ValueError(f"NoiseConfig: {name} must be a positive number, got {v!r}")
        if self.noise_ratio > self.speech_ratio:
            raise ValueError(
                f"NoiseConfig: noise_ratio ({self.noise_ratio}) must be <= speech_ratio "
                f"({self.speech_ratio})"
            )


@functools.lru_cache(maxsize=32)
def minimum_bias(smoothing: float, window_frames: int, n_subwindows: int) -> float:
    """Mean-to-minimum ratio of a recursively smoothed noise periodogram (Monte Carlo).

    Minimum statistics underestimates the noise power: the minimum of ``(U - 1) V + 1 .. U V``
    smoothed periodogram values lies below their mean. R. Martin (2001) approximates the
    ratio in closed form; here it is measured once, with a fixed seed, on exponentially
    distributed periodograms (a complex Gaussian noise STFT coefficient's ``|x|^2``) smoothed
    with ``smoothing`` and searched as :class:`MinimumStatistics` does.
    """
    rng = np.random.default_rng(0)
    n_bins, n_frames = 256, 3 * window_frames + 200
    cfg = NoiseConfig(window_frames=window_frames, n_subwindows=n_subwindows, bias=1.0)
    ms = MinimumStatistics(n_bins, cfg)
    psd = np.ones(n_bins)
    mins = []
    for t, draw in enumerate(rng.exponential(size=(n_frames, n_bins))):
        psd = recursive_average(psd, draw, smoothing)
        m = ms.update(psd)
        if t >= window_frames + 100:
            mins.append(m.mean())
    return float(1.0 / np.mean(mins))


class MinimumStatistics:
    """Streaming noise PSD: ``bias`` x the minimum of the smoothed PSD over a sliding window.

    The window of ``U V`` frames is covered by ``U`` sub-windows of ``V`` frames; the minimum of
    each completed sub-window is kept, so the search spans the last ``(U - 1) V + 1`` to
    ``U V`` frames (Martin 2001). Before the first sub-window completes, the minimum so far is
    used.

    Parameters
    ----------
    n_freqs : int
        Number of frequency bins.
    config : NoiseConfig, optional
    smoothing : float
        Smoothing factor of the PSDs fed to :meth:`update`; sets the bias when
        ``config.bias`` is None.
    """

    def __init__(
        self, n_freqs: int, config: NoiseConfig | None = None, smoothing: float = 0.7
    ) -> None:
        if isinstance(n_freqs, bool) or not isinstance(n_freqs, int) or n_freqs < 1:
            raise ValueError(
                f"MinimumStatistics: n_freqs must be a positive integer, got {n_freqs!r}"
            )
        self.n_freqs = n_freqs
        self.config = NoiseConfig() if config is None else config
        self._sub_len = max(1, self.config.window_frames // self.config.n_subwindows)
        if not (isinstance(smoothing, int | float) and 0.0 <= smoothing < 1.0):
            raise ValueError(f"MinimumStatistics: smoothing must be in [0, 1), got {smoothing!r}")
        self.bias = (
            minimum_bias(float(smoothing), self.config.window_frames, self.config.n_subwindows)
            if self.config.bias is None
            else float(self.config.bias)
        )
        self.reset()

    def reset(self) -> None:
        """Forget the history."""
        u = self.config.n_subwindows
        self._stored = np.full((u, self.n_freqs), np.inf)  # minima of completed sub-windows
        self._stored_min = np.full(self.n_freqs, np.inf)
        self._current = np.full(self.n_freqs, np.inf)  # minimum of the running sub-window
        self._count = 0
        self._slot = 0

    def update(self, psd: np.ndarray) -> np.ndarray:
        """Add one smoothed PSD frame ``(n_freqs,)``; return the noise PSD ``(n_freqs,)``."""
        np.minimum(self._current, psd, out=self._current)
        noise = self.bias * np.minimum(self._stored_min, self._current)
        self._count += 1
        if self._count == self._sub_len:  # sub-window complete: store its minimum
            self._stored[self._slot] = self._current
            self._stored_min = self._stored.min(axis=0)
            self._slot = (self._slot + 1) % self.config.n_subwindows
            self._current = np.full(self.n_freqs, np.inf)
            self._count = 0
        return noise


class NoiseTracker:
    """Speech/noise classification and inter-frame spectral subtraction, frame by frame.

    For each frame: the reference auto-PSD is compared with the minimum-statistics noise level
    (speech bins, noise bins); the PSD frame of each noise bin is stored; speech bins get the
    stored PSD of the latest noise bin at their frequency subtracted (zero before the first
    one) -- the noise-free PSDs :math:`\\hat\\phi_{t,f}` of thesis §5.2.2.

    Parameters
    ----------
    n_freqs : int
    psd_shape : tuple of int
        Trailing shape of a PSD frame (e.g. ``(n_channels, ctf_length)``); a frame is
        ``(n_freqs, *psd_shape)``.
    config : NoiseConfig, optional
    smoothing : float
        Smoothing factor of the PSDs (eq. 5.10's ``beta``), for the minimum's bias.
    """

    def __init__(
        self,
        n_freqs: int,
        psd_shape: tuple[int, ...] = (),
        config: NoiseConfig | None = None,
        smoothing: float = 0.7,
    ) -> None:
        self.config = NoiseConfig() if config is None else config
        self.minstat = MinimumStatistics(n_freqs, self.config, smoothing)
        self.psd_shape = tuple(int(s) for s in psd_shape)
        self.reset()

    def reset(self) -> None:
        """Forget the noise history."""
        self.minstat.reset()
        self._noise_psd = np.zeros((self.minstat.n_freqs, *self.psd_shape), dtype=complex)

    def update(
        self, ref_psd: np.ndarray, psd: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Classify one frame and subtract the noise PSDs.

        Parameters
        ----------
        ref_psd : ndarray (n_freqs,), real
            Smoothed auto-PSD of the reference channel (the first entry of ``phi^1``).
        psd : ndarray (n_freqs, *psd_shape), complex
            Smoothed cross-/auto-PSDs of this frame (eq. 5.10).

        Returns
        -------
        speech : ndarray (n_freqs,) bool
        noise : ndarray (n_freqs,) bool
        cleaned : ndarray (n_freqs, *psd_shape) complex
            ``psd`` minus the latest noise-bin PSD, at every frequency (meaningful at speech
            bins).
        """
        level = self.minstat.update(ref_psd)
        speech = ref_psd > self.config.speech_ratio * level
        noise = ref_psd < self.config.noise_ratio * level
        if np.any(noise):
            self._noise_psd[noise] = psd[noise]
        return speech, noise, psd - self._noise_psd
