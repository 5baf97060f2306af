r"""OVBT: online variational-Bayesian visual multi-person tracking (thesis §3.1).

Per frame: VEM on the box observation model (engine, thesis eqs. 2.22–2.29 / 3.20–3.29),
then the visibility HMM (eqs. 3.31–3.32), death after ``death_frames`` invisible frames
(§3.1.4), and birth from smooth sequences of clutter-assigned detections (eq. 3.30).
Sleeping (invisible) targets stay in the engine, so a matching appearance can wake them up.
Weak detections (below the running split of the detector's scores) follow targets but start
none, and a second visibility filter, on the evidence of the strong ones, decides which
targets are shown (``OVBTConfig.weak_evidence``; not in the thesis, which uses no scores).

Example
-------
>>> from avtrack.visual.ovbt import OVBTracker
>>> tracker = OVBTracker(image_size=(640, 480))
>>> for boxes, scores in frames:            # boxes (M, 4) left, top, width, height
...     out = tracker.step(boxes, scores)   # out.ids (K,), out.boxes (K, 4)
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from avtrack.io.mot import MOTData
from avtrack.vem.birth import (
    BirthCandidate,
    birth_candidates,
    born_states,
    consume_pool,
    select_births,
)
from avtrack.vem.dynamics import (
    box_dynamics_covariance,
    box_dynamics_variance,
    cap_box_scale,
    constant_velocity_transition,
)
from avtrack.vem.engine import VEMEngine
from avtrack.vem.targets import ManagedTargets, PerTarget, births_outside
from avtrack.vem.visibility import windowed_visibility_step
from avtrack.visual.appearance import APPEARANCE_MODELS, AppearanceLikelihood
from avtrack.visual.camera_motion import IDENTITY, apply_motion, compose_motions, warp_boxes
from avtrack.visual.model import (
    BOX_DIM,
    BoxObservationModel,
    BoxObservations,
    box_observation_variance,
    ltwh_to_xywh,
    xywh_to_ltwh,
)
from avtrack.visual.scores import ScoreSplit

#: frame rate (frames/s) at which OVBTConfig's per-frame motion parameters are given
REFERENCE_FPS = 25.0


@dataclass(frozen=True)
class OVBTConfig:
    """Parameters of the visual tracker (one default configuration for all sequences).

    Noise levels are standard deviations as fractions of the box size (thesis §3.1.5 scales
    the covariances with the detected box; see :func:`box_observation_variance`).
    """

    n_iter: int = 3  #: VEM iterations per frame
    obs_std_pos: float = 0.1  #: Φ: centre std / box size
    obs_std_size: float = 0.1  #: Φ: size std / box size
    dyn_std_pos: float = 0.05  #: Λ: centre std per frame / box size
    dyn_std_size: float = 0.03  #: Λ: size std per frame / box size
    dyn_std_vel: float = 0.02  #: Λ: velocity std per frame / box size
    #: the velocity std is given at REFERENCE_FPS and scaled by (REFERENCE_FPS / fps) ** this
    vel_rate_exponent: float = 0.5
    update_priors: bool = True  #: M-step of the assignment priors, eq. 3.29
    marginal_init: bool = True  #: first E-Z step with the predictive marginal, eq. 2.8
    exclusive: bool = True  #: a target explains at most one detection per frame
    max_state_std: float = 0.5  #: cap on every state std / box size (coasting tracks)
    dynamics_mstep: bool = False  #: M-step of Λ, eq. 2.27 (thesis §3.1.3 keeps Λ size-based)
    birth_frames: int = 2  #: B of eq. 3.30 (sequences of B + 1 detections)
    birth_threshold: float = 0.0  #: birth when the log-likelihood ratio exceeds this
    birth_velocity_std: float = 0.05  #: prior velocity std at birth / box size, per frame
    birth_gate: float = 18.47  #: χ²₄(0.999) gate on each innovation of a birth sequence
    #: at frame 1, every detection starts a target (no history to score eq. 3.30 against);
    #: then, before frame B + 1, births from all the frames so far
    startup_birth: bool = True
    birth_max_overlap: float = 0.5  #: reject a birth whose box lies this much inside a target's
    visibility_stay: float = 0.9  #: π_v of the visibility HMM
    visibility_lambda: float = 1.0  #: λ of eq. 3.32
    visibility_window: int = 2  #: frames summed into the visibility evidence ν
    death_frames: int = 10  #: delete a target invisible this many frames (thesis: 10)
    min_score: float = 0.0  #: drop detections with a lower confidence
    #: detections below this confidence only update existing targets, never start one
    #: (None: the running Otsu split of the scores, :mod:`avtrack.visual.scores`)
    birth_min_score: float | None = None
    birth_score_split: bool = True  #: use that split when ``birth_min_score`` is None
    #: weight of such a weak detection in the visibility evidence that shows a target (output);
    #: death still counts every detection, so a target followed through weak detections is
    #: kept, unshown (1: weak detections show targets as strong ones do)
    weak_evidence: float = 0.2
    appearance: str = "bhattacharyya"  #: "bhattacharyya" (histograms) or "cosine" (embeddings)
    appearance_lambda: float = 10.0  #: λ of eq. 3.5 (or κ for "cosine")
    appearance_update: float = 0.1  #: reference-appearance update rate (0: birth appearance)
    #: re-identification: a newborn whose appearance log-ratio (eq. 3.5) against a target that
    #: died at most ``reid_max_age`` frames ago exceeds this, and whose box centre lies within
    #: ``reid_max_distance`` box widths of where that target was, takes its identity (None: off)
    reid_log_ratio: float | None = None
    reid_max_age: int = 50
    reid_max_distance: float = 3.0
    #: :func:`track_mot` (the batch helper, not :meth:`OVBTracker.step`) also reports each
    #: newborn over the earlier frames of its birth sequence (eq. 3.30), at the detections the
    #: birth was inferred from: the model's estimate that the person was there, which an
    #: online output can only give B frames late
    birth_sequence: bool = True
    #: with the video's frames: the camera's motion between frames, estimated from the
    #: background (:mod:`avtrack.visual.camera_motion`), joins the prediction as a control
    #: term (eq. 3.34), as the robot head's ego-motion does (False: a still camera assumed)
    compensate_camera: bool = True

    def __post_init__(self) -> None:
        positive = ("obs_std_pos", "obs_std_size", "dyn_std_pos", "dyn_std_size",
                    "dyn_std_vel", "max_state_std", "birth_max_overlap", "birth_velocity_std",
                    "birth_gate", "visibility_lambda", "appearance_lambda",
                    "reid_max_distance")
        for name in positive:
            v = getattr(self, name)
            if not (isinstance(v, int | float) and np.isfinite(v) and v > 0):
                raise ValueError(f"OVBTConfig.{name} must be a positive number, got {v!r}")
        for name in ("n_iter", "birth_frames", "visibility_window", "death_frames",
                     "reid_max_age"):
            v = getattr(self, name)
            if not (isinstance(v, int) and v >= 1):
                raise ValueError(f"OVBTConfig.{name} must be an integer >= 1, got {v!r}")
        if not 0 < self.visibility_stay < 1:
            raise ValueError(f"OVBTConfig.visibility_stay must be in (0, 1), "
                             f"got {self.visibility_stay!r}")
        if self.appearance not in APPEARANCE_MODELS:
            raise ValueError(f"OVBTConfig.appearance must be one of "
                             f"{sorted(APPEARANCE_MODELS)}, got {self.appearance!r}")
        if not (isinstance(self.vel_rate_exponent, int | float)
                and 0 <= self.vel_rate_exponent <= 2):
            raise ValueError(f"OVBTConfig.vel_rate_exponent must be in [0, 2], "
                             f"got {self.vel_rate_exponent!r}")
        if not (isinstance(self.weak_evidence, int | float) and 0 <= self.weak_evidence <= 1):
            raise ValueError(f"OVBTConfig.weak_evidence must be in [0, 1], "
                             f"got {self.weak_evidence!r}")
        if not 0 <= self.appearance_update <= 1:
            raise ValueError(f"OVBTConfig.appearance_update must be in [0, 1], "
                             f"got {self.appearance_update!r}")
        if self.reid_log_ratio is not None and not (
            isinstance(self.reid_log_ratio, int | float) and np.isfinite(self.reid_log_ratio)
        ):
            raise ValueError(f"OVBTConfig.reid_log_ratio must be a finite number or None, got "
                             f"{self.reid_log_ratio!r}")
        if not isinstance(self.birth_sequence, bool):
            raise ValueError(f"OVBTConfig.birth_sequence must be true or false, got "
                             f"{self.birth_sequence!r}")


@dataclass(frozen=True)
class FrameTracks:
    """Tracks output for one frame.

    Attributes
    ----------
    ids : ndarray (K,) int
        Identities (≥ 1) of the shown targets (visible on the strong detections' evidence).
    boxes : ndarray (K, 4)
        (left, top, width, height) from the posterior means.
    p_visible : ndarray (K,)
        Visibility posterior of each output track.
    """

    ids: np.ndarray
    boxes: np.ndarray
    p_visible: np.ndarray = field(default_factory=lambda: np.zeros(0))


class OVBTracker(ManagedTargets):
    """Online visual multi-person tracker (thesis §3.1) on the VEM engine.

    Parameters
    ----------
    config : OVBTConfig, optional
    image_size : (width, height)
        Sets the clutter density :math:`u(o) = 1/(W H W H)` over box centre and size.
    fps : float, optional
        Frame rate of the sequence (None: :data:`REFERENCE_FPS`). The per-frame size noise
        and birth velocity prior of :class:`OVBTConfig` are given at :data:`REFERENCE_FPS`
        and scaled by ``k = REFERENCE_FPS / fps``, the velocity noise by
        ``k ** vel_rate_exponent``: a person's size change, displacement and change of pace per
        frame grow with the time between frames.
    """

    def __init__(self, config: OVBTConfig | None = None, image_size: tuple[int, int] = (
            1920, 1080), fps: float | None = None):
        self.config = config or OVBTConfig()
        w, h = image_size
        if not (w > 0 and h > 0):
            raise ValueError(f"image_size must be positive (width, height), got {image_size}")
        if fps is not None and not (isinstance(fps, int | float) and np.isfinite(fps)
                                    and 0 < fps <= 1000):
            raise ValueError(f"fps must be a frame rate in (0, 1000], got {fps!r}")
        self.fps = float(REFERENCE_FPS if fps is None else fps)
        per_frame = REFERENCE_FPS / self.fps
        self._dyn_std_pos = self.config.dyn_std_pos
        self._dyn_std_size = self.config.dyn_std_size * per_frame
        self._dyn_std_vel = self.config.dyn_std_vel * per_frame ** self.config.vel_rate_exponent
        self._birth_velocity_std = self.config.birth_velocity_std * per_frame
        self.image_size = (float(w), float(h))
        self.log_clutter = -2.0 * np.log(float(w) * float(h))  # u(o): uniform centre and size
        cfg = self.config
        self._appearance: AppearanceLikelihood = APPEARANCE_MODELS[cfg.appearance](
            cfg.appearance_lambda)
        self.model = BoxObservationModel(self.log_clutter, self._appearance,
                                         cfg.appearance_update)
        self.transition = constant_velocity_transition(BOX_DIM, 2)
        self.engine = VEMEngine(self.transition, [self.model], n_iter=cfg.n_iter,
                                update_priors=cfg.update_priors,
                                dynamics_mstep=cfg.dynamics_mstep,
                                marginal_init=cfg.marginal_init, exclusive=cfg.exclusive)
        self.p_visible: np.ndarray
        self.invisible_run: np.ndarray
        self.mass_history: np.ndarray
        self.p_shown: np.ndarray
        self.shown_history: np.ndarray
        self._init_targets()
        self._pool: deque[BoxObservations] = deque(maxlen=cfg.birth_frames + 1)
        #: per pool frame, the camera's motion from that frame to the latest ``(2, 3)`` (None:
        #: none), so that births read the older detections where the camera sees them now
        self._pool_motion: deque[np.ndarray | None] = deque(maxlen=cfg.birth_frames + 1)
        self._has_appearance: bool | None = None
        self._score_split = ScoreSplit()
        # targets ended lately, for re-identification: id -> (frame, (x, y, w), reference)
        self._ended: dict[int, tuple[int, np.ndarray, np.ndarray]] = {}
        self.frame = 0
        #: with ``record_births`` set (by :func:`track_mot`, which adds them to its results at
        #: the end), each newborn's earlier birth frames as (frame, id, box (x, y, w, h))
        self.record_births = False
        self.birth_rows: list[tuple[int, int, np.ndarray]] = []

    def _dyn_cov(self, mu: np.ndarray) -> np.ndarray:
        return box_dynamics_covariance(mu, self._dyn_std_pos, self._dyn_std_size,
                                       self._dyn_std_vel)

    def _dyn_var(self, mu: np.ndarray) -> np.ndarray:
        return box_dynamics_variance(mu, self._dyn_std_pos, self._dyn_std_size,
                                     self._dyn_std_vel)

    def _velocity_var(self, z: np.ndarray) -> np.ndarray:
        return (self._birth_velocity_std * np.maximum(z[:, 2:4].copy(), 1.0)) ** 2

    def _observations(self, boxes, scores, appearance) -> BoxObservations:
        boxes = np.asarray(boxes, dtype=float).reshape(-1, 4)
        m = boxes.shape[0]
        if not np.isfinite(boxes).all():
            raise ValueError("boxes must be finite")
        if m and not (boxes[:, 2:] > 0).all():
            raise ValueError("box width and height must be > 0")
        keep = np.ones(m, dtype=bool)
        if scores is not None:
            scores = np.asarray(scores, dtype=float).reshape(-1)
            if scores.shape[0] != m:
                raise ValueError(f"got {scores.shape[0]} scores for {m} boxes")
            if not np.isfinite(scores).all():
                raise ValueError("scores must be finite")
            keep = scores >= self.config.min_score
            scores = scores[keep]
        kept = boxes if np.count_nonzero(keep) == m else boxes[keep]
        app = None
        if appearance is not None:
            app = np.asarray(appearance, dtype=float)
            if m == 0:  # an empty frame: keep the descriptor length known so far
                refs = self.model.references
                app = np.zeros((0, app.shape[-1] if app.ndim == 2 else
                                (0 if refs is None else refs.shape[1])))
            app = app.reshape(m, app.shape[-1] if app.ndim == 2 else -1)  # (0, F) when m = 0
            if not np.all(np.isfinite(app)):
                raise ValueError("appearance descriptors must be finite")
            app = self._appearance.normalize(app[keep])
        has = app is not None
        if self._has_appearance is None:
            self._has_appearance = has
        elif self._has_appearance != has:
            raise ValueError("appearance descriptors must be given for every frame or none")
        z = ltwh_to_xywh(kept)
        var = box_observation_variance(z, self.config.obs_std_pos, self.config.obs_std_size)
        return BoxObservations(z, var, app, scores)

    def _frame_observations(self, dets: MOTData, appearance: np.ndarray | None,
                            n_frames: int | None) -> Iterator[BoxObservations]:
        """What :meth:`_observations` gives for each frame ``1..n_frames`` of ``dets``,
        computed for all rows at once (``appearance``: one row per detection, or None), frame
        after frame."""
        n = dets.n_frames if n_frames is None else n_frames
        if n <= 0:
            return iter(())
        # first row of each frame 1..n + 1 (as MOTData.frame_slices, without the slices)
        bounds = np.searchsorted(dets.frames, np.arange(1, n + 2), side="left")
        lo, hi = int(bounds[0]), int(bounds[-1])
        first = self._observations(dets.boxes[lo:hi], dets.scores[lo:hi],
                                   None if appearance is None else appearance[lo:hi])
        # row index in ``first`` of each frame's start: detections below min_score are dropped
        kept = np.zeros(hi - lo + 1, dtype=np.int64)
        np.cumsum(dets.scores[lo:hi] >= self.config.min_score, out=kept[1:])
        return first.iter_split(kept[bounds - lo].tolist())

    def step(self, boxes: np.ndarray, scores: np.ndarray | None = None,
             appearance: np.ndarray | None = None) -> FrameTracks:
        """Process one frame of detections.

        Parameters
        ----------
        boxes : ndarray (M, 4)
            (left, top, width, height), pixels.
        scores : ndarray (M,), optional
            Detection confidences (filtered by ``config.min_score``).
        appearance : ndarray (M, F), optional
            Colour histograms or embeddings, per the configured appearance model.

        Returns
        -------
        FrameTracks
            The visible targets after this frame.
        """
        ids, centre_boxes, p_visible = self._step(self._observations(boxes, scores, appearance))
        return FrameTracks(ids, xywh_to_ltwh(centre_boxes), p_visible)

    def _step(self, obs: BoxObservations, motion: np.ndarray | None = None,
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`step` on prepared observations; returns the shown targets' ids ``(K,)``,
        boxes ``(K, 4)`` as (x, y, w, h) and visibility posteriors ``(K,)``. ``motion``: the
        camera's motion ``(2, 3)`` from the previous frame's pixels to this frame's
        (:mod:`avtrack.visual.camera_motion`), or None for a still camera."""
        cfg = self.config
        self.frame += 1
        eng = self.engine
        scores = obs.scores
        if scores is not None and self._splits:
            self._score_split.add(scores)
        strong: np.ndarray | None = None  # (M,): detections that may start or show a target
        # --- VEM on the existing targets ---------------------------------------------------
        moved = None if motion is None or np.array_equal(motion, IDENTITY) else motion
        if moved is not None:
            self._pool_motion = deque((moved if m is None else compose_motions(moved, m)
                                       for m in self._pool_motion),
                                      maxlen=self._pool_motion.maxlen)
        if eng.n_targets:
            control = None
            if moved is not None:
                # the camera's motion as the control term c_tn of eq. 3.34: the prediction
                # D μ seen through it, minus D μ
                pred = eng.mu @ eng.transition.T
                control = apply_motion(moved, pred) - pred
            inf = eng.step([obs], self._dyn_var(eng.mu), control)  # Λ is diagonal
            # cap_box_covariance on the engine's states, when some std exceeds its cap
            scale = cap_box_scale(eng.mu, eng.variances, cfg.max_state_std)
            if scale.ravel()[scale.argmin()] < 1.0:
                eng.scale_covariances(scale)
            resp, mass = inf.responsibilities[0], inf.mass[0][1:]
            unassigned = (resp.argmax(axis=1) == 0).nonzero()[0]
            # --- visibility (eqs. 3.31–3.32) and death (§3.1.4) ---------------------------
            self.p_visible, self.mass_history = self._visibility(
                self.p_visible, self.mass_history, mass)
            if cfg.weak_evidence < 1.0 and scores is not None:
                strong = self._strong(scores)
                # ν from the strong detections and a share of the weak ones: what shows a target
                shown_mass = np.where(strong, 1.0, cfg.weak_evidence).dot(resp)[1:]
                self.p_shown, self.shown_history = self._visibility(
                    self.p_shown, self.shown_history, shown_mass)
            else:
                self.p_shown = self.p_visible
            run = self.invisible_run + 1
            run[self.p_visible > 0.5] = 0  # frames invisible in a row
            self.invisible_run = run
            keep = self.invisible_run < cfg.death_frames
            if np.count_nonzero(keep) < keep.shape[0]:
                self._remove(keep)
        else:
            unassigned = np.arange(len(obs))
        # --- birth (eq. 3.30) ----------------------------------------------------------------
        if scores is not None and unassigned.shape[0]:  # weak detections only update targets
            if strong is None:
                strong = self._strong(scores)
            unassigned = unassigned[strong[unassigned]]
        self._add_to_pool(obs if unassigned.shape[0] == len(obs) else obs.subset(unassigned))
        # Birth over the last B + 1 frames; at the start of a sequence, over all frames so far,
        # so that the people present from the first frame are not held back.
        if len(self._pool) == cfg.birth_frames + 1 or (
                cfg.startup_birth and len(self._pool) == self.frame >= 2):
            self._birth()
        elif cfg.startup_birth and self.frame == 1:
            self._first_frame_birth()
        shown = self.p_shown > 0.5
        return eng.ids[shown], eng.mu[shown, :BOX_DIM], self.p_shown[shown]

    def _visibility(self, p_visible: np.ndarray, history: np.ndarray,
                    mass: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The visibility filter's step (eqs. 3.31–3.32) from the targets' assigned ``mass``
        ``(N,)``: the new posterior ``(N,)`` and the evidence window ``(N, window)``."""
        cfg = self.config
        return windowed_visibility_step(p_visible, history, mass, cfg.visibility_stay,
                                        cfg.visibility_lambda)

    @property
    def _splits(self) -> bool:
        """Whether the running score split tells weak detections (see OVBTConfig)."""
        return self.config.birth_min_score is None and self.config.birth_score_split

    def _strong(self, scores: np.ndarray) -> np.ndarray:
        """``(M,)``: which of the frame's detections, with ``scores (M,)``, are strong (may start
        a target, count fully in the evidence that shows one); the split has their scores."""
        cfg = self.config
        if cfg.birth_min_score is not None:
            return scores >= cfg.birth_min_score
        if cfg.birth_score_split:
            return self._score_split.may_start(scores)
        return np.ones(scores.shape[0], dtype=bool)

    def _can_birth(self, scores: np.ndarray) -> np.ndarray:
        """``(M,)``: which of a frame's detections may start a target (see OVBTConfig); adds
        the frame's scores to the split (for subclasses with their own frame step)."""
        if self._splits:
            self._score_split.add(scores)
        return self._strong(scores)

    def _per_target(self) -> tuple[PerTarget, ...]:
        """Visibility posterior, frames invisible in a row, visibility evidence window."""
        window = (self.config.visibility_window,)
        return (
            PerTarget("p_visible", 1.0),
            PerTarget("invisible_run", 0, dtype=np.int64),
            PerTarget("mass_history", 1.0, window),
            PerTarget("p_shown", 1.0),
            PerTarget("shown_history", 1.0, window),
        )

    def _remove(self, keep: np.ndarray) -> None:
        refs = self.model.references
        if self.config.reid_log_ratio is not None and refs is not None:
            for i in np.flatnonzero(~keep):
                self._ended[int(self.engine.ids[i])] = (
                    self.frame, self.engine.mu[i, :3].copy(), refs[i].copy())
        super()._remove(keep)

    def _add_to_pool(self, obs: BoxObservations) -> None:
        """This frame's detections that no target took, as the birth pool's newest frame."""
        self._pool.append(obs)
        self._pool_motion.append(None)  # (no camera motion since this frame yet)

    def _birth(self) -> None:
        cfg = self.config
        if 0 in [p.z.shape[0] for p in self._pool]:
            return  # every sequence needs one detection per pool frame
        pools = [(p.z, p.var) if m is None else warp_boxes(m, p.z, p.var)
                 for p, m in zip(self._pool, self._pool_motion, strict=True)]
        cands = birth_candidates(pools, self.transition, self._dyn_cov, self._velocity_var,
                                 self.log_clutter, gate=cfg.birth_gate,
                                 dynamics_var=self._dyn_var)
        cands = births_outside(cands, lambda mu: xywh_to_ltwh(mu[:, :BOX_DIM]),
                               xywh_to_ltwh(self.engine.mu[:, :BOX_DIM]), cfg.birth_max_overlap)
        self._add_born(select_births(cands, cfg.birth_threshold))

    def _reidentify(self, ids: np.ndarray, mu: np.ndarray, refs: np.ndarray) -> np.ndarray:
        """Newborns that look like (eq. 3.5) and stand near a target ended lately take its id
        (greedy, best log-ratio first)."""
        cfg = self.config
        self._ended = {k: v for k, v in self._ended.items()
                       if self.frame - v[0] <= cfg.reid_max_age}
        if not self._ended:
            return ids
        keys = list(self._ended)
        old = np.stack([self._ended[k][2] for k in keys])
        where = np.stack([self._ended[k][1] for k in keys])  # (x, y, w) when it ended
        score = self._appearance.log_ratio(refs, old)  # (k_new, k_old)
        dist = np.hypot(mu[:, None, 0] - where[None, :, 0], mu[:, None, 1] - where[None, :, 1])
        score[dist > cfg.reid_max_distance * where[None, :, 2]] = -np.inf
        ids = ids.copy()
        while score.size and score.max() > cfg.reid_log_ratio:
            i, j = np.unravel_index(int(np.argmax(score)), score.shape)
            ids[i] = keys[j]
            del self._ended[keys[j]]
            score[i, :] = -np.inf
            score[:, j] = -np.inf
        return ids

    def _first_frame_birth(self) -> None:
        """Frame 1 has no history for eq. 3.30 to score, so each detection starts a target at
        the detected box with the birth velocity prior (as SORT outputs its unconfirmed tracks
        over the first frames; the detector's non-maximum suppression has removed duplicates).
        A false detection makes a target that the visibility HMM soon puts to sleep."""
        obs = self._pool[0]
        vel_var = self._velocity_var(obs.z)  # (M, d - 4)
        mu = np.hstack([obs.z, np.zeros_like(vel_var)])
        gamma = np.zeros((len(obs), mu.shape[1], mu.shape[1]))
        diag = np.arange(mu.shape[1])
        gamma[:, diag, diag] = np.hstack([obs.var, vel_var])
        self._add_born([BirthCandidate(np.array([m]), 0.0, mu[m], gamma[m])
                        for m in range(len(obs))])

    def _add_born(self, born: list[BirthCandidate]) -> None:
        """Add the chosen sequences as new targets and take them out of the birth pool."""
        if not born:
            return
        ids = self._new_ids(len(born))
        mu, gamma, init = born_states(born, self._pool[-1].appearance)
        if self.config.reid_log_ratio is not None and init is not None and self._ended:
            ids = self._reidentify(ids, mu, init)
        # the box model gets the appearances; any other model of a subclass (VAVIT) none
        self._add_targets(ids, mu, gamma, [init] + [None] * (len(self.engine.models) - 1))
        if self.record_births:
            first = self.frame - len(self._pool) + 1  # the pool's oldest frame
            for tid, b in zip(ids.tolist(), born, strict=True):
                for f, idx in enumerate(b.indices[:-1].tolist()):  # the last is this frame
                    self.birth_rows.append(
                        (first + f, int(tid), self._pool[f].z[idx, :BOX_DIM].copy()))
        consume_pool(self._pool, born)  # no longer available to other births


def image_size_from_detections(dets: MOTData) -> tuple[int, int]:
    """Smallest (width, height) containing every box (a fallback when the size is unknown)."""
    if len(dets) == 0:
        return (1, 1)
    right = dets.boxes[:, 0] + dets.boxes[:, 2]
    bottom = dets.boxes[:, 1] + dets.boxes[:, 3]
    return (int(np.ceil(max(right.max(), 1.0))), int(np.ceil(max(bottom.max(), 1.0))))


#: Frames of results :func:`track_mot` gathers into one array per column.
_ROWS_BATCH = 512


def track_mot(
    dets: MOTData, appearance: np.ndarray | None = None, config: OVBTConfig | None = None,
    image_size: tuple[int, int] | None = None, n_frames: int | None = None,
    fps: float | None = None, motion: np.ndarray | None = None,
) -> MOTData:
    """Track a whole MOTChallenge detection sequence (batch helper around :class:`OVBTracker`).

    Parameters
    ----------
    dets : MOTData
        Detections, sorted by frame.
    appearance : ndarray (K, F), optional
        One descriptor per detection row.
    config : OVBTConfig, optional
    image_size : (width, height), optional
        Defaults to the extent of the detections.
    n_frames : int, optional
        Sequence length (defaults to the last detected frame).
    fps : float, optional
        Frame rate (None: :data:`REFERENCE_FPS`; see :class:`OVBTracker`).
    motion : ndarray (n_frames, 2, 3), optional
        The camera's motion into each frame from the previous one
        (:mod:`avtrack.visual.camera_motion`); used when ``config.compensate_camera``.

    Returns
    -------
    MOTData
        Results (confidence = visibility posterior; 1 on the rows of a birth sequence's
        earlier frames, ``config.birth_sequence``).
    """
    if appearance is not None:
        appearance = np.asarray(appearance, dtype=float)
        if appearance.ndim != 2 or appearance.shape[0] != len(dets):
            raise ValueError(f"appearance must have one row per detection ({len(dets)}), got "
                             f"shape {appearance.shape}")
    tracker = OVBTracker(config, image_size or image_size_from_detections(dets), fps)
    tracker.record_births = tracker.config.birth_sequence
    rows: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []  # ids, boxes, confidences
    done: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    counts: list[int] = []
    if motion is not None:
        motion = np.asarray(motion, dtype=float)
        if motion.ndim != 3 or motion.shape[1:] != (2, 3):
            raise ValueError(f"motion must be (n_frames, 2, 3), got shape {motion.shape}")
        if not tracker.config.compensate_camera:
            motion = None
    for k, obs in enumerate(tracker._frame_observations(dets, appearance, n_frames)):
        out = tracker._step(obs, None if motion is None or k >= len(motion) else motion[k])
        rows.append(out)
        counts.append(len(out[0]))
        if len(rows) == _ROWS_BATCH:  # one array per column, not thousands of small ones
            done.append(_stack(rows))
            rows = []
    if not counts:
        return MOTData(np.zeros(0), np.zeros(0), np.zeros((0, 4)), np.zeros(0))
    ids, boxes, conf = _stack([*done, *rows])
    frames = np.repeat(np.arange(1, len(counts) + 1), counts)
    if tracker.birth_rows:
        frames, ids, boxes, conf = _with_birth_rows(frames, ids, boxes, conf,
                                                    tracker.birth_rows)
    return MOTData(frames, ids, xywh_to_ltwh(boxes), conf)


def _with_birth_rows(
    frames: np.ndarray, ids: np.ndarray, boxes: np.ndarray, conf: np.ndarray,
    births: list[tuple[int, int, np.ndarray]],
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The results with the birth sequences' earlier frames (:attr:`OVBTracker.birth_rows`)
    added, each after its frame's own rows; a (frame, id) already reported is kept as it is."""
    have = set(zip(frames.tolist(), ids.tolist(), strict=True))
    new = [(f, i, b) for f, i, b in births if (f, i) not in have]
    if not new:
        return frames, ids, boxes, conf
    frames = np.concatenate([frames, [f for f, _, _ in new]])
    ids = np.concatenate([ids, [i for _, i, _ in new]])
    boxes = np.vstack([boxes, np.stack([b for _, _, b in new])])
    conf = np.concatenate([conf, np.ones(len(new))])
    order = np.argsort(frames, kind="stable")
    return frames[order], ids[order], boxes[order], conf[order]


def _stack(
    rows: list[tuple[np.ndarray, np.ndarray, np.ndarray]],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ids, boxes and confidences of consecutive frames, each column in one array."""
    return (np.concatenate([r[0] for r in rows]), np.vstack([r[1] for r in rows]),
            np.concatenate([r[2] for r in rows]))
