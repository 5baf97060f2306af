"""SMC-PHD core (Liu et al. eqs. 4–5, 11–13, 18–20): hand-computed updates, ESS, resampling,
weighted moments, births."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.phd.base import PHDConfig
from avtrack.phd.likelihood import make_frame
from avtrack.phd.smc_phd import (
    constant_velocity,
    effective_sample_size,
    log_transition_ratio,
    phd_update,
    sample_birth,
    systematic_resample,
    weighted_moments,
)


def test_constant_velocity():
    F, Q = constant_velocity(2.0, 0.5)
    np.testing.assert_array_equal(F @ [1.0, 2.0, 3.0, 4.0], [4.0, 6.0, 3.0, 4.0])
    np.testing.assert_array_equal(np.diag(Q), [4.0, 4.0, 0.25, 0.25])


def test_phd_update_hand_computed():
    # two particles, one measurement: G = 0.9 (0.8 * 0.5 + 0.2 * 0.5) = 0.45
    lik = np.array([[0.8], [0.2]])
    w = np.array([0.5, 0.5])
    out, G = phd_update(lik, np.array([0.9]), 0.1, np.array([0.05]), w)
    assert G[0] == pytest.approx(0.45)
    expected = (0.1 + 0.9 * lik[:, 0] / (0.05 + 0.45)) * w  # eq. 11
    np.testing.assert_allclose(out, expected)
    # the detected part of a measurement's mass is G / (kappa + G) <= 1
    assert np.sum(out - 0.1 * w) == pytest.approx(0.45 / 0.5)


def test_phd_update_without_measurements_keeps_the_missed_mass():
    w = np.array([0.3, 0.7])
    out, G = phd_update(np.zeros((2, 0)), np.zeros(0), 0.25, np.zeros(0), w)
    np.testing.assert_allclose(out, 0.25 * w)
    assert G.shape == (0,)


def test_effective_sample_size():
    assert effective_sample_size(np.full(40, 0.3)) == pytest.approx(40)
    assert effective_sample_size(np.r_[1.0, np.zeros(9)]) == pytest.approx(1)
    assert effective_sample_size(np.zeros(0)) == 0


def test_systematic_resample():
    rng = np.random.default_rng(0)
    w = np.array([0.1, 0.0, 0.6, 0.3]) * 7  # unnormalised
    idx = systematic_resample(w, 1000, rng)
    counts = np.bincount(idx, minlength=4)
    np.testing.assert_allclose(counts, [100, 0, 600, 300], atol=1)  # systematic: within 1
    with pytest.raises(ValueError, match="positive sum"):
        systematic_resample(np.zeros(3), 5, rng)


def test_weighted_moments_match_numpy():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(30, 4))
    w = rng.random(30)
    g = np.repeat([0, 1, 2], 10)
    mass, mean, cov = weighted_moments(x, w, g, 4)
    for k in range(3):
        sel = g == k
        assert mass[k] == pytest.approx(w[sel].sum())
        np.testing.assert_allclose(mean[k], np.average(x[sel], axis=0, weights=w[sel]))
        # eq. 18: sum w e e^T / sum w (the biased, "population" form)
        np.testing.assert_allclose(cov[k], np.cov(x[sel].T, aweights=w[sel], bias=True))
    assert mass[3] == 0 and np.all(mean[3] == 0) and np.all(cov[3] == 0)


def test_log_transition_ratio():
    rng = np.random.default_rng(2)
    mean = rng.normal(size=(5, 4))
    pred = mean + rng.normal(size=(5, 4))
    info = np.eye(4) / 4.0
    np.testing.assert_array_equal(log_transition_ratio(pred, pred, mean, info), 0)
    moved = pred + 1.0
    ref = -0.5 * (np.sum((moved - mean) ** 2, 1) - np.sum((pred - mean) ** 2, 1)) / 4.0
    np.testing.assert_allclose(log_transition_ratio(moved, pred, mean, info), ref)
    per_particle = np.broadcast_to(info, (5, 4, 4))
    np.testing.assert_allclose(log_transition_ratio(moved, pred, mean, per_particle), ref)


def test_birth_is_the_product_of_the_visual_and_audio_kernels():
    cfg = PHDConfig(birth_std=6.0, sigma_audio=3.0)
    line = np.array([[1.0, 0.0, 100.0]])  # the vertical line x = 100
    frame = make_frame(np.array([[104.0, 50.0], [300.0, 200.0]]), np.array([0.0]), line, 10.0)
    assert frame.pairs.tolist() == [[1, 1], [0, 2]]
    states, which = sample_birth(frame, np.array([0, 1]), 4000, cfg, np.random.default_rng(3))
    assert states.shape == (4000, 4) and np.bincount(which).tolist() == [2000, 2000]
    a, v = states[which == 0], states[which == 1]
    # eq. 13: x ~ N((104/36 + 100/9) / (1/36 + 1/9), 1 / (1/36 + 1/9)), y ~ N(50, 36)
    assert a[:, 0].mean() == pytest.approx(100.8, abs=0.2)
    assert a[:, 0].std() == pytest.approx(np.sqrt(7.2), rel=0.06)
    assert a[:, 1].std() == pytest.approx(6.0, rel=0.06)
    assert v[:, :2].mean(0) == pytest.approx([300, 200], abs=0.5)
    assert v[:, 2:].std() == pytest.approx(cfg.birth_velocity_std, rel=0.06)
    audio_only = make_frame(np.zeros((0, 2)), np.array([0.0]), line, 10.0)
    with pytest.raises(ValueError, match="visual part"):
        sample_birth(audio_only, np.array([0]), 10, cfg, np.random.default_rng(0))
