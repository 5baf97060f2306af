r"""Birth process: marginal likelihood of smooth observation sequences (thesis eq. 3.30).

For a sequence :math:`(\tilde o_{m_{t-B}}, \dots, \tilde o_{m_t})` of observations left to
clutter in the last ``B + 1`` frames, the linear-Gaussian model makes

.. math::
    \mathcal{L} = \int p(\tilde o_{m_{t-B}}|s_{t-B}) \cdots p(\tilde o_{m_t}|s_t)
        \prod_{k} p(s_{k}|s_{k-1})\, p(s_{t-B})\, ds_{t-B:t}      \quad\text{(eq. 3.30)}

available in closed form by the prediction-error decomposition of a Kalman filter. We take
:math:`p(s_{t-B})` centred at the first observation with the observation covariance on the
observed components and ``velocity_var`` on the velocities, and score the remaining ``B``
observations against the clutter hypothesis: the birth statistic is the log-likelihood ratio

.. math::
    \mathrm{LLR} = \sum_{k=t-B+1}^{t} \log p(\tilde o_{m_k}|\tilde o_{m_{t-B:k-1}})
        - B \log u(o)

(the first observation has the same uniform density under both hypotheses). A person is born
when ``LLR > threshold``. Sequences are enumerated by a beam search over frames with a
chi-square gate, so crowded frames stay cheap.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from avtrack.vem.updates import CVStates, cv_join, cv_transition, symmetrize

_LOG_2PI = np.log(2 * np.pi)


@dataclass(frozen=True)
class BirthCandidate:
    """A smooth observation sequence and the Kalman posterior at its last frame.

    Attributes
    ----------
    indices : ndarray (B + 1,) int
        Index of the observation used in each pool frame (oldest first).
    llr : float
        Birth log-likelihood ratio.
    mu : ndarray (d,)
    gamma : ndarray (d, d)
    """

    indices: np.ndarray
    llr: float
    mu: np.ndarray
    gamma: np.ndarray


def birth_candidates(
    pools: Sequence[tuple[np.ndarray, np.ndarray]],
    transition: np.ndarray,
    dynamics_cov: Callable[[np.ndarray], np.ndarray],
    velocity_var: Callable[[np.ndarray], np.ndarray],
    log_clutter_density: float,
    gate: float = 18.47,
    beam: int = 3,
    dynamics_var: Callable[[np.ndarray], np.ndarray] | None = None,
) -> list[BirthCandidate]:
    """Score every gated observation sequence through ``pools`` (thesis eq. 3.30).

    Parameters
    ----------
    pools : sequence of (z, var)
        For each of the ``B + 1`` frames, oldest first, the unassigned observations
        ``z (M_k, k_obs)`` and the diagonals of their covariances ``var (M_k, k_obs)``.
    transition : ndarray (d, d)
        ``D``; the observed components are the first ``k_obs`` of the state.
    dynamics_cov : callable ``(C, d) -> (C, d, d)``
        Dynamics covariance for a batch of states.
    velocity_var : callable ``(C, k_obs) -> (C, d - k_obs)``
        Prior variance of the unobserved components given the first observation.
    log_clutter_density : float
        :math:`\\log u(o)`.
    gate : float
        Squared Mahalanobis gate on each innovation (default: χ²₄ at 0.999).
    beam : int
        Chains kept per observation and frame.
    dynamics_var : callable ``(C, d) -> (C, d)``, optional
        The diagonal of ``dynamics_cov``, for a diagonal one. Given, with a constant-velocity
        ``D`` (:func:`~avtrack.vem.dynamics.constant_velocity_transition` of the ``k_obs``
        observed components), the Kalman filter runs on each component's (position, velocity)
        pair, the covariances staying in the pattern of :func:`~avtrack.vem.updates.cv_pattern`
        (:func:`_filter_cv`): the same updates with no ``d × d`` product.

    Returns
    -------
    list of BirthCandidate, sorted by decreasing LLR (only sequences that pass every gate).
    """
    if len(pools) < 2:
        raise ValueError(f"birth needs at least 2 frames of observations, got {len(pools)}")
    if beam < 1:
        raise ValueError(f"beam must be >= 1, got {beam}")
    z0, var0 = pools[0]
    c, k = z0.shape
    if c == 0:
        return []
    cv = None if dynamics_var is None else cv_transition(transition, k)
    if cv is not None and dynamics_var is not None:
        return _filter_cv(pools, cv, dynamics_var, velocity_var, log_clutter_density, gate, beam)
    d = transition.shape[0]
    # p(s_{t-B}): centred at the first observation (eq. 3.30 and the text below it).
    mu = np.zeros((c, d))
    mu[:, :k] = z0
    gamma = np.zeros((c, d, d))
    diag = np.arange(d)
    gamma[:, diag, diag] = np.concatenate([var0, velocity_var(z0)], axis=1)
    score = np.zeros(c)
    chains = np.arange(c)[:, None]
    for z, var in pools[1:]:
        m = z.shape[0]
        if m == 0 or mu.shape[0] == 0:
            return []
        # Kalman prediction, eq. 2.21
        gamma = symmetrize(transition @ gamma @ transition.T + dynamics_cov(mu))
        mu = mu @ transition.T
        r = z[None, :, :] - mu[:, None, :k]  # innovation o_m - P μ, (C, M, k)
        block = gamma[:, :k, :k]  # P Γ Pᵀ: diagonal when all its nonzeros are on the diagonal
        diagonal = np.count_nonzero(block) == np.count_nonzero(
            np.diagonal(block, axis1=1, axis2=2))
        if diagonal:  # P Γ Pᵀ diagonal (constant-velocity boxes): S is diagonal too
            s = gamma[:, diag[:k], diag[:k]][:, None, :] + var[None]  # (C, M, k)
            maha = (r * r / s).sum(axis=2)  # rᵀ S⁻¹ r
            logdet = np.log(s).sum(axis=2)  # log |S|
        else:  # innovation covariance S = P Γ Pᵀ + Φ_m for every (chain, observation) pair
            s = gamma[:, None, :k, :k] + var[None, :, :, None] * np.eye(k)  # (C, M, k, k)
            s_inv = np.linalg.inv(s)
            maha = np.einsum("cmi,cmij,cmj->cm", r, s_inv, r)  # rᵀ S⁻¹ r
            _, logdet = np.linalg.slogdet(s)
        ci, mi, score = _beam(score, maha, logdet, k, gate, beam)
        # Kalman update of the kept pairs
        r = r[ci, mi]
        if diagonal:  # K = Γ Pᵀ S⁻¹, (K, d, k)
            kgain = gamma[ci, :, :k] / s[ci, mi][:, None, :]
        else:
            kgain = gamma[ci, :, :k] @ s_inv[ci, mi]
        mu = mu[ci] + (kgain @ r[:, :, None])[:, :, 0]  # μ + K r
        gamma = gamma[ci]
        gamma = symmetrize(gamma - kgain @ gamma[:, :k, :])  # (I - K P) Γ
        chains = np.concatenate([chains[ci], mi[:, None]], axis=1)
    return _candidates(chains, score, len(pools) - 1, log_clutter_density, mu, gamma)


def _beam(
    score: np.ndarray, maha: np.ndarray, logdet: np.ndarray, k: int, gate: float, beam: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One frame of the beam search: from the scores ``(C,)`` of the chains so far and the
    Mahalanobis distances and log-determinants ``(C, M)`` of their innovations, the chains
    ``ci`` and observations ``mi`` of the (at most ``beam`` per observation) extended chains
    that pass the gate, and their scores."""
    m = maha.shape[1]
    loglik = -0.5 * (maha + logdet + k * _LOG_2PI)  # log N(o_m; P μ, S)
    total = score[:, None] + loglik
    total[~(maha < gate)] = -np.inf  # outside the gate
    if total.shape[0] == 1:  # a single chain: nothing to rank
        ci, mi, score = np.zeros(m, dtype=np.intp), np.arange(m), total[0]
    else:  # beam: best chains for each observation
        order = np.argsort(-total, axis=0)[:beam]  # (beam, M)
        ci = order.ravel()
        mi = np.arange(ci.shape[0]) % m  # the observation (column) of each entry of ``order``
        score = total[ci, mi]
    ok = score > -np.inf  # passed every gate
    return ci[ok], mi[ok], score[ok]


def _candidates(
    chains: np.ndarray, score: np.ndarray, n_later: int, log_clutter_density: float,
    mu: np.ndarray, gamma: np.ndarray,
) -> list[BirthCandidate]:
    """The chains ``(C, B + 1)`` as candidates, by decreasing LLR."""
    llr = score - n_later * log_clutter_density
    order = np.argsort(-llr)
    return [BirthCandidate(chains[i], float(llr[i]), mu[i], gamma[i]) for i in order]


def _filter_cv(
    pools: Sequence[tuple[np.ndarray, np.ndarray]],
    cv: tuple[int, float],
    dynamics_var: Callable[[np.ndarray], np.ndarray],
    velocity_var: Callable[[np.ndarray], np.ndarray],
    log_clutter_density: float,
    gate: float,
    beam: int,
) -> list[BirthCandidate]:
    r""":func:`birth_candidates` for a constant-velocity ``D`` with ``cv = (n_vel, Δt)`` and a
    diagonal Λ.

    The states are :class:`~avtrack.vem.updates.CVStates`: per observed component, the
    position and velocity means and :math:`a = \Gamma_{pp}`, :math:`b = \Gamma_{vv}`,
    :math:`c = \Gamma_{pv}`. Every entry of the products of the matrix filter has at most
    two nonzero terms, which are written out below in the order the products form them:

    * prediction (eq. 2.21), from :math:`D\Gamma` (rows :math:`a + \Delta t\,c` and
      :math:`c + \Delta t\,b`) times :math:`D^\top`:
      :math:`c' = c + \Delta t\,b`, :math:`a' = (a + \Delta t\,c) + \Delta t\,c' + \lambda_p`,
      :math:`b' = b + \lambda_v`;
    * update with the diagonal :math:`S = a + \phi` and the gains :math:`K_p = a / S`,
      :math:`K_v = c / S` of :math:`K = \Gamma P^\top S^{-1}`: :math:`\mu_p + K_p r`,
      :math:`\mu_v + K_v r`, and :math:`(I - KP)\Gamma` symmetrised:
      :math:`a - K_p a`, :math:`b - K_v c`, :math:`\frac12((c - K_p c) + (c - K_v a))`.
    """
    n_vel, dt = cv
    z0, var0 = pools[0]
    c, k = z0.shape
    # p(s_{t-B}): centred at the first observation (eq. 3.30 and the text below it)
    zero = np.zeros((c, k))
    var_v = np.zeros((c, k))
    var_v[:, :n_vel] = velocity_var(z0)
    st = CVStates(z0, zero, var0, var_v, zero)
    score = np.zeros(c)
    chains = np.arange(c)[:, None]
    for z, var in pools[1:]:
        if z.shape[0] == 0 or st.mu_p.shape[0] == 0:
            return []
        mu_p, mu_v, a, b, c = st
        lam = dynamics_var(np.concatenate([mu_p, mu_v[:, :n_vel]], axis=1))  # Λ diagonal
        lam_v = np.zeros(b.shape)
        lam_v[:, :n_vel] = lam[:, k:]
        # Kalman prediction, eq. 2.21: D μ and D Γ Dᵀ + Λ (Λ_pv = 0)
        cov = c + dt * b  # c' = c + Δt b
        a = ((a + dt * c) + dt * cov) + lam[:, :k]  # a' = (a + Δt c) + Δt c' + λ_p
        b = b + lam_v  # b' = b + λ_v
        mu_p = mu_p + dt * mu_v  # D μ
        r = z[None, :, :] - mu_p[:, None, :]  # innovation o_m - P μ, (C, M, k)
        s = a[:, None, :] + var[None]  # S = P Γ Pᵀ + Φ_m, diagonal, (C, M, k)
        maha = (r * r / s).sum(axis=2)  # rᵀ S⁻¹ r
        logdet = np.log(s).sum(axis=2)  # log |S|
        ci, mi, score = _beam(score, maha, logdet, k, gate, beam)
        # Kalman update of the kept pairs
        r, s = r[ci, mi], s[ci, mi]
        a, b, cov = a[ci], b[ci], cov[ci]
        k_p, k_v = a / s, cov / s  # K = Γ Pᵀ S⁻¹
        st = CVStates(
            mu_p[ci] + k_p * r,  # μ + K r
            mu_v[ci] + k_v * r,
            a - k_p * a,  # (I - K P) Γ, symmetrised
            b - k_v * cov,
            0.5 * ((cov - k_p * cov) + (cov - k_v * a)),
        )
        chains = np.concatenate([chains[ci], mi[:, None]], axis=1)
    mu, gamma = cv_join(st, n_vel)
    return _candidates(chains, score, len(pools) - 1, log_clutter_density, mu, gamma)


def select_births(candidates: Sequence[BirthCandidate], threshold: float) -> list[BirthCandidate]:
    """Greedy choice of non-overlapping sequences with ``llr > threshold``, best first."""
    used: set[tuple[int, int]] = set()
    chosen = []
    for cand in sorted(candidates, key=lambda c: -c.llr):
        if cand.llr <= threshold:
            break
        keys = {(f, int(i)) for f, i in enumerate(cand.indices)}
        if keys & used:
            continue
        used |= keys
        chosen.append(cand)
    return chosen


def born_states(
    born: Sequence[BirthCandidate], last_appearance: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """The new targets' posteriors and initial appearances.

    Parameters
    ----------
    born : sequence of BirthCandidate
        The chosen sequences (:func:`select_births`), ``k`` of them.
    last_appearance : ndarray (M, F) or None
        Appearance descriptors of the pool's last frame.

    Returns
    -------
    mu : ndarray (k, d)
    gamma : ndarray (k, d, d)
    appearance : ndarray (k, F) or None
        The descriptor of each sequence's last observation.
    """
    mu = np.stack([b.mu for b in born])
    gamma = np.stack([b.gamma for b in born])
    init = None
    if last_appearance is not None:
        init = np.stack([last_appearance[b.indices[-1]] for b in born])
    return mu, gamma, init


def consume_pool(pool, born: Sequence[BirthCandidate]) -> None:
    """Remove the born sequences' observations from the pool frames (in place), so no other
    birth uses them. ``pool`` is a mutable sequence of observation sets with ``len`` and
    ``subset(index_array)``, oldest first, as the candidates' ``indices``."""
    for f, frame in enumerate(pool):
        used = np.zeros(len(frame), dtype=bool)
        used[[int(b.indices[f]) for b in born]] = True
        pool[f] = frame.subset((~used).nonzero()[0])
