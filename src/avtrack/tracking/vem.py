r"""Variational-EM updates of the multi-target tracking engine (thesis ch. 2).

Plain functions on batched arrays; :class:`avtrack.tracking.engine.VEMEngine` wraps them.
Shapes: ``N`` targets, ``M`` observations, state dimension ``d``.

The model (thesis §2.2): each target ``n`` has a Gaussian state
:math:`q(s_{tn}) = \mathcal{N}(\mu_{tn}, \Gamma_{tn})` (eq. 2.22); observation ``m`` is generated
by target :math:`Z_{tm}=n` or by clutter :math:`Z_{tm}=0` (uniform density); the dynamics are
linear-Gaussian :math:`p(s_{tn}|s_{t-1,n}) = \mathcal{N}(D s_{t-1,n}, \Lambda_{tn})` (eq. 2.6).
"""

from __future__ import annotations

import functools
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
    log_post += log_prior  # log τ_tmn η_mn
    # shifted by the row maximum so that exp cannot overflow (in place: small arrays)
    log_post -= log_post.max(axis=1, keepdims=True)
    post = np.exp(log_post, out=log_post)
    post /= post.dot(ones(n + 1))[:, None]  # α_tmn = τη / Σ_i τ_tmi η_mi, eq. 2.25
    return post


def exclusive_projection(alpha: np.ndarray, n_iter: int = 1000, tol: float = 1e-6) -> np.ndarray:
    r"""Project responsibilities onto "each target explains at most one observation".

    The independent assignments of eq. 2.25 let one target absorb several observations (a
    full-body and a partial detection of one person, say). Under the point-target assumption
    (a person produces at most one detection per frame) the E-Z step becomes the I-projection

    .. math::
        \min_q \mathrm{KL}(q\,\|\,\alpha) \ \text{s.t.}\ \sum_{n=0}^{N} q_{mn} = 1,\quad
        \sum_m q_{mn} \le 1 \ (n \ge 1),

    whose solution is :math:`q_{mn} = \alpha_{mn} r_m c_n` with :math:`c_0 = 1`, found by
    alternating Bregman projections onto the two constraint sets (Sinkhorn scaling with a
    one-sided column constraint). Observations a saturated target cannot take flow back to the
    other targets and to clutter.

    Parameters
    ----------
    alpha : ndarray (M, N + 1)
        Row-stochastic responsibilities, clutter in column 0.

    The iterations run in scaling form, :math:`q_{mn} = \alpha_{mn} r_m / t_n` with
    :math:`t_0 = 1`: the column projection is :math:`t_n \leftarrow \max(t_n, s_n)` with
    :math:`s_n = \sum_m \alpha_{mn} r_m`, the row projection
    :math:`r_m = 1 / \sum_n \alpha_{mn} / t_n`, and they stop at the first iterate whose target
    columns sum to at most ``1 + tol`` or after ``n_iter`` projections. Only the few columns
    ever over their bound are iterated (see :func:`_sinkhorn_scales`).

    Returns
    -------
    ndarray (M, N + 1)
        Row-stochastic, target columns summing to at most ``1 + tol``.
    """
    if alpha.shape[1] < 2 or n_iter < 1:
        return alpha
    bound = 1.0 + tol
    s = ones(alpha.shape[0]).dot(alpha[:, 1:])  # column sums of q = α
    if s[s.argmax()] <= bound:  # (argmax: much cheaper than max() on small arrays)
        return alpha
    # Clutter must be able to take the excess: with α_m0 = 0 the constraint set can be empty,
    # and with a tiny α_m0 each iteration only about doubles it, so floor it (the early exits
    # keep the usual case at a few iterations).
    alpha = np.concatenate([np.maximum(alpha[:, :1], CLUTTER_FLOOR), alpha[:, 1:]], axis=1)
    t = _sinkhorn_scales(alpha, np.concatenate([[0.0], s]), n_iter, bound)
    r = 1.0 / alpha.dot(1.0 / t)  # r_m = 1 / Σ_n α_mn / t_n
    return alpha * r[:, None] / t  # q_mn = α_mn r_m / t_n


def _sinkhorn_scales(alpha: np.ndarray, s: np.ndarray, n_iter: int, bound: float) -> np.ndarray:
    r"""Column scales :math:`t` ``(N + 1,)`` of the last iterate of :func:`exclusive_projection`.

    ``s`` ``(N + 1,)`` holds the column sums of ``alpha`` (0 for the clutter column, which is
    never scaled). A column keeps :math:`t_n = 1` until its sum exceeds 1, and usually one or
    two targets ever do; with :math:`A` the columns scaled so far and
    :math:`b_m = \sum_{n \notin A}\alpha_{mn}`, the iterations only need
    :math:`r_m = 1 / (b_m + \sum_{a \in A}\alpha_{ma}/t_a)` and :math:`s_a`. Every
    :math:`r_m`, hence every other column sum, grows with the :math:`t_a`: so when the other
    columns sum to at most 1 at the last iterate of a run of iterations they did at every
    earlier one and were indeed not scaled; otherwise the iterations go back to the first
    iterate where one went over, and go on with that column in :math:`A`. The iterates are
    those of the plain alternating projections.
    """
    t = np.ones(alpha.shape[1])
    k = 0  # projections done; ``s`` are the column sums Σ_m α_mn r_m of iterate k
    while k < n_iter:
        scaled = (t > 1.0) | (s > t)
        active = np.flatnonzero(scaled)
        alpha_a = alpha[:, active]
        alpha_others = alpha[:, np.flatnonzero(~scaled)[1:]]  # targets still at t_n = 1
        b = alpha.dot((~scaled).astype(float))  # Σ_{n∉A} α_mn
        run = _SinkhornRun(alpha_a, b, t[active], s[active], bound)
        while k < n_iter:
            history = run.iterate(min(_RUN, n_iter - k))
            k += history.shape[0]
            # the other columns' sums at every iterate of the run: r (K, M), then (K, |others|)
            r = 1.0 / (b + (1.0 / history).dot(alpha_a.T))
            over = np.flatnonzero((r.dot(alpha_others) > 1.0).any(axis=1))
            if over.shape[0] == 0 and not run.converged:
                continue
            last = history.shape[0] - 1 if over.shape[0] == 0 else int(over[0])
            k -= history.shape[0] - 1 - last  # back to the first iterate with another one over
            t[active] = history[last]
            s = alpha.T.dot(r[last])  # column sums of that iterate
            s[0] = 0.0
            col = s / t
            if col[col.argmax()] <= bound:
                return t
            break
        else:
            t[active] = history[-1]
    return t


#: Iterations between two checks of the columns outside the iterated set.
_RUN = 256


class _SinkhornRun:
    r"""Alternating projections on the columns ``alpha_a`` ``(M, A)`` of
    :func:`_sinkhorn_scales`, the other columns held at :math:`t_n = 1` (``b`` ``(M,)``: their
    row sums), from the scales ``t_a`` and column sums ``s_a`` ``(A,)`` of an iterate.

    With :math:`g_{ma} = \alpha_{ma}/b_m` and :math:`u_a = 1/t_a \le 1`,
    :math:`\alpha_{ma} r_m = g_{ma} / (1 + \sum_c g_{mc} u_c)`. Rows that the iterated targets
    hardly claim (every :math:`g_{ma} \le 10^{-6}`) add
    :math:`g_{ma} - g_{ma}\sum_c g_{mc} u_c` to within :math:`4\cdot 10^{-18}`: constants. For
    one or two columns and at most three other rows (the detections competing for the
    targets), the iterations then run on floats in closed form, else on arrays.
    """

    def __init__(self, alpha_a: np.ndarray, b: np.ndarray, t_a: np.ndarray, s_a: np.ndarray,
                 bound: float):
        self.bound = bound
        self.converged = False
        n_a = alpha_a.shape[1]
        g = alpha_a / b[:, None]  # g_ma = α_ma / b_m
        far = (g <= 1e-6).all(axis=1)
        self.closed = n_a <= 2 and np.count_nonzero(~far) <= 3
        if self.closed:
            g_far = g[far]
            near = np.zeros((3, 2))  # zero rows add nothing
            near[:np.count_nonzero(~far), :n_a] = g[~far]
            self.near = near.tolist()
            c = np.zeros(2)
            c[:n_a] = g_far.sum(axis=0)  # Σ_far g_ma
            cc = np.zeros((2, 2))
            cc[:n_a, :n_a] = g_far.T.dot(g_far)  # Σ_far g_ma g_mc
            self.c, self.cc = c.tolist(), cc.tolist()
            self.t, self.s = t_a.tolist(), s_a.tolist()
        else:
            self.alpha_a, self.alpha_at, self.b = alpha_a, alpha_a.T.copy(), b
            self.t_a, self.s_a = t_a, s_a

    def iterate(self, count: int) -> np.ndarray:
        """Run up to ``count`` projections (fewer on convergence): ``(K, A)`` scales t_a."""
        if not self.closed:
            return self._iterate_arrays(count)
        history = []
        bound = self.bound
        (g_1, h_1), (g_2, h_2), (g_3, h_3) = self.near  # g_m1, g_m2 of the near rows
        if len(self.t) == 1:
            (t_1,), (s_1,) = self.t, self.s
            c_1, c_11 = self.c[0], self.cc[0][0]
            for _ in range(count):
                if s_1 > t_1:  # project onto column sums <= 1: t_a = max(t_a, s_a)
                    t_1 = s_1
                u_1 = 1.0 / t_1
                # project rows; s_a = Σ_m α_ma r_m
                s_1 = (c_1 - c_11 * u_1 + g_1 / (1.0 + g_1 * u_1) + g_2 / (1.0 + g_2 * u_1)
                       + g_3 / (1.0 + g_3 * u_1))
                history.append(t_1)
                if s_1 <= bound * t_1:  # Σ_m q_ma = s_a / t_a
                    self.converged = True
                    break
            self.t, self.s = [t_1], [s_1]
            return np.array(history)[:, None]
        (t_1, t_2), (s_1, s_2) = self.t, self.s
        (c_1, c_2), ((c_11, c_12), (_, c_22)) = self.c, self.cc
        for _ in range(count):
            if s_1 > t_1:  # project onto column sums <= 1: t_a = max(t_a, s_a)
                t_1 = s_1
            if s_2 > t_2:
                t_2 = s_2
            u_1, u_2 = 1.0 / t_1, 1.0 / t_2
            # project rows: 1 / (1 + Σ_c g_mc u_c) for the near rows, then s_a = Σ_m α_ma r_m
            d_1 = 1.0 / (1.0 + g_1 * u_1 + h_1 * u_2)
            d_2 = 1.0 / (1.0 + g_2 * u_1 + h_2 * u_2)
            d_3 = 1.0 / (1.0 + g_3 * u_1 + h_3 * u_2)
            s_1 = c_1 - c_11 * u_1 - c_12 * u_2 + g_1 * d_1 + g_2 * d_2 + g_3 * d_3
            s_2 = c_2 - c_12 * u_1 - c_22 * u_2 + h_1 * d_1 + h_2 * d_2 + h_3 * d_3
            history.append((t_1, t_2))
            if s_1 <= bound * t_1 and s_2 <= bound * t_2:  # Σ_m q_ma = s_a / t_a
                self.converged = True
                break
        self.t, self.s = [t_1, t_2], [s_1, s_2]
        return np.array(history)

    def _iterate_arrays(self, count: int) -> np.ndarray:
        history = []
        t_a, s_a = self.t_a, self.s_a
        for _ in range(count):
            t_a = np.maximum(t_a, s_a)  # project onto column sums <= 1
            s_a = self.alpha_at.dot(1.0 / (self.b + self.alpha_a.dot(1.0 / t_a)))  # rows; s_a
            history.append(t_a)
            col = s_a / t_a
            if col[col.argmax()] <= self.bound:
                self.converged = True
                break
        self.t_a, self.s_a = t_a, s_a
        return np.array(history)


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


def cv_pattern(dim: int, n_vel: int) -> np.ndarray:
    """``(dim, dim)`` bool mask: True where a constant-velocity covariance may be nonzero."""
    k = dim - n_vel
    mask = np.eye(dim, dtype=bool)
    mask[np.arange(n_vel), k + np.arange(n_vel)] = True
    mask[k + np.arange(n_vel), np.arange(n_vel)] = True
    return mask


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
    n, k = states.mu_p.shape
    d = k + n_vel
    mu = np.concatenate([states.mu_p, states.mu_v[:, :n_vel]], axis=1)
    gamma = np.zeros((n, d * d))
    # diagonal, then Γ[i, k + i] and Γ[k + i, i]
    gamma[:, _cv_flat_index(k, n_vel)] = np.concatenate(
        [states.var_p, states.var_v[:, :n_vel], states.cov[:, :n_vel], states.cov[:, :n_vel]],
        axis=1)
    return mu, gamma.reshape(n, d, d)


@functools.cache
def _cv_flat_index(k: int, n_vel: int) -> np.ndarray:
    """Flat indices into a ``d × d`` matrix of its diagonal, ``[i, k + i]`` and ``[k + i, i]``."""
    d = k + n_vel
    p, v = np.arange(n_vel), k + np.arange(n_vel)
    return np.concatenate([np.arange(d) * (d + 1), p * d + v, v * d + p])


def predict_cv(states: CVStates, lam: CVStates, dt: float) -> CVStates:
    r""":func:`predict` (thesis eq. 2.21) of constant-velocity states.

    :math:`p_i' = p_i + \Delta t\, v_i`, so :math:`D\Gamma D^\top + \Lambda` has
    :math:`\Gamma_{pp} + 2\Delta t\,\Gamma_{pv} + \Delta t^2\Gamma_{vv} + \Lambda_{pp}`,
    :math:`\Gamma_{pv} + \Delta t\,\Gamma_{vv} + \Lambda_{pv}` and
    :math:`\Gamma_{vv} + \Lambda_{vv}`.

    Parameters
    ----------
    states : CVStates
        :math:`q(s_{t-1,n})`.
    lam : CVStates
        :math:`\Lambda_{tn}` in the covariance fields; the control term :math:`c_{tn}` of
        eq. 3.34 in the mean fields, or None there for no control.
    dt : float
        :math:`\Delta t` of :func:`~avtrack.models.dynamics.constant_velocity_transition`.

    Returns
    -------
    CVStates
    """
    mu_p, mu_v, var_p, var_v, cov = states
    mu_p = mu_p + dt * mu_v  # D μ: p + Δt v (v unchanged)
    if lam.mu_p is not None:  # + c
        mu_p += lam.mu_p
        mu_v = mu_v + lam.mu_v
    return CVStates(
        mu_p,
        mu_v,
        var_p + (2 * dt) * cov + (dt * dt) * var_v + lam.var_p,  # Γ_pp + 2Δt Γ_pv + Δt² Γ_vv + Λ
        var_v + lam.var_v,  # Γ_vv + Λ_vv
        cov + dt * var_v + lam.cov,  # Γ_pv + Δt Γ_vv + Λ_pv
    )


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
