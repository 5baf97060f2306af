r"""The camera's pitch from the heads it sees: the horizon of people walking in depth.

A head of height ``H`` whose centre stays at one height while its person walks towards or away
from a camera with no roll draws, in the image, a straight line in the plane (box height ``h``,
row of the box centre ``v``). With the camera pitched by :math:`\theta` (negative: looking
down), focal length ``f`` (pixels) and principal row :math:`c_y`, a head centre ``D`` metres
below the optical centre at depth ``z = f H / h`` sits at

.. math::

    v = v_0 + \frac{D}{H \cos\theta}\, h, \qquad v_0 = c_y + f \tan\theta ,

so every person's line meets the others at ``h = 0`` on the row :math:`v_0` of the horizon,
whatever their height (the slope is theirs) [Hoiem, Efros & Hebert, "Putting objects in
perspective", IJCV 2008, where the same relation places the horizon from objects of a known
class]. :func:`estimate_horizon` fits that common intercept with one slope per tracklet
(boxes linked frame to frame by overlap, :func:`link_tracklets`), on tracklets whose boxes
grow or shrink by at least :data:`MIN_SIZE_RATIO`; the pitch is then
:math:`\theta = \arctan((v_0 - c_y) / f)` for the focal length that the audio fit measured.

Box heights are noisy, and noise in the regressor flattens each slope and pulls :math:`v_0`
towards the heads' mean row (errors in variables); boxes are therefore averaged over
:data:`SMOOTH_S` seconds within a tracklet before the fit. The uncertainty is a block bootstrap
(blocks of :data:`BLOCK_S` seconds of one tracklet). People who sit or stand still give no
depth change and so no horizon: the estimate is then absent and the pitch stays held.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import uniform_filter1d
from scipy.optimize import linear_sum_assignment

from avtrack.io.mot import MOTData
from avtrack.metrics.mot import box_iou

#: Fewest times a tracklet's box grows from its small to its large size (10th and 90th
#: percentiles of its smoothed heights) for its slope to be measured: a 15 % change of depth.
MIN_SIZE_RATIO = 1.15

#: Seconds over which a tracklet's box heights and rows are averaged before the fit.
SMOOTH_S = 0.5

#: Length in seconds of the blocks the bootstrap resamples.
BLOCK_S = 2.0

#: Fewest blocks of evidence for a horizon.
MIN_BLOCKS = 4

#: A box whose top or bottom lies within this many pixels of the image's edge is cut by it.
EDGE_PX = 1.0

#: Robust scale of the fit's residuals, pixels (``soft_l1`` loss).
ROW_SCALE_PX = 3.0


@dataclass(frozen=True)
class Horizon:
    """The image row where the heads' lines meet (:func:`estimate_horizon`).

    Attributes
    ----------
    row_px : float
        The horizon's row :math:`v_0`, pixels from the top (may lie outside the image).
    row_std_px : float
        Its standard deviation (block bootstrap).
    n_tracklets, n_blocks : int
        The tracklets and blocks of :data:`BLOCK_S` seconds that measured it.
    """

    row_px: float
    row_std_px: float
    n_tracklets: int
    n_blocks: int

    def pitch_deg(self, focal_px: float, cy: float) -> float:
        """The pitch (degrees, negative looking down) for the focal length ``focal_px`` and
        principal row ``cy``: :math:`\\arctan((v_0 - c_y) / f)`."""
        return math.degrees(math.atan2(self.row_px - cy, focal_px))

    def pitch_std_deg(self, focal_px: float, cy: float) -> float:
        """The pitch's standard deviation from :attr:`row_std_px` (first order)."""
        t = (self.row_px - cy) / focal_px
        return math.degrees(self.row_std_px / focal_px / (1.0 + t * t))


def link_tracklets(detections: MOTData, min_iou: float = 0.3, max_gap: int = 2) -> np.ndarray:
    """Labels ``(K,)`` linking each box to the box of the previous ``max_gap`` frames it
    overlaps most (IoU at least ``min_iou``, one-to-one by the Hungarian method).

    Short and conservative on purpose: a tracklet that jumps between two people would mix
    their heights, and :func:`estimate_horizon` needs no identities across occlusions. A full
    tracker (:mod:`avtrack.visual.ovbt`) is not needed for that.
    """
    if not 0.0 < min_iou <= 1.0:
        raise ValueError(f"link_tracklets: min_iou must be in (0, 1], got {min_iou!r}")
    labels = np.full(detections.frames.shape[0], -1, dtype=np.int64)
    live: list[tuple[int, int, np.ndarray]] = []  # (label, last frame, box)
    n_labels = 0
    for frame, sl in enumerate(detections.frame_slices(), start=1):
        live = [t for t in live if frame - t[1] <= max_gap]
        rows = np.arange(sl.start, sl.stop)
        if live and rows.shape[0]:
            iou = box_iou(np.array([t[2] for t in live]), detections.boxes[rows])
            for i, j in zip(*linear_sum_assignment(-iou), strict=True):
                if iou[i, j] >= min_iou:
                    labels[rows[j]] = live[i][0]
                    live[i] = (live[i][0], frame, detections.boxes[rows[j]])
        for r in rows[labels[rows] < 0]:
            labels[r] = n_labels
            live.append((n_labels, frame, detections.boxes[r]))
            n_labels += 1
    return labels


def estimate_horizon(
    detections: MOTData, fps: float, image_height: int, *, n_bootstrap: int = 40,
    seed: int = 0,
) -> Horizon | None:
    """The horizon of the heads in ``detections`` (see the module docstring), or None when
    fewer than :data:`MIN_BLOCKS` blocks of tracklets change depth enough to measure it.

    Parameters
    ----------
    detections : MOTData
        Head (or face) boxes, sorted by frame; identities are not used.
    fps : float
        Video frame rate.
    image_height : int
        Pixels. A box that touches the top or bottom of the image is cut by it: its height
        and centre are not the head's, and it is left out.
    """
    if not (math.isfinite(fps) and fps > 0):
        raise ValueError(f"estimate_horizon: fps must be > 0, got {fps!r}")
    if not image_height > 0:
        raise ValueError(f"estimate_horizon: image_height must be > 0, got {image_height!r}")
    box = detections.boxes
    whole = (box[:, 1] > EDGE_PX) & (box[:, 1] + box[:, 3] < image_height - EDGE_PX)
    detections = detections.select(whole)
    if len(detections) == 0:
        return None
    labels = link_tracklets(detections)
    box = detections.boxes
    v = box[:, 1] + 0.5 * box[:, 3]  # row of the box centre
    h = box[:, 3].copy()
    win = max(1, round(SMOOTH_S * fps))
    keep: list[int] = []
    order = np.argsort(labels, kind="stable")  # each tracklet's rows, in frame order
    starts = np.flatnonzero(np.r_[True, np.diff(labels[order]) != 0])
    for lab, rows in zip(labels[order][starts], np.split(order, starts[1:]), strict=True):
        if rows.shape[0] < 2 * win:
            continue
        h[rows] = uniform_filter1d(h[rows], win, mode="nearest")
        v[rows] = uniform_filter1d(v[rows], win, mode="nearest")
        if np.percentile(h[rows], 90) >= MIN_SIZE_RATIO * np.percentile(h[rows], 10):
            keep.append(int(lab))
    used = np.isin(labels, keep)
    which = np.searchsorted(keep, labels[used])  # tracklet index of each box, (N,)
    v, h, t = v[used], h[used], detections.frames[used] / fps
    # blocks of BLOCK_S seconds of one tracklet, the bootstrap's units
    _, block = np.unique(np.c_[which, (t // BLOCK_S).astype(np.int64)], axis=0,
                         return_inverse=True)
    block = block.ravel()
    n_blocks = int(block.max(initial=-1)) + 1
    if n_blocks < MIN_BLOCKS:
        return None
    row = _common_intercept(v, h, which, np.ones(v.shape[0]))
    rng = np.random.default_rng(seed)
    reps = [_common_intercept(v, h, which, np.bincount(
        rng.integers(0, n_blocks, n_blocks), minlength=n_blocks)[block].astype(float))
        for _ in range(n_bootstrap)]
    return Horizon(row, float(np.std(reps, ddof=1)), len(keep), n_blocks)


def _common_intercept(v: np.ndarray, h: np.ndarray, which: np.ndarray, mult: np.ndarray,
                      n_iter: int = 30) -> float:
    r"""The intercept :math:`v_0` of ``v = v0 + s_k h`` ``(N,)``, one slope per tracklet
    ``which`` ``(N,)``, rows counted ``mult`` times, with the ``soft_l1`` loss of scale
    :data:`ROW_SCALE_PX`: iteratively reweighted least squares, each slope solved for
    in closed form given :math:`v_0` (so memory and time grow with the rows only, not with
    rows times tracklets, as a dense least-squares Jacobian would).

    For weights ``w``, a tracklet's slope is :math:`s_k = (S_{hv} - v_0 S_h) / S_{hh}`
    (sums over its rows), so each residual is :math:`a - v_0 b` with
    :math:`a = v - h S_{hv}/S_{hh}`, :math:`b = 1 - h S_h/S_{hh}`, and
    :math:`v_0 = \sum w a b / \sum w b^2`; the weights of the loss
    :math:`\rho(z) = 2(\sqrt{1 + z} - 1)`, :math:`z = (e / c)^2`, are
    :math:`1 / \sqrt{1 + z}`.
    """
    n_k = int(which.max(initial=-1)) + 1
    w = mult.copy()
    v0 = float(np.median(v))
    for _ in range(n_iter):
        s_hh = np.bincount(which, w * h * h, n_k)
        s_hv = np.bincount(which, w * h * v, n_k)
        s_h = np.bincount(which, w * h, n_k)
        inv = np.divide(1.0, s_hh, out=np.zeros(n_k), where=s_hh > 0)[which]
        a = v - h * s_hv[which] * inv
        b = 1.0 - h * s_h[which] * inv
        den = float(np.sum(w * b * b))
        if den <= 0.0:
            break
        new = float(np.sum(w * a * b)) / den
        e = a - new * b
        w = mult / np.sqrt(1.0 + (e / ROW_SCALE_PX) ** 2)
        if abs(new - v0) < 1e-6:
            v0 = new
            break
        v0 = new
    return v0
