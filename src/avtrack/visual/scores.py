"""Which detections may start a target: a running two-class split of the detector's scores.

A detector's confidences are on its own scale (a Faster R-CNN's probabilities crowd near 1, a
HOG SVM gives margins, our simulator's head detector N(0.8, 0.1) for people and N(0.35, 0.15)
for false alarms), so no fixed threshold suits every detector. Births (thesis eq. 3.30) are
where false alarms turn into false tracks, so the tracker lets only the detections in the upper
class of the scores seen so far start a target, as ByteTrack (Zhang et al., ECCV 2022) keeps
low-score detections for the association only. The split is Otsu's (1979) threshold, the one
that maximises the between-class variance of the score histogram: no scale, no tuning.
Detections below it still update the targets they belong to.

Not in the thesis (§3.1 does not use detector scores); measured on the six MOT15 sequences in
BENCHMARKS.md. NumPy has no Otsu threshold and scikit-image is not a dependency, so it is
written here (15 lines).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from avtrack._jit import available_once as _compiled
from avtrack.visual import _otsu_kernel

#: scores needed before a split is trusted (below: every detection may start a target)
MIN_SCORES = 50
#: histogram bins of the split
BINS = 64
#: scores kept (the most recent); older ones are dropped
MAX_KEPT = 20000
#: least distance between the two classes' mean scores, in pooled class standard deviations,
#: for a split (one Gaussian class: 2.65; SORT's Faster R-CNN scores on the six MOT15
#: sequences: 3.8-4.2; the simulator's head detector with its false alarms: 3.7-4.0)
MIN_SEPARATION = 3.3


def otsu_threshold(scores: np.ndarray, bins: int = BINS) -> float | None:
    """Otsu's threshold of ``scores (N,)``: scores ``>= t`` form the upper class.

    Returns None when the scores do not split: fewer than two distinct values, or two classes
    whose means lie less than :data:`MIN_SEPARATION` pooled standard deviations apart (Ashman's
    D of the two classes). Otsu cuts any distribution in two, a single bell too (D = 2.65 for
    a Gaussian), and a detector whose scores form one class tells nothing of its false alarms
    by them: splitting it would only hold back the births of half its true detections.
    """
    x = np.asarray(scores, dtype=float).ravel()
    return otsu_threshold_sorted(np.sort(x[np.isfinite(x)]), bins)


def otsu_threshold_sorted(x: np.ndarray, bins: int = BINS) -> float | None:
    """:func:`otsu_threshold` of finite scores ``x (N,)`` sorted in ascending order.

    On sorted scores every step is a binary search or a slice: the histogram of
    ``np.histogram(x, bins, (x[0], x[-1]))`` (bin ``k`` holds ``edges[k] <= x < edges[k + 1]``,
    the last bin its right edge too) is the difference of the edges' insertion points.
    """
    kern = _otsu_kernel.kernel() if _compiled() else None
    if kern is not None:  # the same numbers, in one call
        t = kern(np.ascontiguousarray(x, dtype=float), int(bins), MIN_SEPARATION)
        return None if math.isnan(t) else float(t)
    n_x = x.shape[0]
    if n_x < 2:
        return None
    lo, hi = float(x[0]), float(x[-1])
    if not hi - lo > 1e-9 * max(1.0, abs(hi)):
        return None
    # np.histogram's edges for this range: np.linspace(lo, hi, bins + 1), term by term
    edges = _steps(bins) * ((hi - lo) / bins) + lo
    edges[-1] = hi
    inner = edges[1:-1]
    below = x.searchsorted(inner)  # scores below each inner edge: the lower class's size w0
    # bin counts (differences of 0, below, n) times the bin centres
    sums = np.concatenate(([0], below, [n_x]))
    sums = (sums[1:] - sums[:-1]) * (0.5 * (edges[:-1] + edges[1:]))
    s0 = sums.cumsum()[:-1]  # lower class's score sum for a cut after bin k
    total = float(np.add.reduce(sums))
    w0 = below.astype(float)
    w1 = n_x - w0
    if w0[0] > 0 and w1[-1] > 0:  # (always: x[0] lies below the first inner edge, x[-1] above
        # the last; w0 and w1 are monotone)
        between = w0 * w1 * (s0 / w0 - (total - s0) / w1) ** 2
    else:
        with np.errstate(divide="ignore", invalid="ignore"):
            between = w0 * w1 * (s0 / w0 - (total - s0) / w1) ** 2
        between[(w0 == 0) | (w1 == 0)] = -1.0
    k = int(between.argmax())
    t = float(inner[k])
    split = int(below[k])  # scores below t: the lower class
    if split < 2 or n_x - split < 2:
        return None
    m0, v0 = _mean_var(x[:split])
    m1, v1 = _mean_var(x[split:])
    if not abs(m1 - m0) >= MIN_SEPARATION * math.sqrt(0.5 * (v0 + v1)):
        return None  # one class of scores: nothing to tell false alarms by
    return t



@functools.lru_cache(maxsize=8)
def _steps(bins: int) -> np.ndarray:
    """``(bins + 1,)`` read-only ``0, 1, ..., bins`` as floats."""
    out = np.arange(bins + 1, dtype=float)
    out.flags.writeable = False
    return out


def _mean_var(a: np.ndarray) -> tuple[float, float]:
    """``(a.mean(), a.var())``, computed as NumPy computes them, without their call overhead."""
    mean = np.add.reduce(a) / a.shape[0]
    d = a - mean
    return float(mean), float(np.add.reduce(d * d) / a.shape[0])


class ScoreSplit:
    """Running Otsu split of the scores seen so far (online: frame ``t`` uses frames ``1..t``).

    The threshold is due again whenever the number of scores seen has grown by 5 % (it moves
    little once the histogram holds a few hundred scores). A due threshold is computed when it
    is first read, so frames whose detections all go to targets cost no split.
    """

    def __init__(self) -> None:
        self._chunks: list[np.ndarray] = []  # the kept scores, in the order seen
        self._n_kept = 0
        self._n = 0  # scores seen
        self._n_at_split = 0
        self._due: tuple[np.ndarray, ...] | None = None  # scores of a threshold not yet computed
        self._threshold: float | None = None

    @property
    def threshold(self) -> float | None:
        """The split of the scores up to the latest one it was due for (None: no split)."""
        if self._due is not None:
            x = np.concatenate(self._due)
            self._threshold = otsu_threshold_sorted(np.sort(x[np.isfinite(x)]))
            self._due = None
        return self._threshold

    def add(self, scores: np.ndarray) -> None:
        """Add one frame's ``scores (M,)``."""
        scores = np.array(scores, dtype=float).reshape(-1)  # a copy: kept until the split
        if not scores.size:
            return
        self._chunks.append(scores)
        self._n_kept += scores.size
        self._n += scores.size
        if self._n >= MIN_SCORES and self._n >= 1.05 * self._n_at_split:
            if self._n_kept > MAX_KEPT:  # drop the oldest scores
                self._chunks = [np.concatenate(self._chunks)[-MAX_KEPT:]]
                self._n_kept = MAX_KEPT
            self._due = tuple(self._chunks)
            self._n_at_split = self._n

    def may_start(self, scores: np.ndarray) -> np.ndarray:
        """Which of ``scores (M,)`` lie in the upper class of the split ``(M,)`` (all of them
        while there is no split)."""
        scores = np.asarray(scores, dtype=float).reshape(-1)
        t = self.threshold
        if t is None:
            return np.ones(scores.shape[0], dtype=bool)
        return scores >= t

    def update(self, scores: np.ndarray) -> np.ndarray:
        """Add one frame's ``scores (M,)``; return which of them may start a target ``(M,)``."""
        self.add(scores)
        return self.may_start(scores)
