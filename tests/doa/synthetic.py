"""Shared synthetic DOA scenes of the tracker tests: heat maps of sources on a 5° grid and
their ground truth."""

from __future__ import annotations

import numpy as np

from avtrack.doa.base import FRAME_PERIOD_S
from avtrack.io.doa import DOATable, wrap_azimuth
from avtrack.metrics.doa_tracking import evaluate_tracks
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


def moving(start: float, speed_deg_s: float, n: int = 250) -> np.ndarray:
    """``(n,)`` azimuths of a source moving at ``speed_deg_s`` from ``start`` degrees."""
    return wrap_azimuth(start + speed_deg_s * np.arange(n) * FRAME_PERIOD_S)


def assert_one_track_across_180(tracks: DOATable, truth: DOATable) -> None:
    """The tracks of one source crossing +180 -> -180 stay in (-180, 180], follow it (MAE
    < 3 degrees, under 15 % missed) and keep one identity."""
    assert np.all(tracks.azimuth_deg > -180.0) and np.all(tracks.azimuth_deg <= 180.0)
    s = evaluate_tracks(tracks, truth)
    assert s.mae < 3.0 and s.md_rate < 0.15
    assert len(np.unique(tracks.ids[tracks.active])) == 1
