"""Video files in, one frame at a time (OpenCV's FFmpeg back end: mp4, avi, mkv, webm ...).

:func:`probe_video` reads a file's frame count, rate and size; :func:`iter_frames` decodes it
frame by frame (never the whole file in memory) and checks that it delivers the frames its
header promises. Errors are :class:`~avtrack.errors.InputError` naming the file: unreadable,
empty, truncated, or a frame of another size than the first.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from avtrack.errors import InputError


@dataclass(frozen=True)
class VideoInfo:
    """What a video file's header says.

    Attributes
    ----------
    path : Path
    n_frames : int
        Frame count (as the container reports it).
    fps : float
        Nominal frame rate (frames per second).
    width, height : int
        Frame size in pixels.
    """

    path: Path
    n_frames: int
    fps: float
    width: int
    height: int

    @property
    def image_size(self) -> tuple[int, int]:
        return self.width, self.height


def _capture(path: Path):
    import cv2

    if not path.is_file():
        raise InputError("video file not found" if not path.exists() else "not a regular file",
                         path)
    cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        raise InputError("cannot open the video (not a video file, or a codec OpenCV's FFmpeg "
                         "back end does not decode)", path)
    return cap


def probe_video(path: str | Path) -> VideoInfo:
    """The frame count, rate and size of a video file.

    Raises
    ------
    InputError
        The file is missing, not a video, has no frames, or no valid frame rate or size.
    """
    import cv2

    path = Path(path)
    cap = _capture(path)
    try:
        n = round(float(cap.get(cv2.CAP_PROP_FRAME_COUNT)))
        fps = float(cap.get(cv2.CAP_PROP_FPS))
        w = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH))
        h = int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
    finally:
        cap.release()
    if n <= 0:
        raise InputError("the video has no frames (or its container does not say how many)",
                         path)
    if not (np.isfinite(fps) and 0 < fps <= 1000):
        raise InputError(f"the video has no valid frame rate (got {fps!r})", path)
    if w <= 0 or h <= 0:
        raise InputError(f"the video has no valid frame size (got {w}x{h})", path)
    return VideoInfo(path, n, fps, w, h)


def iter_frames(path: str | Path, info: VideoInfo | None = None) -> Iterator[np.ndarray]:
    """Decode a video frame by frame.

    Yields
    ------
    ndarray (height, width, 3) uint8
        BGR frames ``1, 2, ...`` (frame ``k`` of the file is MOTChallenge frame ``k``).

    Raises
    ------
    InputError
        Fewer decodable frames than the header's count (a truncated or damaged file), or a
        frame of another size than the header's.
    """
    import cv2

    path = Path(path)
    info = info or probe_video(path)
    cap = _capture(path)
    try:
        for k in range(1, info.n_frames + 1):
            ok, img = cap.read()
            if not ok:
                raise InputError(f"the video ends at frame {k - 1}, its header says "
                                 f"{info.n_frames} frames (truncated or damaged file?)", path)
            if img.shape[:2] != (info.height, info.width):
                raise InputError(f"frame {k} is {img.shape[1]}x{img.shape[0]}, the video is "
                                 f"{info.width}x{info.height} (frames of varying size)", path)
            if img.ndim == 2:
                img = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)
            yield img
    finally:
        cap.release()
