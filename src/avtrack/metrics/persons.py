"""Scores of persons tracked through the camera's absences: direction accuracy while out of
view, and identity kept on return.

* :func:`offscreen_direction_error` -- for every frame, the ground-truth persons are matched to
  the tracked persons one to one on azimuth (Hungarian algorithm, matches further apart than
  ``gate_deg`` refused), and the absolute azimuth error is averaged over the ground-truth
  persons that are *out of view* at that frame (no ground-truth box in the image, or its centre
  outside the camera's pixel columns). Coverage is the share of those person-frames matched.
* :func:`identity_on_return` -- a *return* is a ground-truth person reappearing in the image
  after at least ``min_absence`` frames out of it; it is kept when the tracked identity matched
  to that person (IoU >= 0.5, one to one per frame) in the ``window`` frames after the return
  is the identity matched last before the person left.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from avtrack.io.doa import wrap_azimuth
from avtrack.io.mot import MOTData
from avtrack.metrics.mot import box_iou


@dataclass(frozen=True)
class OffscreenScore:
    """Azimuth accuracy while out of view.

    Attributes
    ----------
    mae_deg : float
        Mean absolute azimuth error over the matched out-of-view person-frames (NaN if none).
    coverage : float
        Matched share of the out-of-view person-frames (NaN if none).
    n_frames : int
        Out-of-view person-frames in the ground truth.
    abs_error_sum : float
    n_matched : int
    """

    mae_deg: float
    coverage: float
    n_frames: int
    abs_error_sum: float
    n_matched: int

    @staticmethod
    def sum(parts: list[OffscreenScore]) -> OffscreenScore:
        """Pooled over scenes (sums of errors and counts, not an average of rates)."""
        err = sum(p.abs_error_sum for p in parts)
        n = sum(p.n_frames for p in parts)
        m = sum(p.n_matched for p in parts)
        return OffscreenScore(err / m if m else float("nan"), m / n if n else float("nan"),
                              n, err, m)


def truth_per_frame(
    doa, gt: MOTData, fps: float, n_frames: int, fov: tuple[float, float] | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Ground-truth directions per video frame and whether the camera sees each person.

    Parameters
    ----------
    doa : DOATable
        A scene's ``gt/doa.csv`` (rows every 8 ms, frame 0 at t = 0).
    gt : MOTData
        Its ``gt/gt.txt`` (boxes of the persons in the image).
    fps : float
    n_frames : int
    fov : (float, float), optional
        Pixel columns the camera sees (default: all): a person is in view at a frame when their
        box's centre lies in them.

    Returns
    -------
    frames, ids, azimuth_deg, in_view, active : ndarray (G,)
        One row per person per video frame (1-based frames), the first ``doa`` row of the
        frame; ``active``: the person speaks.
    """
    vf = np.floor(np.asarray(doa.time_s) * fps + 0.5).astype(np.int64) + 1
    _, first = np.unique(np.column_stack([vf, doa.ids]), axis=0, return_index=True)
    sel = np.zeros(vf.shape[0], dtype=bool)
    sel[first] = True
    sel &= vf <= n_frames
    frames, ids, az = vf[sel], np.asarray(doa.ids)[sel], np.asarray(doa.azimuth_deg)[sel]
    active = np.asarray(doa.active, dtype=bool)[sel]
    centre = gt.boxes[:, 0] + 0.5 * gt.boxes[:, 2]
    lo, hi = (-np.inf, np.inf) if fov is None else fov
    seen = {(int(f), int(i)) for f, i, c in zip(gt.frames, gt.ids, centre, strict=True)
            if lo <= c <= hi}
    in_view = np.array([(int(f), int(i)) in seen for f, i in zip(frames, ids, strict=True)],
                       dtype=bool)
    return frames, ids, az, in_view, active


def offscreen_direction_error(
    gt_frames: np.ndarray,
    gt_ids: np.ndarray,
    gt_azimuth: np.ndarray,
    gt_in_view: np.ndarray,
    hyp_frames: np.ndarray,
    hyp_azimuth: np.ndarray,
    gate_deg: float = 30.0,
    gt_mask: np.ndarray | None = None,
) -> OffscreenScore:
    """Azimuth error of the tracked persons for ground-truth persons out of view.

    Parameters
    ----------
    gt_frames, gt_ids, gt_azimuth, gt_in_view : ndarray (G,)
        One row per ground-truth person per video frame (1-based frames), azimuth in degrees,
        whether the person is in the camera's view.
    hyp_frames, hyp_azimuth : ndarray (H,)
        The rows of ``persons.csv``: frame and azimuth of every tracked person.
    gate_deg : float
    gt_mask : ndarray (G,) bool, optional
        Score only these ground-truth rows (e.g. the frames where the person speaks); the
        others still take part in the matching.
    """
    gf = np.asarray(gt_frames, dtype=np.int64)
    ga = np.asarray(gt_azimuth, dtype=float)
    gv = np.asarray(gt_in_view, dtype=bool)
    if gt_mask is not None:  # rows not scored count as in view (matched, not scored)
        gv = gv | ~np.asarray(gt_mask, dtype=bool)
    hf = np.asarray(hyp_frames, dtype=np.int64)
    ha = np.asarray(hyp_azimuth, dtype=float)
    if not (gf.shape == ga.shape == gv.shape == np.shape(gt_ids)):
        raise ValueError("gt_frames, gt_ids, gt_azimuth and gt_in_view must have one shape")
    if hf.shape != ha.shape:
        raise ValueError("hyp_frames and hyp_azimuth must have one shape")
    err_sum, matched = 0.0, 0
    n_out = int((~gv).sum())
    for f in np.unique(gf[~gv]):
        g = np.flatnonzero(gf == f)
        h = np.flatnonzero(hf == f)
        if h.size == 0:
            continue
        d = np.abs(wrap_azimuth(ga[g][:, None] - ha[h][None, :]))
        r, k = linear_sum_assignment(np.where(d <= gate_deg, d, 1e6))
        ok = d[r, k] <= gate_deg
        out = ~gv[g[r[ok]]]
        err_sum += float(d[r[ok], k[ok]][out].sum())
        matched += int(out.sum())
    return OffscreenScore(err_sum / matched if matched else float("nan"),
                          matched / n_out if n_out else float("nan"), n_out, err_sum, matched)


@dataclass(frozen=True)
class ReturnScore:
    """Identity kept on return.

    Attributes
    ----------
    n_returns : int
    n_kept : int
    """

    n_returns: int
    n_kept: int

    @property
    def rate(self) -> float:
        return self.n_kept / self.n_returns if self.n_returns else float("nan")


def _matches(gt: MOTData, res: MOTData) -> dict[int, list[tuple[int, int]]]:
    """Per ground-truth id, the (frame, result id) pairs matched at IoU >= 0.5."""
    out: dict[int, list[tuple[int, int]]] = {}
    for f in np.unique(gt.frames):
        g = np.flatnonzero(gt.frames == f)
        r = np.flatnonzero(res.frames == f)
        if r.size == 0:
            continue
        iou = box_iou(gt.boxes[g], res.boxes[r])
        a, b = linear_sum_assignment(-iou)
        for i, j in zip(a, b, strict=True):
            if iou[i, j] >= 0.5:
                out.setdefault(int(gt.ids[g[i]]), []).append((int(f), int(res.ids[r[j]])))
    return out


def identity_on_return(
    gt: MOTData, res: MOTData, min_absence: int = 25, window: int = 50
) -> ReturnScore:
    """Returns of ground-truth persons into the image and how many kept their identity.

    Parameters
    ----------
    gt : MOTData
        Ground-truth boxes (persons in the image only).
    res : MOTData
        Tracked boxes.
    min_absence : int
        Frames out of the image that make a reappearance a return.
    window : int
        Frames after the return in which the first matched identity is taken.
    """
    matched = _matches(gt, res)
    n_ret = kept = 0
    for pid in np.unique(gt.ids):
        frames = np.unique(gt.frames[gt.ids == pid])
        gaps = np.flatnonzero(np.diff(frames) > min_absence)
        pairs = matched.get(int(pid), [])
        for gi in gaps:
            left, back = frames[gi], frames[gi + 1]
            before = [i for f, i in pairs if f <= left]
            after = [i for f, i in pairs if back <= f < back + window]
            if not before:
                continue
            n_ret += 1
            kept += bool(after) and after[0] == before[-1]
    return ReturnScore(n_ret, kept)
