"""The detector interface: built-in OpenCV detectors and plug-ins (module:attribute)."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.errors import InputError
from avtrack.visual.detect import DETECTORS, HOGPeopleDetector, detect_video, load_detector
from tests.io.test_video import write_video


class RedSquareDetector:
    """A plug-in: boxes around saturated red pixels (the test video's moving square)."""

    def detect(self, frame):
        red = (frame[..., 2] > 200) & (frame[..., 1] < 80) & (frame[..., 0] < 80)
        ys, xs = np.nonzero(red)
        if xs.size == 0:
            return np.zeros((0, 4)), np.zeros(0)
        return np.array([[xs.min(), ys.min(), xs.max() - xs.min() + 1,
                          ys.max() - ys.min() + 1]], float), np.array([0.9])


def make_red_square_detector():
    return RedSquareDetector()


class BadDetector:
    def detect(self, frame):
        return np.zeros((2, 3)), np.zeros(2)


def test_builtin_detectors_run_on_a_frame():
    frame = np.full((240, 320, 3), 100, np.uint8)
    for name in DETECTORS:
        boxes, scores = load_detector(name).detect(frame)
        assert boxes.ndim == 2 and boxes.shape[1] == 4 and scores.shape == (boxes.shape[0],)
    with pytest.raises(ValueError, match="uint8"):
        HOGPeopleDetector().detect(np.zeros((10, 10)))


def test_plugins_load_by_module_and_attribute():
    det = load_detector("tests.visual.test_detect:make_red_square_detector")
    assert isinstance(det, RedSquareDetector)
    assert isinstance(load_detector("tests.visual.test_detect:RedSquareDetector"),
                      RedSquareDetector)
    with pytest.raises(InputError, match="unknown detector 'yolo'"):
        load_detector("yolo")
    with pytest.raises(InputError, match="cannot load"):
        load_detector("tests.visual.test_detect:nothing_here")


def test_detect_video_and_track_mot_with_a_plugin(tmp_path, capsys):
    from avtrack.cli.main import main

    video = tmp_path / "v.avi"
    write_video(video)
    from avtrack.io.video import iter_frames

    dets = detect_video(RedSquareDetector(), iter_frames(video), 12)
    assert len(dets) == 12 and np.allclose(dets.boxes[0, 2:], 20, atol=2)
    with pytest.raises(InputError, match="expected \\(M, 4\\)"):
        detect_video(BadDetector(), iter_frames(video), 12)
    out = tmp_path / "res.txt"
    plugin = "tests.visual.test_detect:make_red_square_detector"
    assert main(["track-mot", "-o", str(out), "--video", str(video), "--detector", plugin,
                 "-q"]) == 0
    rows = [r.split(",") for r in out.read_text().splitlines()]
    assert len(rows) >= 10 and len({r[1] for r in rows}) == 1
    assert main(["track-mot", "-o", str(out), "--force"]) == 2
    assert "give DET.txt, or --video" in capsys.readouterr().err
    assert main(["track-mot", "-o", str(tmp_path / "r.txt"), "--video", str(video),
                 "--detector", "tests.visual.test_detect:BadDetector"]) == 2
    assert "expected (M, 4)" in capsys.readouterr().err
