"""AV-LPF-SMC-PHD: the labelled non-zero particle flow SMC-PHD filter (Liu et al. §3, Alg. 1).

Every particle carries a *track label* (the birth it descends from) and, on each frame, the
fused measurement its label is associated with — its audio label ``l_ring`` and visual label
``l_breve`` are the two parts ``(o_r, u_r)`` of that measurement — instead of a cluster:

- each label takes at most one fused measurement and each measurement at most one label
  (eqs. 15–16 per label: an assignment maximising ``sum log((kappa_r + G_lr) / kappa_r)``,
  eq. 11's factor of the measurement, over the gated pairs — for a DOA line alone only where
  the label explains it better than clutter — ``G_lr`` = eq. 12 over the label's gated
  predicted particles, :meth:`LPFSMCPHD._associate`, ``PHDConfig.association``);
- a face that two confirmed labels explain almost equally well (the best assignment less
  than ``ambiguity_ratio`` times more likely than the best without that pair: two speakers
  crossing with one face detected) goes to neither; those labels are undetectable on that
  frame (``p_D = 0`` in eq. 22, the occluded speaker is still present) and coast on their
  own transitions, at their own velocities, for up to ``occlusion_frames`` frames in a row
  (:meth:`LPFSMCPHD._ambiguous`; not in the seed, see the README's departures);
- births (eq. 13) come from visual measurements that no label takes, join the PHD after the
  frame's update (:mod:`~avtrack.phd.smc_phd`), and take the label of a confirmed label
  without a measurement, or of a recently dropped one, found near them (the older label is
  kept; a dropped label stays a candidate until it is confirmed again; among several, the
  one whose spread since it was dropped makes the birth most likely, ``relink_rule``);
- the flow (eqs. 6–9) uses the label's likelihood (eq. 21, Gaussian in the position: the flow
  is affine) with a quarter of eqs. 18–20's label covariance plus ``Q`` as the prior of eq. 9
  (``flow_prior="label"``, ``label_prior_scale`` 0.25, :func:`label_flow_prior`;
  ``"transition"``: the particle's own ``Q``), composed into one Gaussian map per label
  (:func:`~avtrack.phd.flow.affine_flow_map`);
- a label whose last update had no face point (a DOA line alone, which does not measure the
  distance along the line, or no measurement) is predicted with its velocity decayed by
  ``faceless_velocity_decay`` per frame (:meth:`LPFSMCPHD._transition_mean`; not in the
  seed): it no longer runs off along a DOA line at the velocity it entered the face gap
  with;
- weights follow eqs. 22–23 with density likelihoods and clutter intensities
  (:func:`~avtrack.phd.smc_phd.measurement_model`) and the importance weight of the flow
  actually run: for the label's predicted intensity against the mixture of its parents'
  flows, ``sum_j w_j phi(m_k | m_{k-1}^j) / sum_j q(m_k | m_{k-1}^j)``
  (``marginal_weights``, default), or per parent ``phi(m_k | m_{k-1}) / q(m_k | m_{k-1})``;
- a speaker is a label whose weight on its measurement (eq. 25) is at least ``xi``, at its
  particles' weighted mean (eq. 24); resampling follows Algorithm 1's ESS test over all the
  particles (``resample_rule``), each label resampled on its own. No clustering.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from avtrack.phd.base import register_phd_filter
from avtrack.phd.flow import affine_flow_map, log_gaussian, marginal_log_weights
from avtrack.phd.likelihood import AVFrame, audio_information, visual_information
from avtrack.phd.smc_phd import (
    STATE_DIM,
    Births,
    Prediction,
    SMCPHDFilter,
    Update,
    log_pair_norm,
    measurement_model,
    systematic_resample,
    weighted_moments,
)

#: The seed's clutter terms (§4: kappa_ring = kappa_breve = 0.0035), in the unit of kernels that
#: peak at 1: the background of the NPF's mixture flow.
SEED_KAPPA = 0.0035


def label_information(
    frame: AVFrame, measurement: np.ndarray, sigma_visual: float, sigma_audio: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Quadratic form of the eq. 21 log-likelihood of label groups.

    Parameters
    ----------
    frame : AVFrame
    measurement : ndarray (G,) int
        Fused measurement (row of ``frame.pairs``) of each group; both of its parts are used.

    Returns
    -------
    A : ndarray (G, 4, 4), b : ndarray (G, 4), B : ndarray (G, 4, 3)
        ``log h = -1/2 m^T A m + b^T m + const`` and ``A = B B^T``.
    """
    g = len(measurement)
    pairs = frame.pairs[measurement]
    use_a = pairs[:, 0] > 0
    use_v = pairs[:, 1] > 0
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


def label_flow_prior(cov: np.ndarray, Q: np.ndarray, scale: float = 1.0) -> np.ndarray:
    """Prior covariance of eq. 9 for the labelled flow: ``scale * Sigma_l + Q``.

    ``Sigma_l`` (``cov``, (G, 4, 4)) is the weighted covariance of each label's predicted
    particles (eqs. 18–20); ``Q`` the transition covariance, a floor. ``scale`` 1 is the
    seed's ``P_{k|k-1}``; 0 the particle's own transition prior (``flow_prior=
    "transition"``). Between the two the flow moves a label's particles by more than their
    own transition allows but less than the label-wide Kalman gain; the weights stay the
    flow's importance weights for any ``scale`` (``PHDConfig.label_prior_scale``).
    """
    return scale * np.asarray(cov) + Q


@register_phd_filter("lpf")
class LPFSMCPHD(SMCPHDFilter):
    """AV-LPF-SMC-PHD filter (Liu et al., Algorithm 1).

    Parameters
    ----------
    config : PHDConfig, optional
    seed : int, optional
        Seed of the filter's random generator (prediction noise, births, flow diffusion,
        resampling).
    """

    def reset(self) -> None:
        super().reset()
        self._frame = 0
        self._confirmed: dict[int, int] = {}  # label -> last frame its weight was >= xi
        self._assoc: dict[int, int] = {}  # label -> its measurement on the current frame
        self._seen: dict[int, np.ndarray] = {}  # confirmed label -> position when last >= xi
        self._lost: dict[int, tuple[np.ndarray, int]] = {}  # dropped label -> (position, frame)
        self._occluded: set[int] = set()  # labels coasting through an ambiguous frame
        self._held: dict[int, int] = {}  # such label -> consecutive frames coasted
        self._withheld: set[int] = set()  # the measurements they leave to nobody
        self._faceless: set[int] = set()  # labels whose last update had no face point

    def _transition_mean(self) -> np.ndarray:
        """``F m_{k-1}``; for a label whose last update had no face point (a DOA line alone or
        no measurement, not an occluded label), the velocity decays by
        ``faceless_velocity_decay`` per frame (``F`` with ``a`` in the velocity block)."""
        mean = super()._transition_mean()
        a = self.config.faceless_velocity_decay
        if a < 1 and self._faceless and len(mean):
            sel = np.isin(self.tids, list(self._faceless))
            mean[sel, 2:] = a * self.states[sel, 2:]
        return mean

    def _associate(self, frame: AVFrame, pred: Prediction) -> dict[int, int]:
        """Label-to-measurement association (eqs. 15–16 taken per label): each label takes at
        most one fused measurement and each measurement at most one label, maximising the sum
        of the pairs' scores, ``G_lr = sum_{i in l} p_D^r h^{i,r} w_{k|k-1}^i`` (eq. 12 over
        the label's gated predicted particles). ``PHDConfig.association``: ``"clutter"``, the
        pairs with ``G_lr > kappa_r`` scored ``log(G_lr / kappa_r)``; ``"phd"``, every gated
        pair scored ``log((kappa_r + G_lr) / kappa_r)``, the measurement's factor in eq. 11
        (the label then keeps ``G_lr / (kappa_r + G_lr)`` of it, eq. 22, and a birth gathers
        evidence over frames however high the clutter); ``"face"`` (default), ``"phd"`` for
        measurements with a face point and ``"clutter"`` for a DOA line alone.

        Returns
        -------
        dict
            label -> row of ``frame.pairs``.
        """
        cfg = self.config
        if len(pred.weights) == 0 or frame.n_pairs == 0:
            return {}
        p_d, kappa, _, log_na, log_nv = measurement_model(frame, cfg)
        lik = np.exp(np.where(pred.gated, pred.log_audio + pred.log_visual, -np.inf)
                     + log_pair_norm(frame, log_na, log_nv)) * p_d
        uniq, group = np.unique(pred.tids, return_inverse=True)
        G = np.zeros((len(uniq), frame.n_pairs))
        np.add.at(G, group, pred.weights[:, None] * lik)
        if cfg.association == "clutter":  # the label must explain r better than clutter
            with np.errstate(divide="ignore"):
                score = np.log(G) - np.log(kappa)
            ok = score > 0
        else:  # eq. 11's factor of r, (kappa_r + G_lr) / kappa_r, for any gated label
            score = np.log1p(G / kappa)
            ok = G > 0
            if cfg.association == "face":  # a DOA line alone: better than clutter only
                ok &= (frame.pairs[:, 1] > 0)[None, :] | (G > kappa)
        if not np.any(ok):
            return {}
        cost = np.where(ok, -score, 0.0)
        rows, cols = linear_sum_assignment(cost)
        assoc = {int(uniq[i]): int(r) for i, r in zip(rows, cols, strict=True) if ok[i, r]}
        if cfg.ambiguity_ratio > 1 and cfg.occlusion_frames > 0 and len(frame.visual):
            # the faces' own scores: eq. 12 with the visual part of the likelihood only
            limit = -0.5 * cfg.gate**2
            n_u = len(frame.visual)
            face_pairs = np.flatnonzero(frame.pairs[:, 1] > 0)
            col = frame.pairs[face_pairs, 1] - 1
            first = np.full(n_u, -1)
            first[col[::-1]] = face_pairs[::-1]  # one pair per face for its kernel
            lv = pred.log_visual[:, first]
            paired = (first >= 0)[None, :]
            lik_v = np.exp(np.where(paired & (lv >= limit), lv, -np.inf) + log_nv
                           ) * cfg.p_detect_visual
            Gv = np.zeros((len(uniq), n_u))
            np.add.at(Gv, group, pred.weights[:, None] * lik_v)
            k_v = cfg.clutter_visual / float(np.prod(cfg.image_size))
            for tid in self._ambiguous(uniq, Gv, k_v, frame, assoc):
                assoc.pop(tid, None)
        return assoc

    def _ambiguous(
        self, uniq: np.ndarray, Gv: np.ndarray, kappa_v: float, frame: AVFrame,
        assoc: dict[int, int],
    ) -> set[int]:  # fmt: skip
        """Confirmed labels whose faces are ambiguous (occlusion rule, not in the seed).

        The faces are assigned to the labels alone (at most one each), maximising
        ``sum log((kappa_breve + Gv_lu) / kappa_breve)`` with ``Gv_lu`` eq. 12 over the
        label's gated particles with the visual likelihood only. For each face ``u`` that
        this assignment gives to a confirmed label ``l``, the best assignment with ``(l, u)``
        forbidden is found; when it scores within ``log(ambiguity_ratio)`` of the best, and
        the labels whose face differs between the two are all confirmed (two speakers
        crossing with one face detected, or two faces at the crossing point), those labels
        take no measurement on the frame: each is undetectable (``p_D = 0``: an occluded
        speaker is still present) and coasts on its transition at its own velocity instead of
        being pulled onto the other's face. A label coasts so for at most
        ``occlusion_frames`` frames in a row; then the association of :meth:`_associate`
        applies. The pairs holding an ambiguous face give no births.

        Parameters
        ----------
        uniq : ndarray (L,) int
            The labels, rows of ``Gv``.
        Gv : ndarray (L, U)
            ``Gv_lu`` for each label and face of the frame.
        kappa_v : float
            Visual clutter intensity (per pixel^2).
        assoc : dict
            The frame's association (label -> row of ``frame.pairs``).

        Returns
        -------
        set of int
            The labels that coast; also kept in ``self._occluded``.
        """
        cfg = self.config
        ok = Gv > 0
        cost = np.where(ok, -np.log1p(Gv / kappa_v), 0.0)
        rows, cols = linear_sum_assignment(cost)
        best_pairs = {int(uniq[i]): int(u) for i, u in zip(rows, cols, strict=True) if ok[i, u]}
        index = {int(t): i for i, t in enumerate(uniq.tolist())}
        best = -sum(cost[index[t], u] for t, u in best_pairs.items())
        out: set[int] = set()
        faces: set[int] = set()
        for tid, u in best_pairs.items():
            if tid in out or tid not in self._confirmed:
                continue
            forbid = cost.copy()
            forbid[index[tid], u] = 1e12  # the pair (l, u) forbidden
            rows, cols = linear_sum_assignment(forbid)
            alt = {int(uniq[i]): int(c) for i, c in zip(rows, cols, strict=True)
                   if ok[i, c] and not (i == index[tid] and c == u)}
            alt_score = -sum(cost[index[t], c] for t, c in alt.items())
            if best - alt_score >= np.log(cfg.ambiguity_ratio):
                continue
            changed = {t for t in set(best_pairs) | set(alt) if best_pairs.get(t) != alt.get(t)}
            if len(changed) < 2 or not all(t in self._confirmed for t in changed):
                continue  # not two speakers competing for the same faces
            if any(self._held.get(t, 0) >= cfg.occlusion_frames for t in changed):
                continue  # held long enough: the association decides
            out |= changed
            faces |= {best_pairs[t] for t in changed if t in best_pairs}
        self._held = {t: self._held.get(t, 0) + 1 for t in out}
        self._occluded = out
        self._withheld = {int(r) for r in np.flatnonzero(np.isin(frame.pairs[:, 1] - 1,
                                                                 list(faces)))}
        self._withheld |= {assoc[t] for t in out if t in assoc}
        return out

    def _birth(self, frame: AVFrame, pred: Prediction) -> Births:
        """Births of :meth:`SMCPHDFilter._birth` for the measurements that no label takes
        (:meth:`_associate`); a birth within ``relabel_distance`` of a confirmed label that
        takes no measurement of the frame continues that label (the older label is kept: a
        speaker whose detections jumped out of its gate, or who reappears after a miss, keeps
        its identity)."""
        cfg = self.config
        self._occluded, self._withheld = set(), set()
        self._assoc = self._associate(frame, pred)
        if not self._occluded:
            self._held = {}
        taken = np.zeros(frame.n_pairs, dtype=bool)
        taken[list(self._assoc.values())] = True
        taken[list(self._withheld)] = True  # an ambiguous face: a speaker, not a new one
        pred.explained = taken
        births = super()._birth(frame, pred)
        self._lost = {t: v for t, v in self._lost.items()
                      if self._frame - v[1] <= cfg.relink_frames}
        if not (len(births.tids) and (self._confirmed or self._lost)
                and cfg.relabel_distance > 0):
            return births
        # candidates: confirmed labels alive but without a measurement (at their predicted
        # mean), then dropped labels (where they were last confirmed)
        uniq, group = np.unique(pred.tids, return_inverse=True)
        _, mean, _ = weighted_moments(pred.states, pred.weights + 1e-300, group, len(uniq))
        cand = [(int(t), mean[j, :2], 0) for j, t in enumerate(uniq.tolist())
                if t in self._confirmed and t not in self._assoc and t not in self._occluded]
        # a dropped label stays a candidate until it is confirmed again: a relinked birth that
        # is never confirmed (a lone detection) must not use the label up
        alive = set(uniq.tolist())
        cand += [(t, pos, self._frame - f) for t, (pos, f) in self._lost.items()
                 if t not in alive]
        tids = births.tids.copy()
        for r in np.unique(births.measurement):
            if not cand:
                break
            z = frame.visual[frame.pairs[r, 1] - 1]
            d = np.array([np.linalg.norm(pos - z) for _, pos, _ in cand])
            reach = np.array([cfg.relabel_distance + cfg.relink_speed * gap
                              for _, _, gap in cand])
            if cfg.relink_rule == "reach":  # nearest relative to the reach (old labels win)
                best = int(np.argmin(d / reach))
                ok = d[best] <= reach[best]
            else:
                # the label whose spread since it was dropped explains the birth best: an
                # isotropic Gaussian of std reach / 2 (the reach is two standard deviations),
                # normalised, so a longer gap spreads the label thinner instead of making it
                # more attractive; gated at relink_gate standard deviations
                sd = reach / 2.0
                loglik = -2.0 * np.log(sd) - 0.5 * (d / sd) ** 2
                loglik[d > cfg.relink_gate * sd] = -np.inf
                best = int(np.argmax(loglik))
                ok = bool(np.isfinite(loglik[best]))
            if ok:
                tid = cand.pop(best)[0]
                tids[births.measurement == r] = tid
        return Births(births.states, births.measurement, births.weights, tids)

    def _update(self, frame: AVFrame, pred: Prediction, births: Births) -> Update:
        cfg = self.config
        meas = self._label_measurements(frame, pred)
        moved, log_rho = self._flow(frame, pred, meas)
        if cfg.marginal_weights and not np.all(meas >= 0):
            self._idle_log_weights(pred, meas < 0, log_rho)
        weights, on_measurement = self._weights(frame, pred, moved, meas, log_rho)
        # the labels whose velocity decays in the next prediction (faceless_velocity_decay)
        faced = {t for t, r in self._assoc.items() if frame.pairs[r, 1] > 0}
        self._faceless = set(np.unique(pred.tids).tolist()) - faced - self._occluded
        return self._extract(moved, weights, pred.tids, meas, on_measurement)

    def _label_measurements(self, frame: AVFrame, pred: Prediction) -> np.ndarray:
        """Each predicted particle's fused measurement (row of ``frame.pairs``, -1 for none):
        its label's (eqs. 15–16, :meth:`_associate`). With ``marginal_weights`` every particle
        of the label flows to it (one proposal family per label), else only the particles
        gated on it; missed detections enter through ``p_D`` of eq. 22."""
        n = len(pred.weights)
        meas = np.full(n, -1, dtype=np.int64)
        if n and frame.n_pairs:
            r_of = np.array([self._assoc.get(int(t), -1) for t in pred.tids], dtype=np.int64)
            has = r_of >= 0
            if not self.config.marginal_weights:
                has[has] = pred.gated[np.flatnonzero(has), r_of[has]]
            meas[has] = r_of[has]
        return meas

    def _flow(
        self, frame: AVFrame, pred: Prediction, meas: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The labelled flow (eqs. 6–9) of the particles with a measurement, and its
        importance log-weights.

        The flow of each label is one Gaussian map (:func:`~avtrack.phd.flow.affine_flow_map`)
        whose law given the parent is known, ``m_k ~ N(M F m_{k-1} + c, M Q M^T + Sigma)``;
        the log-weight is ``log phi(m_k | m_{k-1}) - log q(m_k | m_{k-1})`` or, with
        ``marginal_weights``, the label's mixture weight
        (:func:`~avtrack.phd.flow.marginal_log_weights`) less ``log w_{k|k-1}``.

        Returns
        -------
        moved : ndarray (N, 4)
            The particles after the flow (unmoved where ``meas`` is -1).
        log_rho : ndarray (N,)
            Importance log-weights (0 where ``meas`` is -1).
        """
        cfg = self.config
        det = meas >= 0
        moved = pred.states.copy()
        log_rho = np.zeros(len(meas))
        if not np.any(det):
            return moved, log_rho
        ukey, group = np.unique(meas[det], return_inverse=True)
        # eqs. 18-20: covariance of the predicted particles sharing the label's measurement
        _, _, cov = weighted_moments(pred.states[det], pred.weights[det], group, len(ukey))
        if cfg.flow_prior == "label":  # scaled by label_prior_scale, Q a floor
            P = label_flow_prior(cov, self.Q, cfg.label_prior_scale)
        else:  # the particle's own transition density N(F m_{k-1}, Q)
            P = np.broadcast_to(self.Q, cov.shape)
        prior_info = np.linalg.inv(P)
        A, b, B = label_information(frame, ukey, cfg.sigma_visual, cfg.sigma_audio)
        x = pred.states[det]
        # eqs. 6-9 with the label likelihood of eq. 21, as one Gaussian map per label, whose
        # density given the parent is known: m_k ~ N(M F m_{k-1} + c, M Q M^T + Sigma)
        M, c, Sig = affine_flow_map(prior_info, A, b, B, self.steps, cfg.diffusion)
        m_k = np.einsum("nij,nj->ni", M[group], x) + c[group]
        if cfg.diffusion > 0:
            L = np.linalg.cholesky(Sig + 1e-9 * np.eye(STATE_DIM))
            eps = self.rng.standard_normal(x.shape)
            m_k += np.einsum("nij,nj->ni", L[group], eps)
        # importance weight of the flow: phi(m_k | m_{k-1}) / q(m_k | m_{k-1})
        q_mean = np.einsum("nij,nj->ni", M[group], pred.mean[det]) + c[group]
        q_cov = M @ self.Q @ M.transpose(0, 2, 1) + Sig + 1e-9 * np.eye(STATE_DIM)
        log_rho[det] = log_gaussian(m_k, pred.mean[det], self.Q) - log_gaussian(
            m_k, q_mean, q_cov[group]
        )
        if cfg.marginal_weights:  # one proposal per parent, weighted for the label's
            # predicted intensity sum_j w_j phi(m | m_{k-1}^j) (eqs. 4 and 22)
            log_w = np.log(np.maximum(pred.weights[det], 1e-300))
            log_u = np.empty(len(x))
            for g in range(len(ukey)):
                sel = group == g
                log_u[sel] = marginal_log_weights(
                    m_k[sel], log_w[sel], pred.mean[det][sel], self.Q, q_mean[sel], q_cov[g])
            log_rho[det] = log_u - log_w  # w_{k|k-1} log_rho gives u
        moved[det] = m_k
        return moved, log_rho

    def _idle_log_weights(self, pred: Prediction, idle: np.ndarray, log_rho: np.ndarray) -> None:
        """Marginal log-weights, in place in ``log_rho``, of the particles left to the
        transition (no measurement for their label, ``idle`` (N,) bool), per label: the
        weights of :meth:`_flow` with ``q_j = phi(. | m_{k-1}^j)``."""
        idle = np.flatnonzero(idle)
        log_w = np.log(np.maximum(pred.weights[idle], 1e-300))
        for t in np.unique(pred.tids[idle]):
            sel = pred.tids[idle] == t
            mu = pred.mean[idle][sel]
            log_rho[idle[sel]] = marginal_log_weights(
                pred.states[idle][sel], log_w[sel], mu, self.Q, mu, self.Q) - log_w[sel]

    def _weights(
        self, frame: AVFrame, pred: Prediction, moved: np.ndarray, meas: np.ndarray,
        log_rho: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        """Updated weights (eqs. 21–23) and each particle's weight from its measurement alone
        (eq. 22's labelled term, which eq. 25 sums), both ``(N,)``."""
        cfg = self.config
        pairs = frame.pairs
        p_d, kappa, p_miss, log_na, log_nv = measurement_model(frame, cfg)
        det = meas >= 0
        # eq. 21 at the moved particles: the density of the labelled parts
        rho = np.exp(np.clip(log_rho, -500, 500))
        r = meas[det]
        o, u = pairs[r, 0], pairs[r, 1]
        pos = moved[det, :2]
        log_h = np.zeros(len(r))
        ha, hv = o > 0, u > 0
        line = frame.lines[o[ha] - 1]
        d_a = np.einsum("ni,ni->n", pos[ha], line[:, :2]) - line[:, 2]
        log_h[ha] -= 0.5 * (d_a / cfg.sigma_audio) ** 2
        d2_v = np.sum((pos[hv] - frame.visual[u[hv] - 1]) ** 2, axis=1)
        log_h[hv] -= 0.5 * d2_v / cfg.sigma_visual**2
        log_h += ha * log_na + hv * log_nv  # densities; p_D and kappa of the fused measurement
        num = p_d[r] * np.exp(log_h) * rho[det] * pred.weights[det]
        G = np.bincount(r, num, minlength=frame.n_pairs)  # eq. 23 (over measurement r)
        weights = p_miss * pred.weights * rho  # eq. 22, l_ring = l_breve = 0
        if self._occluded:  # p_D = 0 for an occluded label: eq. 22's miss factor is 1
            occ = np.isin(pred.tids, list(self._occluded))
            weights[occ] = pred.weights[occ] * rho[occ]
        weights[det] = num / (kappa[r] + G[r])  # eq. 22, labelled particles
        on_measurement = weights.copy()  # eq. 25 sums the labelled term only
        on_measurement[~det] = 0.0
        if cfg.marginal_weights:
            # eq. 11 for the label's particles, all drawn by its flow: the missed-detection
            # term too, with the same importance weight
            weights[det] += p_miss * pred.weights[det] * rho[det]
        return weights, on_measurement

    def _extract(
        self, states: np.ndarray, weights: np.ndarray, tids: np.ndarray, measurement: np.ndarray,
        on_measurement: np.ndarray | None = None,
    ) -> Update:  # fmt: skip
        """Label-wise speakers (eqs. 24–25 with the persistent labels).

        A label's weight is eq. 25's: the weight of its particles labelled with its main
        measurement (the one holding most of its weight; at most one speaker per measurement,
        eq. 23); ``measurement`` (N,) is each particle's label, -1 for none. Every label whose
        weight is at least ``xi`` is reported at its particles' weighted mean; a confirmed
        label whose weight drops below ``xi`` (missed detections) keeps being reported, with
        that weight, for up to ``coast_frames`` frames. ``on_measurement`` (N,): each
        particle's weight from its measurement alone (eq. 22's labelled term, without
        eq. 11's missed-detection term); ``weights`` when omitted.
        """
        cfg = self.config
        self._frame += 1
        labelled = measurement >= 0
        uniq, group = np.unique(tids, return_inverse=True)
        total, mean, _ = weighted_moments(states, weights, group, len(uniq))
        mass = np.zeros(len(uniq))  # weight on the label's main measurement (eq. 25)
        if np.any(labelled):
            _, r_idx = np.unique(measurement[labelled], return_inverse=True)
            table = np.zeros((len(uniq), r_idx.max() + 1))
            w_on = weights if on_measurement is None else on_measurement
            np.add.at(table, (group[labelled], r_idx), w_on[labelled])
            mass = table.max(axis=1)
        report = []
        for j, (tid, m) in enumerate(zip(uniq.tolist(), mass, strict=True)):
            if m >= cfg.extraction_threshold:
                self._confirmed[tid] = self._frame
                self._lost.pop(tid, None)  # relinked and confirmed
                self._seen[tid] = mean[j, :2].copy()
                report.append(j)
            elif tid in self._occluded and tid in self._confirmed and (
                total[j] >= cfg.extraction_threshold
            ):  # an occluded speaker is still present: reported at its predicted mean
                self._confirmed[tid] = self._frame
                mass[j] = total[j]
                report.append(j)
            elif tid in self._confirmed and (
                self._frame - self._confirmed[tid] <= cfg.coast_frames and total[j] > 0
            ):
                report.append(j)
        live = set(uniq.tolist())
        self._confirmed = {t: f for t, f in self._confirmed.items() if t in live}
        keep = np.asarray(report, dtype=np.int64)
        return Update(states, weights, tids, mean[keep], mass[keep], uniq[keep])

    def _resample(
        self, states: np.ndarray, weights: np.ndarray, tids: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
        """Per label: drop labels that are neither reported, coasting nor heavier than
        ``prune_weight``; when the ESS of all the particles kept (``resample_rule=
        "population"``, Algorithm 1) or of the label's own particles (``"label"``) falls below
        ``resample_fraction`` of their number, resample each label on its own to
        ``particles_per_target`` particles of equal weight (its weight unchanged), so that a
        label keeps its particles through misses."""
        cfg = self.config
        if len(weights) == 0:
            return states, weights, tids, False
        uniq, group = np.unique(tids, return_inverse=True)
        mass = np.bincount(group, weights, minlength=len(uniq))
        sq = np.bincount(group, weights * weights, minlength=len(uniq))
        count = np.bincount(group, minlength=len(uniq))
        out_s, out_w, out_t = [], [], []
        resampled = False
        # Algorithm 1: ESS of all the particles that are kept (Kong, Liu and Wong 1994)
        live = np.isin(group, np.flatnonzero(mass >= cfg.prune_weight))
        w_live = weights[live]
        population = (w_live.sum() ** 2
                      < cfg.resample_fraction * live.sum() * np.sum(w_live * w_live))
        for j, tid in enumerate(uniq.tolist()):
            coasting = (tid in self._confirmed
                        and self._frame - self._confirmed[tid] <= cfg.coast_frames)
            if not (coasting or mass[j] >= cfg.prune_weight) or mass[j] <= 0:
                if self._confirmed.pop(tid, None) is not None and tid in self._seen:
                    self._lost[tid] = (self._seen.pop(tid), self._frame)
                continue
            sel = np.flatnonzero(group == j)
            ess = mass[j] ** 2 / sq[j] if sq[j] > 0 else 0.0
            degenerate = (population if cfg.resample_rule == "population"
                          else ess < cfg.resample_fraction * count[j])
            if degenerate or count[j] > 4 * cfg.particles_per_target:
                idx = sel[systematic_resample(weights[sel], cfg.particles_per_target, self.rng)]
                out_s.append(states[idx])
                out_w.append(np.full(len(idx), mass[j] / len(idx)))
                out_t.append(tids[idx])
                resampled = True
            else:
                out_s.append(states[sel])
                out_w.append(weights[sel])
                out_t.append(tids[sel])
        if not out_s:
            return np.zeros((0, STATE_DIM)), np.zeros(0), np.zeros(0, dtype=np.int64), resampled
        return np.vstack(out_s), np.concatenate(out_w), np.concatenate(out_t), resampled
