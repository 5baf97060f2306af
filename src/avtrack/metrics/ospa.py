r"""Optimal sub-pattern assignment (OSPA) distance between two finite point sets.

Schuhmacher, Vo and Vo, "A consistent metric for performance evaluation of multi-object
filters", IEEE TSP 2008; the metric of Liu et al.'s particle-flow SMC-PHD paper (§4,
order 2). For ``X`` with ``n`` points and
``Y`` with ``m`` points, ``n <= m`` (swap them otherwise), cut-off ``c`` and order ``p``:

.. math::

    \bar d_p^{(c)}(X, Y) = \Bigl(\frac{1}{m}\bigl(\min_{\pi \in \Pi_m}
        \sum_{i=1}^{n} d^{(c)}(x_i, y_{\pi(i)})^p + c^p (m - n)\bigr)\Bigr)^{1/p},
    \qquad d^{(c)}(x, y) = \min(c, d(x, y)).

It splits exactly into a localisation and a cardinality part,
``distance**p == localisation**p + cardinality**p``. Two empty sets are at distance 0, an empty
and a non-empty set at distance ``c``.

The base distance ``d`` is Euclidean unless a callable returning the ``(n, m)`` matrix of base
distances is given (e.g. an angular distance for DOA tracks).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

DistanceFn = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass(frozen=True)
class OSPAResult:
    """OSPA distance of one pair of point sets and its two components.

    Attributes
    ----------
    distance : float
        The OSPA distance, ``(localisation**p + cardinality**p) ** (1/p)``.
    localisation : float
        ``((1/m) sum_i d_c(x_i, y_pi(i))**p) ** (1/p)`` over the optimal assignment.
    cardinality : float
        ``((1/m) c**p |m - n|) ** (1/p)``.
    """

    distance: float
    localisation: float
    cardinality: float


def _as_points(arr: np.ndarray, name: str) -> np.ndarray:
    a = np.asarray(arr, dtype=float)
    if a.ndim == 1 and a.size == 0:
        a = a.reshape(0, 1)
    if a.ndim != 2:
        raise ValueError(f"ospa: {name} must have shape (n, d), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"ospa: {name} must be finite (got NaN or inf)")
    return a


def ospa(
    X: np.ndarray,
    Y: np.ndarray,
    cutoff: float,
    order: float = 2,
    distance: DistanceFn | None = None,
) -> OSPAResult:
    """OSPA distance between point sets ``X`` and ``Y``.

    Parameters
    ----------
    X : ndarray (n, d)
        Estimated points (e.g. speaker positions in pixels).
    Y : ndarray (m, d)
        True points. ``X`` and ``Y`` play symmetric roles.
    cutoff : float
        Cut-off ``c > 0``, in the unit of the base distance.
    order : float
        Order ``p >= 1`` (``np.inf`` allowed: then the distance is ``c`` when the sizes differ,
        else the largest assigned cut-off distance).
    distance : callable, optional
        ``distance(X, Y) -> ndarray (n, m)`` of non-negative base distances; Euclidean when
        omitted. With a callable, ``X`` and ``Y`` may hold any per-point features (e.g.
        azimuths in degrees as ``(n, 1)``).

    Returns
    -------
    OSPAResult
    """
    if not np.isfinite(cutoff) or cutoff <= 0:
        raise ValueError(f"ospa: cutoff must be a finite number > 0, got {cutoff!r}")
    if not (order >= 1):
        raise ValueError(f"ospa: order must be >= 1, got {order!r}")
    X = _as_points(X, "X")
    Y = _as_points(Y, "Y")
    n, m = len(X), len(Y)
    if n and m and distance is None and X.shape[1] != Y.shape[1]:
        raise ValueError(
            f"ospa: X and Y must have the same dimension, got {X.shape[1]} and {Y.shape[1]}"
        )
    if n == 0 and m == 0:
        return OSPAResult(0.0, 0.0, 0.0)
    if n == 0 or m == 0:
        return OSPAResult(float(cutoff), 0.0, float(cutoff))
    if distance is None:
        base = np.linalg.norm(X[:, None, :] - Y[None, :, :], axis=2)
    else:
        base = np.asarray(distance(X, Y), dtype=float)
        if base.shape != (n, m):
            raise ValueError(
                f"ospa: distance(X, Y) must return shape ({n}, {m}), got {base.shape}"
            )
        if np.any(~np.isfinite(base) | (base < 0)):
            raise ValueError("ospa: distance(X, Y) must return finite values >= 0")
    dc = np.minimum(base, cutoff)  # d^(c)(x, y) = min(c, d(x, y))
    big = max(n, m)
    if np.isinf(order):
        if n != m:
            return OSPAResult(float(cutoff), 0.0, float(cutoff))
        rows, cols = linear_sum_assignment(dc)
        loc = float(dc[rows, cols].max())
        return OSPAResult(loc, loc, 0.0)
    rows, cols = linear_sum_assignment(dc**order)  # min over assignments of sum d_c^p
    loc_p = float(np.sum(dc[rows, cols] ** order)) / big
    card_p = cutoff**order * abs(m - n) / big  # c^p (m - n) / m
    return OSPAResult(
        distance=(loc_p + card_p) ** (1 / order),
        localisation=loc_p ** (1 / order),
        cardinality=card_p ** (1 / order),
    )


def ospa_sequence(
    estimates: Sequence[np.ndarray],
    truths: Sequence[np.ndarray],
    cutoff: float,
    order: float = 2,
    distance: DistanceFn | None = None,
) -> np.ndarray:
    """OSPA of each frame of a sequence.

    Parameters
    ----------
    estimates, truths : sequences of ndarray (n_t, d) and (m_t, d)
        One point set per frame (same length).

    Returns
    -------
    ndarray (T, 3)
        Columns ``distance, localisation, cardinality`` per frame; the sequence score of
        Liu et al.'s Table 1 is the mean of the first column.
    """
    if len(estimates) != len(truths):
        raise ValueError(
            f"ospa_sequence: estimates and truths must have the same number of frames, got "
            f"{len(estimates)} and {len(truths)}"
        )
    out = np.empty((len(truths), 3))
    for t, (x, y) in enumerate(zip(estimates, truths, strict=True)):
        r = ospa(x, y, cutoff, order, distance)
        out[t] = r.distance, r.localisation, r.cardinality
    return out


# --------------------------------------------------------------------------- labelled tracks


@dataclass(frozen=True)
class OSPATResult:
    """OSPA-T of a labelled track set against the true tracks.

    Attributes
    ----------
    per_frame : ndarray (T, 3)
        Columns ``distance, localisation, cardinality`` per frame (labels included in the
        localisation part).
    labels : dict
        Estimated track id -> the true track index (0-based) it was assigned to; estimated
        tracks left out are absent (they never match a true label).
    """

    per_frame: np.ndarray
    labels: dict

    @property
    def mean(self) -> float:
        """The sequence score: mean of the per-frame distances."""
        return float(self.per_frame[:, 0].mean()) if len(self.per_frame) else 0.0


def ospa_t(
    estimates: Sequence[tuple[np.ndarray, np.ndarray]],
    truths: Sequence[np.ndarray],
    cutoff: float = 65.0,
    order: float = 2,
    label_penalty: float = 25.0,
) -> OSPATResult:
    r"""OSPA-T: OSPA over labelled tracks, so that identity switches and fragments cost.

    Ristic, Vo, Clark and Vo, "A metric for performance evaluation of multi-target tracking
    algorithms", IEEE TSP 2011, as the released evaluation of the audio-visual SMC-PHD trackers
    computes it (order 2, cut-off 65 px, label penalty 25 px):

    1. Each estimated track ``i`` is assigned to at most one true track ``j`` by one global
       assignment minimising :math:`\sum_{i} D(i, \pi(i))` with
       :math:`D(i, j) = \sum_t \min(c, \|x_t^i - y_t^j\|)^p` over frames where both exist,
       plus :math:`c^p` over frames where exactly one exists (Ristic et al. eq. 15).
       Either side may stay unassigned (matched to an always-absent dummy track, at ``c^p``
       per frame of its own). An assigned estimated track takes its true track's label; the
       others take labels no true track has.
    2. Each frame is scored by OSPA with the base distance
       :math:`\tilde d(x, y) = (\|x - y\|^p + \alpha^p\,[\ell_x \ne \ell_y])^{1/p}` cut off at
       ``c`` (Ristic et al. eq. 11 with the same order for both parts).

    Parameters
    ----------
    estimates : sequence of T pairs ``(ids (n_t,), points (n_t, d))``
        The estimated tracks' ids and positions on each frame (an estimate without identity
        is a track of its own: give it an id used nowhere else).
    truths : sequence of T ndarray (P, d)
        The true tracks' positions on each frame, NaN rows where a track is absent (a fixed
        number ``P`` of true tracks; row ``j`` is always track ``j``).
    cutoff, order, label_penalty : float
        ``c``, ``p`` and ``alpha``.

    Returns
    -------
    OSPATResult
    """
    if len(estimates) != len(truths):
        raise ValueError(
            f"ospa_t: estimates and truths must have the same number of frames, got "
            f"{len(estimates)} and {len(truths)}"
        )
    if not np.isfinite(cutoff) or cutoff <= 0 or not (order >= 1) or not np.isfinite(order):
        raise ValueError(f"ospa_t: need cutoff > 0 and a finite order >= 1, got {cutoff}, "
                         f"{order}")
    if not label_penalty >= 0:
        raise ValueError(f"ospa_t: label_penalty must be >= 0, got {label_penalty}")
    ests, track_ids, est, tru = _track_arrays(estimates, truths)
    # 1. Track-to-track assignment (Ristic et al. eq. 15).
    labels = _assign_tracks(track_ids, est, tru, cutoff, order)
    # 2. Per-frame labelled OSPA.
    out = _labelled_ospa(ests, tru, labels, cutoff, order, label_penalty)
    return OSPATResult(out, labels)


def _track_arrays(
    estimates: Sequence[tuple[np.ndarray, np.ndarray]], truths: Sequence[np.ndarray]
) -> tuple[list[tuple[np.ndarray, np.ndarray]], list[int], np.ndarray, np.ndarray]:
    """The estimates of each frame as arrays, the sorted estimated track ids, and the
    estimated ``(I, T, d)`` and true ``(P, T, d)`` tracks, NaN where a track is absent."""
    n_frames = len(truths)
    truth = [np.asarray(y, dtype=float) for y in truths]
    n_true = max((y.shape[0] for y in truth), default=0)
    dim = max((y.shape[1] for y in truth if y.ndim == 2), default=2)
    # Estimated tracks as (T, d) arrays with NaN where absent.
    ests: list[tuple[np.ndarray, np.ndarray]] = []
    for t, (ids, pts) in enumerate(estimates):
        ids = np.asarray(ids).reshape(-1)
        pts = np.asarray(pts, dtype=float).reshape(len(ids), -1) if len(ids) else np.zeros(
            (0, dim))
        if len(np.unique(ids)) != len(ids):
            raise ValueError(f"ospa_t: frame {t} repeats an estimated track id")
        ests.append((ids, pts))
    track_ids = sorted({int(i) for ids, _ in ests for i in ids})
    col = {tid: k for k, tid in enumerate(track_ids)}
    est = np.full((len(track_ids), n_frames, dim), np.nan)
    for t, (ids, pts) in enumerate(ests):
        for i, p in zip(ids, pts, strict=True):
            est[col[int(i)], t] = p
    tru = np.full((n_true, n_frames, dim), np.nan)
    for t, y in enumerate(truth):
        if y.size:
            tru[: y.shape[0], t] = y
    return ests, track_ids, est, tru


def _assign_tracks(
    track_ids: list[int], est: np.ndarray, tru: np.ndarray, cutoff: float, order: float
) -> dict:
    """The true track (row of ``tru``) assigned to each estimated track id, by the global
    assignment of Ristic et al. eq. 15; unassigned tracks are left out."""
    n_true = tru.shape[0]
    labels: dict = {}
    if len(track_ids) and n_true:
        e_on = np.all(np.isfinite(est), axis=2)  # (I, T)
        y_on = np.all(np.isfinite(tru), axis=2)  # (J, T)
        cost = np.zeros((len(track_ids), n_true))
        cp = cutoff**order
        for j in range(n_true):
            d = np.linalg.norm(est - tru[j][None], axis=2)  # (I, T), NaN unless both exist
            both = e_on & y_on[j][None]
            one = e_on ^ y_on[j][None]
            cost[:, j] = (np.where(both, np.minimum(np.nan_to_num(d), cutoff) ** order, 0.0)
                          .sum(1) + cp * one.sum(1))
        # Dummy tracks (never present) on both sides, so that a track may stay unassigned
        # at the cost of its frames alone.
        n_est = len(track_ids)
        full = np.zeros((n_est + n_true, n_true + n_est))
        full[:n_est, :n_true] = cost
        full[:n_est, n_true:] = (cp * e_on.sum(1))[:, None]
        full[n_est:, :n_true] = (cp * y_on.sum(1))[None, :]
        rows, cols = linear_sum_assignment(full)
        labels = {track_ids[r]: int(c) for r, c in zip(rows, cols, strict=True)
                  if r < n_est and c < n_true}
    return labels


def _labelled_ospa(
    ests: list[tuple[np.ndarray, np.ndarray]],
    tru: np.ndarray,
    labels: dict,
    cutoff: float,
    order: float,
    label_penalty: float,
) -> np.ndarray:
    """``(T, 3)`` per-frame labelled OSPA: distance, localization and cardinality parts
    (Ristic et al. eq. 11)."""
    n_frames = tru.shape[1]
    out = np.zeros((n_frames, 3))
    for t in range(n_frames):
        ids, pts = ests[t]
        y = tru[:, t]
        on = np.all(np.isfinite(y), axis=1)
        Y, ylab = y[on], np.nonzero(on)[0]
        xlab = np.array([labels.get(int(i), -1 - int(k)) for k, i in enumerate(ids)])
        n, m = len(pts), len(Y)
        if n == 0 and m == 0:
            continue
        if n == 0 or m == 0:
            out[t] = cutoff, 0.0, cutoff
            continue
        d = np.linalg.norm(pts[:, None, :] - Y[None, :, :], axis=2) ** order
        d = d + label_penalty**order * (xlab[:, None] != ylab[None, :])
        dc = np.minimum(d ** (1 / order), cutoff) ** order
        r, c = linear_sum_assignment(dc)
        big = max(n, m)
        loc_p = float(dc[r, c].sum()) / big
        card_p = cutoff**order * abs(n - m) / big
        out[t] = (loc_p + card_p) ** (1 / order), loc_p ** (1 / order), card_p ** (1 / order)
    return out
