r"""3-D multi-person tracking on a moving robot head with ego-motion compensation
(thesis §3.2.2–3.2.3).

State per person :math:`s_{tn} = [X_{tn}, W_{tn}, \dot X_{tn}]` (position in the current
left-camera frame, face box size in pixels, velocity in m/s), dynamics

.. math::
    p(s_{tn}|s_{t-1,n}) = \mathcal{N}(s_{tn}; D s_{t-1,n} + C_{tn}, \Lambda_n)
    \quad\text{(eq. 3.34)},\qquad
    D = \begin{pmatrix} I_3 & 0 & \Delta t I_3\\ 0 & I_2 & 0\\ 0 & 0 & I_3\end{pmatrix}

with the control term :math:`C_{tn}` of :mod:`avtrack.robot.egomotion` (eq. 3.45), and
observations :math:`o_{tm} = [X_{tm}, W_{tm}]` from the stereo pair (:func:`stereo_faces`)
with full covariances :math:`\Phi_{tm}` and an appearance descriptor. Each frame runs the VEM
engine (:class:`~avtrack.vem.engine.VEMEngine`): E-Z as eq. 3.20, E-S as eqs.
3.37–3.38 -- the engine's prediction :math:`(D\mu + C, \Lambda + D\Gamma D^\top)` with the
control term is exactly the prior part of eqs. 3.37–3.38 -- then, as in
:class:`~avtrack.visual.ovbt.OVBTracker`, the visibility HMM (eqs. 3.31–3.32), death, and
birth from smooth sequences of unassigned observations (eq. 3.30, window :math:`T_{new}=4`).

Targets that the head has turned away from stay in the engine: their predicted position
leaves the field of view (thanks to :math:`C_{tn}`), they are not counted as missed there and
are picked up again, with their identity, when the head comes back (thesis §3.2.6). With
``control="none"`` (the "w/o" rows of thesis Table 3.3) the tracker ignores the head motion:
no :math:`C_{tn}`, and the birth window is not motion-compensated either.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from avtrack.robot.base import OBS_DIM, STATE_DIM, FaceObservations, HeadMotion, TrackedPeople
from avtrack.robot.egomotion import control_vector, ego_displacement_scale
from avtrack.robot.head import RobotHead
from avtrack.vem.birth import (
    birth_candidates,
    born_states,
    consume_pool,
    select_births,
)
from avtrack.vem.dynamics import constant_velocity_transition
from avtrack.vem.engine import VEMEngine
from avtrack.vem.model import ObservationModel
from avtrack.vem.targets import ManagedTargets, PerTarget, births_outside
from avtrack.vem.visibility import visibility_filter
from avtrack.visual.appearance import (
    APPEARANCE_MODELS,
    AppearanceLikelihood,
    init_appearance_model,
)

_LOG_2PI = float(np.log(2 * np.pi))
CONTROL_MODES = ("jacobian", "exact", "none")


class FaceObservationModel(ObservationModel):
    r"""Gaussian 3-D face likelihood with full covariances, clutter and appearance.

    E-Z (thesis eq. 3.20–3.21, as :class:`~avtrack.visual.model.BoxObservationModel` but
    with :math:`P = [I_5\ 0]` on ``[X, W, Ẋ]`` and a full :math:`\Phi_{tm}`):

    .. math::
        \tau_{tmn} = \mathcal{N}(o_{tm}; P\mu_{tn}, \Phi_{tm})
            e^{-\frac12\mathrm{tr}(\Phi_{tm}^{-1}P\Gamma_{tn}P^\top)}\, b(h_{tm}; h_n),\qquad
        \tau_{tm0} = u(o_{tm})\,u(h_{tm}),

    and on the first iteration of a frame the predictive marginal
    :math:`\mathcal{N}(o_{tm}; P\mu_{tn}, P\Gamma_{tn}P^\top + \Phi_{tm})` (eq. 2.8).
    E-S terms (eqs. 3.37–3.38): :math:`\sum_m\alpha_{tmn}P^\top\Phi_{tm}^{-1}P` and
    :math:`\sum_m\alpha_{tmn}P^\top\Phi_{tm}^{-1}o_{tm}`.

    Parameters
    ----------
    log_clutter_density : float
        :math:`\log u(o)` over the observable volume and box sizes.
    appearance : AppearanceLikelihood, optional
    appearance_update : float
        Rate of the reference-appearance update (0 keeps the birth appearance).
    """

    name = "stereo-face"
    log_clutter_density: float
    appearance: AppearanceLikelihood | None
    appearance_update: float
    references: np.ndarray | None  # (N, F)

    def __init__(
        self,
        log_clutter_density: float,
        appearance: AppearanceLikelihood | None = None,
        appearance_update: float = 0.0,
    ):
        init_appearance_model(self, log_clutter_density, appearance, appearance_update)

    def n_observations(self, obs: FaceObservations) -> int:
        return len(obs)

    def log_likelihood(
        self, obs: FaceObservations, mu: np.ndarray, gamma: np.ndarray, marginal: bool = False
    ) -> tuple[np.ndarray, np.ndarray]:
        r = obs.z[:, None, :] - mu[None, :, :OBS_DIM]  # o - Pμ, (M, N, 5)
        pgp = gamma[:, :OBS_DIM, :OBS_DIM]  # P Γ Pᵀ, (N, 5, 5)
        if marginal:  # eq. 2.8: N(o; Pμ, PΓPᵀ + Φ)
            s = obs.cov[:, None] + pgp[None]  # (M, N, 5, 5)
            chol = np.linalg.cholesky(s)
            y = np.linalg.solve(chol, r[..., None])[..., 0]
            maha = np.einsum("mnk,mnk->mn", y, y)
            logdet = 2 * np.log(np.diagonal(chol, axis1=2, axis2=3)).sum(axis=2)
            log_tau = -0.5 * (maha + logdet + OBS_DIM * _LOG_2PI)
        else:  # eq. 3.21: N(o; Pμ, Φ) exp(-½ tr(Φ⁻¹ PΓPᵀ))
            maha = np.einsum("mni,mij,mnj->mn", r, obs.precision, r)
            trace = np.einsum("mij,nji->mn", obs.precision, pgp)
            log_tau = obs.log_normaliser[:, None] - 0.5 * (maha + trace)
        if (
            self.appearance is not None
            and obs.appearance is not None
            and self.references is not None
            and len(self.references) == mu.shape[0]
        ):
            log_tau = log_tau + self.appearance.log_ratio(obs.appearance, self.references)
        return log_tau, np.full(len(obs), self.log_clutter_density)

    def information(
        self, obs: FaceObservations, resp: np.ndarray, dim: int
    ) -> tuple[np.ndarray, np.ndarray]:
        a = resp[:, 1:]  # (M, N), targets only
        n = a.shape[1]
        info = np.zeros((n, dim, dim))
        info[:, :OBS_DIM, :OBS_DIM] = np.einsum("mn,mij->nij", a, obs.precision)  # Σ α PᵀΦ⁻¹P
        vec = np.zeros((n, dim))
        vec[:, :OBS_DIM] = a.T @ obs.info_vector  # Σ_m α_mn Pᵀ Φ_m⁻¹ o_m
        return info, vec

    def add_targets(self, count: int, init: np.ndarray | None = None) -> None:
        if init is None:
            if self.references is not None and count:
                raise ValueError(
                    "new targets need reference appearances: the tracker already has some"
                )
            return
        init = np.asarray(init, dtype=float).reshape(count, -1)
        self.references = (
            init.copy() if self.references is None else np.vstack([self.references, init])
        )

    def remove_targets(self, keep: np.ndarray) -> None:
        if self.references is not None:
            self.references = self.references[keep]

    def update_targets(self, obs: FaceObservations, resp: np.ndarray) -> None:
        if (
            self.appearance_update <= 0
            or self.references is None
            or obs.appearance is None
            or len(obs) == 0
            or self.appearance is None
        ):
            return
        a = resp[:, 1:]
        weight = np.minimum(a.sum(axis=0), 1.0)[:, None]
        new = self.appearance_update * (a.T @ obs.appearance)
        self.references = self.appearance.normalize(
            (1 - self.appearance_update * weight) * self.references + new
        )


@dataclass(frozen=True)
class RobotTrackerConfig:
    """Parameters of :class:`RobotTracker` (standard deviations unless said otherwise).

    The thesis (§3.2.5) sets :math:`\\Phi` and :math:`\\Lambda_n` from the detected box sizes
    and "5 times the motor speed", in unstated units. Here the observation covariances come
    from the stereo geometry (:func:`stereo_faces`) and :math:`\\Lambda_n` is diagonal:
    constant position, size and velocity terms, plus a motor-speed term on the position with
    standard deviation ``dyn_std_motor`` × the ego-motion displacement
    :math:`\\|X\\|\\|\\dot q\\|\\Delta t` (the error of the compensation: the executed joint
    motion differs from the command) and optionally one on the velocity. The same
    :math:`\\Lambda_n` is used with ``control="none"``, which only drops :math:`C_{tn}` (and the
    motion compensation of the birth window).

    Output: a target is reported while it is in the left image and either visible (visibility
    posterior > 0.5, eqs. 3.31–3.32) or unobserved for at most ``coast_frames`` frames
    (its predicted position bridges short detector misses).
    """

    control: str = "jacobian"  #: C_tn: "jacobian" (eq. 3.45), "exact" (eq. 3.48) or "none"
    n_iter: int = 3  #: VEM iterations per frame
    dyn_std_pos: float = 0.03  #: Λ: position, metres per frame
    dyn_std_size: float = 0.05  #: Λ: box size per frame, fraction of the size
    dyn_std_vel: float = 0.05  #: Λ: velocity, m/s per frame
    dyn_std_motor: float = 0.05  #: Λ: position, fraction of the ego-motion ‖X‖‖q̇‖Δt
    dyn_std_motor_vel: float = 0.0  #: Λ: velocity, fraction of the ego-motion speed ‖X‖‖q̇‖
    max_pos_std: float = 0.6  #: cap on the position std (metres) of coasting targets
    max_vel_std: float = 0.6  #: cap on the velocity std (m/s)
    update_priors: bool = False  #: M step of the priors (eq. 3.29); §3.2.2 keeps 1/(N+1)
    marginal_init: bool = True  #: first E-Z step with the predictive marginal (eq. 2.8)
    exclusive: bool = True  #: a person gives at most one face per frame
    depth_range: tuple[float, float] = (0.4, 8.0)  #: u(o): depths of the observable volume
    max_box_size: float = 320.0  #: u(o): box widths and heights range over (0, this] px
    birth_frames: int = 3  #: B of eq. 3.30 (T_new = B + 1 = 4 frames, thesis §3.2.5)
    birth_threshold: float = 0.0  #: birth when the log-likelihood ratio exceeds this
    birth_velocity_std: float = 0.2  #: prior velocity std at birth, m/s
    birth_gate: float = 20.52  #: χ²₅(0.999) gate on each innovation of a birth sequence
    startup_birth: bool = True  #: before frame B + 1, births from all frames so far (≥ 2)
    birth_max_overlap: float = 0.5  #: reject a birth whose box lies this much in a visible one
    visibility_stay: float = 0.9  #: π_v of the visibility HMM
    visibility_lambda: float = 1.0  #: λ of eq. 3.32
    visibility_window: int = 2  #: frames summed into the visibility evidence ν
    coast_frames: int = 5  #: also output an in-view target unobserved for at most this many
    death_frames: int = 15  #: delete a target invisible this many frames while in view
    max_unseen_frames: int = 600  #: delete a target unobserved this long, in view or not
    view_margin: float = 0.0  #: a target is "in view" when it projects this far inside, px
    appearance: str = "cosine"  #: "cosine" (embeddings) or "bhattacharyya" (histograms)
    appearance_lambda: float = 5.0  #: κ (cosine) or λ (Bhattacharyya, eq. 3.5)
    appearance_update: float = 0.05  #: reference-appearance update rate

    def __post_init__(self) -> None:
        if self.control not in CONTROL_MODES:
            raise ValueError(
                f"RobotTrackerConfig.control must be one of {CONTROL_MODES}, got {self.control!r}"
            )
        for name in (
            "dyn_std_pos",
            "dyn_std_size",
            "dyn_std_vel",
            "max_pos_std",
            "max_vel_std",
            "max_box_size",
            "birth_velocity_std",
            "birth_gate",
            "birth_max_overlap",
            "visibility_lambda",
            "appearance_lambda",
        ):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise ValueError(f"RobotTrackerConfig.{name} must be a positive number, got {v!r}")
        for name in ("dyn_std_motor", "dyn_std_motor_vel"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise ValueError(f"RobotTrackerConfig.{name} must be a number >= 0, got {v!r}")
        if not (isinstance(self.coast_frames, int) and self.coast_frames >= 0):
            raise ValueError(
                f"RobotTrackerConfig.coast_frames must be an integer >= 0, got "
                f"{self.coast_frames!r}"
            )
        for name in (
            "n_iter",
            "birth_frames",
            "visibility_window",
            "death_frames",
            "max_unseen_frames",
        ):
            v = getattr(self, name)
            if not (isinstance(v, int) and not isinstance(v, bool) and v >= 1):
                raise ValueError(f"RobotTrackerConfig.{name} must be an integer >= 1, got {v!r}")
        near, far = (float(v) for v in self.depth_range)
        if not 0 < near < far:
            raise ValueError(
                f"RobotTrackerConfig.depth_range must be (near, far) with "
                f"0 < near < far, got {self.depth_range!r}"
            )
        if not 0 < self.visibility_stay < 1:
            raise ValueError(
                f"RobotTrackerConfig.visibility_stay must be in (0, 1), got "
                f"{self.visibility_stay!r}"
            )
        if self.appearance not in APPEARANCE_MODELS:
            raise ValueError(
                f"RobotTrackerConfig.appearance must be one of "
                f"{sorted(APPEARANCE_MODELS)}, got {self.appearance!r}"
            )
        if not 0 <= self.appearance_update <= 1:
            raise ValueError(
                f"RobotTrackerConfig.appearance_update must be in [0, 1], got "
                f"{self.appearance_update!r}"
            )


@dataclass(frozen=True)
class RobotFrameTracks:
    """Visible tracks after one frame.

    Attributes
    ----------
    ids : ndarray (K,) int
    positions : ndarray (K, 3)
        Posterior mean positions, current left-camera frame, metres.
    sizes : ndarray (K, 2)
        Tracked face box sizes ``(width, height)``, pixels.
    boxes : ndarray (K, 4)
        The tracks in the left image: ``(left, top, width, height)`` centred on the
        projected position with the tracked size, clipped to the image.
    p_visible : ndarray (K,)
    """

    ids: np.ndarray
    positions: np.ndarray
    sizes: np.ndarray
    boxes: np.ndarray
    p_visible: np.ndarray


class RobotTracker(ManagedTargets):
    """Online 3-D multi-person tracker for a moving stereo head (thesis §3.2).

    Parameters
    ----------
    head : RobotHead
        Stereo rig (projection, field of view) and calibration (control term).
    config : RobotTrackerConfig, optional
    fps : float
        Frame rate (the thesis's system runs at 10 FPS).

    Example
    -------
    >>> tracker = RobotTracker(nao_head())
    >>> for faces, motion in frames:   # FaceObservations, HeadMotion (None when still)
    ...     out = tracker.step(faces, motion)   # out.ids (K,), out.boxes (K, 4)
    """

    def __init__(
        self, head: RobotHead, config: RobotTrackerConfig | None = None, fps: float = 10.0
    ):
        if not isinstance(head, RobotHead):
            raise TypeError(f"head must be a RobotHead, got {type(head).__name__}")
        if not (isinstance(fps, int | float) and math.isfinite(fps) and fps > 0):
            raise ValueError(f"fps must be a positive number, got {fps!r}")
        self.head = head
        self.config = cfg = config or RobotTrackerConfig()
        self.dt = 1.0 / float(fps)
        rig = head.rig
        near, far = cfg.depth_range
        # u(o): uniform over the viewing frustum between near and far, and over box sizes
        volume = (far**3 - near**3) / 3 * (rig.width / rig.fx) * (rig.height / rig.fy)
        self.log_clutter = -math.log(volume) - 2 * math.log(cfg.max_box_size)
        self._appearance: AppearanceLikelihood = APPEARANCE_MODELS[cfg.appearance](
            cfg.appearance_lambda
        )
        self.model = FaceObservationModel(
            self.log_clutter, self._appearance, cfg.appearance_update
        )
        self.transition = constant_velocity_transition(OBS_DIM, 3, self.dt)  # D of eq. 3.34
        self.engine = VEMEngine(
            self.transition,
            [self.model],
            n_iter=cfg.n_iter,
            update_priors=cfg.update_priors,
            marginal_init=cfg.marginal_init,
            exclusive=cfg.exclusive,
        )
        self.p_visible: np.ndarray
        self.invisible_run: np.ndarray
        self.unseen_run: np.ndarray
        self.mass_history: np.ndarray
        #: ``(N, 3)`` control term of the last frame (zeros without motion / control).
        self.last_control: np.ndarray
        self._init_targets()
        self._pool: deque[FaceObservations] = deque(maxlen=cfg.birth_frames + 1)
        self._has_appearance: bool | None = None
        self.frame = 0

    # ------------------------------------------------------------------ covariances
    def _dyn_var(self, mu: np.ndarray, motion: HeadMotion | None) -> np.ndarray:
        """Diagonal ``(N, 8)`` of Λ_n: constant terms, the size term, and the motor-speed
        term on the position (thesis §3.2.5)."""
        cfg = self.config
        n = mu.shape[0]
        pos = np.full(n, cfg.dyn_std_pos**2)
        vel = np.full(n, cfg.dyn_std_vel**2)
        if motion is not None:
            scale = ego_displacement_scale(mu[:, :3], motion, self.dt)  # ‖X‖ ‖q̇‖ Δt
            pos = pos + (cfg.dyn_std_motor * scale) ** 2
            vel = vel + (cfg.dyn_std_motor_vel * scale / self.dt) ** 2
        size = (cfg.dyn_std_size * np.maximum(mu[:, 3:5], 1.0)) ** 2
        return np.column_stack([pos, pos, pos, size, vel, vel, vel])

    def _birth_dyn_cov(self, mu: np.ndarray) -> np.ndarray:
        var = self._dyn_var(mu, None)
        out = np.zeros((mu.shape[0], STATE_DIM, STATE_DIM))
        idx = np.arange(STATE_DIM)
        out[:, idx, idx] = var
        return out

    def _velocity_var(self, z: np.ndarray) -> np.ndarray:
        return np.full((z.shape[0], 3), self.config.birth_velocity_std**2)

    def _cap(self) -> None:
        """Bound the position and velocity standard deviations of coasting targets
        (Γ ← S Γ S, which keeps Γ positive definite)."""
        eng, cfg = self.engine, self.config
        var = np.diagonal(eng.gamma, axis1=1, axis2=2)
        cap = np.concatenate(
            [np.full(3, cfg.max_pos_std), np.full(2, np.inf), np.full(3, cfg.max_vel_std)]
        )
        scale = np.minimum(1.0, cap / np.sqrt(np.maximum(var, 1e-300)))
        if scale.min() < 1.0:
            eng.gamma = eng.gamma * scale[:, :, None] * scale[:, None, :]

    # ------------------------------------------------------------------ geometry
    def _in_view(self, positions: np.ndarray) -> np.ndarray:
        """``(N,)`` whether each position projects inside the left image (with margin)."""
        rig, m = self.head.rig, self.config.view_margin
        uv = rig.project(positions)
        with np.errstate(invalid="ignore"):
            return (
                (positions[:, 2] > self.config.depth_range[0])
                & (uv[:, 0] >= m)
                & (uv[:, 0] <= rig.width - m)
                & (uv[:, 1] >= m)
                & (uv[:, 1] <= rig.height - m)
            )

    def _boxes(self, positions: np.ndarray, sizes: np.ndarray) -> np.ndarray:
        """``(K, 4)`` left-image boxes of the tracks, clipped to the image."""
        rig = self.head.rig
        uv = rig.project(positions)
        lt = np.maximum(uv - 0.5 * sizes, 0.0)
        rb = np.minimum(uv + 0.5 * sizes, [rig.width, rig.height])
        return np.column_stack([lt, rb - lt])

    # ------------------------------------------------------------------ tracking
    @property
    def n_targets(self) -> int:
        return self.engine.n_targets

    def people(self) -> TrackedPeople:
        """Every target held (visible, sleeping or out of view), for the servo policies."""
        mu = self.engine.mu
        return TrackedPeople(
            self.engine.ids.copy(), mu[:, :3].copy(), mu[:, 5:8].copy(), self.p_visible > 0.5
        )

    def _check_faces(self, faces: FaceObservations) -> FaceObservations:
        """Type check, consistent use of appearance, descriptors normalised."""
        if not isinstance(faces, FaceObservations):
            raise TypeError(f"faces must be FaceObservations, got {type(faces).__name__}")
        if len(faces) == 0:
            return faces
        has = faces.appearance is not None
        if self._has_appearance is None:
            self._has_appearance = has
        elif self._has_appearance != has:
            raise ValueError("appearance descriptors must be given for every frame or none")
        if faces.appearance is not None:
            faces = FaceObservations(
                faces.positions,
                faces.sizes,
                faces.cov,
                self._appearance.normalize(faces.appearance),
                faces.left_boxes,
            )
        return faces

    def step(self, faces: FaceObservations, motion: HeadMotion | None = None) -> RobotFrameTracks:
        """Process one frame.

        Parameters
        ----------
        faces : FaceObservations
            This frame's 3-D face observations (current camera frame).
        motion : HeadMotion, optional
            The head's joint angles at the previous frame and the velocities commanded since
            (None: the head did not move).

        Returns
        -------
        RobotFrameTracks
            The visible targets inside the left image.
        """
        if motion is not None and not isinstance(motion, HeadMotion):
            raise TypeError(f"motion must be a HeadMotion or None, got {type(motion).__name__}")
        faces = self._check_faces(faces)
        cfg, eng = self.config, self.engine
        control_motion = motion if cfg.control != "none" else None  # the motion compensated
        self.frame += 1
        if control_motion is not None and self._pool:
            # the birth window in the current camera frame (exact head motion, eq. 3.48)
            q1 = control_motion.angles + control_motion.velocity * self.dt
            g = self.head.relative_transform(control_motion.angles, q1)
            self._pool = deque((p.transformed(g) for p in self._pool), maxlen=self._pool.maxlen)
        if eng.n_targets:
            mu_pred = eng.mu @ self.transition.T  # D μ_{t-1}
            control = None
            if control_motion is not None:  # C_tn, eqs. 3.34 and 3.45
                control = control_vector(
                    self.head, mu_pred, control_motion, self.dt, exact=cfg.control == "exact"
                )
            self.last_control = np.zeros((eng.n_targets, 3)) if control is None else control[:, :3]
            # E-Z / E-S (eqs. 3.37–3.38) / M
            inf = eng.step([faces], self._dyn_var(mu_pred, motion), control)
            self._cap()
            resp, mass = inf.responsibilities[0], inf.mass[0][1:]
            unassigned = np.flatnonzero(resp.argmax(axis=1) == 0)
            # visibility (eqs. 3.31–3.32), out-of-view sleeping and death (§3.1.4)
            if cfg.visibility_window == 1:
                self.mass_history, nu = mass[:, None], mass
            else:
                self.mass_history = np.concatenate([mass[:, None], self.mass_history[:, :-1]], 1)
                nu = self.mass_history.sum(axis=1)
            self.p_visible = visibility_filter(
                self.p_visible, nu, cfg.visibility_stay, cfg.visibility_lambda
            )
            in_view = self._in_view(eng.mu[:, :3])
            seen = self.p_visible > 0.5
            self.invisible_run = np.where(seen, 0, self.invisible_run + in_view)
            self.unseen_run = np.where(mass > 0.5, 0, self.unseen_run + 1)
            keep = (self.invisible_run < cfg.death_frames) & (
                self.unseen_run < cfg.max_unseen_frames
            )
            if not keep.all():
                self._remove(keep)
        else:
            unassigned = np.arange(len(faces))
            self.last_control = np.zeros((0, 3))
        # birth (eq. 3.30)
        self._pool.append(faces if unassigned.shape[0] == len(faces) else faces.subset(unassigned))
        if len(self._pool) == cfg.birth_frames + 1 or (
            cfg.startup_birth and len(self._pool) == self.frame >= 2
        ):
            self._birth()
        return self._output()

    def _output(self) -> RobotFrameTracks:
        mu = self.engine.mu
        coasting = self.unseen_run <= self.config.coast_frames
        show = ((self.p_visible > 0.5) | coasting) & self._in_view(mu[:, :3])
        pos, sizes = mu[show, :3], mu[show, 3:5]
        return RobotFrameTracks(
            self.engine.ids[show].copy(),
            pos.copy(),
            sizes.copy(),
            self._boxes(pos, sizes),
            self.p_visible[show].copy(),
        )

    def _per_target(self) -> tuple[PerTarget, ...]:
        """Visibility posterior, frames invisible in view and unseen in a row, visibility
        evidence window, last control term."""
        return (
            PerTarget("p_visible", 1.0),
            PerTarget("invisible_run", 0, dtype=np.int64),
            PerTarget("unseen_run", 0, dtype=np.int64),
            PerTarget("mass_history", 1.0, (self.config.visibility_window,)),
            PerTarget("last_control", 0.0, (3,)),
        )

    def _birth(self) -> None:
        cfg = self.config
        if any(len(p) == 0 for p in self._pool):
            return
        pools = [(p.z, np.diagonal(p.cov, axis1=1, axis2=2)) for p in self._pool]
        cands = birth_candidates(
            pools,
            self.transition,
            self._birth_dyn_cov,
            self._velocity_var,
            self.log_clutter,
            gate=cfg.birth_gate,
        )
        visible = self.p_visible > 0.5
        if cands and visible.any():
            # a new person cannot stand inside a visible person's box (duplicates)
            mu = self.engine.mu[visible]
            cands = births_outside(
                cands,
                lambda m: self._boxes(m[:, :3], m[:, 3:5]),
                self._boxes(mu[:, :3], mu[:, 3:5]),
                cfg.birth_max_overlap,
            )
        born = select_births(cands, cfg.birth_threshold)
        if not born:
            return
        mu, gamma, init = born_states(born, self._pool[-1].appearance)
        self._add_targets(self._new_ids(len(born)), mu, gamma, [init])
        consume_pool(self._pool, born)
