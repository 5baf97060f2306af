r"""Variational-EM updates of the multi-target tracking engine (thesis ch. 2).

Plain functions on batched arrays; :class:`avtrack.vem.engine.VEMEngine` wraps them.
Shapes: ``N`` targets, ``M`` observations, state dimension ``d``.

The model (thesis §2.2): each target ``n`` has a Gaussian state
:math:`q(s_{tn}) = \mathcal{N}(\mu_{tn}, \Gamma_{tn})` (eq. 2.22); observation ``m`` is generated
by target :math:`Z_{tm}=n` or by clutter :math:`Z_{tm}=0` (uniform density); the dynamics are
linear-Gaussian :math:`p(s_{tn}|s_{t-1,n}) = \mathcal{N}(D s_{t-1,n}, \Lambda_{tn})` (eq. 2.6).

The exclusive projection (:func:`exclusive_projection`, solved by :func:`_kl_projection`).

**Optimality conditions.** With a multiplier :math:`\lambda_m` per row and
:math:`\nu_n \ge 0` per target column (:math:`\nu_0 = 0` for clutter), stationarity of
:math:`\sum_{mn} q_{mn}\log(q_{mn}/\alpha_{mn}) + \sum_m\lambda_m(\sum_n q_{mn} - 1) +
\sum_n\nu_n(s_n - 1)` gives each row as :math:`\alpha_m` tilted by the multipliers and
renormalised,

.. math::
    q_{mn}(\nu) = \alpha_{mn} e^{-\nu_n} / Z_m(\nu), \qquad
    Z_m(\nu) = \sum_{n=0}^N \alpha_{mn} e^{-\nu_n},

and the multipliers minimise the (negated) dual
:math:`F(\nu) = \sum_m \log Z_m(\nu) + \sum_{n\ge1} \nu_n` over :math:`\nu \ge 0`, with
:math:`\partial F/\partial\nu_n = 1 - s_n(\nu)`. The problem is convex with linear
constraints and a strictly feasible point (everything on clutter), so :math:`q(\nu)` is
the projection if and only if the KKT conditions hold:

.. math::
    \nu_n \ge 0, \qquad s_n(\nu) \le 1, \qquad \nu_n\,(1 - s_n(\nu)) = 0 \quad (n \ge 1),

i.e. a target's column is scaled down (:math:`\nu_n > 0`) only if it then sums to exactly
1. The Hessian :math:`H = \sum_m \mathrm{diag}(q_m) - q_m q_m^\top` (on the target columns)
is positive definite on the columns with mass because every :math:`q_{m0} > 0`, and its
off-diagonal entries are :math:`\le 0`: raising :math:`\nu_k` moves mass into every other
column.

**Solver.** Only the working set
:math:`W = \{n \ge 1: \nu_n > 0 \text{ or } s_n > 1\}` moves (a column at
:math:`\nu_n = 0` with :math:`s_n \le 1` meets its conditions), by two kinds of iterations,
each of which decreases :math:`F`:

* Exact minimisation over one multiplier, the others held (:func:`_solve_column`): with
  :math:`a_m = \alpha_{mn}e^{-\nu_n}` and :math:`b_m` the rest of row ``m``, the column sum
  after scaling :math:`e^{\nu_n}` by :math:`t`, :math:`s(t) = \sum_m a_m/(a_m + b_m t)`, is
  convex and decreasing in :math:`t`, concave and increasing in :math:`u = 1/t`. Newton's
  method on :math:`t` from :math:`s > 1` (on :math:`u` from :math:`s < 1`) therefore
  approaches the root monotonically from its starting side, never overshooting, and
  converges quadratically; it is clipped at :math:`\nu_n = 0`. This is the whole solver in
  the usual case, one target claimed by two detections (23 of the 25 projected calls of a
  TUD-Campus run). As :math:`s_n` increases with the other multipliers, the root for one
  column can only rise with them, so from :math:`\nu = 0` these steps keep
  :math:`\nu \le \nu^*`: the multipliers rise to the solution from below.
* Projected Newton on :math:`W` once all its multipliers are positive:
  :math:`d = -H_{WW}^{-1}(1 - s_W)`, taken along
  :math:`\nu_n + \mathrm{sign}(d_n)\log(1 + \tau|d_n|)` (Newton on :math:`e^{\nu_n}` where
  :math:`d_n > 0`, on :math:`e^{-\nu_n}` where :math:`d_n < 0`), projected on
  :math:`0 \le \nu_n \le \log(M\max_m \alpha_{mn}/\alpha_{m0}) + 1` (a box that holds
  :math:`\nu^*`: an active column has some :math:`q_{mn} \ge 1/M`, and
  :math:`q_{mn} \le e^{-\nu_n}\alpha_{mn}/\alpha_{m0}`), with Armijo backtracking in
  :math:`\tau` on :math:`F` evaluated without cancellation. A step that fails the search,
  or that did not reduce :math:`\max_W|1 - s_n|` fourfold, is followed by a sweep of
  exact one-column minimisations (a target owning a row against tiny clutter makes
  :math:`F` very flat, and its Newton steps short).

Both kinds decrease :math:`F` sufficiently (Armijo; exact minimisation over a coordinate),
and :math:`F` is strictly convex on the columns with mass (every :math:`q_{m0} > 0`), so
the iterations converge to its minimiser :math:`\nu^*`. They stop when
:math:`s_n \le 1 +` :data:`FEASIBILITY_TOL` for every target and
:math:`\max(1, \nu_n)\,|1 - s_n| \le` :data:`KKT_TOL` wherever :math:`\nu_n > 0`, i.e.
when the KKT conditions hold (stationarity holds by construction of :math:`q(\nu)`).
"""

from __future__ import annotations

import functools
import math
import warnings
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

#: Smallest prior probability kept for any class after the M-step (keeps log finite).
PRIOR_FLOOR = 1e-6

#: Smallest clutter responsibility used by :func:`exclusive_projection`.
CLUTTER_FLOOR = 1e-9


@functools.cache
def ones(n: int) -> np.ndarray:
    """A read-only ``(n,)`` vector of ones: ``a.dot(ones(n))`` sums the rows of a small array
    several times faster than ``a.sum(axis=1)``, whose call overhead dominates at these sizes."""
    out = np.ones(n)
    out.flags.writeable = False
    return out


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
    m, n = log_tau.shape
    log_post = np.empty((m, n + 1))
    log_post[:, 0] = log_clutter
    log_post[:, 1:] = log_tau
    return e_z_normalise(log_post, log_prior)


def e_z_normalise(log_tau: np.ndarray, log_prior: np.ndarray) -> np.ndarray:
    r""":func:`e_z_step` on ``log_tau (M, N + 1)``, the log-likelihoods with the clutter's in
    column 0, in place: returns ``log_tau`` holding :math:`\alpha_{tmn}`."""
    log_tau += log_prior  # log τ_tmn η_mn
    # shifted by the row maximum so that exp cannot overflow (in place: small arrays)
    log_tau -= np.maximum.reduce(log_tau, axis=1, keepdims=True)  # (ndarray.max: slower)
    post = np.exp(log_tau, out=log_tau)
    post /= post.dot(ones(post.shape[1]))[:, None]  # α_tmn = τη / Σ_i τ_tmi η_mi, eq. 2.25
    return post


def exclusive_projection(
    alpha: np.ndarray, n_iter: int | None = None, tol: float = 1e-6,
) -> np.ndarray:
    r"""Project responsibilities onto "each target explains at most one observation".

    The independent assignments of eq. 2.25 let one target absorb several observations (a
    full-body and a partial detection of one person, say). Under the point-target assumption
    (a person produces at most one detection per frame) the E-Z step becomes the I-projection

    .. math::
        \min_q \sum_m \mathrm{KL}(q_m\,\|\,\alpha_m) \ \text{s.t.}\ \sum_{n=0}^{N} q_{mn} = 1,
        \quad s_n = \sum_m q_{mn} \le 1 \ (n \ge 1).

    Observations a saturated target cannot take flow back to the other targets and to clutter.
    Clutter must be able to take the excess (with :math:`\alpha_{m0} = 0` the constraint set
    can be empty), so :math:`\alpha_{m0}` is first raised to :data:`CLUTTER_FLOOR`; the result
    is the projection of that :math:`\alpha` (the rows need not be renormalised: the
    projection onto row sums 1 absorbs their scale).

    The exact projection is computed by :func:`_kl_projection`; the module docstring gives
    the optimality conditions and the solver. Rows sum to 1 to rounding.

    Parameters
    ----------
    alpha : ndarray (M, N + 1)
        Row-stochastic responsibilities, clutter in column 0.
    n_iter : int, optional
        If given, instead of the exact projection, the iterate of the alternating Bregman
        projections (Sinkhorn scaling with a one-sided column constraint) after ``n_iter``
        projections, or the first whose target columns sum to at most ``1 + tol``:
        :math:`q_{mn} = \alpha_{mn} r_m/t_n` with :math:`t_0 = 1`, column step
        :math:`t_n \leftarrow \max(t_n, \sum_m \alpha_{mn} r_m)`, row step
        :math:`r_m = 1 / \sum_n \alpha_{mn}/t_n`. They converge to the projection, but only
        linearly, and very slowly when a target takes almost a whole row of small clutter:
        1000 of them left 17 of the 207 calls of a TUD-Campus run over ``1 + 1e-6``.
    tol : float
        Tolerance of the ``n_iter`` iterations only.

    Returns
    -------
    ndarray (M, N + 1)
        ``alpha`` itself if its target columns already sum to at most
        ``1 + FEASIBILITY_TOL`` (``1 + tol`` with ``n_iter``); else the projection,
        row-stochastic, with target columns summing to at most ``1 + FEASIBILITY_TOL``
        (with ``n_iter``: the iterate, over ``1 + tol`` if ``n_iter`` did not suffice).
    """
    if alpha.shape[1] < 2 or (n_iter is not None and n_iter < 1):
        return alpha
    bound = 1.0 + (FEASIBILITY_TOL if n_iter is None else tol)
    # column sums of q = α (of the whole array: the strided target block is slower to sum)
    s = ones(alpha.shape[0]).dot(alpha)
    s[0] = 0.0  # clutter is unconstrained
    if s[s.argmax()] <= bound:  # (argmax: much cheaper than max() on small arrays)
        return alpha
    alpha = np.concatenate([np.maximum(alpha[:, :1], CLUTTER_FLOOR), alpha[:, 1:]], axis=1)
    if n_iter is not None:
        return _alternating_projections(alpha, n_iter, bound)
    return _kl_projection(alpha)[0]


#: Target columns of :func:`exclusive_projection` may sum to at most 1 + this.
FEASIBILITY_TOL = 1e-12

#: :func:`exclusive_projection` stops when the columns with :math:`\nu_n > 0` have
#: :math:`|1 - s_n| \le` this and :math:`\nu_n|1 - s_n| \le` this (complementary slackness).
KKT_TOL = 1e-10

#: Safeguard on the iterations of :func:`_kl_projection` and :func:`_solve_column` (in
#: testing, at most 25 and 20 were needed).
_MAX_ITER = 100


def _kl_projection(alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""The projection ``q`` ``(M, N + 1)`` of :func:`exclusive_projection` and its multipliers
    :math:`\nu` ``(N + 1,)`` (:math:`\nu_0 = 0`); ``alpha`` has a positive clutter column 0.

    The optimality conditions and the solver are described in the module docstring.
    """
    m, n1 = alpha.shape
    nu = np.zeros(n1)
    w = alpha.copy()  # tilted rows w_mn = α_mn e^{-ν_n}
    nu_max = None
    last_size = math.inf
    for _ in range(_MAX_ITER):
        z = w.dot(ones(n1))  # Z_m
        q = w / z[:, None]
        s = ones(m).dot(q)
        s[0] = 0.0  # clutter is unconstrained
        # columns at ν_n = 0 with s_n <= 1 meet their conditions and stay at ν_n = 0
        work = ((nu > 0.0) | (s > 1.0)).nonzero()[0]
        if work.shape[0] == 0:  # (only possible at ν = 0, after the clutter floor)
            return q, nu
        slack = 1.0 - s[work]  # the gradient of F
        # (a column with ν_n = 0 is in ``work`` only if s_n > 1: its slackness holds)
        gap = slack * np.maximum(nu[work], 1.0)
        if slack[slack.argmin()] >= -FEASIBILITY_TOL and gap[gap.argmax()] <= KKT_TOL:
            return q, nu
        # Newton once every working column has ν_n > 0 and the last Newton step (if any)
        # reduced max |1 - s_n| fourfold; else the exact one-column minimisations, which bring
        # a column that has just come over its bound to it from below
        newton = False
        if work.shape[0] > 1:
            if nu_max is None:
                # a bound on ν*: an active column sums to 1, so some q_mn >= 1/M, and
                # q_mn <= (α_mn / α_m0) e^{-ν_n}
                ratio = float((alpha[:, 1:].max(axis=1) / alpha[:, 0]).max())
                nu_max = math.log(m * ratio) + 1.0
            size = float(np.abs(slack).max())
            newton = bool((nu[work] > 0.0).all()) and size < 0.25 * last_size
        last_size = math.inf
        # (nu_max is set wherever newton is True: the check only narrows its type)
        if newton and nu_max is not None and _newton_step(alpha, w, z, q, slack, nu, work,
                                                          nu_max):
            last_size = size
        else:
            for j in work.tolist():  # exact minimisation over each working column in turn
                rest = np.ones(n1)
                rest[j] = 0.0
                nu[j] = _solve_column(w[:, j].tolist(), w.dot(rest).tolist(), nu[j])
                w[:, j] = alpha[:, j] * math.exp(-nu[j])
    warnings.warn(  # not seen in testing: a handful of iterations are needed
        f"exclusive_projection: KKT conditions not met after {_MAX_ITER} iterations",
        RuntimeWarning, stacklevel=3,
    )
    return w / w.dot(ones(n1))[:, None], nu


def _newton_step(
    alpha: np.ndarray, w: np.ndarray, z: np.ndarray, q: np.ndarray, grad: np.ndarray,
    nu: np.ndarray, work: np.ndarray, nu_max: float,
) -> bool:
    r"""One projected Newton step of :func:`_kl_projection` on the columns ``work``, with
    Armijo backtracking; ``w`` are the tilted rows, ``z`` their sums, ``q`` the iterate,
    ``grad`` :math:`= 1 - s_n` on ``work``; the step is projected on
    :math:`0 \le \nu \le` ``nu_max``, a box that holds :math:`\nu^*`. Updates ``nu`` and ``w``
    in place; False (nothing changed) if no step of the search decreases :math:`F` enough."""
    k = work.shape[0]
    q_w = q[:, work]
    # 1 - q_mn as (Z_m - w_mn) / Z_m, summed without cancellation: the rows a target nearly
    # owns (q_mn ≈ 1) are the ones that matter
    others = np.ones((w.shape[1], k))
    others[work, np.arange(k)] = 0.0
    rest = w.dot(others) / z[:, None]
    hess = -q_w.T.dot(q_w)
    hess[np.diag_indices(k)] = ones(q.shape[0]).dot(q_w * rest)  # Σ_m q_mn (1 - q_mn)
    try:
        d = np.linalg.solve(hess, -grad)
    except np.linalg.LinAlgError:
        return False
    nu_w = nu[work]
    tau = 1.0
    for _ in range(30):
        step = tau * d
        # ν + sign(d) log(1 + τ|d|): Newton on t = e^ν where d > 0, on u = e^{-ν} where d < 0
        delta = np.log1p(np.abs(step))
        np.copysign(delta, step, out=delta)
        np.clip(nu_w + delta, 0.0, nu_max, out=delta)
        delta -= nu_w
        slope = grad.dot(delta)
        if not slope < 0.0:  # (also catches a non-finite d)
            return False
        # F(ν + δ) - F(ν) = Σ_m log(1 + Σ_n q_mn (e^{-δ_n} - 1)) + Σ_n δ_n, no cancellation
        change = np.log1p(q_w.dot(np.expm1(-delta))).sum() + delta.sum()
        if change <= 1e-4 * slope:
            nu_w += delta
            nu[work] = nu_w
            w[:, work] = alpha[:, work] * np.exp(-nu_w)
            return True
        tau *= 0.5
    return False


def _solve_column(a: Sequence[float] | np.ndarray, b: Sequence[float] | np.ndarray,
                  nu_j: float) -> float:
    r"""The multiplier :math:`\nu_j \ge 0` minimising :math:`F` with the other multipliers
    held: :math:`a` ``(M,)`` is column ``j`` of the tilted rows :math:`w` at ``nu_j``, ``b``
    ``(M,)`` the rest of each row (positive). Newton's method on :math:`t` (column sum above 1)
    or :math:`u = 1/t` (below 1) for :math:`s(t) = \sum_m a_m/(a_m + b_m t) = 1` (see
    :func:`exclusive_projection`), from :math:`t = 1`, clipped at :math:`\nu_j = 0`. On floats:
    ``M`` is a handful of detections. (Written on indices, so that the compiled iterations of
    :mod:`avtrack.vem._cv_box_kernel` compile this very function for arrays.)"""
    shift = 0.0  # log t
    scale = 1.0  # t
    for _ in range(_MAX_ITER):
        s = curv = 0.0
        for m in range(len(a)):
            a_m = a[m]
            bt = b[m] * scale
            den = a_m + bt
            p = a_m / den  # q_mj
            s += p
            curv += p * bt / den  # q_mj (1 - q_mj), the second factor without cancellation
        if curv == 0.0:  # (no mass left in the column: only at s = 0)
            return 0.0
        step = (s - 1.0) / curv  # relative Newton step on t (on u if negative)
        new = shift + math.log1p(step) if step > 0.0 else shift - math.log1p(-step)
        if new <= -nu_j:  # the root needs ν_j < 0 (s < 1 at ν_j = 0): clip
            return 0.0
        shift = new
        # Newton converges quadratically: after a step from |s - 1| <= 1e-14 (a few hundred
        # roundings; q_mj (1 - q_mj) can be tiny, which makes the rounding of s alone move t
        # by much more than 1e-13) or a step of 1e-13, the next one is negligible
        if abs(s - 1.0) <= 1e-14 or abs(step) <= 1e-13:
            break
        scale = math.exp(shift)
    return nu_j + shift


def _alternating_projections(alpha: np.ndarray, n_iter: int, bound: float) -> np.ndarray:
    """The ``n_iter`` iterations of :func:`exclusive_projection` (plain Sinkhorn scaling)."""
    t = np.ones(alpha.shape[1])
    s = alpha.T.dot(ones(alpha.shape[0]))
    s[0] = 0.0  # the clutter column is never scaled
    for _ in range(n_iter):
        t = np.maximum(t, s)  # project onto column sums <= 1
        r = 1.0 / alpha.dot(1.0 / t)  # project onto row sums 1
        s = alpha.T.dot(r)
        s[0] = 0.0
        col = s / t
        if col[col.argmax()] <= bound:
            break
    return alpha * r[:, None] / t  # q_mn = α_mn r_m / t_n


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


# --------------------------------------------------------------------------- constant velocity
# Closed forms for constant-velocity states ``s = [p, v]`` (``p``: the ``k`` observed
# components, ``v``: a velocity for the first ``n_vel`` of them) observed through ``P = [I_k 0]``
# with diagonal observation covariances. Starting from diagonal covariances, the prediction
# (eq. 2.21) couples ``p_i`` with ``v_i`` only and the E-S step (eq. 2.23) adds a diagonal
# precision to ``p``, so Γ keeps the pattern of :func:`cv_pattern`: its diagonal plus the
# ``n_vel`` covariances ``Γ[i, k + i]``. Held per component ``i < k`` as a :class:`CVStates`
# (components without a velocity get one that is 0 with variance 0, which every update below
# leaves at 0), the updates are elementwise on ``(N, k)`` arrays, with no ``d × d`` inverse.


class CVStates(NamedTuple):
    """``N`` constant-velocity Gaussian states, per observed component ``i < k``: ``(N, k)``
    arrays of the mean ``μ_p`` and ``μ_v`` of ``p_i`` and ``v_i``, their variances ``Γ_pp`` and
    ``Γ_vv`` and their covariance ``Γ_pv`` (``v_i``, ``Γ_vv``, ``Γ_pv`` are 0 for ``i ≥ n_vel``).
    """

    mu_p: np.ndarray
    mu_v: np.ndarray
    var_p: np.ndarray
    var_v: np.ndarray
    cov: np.ndarray


class CVNoise(NamedTuple):
    r"""The dynamics covariance :math:`\Lambda_{tn}` of constant-velocity states in the fields
    of :class:`CVStates` (``var_p``, ``var_v``, ``cov``; ``cov`` None for
    :math:`\Lambda_{pv} = 0`), and the control term :math:`c_{tn}` of thesis eq. 3.34 in the
    mean fields (``mu_p``, ``mu_v``; None for no control): the ``lam`` of :func:`predict_cv`.
    """

    mu_p: np.ndarray | None
    mu_v: np.ndarray | None
    var_p: np.ndarray
    var_v: np.ndarray
    cov: np.ndarray | None


def cv_pattern(dim: int, n_vel: int) -> np.ndarray:
    """``(dim, dim)`` bool mask: True where a constant-velocity covariance may be nonzero."""
    k = dim - n_vel
    mask = np.eye(dim, dtype=bool)
    mask[np.arange(n_vel), k + np.arange(n_vel)] = True
    mask[k + np.arange(n_vel), np.arange(n_vel)] = True
    return mask


def cv_transition(transition: np.ndarray, k: int) -> tuple[int, float] | None:
    """``(n_vel, Δt)`` when ``transition`` ``(d, d)`` is
    :func:`~avtrack.vem.dynamics.constant_velocity_transition` ``(k, n_vel, Δt)`` (a velocity
    for the first ``n_vel = d - k`` of ``k`` observed components), else None."""
    transition = np.asarray(transition, dtype=float)
    return _cv_transition(transition.shape, transition.tobytes(), k)


@functools.lru_cache(maxsize=64)
def _cv_transition(shape: tuple[int, ...], data: bytes, k: int) -> tuple[int, float] | None:
    if len(shape) != 2 or shape[0] != shape[1]:
        return None
    d = shape[0]
    n_vel = d - k
    if not 0 < k <= d or n_vel > k:
        return None
    transition = np.frombuffer(data).reshape(shape)
    dt = float(transition[0, k]) if n_vel else 1.0
    expected = np.eye(d)
    expected[np.arange(n_vel), k + np.arange(n_vel)] = dt
    return (n_vel, dt) if np.array_equal(transition, expected) and dt > 0 else None


def cv_split(mu: np.ndarray, gamma: np.ndarray, n_vel: int) -> CVStates:
    """``mu (N, d)``, ``gamma (N, d, d)`` with the :func:`cv_pattern` -> :class:`CVStates`."""
    n, d = mu.shape
    k = d - n_vel
    out = np.zeros((5, n, k))
    diag = np.diagonal(gamma, axis1=1, axis2=2)
    out[0] = mu[:, :k]
    out[1, :, :n_vel] = mu[:, k:]
    out[2] = diag[:, :k]
    out[3, :, :n_vel] = diag[:, k:]
    out[4, :, :n_vel] = gamma[:, np.arange(n_vel), k + np.arange(n_vel)]  # Γ[i, k + i]
    return CVStates(*out)


def cv_join(states: CVStates, n_vel: int) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of :func:`cv_split`: :class:`CVStates` -> ``mu (N, d)``, ``gamma (N, d, d)``."""
    return cv_mean(states, n_vel), cv_covariance(states, n_vel)


def cv_mean(states: CVStates, n_vel: int) -> np.ndarray:
    """The means ``mu (N, d)`` of :func:`cv_join`."""
    return np.concatenate([states.mu_p, states.mu_v[:, :n_vel]], axis=1)


def cv_variance(states: CVStates, n_vel: int) -> np.ndarray:
    """The diagonal ``(N, d)`` of the covariances of :func:`cv_join`."""
    return np.concatenate([states.var_p, states.var_v[:, :n_vel]], axis=1)


def cv_covariance(states: CVStates, n_vel: int) -> np.ndarray:
    """The covariances ``gamma (N, d, d)`` of :func:`cv_join`."""
    n, k = states.mu_p.shape
    d = k + n_vel
    gamma = np.zeros((n, d * d))
    # diagonal, then Γ[i, k + i] and Γ[k + i, i]
    gamma[:, _cv_flat_index(k, n_vel)] = np.concatenate(
        [states.var_p, states.var_v[:, :n_vel], states.cov[:, :n_vel], states.cov[:, :n_vel]],
        axis=1)
    return gamma.reshape(n, d, d)


@functools.cache
def _cv_flat_index(k: int, n_vel: int) -> np.ndarray:
    """Flat indices into a ``d × d`` matrix of its diagonal, ``[i, k + i]`` and ``[k + i, i]``."""
    d = k + n_vel
    p, v = np.arange(n_vel), k + np.arange(n_vel)
    return np.concatenate([np.arange(d) * (d + 1), p * d + v, v * d + p])


def predict_cv(states: CVStates, lam: CVNoise | CVStates, dt: float) -> CVStates:
    r""":func:`predict` (thesis eq. 2.21) of constant-velocity states.

    :math:`p_i' = p_i + \Delta t\, v_i`, so :math:`D\Gamma D^\top + \Lambda` has
    :math:`\Gamma_{pp} + 2\Delta t\,\Gamma_{pv} + \Delta t^2\Gamma_{vv} + \Lambda_{pp}`,
    :math:`\Gamma_{pv} + \Delta t\,\Gamma_{vv} + \Lambda_{pv}` and
    :math:`\Gamma_{vv} + \Lambda_{vv}`.

    Parameters
    ----------
    states : CVStates
        :math:`q(s_{t-1,n})`.
    lam : CVNoise or CVStates
        :math:`\Lambda_{tn}` in the covariance fields (``cov`` None for
        :math:`\Lambda_{pv} = 0`); the control term :math:`c_{tn}` of eq. 3.34 in the mean
        fields, or None there for no control.
    dt : float
        :math:`\Delta t` of :func:`~avtrack.vem.dynamics.constant_velocity_transition`.

    Returns
    -------
    CVStates
    """
    mu_p, mu_v, var_p, var_v, cov = states
    if dt == 1.0:  # (products by Δt = 1 are exact: the same numbers without them)
        mu_p = mu_p + mu_v  # D μ: p + Δt v (v unchanged)
        var_p = var_p + 2.0 * cov + var_v + lam.var_p  # Γ_pp + 2Δt Γ_pv + Δt² Γ_vv + Λ
        cov = cov + var_v  # Γ_pv + Δt Γ_vv
    else:
        mu_p = mu_p + dt * mu_v
        var_p = var_p + (2 * dt) * cov + (dt * dt) * var_v + lam.var_p
        cov = cov + dt * var_v
    if lam.cov is not None:
        cov += lam.cov  # + Λ_pv
    if lam.mu_p is not None:  # + c
        mu_p += lam.mu_p
    if lam.mu_v is not None:
        mu_v = mu_v + lam.mu_v
    return CVStates(mu_p, mu_v, var_p, var_v + lam.var_v, cov)  # Γ_vv + Λ_vv


def e_s_step_cv(
    pred: CVStates, info_diag: np.ndarray, info_vector: np.ndarray, observed_only: bool = False,
) -> CVStates:
    r""":func:`e_s_step` (thesis eqs. 2.23–2.24) of constant-velocity states.

    The observation precision :math:`J = \mathrm{diag}(j)` acts on ``p`` only, so the posterior
    splits into one ``(p_i, v_i)`` block per component, each a rank-one update of the
    prediction. By Sherman–Morrison, with :math:`a, c, b` the predicted
    :math:`\Gamma_{pp}, \Gamma_{pv}, \Gamma_{vv}` and :math:`f = 1/(1 + j a)`:

    .. math::
        \Gamma_{pp} = f a,\quad \Gamma_{pv} = f c,\quad \Gamma_{vv} = b - j c\,\Gamma_{pv},
        \quad \mu_p = f(\bar\mu_p + a h),\quad
        \mu_v = \bar\mu_v + \Gamma_{pv}(h - j\bar\mu_p)

    which are eq. 2.23 :math:`\Gamma = (J + \bar\Gamma^{-1})^{-1}` and eq. 2.24
    :math:`\mu = \Gamma(h + \bar\Gamma^{-1}\bar\mu)` without any inverse.

    Parameters
    ----------
    pred : CVStates
        Predicted states :math:`\bar\mu, \bar\Gamma`.
    info_diag : ndarray (N, k)
        Diagonal :math:`j` of the summed precisions :math:`\sum_m \alpha_{tmn}\Phi_{tm}^{-1}`.
    info_vector : ndarray (N, k)
        :math:`h = \sum_m \alpha_{tmn}\Phi_{tm}^{-1} o_{tm}`.
    observed_only : bool
        Update only :math:`\mu_p, \Gamma_{pp}` (all that an E-Z step reads) and leave the
        velocity fields at the prediction.

    Returns
    -------
    CVStates
    """
    mu_p, mu_v, a, b, c = pred
    f = 1.0 / (1.0 + info_diag * a)  # f = 1 / (1 + j Γ̄_pp)
    post_mu_p = f * (mu_p + a * info_vector)  # μ_p = f (μ̄_p + Γ̄_pp h), eq. 2.24
    post_var_p = f * a  # Γ_pp = f Γ̄_pp, eq. 2.23
    if observed_only:
        return CVStates(post_mu_p, mu_v, post_var_p, b, c)
    cov = f * c  # Γ_pv = f Γ̄_pv, eq. 2.23
    return CVStates(
        post_mu_p,
        mu_v + cov * (info_vector - info_diag * mu_p),  # μ_v = μ̄_v + Γ_pv (h - j μ̄_p), eq. 2.24
        post_var_p,
        b - info_diag * c * cov,  # Γ_vv = Γ̄_vv - j Γ̄_pv Γ_pv, eq. 2.23
        cov,
    )


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
    unit = ones(mass.shape[0])
    total = mass.dot(unit)  # Σ_i Σ_m α_tmi
    if total <= 0:
        return np.full(mass.shape, -np.log(mass.shape[0]))
    a = np.maximum(mass / total, PRIOR_FLOOR)  # a_tn, eq. 3.29, floored
    return np.log(a / a.dot(unit))  # renormalised


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
