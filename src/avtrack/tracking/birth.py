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

from avtrack.tracking.vem import symmetrize

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
    d = transition.shape[0]
    if c == 0:
        return []
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
        loglik = -0.5 * (maha + logdet + k * _LOG_2PI)  # log N(o_m; P μ, S)
        total = np.where(maha < gate, score[:, None] + loglik, -np.inf)
        # beam: best chains for each observation
        order = np.argsort(-total, axis=0)[:beam]  # (beam, M)
        ci = order.ravel()
        mi = np.arange(ci.shape[0]) % m  # the observation (column) of each entry of ``order``
        score = total[ci, mi]
        ok = score > -np.inf  # passed every gate
        ci, mi, score = ci[ok], mi[ok], score[ok]
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
    n_later = len(pools) - 1
    llr = score - n_later * log_clutter_density
    order = np.argsort(-llr)
    return [BirthCandidate(chains[i], float(llr[i]), mu[i], gamma[i]) for i in order]


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
