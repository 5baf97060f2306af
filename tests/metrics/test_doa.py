"""Frame-wise DOA metrics of thesis §5.5.1: worked examples and invariants."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avtrack.io.doa import DOATable
from avtrack.metrics.doa import (
    DOAScores,
    angular_error,
    evaluate_doa,
    greedy_match,
    roc_sweep,
)


def table(rows):
    """rows: (frame, id, azimuth, weight, active); time = 0.008 frame."""
    r = np.array(rows, dtype=float).reshape(-1, 5)
    return DOATable(
        r[:, 0].astype(int),
        0.008 * r[:, 0],
        r[:, 1].astype(int),
        r[:, 2],
        np.zeros(len(r)),
        r[:, 3],
        r[:, 4].astype(bool),
    )


def test_angular_error_wraps():
    np.testing.assert_allclose(
        angular_error([170, -170, 10, 0], [-170, 170, 350, 180]), [20, 20, 20, 180]
    )


def test_greedy_match_picks_the_smallest_difference_first():
    # estimates 0 and 12; speakers 10 and 40: (12, 10) first (2 deg), then (0, 40)
    ei, ti, err = greedy_match(np.array([0.0, 12.0]), np.array([10.0, 40.0]))
    np.testing.assert_array_equal(ei, [1, 0])
    np.testing.assert_array_equal(ti, [0, 1])
    np.testing.assert_allclose(err, [2.0, 40.0])
    assert greedy_match(np.array([]), np.array([5.0]))[0].size == 0


def test_worked_example():
    truth = table(
        [
            (1, 1, 10.0, 1, 1),
            (1, 2, 100.0, 1, 1),  # two speakers
            (2, 1, 10.0, 1, 1),
            (2, 2, 100.0, 1, 0),  # speaker 2 silent
            (3, 1, 10.0, 1, 0),  # nobody speaks
        ]
    )
    est = table(
        [
            (1, -1, 14.0, 0.9, 1),
            (1, -1, 130.0, 0.5, 1),  # success (4 deg) + a 30 deg miss
            (2, -1, 8.0, 0.8, 1),
            (2, -1, -60.0, 0.3, 1),  # success (2 deg) + a false alarm
            (3, -1, 50.0, 0.2, 1),  # false alarm
            (4, -1, 0.0, 0.9, 1),  # frame without ground truth rows
        ]
    )
    s = evaluate_doa(est, truth)
    # actual: 3; detected: 6; success: 2 -> MD = 1, FA = 4
    assert (s.n_actual, s.n_detected, s.n_success) == (3, 6, 2)
    assert (s.n_missed, s.n_false_alarms, s.n_frames) == (1, 4, 4)
    assert s.md_rate == pytest.approx(1 / 3) and s.fa_rate == pytest.approx(4 / 3)
    assert s.mae == pytest.approx(3.0)
    # threshold on the weights instead of the active flag
    s2 = evaluate_doa(est, truth, threshold=0.6)
    assert (s2.n_detected, s2.n_success, s2.n_false_alarms) == (3, 2, 1)
    # the success threshold is inclusive
    assert evaluate_doa(est, truth, success_deg=30.0).n_success == 3
    # a time window
    assert evaluate_doa(est, truth, time_range_s=(0.015, 0.02)).n_frames == 1


def test_scores_add_as_components():
    a = DOAScores(10, 8, 6, 12.0, 5)
    b = DOAScores(20, 30, 10, 10.0, 7)
    c = a + b
    assert c == DOAScores(30, 38, 16, 22.0, 12)
    assert c.md_rate == pytest.approx(14 / 30) and c.mae == pytest.approx(22 / 16)
    assert np.isnan(DOAScores(0, 0, 0, 0.0).md_rate) and np.isnan(DOAScores(1, 0, 0, 0.0).mae)
    assert c.as_dict()["MD%"] == pytest.approx(100 * 14 / 30)


@settings(max_examples=50, deadline=None)
@given(st.integers(0, 10_000))
def test_metrics_are_invariant_to_relabelling_and_row_order(seed):
    rng = np.random.default_rng(seed)
    n_gt, n_est = 30, 40
    truth = table(
        np.c_[
            rng.integers(0, 6, n_gt),
            rng.integers(1, 4, n_gt),
            rng.uniform(-180, 180, n_gt),
            np.ones(n_gt),
            rng.integers(0, 2, n_gt),
        ]
    )
    est = table(
        np.c_[
            rng.integers(0, 6, n_est),
            -np.ones(n_est),
            rng.uniform(-180, 180, n_est),
            rng.uniform(0, 1, n_est),
            rng.integers(0, 2, n_est),
        ]
    )
    s = evaluate_doa(est, truth)
    perm_t, perm_e = rng.permutation(n_gt), rng.permutation(n_est)
    truth2 = truth.select(perm_t)
    truth2 = DOATable(
        truth2.frames,
        truth2.time_s,
        rng.integers(5, 9, n_gt),
        truth2.azimuth_deg,
        truth2.elevation_deg,
        truth2.weight,
        truth2.active,
    )
    assert evaluate_doa(est.select(perm_e), truth2) == s
    # the vectorised matching equals the per-frame greedy_match
    success = 0
    for f in range(6):
        e = est.azimuth_deg[(est.frames == f) & est.active]
        t = truth.azimuth_deg[(truth.frames == f) & truth.active]
        success += int(np.sum(greedy_match(e, t)[2] <= 15.0))
    assert s.n_success == success


def test_roc_sweep_is_monotone_and_picks_the_balanced_point():
    truth = table([(f, 1, 20.0, 1, 1) for f in range(10)])
    est = table(
        [(f, -1, 21.0, 0.5, 1) for f in range(10)]
        + [(f, -1, -90.0, 0.1 * (f % 3), 1) for f in range(10)]
    )
    curve = roc_sweep(est, truth, thresholds=[0.0, 0.15, 0.3, 0.6])
    assert np.all(np.diff(curve.fa_rate) <= 0) and np.all(np.diff(curve.md_rate) >= 0)
    thr, best = curve.best
    assert thr == 0.3 and best.md_rate == 0.0 and best.fa_rate == 0.0
    np.testing.assert_allclose(curve.mae[:3], 1.0)
    with pytest.raises(ValueError, match="thresholds must be"):
        roc_sweep(est, truth, thresholds=[])


def test_bad_arguments():
    t = table([(0, 1, 0.0, 1, 1)])
    with pytest.raises(TypeError, match="DOATables"):
        evaluate_doa([], t)
    with pytest.raises(ValueError, match="period_s must be > 0"):
        evaluate_doa(t, t, period_s=0.0)
    with pytest.raises(ValueError, match="finite"):
        greedy_match(np.array([np.nan]), np.array([0.0]))


def _moving(n: int, speed_deg_s: float, period: float = 0.008, delay: int = 0) -> DOATable:
    """A talker turning at ``speed_deg_s`` from -60°, reported ``delay`` frames late."""
    frames = np.arange(n)
    t = frames * period
    az = -60.0 + speed_deg_s * np.maximum(t - delay * period, 0.0)
    ones = np.ones(n)
    return DOATable(frames, t, ones.astype(int), az, 0 * ones, ones, ones.astype(bool))


@pytest.mark.parametrize("delay", [0, 7, 30, -5])
def test_estimate_lag_finds_a_hand_built_shift(delay):
    from avtrack.metrics.doa import estimate_lag

    truth = _moving(500, 30.0)
    est = _moving(500, 30.0, delay=delay)
    res = estimate_lag(est, truth, max_shift_frames=40)
    assert res.lag_frames == delay
    assert res.lag_s == pytest.approx(delay * 0.008)
    assert res.mae[res.shifts == delay][0] < 0.05
    if delay:
        assert res.mae_at_zero == pytest.approx(abs(delay) * 0.008 * 30.0, rel=0.05)


def test_estimate_lag_of_a_still_talker_is_zero_and_bad_input_raises():
    from avtrack.metrics.doa import estimate_lag

    truth = _moving(100, 0.0)
    assert estimate_lag(truth, truth, max_shift_frames=10).lag_frames == 0
    for bad in (-1, 2.5, True):
        with pytest.raises(ValueError, match="max_shift_frames"):
            estimate_lag(truth, truth, max_shift_frames=bad)
    far = DOATable(truth.frames, truth.time_s, truth.ids, truth.azimuth_deg + 90,
                   truth.elevation_deg, truth.weight, truth.active)  # fmt: skip
    with pytest.raises(ValueError, match="no successful estimate"):
        _ = estimate_lag(far, truth, max_shift_frames=3).lag_frames
