"""Steps the video paths share: detections found in a video's frames, appearance
descriptors read from a file, detections checked against the video they belong to."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from avtrack.errors import InputError
from avtrack.io.mot import MOTData
from avtrack.io.video import VideoInfo, iter_frames, probe_video
from avtrack.pipelines.base import Step, no_step
from avtrack.visual.detect import detect_video, load_detector


def detect_in_video(video_path: Path, spec: str, step: Step = no_step) -> MOTData:
    """Detections of the detector ``spec`` (a built-in name or ``module:attribute``,
    :func:`~avtrack.visual.detect.load_detector`) on every frame of a video.

    Raises
    ------
    InputError
        Unreadable video, unknown detector, or the detector failing (named as such).
    """
    info = probe_video(video_path)
    detector = load_detector(spec)
    with step(f"detecting people in {info.n_frames} frames ({spec})"):
        try:
            return detect_video(detector, iter_frames(info.path, info), info.n_frames)
        except InputError:
            raise
        except Exception as exc:  # a plug-in's own failure, named as such
            raise InputError(f"--detector {spec} failed: {type(exc).__name__}: {exc}",
                             video_path) from None


def read_appearance(path: Path, n_rows: int) -> np.ndarray:
    """Appearance descriptors ``(n_rows, F)`` from a ``.npy`` file, one row per detection.

    Raises
    ------
    InputError
        Missing or unreadable file, another number of rows, NaN or infinite values.
    """
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
    outside its image (InputError naming ``det_path``)."""
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
