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

import numpy as np

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
    x = x[np.isfinite(x)]
    if x.size < 2:
        return None
    lo, hi = float(x.min()), float(x.max())
    if not hi - lo > 1e-9 * max(1.0, abs(hi)):
        return None
    counts, edges = np.histogram(x, bins=bins, range=(lo, hi))
    centres = 0.5 * (edges[:-1] + edges[1:])
    w0 = np.cumsum(counts)[:-1].astype(float)  # lower class size for a cut after bin k
    s0 = np.cumsum(counts * centres)[:-1]
    n, total = float(counts.sum()), float((counts * centres).sum())
    w1 = n - w0
    with np.errstate(divide="ignore", invalid="ignore"):
        between = w0 * w1 * (s0 / w0 - (total - s0) / w1) ** 2
    between[(w0 == 0) | (w1 == 0)] = -1.0
    t = float(edges[1:-1][int(np.argmax(between))])
    lower, upper = x[x < t], x[x >= t]
    if lower.size < 2 or upper.size < 2:
        return None
    spread = np.sqrt(0.5 * (lower.var() + upper.var()))
    if not abs(upper.mean() - lower.mean()) >= MIN_SEPARATION * spread:
        return None  # one class of scores: nothing to tell false alarms by
    return t


class ScoreSplit:
    """Running Otsu split of the scores seen so far (online: frame ``t`` uses frames ``1..t``).

    The threshold is recomputed every frame for the first 500 scores, then whenever the
    number of scores seen has grown by 5 % (it moves little once the histogram is full).
    """

    def __init__(self) -> None:
        self._chunks: list[np.ndarray] = []
        self._n = 0  # scores seen
        self._n_at_split = 0
        self.threshold: float | None = None

    def update(self, scores: np.ndarray) -> np.ndarray:
        """Add one frame's ``scores (M,)``; return which of them may start a target ``(M,)``."""
        scores = np.asarray(scores, dtype=float).reshape(-1)
        if scores.size:
            self._chunks.append(scores)
            self._n += scores.size
            if self._n >= MIN_SCORES and (self._n < 500 or self._n >= 1.05 * self._n_at_split):
                kept = np.concatenate(self._chunks)[-MAX_KEPT:]
                self._chunks = [kept]
                self.threshold = otsu_threshold(kept)
                self._n_at_split = self._n
        if self.threshold is None:
            return np.ones(scores.shape[0], dtype=bool)
        return scores >= self.threshold
