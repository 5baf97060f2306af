"""Video decoding (OpenCV), colour histograms from pixels, track-mot --video."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.errors import InputError
from avtrack.io.mot import MOTData, write_mot
from avtrack.io.video import iter_frames, probe_video
from avtrack.visual.histograms import box_histograms, detection_histograms, person_histograms


def write_video(path, n_frames=12, size=(96, 64), fps=10.0):
    """A small MJPG AVI: a red square moving right on grey; returns the frames written."""
    import cv2

    w, h = size
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, (w, h))
    assert writer.isOpened()
    frames = []
    for k in range(n_frames):
        img = np.full((h, w, 3), 128, np.uint8)
        img[20:40, 5 + 4 * k : 25 + 4 * k] = (0, 0, 255)  # BGR red
        writer.write(img)
        frames.append(img)
    writer.release()
    return frames


def read_video(path) -> list[np.ndarray]:
    """Every frame of the video at ``path``, decoded by OpenCV."""
    import cv2

    cap = cv2.VideoCapture(str(path))
    frames = []
    while True:
        ok, frame = cap.read()
        if not ok:
            break
        frames.append(frame)
    cap.release()
    return frames


def test_probe_and_decode_a_small_video(tmp_path):
    path = tmp_path / "v.avi"
    written = write_video(path)
    info = probe_video(path)
    assert (info.n_frames, info.width, info.height) == (12, 96, 64)
    assert info.fps == pytest.approx(10.0)
    frames = list(iter_frames(path, info))
    assert len(frames) == 12 and frames[0].shape == (64, 96, 3) and frames[0].dtype == np.uint8
    # MJPG is lossy: the red square is still where it was drawn
    assert np.abs(frames[3].astype(int) - written[3].astype(int)).mean() < 6


def test_bad_videos_are_named(tmp_path):
    with pytest.raises(InputError, match="video file not found"):
        probe_video(tmp_path / "none.mp4")
    (tmp_path / "text.mp4").write_text("not a video\n")
    with pytest.raises(InputError, match="cannot open the video"):
        probe_video(tmp_path / "text.mp4")
    path = tmp_path / "v.avi"
    write_video(path, n_frames=30)
    data = path.read_bytes()
    cut = tmp_path / "cut.avi"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(InputError) as err:
        info = probe_video(cut)
        list(iter_frames(cut, info))
    assert "cut.avi" in str(err.value)


def test_box_histograms_hand_case():
    img = np.full((10, 10, 3), 0, np.uint8)
    img[:, :5] = (0, 0, 255)  # pure red: hue 0, saturation 255
    img[:, 5:] = (255, 0, 0)  # pure blue: hue 120 (of 180), saturation 255
    h = box_histograms(img, np.array([[0, 0, 5, 10], [0, 0, 10, 10], [50, 50, 5, 5]]), (6, 4))
    red, half, outside = h.reshape(3, 6, 4)
    assert red[0, 3] == pytest.approx(1.0)
    assert half[0, 3] == pytest.approx(0.5) and half[4, 3] == pytest.approx(0.5)
    assert np.allclose(outside, 1 / 24)  # no pixel inside: uniform


def test_person_histograms_read_the_inner_part_and_tell_black_from_white():
    """A 20 x 40 box: a 2-px background border on each side (outside 20-80 % of the width),
    a head strip (top 15 %), black coat, white trousers; another person all in white."""
    img = np.full((40, 40, 3), 0, np.uint8)
    img[:, :] = (0, 200, 0)  # green background (hue 60)
    img[6:22, 4:16] = (0, 0, 0)  # black coat: value bin 0
    img[22:36, 4:16] = (255, 255, 255)  # white trousers: value bin 3, saturation bin 0
    img[0:6, 4:16] = (0, 0, 255)  # red head: outside the inner part
    img[:, 20:40] = (255, 255, 255)  # a person all in white
    h = person_histograms(img, np.array([[0, 0, 20, 40], [20, 0, 20, 40], [90, 90, 5, 5]]))
    assert h.shape == (3, 128) and np.allclose(h.sum(axis=1), 1.0)
    coat, white, outside = h.reshape(3, 8, 4, 4)
    assert coat[0, 0, 0] == pytest.approx(16 / 30, abs=0.05)  # rows 6-21 of the inner 6-35
    assert coat[0, 0, 3] == pytest.approx(14 / 30, abs=0.05)
    assert coat[2].sum() == 0 and coat[0, 3].sum() == 0  # no background green, no red head
    assert white[0, 0, 3] == pytest.approx(1.0)
    assert np.allclose(outside, 1 / 128)
    # the whole-box hue-saturation histogram cannot tell the two apart from their hue
    hs = box_histograms(img, np.array([[4, 6, 12, 30], [24, 6, 12, 30]]))
    assert np.allclose(hs[0], hs[1])  # black and white: both hue 0, saturation 0


def test_detection_histograms_descriptor_choice(tmp_path):
    path = tmp_path / "v.avi"
    write_video(path)
    dets = MOTData(np.array([1, 5]), -np.ones(2), np.array(
        [[5.0, 20, 20, 20], [60.0, 45, 20, 15]]), np.ones(2))
    h = detection_histograms(iter_frames(path), dets, 12, descriptor="person")
    assert h.shape == (2, 128) and np.allclose(h.sum(axis=1), 1.0)
    with pytest.raises(ValueError, match="descriptor"):
        detection_histograms(iter_frames(path), dets, 12, descriptor="sift")


def test_detection_histograms_follow_the_frames(tmp_path):
    path = tmp_path / "v.avi"
    write_video(path)
    dets = MOTData(np.array([1, 5, 5]), -np.ones(3), np.array(
        [[5.0, 20, 20, 20], [21.0, 20, 20, 20], [60.0, 45, 20, 15]]), np.ones(3))
    h = detection_histograms(iter_frames(path), dets, 12)
    assert h.shape == (3, 64) and np.allclose(h.sum(axis=1), 1.0)
    assert h[0].argmax() == h[1].argmax() == 7  # red, saturated: hue bin 0, top saturation bin
    assert h[2, 7] < 0.05  # the grey background


def test_track_mot_with_video(tmp_path, capsys):
    from avtrack.cli.main import main

    path = tmp_path / "v.avi"
    write_video(path)
    boxes = np.array([[5.0 + 4 * k, 20, 20, 20] for k in range(12)])
    det = tmp_path / "det.txt"
    write_mot(det, MOTData(np.arange(1, 13), -np.ones(12), boxes, np.ones(12)))
    out = tmp_path / "res.txt"
    assert main(["track-mot", str(det), "-o", str(out), "--video", str(path), "-q"]) == 0
    assert len(out.read_text().splitlines()) >= 10
    # detections past the video's end, or outside its image: one line, no output
    bad = tmp_path / "bad.txt"
    write_mot(bad, MOTData(np.array([1, 20]), -np.ones(2), boxes[:2], np.ones(2)))
    assert main(["track-mot", str(bad), "-o", str(tmp_path / "r2.txt"), "--video",
                 str(path)]) == 2
    assert "reach frame 20" in capsys.readouterr().err
    write_mot(bad, MOTData(np.array([1]), -np.ones(1), np.array([[500.0, 5, 10, 10]]),
                           np.ones(1)))
    assert main(["track-mot", str(bad), "-o", str(tmp_path / "r2.txt"), "--video",
                 str(path)]) == 2
    assert "entirely outside" in capsys.readouterr().err
    assert not (tmp_path / "r2.txt").exists()


def test_shared_real_videos(shared_data):
    tud = probe_video(shared_data / "mot15" / "TUD-Campus" / "TUD-Campus.mp4")
    assert (tud.n_frames, tud.width, tud.height) == (71, 640, 480)
    first = next(iter_frames(tud.path, tud))
    assert first.shape == (480, 640, 3) and first.std() > 10  # a real image, not blank


def test_track_mot_report_draws_over_the_real_frames(tmp_path):
    """--report DIR: index.html and tracks.webm whose frames are the video's own (grey with
    the red square), scored against SEQ/gt/gt.txt when the sequence folder has one."""

    from avtrack.cli.main import main

    seq = tmp_path / "SEQ"
    (seq / "det").mkdir(parents=True)
    (seq / "gt").mkdir()
    path = seq / "v.avi"
    frames = write_video(path, size=(320, 240))
    boxes = np.array([[5.0 + 4 * k, 20, 20, 20] for k in range(12)])
    write_mot(seq / "det" / "det.txt", MOTData(np.arange(1, 13), -np.ones(12), boxes,
                                               np.ones(12)))
    (seq / "gt" / "gt.txt").write_text("".join(
        f"{k + 1},1,{5 + 4 * k},20,20,20,1,1,1\n" for k in range(12)))
    report = tmp_path / "report"
    args = ["track-mot", str(seq / "det" / "det.txt"), "-o", str(tmp_path / "res.txt"),
            "--video", str(path), "-q"]
    assert main([*args, "--report", str(report)]) == 0
    page = (report / "index.html").read_text()
    assert "MOTA" in page and "IDF1" in page
    got = read_video(report / "tracks.webm")
    assert len(got) == 12
    # away from the header band and the legend (top left): the video's own grey, where a
    # rendered room would have its walls and floor
    diff = np.abs(got[5][120:, 160:].astype(float) - frames[5][120:, 160:].astype(float))
    assert np.median(diff) < 10
    # --report needs --video; an existing report folder needs --force
    assert main([*args[:4], "--report", str(tmp_path / "r2")]) == 2
    assert not (tmp_path / "r2").exists()
    assert main([*args, "--report", str(report)]) == 2
    assert main([*args, "--report", str(report), "--force"]) == 0
