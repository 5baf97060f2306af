"""The MOTChallenge path: detections of a file, or of a detector on a video, to OVBT tracks,
with the sequence's image size, length and frame rate found where the command line finds
them."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from avtrack.errors import InputError
from avtrack.io.mot import MOTData, read_mot, write_mot
from avtrack.pipelines import MOTRun, track_mot_sequence
from avtrack.pipelines.mot import (
    DETECTOR_DEFAULTS,
    VIDEO_DEFAULTS,
    default_config,
    score_against_sequence,
)
from avtrack.visual.ovbt import OVBTConfig, track_mot
from tests.io.test_video import write_video

RED_SQUARE = "tests.visual.test_detect:make_red_square_detector"


def _walkers(n_frames: int = 20) -> MOTData:
    """Two people walking right, one detection each per frame."""
    frames = np.repeat(np.arange(1, n_frames + 1), 2)
    k = frames - 1
    left = np.where(np.arange(frames.size) % 2 == 0, 10 + 3 * k, 200 + 2 * k)
    boxes = np.column_stack([left, np.full(frames.size, 40.0), np.full(frames.size, 30.0),
                             np.full(frames.size, 80.0)])
    return MOTData(frames, -np.ones(frames.size, int), boxes, np.full(frames.size, 0.9))


@pytest.fixture
def sequence(tmp_path):
    """SEQ/det/det.txt and SEQ/seqinfo.ini (640x480, 7 fps, 25 frames)."""
    det = tmp_path / "SEQ" / "det" / "det.txt"
    det.parent.mkdir(parents=True)
    write_mot(det, _walkers())
    (tmp_path / "SEQ" / "seqinfo.ini").write_text(
        "[Sequence]\nname=SEQ\nframeRate=7\nseqLength=25\nimWidth=640\nimHeight=480\n")
    return det


def test_default_config_adds_the_video_defaults_only_with_a_video():
    assert default_config(video=False) == OVBTConfig()
    assert default_config(video=True) == replace(OVBTConfig(), **VIDEO_DEFAULTS)


def test_default_config_for_a_built_in_detector_lets_weak_boxes_show_targets():
    assert default_config(video=True, detector=True) == replace(
        OVBTConfig(), **VIDEO_DEFAULTS, **DETECTOR_DEFAULTS)
    assert default_config(video=True, detector=True).weak_evidence == 1.0
    with pytest.raises(ValueError, match="needs video"):
        default_config(video=False, detector=True)


def test_detections_file_tracks_as_the_library_does_with_the_seqinfo(sequence):
    run = track_mot_sequence(OVBTConfig(), sequence)
    assert isinstance(run, MOTRun)
    assert (run.image_size, run.n_frames, run.fps) == ((640, 480), 25, 7.0)
    assert run.fps_source == str(sequence.parent.parent / "seqinfo.ini")
    assert run.video is None and len(run.detections) == 40
    expected = track_mot(read_mot(sequence), None, OVBTConfig(), (640, 480), 25, 7.0)
    np.testing.assert_array_equal(run.tracks.boxes, expected.boxes)
    np.testing.assert_array_equal(run.tracks.ids, expected.ids)
    assert len(np.unique(run.tracks.ids)) == 2


def test_given_image_size_and_frame_rate_win_over_the_seqinfo(sequence):
    run = track_mot_sequence(OVBTConfig(), sequence, image_size=(800, 600), fps=12.5)
    assert (run.image_size, run.fps, run.fps_source) == ((800, 600), 12.5, None)
    assert run.n_frames == 20  # the seqinfo's length goes with its image size


def test_without_seqinfo_the_detections_give_the_image_size(tmp_path):
    det = tmp_path / "det.txt"
    write_mot(det, _walkers())
    run = track_mot_sequence(OVBTConfig(), det)
    assert run.fps is None and run.fps_source is None and run.n_frames == 20
    assert run.image_size[0] >= 240 and run.image_size[1] >= 120


def test_stages_are_opened_around_each_long_step(tmp_path, sequence):
    opened: list[str] = []

    def stage(desc):
        opened.append(desc)
        return np.errstate()  # any context manager

    track_mot_sequence(OVBTConfig(), sequence, stage=stage)
    assert opened == ["tracking 25 frames"]
    video = tmp_path / "v.avi"
    write_video(video)
    opened.clear()
    track_mot_sequence(default_config(video=True), video=video, detector=RED_SQUARE,
                       stage=stage)
    assert [d.split(" ")[0] for d in opened] == ["detecting", "colour", "tracking"]


def test_video_and_detector_give_one_track_of_the_red_square(tmp_path):
    video = tmp_path / "v.avi"
    write_video(video)
    run = track_mot_sequence(default_config(video=True), video=video, detector=RED_SQUARE)
    assert run.video is not None and run.image_size == (96, 64) and run.n_frames == 12
    assert run.fps == pytest.approx(10.0) and run.fps_source == "the video's header"
    assert len(run.detections) == 12 and len(np.unique(run.tracks.ids)) == 1


def test_inconsistent_inputs_are_named(tmp_path):
    video = tmp_path / "v.avi"
    write_video(video)  # 12 frames of 96x64
    det = tmp_path / "det.txt"
    small = _walkers(12)
    write_mot(det, replace(small, boxes=small.boxes * 0.2))  # inside the video's image
    config = default_config(video=True)
    for kwargs, message in [
        ({}, "give the detections, or a video"),
        ({"detections": det, "detector": "hog"}, "--detector detects in the frames"),
        ({"detections": det, "video": video, "image_size": (100, 64)},
         "--image-size 100x64 differs from the video's 96x64"),
    ]:
        with pytest.raises(InputError, match=message):
            track_mot_sequence(config, **kwargs)
    with pytest.raises(InputError, match="the config's appearance must be 'bhattacharyya'"):
        track_mot_sequence(replace(config, appearance="cosine"), det, video=video)
    write_mot(det, replace(small, boxes=small.boxes * 0.2, frames=small.frames + 1))
    with pytest.raises(InputError, match="detections reach frame 13, the video"):
        track_mot_sequence(config, det, video=video)
    write_mot(det, small)  # the second walker is right of the 96-pixel image
    with pytest.raises(InputError, match="lies entirely outside the video's 96x64 image"):
        track_mot_sequence(config, det, video=video)


def test_scores_against_the_sequence_ground_truth(sequence):
    run = track_mot_sequence(OVBTConfig(), sequence)
    assert score_against_sequence(run.tracks, sequence, run.n_frames) == (None, {})
    gt = sequence.parent.parent / "gt" / "gt.txt"
    gt.parent.mkdir()
    truth = _walkers()
    write_mot(gt, replace(truth, ids=np.tile([1, 2], 20), scores=np.ones(40)))
    found, scores = score_against_sequence(run.tracks, sequence, run.n_frames)
    assert found is not None and len(found) == 40
    assert set(scores) == {"MOTA", "IDF1", "HOTA", "IDSW"} and scores["IDSW"] == 0.0
    assert scores["MOTA"] > 80.0
