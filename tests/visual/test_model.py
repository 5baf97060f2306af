"""Tests of avtrack.visual.model: box conversions, the observation covariance, and the box
observation model (variational and marginal likelihoods against scipy, information sums,
reference appearances)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from scipy.stats import multivariate_normal

from avtrack.vem.model import DiagonalObservationModel
from avtrack.visual.appearance import BhattacharyyaAppearance
from avtrack.visual.model import (
    BoxObservationModel,
    BoxObservations,
    box_observation_variance,
    ltwh_to_xywh,
    xywh_to_ltwh,
)

P = np.hstack([np.eye(4), np.zeros((4, 2))])


def small_case(seed: int = 0):
    """3 boxes, 2 targets with full (correlated) state covariances."""
    rng = np.random.default_rng(seed)
    z = np.column_stack([rng.uniform(50, 150, (3, 2)), rng.uniform(20, 60, (3, 2))])
    obs = BoxObservations(z, box_observation_variance(z))
    mu = np.column_stack([z[:2] + rng.normal(scale=3.0, size=(2, 4)), rng.normal(size=(2, 2))])
    a = rng.normal(size=(2, 6, 6))
    gamma = a @ np.swapaxes(a, 1, 2) + np.eye(6)
    return obs, mu, gamma


# --------------------------------------------------------------------------- conversions


def test_conversions_by_hand():
    ltwh = np.array([[10.0, 20.0, 30.0, 40.0]])
    np.testing.assert_array_equal(ltwh_to_xywh(ltwh), [[25.0, 40.0, 30.0, 40.0]])
    np.testing.assert_array_equal(xywh_to_ltwh([[25.0, 40.0, 30.0, 40.0]]), ltwh)


@settings(max_examples=100, deadline=None)
@given(hnp.arrays(np.float64, st.tuples(st.integers(0, 5), st.just(4)),
                  elements=st.floats(-1e4, 1e4)))
def test_conversions_round_trip(boxes):
    np.testing.assert_allclose(xywh_to_ltwh(ltwh_to_xywh(boxes)), boxes, rtol=0, atol=1e-9)
    np.testing.assert_allclose(ltwh_to_xywh(xywh_to_ltwh(boxes)), boxes, rtol=0, atol=1e-9)


def test_observation_variance_by_hand():
    var = box_observation_variance(np.array([[0.0, 0.0, 20.0, 50.0], [0.0, 0.0, 0.5, 2.0]]))
    # stds (0.1·w, 0.1·h, 0.2·w, 0.2·h); sizes below 1 px count as 1 px
    np.testing.assert_allclose(var, [[4.0, 25.0, 16.0, 100.0], [0.01, 0.04, 0.04, 0.16]],
                               rtol=1e-14)


def test_box_observations_validation():
    with pytest.raises(ValueError, match=r"z and var must be \(M, 4\)"):
        BoxObservations(np.zeros((2, 4)), np.ones((2, 3)))
    with pytest.raises(ValueError, match="appearance has 1 rows for 2 boxes"):
        BoxObservations(np.zeros((2, 4)), np.ones((2, 4)), np.ones((1, 8)))
    obs = BoxObservations(np.arange(12.0).reshape(3, 4), np.ones((3, 4)), np.eye(3))
    sub = obs.subset(np.array([2, 0]))
    assert len(sub) == 2
    np.testing.assert_array_equal(sub.z, obs.z[[2, 0]])
    np.testing.assert_array_equal(sub.appearance, np.eye(3)[[2, 0]])


def test_split_frames_carry_the_constants_they_would_compute():
    rng = np.random.default_rng(3)
    z = np.column_stack([rng.uniform(50, 150, (7, 2)), rng.uniform(20, 60, (7, 2))])
    batch = BoxObservations(z, box_observation_variance(z), rng.uniform(size=(7, 5)))
    frames = batch.split([0, 3, 3, 7])
    assert [len(f) for f in frames] == [3, 0, 4]
    for f, rows in zip(frames, (slice(0, 3), slice(3, 3), slice(3, 7)), strict=True):
        np.testing.assert_array_equal(f.z, z[rows])
        np.testing.assert_array_equal(f.appearance, batch.appearance[rows])
        fresh = BoxObservations(f.z.copy(), f.var.copy(), f.appearance)
        for name in ("inv_var", "information_terms", "log_normaliser"):
            assert name in vars(f)  # set by split, not recomputed
            np.testing.assert_array_equal(getattr(f, name), getattr(fresh, name))


# --------------------------------------------------------------------------- likelihoods


def test_variational_log_likelihood_matches_scipy():
    obs, mu, gamma = small_case()
    model = BoxObservationModel(log_clutter_density=-20.0)
    log_tau, log_clutter = model.log_likelihood(obs, mu, gamma, marginal=False)
    assert log_tau.shape == (3, 2)
    np.testing.assert_array_equal(log_clutter, np.full(3, -20.0))
    for m in range(3):
        phi = np.diag(obs.var[m])
        for n in range(2):
            # log N(o; Pμ, Φ) - ½ tr(Pᵀ Φ⁻¹ P Γ)   (thesis eq. 2.25)
            ref = (multivariate_normal.logpdf(obs.z[m], P @ mu[n], phi)
                   - 0.5 * np.trace(P.T @ np.linalg.inv(phi) @ P @ gamma[n]))
            np.testing.assert_allclose(log_tau[m, n], ref, rtol=1e-12)


def test_marginal_log_likelihood_matches_scipy():
    obs, mu, gamma = small_case(1)
    model = BoxObservationModel(log_clutter_density=-20.0)
    log_tau, _ = model.log_likelihood(obs, mu, gamma, marginal=True)
    for m in range(3):
        for n in range(2):
            # log N(o; Pμ, Φ + PΓPᵀ)   (thesis eq. 2.8)
            ref = multivariate_normal.logpdf(obs.z[m], P @ mu[n],
                                             np.diag(obs.var[m]) + P @ gamma[n] @ P.T)
            np.testing.assert_allclose(log_tau[m, n], ref, rtol=1e-12)


def test_information_equals_explicit_sums():
    obs, _, _ = small_case(2)
    rng = np.random.default_rng(3)
    resp = rng.dirichlet(np.ones(3), size=3)  # (M, N + 1), clutter first
    model = BoxObservationModel(log_clutter_density=-20.0)
    info, vec = model.information(obs, resp, 6)
    for n in range(2):
        j = np.zeros((6, 6))
        h = np.zeros(6)
        for m in range(3):
            phi_inv = np.linalg.inv(np.diag(obs.var[m]))
            j += resp[m, n + 1] * P.T @ phi_inv @ P  # Σ α Pᵀ Φ⁻¹ P
            h += resp[m, n + 1] * P.T @ phi_inv @ obs.z[m]  # Σ α Pᵀ Φ⁻¹ o
        np.testing.assert_allclose(info[n], j, rtol=1e-14)
        np.testing.assert_allclose(vec[n], h, rtol=1e-14)


def test_appearance_adds_its_log_ratio():
    obs, mu, gamma = small_case(4)
    app = BhattacharyyaAppearance(lam=5.0, neutral_distance=0.3)
    rng = np.random.default_rng(5)
    hist = app.normalize(rng.uniform(size=(3, 8)))
    refs = app.normalize(rng.uniform(size=(2, 8)))
    plain = BoxObservationModel(-20.0).log_likelihood(obs, mu, gamma)[0]
    model = BoxObservationModel(-20.0, app)
    model.add_targets(2, refs)
    with_app = BoxObservations(obs.z, obs.var, hist)
    got = model.log_likelihood(with_app, mu, gamma)[0]
    np.testing.assert_allclose(got - plain, app.log_ratio(hist, refs), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("marginal", [False, True])
@pytest.mark.parametrize("with_appearance", [False, True])
def test_responsibilities_equal_the_e_z_step_of_the_likelihoods(marginal, with_appearance):
    """The box model's fused E-Z (log-likelihoods written into the E-Z array, computed on
    gathered (observation, target) pairs) gives exactly e_z_step of log_likelihood_diagonal,
    the base-class composition."""
    rng = np.random.default_rng(6)
    z = np.column_stack([rng.uniform(50, 150, (5, 2)), rng.uniform(20, 60, (5, 2))])
    mu = z[[0, 2, 2, 4]] + rng.normal(scale=3.0, size=(4, 4))
    var = rng.uniform(1.0, 30.0, (4, 4))
    app = BhattacharyyaAppearance()
    model = BoxObservationModel(-20.0, app if with_appearance else None)
    hist = None
    if with_appearance:
        model.add_targets(4, app.normalize(rng.uniform(size=(4, 6))))
        hist = app.normalize(rng.uniform(size=(5, 6)))
    obs = BoxObservations(z, box_observation_variance(z), hist)
    log_prior = np.log(rng.dirichlet(np.ones(5)))
    for exclusive in (False, True):
        got = model.responsibilities_diagonal(obs, mu, var, log_prior, marginal, exclusive)
        ref = DiagonalObservationModel.responsibilities_diagonal(
            model, obs, mu, var, log_prior, marginal, exclusive)
        np.testing.assert_array_equal(got, ref)
    log_tau, _ = model.log_likelihood_diagonal(obs, mu, var, marginal)
    r = z[:, None, :] - mu
    if marginal:  # the broadcast formulas, by hand
        s = box_observation_variance(z)[:, None, :] + var
        expected = -0.5 * ((r * r / s).sum(axis=2) + np.log(s).sum(axis=2) + 4 * np.log(2 * np.pi))
    else:
        expected = (-0.5 * ((r * r + var) / box_observation_variance(z)[:, None, :]).sum(axis=2)
                    + obs.log_normaliser[:, None])
    if with_appearance:
        expected += app.log_ratio(hist, model.references)
    np.testing.assert_allclose(log_tau, expected, rtol=1e-12, atol=1e-9)


# --------------------------------------------------------------------------- target hooks


def test_reference_appearances_follow_targets():
    model = BoxObservationModel(-20.0, BhattacharyyaAppearance(), appearance_update=0.5)
    model.add_targets(2, np.array([[1.0, 0.0], [0.0, 1.0]]))
    model.add_targets(1, np.array([[0.5, 0.5]]))
    model.remove_targets(np.array([True, False, True]))
    np.testing.assert_array_equal(model.references, [[1.0, 0.0], [0.5, 0.5]])
    with pytest.raises(ValueError, match="need reference appearances"):
        model.add_targets(1, None)
    # update: target 0 took observation 0 fully -> h = (1 - 0.5) h + 0.5 h_obs, renormalised
    obs = BoxObservations(np.ones((1, 4)) * 10, np.ones((1, 4)), np.array([[0.0, 1.0]]))
    model.update_targets(obs, np.array([[0.0, 1.0, 0.0]]))
    np.testing.assert_allclose(model.references, [[0.5, 0.5], [0.5, 0.5]], rtol=1e-14)


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"log_clutter_density": float("inf")}, "log_clutter_density must be finite, got inf"),
    ({"log_clutter_density": 0.0, "appearance_update": 1.5},
     r"appearance_update must be in \[0, 1\], got 1.5"),
])
def test_bad_model_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        BoxObservationModel(**kwargs)
