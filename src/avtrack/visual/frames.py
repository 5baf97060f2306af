"""Checks shared by the frame-based detectors (:mod:`avtrack.visual.detect` and the learned
detectors it registers)."""

from __future__ import annotations

import numpy as np


def check_frame(frame: np.ndarray) -> np.ndarray:
    """``frame`` as an ``(height, width, 3)`` uint8 array; ValueError otherwise."""
    img = np.asarray(frame)
    if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
        raise ValueError(f"frame must be (height, width, 3) uint8 BGR, got {img.shape} "
                         f"{img.dtype}")
    return img
