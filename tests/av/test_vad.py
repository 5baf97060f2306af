"""Voice activity detection and its fusion with the person tracker's directional evidence."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from avtrack.audio.stft import FRAME_HOP_S
from avtrack.av import vad as V
from avtrack.io.persons import PersonsTable
from avtrack.simulate.speech import synthetic_speech

FS = 16000


def test_voice_activity_tells_speech_from_silence():
    pytest.importorskip("webrtcvad")
    rng = np.random.default_rng(0)
    speech = synthetic_speech(2.0, FS, rng, f0=140.0)
    x = np.concatenate([speech, np.zeros(2 * FS), speech])
    x += 1e-3 * rng.standard_normal(x.size)  # a quiet noise floor, 60 dB under the speech
    act = V.voice_activity(x, FS)
    assert act.frame_s == 0.01 and act.speech.size == 600
    t = act.time_s
    # the truth: 10 ms frames of the clean signal within 40 dB of its loudest (the synthetic
    # speech pauses for a third of a second after 0.4 s)
    e = (np.concatenate([speech, np.zeros(2 * FS), speech]).reshape(-1, 160) ** 2).mean(axis=1)
    truth = e > 1e-4 * e.max()
    assert truth[(t > 0.2) & (t < 1.8)].mean() < 0.85  # the pause is there
    for part in ((t > 0.2) & (t < 1.8), (t > 4.2) & (t < 5.8)):
        assert (act.speech[part] == truth[part]).mean() > 0.95
    assert act.speech[(t > 2.3) & (t < 3.7)].mean() < 0.05
    # at arbitrary times (the 8 ms audio frames): the 10 ms frame containing each
    np.testing.assert_array_equal(act.at(np.array([1.0, 3.0, -1.0, 99.0])),
                                  [True, False, False, False])
    with pytest.raises(ValueError, match="aggressiveness"):
        V.voice_activity(x, FS, aggressiveness=4)


def test_remove_overhang_by_hand():
    # runs of 20 and 9 frames (the detector's 9- and 6-frame hangovers at mode 3), one cut by
    # the signal's end, and a lone frame
    x = np.zeros(60, dtype=bool)
    x[2:22] = True  # 11 speech frames + 9 overhang -> 2..12
    x[30:39] = True  # 3 speech frames + 6 overhang -> 30..32
    x[45:46] = True  # shorter than any overhang: one frame stays
    x[55:] = True  # cut by the end: kept whole
    out = V.remove_overhang(x, 3)
    want = np.zeros(60, dtype=bool)
    want[2:13] = want[30:33] = want[45] = True
    want[55:] = True
    np.testing.assert_array_equal(out, want)
    # modes 0-1 hang on longer: 14 frames after a long run
    y = np.zeros(40, dtype=bool)
    y[0:30] = True
    assert np.flatnonzero(V.remove_overhang(y, 0)).max() == 15
    np.testing.assert_array_equal(V.remove_overhang(np.zeros(5, dtype=bool), 3), np.zeros(5))


def test_voice_activity_ends_with_the_speech_not_the_hangover():
    pytest.importorskip("webrtcvad")
    rng = np.random.default_rng(3)
    burst = synthetic_speech(1.0, FS, rng, f0=150.0)
    burst[-int(0.05 * FS):] *= np.linspace(1, 0, int(0.05 * FS))
    x = np.concatenate([np.zeros(FS), burst, np.zeros(FS)])
    x += 1e-3 * rng.standard_normal(x.size)
    with_hang = V.voice_activity(x, FS, trim_overhang=False)
    trimmed = V.voice_activity(x, FS)
    end_raw = with_hang.time_s[with_hang.speech].max()
    end = trimmed.time_s[trimmed.speech].max()
    assert end_raw > 2.05  # the detector says speech ~90 ms past the burst's end (2.0 s)
    assert 1.9 < end <= 2.02
    assert abs(end_raw - end - 0.09) < 0.015
    # the start: padded by ONSET_PAD_S before the detector's first speech frame
    start_raw = V.voice_activity(x, FS, onset_pad_s=0.0).time_s
    start_raw = start_raw[V.voice_activity(x, FS, onset_pad_s=0.0).speech].min()
    start = trimmed.time_s[trimmed.speech].min()
    assert start == pytest.approx(start_raw - V.ONSET_PAD_S)
    assert 0.95 < start <= 1.02  # the burst starts at 1.0 s
    with pytest.raises(ValueError, match="onset_pad_s"):
        V.voice_activity(x, FS, onset_pad_s=-0.01)


def _two_person_case(hop: float = FRAME_HOP_S):
    """Persons 1 (-30 deg) and 2 (+30 deg) for 3 s at 25 fps; 1 talks over [0.504, 2.0) s, 2
    over [1.5, 2.704) s (overlapping half a second). Heat maps at 8 ms put the frame's mass on
    whoever talks (split in the overlap, spread uniformly in silence); the voice activity is
    the union of the turns at 10 ms; the tracker heard each in its turns' video frames."""
    fps, n_f = 25.0, 75
    turns = {1: (0.504, 2.0), 2: (1.5, 2.704)}
    az_of = {1: -30.0, 2: 30.0}
    frames = np.repeat(np.arange(1, n_f + 1), 2)
    ids = np.tile([1, 2], n_f)
    az = np.array([az_of[i] for i in ids.tolist()])
    t_row = (frames - 1) / fps
    heard = np.array([turns[i][0] <= t < turns[i][1] for i, t in zip(ids, t_row, strict=True)])
    persons = PersonsTable(frames, ids, az, np.zeros(az.size), np.full((az.size, 2), np.nan),
                           np.ones(az.size, bool), heard.astype(float), fps)
    grid = np.arange(-90.0, 90.0 + 1e-9, 5.0)
    t_heat = np.arange(round(3.0 / hop)) * hop + hop / 2
    w = np.full((t_heat.size, grid.size), 1.0 / grid.size)
    talking = np.stack([(t_heat >= turns[i][0]) & (t_heat < turns[i][1]) for i in (1, 2)], 1)
    for j in np.flatnonzero(talking.any(axis=1)):
        w[j] = 0.0
        who = [i for i in (1, 2) if talking[j, i - 1]]
        for i in who:
            w[j, np.argmin(np.abs(grid - az_of[i]))] = 1.0 / len(who)
    t_vad = (np.arange(300) + 0.5) * 0.01
    speech = np.zeros(t_vad.size, bool)
    for a, b in turns.values():
        speech |= (t_vad >= a) & (t_vad < b)
    act = V.VoiceActivity(t_vad, speech, 0.01)
    return persons, heard, w, t_heat, grid, act, turns


def test_fusion_keeps_an_overlapping_turn_and_gives_each_voice_its_person():
    persons, heard, w, t_heat, grid, act, _turns = _two_person_case()
    t, ids, speaking = V.fuse_speaking(persons, heard, V.AzimuthProfile(w, t_heat, grid), act)
    np.testing.assert_array_equal(ids, [1, 2])
    overlap = (t > 1.62) & (t < 1.9)
    assert speaking[overlap].all()  # both talk: overlapped speech kept
    alone1 = (t > 0.72) & (t < 1.38)
    assert speaking[alone1, 0].all() and not speaking[alone1, 1].any()
    alone2 = (t > 2.12) & (t < 2.6)
    assert speaking[alone2, 1].all() and not speaking[alone2, 0].any()
    assert not speaking[(t < 0.4) | (t > 2.9)].any()  # silence: nobody
    # the voice activity alone makes no speaker: a person the tracker never heard stays silent
    profile = V.AzimuthProfile(w, t_heat, grid)
    _, _, none = V.fuse_speaking(persons, np.zeros_like(heard), profile, act)
    assert not none.any()


def test_speech_from_where_nobody_is_tracked_is_an_unseen_speaker():
    """A voice at +45 deg, where no person is tracked, that the tracker gave to the person at
    +30 deg (its peaks close enough to theirs): the fusion gives it to nobody, and the
    unclaimed speech is one speaker at +45 deg."""
    hop, fps, n_f = FRAME_HOP_S, 25.0, 75
    frames = np.arange(1, n_f + 1)
    persons = PersonsTable(frames, np.ones(n_f, int), np.full(n_f, 30.0), np.zeros(n_f),
                           np.full((n_f, 2), np.nan), np.ones(n_f, bool), np.ones(n_f), fps)
    grid = np.arange(-90.0, 90.0 + 1e-9, 5.0)
    t_heat = np.arange(round(3.0 / hop)) * hop + hop / 2
    w = np.full((t_heat.size, grid.size), 1.0 / grid.size)
    voice = (t_heat >= 0.5) & (t_heat < 2.5)
    w[voice] = 0.0
    w[voice, np.argmin(np.abs(grid - 45.0))] = 1.0
    t_vad = (np.arange(300) + 0.5) * 0.01
    act = V.VoiceActivity(t_vad, (t_vad >= 0.5) & (t_vad < 2.5), 0.01)
    profile = V.AzimuthProfile(w, t_heat, grid)
    t, _ids, speaking = V.fuse_speaking(persons, np.ones(n_f, bool), profile, act)
    assert not speaking.any()
    centres, unseen = V.unclaimed_speakers(persons, speaking, profile, act)
    np.testing.assert_array_equal(centres, [45.0])
    inner = (t > 0.62) & (t < 2.38)
    assert unseen[inner, 0].all() and not unseen[(t < 0.4) | (t > 2.6), 0].any()
    segs = V.activity_segments(t, np.arange(1, 2), unseen, label="U{}")
    assert [s.speaker for s in segs] == ["U1"] and abs(segs[0].duration - 2.0) < 0.15
    # from where the person stands, the same voice is theirs
    w2 = np.roll(w, -3, axis=1)  # +45 -> +30 deg
    _, _, mine = V.fuse_speaking(persons, np.ones(n_f, bool), profile._replace(weights=w2), act)
    assert mine[inner, 0].all()


def test_turn_boundaries_are_refined_at_the_audio_frame_rate():
    """Turns start and end on the 8 ms audio frames, within a frame of the truth where speech
    starts or stops (0.504 s and 2.704 s are not on the video's 40 ms grid, the tracker's
    turns are)."""
    persons, heard, w, t_heat, grid, act, turns = _two_person_case()
    t, ids, speaking = V.fuse_speaking(persons, heard, V.AzimuthProfile(w, t_heat, grid), act)
    segs = V.activity_segments(t, ids, speaking)
    by = {s.speaker: s for s in segs}
    assert set(by) == {"P1", "P2"} and len(segs) == 2
    p1, p2 = by["P1"], by["P2"]
    # boundaries next to silence: the voice activity's, within one 8 ms frame (+ rounding)
    assert abs(p1.start - turns[1][0]) <= 0.012
    assert abs(p2.start + p2.duration - turns[2][1]) <= 0.012
    # boundaries inside speech (the overlap's): the directional evidence's, smoothed over
    # smooth_s = 0.2 s, within half of it
    assert abs(p2.start - turns[2][0]) <= 0.1
    assert abs(p1.start + p1.duration - turns[1][1]) <= 0.1
    # frame j covers [t_j - hop/2, t_j + hop/2): boundaries on the 8 ms grid
    for s in segs:
        for edge in (s.start, s.start + s.duration):
            assert abs(edge / FRAME_HOP_S - round(edge / FRAME_HOP_S)) < 1e-6
    # pauses of a person up to max_gap are bridged, longer ones split the turn
    mask = np.zeros((120, 1), bool)
    mask[10:40] = mask[60:90] = True  # 0.24 s turns, 0.16 s apart
    tt = (np.arange(120) + 0.5) * FRAME_HOP_S
    assert len(V.activity_segments(tt, np.array([7]), mask, max_gap=0.2)) == 1
    assert len(V.activity_segments(tt, np.array([7]), mask, max_gap=0.1)) == 2


def _trailing(w: np.ndarray, k: int) -> np.ndarray:
    """The maps ``w`` ``(T, A)`` trailing by ``k`` frames (uniform before the first)."""
    out = np.full_like(w, 1.0 / w.shape[1])
    out[k:] = w[: w.shape[0] - k]
    return out


def test_map_delay_finds_how_far_the_maps_trail_the_speech():
    _persons, _heard, w, t_heat, grid, act, _turns = _two_person_case()
    # within a frame (the activity's 10 ms frames and the maps' 8 ms ones do not line up)
    assert V.map_delay(V.AzimuthProfile(w, t_heat, grid), act) <= FRAME_HOP_S + 1e-12
    for k in (10, 25, 40):
        got = V.map_delay(V.AzimuthProfile(_trailing(w, k), t_heat, grid), act)
        assert abs(got - k * FRAME_HOP_S) <= FRAME_HOP_S + 1e-12
    # searched up to max_delay_s only
    got = V.map_delay(V.AzimuthProfile(_trailing(w, 40), t_heat, grid), act, max_delay_s=0.1)
    assert got <= 0.1 + 1e-12
    # nothing to line up: no speech, or maps that never change
    silent = V.VoiceActivity(act.time_s, np.zeros_like(act.speech), act.frame_s)
    assert V.map_delay(V.AzimuthProfile(w, t_heat, grid), silent) == 0.0
    flat = np.full_like(w, 1.0 / grid.size)
    assert V.map_delay(V.AzimuthProfile(flat, t_heat, grid), act) == 0.0
    # maps that do not follow the speech (their best correlation, 0.014, is at 62 frames): no
    # lag read into their noise; the same noise with a direction following the speech 30
    # frames late (correlation 0.72): that lag
    rng = np.random.default_rng(0)
    noise = rng.dirichlet(np.full(grid.size, 0.2), size=w.shape[0])
    assert V.map_delay(V.AzimuthProfile(noise, t_heat, grid), act) == 0.0
    noise[:, 0] += 0.5 * np.roll(act.at(t_heat), 30)
    assert abs(V.map_delay(V.AzimuthProfile(noise, t_heat, grid), act) - 0.24) < 1e-9
    with pytest.raises(ValueError, match="max_delay_s"):
        V.map_delay(V.AzimuthProfile(w, t_heat, grid), act, max_delay_s=-0.1)


def test_advance_by_hand():
    w = np.arange(10.0).reshape(5, 2)
    t = (np.arange(5) + 0.5) * 0.01
    prof = V.AzimuthProfile(w, t, np.array([0.0, 5.0]))
    got = V.advance(prof, 0.02)  # two frames
    assert got.lead == 2 and got.weights is w  # not copied
    maps = got.maps()
    np.testing.assert_array_equal(maps.rows(0, 5), w[[2, 3, 4, 4, 4]])
    np.testing.assert_array_equal(maps.rows(1, 3), w[[3, 4]])
    np.testing.assert_array_equal(maps.columns(np.array([1])), w[[2, 3, 4, 4, 4]][:, [1]])
    np.testing.assert_array_equal(maps.columns(0), w[[2, 3, 4, 4, 4], 0])
    assert V.advance(got, 0.01).lead == 3  # leads add up
    np.testing.assert_array_equal(V.advance(prof, 0.0).maps().rows(0, 5), w)
    np.testing.assert_array_equal(got.time_s, t)
    np.testing.assert_array_equal(w, np.arange(10.0).reshape(5, 2))  # the input unchanged
    with pytest.raises(ValueError, match="delay_s"):
        V.advance(prof, -0.01)
    with pytest.raises(ValueError, match="lead"):
        prof._replace(lead=-1).checked()


def test_profile_of_maps_sums_the_elevations():
    from avtrack.localize.grid import DirectionGrid

    grid = DirectionGrid(np.array([0.0, 90.0, 180.0]), np.array([0.0, 30.0]))
    w = np.arange(12.0).reshape(2, 6)  # (frames, elevation-major candidates)
    t = np.array([0.004, 0.012])
    prof = V.AzimuthProfile.of_maps(w, t, grid)
    np.testing.assert_array_equal(prof.weights, [[3.0, 5.0, 7.0], [15.0, 17.0, 19.0]])
    np.testing.assert_array_equal(prof.azimuths_deg, [0.0, 90.0, 180.0])
    flat = DirectionGrid(np.arange(6) * 60.0 - 120.0, np.zeros(1))
    assert V.AzimuthProfile.of_maps(w, t, flat).weights is w  # one elevation: not copied


def test_fusion_on_advanced_maps_equals_fusion_on_the_maps_moved_by_hand():
    """A lead reads each frame's map later without copying the maps: the fusion and the
    unclaimed speakers are those of the maps themselves moved."""
    persons, heard, w, t_heat, grid, act = _random_scene(0, 3, 12.0)
    ahead = V.advance(V.AzimuthProfile(w, t_heat, grid), 0.2)
    moved = V.AzimuthProfile(w[np.minimum(np.arange(w.shape[0]) + ahead.lead, w.shape[0] - 1)],
                             t_heat, grid)
    assert ahead.lead == 25
    a = V.fuse_speaking(persons, heard, ahead, act)
    b = V.fuse_speaking(persons, heard, moved, act)
    np.testing.assert_array_equal(a[2], b[2])
    assert a[2].any()
    ua = V.unclaimed_speakers(persons, a[2], ahead, act)
    ub = V.unclaimed_speakers(persons, b[2], moved, act)
    np.testing.assert_array_equal(ua[0], ub[0])
    np.testing.assert_array_equal(ua[1], ub[1])
    assert V.map_delay(ahead, act) == V.map_delay(moved, act)


def test_turn_change_inside_speech_is_found_on_maps_that_trail():
    """Maps trailing the speech by 0.2 s move the turn change inside speech (P1's end, P2's
    start) 0.2 s late; advanced by their measured delay, within 0.1 s again."""
    persons, heard, w, t_heat, grid, act, turns = _two_person_case()
    late = V.AzimuthProfile(_trailing(w, 25), t_heat, grid)

    def p1_end(profile):
        t, ids, speaking = V.fuse_speaking(persons, heard, profile, act)
        by = {s.speaker: s for s in V.activity_segments(t, ids, speaking)}
        return by["P1"].start + by["P1"].duration

    assert p1_end(late) - turns[1][1] > 0.15
    aligned = V.advance(late, V.map_delay(late, act))
    assert abs(p1_end(aligned) - turns[1][1]) <= 0.1


def test_missing_detector_is_said_and_raises_a_clear_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "webrtcvad", None)  # import webrtcvad -> ImportError
    assert not V.vad_available()
    with pytest.raises(ImportError, match="pip install webrtcvad-wheels"):
        V.voice_activity(np.zeros(FS), FS)
    with pytest.warns(RuntimeWarning, match="voice activity detector not installed"):
        V.warn_vad_missing()


@pytest.mark.slow
def test_without_the_detector_track_av_keeps_the_trackers_turns(monkeypatch):
    """With the detector's import failing, the default pipeline warns and gives exactly the
    turns of ``vad=False`` (the tracker's speaking probability at the video frame rate); with
    it, the turns are refined on 8 ms frames."""
    from avtrack.audio.arrays import load_array
    from avtrack.av.persons_scene import (
        audio_peaks,
        grid_span,
        scene_heat_maps,
        track_scene_persons,
    )
    from avtrack.io.scene import load_scene
    from tests.av.scenes import out_of_image

    scene = load_scene(out_of_image())
    heat, grid = scene_heat_maps(scene, load_array(scene.path / "array.json"))
    peaks = audio_peaks(heat.weights, heat.time_s, grid, scene.fps, scene.n_frames)
    kw = {"peaks": peaks, "span": grid_span(grid), "heat": heat}
    before = track_scene_persons(scene, vad=False, **kw).speech
    assert before
    if V.vad_available():
        fused = track_scene_persons(scene, **kw).speech
        assert fused != before
        assert any(abs(s.start * 25 - round(s.start * 25)) > 1e-6 for s in fused)
    monkeypatch.setitem(sys.modules, "webrtcvad", None)
    with pytest.warns(RuntimeWarning, match="pip install webrtcvad-wheels"):
        fallback = track_scene_persons(scene, **kw).speech
    assert fallback == before


# ------------------------------------------------------------------- block-wise and lean forms


@pytest.mark.parametrize("n", [0, 1, 2, 3, 999, 1000, 1001, 1002, 16000, 123457])
def test_amplitude_level_is_numpys_percentile_from_blocks(n):
    rng = np.random.default_rng(n)
    x = rng.standard_normal(n) * rng.uniform(0.1, 2.0)
    x[rng.random(n) < 0.2] = 0.25  # ties
    expected = float(np.percentile(np.abs(x), V.LEVEL_PERCENTILE)) if n else 0.0
    for size in (1, 7, 160, max(n, 1)):
        level = V.AmplitudeLevel(n)
        for i in range(0, n, size):
            level.add(x[i : i + size])
        assert level.value() == expected  # exactly
    for q in (0.0, 50.0, 99.0, 100.0):
        level = V.AmplitudeLevel(n, q)
        level.add(x)
        assert level.value() == (float(np.percentile(np.abs(x), q)) if n else 0.0)


def test_amplitude_level_bad_input():
    with pytest.raises(ValueError, match="n_samples must be an integer >= 0, got -1"):
        V.AmplitudeLevel(-1)
    with pytest.raises(ValueError, match="percentile must be in"):
        V.AmplitudeLevel(10, 101.0)
    level = V.AmplitudeLevel(3)
    level.add(np.ones(2))
    with pytest.raises(ValueError, match="2 of the 3 samples"):
        level.value()
    with pytest.raises(ValueError, match="more than the 3 samples"):
        level.add(np.ones(2))


def test_voice_activity_in_blocks_is_the_whole_signals():
    pytest.importorskip("webrtcvad")
    rng = np.random.default_rng(3)
    speech = synthetic_speech(1.5, FS, rng, f0=120.0)
    x = np.concatenate([speech, np.zeros(FS + 37), speech[: FS // 2]])
    x += 1e-3 * rng.standard_normal(x.size)
    whole = V.voice_activity(x, FS)
    level = V.AmplitudeLevel(x.size)
    level.add(x)
    for size in (161, 1000, 64000):
        blocks = (x[i : i + size] for i in range(0, x.size, size))
        act = V.voice_activity_blocks(blocks, level.value())
        np.testing.assert_array_equal(act.speech, whole.speech)
        np.testing.assert_array_equal(act.time_s, whole.time_s)


def _still_persons(azimuths: dict[int, float], n_f: int = 50, fps: float = 25.0):
    """Persons standing at the given azimuths (id -> degrees) for ``n_f`` video frames, all
    heard throughout."""
    frames = np.repeat(np.arange(1, n_f + 1), len(azimuths))
    ids = np.tile(list(azimuths), n_f)
    az = np.array([azimuths[i] for i in ids.tolist()])
    return PersonsTable(frames, ids, az, np.zeros(az.size), np.full((az.size, 2), np.nan),
                        np.ones(az.size, bool), np.ones(az.size), fps)


def _still_energy(cells: dict[float, float]):
    """2 s of heat maps on a 5-degree grid with the same energy in every frame (azimuth ->
    mass), speech heard throughout; the profile, the activity and the frames away from the
    ends."""
    grid = np.arange(-90.0, 90.0 + 1e-9, 5.0)
    t_heat = np.arange(round(2.0 / FRAME_HOP_S)) * FRAME_HOP_S + FRAME_HOP_S / 2
    w = np.zeros((t_heat.size, grid.size))
    for az, mass in cells.items():
        w[:, grid == az] = mass
    act = V.VoiceActivity((np.arange(200) + 0.5) * 0.01, np.ones(200, bool), 0.01)
    return V.AzimuthProfile(w, t_heat, grid), act, (t_heat > 0.2) & (t_heat < 1.8)


def test_fusion_gives_each_direction_to_the_nearest_candidate():
    """Persons 12 deg apart, both heard; the talker stands at person 1 (0 deg), the frame's
    energy 0.3 / 0.4 / 0.3 at 0 / 5 / 10 deg. Person 2's 10-degree window (2-22 deg) holds
    0.7, over 0.6 of the frame's peak (1.0): both would speak. Shared out, the 10-degree cell
    (2 deg from person 2) is hers and the 5-degree cell (5 deg from person 1, 7 from her) is
    his: 0.7 for person 1, 0.3 for person 2, who is then silent."""
    persons = _still_persons({1: 0.0, 2: 12.0})
    prof, act, mid = _still_energy({0.0: 0.3, 5.0: 0.4, 10.0: 0.3})
    heard = np.ones(len(persons), bool)
    _, _, both = V.fuse_speaking(persons, heard, prof, act, nearest_only=False)
    _, _, nearest = V.fuse_speaking(persons, heard, prof, act)
    assert both[mid].all()
    assert nearest[mid, 0].all() and not nearest[mid, 1].any()


def test_fusion_gives_unclaimed_speech_to_the_person_at_its_peak():
    """One person heard; the frame's energy 0.4 / 0.3 / 0.3 at 15 / 20 / 25 deg, so the
    strongest 10-degree window (centred at 20) holds 1.0. A person at 5 deg holds 0.4 in
    their window, under 0.6 of it, but the strongest direction (15) is within 10 deg of them:
    they speak. A person at 0 deg is 15 deg from it: the speech stays nobody's."""
    prof, act, mid = _still_energy({15.0: 0.4, 20.0: 0.3, 25.0: 0.3})
    for az0, expect in ((5.0, True), (0.0, False)):
        persons = _still_persons({1: az0})
        heard = np.ones(len(persons), bool)
        _, _, plain = V.fuse_speaking(persons, heard, prof, act, peak_to_nearest=False)
        _, _, got = V.fuse_speaking(persons, heard, prof, act)
        assert not plain[mid].any()
        assert got[mid, 0].all() if expect else not got[mid].any()


def _dense_fusion(persons, heard, w, t_heat, grid, act, window_deg=10.0, smooth_s=0.2,
                  share=0.6, min_mass=0.05, margin_s=0.3, hop_s=FRAME_HOP_S,
                  nearest_only=True, peak_to_nearest=True):
    """:func:`V.fuse_speaking` written over whole ``(frames, persons, directions)`` arrays."""
    from scipy.ndimage import binary_dilation, uniform_filter1d

    ids = np.unique(persons.ids)
    az = np.stack([V._person_azimuth(persons, int(p), t_heat) for p in ids], axis=1)
    alive = np.isfinite(az)
    diff = np.abs((grid[None, None, :] - np.nan_to_num(az)[:, :, None] + 180.0) % 360.0 - 180.0)
    mass = np.where(alive, np.einsum("ja,jna->jn", w, (diff <= window_deg).astype(float)), 0.0)
    k = max(1, round(smooth_s / hop_s))
    mass = uniform_filter1d(mass, size=k, axis=0, mode="nearest")
    frame_of = np.floor(t_heat * persons.fps + 0.5).astype(np.int64) + 1
    was_heard = np.zeros((int(frame_of.max()) + 2, ids.size), bool)
    for f, p, s in zip(persons.frames, persons.ids, heard, strict=True):
        if s:
            was_heard[f, int(np.flatnonzero(ids == p)[0])] = True
    r = round(margin_s / hop_s)
    cand = binary_dilation(was_heard[np.clip(frame_of, 0, was_heard.shape[0] - 1)],
                           structure=np.ones((2 * r + 1, 1), bool)) & alive
    near = (np.abs((grid[:, None] - grid[None, :] + 180.0) % 360.0 - 180.0) <= window_deg)
    peak = uniform_filter1d(w @ near.astype(float), size=k, axis=0, mode="nearest").max(axis=1)
    top = np.maximum(np.where(cand, mass, 0.0).max(axis=1), peak)[:, None]
    if nearest_only:  # each direction counted for the nearest candidate only
        d_cand = np.where(cand[:, :, None], diff, np.inf)  # (J, N, A)
        closer = np.stack([np.delete(d_cand, n, axis=1).min(axis=1, initial=np.inf) < diff[:, n]
                           for n in range(ids.size)], axis=1)
        inside = (diff <= window_deg) & ~closer
        mass = np.where(alive, np.einsum("ja,jna->jn", w, inside.astype(float)), 0.0)
        mass = uniform_filter1d(mass, size=k, axis=0, mode="nearest")
    eligible = cand & (mass >= min_mass) & act.at(t_heat)[:, None]
    speaking = eligible & (mass >= share * top)
    if peak_to_nearest:  # unclaimed speech to the eligible person nearest the strongest cell
        best = grid[uniform_filter1d(w, size=k, axis=0, mode="nearest").argmax(axis=1)]
        d = np.abs((np.nan_to_num(az, nan=1e9) - best[:, None] + 180.0) % 360.0 - 180.0)
        d = np.where(eligible & alive, d, np.inf)
        rows = np.flatnonzero(eligible.any(axis=1) & ~speaking.any(axis=1))
        pick = d[rows].argmin(axis=1)
        ok = d[rows, pick] <= window_deg
        speaking[rows[ok], pick[ok]] = True
    return speaking


def _random_scene(seed: int, n_persons: int, seconds: float):
    """Persons walking at random, born and dying at random, with random speaking flags;
    random heat maps over a circular 5-degree grid and random voice activity."""
    rng = np.random.default_rng(seed)
    fps = 25.0
    rows = []
    for pid in range(1, n_persons + 1):
        start = int(rng.integers(1, int(seconds * fps) - 2))
        stop = int(rng.integers(start + 1, int(seconds * fps) + 1))
        f = np.arange(start, stop + 1)
        a = rng.uniform(-180, 180) + np.cumsum(rng.normal(0, 3, f.size))
        rows += [(int(fi), pid, float(ai)) for fi, ai in zip(f, a, strict=True)]
    rows.sort()
    frames, ids, az = (np.array(c) for c in zip(*rows, strict=True))
    az = (az + 180.0) % 360.0 - 180.0
    heard = rng.random(frames.size) < 0.4
    persons = PersonsTable(frames, ids, az, np.zeros(az.size), np.full((az.size, 2), np.nan),
                           np.ones(az.size, bool), heard.astype(float), fps)
    grid = np.arange(72) * 5.0 - 180.0
    t_heat = np.arange(int(seconds / FRAME_HOP_S)) * FRAME_HOP_S + 0.008
    w = rng.dirichlet(np.full(grid.size, 0.2), size=t_heat.size)
    t_vad = (np.arange(int(seconds * 100)) + 0.5) * 0.01
    act = V.VoiceActivity(t_vad, rng.random(t_vad.size) < 0.7, 0.01)
    return persons, heard, w, t_heat, grid, act


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_fusion_person_by_person_equals_the_dense_formula(seed, monkeypatch):
    """The fusion holds one person's and a few directions' values at a time; its decisions
    are those of the formula over whole (frames, persons, directions) arrays, whatever the
    chunk sizes."""
    persons, heard, w, t_heat, grid, act = _random_scene(seed, 6, 12.0)
    expected = _dense_fusion(persons, heard, w, t_heat, grid, act)
    assert 0 < expected.sum() < expected.size
    for values, columns in ((V._CHUNK_VALUES, V._COLUMNS), (72 * 97, 5), (1, 1)):
        monkeypatch.setattr(V, "_CHUNK_VALUES", values)
        monkeypatch.setattr(V, "_COLUMNS", columns)
        _, _, speaking = V.fuse_speaking(persons, heard, V.AzimuthProfile(w, t_heat, grid), act)
        np.testing.assert_array_equal(speaking, expected)


def test_unclaimed_speakers_in_column_chunks_equal_the_dense_formula(monkeypatch):
    from scipy.ndimage import uniform_filter1d

    persons, heard, w, t_heat, grid, act = _random_scene(5, 3, 12.0)
    w[:, 40:43] += 0.5  # a talker nobody stands at, 20-30 deg
    profile = V.AzimuthProfile(w, t_heat, grid)
    _, _, speaking = V.fuse_speaking(persons, heard, profile, act)
    k = round(0.2 / FRAME_HOP_S)
    smooth = uniform_filter1d(w, size=k, axis=0, mode="nearest")
    near = np.abs((grid[:, None] - grid[None, :] + 180.0) % 360.0 - 180.0) <= 10.0
    best = smooth.argmax(axis=1)
    maps = profile.checked().maps()
    np.testing.assert_allclose((smooth @ near)[np.arange(best.size), best],
                               V._strongest_direction(maps, near, k)[1], rtol=1e-12)
    np.testing.assert_array_equal(V._strongest_direction(maps, near, k)[0], best)
    expected = V.unclaimed_speakers(persons, speaking, profile, act)
    assert expected[0].size >= 1
    monkeypatch.setattr(V, "_COLUMNS", 3)
    centres, unseen = V.unclaimed_speakers(persons, speaking, profile, act)
    np.testing.assert_array_equal(centres, expected[0])
    np.testing.assert_array_equal(unseen, expected[1])
