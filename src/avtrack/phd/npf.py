"""AV-NPF-SMC-PHD: the non-zero particle flow SMC-PHD filter with clustering (Liu et al. §2, the
baseline of ref. [9]).

- The predicted particles are clustered by k-means (k-means++ seeding, ref. [15]) into
  ``round(sum w_{k|k-1})`` clusters; each particle's prior covariance ``P_{k|k-1}`` (eq. 9)
  is its cluster's weighted covariance plus the process noise ``Q``.
- The flow (eqs. 6–9) moves every surviving particle towards the audio-visual likelihood of
  eq. 10 over *all* measurements — the weighted mean of every visual kernel and every DOA-line
  kernel — plus a constant background ``kappa`` (so that particles far from every measurement
  are not pulled); its Hessian is the Gauss–Newton one (:func:`~avtrack.phd.flow.mixture_flow`),
  one 4×4 inverse per particle and step.
- The weights follow the PHD update of eqs. 11–12 over the fused measurements, the likelihood
  of a measurement being the product of the densities of its parts (as eq. 21: the weighted
  mean of eq. 10 would give every particle on a DOA line half the weight of a particle on the
  speaker) with ``p_D`` and ``kappa`` of :func:`~avtrack.phd.smc_phd.measurement_model`,
  times the flow's proposal factor of eq. 22. The flow is deterministic (``diffusion`` is
  not used: the stochastic per-particle flow has no tractable density) and eq. 22's factor
  uses the exact Jacobian of the flow, so it is an importance weight; the flow's mixture
  keeps the seed's background ``kappa`` (peak-1 kernels) as its floor.
- Speakers are the centroids of a weighted k-means of the updated particles into
  ``round(sum w_k)`` clusters, weighted by their cluster masses (§2). Identities: none (-1).
"""

from __future__ import annotations

import numpy as np

from avtrack.phd.base import register_phd_filter
from avtrack.phd.flow import mixture_flow
from avtrack.phd.likelihood import (
    AVFrame,
    audio_information,
    pair_log_kernels,
    visual_information,
)
from avtrack.phd.lpf import SEED_KAPPA
from avtrack.phd.smc_phd import (
    STATE_DIM,
    Births,
    Prediction,
    SMCPHDFilter,
    Update,
    log_pair_norm,
    log_transition_ratio,
    measurement_model,
    phd_update,
    weighted_moments,
)


def kmeans(
    points: np.ndarray,
    k: int,
    rng: np.random.Generator,
    weights: np.ndarray | None = None,
    n_iter: int = 10,
) -> tuple[np.ndarray, np.ndarray]:
    """Weighted k-means with k-means++ seeding (Arthur and Vassilvitskii 2007, seed ref. [15]).

    Parameters
    ----------
    points : ndarray (N, d)
    k : int
        Number of clusters, ``1 <= k <= N``.
    rng : numpy.random.Generator
    weights : ndarray (N,), optional
        Non-negative point weights (uniform when omitted).
    n_iter : int
        Lloyd iterations (stops early when the assignment is stable).

    Returns
    -------
    centres : ndarray (k, d)
    assign : ndarray (N,) int
    """
    pts = np.asarray(points, dtype=float)
    n = pts.shape[0]
    if not 1 <= k <= n:
        raise ValueError(f"kmeans: k must be in 1..{n}, got {k}")
    w = np.ones(n) if weights is None else np.asarray(weights, dtype=float)
    w_seed = w + 1e-300
    centres = np.empty((k, pts.shape[1]))
    centres[0] = pts[rng.choice(n, p=w_seed / w_seed.sum())]
    d2 = np.sum((pts - centres[0]) ** 2, axis=1)
    for j in range(1, k):  # k-means++: next centre with probability ∝ w D^2
        p = w_seed * d2
        centres[j] = pts[rng.choice(n, p=p / p.sum())] if p.sum() > 0 else pts[j]
        d2 = np.minimum(d2, np.sum((pts - centres[j]) ** 2, axis=1))
    assign = np.full(n, -1)
    for _ in range(n_iter):
        dist = np.sum((pts[:, None, :] - centres[None]) ** 2, axis=2)
        new = np.argmin(dist, axis=1)
        if np.array_equal(new, assign):
            break
        assign = new
        mass = np.bincount(assign, w, minlength=k)
        sums = np.zeros_like(centres)
        np.add.at(sums, assign, w[:, None] * pts)
        ok = mass > 0
        centres[ok] = sums[ok] / mass[ok, None]
    return centres, assign


@register_phd_filter("npf")
class NPFSMCPHD(SMCPHDFilter):
    """AV-NPF-SMC-PHD filter (Liu et al. §2, ref. [9]).

    Parameters
    ----------
    config : PHDConfig, optional
    seed : int, optional
        Seed of the filter's random generator.
    kmeans_iterations : int
        Lloyd iterations of each k-means.
    """

    def __init__(self, config=None, seed: int | None = 0, kmeans_iterations: int = 10) -> None:
        if kmeans_iterations < 1:
            raise ValueError(f"kmeans_iterations must be >= 1, got {kmeans_iterations}")
        self.kmeans_iterations = int(kmeans_iterations)
        super().__init__(config, seed)

    def _components(self, frame: AVFrame):
        """Quadratic forms of every kernel of eq. 10 (DOA lines, then visual points)."""
        cfg = self.config
        n_o, n_u = frame.lines.shape[0], frame.visual.shape[0]
        Aa, ba = audio_information(frame.lines, cfg.sigma_audio)
        Av, bv = visual_information(frame.visual, cfg.sigma_visual)
        norm = n_o * cfg.weight_audio + n_u * cfg.weight_visual  # |w_ring|_1 + |w_breve|_1
        with np.errstate(divide="ignore"):
            log_wa = np.log(cfg.weight_audio / norm) if norm > 0 else 0.0
            log_wv = np.log(cfg.weight_visual / norm) if norm > 0 else 0.0
        log_c = np.concatenate([
            log_wa - 0.5 * frame.lines[:, 2] ** 2 / cfg.sigma_audio**2,
            log_wv - 0.5 * np.sum(frame.visual**2, axis=1) / cfg.sigma_visual**2,
        ])  # fmt: skip
        B = np.zeros((n_o + n_u, STATE_DIM, 3))
        B[:n_o, :2, 2] = frame.lines[:, :2] / cfg.sigma_audio
        B[n_o:, 0, 0] = B[n_o:, 1, 1] = 1.0 / cfg.sigma_visual
        A = np.concatenate([Aa, Av])
        b = np.concatenate([ba, bv])
        keep = np.isfinite(log_c)  # a modality with zero weight contributes nothing
        return A[keep], b[keep], log_c[keep], B[keep], keep

    def _cluster_gate(self, frame: AVFrame, centre: np.ndarray, cov: np.ndarray) -> np.ndarray:
        """Kernels of eq. 10 within the gate of each cluster: ``(k, O + U)`` bool.

        A DOA line is gated by its distance to the cluster centre over
        ``sqrt(n^T C n + sigma_a^2)``, a visual point by its Mahalanobis distance for
        ``C + sigma_v^2 I`` (``C``: the cluster's position covariance).
        """
        cfg = self.config
        lines = frame.lines
        d_a = centre @ lines[:, :2].T - lines[:, 2]  # (k, O)
        var_a = np.einsum("oi,kij,oj->ko", lines[:, :2], cov, lines[:, :2]) + cfg.sigma_audio**2
        S_v = np.linalg.inv(cov + cfg.sigma_visual**2 * np.eye(2))
        e = frame.visual[None, :, :] - centre[:, None, :]  # (k, U, 2)
        d2_v = np.einsum("kui,kij,kuj->ku", e, S_v, e)
        g2 = cfg.gate**2
        return np.hstack([d_a**2 / var_a <= g2, d2_v <= g2])

    def _update(self, frame: AVFrame, pred: Prediction, births: Births) -> Update:
        cfg = self.config
        n = len(pred.weights)

        moved = pred.states.copy()
        log_rho = np.zeros(n)
        A, b, log_c, B, keep = self._components(frame)
        if n and len(A):
            # clustering: per-speaker covariances P_{k|k-1} of eq. 9
            k = int(min(n, max(1, round(pred.weights.sum()))))
            n_it = self.kmeans_iterations
            _, assign = kmeans(pred.states[:, :2], k, self.rng, pred.weights, n_it)
            _, mean, cov = weighted_moments(pred.states, pred.weights, assign, k)
            P = cov + self.Q
            allowed = self._cluster_gate(frame, mean[:, :2], P[:, :2, :2])[:, keep][assign]
            prior_info = np.linalg.inv(P)[assign]
            # eq. 10: every particle flows towards the mixture of every kernel within the
            # cluster's gate, over a background (the seed's kappa in the kernels' unit)
            x, floor = pred.states, np.log(2 * SEED_KAPPA)
            # the deterministic flow, whose exact Jacobian makes eq. 22 an importance weight
            # (the stochastic one has no tractable density)
            moved, log_det = mixture_flow(x, prior_info, A, b, log_c, B, self.steps, floor,
                                          0.0, self.rng, allowed,
                                          exact_jacobian=True)  # fmt: skip
            # the flow's proposal factor, eq. 22: |det J| phi(m_k | .) / phi(m_k|k-1 | .)
            log_rho = log_det + log_transition_ratio(moved, pred.states, pred.mean, self.Q_info)

        rho = np.exp(np.clip(log_rho, -500, 500))
        w_prior = pred.weights * rho
        tids = pred.tids
        log_a, log_v = pair_log_kernels(moved[:, :2], frame, cfg.sigma_visual, cfg.sigma_audio)
        # densities, with p_D and kappa of each fused measurement
        p_d, kappa, p_miss, log_na, log_nv = measurement_model(frame, cfg)
        lik = np.exp(log_a + log_v + log_pair_norm(frame, log_na, log_nv))
        weights, _ = phd_update(lik, p_d, p_miss, kappa, w_prior)  # eqs. 11-12

        # state extraction by clustering the updated particles (§2)
        card = weights.sum()
        k = int(min(len(weights), round(card)))
        if k >= 1:
            _, assign = kmeans(moved[:, :2], k, self.rng, weights, self.kmeans_iterations)
            mass, mean, _ = weighted_moments(moved, weights, assign, k)
            ok = mass > 0
            return Update(moved, weights, tids, mean[ok], mass[ok], np.full(ok.sum(), -1))
        return Update(moved, weights, tids, np.zeros((0, STATE_DIM)), np.zeros(0), np.zeros(0))
