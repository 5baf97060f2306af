"""Recursive-EM baselines (thesis §5.5.1)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from avtrack.localize.rem import PRPREMConfig, REMConfig, rem_update


def test_rem_update_hand_case():
    w = np.array([0.5, 0.5])
    ratios = np.array([[1.5, 0.5], [1.0, 1.0]])  # posteriors (0.75, 0.25) and (0.5, 0.5)
    # w_t = (1 - a) w + a mean_k posterior_k
    np.testing.assert_allclose(
        rem_update(w, ratios, 0.1), 0.9 * w + 0.1 * np.array([0.625, 0.375])
    )
    # the mean ratio over the features gives the same step
    np.testing.assert_allclose(rem_update(w, ratios.mean(axis=0), 0.1), rem_update(w, ratios, 0.1))


@settings(max_examples=100, deadline=None)
@given(
    w=arrays(float, 5, elements=st.floats(1e-9, 1.0)),
    n=arrays(float, (4, 5), elements=st.floats(1e-9, 1e3)),
    rate=st.floats(0.0, 1.0),
)
def test_rem_update_stays_on_the_simplex(w, n, rate):
    w = w / w.sum()
    ratios = n / (n @ w)[:, None]  # valid likelihood ratios
    out = rem_update(w, ratios, rate)
    assert np.all(out >= 0) and out.sum() == pytest.approx(1.0)


def test_configs():
    assert REMConfig().rate == 0.065 and REMConfig().smoothing == 0.0
    prp = PRPREMConfig()
    assert prp.dprtf.ctf_length == 1 and prp.dprtf.phase_only
    with pytest.raises(ValueError, match="rate must be <= 1"):
        REMConfig(rate=2.0)
