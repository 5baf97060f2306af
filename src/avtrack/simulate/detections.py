"""Simulated head detections seen by a pinhole camera: misses, false alarms, occlusions,
box noise and appearance descriptors, with exact MOTChallenge ground truth.

Detection model, per frame ``t`` and person ``p`` with head box ``b_tp`` (see
:meth:`PinholeCamera.head_box`):

- a person whose head box lies entirely outside the image (or behind the camera) is neither in
  the ground truth nor detected;
- ``o_tp`` is the fraction of ``b_tp`` covered by the union of the boxes of people nearer to the
  camera (exact, see :func:`occluded_fraction`); the ground-truth visibility is ``1 - o_tp``;
- the person is detected with probability ``1 - miss_rate`` if ``o_tp <= occlusion_threshold``
  and never otherwise;
- a detected box is ``(c + ε_c, s · exp(ε_s))`` for centre ``c`` and size ``s``, with
  ``ε_c ~ N(0, (centre_noise · s)^2)`` per axis and ``ε_s ~ N(0, size_noise^2)``, clipped to
  the image;
- each frame has ``Poisson(false_alarm_rate)`` false alarms: head-sized boxes (a head at a depth
  drawn uniformly in ``false_alarm_depth``) at uniform random positions inside the image;
- scores are ``N(score_mean, score_std^2)`` (true, false) clipped to ``[0.001, 1]``;
- person ``p`` has a unit signature ``a_p``; a detection of ``p`` has the descriptor
  ``normalise(a_p + appearance_noise · n / sqrt(D))``, ``n ~ N(0, I_D)``; a false alarm has a
  random unit descriptor.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from avtrack.io.camera import PinholeCamera
from avtrack.io.mot import MOTData


def _pair(name: str, value: tuple[float, float], positive: bool = False) -> tuple[float, float]:
    try:
        a, b = (float(v) for v in value)
    except (TypeError, ValueError):
        msg = f"DetectorConfig: {name} must be a pair of numbers, got {value!r}"
        raise ValueError(msg) from None
    if not (math.isfinite(a) and math.isfinite(b)) or (positive and (a <= 0 or b <= 0)):
        kind = "positive" if positive else "finite"
        raise ValueError(f"DetectorConfig: {name} must be two {kind} numbers, got {value!r}")
    return a, b


#: Boxes narrower or shorter than this (pixels) are not seen or detected.
MIN_BOX_PX = 1.0


@dataclass(frozen=True)
class DetectorConfig:
    """Parameters of the simulated head detector (see the module docstring for the model).

    Attributes
    ----------
    miss_rate : float in [0, 1]
        Probability of missing a visible, not-too-occluded person.
    false_alarm_rate : float >= 0
        Mean number of false alarms per frame (Poisson).
    centre_noise : float >= 0
        Standard deviation of the box centre, as a fraction of the box width (x) and height (y).
    size_noise : float >= 0
        Relative standard deviation of the box size (log-normal factor).
    occlusion_threshold : float in [0, 1]
        A person whose box is covered by nearer people's boxes by more than this fraction is
        not detected.
    score_mean, score_std : (float, float)
        Mean and standard deviation of the scores of (true, false) detections.
    appearance_dim : int
        Length D of the appearance descriptors.
    appearance_noise : float >= 0
        Norm (in expectation) of the noise added to a person's signature.
    head_size : (float, float)
        Head width and height in metres.
    false_alarm_depth : (float, float)
        Range of depths (metres) from which false-alarm box sizes are drawn.
    """

    miss_rate: float = 0.1
    false_alarm_rate: float = 0.2
    centre_noise: float = 0.05
    size_noise: float = 0.05
    occlusion_threshold: float = 0.5
    score_mean: tuple[float, float] = (0.8, 0.35)
    score_std: tuple[float, float] = (0.1, 0.15)
    appearance_dim: int = 64
    appearance_noise: float = 0.3
    head_size: tuple[float, float] = (0.18, 0.24)
    false_alarm_depth: tuple[float, float] = (1.0, 6.0)

    def __post_init__(self) -> None:
        for name in ("miss_rate", "occlusion_threshold"):
            v = float(getattr(self, name))
            if not 0.0 <= v <= 1.0:
                raise ValueError(f"DetectorConfig: {name} must be in [0, 1], got {v!r}")
            object.__setattr__(self, name, v)
        for name in ("false_alarm_rate", "centre_noise", "size_noise", "appearance_noise"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v >= 0.0):
                raise ValueError(f"DetectorConfig: {name} must be a finite number >= 0, got {v!r}")
            object.__setattr__(self, name, v)
        mean = _pair("score_mean", self.score_mean)
        std = _pair("score_std", self.score_std)
        if min(std) < 0:
            raise ValueError(f"DetectorConfig: score_std must be >= 0, got {self.score_std!r}")
        object.__setattr__(self, "score_mean", mean)
        object.__setattr__(self, "score_std", std)
        object.__setattr__(self, "head_size", _pair("head_size", self.head_size, positive=True))
        depth = _pair("false_alarm_depth", self.false_alarm_depth, positive=True)
        if depth[0] > depth[1]:
            raise ValueError(
                f"DetectorConfig: false_alarm_depth must be (near, far) with "
                f"near <= far, got {self.false_alarm_depth!r}"
            )
        object.__setattr__(self, "false_alarm_depth", depth)
        d = self.appearance_dim
        if isinstance(d, bool) or not isinstance(d, int | np.integer) or d < 1:
            raise ValueError(f"DetectorConfig: appearance_dim must be an integer >= 1, got {d!r}")
        object.__setattr__(self, "appearance_dim", int(d))


@dataclass(frozen=True)
class SimulatedDetections:
    """Output of :func:`simulate_detections`.

    Attributes
    ----------
    detections : MOTData
        R rows in MOTChallenge detection format (``ids`` all -1, ``extra`` = -1 x 3), sorted
        by frame and, within a frame, by decreasing score; frames 1-based.
    appearance : ndarray (R, D)
        Unit appearance descriptor of each detection row.
    gt : MOTData
        MOTChallenge ground truth: person id (1-based), clipped head box, flag 1 (``scores``),
        ``extra[:, 0]`` class 1 and ``extra[:, 1]`` visibility ``1 - occluded fraction``; one
        row per frame and person whose head box is at least partly in the image.
    det_person : ndarray (R,) int
        Person id of each detection row, -1 for false alarms.
    """

    detections: MOTData
    appearance: np.ndarray
    gt: MOTData
    det_person: np.ndarray

    def __post_init__(self) -> None:
        r = len(self.detections)
        app = np.asarray(self.appearance, dtype=float)
        if app.ndim != 2 or app.shape[0] != r:
            raise ValueError(
                f"SimulatedDetections: appearance must have shape ({r}, D), got {app.shape}"
            )
        who = np.asarray(self.det_person, dtype=np.int64)
        if who.shape != (r,):
            raise ValueError(
                f"SimulatedDetections: det_person must have shape ({r},), got {who.shape}"
            )
        object.__setattr__(self, "appearance", app)
        object.__setattr__(self, "det_person", who)


def occluded_fraction(boxes: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """Fraction of each box covered by the union of the boxes of nearer objects.

    Exact: the union is measured on the grid cut by all box edges (coordinate compression),
    so the cost is O(n^4) cells for n boxes — meant for the few people of one frame.

    Parameters
    ----------
    boxes : ndarray (n, 4)
        ``(left, top, width, height)``, width and height > 0.
    depth : ndarray (n,)
        Distance along the optical axis; box ``j`` occludes box ``i`` when
        ``depth[j] < depth[i]`` (equal depths do not occlude each other).

    Returns
    -------
    ndarray (n,)
        Occluded fraction in [0, 1].
    """
    b = np.asarray(boxes, dtype=float)
    z = np.asarray(depth, dtype=float)
    n = b.shape[0] if b.ndim else -1
    if b.ndim != 2 or b.shape[1] != 4 or z.shape != (n,):
        raise ValueError(
            f"occluded_fraction: boxes must be (n, 4) and depth (n,), got {b.shape} and {z.shape}"
        )
    if n < 2:
        return np.zeros(n)
    le, to = b[:, 0], b[:, 1]
    ri, bo = le + b[:, 2], to + b[:, 3]
    # Nearer boxes clipped to box i: (n_i, n_j).
    cl = np.maximum(le[None, :], le[:, None])
    cr = np.minimum(ri[None, :], ri[:, None])
    ct = np.maximum(to[None, :], to[:, None])
    cb = np.minimum(bo[None, :], bo[:, None])
    nearer = (z[None, :] < z[:, None]) & (cl < cr) & (ct < cb)
    # Cell edges inside box i: its own edges and those of the clipped nearer boxes.
    xs = np.sort(np.concatenate([le[:, None], ri[:, None], cl, cr], axis=1), axis=1)
    ys = np.sort(np.concatenate([to[:, None], bo[:, None], ct, cb], axis=1), axis=1)
    xm, dx = (xs[:, 1:] + xs[:, :-1]) / 2, np.diff(xs, axis=1)  # (n_i, 2n + 1)
    ym, dy = (ys[:, 1:] + ys[:, :-1]) / 2, np.diff(ys, axis=1)
    in_x = (cl[:, :, None] <= xm[:, None, :]) & (xm[:, None, :] < cr[:, :, None])  # (i, j, a)
    in_y = (ct[:, :, None] <= ym[:, None, :]) & (ym[:, None, :] < cb[:, :, None])  # (i, j, b)
    in_x &= nearer[:, :, None]
    covered = np.any(in_x[:, :, :, None] & in_y[:, :, None, :], axis=1)  # (i, a, b)
    area = np.einsum("iab,ia,ib->i", covered, dx, dy)
    return np.clip(area / (b[:, 2] * b[:, 3]), 0.0, 1.0)


def _unit(x: np.ndarray) -> np.ndarray:
    return x / np.linalg.norm(x, axis=-1, keepdims=True)


def _check_inputs(
    camera: PinholeCamera,
    head_positions: np.ndarray,
    rng: np.random.Generator,
    config: DetectorConfig | None,
) -> tuple[DetectorConfig, np.ndarray]:
    """Check :func:`simulate_detections`'s arguments; the configuration and the head
    positions ``(T, P, 3)`` as floats."""
    if not isinstance(camera, PinholeCamera):
        raise TypeError(
            f"simulate_detections: camera must be a PinholeCamera, got {type(camera).__name__}"
        )
    if not isinstance(rng, np.random.Generator):
        raise TypeError(
            f"simulate_detections: rng must be a numpy.random.Generator, got {type(rng).__name__}"
        )
    cfg = DetectorConfig() if config is None else config
    if not isinstance(cfg, DetectorConfig):
        raise TypeError(
            f"simulate_detections: config must be a DetectorConfig, got {type(cfg).__name__}"
        )
    pos = np.asarray(head_positions, dtype=float)
    if pos.ndim != 3 or pos.shape[2] != 3:
        raise ValueError(
            f"simulate_detections: head_positions must have shape (T, P, 3), got {pos.shape}"
        )
    if np.any(np.isinf(pos)):
        raise ValueError("simulate_detections: head_positions must be finite or NaN (absent)")
    return cfg, pos


def _head_boxes(
    camera: PinholeCamera, pos: np.ndarray, cfg: DetectorConfig
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The head boxes ``(T, P, 4)`` (NaN outside the image), whether each is in the image
    ``(T, P)``, and the fraction of each hidden by nearer heads ``(T, P)``."""
    n_t, n_p, _ = pos.shape
    boxes = camera.head_box(pos.reshape(-1, 3), cfg.head_size).reshape(n_t, n_p, 4)
    # a head cut to a sliver under a pixel by the image's edge is not in the image (its box
    # would also be written as 0 pixels wide in a MOTChallenge file)
    boxes[(boxes[:, :, 2] < MIN_BOX_PX) | (boxes[:, :, 3] < MIN_BOX_PX)] = np.nan
    _, depth = camera.project(pos.reshape(-1, 3))
    depth = depth.reshape(n_t, n_p)
    seen = np.isfinite(boxes[:, :, 0])  # (T, P)
    occluded = np.zeros((n_t, n_p))
    for t in np.flatnonzero(seen.sum(axis=1) > 1):
        idx = np.flatnonzero(seen[t])
        occluded[t, idx] = occluded_fraction(boxes[t, idx], depth[t, idx])
    return boxes, seen, occluded


def _ground_truth(boxes: np.ndarray, seen: np.ndarray, occluded: np.ndarray) -> MOTData:
    """Every (frame, person) with a box in the image, ordered by frame then id; column 8 is
    the class (1), column 9 the visible fraction."""
    gt_t, gt_p = np.nonzero(seen)
    gt_vis = 1.0 - occluded[gt_t, gt_p]
    return MOTData(
        frames=gt_t + 1,
        ids=gt_p + 1,
        boxes=boxes[gt_t, gt_p],
        scores=np.ones(gt_t.size),
        extra=np.column_stack([np.ones(gt_t.size), gt_vis]),
    )


def _true_detections(
    camera: PinholeCamera,
    boxes: np.ndarray,
    seen: np.ndarray,
    occluded: np.ndarray,
    signatures: np.ndarray,
    cfg: DetectorConfig,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The detections of the persons: frame index ``(K,)``, person index ``(K,)``, noisy
    boxes ``(K, 4)``, scores ``(K,)`` and appearance features ``(K, D)``."""
    n_t, n_p, dim = boxes.shape[0], boxes.shape[1], signatures.shape[1]
    # True detections. Draws are made for every (frame, person) so that they do not depend on
    # which people happen to be visible.
    u_miss = rng.random((n_t, n_p))
    e_centre = rng.standard_normal((n_t, n_p, 2))
    e_size = rng.standard_normal((n_t, n_p, 2))
    e_score = rng.standard_normal((n_t, n_p))
    e_app = rng.standard_normal((n_t, n_p, dim))
    hit = seen & (occluded <= cfg.occlusion_threshold) & (u_miss >= cfg.miss_rate)
    ht, hp = np.nonzero(hit)
    b = boxes[ht, hp]
    size = b[:, 2:]
    new_size = size * np.exp(cfg.size_noise * e_size[ht, hp])  # s' = s exp(ε_s)
    shift = cfg.centre_noise * size * e_centre[ht, hp]  # ε_c ~ N(0, (σ_c s)^2)
    corner = b[:, :2] + shift - (new_size - size) / 2  # keeps the centre at c + ε_c
    det_boxes = _clip_boxes(np.column_stack([corner, new_size]), camera)
    keep = (det_boxes[:, 2] >= MIN_BOX_PX) & (det_boxes[:, 3] >= MIN_BOX_PX)
    ht, hp, det_boxes = ht[keep], hp[keep], det_boxes[keep]
    true_scores = cfg.score_mean[0] + cfg.score_std[0] * e_score[ht, hp]
    noise = cfg.appearance_noise * e_app[ht, hp] / math.sqrt(dim)
    true_app = _unit(signatures[hp] + noise)  # normalise(a_p + σ n / sqrt(D))
    return ht, hp, det_boxes, true_scores, true_app


def _false_alarms(
    camera: PinholeCamera, n_t: int, cfg: DetectorConfig, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Poisson false alarms: frame index ``(K,)``, boxes ``(K, 4)`` of a head's size at a
    random depth, scores ``(K,)`` and random appearance features ``(K, D)``."""
    dim = cfg.appearance_dim
    n_fa = rng.poisson(cfg.false_alarm_rate, n_t)
    fa_t = np.repeat(np.arange(n_t), n_fa)
    k = fa_t.size
    fa_depth = rng.uniform(*cfg.false_alarm_depth, k)
    fa_w = np.minimum(camera.fx * cfg.head_size[0] / fa_depth, camera.width)
    fa_h = np.minimum(camera.fy * cfg.head_size[1] / fa_depth, camera.height)
    fa_left = rng.random(k) * (camera.width - fa_w)
    fa_top = rng.random(k) * (camera.height - fa_h)
    fa_boxes = np.column_stack([fa_left, fa_top, fa_w, fa_h])
    fa_scores = cfg.score_mean[1] + cfg.score_std[1] * rng.standard_normal(k)
    fa_app = _unit(rng.standard_normal((k, dim)))
    return fa_t, fa_boxes, fa_scores, fa_app


def simulate_detections(
    camera: PinholeCamera,
    head_positions: np.ndarray,
    rng: np.random.Generator,
    config: DetectorConfig | None = None,
) -> SimulatedDetections:
    """Detections and ground truth of people's heads seen by ``camera``.

    Parameters
    ----------
    camera : PinholeCamera
    head_positions : ndarray (T, P, 3)
        Head centre of each person in each frame, room frame, metres; a NaN row when a
        person is absent. Person ``p`` (0-based column) gets the id ``p + 1``.
    rng : numpy.random.Generator
        Source of all randomness (signatures, misses, noise, false alarms).
    config : DetectorConfig, optional
        Defaults to ``DetectorConfig()``.

    Returns
    -------
    SimulatedDetections
    """
    cfg, pos = _check_inputs(camera, head_positions, rng, config)
    n_t, n_p, _ = pos.shape
    dim = cfg.appearance_dim

    signatures = _unit(rng.standard_normal((n_p, dim)))  # a_p, one per person

    boxes, seen, occluded = _head_boxes(camera, pos, cfg)
    gt = _ground_truth(boxes, seen, occluded)
    ht, hp, det_boxes, true_scores, true_app = _true_detections(
        camera, boxes, seen, occluded, signatures, cfg, rng
    )
    fa_t, fa_boxes, fa_scores, fa_app = _false_alarms(camera, n_t, cfg, rng)
    k = fa_t.size

    frames = np.concatenate([ht, fa_t]) + 1
    scores = np.clip(np.concatenate([true_scores, fa_scores]), 1e-3, 1.0)
    order = np.lexsort((-scores, frames))  # by frame, then decreasing score
    det = MOTData(
        frames=frames[order],
        ids=-np.ones(order.size, dtype=np.int64),
        boxes=np.concatenate([det_boxes, fa_boxes])[order],
        scores=scores[order],
        extra=-np.ones((order.size, 3)),
    )
    appearance = np.concatenate([true_app, fa_app]).reshape(-1, dim)[order]
    det_person = np.concatenate([hp + 1, -np.ones(k, dtype=np.int64)])[order]
    return SimulatedDetections(det, appearance, gt, det_person)


def _clip_boxes(boxes: np.ndarray, camera: PinholeCamera) -> np.ndarray:
    """Clip ``(left, top, width, height)`` boxes to the image; empty results get size <= 0.

    Coordinates already inside the image are returned bit-for-bit unchanged.
    """
    out = np.array(boxes, dtype=float)
    for k, limit in ((0, float(camera.width)), (1, float(camera.height))):
        low = out[:, k] < 0
        out[low, k + 2] += out[low, k]  # move the near edge to 0
        out[low, k] = 0.0
        high = out[:, k] + out[:, k + 2] > limit
        out[high, k + 2] = limit - out[high, k]
    return out
