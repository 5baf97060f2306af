r"""Heads as the tops of moving foreground blobs on a static camera, with illumination
compensation: visual measurements that do not need the person to face the camera.

A standing or walking person seen by a static camera above head height is a foreground blob
whose highest part is the head. The detector

1. **compensates the camera's exposure.** Cameras with automatic gain (AV16.3's) brighten or
   darken the whole image when a dark-clothed person comes close, which a background model
   reads as the whole image turning foreground. Each frame is divided by a per-channel gain:
   the median ratio of frame to background over the pixels the last frame called background
   (a robust global-gain estimate; the diagonal "von Kries" model of illumination change,
   e.g. Finlayson, Schiele and Crowley, "Comprehensive colour image normalization", ECCV 1998),
   before
2. **background subtraction** (OpenCV's MOG2, Zivkovic, "Improved adaptive Gaussian mixture
   model for background subtraction", ICPR 2004; shadows are not foreground), cleaned by a
   box filter: "solid" foreground is where at least half of a small window is foreground;
3. **head tops** are the local minima of the foreground's upper contour (the first solid row
   of each column), the head-top / contour-peak idea of silhouette-based people detectors
   (Haritaoglu, Harwood and Davis, "W4: real-time surveillance of people and their
   activities", IEEE PAMI 2000; Zhao and Nevatia, "Tracking multiple humans in complex
   situations", IEEE PAMI 2004). A peak must be the highest point within ``peak_radius``
   head heights, and a peak within ``suppress`` head heights of a higher one is that person's
   shoulder and is dropped;
4. **the head's size** comes from the camera geometry: ``head_height`` gives, for every pixel,
   how tall (pixels) a head whose mouth is at that pixel is (for a calibrated camera, a head
   of :data:`~avtrack.av.geometry.HEAD_HEIGHT_M` at the depth where the pixel's ray meets the
   plane of mouths, :meth:`avtrack.av.av163.AV163View.head_height_map`); the mouth lies
   ``mouth_fraction`` of a head height below the head top (vertex to stomion is about 0.69 of
   vertex to menton in adult anthropometric tables), solved as a fixed point because the
   head's size depends on where its mouth is. The geometry is an upper bound: the head is
   no taller than the widest foreground run through the head-top column within
   ``width_rows`` head heights below the top, over ``head_aspect`` (head breadth over
   height), and no smaller than ``min_size`` of the geometry's head. A seated person's mouth
   lies below the mouth plane, which the geometry reads as a nearer, bigger head; the
   widest run rather than the width at one row, because a person who stands still fades
   into the background model from the inside and leaves holes under the head top;
5. **the face, where visible**: skin pixels inside the head box (one measured head wide and
   tall from the head top; the YCrCb skin rule of Chai and Ngan, "Face segmentation using
   skin-colour map in videophone applications", IEEE TCSVT 1999: 133 <= Cr <= 173,
   77 <= Cb <= 127). When at least ``min_skin`` of the box is skin, the mouth is placed at
   the skin's mean column (a face in profile is off the head's centre) and at its
   ``mouth_quantile`` row (the lower face); otherwise (back of the head) the mouth lies
   ``mouth_fraction`` of the measured head below the head top. Sizing the box by the
   measured head keeps a hand at the ear, the neck and the shoulder of a head smaller than
   the geometry's out of the skin that places the mouth;
6. **no head without a body or motion**: a head top without a visible face needs at least
   ``min_fill`` of the lower half of its head box to be foreground (a speck of foreground,
   such as a reflection in a picture's glass or flicker on a high-contrast edge, is not a
   head), and every head needs at least ``min_motion`` of the foreground in its head box to
   have changed (grey level by more than 12) over the last ``motion_lag`` frames: a "ghost",
   the place a person stood long enough to be absorbed into the background model and then
   left, is foreground that does not move (Cucchiara, Grana, Piccardi and Prati, "Detecting
   moving objects, ghosts, and shadows in video streams", IEEE PAMI 2003);
7. **identity evidence** (optional): the Bhattacharyya coefficient of the hue-saturation
   histogram of the head box (one head wide, 1.3 high from the top: head and neck) with the
   best-matching colour template scores each head; heads below ``min_similarity`` are dropped.

Each head is reported as a box ``(left, top, width, height)`` one head tall and ``0.75``
head wide, placed so that the mouth is at its horizontal centre and ``mouth_fraction`` of its
height (``mouth_offset``) below its top, like :data:`~avtrack.io.av163.TEMPLATE_MOUTH_OFFSET`
for template windows (without a visible face the box's top is the head top).

The detector keeps the background model between calls: give it the frames of one video in
order (``reset()`` before another video). People taller or shorter than the mouth plane
assumes and heads leaving the top of the image get biased mouth points when no face is
visible (the head top is still found; its offset to the mouth is off by the size error, which
the width bound only limits from above: a head bigger than the geometry's keeps the
geometry's size, and its face box ends above its chin); two people whose heads touch in the
image give one head; a moving object that is not a person gives a head when its colours pass
the templates; a person who stays perfectly still for ``motion_lag`` frames is dropped.
"""

from __future__ import annotations

import numpy as np

from avtrack.visual.colour import _as_templates, hue_saturation_bins

#: Vertex-to-stomion over vertex-to-menton (head height) of an adult head.
MOUTH_FRACTION = 0.69
#: Head breadth over head height of an adult head (about 0.155 m / 0.24 m).
HEAD_ASPECT = 0.65


def _run_width(row: np.ndarray, x: int) -> int:
    """Length of the run of True in ``row`` through column ``x`` (0 when ``row[x]`` is
    False)."""
    if not row[x]:
        return 0
    left = row[x::-1]
    right = row[x:]
    a = int(np.argmin(left)) if not left.all() else len(left)
    b = int(np.argmin(right)) if not right.all() else len(right)
    return a + b - 1


class ForegroundHeadDetector:
    """Heads as the peaks of the foreground's upper contour (see the module docstring).

    Parameters
    ----------
    head_height : float or ndarray (height, width)
        Head height in pixels of a head whose mouth is at each pixel (a map), or one value for
        the whole image.
    templates : ndarray (K, 16, 16), optional
        Colour templates (e.g. AV16.3's ``hist_temp``); without them every head scores 1.
    min_similarity : float
        Bhattacharyya coefficient a head needs with its best template (with templates).
    mouth_fraction : float
        Mouth below the head top, in head heights.
    peak_radius : float
        A head top is the highest foreground within this many head heights on either side.
    suppress : float
        A lower peak within this many head heights (of the smaller of the two heads) of a
        higher one is dropped (a shoulder).
    min_head : float
        Heads smaller than this many pixels tall are not looked for (noise).
    head_aspect : float
        Head breadth over head height: the head is no taller than the widest foreground run
        through its top's column within ``width_rows`` head heights below the top divided
        by this (0: the geometry alone).
    width_rows : float
        Rows searched for the head's width, in head heights below its top.
    min_size : float
        The measured head is no smaller than this fraction of the geometry's.
    border : float
        Head-top plateaus that reach the image's left or right edge, or come within this
        many head heights of it, are dropped: a blob cut by the edge peaks at the edge,
        wherever its head is.
    gain : bool
        Compensate global exposure changes before background subtraction.
    min_skin : float
        Fraction of the head box that must be skin for the face to place the mouth (above 1:
        never).
    mouth_quantile : float
        The mouth's row within the face's skin pixels (a quantile, from the top).
    min_fill : float
        Fraction of the lower half of a faceless head's box that must be foreground (0: no
        check).
    min_motion : float
        Fraction of the foreground in a head's box that must have changed over the last
        ``motion_lag`` frames (0: no check).
    motion_lag : int
        Frames back that motion is measured against.
    """

    def __init__(
        self,
        head_height,
        templates: np.ndarray | None = None,
        min_similarity: float = 0.5,
        mouth_fraction: float = MOUTH_FRACTION,
        peak_radius: float = 0.4,
        suppress: float = 0.8,
        min_head: float = 6.0,
        border: float = 0.1,
        head_aspect: float = HEAD_ASPECT,
        gain: bool = True,
        min_skin: float = 0.05,
        mouth_quantile: float = 0.85,
        width_rows: float = 0.5,
        min_size: float = 0.5,
        min_fill: float = 0.05,
        min_motion: float = 0.05,
        motion_lag: int = 4,
    ) -> None:
        hh = np.asarray(head_height, dtype=float)
        if hh.ndim not in (0, 2) or not np.all(np.isfinite(hh)) or np.any(hh <= 0):
            raise ValueError("head_height must be a positive number or a positive (height, "
                             "width) map")
        self.head_height = hh
        self.templates = None if templates is None else _as_templates(templates)
        for name, v in (("min_similarity", min_similarity), ("mouth_fraction", mouth_fraction)):
            if not 0 <= v <= 1:
                raise ValueError(f"{name} must lie in [0, 1], got {v}")
        if peak_radius <= 0 or suppress < 0 or min_head <= 0:
            raise ValueError("peak_radius and min_head must be positive, suppress >= 0")
        self.min_similarity = float(min_similarity)
        self.mouth_offset = float(mouth_fraction)
        self.peak_radius = float(peak_radius)
        self.suppress = float(suppress)
        self.min_head = float(min_head)
        if border < 0:
            raise ValueError(f"border must be >= 0, got {border}")
        self.border = float(border)
        if head_aspect < 0:
            raise ValueError(f"head_aspect must be >= 0, got {head_aspect}")
        self.head_aspect = float(head_aspect)
        self.gain = bool(gain)
        if min_skin < 0 or not 0 <= mouth_quantile <= 1:
            raise ValueError("min_skin must be >= 0 and mouth_quantile in [0, 1]")
        self.min_skin = float(min_skin)
        self.mouth_quantile = float(mouth_quantile)
        if width_rows <= 0 or not 0 < min_size <= 1:
            raise ValueError("width_rows must be positive and min_size in (0, 1]")
        self.width_rows = float(width_rows)
        self.min_size = float(min_size)
        if not 0 <= min_fill <= 1 or not 0 <= min_motion <= 1 or int(motion_lag) < 1:
            raise ValueError("min_fill and min_motion must lie in [0, 1], motion_lag >= 1")
        self.min_fill = float(min_fill)
        self.min_motion = float(min_motion)
        self.motion_lag = int(motion_lag)
        self.reset()

    def reset(self) -> None:
        """Forget the background model (before the frames of another video)."""
        import cv2

        self._mog = cv2.createBackgroundSubtractorMOG2(history=500, varThreshold=16,
                                                       detectShadows=True)
        self._background: np.ndarray | None = None
        self._mask: np.ndarray | None = None
        self._grey: list[np.ndarray] = []  # the last motion_lag + 1 frames, grey

    # ------------------------------------------------------------------ foreground
    def _compensate(self, frame: np.ndarray) -> np.ndarray:
        """The frame divided by its global per-channel gain relative to the background."""
        x = frame.astype(np.float32)
        if self.gain and self._background is not None and self._mask is not None:
            bg = self._mask[::4, ::4] == 0
            f = x[::4, ::4][bg]
            b = self._background[::4, ::4][bg]
            ok = (f.min(axis=1) > 10) & (f.max(axis=1) < 250)  # not clipped
            if ok.sum() >= 100:
                x *= np.median(b[ok] / f[ok], axis=0).astype(np.float32)
        return x

    def foreground(self, frame: np.ndarray) -> np.ndarray:
        """Update the background model with a frame; its foreground mask (bool)."""
        x = self._compensate(frame)
        norm = np.clip(x, 0, 255).astype(np.uint8)
        mask = self._mog.apply(norm)
        if self._background is None:
            self._background = norm.astype(np.float32)
        else:  # a running mean of the background pixels, for the gain only
            still = (mask == 0)[..., None]
            self._background = np.where(still, 0.95 * self._background + 0.05 * x,
                                        self._background)
        self._mask = mask
        return mask == 255  # 127 = shadow

    # ------------------------------------------------------------------ heads
    def _size(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        if self.head_height.ndim == 0:
            return np.full(np.shape(x), float(self.head_height))
        h, w = self.head_height.shape
        return self.head_height[np.clip(y.astype(int), 0, h - 1), np.clip(x.astype(int), 0, w - 1)]

    def heads(self, mask: np.ndarray) -> np.ndarray:
        """Head tops of a foreground mask: ``(M, 3)`` rows ``x, top, head height`` (pixels)."""
        import cv2
        from scipy.ndimage import minimum_filter1d

        height = mask.shape[0]
        if self.head_height.ndim == 2 and self.head_height.shape != mask.shape:
            raise ValueError(f"head_height map {self.head_height.shape} does not match the "
                             f"frame {mask.shape}")
        solid = cv2.blur(mask.astype(np.float32), (5, 9)) >= 0.5
        self._solid = solid
        top = np.where(solid.any(axis=0), solid.argmax(axis=0), height).astype(float)
        # local minima at the smallest radius, one per plateau (its centre)
        idx = np.flatnonzero((top < height - 1)
                             & (top <= minimum_filter1d(top, 7, mode="nearest")))
        width = mask.shape[1]
        xs = []
        start = 0
        for k in range(1, len(idx) + 1):
            if k == len(idx) or idx[k] != idx[k - 1] + 1 or top[idx[k]] != top[idx[start]]:
                xs.append((idx[start], idx[k - 1]))
                start = k
        if not xs:
            return np.zeros((0, 3))
        ends = np.array(xs)
        xc = ends.sum(axis=1) // 2
        yt = top[xc]
        ym = yt.copy()
        for _ in range(6):  # mouth = top + fraction * head height at the mouth
            h = self._size(xc, ym)
            ym = yt + self.mouth_offset * h
        # a plateau reaching the image's edge (or within `border` heads of it) is a blob cut
        # by the frame, not a head top
        near = self.border * h
        keep = (h >= self.min_head) & (ends[:, 0] > near) & (ends[:, 1] < width - 1 - near)
        for i in np.flatnonzero(keep):
            r = max(int(self.peak_radius * h[i]), 3)
            if yt[i] > top[max(xc[i] - r, 0): xc[i] + r + 1].min():
                keep[i] = False
        order = [i for i in np.lexsort((xc, yt)) if keep[i]]
        kept: list[int] = []
        for i in order:  # highest first; a lower peak beside a head is its shoulder
            if any(abs(xc[i] - xc[k]) < self.suppress * min(h[k], h[i]) for k in kept):
                continue
            kept.append(i)
        kept.sort(key=lambda i: xc[i])
        return np.column_stack([xc[kept], yt[kept], h[kept]]).astype(float).reshape(-1, 3)

    def head_size(self, heads: np.ndarray) -> np.ndarray:
        """Measured head heights (pixels) of ``heads`` (rows ``x, top, head height`` of
        :meth:`heads`, on the last frame's foreground): the geometry's head height, no taller
        than the widest foreground run through the head-top column within ``width_rows``
        head heights below the top over ``head_aspect``, no smaller than ``min_size`` of
        the geometry's."""
        h = np.asarray(heads, dtype=float).reshape(-1, 3)[:, 2].copy()
        if self.head_aspect <= 0:
            return h
        height = self._solid.shape[0]
        for i, (x, top, hh) in enumerate(np.asarray(heads, dtype=float).reshape(-1, 3)):
            y0, y1 = int(max(top, 0)), int(min(top + self.width_rows * hh, height))
            widest = max((_run_width(self._solid[y], int(x)) for y in range(y0, y1)), default=0)
            if widest > 0:
                h[i] = float(np.clip(widest / self.head_aspect, self.min_size * hh, hh))
        return h

    def detect(self, frame: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Head boxes ``(M, 4)`` (left, top, width, height; the mouth at ``mouth_offset`` of
        the height) and ``(M,)`` scores (best template coefficient, or 1 without templates)."""
        img = np.asarray(frame)
        if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
            raise ValueError(f"frame must be (height, width, 3) uint8 BGR, got {img.shape} "
                             f"{img.dtype}")
        heads = self.heads(self.foreground(img))
        if self.min_motion > 0:
            import cv2

            grey = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY).astype(np.int16)
            self._grey = [*self._grey[-self.motion_lag:], grey]
        if len(heads) == 0:
            return np.zeros((0, 4)), np.zeros(0)
        x, top, h = heads.T
        H, W = img.shape[:2]
        size = self.head_size(heads)
        mx, my = x.copy(), top + self.mouth_offset * size
        on_face = np.zeros(len(heads), dtype=bool)
        if self.min_skin <= 1:
            import cv2

            for i in range(len(heads)):  # the face, where visible, places the mouth
                x0, x1 = int(max(x[i] - 0.5 * size[i], 0)), int(min(x[i] + 0.5 * size[i], W))
                y0, y1 = int(max(top[i], 0)), int(min(top[i] + size[i], H))
                if x1 <= x0 or y1 <= y0:
                    continue
                ycc = cv2.cvtColor(img[y0:y1, x0:x1], cv2.COLOR_BGR2YCrCb)
                skin = ((ycc[..., 1] >= 133) & (ycc[..., 1] <= 173)
                        & (ycc[..., 2] >= 77) & (ycc[..., 2] <= 127))
                if skin.any() and skin.mean() >= self.min_skin:
                    rows, cols = np.nonzero(skin)
                    mx[i] = x0 + cols.mean()
                    my[i] = y0 + np.quantile(rows, self.mouth_quantile)
                    on_face[i] = True
        boxes = np.column_stack([mx - 0.375 * h, my - self.mouth_offset * h, 0.75 * h, h])
        ok = np.ones(len(boxes), dtype=bool)
        for i in range(len(boxes)):
            x0, x1 = int(max(x[i] - 0.5 * h[i], 0)), int(min(x[i] + 0.5 * h[i], W))
            y0, y1 = int(max(top[i], 0)), int(min(top[i] + h[i], H))
            if x1 <= x0 or y1 <= y0:
                continue
            if self.min_fill > 0 and not on_face[i]:  # a speck of foreground is no head
                ym = int(min(top[i] + 0.5 * h[i], H - 1))
                if y1 > ym and self._solid[ym:y1, x0:x1].mean() < self.min_fill:
                    ok[i] = False
            if self.min_motion > 0 and len(self._grey) > self.motion_lag:
                fg = self._solid[y0:y1, x0:x1]  # a ghost is foreground that does not move
                if fg.any():
                    moved = np.abs(grey[y0:y1, x0:x1] - self._grey[0][y0:y1, x0:x1]) > 12
                    if moved[fg].mean() < self.min_motion:
                        ok[i] = False
        if self.templates is None:
            return boxes[ok], np.ones(int(ok.sum()))
        bins = hue_saturation_bins(img)
        scores = np.empty(len(boxes))
        for i in range(len(boxes)):  # head and neck: one head wide, 1.3 tall
            x0, x1 = int(max(x[i] - 0.5 * h[i], 0)), int(min(x[i] + 0.5 * h[i], W))
            y0, y1 = int(max(top[i], 0)), int(min(top[i] + 1.3 * h[i], H))
            hist = np.bincount(bins[y0:y1, x0:x1].ravel(), minlength=256).astype(float)
            hist /= max(hist.sum(), 1.0)
            scores[i] = float((np.sqrt(self.templates) @ np.sqrt(hist)).max())
        ok &= scores >= self.min_similarity
        return boxes[ok], scores[ok]
