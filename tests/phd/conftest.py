"""A seeded synthetic audio-visual scene shared by the SMC-PHD tests."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.phd.likelihood import AVFrame, make_frame

ARRAY_POINT = np.array([180.0, 420.0])  # where every synthetic DOA line comes from (pixels)


def line_through(points: np.ndarray) -> np.ndarray:
    """DOA-like lines ``(n_x, n_y, c)`` from :data:`ARRAY_POINT` through each point."""
    d = points - ARRAY_POINT
    n = np.column_stack([-d[:, 1], d[:, 0]]) / np.linalg.norm(d, axis=1)[:, None]
    return np.column_stack([n, np.einsum("ij,ij->i", n, points)])


def synthetic_scene(
    seed: int = 0, n_frames: int = 60, p_miss: float = 0.1, sigma: float = 2.0
) -> tuple[list[AVFrame], list[np.ndarray]]:
    """Two speakers: A walks from (80, 100) to (280, 110), B stands at (200, 200) and appears
    at frame 10. Visual points with noise ``sigma`` and misses; a DOA line (with 1 px
    noise) through each speaker; one false alarm every 10 frames.

    Returns
    -------
    frames : list of AVFrame
    truth : list of ndarray (m_t, 2)
    """
    rng = np.random.default_rng(seed)
    frames, truth = [], []
    for t in range(n_frames):
        a = np.array([80 + 200 * t / (n_frames - 1), 100 + 10 * t / (n_frames - 1)])
        gt = np.array([a, [200.0, 200.0]]) if t >= 10 else a[None]
        seen = rng.random(len(gt)) > p_miss
        vis = gt[seen] + rng.normal(scale=sigma, size=(seen.sum(), 2))
        if t % 10 == 5:
            vis = np.vstack([vis, rng.uniform([0, 0], [360, 288])])
        heard = gt
        lines = line_through(heard + rng.normal(scale=1.0, size=heard.shape))
        frames.append(make_frame(vis, np.arange(len(heard), dtype=float), lines, 10.0))
        truth.append(gt)
    return frames, truth


@pytest.fixture(scope="session")
def scene():
    return synthetic_scene(0)
