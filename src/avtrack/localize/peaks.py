"""Peak selection on heat maps: frame-wise localization and counting (thesis §5.3.3).

A candidate is a peak when its value is a local maximum of the heat map -- at least as large
as its neighbours along azimuth (wrapping around on a circular grid) and along elevation, and
strictly larger than the neighbours that come before it, so that a plateau gives one peak and
a flat (uniform) map gives none -- and is at least the threshold. Frame-wise localization
keeps the peaks above a threshold [78, 81]. On a grid of several elevations, peaks are taken
on the map over azimuth (:func:`~avtrack.localize.grid.azimuth_profile`: the trackers follow
azimuth, and a thresholded mass keeps its meaning whatever the number of elevation rows), each
reported at the elevation where its azimuth's value is largest. Sweeping that threshold gives
the ROC curve of thesis Fig. 5.3 (:func:`avtrack.metrics.doa.roc_sweep`).
"""

from __future__ import annotations

import numpy as np

from avtrack.io.doa import DOATable
from avtrack.localize.base import HeatMaps
from avtrack.localize.grid import DirectionGrid, azimuth_profile


def local_maxima(weights: np.ndarray, grid: DirectionGrid) -> np.ndarray:
    """Mask of the local maxima of heat maps.

    Parameters
    ----------
    weights : ndarray (n_frames, D) or (D,)
    grid : DirectionGrid

    Returns
    -------
    ndarray of bool, the shape of ``weights``
    """
    w = np.asarray(weights, dtype=float)
    squeeze = w.ndim == 1
    if squeeze:
        w = w[None]
    if w.ndim != 2 or w.shape[1] != grid.size:
        raise ValueError(
            f"local_maxima: weights must have shape (n_frames, {grid.size}), got {w.shape}"
        )
    g = w.reshape(w.shape[0], grid.n_elevations, grid.n_azimuths)
    peak = np.ones(g.shape, dtype=bool)
    if grid.n_azimuths > 1:
        if grid.circular:
            prev, nxt = np.roll(g, 1, axis=2), np.roll(g, -1, axis=2)
            peak &= (g > prev) & (g >= nxt)
        else:
            peak[:, :, 1:] &= g[:, :, 1:] > g[:, :, :-1]
            peak[:, :, :-1] &= g[:, :, :-1] >= g[:, :, 1:]
    if grid.n_elevations > 1:
        peak[:, 1:, :] &= g[:, 1:, :] > g[:, :-1, :]
        peak[:, :-1, :] &= g[:, :-1, :] >= g[:, 1:, :]
    out = peak.reshape(w.shape)
    return out[0] if squeeze else out


def find_peaks(
    heatmaps: HeatMaps, grid: DirectionGrid, threshold: float = 0.0, max_peaks: int | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Peaks of every frame with value ``>= threshold``, strongest first within a frame.

    Returns
    -------
    rows : ndarray (K,) int
        Index of the frame in ``heatmaps`` (not the STFT frame number).
    candidates : ndarray (K,) int
        Candidate index in ``grid``.
    values : ndarray (K,) float
    """
    if max_peaks is not None and (not isinstance(max_peaks, int) or max_peaks < 1):
        raise ValueError(f"find_peaks: max_peaks must be a positive integer, got {max_peaks!r}")
    w = heatmaps.weights
    mask = local_maxima(w, grid) & (w >= threshold)
    rows, cand = np.nonzero(mask)
    vals = w[rows, cand]
    order = np.lexsort((-vals, rows))
    rows, cand, vals = rows[order], cand[order], vals[order]
    if max_peaks is not None and rows.size:
        start = np.r_[0, np.flatnonzero(np.diff(rows)) + 1]
        rank = np.arange(rows.size) - np.repeat(start, np.diff(np.r_[start, rows.size]))
        keep = rank < max_peaks
        rows, cand, vals = rows[keep], cand[keep], vals[keep]
    return rows, cand, vals


def peak_table(
    heatmaps: HeatMaps,
    grid: DirectionGrid,
    threshold: float,
    floor: float | None = None,
    max_peaks: int | None = None,
    reduce: str = "sum",
) -> DOATable:
    """Frame-wise DOA estimates as a :class:`~avtrack.io.doa.DOATable` (``id = -1``).

    Peaks at or above ``floor`` (default: ``threshold``) are listed; ``active`` says whether
    they reach ``threshold``. A low ``floor`` keeps the weaker peaks for a later threshold
    sweep (:func:`avtrack.metrics.doa.roc_sweep`). On a grid of several elevations the peaks
    are those of the azimuth profile (``reduce``: the localizer's
    :attr:`~avtrack.localize.base.Localizer.profile_reduce`).
    """
    floor = threshold if floor is None else floor
    if grid.n_elevations > 1:
        profile, elevation = azimuth_profile(heatmaps.weights, grid, reduce)
        heatmaps = HeatMaps(heatmaps.frames, heatmaps.time_s, profile, heatmaps.n_observations)
        flat = DirectionGrid(grid.azimuth_values, np.zeros(1))
        rows, cand, vals = find_peaks(heatmaps, flat, min(floor, threshold), max_peaks)
        elevations = elevation[rows, cand]
        azimuths = flat.azimuth_deg[cand]
    else:
        rows, cand, vals = find_peaks(heatmaps, grid, min(floor, threshold), max_peaks)
        azimuths, elevations = grid.azimuth_deg[cand], grid.elevation_deg[cand]
    return DOATable(
        heatmaps.frames[rows],
        heatmaps.time_s[rows],
        np.full(rows.size, -1),
        azimuths,
        elevations,
        vals,
        vals >= threshold,
    )
