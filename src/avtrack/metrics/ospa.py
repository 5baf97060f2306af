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
