"""Weighted-direction observation model (thesis eq. 5.22, E-Z eq. 5.40, E-S eqs. 5.36–5.37)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import multivariate_normal

from avtrack.doa.model import MIN_WEIGHT, WeightedDirectionModel, WeightedDirections


def _frame(rng: np.random.Generator, m: int = 7) -> WeightedDirections:
    return WeightedDirections.from_azimuths(rng.uniform(-np.pi, np.pi, m), rng.uniform(0, 1, m))


def _states(rng: np.random.Generator, n: int = 3) -> tuple[np.ndarray, np.ndarray]:
    mu = rng.normal(size=(n, 3))
    a = rng.normal(size=(n, 3, 3))
    return mu, a @ np.swapaxes(a, 1, 2) * 0.1 + 0.01 * np.eye(3)


def test_variational_log_likelihood_matches_eq_5_40():
    rng = np.random.default_rng(0)
    obs, (mu, gamma) = _frame(rng), _states(rng)
    model = WeightedDirectionModel(obs_var=0.03, log_clutter_density=-1.5)
    log_tau, log_clutter = model.log_likelihood(obs, mu, gamma)
    assert log_tau.shape == (7, 3) and np.all(log_clutter == -1.5)
    for m in range(7):
        w, b = obs.weights[m], obs.directions[m]
        for n in range(3):
            cov = 0.03 / w * np.eye(2)  # Σ / w
            expected = multivariate_normal(mu[n, :2], cov).logpdf(b)
            expected -= 0.5 * w / 0.03 * np.trace(gamma[n, :2, :2])  # -½ tr(w Σ⁻¹ M Γ Mᵀ)
            assert log_tau[m, n] == pytest.approx(expected, rel=1e-12, abs=1e-12)


def test_marginal_log_likelihood_is_the_predictive_density():
    rng = np.random.default_rng(1)
    obs, (mu, gamma) = _frame(rng), _states(rng)
    model = WeightedDirectionModel(obs_var=0.01)
    log_tau, _ = model.log_likelihood(obs, mu, gamma, marginal=True)
    for m in range(7):
        for n in range(3):
            cov = gamma[n, :2, :2] + 0.01 / obs.weights[m] * np.eye(2)
            expected = multivariate_normal(mu[n, :2], cov).logpdf(obs.directions[m])
            assert log_tau[m, n] == pytest.approx(expected, rel=1e-10)


@pytest.mark.parametrize("marginal", [False, True])
def test_uninformative_weights_give_minus_inf_without_warnings(marginal):
    obs = WeightedDirections.from_azimuths(np.array([0.0, 1.0, 2.0]), np.array([0.0, 1e-300, 0.5]))
    mu, gamma = np.array([[1.0, 0.0, 0.0]]), np.eye(3)[None] * 0.01
    with np.errstate(all="raise"):
        log_tau, _ = WeightedDirectionModel().log_likelihood(obs, mu, gamma, marginal)
    assert np.all(np.isneginf(log_tau[:2])) and np.isfinite(log_tau[2, 0])
    assert 1e-300 <= MIN_WEIGHT


def test_information_terms_are_eqs_5_36_5_37():
    rng = np.random.default_rng(2)
    obs = _frame(rng, 5)
    resp = rng.dirichlet(np.ones(3), size=5)  # (M, N + 1), clutter first
    info, vec = WeightedDirectionModel(obs_var=0.02).information(obs, resp, 3)
    for n in range(2):
        a = resp[:, n + 1] * obs.weights
        assert np.allclose(info[n], np.diag([a.sum() / 0.02, a.sum() / 0.02, 0.0]))
        assert np.allclose(vec[n], np.r_[a @ obs.directions / 0.02, 0.0])
    mass = WeightedDirectionModel().weighted_mass(obs, resp)
    assert np.allclose(mass, obs.weights @ resp[:, 1:])


def test_bad_input_names_the_argument():
    with pytest.raises(ValueError, match="obs_var"):
        WeightedDirectionModel(obs_var=0.0)
    with pytest.raises(ValueError, match="log_clutter_density"):
        WeightedDirectionModel(log_clutter_density=np.inf)
    with pytest.raises(ValueError, match="weights must be >= 0"):
        WeightedDirections.from_azimuths(np.zeros(2), np.array([0.1, -0.1]))
    with pytest.raises(ValueError, match="shape"):
        WeightedDirections.from_azimuths(np.zeros(2), np.zeros(3))
    with pytest.raises(ValueError, match="finite"):
        WeightedDirections.from_azimuths(np.array([np.nan]), np.ones(1))
    with pytest.raises(ValueError, match=r"\(M, 2\)"):
        WeightedDirections(np.zeros((2, 3)), np.zeros(2))
