"""Synthetic localizer heat maps of moving sources, for the DOA trackers' tests and benchmarks.

The heat maps look like those of the DP-RTF + EG localizer (:mod:`avtrack.localize.cgmm_eg`):
a von Mises bump per active source over the candidate azimuths, occasional spurious bumps and
a near-uniform floor, each frame summing to one.
"""

from __future__ import annotations

import numpy as np


def synthetic_heatmaps(
    azimuth_deg: np.ndarray,
    active: np.ndarray,
    grid_deg: np.ndarray,
    rng: np.random.Generator,
    width_deg: float = 6.0,
    peak_mass: float = 0.6,
    jitter_deg: float = 2.0,
    spurious_rate: float = 0.05,
    background: float = 0.1,
) -> np.ndarray:
    """EG-like heat maps of moving sources for tests and benchmarks.

    Each active source adds a von Mises bump of total mass ``peak_mass × U(0.5, 1.5)`` centred
    at its azimuth plus Gaussian jitter; with probability ``spurious_rate`` per frame a
    spurious bump appears at a random direction; a uniform ``background`` mass is spread over
    all candidates; each frame is normalised to sum to one.

    Parameters
    ----------
    azimuth_deg : ndarray (T, K)
        Source azimuths, degrees.
    active : ndarray (T, K) bool
        Whether each source emits at each frame.
    grid_deg : ndarray (D,)
        Candidate azimuths, degrees.
    rng : numpy.random.Generator

    Returns
    -------
    ndarray (T, D)
    """
    az = np.asarray(azimuth_deg, dtype=float)
    on = np.asarray(active, dtype=bool)
    grid = np.deg2rad(np.asarray(grid_deg, dtype=float).reshape(-1))
    if az.ndim != 2 or on.shape != az.shape:
        raise ValueError(
            f"azimuth_deg and active must be (T, K) of one shape, got {az.shape} and {on.shape}"
        )
    t_, k = az.shape
    kappa = 1.0 / np.deg2rad(width_deg) ** 2
    centre = np.deg2rad(az + jitter_deg * rng.standard_normal((t_, k)))
    amp = peak_mass * rng.uniform(0.5, 1.5, (t_, k)) * on
    bumps = np.exp(kappa * (np.cos(grid[None, None, :] - centre[:, :, None]) - 1.0))
    bumps /= bumps.sum(axis=2, keepdims=True)
    w = (amp[:, :, None] * bumps).sum(axis=1)
    spur = np.asarray(rng.random(t_) < spurious_rate)
    if spur.any():
        c = rng.uniform(-np.pi, np.pi, int(spur.sum()))
        b = np.exp(kappa * (np.cos(grid[None, :] - c[:, None]) - 1.0))
        w[spur] += peak_mass * 0.5 * b / b.sum(axis=1, keepdims=True)
    w += background / grid.size
    return w / w.sum(axis=1, keepdims=True)
