"""CGMM likelihood ratios, exponentiated-gradient updates (eqs. 5.12-5.19), smoothing."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from avtrack.localize.cgmm_eg import (
    EGConfig,
    cgmm_densities,
    cgmm_likelihood_ratios,
    decay_to_uniform,
    densities_from_coefficients,
    density_coefficients,
    eg_update,
    eg_update_layers,
    evidence_change,
    local_mass,
    local_max,
    mean_ratios,
    place_presence,
    ratios_from_densities,
    snap_to_presence,
    spatial_smoothing,
)
from avtrack.localize.grid import DirectionGrid


def complex_gauss(c, mean, var):
    return np.exp(-(np.abs(c - mean) ** 2) / var) / (np.pi * var)


def test_likelihood_ratios_match_the_direct_formula():
    rng = np.random.default_rng(0)
    feats = rng.standard_normal(5) + 1j * rng.standard_normal(5)
    means = rng.standard_normal((5, 4)) + 1j * rng.standard_normal((5, 4))
    w = np.array([0.1, 0.2, 0.3, 0.4])
    n = complex_gauss(feats[:, None], means, 0.5)
    expected = n / (n @ w)[:, None]  # N_kd / sum_d' w_d' N_kd'   (eq. 5.17)
    np.testing.assert_allclose(cgmm_likelihood_ratios(feats, means, w, 0.5), expected)
    # far-away features with a tiny variance: no underflow
    r = cgmm_likelihood_ratios(feats + 50, means, w, 1e-3)
    assert np.all(np.isfinite(r)) and np.allclose(r @ w, 1.0)


def test_densities_from_precomputed_coefficients_match_the_direct_formula():
    rng = np.random.default_rng(1)
    feats = rng.standard_normal(6) + 1j * rng.standard_normal(6)
    means = rng.standard_normal((6, 5)) + 1j * rng.standard_normal((6, 5))
    n = complex_gauss(feats[:, None], means, 0.3)
    expected = n / n.max(axis=1, keepdims=True)  # each row scaled to its largest entry
    coef = density_coefficients(means, 0.3)
    assert coef.shape == (6, 3, 5)
    np.testing.assert_allclose(densities_from_coefficients(feats, coef), expected, rtol=1e-12)
    np.testing.assert_allclose(cgmm_densities(feats, means, 0.3), expected, rtol=1e-12)
    # a 1-feature hand case: c = 1 + 1j, means 1 + 1j and 0, sigma^2 = 1: densities 1, e^-2
    d = densities_from_coefficients(np.array([1 + 1j]), density_coefficients(
        np.array([[1 + 1j, 0j]]), 1.0))
    np.testing.assert_allclose(d, [[1.0, np.exp(-2.0)]], rtol=1e-12)


@settings(max_examples=40, deadline=None)
@given(
    dens=arrays(np.float64, (7, 4), elements=st.floats(1e-6, 1.0)),
    raw_w=arrays(np.float64, 4, elements=st.floats(0.01, 1.0)),
)
def test_mean_ratios_is_the_mean_of_the_ratios(dens, raw_w):
    w = raw_w / raw_w.sum()
    ratios = ratios_from_densities(dens, w)
    np.testing.assert_allclose(mean_ratios(dens, w), ratios.mean(axis=0), rtol=1e-10)
    # the updates take either form and give the same weights
    np.testing.assert_allclose(eg_update(w, ratios, 0.3, 0.1),
                               eg_update(w, mean_ratios(dens, w), 0.3, 0.1), rtol=1e-10)
    np.testing.assert_allclose(evidence_change(w, ratios),
                               evidence_change(w, mean_ratios(dens, w)), rtol=1e-9, atol=1e-12)
    layers = np.vstack([w, w]) / 2
    np.testing.assert_allclose(eg_update_layers(layers, ratios, 0.3, 0.1),
                               eg_update_layers(layers, mean_ratios(dens, w), 0.3, 0.1),
                               rtol=1e-10)


def test_eg_update_hand_case():
    w = np.array([0.25, 0.25, 0.5])
    ratios = np.array([[2.0, 1.0, 0.5], [1.0, 1.0, 1.0]])
    eta, gamma = 0.5, 0.1
    grad_l = -ratios.mean(axis=0)
    grad_h = -(1 + np.log(w))
    r = np.exp(-eta * (grad_l + gamma * grad_h))  # eq. 5.18
    np.testing.assert_allclose(eg_update(w, ratios, eta, gamma), r * w / np.sum(r * w))
    # the best-explained direction gains weight
    assert eg_update(w, ratios, eta, 0.0)[0] > 0.25


def test_entropy_term_sharpens():
    w = np.array([0.2, 0.3, 0.5])
    flat = np.ones((1, 3))
    assert eg_update(w, flat, 0.1, 0.5)[2] > 0.5 > eg_update(w, flat, 0.1, 0.0)[2] - 1e-15


@settings(max_examples=200, deadline=None)
@given(
    w=arrays(float, 6, elements=st.floats(1e-12, 1.0)),
    ratios=arrays(float, (3, 6), elements=st.floats(0.0, 1e6)),
    eta=st.floats(1e-3, 5.0),
    gamma=st.floats(0.0, 2.0),
)
def test_eg_update_stays_on_the_simplex(w, ratios, eta, gamma):
    w = w / w.sum()
    out = eg_update(w, ratios, eta, gamma)
    assert np.all(np.isfinite(out)) and np.all(out >= 0)
    assert out.sum() == pytest.approx(1.0, abs=1e-12)
    g = DirectionGrid.azimuths(60.0)
    s = spatial_smoothing(decay_to_uniform(out, 0.065), g, 0.02)
    assert np.all(s > 0) and s.sum() == pytest.approx(1.0, abs=1e-12)


def test_silence_relaxes_to_uniform():
    w = np.array([1.0, 0.0, 0.0, 0.0])
    out = decay_to_uniform(w, 0.065)
    np.testing.assert_allclose(out, [0.935 + 0.065 / 4, 0.065 / 4, 0.065 / 4, 0.065 / 4])
    for _ in range(300):
        out = decay_to_uniform(out, 0.065)
    np.testing.assert_allclose(out, 0.25, atol=1e-8)


def test_spatial_smoothing_hand_case_wraps_around():
    g = DirectionGrid.azimuths(90.0)  # -90, 0, 90, 180
    w = np.array([1.0, 0.0, 0.0, 0.0])
    # w_d <- (w_d + 0.02 w_{d-1} + 0.02 w_{d+1}) / 1.04, circular
    np.testing.assert_allclose(
        spatial_smoothing(w, g, 0.02), [1 / 1.04, 0.02 / 1.04, 0, 0.02 / 1.04]
    )
    lin = DirectionGrid([-30.0, 0.0, 30.0], [0.0])
    out = spatial_smoothing(np.array([0.0, 0.0, 1.0]), lin, 0.5)
    np.testing.assert_allclose(out, [0.0, 1 / 3, 2 / 3])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"variance": 0.0}, "variance must be a finite number > 0"),
        ({"step": -1.0}, "step must be"),
        ({"silence_rate": 1.5}, "silence_rate must be <= 1"),
        ({"dprtf": {}}, "dprtf must be a DPRTFConfig"),
        ({"share": 1.5}, "share must be <= 1"),
        ({"share": -0.1}, "share must be a finite number >= 0"),
        ({"step_boost": float("nan")}, "step_boost must be a finite number >= 0"),
        ({"output_silence_rate": 0.0}, "output_silence_rate must be a finite number > 0"),
        ({"output_silence_rate": 2.0}, "output_silence_rate must be <= 1"),
        ({"position_step": 0.0}, "position_step must be a finite number > 0"),
        ({"position_smoothing": 1.5}, "position_smoothing must be <= 1"),
        ({"position_share": -0.1}, "position_share must be a finite number >= 0"),
        ({"presence_reach": -1}, "presence_reach must be an integer >= 0"),
        ({"snap_reach": 1.5}, "snap_reach must be an integer >= 0"),
        ({"still_prior": 0.0}, "still_prior must be None or in"),
        ({"still_prior": 1.0}, "still_prior must be None or in"),
        ({"still_prior": True}, "still_prior must be None or in"),
        ({"still_prior": 0.3}, "still_prior needs position_velocities_deg_s"),
        ({"still_prior": 0.3, "position_velocities_deg_s": (-30.0, 30.0)},
         "still_prior needs position_velocities_deg_s"),
    ],
)
def test_config_validation(kwargs, match):
    with pytest.raises((ValueError, TypeError), match=match):
        EGConfig(**kwargs)


def test_evidence_change_hand_cases():
    w = np.array([0.7, 0.1, 0.1, 0.1])
    # features that only the first direction explains: posterior = (1, 0, 0, 0)
    ratios = np.array([[1 / 0.7, 0, 0, 0]] * 3)
    assert evidence_change(w, ratios) == pytest.approx(0.3)
    # features spread like the weights themselves: ratio 1 everywhere, no change
    assert evidence_change(w, np.ones((2, 4))) == pytest.approx(0.0, abs=1e-15)
    # features from the second direction only: posterior (0, 1, 0, 0)
    assert evidence_change(w, np.array([[0, 10.0, 0, 0]])) == pytest.approx(0.9)


def _eg(config):
    from avtrack.audio.arrays import builtin_array
    from avtrack.localize import make_localizer

    return make_localizer("dprtf-eg", builtin_array("nao4"), DirectionGrid.azimuths(90.0), config)


def test_fixed_share_keeps_a_floor_and_adaptive_step_moves_faster():
    ratios = np.array([[0.0, 1 / 0.1, 0.0, 0.0]] * 4)  # the talker is where w is small
    w = np.array([0.7, 0.1, 0.1, 0.1])
    plain = _eg(EGConfig(smoothing=0.0))._update(w, ratios)
    boosted = _eg(EGConfig(smoothing=0.0, step_boost=10.0))._update(w, ratios)
    assert boosted[1] > plain[1] and boosted[0] < plain[0]  # the step grew with the change
    np.testing.assert_allclose(plain, eg_update(w, ratios, 0.07, 0.1))
    shared = _eg(EGConfig(share=0.04))._update(np.array([1.0, 0, 0, 0]), np.ones((1, 4)))
    assert shared.min() >= 0.04 / 4 and shared.sum() == pytest.approx(1.0)


def test_evidence_gated_output_relaxes_without_features():
    loc = _eg(EGConfig(output_silence_rate=0.5))
    w = np.array([0.7, 0.1, 0.1, 0.1])
    np.testing.assert_array_equal(loc._emit(w, np.ones((1, 4))), w)
    np.testing.assert_allclose(loc._emit(np.full(4, 9.0), None), 0.5 * w + 0.5 / 4)
    assert _eg(EGConfig())._emit(w, None) is w  # the thesis: the heat map is w_t


def test_local_mass_hand_cases():
    circ = DirectionGrid.azimuths(90.0)  # 4 azimuths, circular
    w = np.array([0.5, 0.2, 0.1, 0.2])
    np.testing.assert_allclose(local_mass(w, circ, 0), w)
    # w_{d-1} + w_d + w_{d+1}, wrapping around
    np.testing.assert_allclose(local_mass(w, circ, 1), [0.9, 0.8, 0.5, 0.8])
    lin = DirectionGrid([0.0, 10.0, 20.0, 30.0, 40.0], [0.0])  # 5 cells, not circular
    assert not lin.circular
    np.testing.assert_allclose(local_mass(np.arange(5.0), lin, 2), [3, 6, 10, 10, 9])


def test_local_max_hand_cases():
    circ = DirectionGrid.azimuths(60.0)  # 6 azimuths, circular
    x = np.array([5.0, 1.0, 0.0, 2.0, 0.0, 1.0])
    np.testing.assert_array_equal(local_max(x, circ, 0), x)
    np.testing.assert_array_equal(local_max(x, circ, 1), [5, 5, 2, 2, 2, 5])
    lin = DirectionGrid([0.0, 10.0, 20.0, 30.0], [0.0])  # not circular
    np.testing.assert_array_equal(local_max(np.array([4.0, 0, 0, 1]), lin, 1), [4, 4, 1, 1])


def test_place_presence_moves_the_slow_mass_onto_the_fast_peak():
    g = DirectionGrid.azimuths(30.0)  # 12 azimuths
    w = np.full(12, 0.01)
    w[[1, 2]] = [0.6, 0.3]  # slow: a talker at cell 1 (sums to 1)
    v = np.full(12, 0.01)
    v[[2, 3, 4]] = [0.1, 0.71, 0.1]  # fast: the talker is at cell 3
    h = place_presence(v, w, g, 2)
    # P_d(x) = max_{|j| <= 2} M_{d+j}(x),  M_d(x) = x_{d-2} + ... + x_{d+2}
    p_w, p_v = local_max(local_mass(w, g, 2), g, 2), local_max(local_mass(v, g, 2), g, 2)
    np.testing.assert_allclose(h, v * p_w / p_v)
    # around the fast peak both factors are flat: M_3(w) = 0.6 + 0.3 + 3 * 0.01 (cells 1..5),
    # M_3(v) = 0.1 + 0.71 + 0.1 + 2 * 0.01
    np.testing.assert_allclose(p_w[2:5], 0.93)
    np.testing.assert_allclose(p_v[2:5], 0.93)
    np.testing.assert_allclose(h[2:5], v[2:5])  # the shape of v, the mass of w
    assert np.argmax(h) == 3
    # far from the slow mass (M_d(w) = 5 * 0.01 for d = 6..10), a bump of v is scaled down:
    # P_8(v) = M_6(v) = v_4 + v_5 + v_6 + v_7 + v_8 = 0.1 + 3 * 0.01 + 0.3
    v2 = v.copy()
    v2[8] = 0.3
    assert place_presence(v2, w, g, 2)[8] == pytest.approx(0.3 * 0.05 / 0.43)


def test_snap_moves_a_peak_of_v_to_the_peak_of_w_beside_it():
    g = DirectionGrid.azimuths(30.0)  # 12 azimuths, circular
    # two peaks of v: cell 3 (its slopes cells 0..6) and cell 9 (cells 7..11)
    v = np.array([0.02, 0.05, 0.2, 0.5, 0.2, 0.05, 0.02, 0.01, 0.02, 0.05, 0.03, 0.025])
    heat = v.copy()
    w = np.full(12, 0.02)
    w[4] = 0.5  # the slow weights' peak one cell beside v's first peak
    w[[10, 11]] = [0.1, 0.2]  # and two cells beside the second one (climbing from 9: 11)
    out = snap_to_presence(heat, v, w, g, 1)
    # the first peak's slopes move one cell up, as one block; the second stays (2 > reach)
    assert np.argmax(out) == 4
    np.testing.assert_allclose(out[[3, 4, 5]], heat[[2, 3, 4]])
    assert out[9] == heat[9] and out[10] == heat[10]
    assert out.sum() == pytest.approx(heat.sum())
    out2 = snap_to_presence(heat, v, w, g, 2)  # within reach 2 the second moves too
    assert out2[11] == heat[9]
    np.testing.assert_array_equal(snap_to_presence(heat, v, w, g, 0), heat)


def test_snap_wraps_around_on_a_circular_grid_and_stops_at_the_ends_of_a_line():
    circ = DirectionGrid.azimuths(30.0)
    v = np.full(12, 0.01)
    v[0] = 0.8
    w = np.full(12, 0.01)
    w[11] = 0.8  # one cell below 0, across the wrap
    out = snap_to_presence(v, v, w, circ, 1)
    assert np.argmax(out) == 11 and out.sum() == pytest.approx(v.sum())
    line = DirectionGrid(np.arange(0.0, 181.0, 30.0), np.zeros(1))  # 7 azimuths, not circular
    v = np.full(7, 0.01)
    v[5] = 0.8
    w = np.full(7, 0.01)
    w[6] = 0.8
    out = snap_to_presence(v, v, w, line, 1)
    assert np.argmax(out) == 6 and out.sum() == pytest.approx(v.sum())  # cell 6 keeps 5 and 6


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(0, 4))
def test_snap_keeps_the_maps_mass_and_moves_no_value_further_than_reach(seed, reach):
    rng = np.random.default_rng(seed)
    g = DirectionGrid.sphere(30.0, (0.0, 30.0))  # two elevation rows of 12
    v, w, heat = rng.random((3, g.size))
    out = snap_to_presence(heat, v, w, g, reach)
    assert out.sum() == pytest.approx(heat.sum())
    assert np.all(out >= 0)
    # each row keeps its own mass: cells move only along azimuth
    np.testing.assert_allclose(out.reshape(2, 12).sum(1), heat.reshape(2, 12).sum(1))


def test_the_fast_maps_run_keeps_the_thesis_weights_of_dprtf_eg():
    """``keep_presence``: after each ``process`` the fast localizer's ``w_t`` are exactly the
    ``dprtf-eg`` heat maps of the same blocks."""
    from avtrack.audio.arrays import builtin_array
    from avtrack.localize import make_localizer

    array = builtin_array("nao4")
    rng = np.random.default_rng(3)
    x = rng.standard_normal((array.n_mics, 16000))
    x[:, 4000:] += np.roll(x[:1, 4000:], 1, axis=1)  # a coherent source after 0.25 s
    eg = make_localizer("dprtf-eg", array)
    fast = make_localizer("dprtf-eg-fast", array)
    fast.keep_presence = True
    eg.reset()
    fast.reset()
    for i in range(0, x.shape[1], 3000):
        a = eg.process(x[:, i : i + 3000])
        b = fast.process(x[:, i : i + 3000])
        if len(a):
            np.testing.assert_array_equal(fast.presence, a.weights)
            assert not np.array_equal(b.weights, a.weights)


def test_position_weights_follow_eqs_5_17_to_5_19_with_their_own_step():
    cfg = EGConfig(position_step=0.3, position_smoothing=0.0, position_share=0.04)
    loc = _eg(cfg)
    w = np.array([0.7, 0.1, 0.1, 0.1])
    dens = np.array([[0.1, 1.0, 0.2, 0.1], [0.2, 1.0, 0.1, 0.1]])
    v0 = loc.position.copy()  # uniform
    heat = loc._emit(w, dens)
    ratios = dens / (dens @ v0)[:, None]
    v1 = decay_to_uniform(eg_update(v0, ratios, 0.3, 0.1), 0.04)
    np.testing.assert_allclose(loc.position, v1)
    np.testing.assert_allclose(heat, place_presence(v1, w, loc.grid, cfg.presence_reach))
    loc._emit(w, None)  # a silent frame: v relaxes at eta'
    np.testing.assert_allclose(loc.position, decay_to_uniform(v1, 0.065))


def _synthetic_lag(config):
    """Lag (frames) of the heat map's argmax behind a talker walking at 30 deg/s, from
    CGMM densities drawn around the talker's direction (8 ms frames, 5 degree grid). A map
    with ``smoother_lag_s`` is read as its frames' smoothed maps once the signal has ended."""
    rng = np.random.default_rng(0)
    loc = _eg(config)
    loc.grid = DirectionGrid.azimuths()
    loc._reset_state()
    az = loc.grid.azimuth_deg
    n = 600
    truth = -60.0 + 0.24 * np.arange(n)  # 30 deg/s
    w = loc.weights
    heat = np.empty((n, az.size))
    for t in range(n):
        a = truth[t] + 5.0 * rng.standard_normal(40)  # 40 features scattered around the talker
        dens = np.exp(-0.5 * ((az[None, :] - a[:, None]) / 15.0) ** 2) + 1e-3
        w, heat[t] = loc._frame(w, dens)
    if config.smoother_lag_s is not None:
        loc._held_counts = [40] * n  # as _process_stft records them
        heat, counts = loc._smoothed(final=True)
        assert heat.shape == (n, az.size) and np.all(counts == 40)
    peak = az[np.argmax(heat, axis=1)]
    shifts = np.arange(0, 80)
    err = [np.mean(np.abs(peak[200:] - truth[200 - s : n - s])) for s in shifts]
    return int(shifts[np.argmin(err)])


def test_the_smoother_shortens_the_trail_of_a_small_still_walk():
    """With the zero-velocity layer's walk at 0.03, the map trails a talker walking at 30
    deg/s by over 25 frames; read 0.2 s late it trails by under 20."""
    layers = dict(position_step=0.3, position_smoothing=0.07, still_smoothing=0.03,
                  position_velocities_deg_s=(-60.0, -30.0, 0.0, 30.0, 60.0))
    assert _synthetic_lag(EGConfig(**layers)) > 25
    assert _synthetic_lag(EGConfig(**layers, smoother_lag_s=0.2)) < 20
    with pytest.raises(ValueError, match="smoother_lag_s needs the position weights"):
        EGConfig(smoother_lag_s=0.2)
    with pytest.raises(ValueError, match="smoother_gap_s must be a finite number > 0"):
        EGConfig(**layers, smoother_lag_s=0.2, smoother_gap_s=0.0)


def test_position_weights_follow_a_moving_talker_with_a_short_lag():
    thesis = _synthetic_lag(EGConfig())
    fast = _synthetic_lag(EGConfig(position_step=0.3))
    assert thesis > 20  # the thesis weights trail the talker
    assert fast <= 10


def test_drift_moves_mass_by_linear_interpolation():
    from avtrack.localize.cgmm_eg import drift

    grid = DirectionGrid.azimuths(90.0)  # -90, 0, 90, 180 (circular)
    w = np.array([0.0, 1.0, 0.0, 0.0])
    np.testing.assert_allclose(drift(w, grid, 0.25), [0.0, 0.75, 0.25, 0.0])
    np.testing.assert_allclose(drift(w, grid, -1.0), [1.0, 0.0, 0.0, 0.0])
    np.testing.assert_allclose(drift(np.array([0.1, 0.2, 0.3, 0.4]), grid, 1.0),
                               [0.4, 0.1, 0.2, 0.3])  # wraps around
    line = DirectionGrid(np.array([0.0, 10.0, 20.0]), np.zeros(1))
    np.testing.assert_allclose(drift(np.array([0.0, 0.0, 1.0]), line, 0.5), [0, 0, 0.5])
    with pytest.raises(ValueError, match=r"cells must be in \[-1, 1\]"):
        drift(w, grid, 1.5)


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(0.01, 1.0), min_size=8, max_size=8), st.floats(-1.0, 1.0))
def test_drift_keeps_the_mass_on_a_circle(values, cells):
    from avtrack.localize.cgmm_eg import drift

    w = np.asarray(values)
    out = drift(w, DirectionGrid.azimuths(45.0), cells)
    assert np.all(out >= 0) and np.isclose(out.sum(), w.sum())


def test_layered_eg_update_with_one_layer_is_the_plain_update():
    from avtrack.localize.cgmm_eg import eg_update, eg_update_layers

    rng = np.random.default_rng(0)
    w = rng.dirichlet(np.ones(6))
    ratios = rng.uniform(0.1, 3.0, size=(5, 6))
    np.testing.assert_allclose(eg_update_layers(w[None], ratios, 0.3, 0.1)[0],
                               eg_update(w, ratios, 0.3, 0.1))
    # two layers: each direction's layers get the same gradient; the total sums to one
    layers = np.stack([0.25 * w, 0.75 * w])
    out = eg_update_layers(layers, ratios, 0.3, 0.0)
    assert np.isclose(out.sum(), 1.0)
    np.testing.assert_allclose(out[0] / out[1], 1 / 3)


def test_velocity_layers_follow_a_moving_talker_with_a_small_random_walk():
    walk = _synthetic_lag(EGConfig(position_step=0.3, position_smoothing=0.05))
    layers = _synthetic_lag(EGConfig(position_step=0.3, position_smoothing=0.05,
                                     position_velocities_deg_s=(-60.0, -30.0, 0.0, 30.0, 60.0)))
    assert walk > 20  # a small random walk alone trails the talker
    assert layers <= 10
    with pytest.raises(ValueError, match="position_velocities_deg_s must be a non-empty list"):
        EGConfig(position_velocities_deg_s=())
    with pytest.raises(ValueError, match="must move at most one azimuth cell"):
        _eg(EGConfig(position_step=0.3, position_velocities_deg_s=(1e6,)))


def test_still_prior_is_the_stationary_share_of_the_zero_velocity_layer():
    """The velocity switch is a Markov chain over the layers: without evidence, each
    direction's mass settles to ``still_prior`` in the zero-velocity layer (the rest shared
    by the moving layers); without ``still_prior``, to equal shares; mass is kept."""
    velocities = (-60.0, -30.0, 0.0, 30.0, 60.0)
    shares = {}
    for prior in (None, 0.6):
        loc = _eg(EGConfig(position_step=0.3, position_velocities_deg_s=velocities,
                           velocity_switch=0.05, silence_rate=1e-9, still_prior=prior))
        loc.position_layers = np.zeros_like(loc.position_layers)
        loc.position_layers[0] = 0.25  # all the mass in the -60 deg/s layer
        for _ in range(600):
            total = loc._position_step(None)
        assert total.sum() == pytest.approx(1.0)
        shares[prior] = loc.position_layers.sum(axis=1)
    np.testing.assert_allclose(shares[None], 0.2, atol=1e-3)
    np.testing.assert_allclose(shares[0.6], [0.1, 0.1, 0.6, 0.1, 0.1], atol=1e-3)


def test_presence_by_peak_keeps_the_position_peaks_in_place():
    from avtrack.localize.cgmm_eg import place_presence, place_presence_by_peak, uphill

    grid = DirectionGrid.azimuths(45.0)  # 8 cells, circular
    v = np.array([1.0, 2.0, 3.0, 2.0, 1.0, 5.0, 4.0, 0.5])
    np.testing.assert_array_equal(uphill(v, grid), [2, 2, 2, 2, 5, 5, 5, 5])
    # a broad peak of v at cell 2 with the presence mass beside it (cells 4-5)
    v = np.array([0.5, 3.0, 4.0, 3.9, 0.5, 0.1, 0.1, 0.1])
    w = np.array([0.0, 0.0, 0.0, 0.0, 5.0, 5.0, 0.0, 0.0])
    by_peak = place_presence_by_peak(v, w, grid, 1)
    slope = uphill(v, grid) == 2
    ratio = by_peak[slope] / v[slope]
    np.testing.assert_allclose(ratio, ratio[0])  # one scale for the whole slope
    assert np.argmax(by_peak) == 2
    # the per-cell ratio tilts the peak towards the presence mass
    assert np.argmax(place_presence(v, w, grid, 1)) == 3


@pytest.mark.slow
def test_still_prior_keeps_a_standing_talkers_peaks_on_it(tmp_path):
    """One standing talker 1.7 m from an 8-microphone circle (4.6 cm radius) in a reverberant
    room (T60 0.44 s): with equal layer shares the fast map's peaks wander along the moving
    layers, up to 30 degrees from the talker; with most of the mass kept still they stay."""
    import json
    from dataclasses import replace

    from avtrack.io.scenario import validate_scenario
    from avtrack.localize import make_localizer, peak_table
    from avtrack.localize.cgmm_eg import FastEGConfig
    from avtrack.simulate.library import named_scenario
    from avtrack.simulate.scene import simulate_scene

    phi = np.deg2rad(45.0 * np.arange(8))
    ring = 0.0463 * np.stack([np.cos(phi), np.sin(phi), np.zeros(8)], axis=1)
    path = tmp_path / "circle8.json"
    path.write_text(json.dumps({"name": "circle8", "positions": ring.tolist()}))
    raw = named_scenario("array-talkers", 3, 8.0)
    raw["people"] = raw["people"][:1]
    raw["array"]["name"] = str(path)
    scene = simulate_scene(validate_scenario(raw))
    gt = scene.doa
    r = np.deg2rad(gt.azimuth_deg[gt.active])
    talker = np.rad2deg(np.arctan2(np.sin(r).mean(), np.cos(r).mean()))
    far = {}
    for prior in (None, 0.3):
        loc = make_localizer("dprtf-eg-fast", scene.array,
                             config=replace(FastEGConfig(), still_prior=prior))
        heat = loc.run(scene.audio)
        table = peak_table(heat, loc.grid, loc.default_threshold, reduce=loc.profile_reduce)
        err = np.abs((np.asarray(table.azimuth_deg) - talker + 180.0) % 360.0 - 180.0)
        far[prior] = int(np.count_nonzero(err > 10.0))
    assert far[0.3] <= 0.5 * far[None]
