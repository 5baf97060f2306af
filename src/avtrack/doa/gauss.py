r"""Gaussian VEM multi-speaker DOA tracker (thesis §5.4, eqs. 5.20–5.43, Algorithm 3).

State of speaker ``n``: :math:`s_{tn} = [u_{tn}; v_{tn}]` with the unit direction vector
:math:`u_{tn} = (\cos\theta_{tn}, \sin\theta_{tn})` and the angular velocity :math:`v_{tn}`
(rad/s). Observations: candidate directions :math:`b_{td}` of the localizer with their
weights :math:`w_{td}` as precisions (:class:`~avtrack.doa.model.WeightedDirectionModel`,
eq. 5.22) -- by default every candidate above the frame's median weight
(:data:`~avtrack.doa.base.DEFAULT_OBSERVATIONS`; the E-S step then returns the centroid of
the whole lobe, which trails a moving talker; ``"peaks-over-uniform"`` observations with
``obs_var=0.0003`` follow the peaks instead, an option); uniform assignment priors
:math:`\pi_{dn} = 1/(N+1)` (eq. 5.23).

Dynamics (eqs. 5.25–5.27): :math:`p(s_{tn}|s_{t-1,n}) = \mathcal{N}(D_{t-1,n}s_{t-1,n},
\Lambda)`, with the transition linearised around the previous direction,

.. math::
    D_{t-1,n} = \begin{pmatrix} 1 & 0 & -\sin\theta_{t-1,n}\Delta t \\
                                0 & 1 & \cos\theta_{t-1,n}\Delta t \\
                                0 & 0 & 1 \end{pmatrix}             \quad\text{(eq. 5.27)}

Per frame, ``n_iter`` iterations of E-Z (eqs. 5.39–5.40) → E-S (eqs. 5.36–5.37) → M
(:math:`\Lambda` by eq. 2.27, optional) on the generic :class:`~avtrack.vem.engine.VEMEngine`,
the direction being renormalised after every E-S step (§5.4.1). Then

- **birth** (§5.4.2, eqs. 5.41–5.42): over the last ``L + 1`` frames (:math:`t-L..t`,
  ``L = 3``), the highest-weight observation assigned to clutter in each frame forms a
  sequence; its marginal likelihood under the model (Kalman prediction-error decomposition,
  starting from a broad prior) against the clutter density gives a log-likelihood ratio, and a
  speaker is born when it exceeds ``birth_threshold`` (and lies at least
  ``birth_min_separation_deg`` from every track: a side lobe of a tracked speaker is not a new
  speaker);
- **speaker activity** (§5.4.3, eq. 5.43): track ``n`` is active when
  :math:`\sum_{i=t-L'+1}^{t}\sum_d\alpha_{idn}w_{id} > \delta`;
- tracks survive speech pauses: a silent track keeps being predicted by its dynamics (its
  covariance is capped at ``max_direction_std`` / ``max_velocity_std``) and is deleted only
  after ``death_s`` seconds of silence, or when it has shadowed an older track (within
  ``merge_deg`` and moving alike: angular velocities within ``merge_velocity_deg_s``) for
  ``merge_s`` seconds; two talkers crossing each other move apart in velocity and are kept.

Deliberate choices where the thesis is silent: the clutter density ``log_clutter_density`` of a
direction vector (the "volume of the observation space" of eq. 5.22 is not given), the death and
merge rules, and ``velocity_decay`` (1 = the thesis's constant velocity; below 1 the angular
velocity relaxes to 0 while nothing is observed, so a silent track does not drift away).

Example
-------
>>> from avtrack.doa.gauss import GaussDOATracker
>>> tracker = GaussDOATracker()                   # one update every 32 ms
>>> out = tracker.step(azimuths_deg, weights)     # (D,) candidates and their EG weights
>>> out.ids, out.azimuth_deg, out.active
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from avtrack.doa.base import (
    DOATracker,
    SpeakerActivity,
    TrackFrame,
    check_config_fields,
    register_tracker,
)
from avtrack.doa.model import (
    MIN_WEIGHT,
    STATE_DIM,
    WeightedDirectionModel,
    WeightedDirections,
)
from avtrack.vem.engine import VEMEngine
from avtrack.vem.updates import symmetrize

_LOG_2PI = float(np.log(2 * np.pi))


@dataclass(frozen=True)
class GaussConfig:
    """Parameters of :class:`GaussDOATracker` (thesis §5.5.1 values where it gives them)."""

    n_iter: int = 3  #: VEM iterations per frame (thesis: 5)
    obs_var: float = 0.0012  #: σ² of Σ = σ² I₂ (thesis: 0.03, its weight scale; 0.0003 on peaks)
    log_clutter_density: float = 0.0  #: log U(vol B) of a direction vector, eq. 5.22
    dyn_std_dir: float = 0.04  #: Λ: std of each unit-vector component per frame
    dyn_std_vel: float = 0.1  #: Λ: std of the angular velocity per frame, rad/s
    velocity_decay: float = 0.9  #: D[2, 2] (thesis eq. 5.27: 1)
    dynamics_mstep: bool = False  #: re-estimate Λ by eq. 2.27 each iteration
    marginal_init: bool = True  #: first E-Z step with the predictive marginal (eq. 2.8)
    max_direction_std: float = 0.5  #: cap on the std of the direction components
    max_velocity_std: float = 1.0  #: cap on the std of the angular velocity, rad/s
    birth_frames: int = 3  #: L of §5.4.2 (sequences over frames t-L..t)
    birth_threshold: float = 6.0  #: ε₁ of eq. 5.41, as a log-likelihood ratio to clutter
    birth_velocity_std: float = 0.5  #: prior std of the angular velocity at birth, rad/s
    birth_min_separation_deg: float = 10.0  #: no birth this close to an existing track
    activity_frames: int = 3  #: L' of eq. 5.43
    activity_threshold: float = 0.045  #: δ of eq. 5.43 (thesis: 0.15, for its weight scale)
    death_s: float = 10.0  #: delete a track silent this long, seconds
    merge_deg: float = 8.0  #: a track this close to an older one ...
    merge_s: float = 0.2  #: ... for this long is deleted (a duplicate), seconds
    merge_velocity_deg_s: float = 10.0  #: ... if their angular velocities differ less, °/s
    lead_s: float = 0.0  #: report the direction eq. 5.27 predicts this far ahead, s (0: thesis)

    def __post_init__(self) -> None:
        check_config_fields(
            self,
            positive=(
                "obs_var",
                "dyn_std_dir",
                "dyn_std_vel",
                "max_direction_std",
                "max_velocity_std",
                "birth_velocity_std",
                "death_s",
                "merge_s",
                "merge_velocity_deg_s",
            ),
            finite=(
                "log_clutter_density",
                "birth_threshold",
                "activity_threshold",
                "birth_min_separation_deg",
                "merge_deg",
            ),
            counts=("n_iter", "birth_frames", "activity_frames"),
            non_negative=("lead_s",),
        )
        if not (isinstance(self.velocity_decay, int | float) and 0 < self.velocity_decay <= 1):
            raise ValueError(
                f"GaussConfig.velocity_decay must be in (0, 1], got {self.velocity_decay!r}"
            )


def direction_transition(mu: np.ndarray, dt: float, decay: float = 1.0) -> np.ndarray:
    r"""Linearised transitions :math:`D_{t-1,n}` (thesis eq. 5.27) of states ``mu (N, 3)``.

    The entries :math:`-\sin\theta\,\Delta t` and :math:`\cos\theta\,\Delta t` use the (unit)
    direction :math:`(\cos\theta, \sin\theta) = \mu_{:2}/\|\mu_{:2}\|`; ``decay`` is ``D[2, 2]``.

    Returns
    -------
    ndarray (N, 3, 3)
    """
    u = normalize_direction(mu)[:, :2]
    n = mu.shape[0]
    tr = np.zeros((n, STATE_DIM, STATE_DIM))
    tr[:, 0, 0] = tr[:, 1, 1] = 1.0
    tr[:, 2, 2] = decay
    tr[:, 0, 2] = -u[:, 1] * dt  # -sin θ Δt
    tr[:, 1, 2] = u[:, 0] * dt  # cos θ Δt
    return tr


def lead_gain(dt: float, decay: float, lead_s: float) -> float:
    r"""Seconds of angular velocity in the direction predicted ``lead_s`` ahead.

    Eq. 5.27 applied ``n = lead_s / Δt`` times moves the direction by
    :math:`v\,\Delta t\,(1 + a + \dots + a^{n-1}) = v\,\Delta t\,(1 - a^n) / (1 - a)` (``a`` the
    velocity decay ``D[2, 2]``; ``lead_s`` itself when ``a = 1``), taken for real ``n``.
    """
    if lead_s == 0.0:
        return 0.0
    if decay == 1.0:
        return float(lead_s)
    n = lead_s / dt
    return float(dt * (1.0 - decay**n) / (1.0 - decay))


def normalize_direction(mu: np.ndarray) -> np.ndarray:
    """``mu (N, 3)`` with its direction part rescaled to unit length (§5.4.1)."""
    out = np.array(mu, dtype=float)
    norm = np.sqrt(out[:, 0] * out[:, 0] + out[:, 1] * out[:, 1])
    norm[norm == 0] = 1.0
    out[:, :2] /= norm[:, None]
    return out


def birth_log_ratio(
    directions: np.ndarray,
    weights: np.ndarray,
    obs_var: float,
    dyn_cov: np.ndarray,
    dt: float,
    velocity_var: float,
    log_clutter_density: float,
    decay: float = 1.0,
) -> tuple[float, np.ndarray, np.ndarray]:
    r"""Birth statistic of one observation sequence (thesis eqs. 5.41–5.42).

    The marginal likelihood of eq. 5.42 by the Kalman prediction-error decomposition, with the
    linearised dynamics of eq. 5.27 evaluated at the current mean: :math:`p(\hat s_{t-L})` is
    a broad prior, so the first observation only centres the state (mean :math:`b_{t-L}`,
    covariance :math:`\Sigma/w_{t-L}` on the direction, ``velocity_var`` on the velocity) and
    the next ``L`` observations are scored against clutter:

    .. math::
        \mathrm{LLR} = \sum_{k=t-L+1}^{t}\big[\log\mathcal{N}(b_k; M D\mu_{k-1},
            M(D\Gamma_{k-1}D^\top + \Lambda)M^\top + \Sigma/w_k) - \log u\big]

    Parameters
    ----------
    directions : ndarray (L + 1, 2)
        Unit vectors, oldest first.
    weights : ndarray (L + 1,)
        Their weights (> 0).
    obs_var : float
        σ² of Σ.
    dyn_cov : ndarray (3, 3)
        Λ.
    dt : float
        Frame period, seconds.
    velocity_var : float
        Prior variance of the angular velocity.
    log_clutter_density : float
        :math:`\log u`.
    decay : float
        ``D[2, 2]``.

    Returns
    -------
    llr : float
    mu : ndarray (3,)
        Posterior mean at the last frame (unit direction).
    gamma : ndarray (3, 3)
        Posterior covariance at the last frame.
    """
    b = np.asarray(directions, dtype=float)
    w = np.asarray(weights, dtype=float)
    if b.ndim != 2 or b.shape[1] != 2 or w.shape != (b.shape[0],) or b.shape[0] < 2:
        raise ValueError(
            f"directions must be (L + 1, 2) and weights (L + 1,) with L >= 1, got "
            f"{b.shape} and {w.shape}"
        )
    if not np.all(w > 0):
        raise ValueError("weights of a birth sequence must be > 0")
    mu = np.array([b[0, 0], b[0, 1], 0.0])
    gamma = np.diag([obs_var / w[0], obs_var / w[0], velocity_var])
    llr = 0.0
    for k in range(1, b.shape[0]):
        tr = direction_transition(mu[None], dt, decay)[0]
        mu = tr @ mu  # D μ, eq. 5.34
        gamma = symmetrize(tr @ gamma @ tr.T + dyn_cov)  # D Γ Dᵀ + Λ, eq. 5.34
        s = gamma[:2, :2] + (obs_var / w[k]) * np.eye(2)  # innovation covariance
        r = b[k] - mu[:2]
        s_inv = np.linalg.inv(s)
        llr += -0.5 * (r @ s_inv @ r + np.log(np.linalg.det(s))) - _LOG_2PI - log_clutter_density
        gain = gamma[:, :2] @ s_inv  # Kalman update
        mu = normalize_direction((mu + gain @ r)[None])[0]
        gamma = symmetrize(gamma - gain @ gamma[:2, :])
    return float(llr), mu, gamma


@register_tracker("gauss")
class GaussDOATracker(DOATracker):
    """Gaussian VEM DOA tracker (thesis §5.4); see the module docstring for the model.

    Parameters
    ----------
    config : GaussConfig, optional
    frame_period_s : float
        Seconds between two :meth:`step` calls (Δt of eq. 5.27; thesis: 32 ms).
    """

    Config = GaussConfig

    def _reset_state(self) -> None:
        cfg: GaussConfig = self.config
        self.model = WeightedDirectionModel(cfg.obs_var, cfg.log_clutter_density)
        self.engine = VEMEngine(
            np.eye(STATE_DIM),
            [self.model],
            n_iter=cfg.n_iter,
            update_priors=False,
            dynamics_mstep=cfg.dynamics_mstep,
            marginal_init=cfg.marginal_init,
        )
        self.activity = SpeakerActivity(cfg.activity_frames, cfg.activity_threshold)
        self.shadowed = np.zeros(0, dtype=np.int64)
        self._pool: deque[tuple[np.ndarray, float] | None] = deque(maxlen=cfg.birth_frames + 1)
        self._lam_diag = np.array([cfg.dyn_std_dir, cfg.dyn_std_dir, cfg.dyn_std_vel]) ** 2
        self._cap = np.array([cfg.max_direction_std, cfg.max_direction_std, cfg.max_velocity_std])
        self._death_frames = max(1, round(cfg.death_s / self.frame_period_s))
        self._merge_frames = max(1, round(cfg.merge_s / self.frame_period_s))
        self._cos_merge = np.cos(np.deg2rad(cfg.merge_deg))
        self._merge_vel = np.deg2rad(cfg.merge_velocity_deg_s)
        self._cos_birth = np.cos(np.deg2rad(cfg.birth_min_separation_deg))
        self._dir_cache: tuple[np.ndarray, np.ndarray] | None = None
        self._lead = lead_gain(self.frame_period_s, cfg.velocity_decay, cfg.lead_s)

    @property
    def n_tracks(self) -> int:
        return self.engine.n_targets

    def _step(self, azimuth_rad: np.ndarray, weight: np.ndarray) -> TrackFrame:
        cfg: GaussConfig = self.config
        directions = self._directions(azimuth_rad)
        informative = weight > MIN_WEIGHT
        if not informative.all():
            # A candidate of weight ~0 has likelihood 0 under every track (eq. 5.22: precision
            # 0), so it is all clutter and adds nothing to eqs. 5.36-5.37, 5.43 or a birth;
            # dropping it gives the same result faster ("above-median" zeroes half of them).
            directions, weight = directions[informative], weight[informative]
        obs = WeightedDirections(directions, weight)
        eng = self.engine
        n = eng.n_targets
        if n:
            # --- VEM (Algorithm 3): E-Z, E-S with renormalisation, M --------------------------
            tr = direction_transition(eng.mu, self.frame_period_s, cfg.velocity_decay)
            inf = eng.step(
                [obs],
                np.broadcast_to(self._lam_diag, (n, STATE_DIM)),
                transition=tr,
                constrain=normalize_direction,
            )
            resp = inf.responsibilities[0]
            std = np.sqrt(np.diagonal(eng.gamma, axis1=1, axis2=2))
            scale = np.minimum(1.0, self._cap / np.maximum(std, 1e-300))  # covariance cap
            if scale.min() < 1.0:
                eng.scale_covariances(scale)
            mass = self.model.weighted_mass(obs, resp)  # Σ_d α_tdn w_td
            unassigned = resp.argmax(axis=1) == 0
        else:
            mass = np.zeros(0)
            unassigned = np.ones(len(obs), dtype=bool)
        # --- speaker activity (eq. 5.43), death and duplicates ---------------------------------
        score, active = self.activity.update(mass)
        if n:
            keep = self.activity.silent_frames < self._death_frames
            u = eng.mu[:, :2]
            cos = u @ u.T
            v = eng.mu[:, 2]
            alike = np.abs(v[:, None] - v[None, :]) < self._merge_vel
            older = np.tril((cos > self._cos_merge) & alike, k=-1)  # [i, j]: j < i is close to i
            self.shadowed = np.where(older.any(axis=1), self.shadowed + 1, 0)
            keep &= self.shadowed < self._merge_frames
            if not keep.all():
                eng.remove_targets(keep)
                self.activity.remove(keep)
                self.shadowed = self.shadowed[keep]
                score, active = score[keep], active[keep]
        # --- birth (§5.4.2) ---------------------------------------------------------------------
        cand = np.flatnonzero(unassigned & (weight > MIN_WEIGHT))
        if cand.size:
            best = cand[np.argmax(weight[cand])]
            self._pool.append((obs.directions[best], float(weight[best])))
        else:
            self._pool.append(None)
        born = self._birth()
        if born:
            score = np.concatenate([score, [born]])
            active = np.concatenate([active, [born > self.activity.threshold]])
        u = eng.mu[:, :2]
        theta = np.arctan2(u[:, 1], u[:, 0])
        if self._lead:  # latency compensation: the direction predicted lead_s ahead
            theta = theta + self._lead * eng.mu[:, 2]
        return TrackFrame(eng.ids.copy(), np.rad2deg(theta), active, score)

    def _directions(self, azimuth_rad: np.ndarray) -> np.ndarray:
        """Unit vectors ``(M, 2)`` of the azimuths, reused while the (read-only) candidate
        directions do not change."""
        cached = self._dir_cache
        if cached is not None and cached[0] is azimuth_rad:
            return cached[1]
        b = np.stack([np.cos(azimuth_rad), np.sin(azimuth_rad)], axis=1)
        if not azimuth_rad.flags.writeable:
            b.flags.writeable = False
            self._dir_cache = (azimuth_rad, b)
        return b

    def _birth(self) -> float:
        """Try a birth from the pooled sequence; returns the new track's activity statistic
        (0.0 when nobody is born)."""
        cfg: GaussConfig = self.config
        if len(self._pool) < cfg.birth_frames + 1 or any(p is None for p in self._pool):
            return 0.0
        pool = [p for p in self._pool if p is not None]  # all of them (checked above)
        w = np.array([p[1] for p in pool])
        # cheap exact bound: each innovation density is at most N(0; 0, Σ/w_k)
        bound = (np.log(w[1:] / (2 * np.pi * cfg.obs_var)) - cfg.log_clutter_density).sum()
        if bound <= cfg.birth_threshold:
            return 0.0
        b = np.stack([p[0] for p in pool])
        llr, mu, gamma = birth_log_ratio(
            b,
            w,
            cfg.obs_var,
            np.diag(self._lam_diag),
            self.frame_period_s,
            cfg.birth_velocity_std**2,
            cfg.log_clutter_density,
            cfg.velocity_decay,
        )
        if llr <= cfg.birth_threshold:  # eq. 5.41
            return 0.0
        eng = self.engine
        if eng.n_targets and (eng.mu[:, :2] @ mu[:2]).max() > self._cos_birth:
            return 0.0  # too close to a tracked speaker
        eng.add_targets(self._new_ids(1), mu[None], gamma[None])
        recent = float(w[-cfg.activity_frames :].sum())
        self.activity.add(1, recent / cfg.activity_frames)
        self.shadowed = np.concatenate([self.shadowed, [0]])
        self._pool.clear()
        return recent
