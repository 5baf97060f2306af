"""Compiled log-densities of the CGMM localizers (thesis eq. 5.12), in single precision.

Why by hand: each frame needs ``log N_c(ĉ_k; c_{k,d}, sigma^2)`` for its ``K`` features over the
``D`` candidate directions (``K x D`` up to ~1000 x 400), each feature with its own row of
coefficients (:func:`~avtrack.localize.cgmm_eg.density_coefficients`). With NumPy that is a
gather of the rows, three passes and a row maximum; here it is one pass per row while the row
is in the CPU cache. The exponential is left to NumPy, whose single-precision ``exp`` is
vectorised (LLVM has no vector ``exp`` without Intel's SVML). Single precision: the densities
feed only the mean likelihood ratios of eqs. 5.17-5.19, where a relative error of ~1e-5 moves no
peak (the localizer tests compare with the double-precision form).

:class:`~avtrack.localize.cgmm_eg.CGMMLocalizer` uses it when Numba is available (the
condition of :func:`avtrack._jit.available`) and NumPy's form otherwise.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from avtrack._jit import available, build_once

__all__ = ["available", "kernel", "log_densities", "log_densities_numpy"]

#: the compiled :func:`log_densities`, built on first use
_KERNEL: Callable[..., None] | None = None
_FAILED = False
SIGNATURE = "void(f8[::1], f8[::1], i8[::1], f4[:, :, ::1], f4[:, ::1])"


def kernel() -> Callable[..., None] | None:
    """The compiled :func:`log_densities`, or None if Numba cannot build it here (warned once)."""
    return build_once(globals(), _compile, "CGMM densities")


def _compile(njit: Callable[..., Any], cache: bool) -> Callable[..., None]:
    fast = {"reassoc", "contract", "arcp", "nsz"}
    return njit(SIGNATURE, cache=cache, nogil=True, fastmath=fast)(log_densities)


def log_densities(
    re: np.ndarray, im: np.ndarray, rows: np.ndarray, coef: np.ndarray, out: np.ndarray
) -> None:
    """``out[k, d] = [Re ĉ_k, Im ĉ_k, 1] . coef[rows[k], :, d]`` minus the row's maximum.

    Parameters
    ----------
    re, im : ndarray (K,), float64
        The features' real and imaginary parts.
    rows : ndarray (K,), int64
        Each feature's row of ``coef``.
    coef : ndarray (R, 3, D), float32
        :func:`~avtrack.localize.cgmm_eg.density_coefficients`, one row per (pair, bin).
    out : ndarray (K, D), float32
        Written: log-densities up to a constant per feature, 0 at each row's maximum.
    """
    d_ = coef.shape[2]
    for k in range(rows.size):
        r = rows[k]
        a = np.float32(re[k])
        b = np.float32(im[k])
        top = np.float32(-np.inf)
        for d in range(d_):
            val = a * coef[r, 0, d] + b * coef[r, 1, d] + coef[r, 2, d]
            out[k, d] = val
            top = max(top, val)
        for d in range(d_):
            out[k, d] -= top


def log_densities_numpy(
    re: np.ndarray, im: np.ndarray, rows: np.ndarray, coef: np.ndarray, out: np.ndarray
) -> None:
    """:func:`log_densities` with NumPy (same arguments)."""
    c = coef[rows]  # (K, 3, D)
    np.multiply(re.astype(np.float32)[:, None], c[:, 0], out=out)
    out += im.astype(np.float32)[:, None] * c[:, 1]
    out += c[:, 2]
    out -= out.max(axis=1, keepdims=True)
