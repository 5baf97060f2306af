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


def test_rem_peak_threshold_follows_the_cell_width(static_scene):
    """The REM posterior spreads a talker over a fixed angle, so its mass per cell halves on a
    grid twice as fine: the default threshold scaled with the cell finds the talker in the
    same frames on a 2.5-degree grid as on the 5-degree grid; the 5-degree threshold on the
    finer grid misses some."""
    from avtrack.localize import make_localizer
    from avtrack.localize.grid import DirectionGrid
    from avtrack.localize.peaks import peak_table
    from tests.localize.conftest import SOURCE_AZIMUTH_DEG

    array, x = static_scene

    def frames_on_talker(step: float, threshold: float | None = None) -> int:
        loc = make_localizer("prp-rem", array, DirectionGrid.azimuths(step))
        thr = loc.peak_threshold if threshold is None else threshold
        tab = peak_table(loc.run(x), loc.grid, thr)
        near = np.abs((tab.azimuth_deg - SOURCE_AZIMUTH_DEG + 180) % 360 - 180) <= 20
        return np.unique(tab.frames[tab.active & near]).size

    coarse = make_localizer("prp-rem", array, DirectionGrid.azimuths(5.0))
    fine = make_localizer("prp-rem", array, DirectionGrid.azimuths(2.5))
    assert coarse.peak_threshold == coarse.default_threshold == 0.05
    assert fine.peak_threshold == pytest.approx(0.025)
    n5 = frames_on_talker(5.0)
    assert n5 > 50
    assert abs(frames_on_talker(2.5) - n5) <= 0.1 * n5
    assert frames_on_talker(2.5, threshold=0.05) < 0.9 * n5  # a fifth fewer here
    eg = make_localizer("dprtf-eg", array, DirectionGrid.azimuths(2.5))
    assert eg.peak_threshold == eg.default_threshold  # its peaks' width is set in cells
