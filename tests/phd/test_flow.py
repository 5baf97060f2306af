"""The particle flow (Liu et al. eqs. 6–9): Kalman-update parity on a linear-Gaussian single
target, the Jacobian determinant, and the mixture flow's reduction to the affine one."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.phd.flow import affine_flow, flow_steps, mixture_flow
from avtrack.phd.likelihood import audio_information, visual_information

MU0 = np.array([100.0, 50.0, 1.0, -1.0])
P0 = np.array(
    [[25.0, 3.0, 4.0, 0.0], [3.0, 16.0, 0.0, 2.0], [4.0, 0.0, 2.0, 0.0], [0.0, 2.0, 0.0, 1.5]]
)
SIGMA = 4.0
Z = np.array([110.0, 45.0])


def kalman(mu, P, H, R, z):
    """Kalman update: mu + K (z - H mu), (I - K H) P."""
    K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
    return mu + K @ (z - H @ mu), (np.eye(len(mu)) - K @ H) @ P


def visual_problem():
    A, b = visual_information(Z[None], SIGMA)
    B = np.zeros((1, 4, 2))
    B[0, 0, 0] = B[0, 1, 1] = 1 / SIGMA
    H = np.eye(2, 4)
    return A, b, B, *kalman(MU0, P0, H, SIGMA**2 * np.eye(2), Z)


def run(states, A, b, B, steps, diffusion=0.0, rng=None):
    group = np.zeros(len(states), dtype=int)
    return affine_flow(states, group, np.linalg.inv(P0)[None], A, b, B, steps, diffusion, rng)


def test_flow_steps():
    s = flow_steps(10, 1.2)
    assert s.shape == (10,) and s.sum() == pytest.approx(1) and np.all(np.diff(s) > 0)
    with pytest.raises(ValueError, match="n_steps must be an integer >= 1"):
        flow_steps(0)
    with pytest.raises(ValueError, match="ratio must be > 0"):
        flow_steps(3, 0.0)


def test_zero_diffusion_moves_the_prior_mean_to_the_kalman_mean():
    A, b, B, mu_post, _ = visual_problem()
    errs = []
    for n in (25, 100, 400):
        m, _ = run(MU0[None], A, b, B, flow_steps(n, 1.0))
        errs.append(np.abs(m[0] - mu_post).max())
    assert errs[-1] < 0.01  # pixels (and pixels per frame for the velocity)
    assert errs[0] > errs[1] > errs[2]  # converges with the number of steps
    assert np.abs(MU0 - mu_post).max() > 5  # ... from a prior mean 5+ px away


def test_diffusion_gives_the_kalman_posterior_distribution():
    A, b, B, mu_post, P_post = visual_problem()
    rng = np.random.default_rng(0)
    x0 = rng.multivariate_normal(MU0, P0, size=20000)
    m, _ = run(x0, A, b, B, flow_steps(60, 1.0), diffusion=1.0, rng=rng)
    se = np.sqrt(np.diag(P_post) / len(m))
    np.testing.assert_array_less(np.abs(m.mean(0) - mu_post), 5 * se + 0.02)
    d = np.sqrt(np.diag(P_post))
    se_cov = np.sqrt((np.outer(d, d) ** 2 + P_post**2) / len(m))  # sampling error of a covariance
    np.testing.assert_array_less(np.abs(np.cov(m.T) - P_post), 4 * se_cov + 0.02 * np.abs(P_post))
    # without diffusion the mean is right but the spread collapses below the posterior's
    m0, _ = run(x0, A, b, B, flow_steps(60, 1.0))
    assert np.trace(np.cov(m0.T)) < 0.8 * np.trace(P_post)


def test_doa_line_flow_matches_the_scalar_kalman_update():
    n = np.array([0.6, 0.8])
    line = np.array([[*n, n @ np.array([110.0, 55.0])]])
    A, b = audio_information(line, SIGMA)
    B = np.zeros((1, 4, 1))
    B[0, :2, 0] = n / SIGMA
    H = np.zeros((1, 4))
    H[0, :2] = n
    mu_post, _ = kalman(MU0, P0, H, np.array([[SIGMA**2]]), line[0, 2:])
    m, _ = run(MU0[None], A, b, B, flow_steps(400, 1.0))
    np.testing.assert_allclose(m[0], mu_post, atol=0.01)
    # the particle ends up close to the line (it started 10 px away)
    assert abs(m[0, :2] @ n - line[0, 2]) < abs(MU0[:2] @ n - line[0, 2]) / 2


def test_log_det_is_the_jacobian_of_the_map():
    A, b, B, *_ = visual_problem()
    steps = flow_steps(10)
    x = MU0[None] + np.array([[0.5, -1.0, 0.1, 0.0]])
    m, log_det = run(x, A, b, B, steps)
    h = 1e-4
    J = np.column_stack([(run(x + h * e, A, b, B, steps)[0][0] - m[0]) / h for e in np.eye(4)])
    assert log_det[0] == pytest.approx(np.log(abs(np.linalg.det(J))), rel=1e-6)
    assert log_det[0] < 0  # the flow contracts towards the measurement


def test_mixture_flow_with_one_component_is_the_affine_flow():
    A, b, B, *_ = visual_problem()
    x = np.random.default_rng(1).multivariate_normal(MU0, P0, size=50)
    steps = flow_steps(8)
    m1, d1 = run(x, A, b, B, steps)
    info = np.broadcast_to(np.linalg.inv(P0), (50, 4, 4)).copy()
    m2, d2 = mixture_flow(x, info, A, b, np.zeros(1), B, steps, diffusion=0.0)
    np.testing.assert_allclose(m2, m1, atol=1e-9)
    np.testing.assert_allclose(d2, d1, atol=1e-9)


def test_mixture_flow_floor_and_allowed_mask_stop_far_pulls():
    A, b, B, *_ = visual_problem()
    far = np.array([[300.0, 250.0, 0.0, 0.0]])  # 200+ px from the only component
    info = np.linalg.inv(P0)[None]
    moved, _ = mixture_flow(far, info, A, b, np.zeros(1), B, flow_steps(5), log_floor=-5.0,
                            diffusion=0.0)  # fmt: skip
    np.testing.assert_allclose(moved, far, atol=1e-9)
    moved, log_det = mixture_flow(far, info, A, b, np.zeros(1), B, flow_steps(5),
                                  diffusion=0.0, allowed=np.zeros((1, 1), bool))  # fmt: skip
    np.testing.assert_allclose(moved, far)
    assert log_det[0] == 0


def test_bad_input():
    A, b, B, *_ = visual_problem()
    x = MU0[None]
    info = np.linalg.inv(P0)[None]
    with pytest.raises(ValueError, match="group must have shape"):
        affine_flow(x, np.zeros(2, int), info, A, b, B, flow_steps(2))
    with pytest.raises(ValueError, match=r"group must be in 0\.\.0"):
        affine_flow(x, np.ones(1, int), info, A, b, B, flow_steps(2))
    with pytest.raises(ValueError, match="A must have shape"):
        affine_flow(x, np.zeros(1, int), info, A[:, :2], b, B, flow_steps(2))
    with pytest.raises(ValueError, match="rng is required"):
        affine_flow(x, np.zeros(1, int), info, A, b, B, flow_steps(2), diffusion=1.0)
    with pytest.raises(ValueError, match="prior_info must have shape"):
        mixture_flow(x, info[0], A, b, np.zeros(1), B, flow_steps(2), diffusion=0.0)
    with pytest.raises(ValueError, match="allowed must have shape"):
        mixture_flow(x, info, A, b, np.zeros(1), B, flow_steps(2), diffusion=0.0,
                     allowed=np.ones((2, 1), bool))  # fmt: skip
