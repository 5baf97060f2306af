"""Audio-visual pipelines (``track-av``'s user paths): typed results equal to the library's,
and a recording of one's own read in blocks giving what the whole signal gives."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.audio.arrays import load_array
from avtrack.audio.recording import FS, ArrayRecording, read_array_audio
from avtrack.av.persons import PersonConfig
from avtrack.av.persons_scene import (
    CALIBRATION_LOCALIZER,
    PERSONS_LOCALIZER,
    audio_peak_floor,
    audio_peaks,
    localizer_grid,
    track_scene_persons,
)
from avtrack.av.vad import vad_available, voice_activity
from avtrack.av.vavit import VAVITConfig
from avtrack.errors import InputError
from avtrack.io.scene import load_scene
from avtrack.localize import make_localizer
from avtrack.pipelines.av import (
    AV163Run,
    AVRun,
    ImageRun,
    av163_scores,
    track_av163_sequence,
    track_scene_direction,
    track_scene_image,
)
from avtrack.pipelines.av_recording import (
    RecordingInputs,
    RecordingRun,
    localize_for_persons,
    track_own_recording,
)
from tests.av.scenes import _place, _small_room
from tests.cli.test_track_av import _recording_files


@pytest.fixture(scope="module")
def scene_dir(tmp_path_factory):
    """A 5 s scene: person 1 seated in front of the camera, person 2 seated at -75 degrees,
    out of its view; they take turns talking."""
    from avtrack.io.scenario import validate_scenario
    from avtrack.simulate.scene import simulate_scene, write_scene

    raw = {
        **_small_room("test-pipelines", 7, 5.0, hfov_deg=60.0),
        "people": [
            {"id": 1, "motion": {"type": "seated", "position": _place(5.0, 2.0, 1.6),
                                 "sway": 0.05}},
            {"id": 2, "motion": {"type": "seated", "position": _place(-75.0, 2.0, 1.6),
                                 "sway": 0.0}},
        ],
        "speech": {"mode": "turn-taking", "utterances": "synthetic", "mean_turn": 1.5,
                   "mean_pause": 0.3},
        "noise": {"diffuse_snr_db": 25.0, "fan_snr_db": None},
        "detector": {"miss_rate": 0.05, "false_alarm_rate": 0.0},
    }
    return write_scene(simulate_scene(validate_scenario(raw)),
                       tmp_path_factory.mktemp("scene") / "small")


def _same_run(a: AVRun, b: AVRun) -> None:
    """Equal outputs: the rows of tracks.txt, persons.csv and speech.rttm."""
    for name in ("frames", "ids", "boxes", "scores"):
        np.testing.assert_array_equal(getattr(a.tracks, name), getattr(b.tracks, name))
    np.testing.assert_array_equal(a.speaking, b.speaking)
    assert a.persons.to_csv() == b.persons.to_csv()
    assert a.speech == b.speech


def _recording_stage(steps: list[str]):
    """A ``stage`` that records what it is told."""
    import contextlib

    def stage(what: str):
        steps.append(what)
        return contextlib.nullcontext()

    return stage


def test_scene_direction_is_the_librarys_persons_tracker(scene_dir):
    steps: list[str] = []
    run = track_scene_direction(scene_dir, PersonConfig(), voices=True,
                                stage=_recording_stage(steps))
    res = track_scene_persons(load_scene(scene_dir), config=PersonConfig())
    _same_run(run, AVRun(res.tracks, res.speaking, res.persons, res.speech, res.n_frames,
                         res.fps, 0.0, None, FS))
    assert steps == ["tracking 125 frames", f"beamforming {run.n_persons} voices"]
    assert run.n_persons == len(np.unique(res.persons.ids)) == 2
    assert run.duration_s == pytest.approx(5.0)
    assert run.voices is not None and sorted(run.voices) == sorted(np.unique(res.persons.ids))
    assert run.voices_fs == load_scene(scene_dir).fs
    assert all(v.shape == (load_scene(scene_dir).audio.shape[1],) for v in run.voices.values())


def test_scene_image_without_audio_is_the_visual_tracker(scene_dir):
    run = track_scene_image(scene_dir, VAVITConfig(), use_audio=False)
    assert isinstance(run, ImageRun)
    assert run.speech is None and run.mapping is None and not run.mapping_trained
    assert np.unique(run.tracks.ids).tolist() == [1]  # person 2 is never seen
    # persons.csv of the image model: one row per reported box, at its centre
    np.testing.assert_array_equal(run.persons.frames, run.tracks.frames)
    np.testing.assert_allclose(run.persons.pixels,
                               run.tracks.boxes[:, :2] + run.tracks.boxes[:, 2:] / 2)
    with pytest.raises(InputError, match="--calibration-positions must be >= 4, got 3"):
        track_scene_image(scene_dir, VAVITConfig(), calibration_positions=3)


@pytest.fixture(scope="module")
def own(scene_dir, tmp_path_factory):
    """The scene as a recording of one's own: its WAV, detections and a camera file in the
    array's frame."""
    scene_dir, camera = _recording_files(tmp_path_factory.mktemp("own"), scene_dir)
    return scene_dir, camera, load_array(scene_dir / "array.json")


def test_block_wise_localization_is_the_whole_signals(own):
    """Heat maps, peaks and voice activity of the recording read in 0.3 s blocks equal those
    of the whole signal at once (the localizer run on the read recording, the detector on
    microphone 0)."""
    scene_dir, _, array = own
    wav = scene_dir / "audio.wav"
    audio = read_array_audio(wav, array, quiet=True)
    grid = localizer_grid(array)
    heat = make_localizer(PERSONS_LOCALIZER, array, grid).run(audio)
    n_frames = int(np.floor(audio.shape[1] / FS * 25.0 + 1e-9))
    peaks = audio_peaks(heat.weights, heat.time_s, grid, 25.0, n_frames,
                        floor=audio_peak_floor(PERSONS_LOCALIZER))
    steps: list[str] = []
    got = localize_for_persons(ArrayRecording(wav, array, quiet=True, block_s=0.3), 25.0,
                               n_frames, vad=vad_available(), stage=_recording_stage(steps))
    assert len(got.peaks) == n_frames
    for a, b in zip(got.peaks, peaks, strict=True):
        np.testing.assert_array_equal(a, b)
    assert steps[0] == f"localizing {audio.shape[1] / FS:.1f} s"
    if vad_available():
        assert got.heat is not None and got.activity is not None
        np.testing.assert_array_equal(got.heat.weights, heat.weights)
        np.testing.assert_array_equal(got.heat.time_s, heat.time_s)
        np.testing.assert_array_equal(got.activity.speech, voice_activity(audio[0], FS).speech)
    else:
        assert got.heat is None and got.activity is None
    bare = localize_for_persons(ArrayRecording(wav, array, quiet=True), 25.0, n_frames,
                                vad=False)
    assert bare.heat is None and bare.activity is None  # only the peaks are kept


def test_calibration_peaks_come_from_the_same_run_and_leave_the_persons_maps_alone(own):
    """With ``calibration`` the persons' maps and peaks are those of ``dprtf-eg`` (the thesis
    weights kept by the calibration localizer's run), and the calibration peaks those of
    :data:`CALIBRATION_LOCALIZER` run on its own."""
    scene_dir, _, array = own
    wav = scene_dir / "audio.wav"
    audio = read_array_audio(wav, array, quiet=True)
    grid = localizer_grid(array)
    n_frames = int(np.floor(audio.shape[1] / FS * 25.0 + 1e-9))
    fast = make_localizer(CALIBRATION_LOCALIZER, array, grid).run(audio)
    want = audio_peaks(fast.weights, fast.time_s, grid, 25.0, n_frames,
                       floor=audio_peak_floor(CALIBRATION_LOCALIZER))
    rec = ArrayRecording(wav, array, quiet=True, block_s=0.3)
    plain = localize_for_persons(rec, 25.0, n_frames, vad=False)
    both = localize_for_persons(rec, 25.0, n_frames, vad=False, calibration=True)
    assert plain.calibration_peaks is None
    for a, b in zip(both.peaks, plain.peaks, strict=True):
        np.testing.assert_array_equal(a, b)
    assert len(both.calibration_peaks) == n_frames
    for a, b in zip(both.calibration_peaks, want, strict=True):
        np.testing.assert_allclose(a, b)
    assert any(len(a) for a in want)


def test_yaw_peaks_are_the_calibration_map_over_the_elevations_the_array_hears(own):
    """``yaw_map``: the peaks of :data:`CALIBRATION_LOCALIZER` run on
    ``DirectionGrid.for_array`` (kept as its azimuth profile) for the 4-microphone array;
    none without ``yaw_map``, and none for an array that hears no elevation."""
    from avtrack.audio.arrays import MicArray
    from avtrack.localize.grid import DirectionGrid, azimuth_profile

    scene_dir, _, array = own
    wav = scene_dir / "audio.wav"
    audio = read_array_audio(wav, array, quiet=True)
    grid = localizer_grid(array)
    full = DirectionGrid.for_array(array)
    assert full.n_elevations > 1
    n_frames = int(np.floor(audio.shape[1] / FS * 25.0 + 1e-9))
    maps = make_localizer(CALIBRATION_LOCALIZER, array, full).run(audio)
    profile = azimuth_profile(maps.weights, full)[0]
    want = audio_peaks(profile, maps.time_s, DirectionGrid(grid.azimuth_values, np.zeros(1)),
                       25.0, n_frames, floor=audio_peak_floor(CALIBRATION_LOCALIZER))
    rec = ArrayRecording(wav, array, quiet=True, block_s=0.3)
    got = localize_for_persons(rec, 25.0, n_frames, vad=False, calibration=True, yaw_map=True)
    for a, b in zip(got.yaw_peaks, want, strict=True):
        np.testing.assert_allclose(a, b, atol=1e-6)
    assert any(len(a) for a in want)
    assert localize_for_persons(rec, 25.0, n_frames, vad=False,
                                calibration=True).yaw_peaks is None
    from avtrack.pipelines.av_recording import _yaw_localizer

    pair = MicArray("pair", array.positions[:2])  # a line: no elevation heard
    assert _yaw_localizer(pair) is None and _yaw_localizer(array) is not None


def test_calibration_peaks_are_read_at_the_time_the_maps_describe():
    """A talker who speaks over [0.5, 2.5) s, from -30 deg before 1.5 s and +30 deg after;
    the maps trail by 0.2 s. Without the voice activity the peaks of the video frames just
    after 1.5 s are still at -30 deg; with it, the maps' delay is measured and every frame
    of speech has its talker's direction (but the frame averaging maps from both sides of the
    change)."""
    from avtrack.av.vad import VoiceActivity
    from avtrack.localize.grid import DirectionGrid
    from avtrack.pipelines.av_recording import _calibration_peaks

    grid = DirectionGrid(np.arange(-90.0, 90.0 + 1e-9, 5.0), np.zeros(1))
    hop, fps, n_frames = 0.008, 25.0, 75
    t = (np.arange(375) + 0.5) * hop
    said = np.where(t < 1.5, -30.0, 30.0)
    talking = (t >= 0.5) & (t < 2.5)
    w = np.full((t.size, grid.size), 0.2 / grid.size)
    for j in np.flatnonzero(talking):
        w[j, np.argmin(np.abs(grid.azimuth_deg - said[j]))] += 0.8
    late = np.full_like(w, 1.0 / grid.size)
    late[25:] = w[:-25]  # 0.2 s behind
    t_vad = (np.arange(300) + 0.5) * 0.01
    act = VoiceActivity(t_vad, (t_vad >= 0.5) & (t_vad < 2.5), 0.01)
    frame_t = np.arange(n_frames) / fps
    speaking = (frame_t >= 0.6) & (frame_t < 2.4) & (np.abs(frame_t - 1.5) > 0.04)

    def peaks(activity):
        got = _calibration_peaks(late, t, grid, fps, n_frames, activity)
        return {i: got[i] for i in np.flatnonzero(speaking)}

    plain, aligned = peaks(None), peaks(act)
    truth = {i: np.where(frame_t[i] < 1.5, -30.0, 30.0) for i in plain}
    assert any(plain[i].tolist() != [truth[i]] for i in plain)  # trailing: -30 after 1.5 s
    assert all(aligned[i].tolist() == [truth[i]] for i in aligned)


def test_own_recording_in_blocks_equals_one_block(own):
    scene_dir, camera, array = own
    inputs = RecordingInputs(camera=camera, detections=scene_dir / "detections.txt",
                             appearance=scene_dir / "appearance.npy",
                             audio=scene_dir / "audio.wav", array=array, fps=25.0)
    blocks = track_own_recording(inputs, PersonConfig(), block_s=0.7)
    whole = track_own_recording(inputs, PersonConfig(), block_s=60.0)
    assert isinstance(blocks, RecordingRun)
    _same_run(blocks, whole)
    assert blocks.n_frames == 125 and blocks.fps == 25.0 and blocks.audio_fs == FS
    assert blocks.speech and blocks.n_persons == 2
    assert blocks.camera_fit is None and blocks.camera_check is not None
    assert not blocks.camera_check.warnings  # the camera file agrees with the recording


def test_own_recording_from_a_doa_csv(own):
    scene_dir, camera, _ = own
    det = scene_dir / "detections.txt"
    inputs = RecordingInputs(camera=camera, detections=det, doa=scene_dir / "gt" / "doa.csv",
                             fps=25.0)
    run = track_own_recording(inputs, PersonConfig())
    assert run.speech and run.audio_fs is None and run.camera_check is not None
    # without audio: the visual tracker, no speaker turns
    visual = track_own_recording(inputs, PersonConfig(), use_audio=False)
    assert visual.speech is None and visual.camera_check is None
    assert np.unique(visual.persons.ids).tolist() == [1]
    # the camera estimated: person 1 talks from one place of the image only
    with pytest.raises(InputError, match="--camera auto: too little evidence"):
        track_own_recording(RecordingInputs(camera=None, detections=det,
                                            doa=scene_dir / "gt" / "doa.csv", fps=25.0,
                                            image_size=(640, 480)), PersonConfig())
    with pytest.raises(InputError, match="--camera auto needs the audio's directions"):
        track_own_recording(RecordingInputs(camera=None, detections=det, fps=25.0,
                                            image_size=(640, 480)),
                            PersonConfig(), use_audio=False)


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"fps": None}, "--fps: give the frame rate"),
        ({"fps": 0.0}, r"--fps must be in \(0, 1000\], got 0.0"),
        ({"detections": None}, "give --video .* or --detections"),
        ({"camera": None}, "--image-size WIDTHxHEIGHT"),
    ],
)
def test_own_recording_bad_input(own, change, match):
    scene_dir, camera, _ = own
    inputs = {"camera": camera, "detections": scene_dir / "detections.txt",
              "doa": scene_dir / "gt" / "doa.csv", "fps": 25.0, **change}
    with pytest.raises(InputError, match=match):
        track_own_recording(RecordingInputs(**inputs), PersonConfig())


def test_own_recording_voices_need_the_recording(own):
    scene_dir, camera, _ = own
    inputs = RecordingInputs(camera=camera, detections=scene_dir / "detections.txt",
                             doa=scene_dir / "gt" / "doa.csv", fps=25.0)
    with pytest.raises(InputError, match="--voices needs --audio"):
        track_own_recording(inputs, PersonConfig(), voices=True)


def test_av163_sequence(tmp_path):
    from tests.cli.test_track_phd import write_av163_video
    from tests.io.test_av163 import write_av163

    folder = write_av163(tmp_path / "av", seq=7, cam=2, n_frames=30)
    video = write_av163_video(tmp_path / "v.avi")
    run = track_av163_sequence(folder, 7, 2, video, PersonConfig())
    assert isinstance(run, AV163Run) and run.n_frames == 30 and run.speech is not None
    assert run.sequence.n_frames == 30
    scores = av163_scores(run)
    assert set(scores) == {"OSPA (px)", "persons", "speakers"}
    assert scores["persons"] == run.n_persons and 0 <= scores["OSPA (px)"] <= 50
    with pytest.raises(InputError, match=r"AV16\.3 folder not found"):
        track_av163_sequence(tmp_path / "none", 7, 2, video, PersonConfig())
