"""Tests of avtrack.vem.birth: the birth statistic of thesis eq. 3.30 against a brute-force
joint-Gaussian computation and an independent Kalman filter, smooth vs. jumpy sequences, gating,
and the greedy selection of non-overlapping sequences."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.linalg import block_diag
from scipy.stats import multivariate_normal

from avtrack.vem.birth import BirthCandidate, birth_candidates, select_births
from avtrack.vem.dynamics import box_dynamics_covariance, constant_velocity_transition
from avtrack.visual.model import box_observation_variance

# The tracker's call (OVBTracker._birth with the default OVBTConfig).
D = constant_velocity_transition(4, 2)
P = np.hstack([np.eye(4), np.zeros((4, 2))])  # observed components: (x, y, w, h)
LOG_U = -2.0 * np.log(640.0 * 480.0)  # uniform clutter density of a 640x480 image


def dyn_cov(mu: np.ndarray) -> np.ndarray:
    return box_dynamics_covariance(mu, 0.05, 0.05, 0.05)


def velocity_var(z: np.ndarray) -> np.ndarray:
    return (0.05 * np.maximum(z[:, 2:4], 1.0)) ** 2


def pools_from(frames: list[np.ndarray]) -> list[tuple[np.ndarray, np.ndarray]]:
    """``(z, var)`` pools from per-frame box arrays ``(M_k, 4)``."""
    out = []
    for z in frames:
        z = np.asarray(z, dtype=float).reshape(-1, 4)
        out.append((z, box_observation_variance(z)))
    return out


def smooth_track(x0=100.0, y0=200.0, vx=2.0, vy=1.0, w=40.0, h=90.0, n=4) -> np.ndarray:
    k = np.arange(n)[:, None]
    return np.hstack([x0 + vx * k, y0 + vy * k, np.full((n, 1), w), np.full((n, 1), h)])


def prior(z0: np.ndarray, var0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """p(s_{t-B}): centred at the first box, observation variance, velocity prior."""
    m0 = np.concatenate([z0, np.zeros(2)])
    g0 = np.diag(np.concatenate([var0, velocity_var(z0[None])[0]]))
    return m0, g0


def kalman_llr(boxes: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Prediction-error decomposition by a plain Kalman filter loop (independent of the code)."""
    var = box_observation_variance(boxes)
    mu, gamma = prior(boxes[0], var[0])
    total = 0.0
    for z, v in zip(boxes[1:], var[1:], strict=True):
        lam = dyn_cov(mu[None])[0]
        mu, gamma = D @ mu, D @ gamma @ D.T + lam  # predict
        r = np.diag(v)
        s = P @ gamma @ P.T + r
        total += multivariate_normal.logpdf(z, P @ mu, s)  # log p(o_k | o_{0:k-1})
        k = gamma @ P.T @ np.linalg.inv(s)
        mu = mu + k @ (z - P @ mu)
        gamma = (np.eye(6) - k @ P) @ gamma
    return total - (len(boxes) - 1) * LOG_U, mu, gamma


def joint_gaussian_llr(boxes: np.ndarray, lam: np.ndarray) -> float:
    """log N(o_1..o_B) of the stacked observations given o_0, with a constant Λ (brute force).

    ``s_k = Dᵏ s_0 + Σ_{j<=k} D^{k-j} w_j``, so ``[o_1..o_B] = A [s_0, w_1..w_B] + v`` with
    ``[s_0, w] ~ N([m0, 0], blockdiag(Γ0, Λ, ..., Λ))`` and ``v ~ N(0, blockdiag(Φ_1..Φ_B))``.
    """
    var = box_observation_variance(boxes)
    m0, g0 = prior(boxes[0], var[0])
    b = len(boxes) - 1
    a = np.zeros((4 * b, 6 * (b + 1)))
    for k in range(1, b + 1):
        rows = slice(4 * (k - 1), 4 * k)
        a[rows, :6] = P @ np.linalg.matrix_power(D, k)
        for j in range(1, k + 1):
            a[rows, 6 * j: 6 * (j + 1)] = P @ np.linalg.matrix_power(D, k - j)
    latent_cov = block_diag(g0, *[lam] * b)
    cov = a @ latent_cov @ a.T + np.diag(var[1:].ravel())
    mean = a[:, :6] @ m0
    return multivariate_normal.logpdf(boxes[1:].ravel(), mean, cov) - b * LOG_U


# --------------------------------------------------------------------------- likelihood


def test_single_chain_llr_equals_joint_gaussian_brute_force():
    rng = np.random.default_rng(0)
    boxes = smooth_track() + rng.normal(scale=[2.0, 2.0, 3.0, 4.0], size=(4, 4))
    lam = dyn_cov(boxes[:1, :])[0] * 2.0  # any constant SPD Λ
    cands = birth_candidates(pools_from(list(boxes)), D, lambda mu: np.broadcast_to(
        lam, (mu.shape[0], 6, 6)), velocity_var, LOG_U)
    assert len(cands) == 1
    np.testing.assert_array_equal(cands[0].indices, [0, 0, 0, 0])
    np.testing.assert_allclose(cands[0].llr, joint_gaussian_llr(boxes, lam), rtol=0, atol=1e-8)


def test_single_chain_with_box_dynamics_equals_a_plain_kalman_filter():
    rng = np.random.default_rng(1)
    boxes = smooth_track(vx=-3.0, w=60.0, h=150.0) + rng.normal(scale=3.0, size=(4, 4))
    cands = birth_candidates(pools_from(list(boxes)), D, dyn_cov, velocity_var, LOG_U)
    assert len(cands) == 1
    llr, mu, gamma = kalman_llr(boxes)
    np.testing.assert_allclose(cands[0].llr, llr, rtol=0, atol=1e-8)
    np.testing.assert_allclose(cands[0].mu, mu, rtol=0, atol=1e-8)
    np.testing.assert_allclose(cands[0].gamma, gamma, rtol=0, atol=1e-8)


def test_smooth_sequence_scores_far_above_a_jumpy_one():
    rng = np.random.default_rng(2)
    smooth = smooth_track()
    jumpy = smooth + rng.normal(scale=[15.0, 30.0, 8.0, 20.0], size=(4, 4))
    jumpy[:, 2:] = np.abs(jumpy[:, 2:])
    kw = dict(gate=np.inf)  # score both, whatever the gate
    s = birth_candidates(pools_from(list(smooth)), D, dyn_cov, velocity_var, LOG_U, **kw)
    j = birth_candidates(pools_from(list(jumpy)), D, dyn_cov, velocity_var, LOG_U, **kw)
    assert s[0].llr > 0  # smooth: born with the default threshold 0
    assert s[0].llr > j[0].llr + 20.0


# --------------------------------------------------------------------------- gating and beam


def test_gate_removes_a_far_outlier():
    track = smooth_track()
    outlier = track[3] + np.array([300.0, 0.0, 0.0, 0.0])
    frames = [track[0], track[1], track[2], np.vstack([outlier, track[3]])]
    cands = birth_candidates(pools_from(frames), D, dyn_cov, velocity_var, LOG_U)
    assert [c.indices.tolist() for c in cands] == [[0, 0, 0, 1]]
    # with the outlier alone in the last frame, nothing passes
    frames[3] = outlier
    assert birth_candidates(pools_from(frames), D, dyn_cov, velocity_var, LOG_U) == []


def test_two_people_each_get_their_own_best_sequence():
    a = smooth_track(x0=100.0)
    b = smooth_track(x0=160.0, vx=-1.0)
    frames = [np.vstack([a[0], b[0]]), np.vstack([b[1], a[1]]), np.vstack([a[2], b[2]]),
              np.vstack([b[3], a[3]])]
    cands = birth_candidates(pools_from(frames), D, dyn_cov, velocity_var, LOG_U, beam=3)
    llrs = [c.llr for c in cands]
    assert llrs == sorted(llrs, reverse=True)
    born = select_births(cands, 0.0)
    assert sorted(c.indices.tolist() for c in born) == [[0, 1, 0, 1], [1, 0, 1, 0]]


def test_empty_pool_yields_no_candidate():
    track = smooth_track()
    frames = [track[0], np.zeros((0, 4)), track[2], track[3]]
    assert birth_candidates(pools_from(frames), D, dyn_cov, velocity_var, LOG_U) == []
    frames = [np.zeros((0, 4)), track[1], track[2], track[3]]
    assert birth_candidates(pools_from(frames), D, dyn_cov, velocity_var, LOG_U) == []


def dyn_var(mu: np.ndarray) -> np.ndarray:
    return np.diagonal(dyn_cov(mu), axis1=1, axis2=2)


@pytest.mark.parametrize("dt", [1.0, 0.5])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_constant_velocity_path_equals_the_matrix_filter(seed, dt):
    """``dynamics_var`` with a constant-velocity D: the elementwise filter gives the
    candidates of the matrix one (several people, clutter and a missing detection)."""
    rng = np.random.default_rng(seed)
    tracks = [smooth_track(x0=x0, vx=vx, w=w, h=2.2 * w, n=4)
              for x0, vx, w in ((100.0, 2.0, 40.0), (180.0, -3.0, 55.0), (260.0, 0.5, 30.0))]
    frames = []
    for f in range(4):
        rows = [t[f] + rng.normal(scale=2.0, size=4) for t in tracks if rng.random() > 0.2]
        rows.append(rng.uniform([0, 0, 20, 40], [640, 480, 80, 160]))  # clutter
        frames.append(np.vstack(rows))
    d = constant_velocity_transition(4, 2, dt)
    kw = dict(gate=np.inf, beam=2)  # every sequence: long chains of updates
    ref = birth_candidates(pools_from(frames), d, dyn_cov, velocity_var, LOG_U, **kw)
    cv = birth_candidates(pools_from(frames), d, dyn_cov, velocity_var, LOG_U,
                          dynamics_var=dyn_var, **kw)
    assert len(cv) == len(ref) > 3
    for a, b in zip(cv, ref, strict=True):
        np.testing.assert_array_equal(a.indices, b.indices)
        np.testing.assert_allclose(a.llr, b.llr, rtol=1e-12, atol=0)
        np.testing.assert_allclose(a.mu, b.mu, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(a.gamma, b.gamma, rtol=1e-12, atol=1e-12)
        assert a.gamma.shape == (6, 6)


def test_constant_velocity_path_from_a_single_detection():
    """One chain to start from (no ranking in the first beam step), then several."""
    track = smooth_track(w=50.0, h=110.0)
    frames = [track[0], np.vstack([track[1], track[1] + [4.0, -3.0, 2.0, 1.0]]),
              np.vstack([track[2] + [60.0, 0, 0, 0], track[2]]), track[3]]
    ref = birth_candidates(pools_from(frames), D, dyn_cov, velocity_var, LOG_U)
    cv = birth_candidates(pools_from(frames), D, dyn_cov, velocity_var, LOG_U,
                          dynamics_var=dyn_var)
    assert len(cv) == len(ref) == 2
    for a, b in zip(cv, ref, strict=True):
        np.testing.assert_array_equal(a.indices, b.indices)
        np.testing.assert_allclose(a.llr, b.llr, rtol=1e-12, atol=0)
        np.testing.assert_allclose(a.mu, b.mu, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(a.gamma, b.gamma, rtol=1e-12, atol=1e-12)


def test_dynamics_var_is_ignored_without_a_constant_velocity_transition():
    """Any other D takes the matrix filter (here one that damps the velocity)."""
    d = constant_velocity_transition(4, 2)
    d[4, 4] = d[5, 5] = 0.9
    pools = pools_from(list(smooth_track()))
    ref = birth_candidates(pools, d, dyn_cov, velocity_var, LOG_U)
    out = birth_candidates(pools, d, dyn_cov, velocity_var, LOG_U,
                           dynamics_var=lambda mu: pytest.fail("not a CV transition"))
    assert [c.llr for c in out] == [c.llr for c in ref]


def test_bad_arguments_raise():
    pools = pools_from(list(smooth_track()))
    with pytest.raises(ValueError, match="at least 2 frames"):
        birth_candidates(pools[:1], D, dyn_cov, velocity_var, LOG_U)
    with pytest.raises(ValueError, match="beam must be >= 1, got 0"):
        birth_candidates(pools, D, dyn_cov, velocity_var, LOG_U, beam=0)


# --------------------------------------------------------------------------- selection


def cand(indices: list[int], llr: float) -> BirthCandidate:
    return BirthCandidate(np.array(indices), llr, np.zeros(6), np.eye(6))


def test_select_births_by_hand():
    cands = [cand([0, 0, 0], 9.0), cand([1, 0, 1], 8.0), cand([1, 1, 1], 5.0),
             cand([2, 2, 2], -1.0)]
    born = select_births(cands, 0.0)
    # [1, 0, 1] reuses observation 0 of frame 1; [2, 2, 2] is below the threshold
    assert [c.llr for c in born] == [9.0, 5.0]
    assert select_births(cands, 9.0) == []  # strict threshold


@settings(max_examples=100, deadline=None)
@given(
    data=st.lists(
        st.tuples(st.lists(st.integers(0, 2), min_size=3, max_size=3),
                  st.floats(-10, 10, allow_nan=False)),
        max_size=12),
    threshold=st.floats(-5, 5),
)
def test_select_births_never_reuses_an_observation(data, threshold):
    cands = sorted((cand(i, llr) for i, llr in data), key=lambda c: -c.llr)
    born = select_births(cands, threshold)
    keys = [(f, int(i)) for c in born for f, i in enumerate(c.indices)]
    assert len(keys) == len(set(keys))
    assert all(c.llr > threshold for c in born)
    # greedy maximality: every candidate above the threshold that was left out conflicts
    chosen = {id(c) for c in born}
    used = set(keys)
    for c in cands:
        if c.llr > threshold and id(c) not in chosen:
            assert {(f, int(i)) for f, i in enumerate(c.indices)} & used


def test_select_births_does_not_depend_on_input_order():
    born = select_births([cand([0, 0], -1.0), cand([1, 1], 5.0)], 0.0)
    assert [c.llr for c in born] == [5.0]


def test_born_states_and_consume_pool():
    from avtrack.vem.birth import BirthCandidate, born_states, consume_pool
    from avtrack.visual.model import BoxObservations

    def frame(m):
        z = np.arange(m * 4, dtype=float).reshape(m, 4) + 10.0
        return BoxObservations(z, np.ones((m, 4)), np.eye(m, 3))

    pool = [frame(3), frame(2)]
    born = [
        BirthCandidate(np.array([2, 0]), 5.0, np.full(6, 1.0), np.eye(6)),
        BirthCandidate(np.array([0, 1]), 4.0, np.full(6, 2.0), 2 * np.eye(6)),
    ]
    mu, gamma, app = born_states(born, pool[-1].appearance)
    assert mu.shape == (2, 6) and gamma.shape == (2, 6, 6)
    np.testing.assert_array_equal(app, pool[-1].appearance[[0, 1]])
    assert born_states(born, None)[2] is None
    kept = pool[0].z[1]
    consume_pool(pool, born)
    assert [len(p) for p in pool] == [1, 0]
    np.testing.assert_array_equal(pool[0].z, kept[None])
