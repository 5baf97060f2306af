"""Compiled VEM iterations of one frame: constant-velocity states, one diagonal Gaussian
observation model with a uniform clutter class (the visual box model of thesis ch. 3).

Why by hand: a frame of OVBT holds a handful of detections and targets, so each of the
NumPy calls of :meth:`~avtrack.vem.engine.VEMEngine._iterate_cv_one` (the E-Z step, eq. 2.25
or 2.8; the exclusive projection; the E-S step, eqs. 2.23-2.24; the M step of the priors,
eq. 3.29; about 80 calls for three iterations) costs more in call overhead than in
arithmetic: half of a frame's time. Here the same updates run as one compiled loop over the
``M x N`` pairs. The formulas are those of :mod:`avtrack.vem.updates` (the functions named
below), written element by element in the same order of operations; only sums of more than
two terms may be rounded differently from NumPy's, so the results agree with the NumPy path
to rounding (tested), not to the bit.

:class:`~avtrack.vem.engine.VEMEngine` uses it when Numba is available (the condition of
:func:`avtrack._jit.available`) and the model offers its terms
(:meth:`~avtrack.vem.model.DiagonalObservationModel.compiled_terms`); else the NumPy path.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from avtrack._jit import available, build_once
from avtrack.vem.updates import (
    _MAX_ITER,
    CLUTTER_FLOOR,
    FEASIBILITY_TOL,
    KKT_TOL,
    PRIOR_FLOOR,
    _solve_column,
)

__all__ = ["available", "iterate_frame", "kernel"]

#: the compiled :func:`iterate_frame`, built on first use
_KERNEL: Callable[..., int] | None = None
_FAILED = False

_LOG_2PI = math.log(2.0 * math.pi)


def kernel() -> Callable[..., int] | None:
    """The compiled :func:`iterate_frame`, or None if Numba cannot build it here (warned
    once)."""
    return build_once(globals(), _compile, "VEM frame iterations")


#: explicit signatures (C-contiguous float64 arrays): each function is compiled once, when built
SIGNATURES = {
    "_solve_column": "f8(f8[::1], f8[::1], f8)",
    "_newton_step": "b1(f8[:, ::1], f8[:, ::1], f8[::1], f8[:, ::1], f8[::1], f8[::1], "
                    "i8[::1], f8)",
    "_kl_projection": "b1(f8[:, ::1], f8[:, ::1])",
    "iterate_frame": "i8(f8[:, ::1], f8[:, ::1], f8[:, ::1], f8[::1], f8, f8[:, ::1], b1, "
                     "f8[:, :, ::1], f8[:, :, ::1], f8, b1, f8[:, :, ::1], i8, b1, b1, b1, "
                     "f8[:, ::1], f8[::1])",
}


def _compile(njit: Callable[..., Any], cache: bool) -> Callable[..., int]:
    g = globals()
    # the functions call each other through the ``*_c`` names: bind the compiled ones first
    for name in ("_solve_column", "_newton_step", "_kl_projection"):
        g[name + "_c"] = njit(SIGNATURES[name], cache=cache, nogil=True)(g[name])
    for name in ("_predict", "_e_z", "_exclusive", "_e_s", "_m_step"):  # typed by their caller
        g[name + "_c"] = njit(cache=cache, nogil=True)(g[name])
    return njit(SIGNATURES["iterate_frame"], cache=cache, nogil=True)(iterate_frame)


def iterate_frame(
    z: np.ndarray, var: np.ndarray, inv_var: np.ndarray, log_norm: np.ndarray,
    log_clutter: float, app: np.ndarray, has_app: bool, pred: np.ndarray, lam: np.ndarray,
    dt: float, predict: bool, post: np.ndarray, n_iter: int, marginal_init: bool,
    update_priors: bool, exclusive: bool, resp: np.ndarray, mass: np.ndarray,
) -> int:
    r"""The VEM iterations of one frame (:meth:`~avtrack.vem.engine.VEMEngine._iterate_cv_one`).

    Parameters
    ----------
    z, var, inv_var : ndarray (M, k)
        Observations, the diagonals of their covariances and of their inverses.
    log_norm : ndarray (M,)
        Their Gaussians' log normalisers.
    log_clutter : float
        Log density of the clutter class.
    app : ndarray (M, N)
        Appearance log ratios added to every target's log-likelihood (read when ``has_app``).
    pred : ndarray (5, N, k)
        The predicted states (``mu_p, mu_v, var_p, var_v, cov`` of
        :class:`~avtrack.vem.updates.CVStates`); with ``predict``, the previous frame's
        posterior states, predicted here in place (:func:`~avtrack.vem.updates.predict_cv`).
    lam : ndarray (2, N, k)
        With ``predict``: the diagonal dynamics covariances :math:`\Lambda_{pp}`,
        :math:`\Lambda_{vv}` (:math:`\Lambda_{pv} = 0`, no control term).
    dt : float
        With ``predict``: :math:`\Delta t` of the constant-velocity transition.
    post : ndarray (5, N, k)
        Written: the posterior states.
    n_iter, marginal_init, update_priors, exclusive
        As :class:`~avtrack.vem.engine.VEMEngine`.
    resp : ndarray (M, N + 1)
        Written: the last iteration's responsibilities (clutter in column 0).
    mass : ndarray (N + 1,)
        Written: their column sums.

    Returns
    -------
    int
        0, or the number of exclusive projections that did not meet their KKT conditions.
    """
    n1 = pred.shape[1] + 1
    if predict:
        _predict_c(pred, lam, dt)
    log_prior = np.full(n1, -math.log(n1))  # η = 1/(N+1)
    post[:] = pred  # E-Z initialisation, thesis §4.6.1
    unconverged = 0
    last = n_iter - 1
    for it in range(n_iter):
        _e_z_c(z, var, inv_var, log_norm, log_clutter, app, has_app, post,
               marginal_init and it == 0, log_prior, resp)
        if exclusive and n1 >= 2 and not _exclusive_c(resp):
            unconverged += 1
        _e_s_c(z, inv_var, resp, pred, post, it == last)
        _m_step_c(resp, mass, log_prior, update_priors and it < last)
    return unconverged


def _predict(pred: np.ndarray, lam: np.ndarray, dt: float) -> None:
    """:func:`~avtrack.vem.updates.predict_cv` of ``pred (5, N, k)`` in place, with the
    diagonal ``lam (2, N, k)`` (thesis eq. 2.21; the same operations in the same order)."""
    for j in range(pred.shape[1]):
        for c in range(pred.shape[2]):
            mu_p, mu_v = pred[0, j, c], pred[1, j, c]
            var_p, var_v, cov = pred[2, j, c], pred[3, j, c], pred[4, j, c]
            if dt == 1.0:
                pred[0, j, c] = mu_p + mu_v
                pred[2, j, c] = var_p + 2.0 * cov + var_v + lam[0, j, c]
                pred[4, j, c] = cov + var_v
            else:
                pred[0, j, c] = mu_p + dt * mu_v
                pred[2, j, c] = var_p + (2 * dt) * cov + (dt * dt) * var_v + lam[0, j, c]
                pred[4, j, c] = cov + dt * var_v
            pred[3, j, c] = var_v + lam[1, j, c]


def _e_z(
    z: np.ndarray, var: np.ndarray, inv_var: np.ndarray, log_norm: np.ndarray,
    log_clutter: float, app: np.ndarray, has_app: bool, post: np.ndarray, marginal: bool,
    log_prior: np.ndarray, resp: np.ndarray,
) -> None:
    """The E-Z step, eq. 2.25 (eq. 2.8 with ``marginal``), into ``resp (M, N + 1)``:
    ``BoxObservationModel._log_tau_diagonal`` and ``e_z_normalise``."""
    m, k = z.shape
    n1 = resp.shape[1]
    for i in range(m):
        resp[i, 0] = log_clutter
        for j in range(n1 - 1):
            acc = 0.0
            if marginal:  # N(o; Pμ, PΓPᵀ + Φ), diagonal
                for c in range(k):
                    r = z[i, c] - post[0, j, c]
                    s = var[i, c] + post[2, j, c]
                    acc += (r * r / s + math.log(s)) * -0.5
                val = acc - 0.5 * k * _LOG_2PI
            else:  # N(o; Pμ, Φ) exp(-½ tr(Pᵀ Φ⁻¹ P Γ))
                for c in range(k):
                    r = z[i, c] - post[0, j, c]
                    acc += (r * r + post[2, j, c]) * inv_var[i, c] * -0.5
                val = acc + log_norm[i]
            if has_app:
                val += app[i, j]
            resp[i, j + 1] = val
        top = -np.inf  # α_tmn = τη / Σ_i τ_tmi η_mi
        for j in range(n1):
            resp[i, j] += log_prior[j]
            top = max(top, resp[i, j])
        tot = 0.0
        for j in range(n1):
            resp[i, j] = math.exp(resp[i, j] - top)
            tot += resp[i, j]
        for j in range(n1):
            resp[i, j] /= tot


def _exclusive(resp: np.ndarray) -> bool:
    """``exclusive_projection`` of ``resp (M, N + 1)`` in place; False when the projection
    did not meet its KKT conditions."""
    worst = 0.0
    for j in range(1, resp.shape[1]):
        s = 0.0
        for i in range(resp.shape[0]):
            s += resp[i, j]
        worst = max(worst, s)
    if worst <= 1.0 + FEASIBILITY_TOL:
        return True
    alpha = resp.copy()
    for i in range(resp.shape[0]):
        alpha[i, 0] = max(alpha[i, 0], CLUTTER_FLOOR)
    return _kl_projection_c(alpha, resp)


def _e_s(z: np.ndarray, inv_var: np.ndarray, resp: np.ndarray, pred: np.ndarray,
         post: np.ndarray, full: bool) -> None:
    """The E-S step, eqs. 2.23-2.24 (``information_diagonal``, ``e_s_step_cv``), into
    ``post``; without ``full`` only μ_p and Γ_pp (all that an E-Z step reads)."""
    m, k = z.shape
    n = pred.shape[1]
    terms = np.zeros((n, 2 * k))  # Σ_m α_mn Φ_m⁻¹, Σ_m α_mn Φ_m⁻¹ o_m (eq. 4.26)
    for i in range(m):
        for j in range(n):
            a = resp[i, j + 1]
            for c in range(k):
                terms[j, c] += a * inv_var[i, c]
                terms[j, k + c] += a * (z[i, c] * inv_var[i, c])
    for j in range(n):
        for c in range(k):
            jd = terms[j, c]
            h = terms[j, k + c]
            a = pred[2, j, c]
            f = 1.0 / (1.0 + jd * a)
            post[0, j, c] = f * (pred[0, j, c] + a * h)
            post[2, j, c] = f * a
            if full:
                cv = f * pred[4, j, c]
                post[1, j, c] = pred[1, j, c] + cv * (h - jd * pred[0, j, c])
                post[3, j, c] = pred[3, j, c] - jd * pred[4, j, c] * cv
                post[4, j, c] = cv


def _m_step(resp: np.ndarray, mass: np.ndarray, log_prior: np.ndarray, update: bool) -> None:
    """The assigned mass ``(N + 1,)`` and, with ``update``, the priors' M step (eq. 3.29:
    ``m_step_priors``) into ``log_prior``."""
    n1 = resp.shape[1]
    for j in range(n1):
        s = 0.0
        for i in range(resp.shape[0]):
            s += resp[i, j]
        mass[j] = s
    if not update:
        return
    total = 0.0
    for j in range(n1):
        total += mass[j]
    if total <= 0:
        log_prior[:] = -math.log(n1)
        return
    asum = 0.0
    for j in range(n1):
        log_prior[j] = max(mass[j] / total, PRIOR_FLOOR)
        asum += log_prior[j]
    for j in range(n1):
        log_prior[j] = math.log(log_prior[j] / asum)


def _kl_projection(alpha: np.ndarray, q: np.ndarray) -> bool:
    """:func:`avtrack.vem.updates._kl_projection` into ``q (M, N + 1)``; False when the KKT
    conditions were not met within its iterations (``q`` then holds the last iterate)."""
    m, n1 = alpha.shape
    nu = np.zeros(n1)
    w = alpha.copy()
    z = np.empty(m)
    s = np.empty(n1)
    nu_max = -1.0  # not yet bounded
    last_size = np.inf
    for _ in range(_MAX_ITER):
        for i in range(m):
            t = 0.0
            for j in range(n1):
                t += w[i, j]
            z[i] = t
        s[:] = 0.0
        for i in range(m):
            for j in range(n1):
                q[i, j] = w[i, j] / z[i]
                s[j] += q[i, j]
        s[0] = 0.0
        n_work = 0
        for j in range(n1):
            if nu[j] > 0.0 or s[j] > 1.0:
                n_work += 1
        work = np.empty(n_work, dtype=np.int64)
        n_work = 0
        for j in range(n1):
            if nu[j] > 0.0 or s[j] > 1.0:
                work[n_work] = j
                n_work += 1
        if work.size == 0:
            return True
        slack = 1.0 - s[work]
        lowest = np.inf
        widest = -np.inf
        for i in range(work.size):
            lowest = min(lowest, slack[i])
            widest = max(widest, slack[i] * max(nu[work[i]], 1.0))
        if lowest >= -FEASIBILITY_TOL and widest <= KKT_TOL:
            return True
        newton = False
        size = 0.0
        if work.size > 1:
            if nu_max < 0.0:
                ratio = 0.0
                for i in range(m):
                    top = 0.0
                    for j in range(1, n1):
                        top = max(top, alpha[i, j])
                    ratio = max(ratio, top / alpha[i, 0])
                nu_max = math.log(m * ratio) + 1.0
            for i in range(work.size):
                size = max(size, abs(slack[i]))
            newton = size < 0.25 * last_size
            for i in range(work.size):
                newton = newton and nu[work[i]] > 0.0
        last_size = np.inf
        if newton and _newton_step_c(alpha, w, z, q, slack, nu, work, nu_max):
            last_size = size
        else:
            for jj in range(work.size):  # exact minimisation over each working column
                j = work[jj]
                rest = np.empty(m)
                for i in range(m):
                    t = 0.0
                    for c in range(n1):
                        if c != j:
                            t += w[i, c]
                    rest[i] = t
                nu[j] = _solve_column_c(w[:, j].copy(), rest, nu[j])
                e = math.exp(-nu[j])
                for i in range(m):
                    w[i, j] = alpha[i, j] * e
    for i in range(m):
        t = 0.0
        for j in range(n1):
            t += w[i, j]
        for j in range(n1):
            q[i, j] = w[i, j] / t
    return False


def _newton_step(
    alpha: np.ndarray, w: np.ndarray, z: np.ndarray, q: np.ndarray, grad: np.ndarray,
    nu: np.ndarray, work: np.ndarray, nu_max: float,
) -> bool:
    """:func:`avtrack.vem.updates._newton_step`."""
    m = q.shape[0]
    k = work.size
    q_w = np.empty((m, k))
    rest = np.empty((m, k))
    for i in range(m):
        for a in range(k):
            q_w[i, a] = q[i, work[a]]
            t = 0.0
            for c in range(w.shape[1]):
                if c != work[a]:
                    t += w[i, c]
            rest[i, a] = t / z[i]
    hess = np.empty((k, k))
    for a in range(k):
        for b in range(k):
            t = 0.0
            for i in range(m):
                t += q_w[i, a] * q_w[i, b]
            hess[a, b] = -t
        t = 0.0
        for i in range(m):
            t += q_w[i, a] * rest[i, a]
        hess[a, a] = t
    try:
        d = np.linalg.solve(hess, -grad)
    except Exception:  # singular
        return False
    nu_w = np.empty(k)
    for a in range(k):
        nu_w[a] = nu[work[a]]
    delta = np.empty(k)
    tau = 1.0
    for _ in range(30):
        slope = 0.0
        for a in range(k):
            step = tau * d[a]
            dl = math.log1p(abs(step))
            dl = dl if step >= 0.0 else -dl
            delta[a] = min(max(nu_w[a] + dl, 0.0), nu_max) - nu_w[a]
            slope += grad[a] * delta[a]
        if not slope < 0.0:
            return False
        change = 0.0
        for i in range(m):
            t = 0.0
            for a in range(k):
                t += q_w[i, a] * math.expm1(-delta[a])
            change += math.log1p(t)
        for a in range(k):
            change += delta[a]
        if change <= 1e-4 * slope:
            for a in range(k):
                nu_w[a] += delta[a]
                nu[work[a]] = nu_w[a]
                e = math.exp(-nu_w[a])
                for i in range(m):
                    w[i, work[a]] = alpha[i, work[a]] * e
            return True
        tau *= 0.5
    return False


# the functions call each other by these names; compiled, _compile rebinds them
_solve_column_c = _solve_column
_newton_step_c = _newton_step
_kl_projection_c = _kl_projection
_predict_c = _predict
_e_z_c = _e_z
_exclusive_c = _exclusive
_e_s_c = _e_s
_m_step_c = _m_step
