"""Audio observations of thesis §4.7.2: averaging, sub-bands, low-energy bands, VAD, streaming."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.av.features import (
    AudioFeatureConfig,
    AudioFeatureExtractor,
    AudioFeatures,
    aggregate_frames,
    extract_audio_features,
    video_frame_index,
)


def small_config(**kw) -> AudioFeatureConfig:
    return AudioFeatureConfig(n_bands=2, band_size=2, **kw)


def test_video_frame_index_is_nearest_frame():
    cfg = AudioFeatureConfig()  # 8 ms hop, 16 ms window, 25 fps: five STFT frames per frame
    idx = video_frame_index(np.arange(12), cfg)
    # STFT frame t is centred at 8 (t + 1) ms; video frame f at 40 f ms
    np.testing.assert_array_equal(idx, np.floor((8 * (np.arange(12) + 1)) / 40 + 0.5))
    assert set(np.bincount(video_frame_index(np.arange(500), cfg))[1:-1].tolist()) == {5}


def test_aggregate_hand_computed():
    cfg = small_config(min_valid_fraction=0.5, vad_min_fraction=0.0, max_band_drop_db=60.0)
    n_f, t_ = 128, 4
    values = np.zeros((1, n_f, t_), complex)
    valid = np.zeros((1, n_f, t_), bool)
    values[0, 0, :2] = [0.2 + 0.1j, 0.4 + 0.3j]  # bin 0: two valid frames in video frame 0
    values[0, 1, :2] = [0.6j, 0.6j]
    valid[0, :2, :2] = True
    values[0, 2, 0] = 0.5  # band 1 (bins 2, 3): bin 3 never valid -> inactive
    valid[0, 2, 0] = True
    speech = np.ones((n_f, t_), bool)
    power = np.ones((n_f, t_))
    index = np.array([0, 0, 1, 1])
    out = aggregate_frames(values, valid, speech, power, index, 2, 0, cfg)
    assert out.features.shape == (2, 2, 4)  # D = 2 L (I - 1) = 4
    np.testing.assert_array_equal(out.active, [[True, False], [False, False]])
    # g = (Re c_0, Re c_1, Im c_0, Im c_1) averaged over the valid STFT frames
    np.testing.assert_allclose(out.features[0, 0], [0.3, 0.0, 0.2, 0.6])
    assert np.all(out.features[0, 1] == 0) and np.all(out.features[1] == 0)
    assert out.frame(0)[0].tolist() == [0]


def test_low_energy_bands_and_vad_are_dropped():
    cfg = small_config(min_valid_fraction=0.5, vad_min_fraction=0.5, max_band_drop_db=20.0)
    n_f = 128
    values = np.full((1, n_f, 2), 0.5 + 0.5j)
    valid = np.ones((1, n_f, 2), bool)
    power = np.ones((n_f, 2))
    power[2:4] = 1e-3  # band 1 is 30 dB below band 0
    speech = np.ones((n_f, 2), bool)
    speech[:, 1] = False  # video frame 1 has no speech bins
    out = aggregate_frames(values, valid, speech, power, np.array([0, 1]), 2, 0, cfg)
    np.testing.assert_array_equal(out.vad, [True, False])
    np.testing.assert_array_equal(out.active, [[True, False], [False, False]])
    np.testing.assert_allclose(out.speech_fraction, [1.0, 0.0])


def test_streaming_equals_batch_and_noise_gives_features():
    rng = np.random.default_rng(0)
    fs = 16000
    src = rng.standard_normal(fs)  # 1 s of white noise from a fixed direction (delays)
    sig = np.stack([src, np.roll(src, 2), np.roll(src, 4)])
    sig[:, : fs // 4] *= 1e-3  # a quiet start for the noise tracker
    sig += 1e-4 * rng.standard_normal(sig.shape)
    cfg = AudioFeatureConfig()
    batch = extract_audio_features(sig, fs, 25, cfg)
    ext = AudioFeatureExtractor(3, fs, cfg)
    parts = [ext.process(sig[:, a : a + 1234]) for a in range(0, sig.shape[1], 1234)]
    parts.append(ext.flush(25))
    stream = AudioFeatures.concatenate(parts, 16, batch.feature_dim)
    assert len(stream) == 25
    np.testing.assert_array_equal(stream.active, batch.active)
    np.testing.assert_allclose(stream.features, batch.features, atol=1e-12)
    assert batch.feature_dim == 2 * 8 * 2
    assert not batch.vad[:5].any()  # the quiet start
    assert batch.vad[12:].all() and batch.active[12:].sum(axis=1).min() >= 8
    # a static source: the features hardly change once the estimator has converged
    late = batch.features[15:, 4][batch.active[15:, 4]]
    assert late.std(axis=0).max() < 0.1


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="n_bands"):
        AudioFeatureConfig(n_bands=0)
    with pytest.raises(ValueError, match="exceeds"):
        AudioFeatureConfig(n_bands=17)
    with pytest.raises(ValueError, match="fs must be"):
        AudioFeatureExtractor(2, 8000)
    with pytest.raises(ValueError, match="n_channels"):
        AudioFeatureExtractor(1, 16000)
    with pytest.raises(ValueError, match="audio must be"):
        extract_audio_features(np.zeros(100), 16000, 1)
    with pytest.raises(ValueError, match="n_frames"):
        extract_audio_features(np.zeros((2, 100)), 16000, -1)
    two = AudioFeatureConfig().dprtf_config(2)
    assert two.consistency_threshold == 0.0  # the consistency test needs three channels
