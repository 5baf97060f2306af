"""The VAVIT audio observation model (thesis eqs. 4.15-4.16, 4.29-4.30, term #2 of 4.26)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import multivariate_normal as mvn

from avtrack.av.audio_model import AudioGLLiMModel, AudioObservations
from avtrack.av.gllim import AudioImageMapping, GLLiM


def random_mapping(p: int, d: int = 6, r: int = 3, k: int = 4, seed: int = 0):
    rng = np.random.default_rng(seed)
    models = []
    for _ in range(k):
        a = rng.normal(size=(r, d, d))
        sigma = a @ a.transpose(0, 2, 1) / d + 0.2 * np.eye(d)
        b = rng.normal(size=(r, p, p))
        omega = 100.0 * (b @ b.transpose(0, 2, 1) + np.eye(p))
        models.append(
            GLLiM(
                rng.dirichlet(np.ones(r) * 3),
                rng.uniform(0, 300, (r, p)),
                omega,
                rng.normal(size=(r, d, p)) / 50,
                rng.normal(size=(r, d)),
                sigma,
            )
        )
    return AudioImageMapping.from_models(models)


def states(n: int, seed: int = 1):
    rng = np.random.default_rng(seed)
    mu = np.column_stack(
        [rng.uniform(0, 300, (n, 2)), rng.uniform(20, 40, (n, 2)), rng.normal(size=(n, 2))]
    )
    a = rng.normal(size=(n, 6, 6))
    gamma = a @ a.transpose(0, 2, 1) * 5 + np.eye(6)
    return mu, gamma


@pytest.mark.parametrize("p", [1, 2])
@pytest.mark.parametrize("marginal", [False, True])
def test_log_kappa_matches_direct_computation(p, marginal):
    mapping = random_mapping(p)
    model = AudioGLLiMModel(mapping, sigma_scale=1.5)
    mu, gamma = states(3)
    rng = np.random.default_rng(2)
    bands = np.array([3, 0])
    g = rng.normal(size=(2, 6))
    x_tilde = mu[:, :p] + 5.0
    obs = model.observations(bands, g, x_tilde)
    log_kappa, _ = model.log_likelihood(obs, mu, gamma, marginal)
    for i, k in enumerate(bands):
        m = mapping.model(k)
        w = m.component_posterior(x_tilde)  # eq. 4.16 at the naive prediction
        for n in range(3):
            for r in range(mapping.n_components):
                lm, x = m.lmat[r], mu[n, :p]
                sig = 1.5 * m.sigma[r]
                gxx = gamma[n, :p, :p]
                if marginal:  # N(g; L mu + l, Sigma + L Gamma L^T)
                    ref = mvn(lm @ x + m.lvec[r], sig + lm @ gxx @ lm.T).logpdf(g[i])
                else:  # eq. 4.30: N(g; L mu + l, Sigma) exp(-tr(L^T Sigma^-1 L Gamma) / 2)
                    ref = mvn(lm @ x + m.lvec[r], sig).logpdf(g[i])
                    ref -= 0.5 * np.trace(lm.T @ np.linalg.inv(sig) @ lm @ gxx)
                ref += np.log(w[n, r])
                assert log_kappa[i, n, r] == pytest.approx(ref, rel=1e-9, abs=1e-9)


def test_responsibilities_and_information():
    mapping = random_mapping(2)
    model = AudioGLLiMModel(mapping, information_scale=0.5)
    mu, gamma = states(2)
    rng = np.random.default_rng(3)
    obs = model.observations(np.array([1, 2, 3]), rng.normal(size=(3, 6)), mu[:, :2])
    beta = model.responsibilities(obs, mu, gamma, np.log(np.full(3, 1 / 3)))
    assert beta.shape == (3, 3, mapping.n_components)
    np.testing.assert_allclose(beta.sum(axis=(1, 2)), 1.0)
    assert np.all(beta[:, 0, 1:] == 0)  # clutter has no component
    np.testing.assert_allclose(model.assigned_mass(beta).sum(), 3.0)
    info, vec = model.information(obs, beta, 6)
    for n in range(2):  # term #2 of eqs. 4.26-4.27, by hand
        j, h = np.zeros((2, 2)), np.zeros(2)
        for i, k in enumerate(obs.bands):
            for r in range(mapping.n_components):
                lm, si = mapping.lmat[k, r], np.linalg.inv(mapping.sigma[k, r])
                j += beta[i, n + 1, r] * lm.T @ si @ lm
                h += beta[i, n + 1, r] * lm.T @ si @ (obs.g[i] - mapping.lvec[k, r])
        np.testing.assert_allclose(info[n, :2, :2], 0.5 * j, rtol=1e-9)
        np.testing.assert_allclose(vec[n, :2], 0.5 * h, rtol=1e-9)
        assert np.all(info[n, 2:] == 0) and np.all(vec[n, 2:] == 0)
        assert np.all(np.linalg.eigvalsh(info[n]) > -1e-12)


def test_clutter_densities():
    mapping = random_mapping(2)
    g = np.random.default_rng(4).normal(size=(2, 6))
    uniform = AudioGLLiMModel(mapping)
    obs = uniform.observations(np.array([0, 2]), g, np.zeros((1, 2)))
    _, clutter = uniform.log_likelihood(obs, *states(1))
    np.testing.assert_allclose(clutter, -3 * np.log(np.pi))  # unit discs: vol = pi^(D/2)
    marg = AudioGLLiMModel(mapping, marginal_clutter=True)
    _, clutter = marg.log_likelihood(marg.observations(obs.bands, g, obs.x_tilde), *states(1))
    for i, k in enumerate(obs.bands):  # p(g) = sum_r pi_r N(g; L nu + l, Sigma + L Omega L^T)
        m = mapping.model(k)
        ref = sum(
            m.pi[r]
            * mvn(
                m.lmat[r] @ m.nu[r] + m.lvec[r], m.sigma[r] + m.lmat[r] @ m.omega[r] @ m.lmat[r].T
            ).pdf(g[i])
            for r in range(mapping.n_components)
        )
        assert clutter[i] == pytest.approx(np.log(ref), rel=1e-9)


def test_empty_frames_and_bad_input():
    mapping = random_mapping(2)
    model = AudioGLLiMModel(mapping)
    mu, gamma = states(2)
    empty = model.observations(np.zeros(0, int), np.zeros((0, 6)), mu[:, :2])
    beta = model.responsibilities(empty, mu, gamma, np.zeros(3))
    assert beta.shape == (0, 3, 3)
    info, vec = model.information(empty, beta, 6)
    assert not info.any() and not vec.any()
    with pytest.raises(ValueError, match="bands must be in"):
        model.observations(np.array([9]), np.zeros((1, 6)), mu[:, :2])
    with pytest.raises(ValueError, match="dimension 5"):
        model.observations(np.array([1]), np.zeros((1, 5)), mu[:, :2])
    with pytest.raises(ValueError, match="finite"):
        AudioObservations(np.array([1]), np.full((1, 6), np.nan), mu[:, :2])
    with pytest.raises(ValueError, match="sigma_scale"):
        AudioGLLiMModel(mapping, sigma_scale=-1.0)
    with pytest.raises(TypeError, match="AudioImageMapping"):
        AudioGLLiMModel(mapping.model(0))
