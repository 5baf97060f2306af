"""Non-zero-diffusion particle flow (Liu et al. eqs. 6–9) and its Jacobian determinants.

The flow moves each particle ``m`` from the prior towards the posterior along the log-homotopy
``log psi(m, lambda) = log g(m) + lambda log h(m)``, ``lambda`` from 0 to 1, in steps
``Delta lambda`` (Daum and Huang 2013, ref. [14] of the seed)::

    m <- m + Delta m                                              (eq. 6)
    Delta m = f(m, lambda) Delta lambda + v w                     (eq. 7)
    f = -[grad^2 log psi]^-1 grad log h                           (eq. 8)
    grad^2 log psi ~ -P^-1 + lambda grad^2 log h                  (eq. 9)

with ``P`` the prior (predicted) covariance of the particle's speaker. For a log-likelihood
that is quadratic in the state, ``log h = -1/2 m^T A m + b^T m + const``, the flow is affine:
``f = S (b - A m)`` with ``S(lambda) = (P^-1 + lambda A)^-1``. We take the Wiener term ``w``
with covariance ``Delta lambda S A S``: then the flow's Fokker–Planck equation maps a Gaussian
prior exactly onto the Gaussian posterior (the Kalman update; without diffusion the mean is
still exact but the spread shrinks too much). ``v`` (``diffusion``) scales it.

The Jacobian of one step is ``I + Delta lambda grad f = I - Delta lambda S A``; the weights
of seed eq. 22 use the product of its determinants over the steps.

- :func:`affine_flow` — particles grouped by a shared quadratic log-likelihood and prior (the
  labelled flow of AV-LPF-SMC-PHD, eq. 21: one ``S`` per label and step).
- :func:`mixture_flow` — a per-particle flow for a mixture likelihood (eq. 10, the
  AV-NPF-SMC-PHD flow), with the Gauss–Newton Hessian
  ``grad^2 log h ~ -sum_r pi_r A_r`` (the responsibility-weighted component Hessians).
"""

from __future__ import annotations

import numpy as np


def flow_steps(n_steps: int, ratio: float = 1.2) -> np.ndarray:
    """Pseudo-time steps ``Delta lambda``: ``n_steps`` geometrically growing steps summing to 1
    (small steps first, where the flow is fastest).

    Returns
    -------
    ndarray (n_steps,)
    """
    if isinstance(n_steps, bool) or not isinstance(n_steps, int | np.integer) or n_steps < 1:
        raise ValueError(f"flow_steps: n_steps must be an integer >= 1, got {n_steps!r}")
    if not ratio > 0:
        raise ValueError(f"flow_steps: ratio must be > 0, got {ratio!r}")
    steps = ratio ** np.arange(n_steps, dtype=float)
    return steps / steps.sum()


def _slogdet_abs(M: np.ndarray) -> np.ndarray:
    return np.linalg.slogdet(M)[1]


def affine_flow(
    states: np.ndarray,
    group: np.ndarray,
    prior_info: np.ndarray,
    A: np.ndarray,
    b: np.ndarray,
    B: np.ndarray,
    steps: np.ndarray,
    diffusion: float = 1.0,
    rng: np.random.Generator | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Flow particles whose log-likelihood is quadratic and shared within groups.

    Parameters
    ----------
    states : ndarray (N, M)
        Particle states ``m_{k|k-1}``.
    group : ndarray (N,) int
        Group of each particle, in ``0..G-1``.
    prior_info : ndarray (G, M, M)
        ``P^-1`` of each group (eq. 9).
    A : ndarray (G, M, M)
        ``-grad^2 log h`` of each group (positive semi-definite).
    b : ndarray (G, M)
        ``grad log h = b - A m``.
    B : ndarray (G, M, K)
        A factor of ``A = B B^T`` (for the diffusion).
    steps : ndarray (S,)
        ``Delta lambda`` per step (:func:`flow_steps`).
    diffusion : float
        ``v`` of eq. 7 (0: zero-diffusion flow).
    rng : numpy.random.Generator
        Needed when ``diffusion > 0``.

    Returns
    -------
    states : ndarray (N, M)
        Particles after the flow, ``m_k``.
    log_det : ndarray (N,)
        ``log |det(dm_k / dm_{k|k-1})|`` = sum over steps of ``log|det(I - Delta lambda S A)|``.
    """
    m = np.array(states, dtype=float, copy=True)
    n, dim = m.shape
    group = np.asarray(group, dtype=np.int64)
    if group.shape != (n,):
        raise ValueError(f"affine_flow: group must have shape ({n},), got {group.shape}")
    g = prior_info.shape[0]
    for name, arr, shape in (
        ("prior_info", prior_info, (g, dim, dim)),
        ("A", A, (g, dim, dim)),
        ("b", b, (g, dim)),
    ):
        if arr.shape != shape:
            raise ValueError(f"affine_flow: {name} must have shape {shape}, got {arr.shape}")
    if n and (group.min() < 0 or group.max() >= g):
        raise ValueError(f"affine_flow: group must be in 0..{g - 1}")
    if diffusion < 0:
        raise ValueError(f"affine_flow: diffusion must be >= 0, got {diffusion}")
    if diffusion > 0 and rng is None:
        raise ValueError("affine_flow: rng is required when diffusion > 0")
    log_det_g = np.zeros(g)
    eye = np.eye(dim)
    lam = 0.0
    for dl in steps:
        lam_mid = lam + dl / 2
        # eq. 9: S = -[grad^2 log psi]^-1 = (P^-1 + lambda A)^-1
        S = np.linalg.inv(prior_info + lam_mid * A)
        Si, Ai, bi = S[group], A[group], b[group]
        f = np.einsum("nij,nj->ni", Si, bi - np.einsum("nij,nj->ni", Ai, m))  # eq. 8: S(b - Am)
        m += f * dl  # eq. 6-7, drift part
        if diffusion > 0 and rng is not None:  # rng is given when diffusion > 0 (checked)
            SB = S @ B  # diffusion covariance dl * S A S = dl (SB)(SB)^T
            eps = rng.standard_normal((n, B.shape[2]))
            m += diffusion * np.sqrt(dl) * np.einsum("nik,nk->ni", SB[group], eps)  # eq. 7: v w
        log_det_g += _slogdet_abs(eye - dl * S @ A)  # det(I + dl grad f), grad f = -S A
        lam += dl
    return m, log_det_g[group]


def _check_mixture_arguments(
    m: np.ndarray,
    prior_info: np.ndarray,
    A: np.ndarray,
    b: np.ndarray,
    log_c: np.ndarray,
    B: np.ndarray,
    diffusion: float,
    rng: np.random.Generator | None,
    allowed: np.ndarray | None,
) -> None:
    """Check the shapes of :func:`mixture_flow`'s arguments against the states ``m`` (N, M)."""
    n, dim = m.shape
    r = A.shape[0]
    if prior_info.shape != (n, dim, dim):
        raise ValueError(
            f"mixture_flow: prior_info must have shape ({n}, {dim}, {dim}), got {prior_info.shape}"
        )
    if b.shape != (r, dim) or log_c.shape != (r,) or B.shape[:2] != (r, dim):
        raise ValueError("mixture_flow: A, b, log_c and B must describe the same components")
    if diffusion > 0 and rng is None:
        raise ValueError("mixture_flow: rng is required when diffusion > 0")
    if allowed is not None and np.shape(allowed) != (n, r):
        raise ValueError(
            f"mixture_flow: allowed must have shape ({n}, {r}), got {np.shape(allowed)}"
        )


def _responsibilities(
    Am: np.ndarray,
    m: np.ndarray,
    b: np.ndarray,
    log_c: np.ndarray,
    log_floor: float,
    allowed: np.ndarray | None,
) -> np.ndarray:
    """``(N, R)`` responsibilities of the mixture's components for each particle ``m`` (N, M),
    the floor taking the rest; ``Am`` (N, R, M) holds ``A_r m``."""
    log_h = log_c - 0.5 * np.einsum("nri,ni->nr", Am, m) + m @ b.T
    if allowed is not None:
        log_h = np.where(allowed, log_h, -np.inf)
    top = np.maximum(log_h.max(axis=1), log_floor)
    top = np.where(np.isfinite(top), top, 0.0)
    resp = np.exp(log_h - top[:, None])  # responsibilities pi_r of the mixture
    den = resp.sum(axis=1) + np.exp(log_floor - top)
    resp /= np.where(den > 0, den, 1.0)[:, None]
    return resp


def _exact_jacobian(
    A: np.ndarray,
    b: np.ndarray,
    Am: np.ndarray,
    resp: np.ndarray,
    grad: np.ndarray,
    A_bar: np.ndarray,
    S: np.ndarray,
    f: np.ndarray,
    lam_mid: float,
) -> np.ndarray:
    """``(N, M, M)`` exact derivative of the flow ``f = S g`` in ``m`` (see
    :func:`mixture_flow`'s ``exact_jacobian``)."""
    g_r = b[None] - Am  # (N, R, M)
    dev = g_r - grad[:, None, :]
    C = np.einsum("nr,nri,nrj->nij", resp, g_r, dev)
    Af = np.einsum("rij,nj->nri", A, f)
    D = np.einsum("nr,nri,nrj->nij", resp, Af, dev)
    return S @ (C - A_bar - lam_mid * D)


def mixture_flow(
    states: np.ndarray,
    prior_info: np.ndarray,
    A: np.ndarray,
    b: np.ndarray,
    log_c: np.ndarray,
    B: np.ndarray,
    steps: np.ndarray,
    log_floor: float = -np.inf,
    diffusion: float = 1.0,
    rng: np.random.Generator | None = None,
    allowed: np.ndarray | None = None,
    exact_jacobian: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Flow particles towards a mixture likelihood (seed eq. 10), per particle.

    ``h(m) = exp(log_floor) + sum_r exp(log_c_r - 1/2 m^T A_r m + b_r^T m)``; the floor is a
    constant background that keeps particles far from every component from being pulled.
    ``allowed`` restricts each particle's mixture to some components (e.g. those gated by its
    cluster).

    Parameters
    ----------
    states : ndarray (N, M)
    prior_info : ndarray (N, M, M)
        ``P^-1`` of each particle (its cluster's).
    A : ndarray (R, M, M), b : ndarray (R, M), log_c : ndarray (R,)
        Component quadratic forms and log constants (weights included).
    B : ndarray (R, M, K)
        Factors ``A_r = B_r B_r^T``.
    steps : ndarray (S,)
    log_floor : float
    diffusion : float
    rng : numpy.random.Generator
    allowed : ndarray (N, R) bool, optional
        Components each particle's mixture may use (all when omitted).
    exact_jacobian : bool
        ``log_det`` from the exact derivative of the step map (responsibilities and ``S``
        depend on ``m``): with ``g_r = b_r - A_r m``, ``g = sum_r pi_r g_r`` and
        ``f = S g``, ``grad f = S [sum_r pi_r g_r (g_r - g)^T - A_bar
        - lambda sum_r pi_r (A_r f)(g_r - g)^T]``. Otherwise the Gauss–Newton ``-S A_bar``
        (responsibilities held fixed). Only the exact one makes eq. 22 an importance weight
        of the deterministic flow (``diffusion = 0``).

    Returns
    -------
    states : ndarray (N, M)
    log_det : ndarray (N,)
    """
    m = np.array(states, dtype=float, copy=True)
    n, dim = m.shape
    r = A.shape[0]
    _check_mixture_arguments(m, prior_info, A, b, log_c, B, diffusion, rng, allowed)
    log_det = np.zeros(n)
    if r == 0:
        return m, log_det
    eye = np.eye(dim)
    lam = 0.0
    k = B.shape[2]
    for dl in steps:
        lam_mid = lam + dl / 2
        Am = np.einsum("rij,nj->nri", A, m)  # (N, R, M)
        resp = _responsibilities(Am, m, b, log_c, log_floor, allowed)
        grad = np.einsum("nr,nri->ni", resp, b[None] - Am)  # grad log h = sum_r pi_r (b_r - A_r m)
        A_bar = np.einsum("nr,rij->nij", resp, A)  # -grad^2 log h (Gauss-Newton)
        S = np.linalg.inv(prior_info + lam_mid * A_bar)  # eq. 9
        f = np.einsum("nij,nj->ni", S, grad)  # eq. 8
        m += f * dl  # eq. 6-7, drift part
        if diffusion > 0 and rng is not None:  # rng is given when diffusion > 0 (checked)
            fac = (np.sqrt(resp)[:, :, None, None] * B[None]).transpose(0, 2, 1, 3)
            SB = S @ fac.reshape(n, dim, r * k)  # A_bar = fac fac^T
            eps = rng.standard_normal((n, r * k))
            m += diffusion * np.sqrt(dl) * np.einsum("nik,nk->ni", SB, eps)  # eq. 7: v w
        if exact_jacobian:
            jac = _exact_jacobian(A, b, Am, resp, grad, A_bar, S, f, lam_mid)
        else:
            jac = -S @ A_bar
        log_det += _slogdet_abs(eye + dl * jac)  # det(I + dl grad f)
        lam += dl
    return m, log_det


def affine_flow_map(
    prior_info: np.ndarray,
    A: np.ndarray,
    b: np.ndarray,
    B: np.ndarray,
    steps: np.ndarray,
    diffusion: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The affine flow of :func:`affine_flow` as one Gaussian map per group.

    Each step of eqs. 6–8 with the quadratic log-likelihood is affine,
    ``m <- J_s m + Delta lambda S_s b + v sqrt(Delta lambda) S_s B eps``, ``J_s = I - Delta lambda
    S_s A``; composed over the steps, ``m_k = M m_{k|k-1} + c + e`` with
    ``e ~ N(0, Sigma)``::

        M     <- J_s M                                   (M_0 = I)
        c     <- J_s c + Delta lambda S_s b              (c_0 = 0)
        Sigma <- J_s Sigma J_s^T + v^2 Delta lambda S_s A S_s   (Sigma_0 = 0)

    Sampling ``m_k`` this way has the same law as running the steps one by one, and gives the
    proposal density of the flow in closed form (:mod:`avtrack.phd.lpf`, the weights of
    eq. 22): given the parent, ``m_{k|k-1} ~ N(F m_{k-1}, Q)`` so
    ``m_k ~ N(M F m_{k-1} + c, M Q M^T + Sigma)``. With ``diffusion = 0`` the map is
    deterministic and ``|det M|`` is the product of eq. 22's ``|det(I + Delta lambda grad f)|``.

    Parameters
    ----------
    prior_info : ndarray (G, M, M)
        ``P^-1`` of each group (eq. 9).
    A : ndarray (G, M, M), b : ndarray (G, M), B : ndarray (G, M, K)
        ``-grad^2 log h``, ``grad log h = b - A m`` and a factor ``A = B B^T``.
    steps : ndarray (S,)
        ``Delta lambda`` per step.
    diffusion : float
        ``v`` of eq. 7.

    Returns
    -------
    M : ndarray (G, M, M)
    c : ndarray (G, M)
    Sigma : ndarray (G, M, M)
    """
    g, dim = b.shape
    for name, arr, shape in (("prior_info", prior_info, (g, dim, dim)), ("A", A, (g, dim, dim))):
        if arr.shape != shape:
            raise ValueError(f"affine_flow_map: {name} must have shape {shape}, got {arr.shape}")
    if B.shape[:2] != (g, dim):
        raise ValueError(f"affine_flow_map: B must have shape ({g}, {dim}, K), got {B.shape}")
    if not (np.isfinite(diffusion) and diffusion >= 0):
        raise ValueError(f"affine_flow_map: diffusion must be >= 0, got {diffusion}")
    eye = np.eye(dim)
    M = np.broadcast_to(eye, (g, dim, dim)).copy()
    c = np.zeros((g, dim))
    Sigma = np.zeros((g, dim, dim))
    lam = 0.0
    for dl in steps:
        S = np.linalg.inv(prior_info + (lam + dl / 2) * A)  # eq. 9 at the step's midpoint
        J = eye - dl * S @ A  # I + dl grad f, grad f = -S A (eq. 8)
        M = J @ M
        c = np.einsum("gij,gj->gi", J, c) + dl * np.einsum("gij,gj->gi", S, b)
        if diffusion > 0:
            SB = S @ B
            Sigma = (J @ Sigma @ J.transpose(0, 2, 1)
                     + diffusion**2 * dl * SB @ SB.transpose(0, 2, 1))
        lam += dl
    return M, c, Sigma


def log_gaussian(x: np.ndarray, mean: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """``log N(x; mean, cov)`` row by row.

    Parameters
    ----------
    x, mean : ndarray (N, M)
    cov : ndarray (N, M, M) or (M, M)
        Symmetric positive definite.

    Returns
    -------
    ndarray (N,)
    """
    x = np.asarray(x, dtype=float)
    n, dim = x.shape
    cov = np.broadcast_to(cov, (n, dim, dim))
    L = np.linalg.cholesky(cov)
    e = np.linalg.solve(L, (x - mean)[:, :, None])[:, :, 0]
    log_det = 2 * np.sum(np.log(np.diagonal(L, axis1=1, axis2=2)), axis=1)
    return -0.5 * (np.sum(e * e, axis=1) + log_det + dim * np.log(2 * np.pi))


def pairwise_log_gaussian(x: np.ndarray, means: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """``log N(x_i; mean_j, cov)`` for every pair ``(i, j)`` with one shared covariance.

    Parameters
    ----------
    x : ndarray (N, M)
    means : ndarray (K, M)
    cov : ndarray (M, M)
        Symmetric positive definite.

    Returns
    -------
    ndarray (N, K)
    """
    x = np.asarray(x, dtype=float)
    dim = x.shape[1]
    L = np.linalg.cholesky(cov)
    L_inv = np.linalg.inv(L)
    e = (x[:, None, :] - means[None, :, :]) @ L_inv.T  # whitened differences (N, K, M)
    log_det = 2 * np.sum(np.log(np.diag(L)))
    return -0.5 * (np.sum(e * e, axis=2) + log_det + dim * np.log(2 * np.pi))


def _logsumexp_rows(a: np.ndarray) -> np.ndarray:
    top = np.max(a, axis=1, keepdims=True)
    top = np.where(np.isfinite(top), top, 0.0)
    with np.errstate(divide="ignore"):
        return np.log(np.sum(np.exp(a - top), axis=1)) + top[:, 0]


def marginal_log_weights(
    x: np.ndarray,
    log_w: np.ndarray,
    transition_mean: np.ndarray,
    Q: np.ndarray,
    proposal_mean: np.ndarray,
    proposal_cov: np.ndarray,
) -> np.ndarray:
    """Log importance weights of particles drawn one per parent from a family of proposals,
    for the predicted intensity of those parents (deterministic-mixture weights).

    Particle ``i`` was drawn from its own parent's proposal
    ``q_i = N(proposal_mean_i, proposal_cov)``; its weight for the predicted PHD of the
    group, ``D(m) = sum_j w_j N(m; transition_mean_j, Q)`` (eq. 4's numerator summed over
    the parents, the seed's ``phi(m | m_{k-1}^j) w_{k-1}^j``), is::

        u_i = D(m_i) / sum_j q_j(m_i)

    (Veach and Guibas 1995, balance heuristic; Klaas, de Freitas and Doucet 2005, the
    marginal particle filter; Elvira et al. 2019, deterministic-mixture MIS). For any
    function ``g``, ``E[sum_i u_i g(m_i)] = sum_i int q_i g D / sum_j q_j = int g D``: the
    weights are unbiased for the predicted intensity, the quantity the PHD update needs (it
    never needs the particles' paths), and far less spread than the per-parent ratio
    ``w_i phi(m_i | m_{k-1}^i) / q_i(m_i)``, which carries the spread of the parents.

    Parameters
    ----------
    x : ndarray (N, M)
        The drawn particles ``m_k``.
    log_w : ndarray (N,)
        ``log w_{k|k-1}`` of the parents (one parent per particle, same order).
    transition_mean : ndarray (N, M)
        ``F m_{k-1}`` of each parent.
    Q : ndarray (M, M)
        Transition covariance.
    proposal_mean : ndarray (N, M)
        Mean of each parent's proposal.
    proposal_cov : ndarray (M, M)
        Covariance of the proposals (shared by the group).

    Returns
    -------
    ndarray (N,)
        ``log u_i``.
    """
    log_d = pairwise_log_gaussian(x, transition_mean, Q) + log_w[None, :]
    log_q = pairwise_log_gaussian(x, proposal_mean, proposal_cov)
    return _logsumexp_rows(log_d) - _logsumexp_rows(log_q)
