"""Scores of an SMC-PHD run on AV16.3: OSPA of the position sets and OSPA-T of the labelled
tracks, with the cut-offs of the SMC-PHD authors' released evaluation."""

from __future__ import annotations

import numpy as np

from avtrack.metrics.ospa import ospa_sequence, ospa_t
from avtrack.phd.base import PHDResult

#: OSPA cut-off (pixels) and order used for every report.
OSPA_CUTOFF = 50.0
OSPA_ORDER = 2
#: OSPA-T cut-off and label penalty (pixels) of the SMC-PHD authors' released evaluation.
OSPA_T_CUTOFF = 65.0
OSPA_T_LABEL_PENALTY = 25.0


def ospa_of(result: PHDResult, truth: list[np.ndarray]) -> np.ndarray:
    """Per-frame OSPA ``(T, 3)`` (distance, localisation, cardinality) of ``result``'s position
    sets against ``truth`` (:data:`OSPA_CUTOFF`, :data:`OSPA_ORDER`)."""
    return ospa_sequence(result.positions(), truth, OSPA_CUTOFF, OSPA_ORDER)


def ospa_t_of(result: PHDResult, seq) -> float:
    """OSPA-T of a filter's labelled estimates against ``posGT`` (presence from ``X_true``)."""
    return ospa_t_of_rows(result.rows(seq.frames), seq)


def ospa_t_of_rows(rows: np.ndarray, seq) -> float:
    """OSPA-T of estimate rows ``frame, id, x, y`` ``(K, 4)`` (:meth:`PHDResult.rows`, or the
    output CSV read back) against ``posGT`` (presence from ``X_true``) of the AV16.3 sequence
    ``seq``."""
    ids = rows[:, 1].astype(np.int64)
    # An estimate without identity (id -1, e.g. the clustering filter's) is a track of its own.
    unlabelled = ids < 0
    ids[unlabelled] = ids.max(initial=0) + 1 + np.arange(int(unlabelled.sum()))
    estimates = []
    for f in seq.frames:
        on = rows[:, 0] == f
        estimates.append((ids[on], rows[on, 2:4]))
    truths = [np.where(seq.present[t][:, None], seq.positions[:, t], np.nan)
              for t in range(seq.n_frames)]
    return ospa_t(estimates, truths, OSPA_T_CUTOFF, OSPA_ORDER, OSPA_T_LABEL_PENALTY).mean
