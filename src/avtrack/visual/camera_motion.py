"""Global camera motion between consecutive video frames, for camera-motion compensation.

A camera that pans, tilts or rides on a vehicle moves every person in the image by its own
motion, which a constant-velocity model does not predict. The robot head of thesis §3.2 knows
its motion from the motors and adds it to the prediction (the control term :math:`c_{tn}` of
eq. 3.34); a hand-held or vehicle camera's motion is estimated here from the frames, as
BoT-SORT's global motion compensation does (N. Aharon, R. Orfaig, B.-Z. Bobrovsky, "BoT-SORT:
Robust associations multi-pedestrian tracking", arXiv:2206.14651, 2022): corners of the
background (outside the detection boxes, which move with the people) followed by pyramidal
Lucas-Kanade optical flow from one frame to the next, and a similarity transform (rotation,
uniform scale, translation) fitted to them with RANSAC (OpenCV's ``goodFeaturesToTrack``,
``calcOpticalFlowPyrLK`` and ``estimateAffinePartial2D``; written here only to join them).

A frame whose fit is not trusted (too few corners or inliers) gets the identity: no
compensation rather than a wrong one; so does a motion that moves no corner of the frame by
``min_shift`` pixels (half a pixel: on the shared still-camera videos the fits scatter by 0.1 to
0.2 pixels, so a still camera is left as it is).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import numpy as np

__all__ = ["IDENTITY", "CameraMotion", "apply_motion", "compose_motions", "frame_motions",
           "warp_boxes"]

#: The affine map ``(2, 3)`` of a frame without camera motion.
IDENTITY = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
IDENTITY.flags.writeable = False


class CameraMotion:
    """The camera's motion from each frame to the next, one frame at a time.

    Parameters
    ----------
    downscale : int
        The frames are reduced by this factor before corners and flow are sought (>= 1; the
        transform is given in full-resolution pixels).
    max_corners : int
        Corners sought in a frame.
    min_inliers : int
        Fewer RANSAC inliers than this (or fewer corners followed): the identity.
    min_shift : float
        A fit that moves no corner of the frame by this many pixels: the identity.
    """

    def __init__(self, downscale: int = 2, max_corners: int = 600, min_inliers: int = 20,
                 min_shift: float = 0.5):
        if isinstance(downscale, bool) or not isinstance(downscale, int) or downscale < 1:
            raise ValueError(f"CameraMotion: downscale must be an integer >= 1, got {downscale!r}")
        if max_corners < 1 or min_inliers < 3:
            raise ValueError("CameraMotion: max_corners must be >= 1 and min_inliers >= 3, got "
                             f"{max_corners!r} and {min_inliers!r}")
        self.downscale = downscale
        self.max_corners = int(max_corners)
        self.min_inliers = int(min_inliers)
        if not min_shift >= 0:
            raise ValueError(f"CameraMotion: min_shift must be >= 0, got {min_shift!r}")
        self.min_shift = float(min_shift)
        self._prev: np.ndarray | None = None
        self._prev_points: np.ndarray | None = None

    def push(self, frame_bgr: np.ndarray, boxes_ltwh: np.ndarray | None = None) -> np.ndarray:
        """The affine map ``(2, 3)`` taking the previous frame's pixel coordinates to this
        frame's (:data:`IDENTITY` for the first frame or an untrusted fit).

        Parameters
        ----------
        frame_bgr : ndarray (H, W, 3) uint8
        boxes_ltwh : ndarray (M, 4), optional
            This frame's detections (left, top, width, height): no corner is taken inside.
        """
        import cv2

        frame = np.asarray(frame_bgr)
        if frame.ndim != 3 or frame.shape[2] != 3:
            raise ValueError(f"CameraMotion.push: expected an (H, W, 3) BGR frame, got shape "
                             f"{frame.shape}")
        gray = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
        s = self.downscale
        if s > 1:
            gray = cv2.resize(gray, (gray.shape[1] // s, gray.shape[0] // s),
                              interpolation=cv2.INTER_AREA)
        mask = np.full(gray.shape, 255, dtype=np.uint8)
        if boxes_ltwh is not None and len(boxes_ltwh):
            b = np.asarray(boxes_ltwh, dtype=float).reshape(-1, 4) / s
            for left, top, w, h in b:
                x0, y0 = max(int(left), 0), max(int(top), 0)
                mask[y0:max(int(top + h) + 1, y0), x0:max(int(left + w) + 1, x0)] = 0
        points = cv2.goodFeaturesToTrack(gray, self.max_corners, 0.01, 1.0 + 8.0 / s,
                                         mask=mask, blockSize=3)
        motion = IDENTITY
        prev, prev_points = self._prev, self._prev_points
        if prev is not None and prev_points is not None and len(prev_points) >= self.min_inliers \
                and prev.shape == gray.shape:
            nxt, status, _err = cv2.calcOpticalFlowPyrLK(
                prev, gray, prev_points, None)  # type: ignore[call-overload]
            ok = status.reshape(-1) == 1
            if np.count_nonzero(ok) >= self.min_inliers:
                src = prev_points.reshape(-1, 2)[ok]
                dst = nxt.reshape(-1, 2)[ok]
                fit, inliers = cv2.estimateAffinePartial2D(
                    src, dst, method=cv2.RANSAC, ransacReprojThreshold=1.0)
                if fit is not None and inliers is not None and int(inliers.sum()) >= \
                        self.min_inliers:
                    fit = np.asarray(fit, dtype=float)
                    fit[:, 2] *= s  # the translation in full-resolution pixels
                    h, w = frame.shape[:2]
                    corners = np.array([[0.0, 0.0], [w, 0.0], [0.0, h], [w, h]])
                    moved = corners @ fit[:, :2].T + fit[:, 2] - corners
                    if np.abs(moved).max() >= self.min_shift:
                        motion = fit
        self._prev, self._prev_points = gray, points
        return motion


def frame_motions(frames: Iterable[np.ndarray], boxes_per_frame: Iterable[np.ndarray | None],
                  estimator: CameraMotion | None = None) -> Iterator[np.ndarray]:
    """:meth:`CameraMotion.push` over a sequence: the map ``(2, 3)`` into each frame from the
    previous one (the identity for the first)."""
    est = CameraMotion() if estimator is None else estimator
    for frame, boxes in zip(frames, boxes_per_frame, strict=False):
        yield est.push(frame, boxes)


def apply_motion(motion: np.ndarray, mu: np.ndarray) -> np.ndarray:
    """Box states ``mu (N, d)`` (centre x, y, width, height, then the velocities of x and y
    and any more) seen through the camera motion ``(2, 3)``: centres mapped, sizes and
    velocities scaled and turned with the map's linear part (its scale is the square root of
    its determinant, a similarity's zoom). A new array."""
    a = np.asarray(motion, dtype=float)
    out = np.array(mu, dtype=float)
    lin = a[:, :2]
    out[:, :2] = mu[:, :2] @ lin.T + a[:, 2]
    zoom = float(np.sqrt(abs(np.linalg.det(lin))))
    out[:, 2:4] = mu[:, 2:4] * zoom
    if mu.shape[1] >= 6:
        out[:, 4:6] = mu[:, 4:6] @ lin.T
    return out


def compose_motions(later: np.ndarray, earlier: np.ndarray) -> np.ndarray:
    """The map ``(2, 3)`` of ``earlier`` followed by ``later``."""
    a = np.asarray(later, dtype=float)
    b = np.asarray(earlier, dtype=float)
    out = np.empty((2, 3))
    out[:, :2] = a[:, :2] @ b[:, :2]
    out[:, 2] = a[:, :2] @ b[:, 2] + a[:, 2]
    return out


def warp_boxes(motion: np.ndarray, z: np.ndarray, var: np.ndarray,
               ) -> tuple[np.ndarray, np.ndarray]:
    """Boxes ``z (M, 4)`` (centre x, y, width, height) and the diagonals of their covariances
    ``var (M, 4)`` seen through the camera motion ``(2, 3)``: :func:`apply_motion` of the boxes,
    the variances scaled by the zoom squared."""
    a = np.asarray(motion, dtype=float)
    zoom2 = float(abs(np.linalg.det(a[:, :2])))
    return apply_motion(a, z), np.asarray(var, dtype=float) * zoom2
