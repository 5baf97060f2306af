"""Visual multi-person tracking of a MOTChallenge sequence (OVBT, thesis §3.1): the detections
of a file, or of a detector run on a video's frames, to tracks.

With the sequence's video, the appearance of each detection is the colour histogram of its box
in the real frame (thesis eq. 3.5, Bhattacharyya likelihood) and the tracker re-identifies
targets that ended lately (:data:`VIDEO_DEFAULTS`).
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import AbstractContextManager
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from avtrack.errors import InputError
from avtrack.io.datasets import find_seqinfo, read_seqinfo
from avtrack.io.mot import MOTData, read_mot
from avtrack.io.video import VideoInfo, iter_frames, probe_video
from avtrack.visual.camera_motion import CameraMotion
from avtrack.visual.detect import DEFAULT_PERSON_DETECTOR, detect_video, load_detector
from avtrack.visual.histograms import detection_histograms
from avtrack.visual.ovbt import OVBTConfig, image_size_from_detections, track_mot

#: OVBTConfig fields that tracking with the video changes (before a config file): the weight
#: of the person colour histograms in the association (λ of eq. 3.5; MOTA with the video is
#: at least MOTA without it for λ in 8-15, lower below) and re-identification of a target that
#: ended lately. Chosen on TUD-Campus and PETS09-S2L1, the two shared sequences with video
#: (BENCHMARKS.md).
VIDEO_DEFAULTS: dict[str, Any] = {"appearance_lambda": 10.0, "reid_log_ratio": 0.4,
                                  "reid_max_age": 25, "reid_max_distance": 4.0}

#: Opens a named stage of a run around one long call (a progress display); see
#: :func:`no_stage`.
Stage = Callable[[str], AbstractContextManager[object]]


def no_stage(desc: str) -> AbstractContextManager[object]:
    """The default :data:`Stage`: shows nothing."""
    return contextlib.nullcontext()


#: OVBTConfig fields that tracking a built-in detector's boxes changes (after
#: :data:`VIDEO_DEFAULTS`): the detectors report only boxes above their own operating point, and
#: the lower class of those scores is mostly people, so weak boxes show targets as strong ones
#: do (on TUD-Campus with ``ssd-person``, MOTA 61.6 against 57.7 at the public detections'
#: ``weak_evidence``; BENCHMARKS.md, detectors).
DETECTOR_DEFAULTS: dict[str, Any] = {"weak_evidence": 1.0}


def default_config(video: bool, detector: bool = False) -> OVBTConfig:
    """The tracker's defaults on this path: :class:`OVBTConfig`'s, with :data:`VIDEO_DEFAULTS`
    over them when the appearance comes from the video's frames (``video``) and
    :data:`DETECTOR_DEFAULTS` when a built-in detector found the boxes in them (``detector``)."""
    if not video:
        if detector:
            raise ValueError("a detector finds the boxes in a video: detector needs video")
        return OVBTConfig()
    return replace(OVBTConfig(), **VIDEO_DEFAULTS, **(DETECTOR_DEFAULTS if detector else {}))


@dataclass(frozen=True, eq=False)
class MOTRun:
    """What :func:`track_mot_sequence` did.

    Attributes
    ----------
    tracks : MOTData
        The results (confidence = the track's visibility probability).
    detections : MOTData
        The detections tracked (read, or found by the detector).
    n_frames : int
        Frames tracked.
    image_size : (int, int)
        Width and height in pixels.
    fps : float or None
        Frame rate used (None: not known; the tracker assumes its reference rate).
    fps_source : str or None
        Where ``fps`` came from (``"the video's header"``, the seqinfo.ini path); None when
        the caller gave it or it is not known.
    elapsed_s : float
        Seconds spent on the colour histograms and the tracking (reading excluded).
    video : VideoInfo or None
        The video's header, when there is a video.
    """

    tracks: MOTData
    detections: MOTData
    n_frames: int
    image_size: tuple[int, int]
    fps: float | None
    fps_source: str | None
    elapsed_s: float
    video: VideoInfo | None


def detect_in_video(video_path: Path, spec: str, stage: Stage = no_stage) -> MOTData:
    """Detections of a detector on every frame of a video.

    Parameters
    ----------
    video_path : Path
    spec : str
        A built-in detector's name (:data:`avtrack.visual.detect.DETECTORS`) or a
        ``module:attribute`` plug-in (:func:`~avtrack.visual.detect.load_detector`).
    stage : callable, optional
        Opened around the detection (see :data:`Stage`).
    """
    info = probe_video(video_path)
    detector = load_detector(spec)
    with stage(f"detecting people in {info.n_frames} frames ({spec})"):
        try:
            return detect_video(detector, iter_frames(info.path, info), info.n_frames)
        except InputError:
            raise
        except Exception as exc:  # a plug-in's own failure, named as such
            raise InputError(f"--detector {spec} failed: {type(exc).__name__}: {exc}",
                             video_path) from None


def load_appearance(path: Path, n_rows: int) -> np.ndarray:
    """Appearance descriptors ``(n_rows, F)`` from a ``.npy`` file, one row per detection row."""
    if not path.is_file():
        raise InputError("appearance file not found", path)
    try:
        app = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:  # EOFError: an empty file
        raise InputError(f"not a .npy array: {exc}", path) from None
    if app.ndim != 2 or app.shape[0] != n_rows:
        raise InputError(f"expected shape ({n_rows}, F) (one row per detection), got "
                         f"{app.shape}", path)
    if not np.all(np.isfinite(app)):
        raise InputError("contains NaN or infinite values", path)
    return app.astype(float)


def check_against_video(dets: MOTData, video: VideoInfo, det_path: Path) -> None:
    """Detections that cannot belong to the video: frames past its last one, boxes entirely
    outside its image."""
    if len(dets) == 0:
        return
    last = int(dets.frames.max())
    if last > video.n_frames:
        raise InputError(f"detections reach frame {last}, the video {video.path} has "
                         f"{video.n_frames} frames", det_path)
    w, h = video.image_size
    b = dets.boxes
    outside = (b[:, 0] >= w) | (b[:, 1] >= h) | (b[:, 0] + b[:, 2] <= 0) | (b[:, 1] + b[:, 3] <= 0)
    if outside.any():
        k = int(np.flatnonzero(outside)[0])
        raise InputError(f"detection of frame {int(dets.frames[k])} lies entirely outside the "
                         f"video's {w}x{h} image (box {b[k].round(1).tolist()})", det_path)


def track_mot_sequence(
    config: OVBTConfig,
    detections: Path | None = None,
    *,
    video: Path | None = None,
    detector: str | None = None,
    appearance: Path | None = None,
    image_size: tuple[int, int] | None = None,
    fps: float | None = None,
    config_path: Path | None = None,
    stage: Stage = no_stage,
) -> MOTRun:
    """Track the people of a MOTChallenge sequence with OVBT
    (:func:`~avtrack.visual.ovbt.track_mot`).

    Parameters
    ----------
    config : OVBTConfig
        The tracker's parameters (:func:`default_config` gives this path's defaults).
    detections : Path, optional
        MOTChallenge detections; without them, ``detector`` finds them in ``video``'s frames.
    video : Path, optional
        The sequence's video (frame k is MOT frame k): the appearance becomes the colour
        histograms of the detection boxes (``config.appearance`` must be ``bhattacharyya``);
        the image size, length and frame rate are the video's.
    detector : str, optional
        Without ``detections``: the detector run on ``video``'s frames (default
        :data:`~avtrack.visual.detect.DEFAULT_PERSON_DETECTOR`).
    appearance : Path, optional
        Appearance descriptors (``.npy``, one row per detection row); not with ``video``.
    image_size : (int, int), optional
        Width and height in pixels (default: the video's, else seqinfo.ini next to the
        detections, else the detections' extent); with a video it must be the video's.
    fps : float, optional
        Frame rate (default: the video's, else seqinfo.ini's ``frameRate``).
    config_path : Path, optional
        The file ``config`` was read from, named in errors about it.
    stage : callable, optional
        Opened around each long step: detecting, histograms, tracking (see :data:`Stage`).

    Raises
    ------
    InputError
        Unreadable or inconsistent inputs (detections past the video's end, boxes outside
        its image, an image size that is not the video's, a config that cannot use the
        video's histograms).
    """
    if detections is not None and detector is not None:
        raise InputError("--detector detects in the frames: give it without DET.txt")
    if video is not None and appearance is not None:
        raise InputError("the appearance comes from the video's frames: give either, not both")
    if detections is not None:
        dets = read_mot(detections, kind="det")
    elif video is not None:
        dets = detect_in_video(video, detector or DEFAULT_PERSON_DETECTOR, stage)
    else:
        raise InputError("give the detections, or a video to detect people in")
    app = None if appearance is None else load_appearance(appearance, len(dets))
    fps_source = None
    info = None
    if video is not None:
        info = probe_video(video)
        check_against_video(dets, info, detections or video)
        if not fps and info.fps:
            fps, fps_source = info.fps, "the video's header"
        if config.appearance != "bhattacharyya":
            raise InputError("--video gives colour histograms: the config's appearance must be "
                             f"'bhattacharyya', got {config.appearance!r}", config_path)
    size, n_frames, fps, fps_source = _sequence_shape(dets, detections, video, info,
                                                      image_size, fps, fps_source)
    t0 = time.perf_counter()
    n = max(dets.n_frames, n_frames or 0)
    motion = None
    if info is not None:
        what = f"colour histograms of {len(dets)} boxes in {n} frames"
        with stage(what + (" and the camera's motion" if config.compensate_camera else "")):
            app, motion = frames_appearance(iter_frames(info.path, info), dets, n,
                                            config.compensate_camera)
    try:
        with stage(f"tracking {n} frames"):
            tracks = track_mot(dets, app, config, size, n_frames, fps, motion)
    except ValueError as exc:
        raise InputError(str(exc), detections or video) from None
    return MOTRun(tracks, dets, n, size, fps, fps_source, time.perf_counter() - t0, info)


def frames_appearance(frames: Iterable[np.ndarray], dets: MOTData, n_frames: int,
                      camera_motion: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """What the tracker takes from a sequence's frames, in one pass over them: the person
    colour histogram of every detection row ``(len(dets), F)``
    (:func:`~avtrack.visual.histograms.detection_histograms`) and, with ``camera_motion``,
    the camera's motion into each frame ``(n_frames, 2, 3)``
    (:class:`~avtrack.visual.camera_motion.CameraMotion`, corners outside the frame's
    detection boxes; None without)."""
    motions: list[np.ndarray] = []

    def passing(frames: Iterable[np.ndarray]) -> Iterator[np.ndarray]:
        estimator = CameraMotion()
        for sl, frame in zip(dets.frame_slices(n_frames), frames, strict=False):
            motions.append(estimator.push(frame, dets.boxes[sl]))
            yield frame

    app = detection_histograms(passing(frames) if camera_motion else frames, dets, n_frames,
                               descriptor="person")
    return app, (np.stack(motions) if camera_motion and motions else None)


def _sequence_shape(
    dets: MOTData, detections: Path | None, video: Path | None, info: VideoInfo | None,
    image_size: tuple[int, int] | None, fps: float | None, fps_source: str | None,
) -> tuple[tuple[int, int], int | None, float | None, str | None]:
    """Image size, length (None: unknown), frame rate and where the rate came from: the
    video's, else seqinfo.ini next to the detections, else the detections' extent."""
    if info is not None:
        if image_size is not None and tuple(image_size) != info.image_size:
            raise InputError(f"--image-size {image_size[0]}x{image_size[1]} differs from the "
                             f"video's {info.width}x{info.height}", video)
        return info.image_size, info.n_frames, fps, fps_source
    seqinfo = find_seqinfo(detections) if detections is not None else None
    ini = read_seqinfo(seqinfo) if seqinfo else {}
    n_frames = None
    if image_size is not None:
        size = (int(image_size[0]), int(image_size[1]))
    elif "width" in ini and "height" in ini:
        size = (int(ini["width"]), int(ini["height"]))
    else:
        size = image_size_from_detections(dets)
    if image_size is None:
        length = ini.get("length")  # (an int: read_seqinfo parses it)
        n_frames = None if length is None else int(length)
    if not fps and ini.get("frame_rate"):
        fps, fps_source = float(ini["frame_rate"]), f"{seqinfo}"
    return size, n_frames, fps, fps_source


def score_against_sequence(
    tracks: MOTData, detections: Path | None, n_frames: int
) -> tuple[MOTData | None, dict[str, float]]:
    """The ground truth of the sequence holding ``detections`` (MOTChallenge layout:
    ``SEQ/det/det.txt``, ``SEQ/gt/gt.txt``) and the scores of ``tracks`` against it (MOTA,
    IDF1, HOTA, IDSW); ``(None, {})`` without one. The ground truth is returned only when it
    ends within the ``n_frames`` tracked."""
    if detections is None:
        return None, {}
    gt_path = detections.resolve().parent.parent / "gt" / "gt.txt"
    if not gt_path.is_file():
        return None, {}
    from avtrack.metrics.mot import evaluate_mot  # (loads SciPy: only when scoring)

    gt = read_mot(gt_path, kind="gt")
    s = evaluate_mot(gt, tracks, n_frames=n_frames)
    scores = {"MOTA": s.MOTA, "IDF1": s.IDF1, "HOTA": s.HOTA, "IDSW": float(s.IDSW)}
    return (gt if gt.n_frames <= n_frames else None), scores
