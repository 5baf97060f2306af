"""Noise PSD by minimum statistics, classification, inter-frame spectral subtraction."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.audio.noise import (
    MinimumStatistics,
    NoiseConfig,
    NoiseTracker,
    minimum_bias,
    recursive_average,
)


def test_recursive_average_hand_case():
    # phi_t = beta phi_{t-1} + (1 - beta) p   (eq. 5.10)
    assert recursive_average(np.array(2.0), np.array(4.0), 0.75) == pytest.approx(2.5)
    np.testing.assert_allclose(
        recursive_average(np.array([1 + 1j]), np.array([3j]), 0.5), [0.5 + 2j]
    )


def test_constant_psd_gives_bias_times_the_constant():
    ms = MinimumStatistics(3, NoiseConfig(bias=2.0, window_frames=10, n_subwindows=2))
    for _ in range(25):
        out = ms.update(np.array([1.0, 2.0, 4.0]))
    np.testing.assert_allclose(out, [2.0, 4.0, 8.0])


def test_minimum_is_searched_over_the_window_only():
    cfg = NoiseConfig(bias=1.0, window_frames=8, n_subwindows=4)  # sub-windows of 2 frames
    ms = MinimumStatistics(1, cfg)
    out = [ms.update(np.array([v]))[0] for v in [5, 1] + [3] * 12]
    assert out[1] == 1.0
    # the 1 sits in the first sub-window; it leaves the search after 4 more sub-windows
    assert out[8] == 1.0 and out[9] == 1.0 and out[10] == 3.0


def test_bias_makes_the_noise_level_the_mean_power():
    beta = 0.7
    rng = np.random.default_rng(5)
    ms = MinimumStatistics(200, NoiseConfig(), smoothing=beta)
    psd = np.full(200, 4.0)
    levels = []
    for t in range(600):
        psd = recursive_average(psd, 4.0 * rng.exponential(size=200), beta)
        level = ms.update(psd)
        if t > 200:
            levels.append(level.mean())
    assert np.mean(levels) == pytest.approx(4.0, rel=0.1)
    # smoother periodograms have minima closer to their mean
    assert minimum_bias(0.9, 125, 5) < minimum_bias(0.7, 125, 5) < minimum_bias(0.5, 125, 5)


def test_tracker_classifies_and_subtracts_the_latest_noise_psd():
    cfg = NoiseConfig(bias=1.0, speech_ratio=3.0, noise_ratio=1.5, window_frames=50)
    tr = NoiseTracker(2, (2,), cfg)
    noise_psd = np.array([[1.0, 0.5j], [2.0, 1.0]])
    for _ in range(5):
        speech, noise, cleaned = tr.update(np.array([1.0, 1.0]), noise_psd)
        assert not speech.any() and noise.all()
    loud = np.array([[10.0, 4j], [2.5, 1.0]])
    speech, noise, cleaned = tr.update(np.array([10.0, 1.2]), loud)
    np.testing.assert_array_equal(speech, [True, False])
    np.testing.assert_array_equal(noise, [False, True])
    np.testing.assert_allclose(cleaned[0], loud[0] - noise_psd[0])
    # bin 1 was a noise bin: its PSD is the new noise reference
    np.testing.assert_allclose(tr.update(np.array([1.0, 10.0]), loud)[2][1], [0, 0])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"window_frames": 0}, "window_frames must be a positive integer"),
        ({"n_subwindows": 200}, "n_subwindows must be <= window_frames"),
        ({"bias": -1.0}, "bias must be a positive number"),
        ({"speech_ratio": 1.0, "noise_ratio": 2.0}, "noise_ratio .* must be <= speech_ratio"),
    ],
)
def test_config_validation(kwargs, match):
    with pytest.raises(ValueError, match=match):
        NoiseConfig(**kwargs)


def test_minimum_statistics_validation():
    with pytest.raises(ValueError, match="n_freqs must be a positive integer"):
        MinimumStatistics(0)
    with pytest.raises(ValueError, match="smoothing must be in"):
        MinimumStatistics(4, smoothing=1.0)
