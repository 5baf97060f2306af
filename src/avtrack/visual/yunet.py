"""A learned face detector for meetings and robots: YuNet (libfacedetection).

Wu, Peng and Yu, "YuNet: A tiny millisecond-level face detector", Machine Intelligence
Research 2023; the network and its weights are compiled into the ``yuface`` package's
``libfacedetection`` (PyPI, no other dependency). It finds frontal and profile faces from
about 10 pixels up, with five landmarks (eyes, nose tip, mouth corners).

Small faces (a 15-20 pixel face in a 360 × 288 meeting-room frame) are found more often at a
slightly larger scale: ``upscale`` resizes the frame first (1.25 keeps AV16.3's 360 × 288
frames above 25 frames/s on one core). A face turned away from the camera is not found: for
the back of a head, the tracker's dynamics carry the person (or use a head detector that
works on motion, :class:`avtrack.visual.heads.ForegroundHeadDetector`).
"""

from __future__ import annotations

import numpy as np

from avtrack.errors import InputError


class YuNetFaceDetector:
    """Face boxes from YuNet (see the module docstring); score = YuNet's confidence (0-1).

    The mouth (the midpoint of YuNet's two mouth-corner landmarks) lies ``mouth_offset`` =
    0.78 of the box's height below its top (median over AV16.3 sequence 30, camera 1; 10-90 %:
    0.74-0.84), which :func:`avtrack.av.av163.track_av163` reads to place the mouth.

    Parameters
    ----------
    min_score : float
        Faces with a lower confidence are dropped (YuNet's own threshold).
    upscale : float
        The frame is resized by this factor before detection (>= 1).
    """

    def __init__(self, min_score: float = 0.35, upscale: float = 1.25):
        try:
            import yuface
        except ImportError:
            import sys

            raise InputError("this detector needs the package yuface: pip install "
                             "'avtrack[detectors]'" + ("" if sys.version_info < (3, 12) else
                             " (yuface has wheels for Python 3.11 only)")) from None
        if not 0.0 <= min_score < 1.0:
            raise ValueError(f"min_score must be in [0, 1), got {min_score}")
        if not (np.isfinite(upscale) and upscale >= 1.0):
            raise ValueError(f"upscale must be >= 1, got {upscale}")
        self._detect = yuface.detect
        self.mouth_offset = 0.78
        self.min_score = float(min_score)
        self.upscale = float(upscale)

    def detect(self, frame: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        import cv2

        from avtrack.visual.frames import check_frame

        img = check_frame(frame)
        if self.upscale > 1.0:
            img = cv2.resize(img, None, fx=self.upscale, fy=self.upscale,
                             interpolation=cv2.INTER_LINEAR)
        conf, boxes, _ = self._detect(np.ascontiguousarray(img), conf=self.min_score)
        boxes = np.asarray(boxes, dtype=float).reshape(-1, 4) / self.upscale
        scores = np.asarray(conf, dtype=float).reshape(-1) / 100.0  # percent -> 0-1
        return boxes, scores
