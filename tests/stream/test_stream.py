"""Streaming API: same results as the batch pipelines in any block sizes, bounded state,
late inputs, clear errors."""

from __future__ import annotations

import functools
import tracemalloc

import numpy as np
import pytest

from avtrack.doa.base import (
    PEAK_FLOOR,
    EvidenceGate,
    gate_maps,
    heatmap_sequence,
    make_tracker,
    map_reading,
)
from avtrack.io.scenario import validate_scenario
from avtrack.localize import DEFAULT_LOCALIZER, make_localizer
from avtrack.localize.grid import azimuth_profile
from avtrack.simulate.library import named_scenario
from avtrack.simulate.scene import simulate_scene
from avtrack.stream import AVStream, DOAStream
from tests.av.scenes import walkout


@functools.cache
def meeting(duration: float = 4.0):
    """A seeded 2-4 person meeting recorded by the nao4 array (free field)."""
    raw = named_scenario("meeting", 7, duration)
    raw["array"] = {**raw["array"], "name": "nao4", "hrir": False}
    scene = simulate_scene(validate_scenario(raw))
    return scene.array, scene.audio


def blocks_of(x: np.ndarray, sizes) -> list[np.ndarray]:
    out, start, k = [], 0, 0
    while start < x.shape[1]:
        n = sizes[k % len(sizes)]
        out.append(x[:, start : start + n])
        start, k = start + n, k + 1
    return out


def batch_doa_tracks(array, x, tracker: str, step: int = 4, method: str = DEFAULT_LOCALIZER):
    """The batch pipeline with the stream's defaults: ``method``'s maps, read as
    :func:`map_reading` says."""
    loc = make_localizer(method, array)
    heat = loc.run(x)
    reading = map_reading(tracker, method)
    profile, _ = azimuth_profile(heat.weights, loc.grid, loc.profile_reduce)
    profile = gate_maps(profile, loc.evidence(heat.n_observations), reading.evidence_hold_s,
                        loc.stft_config.frame_period_s)
    seq = heatmap_sequence(
        profile, loc.grid.azimuth_values, heat.frames, heat.time_s, step,
        reading.observations, PEAK_FLOOR, reading.uniform_floor,
    )
    trk = make_tracker(tracker, reading.config,
                       frame_period_s=step * loc.stft_config.frame_period_s)
    trk.reset()
    outs = [trk.step(a, w) for a, w in zip(seq.azimuth_deg, seq.weight, strict=True)]
    return seq, outs


@pytest.mark.parametrize("tracker", ["vonmises", "gauss"])
@pytest.mark.parametrize("sizes", [[16000], [1, 127, 129, 3000], [512]])
def test_doa_stream_equals_the_batch_pipeline(tracker, sizes):
    array, x = meeting()
    seq, expected = batch_doa_tracks(array, x, tracker)
    stream = DOAStream(array, tracker=tracker)
    got = [f for b in blocks_of(x, sizes) for f in stream.push(b)] + stream.finish()
    assert len(got) == len(seq) > 100
    np.testing.assert_array_equal([g.frame for g in got], seq.frames)
    np.testing.assert_allclose([g.time_s for g in got], seq.time_s)
    assert sum(len(e) for e in expected) > 0, "the scene must produce tracks"
    for g, e in zip(got, expected, strict=True):
        np.testing.assert_array_equal(g.tracks.ids, e.ids)
        np.testing.assert_array_equal(g.tracks.azimuth_deg, e.azimuth_deg)
        np.testing.assert_array_equal(g.tracks.active, e.active)


def test_doa_stream_reset_starts_over():
    array, x = meeting()
    stream = DOAStream(array, step=2)
    first = [f.tracks.ids.tolist() for f in stream.push(x[:, :24000])]
    stream.reset()
    again = [f.tracks.ids.tolist() for f in stream.push(x[:, :24000])]
    assert first == again and stream.samples_in == 24000


def test_doa_stream_latency_and_frame_period():
    array, _ = meeting()
    stream = DOAStream(array, step=4, method="dprtf-eg-fast")
    assert stream.latency_s == pytest.approx((256 + 3 * 128) / 16000)
    assert stream.tracker.frame_period_s == pytest.approx(0.032)
    # the default map is read 0.2 s (25 frames of 8 ms) late
    stream = DOAStream(array, step=4)
    assert stream.localizer.latency_frames == 25
    assert stream.latency_s == pytest.approx((256 + 28 * 128) / 16000)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"step": 0}, "step must be a positive integer"),
        ({"observations": "lines"}, "observations must be one of"),
        ({"floor": -1.0}, "floor must be a finite number"),
        ({"method": "music"}, "method must be one of"),
        ({"tracker": "kalman"}, "kalman"),
    ],
)
def test_doa_stream_rejects_bad_parameters(kwargs, message):
    array, _ = meeting()
    with pytest.raises((ValueError, KeyError), match=message):
        DOAStream(array, **kwargs)


def test_doa_stream_rejects_bad_blocks():
    array, _ = meeting()
    stream = DOAStream(array)
    with pytest.raises(ValueError, match=r"block must have shape \(4, n_samples\)"):
        stream.push(np.zeros((2, 100)))
    with pytest.raises(ValueError, match="finite"):
        stream.push(np.full((4, 300), np.nan))


def test_doa_stream_memory_stays_flat():
    """Traced memory after 4 s and after 16 s of streaming differ by less than 256 KiB."""
    array, x = meeting()
    stream = DOAStream(array)
    blocks = blocks_of(x, [320])  # 20 ms blocks
    for b in blocks:  # warm-up: lazily built tables, first tracks
        stream.push(b)
    tracemalloc.start()
    try:
        levels = []
        for _ in range(4):
            for b in blocks:
                stream.push(b)
            levels.append(tracemalloc.get_traced_memory()[0])
    finally:
        tracemalloc.stop()
    assert max(levels) - levels[0] < 256 * 1024, levels


# ---------------------------------------------------------------------------- audio-visual
def _scene_inputs():
    from avtrack.io.scene import load_scene

    scene_dir, mapping, _ = walkout()
    return load_scene(scene_dir), mapping


def _frame_detections(sc):
    slices = sc.detections.frame_slices(sc.n_frames)
    for sl in slices:
        app = None if sc.appearance is None else sc.appearance[sl]
        yield sc.detections.boxes[sl], sc.detections.scores[sl], app


def test_av_stream_equals_track_scene_in_real_time_order():
    from avtrack.av.vavit import track_scene

    sc, mapping = _scene_inputs()
    batch = track_scene(sc.path, mapping, scene=sc)
    stream = AVStream(mapping, sc.image_size, sc.audio.shape[0], fps=sc.fps, fs=sc.fs)
    hop = int(sc.fs / sc.fps)  # audio of one video frame
    out = []
    for t, (boxes, scores, app) in enumerate(_frame_detections(sc)):
        out += stream.push_detections(boxes, scores, app)
        out += stream.push_audio(sc.audio[:, t * hop : (t + 1) * hop])
    out += stream.push_audio(sc.audio[:, sc.n_frames * hop :])
    out += stream.close(sc.n_frames)
    assert [o.frame for o in out] == list(range(sc.n_frames))
    assert all(o.had_audio and o.had_detections for o in out)
    assert stream.stats == {"frames_without_audio": 0, "frames_without_detections": 0}
    ids = np.concatenate([o.tracks.ids for o in out])
    boxes = np.concatenate([o.tracks.boxes for o in out])
    speaking = np.concatenate([o.tracks.speaking for o in out])
    np.testing.assert_array_equal(ids, batch.tracks.ids)
    np.testing.assert_allclose(boxes, batch.tracks.boxes, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(speaking, batch.speaking)
    assert speaking.any()


def test_av_stream_tracks_without_a_stalled_microphone_and_drops_late_audio():
    sc, mapping = _scene_inputs()
    stream = AVStream(mapping, sc.image_size, sc.audio.shape[0], fps=sc.fps, fs=sc.fs, max_lag=5)
    dets = list(_frame_detections(sc))
    out = []
    for d in dets[:20]:
        out += stream.push_detections(*d)
    # audio stalled: all but the last max_lag frames were tracked from the detections alone
    assert [o.frame for o in out] == list(range(15))
    assert not any(o.had_audio for o in out)
    assert stream.stats["frames_without_audio"] == 15
    hop = int(sc.fs / sc.fps)
    out2 = stream.push_audio(sc.audio[:, : 24 * hop])  # late audio for frames 0..~22
    # frames 15..19 take their (now arrived) audio; audio of frames 0..14 is dropped
    assert [o.frame for o in out2] == list(range(15, 20))
    assert all(o.had_audio and o.had_detections for o in out2)
    waiting = len(stream._audio)  # audio of frames 20.. waits for their detections
    assert 1 <= waiting <= 5
    out3 = []
    for d in dets[20 : 20 + waiting]:
        out3 += stream.push_detections(*d)
    assert [o.frame for o in out3] == list(range(20, 20 + waiting))
    assert all(o.had_audio and o.had_detections for o in out3)
    assert stream.stats == {"frames_without_audio": 15, "frames_without_detections": 0}


def test_av_stream_tracks_empty_frames_when_the_camera_stalls():
    sc, mapping = _scene_inputs()
    stream = AVStream(mapping, sc.image_size, sc.audio.shape[0], fps=sc.fps, fs=sc.fs, max_lag=4)
    hop = int(sc.fs / sc.fps)
    out = stream.push_audio(sc.audio[:, : 20 * hop])
    assert out and all(not o.had_detections for o in out)
    assert len(stream._audio) == 4
    assert stream.stats["frames_without_detections"] == len(out)


def test_av_stream_rejects_bad_parameters():
    sc, mapping = _scene_inputs()
    with pytest.raises(ValueError, match="trained for 4 microphones"):
        AVStream(mapping, sc.image_size, 8)
    with pytest.raises(ValueError, match="max_lag"):
        AVStream(mapping, sc.image_size, 4, max_lag=0)
    with pytest.raises(ValueError, match="fps"):
        AVStream(mapping, sc.image_size, 4, fps=0)
    with pytest.raises(TypeError, match="AudioImageMapping"):
        AVStream(object(), sc.image_size, 4)
    stream = AVStream(mapping, sc.image_size, 4, fps=sc.fps)
    with pytest.raises(ValueError, match=r"boxes must have shape \(M, 4\), got \(2, 6\)"):
        stream.push_detections(np.ones((2, 6)))
    assert stream.push_detections([]) == []  # an empty frame is fine


@pytest.mark.parametrize("tracker", ["vonmises", "gauss"])
def test_tracks_fall_silent_soon_after_the_localizer_hears_nobody(tracker):
    """After speech ends, the map keeps its peaks while it relaxes to uniform; the trackers
    read it only ``evidence_hold_s`` past the latest frame with features, so no track stays
    active long after. Read ungated, the von Mises tracker's tracks do; the Gaussian tracker's
    two-frame activity window (eq. 5.43) ends them within the same bound on this scene."""
    array, x = meeting()
    rng = np.random.default_rng(0)
    quiet = 1e-3 * np.std(x) * rng.standard_normal((x.shape[0], 2 * 16000))
    y = np.concatenate([x, quiet], axis=1)
    loc = make_localizer("dprtf-eg-fast", array)
    heat = loc.run(y)
    ev = loc.evidence(heat.n_observations)
    last_evidence = int(np.flatnonzero(ev)[-1])
    hold = EvidenceGate.for_hold(map_reading(tracker, "dprtf-eg-fast").evidence_hold_s,
                                 loc.stft_config.frame_period_s).hold_frames

    def last_active(**kw) -> int:
        frames = [f for f in DOAStream(array, tracker=tracker, **kw).push(y)
                  if np.any(f.tracks.active)]
        return frames[-1].frame if frames else -1

    # the hold, then the tracker's activity window (eq. 5.43: L' frames of 4 hops) and one block
    window = map_reading(tracker, "dprtf-eg-fast").config.activity_frames
    bound = last_evidence + hold + 4 * (window + 1)
    assert last_active() <= bound
    if tracker == "vonmises":
        assert last_active(evidence_hold_s=None) > bound


def test_doa_stream_refuses_a_hold_that_is_not_seconds():
    with pytest.raises(ValueError, match="evidence_hold_s"):
        DOAStream(meeting()[0], evidence_hold_s="long")
    with pytest.raises(ValueError, match="hold_s"):
        DOAStream(meeting()[0], evidence_hold_s=-0.1)
