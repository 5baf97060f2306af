"""Imperfect microphones: gain and delay mismatch between channels, and sensor self-noise.

The renderer (:mod:`avtrack.simulate.acoustics`) gives every microphone the same ideal
response. Real arrays differ from microphone to microphone and add their own noise; the model
here, applied to the rendered microphone signals ``x_m[n]`` (speech and acoustic noise), is

.. math::

    y_m[n] = 10^{g_m / 20} \\, x_m[n - \\delta_m] + \\sigma \\, w_m[n]

- ``g_m ~ N(0, s_g^2)`` dB: a per-microphone gain mismatch, drawn once per scene
  (``s_g`` = :attr:`SensorModel.gain_mismatch_db`);
- ``delta_m ~ N(0, s_d^2)`` samples: a per-microphone delay (a sub-sample phase mismatch,
  ``-2 pi f delta_m / fs`` rad at ``f``), drawn once per scene
  (``s_d`` = :attr:`SensorModel.delay_mismatch_samples`), applied as a band-limited
  fractional delay in the frequency domain;
- ``w_m[n]`` white Gaussian noise, independent across microphones (spatially white: its
  coherence between any two microphones is 0), scaled so that the speech-to-self-noise ratio
  is :attr:`SensorModel.self_noise_snr_db` with the convention of
  :func:`~avtrack.simulate.acoustics.mix_at_snr` (power summed over the microphones, averaged
  over the speech-active samples).

The common gain and delay of the array are irrelevant to localization; only their differences
between microphones matter (the inter-microphone level and phase differences of the DP-RTF,
thesis eq. 4.5). Measured on six ReSpeaker 4-mic recordings (``benchmarks/bench_sim_vs_real.py``)
the noise of the quiet frames is white and incoherent between the microphones (MSC 0.02, the
estimator's floor), which is what the self-noise term reproduces.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SensorModel:
    """The imperfections of the microphones of one scene.

    Attributes
    ----------
    gain_mismatch_db : float
        Standard deviation ``s_g`` of the per-microphone gain, dB (>= 0; 0 = matched gains).
    delay_mismatch_samples : float
        Standard deviation ``s_d`` of the per-microphone delay, samples (>= 0; 0 = none).
    self_noise_snr_db : float or None
        Speech-to-self-noise ratio, dB; None = no self-noise.
    """

    gain_mismatch_db: float = 0.0
    delay_mismatch_samples: float = 0.0
    self_noise_snr_db: float | None = None

    def __post_init__(self) -> None:
        for name in ("gain_mismatch_db", "delay_mismatch_samples"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ValueError(f"SensorModel: {name} must be a finite number, got {v!r}")
            if v < 0:
                raise ValueError(f"SensorModel: {name} must be >= 0, got {v!r}")
            object.__setattr__(self, name, float(v))
        snr = self.self_noise_snr_db
        if snr is not None:
            if isinstance(snr, bool) or not isinstance(snr, (int, float)) or not math.isfinite(
                snr
            ):
                raise ValueError(
                    f"SensorModel: self_noise_snr_db must be a finite number or None, got {snr!r}"
                )
            object.__setattr__(self, "self_noise_snr_db", float(snr))

    @property
    def is_ideal(self) -> bool:
        """True when the model changes nothing."""
        return (
            self.gain_mismatch_db == 0
            and self.delay_mismatch_samples == 0
            and self.self_noise_snr_db is None
        )

    def draw(self, n_mics: int, rng: np.random.Generator) -> SensorDraw:
        """The per-microphone gains and delays of one scene.

        Both are always drawn (``2 * n_mics`` normal deviates, gains first), so that changing
        one standard deviation leaves the other draw unchanged.
        """
        if isinstance(n_mics, bool) or not isinstance(n_mics, int) or n_mics < 1:
            raise ValueError(f"SensorModel.draw: n_mics must be an integer >= 1, got {n_mics!r}")
        z = rng.standard_normal((2, n_mics))
        return SensorDraw(self.gain_mismatch_db * z[0], self.delay_mismatch_samples * z[1])


@dataclass(frozen=True, eq=False)
class SensorDraw:
    """The drawn mismatch of one scene.

    Attributes
    ----------
    gains_db : ndarray (n_mics,)
        ``g_m``, dB.
    delays_samples : ndarray (n_mics,)
        ``delta_m``, samples (positive: the microphone hears later).
    """

    gains_db: np.ndarray
    delays_samples: np.ndarray

    def __post_init__(self) -> None:
        g = np.array(self.gains_db, dtype=float).reshape(-1)
        d = np.array(self.delays_samples, dtype=float).reshape(-1)
        if g.shape != d.shape or g.size == 0:
            raise ValueError(
                f"SensorDraw: gains_db and delays_samples must have the same length >= 1, got "
                f"{g.shape} and {d.shape}"
            )
        if not (np.all(np.isfinite(g)) and np.all(np.isfinite(d))):
            raise ValueError("SensorDraw: gains_db and delays_samples must be finite")
        for a in (g, d):
            a.setflags(write=False)
        object.__setattr__(self, "gains_db", g)
        object.__setattr__(self, "delays_samples", d)


def apply_mismatch(x: np.ndarray, draw: SensorDraw) -> np.ndarray:
    """``10^(g_m / 20) x_m[n - delta_m]`` for every microphone.

    The delay is band-limited: ``Y_m(f) = X_m(f) e^{-j 2 pi f delta_m / fs}`` on an FFT of the
    signal zero-padded by more than the largest delay (no wrap-around of the signal's ends).

    Parameters
    ----------
    x : ndarray (n_mics, n_samples)
    draw : SensorDraw
        With ``n_mics`` entries.

    Returns
    -------
    ndarray (n_mics, n_samples)
    """
    x = np.asarray(x, dtype=float)
    if x.ndim != 2 or x.shape[0] != draw.gains_db.size:
        raise ValueError(
            f"apply_mismatch: x must be ({draw.gains_db.size}, n_samples), got {x.shape}"
        )
    gain = 10 ** (draw.gains_db / 20)  # g_m dB -> amplitude
    out = x * gain[:, None]
    if np.any(draw.delays_samples != 0):
        n = x.shape[1]
        pad = 2 * math.ceil(float(np.max(np.abs(draw.delays_samples)))) + 64
        n_fft = n + pad
        spec = np.fft.rfft(out, n_fft, axis=1)
        k = np.arange(spec.shape[1])
        # Y_m(k) = X_m(k) exp(-j 2 pi k delta_m / N)
        spec *= np.exp(-2j * np.pi * k[None, :] * draw.delays_samples[:, None] / n_fft)
        out = np.fft.irfft(spec, n_fft, axis=1)[:, :n]
    return out


def white_noise(n_mics: int, n_samples: int, rng: np.random.Generator) -> np.ndarray:
    """``w (n_mics, n_samples)``: independent unit-variance white Gaussian noise per
    microphone."""
    return rng.standard_normal((n_mics, n_samples))
