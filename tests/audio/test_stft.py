"""STFT front-end: hand cases, whole-signal vs streaming, validation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avtrack.audio.stft import STFTConfig, StreamingSTFT, stft


def test_defaults_are_the_thesis_front_end():
    c = STFTConfig()
    assert (c.fs, c.win_len, c.hop, c.n_freqs, c.window) == (16000, 256, 128, 128, "hann")
    assert c.frame_period_s == pytest.approx(0.008)
    assert c.freqs_hz[1] == pytest.approx(62.5) and c.freqs_hz[-1] == pytest.approx(7937.5)
    # frame t is centred at (t hop + win / 2) / fs = 0.008 (t + 1)
    np.testing.assert_allclose(c.frame_times([0, 1, 9]), [0.008, 0.016, 0.080])
    assert [c.n_frames(n) for n in (0, 255, 256, 383, 384, 1000)] == [0, 0, 1, 1, 2, 6]


def test_one_frame_matches_the_dft_formula():
    c = STFTConfig(fs=8, win_len=8, hop=4, n_freqs=5)
    x = np.arange(12.0)[None, :] ** 1.5
    spec = stft(x, c)
    w = c.window_samples()
    n = np.arange(8)
    for t in range(2):
        for k in range(5):
            expected = np.sum(w * x[0, 4 * t : 4 * t + 8] * np.exp(-2j * np.pi * k * n / 8))
            assert spec[0, k, t] == pytest.approx(expected, abs=1e-12)


def test_sinusoid_peaks_at_its_bin():
    fs = 16000
    t = np.arange(4000) / fs
    x = np.stack([np.cos(2 * np.pi * 1000 * t), np.sin(2 * np.pi * 2500 * t)])
    spec = stft(x)
    assert spec.shape == (2, 128, 30)
    assert np.argmax(np.abs(spec[0]).mean(axis=1)) == 16  # 1000 / 62.5
    assert np.argmax(np.abs(spec[1]).mean(axis=1)) == 40  # 2500 / 62.5


@settings(max_examples=30, deadline=None)
@given(st.lists(st.integers(min_value=0, max_value=700), min_size=1, max_size=12))
def test_streaming_equals_whole_signal(sizes):
    rng = np.random.default_rng(0)
    x = rng.standard_normal((3, sum(sizes)))
    s = StreamingSTFT(3)
    parts, start = [], 0
    for n in sizes:
        parts.append(s.process(x[:, start : start + n]))
        start += n
    streamed = np.concatenate(parts, axis=2)
    whole = stft(x)
    assert streamed.shape == whole.shape
    np.testing.assert_allclose(streamed, whole, rtol=0, atol=1e-12)
    assert s.frames_done == whole.shape[2] and s.samples_seen == x.shape[1]


def test_reset_starts_a_new_signal():
    rng = np.random.default_rng(1)
    x = rng.standard_normal((1, 1000))
    s = StreamingSTFT(1)
    s.process(rng.standard_normal((1, 300)))
    s.reset()
    np.testing.assert_allclose(s.process(x), stft(x), atol=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"hop": 0}, "hop must be a positive integer"),
        ({"hop": 300}, "hop must be <= win_len"),
        ({"n_freqs": 200}, "n_freqs must be <= win_len // 2 \\+ 1"),
        ({"window": "kaiser"}, "window must be one of"),
        ({"fs": 16000.0}, "fs must be a positive integer"),
    ],
)
def test_config_validation(kwargs, match):
    with pytest.raises(ValueError, match=match):
        STFTConfig(**kwargs)


def test_bad_blocks_are_rejected():
    s = StreamingSTFT(2)
    with pytest.raises(ValueError, match="expected 2 channels"):
        s.process(np.zeros((3, 10)))
    with pytest.raises(ValueError, match="2-D array"):
        s.process(np.zeros(10))
    with pytest.raises(ValueError, match="finite"):
        s.process(np.full((2, 10), np.nan))
    with pytest.raises(TypeError, match="real samples"):
        s.process(np.zeros((2, 10), dtype=complex))
    with pytest.raises(ValueError, match="n_channels must be a positive integer"):
        StreamingSTFT(0)
