r"""Colour-template detection of heads on a static camera: the colour-histogram visual
measurements of the audio-visual SMC-PHD trackers.

Kilic, Barnard, Wang and Kittler ("Audio assisted robust visual tracking with adaptive particle
filtering", IEEE TMM 2015; "Mean-shift and sparse sampling-based SMC-PHD filtering for audio
informed visual speaker tracking", IEEE TMM 2016) measure a speaker in the image by comparing
the hue-saturation histogram of an image window with a reference histogram of that speaker
(AV16.3's ``hist_temp_16bins`` templates: 16 hue x 16 saturation bins of HSV, rows hue) through
the Bhattacharyya coefficient

.. math::  \rho(h, q) = \sum_b \sqrt{h_b\, q_b}.

Here every window of a fixed size on a grid of ``cell`` pixels is scored against every template
at once (per-cell histograms, a summed-area table over cells, one matrix product), windows with
too little moving foreground are left out (OpenCV's MOG2 background subtractor, Zivkovic,
"Improved adaptive Gaussian mixture model for background subtraction", ICPR 2004: a static
camera's walls and furniture share the skin and hair colours of the templates), and each
template's best window above ``min_similarity`` becomes one detection, scored by its
coefficient. Hand-written because no maintained library computes dense template-histogram maps;
OpenCV computes the colour conversion and the background model.

The detector keeps the background model between calls: give it the frames of one video in
order (``reset()`` before another video).
"""

from __future__ import annotations

import numpy as np

#: Bins of the AV16.3 templates: hue x saturation.
TEMPLATE_BINS = (16, 16)


def _as_templates(templates: np.ndarray) -> np.ndarray:
    q = np.asarray(templates, dtype=float)
    if q.ndim == 2 and q.shape == TEMPLATE_BINS:
        q = q[None]
    if q.ndim != 3 or q.shape[1:] != TEMPLATE_BINS or q.shape[0] < 1:
        raise ValueError(
            f"templates must have shape (K, {TEMPLATE_BINS[0]}, {TEMPLATE_BINS[1]}), got "
            f"{q.shape}"
        )
    if not np.all(np.isfinite(q)) or np.any(q < 0) or np.any(q.sum(axis=(1, 2)) <= 0):
        raise ValueError("templates must be finite, non-negative and not all zero")
    q = q / q.sum(axis=(1, 2), keepdims=True)
    return q.reshape(q.shape[0], -1)


def hue_saturation_bins(frame_bgr: np.ndarray) -> np.ndarray:
    """The joint hue-saturation bin (0..255, hue major) of every pixel: ``(height, width)``."""
    import cv2

    hsv = cv2.cvtColor(frame_bgr, cv2.COLOR_BGR2HSV)  # hue 0..179, saturation 0..255
    hue = (hsv[..., 0].astype(np.int32) * TEMPLATE_BINS[0]) // 180
    sat = hsv[..., 1].astype(np.int32) * TEMPLATE_BINS[1] // 256
    return hue * TEMPLATE_BINS[1] + sat


def similarity_maps(
    bins: np.ndarray, templates: np.ndarray, window: tuple[int, int], cell: int
) -> np.ndarray:
    """Bhattacharyya coefficient of every grid window with every template.

    Parameters
    ----------
    bins : ndarray (height, width) int
        :func:`hue_saturation_bins` of a frame.
    templates : ndarray (K, 256)
        Normalised templates.
    window : (int, int)
        Window width and height in cells.
    cell : int
        Grid step in pixels.

    Returns
    -------
    ndarray (rows, cols, K)
        Entry ``[i, j, k]`` is the window whose top-left pixel is ``(j * cell, i * cell)``.
    """
    ww, wh = window
    gh, gw = bins.shape[0] // cell, bins.shape[1] // cell
    # Only bins some template holds contribute to the coefficient; a window's histogram is
    # normalised by its pixel count, so the other bins can be dropped before counting.
    support = np.flatnonzero(templates.sum(axis=0) > 0)
    slot = np.full(templates.shape[1], -1)
    slot[support] = np.arange(support.size)
    s = slot[bins[: gh * cell, : gw * cell]]
    cell_id = (np.arange(gh * cell)[:, None] // cell) * gw + np.arange(gw * cell)[None, :] // cell
    ok = s >= 0
    counts = np.bincount(s[ok] * (gh * gw) + cell_id[ok], minlength=support.size * gh * gw)
    # Summed-area table over cells, bins first (contiguous cumulative sums; float32 is exact
    # for counts below 2**24).
    sat = np.zeros((support.size, gh + 1, gw + 1), np.float32)
    sat[:, 1:, 1:] = counts.reshape(support.size, gh, gw).astype(np.float32).cumsum(1).cumsum(2)
    win = sat[:, wh:, ww:] - sat[:, :-wh, ww:] - sat[:, wh:, :-ww] + sat[:, :-wh, :-ww]
    win = np.sqrt(np.maximum(win, 0.0) / float(ww * wh * cell * cell))
    rows, cols = win.shape[1:]
    rho = np.sqrt(templates[:, support]).astype(np.float32) @ win.reshape(support.size, -1)
    return rho.T.reshape(rows, cols, templates.shape[0]).astype(float)


class ColourTemplateDetector:
    """Heads found by their colour histograms (see the module docstring).

    Parameters
    ----------
    templates : ndarray (K, 16, 16)
        Reference hue-saturation histograms, one per person (e.g. AV16.3's ``hist_temp``).
    window : (int, int)
        Window width and height in pixels (multiples of ``cell``); AV16.3's heads and
        shoulders at 360 x 288 fill about 32 x 48.
    cell : int
        Grid step in pixels.
    min_similarity : float
        Bhattacharyya coefficient a window needs to be reported.
    min_foreground : float
        Fraction of a window's pixels the background model must call foreground (0 turns
        the background model off).
    """

    def __init__(
        self,
        templates: np.ndarray,
        window: tuple[int, int] = (32, 48),
        cell: int = 4,
        min_similarity: float = 0.6,
        min_foreground: float = 0.4,
    ) -> None:
        self.templates = _as_templates(templates)
        if int(cell) < 1:
            raise ValueError(f"cell must be >= 1, got {cell}")
        self.cell = int(cell)
        w, h = (int(v) for v in window)
        if w < self.cell or h < self.cell or w % self.cell or h % self.cell:
            raise ValueError(f"window {window} must be positive multiples of cell {cell}")
        self.window = (w // self.cell, h // self.cell)
        if not 0 <= min_similarity <= 1 or not 0 <= min_foreground <= 1:
            raise ValueError("min_similarity and min_foreground must lie in [0, 1]")
        self.min_similarity = float(min_similarity)
        self.min_foreground = float(min_foreground)
        self.reset()

    def reset(self) -> None:
        """Forget the background model (before the frames of another video)."""
        import cv2

        self._background = cv2.createBackgroundSubtractorMOG2(
            history=500, varThreshold=16, detectShadows=True
        )

    def _foreground(self, frame: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
        """Fraction of foreground pixels in every grid window: ``shape``."""
        import cv2

        mask = (self._background.apply(frame) == 255).astype(np.float32)  # 127 = shadow
        ww, wh = self.window
        gh, gw = frame.shape[0] // self.cell, frame.shape[1] // self.cell
        cells = cv2.resize(mask[: gh * self.cell, : gw * self.cell], (gw, gh),
                           interpolation=cv2.INTER_AREA).astype(float)
        sat = np.zeros((gh + 1, gw + 1))
        sat[1:, 1:] = cells.cumsum(0).cumsum(1)
        frac = (sat[wh:, ww:] - sat[:-wh, ww:] - sat[wh:, :-ww] + sat[:-wh, :-ww]) / (ww * wh)
        if frac.shape != shape:
            raise RuntimeError(f"foreground fractions of shape {frac.shape}, expected {shape}: "
                               "the frame size changed within the video")
        return frac

    def detect(self, frame: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """At most one box per template, no two overlapping by more than half a window:
        ``(M, 4)`` (left, top, width, height) and ``(M,)`` Bhattacharyya coefficients; row
        order follows the templates."""
        img = np.asarray(frame)
        if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
            raise ValueError(f"frame must be (height, width, 3) uint8 BGR, got {img.shape} "
                             f"{img.dtype}")
        ww, wh = self.window
        if img.shape[0] < wh * self.cell or img.shape[1] < ww * self.cell:
            raise ValueError(f"frame {img.shape[1]} x {img.shape[0]} is smaller than the "
                             f"window {ww * self.cell} x {wh * self.cell}")
        rho = similarity_maps(hue_saturation_bins(img), self.templates, self.window, self.cell)
        if self.min_foreground > 0:
            fg = self._foreground(img, rho.shape[:2])
            rho = np.where(fg[..., None] >= self.min_foreground, rho, 0.0)
        # One window per template, and no two templates on one person: the templates take
        # their best windows in order of similarity, each away from the windows already taken
        # (a person is not two people; an absent person's template would otherwise land on
        # whoever looks most like them).
        rows, cols = rho.shape[:2]
        ii, jj = np.mgrid[0:rows, 0:cols]
        free = np.ones((rows, cols), dtype=bool)
        found: list[tuple[int, int, int, float]] = []
        todo = list(range(rho.shape[2]))
        while todo:
            masked = np.where(free[..., None], rho[..., todo], -1.0).reshape(-1, len(todo))
            best = masked.argmax(axis=0)
            score = masked[best, np.arange(len(todo))]
            k = int(np.argmax(score))
            if score[k] < self.min_similarity:
                break
            i, j = np.unravel_index(best[k], (rows, cols))
            found.append((todo.pop(k), int(i), int(j), float(score[k])))
            free &= (np.abs(ii - i) >= wh) | (np.abs(jj - j) >= ww)
        found.sort()
        c = self.cell
        boxes = np.array([[j * c, i * c, ww * c, wh * c] for _, i, j, _ in found],
                         dtype=float).reshape(-1, 4)
        return boxes, np.array([f[3] for f in found], dtype=float)
