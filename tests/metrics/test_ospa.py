"""OSPA: hand-computed cases, invariants, custom base distances, Stone Soup parity."""

from __future__ import annotations

import datetime

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from avtrack.metrics.ospa import OSPAResult, ospa, ospa_sequence


def test_single_pair_is_the_distance():
    r = ospa(np.array([[0.0, 0.0]]), np.array([[3.0, 4.0]]), cutoff=50)
    assert r == OSPAResult(5.0, 5.0, 0.0)


def test_empty_sets():
    assert ospa(np.zeros((0, 2)), np.zeros((0, 2)), 50) == OSPAResult(0.0, 0.0, 0.0)
    assert ospa(np.zeros((0, 2)), np.ones((2, 2)), 50).distance == 50
    assert ospa(np.ones((3, 2)), np.zeros((0, 2)), 7.5) == OSPAResult(7.5, 0.0, 7.5)


def test_hand_computed_cardinality_and_cutoff():
    # X = {(0,0), (10,0)}, Y = {(3,4)}, c = 10, p = 2: best assignment (0,0)->(3,4) at 5,
    # one missed point at c: sqrt((5^2 + 10^2) / 2)
    r = ospa(np.array([[0.0, 0], [10, 0]]), np.array([[3.0, 4]]), cutoff=10)
    assert r.distance == pytest.approx(np.sqrt(62.5), abs=1e-12)
    assert r.localisation == pytest.approx(np.sqrt(12.5), abs=1e-12)
    assert r.cardinality == pytest.approx(np.sqrt(50.0), abs=1e-12)
    # distances beyond the cut-off count as c
    assert ospa(np.array([[0.0, 0]]), np.array([[100.0, 0]]), 50).distance == 50


def test_assignment_is_optimal_not_greedy():
    # greedy nearest-first would pair (0,0)-(1,0) then (2,0)-(-2,0): 1 + 16; optimal 9 + 1
    X = np.array([[0.0, 0], [2, 0]])
    Y = np.array([[1.0, 0], [-2, 0]])
    assert ospa(X, Y, 100).distance == pytest.approx(np.sqrt((4 + 1) / 2))


def test_order_one_and_infinity():
    X = np.array([[0.0, 0], [10, 0]])
    Y = np.array([[3.0, 4]])
    assert ospa(X, Y, 10, order=1).distance == pytest.approx((5 + 10) / 2)
    assert ospa(X, Y, 10, order=np.inf).distance == 10
    assert ospa(X[:1], Y, 10, order=np.inf).distance == 5


def test_custom_angular_distance():
    def angular(a, b):
        d = np.abs(a[:, None, 0] - b[None, :, 0]) % 360
        return np.minimum(d, 360 - d)

    r = ospa(np.array([[170.0]]), np.array([[-170.0], [0.0]]), cutoff=30, distance=angular)
    assert r.distance == pytest.approx(np.sqrt((20**2 + 30**2) / 2))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"cutoff": 0}, "cutoff must be"),
        ({"cutoff": np.inf}, "cutoff must be"),
        ({"order": 0.5}, "order must be >= 1"),
        ({"X": np.zeros((2, 3))}, "same dimension"),
        ({"X": np.array([[np.nan, 0.0]])}, "X must be finite"),
        ({"Y": np.zeros(3)}, "Y must have shape"),
        ({"distance": lambda a, b: np.zeros((1, 1))}, r"must return shape \(2, 1\)"),
        ({"distance": lambda a, b: -np.ones((2, 1))}, "finite values >= 0"),
    ],
)
def test_bad_input(kwargs, message):
    args = {"X": np.zeros((2, 2)), "Y": np.ones((1, 2)), "cutoff": 5.0} | kwargs
    with pytest.raises(ValueError, match=message):
        ospa(**args)


points = arrays(np.float64, st.tuples(st.integers(0, 5), st.just(2)),
                elements=st.floats(-100, 100))  # fmt: skip


@settings(max_examples=60, deadline=None)
@given(X=points, Y=points, seed=st.integers(0, 2**16))
def test_invariants(X, Y, seed):
    r = ospa(X, Y, 20.0)
    # symmetric, invariant to relabelling, bounded by c, split into its two parts
    perm = np.random.default_rng(seed).permutation(len(X))
    assert ospa(Y, X, 20.0).distance == pytest.approx(r.distance, abs=1e-9)
    assert ospa(X[perm], Y, 20.0).distance == pytest.approx(r.distance, abs=1e-9)
    assert 0 <= r.distance <= 20.0 + 1e-9
    assert r.distance**2 == pytest.approx(r.localisation**2 + r.cardinality**2, abs=1e-9)


def test_matches_stone_soup():
    from stonesoup.measures import Euclidean
    from stonesoup.metricgenerator.ospametric import OSPAMetric
    from stonesoup.types.state import State

    rng = np.random.default_rng(0)
    t = datetime.datetime(2024, 1, 1)
    for cutoff, order in [(50.0, 2), (10.0, 1), (30.0, 3)]:
        metric = OSPAMetric(c=cutoff, p=order, measure=Euclidean((0, 1)))
        for _ in range(20):
            X = rng.uniform(0, 100, (rng.integers(1, 6), 2))
            Y = rng.uniform(0, 100, (rng.integers(1, 6), 2))
            ref = metric.compute_OSPA_distance(
                [State(x[:, None], timestamp=t) for x in X],
                [State(y[:, None], timestamp=t) for y in Y],
            ).value
            assert ospa(X, Y, cutoff, order).distance == pytest.approx(ref, rel=1e-12)


def test_sequence():
    est = [np.zeros((0, 2)), np.array([[0.0, 0.0]]), np.array([[0.0, 0.0]])]
    gt = [np.zeros((0, 2)), np.array([[3.0, 4.0]]), np.zeros((0, 2))]
    out = ospa_sequence(est, gt, 50)
    np.testing.assert_allclose(out, [[0, 0, 0], [5, 5, 0], [50, 0, 50]])
    with pytest.raises(ValueError, match="same number of frames"):
        ospa_sequence(est, gt[:2], 50)


# --------------------------------------------------------------------------- OSPA-T


def _tracks(*frames):
    """Frames of ``{id: (x, y)}`` -> the ``(ids, points)`` pairs ospa_t takes."""
    return [(np.array(list(f), dtype=int), np.array(list(f.values()), dtype=float).reshape(-1, 2))
            for f in frames]


def test_ospa_t_hand_cases():
    from avtrack.metrics.ospa import ospa_t

    truth = [np.array([[0.0, 0.0], [100.0, 0.0]])] * 4
    # Two tracks 3 px off, labels kept: the distance is 3 every frame.
    est = _tracks(*[{7: (3, 0), 9: (100, 3)}] * 4)
    r = ospa_t(est, truth, cutoff=65, order=2, label_penalty=25)
    assert r.labels == {7: 0, 9: 1}
    assert r.mean == pytest.approx(3.0)
    # Track 7 becomes track 8 on the last frame: 7 covers more of true track 0, so 8 matches
    # no true track and on that frame one of two pairs costs sqrt(3^2 + 25^2):
    # OSPA = sqrt((634 + 9) / 2).
    est = _tracks(*[{7: (3, 0), 9: (100, 3)}] * 3, {8: (3, 0), 9: (100, 3)})
    r = ospa_t(est, truth, 65, 2, 25)
    assert r.labels == {7: 0, 9: 1}
    assert r.per_frame[:3, 0] == pytest.approx([3.0] * 3)
    assert r.per_frame[3, 0] == pytest.approx(np.sqrt((634 + 9) / 2))
    # A missed target costs the cut-off in the cardinality part: sqrt(65^2 / 2).
    est = _tracks(*[{9: (100, 0)}] * 4)
    r = ospa_t(est, truth, 65, 2, 25)
    assert r.per_frame[:, 0] == pytest.approx([np.sqrt(65**2 / 2)] * 4)
    assert r.per_frame[:, 2] == pytest.approx([np.sqrt(65**2 / 2)] * 4)
    # Absent truth (NaN row) and no estimate: 0; a false track alone: the cut-off.
    truth2 = [np.array([[np.nan, np.nan]]), np.array([[np.nan, np.nan]])]
    r = ospa_t(_tracks({}, {5: (1, 1)}), truth2, 65, 2, 25)
    assert r.per_frame[:, 0] == pytest.approx([0.0, 65.0])


def test_ospa_t_without_label_penalty_is_ospa():
    from avtrack.metrics.ospa import ospa, ospa_t

    rng = np.random.default_rng(3)
    truth = [rng.uniform(0, 100, (3, 2)) for _ in range(6)]
    est = [(rng.permutation(5)[:k], rng.uniform(0, 100, (k, 2))) for k in (0, 1, 2, 3, 4, 2)]
    r = ospa_t(est, truth, 40, 2, label_penalty=0.0)
    plain = [ospa(p, y, 40, 2).distance for (_, p), y in zip(est, truth, strict=True)]
    assert r.per_frame[:, 0] == pytest.approx(plain)


def test_ospa_t_rejects_bad_input():
    from avtrack.metrics.ospa import ospa_t

    with pytest.raises(ValueError, match="same number of frames"):
        ospa_t(_tracks({1: (0, 0)}), [], 65)
    with pytest.raises(ValueError, match="repeats"):
        ospa_t([(np.array([1, 1]), np.zeros((2, 2)))], [np.zeros((1, 2))], 65)
    with pytest.raises(ValueError, match="cutoff"):
        ospa_t(_tracks({1: (0, 0)}), [np.zeros((1, 2))], 0)


def test_ospa_t_more_true_than_estimated_tracks():
    """Two true tracks, one estimate that follows the second: it takes the second's label;
    the first is missed on every frame."""
    from avtrack.metrics.ospa import ospa_t

    truth = [np.array([[0.0, 0.0], [100.0, 0.0]])] * 3
    est = _tracks(*[{4: (100, 4)}] * 3)
    r = ospa_t(est, truth, 65, 2, 25)
    assert r.labels == {4: 1}
    assert r.per_frame[:, 0] == pytest.approx([np.sqrt((16 + 65**2) / 2)] * 3)
