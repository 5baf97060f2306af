"""Compiled CGMM densities of the localizers (thesis eq. 5.12), in single precision.

Why by hand: each frame needs ``N_c(ĉ_k; c_{k,d}, sigma^2)`` (up to a factor per feature) for
its ``K`` features over the ``D`` candidate directions (``K x D`` up to ~1000 x 400), each
feature with its own row of coefficients (:func:`~avtrack.localize.cgmm_eg.density_coefficients`).
With NumPy that is a gather of the rows, three passes, a row maximum and a pass of ``exp``; here
each row is done while it is in the CPU cache. The exponential is Cephes' single-precision
``expf`` (range reduction by ``ln 2``, a degree-7 polynomial, the power of two written into the
exponent bits), written out so that LLVM vectorises it: Numba's ``exp`` is a scalar call
(LLVM has no vector ``exp`` without Intel's SVML). Its relative error is about 4e-7 (tested
against ``numpy.exp``). Single precision: the densities feed only the mean likelihood ratios of
eqs. 5.17-5.19, where a relative error of ~1e-5 moves no peak (the localizer tests compare with
the double-precision form).

:class:`~avtrack.localize.cgmm_eg.CGMMLocalizer` uses it when Numba is available (the
condition of :func:`avtrack._jit.available`) and NumPy's form otherwise.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from avtrack._jit import available, build_once

__all__ = ["available", "densities", "densities_numpy", "kernel"]

#: the compiled :func:`densities`, built on first use
_KERNEL: Callable[..., None] | None = None
_FAILED = False
SIGNATURE = "void(f8[::1], f8[::1], i8[::1], f4[:, :, ::1], f4[:, ::1], i4[::1])"

_LOG2E = np.float32(1.44269504088896341)
_LN2_HI = np.float32(0.693359375)  # ln 2 in two parts (Cody and Waite): hi * n is exact
_LN2_LO = np.float32(-2.12194440e-4)
_LOWEST = np.float32(-87.0)  # e^-87 ~ 1.6e-38, the smallest normal float32 is 1.2e-38


def kernel() -> Callable[..., None] | None:
    """The compiled :func:`densities`, or None if Numba cannot build it here (warned once)."""
    return build_once(globals(), _compile, "CGMM densities")


def _compile(njit: Callable[..., Any], cache: bool) -> Callable[..., None]:
    fast = {"reassoc", "contract", "arcp", "nsz"}
    return njit(SIGNATURE, cache=cache, nogil=True, fastmath=fast)(densities)


def densities(
    re: np.ndarray, im: np.ndarray, rows: np.ndarray, coef: np.ndarray, out: np.ndarray,
    bits: np.ndarray,
) -> None:
    """``out[k, d] = exp(l_kd - max_d' l_kd')`` with ``l_kd = [Re ĉ_k, Im ĉ_k, 1] .
    coef[rows[k], :, d]``: :func:`~avtrack.localize.cgmm_eg.densities_from_coefficients`.

    Parameters
    ----------
    re, im : ndarray (K,), float64
        The features' real and imaginary parts.
    rows : ndarray (K,), int64
        Each feature's row of ``coef``.
    coef : ndarray (R, 3, D), float32
        :func:`~avtrack.localize.cgmm_eg.density_coefficients`, one row per (pair, bin).
    out : ndarray (K, D), float32
        Written: densities in (0, 1], 1 at each row's maximum (entries below ``e^-87`` are
        about ``1e-38``, not 0).
    bits : ndarray (D,), int32
        Work array (the powers of two of one row).
    """
    d_ = coef.shape[2]
    scale = bits.view(np.float32)
    for k in range(rows.size):
        r = rows[k]
        a = np.float32(re[k])
        b = np.float32(im[k])
        top = np.float32(-np.inf)
        for d in range(d_):
            val = a * coef[r, 0, d] + b * coef[r, 1, d] + coef[r, 2, d]
            out[k, d] = val
            top = max(top, val)
        for d in range(d_):  # e^x = 2^n e^g, x = n ln 2 + g, |g| <= ln 2 / 2 (Cephes expf)
            x = max(out[k, d] - top, _LOWEST)
            n = np.floor(x * _LOG2E + np.float32(0.5))
            g = x - n * _LN2_HI - n * _LN2_LO
            p = np.float32(1.9875691500e-4)
            p = p * g + np.float32(1.3981999507e-3)
            p = p * g + np.float32(8.3334519073e-3)
            p = p * g + np.float32(4.1665795894e-2)
            p = p * g + np.float32(1.6666665459e-1)
            p = p * g + np.float32(5.0000001201e-1)
            out[k, d] = p * g * g + g + np.float32(1.0)
            bits[d] = (np.int32(n) + np.int32(127)) << np.int32(23)  # the float32 2^n
        for d in range(d_):
            out[k, d] *= scale[d]


def densities_numpy(
    re: np.ndarray, im: np.ndarray, rows: np.ndarray, coef: np.ndarray, out: np.ndarray,
    bits: np.ndarray | None = None,
) -> None:
    """:func:`densities` with NumPy (same arguments; ``bits`` is not used)."""
    c = coef[rows]  # (K, 3, D)
    np.multiply(re.astype(np.float32)[:, None], c[:, 0], out=out)
    out += im.astype(np.float32)[:, None] * c[:, 1]
    out += c[:, 2]
    out -= out.max(axis=1, keepdims=True)
    np.exp(out, out=out)
