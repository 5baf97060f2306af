r"""Acoustic tracking metrics: thesis §5.5.1 scores, identity switches and OSPA.

Per evaluated frame, the active estimates are greedily matched to the active (speaking)
ground-truth speakers exactly as in :mod:`avtrack.metrics.doa` (smallest azimuth difference
first); a match within 15° is a success, an actual speaker without a success is a miss
detection (MD), an estimate that is not a success a false alarm (FA); MAE is the mean absolute
error of the successes. On top of these (thesis Tables 5.1–5.3):

- **identity switches** (IDs, thesis §5.5.1: "the number of the identity changes in the
  tracks"): for each ground-truth speaker, the track id of its successful matches over time;
  every change of that id counts one switch (frames without a success do not reset it);
- **OSPA** (Schuhmacher, Vo & Vo 2008) between the active estimates and the active speakers
  of each frame, with the wrapped azimuth difference as base distance, order ``p = 2`` and
  cut-off ``c = 30°`` (the LOCATA challenge convention):

  .. math::
      \bar d_p^{(c)}(X, Y) = \Big(\frac{1}{n}\Big(\min_{\pi}\sum_{i=1}^{m}
      \min(c, d(x_i, y_{\pi(i)}))^p + c^p(n - m)\Big)\Big)^{1/p},\quad m \le n,

  0 when both sets are empty, averaged over the evaluated frames.

:class:`TrackingScores` holds summed components, so sequences add up (``a + b``) and corpus
values come from the sums.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from avtrack.io.doa import DOATable
from avtrack.metrics.doa import FRAME_PERIOD_S, SUCCESS_DEG, DOAScores, angular_error, greedy_match
from avtrack.metrics.ospa import OSPAResult, ospa

OSPA_CUTOFF_DEG = 30.0
"""OSPA cut-off of the LOCATA challenge, degrees."""
OSPA_ORDER = 2.0


def angular_distance(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``(n, m)`` wrapped azimuth differences in [0, 180] between azimuths ``x (n, 1)`` and
    ``y (m, 1)`` in degrees (the base distance of the OSPA)."""
    return angular_error(x[:, :1], y[:, 0][None, :])


def ospa_angular(
    est_deg: np.ndarray,
    true_deg: np.ndarray,
    cutoff_deg: float = OSPA_CUTOFF_DEG,
    order: float = OSPA_ORDER,
) -> OSPAResult:
    """OSPA between two sets of azimuths (degrees), wrapped differences as base distance
    (:func:`avtrack.metrics.ospa.ospa` with :func:`angular_distance`).

    Parameters
    ----------
    est_deg : ndarray (n,)
    true_deg : ndarray (m,)
    cutoff_deg : float
        ``c`` > 0.
    order : float
        ``p`` ≥ 1.
    """
    x = np.asarray(est_deg, dtype=float).reshape(-1, 1)
    y = np.asarray(true_deg, dtype=float).reshape(-1, 1)
    return ospa(x, y, cutoff_deg, order, angular_distance)


@dataclass(frozen=True)
class TrackingScores:
    """Summed components of the tracking metrics (add two to combine sequences).

    Attributes
    ----------
    doa : DOAScores
        MD / FA / MAE components (thesis §5.5.1).
    id_switches : int
        Identity switches.
    ospa_sum : float
        Sum over frames of the per-frame OSPA distance, degrees.
    n_frames : int
        Evaluated frames.
    """

    doa: DOAScores
    id_switches: int
    ospa_sum: float
    n_frames: int

    def __add__(self, other: TrackingScores) -> TrackingScores:
        if not isinstance(other, TrackingScores):
            return NotImplemented
        return TrackingScores(
            self.doa + other.doa,
            self.id_switches + other.id_switches,
            self.ospa_sum + other.ospa_sum,
            self.n_frames + other.n_frames,
        )

    @property
    def md_rate(self) -> float:
        return self.doa.md_rate

    @property
    def fa_rate(self) -> float:
        return self.doa.fa_rate

    @property
    def mae(self) -> float:
        return self.doa.mae

    @property
    def ospa(self) -> float:
        """Mean per-frame OSPA, degrees (NaN without frames)."""
        return self.ospa_sum / self.n_frames if self.n_frames else float("nan")

    def as_dict(self) -> dict[str, float]:
        """Rates in percent, MAE and OSPA in degrees, IDs, and the counts."""
        out = self.doa.as_dict()
        out["IDs"] = self.id_switches
        out["OSPA"] = self.ospa
        return out


def evaluate_tracks(
    tracks: DOATable,
    truth: DOATable,
    *,
    frame_times: np.ndarray | None = None,
    success_deg: float = SUCCESS_DEG,
    period_s: float = FRAME_PERIOD_S,
    cutoff_deg: float = OSPA_CUTOFF_DEG,
    order: float = OSPA_ORDER,
    time_range_s: tuple[float, float] | None = None,
) -> TrackingScores:
    """Score DOA tracks (or frame-wise estimates) against ground truth.

    Parameters
    ----------
    tracks : DOATable
        Estimates; rows with ``active`` are used; ``id`` ≥ 1 for tracks (frame-wise estimates
        with ``id = -1`` give 0 identity switches).
    truth : DOATable
        Ground truth; rows with ``active`` are the speaking speakers, ``id`` their identity.
    frame_times : ndarray (T,), optional
        Times of the frames to evaluate (e.g. the tracker's 32 ms frames). Default: every
        frame of ``truth`` and of ``tracks``.
    success_deg : float
        Success threshold (15°).
    period_s : float
        Frame period used to align the tables by time (8 ms).
    cutoff_deg, order : float
        OSPA cut-off (30°) and order (2).
    time_range_s : (float, float), optional
        Only frames within this interval.
    """
    if not (isinstance(tracks, DOATable) and isinstance(truth, DOATable)):
        raise TypeError("evaluate_tracks: tracks and truth must be DOATables")
    if not (isinstance(period_s, int | float) and period_s > 0):
        raise ValueError(f"period_s must be > 0, got {period_s!r}")
    ek = np.rint(tracks.time_s / period_s).astype(np.int64)
    tk = np.rint(truth.time_s / period_s).astype(np.int64)
    if frame_times is None:
        keys = np.unique(np.r_[ek, tk])
    else:
        ft = np.asarray(frame_times, dtype=float).reshape(-1)
        if not np.all(np.isfinite(ft)):
            raise ValueError("frame_times must be finite")
        keys = np.unique(np.rint(ft / period_s).astype(np.int64))
    if time_range_s is not None:
        lo, hi = np.rint(np.asarray(time_range_s, dtype=float) / period_s)
        keys = keys[(keys >= lo) & (keys <= hi)]
    e_sel = tracks.active & np.isin(ek, keys)
    t_sel = truth.active & np.isin(tk, keys)
    e_rows = _group(ek[e_sel], keys)
    t_rows = _group(tk[t_sel], keys)
    e_az, e_id = tracks.azimuth_deg[e_sel], tracks.ids[e_sel]
    t_az, t_id = truth.azimuth_deg[t_sel], truth.ids[t_sel]
    n_success = 0
    err_sum = 0.0
    switches = 0
    ospa_sum = 0.0
    last: dict[int, int] = {}
    for f in range(keys.size):
        ei, ti = e_rows[f], t_rows[f]
        ospa_sum += ospa_angular(e_az[ei], t_az[ti], cutoff_deg, order).distance
        if ei.size == 0 or ti.size == 0:
            continue
        k, g, err = greedy_match(e_az[ei], t_az[ti])
        ok = err <= success_deg
        n_success += int(ok.sum())
        err_sum += float(err[ok].sum())
        for kk, gg in zip(k[ok], g[ok], strict=True):
            track_id, speaker = int(e_id[ei[kk]]), int(t_id[ti[gg]])
            if track_id < 1:
                continue
            if speaker in last and last[speaker] != track_id:
                switches += 1
            last[speaker] = track_id
    doa = DOAScores(int(t_sel.sum()), int(e_sel.sum()), n_success, err_sum, int(keys.size))
    return TrackingScores(doa, switches, ospa_sum, int(keys.size))


def _group(row_keys: np.ndarray, keys: np.ndarray) -> list[np.ndarray]:
    """Row indices of each key of ``keys`` (rows in table order within a key)."""
    pos = np.searchsorted(keys, row_keys)
    order = np.argsort(pos, kind="stable")
    bounds = np.searchsorted(pos[order], np.arange(keys.size + 1))
    return [order[bounds[i] : bounds[i + 1]] for i in range(keys.size)]
