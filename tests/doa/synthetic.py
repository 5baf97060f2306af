"""Shared synthetic DOA scenes of the tracker tests: heat maps of sources on a 5° grid and
their ground truth."""

from __future__ import annotations

import numpy as np

from avtrack.doa.base import FRAME_PERIOD_S
from avtrack.io.doa import DOATable, wrap_azimuth
from avtrack.simulate.heatmaps import synthetic_heatmaps

GRID = -180.0 + 5.0 * np.arange(1, 73)  # thesis §5.5.1: 72 azimuths every 5°


def heatmaps_and_truth(
    az: np.ndarray, on: np.ndarray, seed: int = 0, **kw
) -> tuple[np.ndarray, np.ndarray, DOATable]:
    """Heat maps ``(T, len(GRID))`` of sources ``az (T, K)`` (active where ``on``), their frame
    times (32 ms frames) and the matching ground truth."""
    rng = np.random.default_rng(seed)
    t_, k = az.shape
    w = synthetic_heatmaps(az, on, GRID, rng, **kw)
    t = np.arange(t_) * FRAME_PERIOD_S
    truth = DOATable(
        np.repeat(np.arange(t_), k),
        np.repeat(t, k),
        np.tile(np.arange(1, k + 1), t_),
        wrap_azimuth(az.ravel()),
        np.zeros(az.size),
        np.ones(az.size),
        on.ravel(),
    )
    return w, t, truth
