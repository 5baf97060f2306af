"""Frame-wise DOA evaluation of thesis §5.5.1: greedy matching, success within 15 degrees,
MAE, miss-detection and false-alarm rates, and the ROC sweep over the peak threshold
(thesis Fig. 5.3, Tables 5.1–5.2).

Protocol (per frame). The azimuth differences of all estimated/actual speaker pairs are
computed; the pair with the smallest difference is matched, its estimate and speaker removed,
and so on until the estimates or the speakers run out (greedy matching). A matched estimate is a
*success* when its difference is at most 15 degrees. Every actual (active) speaker without a
successful estimate is a miss detection (MD); every estimate that is not a success is a false
alarm (FA). Over all frames:

- MD rate = total MDs / total actual speakers, FA rate = total FAs / total actual speakers;
- MAE = mean absolute azimuth error of the successes.

:class:`DOAScores` holds the summed components, so that scores of several sequences add up
(``a + b``) and the corpus rates are computed from the sums, not averaged.

Frames of the estimate and ground-truth tables are aligned by time: a row's frame key is
``round(time_s / period_s)`` (8 ms STFT hop by default).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from avtrack.io.doa import DOATable

SUCCESS_DEG = 15.0
"""Largest azimuth error of a successful localization (thesis §5.5.1)."""
FRAME_PERIOD_S = 0.008


def angular_error(a_deg: np.ndarray | float, b_deg: np.ndarray | float) -> np.ndarray:
    """Absolute azimuth difference in degrees, wrapped to [0, 180]."""
    d = np.mod(np.asarray(a_deg, dtype=float) - np.asarray(b_deg, dtype=float), 360.0)
    return np.minimum(d, 360.0 - d)


def greedy_match(est_deg: np.ndarray, true_deg: np.ndarray) -> tuple[np.ndarray, ...]:
    """Greedy matching of one frame's estimates to its actual speakers (thesis §5.5.1).

    Parameters
    ----------
    est_deg : ndarray (K,)
        Estimated azimuths, degrees.
    true_deg : ndarray (G,)
        Actual speakers' azimuths, degrees.

    Returns
    -------
    est_index, true_index : ndarray (min(K, G),) int
        Matched pairs in the order they were picked (smallest difference first).
    error : ndarray (min(K, G),)
        Their azimuth differences.
    """
    est = np.asarray(est_deg, dtype=float).reshape(-1)
    tru = np.asarray(true_deg, dtype=float).reshape(-1)
    if not (np.all(np.isfinite(est)) and np.all(np.isfinite(tru))):
        raise ValueError("greedy_match: azimuths must be finite")
    dist = angular_error(est[:, None], tru[None, :])
    ei, ti, err = [], [], []
    for _ in range(min(est.size, tru.size)):
        k, g = np.unravel_index(np.argmin(dist), dist.shape)
        ei.append(k)
        ti.append(g)
        err.append(dist[k, g])
        dist[k, :] = np.inf
        dist[:, g] = np.inf
    return np.array(ei, dtype=int), np.array(ti, dtype=int), np.array(err, dtype=float)


@dataclass(frozen=True)
class DOAScores:
    """Summed components of the §5.5.1 metrics (add two to combine sequences).

    Attributes
    ----------
    n_actual : int
        Actual (active) speaker-frames.
    n_detected : int
        Estimates.
    n_success : int
        Matched estimates within the success threshold.
    abs_error_sum : float
        Sum of the successes' absolute errors, degrees.
    n_frames : int
        Frames evaluated.
    """

    n_actual: int
    n_detected: int
    n_success: int
    abs_error_sum: float
    n_frames: int = 0

    def __add__(self, other: DOAScores) -> DOAScores:
        if not isinstance(other, DOAScores):
            return NotImplemented
        return DOAScores(
            self.n_actual + other.n_actual,
            self.n_detected + other.n_detected,
            self.n_success + other.n_success,
            self.abs_error_sum + other.abs_error_sum,
            self.n_frames + other.n_frames,
        )

    @property
    def n_missed(self) -> int:
        """Miss detections: actual speakers without a successful estimate."""
        return self.n_actual - self.n_success

    @property
    def n_false_alarms(self) -> int:
        """False alarms: estimates that are not successes."""
        return self.n_detected - self.n_success

    @property
    def md_rate(self) -> float:
        """MDs / actual speakers (fraction; NaN without actual speakers)."""
        return self.n_missed / self.n_actual if self.n_actual else float("nan")

    @property
    def fa_rate(self) -> float:
        """FAs / actual speakers (fraction; NaN without actual speakers)."""
        return self.n_false_alarms / self.n_actual if self.n_actual else float("nan")

    @property
    def mae(self) -> float:
        """Mean absolute error of the successes, degrees (NaN without successes)."""
        return self.abs_error_sum / self.n_success if self.n_success else float("nan")

    def as_dict(self) -> dict[str, float]:
        """Rates in percent, MAE in degrees, and the counts."""
        return {
            "MD%": 100.0 * self.md_rate,
            "FA%": 100.0 * self.fa_rate,
            "MAE": self.mae,
            "actual": self.n_actual,
            "detected": self.n_detected,
            "success": self.n_success,
            "frames": self.n_frames,
        }


def _keys(table: DOATable, period_s: float) -> np.ndarray:
    return np.rint(table.time_s / period_s).astype(np.int64)


def _padded(keys: np.ndarray, values: np.ndarray, frame_keys: np.ndarray, fill: float):
    """Rows grouped per frame key into a ``(n_frames, width)`` array padded with ``fill``."""
    pos = np.searchsorted(frame_keys, keys)
    order = np.argsort(pos, kind="stable")
    pos, vals = pos[order], values[order]
    counts = np.bincount(pos, minlength=frame_keys.size)
    width = int(counts.max()) if counts.size else 0
    out = np.full((frame_keys.size, max(width, 1)), fill, dtype=float)
    if pos.size:
        start = np.r_[0, np.cumsum(counts)[:-1]]
        col = np.arange(pos.size) - start[pos]
        out[pos, col] = vals
    return out


class _Aligned:
    """Estimates and actual speakers grouped per frame, padded with NaN."""

    def __init__(
        self, est: DOATable, truth: DOATable, period_s: float, time_range_s, truth_shift: int = 0
    ):
        if not (isinstance(est, DOATable) and isinstance(truth, DOATable)):
            raise TypeError("evaluate_doa: estimates and truth must be DOATables")
        if not (isinstance(period_s, int | float) and period_s > 0):
            raise ValueError(f"evaluate_doa: period_s must be > 0, got {period_s!r}")
        ek, tk = _keys(est, period_s), _keys(truth, period_s) + truth_shift
        keep_e = np.ones(len(est), dtype=bool)
        keep_t = truth.active.copy()
        frames_t = np.ones(len(truth), dtype=bool)
        if time_range_s is not None:
            lo, hi = time_range_s
            t_time = truth.time_s + truth_shift * period_s
            keep_e &= (est.time_s >= lo) & (est.time_s <= hi)
            frames_t &= (t_time >= lo) & (t_time <= hi)
            keep_t &= frames_t
        self.frame_keys = np.unique(np.r_[ek[keep_e], tk[frames_t]])
        self.est_az = _padded(ek[keep_e], est.azimuth_deg[keep_e], self.frame_keys, np.nan)
        self.est_w = _padded(ek[keep_e], est.weight[keep_e], self.frame_keys, np.nan)
        self.est_active = _padded(
            ek[keep_e], est.active[keep_e].astype(float), self.frame_keys, 0.0
        ).astype(bool)
        self.true_az = _padded(tk[keep_t], truth.azimuth_deg[keep_t], self.frame_keys, np.nan)
        self.dist = angular_error(self.est_az[:, :, None], self.true_az[:, None, :])


def _score(aligned: _Aligned, est_mask: np.ndarray, success_deg: float) -> DOAScores:
    """Greedy matching of all frames at once (estimates restricted to ``est_mask``)."""
    dist = np.where(est_mask[:, :, None], aligned.dist, np.nan)
    dist = np.where(np.isnan(dist), np.inf, dist)
    t_, k_, g_ = dist.shape
    n_success = 0
    err_sum = 0.0
    rows = np.arange(t_)
    flat = dist.reshape(t_, -1).copy()
    for _ in range(min(k_, g_)):
        idx = np.argmin(flat, axis=1)
        best = flat[rows, idx]
        ok = np.isfinite(best)
        if not np.any(ok):
            break
        good = ok & (best <= success_deg)
        n_success += int(np.count_nonzero(good))
        err_sum += float(best[good].sum())
        k, g = np.divmod(idx, g_)
        f3 = flat.reshape(t_, k_, g_)
        f3[rows[ok], k[ok], :] = np.inf  # the estimate is used
        f3[rows[ok], :, g[ok]] = np.inf  # the speaker is used
    n_actual = int(np.count_nonzero(~np.isnan(aligned.true_az)))
    n_detected = int(np.count_nonzero(est_mask))
    return DOAScores(n_actual, n_detected, n_success, err_sum, t_)


def evaluate_doa(
    estimates: DOATable,
    truth: DOATable,
    *,
    success_deg: float = SUCCESS_DEG,
    threshold: float | None = None,
    period_s: float = FRAME_PERIOD_S,
    time_range_s: tuple[float, float] | None = None,
) -> DOAScores:
    """Score frame-wise DOA estimates against ground truth (thesis §5.5.1).

    Parameters
    ----------
    estimates : DOATable
        The estimates; by default the rows with ``active`` are used.
    truth : DOATable
        Ground truth; rows with ``active`` are the actual (speaking) speakers. Frames listed in
        ``truth`` without an active speaker still count (estimates there are false alarms).
    success_deg : float
        Success threshold (15 degrees).
    threshold : float, optional
        Use the estimates with ``weight >= threshold`` instead of the ``active`` flag.
    period_s : float
        Frame period used to align the two tables by time.
    time_range_s : (float, float), optional
        Only frames within this time interval.
    """
    aligned = _Aligned(estimates, truth, period_s, time_range_s)
    if threshold is None:
        mask = aligned.est_active & ~np.isnan(aligned.est_az)
    else:
        mask = aligned.est_w >= threshold
    return _score(aligned, mask, success_deg)


@dataclass(frozen=True)
class ROCCurve:
    """MD and FA rates (and MAE) as the peak threshold varies (thesis Fig. 5.3).

    Attributes
    ----------
    thresholds : ndarray (N,) increasing
    scores : tuple of DOAScores, one per threshold
    """

    thresholds: np.ndarray
    scores: tuple[DOAScores, ...]

    @property
    def md_rate(self) -> np.ndarray:
        return np.array([s.md_rate for s in self.scores])

    @property
    def fa_rate(self) -> np.ndarray:
        return np.array([s.fa_rate for s in self.scores])

    @property
    def mae(self) -> np.ndarray:
        return np.array([s.mae for s in self.scores])

    @property
    def best_index(self) -> int:
        """The point closest to the origin of the (FA, MD) plane (thesis §5.5.2)."""
        return int(np.nanargmin(np.hypot(self.md_rate, self.fa_rate)))

    @property
    def best(self) -> tuple[float, DOAScores]:
        """``(threshold, scores)`` at :attr:`best_index`."""
        i = self.best_index
        return float(self.thresholds[i]), self.scores[i]


def roc_sweep(
    estimates: DOATable,
    truth: DOATable,
    thresholds: np.ndarray | None = None,
    *,
    success_deg: float = SUCCESS_DEG,
    period_s: float = FRAME_PERIOD_S,
    time_range_s: tuple[float, float] | None = None,
) -> ROCCurve:
    """:func:`evaluate_doa` at every threshold on the estimates' ``weight`` (ignores ``active``).

    ``estimates`` should list every candidate peak with its weight (e.g.
    :func:`avtrack.localize.peaks.peak_table` with a low ``floor``). Default thresholds: 40
    quantiles of the estimates' weights.
    """
    if thresholds is None:
        w = estimates.weight
        thresholds = np.unique(np.quantile(w, np.linspace(0, 0.99, 40))) if w.size else np.zeros(1)
    thr = np.sort(np.asarray(thresholds, dtype=float).reshape(-1))
    if thr.size == 0 or not np.all(np.isfinite(thr)):
        raise ValueError("roc_sweep: thresholds must be a non-empty array of finite numbers")
    aligned = _Aligned(estimates, truth, period_s, time_range_s)
    scores = tuple(_score(aligned, aligned.est_w >= t, success_deg) for t in thr)
    return ROCCurve(thr, scores)


@dataclass(frozen=True)
class LagResult:
    """How late the estimates are: the time shift of the ground truth that minimises the MAE.

    Attributes
    ----------
    shifts : ndarray (S,) int
        Shifts tried, in frames of ``period_s``; shift ``s`` compares the estimates at frame
        ``k`` with the ground truth at frame ``k - s`` (``s > 0``: the estimates come late).
    mae : ndarray (S,)
        MAE (degrees) at each shift (NaN where nothing succeeds).
    period_s : float
        The frame period.
    """

    shifts: np.ndarray
    mae: np.ndarray
    period_s: float

    @property
    def lag_frames(self) -> int:
        """The shift with the smallest MAE (the one nearest 0 among equals)."""
        if not np.any(np.isfinite(self.mae)):
            raise ValueError("estimate_lag: no successful estimate at any shift")
        best = np.nanmin(self.mae)
        cand = self.shifts[self.mae <= best]
        return int(cand[np.argmin(np.abs(cand))])

    @property
    def lag_s(self) -> float:
        """:attr:`lag_frames` in seconds."""
        return self.lag_frames * self.period_s

    @property
    def mae_at_zero(self) -> float:
        """The MAE without shift (NaN when 0 is not among the shifts)."""
        zero = self.shifts == 0
        return float(self.mae[zero][0]) if zero.any() else float("nan")


def estimate_lag(
    estimates: DOATable,
    truth: DOATable,
    *,
    max_shift_frames: int = 75,
    success_deg: float = SUCCESS_DEG,
    threshold: float | None = None,
    period_s: float = FRAME_PERIOD_S,
    time_range_s: tuple[float, float] | None = None,
) -> LagResult:
    """The lag of DOA estimates behind the ground truth.

    The ground truth is shifted later in time by ``s`` frames, ``s = -max_shift_frames ..
    max_shift_frames``, and scored by :func:`evaluate_doa` (thesis §5.5.1) at each shift; the
    lag is the shift with the smallest MAE. An estimator that reports a talker's direction
    ``L`` frames late has its MAE minimum at ``s = L``.

    Parameters
    ----------
    estimates, truth : DOATable
        As for :func:`evaluate_doa` (estimates: ``active`` rows, or ``weight >= threshold``).
    max_shift_frames : int
        Largest shift tried, each way (75 frames = 0.6 s at 8 ms).
    success_deg, threshold, period_s, time_range_s
        As for :func:`evaluate_doa`.
    """
    if isinstance(max_shift_frames, bool) or not isinstance(max_shift_frames, int | np.integer):
        raise ValueError(
            f"estimate_lag: max_shift_frames must be an integer, got {max_shift_frames!r}"
        )
    if max_shift_frames < 0:
        raise ValueError(f"estimate_lag: max_shift_frames must be >= 0, got {max_shift_frames}")
    if not (isinstance(success_deg, int | float) and success_deg > 0):
        raise ValueError(f"estimate_lag: success_deg must be > 0, got {success_deg!r}")
    shifts = np.arange(-int(max_shift_frames), int(max_shift_frames) + 1)
    mae = np.empty(shifts.size)
    for i, s in enumerate(shifts):
        aligned = _Aligned(estimates, truth, period_s, time_range_s, int(s))
        if threshold is None:
            mask = aligned.est_active & ~np.isnan(aligned.est_az)
        else:
            mask = aligned.est_w >= threshold
        mae[i] = _score(aligned, mask, success_deg).mae
    return LagResult(shifts, mae, float(period_s))
