r"""Colour histograms of detection boxes from video frames: the :math:`h_{tm}` of thesis eq. 3.5.

The thesis's visual observations carry a colour histogram per box, compared with the
Bhattacharyya likelihood (:class:`~avtrack.visual.appearance.BhattacharyyaAppearance`). Here a
box's descriptor is the joint hue-saturation histogram of its pixels in HSV
(``bins = (n_hue, n_saturation)``), normalised to sum to one; the value (brightness) channel is
left out so that shadows and lighting change it less. OpenCV computes the histograms.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from avtrack.io.mot import MOTData

#: Hue x saturation bins of a box histogram.
DEFAULT_BINS = (8, 8)


def box_histograms(
    frame_bgr: np.ndarray, boxes: np.ndarray, bins: tuple[int, int] = DEFAULT_BINS
) -> np.ndarray:
    """Normalised hue-saturation histograms of boxes in one frame.

    Parameters
    ----------
    frame_bgr : ndarray (height, width, 3) uint8
    boxes : ndarray (M, 4)
        (left, top, width, height), pixels; the part inside the image is used.
    bins : (int, int)

    Returns
    -------
    ndarray (M, n_hue * n_saturation)
        Rows sum to one; a box with no pixel inside the image gets the uniform histogram.
    """
    import cv2

    img = np.asarray(frame_bgr)
    if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
        raise ValueError(f"frame must be (height, width, 3) uint8, got {img.shape} {img.dtype}")
    b = np.asarray(boxes, dtype=float).reshape(-1, 4)
    nh, ns = (int(x) for x in bins)
    if nh < 1 or ns < 1:
        raise ValueError(f"bins must be two integers >= 1, got {bins!r}")
    out = np.full((b.shape[0], nh * ns), 1.0 / (nh * ns))
    if b.shape[0] == 0:
        return out
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    h, w = img.shape[:2]
    x0 = np.clip(np.floor(b[:, 0]), 0, w).astype(int)
    y0 = np.clip(np.floor(b[:, 1]), 0, h).astype(int)
    x1 = np.clip(np.ceil(b[:, 0] + b[:, 2]), 0, w).astype(int)
    y1 = np.clip(np.ceil(b[:, 1] + b[:, 3]), 0, h).astype(int)
    for k in range(b.shape[0]):
        if x1[k] <= x0[k] or y1[k] <= y0[k]:
            continue
        patch = np.ascontiguousarray(hsv[y0[k] : y1[k], x0[k] : x1[k]])
        hist = cv2.calcHist([patch], [0, 1], None, [nh, ns], [0, 180, 0, 256]).ravel()
        total = hist.sum()
        if total > 0:
            out[k] = hist / total
    return out


def detection_histograms(
    frames: Iterable[np.ndarray], detections: MOTData, n_frames: int,
    bins: tuple[int, int] = DEFAULT_BINS,
) -> np.ndarray:
    """The histogram of every detection row, decoding the frames once, in order.

    Parameters
    ----------
    frames : iterable of ndarray
        Frames ``1 .. n_frames`` (e.g. :func:`avtrack.io.video.iter_frames`).
    detections : MOTData
        Sorted by frame; no frame past ``n_frames``.
    n_frames : int
    bins : (int, int)

    Returns
    -------
    ndarray (len(detections), n_hue * n_saturation)
    """
    out = np.zeros((len(detections), int(bins[0]) * int(bins[1])))
    slices = detections.frame_slices(n_frames)
    for sl, frame in zip(slices, frames, strict=False):
        if sl.stop > sl.start:
            out[sl] = box_histograms(frame, detections.boxes[sl], bins)
    return out
