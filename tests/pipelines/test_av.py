"""Audio-visual pipelines (``track-av``'s user paths): typed results equal to the library's,
and a recording of one's own read in blocks giving what the whole signal gives."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.audio.arrays import load_array
from avtrack.audio.recording import FS, ArrayRecording, read_array_audio
from avtrack.av.persons import PersonConfig
from avtrack.av.persons_scene import (
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
from tests.av.scenes import out_of_image, walkout
from tests.cli.test_track_av import _recording_files


def _same_run(a: AVRun, b: AVRun) -> None:
    """Equal outputs: the rows of tracks.txt, persons.csv and speech.rttm."""
    for name in ("frames", "ids", "boxes", "scores"):
        np.testing.assert_array_equal(getattr(a.tracks, name), getattr(b.tracks, name))
    np.testing.assert_array_equal(a.speaking, b.speaking)
    assert a.persons.to_csv() == b.persons.to_csv()
    assert a.speech == b.speech


def test_scene_direction_is_the_librarys_persons_tracker():
    scene_dir = out_of_image()
    steps: list[str] = []

    def step(what: str):
        steps.append(what)
        import contextlib

        return contextlib.nullcontext()

    run = track_scene_direction(scene_dir, PersonConfig(), step=step)
    res = track_scene_persons(load_scene(scene_dir), config=PersonConfig())
    _same_run(run, AVRun(res.tracks, res.speaking, res.persons, res.speech, res.n_frames,
                         res.fps, 0.0, None, FS))
    assert steps == ["tracking 400 frames"]
    assert run.voices is None and run.n_persons == len(np.unique(res.persons.ids))
    assert run.duration_s == pytest.approx(16.0)


def test_scene_image_without_audio_and_with_a_mapping_file():
    scene_dir, _, mapping_path = walkout()
    visual = track_scene_image(scene_dir, VAVITConfig(), use_audio=False, fov_fraction=0.4)
    assert isinstance(visual, ImageRun)
    assert visual.speech is None and visual.mapping is None and not visual.mapping_trained
    assert len(np.unique(visual.tracks.ids)) == 2  # the visual tracker loses the walker
    heard = track_scene_image(scene_dir, VAVITConfig(), mapping=mapping_path, fov_fraction=0.4)
    assert heard.speech and not heard.mapping_trained and heard.mapping is not None
    # persons.csv of the image model: one row per reported box, at its centre
    np.testing.assert_array_equal(heard.persons.frames, heard.tracks.frames)
    np.testing.assert_allclose(heard.persons.pixels,
                               heard.tracks.boxes[:, :2] + heard.tracks.boxes[:, 2:] / 2)
    with pytest.raises(InputError, match="--calibration-positions must be >= 4, got 3"):
        track_scene_image(scene_dir, VAVITConfig(), calibration_positions=3)


@pytest.fixture(scope="module")
def own(tmp_path_factory):
    """The out-of-image scene as a recording of one's own: its WAV, detections and a camera
    file in the array's frame."""
    scene_dir, camera = _recording_files(tmp_path_factory.mktemp("own"))
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

    def step(what: str):
        import contextlib

        steps.append(what)
        return contextlib.nullcontext()

    got = localize_for_persons(ArrayRecording(wav, array, quiet=True, block_s=0.3), 25.0,
                               n_frames, vad=vad_available(), step=step)
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


def test_own_recording_in_blocks_equals_one_block(own):
    scene_dir, camera, array = own
    inputs = RecordingInputs(camera=camera, detections=scene_dir / "detections.txt",
                             appearance=scene_dir / "appearance.npy",
                             audio=scene_dir / "audio.wav", array=array, fps=25.0)
    blocks = track_own_recording(inputs, PersonConfig(), block_s=0.7)
    whole = track_own_recording(inputs, PersonConfig(), block_s=60.0)
    assert isinstance(blocks, RecordingRun)
    _same_run(blocks, whole)
    assert blocks.n_frames == 400 and blocks.fps == 25.0 and blocks.audio_fs == FS
    assert blocks.speech and len({s.speaker for s in blocks.speech}) == 2
    assert blocks.camera_fit is None and blocks.camera_check is not None
    assert not blocks.camera_check.warnings  # the camera file agrees with the recording


def test_own_recording_from_a_doa_csv_with_the_camera_estimated(tmp_path):
    scene_dir, camera = _recording_files(tmp_path, walkout()[0])
    inputs = RecordingInputs(camera=None, detections=scene_dir / "detections.txt",
                             doa=scene_dir / "gt" / "doa.csv", fps=25.0,
                             image_size=(640, 480))
    run = track_own_recording(inputs, PersonConfig())
    assert run.camera_fit is not None and run.camera_check is None
    assert run.camera is run.camera_fit.camera
    assert run.speech and run.audio_fs is None
    # without audio: the visual tracker, no speaker turns; the camera is needed then
    visual = track_own_recording(RecordingInputs(camera=camera,
                                                 detections=scene_dir / "detections.txt",
                                                 fps=25.0), PersonConfig(), use_audio=False)
    assert visual.speech is None and visual.camera_check is None
    with pytest.raises(InputError, match="--camera auto needs the audio's directions"):
        track_own_recording(RecordingInputs(camera=None, detections=scene_dir / "detections.txt",
                                            fps=25.0, image_size=(640, 480)),
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
    with pytest.raises(InputError, match="AV16.3 folder not found"):
        track_av163_sequence(tmp_path / "none", 7, 2, video, PersonConfig())
