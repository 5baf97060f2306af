r"""von Mises VEM multi-source DOA tracker (thesis §5.6 and appendix A, eqs. 5.44–5.62).

Circular states :math:`s_{tn} \in (-\pi, \pi]` and DOA observations :math:`y_{tm}` with
confidences :math:`\omega_{tm} \in [0, 1]`:

.. math::
    p(y_{tm}|z_{tm}=n, s_{tn}) = \mathcal{M}(y_{tm}; s_{tn}, \kappa_y\omega_{tm})\ (n \ne 0),
    \quad \mathcal{U}(y_{tm}) = 1/2\pi\ (n = 0)                        \quad\text{(eq. 5.46)}

.. math::
    p(s_{tn}|s_{t-1,n}) = \mathcal{M}(s_{tn}; s_{t-1,n}, \kappa_d)     \quad\text{(eq. 5.49)}

with :math:`\mathcal{M}(y; s, \kappa) = e^{\kappa\cos(y - s)}/(2\pi I_0(\kappa))` and
assignment priors :math:`\pi_n` (eq. 5.47). Under the factorisation
:math:`q(s_t)q(z_t)` (eq. 5.50) every :math:`q(s_{tn})` stays von Mises
:math:`\mathcal{M}(\mu_{tn}, \kappa_{tn})`. Per frame:

1. prediction (eqs. 5.55–5.56): :math:`\tilde\kappa_{t-1,n} = A^{-1}(A(\kappa_{t-1,n})
   A(\kappa_d))`, :math:`A = I_1/I_0`, :math:`A^{-1}(a) \approx (2a - a^3)/(1 - a^2)`;
2. ``n_iter`` iterations of E-Z (eq. 5.59, A.2) → E-S (eqs. 5.57–5.58, A.1) → M (priors
   :math:`\pi_n \propto \sum_m\alpha_{tmn}`; one gradient step each on :math:`\kappa_y` and
   :math:`\kappa_d`, A.3);
3. birth (§5.6.4, eqs. 5.60–5.61, A.4) from sequences of clutter-assigned DOAs over the last
   ``L + 1`` frames (``L = 2``);
4. voice activity (eq. 5.62): active when
   :math:`\sum_{t'=t-D}^{t}\sum_m\alpha_{t'mn}\omega_{t'm} > \delta` (``D = 2``,
   :math:`\delta = 0.025`).

Readings of the printed equations (derived again from the model):

* E-Z. The expected log-likelihood under :math:`q(s_{tn}) = \mathcal{M}(\mu_{tn},
  \kappa_{tn})` is :math:`\kappa_y\omega_{tm}A(\kappa_{tn})\cos(y_{tm}-\mu_{tn}) -
  \log(2\pi I_0(\kappa_y\omega_{tm}))`, so
  :math:`\log\beta_{tmn}` uses :math:`A(\kappa_{tn})` (the text after eq. 5.59:
  ":math:`\kappa_{tmn} = \kappa_y\omega_{tm}A(\kappa_{tn})`"), not the printed
  :math:`A(\omega_{tm}\kappa_y)`, keeps the normaliser, and is exponentiated (the printed
  :math:`\beta` is the exponent). :math:`\beta_{tm0} = 1/2\pi`.
* Birth. The harmonic addition of A.4 has the cross term :math:`2\hat\kappa\kappa_y
  \hat\omega\cos(\hat y - \hat\mu)` (eq. 5.61's recursion omits the 2); the new source
  starts from the posterior at ``t`` (the last observation included), and the statistic is
  compared with the clutter likelihood :math:`(2\pi)^{-(L+1)}` as a log ratio.
* Constant-velocity prediction (``velocity_std > 0``, the default; 0 gives eqs. 5.49 and
  5.55–5.56 as printed). Each source also carries an angular velocity :math:`\nu_{tn}` with a
  Gaussian spread; the prediction is :math:`\tilde s = \mu_{t-1,n} + \nu_{t-1,n}\Delta t`
  whose variance :math:`1/\kappa + 2\Delta t\,c + \Delta t^2 v` (``c`` = Cov(s, ν),
  ``v`` = Var(ν)) replaces :math:`1/\kappa_{t-1,n}` in eq. 5.56, and after the E-S step
  :math:`\nu` is conditioned on the new direction as in a Kalman filter whose observations
  inform the direction only: :math:`\nu \leftarrow \nu + \frac{\mathrm{Cov}(\tilde s,
  \nu)}{\mathrm{Var}(\tilde s)}(\mu_{tn} - \tilde s)`, with :math:`\mathrm{Var} = 1/\kappa`.
  The static model of eq. 5.49 trails a moving talker; a silent source's velocity decays.
* The M-step gradient steps on the concentrations are taken on :math:`\log\kappa`
  (:math:`\partial Q/\partial\log\kappa = \kappa\,\partial Q/\partial\kappa`), which keeps
  them positive and makes one step size fit the very different scales of :math:`\kappa_y` and
  :math:`\kappa_d`; the priors restart from uniform at each frame, as in the Gaussian engine.

Bessel ratios use the exponentially scaled :func:`scipy.special.i0e` / ``i1e`` and are exact
for any concentration (no overflow for :math:`\kappa \gg 700`).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from scipy.special import i0e, i1e

from avtrack.doa.base import (
    FAST_MAP_OVERRIDES,
    DOATracker,
    SpeakerActivity,
    TrackFrame,
    check_config_fields,
    register_tracker,
)
from avtrack.vem.updates import e_z_step, exclusive_projection, m_step_priors

_LOG_2PI = math.log(2 * math.pi)
#: Largest Bessel ratio fed to :func:`inv_bessel_ratio` (κ ≈ 5e11).
_MAX_RATIO = 1.0 - 1e-12


def bessel_ratio(kappa: np.ndarray | float) -> np.ndarray:
    r""":math:`A(\kappa) = I_1(\kappa)/I_0(\kappa)`, safe for any :math:`\kappa \ge 0`."""
    k = np.asarray(kappa, dtype=float)
    return i1e(k) / i0e(k)  # the e^{-κ} scalings cancel


def log_i0(kappa: np.ndarray | float) -> np.ndarray:
    r""":math:`\log I_0(\kappa)` without overflow: :math:`\log(I_0(\kappa)e^{-\kappa}) +
    \kappa`."""
    k = np.asarray(kappa, dtype=float)
    return np.log(i0e(k)) + np.abs(k)


def inv_bessel_ratio(a: np.ndarray | float) -> np.ndarray:
    r""":math:`A^{-1}(a) \approx (2a - a^3)/(1 - a^2)` (thesis, below eq. 5.56), for
    :math:`a \in [0, 1)` (clipped to ``[0, 1 - 1e-12]``)."""
    a = np.minimum(np.maximum(np.asarray(a, dtype=float), 0.0), _MAX_RATIO)  # (np.clip: slower)
    return np.asarray((2 * a - a**3) / ((1 - a) * (1 + a)))  # (2a - a³)/(1 - a²)


def d_inv_bessel_ratio(a: np.ndarray | float) -> np.ndarray:
    r""":math:`\tilde A(a) = dA^{-1}/da = (2 - a^2 + a^4)/(1 - a^2)^2` (appendix A.3.3)."""
    a = np.minimum(np.maximum(np.asarray(a, dtype=float), 0.0), _MAX_RATIO)
    return np.asarray((2 - a**2 + a**4) / ((1 - a) * (1 + a)) ** 2)


def d_bessel_ratio(kappa: np.ndarray | float) -> np.ndarray:
    r""":math:`A'(\kappa) = (I_2I_0 - I_1^2)/I_0^2 = 1 - A(\kappa)/\kappa - A(\kappa)^2`
    (appendix A.3.3; the limit at 0 is 1/2)."""
    k = np.asarray(kappa, dtype=float)
    a = bessel_ratio(k)
    small = k < 1e-6
    a_over_k = np.where(small, 0.5, a / np.where(small, 1.0, k))
    return 1.0 - a_over_k - a * a


def predicted_concentration(kappa: np.ndarray | float, kappa_d: float) -> np.ndarray:
    r""":math:`\tilde\kappa = A^{-1}(A(\kappa)A(\kappa_d))` (thesis eq. 5.56)."""
    return inv_bessel_ratio(bessel_ratio(kappa) * bessel_ratio(kappa_d))


def birth_log_ratio(
    y: np.ndarray,
    omega: np.ndarray,
    kappa_y: float,
    kappa_d: float,
    kappa0: np.ndarray | float = 0.0,
    mu0: np.ndarray | float = 0.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Birth statistic of DOA sequences (thesis eqs. 5.60–5.61, appendix A.4).

    :math:`\log\tau_j = \sum_{l}\big[\log I_0(\bar\kappa_{t-l}) - \log 2\pi -
    \log I_0(\kappa_y\hat\omega_{t-l}) - \log I_0(\hat\kappa_{t-l})\big]` with the recursion
    :math:`\bar\kappa e^{i\bar\mu} = \hat\kappa e^{i\hat\mu} + \kappa_y\hat\omega e^{i\hat y}`
    (harmonic addition), :math:`\hat\mu \leftarrow \bar\mu`,
    :math:`\hat\kappa \leftarrow A^{-1}(A(\bar\kappa)A(\kappa_d))`, from
    :math:`p(s_{t-L}) = \mathcal{M}(\mu_0, \kappa_0)` (:math:`\kappa_0 = 0`: uniform). Returned
    as the log ratio to the clutter likelihood :math:`(2\pi)^{-(L+1)}`.

    Parameters
    ----------
    y : ndarray (J, L + 1)
        DOAs of ``J`` sequences, radians, oldest first.
    omega : ndarray (J, L + 1)
        Their confidences.
    kappa_y, kappa_d : float
    kappa0, mu0 : float or ndarray (J,)
        Prior of the first state (one per sequence, or one for all).

    Returns
    -------
    llr : ndarray (J,)
        :math:`\log\tau_j + (L + 1)\log 2\pi`.
    mu : ndarray (J,)
        :math:`\bar\mu_t`, posterior mean at the last frame.
    kappa : ndarray (J,)
        :math:`\bar\kappa_t`, posterior concentration at the last frame.
    """
    y = np.asarray(y, dtype=float)
    omega = np.asarray(omega, dtype=float)
    if y.ndim != 2 or omega.shape != y.shape:
        raise ValueError(
            f"y and omega must be (J, L + 1) arrays of one shape, got {y.shape} and {omega.shape}"
        )
    j = y.shape[0]
    k_hat = np.broadcast_to(np.asarray(kappa0, dtype=float), (j,)).copy()
    mu_hat = np.broadcast_to(np.asarray(mu0, dtype=float), (j,)).copy()
    log_tau = np.zeros(j)
    k_bar = k_hat
    mu_bar = mu_hat
    a_d = bessel_ratio(kappa_d)
    for col in range(y.shape[1]):
        x = kappa_y * omega[:, col]
        c = k_hat * np.cos(mu_hat) + x * np.cos(y[:, col])  # harmonic addition, A.4
        s = k_hat * np.sin(mu_hat) + x * np.sin(y[:, col])
        k_bar = np.hypot(c, s)  # κ̄² = κ̂² + (κ_y ω)² + 2 κ̂ κ_y ω cos(ŷ - μ̂)
        mu_bar = np.arctan2(s, c)
        log_tau += log_i0(k_bar) - _LOG_2PI - log_i0(x) - log_i0(k_hat)  # eq. 5.61
        mu_hat = mu_bar
        k_hat = inv_bessel_ratio(bessel_ratio(k_bar) * a_d)  # κ̂ = A⁻¹(A(κ̄) A(κ_d))
    return log_tau + y.shape[1] * _LOG_2PI, mu_bar, k_bar


@dataclass(frozen=True)
class VonMisesConfig:
    """Parameters of :class:`VonMisesDOATracker` (thesis §5.6.5 values where it gives them)."""

    n_iter: int = 3  #: VEM iterations per frame
    kappa_y: float = 120.0  #: initial observation concentration κ_y (of a confidence-1 DOA)
    kappa_d: float = 200.0  #: initial dynamics concentration κ_d (per frame)
    learn_kappa_y: bool = True  #: gradient steps on κ_y (A.3.1)
    learn_kappa_d: bool = True  #: gradient steps on κ_d (A.3.3)
    kappa_rate: float = 0.008  #: step size of the gradient steps on log κ
    kappa_y_range: tuple[float, float] = (5.0, 1000.0)  #: κ_y is kept in this interval
    kappa_d_range: tuple[float, float] = (20.0, 10000.0)  #: κ_d is kept in this interval
    update_priors: bool = True  #: M-step of the priors π_n (eq. 5.47)
    exclusive: bool = False  #: a source explains at most one DOA per frame (for peaks)
    birth_frames: int = 2  #: L of §5.6.4 (sequences over frames t-L..t)
    birth_candidates: int = 2  #: unassigned DOAs per frame (highest confidence) in sequences
    birth_threshold: float = 1.7  #: on log τ_j + (L + 1) log 2π (eq. 5.61 vs clutter)
    birth_min_separation_deg: float = 20.0  #: no birth this close to an existing track
    birth_floor: float = 0.05  #: DOAs of a lower confidence cannot start a source
    activity_frames: int = 3  #: D + 1 of eq. 5.62 (D = 2)
    activity_threshold: float = 0.035  #: δ of eq. 5.62 (thesis: 0.025, for its confidences)
    death_s: float = 10.0  #: delete a track silent this long, seconds
    merge_deg: float = 8.0  #: a track this close to an older one ...
    merge_s: float = 1.5  #: ... for this long is deleted (a duplicate), seconds
    velocity_std: float = 0.05  #: std of the angular velocity's change per frame, rad/s
    birth_velocity_std: float = 0.5  #: prior std of the angular velocity at birth, rad/s
    silent_velocity_decay: float = 0.8  #: the velocity is multiplied by this per silent frame
    lead_s: float = 0.0  #: report the direction predicted this far ahead, s (0: thesis)

    def __post_init__(self) -> None:
        check_config_fields(
            self,
            positive=(
                "kappa_y",
                "kappa_d",
                "kappa_rate",
                "death_s",
                "merge_s",
                "birth_velocity_std",
            ),
            finite=(
                "birth_threshold",
                "activity_threshold",
                "birth_min_separation_deg",
                "merge_deg",
                "birth_floor",
            ),
            counts=("n_iter", "birth_frames", "birth_candidates", "activity_frames"),
            non_negative=("velocity_std", "lead_s"),
        )
        d = self.silent_velocity_decay
        if isinstance(d, bool) or not (isinstance(d, int | float) and 0 <= d <= 1):
            raise ValueError(f"VonMisesConfig.silent_velocity_decay must be in [0, 1], got {d!r}")
        for name in ("kappa_y_range", "kappa_d_range"):
            v = tuple(getattr(self, name))
            if len(v) != 2 or not (0 < v[0] <= v[1] < np.inf):
                raise ValueError(
                    f"VonMisesConfig.{name} must be (low, high) with "
                    f"0 < low <= high, got {getattr(self, name)!r}"
                )
            object.__setattr__(self, name, (float(v[0]), float(v[1])))
        for name, rng in (("kappa_y", self.kappa_y_range), ("kappa_d", self.kappa_d_range)):
            if not rng[0] <= getattr(self, name) <= rng[1]:
                raise ValueError(
                    f"VonMisesConfig.{name} must lie in {name}_range {rng}, "
                    f"got {getattr(self, name)!r}"
                )


#: Settings for ``dprtf-eg-fast`` heat maps: the Config with the overrides of
#: :data:`avtrack.doa.base.FAST_MAP_OVERRIDES` (where they are explained); to be used with
#: observations ``heatmap_sequence(..., "peaks-over-uniform",
#: uniform_floor=FAST_MAP_UNIFORM_PEAK_FLOOR)``.
FAST_MAP_CONFIG = VonMisesConfig(**FAST_MAP_OVERRIDES["vonmises"])


@register_tracker("vonmises")
class VonMisesDOATracker(DOATracker):
    """von Mises VEM DOA tracker (thesis §5.6); see the module docstring for the model.

    Attributes
    ----------
    ids : ndarray (N,) int
    mu : ndarray (N,)
        Posterior mean directions :math:`\\mu_{tn}`, radians.
    kappa : ndarray (N,)
        Posterior concentrations :math:`\\kappa_{tn}`.
    kappa_y, kappa_d : float
        Current model concentrations (learned online when configured).
    """

    Config = VonMisesConfig

    def _reset_state(self) -> None:
        cfg: VonMisesConfig = self.config
        self.ids = np.zeros(0, dtype=np.int64)
        self.mu = np.zeros(0)
        self.kappa = np.zeros(0)
        self.nu = np.zeros(0)  # angular velocities ν_tn, rad/s
        self.cov_sv = np.zeros(0)  # Cov(s_tn, ν_tn)
        self.var_v = np.zeros(0)  # Var(ν_tn)
        self.kappa_y = float(cfg.kappa_y)
        self.kappa_d = float(cfg.kappa_d)
        self.activity = SpeakerActivity(cfg.activity_frames, cfg.activity_threshold)
        self.shadowed = np.zeros(0, dtype=np.int64)
        self._pool: deque[tuple[np.ndarray, np.ndarray]] = deque(maxlen=cfg.birth_frames + 1)
        self._death_frames = max(1, round(cfg.death_s / self.frame_period_s))
        self._merge_frames = max(1, round(cfg.merge_s / self.frame_period_s))
        self._cos_merge = math.cos(math.radians(cfg.merge_deg))
        self._cos_birth = math.cos(math.radians(cfg.birth_min_separation_deg))

    @property
    def n_tracks(self) -> int:
        return int(self.ids.shape[0])

    def _vem(self, y: np.ndarray, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """One frame of VEM on the current tracks; returns the responsibilities ``(M, N + 1)``
        and the weighted masses :math:`\\sum_m\\alpha_{tmn}\\omega_{tm}` ``(N,)``."""
        cfg: VonMisesConfig = self.config
        m, n = y.shape[0], self.n_tracks
        dt = self.frame_period_s
        cv = cfg.velocity_std > 0
        if cv:
            # constant-velocity prediction: s̃ = μ + ν Δt with the spread of ν folded into the
            # concentration before the dynamics noise (eqs. 5.55–5.56 when ν ≡ 0)
            var_s = 1.0 / np.maximum(self.kappa, 1e-12)
            var_s = var_s + 2 * dt * self.cov_sv + dt * dt * self.var_v  # [1 Δt] P [1 Δt]ᵀ
            cov_sv = self.cov_sv + dt * self.var_v  # Cov(s̃, ν̃)
            var_v = self.var_v + cfg.velocity_std**2  # Var(ν̃)
            mu_prev = np.mod(self.mu + self.nu * dt + np.pi, 2 * np.pi) - np.pi
            a_prev = bessel_ratio(1.0 / var_s)
        else:
            mu_prev = self.mu
            a_prev = bessel_ratio(self.kappa)
        a_d = float(bessel_ratio(self.kappa_d))
        k_tilde = inv_bessel_ratio(a_prev * a_d)  # eq. 5.56
        c_prev, s_prev = k_tilde * np.cos(mu_prev), k_tilde * np.sin(mu_prev)
        mu, kappa = mu_prev, k_tilde  # E-Z initialisation with the prediction, eq. 5.55
        cy, sy = np.cos(y), np.sin(y)
        log_prior = np.full(n + 1, -math.log(n + 1))  # π_n = 1/(N+1) at the frame start
        log_clutter = np.full(m, -_LOG_2PI)  # β_tm0 = 1/2π
        alpha = np.zeros((m, n + 1))
        for _ in range(cfg.n_iter):
            x = self.kappa_y * omega  # κ_y ω_tm, (M,)
            # cos(y_tm - μ_tn), (M, N)
            cos_d = cy[:, None] * np.cos(mu)[None, :] + sy[:, None] * np.sin(mu)[None, :]
            # E-Z, eq. 5.59 / A.2: log β = κ_y ω A(κ_tn) cos(y - μ) - log(2π I_0(κ_y ω))
            log_beta = x[:, None] * bessel_ratio(kappa)[None, :] * cos_d
            log_beta -= (_LOG_2PI + log_i0(x))[:, None]
            alpha = e_z_step(log_beta, log_clutter, log_prior)
            if cfg.exclusive:  # point sources: at most one DOA each per frame
                alpha = exclusive_projection(alpha)
            aw = alpha[:, 1:] * omega[:, None]  # α_tmn ω_tm, (M, N)
            # E-S, eqs. 5.57–5.58 (harmonic addition, A.1)
            c = self.kappa_y * cy.dot(aw) + c_prev
            s = self.kappa_y * sy.dot(aw) + s_prev
            mu = np.arctan2(s, c)  # eq. 5.57
            kappa = np.hypot(c, s)  # eq. 5.58
            # M step: priors (eq. 5.47, A.3.2), then one gradient step on log κ_y and log κ_d
            if cfg.update_priors:
                log_prior = m_step_priors(alpha.sum(axis=0))
            a_k = bessel_ratio(kappa)
            if cfg.learn_kappa_y and m and n:
                cos_d = cy[:, None] * np.cos(mu)[None, :] + sy[:, None] * np.sin(mu)[None, :]
                # ∂Q/∂κ_y = Σ_mn α ω (A(κ_tn) cos(y - μ_tn) - A(κ_y ω)), A.3.1
                grad = float((aw * (a_k[None, :] * cos_d - bessel_ratio(x)[:, None])).sum())
                lo, hi = cfg.kappa_y_range
                step = self.kappa_y * math.exp(cfg.kappa_rate * self.kappa_y * grad)
                self.kappa_y = float(min(max(step, lo), hi))  # (np.clip: slow on a scalar)
            if cfg.learn_kappa_d and n:
                # ∂Q/∂κ_d = Σ_n (A(κ_tn) cos(μ_tn - μ_t-1,n) - A(κ̃_n)) B(κ_d), A.3.3
                b = d_inv_bessel_ratio(a_prev * a_d) * a_prev * d_bessel_ratio(self.kappa_d)
                grad = float(((a_k * np.cos(mu - mu_prev) - bessel_ratio(k_tilde)) * b).sum())
                lo, hi = cfg.kappa_d_range
                step = self.kappa_d * math.exp(cfg.kappa_rate * self.kappa_d * grad)
                self.kappa_d = float(min(max(step, lo), hi))  # (np.clip: slow on a scalar)
        self.mu, self.kappa = mu, kappa
        if cv and n:
            # ν given the updated direction: Gaussian conditioning on s (the observations inform
            # s only), ν = ν̃ + Cov(s̃, ν̃)/Var(s̃) (μ - s̃)
            var_pred = 1.0 / np.maximum(k_tilde, 1e-12)
            gain = cov_sv / var_pred
            shrink = np.minimum(1.0, (1.0 / np.maximum(kappa, 1e-12)) / var_pred)
            resid = np.mod(mu - mu_prev + np.pi, 2 * np.pi) - np.pi
            self.nu = self.nu + gain * resid
            self.cov_sv = cov_sv * shrink
            self.var_v = np.minimum(
                var_v - gain * cov_sv * (1.0 - shrink), cfg.birth_velocity_std**2
            )
        return alpha, omega.dot(alpha[:, 1:])

    def _step(self, azimuth_rad: np.ndarray, weight: np.ndarray) -> TrackFrame:
        cfg: VonMisesConfig = self.config
        y = np.mod(azimuth_rad + np.pi, 2 * np.pi) - np.pi
        n = self.n_tracks
        if n:
            alpha, mass = self._vem(y, weight)
            unassigned = alpha.argmax(axis=1) == 0
        else:
            mass = np.zeros(0)
            unassigned = np.ones(y.shape[0], dtype=bool)
        # --- voice activity (eq. 5.62), death and duplicates -----------------------------------
        score, active = self.activity.update(mass)
        if n:
            self.nu = np.where(active, self.nu, cfg.silent_velocity_decay * self.nu)
            keep = self.activity.silent_frames < self._death_frames
            cos = np.cos(self.mu[:, None] - self.mu[None, :])
            older = np.tril(cos > self._cos_merge, k=-1)  # [i, j]: j < i is close to i
            self.shadowed = np.where(older.any(axis=1), self.shadowed + 1, 0)
            keep &= self.shadowed < self._merge_frames
            if not keep.all():
                self.ids, self.mu, self.kappa = self.ids[keep], self.mu[keep], self.kappa[keep]
                self.nu, self.cov_sv = self.nu[keep], self.cov_sv[keep]
                self.var_v = self.var_v[keep]
                self.activity.remove(keep)
                self.shadowed = self.shadowed[keep]
                score, active = score[keep], active[keep]
        # --- birth (§5.6.4) -------------------------------------------------------------------
        cand = np.flatnonzero(unassigned & (weight > 0) & (weight >= cfg.birth_floor))
        if cand.size > cfg.birth_candidates:
            cand = cand[np.argsort(-weight[cand], kind="stable")[: cfg.birth_candidates]]
        self._pool.append((y[cand], weight[cand]))
        born = self._birth()
        if born:
            score = np.concatenate([score, [born]])
            active = np.concatenate([active, [born > self.activity.threshold]])
        theta = self.mu
        if cfg.lead_s:  # latency compensation: the constant-velocity prediction lead_s ahead
            theta = theta + cfg.lead_s * self.nu
        return TrackFrame(self.ids.copy(), np.rad2deg(theta), active, score)

    def _continues_a_track(self, y: np.ndarray, omega: np.ndarray, llr_new: float) -> bool:
        """Whether the birth sequence ``y`` ``(L + 1,)`` (confidences ``omega``) is better
        explained by an existing track than by a new source; that track is then re-started
        on the sequence (same identity) and True is returned.

        The same marginal likelihood as the birth test (eq. 5.61), with the track's
        distribution as the prior of the first state instead of the uniform one. A silent
        track's distribution widens (eq. 5.56), and the variational E-Z step (eq. 5.59) scores
        a wide track's DOAs below clutter, so its talker's return reaches the birth pool: the
        exact marginal gives it back to the track instead of starting a duplicate beside it.
        """
        n = self.n_tracks
        seq_y = np.broadcast_to(y, (n, y.size))
        seq_w = np.broadcast_to(omega, (n, omega.size))
        llr, mu, kappa = birth_log_ratio(
            seq_y, seq_w, self.kappa_y, self.kappa_d, kappa0=self.kappa, mu0=self.mu
        )
        k = int(np.argmax(llr))
        if llr[k] <= llr_new:
            return False
        self.mu[k], self.kappa[k] = mu[k], kappa[k]
        self.nu[k], self.cov_sv[k] = 0.0, 0.0
        self.var_v[k] = self.config.birth_velocity_std ** 2
        self._pool.clear()
        return True

    def _birth(self) -> float:
        """Try a birth from the pooled DOAs; returns the new track's activity statistic
        (0.0 when nobody is born)."""
        cfg: VonMisesConfig = self.config
        if len(self._pool) < cfg.birth_frames + 1 or any(p[0].size == 0 for p in self._pool):
            return 0.0
        # every sequence of one pooled DOA per frame, oldest first
        grids = np.meshgrid(*[np.arange(p[0].size) for p in self._pool], indexing="ij")
        idx = [g.ravel() for g in grids]
        y = np.stack([p[0][i] for p, i in zip(self._pool, idx, strict=True)], axis=1)
        om = np.stack([p[1][i] for p, i in zip(self._pool, idx, strict=True)], axis=1)
        llr, mu, kappa = birth_log_ratio(y, om, self.kappa_y, self.kappa_d)  # eq. 5.61
        best = int(np.argmax(llr))
        if llr[best] <= cfg.birth_threshold:
            return 0.0
        if self.n_tracks and self._continues_a_track(y[best], om[best], float(llr[best])):
            return 0.0
        if self.n_tracks and np.cos(self.mu - mu[best]).max() > self._cos_birth:
            return 0.0  # too close to a tracked source
        self.ids = np.concatenate([self.ids, self._new_ids(1)])
        self.mu = np.concatenate([self.mu, [mu[best]]])
        self.kappa = np.concatenate([self.kappa, [kappa[best]]])
        self.nu = np.concatenate([self.nu, [0.0]])
        self.cov_sv = np.concatenate([self.cov_sv, [0.0]])
        self.var_v = np.concatenate([self.var_v, [cfg.birth_velocity_std**2]])
        recent = float(om[best, -cfg.activity_frames :].sum())
        self.activity.add(1, recent / cfg.activity_frames)
        self.shadowed = np.concatenate([self.shadowed, [0]])
        self._pool.clear()
        return recent
