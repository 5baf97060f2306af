"""Tests of avtrack.visual.appearance: Bhattacharyya (thesis eq. 3.5) and cosine appearance
log ratios at their extremes, normalisation, and argument validation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from avtrack.visual.appearance import (
    APPEARANCE_MODELS,
    BhattacharyyaAppearance,
    CosineAppearance,
)

# √(1 - BC) turns a rounding error of 1e-16 in BC into ~1e-8 in d_B
SQRT_EPS = 1e-7


def test_bhattacharyya_identical_histograms_give_distance_zero():
    model = BhattacharyyaAppearance(lam=10.0, neutral_distance=0.4)
    rng = np.random.default_rng(0)
    h = model.normalize(rng.uniform(size=(3, 16)))
    ratio = model.log_ratio(h, h)
    # d_B = 0 on the diagonal: log ratio = -λ (0 - d0) = λ d0 = 4
    np.testing.assert_allclose(np.diag(ratio), 4.0, rtol=0, atol=10 * SQRT_EPS)


def test_bhattacharyya_disjoint_histograms_give_distance_one():
    model = BhattacharyyaAppearance(lam=10.0, neutral_distance=0.4)
    h = model.normalize(np.array([[1.0, 2.0, 0.0, 0.0], [0.0, 0.0, 3.0, 1.0]]))
    ratio = model.log_ratio(h[:1], h[1:])
    # BC = 0, d_B = 1: log ratio = -10 (1 - 0.4) = -6
    np.testing.assert_allclose(ratio, [[-6.0]], rtol=0, atol=1e-14)


def test_bhattacharyya_by_hand():
    model = BhattacharyyaAppearance(lam=2.0, neutral_distance=0.5)
    a = np.array([[0.5, 0.5]])
    b = np.array([[1.0, 0.0]])
    # BC = √(0.5·1) = 0.7071067812; d_B = √(1 - BC) = 0.5411961001; -2 (d_B - 0.5) = -0.0823922
    np.testing.assert_allclose(model.log_ratio(a, b), [[-0.0823922003]], rtol=0, atol=1e-9)


def test_bhattacharyya_normalize():
    model = BhattacharyyaAppearance()
    h = model.normalize(np.array([[1.0, 3.0], [0.0, 0.0]]))
    # a zero histogram becomes uniform instead of dividing by zero
    np.testing.assert_allclose(h, [[0.25, 0.75], [0.5, 0.5]])
    with pytest.raises(ValueError, match="non-negative"):
        model.normalize(np.array([[1.0, -0.1]]))


@settings(max_examples=50, deadline=None)
@given(hnp.arrays(np.float64, (4, 6), elements=st.floats(0, 100)))
def test_bhattacharyya_ratio_is_bounded(raw):
    model = BhattacharyyaAppearance(lam=3.0, neutral_distance=0.25)
    h = model.normalize(raw)
    ratio = model.log_ratio(h, h)
    # d_B ∈ [0, 1]: ratio ∈ [-λ (1 - d0), λ d0]
    assert np.all(ratio <= 3.0 * 0.25 + 1e-12)
    assert np.all(ratio >= -3.0 * 0.75 - 1e-12)
    np.testing.assert_allclose(ratio, ratio.T, rtol=0, atol=1e-12)


def test_cosine_identical_and_orthogonal():
    model = CosineAppearance(kappa=10.0, neutral_similarity=0.5)
    e = model.normalize(np.array([[3.0, 4.0, 0.0], [0.0, 0.0, 2.0], [0.0, 0.0, 0.0]]))
    np.testing.assert_allclose(e, [[0.6, 0.8, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]])
    ratio = model.log_ratio(e[:2], e[:2])
    # identical: κ (1 - c0) = 5; orthogonal: κ (0 - c0) = -5
    np.testing.assert_allclose(ratio, [[5.0, -5.0], [-5.0, 5.0]], rtol=0, atol=1e-14)
    # opposite: κ (-1 - c0) = -15
    np.testing.assert_allclose(model.log_ratio(e[:1], -e[:1]), [[-15.0]], rtol=0, atol=1e-14)


@pytest.mark.parametrize(("cls", "kwargs", "match"), [
    (BhattacharyyaAppearance, {"lam": 0.0}, "lam must be > 0, got 0.0"),
    (BhattacharyyaAppearance, {"neutral_distance": 1.0},
     r"neutral_distance must be in \(0, 1\), got 1.0"),
    (CosineAppearance, {"kappa": -1.0}, "kappa must be > 0, got -1.0"),
    (CosineAppearance, {"neutral_similarity": 1.0},
     r"neutral_similarity must be in \(-1, 1\), got 1.0"),
])
def test_bad_parameters(cls, kwargs, match):
    with pytest.raises(ValueError, match=match):
        cls(**kwargs)


def test_registry():
    assert APPEARANCE_MODELS == {"bhattacharyya": BhattacharyyaAppearance,
                                 "cosine": CosineAppearance}
