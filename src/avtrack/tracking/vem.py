r"""Variational-EM updates of the multi-target tracking engine (thesis ch. 2).

Plain functions on batched arrays; :class:`avtrack.tracking.engine.VEMEngine` wraps them.
Shapes: ``N`` targets, ``M`` observations, state dimension ``d``.

The model (thesis §2.2): each target ``n`` has a Gaussian state
:math:`q(s_{tn}) = \mathcal{N}(\mu_{tn}, \Gamma_{tn})` (eq. 2.22); observation ``m`` is generated
by target :math:`Z_{tm}=n` or by clutter :math:`Z_{tm}=0` (uniform density); the dynamics are
linear-Gaussian :math:`p(s_{tn}|s_{t-1,n}) = \mathcal{N}(D s_{t-1,n}, \Lambda_{tn})` (eq. 2.6).
"""

from __future__ import annotations

import numpy as np
from scipy.special import logsumexp

#: Smallest prior probability kept for any class after the M-step (keeps log finite).
PRIOR_FLOOR = 1e-6


def symmetrize(a: np.ndarray) -> np.ndarray:
    """``(a + aᵀ) / 2`` over the last two axes; ``a`` is ``(..., d, d)``."""
    return 0.5 * (a + np.swapaxes(a, -1, -2))


def predict(
    mu: np.ndarray, gamma: np.ndarray, transition: np.ndarray, lam: np.ndarray,
    control: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    r"""Predictive distribution of each target (thesis eq. 2.21).

    :math:`\mathcal{N}(s_{tn}; D\mu_{t-1,n} + c_{tn}, D\Gamma_{t-1,n}D^\top + \Lambda_{tn})`;
    the optional control term :math:`c_{tn}` is the ego-motion compensation of thesis eq. 3.34.

    Parameters
    ----------
    mu : ndarray (N, d)
    gamma : ndarray (N, d, d)
    transition : ndarray (d, d)
        ``D``.
    lam : ndarray (N, d, d)
        Dynamics covariance :math:`\Lambda_{tn}`.
    control : ndarray (N, d), optional

    Returns
    -------
    mu_pred : ndarray (N, d)
    gamma_pred : ndarray (N, d, d)
    """
    mu_pred = mu @ transition.T  # D mu_{t-1}
    if control is not None:
        mu_pred = mu_pred + control
    gamma_pred = symmetrize(transition @ gamma @ transition.T + lam)  # D Γ Dᵀ + Λ
    return mu_pred, gamma_pred


def e_z_step(log_tau: np.ndarray, log_clutter: np.ndarray, log_prior: np.ndarray) -> np.ndarray:
    r"""Assignment posteriors :math:`\alpha_{tmn}` (thesis eq. 2.25 / 3.20 / 4.28).

    :math:`\alpha_{tmn} = \tau_{tmn}\eta_{mn} / \sum_{i=0}^N \tau_{tmi}\eta_{mi}`, in log space.

    Parameters
    ----------
    log_tau : ndarray (M, N)
        :math:`\log\tau_{tmn}` for the targets ``n = 1..N``.
    log_clutter : ndarray (M,)
        :math:`\log\tau_{tm0}`, the clutter (uniform) log density.
    log_prior : ndarray (N + 1,) or (M, N + 1)
        :math:`\log\eta_{mn}`, clutter first.

    Returns
    -------
    alpha : ndarray (M, N + 1)
        Rows sum to one; column 0 is clutter.
    """
    log_post = np.concatenate([log_clutter[:, None], log_tau], axis=1) + log_prior
    return np.exp(log_post - logsumexp(log_post, axis=1, keepdims=True))


def exclusive_projection(alpha: np.ndarray, n_iter: int = 50, tol: float = 1e-6) -> np.ndarray:
    r"""Project responsibilities onto "each target explains at most one observation".

    The independent assignments of eq. 2.25 let one target absorb several observations (a
    full-body and a partial detection of one person, say). Under the point-target assumption
    (a person produces at most one detection per frame) the E-Z step becomes the I-projection

    .. math::
        \min_q \mathrm{KL}(q\,\|\,lpha) \ 	ext{s.t.}\ \sum_{n=0}^{N} q_{mn} = 1,\quad
        \sum_m q_{mn} \le 1 \ (n \ge 1),

    whose solution is :math:`q_{mn} = lpha_{mn} r_m c_n` with :math:`c_0 = 1`, found by
    alternating Bregman projections onto the two constraint sets (Sinkhorn scaling with a
    one-sided column constraint). Observations a saturated target cannot take flow back to the
    other targets and to clutter.

    Parameters
    ----------
    alpha : ndarray (M, N + 1)
        Row-stochastic responsibilities, clutter in column 0.

    Returns
    -------
    ndarray (M, N + 1)
        Row-stochastic, target columns summing to at most ``1 + tol``.
    """
    q = alpha
    for _ in range(n_iter):
        col = q[:, 1:].sum(axis=0)
        if col.size == 0 or col.max() <= 1.0 + tol:
            break
        q = q.copy()
        q[:, 1:] /= np.maximum(col, 1.0)  # project onto column sums <= 1
        q /= q.sum(axis=1, keepdims=True)  # project onto rows summing to 1
    return q


def e_s_step(
    mu_pred: np.ndarray, precision_pred: np.ndarray, info_matrix: np.ndarray,
    info_vector: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    r"""State posteriors :math:`q(s_{tn})` (thesis eqs. 2.23–2.24, general form eqs. 4.26–4.27).

    .. math::
        \Gamma_{tn} = \Big(\underbrace{\textstyle\sum_{\text{models}} J_n}_{\#1,\#2}
            + \underbrace{(\Lambda_{tn} + D\Gamma_{t-1,n}D^\top)^{-1}}_{\#3}\Big)^{-1},\quad
        \mu_{tn} = \Gamma_{tn}\Big(\textstyle\sum h_n + (\Lambda_{tn} +
            D\Gamma_{t-1,n}D^\top)^{-1} D\mu_{t-1,n}\Big)

    where each observation model contributes
    :math:`J_n = \sum_m \alpha_{tmn} P^\top\Phi_{tm}^{-1}P` and
    :math:`h_n = \sum_m \alpha_{tmn} P^\top\Phi_{tm}^{-1}o_{tm}`.

    Parameters
    ----------
    mu_pred : ndarray (N, d)
        Predicted mean (the control term already added).
    precision_pred : ndarray (N, d, d)
        Inverse of the predicted covariance (term #3).
    info_matrix : ndarray (N, d, d)
        Summed observation precision contributions.
    info_vector : ndarray (N, d)
        Summed observation information vectors.

    Returns
    -------
    mu : ndarray (N, d)
    gamma : ndarray (N, d, d)
        Symmetric positive definite.
    """
    gamma = symmetrize(np.linalg.inv(info_matrix + precision_pred))  # eq. 2.23
    rhs = info_vector + np.einsum("nij,nj->ni", precision_pred, mu_pred)
    mu = np.einsum("nij,nj->ni", gamma, rhs)  # eq. 2.24
    return mu, gamma


def m_step_priors(mass: np.ndarray) -> np.ndarray:
    r"""Assignment priors :math:`a_{tn}` maximising eq. 3.28 (thesis eq. 3.29).

    :math:`a_{tn} = \sum_m \alpha_{tmn} / \sum_{i}\sum_m \alpha_{tmi}`, floored at
    :data:`PRIOR_FLOOR` and renormalised so that a class that lost every observation in one
    iteration can still win some back in the next.

    Parameters
    ----------
    mass : ndarray (N + 1,)
        :math:`\sum_m \alpha_{tmn}`, clutter first.

    Returns
    -------
    log_prior : ndarray (N + 1,)
    """
    total = mass.sum()
    if total <= 0:
        return np.full(mass.shape, -np.log(mass.shape[0]))
    a = np.maximum(mass / total, PRIOR_FLOOR)
    return np.log(a / a.sum())


def m_step_dynamics(
    mu: np.ndarray, gamma: np.ndarray, mu_pred: np.ndarray, gamma_prev_pred: np.ndarray,
    floor: np.ndarray,
) -> np.ndarray:
    r"""Dynamics covariance :math:`\Lambda_{tn}` (thesis eq. 2.27).

    .. math::
        \Lambda_{tn} = \Gamma_{tn} - D\Gamma_{t-1,n}D^\top
            + (\mu_{tn} - D\mu_{t-1,n})(\mu_{tn} - D\mu_{t-1,n})^\top

    Eq. 2.27 is the stationary point of eq. 2.26 but it is not guaranteed to be positive
    definite (:math:`\Gamma_{tn}` is usually smaller than :math:`D\Gamma_{t-1,n}D^\top`), so the
    result is projected onto the SPD cone by clipping its eigenvalues from below at ``floor``.

    Parameters
    ----------
    mu, mu_pred : ndarray (N, d)
        Posterior mean and :math:`D\mu_{t-1,n}` (plus control).
    gamma : ndarray (N, d, d)
        Posterior covariance :math:`\Gamma_{tn}`.
    gamma_prev_pred : ndarray (N, d, d)
        :math:`D\Gamma_{t-1,n}D^\top`.
    floor : ndarray (N,)
        Smallest variance allowed along any direction, per target (> 0).

    Returns
    -------
    lam : ndarray (N, d, d)
        Symmetric positive definite.
    """
    r = mu - mu_pred
    lam = symmetrize(gamma - gamma_prev_pred + r[:, :, None] * r[:, None, :])  # eq. 2.27
    w, v = np.linalg.eigh(lam)
    w = np.maximum(w, floor[:, None])
    return symmetrize((v * w[:, None, :]) @ np.swapaxes(v, -1, -2))


def gaussian_log_marginal(
    obs: np.ndarray, obs_cov: np.ndarray, mean: np.ndarray, cov: np.ndarray,
) -> np.ndarray:
    r""":math:`\log\mathcal{N}(o; m, C + \Phi)` for every (batch) pair.

    Parameters
    ----------
    obs : ndarray (..., k)
    obs_cov : ndarray (..., k, k)
    mean : ndarray (..., k)
    cov : ndarray (..., k, k)

    Returns
    -------
    ndarray (...)
    """
    s = obs_cov + cov
    r = obs - mean
    _, logdet = np.linalg.slogdet(s)
    maha = np.einsum("...i,...i->...", r, np.linalg.solve(s, r[..., None])[..., 0])
    return -0.5 * (maha + logdet + r.shape[-1] * np.log(2 * np.pi))
