"""Tests of avtrack.simulate.speech: turn-taking schedules, schedules from VAD tracks (hand
case and the real LOCATA track), utterance loading, synthetic speech and segment filling."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import scipy.io
import soundfile as sf

from avtrack.errors import InputError
from avtrack.simulate.speech import (
    SpeechSegment,
    fill_segments,
    load_utterances,
    schedule_from_vad,
    synthetic_speech,
    turn_taking_schedule,
)


def overlap_fraction(segs: list[SpeechSegment]) -> float:
    """Fraction of turns that start while an earlier turn is still going on."""
    ends = np.maximum.accumulate([s.end for s in segs])
    return float(np.mean([b.start < e for b, e in zip(segs[1:], ends[:-1], strict=True)]))


# ---------------------------------------------------------------------------- segments


def test_speech_segment_validation():
    s = SpeechSegment(2, 1.0, 2.5)
    assert s.duration == 1.5 and s.utterance == "synthetic"
    with pytest.raises(ValueError, match="speaker must be an integer >= 1"):
        SpeechSegment(0, 0.0, 1.0)
    with pytest.raises(ValueError, match="end must be finite and > start"):
        SpeechSegment(1, 2.0, 2.0)
    with pytest.raises(ValueError, match="start must be finite and >= 0"):
        SpeechSegment(1, float("nan"), 2.0)


# ---------------------------------------------------------------------------- turn taking


def test_turn_taking_properties():
    segs = turn_taking_schedule(3, 900.0, np.random.default_rng(0), overlap_prob=0.15)
    starts = [s.start for s in segs]
    assert starts == sorted(starts)
    assert all(0 <= s.start < s.end <= 900.0 for s in segs)
    assert {s.speaker for s in segs} == {1, 2, 3}
    talk = [sum(s.duration for s in segs if s.speaker == k) for k in (1, 2, 3)]
    assert min(talk) > 0.2 * 900 / 3  # everyone talks a fair share
    assert overlap_fraction(segs) == pytest.approx(0.15, abs=0.05)
    lengths = np.array([s.duration for s in segs[:-1]])
    assert lengths.mean() == pytest.approx(2.5, rel=0.2)
    assert lengths.min() >= 0.3 - 1e-12
    # Consecutive turns change speaker.
    assert all(a.speaker != b.speaker for a, b in itertools.pairwise(segs))
    # Overlaps are between 0.2 and 1 s (or half a turn).
    for a, b in itertools.pairwise(segs):
        if b.start < a.end:
            assert a.end - b.start <= 1.0 + 1e-9


@pytest.mark.parametrize("p", [0.0, 0.5])
def test_turn_taking_overlap_probability(p):
    segs = turn_taking_schedule(2, 900.0, np.random.default_rng(1), overlap_prob=p)
    assert overlap_fraction(segs) == pytest.approx(p, abs=0.06)


def test_turn_taking_deterministic_by_seed():
    a = turn_taking_schedule(4, 60.0, np.random.default_rng(5))
    b = turn_taking_schedule(4, 60.0, np.random.default_rng(5))
    c = turn_taking_schedule(4, 60.0, np.random.default_rng(6))
    assert a == b and a != c


def test_turn_taking_active_mask():
    # 10 s in 100-ms frames: speaker 1 alone in [0, 4), both in [4, 7), nobody in [7, 10).
    mask = np.zeros((100, 2), dtype=bool)
    mask[:70, 0] = True
    mask[40:70, 1] = True
    segs = turn_taking_schedule(2, 10.0, np.random.default_rng(2), active=mask)
    assert segs
    for s in segs:
        assert s.end <= 7.0 + 1e-9
        if s.speaker == 2:
            assert s.start >= 4.0 - 1e-9
    # The same through a callable.
    segs = turn_taking_schedule(
        2,
        10.0,
        np.random.default_rng(2),
        active=lambda t: np.array([t < 7.0, 4.0 <= t < 7.0]),
    )
    assert all(s.end <= 7.0 + 0.01 for s in segs)
    assert all(s.start >= 4.0 - 0.01 for s in segs if s.speaker == 2)


def test_turn_taking_bad_arguments():
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="n_speakers must be an integer >= 1"):
        turn_taking_schedule(0, 10.0, rng)
    with pytest.raises(ValueError, match="duration must be a finite number > 0"):
        turn_taking_schedule(2, -1.0, rng)
    with pytest.raises(ValueError, match=r"overlap_prob must be in \[0, 1\]"):
        turn_taking_schedule(2, 10.0, rng, overlap_prob=2.0)
    with pytest.raises(ValueError, match=r"active must have shape \(F, 2\)"):
        turn_taking_schedule(2, 10.0, rng, active=np.ones((10, 3), bool))
    with pytest.raises(TypeError, match=r"rng must be a numpy\.random\.Generator"):
        turn_taking_schedule(2, 10.0, 0)


# ---------------------------------------------------------------------------- VAD


def test_schedule_from_vad_hand_case():
    vad = np.array(
        [
            [1, 0],
            [1, 0],
            [1, 1],
            [0, 1],
            [0, 1],
            [1, 1],
            [0, 0],
            [0, 1],
        ],
        dtype=np.uint8,
    )
    segs = schedule_from_vad(vad, 0.5, min_dur=0.0)
    got = [(s.speaker, s.start, s.end) for s in segs]
    assert got == [(1, 0.0, 1.5), (2, 1.0, 3.0), (1, 2.5, 3.0), (2, 3.5, 4.0)]
    assert all(s.utterance == "vad" for s in segs)
    # min_dur drops the one-frame runs; min_gap joins speaker 2's runs.
    assert [(s.speaker, s.start, s.end) for s in schedule_from_vad(vad, 0.5, min_dur=0.6)] == [
        (1, 0.0, 1.5),
        (2, 1.0, 3.0),
    ]
    joined = schedule_from_vad(vad, 0.5, min_dur=0.0, min_gap=0.6)
    assert (2, 1.0, 4.0) in [(s.speaker, s.start, s.end) for s in joined]
    assert schedule_from_vad(np.zeros((5, 2), bool), 0.1) == []


def test_schedule_from_vad_rejects_bad_input():
    with pytest.raises(ValueError, match=r"vad must have shape \(F, S\)"):
        schedule_from_vad(np.ones(5, bool), 0.01)
    with pytest.raises(ValueError, match="vad must be bool or contain only 0 and 1"):
        schedule_from_vad(np.full((3, 1), 0.5), 0.01)
    with pytest.raises(ValueError, match="frame_s must be a finite number > 0"):
        schedule_from_vad(np.ones((3, 1), bool), 0.0)


def test_schedule_from_real_locata_vad(shared_data):
    vad = scipy.io.loadmat(shared_data / "nao" / "LOCATA-speakerVAD.mat")["speakerVAD"]
    segs = schedule_from_vad(vad, 0.008)
    assert {s.speaker for s in segs} == {1, 2}
    assert all(0 <= s.start < s.end <= vad.shape[0] * 0.008 + 1e-9 for s in segs)
    total = sum(s.duration for s in segs)
    assert 0 < total <= 2 * vad.shape[0] * 0.008


def test_turn_taking_restricted_to_real_vad(shared_data):
    vad = scipy.io.loadmat(shared_data / "nao" / "LOCATA-speakerVAD.mat")["speakerVAD"]
    duration = vad.shape[0] * 0.008
    for seed in range(3):
        segs = turn_taking_schedule(
            2, duration, np.random.default_rng(seed), active=vad, active_frame_s=0.008
        )
        assert {s.speaker for s in segs} == {1, 2}
        for s in segs:  # every turn lies inside its speaker's active frames
            a, b = int(np.floor(s.start / 0.008 + 1e-9)), int(np.ceil(s.end / 0.008 - 1e-9))
            assert vad[a:b, s.speaker - 1].all()


# ---------------------------------------------------------------------------- utterances


def test_load_utterances_reads_and_resamples(tmp_path):
    t = np.arange(8000) / 8000
    sf.write(tmp_path / "b.wav", 0.5 * np.sin(2 * np.pi * 300 * t), 8000)
    sf.write(tmp_path / "a.flac", 0.1 * np.sin(2 * np.pi * 200 * np.arange(1600) / 16000), 16000)
    (tmp_path / "notes.txt").write_text("ignored")
    utts = load_utterances(tmp_path, fs=16000)
    assert [name for name, _ in utts] == ["a", "b"]
    assert utts[0][1].shape == (1600,)
    assert utts[1][1].shape == (16000,)  # 1 s at 8 kHz -> 16 kHz
    assert np.sqrt(np.mean(utts[1][1][2000:-2000] ** 2)) == pytest.approx(
        0.5 / np.sqrt(2), rel=0.02
    )


def test_load_utterances_errors(tmp_path):
    with pytest.raises(InputError, match="utterance folder not found"):
        load_utterances(tmp_path / "missing")
    with pytest.raises(InputError, match="no audio files"):
        load_utterances(tmp_path)
    (tmp_path / "bad.wav").write_text("this is not a wav file")
    with pytest.raises(InputError, match="cannot read audio") as err:
        load_utterances(tmp_path)
    assert "bad.wav" in str(err.value)
    (tmp_path / "bad.wav").unlink()
    sf.write(tmp_path / "stereo.wav", np.zeros((100, 2)), 16000)
    with pytest.raises(InputError, match="expected a mono utterance, got 2 channels"):
        load_utterances(tmp_path)


def test_load_real_utterances(shared_data):
    utts = load_utterances(shared_data / "audio" / "speech")
    assert len(utts) == 7
    assert all(1.5 * 16000 <= x.size <= 4.5 * 16000 for _, x in utts)


# ---------------------------------------------------------------------------- signals


def test_synthetic_speech_is_speech_like():
    fs = 16000
    y = synthetic_speech(6.0, fs, np.random.default_rng(3), f0=150.0)
    assert y.shape == (6 * fs,) and np.all(np.isfinite(y))
    active = y != 0
    assert np.sqrt(np.mean(y[active] ** 2)) == pytest.approx(1.0, rel=1e-6)
    assert 0.02 < 1 - active.mean() < 0.4  # some pauses, mostly speech
    # Syllabic modulation: the spectrum of the 10-ms RMS envelope is centred at 2-8 Hz, with
    # over a third of its power (0.5-50 Hz) in 2-8 Hz (0.25-0.54 for the CMU ARCTIC files).
    env = np.sqrt(np.mean(y.reshape(-1, 160) ** 2, axis=1))
    spec = np.abs(np.fft.rfft(env - env.mean())) ** 2
    freqs = np.fft.rfftfreq(env.size, 0.01)
    band = spec[(freqs >= 2) & (freqs <= 8)].sum() / spec[(freqs >= 0.5) & (freqs <= 50)].sum()
    centroid = (spec * freqs)[freqs <= 50].sum() / spec[freqs <= 50].sum()
    assert band > 0.35 and 2.0 <= centroid <= 8.0
    # Most energy below 4 kHz, and pitch near f0: autocorrelation peak of a loud 50-ms window.
    power = np.abs(np.fft.rfft(y)) ** 2
    f = np.fft.rfftfreq(y.size, 1 / fs)
    assert power[f < 4000].sum() > 0.8 * power.sum()
    centre = int(np.argmax(np.convolve(y**2, np.ones(800), "same")))
    w = y[centre - 400 : centre + 400]
    ac = np.correlate(w, w, "full")[w.size - 1 :]
    lag = np.argmax(ac[fs // 300 : fs // 60]) + fs // 300
    assert fs / lag == pytest.approx(150.0, rel=0.25)


def test_synthetic_speech_deterministic_and_edge_cases():
    a = synthetic_speech(1.0, 16000, np.random.default_rng(0))
    b = synthetic_speech(1.0, 16000, np.random.default_rng(0))
    np.testing.assert_array_equal(a, b)
    assert synthetic_speech(0.0, 16000, np.random.default_rng(0)).shape == (0,)
    with pytest.raises(ValueError, match="duration_s must be a finite number >= 0"):
        synthetic_speech(-1.0, 16000, np.random.default_rng(0))


def check_filled(out: np.ndarray, segs: list[SpeechSegment], fs: int) -> None:
    inside = np.zeros(out.shape, dtype=bool)
    for s in segs:
        a, b = round(s.start * fs), min(round(s.end * fs), out.shape[1])
        inside[s.speaker - 1, a:b] = True
        seg = out[s.speaker - 1, a:b]
        assert np.sqrt(np.mean(seg**2)) > 0.1
        assert abs(seg[0]) < 0.05 * np.abs(seg).max()  # faded in
    assert np.all(out[~inside] == 0.0)


def test_fill_segments_synthetic():
    fs = 8000
    segs = turn_taking_schedule(3, 20.0, np.random.default_rng(0))
    out = fill_segments(segs, [], fs, 3, 20.0, np.random.default_rng(1))
    assert out.shape == (3, 20 * fs)
    check_filled(out, segs, fs)
    again = fill_segments(segs, [], fs, 3, 20.0, np.random.default_rng(1))
    np.testing.assert_array_equal(out, again)


def test_fill_segments_with_utterances():
    fs = 8000
    rng = np.random.default_rng(0)
    utts = [
        ("u1", np.concatenate([np.zeros(800), rng.standard_normal(4000), np.zeros(800)])),
        ("u2", 3.0 * rng.standard_normal(2000)),
    ]
    segs = [SpeechSegment(1, 0.5, 3.0), SpeechSegment(2, 2.0, 2.6), SpeechSegment(1, 4.0, 5.0)]
    out = fill_segments(segs, utts, fs, 2, 6.0, np.random.default_rng(1))
    check_filled(out, segs, fs)
    # Leading silence was trimmed: the material starts right after the fade.
    assert np.all(out[0, round(0.5 * fs) + 80 : round(0.5 * fs) + 400] != 0)


def test_fill_segments_with_real_utterances(shared_data):
    fs = 16000
    utts = load_utterances(shared_data / "audio" / "speech", fs)
    segs = turn_taking_schedule(2, 12.0, np.random.default_rng(0))
    out = fill_segments(segs, utts, fs, 2, 12.0, np.random.default_rng(0))
    check_filled(out, segs, fs)


def test_fill_segments_bad_arguments():
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match=r"segment speaker 3 > n_speakers \(2\)"):
        fill_segments([SpeechSegment(3, 0.0, 1.0)], [], 8000, 2, 2.0, rng)
    with pytest.raises(ValueError, match="segments of speaker 1 overlap"):
        fill_segments(
            [SpeechSegment(1, 0.0, 1.0), SpeechSegment(1, 0.5, 1.5)], [], 8000, 2, 2.0, rng
        )
    with pytest.raises(ValueError, match="utterance 'x' must be a non-empty finite 1-D"):
        fill_segments([SpeechSegment(1, 0.0, 1.0)], [("x", np.zeros((2, 2)))], 8000, 1, 2.0, rng)


@pytest.mark.parametrize("seed", range(40))
def test_turn_taking_never_overlaps_a_speaker_with_itself(seed):
    """With overlapping turn changes, A cut in on by B who is cut in on by A again must not
    start A's new turn before A's previous one ends (the meeting scene of seed 16 did)."""
    segs = turn_taking_schedule(3, 40.0, np.random.default_rng(seed), 2.5, 0.6, 0.6)
    for spk in {s.speaker for s in segs}:
        mine = sorted((s.start, s.end) for s in segs if s.speaker == spk)
        assert all(b[0] >= a[1] - 1e-9 for a, b in itertools.pairwise(mine))
