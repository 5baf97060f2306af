"""Tests of avtrack.vem.dynamics: the constant-velocity transition, the size-adaptive
dynamics covariance and the covariance cap (SPD kept, diagonal bounded)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from avtrack.vem.dynamics import (
    box_dynamics_covariance,
    cap_box_covariance,
    constant_velocity_transition,
)


def test_box_transition_by_hand():
    d = constant_velocity_transition(4, 2)
    expected = np.eye(6)
    expected[0, 4] = 1.0  # x += ẋ
    expected[1, 5] = 1.0  # y += ẏ
    np.testing.assert_array_equal(d, expected)
    s = np.array([10.0, 20.0, 30.0, 60.0, 2.0, -1.0])
    np.testing.assert_array_equal(d @ s, [12.0, 19.0, 30.0, 60.0, 2.0, -1.0])


def test_transition_with_time_step_and_no_velocity():
    np.testing.assert_array_equal(constant_velocity_transition(1, 1, dt=0.5),
                                  [[1.0, 0.5], [0.0, 1.0]])
    np.testing.assert_array_equal(constant_velocity_transition(3, 0), np.eye(3))


@pytest.mark.parametrize(("n_obs", "n_vel", "dt", "match"), [
    (2, 3, 1.0, "n_vel <= n_obs"),
    (0, 0, 1.0, "n_obs >= 1"),
    (2, -1, 1.0, "0 <= n_vel"),
    (4, 2, 0.0, "dt must be > 0, got 0.0"),
    (4, 2, float("nan"), "dt must be > 0, got nan"),
])
def test_transition_bad_arguments(n_obs, n_vel, dt, match):
    with pytest.raises(ValueError, match=match):
        constant_velocity_transition(n_obs, n_vel, dt)


def test_box_dynamics_covariance_by_hand():
    mu = np.array([[100.0, 50.0, 20.0, 40.0, 1.0, 1.0]])
    cov = box_dynamics_covariance(mu, pos=0.1, size=0.2, vel=0.05)
    # stds (0.1·20, 0.1·40, 0.2·20, 0.2·40, 0.05·20, 0.05·40) = (2, 4, 4, 8, 1, 2)
    np.testing.assert_allclose(cov[0], np.diag([4.0, 16.0, 16.0, 64.0, 1.0, 4.0]), rtol=1e-14)


def test_box_dynamics_covariance_scales_with_box_size():
    rng = np.random.default_rng(0)
    mu = np.column_stack([rng.uniform(0, 500, (5, 2)), rng.uniform(5, 200, (5, 2)),
                          rng.normal(size=(5, 2))])
    big = mu.copy()
    big[:, 2:4] *= 3.0
    cov, cov_big = box_dynamics_covariance(mu), box_dynamics_covariance(big)
    np.testing.assert_allclose(cov_big, 9.0 * cov, rtol=1e-12)  # std × 3 -> variance × 9
    assert np.all(np.linalg.eigvalsh(cov) > 0)
    # positions and velocities do not matter; sizes below one pixel count as one pixel
    moved = mu.copy()
    moved[:, [0, 1, 4, 5]] += 7.0
    np.testing.assert_array_equal(box_dynamics_covariance(moved), cov)
    tiny = mu.copy()
    tiny[:, 2:4] = 0.0
    np.testing.assert_allclose(box_dynamics_covariance(tiny),
                               box_dynamics_covariance(np.ones_like(mu)))


def test_cap_by_hand():
    mu = np.array([[0.0, 0.0, 10.0, 20.0, 0.0, 0.0]])
    gamma = np.diag([400.0, 1.0, 1.0, 1.0, 1.0, 1.0])[None]
    gamma[0, 0, 1] = gamma[0, 1, 0] = 10.0  # correlation 0.5
    capped = cap_box_covariance(mu, gamma, max_std=0.5)
    # x std 20 > cap 0.5·10 = 5: scale 1/4 -> variance 25, covariance 10/4; others unchanged
    expected = gamma.copy()
    expected[0, 0, 0] = 25.0
    expected[0, 0, 1] = expected[0, 1, 0] = 2.5
    np.testing.assert_allclose(capped, expected, rtol=1e-14)


@settings(max_examples=50, deadline=None)
@given(
    a=hnp.arrays(np.float64, (3, 6, 6), elements=st.floats(-30, 30)),
    wh=hnp.arrays(np.float64, (3, 2), elements=st.floats(2, 300)),
    max_std=st.floats(0.05, 2.0),
)
def test_cap_keeps_spd_and_bounds_the_diagonal(a, wh, max_std):
    gamma = a @ np.swapaxes(a, 1, 2) + 0.1 * np.eye(6)
    mu = np.zeros((3, 6))
    mu[:, 2:4] = wh
    capped = cap_box_covariance(mu, gamma, max_std)
    np.testing.assert_allclose(capped, np.swapaxes(capped, 1, 2), rtol=0, atol=1e-12)
    assert np.all(np.linalg.eigvalsh(capped) > 0)
    cap = max_std * np.concatenate([wh, wh, wh], axis=1)
    assert np.all(np.diagonal(capped, axis1=1, axis2=2) <= cap**2 * (1 + 1e-12))
    # correlations are kept
    def corr(g):
        s = np.sqrt(np.diagonal(g, axis1=1, axis2=2))
        return g / s[:, :, None] / s[:, None, :]
    np.testing.assert_allclose(corr(capped), corr(gamma), rtol=1e-9, atol=1e-12)


def test_cap_bad_max_std():
    with pytest.raises(ValueError, match="max_std must be > 0, got 0"):
        cap_box_covariance(np.zeros((1, 6)), np.eye(6)[None], 0.0)
