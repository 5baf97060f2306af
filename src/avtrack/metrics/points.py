"""How well detected image points match true ones, frame by frame.

A true point is found when a detected point lies within ``hit_px`` pixels of it; a detected
point is near the truth when a true point lies within ``near_px`` pixels of it. Their shares
are the detector's recall and precision of :attr:`PointMatches.recall` and
:attr:`PointMatches.precision` (each true or detected point counted on its own, no
one-to-one assignment).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PointMatches:
    """Counts of :func:`point_matches` over a sequence.

    Attributes
    ----------
    n_true : int
        True points.
    n_found : int
        True points with a detected point within ``hit_px``.
    n_points : int
        Detected points.
    n_near : int
        Detected points with a true point within ``near_px``.
    """

    n_true: int
    n_found: int
    n_points: int
    n_near: int

    @property
    def recall(self) -> float:
        """Share of the true points found (0 without true points)."""
        return self.n_found / max(self.n_true, 1)

    @property
    def precision(self) -> float:
        """Share of the detected points near a true point (0 without detections)."""
        return self.n_near / max(self.n_points, 1)


def point_matches(
    points: Sequence[np.ndarray],
    truths: Sequence[np.ndarray],
    hit_px: float = 20.0,
    near_px: float = 40.0,
) -> PointMatches:
    """Match the detected ``points`` (one ``(K_t, 2)`` array a frame) with the true points
    ``truths`` (one ``(P_t, 2)`` array a frame), pixels; see the module docstring."""
    if len(points) != len(truths):
        raise ValueError(
            f"point_matches: points and truths must have the same number of frames, got "
            f"{len(points)} and {len(truths)}"
        )
    found = n_true = near = n_points = 0
    for pts, truth in zip(points, truths, strict=True):
        for y in truth:
            n_true += 1
            found += bool(len(pts)) and np.min(np.linalg.norm(pts - y, axis=1)) < hit_px
        for p in pts:
            n_points += 1
            near += bool(len(truth)) and np.min(np.linalg.norm(truth - p, axis=1)) < near_px
    return PointMatches(n_true, int(found), n_points, int(near))
