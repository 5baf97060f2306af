"""AV-LPF-SMC-PHD: the labelled non-zero particle flow SMC-PHD filter (Liu et al. §3, Alg. 1).

Every particle carries an audio label ``l_ring`` and a visual label ``l_breve`` — the
measurement it is associated with, 0 for none — instead of a cluster:

- births are labelled with the measurement they are drawn from (eq. 13);
- a surviving particle takes the best measurement within the gate (eqs. 15–16: the argmax of
  the product of the audio and visual kernels, eq. 21), each of its two labels kept with
  probability ``p_D`` of that modality (the random ``r(1) < p_D`` of eq. 17);
- the covariance ``P_{k|k-1}`` of a particle is the weighted covariance of the predicted
  particles with the same two labels (eqs. 18–20), plus the process noise ``Q`` (a floor for
  labels held by a single particle);
- the flow (eqs. 6–9) uses the particle's own likelihood (eq. 21), the product of its labelled
  kernels: quadratic in the state, so the flow is affine and shared by all particles with the
  same labels (one 4×4 inverse per label and step, :func:`~avtrack.phd.flow.affine_flow`);
- weights follow eqs. 22–23, with the flow's proposal factor (Jacobian determinant and
  density ratio) chosen by :attr:`PHDConfig.flow_weights` (default: the transition-density
  ratio written in eq. 22);
- the speakers are the measurements whose labelled particles weigh at least ``xi`` (0.5), at
  their particles' weighted mean (eqs. 24–25). No clustering anywhere.

Labels refer to the fused measurements of :func:`~avtrack.phd.likelihood.pair_measurements`:
the audio and visual labels of a particle are the two parts ``(o_r, u_r)`` of one fused
measurement ``r`` (or one of them, or none, after the ``p_D`` draw). Deviations from the
seed's text, each needed to keep a speaker from being counted twice or the weights from being
unbounded: the normaliser ``G`` of eq. 23 sums over all particles labelled with a part of the
same fused measurement (not only those with both labels equal), the label-(0, 0) weight of
eq. 22 keeps the factor ``w_{k|k-1}`` of eq. 11, and eqs. 24–25 use the updated weights and
states. Reported speakers carry the identity of the birth that most of their weight descends
from.
"""

from __future__ import annotations

import numpy as np

from avtrack.phd.base import register_phd_filter
from avtrack.phd.flow import affine_flow
from avtrack.phd.likelihood import AVFrame, audio_information, visual_information
from avtrack.phd.smc_phd import (
    STATE_DIM,
    Births,
    Prediction,
    SMCPHDFilter,
    Update,
    log_transition_ratio,
    weighted_moments,
)

_BOTH, _AUDIO, _VISUAL = 0, 1, 2  # which parts of the fused measurement a particle keeps


def label_information(
    frame: AVFrame, measurement: np.ndarray, kind: np.ndarray, sigma_visual: float,
    sigma_audio: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """Quadratic form of the eq. 21 log-likelihood of label groups.

    Parameters
    ----------
    frame : AVFrame
    measurement : ndarray (G,) int
        Fused measurement (row of ``frame.pairs``) of each group.
    kind : ndarray (G,) int
        0: both parts, 1: the audio part only, 2: the visual part only.

    Returns
    -------
    A : ndarray (G, 4, 4), b : ndarray (G, 4), B : ndarray (G, 4, 3)
        ``log h = -1/2 m^T A m + b^T m + const`` and ``A = B B^T``.
    """
    g = len(measurement)
    pairs = frame.pairs[measurement]
    use_a = (pairs[:, 0] > 0) & (kind != _VISUAL)
    use_v = (pairs[:, 1] > 0) & (kind != _AUDIO)
    A = np.zeros((g, STATE_DIM, STATE_DIM))
    b = np.zeros((g, STATE_DIM))
    B = np.zeros((g, STATE_DIM, 3))
    if np.any(use_v):
        Av, bv = visual_information(frame.visual[pairs[use_v, 1] - 1], sigma_visual)
        A[use_v] += Av
        b[use_v] += bv
        B[use_v, 0, 0] = B[use_v, 1, 1] = 1.0 / sigma_visual
    if np.any(use_a):
        lines = frame.lines[pairs[use_a, 0] - 1]
        Aa, ba = audio_information(lines, sigma_audio)
        A[use_a] += Aa
        b[use_a] += ba
        B[use_a, :2, 2] = lines[:, :2] / sigma_audio
    return A, b, B


def _majority(tids: np.ndarray, weights: np.ndarray, group: np.ndarray, n_groups: int):
    """Per group, the tid carrying most weight (-1 for an empty group)."""
    out = np.full(n_groups, -1, dtype=np.int64)
    if tids.size == 0:
        return out
    uniq, inv = np.unique(tids, return_inverse=True)
    table = np.zeros((n_groups, len(uniq)))
    np.add.at(table, (group, inv), weights)
    has = table.sum(axis=1) > 0
    out[has] = uniq[np.argmax(table[has], axis=1)]
    return out


@register_phd_filter("lpf")
class LPFSMCPHD(SMCPHDFilter):
    """AV-LPF-SMC-PHD filter (Liu et al., Algorithm 1).

    Parameters
    ----------
    config : PHDConfig, optional
    seed : int, optional
        Seed of the filter's random generator (prediction noise, births, label draws, flow
        diffusion, resampling).
    """

    def _update(self, frame: AVFrame, pred: Prediction, births: Births) -> Update:
        cfg = self.config
        pairs = frame.pairs
        n_r = frame.n_pairs
        n = len(pred.weights)
        pa, pv = cfg.p_detect_audio, cfg.p_detect_visual
        kappa = cfg.clutter_audio + cfg.clutter_visual

        # eqs. 15-17: best gated measurement, each part kept with probability p_D
        meas = np.full(n, -1, dtype=np.int64)
        kind = np.zeros(n, dtype=np.int64)
        if n and n_r:
            score = np.where(pred.gated, pred.log_audio + pred.log_visual, -np.inf)
            best = np.argmax(score, axis=1)
            found = np.isfinite(score[np.arange(n), best])
            keep_a = (self.rng.random(n) < pa) & (pairs[best, 0] > 0)  # delta_{r(1)}(p_D)
            keep_v = (self.rng.random(n) < pv) & (pairs[best, 1] > 0)
            det = found & (keep_a | keep_v)
            meas[det] = best[det]
            kind = np.where(keep_a & keep_v, _BOTH, np.where(keep_a, _AUDIO, _VISUAL))
        det = meas >= 0
        moved = pred.states.copy()
        log_rho = np.zeros(n)
        if np.any(det):
            key = meas[det] * 3 + kind[det]
            ukey, group = np.unique(key, return_inverse=True)
            # eqs. 18-20: covariance of the predicted particles sharing both labels
            _, mean, cov = weighted_moments(pred.states[det], pred.weights[det], group, len(ukey))
            prior_info = np.linalg.inv(cov + self.Q)
            A, b, B = label_information(
                frame, ukey // 3, ukey % 3, cfg.sigma_visual, cfg.sigma_audio
            )
            x = pred.states[det]
            # eqs. 6-9 with the label likelihood of eq. 21
            m_k, log_det = affine_flow(x, group, prior_info, A, b, B, self.steps, cfg.diffusion,
                                       self.rng)  # fmt: skip
            moved[det] = m_k
            # eq. 22: |det(I + dl grad f)| phi(m_k | .) / phi(m_k|k-1 | .)
            if cfg.flow_weights == "transition":
                log_rho[det] = log_det + log_transition_ratio(
                    m_k, pred.states[det], pred.mean[det], self.Q_info
                )
            elif cfg.flow_weights == "gaussian":
                log_rho[det] = log_det + log_transition_ratio(
                    m_k, pred.states[det], mean[group], prior_info[group]
                )

        # eq. 21 at the moved particles and at the births (labelled with both parts)
        states = np.vstack([moved, births.states])
        meas_all = np.concatenate([meas, births.measurement])
        kind_all = np.concatenate([kind, np.full(len(births.measurement), _BOTH)])
        w_prior = np.concatenate([pred.weights, births.weights])
        rho = np.exp(np.clip(np.concatenate([log_rho, np.zeros(len(births.weights))]), -500, 500))
        lab = meas_all >= 0
        r = meas_all[lab]
        o = pairs[r, 0] * (kind_all[lab] != _VISUAL)
        u = pairs[r, 1] * (kind_all[lab] != _AUDIO)
        pos = states[lab, :2]
        log_h = np.zeros(len(r))
        ha, hv = o > 0, u > 0
        line = frame.lines[o[ha] - 1]
        d_a = np.einsum("ni,ni->n", pos[ha], line[:, :2]) - line[:, 2]
        log_h[ha] -= 0.5 * (d_a / cfg.sigma_audio) ** 2
        d2_v = np.sum((pos[hv] - frame.visual[u[hv] - 1]) ** 2, axis=1)
        log_h[hv] -= 0.5 * d2_v / cfg.sigma_visual**2
        # p_ring^delta0(l_ring) p_breve^delta0(l_breve) of eqs. 22-23
        p_d = np.where(ha, pa, 1.0) * np.where(hv, pv, 1.0)
        num = p_d * np.exp(log_h) * rho[lab] * w_prior[lab]
        G = np.bincount(r, num, minlength=n_r)  # eq. 23 (over the particles of measurement r)
        weights = (1 - pa) * (1 - pv) * w_prior  # eq. 22, l_ring = l_breve = 0
        weights[lab] = num / (kappa + G[r])  # eq. 22, labelled particles

        # eqs. 24-25: speakers = measurements whose particles weigh at least xi
        tids = np.concatenate([pred.tids, births.tids])
        group = np.where(lab, meas_all, n_r)
        mass, mean, _ = weighted_moments(states, weights, group, n_r + 1)
        keep = np.flatnonzero(mass[:n_r] >= cfg.extraction_threshold)
        ids = _majority(tids[lab], weights[lab], meas_all[lab], n_r)[keep]
        ids = _unique_ids(ids, mass[keep])
        return Update(states, weights, tids, mean[keep], mass[keep], ids)


def _unique_ids(ids: np.ndarray, mass: np.ndarray) -> np.ndarray:
    """Keep each identity on its heaviest speaker; the others get -1."""
    out = ids.copy()
    seen: set[int] = set()
    for i in np.argsort(-mass, kind="stable"):
        if out[i] >= 0 and int(out[i]) in seen:
            out[i] = -1
        seen.add(int(out[i]))
    return out
