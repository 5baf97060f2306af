"""A video (MP4 or WebM) of the tracks, their identities and who speaks, over the camera view.

The simulator renders no images, so every frame is drawn here, back to front:

1. **the room** (drawn once): with a camera and the room's dimensions, each pixel's ray is cast
   through the pinhole camera into the shoebox room, giving floor (with a 0.5 m grid), walls,
   ceiling and their edges; with a camera only, a floor plane up to the horizon; with neither,
   a wall/floor gradient;
2. **the ground-truth people**: a head-and-shoulders silhouette at each ground-truth head box,
   the farthest (smallest) first, and optionally the ground-truth box as a thin grey outline;
3. **the tracks**: each box outlined in its person's colour (:func:`avtrack.viz.palette.
   person_bgr`, the colour of that id on every figure of the report) with an id tag above it;
   a track that speaks gets a thicker box, the tag ``<id> speaking`` and a speech bubble (filled
   in the track's colour, white rim and dots) beside the head, to the right of the box;
4. the frame number, time and title in a band at the top, and the legend under it at the top
   left (clear of a video player's controls, which cover the bottom).

Frames are ``(height, width, 3)`` ``uint8`` BGR images (OpenCV's order). The container follows
the file suffix: ``.mp4`` with H.264 (PyAV's ``libx264``, :data:`H264_ENCODER`; plays in web
browsers and video players) where PyAV has that encoder, else with OpenCV's MPEG-4 Part 2
(``mp4v``, which browsers do not play); ``.webm`` with OpenCV's VP8 (plays in Chromium and
Firefox). A ``codec`` given explicitly is an OpenCV four-character code (:data:`VIDEO_CODECS`
holds the defaults). The encoders need even frame sizes: an odd width or height is rounded up
and the extra column / row is background. Files are written atomically (a temporary file next
to the destination, renamed onto it when complete); several files of the same frames are
written in one pass (``also_to``), so a video's frames are read once.

Example
-------
>>> res = track_scene(scene_dir, mapping)
>>> render_scene_video(scene_dir, res, "out/tracks.webm")
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import math
import os
import sys
from collections.abc import Iterable, Iterator, Sequence
from fractions import Fraction
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypedDict, Unpack

import numpy as np

from avtrack.io.base import temp_output
from avtrack.io.camera import PinholeCamera
from avtrack.io.mot import MOTData
from avtrack.viz.palette import person_bgr

if TYPE_CHECKING:
    from avtrack.av.persons_scene import PersonsResult
    from avtrack.av.vavit import AVSceneResult
    from avtrack.io.persons import PersonsTable
    from avtrack.io.scene import SceneInputs

#: Four-character code of OpenCV's encoder for each file suffix (for ``.mp4``, used only where
#: PyAV has no H.264 encoder, or when asked for with ``codec``).
VIDEO_CODECS: dict[str, str] = {".mp4": "mp4v", ".webm": "VP80"}

#: PyAV's encoder of the ``.mp4`` files (H.264), and its settings: constant quality 23 (x264's
#: default) at the ``fast`` preset, 4:2:0 chroma (what browsers decode), the index at the front
#: of the file (playback starts before a linked file is fully read).
H264_ENCODER = "libx264"
_H264_OPTIONS = {"crf": "23", "preset": "fast"}

#: matplotlib's ``tab10`` as BGR: person ``p`` gets ``TAB10_BGR[(p - 1) % 10]``
#: (:func:`avtrack.viz.palette.person_bgr`).
TAB10_BGR: tuple[tuple[int, int, int], ...] = tuple(person_bgr(k) for k in range(1, 11))

#: Spacing of the floor grid, metres.
FLOOR_GRID_M = 0.5
#: Radius of the speech bubble at an image height of 480 pixels (scaled with the height).
BUBBLE_RADIUS = 10
#: Most track ids listed in the legend.
LEGEND_MAX_TRACKS = 8

_GT_BGR = (200, 200, 200)
_SKIN_BGR = (150, 178, 214)
_CLOTH_BGR = (92, 84, 76)
_OUTLINE_BGR = (50, 50, 50)
_WHITE = (255, 255, 255)
_INK = (20, 20, 20)


# --------------------------------------------------------------------------- validation


def _image_size(image_size: Sequence[int]) -> tuple[int, int]:
    try:
        w, h = image_size
    except (TypeError, ValueError):
        raise ValueError(
            f"image_size must be (width, height), two integers > 0, got {image_size!r}"
        ) from None
    for name, v in (("width", w), ("height", h)):
        ok = not isinstance(v, bool) and isinstance(v, int | np.integer) and 0 < v <= 16384
        if not ok:
            raise ValueError(f"image_size: {name} must be an integer in [1, 16384], got {v!r}")
    return int(w), int(h)


def _room_dims(room_dims: Sequence[float] | np.ndarray | None) -> np.ndarray | None:
    if room_dims is None:
        return None
    d = np.asarray(room_dims, dtype=float)
    if d.shape != (3,) or not np.all(np.isfinite(d)) or np.any(d <= 0):
        raise ValueError(f"room_dims must be 3 finite sizes > 0 (metres), got {room_dims!r}")
    return d


def _check_camera(camera: PinholeCamera | None, size: tuple[int, int]) -> None:
    if camera is None:
        return
    if not isinstance(camera, PinholeCamera):
        raise TypeError(f"camera must be a PinholeCamera or None, got {type(camera).__name__}")
    if (camera.width, camera.height) != size:
        raise ValueError(
            f"camera image size {camera.width}x{camera.height} does not match image_size "
            f"{size[0]}x{size[1]}"
        )


@contextlib.contextmanager
def _native_stderr_silenced():
    """Silence file descriptor 2 (native code's stderr) for the block.

    OpenCV's FFmpeg back-end prints "tag 'VP80' is not supported with codec id 139" to the
    process's stderr each time a WebM writer opens -- the file is fine (FFmpeg picks the
    right tag) and OpenCV's log level does not reach that message -- so it would only
    confuse the people reading ``avtrack demo``'s output.
    """
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError, AttributeError):  # no real fd 2 (embedded interpreters)
        yield
        return
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
            yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def video_codec(path: str | Path, codec: str | None = None) -> str:
    """The four-character code of OpenCV's encoder for ``path`` (the file is encoded by
    OpenCV with it unless it is an ``.mp4`` without ``codec`` and :func:`h264_available`).

    Parameters
    ----------
    path : str or Path
        Destination; its suffix (``.mp4`` or ``.webm``, any case) picks the container.
    codec : str, optional
        Four characters overriding the default of the suffix (:data:`VIDEO_CODECS`).

    Raises
    ------
    ValueError
        For another suffix, or a codec that is not four characters.
    """
    suffix = Path(path).suffix.lower()
    if suffix not in VIDEO_CODECS:
        raise ValueError(
            f"path: video suffix must be one of {sorted(VIDEO_CODECS)}, got {suffix or 'none'!r} "
            f"({path})"
        )
    if codec is None:
        return VIDEO_CODECS[suffix]
    if not isinstance(codec, str) or len(codec) != 4:
        raise ValueError(f"codec must be a four-character code such as 'mp4v', got {codec!r}")
    return codec


# --------------------------------------------------------------------------- colours


def track_colours(ids: np.ndarray | Sequence[int]) -> dict[int, tuple[int, int, int]]:
    """BGR colour of each track id: ``tab10`` by rank of the sorted unique ids (ten distinct
    colours for up to ten tracks, whatever their ids).

    These depend on which other ids are given; the overlay and the report's figures colour a
    person by their id alone (:func:`avtrack.viz.palette.person_bgr`), which is the same as
    this when the ids are ``1, ..., K``.

    Parameters
    ----------
    ids : array_like (K,) int

    Returns
    -------
    dict
        ``{id: (b, g, r)}``.
    """
    unique = np.unique(np.asarray(ids, dtype=np.int64))
    return {int(t): TAB10_BGR[k % len(TAB10_BGR)] for k, t in enumerate(unique)}


# --------------------------------------------------------------------------- background


def _gradient_background(width: int, height: int) -> np.ndarray:
    """A plain room: wall gradient above 55 % of the height, floor gradient below."""
    v = (np.arange(height, dtype=np.float32) + 0.5) / height
    horizon = 0.55
    wall_top, wall_bottom = np.array([222, 226, 228]), np.array([188, 196, 202])
    floor_far, floor_near = np.array([132, 150, 166]), np.array([96, 112, 128])
    col = np.empty((height, 3), dtype=np.float32)
    up = v < horizon
    a = (v[up] / horizon)[:, None]
    col[up] = wall_top + a * (wall_bottom - wall_top)
    b = ((v[~up] - horizon) / (1 - horizon))[:, None]
    col[~up] = floor_far + b * (floor_near - floor_far)
    img = np.repeat(col[:, None, :], width, axis=1)
    return np.clip(img, 0, 255).astype(np.uint8)


def render_background(
    image_size: Sequence[int],
    camera: PinholeCamera | None = None,
    room_dims: Sequence[float] | np.ndarray | None = None,
) -> np.ndarray:
    """The empty room as the camera sees it.

    Each pixel centre ``(u, v)`` is back-projected to the room-frame ray
    ``d = R^T K^{-1} [u, v, 1]^T`` from the optical centre ``C``; the ray meets the shoebox
    ``[0, L_x] x [0, L_y] x [0, L_z]`` at ``C + t d`` with ``t = min_a (b_a - C_a) / d_a``
    (``b_a`` the wall ahead along axis ``a``), which gives the surface and its shading.

    Parameters
    ----------
    image_size : (int, int)
        ``(width, height)`` in pixels.
    camera : PinholeCamera, optional
        Without it: a wall/floor gradient.
    room_dims : ndarray (3,), optional
        Room size in metres; without it (but with a camera): an endless floor at z = 0.

    Returns
    -------
    ndarray (height, width, 3) uint8
        BGR image.

    Raises
    ------
    ValueError
        On a bad size, a camera of another image size, or a camera outside the room.
    """
    width, height = _image_size(image_size)
    _check_camera(camera, (width, height))
    dims = _room_dims(room_dims)
    if camera is None:
        return _gradient_background(width, height)
    c = camera.position
    lo = np.array([-np.inf, -np.inf, 0.0])
    hi = np.full(3, np.inf) if dims is None else dims
    if not np.all((c > lo) & (c < hi)):
        raise ValueError(
            f"camera position {c.tolist()} must be inside the room "
            f"{'above the floor' if dims is None else f'(0, 0, 0)-{dims.tolist()}'}"
        )
    u = np.arange(width, dtype=float) + 0.5
    v = np.arange(height, dtype=float) + 0.5
    xn, yn = np.meshgrid((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy)
    xc = np.stack([xn, yn, np.ones_like(xn)], axis=-1)  # K^-1 [u, v, 1]^T, (H, W, 3)
    d = xc @ camera.R  # d = R^T x_c, (H, W, 3); t below is the depth along the optical axis
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = np.where(d > 0, hi, lo)
        t_axis = (bound - c) / d  # distance to the wall ahead along each axis
    t_axis = np.where(np.isfinite(t_axis) & (t_axis > 0), t_axis, np.inf)
    order = np.sort(t_axis, axis=-1)
    t = order[..., 0]
    axis = np.argmin(t_axis, axis=-1)
    hit = np.isfinite(t)
    p = c + np.where(hit, t, 0.0)[..., None] * d
    pixel_m = t / camera.fx  # size of a pixel at that depth, metres

    img = np.empty((height, width, 3), dtype=np.float32)
    wall_x, wall_y = np.array([196, 206, 214]), np.array([184, 194, 204])
    ceiling, floor = np.array([228, 232, 234]), np.array([120, 140, 160])
    img[:] = np.where((axis == 0)[..., None], wall_x, wall_y)
    down, up = (axis == 2) & (d[..., 2] < 0), (axis == 2) & (d[..., 2] > 0)
    img[up] = ceiling
    img[down] = floor
    # floor grid: anti-aliased lines one pixel wide every FLOOR_GRID_M metres
    g = p[down][:, :2] / FLOOR_GRID_M
    dist = np.min(np.abs(g - np.round(g)), axis=1) * FLOOR_GRID_M  # metres to the nearest line
    line = np.clip(1.0 - dist / np.maximum(pixel_m[down], 1e-9), 0.0, 1.0)
    img[down] *= (1.0 - 0.25 * line)[:, None]
    # skirting board: the bottom 8 cm of the walls
    skirt = (axis < 2) & hit & (p[..., 2] < 0.08)
    img[skirt] *= 0.8
    # room edges: where the second-nearest wall is within a pixel of the nearest
    second = order[..., 1]
    with np.errstate(invalid="ignore"):  # inf - inf where no second wall is ahead
        gap = (second - t) * np.linalg.norm(d, axis=-1)  # metres between the two walls
    edge = hit & np.isfinite(gap) & (gap < pixel_m)
    img[edge] *= 0.7
    # distance shading
    shade = np.clip(1.08 - 0.045 * np.where(hit, t, 30.0), 0.72, 1.0)
    img *= shade[..., None]
    if dims is None:  # beyond the horizon: wall gradient
        sky = ~hit
        img[sky] = _gradient_background(width, height).astype(np.float32)[sky]
    return np.clip(img + 0.5, 0, 255).astype(np.uint8)


# --------------------------------------------------------------------------- drawing


def _int_box(box: np.ndarray, width: int, height: int) -> tuple[int, int, int, int]:
    """``(x0, y0, x1, y1)`` integer corners, kept within a frame's size of the image."""
    left, top, w, h = (float(x) for x in box)
    x0 = round(min(max(left, -width), 2 * width))
    y0 = round(min(max(top, -height), 2 * height))
    x1 = round(min(max(left + w, -width), 2 * width))
    y1 = round(min(max(top + h, -height), 2 * height))
    return x0, y0, x1, y1


def _draw_person(img: np.ndarray, box: np.ndarray, cv2) -> None:
    """Head (ellipse in the head box), neck and shoulders below it."""
    x0, y0, x1, y1 = _int_box(box, img.shape[1], img.shape[0])
    w, h = max(x1 - x0, 2), max(y1 - y0, 2)
    cx = (x0 + x1) // 2
    sh_top = y1 + int(0.15 * h)  # shoulders start just below the chin
    body = np.array(
        [
            [cx - int(1.1 * w), sh_top + int(0.35 * h)],
            [cx - int(0.7 * w), sh_top],
            [cx + int(0.7 * w), sh_top],
            [cx + int(1.1 * w), sh_top + int(0.35 * h)],
            [cx + int(1.2 * w), y1 + 4 * h],
            [cx - int(1.2 * w), y1 + 4 * h],
        ],
        dtype=np.int32,
    )
    cv2.fillPoly(img, [body], _CLOTH_BGR, cv2.LINE_AA)
    cv2.polylines(img, [body], True, _OUTLINE_BGR, 1, cv2.LINE_AA)
    neck = (cx - max(int(0.22 * w), 1), y1 - int(0.2 * h), cx + max(int(0.22 * w), 1), sh_top + 2)
    cv2.rectangle(img, neck[:2], neck[2:], _SKIN_BGR, -1)
    axes = (max(w // 2, 1), max(h // 2, 1))
    cv2.ellipse(img, (cx, (y0 + y1) // 2), axes, 0, 0, 360, _SKIN_BGR, -1, cv2.LINE_AA)
    cv2.ellipse(img, (cx, (y0 + y1) // 2), axes, 0, 0, 360, _OUTLINE_BGR, 1, cv2.LINE_AA)


def _text_colour(bgr: tuple[int, int, int]) -> tuple[int, int, int]:
    b, g, r = bgr
    return _INK if 0.299 * r + 0.587 * g + 0.114 * b > 150 else _WHITE


def _draw_bubble(img: np.ndarray, cx: int, cy: int, r: int, colour, cv2) -> None:
    """Speech bubble: filled disc with a tail towards the lower left, white rim and dots."""
    tail = np.array(
        [
            [cx - int(0.8 * r), cy + int(0.2 * r)],
            [cx - int(0.1 * r), cy + int(0.9 * r)],
            [cx - int(1.7 * r), cy + int(1.3 * r)],
        ],
        dtype=np.int32,
    )
    cv2.fillPoly(img, [tail], colour, cv2.LINE_AA)
    cv2.polylines(img, [tail], True, _WHITE, 1, cv2.LINE_AA)
    cv2.circle(img, (cx, cy), r, colour, -1, cv2.LINE_AA)
    cv2.circle(img, (cx, cy), r, _WHITE, 1, cv2.LINE_AA)
    dot = max(1, r // 6)
    for dx in (-r // 2, 0, r // 2):
        cv2.circle(img, (cx + dx, cy + r // 3), dot, _WHITE, -1, cv2.LINE_AA)


def _blend(img: np.ndarray, x0: int, y0: int, patch: np.ndarray, alpha: np.ndarray) -> None:
    """``img[y0:, x0:] = alpha patch + (1 - alpha) img`` over the patch (clipped)."""
    h, w = patch.shape[:2]
    x1, y1 = min(x0 + w, img.shape[1]), min(y0 + h, img.shape[0])
    x0c, y0c = max(x0, 0), max(y0, 0)
    if x1 <= x0c or y1 <= y0c:
        return
    roi = img[y0c:y1, x0c:x1]
    p = patch[y0c - y0 : y1 - y0, x0c - x0 : x1 - x0]
    a = alpha[y0c - y0 : y1 - y0, x0c - x0 : x1 - x0]
    roi[:] = (a * p + (1.0 - a) * roi + 0.5).astype(np.uint8)


class _Layout:
    """Sizes that scale with the image height (designed at 480 pixels)."""

    def __init__(self, height: int):
        self.s = max(height / 480.0, 0.5)
        self.font_scale = max(0.45 * self.s, 0.33)  # Hershey text is unreadable below that
        self.thick = max(1, round(self.s))
        self.box = max(2, round(2 * self.s))
        self.box_speaking = max(4, round(4 * self.s))
        self.bubble = max(6, round(BUBBLE_RADIUS * self.s))
        self.pad = max(2, round(3 * self.s))


def _legend(
    colours: dict[int, tuple[int, int, int]], show_gt: bool, lay: _Layout, cv2
) -> tuple[np.ndarray, np.ndarray]:
    """The legend panel ``(h, w, 3)`` and its opacity ``(h, w, 1)``."""
    font = cv2.FONT_HERSHEY_SIMPLEX
    entries: list[tuple[str, str, tuple[int, int, int]]] = []
    ids = sorted(colours)
    for tid in ids[:LEGEND_MAX_TRACKS]:
        entries.append(("box", f"track {tid}", colours[tid]))
    if len(ids) > LEGEND_MAX_TRACKS:
        entries.append(("none", f"+{len(ids) - LEGEND_MAX_TRACKS} more tracks", _WHITE))
    entries.append(("bubble", "speaking", (200, 200, 200)))
    if show_gt:
        entries.append(("gt", "ground truth", _GT_BGR))
    (_, th), base = cv2.getTextSize("ground truth+", font, lay.font_scale, lay.thick)
    row = th + base + 2 * lay.pad
    sw = 2 * lay.bubble + 2
    width = (
        max(cv2.getTextSize(text, font, lay.font_scale, lay.thick)[0][0] for _, text, _ in entries)
        + sw
        + 4 * lay.pad
    )
    height = row * len(entries) + 2 * lay.pad
    panel = np.full((height, width, 3), 30, dtype=np.uint8)
    for k, (kind, text, colour) in enumerate(entries):
        y = lay.pad + k * row
        x = 2 * lay.pad
        mid = y + row // 2
        if kind == "box":
            cv2.rectangle(panel, (x, y + lay.pad), (x + sw, y + row - lay.pad), colour, lay.box)
        elif kind == "gt":
            cv2.rectangle(panel, (x, y + lay.pad), (x + sw, y + row - lay.pad), colour, 1)
        elif kind == "bubble":
            r = max(3, (row - 2 * lay.pad) // 2)
            _draw_bubble(panel, x + sw - r - 1, mid - r // 3, r, (120, 120, 120), cv2)
        cv2.putText(
            panel,
            text,
            (x + sw + lay.pad, mid + th // 2),
            font,
            lay.font_scale,
            _WHITE,
            lay.thick,
            cv2.LINE_AA,
        )
    alpha = np.where(np.any(panel != 30, axis=-1), 1.0, 0.6).astype(np.float32)[..., None]
    return panel, alpha


class _Renderer:
    """Draws the frames; everything that does not change over time is prepared once."""

    def __init__(
        self,
        tracks: MOTData,
        speaking: np.ndarray,
        size: tuple[int, int],
        fps: float,
        n_frames: int,
        gt: MOTData | None,
        camera: PinholeCamera | None,
        room_dims: np.ndarray | None,
        show_gt_boxes: bool,
        legend: bool,
        title: str | None,
        persons=None,
    ):
        import cv2

        self.cv2 = cv2
        self.tracks, self.speaking, self.gt = tracks, speaking, gt
        self.persons = persons
        self.fps, self.n_frames, self.title = fps, n_frames, title
        self.show_gt_boxes = show_gt_boxes and gt is not None
        w, h = size
        self.size = size
        self.out_size = (w + w % 2, h + h % 2)  # the encoders need even sizes
        bg = render_background(size, camera, room_dims)
        if self.out_size != size:
            bg = cv2.copyMakeBorder(bg, 0, h % 2, 0, w % 2, cv2.BORDER_REPLICATE)
        self.background = bg
        self.lay = _Layout(h)
        ids = tracks.ids if persons is None else np.r_[tracks.ids, persons.ids]
        self.colours = {int(i): person_bgr(int(i)) for i in np.unique(ids)}
        self.track_rows = tracks.frame_slices(n_frames)
        self.person_rows = None
        if persons is not None:
            bounds = np.searchsorted(persons.frames, np.arange(1, n_frames + 2))
            self.person_rows = [slice(int(a), int(b)) for a, b in itertools.pairwise(bounds)]
        self.gt_rows = None if gt is None else gt.frame_slices(n_frames)
        self.legend = _legend(self.colours, gt is not None, self.lay, cv2) if legend else None

    def frame(self, f: int, background: np.ndarray | None = None) -> np.ndarray:
        """Frame ``f`` (1-based), ``(height, width, 3)`` uint8 BGR, drawn over ``background``
        (a real video frame of the image size; None: the rendered room, with the
        ground-truth people drawn in it)."""
        cv2, lay = self.cv2, self.lay
        width, height = self.size
        if background is None:
            img = self.background.copy()
        else:
            frame = np.asarray(background)
            if frame.shape != (height, width, 3) or frame.dtype != np.uint8:
                raise ValueError(f"frame {f} is {frame.shape} {frame.dtype}, expected "
                                 f"({height}, {width}, 3) uint8 (the image size)")
            img = frame if self.out_size == self.size else cv2.copyMakeBorder(
                frame, 0, height % 2, 0, width % 2, cv2.BORDER_REPLICATE)
            img = img.copy()
        if self.gt is not None and self.gt_rows is not None:
            rows = self.gt_rows[f - 1]
            boxes = self.gt.boxes[rows]
            if background is None:  # real frames show the people themselves
                for k in np.argsort(boxes[:, 3], kind="stable"):  # farthest (smallest) first
                    _draw_person(img, boxes[k], cv2)
            if self.show_gt_boxes:
                for box in boxes:
                    x0, y0, x1, y1 = _int_box(box, width, height)
                    cv2.rectangle(img, (x0, y0), (x1, y1), _GT_BGR, 1)
        rows = self.track_rows[f - 1]
        ids = self.tracks.ids[rows]
        boxes = self.tracks.boxes[rows]
        speaks = self.speaking[rows]
        font = cv2.FONT_HERSHEY_SIMPLEX
        for tid, box, talk in zip(ids.tolist(), boxes, speaks.tolist(), strict=True):
            colour = self.colours[tid]
            x0, y0, x1, y1 = _int_box(box, width, height)
            cv2.rectangle(img, (x0, y0), (x1, y1), colour, lay.box_speaking if talk else lay.box)
            text = f"{tid} speaking" if talk else f"{tid}"
            (tw, th), base = cv2.getTextSize(text, font, lay.font_scale, lay.thick)
            tag_h = th + base + lay.pad
            ty = y0 - tag_h if y0 - tag_h >= 0 else y1  # above the box, or below if no room
            cv2.rectangle(img, (x0, ty), (x0 + tw + 2 * lay.pad, ty + tag_h), colour, -1)
            cv2.putText(
                img,
                text,
                (x0 + lay.pad, ty + th + lay.pad // 2),
                font,
                lay.font_scale,
                _text_colour(colour),
                lay.thick,
                cv2.LINE_AA,
            )
            if talk:
                r = lay.bubble
                _draw_bubble(img, x1 + r + lay.pad + 2, y0 + r, r, colour, cv2)
        if self.person_rows is not None:
            self._unseen_persons(img, self.person_rows[f - 1], set(ids.tolist()))
        band_h = self._header(img, f)
        if self.legend is not None:  # top left, under the header: clear of player controls
            panel, alpha = self.legend
            _blend(img, lay.pad, min(band_h + lay.pad, img.shape[0] - panel.shape[0]), panel,
                   alpha)
        return img

    def _unseen_persons(self, img: np.ndarray, rows: slice, boxed: set[int]) -> None:
        """Persons tracked without a box at one frame (``rows`` of :attr:`persons`): a ring
        at their direction's pixel when it is in the image, else an arrow at the image edge on
        their side, labelled with their id and azimuth (a speaking bubble when they speak)."""
        cv2, lay, p = self.cv2, self.lay, self.persons
        width, height = self.size
        font = cv2.FONT_HERSHEY_SIMPLEX
        for k in range(rows.start, rows.stop):
            pid = int(p.ids[k])
            if pid in boxed:
                continue
            colour = self.colours[pid]
            talk = bool(p.speaking[k] >= 0.5)
            x, y = p.pixels[k]
            text = f"{pid} {p.azimuth_deg[k]:+.0f} deg"
            r = lay.bubble
            if np.isfinite(x) and np.isfinite(y):
                cx, cy = round(float(x)), round(float(y))
                cv2.circle(img, (cx, cy), 2 * r, colour, lay.thick, cv2.LINE_AA)
                tx, ty = cx + 2 * r + lay.pad, cy
            else:
                left = p.side[k] < 0
                cy = height // 2 + (pid % 5 - 2) * 4 * r  # persons on one side stack
                tip = lay.pad if left else width - lay.pad
                base = tip + 3 * r if left else tip - 3 * r
                pts = np.array([[tip, cy], [base, cy - 2 * r], [base, cy + 2 * r]], np.int32)
                cv2.fillPoly(img, [pts], colour, cv2.LINE_AA)
                (tw, _), _ = cv2.getTextSize(text, font, lay.font_scale, lay.thick)
                tx = base + lay.pad if left else base - lay.pad - tw
                ty = cy
            cv2.putText(img, text, (tx, ty + r // 2), font, lay.font_scale, colour, lay.thick,
                        cv2.LINE_AA)
            if talk:
                _draw_bubble(img, int(tx + r), int(ty - 2 * r), r, colour, cv2)

    def _header(self, img: np.ndarray, f: int) -> int:
        """Draw the top band (frame, time, title); returns its height in pixels."""
        cv2, lay = self.cv2, self.lay
        font = cv2.FONT_HERSHEY_SIMPLEX
        text = f"frame {f}/{self.n_frames}   t = {(f - 1) / self.fps:6.2f} s"
        (tw, th), base = cv2.getTextSize(text, font, lay.font_scale, lay.thick)
        band_h = th + base + 2 * lay.pad
        band = img[:band_h]
        band[:] = (band.astype(np.float32) * 0.45 + 0.5).astype(np.uint8)  # darken
        y = lay.pad + th
        cv2.putText(
            img, text, (2 * lay.pad, y), font, lay.font_scale, _WHITE, lay.thick, cv2.LINE_AA
        )
        if self.title:
            (tw2, _), _ = cv2.getTextSize(self.title, font, lay.font_scale, lay.thick)
            x = max(img.shape[1] - tw2 - 2 * lay.pad, 2 * lay.pad + tw + 4 * lay.pad)
            cv2.putText(
                img, self.title, (x, y), font, lay.font_scale, _WHITE, lay.thick, cv2.LINE_AA
            )
        return band_h


# --------------------------------------------------------------------------- public API


def _check_inputs(
    tracks: MOTData,
    speaking: np.ndarray | Sequence[bool] | None,
    image_size: Sequence[int],
    fps: float,
    n_frames: int | None,
    gt: MOTData | None,
) -> tuple[np.ndarray, tuple[int, int], float, int]:
    if not isinstance(tracks, MOTData):
        raise TypeError(f"tracks must be MOTData, got {type(tracks).__name__}")
    if gt is not None and not isinstance(gt, MOTData):
        raise TypeError(f"gt must be MOTData or None, got {type(gt).__name__}")
    if speaking is None:
        talk = np.zeros(len(tracks), dtype=bool)
    else:
        talk = np.asarray(speaking)
        if talk.shape != (len(tracks),):
            raise ValueError(
                f"speaking must have shape ({len(tracks)},), one flag per row of tracks, "
                f"got {talk.shape}"
            )
        if talk.dtype != bool:
            raise TypeError(f"speaking must be a boolean array, got dtype {talk.dtype}")
    size = _image_size(image_size)
    if isinstance(fps, bool) or not isinstance(fps, int | float | np.number):
        raise TypeError(f"fps must be a number, got {type(fps).__name__}")
    if not (math.isfinite(fps) and 0 < fps <= 1000):
        raise ValueError(f"fps must be in (0, 1000] frames per second, got {fps!r}")
    last = max(tracks.n_frames, 0 if gt is None else gt.n_frames)
    if n_frames is None:
        if last == 0:
            raise ValueError("n_frames: tracks and gt are empty; give the number of frames")
        n = last
    else:
        if isinstance(n_frames, bool) or not isinstance(n_frames, int | np.integer):
            raise TypeError(f"n_frames must be an integer, got {type(n_frames).__name__}")
        n = int(n_frames)
        if n < 1:
            raise ValueError(f"n_frames must be >= 1, got {n}")
        if last > n:
            raise ValueError(f"n_frames is {n} but tracks / gt have rows up to frame {last}")
    return talk, size, float(fps), n


class OverlayOptions(TypedDict, total=False):
    """The keyword options of :func:`render_overlay_frames` and :func:`render_overlay_video`
    that shape the frames (described, with their defaults, at :func:`render_overlay_video`)."""

    n_frames: int | None
    gt: MOTData | None
    camera: PinholeCamera | None
    room_dims: Sequence[float] | np.ndarray | None
    show_gt_boxes: bool
    legend: bool
    title: str | None
    persons: PersonsTable | None


def _renderer(
    tracks: MOTData,
    speaking: np.ndarray | Sequence[bool] | None,
    image_size: Sequence[int],
    fps: float,
    *,
    n_frames: int | None = None,
    gt: MOTData | None = None,
    camera: PinholeCamera | None = None,
    room_dims: Sequence[float] | np.ndarray | None = None,
    show_gt_boxes: bool = True,
    legend: bool = True,
    title: str | None = None,
    persons: PersonsTable | None = None,
) -> _Renderer:
    """The checked inputs of :func:`render_overlay_frames` and :func:`render_overlay_video`
    (parameters and defaults as there) as the renderer of their frames."""
    talk, size, fps, n = _check_inputs(tracks, speaking, image_size, fps, n_frames, gt)
    if not isinstance(show_gt_boxes, bool) or not isinstance(legend, bool):
        raise TypeError("show_gt_boxes and legend must be booleans")
    if title is not None and not isinstance(title, str):
        raise TypeError(f"title must be a string or None, got {type(title).__name__}")
    return _Renderer(
        tracks, talk, size, fps, n, gt, camera, _room_dims(room_dims), show_gt_boxes, legend,
        title, persons,
    )


def render_overlay_frames(
    tracks: MOTData,
    speaking: np.ndarray | Sequence[bool] | None,
    image_size: Sequence[int],
    fps: float,
    **options: Unpack[OverlayOptions],
) -> Iterator[np.ndarray]:
    """The frames of :func:`render_overlay_video`, one at a time (the inputs are checked and
    the background drawn before the first one is asked for).

    Parameters are those of :func:`render_overlay_video`.

    Returns
    -------
    iterator of ndarray (height', width', 3) uint8
        BGR frames ``1, ..., n_frames``; ``height'`` and ``width'`` are ``height`` and
        ``width`` rounded up to even numbers.
    """
    r = _renderer(tracks, speaking, image_size, fps, **options)
    return (r.frame(f) for f in range(1, r.n_frames + 1))


@functools.cache
def h264_available() -> bool:
    """Whether PyAV is installed with the H.264 encoder :data:`H264_ENCODER` (its wheels
    ship it): then ``.mp4`` files are H.264, which web browsers play."""
    try:
        import av

        av.codec.Codec(H264_ENCODER, "w")
    except Exception:  # ImportError, or av's error for an encoder it was built without
        return False
    return True


class _H264Writer:
    """PyAV's H.264 encoder into an MP4 file, with OpenCV's writer's ``write`` / ``release``."""

    def __init__(self, tmp: Path, r: _Renderer):
        import av

        self._av = av
        self._out = av.open(str(tmp), "w", format="mp4", options={"movflags": "+faststart"})
        try:
            rate = Fraction(r.fps).limit_denominator(1001)  # 29.97 -> 30000/1001
            stream: Any = self._out.add_stream(H264_ENCODER, rate=rate)
            stream.width, stream.height = r.out_size
            stream.pix_fmt = "yuv420p"
            stream.options = dict(_H264_OPTIONS)
        except BaseException:
            self._out.close()
            raise
        self._stream = stream

    def write(self, img: np.ndarray) -> None:
        frame = self._av.VideoFrame.from_ndarray(img, format="bgr24")
        self._out.mux(self._stream.encode(frame))  # converted to the stream's yuv420p

    def release(self) -> None:
        try:
            self._out.mux(self._stream.encode(None))  # flush the delayed frames
        finally:
            self._out.close()


def _open_video_writer(tmp: Path, fourcc: str | None, r: _Renderer, path: Path) -> Any:
    """A writer of ``r``'s frames into ``tmp``: H.264 through PyAV when ``fourcc`` is None,
    else OpenCV's with that code (RuntimeError naming ``path`` if it cannot be opened)."""
    if fourcc is None:
        return _H264Writer(tmp, r)
    import cv2

    with _native_stderr_silenced():  # FFmpeg's harmless 'tag ... not supported' notice
        writer = cv2.VideoWriter(str(tmp), cv2.VideoWriter.fourcc(*fourcc), r.fps, r.out_size)
    if not writer.isOpened():
        raise RuntimeError(
            f"OpenCV {cv2.__version__} cannot open a {fourcc!r} video writer for {path} "
            f"(codecs that work with opencv-python-headless: "
            f"{', '.join(f'{v!r} for {k}' for k, v in VIDEO_CODECS.items())})"
        )
    return writer


def _write_frames(
    writers: Sequence[Any],
    r: _Renderer,
    frames: Iterable[np.ndarray] | None,
    desc: str,
    progress: bool,
) -> None:
    """Write ``r``'s frames ``1, ..., r.n_frames`` with every writer, drawn over ``frames``
    when given (ValueError if they end early)."""
    from tqdm import tqdm

    source = None if frames is None else iter(frames)
    for f in tqdm(range(1, r.n_frames + 1), unit="frame", desc=desc, disable=not progress):
        bg = None
        if source is not None:
            bg = next(source, None)
            if bg is None:
                raise ValueError(f"the video ended at frame {f - 1} of {r.n_frames}")
        img = r.frame(f) if bg is None else r.frame(f, bg)
        for writer in writers:
            writer.write(img)


def _encoder(path: Path, codec: str | None) -> str | None:
    """OpenCV's four-character code for ``path``, or None for H.264 through PyAV."""
    fourcc = video_codec(path, codec)
    if codec is None and path.suffix.lower() == ".mp4" and h264_available():
        return None
    return fourcc


def _encode_videos(
    targets: Sequence[tuple[Path, str | None]],
    r: _Renderer,
    frames: Iterable[np.ndarray] | None,
    progress: bool,
) -> None:
    """Encode ``r``'s frames into each ``(path, fourcc)`` of ``targets`` in one pass, each
    through a temporary file, leaving none of the paths changed on failure."""
    temps: list[Path] = []
    writers: list[Any] = []
    try:
        for path, fourcc in targets:
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp_name = temp_output(path, path.suffix)
            os.close(fd)
            temps.append(Path(tmp_name))
            writers.append(_open_video_writer(temps[-1], fourcc, r, path))
        _write_frames(writers, r, frames, targets[0][0].name, progress)
        while writers:
            writers.pop(0).release()
        for (path, fourcc), tmp in zip(targets, temps, strict=True):
            if tmp.stat().st_size == 0:
                raise RuntimeError(
                    f"the encoder wrote an empty video for {path} (codec {fourcc or 'H.264'!r})"
                )
        for (path, _), tmp in zip(targets, temps, strict=True):
            os.replace(tmp, path)
    except BaseException:
        for writer in writers:
            with contextlib.suppress(Exception):
                writer.release()
        for tmp in temps:
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
        raise


def html_video_type(path: str | Path) -> str | None:
    """The ``type`` of an HTML ``<source>`` for a video file (MIME type and codec), or None
    for a video web browsers do not play (an MP4 of MPEG-4 Part 2, say).

    The codec is read from the file (PyAV, or OpenCV's four-character code without it); an
    H.264 MP4 is typed with its profile and level, ``video/mp4; codecs="avc1.64001E"``.

    Raises
    ------
    ValueError
        When the file cannot be read as a video.
    """
    path = Path(path)
    name, avcc = _probe_codec(path)
    suffix = path.suffix.lower()
    if suffix == ".webm" and name in ("vp8", "vp9"):
        return f'video/webm; codecs="{name}"'
    if suffix == ".mp4" and name == "h264":
        if len(avcc) >= 4 and avcc[0] == 1:  # avcC: version, profile, compatibility, level
            return f'video/mp4; codecs="avc1.{avcc[1]:02X}{avcc[2]:02X}{avcc[3]:02X}"'
        return "video/mp4"
    return None


def _probe_codec(path: Path) -> tuple[str, bytes]:
    """FFmpeg's name of the first video stream's codec and its extra data (the ``avcC``
    record of H.264 in MP4; empty when read through OpenCV)."""
    try:
        import av
    except ImportError:
        return _probe_codec_opencv(path)
    try:
        with av.open(str(path)) as container:
            ctx = container.streams.video[0].codec_context
            return ctx.name, bytes(ctx.extradata or b"")
    except (av.FFmpegError, IndexError) as exc:
        raise ValueError(f"cannot read {path} as a video: {exc}") from None


def _probe_codec_opencv(path: Path) -> tuple[str, bytes]:
    """:func:`_probe_codec` through OpenCV's four-character code (no extra data)."""
    import cv2

    cap = cv2.VideoCapture(str(path))
    try:
        if not cap.isOpened():
            raise ValueError(f"cannot read {path} as a video")
        code = int(cap.get(cv2.CAP_PROP_FOURCC)).to_bytes(4, "little").decode("latin-1")
    finally:
        cap.release()
    names = {"avc1": "h264", "h264": "h264", "vp80": "vp8", "vp90": "vp9", "fmp4": "mpeg4",
             "mp4v": "mpeg4"}  # fmt: skip
    return names.get(code.lower(), code.lower()), b""


def render_overlay_video(
    path: str | Path,
    tracks: MOTData,
    speaking: np.ndarray | Sequence[bool] | None,
    image_size: Sequence[int],
    fps: float,
    *,
    codec: str | None = None,
    progress: bool = False,
    frames: Iterable[np.ndarray] | None = None,
    also_to: Sequence[str | Path] = (),
    **options: Unpack[OverlayOptions],
) -> Path:
    """Write the video of the tracks and their speaking status over the rendered room, or
    over the real video's frames (``frames``).

    Parameters
    ----------
    path : str or Path
        ``.mp4`` (H.264 where :func:`h264_available`, else MPEG-4 Part 2) or ``.webm`` (VP8)
        file; its folder is created if needed.
    tracks : MOTData
        Tracked head boxes ``(left, top, width, height)``, 1-based frames, one id per track
        (e.g. :attr:`AVSceneResult.tracks <avtrack.av.vavit.AVSceneResult>`).
    speaking : ndarray (len(tracks),) bool or None
        Whether the track of each row speaks at that frame (``AVSceneResult.speaking``);
        None: nobody speaks.
    image_size : (int, int)
        ``(width, height)`` of the camera image, pixels.
    fps : float
        Frame rate; frame ``f`` is at time ``(f - 1) / fps``.
    n_frames : int, optional
        Number of frames (default: the last frame of ``tracks`` and ``gt``).
    gt : MOTData, optional
        Ground-truth head boxes: drawn as people (and thin grey boxes, ``show_gt_boxes``).
    camera : PinholeCamera, optional
        The camera (``camera.json``), to render the room in perspective; its image size must be
        ``image_size``.
    room_dims : ndarray (3,), optional
        Room size in metres (``scene.yaml`` ``room.dims``), for the walls.
    codec : str, optional
        OpenCV four-character code for ``path`` overriding the suffix's default.
    show_gt_boxes : bool
        Outline the ground-truth boxes in thin grey.
    legend : bool
        Track colours and symbols, top left.
    title : str, optional
        Written at the top right of each frame.
    progress : bool
        Show a progress bar (tqdm, on stderr).
    persons : PersonsTable, optional
        Every tracked person every frame (:class:`avtrack.io.persons.PersonsTable`): those
        without a box are drawn as a ring at their direction's pixel, or, out of the image, as
        an arrow at the edge on their side with their azimuth.
    frames : iterable of ndarray (height, width, 3) uint8, optional
        The real video's BGR frames ``1, ..., n_frames`` (e.g.
        :func:`avtrack.io.video.iter_frames`), drawn over instead of the rendered room, one at
        a time; a video that ends early is an error.
    also_to : sequence of str or Path
        More files of the same frames (each ``.mp4`` or ``.webm``, with its suffix's default
        codec), encoded in the same pass: the frames are drawn, and ``frames`` read, once.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ValueError
        Unknown suffix, bad sizes or shapes, frames beyond ``n_frames``.
    TypeError
        Arguments of the wrong type (``speaking`` not boolean, ``tracks`` not MOTData, ...).
    RuntimeError
        OpenCV cannot open an encoder for ``codec``. Nothing is left at ``path`` (nor at the
        ``also_to`` paths) then, nor after any other failure.
    """
    if isinstance(also_to, str | Path):
        raise TypeError(f"also_to must be a sequence of paths, got the single path {also_to!r}")
    targets = [(Path(path), _encoder(Path(path), codec))]
    targets += [(Path(p), _encoder(Path(p), None)) for p in also_to]
    r = _renderer(tracks, speaking, image_size, fps, **options)
    _encode_videos(targets, r, frames, progress)
    return Path(path)


def render_scene_video(
    scene: str | Path | SceneInputs,
    result: AVSceneResult | PersonsResult,
    path: str | Path,
    *,
    ground_truth: bool = True,
    codec: str | None = None,
    show_gt_boxes: bool = True,
    legend: bool = True,
    title: str | None = None,
    progress: bool = False,
) -> Path:
    """Video of a tracker's result on a scene directory (:mod:`avtrack.simulate.scene`).

    The room comes from ``camera.json`` and ``scene.yaml`` (``room.dims``), the people from
    ``gt/gt.txt`` (when present and ``ground_truth``), the tracks and speaking flags from
    ``result``.

    Parameters
    ----------
    scene : str, Path or SceneInputs
        The scene directory, or its inputs from :func:`avtrack.io.scene.load_scene`.
    result : AVSceneResult or PersonsResult
        From :func:`avtrack.av.vavit.track_scene` or
        :func:`avtrack.av.persons_scene.track_scene_persons` on that scene (with a
        ``PersonsResult``, the persons tracked without a box are drawn too).
    path : str or Path
        ``.mp4`` or ``.webm`` destination.
    ground_truth : bool
        Draw the ground-truth people (and, with ``show_gt_boxes``, their boxes).
    codec, show_gt_boxes, legend, progress
        As in :func:`render_overlay_video`.
    title : str, optional
        Default: the scenario's name.

    Returns
    -------
    Path
    """
    import json

    from avtrack.av.persons_scene import PersonsResult
    from avtrack.av.vavit import AVSceneResult
    from avtrack.errors import InputError
    from avtrack.io.mot import read_mot
    from avtrack.io.scene import SceneInputs, load_scene

    if not isinstance(result, AVSceneResult | PersonsResult):
        raise TypeError(
            f"result must be an AVSceneResult or PersonsResult, got {type(result).__name__}"
        )
    if isinstance(scene, str | Path):
        scene = load_scene(scene)
    if not isinstance(scene, SceneInputs):
        raise TypeError(
            f"scene must be a scene directory or SceneInputs, got {type(scene).__name__}"
        )
    if tuple(result.image_size) != tuple(scene.image_size):
        raise ValueError(
            f"result image size {tuple(result.image_size)} does not match the scene's "
            f"{tuple(scene.image_size)}"
        )
    cam_path = scene.path / "camera.json"
    try:
        camera = PinholeCamera.from_json(json.loads(cam_path.read_text()), cam_path)
    except (OSError, json.JSONDecodeError) as exc:
        raise InputError(f"cannot read the camera: {exc}", cam_path) from None
    gt_path = scene.path / "gt" / "gt.txt"
    gt = read_mot(gt_path, kind="gt") if ground_truth and gt_path.is_file() else None
    room = scene.scenario["room"]["dims"] if scene.scenario else None
    if title is None and scene.scenario:
        title = str(scene.scenario.get("name") or "") or None
    n_frames = max(result.n_frames, 0 if gt is None else gt.n_frames)
    return render_overlay_video(
        path,
        result.tracks,
        result.speaking,
        scene.image_size,
        result.fps,
        n_frames=n_frames,
        gt=gt,
        camera=camera,
        room_dims=room,
        codec=codec,
        show_gt_boxes=show_gt_boxes,
        legend=legend,
        title=title,
        progress=progress,
        persons=result.persons if isinstance(result, PersonsResult) else None,
    )
