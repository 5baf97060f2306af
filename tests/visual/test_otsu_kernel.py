"""The compiled Otsu split (avtrack.visual._otsu_kernel) gives the NumPy form's numbers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avtrack.visual import _otsu_kernel as K
from avtrack.visual import scores as S

pytestmark = pytest.mark.skipif(K.kernel() is None, reason="Numba cannot build the kernel here")


@pytest.mark.parametrize("n", [1, 2, 7, 8, 9, 15, 16, 17, 128, 129, 130, 257, 1000, 4099, 20000])
def test_pairwise_sum_is_numpys_add_reduce_to_the_bit(n):
    rng = np.random.default_rng(n)
    a = rng.normal(size=n) * 10.0 ** rng.uniform(-3, 3, size=n)
    assert K.pairwise_sum(a) == np.add.reduce(a)


def _numpy_split(x: np.ndarray) -> float | None:
    """The NumPy form of otsu_threshold_sorted (the kernel switched off)."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(S, "_compiled", lambda: False)
        return S.otsu_threshold_sorted(x)


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n_true=st.integers(0, 3000), n_false=st.integers(0, 800),
       gap=st.floats(0.0, 0.6))
def test_compiled_split_equals_the_numpy_one(seed, n_true, n_false, gap):
    rng = np.random.default_rng(seed)
    x = np.sort(np.concatenate([rng.normal(0.35 + gap, 0.1, n_true),
                                rng.normal(0.35, 0.12, n_false)]))
    expected = _numpy_split(x)
    got = K.kernel()(x, S.BINS, S.MIN_SEPARATION)
    if expected is None:
        assert math.isnan(got)
    else:
        assert got == expected


def test_the_tracker_asks_the_compiled_split():
    x = np.sort(np.concatenate([np.random.default_rng(1).normal(0.9, 0.03, 300),
                                np.random.default_rng(2).normal(0.55, 0.05, 80)]))
    t = S.otsu_threshold_sorted(x)
    assert t is not None and t == _numpy_split(x)
