"""Particle SMC-PHD core shared by the AV-NPF and AV-LPF filters (Liu et al., §2–3).

Model: a speaker state ``m = [x, y, vx, vy]`` (pixels, pixels per frame) follows the
constant-velocity model ``m_k = F m_{k-1} + n``, ``n ~ N(0, Q)`` (eq. 1 / 14). The PHD is a
weighted particle set ``{m^i, w^i}``; its total weight is the expected number of speakers.

One step (:meth:`SMCPHDFilter._step`):

1. predict the surviving particles through the transition, ``w_{k|k-1} = p_S w_{k-1}``
   (eq. 4 with the transition as proposal ``q_k``);
2. birth: for each fused measurement that has a visual part and that the surviving particles
   do not explain — ``G_r = sum_i p_D^r h^{i,r} w_{k|k-1}^i`` (eq. 12 at the predicted
   particles) below the clutter intensity ``kappa_r``, i.e. the measurement is more likely
   clutter or new than an existing speaker ("if a new speaker appears", §2) — ``N_B / n``
   particles drawn from the product of its visual and audio kernels (eq. 13, a Gaussian here)
   with weights ``gamma / (N_B p) = birth_mass / n`` (eq. 5). As in the adaptive birth of
   Ristic, Clark, Vo and Vo (2012), newborn particles join the PHD *after* the update of the
   frame they are drawn from (the measurement that spawned them cannot also confirm them):
   a speaker is confirmed by a second detection, a lone false alarm is not;
3. the filter-specific update (flow, weights, speaker extraction) of the surviving particles;
4. resampling when the effective sample size ``(sum w)^2 / sum w^2`` (Kong et al., ref. [16])
   falls below half the particles (§2), to ``particles_per_target`` per estimated speaker
   (the LPF resamples each label on its own, :meth:`SMCPHDFilter._resample`).

Likelihoods are densities (:func:`measurement_model`): the visual one per pixel^2, the
DOA-line one per pixel of line offset, a fused pair's their product; the clutter intensities
``kappa`` are in the same units, from the false-alarm rates of the configuration.
"""

from __future__ import annotations

from abc import abstractmethod
from dataclasses import dataclass

import numpy as np

from avtrack.phd.base import PHDConfig, PHDEstimate, PHDFilter
from avtrack.phd.flow import flow_steps
from avtrack.phd.likelihood import AVFrame, pair_log_kernels

STATE_DIM = 4


# --------------------------------------------------------------------------- plain functions


def constant_velocity(
    position_std: float, velocity_std: float, correlation: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Transition matrix ``F`` and process-noise covariance ``Q`` (one frame).

    ``correlation`` is that of the position and velocity noise of one axis (0: independent;
    ``sqrt(3)/2`` for an integrated white-noise acceleration). With it, a position measurement
    also informs the velocity of each particle's own transition (the flow and the weights).

    Returns
    -------
    F : ndarray (4, 4)
        ``[x, y] += [vx, vy]``.
    Q : ndarray (4, 4)
        ``diag(position_std^2, position_std^2, velocity_std^2, velocity_std^2)``.
    """
    F = np.eye(STATE_DIM)
    F[0, 2] = F[1, 3] = 1.0
    if not -1 < correlation < 1:
        raise ValueError(f"constant_velocity: correlation must be in (-1, 1), got {correlation}")
    Q = np.diag([position_std**2] * 2 + [velocity_std**2] * 2)
    Q[0, 2] = Q[2, 0] = Q[1, 3] = Q[3, 1] = correlation * position_std * velocity_std
    return F, Q


def measurement_model(
    frame: AVFrame, config: PHDConfig
) -> tuple[np.ndarray, np.ndarray, float, float, float]:
    """Detection probabilities, clutter intensities and likelihood normalisers of a frame's
    fused measurements (eqs. 11–12, 22–23 with density likelihoods).

    Parameters
    ----------
    frame : AVFrame
    config : PHDConfig

    Returns
    -------
    p_detect : ndarray (R,)
        ``p_ring p_breve`` for a pair, ``(1 - p_ring) p_breve`` for a visual point alone,
        ``p_ring (1 - p_breve)`` for a DOA line alone.
    kappa : ndarray (R,)
        Clutter intensity of each measurement in the unit of its likelihood:
        ``kappa_ring kappa_breve``, ``kappa_breve`` or ``kappa_ring``
        (:class:`~avtrack.phd.base.PHDConfig`, ``clutter_audio`` / ``clutter_visual``).
    p_miss : float
        ``(1 - p_ring)(1 - p_breve)``.
    log_norm_audio, log_norm_visual : float
        ``-log(sqrt(2 pi) sigma_a)`` and ``-log(2 pi sigma_v^2)``: added to the log kernels of
        :func:`~avtrack.phd.likelihood.pair_log_kernels` they give log densities.
    """
    cfg = config
    w, h = cfg.image_size
    k_v = cfg.clutter_visual / (w * h)
    k_a = cfg.clutter_audio / float(np.hypot(w, h))
    pa, pv = cfg.p_detect_audio, cfg.p_detect_visual
    has_a, has_v = frame.pairs[:, 0] > 0, frame.pairs[:, 1] > 0
    p_d = np.where(has_a, pa, 1 - pa) * np.where(has_v, pv, 1 - pv)
    kappa = np.where(has_a, k_a, 1.0) * np.where(has_v, k_v, 1.0)
    log_na = -0.5 * np.log(2 * np.pi * cfg.sigma_audio**2)
    log_nv = -np.log(2 * np.pi * cfg.sigma_visual**2)
    return p_d, kappa, (1 - pa) * (1 - pv), float(log_na), float(log_nv)


def log_pair_norm(frame: AVFrame, log_norm_audio: float, log_norm_visual: float) -> np.ndarray:
    """Log normaliser of each fused measurement's likelihood ``(R,)`` (the sum of its parts'
    :func:`measurement_model` normalisers)."""
    return ((frame.pairs[:, 0] > 0) * log_norm_audio
            + (frame.pairs[:, 1] > 0) * log_norm_visual)


def log_transition_ratio(
    moved: np.ndarray, predicted: np.ndarray, mean: np.ndarray, info: np.ndarray
) -> np.ndarray:
    """``log phi(m_k | .) - log phi(m_{k|k-1} | .)`` of eq. 22 for a Gaussian density
    ``phi = N(mean, info^-1)``.

    Parameters
    ----------
    moved : ndarray (N, 4)
        ``m_k`` (after the flow).
    predicted : ndarray (N, 4)
        ``m_{k|k-1}`` (before the flow).
    mean : ndarray (N, 4)
        The density's mean per particle: ``F m_{k-1}`` for the transition density, or the
        particle's label / cluster mean.
    info : ndarray (4, 4) or (N, 4, 4)
        The inverse covariance: ``Q^-1``, or per particle ``P_{k|k-1}^-1``.

    Returns
    -------
    ndarray (N,)
    """
    e1, e0 = moved - mean, predicted - mean
    if info.ndim == 2:
        info = info[None]
    q1 = np.einsum("ni,nij,nj->n", e1, np.broadcast_to(info, (len(e1), *info.shape[1:])), e1)
    q0 = np.einsum("ni,nij,nj->n", e0, np.broadcast_to(info, (len(e0), *info.shape[1:])), e0)
    return -0.5 * (q1 - q0)


def phd_update(
    likelihood: np.ndarray,
    p_detect: np.ndarray,
    p_miss: float,
    clutter: np.ndarray,
    weights: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The SMC-PHD weight update of seed eqs. 11–12.

    ``w_k^i = [p_miss + sum_r p_D^r h^{i,r} / (kappa^r + G^r)] w^i``,
    ``G^r = sum_i p_D^r h^{i,r} w^i``.

    Parameters
    ----------
    likelihood : ndarray (N, R)
        ``h^{i,r}``.
    p_detect : ndarray (R,)
        Detection probability of each measurement's kind.
    p_miss : float
        Probability that a speaker produces no measurement (``1 - p_D``).
    clutter : ndarray (R,)
        ``kappa(z^r)``.
    weights : ndarray (N,)
        Predicted weights ``w_{k|k-1}`` (already multiplied by any proposal correction).

    Returns
    -------
    weights : ndarray (N,)
    G : ndarray (R,)
    """
    ph = likelihood * p_detect  # p_D h^{i,r}
    G = weights @ ph  # eq. 12: G^r = sum_i p_D h^{i,r} w^i
    return (p_miss + ph @ (1.0 / (clutter + G))) * weights, G  # eq. 11


def effective_sample_size(weights: np.ndarray) -> float:
    """``(sum w)^2 / sum w^2`` (Kong, Liu and Wong 1994); 0 for an empty or zero set."""
    w = np.asarray(weights, dtype=float)
    s2 = float(np.sum(w * w))
    return float(np.sum(w)) ** 2 / s2 if s2 > 0 else 0.0


def systematic_resample(weights: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """Indices of ``n`` particles drawn by systematic resampling (``weights`` need not sum
    to 1)."""
    w = np.asarray(weights, dtype=float)
    total = w.sum()
    if n < 0 or not (total > 0 and np.isfinite(total)):
        raise ValueError(
            f"systematic_resample: need n >= 0 and finite weights with a positive sum, got n={n},"
            f" sum={total}"
        )
    cum = np.cumsum(w / total)
    cum[-1] = 1.0
    u = (rng.random() + np.arange(n)) / n
    return np.minimum(np.searchsorted(cum, u, side="right"), len(w) - 1)


def weighted_moments(
    states: np.ndarray, weights: np.ndarray, group: np.ndarray, n_groups: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-group weighted mean and covariance (seed eqs. 18–20, the indicator ``s`` selecting
    the group).

    Parameters
    ----------
    states : ndarray (N, M)
    weights : ndarray (N,)
    group : ndarray (N,) int in ``0..n_groups-1``
    n_groups : int

    Returns
    -------
    mass : ndarray (G,)
        Summed weights.
    mean : ndarray (G, M)
        ``sum s w m / sum s w`` (eq. 19's second term); 0 for empty groups.
    cov : ndarray (G, M, M)
        ``sum s w e e^T / sum s w`` (eq. 18); 0 for empty groups.
    """
    dim = states.shape[1]
    mass = np.bincount(group, weights, minlength=n_groups)
    wm = np.zeros((n_groups, dim))
    np.add.at(wm, group, weights[:, None] * states)
    safe = np.where(mass > 0, mass, 1.0)
    mean = wm / safe[:, None]
    e = states - mean[group]  # eq. 19: e(m^i) = m^i - weighted label mean
    cov = np.zeros((n_groups, dim, dim))
    np.add.at(cov, group, weights[:, None, None] * e[:, :, None] * e[:, None, :])
    return mass, mean, cov / safe[:, None, None]  # eq. 18


def sample_birth(
    frame: AVFrame, measurements: np.ndarray, n_birth: int, config: PHDConfig,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Birth particles around fused measurements (seed eq. 13).

    The birth density of measurement ``r`` is the product of a Gaussian of spread
    ``birth_std`` around its visual point and, when it has one, its DOA-line kernel: a
    Gaussian with information ``I / birth_std^2 + n n^T / sigma_audio^2`` on the position;
    velocities are ``N(0, birth_velocity_std^2)``.

    Parameters
    ----------
    frame : AVFrame
    measurements : ndarray (K,) int
        Indices (0-based rows of ``frame.pairs``) of the measurements to give births; each
        must have a visual part.
    n_birth : int
        ``N_B``, split as evenly as possible among the measurements.

    Returns
    -------
    states : ndarray (B, 4)
    measurement : ndarray (B,) int
        The measurement each birth particle comes from.
    """
    k = len(measurements)
    if k == 0:
        return np.zeros((0, STATE_DIM)), np.zeros(0, dtype=np.int64)
    counts = np.full(k, n_birth // k) + (np.arange(k) < n_birth % k)
    counts = np.maximum(counts, 1)
    which = np.repeat(np.asarray(measurements, dtype=np.int64), counts)
    pairs = frame.pairs[which]
    if np.any(pairs[:, 1] == 0):
        raise ValueError("sample_birth: births need measurements with a visual part")
    info = np.broadcast_to(np.eye(2) / config.birth_std**2, (len(which), 2, 2)).copy()
    vec = frame.visual[pairs[:, 1] - 1] / config.birth_std**2
    has_a = pairs[:, 0] > 0
    if np.any(has_a):
        line = frame.lines[pairs[has_a, 0] - 1]
        n = line[:, :2]
        info[has_a] += n[:, :, None] * n[:, None, :] / config.sigma_audio**2
        vec[has_a] += n * line[:, 2:3] / config.sigma_audio**2
    cov = np.linalg.inv(info)  # eq. 13: N(F_ring(m)|z_ring) N(F_breve(m)|z_breve) ∝ N(m; mu, C)
    mu = np.einsum("bij,bj->bi", cov, vec)
    eps = rng.standard_normal((len(which), 2))
    pos = mu + np.einsum("bij,bj->bi", np.linalg.cholesky(cov), eps)
    vel = rng.normal(scale=config.birth_velocity_std, size=(len(which), 2))
    return np.hstack([pos, vel]), which


# --------------------------------------------------------------------------- filter skeleton


@dataclass
class Prediction:
    """Predicted surviving particles and their kernels for one frame (internal).

    ``N`` survivors, ``R`` fused measurements.
    """

    states: np.ndarray  # (N, 4) m_{k|k-1}
    mean: np.ndarray  # (N, 4) F m_{k-1}
    weights: np.ndarray  # (N,) w_{k|k-1}
    tids: np.ndarray  # (N,) birth identities
    log_audio: np.ndarray  # (N, R)
    log_visual: np.ndarray  # (N, R)
    gated: np.ndarray  # (N, R) bool, within the gate of every part of r
    explained: np.ndarray  # (R,) bool, G_r (eq. 12 at the predicted particles) > kappa_r


@dataclass
class Births:
    """Birth particles of one frame (internal)."""

    states: np.ndarray  # (B, 4)
    measurement: np.ndarray  # (B,) row of frame.pairs
    weights: np.ndarray  # (B,) eq. 5
    tids: np.ndarray  # (B,)


@dataclass
class Update:
    """What a subclass's update returns (internal): the updated surviving particles (the
    births are added by the skeleton) and the speakers."""

    states: np.ndarray  # (N, 4)
    weights: np.ndarray  # (N,)
    tids: np.ndarray  # (N,)
    speaker_states: np.ndarray  # (J, 4)
    speaker_weights: np.ndarray  # (J,)
    speaker_ids: np.ndarray  # (J,)


class SMCPHDFilter(PHDFilter):
    """Prediction, birth and resampling of a particle AV SMC-PHD filter; subclasses implement
    :meth:`_update` (flow, weights, extraction)."""

    def __init__(self, config: PHDConfig | None = None, seed: int | None = 0) -> None:
        super().__init__(config, seed)
        cfg = self.config
        self.F, self.Q = constant_velocity(cfg.position_std, cfg.velocity_std,
                                           cfg.motion_correlation)
        self.Q_info = np.linalg.inv(self.Q)
        self._Q_chol = np.linalg.cholesky(self.Q)
        self.steps = flow_steps(cfg.flow_steps, cfg.flow_step_ratio)
        self.reset()

    def reset(self) -> None:
        """Forget all particles (an empty PHD)."""
        self.states = np.zeros((0, STATE_DIM))
        self.weights = np.zeros(0)
        self.tids = np.zeros(0, dtype=np.int64)
        self._next_tid = 1

    # ------------------------------------------------------------------ steps

    def _predict(self, frame: AVFrame) -> Prediction:
        cfg = self.config
        mean = self._transition_mean()  # F m_{k-1}
        noise = self.rng.standard_normal(self.states.shape) @ self._Q_chol.T
        pred = mean + noise  # eq. 1 / 14: m_{k|k-1} = F m_{k-1} + n
        log_a, log_v = pair_log_kernels(pred[:, :2], frame, cfg.sigma_visual, cfg.sigma_audio)
        limit = -0.5 * cfg.gate**2
        gated = (log_a >= limit) & (log_v >= limit)
        w = cfg.p_survival * self.weights  # eq. 4: w_{k|k-1} = phi / q w_{k-1} = p_S w_{k-1}
        p_d, kappa, _, log_na, log_nv = measurement_model(frame, cfg)
        log_lik = np.where(gated, log_a + log_v, -np.inf) + log_pair_norm(frame, log_na, log_nv)
        lik = np.exp(log_lik)
        explained = w @ lik * p_d > kappa  # eq. 12 at the predicted particles
        return Prediction(pred, mean, w, self.tids, log_a, log_v, gated, explained)

    def _transition_mean(self) -> np.ndarray:
        """``F m_{k-1}`` of every particle (eq. 1), the mean of its transition density."""
        return self.states @ self.F.T

    def _birth(self, frame: AVFrame, pred: Prediction) -> Births:
        cfg = self.config
        new = np.flatnonzero((frame.pairs[:, 1] > 0) & ~pred.explained)
        states, which = sample_birth(frame, new, cfg.n_birth, cfg, self.rng)
        counts = np.bincount(which, minlength=frame.n_pairs)
        weights = cfg.birth_mass / counts[which] if which.size else np.zeros(0)  # eq. 5
        _, first = np.unique(which, return_inverse=True)
        tids = self._next_tid + first
        self._next_tid += len(new)
        return Births(states, which, weights, tids.astype(np.int64))

    def _step(self, frame: AVFrame) -> PHDEstimate:
        pred = self._predict(frame)
        births = self._birth(frame, pred)
        upd = self._update(frame, pred, births)
        if not np.all(np.isfinite(upd.weights)) or np.any(upd.weights < 0):
            raise FloatingPointError(f"{type(self).__name__}: particle weights are not finite")
        # newborn particles join after the update (adaptive birth, see the module docstring)
        states = np.vstack([upd.states, births.states])
        w = np.concatenate([upd.weights, births.weights])
        tids = np.concatenate([upd.tids, births.tids])
        n = len(w)
        ess = effective_sample_size(w)
        self.states, self.weights, self.tids, resample = self._resample(states, w, tids)
        card = float(self.weights.sum())  # after any pruning
        return PHDEstimate(
            upd.speaker_states,
            upd.speaker_weights,
            upd.speaker_ids,
            ess,
            n,
            bool(resample),
            card,
        )

    def _resample(
        self, states: np.ndarray, weights: np.ndarray, tids: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
        """Resample all particles together when their ESS falls below ``resample_fraction``
        of their number (§2), to ``particles_per_target`` per estimated speaker."""
        cfg = self.config
        card, n = float(weights.sum()), len(weights)
        n_target = cfg.particles_per_target * max(1, round(card))
        resample = n > 0 and (
            effective_sample_size(weights) < cfg.resample_fraction * n or n > 10 * n_target
        )
        if resample and card > 0:
            idx = systematic_resample(weights, n_target, self.rng)
            return states[idx], np.full(n_target, card / n_target), tids[idx], True
        return states, weights, tids, bool(resample)

    @abstractmethod
    def _update(self, frame: AVFrame, pred: Prediction, births: Births) -> Update: ...
