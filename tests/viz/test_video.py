"""The MP4 / WebM overlay: frames, colours, speaking marker, codecs, atomic writes."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from avtrack.io.camera import PinholeCamera
from avtrack.io.mot import MOTData
from avtrack.viz import video
from avtrack.viz.video import (
    TAB10_BGR,
    VIDEO_CODECS,
    render_background,
    render_overlay_frames,
    render_overlay_video,
    render_scene_video,
    track_colours,
    video_codec,
)

cv2 = pytest.importorskip("cv2")

N_FRAMES = 10
SIZE = (320, 240)
SPEAKING_FRAMES = range(4, 8)  # track 2 speaks at frames 4..7
TOL = 40  # per-channel tolerance of the lossy codecs on flat colours


def _tracks() -> tuple[MOTData, np.ndarray]:
    """Track 1 moves right, track 2 stands still and speaks at SPEAKING_FRAMES."""
    frames = np.repeat(np.arange(1, N_FRAMES + 1), 2)
    ids = np.tile([1, 2], N_FRAMES)
    boxes = []
    for f in range(1, N_FRAMES + 1):
        boxes += [[40 + 3 * f, 90, 50, 60], [200, 80, 50, 60]]
    tracks = MOTData(frames, ids, np.array(boxes, float), np.ones(2 * N_FRAMES))
    speaking = (ids == 2) & np.isin(frames, SPEAKING_FRAMES)
    return tracks, speaking


def _read(path) -> list[np.ndarray]:
    cap = cv2.VideoCapture(str(path))
    out = []
    while True:
        ok, img = cap.read()
        if not ok:
            break
        out.append(img)
    cap.release()
    return out


def _corners(tracks: MOTData, f: int, tid: int) -> tuple[int, int, int, int]:
    left, top, w, h = tracks.boxes[(tracks.frames == f) & (tracks.ids == tid)][0]
    return round(left), round(top), round(left + w), round(top + h)


def _near(img: np.ndarray, colour) -> np.ndarray:
    """Pixels within TOL of ``colour`` in every channel, (h, w) bool."""
    return np.all(np.abs(img.astype(int) - np.array(colour)) < TOL, axis=-1)


def _edge_colour(img: np.ndarray, corners) -> np.ndarray:
    """Median colour of the 3-pixel strip along the left edge of a box."""
    x0, y0, _, y1 = corners
    return np.median(img[y0 + 10 : y1 - 10, x0 - 1 : x0 + 2].reshape(-1, 3), axis=0)


def _bubble_pixels(img: np.ndarray, corners, colour) -> int:
    """Pixels of the track's colour right of the box, where the speech bubble goes."""
    _, y0, x1, _ = corners
    return int(_near(img[y0 : y0 + 20, x1 + 4 : x1 + 26], colour).sum())


# --------------------------------------------------------------------------- raw frames


def test_frames_have_the_size_and_the_track_colours():
    tracks, speaking = _tracks()
    frames = list(render_overlay_frames(tracks, speaking, SIZE, 25.0))
    assert len(frames) == N_FRAMES
    for f, img in enumerate(frames, start=1):
        assert img.shape == (SIZE[1], SIZE[0], 3) and img.dtype == np.uint8
        for rank, tid in enumerate((1, 2)):
            x0, y0, _, y1 = _corners(tracks, f, tid)
            assert tuple(img[(y0 + y1) // 2, x0]) == TAB10_BGR[rank]


def test_speech_bubble_only_on_speaking_frames():
    tracks, speaking = _tracks()
    frames = list(render_overlay_frames(tracks, speaking, SIZE, 25.0))
    for f, img in enumerate(frames, start=1):
        n = _bubble_pixels(img, _corners(tracks, f, 2), TAB10_BGR[1])
        if f in SPEAKING_FRAMES:
            assert n > 25, f
        else:
            assert n == 0, f
        assert _bubble_pixels(img, _corners(tracks, f, 1), TAB10_BGR[0]) == 0  # never speaks


def test_nobody_speaks_without_flags_and_silent_frames_do_not_depend_on_others():
    tracks, speaking = _tracks()
    with_flags = list(render_overlay_frames(tracks, speaking, SIZE, 25.0))
    silent = list(render_overlay_frames(tracks, None, SIZE, 25.0))
    for f in range(1, N_FRAMES + 1):
        same = np.array_equal(with_flags[f - 1], silent[f - 1])
        assert same == (f not in SPEAKING_FRAMES)


def test_ground_truth_people_and_boxes_are_drawn():
    tracks, speaking = _tracks()
    gt = MOTData([1, 1], [7, 8], [[120, 40, 30, 40], [260, 150, 20, 30]], [1, 1])
    img = next(render_overlay_frames(tracks, speaking, SIZE, 25.0, gt=gt))
    assert tuple(img[60, 135]) == video._SKIN_BGR  # head centre
    assert tuple(img[100, 135]) == video._CLOTH_BGR  # body below it
    assert tuple(img[55, 120]) == video._GT_BGR  # thin grey box edge
    bare = next(render_overlay_frames(tracks, speaking, SIZE, 25.0, gt=gt, show_gt_boxes=False))
    assert tuple(bare[55, 120]) != video._GT_BGR


def test_odd_sizes_are_rounded_up_to_even():
    tracks, speaking = _tracks()
    img = next(render_overlay_frames(tracks, speaking, (321, 241), 25.0))
    assert img.shape == (242, 322, 3)


def test_track_colours_follow_the_rank_of_the_id():
    assert track_colours([9, 3, 3, 5]) == {3: TAB10_BGR[0], 5: TAB10_BGR[1], 9: TAB10_BGR[2]}
    many = track_colours(np.arange(12))
    assert many[10] == TAB10_BGR[0] and many[11] == TAB10_BGR[1]


# --------------------------------------------------------------------------- background


def _camera() -> PinholeCamera:
    return PinholeCamera.from_fov(70.0, SIZE[0], SIZE[1], [2.5, 0.5, 1.35], yaw_deg=90.0)


def test_room_background_shows_floor_below_and_ceiling_above():
    room = render_background(SIZE, _camera(), [5.0, 4.0, 2.7]).astype(int)
    assert room.shape == (SIZE[1], SIZE[0], 3) and room.dtype == int
    floor, ceiling = room[-5:].mean(axis=(0, 1)), room[:5].mean(axis=(0, 1))
    assert np.all(ceiling > floor + 30)
    # a plane without walls reaches the horizon: the top half is the wall gradient
    plane = render_background(SIZE, _camera())
    assert np.array_equal(plane[:20], render_background(SIZE)[:20])


def test_background_bad_inputs():
    with pytest.raises(ValueError, match="inside the room"):
        render_background(SIZE, _camera(), [2.0, 4.0, 2.7])
    with pytest.raises(ValueError, match="camera image size 320x240 does not match"):
        render_background((640, 480), _camera())
    with pytest.raises(ValueError, match="room_dims must be 3"):
        render_background(SIZE, _camera(), [5.0, 4.0])
    with pytest.raises(ValueError, match="image_size: width must be an integer"):
        render_background((320.5, 240))


# --------------------------------------------------------------------------- video files


@pytest.mark.parametrize("suffix", sorted(VIDEO_CODECS))
def test_video_round_trip(tmp_path, suffix):
    tracks, speaking = _tracks()
    path = tmp_path / "sub" / f"tracks{suffix}"
    assert render_overlay_video(path, tracks, speaking, SIZE, 25.0, title="test") == path
    assert sorted(p.name for p in path.parent.iterdir()) == [path.name]  # no temporary left
    frames = _read(path)
    assert len(frames) == N_FRAMES
    for f, img in enumerate(frames, start=1):
        assert img.shape == (SIZE[1], SIZE[0], 3)
        for rank, tid in enumerate((1, 2)):
            edge = _edge_colour(img, _corners(tracks, f, tid))
            assert np.all(np.abs(edge - TAB10_BGR[rank]) < TOL), (f, tid, edge)
        n = _bubble_pixels(img, _corners(tracks, f, 2), TAB10_BGR[1])
        assert (n > 15) if f in SPEAKING_FRAMES else (n < 3), (f, n)


def test_video_codec_follows_the_suffix():
    assert video_codec("a.mp4") == "mp4v" and video_codec("b.WEBM") == "VP80"
    assert video_codec("a.mp4", "XVID") == "XVID"
    with pytest.raises(ValueError, match=r"suffix must be one of \['.mp4', '.webm'\], got '.avi'"):
        video_codec("a.avi")
    with pytest.raises(ValueError, match="got 'none'"):
        video_codec("video")
    with pytest.raises(ValueError, match="four-character"):
        video_codec("a.mp4", "h264x")


@pytest.mark.parametrize(
    ("change", "error", "match"),
    [
        ({"path": "x.avi"}, ValueError, "suffix"),
        ({"speaking": np.zeros(3, bool)}, ValueError, r"speaking must have shape \(20,\)"),
        ({"speaking": np.zeros(20, int)}, TypeError, "speaking must be a boolean array"),
        ({"image_size": (320,)}, ValueError, "image_size must be"),
        ({"image_size": (0, 240)}, ValueError, "width must be an integer"),
        ({"fps": 0.0}, ValueError, "fps must be in"),
        ({"fps": float("nan")}, ValueError, "fps must be in"),
        ({"n_frames": 5}, ValueError, "rows up to frame 10"),
        ({"n_frames": 0}, ValueError, "n_frames must be >= 1"),
        ({"tracks": np.zeros((20, 4))}, TypeError, "tracks must be MOTData"),
        ({"camera": "cam"}, TypeError, "camera must be a PinholeCamera"),
        ({"room_dims": [1.0, -1.0, 2.0]}, ValueError, "room_dims"),
        ({"codec": "mp4"}, ValueError, "four-character"),
    ],
)
def test_bad_arguments_are_named_and_leave_nothing(tmp_path, change, error, match):
    tracks, speaking = _tracks()
    args = {
        "path": "out.mp4",
        "tracks": tracks,
        "speaking": speaking,
        "image_size": SIZE,
        "fps": 25.0,
    }
    args.update(change)
    args["path"] = tmp_path / args["path"]
    with pytest.raises(error, match=match):
        render_overlay_video(**args)
    assert list(tmp_path.iterdir()) == []


def test_empty_input_needs_n_frames(tmp_path):
    empty = MOTData(np.zeros(0), np.zeros(0), np.zeros((0, 4)), np.zeros(0))
    with pytest.raises(ValueError, match="give the number of frames"):
        render_overlay_video(tmp_path / "e.mp4", empty, None, SIZE, 25.0)
    path = render_overlay_video(tmp_path / "e.mp4", empty, None, SIZE, 25.0, n_frames=3)
    assert len(_read(path)) == 3


def test_unknown_codec_is_a_clear_error_and_keeps_the_old_file(tmp_path):
    tracks, speaking = _tracks()
    path = tmp_path / "out.mp4"
    path.write_bytes(b"old")
    with pytest.raises(RuntimeError, match="cannot open a 'avc1' video writer"):
        render_overlay_video(path, tracks, speaking, SIZE, 25.0, codec="avc1")
    assert path.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["out.mp4"]


def test_failure_while_writing_leaves_no_file(tmp_path, monkeypatch):
    tracks, speaking = _tracks()
    frame = video._Renderer.frame

    def fail_at_5(self, f):
        if f == 5:
            raise KeyboardInterrupt
        return frame(self, f)

    monkeypatch.setattr(video._Renderer, "frame", fail_at_5)
    with pytest.raises(KeyboardInterrupt):
        render_overlay_video(tmp_path / "out.webm", tracks, speaking, SIZE, 25.0)
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------- a scene


def _tiny_scenario() -> dict:
    return {
        "name": "tiny-video",
        "duration": 2.0,
        "seed": 0,
        "room": {"dims": [5.0, 4.0, 2.7], "t60": 0.0},
        "array": {"name": "nao4", "position": [2.5, 0.5, 1.3], "yaw_deg": 90.0},
        "camera": {"hfov_deg": 70.0, "width": 320, "height": 240},
        "people": [
            {"id": 1, "motion": {"type": "seated", "position": [2.0, 2.5, 1.2]}},
            {"id": 2, "motion": {"type": "seated", "position": [3.1, 2.8, 1.25]}},
        ],
        "speech": {
            "mode": "turn-taking",
            "utterances": "synthetic",
            "mean_turn": 0.8,
            "mean_pause": 0.2,
        },
        "noise": {"diffuse_snr_db": None, "fan_snr_db": None},
        "detector": {"miss_rate": 0.0, "false_alarm_rate": 0.0},
    }


def test_scene_video_end_to_end(tmp_path):
    from avtrack.av.vavit import track_scene
    from avtrack.io.scenario import validate_scenario
    from avtrack.io.scene import load_scene
    from avtrack.simulate.scene import simulate_scene, write_scene

    scene_dir = write_scene(simulate_scene(validate_scenario(_tiny_scenario())), tmp_path / "s")
    inputs = load_scene(scene_dir)
    res = track_scene(scene_dir, use_audio=False, scene=inputs)
    assert len(res.tracks) and res.n_frames == 50
    talk = res.tracks.ids == res.tracks.ids.min()  # say the first track speaks throughout
    res = dataclasses.replace(res, speaking=talk)
    path = render_scene_video(scene_dir, res, tmp_path / "scene.webm")
    frames = _read(path)
    assert len(frames) == res.n_frames and frames[0].shape == (240, 320, 3)
    colours = track_colours(res.tracks.ids)
    row = int(np.flatnonzero(res.tracks.frames == 25)[0])
    tid, f = int(res.tracks.ids[row]), 25
    corners = _corners(res.tracks, f, tid)
    edge = _edge_colour(frames[f - 1], corners)
    assert np.all(np.abs(edge - colours[tid]) < TOL)
    # the same from already-loaded inputs, and the result must fit the scene
    assert render_scene_video(inputs, res, tmp_path / "again.mp4").is_file()
    with pytest.raises(ValueError, match="does not match the scene"):
        render_scene_video(
            inputs, dataclasses.replace(res, image_size=(640, 480)), tmp_path / "bad.mp4"
        )
    with pytest.raises(TypeError, match="AVSceneResult"):
        render_scene_video(inputs, res.tracks, tmp_path / "bad.mp4")
    assert not (tmp_path / "bad.mp4").exists()


def test_legend_sits_at_the_top_clear_of_player_controls():
    """A browser's video controls cover the bottom of the frame: the legend is drawn under
    the header band at the top left, and nothing of it in the bottom third."""
    tracks, speaking = _tracks()
    with_legend = next(iter(render_overlay_frames(tracks, speaking, SIZE, 25.0, legend=True)))
    without = next(iter(render_overlay_frames(tracks, speaking, SIZE, 25.0, legend=False)))
    changed = np.any(with_legend != without, axis=2)
    rows = np.flatnonzero(changed.any(axis=1))
    assert rows.size > 0
    assert rows.max() < SIZE[1] * 2 // 3, (rows.min(), rows.max(), SIZE)
    assert rows.min() > 5  # below the header band's first text row, not over the frame edge


# --------------------------------------------------------------------------- H.264 and WebM


def test_mp4_is_h264_where_pyav_has_the_encoder_and_mpeg4_part_2_otherwise(tmp_path,
                                                                           monkeypatch):
    from avtrack.viz.video import h264_available, html_video_type

    tracks, speaking = _tracks()
    if h264_available():
        path = render_overlay_video(tmp_path / "h.mp4", tracks, speaking, SIZE, 25.0)
        assert html_video_type(path).startswith('video/mp4; codecs="avc1.')
        assert len(_read(path)) == N_FRAMES
    monkeypatch.setattr(video, "h264_available", lambda: False)
    path = render_overlay_video(tmp_path / "p2.mp4", tracks, speaking, SIZE, 25.0)
    assert html_video_type(path) is None  # MPEG-4 Part 2: browsers do not play it
    assert len(_read(path)) == N_FRAMES
    webm = render_overlay_video(tmp_path / "v.webm", tracks, speaking, SIZE, 25.0)
    assert html_video_type(webm) == 'video/webm; codecs="vp8"'
    with pytest.raises(ValueError, match="cannot read"):
        (tmp_path / "text.mp4").write_text("not a video\n")
        html_video_type(tmp_path / "text.mp4")


def test_also_to_writes_more_files_of_the_same_frames_in_one_pass(tmp_path):
    tracks, speaking = _tracks()
    drawn = []
    frames = (np.full((SIZE[1], SIZE[0], 3), 90, np.uint8) for _ in range(N_FRAMES))

    def counted():
        for img in frames:
            drawn.append(1)
            yield img

    path = render_overlay_video(tmp_path / "a.webm", tracks, speaking, SIZE, 25.0,
                                frames=counted(), also_to=[tmp_path / "a.mp4"])  # fmt: skip
    assert len(drawn) == N_FRAMES  # the video's frames read once for both files
    webm, mp4 = _read(path), _read(tmp_path / "a.mp4")
    assert len(webm) == len(mp4) == N_FRAMES
    assert np.median(np.abs(webm[5].astype(int) - mp4[5].astype(int))) < 6
    with pytest.raises(TypeError, match="also_to must be a sequence of paths"):
        render_overlay_video(tmp_path / "b.webm", tracks, speaking, SIZE, 25.0,
                             also_to=tmp_path / "b.mp4")  # type: ignore[arg-type]


def test_a_failure_leaves_none_of_the_files(tmp_path, monkeypatch):
    tracks, speaking = _tracks()
    frame = video._Renderer.frame

    def fail_at_5(self, f):
        if f == 5:
            raise RuntimeError("boom")
        return frame(self, f)

    monkeypatch.setattr(video._Renderer, "frame", fail_at_5)
    with pytest.raises(RuntimeError, match="boom"):
        render_overlay_video(tmp_path / "out.webm", tracks, speaking, SIZE, 25.0,
                             also_to=[tmp_path / "out.mp4"])  # fmt: skip
    assert list(tmp_path.iterdir()) == []
