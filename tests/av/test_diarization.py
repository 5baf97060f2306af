"""Diarization (thesis eq. 4.34), speaker turns, and the audio-only baseline."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.av.diarization import (
    audio_only_diarization,
    localize_frames,
    speaking_segments,
    speaking_status,
    unseen_speakers,
)
from avtrack.av.features import AudioFeatures
from avtrack.av.gllim import AudioImageMapping, GLLiM


def test_speaking_status_is_eq_4_34():
    share = np.array([[0.5, 0.2], [0.3, 0.3], [0.9, 0.0]])
    n_bands = np.array([4, 5, 0])
    np.testing.assert_array_equal(
        speaking_status(share, n_bands, 0.3), [[True, False], [True, True], [False, False]]
    )
    with pytest.raises(ValueError, match="gamma"):
        speaking_status(share, n_bands, 0.0)


def test_speaking_segments_merge_bridge_and_drop():
    fps = 25.0
    frames = np.array([1, 2, 3, 6, 7, 20, 21, 22, 23, 24, 30])
    ids = np.array([1, 1, 1, 1, 1, 2, 2, 2, 2, 2, 2])
    on = np.ones(11, bool)
    segs = speaking_segments(frames, ids, on, fps)
    # frame f covers [(f - 1.5) / fps, (f - 0.5) / fps)
    got = [(s.speaker, round(s.start, 3), round(s.end, 3)) for s in segs]
    assert got == [("P1", 0.0, 0.1), ("P1", 0.18, 0.26), ("P2", 0.74, 0.94), ("P2", 1.14, 1.18)]
    bridged = speaking_segments(frames, ids, on, fps, max_gap=0.1, min_duration=0.1)
    got = [(s.speaker, round(s.start, 3), round(s.end, 3)) for s in bridged]
    assert got == [("P1", 0.0, 0.26), ("P2", 0.74, 0.94)]
    with pytest.raises(ValueError, match="same length"):
        speaking_segments(frames, ids[:3], on, fps)


def two_speaker_features(seed: int = 0):
    """Features of a 1-D linear map, two talkers at x = 100 and x = 500 taking turns."""
    rng = np.random.default_rng(seed)
    d = 4
    lmat = rng.normal(size=(1, d, 1)) / 100
    model = GLLiM(
        np.ones(1),
        np.array([[300.0]]),
        np.array([[[200.0**2]]]),
        lmat,
        np.zeros((1, d)),
        np.eye(d)[None] * 0.01,
    )
    mapping = AudioImageMapping.from_models([model, model])
    t = 200
    who = np.where((np.arange(t) // 50) % 2 == 0, 1, 2)
    x = np.where(who == 1, 100.0, 500.0)
    feats = np.zeros((t, 2, d))
    for k in range(2):
        feats[:, k] = x[:, None] * lmat[0, :, 0] + 0.1 * rng.normal(size=(t, d))
    active = np.ones((t, 2), bool)
    active[::10] = False
    vad = active.any(axis=1)
    return AudioFeatures(feats, active, vad, vad.astype(float), np.ones((t, 2))), mapping, who


def test_localize_and_audio_only_baseline():
    feats, mapping, who = two_speaker_features()
    pos = localize_frames(feats, mapping)
    assert pos.shape == (200, 1)
    assert np.isnan(pos[::10]).all()
    ok = np.isfinite(pos[:, 0])
    assert np.median(np.abs(pos[ok, 0] - np.where(who == 1, 100, 500)[ok])) < 30
    segs = audio_only_diarization(feats, mapping, 25.0)
    assert len({s.speaker for s in segs}) == 2
    first = {s.speaker for s in segs if s.end <= 2.0}
    assert len(first) == 1  # the first turn (frames 1-50) is one speaker
    # unseen_speakers clusters only the frames no tracked person claims
    claimed = np.zeros(200, bool)
    claimed[:100] = True
    unseen = unseen_speakers(feats, mapping, 25.0, claimed)
    assert unseen and all(s.start >= 100 / 25 - 0.1 for s in unseen)
    assert all(s.speaker.startswith("U") for s in unseen)
