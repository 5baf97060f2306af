"""Compiled per-bin kernel of the DP-RTF estimator's Cholesky solver (thesis eqs. 5.9, 5.11).

Why by hand: each STFT frame updates, for every speech bin, an ``IQ x IQ`` Hermitian matrix
``R_t = lambda^g R_{t-1} + U_t`` and needs two columns of ``R_t^{-1}`` restricted to the first
CTF coefficients. With NumPy this is a dozen passes over ``(F_s, IQ, IQ)`` complex arrays per
frame (gather, scale, outer product, scatter, the copies LAPACK's batched ``zpotrf`` makes)
plus ``zpotrf`` itself, which is slow for 32 x 32 matrices; on a 2-core machine that NumPy form
takes 75 % of the localizer's time. No maintained library fuses a per-bin covariance update
with a small Cholesky factorisation, so this module does it with Numba: each bin's matrix is
updated in place (lower triangle only, which is all the factorisation reads) and factorised
while it is in the CPU cache, then the bin's features and their consistency test (eq. 5.11)
are computed there too (a frame's speech bins in one call, not a dozen NumPy calls per frame).
:class:`avtrack.audio.dprtf.DPRTFEstimator` uses it when Numba is
installed (a dependency) and falls back to the NumPy form otherwise or with
``AVTRACK_NO_JIT=1``; the tests check that both agree. Called uncompiled (plain Python), it
gives the same numbers, slowly.

Arithmetic (same as ``DPRTFEstimator._update_cholesky``): with ``v[q, k]`` the PSD vector of
channel ``k`` at lag position ``q`` (unknown index ``q I + k``), ``S[q, p] = sum_j conj(v[q, j])
v[p, j]`` and

    U[(q, k), (p, l)] = delta_kl S[q, p] - conj(v[q, l]) v[p, k]          (pairs' sum, eq. 5.3)

``R <- age R + U`` (``R = 0`` first at a bin's first speech frame), then ``delta``-loading of
the diagonal, ``R = L L^H`` and, for the last ``I`` unknowns ``A`` (the lag-0 coefficients),
``(R^{-1})_{AA} = L_AA^{-H} L_AA^{-1}``: column ``ref`` is two ``I x I`` triangular solves.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from avtrack._jit import available, build_once

__all__ = ["SIGNATURE", "available", "frame_features", "kernel"]

#: the compiled kernel, built on first use (importing Numba costs ~0.5 s, so not at import)
_KERNEL: Callable[..., bool] | None = None


#: the kernel's one signature: C-contiguous arrays as ``DPRTFEstimator`` passes them
SIGNATURE = (
    "b1(c16[:, :, ::1], i8[::1], i8[::1], c16[:, :, ::1], b1[::1], f8[::1], i8[::1], i8, f8, "
    "b1, f8, f8, f8, f8, f8, b1, c16[:, ::1], b1[:, ::1])"
)
_FAILED = False  # the kernel could not be built here (then the NumPy form is used)


def kernel() -> Callable[..., bool] | None:
    """The compiled :func:`frame_features`, or None if Numba cannot build it on this machine
    (warned once; the estimator then uses its NumPy form). Built once per process for
    :data:`SIGNATURE`."""
    return build_once(globals(), lambda njit, cache: _compile(njit, _FASTMATH, cache),
                      "DP-RTF kernel")


#: reassociation lets the dot products vectorise; no "fast" flags that assume finite values,
#: since a non-positive pivot must still be detected
_FASTMATH = {"reassoc", "contract", "arcp", "nsz"}


def _compile(njit: Callable[..., Any], fastmath: set[str], cache: bool) -> Callable[..., bool]:
    """:func:`frame_features` compiled for :data:`SIGNATURE`, its per-bin steps first (each
    for its own signature, and bound in this module's namespace, where the compiled
    :func:`frame_features` looks them up). NumPy's error model: a real division by zero gives
    an infinite or NaN value, as in the NumPy form, not an exception."""
    for name, signature in _STEP_SIGNATURES.items():
        # inlined where called (Numba IR): the same machine code as one function
        globals()[name] = njit(signature, cache=cache, nogil=True, fastmath=fastmath,
                               inline="always", error_model="numpy")(_PY_STEPS[name])
    return njit(SIGNATURE, cache=cache, nogil=True, fastmath=fastmath,
                error_model="numpy")(frame_features)


def frame_features(
    phi_hat: np.ndarray,
    s: np.ndarray,
    lag_order: np.ndarray,
    r: np.ndarray,
    started: np.ndarray,
    memory: np.ndarray,
    last: np.ndarray,
    t: int,
    lam: float,
    forget_over_noise: bool,
    min_memory: float,
    regularization: float,
    loading: float,
    threshold: float,
    faded: float,
    phase_only: bool,
    values: np.ndarray,
    valid: np.ndarray,
) -> bool:
    """One frame of the estimator for its speech bins: each bin's memory weight, ``R`` updated
    in place, and for the bins with enough memory the two reference solutions and the
    features (the NumPy form: ``DPRTFEstimator._age``, ``_update_cholesky`` and
    :func:`~avtrack.audio.dprtf.dprtf_features`).

    Parameters
    ----------
    phi_hat : ndarray (F, I, Q), complex128
        The frame's noise-free PSDs ``phi-hat^i_{t-q, f}`` at ``[f, i, q]``.
    s : ndarray (F_s,), int64
        Speech bins.
    lag_order : ndarray (Q,), int64
        Lags in the unknowns' order (lag 0 last).
    r : ndarray (F, n, n), complex128
        The estimator's matrices; only the lower triangles are read and written.
    started, memory, last : ndarray (F,)
        The estimator's per-bin state (bool, float64, int64), updated in place.
    t : int
        Index of this frame.
    lam, forget_over_noise, min_memory, faded
        ``lambda``, whether memory fades over non-speech frames (``lambda^g``), the memory a
        bin needs to give features, and the weight below which a bin starts afresh.
    regularization, loading : float
        ``delta`` relative to ``trace(U)`` at a first frame, and the relative ridge.
    threshold, phase_only
        The consistency test (eq. 5.11) and the features' normalisation.
    values : ndarray (I - 1, F), complex128
    valid : ndarray (I - 1, F), bool
        Written at the bins with enough memory (left as given elsewhere).

    Returns
    -------
    ok : bool
        False if a matrix was not numerically positive definite (the caller then raises).
    """
    n_s = s.size
    i_ = phi_hat.shape[1]
    q_ = lag_order.size
    n = q_ * i_
    u = np.empty(n, dtype=np.complex128)
    smat = np.empty((q_, q_), dtype=np.complex128)
    # the factor L = lr + i li, split so that the dot products below vectorise
    lr = np.zeros((n, n))
    li = np.zeros((n, n))
    y = np.empty(i_, dtype=np.complex128)
    vb = np.empty((q_, i_), dtype=np.complex128)
    z = np.empty((i_, 2), dtype=np.complex128)
    ok = True
    for b in range(n_s):
        f = s[b]
        # the memory's weight lambda^g, g frames since the bin's latest speech frame
        age = lam ** float(t - last[f]) if forget_over_noise else lam
        if lam > 0.0 and forget_over_noise and started[f] and age < faded:
            started[f] = False  # faded: the bin starts afresh
        new = not started[f]
        memory[f] = 1.0 if new else age * memory[f] + 1.0
        last[f] = t
        for q in range(q_):  # PSD vectors, lags in the unknowns' order
            for k in range(i_):
                vb[q, k] = phi_hat[f, k, lag_order[q]]
        rf = r[f]
        _update_bin(rf, vb, u, smat, age, new, regularization, loading)
        started[f] = True
        if memory[f] >= min_memory * (1.0 - 1e-9):  # enough equations
            ok = _cholesky(rf, lr, li) and ok
            _solve_refs(lr, li, y, z)
            _bin_features(z, threshold, phase_only, values, valid, f)
    return ok


def _bin_features(
    z: np.ndarray, threshold: float, phase_only: bool, values: np.ndarray, valid: np.ndarray,
    f: int,
) -> None:
    """:func:`~avtrack.audio.dprtf.dprtf_features` of one bin from ``z (I, 2)``, the two
    reference columns of ``(R^{-1})_{AA}``, into column ``f`` of ``values`` and ``valid``.
    A zero reference entry gives no feature (the NumPy form's infinite or NaN ratios fail the
    test; Numba raises on a complex division by zero whatever its error model)."""
    if z[0, 0] == 0 or z[0, 1] == 0:
        for i in range(1, z.shape[0]):
            values[i - 1, f] = 0j
            valid[i - 1, f] = False
        return
    for i in range(1, z.shape[0]):
        c1 = z[i, 0] / z[0, 0]  # c~^i = a^i_0 / a^1_0 (reference 1)
        c2 = z[i, 1] / z[0, 1]  # c̄^i / c̄^1 (reference 2)
        a1 = abs(c1)
        a2 = abs(c2)
        d = abs(1.0 + c1.conjugate() * c2) / np.sqrt((1.0 + a1 * a1) * (1.0 + a2 * a2))
        c = 0.5 * (c1 + c2)
        ac = abs(c)
        feat = c / (ac * np.sqrt(2.0)) if phase_only else c / np.sqrt(1.0 + ac * ac)
        good = (d >= threshold and np.isfinite(d) and np.isfinite(feat.real)
                and np.isfinite(feat.imag))
        values[i - 1, f] = feat if good else 0j
        valid[i - 1, f] = good


def _update_bin(
    rf: np.ndarray, vb: np.ndarray, u: np.ndarray, smat: np.ndarray, a: float, new: bool,
    regularization: float, loading: float,
) -> None:
    """``R <- a R + U`` and the ridge on the lower triangle of one bin's ``rf (n, n)`` from its
    PSD vectors ``vb (Q, I)`` (``R = 0`` first when ``new``); ``u (n,)`` and ``smat (Q, Q)``
    are work arrays."""
    q_, i_ = vb.shape
    n = q_ * i_
    for q in range(q_):
        for k in range(i_):
            u[q * i_ + k] = vb[q, k]
    trace_s = 0.0
    for q in range(q_):
        for p in range(q_):
            acc = 0j
            for j in range(i_):
                acc += np.conj(vb[q, j]) * vb[p, j]
            smat[q, p] = acc
        trace_s += smat[q, q].real
    trace_u = (i_ - 1) * trace_s
    ridge = loading * trace_u / n
    if new:
        ridge += regularization * trace_u
        for row in range(n):
            for col in range(row + 1):
                rf[row, col] = 0j
    ridge = max(ridge, np.finfo(np.float64).tiny)
    # row (q, k), column (p, l), p I + l <= q I + k
    for q in range(q_):
        for k in range(i_):
            row = q * i_ + k
            uk = u[k::i_]  # v[:, k]
            for p in range(q + 1):
                l_end = i_ if p < q else k + 1
                for l_ in range(l_end):
                    col = p * i_ + l_
                    val = a * rf[row, col] - np.conj(u[q * i_ + l_]) * uk[p]
                    if l_ == k:
                        val += smat[q, p]
                    rf[row, col] = val
            rf[row, row] += ridge


def _cholesky(rf: np.ndarray, lr: np.ndarray, li: np.ndarray) -> bool:
    """``R = L L^H`` of the lower triangle of ``rf (n, n)`` into ``L = lr + i li``, left-looking:
    entry ``(i, j)`` needs the dot product of rows ``i`` and ``j`` of ``L`` over the columns
    ``< j`` (contiguous). Four rows ``i`` at a time share each load of row ``j`` (register
    blocking: 1.5 x faster for ``n = 64`` than one row at a time; the same sums, in the same
    order). False if a pivot was not positive (then ``tiny`` stands for it)."""
    n = rf.shape[0]
    tiny = np.finfo(np.float64).tiny
    ok = True
    for j in range(n):
        d = rf[j, j].real
        for m in range(j):
            d -= lr[j, m] * lr[j, m] + li[j, m] * li[j, m]
        if not d > 0.0:
            ok = False
            d = tiny
        dj = np.sqrt(d)
        lr[j, j] = dj
        li[j, j] = 0.0
        inv = 1.0 / dj
        i = j + 1
        while i + 3 < n:
            re0 = rf[i, j].real
            im0 = rf[i, j].imag
            re1 = rf[i + 1, j].real
            im1 = rf[i + 1, j].imag
            re2 = rf[i + 2, j].real
            im2 = rf[i + 2, j].imag
            re3 = rf[i + 3, j].real
            im3 = rf[i + 3, j].imag
            for m in range(j):
                a = lr[j, m]
                b = li[j, m]
                re0 -= lr[i, m] * a + li[i, m] * b
                im0 -= li[i, m] * a - lr[i, m] * b
                re1 -= lr[i + 1, m] * a + li[i + 1, m] * b
                im1 -= li[i + 1, m] * a - lr[i + 1, m] * b
                re2 -= lr[i + 2, m] * a + li[i + 2, m] * b
                im2 -= li[i + 2, m] * a - lr[i + 2, m] * b
                re3 -= lr[i + 3, m] * a + li[i + 3, m] * b
                im3 -= li[i + 3, m] * a - lr[i + 3, m] * b
            lr[i, j] = re0 * inv
            li[i, j] = im0 * inv
            lr[i + 1, j] = re1 * inv
            li[i + 1, j] = im1 * inv
            lr[i + 2, j] = re2 * inv
            li[i + 2, j] = im2 * inv
            lr[i + 3, j] = re3 * inv
            li[i + 3, j] = im3 * inv
            i += 4
        while i < n:
            re = rf[i, j].real
            im = rf[i, j].imag
            for m in range(j):
                re -= lr[i, m] * lr[j, m] + li[i, m] * li[j, m]
                im -= li[i, m] * lr[j, m] - lr[i, m] * li[j, m]
            lr[i, j] = re * inv
            li[i, j] = im * inv
            i += 1
    return ok


def _solve_refs(lr: np.ndarray, li: np.ndarray, y: np.ndarray, out_b: np.ndarray) -> None:
    """``(R^{-1})_{AA} e_ref = L_AA^{-H} L_AA^{-1} e_ref`` for refs 0 and 1 into ``out_b (I,
    2)``, ``A`` the last ``I`` unknowns; ``y (I,)`` is a work array."""
    i_ = y.shape[0]
    base = lr.shape[0] - i_
    for ref in range(2):
        for i in range(i_):  # forward: L_AA y = e_ref
            acc = 1.0 + 0j if i == ref else 0j
            for m in range(i):
                acc -= (lr[base + i, base + m] + 1j * li[base + i, base + m]) * y[m]
            y[i] = acc / lr[base + i, base + i]
        for i in range(i_ - 1, -1, -1):  # backward: L_AA^H z = y
            acc = y[i]
            for m in range(i + 1, i_):
                acc -= (lr[base + m, base + i] - 1j * li[base + m, base + i]) * out_b[m, ref]
            out_b[i, ref] = acc / lr[base + i, base + i]


#: the per-bin steps as Python functions (:func:`_compile` binds compiled ones in their place)
_PY_STEPS: dict[str, Callable[..., Any]] = {
    "_update_bin": _update_bin, "_cholesky": _cholesky, "_solve_refs": _solve_refs,
    "_bin_features": _bin_features}
#: their signatures, as :func:`frame_features` passes them
_STEP_SIGNATURES = {
    "_update_bin": "void(c16[:, ::1], c16[:, ::1], c16[::1], c16[:, ::1], f8, b1, f8, f8)",
    "_cholesky": "b1(c16[:, ::1], f8[:, ::1], f8[:, ::1])",
    "_solve_refs": "void(f8[:, ::1], f8[:, ::1], c16[::1], c16[:, ::1])",
    "_bin_features": "void(c16[:, ::1], f8, b1, c16[:, ::1], b1[:, ::1], i8)",
}
