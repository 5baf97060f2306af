"""Tests of avtrack.vem.engine.VEMEngine: one frame with one sure observation equals the
Kalman update, target bookkeeping keeps every per-target array aligned, and argument checks."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.vem.dynamics import (
    box_dynamics_covariance,
    box_dynamics_variance,
    constant_velocity_transition,
)
from avtrack.vem.engine import VEMEngine
from avtrack.vem.updates import predict_cv
from avtrack.visual.appearance import BhattacharyyaAppearance
from avtrack.visual.model import BoxObservationModel, BoxObservations, box_observation_variance

D = constant_velocity_transition(4, 2)
P = np.hstack([np.eye(4), np.zeros((4, 2))])
NO_CLUTTER = -1e4  # log u(o): clutter never wins


def one_target_engine(**kwargs) -> tuple[VEMEngine, np.ndarray, np.ndarray]:
    mu0 = np.array([100.0, 200.0, 40.0, 80.0, 2.0, -1.0])
    a = np.random.default_rng(0).normal(size=(6, 6))
    gamma0 = a @ a.T + np.diag([4.0, 4.0, 9.0, 9.0, 1.0, 1.0])
    engine = VEMEngine(D, [BoxObservationModel(NO_CLUTTER)], **kwargs)
    engine.add_targets([7], mu0[None], gamma0[None])
    return engine, mu0, gamma0


def kalman(mu0, gamma0, lam, z, var):
    """Textbook predict + update with H = P = [I₄ 0], R = diag(var)."""
    mu_p = D @ mu0
    p_p = D @ gamma0 @ D.T + lam
    r = np.diag(var)
    k = p_p @ P.T @ np.linalg.inv(P @ p_p @ P.T + r)  # K = P Hᵀ (H P Hᵀ + R)⁻¹
    return mu_p + k @ (z - P @ mu_p), (np.eye(6) - k @ P) @ p_p


@pytest.mark.parametrize("offset", [np.zeros(4), np.array([3.0, -2.0, 1.5, 4.0])])
@pytest.mark.parametrize("n_iter", [1, 3])
def test_one_sure_observation_is_the_kalman_update(offset, n_iter):
    engine, mu0, gamma0 = one_target_engine(n_iter=n_iter, marginal_init=False)
    lam = box_dynamics_covariance(mu0[None])
    z = (D @ mu0)[None, :4] + offset  # offset 0: exactly at the prediction
    var = box_observation_variance(z)
    inf = engine.step([BoxObservations(z, var)], lam)
    mu_k, gamma_k = kalman(mu0, gamma0, lam[0], z[0], var[0])
    np.testing.assert_allclose(inf.responsibilities[0], [[0.0, 1.0]], rtol=0, atol=1e-300)
    np.testing.assert_allclose(inf.mu[0], mu_k, rtol=0, atol=1e-10)
    np.testing.assert_allclose(inf.gamma[0], gamma_k, rtol=0, atol=1e-10)
    np.testing.assert_array_equal(engine.mu, inf.mu)  # state updated in place
    np.testing.assert_array_equal(engine.gamma, inf.gamma)
    np.testing.assert_allclose(inf.mass[0], [0.0, 1.0], rtol=0, atol=1e-300)
    if not offset.any():
        np.testing.assert_allclose(inf.mu[0], D @ mu0, rtol=0, atol=1e-10)


def test_no_observation_is_the_prediction():
    engine, mu0, gamma0 = one_target_engine(n_iter=2)
    lam = box_dynamics_covariance(mu0[None])
    inf = engine.step([BoxObservations(np.zeros((0, 4)), np.zeros((0, 4)))], lam)
    np.testing.assert_allclose(inf.mu[0], D @ mu0, rtol=0, atol=1e-10)
    np.testing.assert_allclose(inf.gamma[0], D @ gamma0 @ D.T + lam[0], rtol=1e-10, atol=1e-10)
    assert inf.responsibilities[0].shape == (0, 2)


def test_control_shifts_the_prediction():
    engine, mu0, _ = one_target_engine(n_iter=1)
    lam = box_dynamics_covariance(mu0[None])
    control = np.array([[5.0, -3.0, 0.0, 0.0, 0.0, 0.0]])
    inf = engine.step([BoxObservations(np.zeros((0, 4)), np.zeros((0, 4)))], lam, control)
    np.testing.assert_allclose(inf.mu[0], D @ mu0 + control[0], rtol=0, atol=1e-10)


def test_step_without_targets_gives_everything_to_clutter():
    engine = VEMEngine(D, [BoxObservationModel(-20.0)])
    z = np.array([[10.0, 10.0, 5.0, 5.0], [50.0, 50.0, 5.0, 5.0]])
    inf = engine.step([BoxObservations(z, box_observation_variance(z))], np.zeros((0, 6, 6)))
    np.testing.assert_array_equal(inf.responsibilities[0], np.ones((2, 1)))
    assert inf.mu.shape == (0, 6)
    assert inf.gamma.shape == (0, 6, 6)


def test_adding_and_removing_targets_keeps_arrays_aligned():
    model = BoxObservationModel(-20.0, BhattacharyyaAppearance())
    engine = VEMEngine(D, [model], n_iter=2)
    mu = np.array([[10.0, 10, 20, 40, 0, 0], [100, 10, 20, 40, 0, 0], [200, 10, 20, 40, 0, 0]])
    gamma = np.stack([k * np.eye(6) for k in (1.0, 2.0, 3.0)])
    refs = np.eye(3)
    engine.add_targets([1, 2], mu[:2], gamma[:2], [refs[:2]])
    engine.add_targets([5], mu[2:], gamma[2:], [refs[2:]])
    np.testing.assert_array_equal(engine.ids, [1, 2, 5])
    assert engine.n_targets == 3
    engine.remove_targets(np.array([True, False, True]))
    np.testing.assert_array_equal(engine.ids, [1, 5])
    np.testing.assert_array_equal(engine.mu, mu[[0, 2]])
    np.testing.assert_array_equal(engine.gamma, gamma[[0, 2]])
    np.testing.assert_array_equal(model.references, refs[[0, 2]])
    with pytest.raises(ValueError, match=r"target ids already in use: \[5\]"):
        engine.add_targets([5], mu[:1], gamma[:1], [refs[:1]])
    # a frame with the remaining two targets: arrays follow the new count
    z = mu[[2, 0], :4]
    obs = BoxObservations(z, box_observation_variance(z), refs[[2, 0]])
    inf = engine.step([obs], box_dynamics_covariance(engine.mu))
    assert inf.mu.shape == (2, 6)
    assert inf.responsibilities[0].shape == (2, 3)
    # observation 0 is target 5 (second), observation 1 is target 1 (first)
    np.testing.assert_array_equal(np.argmax(inf.responsibilities[0], axis=1), [2, 1])


@pytest.mark.parametrize("exclusive", [False, True])
def test_single_model_iterations_equal_the_general_loop(exclusive):
    """The one-model VEM loop of the constant-velocity path is the per-model loop, exactly
    (crowded frame: two detections of one target, appearance, every iteration kind)."""
    rng = np.random.default_rng(4)
    model = BoxObservationModel(-20.0, BhattacharyyaAppearance(), appearance_update=0.1)
    engine = VEMEngine(D, [model], n_iter=4, exclusive=exclusive)
    engine._compiled = False  # the NumPy form (the compiled one: test_cv_box_kernel.py)
    mu = np.column_stack([rng.uniform(50, 300, (3, 2)), rng.uniform(30, 60, (3, 2)),
                          rng.normal(size=(3, 2))])
    gamma = np.stack([np.diag(rng.uniform(1, 9, 6)) for _ in range(3)])
    refs = rng.uniform(size=(3, 5))
    engine.add_targets([1, 2, 3], mu, gamma, [refs])
    z = np.vstack([mu[[0, 0, 2], :4] + rng.normal(scale=2.0, size=(3, 4)), [400, 50, 40, 40]])
    obs = BoxObservations(z, box_observation_variance(z), rng.uniform(size=(4, 5)))
    states = engine._cached_cv_states()
    assert states is not None  # (the constant-velocity path applies)
    pred = predict_cv(states, engine._cv_diagonal(box_dynamics_variance(mu)), 1.0)
    post, resps, mass = engine._iterate_cv([obs], pred)
    post_one, resps_one, mass_one = engine._iterate_cv_one([obs], pred)
    for a, b in zip(post_one, post, strict=True):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(resps_one[0], resps[0])
    np.testing.assert_array_equal(mass_one[0], mass[0])
    assert resps[0][:, 1].sum() > 1.2 or exclusive  # the crowded case is exercised


def test_split_states_between_frames_equal_plain_arrays():
    """The constant-velocity path keeps its states split between frames (mu, gamma built
    when read): removing and scaling targets there gives the frames of an engine whose
    states are re-assigned as plain arrays after every operation."""
    rng = np.random.default_rng(5)
    engines = [VEMEngine(D, [BoxObservationModel(-20.0)], exclusive=True) for _ in range(2)]
    mu = np.column_stack([rng.uniform(50, 300, (4, 2)), rng.uniform(30, 60, (4, 2)),
                          rng.normal(size=(4, 2))])
    gamma = np.stack([np.diag(rng.uniform(1, 9, 6)) for _ in range(4)])
    for engine in engines:
        engine.add_targets([1, 2, 3, 4], mu, gamma)

    def as_arrays(engine):  # plain (writable) arrays: the split form is dropped
        engine.mu, engine.gamma = engine.mu.copy(), engine.gamma.copy()

    for frame in range(4):
        z = engines[0].mu[:, :4] + rng.normal(scale=2.0, size=(engines[0].n_targets, 4))
        obs = BoxObservations(z, box_observation_variance(z))
        infs = [e.step([obs], box_dynamics_variance(e.mu)) for e in engines]
        as_arrays(engines[1])
        assert not engines[0].mu.flags.writeable and not engines[0].gamma.flags.writeable
        np.testing.assert_array_equal(infs[0].mu, infs[1].mu)
        np.testing.assert_array_equal(infs[0].gamma, infs[1].gamma)
        np.testing.assert_array_equal(engines[0].variances,
                                      np.diagonal(engines[1].gamma, axis1=1, axis2=2))
        if frame == 1:  # halve the velocity std of every target
            for e in engines:
                e.scale_covariances(np.tile([1.0, 1, 1, 1, 0.5, 0.5], (e.n_targets, 1)))
            as_arrays(engines[1])
        if frame == 2:
            for e in engines:
                e.remove_targets(np.array([True, False, True, True]))
            as_arrays(engines[1])
        for e in engines[1:]:
            np.testing.assert_array_equal(e.mu, engines[0].mu)
            np.testing.assert_array_equal(e.gamma, engines[0].gamma)
    assert engines[0].n_targets == 3


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"transition": np.ones((6, 4))}, r"transition must be square \(d, d\), got \(6, 4\)"),
    ({"n_iter": 0}, "n_iter must be >= 1, got 0"),
    ({"models": []}, "at least one observation model"),
    ({"dynamics_floor": 0.0}, "dynamics_floor must be > 0, got 0.0"),
])
def test_bad_constructor_arguments(kwargs, match):
    args = {"transition": D, "models": [BoxObservationModel(-20.0)], **kwargs}
    with pytest.raises(ValueError, match=match):
        VEMEngine(**args)


def test_step_needs_one_observation_set_per_model():
    engine, mu0, _ = one_target_engine()
    with pytest.raises(ValueError, match="expected 1 observation sets, got 2"):
        engine.step([None, None], box_dynamics_covariance(mu0[None]))
