"""Tests of avtrack.vem.visibility: one hand-computed step of the two-state HMM filter
(thesis eqs. 3.31–3.32, with the module's reading of eq. 3.32), its long-run behaviour, and
argument validation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avtrack.vem.visibility import (
    LIKELIHOOD_FLOOR,
    visibility_filter,
    visibility_likelihood,
)


def test_one_step_by_hand():
    p = np.array([0.5, 0.8])
    nu = np.array([1.0, 0.5])
    got = visibility_filter(p, nu, stay=0.9, lam=2.0)
    # target 1: prior p(V=1) = 0.9·0.5 + 0.1·0.5 = 0.5; e = exp(-2·1) = 0.1353352832
    #   posterior = (1 - e)·0.5 / ((1 - e)·0.5 + e·0.5) = 1 - e = 0.8646647168
    # target 2: prior = 0.9·0.8 + 0.1·0.2 = 0.74; e = exp(-2·0.5) = 0.3678794412
    #   num = 0.6321205588·0.74 = 0.4677692135; den = num + 0.3678794412·0.26 = 0.5634178682
    #   posterior = 0.8302349640
    e1, e2 = np.exp(-2.0), np.exp(-1.0)
    expected = [1 - e1, (1 - e2) * 0.74 / ((1 - e2) * 0.74 + e2 * 0.26)]
    np.testing.assert_allclose(got, expected, rtol=1e-14)
    np.testing.assert_allclose(got, [0.8646647168, 0.8302349640], rtol=0, atol=1e-10)


def test_likelihood_floor():
    l0, l1 = visibility_likelihood(np.array([0.0, 100.0]), lam=2.0)
    # ν = 0: p(ν|v=0) = e⁰ = 1, p(ν|v=1) = 0 -> floor; ν = 100: the other way round
    np.testing.assert_allclose(l0, [1.0, LIKELIHOOD_FLOOR])
    np.testing.assert_allclose(l1, [LIKELIHOOD_FLOOR, 1.0])


def test_zero_evidence_decays_toward_invisible():
    p = np.array([1.0])
    history = []
    for _ in range(20):
        p = visibility_filter(p, np.zeros(1), stay=0.9, lam=2.0)
        history.append(p[0])
    # first step: prior 0.9, likelihoods (1, floor 1e-3): 0.9e-3 / (0.9e-3 + 0.1) = 0.0089197
    np.testing.assert_allclose(history[0], 0.9e-3 / (0.9e-3 + 0.1), rtol=1e-12)
    assert np.all(np.diff(history) <= 0)
    # it settles where the 10 % switching chance balances the 1e-3 likelihood floor:
    # p = 1e-3 (0.9 p + 0.1 (1 - p)) / (1e-3 (0.1 + 0.8 p) + (0.9 - 0.8 p)) ≈ 1.11e-4
    assert history[-1] < 2e-4


def test_strong_evidence_goes_to_visible():
    p = np.array([0.0])
    for _ in range(10):
        p = visibility_filter(p, np.array([10.0]), stay=0.9, lam=2.0)
    assert p[0] > 0.999


@settings(max_examples=100, deadline=None)
@given(p=st.floats(0, 1), nu=st.floats(0, 50), stay=st.floats(0.01, 0.99),
       lam=st.floats(0.01, 10))
def test_output_is_a_probability_and_monotone_in_the_evidence(p, nu, stay, lam):
    lo = visibility_filter(np.array([p]), np.array([nu]), stay, lam)[0]
    hi = visibility_filter(np.array([p]), np.array([nu + 1.0]), stay, lam)[0]
    assert 0 < lo < 1
    assert hi >= lo - 1e-12


@pytest.mark.parametrize("stay", [0.0, 1.0, -0.1, 1.5, float("nan")])
def test_bad_stay_raises(stay):
    with pytest.raises(ValueError, match=r"stay must be in \(0, 1\), got"):
        visibility_filter(np.array([0.5]), np.array([1.0]), stay=stay, lam=2.0)


@pytest.mark.parametrize("lam", [0.0, -1.0, float("nan")])
def test_bad_lam_raises(lam):
    with pytest.raises(ValueError, match="lam must be > 0, got"):
        visibility_filter(np.array([0.5]), np.array([1.0]), stay=0.9, lam=lam)


def test_windowed_step_compiled_and_numpy_agree():
    """The windowed step (evidence window shifted, its sum filtered) gives the same window and
    the same posteriors whether compiled or not, and matches visibility_filter on the sum."""
    from avtrack.vem import visibility as V

    rng = np.random.default_rng(3)
    p = rng.uniform(0.01, 0.99, 7)
    history = rng.uniform(0.0, 1.0, (7, 3))
    mass = rng.uniform(0.0, 1.2, 7)
    p_np, w_np = V._windowed_visibility_step(p, history, mass, 0.9, 1.0)
    np.testing.assert_array_equal(w_np[:, 0], mass)
    np.testing.assert_array_equal(w_np[:, 1:], history[:, :-1])
    np.testing.assert_allclose(p_np, V.visibility_filter(p, w_np.sum(axis=1), 0.9, 1.0),
                               rtol=1e-15)
    kern = V._window_kernel()
    if kern is not None:
        p_c, w_c = kern(p, history, mass, 0.9, 1.0)
        np.testing.assert_array_equal(w_c, w_np)
        np.testing.assert_allclose(p_c, p_np, rtol=1e-14)
    p_w, w_w = V.windowed_visibility_step(p, history, mass, 0.9, 1.0)
    np.testing.assert_allclose(p_w, p_np, rtol=1e-14)
    np.testing.assert_array_equal(w_w, w_np)
