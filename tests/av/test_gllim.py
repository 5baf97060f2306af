"""GLLiM EM (thesis eqs. 4.13–4.16): recovery of a known map, forward/inverse, I/O, parity."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from avtrack.av.gllim import (
    AudioImageMapping,
    GLLiM,
    fit_gllim,
    load_mapping,
    save_mapping,
)
from avtrack.errors import InputError


def known_map(n: int = 1500, noise: float = 0.02, seed: int = 0):
    """Three well-separated position clusters, each with its own affine map to R^6."""
    rng = np.random.default_rng(seed)
    nu = np.array([[-4.0, 0.0], [0.0, 3.0], [4.0, -1.0]])
    omega = np.array(
        [np.diag([0.6, 0.3]), np.array([[0.5, 0.2], [0.2, 0.4]]), np.diag([0.3, 0.7])]
    )
    lmat = rng.normal(size=(3, 6, 2))
    lvec = rng.normal(size=(3, 6))
    pi = np.array([0.3, 0.45, 0.25])
    labels = rng.choice(3, size=n, p=pi)
    x = np.array([rng.multivariate_normal(nu[r], omega[r]) for r in labels])
    g = np.einsum("mdp,mp->md", lmat[labels], x) + lvec[labels]
    g += noise * rng.standard_normal(g.shape)
    truth = GLLiM(pi, nu, omega, lmat, lvec, np.repeat(noise**2 * np.eye(6)[None], 3, 0))
    return x, g, truth


def test_em_recovers_a_known_piecewise_affine_map():
    x, g, truth = known_map()
    fit = fit_gllim(x, g, 3, covariance_type="diag", reg_g=0.0, rng=0)
    m = fit.model
    assert fit.converged
    assert np.all(np.diff(fit.log_likelihood) > -1e-9)  # EM never decreases the likelihood
    order = [int(np.argmin(np.linalg.norm(m.nu - c, axis=1))) for c in truth.nu]
    assert sorted(order) == [0, 1, 2]
    np.testing.assert_allclose(m.pi[order], truth.pi, atol=0.04)
    np.testing.assert_allclose(m.nu[order], truth.nu, atol=0.1)
    np.testing.assert_allclose(m.omega[order], truth.omega, atol=0.1)
    np.testing.assert_allclose(m.lmat[order], truth.lmat, atol=0.01)
    np.testing.assert_allclose(m.lvec[order], truth.lvec, atol=0.02)
    noise_var = np.diagonal(m.sigma, axis1=1, axis2=2)
    np.testing.assert_allclose(noise_var, 0.02**2, rtol=0.2)


def test_forward_then_inverse_round_trips():
    x, g, _ = known_map(noise=0.01, seed=1)
    model = fit_gllim(x, g, 3, rng=0).model
    rng = np.random.default_rng(5)
    probe = x[rng.choice(len(x), 200, replace=False)]
    back, weights, cov = model.inverse(model.forward(probe))
    np.testing.assert_allclose(back, probe, atol=0.05)
    np.testing.assert_allclose(weights.sum(axis=1), 1.0)
    assert np.all(np.linalg.eigvalsh(cov) > 0)
    # and the other way round, where one expert explains the feature (between clusters the
    # posterior mean of a mixture need not map back onto g)
    mean, w, _ = model.inverse(g[:300])
    sure = (w.max(axis=1) > 0.99) & (model.component_posterior(mean).max(axis=1) > 0.99)
    assert sure.sum() > 250
    np.testing.assert_allclose(model.forward(mean[sure]), g[:300][sure], atol=0.05)


def test_component_posterior_is_eq_4_16():
    _, _, truth = known_map()
    x = np.array([[0.1, 2.5], [-3.0, 0.2]])
    w = truth.component_posterior(x)
    from scipy.stats import multivariate_normal as mvn

    dens = np.array(
        [[truth.pi[r] * mvn(truth.nu[r], truth.omega[r]).pdf(xi) for r in range(3)] for xi in x]
    )
    np.testing.assert_allclose(w, dens / dens.sum(axis=1, keepdims=True), rtol=1e-10)


def test_inverse_matches_bayes_rule_on_a_grid():
    """p(x|g) from the closed form equals p(g, x) / p(g) integrated numerically."""
    x, g, _ = known_map(noise=0.3, seed=2)
    model = fit_gllim(x, g, 3, covariance_type="full", rng=0).model
    gx, gy = np.meshgrid(np.linspace(-8, 8, 321), np.linspace(-5, 7, 241))
    grid = np.column_stack([gx.ravel(), gy.ravel()])
    probe = g[7]
    log_joint = model.log_joint(grid, np.repeat(probe[None], len(grid), 0))
    w = np.exp(log_joint - log_joint.max())
    w /= w.sum()
    mean, _, cov = model.inverse(probe[None])
    np.testing.assert_allclose(mean[0], w @ grid, atol=0.02)
    dev = grid - w @ grid
    np.testing.assert_allclose(cov[0], (w[:, None] * dev).T @ dev, atol=0.02)


@pytest.mark.parametrize("cov", ["full", "diag", "iso"])
def test_covariances_stay_spd(cov):
    x, g, _ = known_map(n=300, seed=3)
    m = fit_gllim(x, g, 5, covariance_type=cov, rng=1).model
    assert np.all(np.linalg.eigvalsh(m.sigma) > 0)
    assert np.all(np.linalg.eigvalsh(m.omega) > 0)
    if cov == "iso":
        d = np.diagonal(m.sigma, axis1=1, axis2=2)
        np.testing.assert_allclose(d, d[:, :1] * np.ones_like(d))


def test_seeded_fit_is_deterministic():
    x, g, _ = known_map(n=400)
    a = fit_gllim(x, g, 4, rng=7).model
    b = fit_gllim(x, g, 4, rng=7).model
    np.testing.assert_array_equal(a.lmat, b.lmat)


def test_save_and_load_round_trip(tmp_path):
    x, g, _ = known_map(n=400)
    models = [fit_gllim(x, g + k, 3, rng=k).model for k in range(2)]
    mapping = AudioImageMapping.from_models(models, {"band_size": 8, "bands": [0, 1]})
    path = save_mapping(tmp_path / "map.npz", mapping)
    back = load_mapping(path)
    assert back.meta == {"band_size": 8, "bands": [0, 1]}
    for k in range(2):
        np.testing.assert_array_equal(back.model(k).sigma, models[k].sigma)
        np.testing.assert_array_equal(back.model(k).lmat, models[k].lmat)


def test_load_rejects_bad_files(tmp_path):
    with pytest.raises(InputError, match="not found"):
        load_mapping(tmp_path / "missing.npz")
    bad = tmp_path / "bad.npz"
    np.savez(bad, pi=np.ones((1, 1)))
    with pytest.raises(InputError, match=r"bad\.npz.*missing"):
        load_mapping(bad)
    junk = tmp_path / "junk.npz"
    junk.write_text("not a zip")
    with pytest.raises(InputError, match=r"junk\.npz"):
        load_mapping(junk)


def test_bad_arguments_are_named():
    x, g, _ = known_map(n=50)
    with pytest.raises(ValueError, match="n_components"):
        fit_gllim(x, g, 0)
    with pytest.raises(ValueError, match="covariance_type"):
        fit_gllim(x, g, 2, covariance_type="banded")
    with pytest.raises(ValueError, match="g must be"):
        fit_gllim(x, g[:10], 2)
    g_nan = g.copy()
    g_nan[3, 1] = np.nan
    with pytest.raises(ValueError, match="finite"):
        fit_gllim(x, g_nan, 2)
    with pytest.raises(ValueError, match="pi must be positive"):
        GLLiM(
            [0.5, 0.6],
            np.zeros((2, 2)),
            np.repeat(np.eye(2)[None], 2, 0),
            np.zeros((2, 3, 2)),
            np.zeros((2, 3)),
            np.repeat(np.eye(3)[None], 2, 0),
        )


def test_a_gllim_and_a_stack_of_them_check_their_parameters_alike():
    r, p, d = 2, 2, 3
    args = [np.full(r, 0.5), np.zeros((r, p)), np.repeat(np.eye(p)[None], r, 0),
            np.zeros((r, d, p)), np.zeros((r, d)), np.repeat(np.eye(d)[None], r, 0)]
    model = GLLiM(*args)
    assert not model.sigma.flags.writeable and model.sigma is not args[5]
    with pytest.raises(ValueError, match=r"^GLLiM: pi must be \(R\) with sizes >= 1"):
        GLLiM(np.zeros(0), *args[1:])
    with pytest.raises(ValueError, match=r"^GLLiM: nu must be \(R=2, P\), got shape \(3, 2\)"):
        GLLiM(args[0], np.zeros((3, p)), *args[2:])
    with pytest.raises(ValueError, match=r"^GLLiM: lmat must have shape \(2, 3, 2\)"):
        GLLiM(*args[:3], np.zeros((r, p, d)), *args[4:])
    stacked = [np.stack([a, a]) for a in args]
    mapping = AudioImageMapping(*stacked)
    assert (mapping.n_bands, mapping.n_components, mapping.feature_dim) == (2, 2, 3)
    with pytest.raises(ValueError, match=r"^AudioImageMapping: pi must be \(K, R\)"):
        AudioImageMapping(args[0], *stacked[1:])
    with pytest.raises(ValueError, match=r"^AudioImageMapping: lvec must be \(K=2, R=2, D\)"):
        AudioImageMapping(*stacked[:4], np.zeros((2, 3, d)), stacked[5])
    bad = stacked[5].copy()
    bad[1, 0, 0, 0] = np.nan
    with pytest.raises(ValueError, match=r"^AudioImageMapping: sigma must be finite"):
        AudioImageMapping(*stacked[:5], bad)


# The xllim binding (2.0.11) takes ownership of arrays given to its parameter setters and can
# free them twice at interpreter exit, so the parity run happens in a child process.
_XLLIM_SCRIPT = textwrap.dedent("""
    import json, sys
    import numpy as np
    import xllim
    d = np.load(sys.argv[1])
    cov, n_iter = sys.argv[2], int(sys.argv[3])
    r, dim, p = d["lmat"].shape
    params = getattr(xllim, "_GLLiMParameters_full_" + cov)(r, dim, p)
    keep = {"Pi": d["pi"][None, :], "A": d["lmat"], "B": d["lvec"], "C": d["nu"],
            "Gamma": d["omega"],
            "Sigma": np.diagonal(d["sigma"], axis1=1, axis2=2) if cov == "diag" else d["sigma"]}
    keep = {k: np.array(v, order="C", copy=True) for k, v in keep.items()}
    for k, v in keep.items():
        setattr(params, k, v)
    model = xllim.GLLiM(r, dim, p, "full", cov)
    model.setParams(params)
    model.train(np.asfortranarray(d["x"].T), np.asfortranarray(d["g"].T), n_iter, 0.0, 0.0, 0)
    out = model.getParams()
    print(json.dumps({k: np.asarray(getattr(out, k)).tolist()
                      for k in ("Pi", "A", "B", "C", "Gamma", "Sigma")}), flush=True)
""")


@pytest.mark.parametrize("cov", ["full", "diag"])
def test_em_matches_xllim(tmp_path, cov):
    pytest.importorskip("xllim")
    x, g, _ = known_map(n=600, noise=0.1, seed=4)
    init = fit_gllim(x, g, 4, covariance_type=cov, max_iter=0, reg_x=0, reg_g=0, rng=0).model
    np.savez(
        tmp_path / "init.npz",
        x=x,
        g=g,
        pi=init.pi,
        nu=init.nu,
        omega=init.omega,
        lmat=init.lmat,
        lvec=init.lvec,
        sigma=init.sigma,
    )
    proc = subprocess.run(
        [sys.executable, "-c", _XLLIM_SCRIPT, str(tmp_path / "init.npz"), cov, "5"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    line = proc.stdout.strip().splitlines()
    assert line, f"xllim run produced no output: {proc.stderr[-500:]}"
    ref = {k: np.asarray(v) for k, v in json.loads(line[-1]).items()}
    mine = fit_gllim(
        x, g, 4, covariance_type=cov, max_iter=5, tol=0, reg_x=0, reg_g=0, init=init
    ).model
    np.testing.assert_allclose(ref["Pi"].ravel(), mine.pi, atol=1e-10)
    np.testing.assert_allclose(ref["C"], mine.nu, atol=1e-10)
    np.testing.assert_allclose(ref["Gamma"], mine.omega, atol=1e-10)
    np.testing.assert_allclose(ref["A"], mine.lmat, atol=1e-9)
    np.testing.assert_allclose(ref["B"], mine.lvec, atol=1e-9)
    sigma = np.diagonal(mine.sigma, axis1=1, axis2=2) if cov == "diag" else mine.sigma
    np.testing.assert_allclose(ref["Sigma"], sigma, atol=1e-10)
