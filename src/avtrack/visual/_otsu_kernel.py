"""Compiled Otsu split of sorted scores (:func:`avtrack.visual.scores.otsu_threshold_sorted`).

Why by hand: the visual tracker asks for the split of the scores seen so far every time their
number has grown by 5 %, a few dozen times a sequence, and each NumPy form costs some twenty
calls on arrays of 64 bins: a tenth of a tracking frame. Here it is one compiled call. It is
written to give NumPy's numbers exactly: the same operations in the same order, and NumPy's
pairwise summation for the sums NumPy computes with ``np.add.reduce`` (tested bit for bit).

:func:`~avtrack.visual.scores.otsu_threshold_sorted` uses it when Numba is available (the
condition of :func:`avtrack._jit.available`) and its NumPy form otherwise.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from avtrack._jit import build_once

__all__ = ["kernel", "otsu_sorted", "pairwise_sum"]

_KERNEL: Callable[..., float] | None = None
_FAILED = False

#: NumPy's block of its pairwise summation (``PW_BLOCKSIZE``)
_BLOCK = 128


def kernel() -> Callable[..., float] | None:
    """The compiled :func:`otsu_sorted` (NaN: no split), or None where Numba cannot build it
    (warned once)."""
    return build_once(globals(), _compile, "Otsu split")


def _compile(njit: Callable[..., Any], cache: bool) -> Callable[..., float]:
    g = globals()
    # compiled in place, callees first: the functions call each other (and ``_pairwise``
    # itself) by these names, which then resolve to the compiled ones
    for name, sig in (("_pairwise", "f8(f8[::1], i8, i8)"), ("pairwise_sum", "f8(f8[::1])"),
                      ("_mean_var", "UniTuple(f8, 2)(f8[::1])")):
        g[name] = njit(sig, cache=cache, nogil=True)(g[name])
    return njit("f8(f8[::1], i8, f8)", cache=cache, nogil=True)(otsu_sorted)


def _pairwise(a: np.ndarray, start: int, n: int) -> float:
    """NumPy's pairwise sum of ``a[start:start + n]`` (``@TYPE@_pairwise_sum``)."""
    if n < 8:
        res = 0.0
        for i in range(n):
            res += a[start + i]
        return res
    if n <= _BLOCK:
        r0, r1, r2, r3 = a[start], a[start + 1], a[start + 2], a[start + 3]
        r4, r5, r6, r7 = a[start + 4], a[start + 5], a[start + 6], a[start + 7]
        i = 8
        while i < n - (n % 8):
            r0 += a[start + i]
            r1 += a[start + i + 1]
            r2 += a[start + i + 2]
            r3 += a[start + i + 3]
            r4 += a[start + i + 4]
            r5 += a[start + i + 5]
            r6 += a[start + i + 6]
            r7 += a[start + i + 7]
            i += 8
        res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
        while i < n:
            res += a[start + i]
            i += 1
        return res
    n2 = n // 2
    n2 -= n2 % 8
    return _pairwise(a, start, n2) + _pairwise(a, start + n2, n - n2)


def pairwise_sum(a: np.ndarray) -> float:
    """``np.add.reduce(a)`` of a contiguous 1-D float64 array, to the bit (NumPy's pairwise
    sum of the whole array, from 0)."""
    return _pairwise(a, 0, a.size)


def otsu_sorted(x: np.ndarray, bins: int, min_separation: float) -> float:
    """:func:`avtrack.visual.scores.otsu_threshold_sorted` of sorted finite scores ``x``;
    NaN where that gives None."""
    n_x = x.size
    if n_x < 2:
        return np.nan
    lo, hi = x[0], x[-1]
    if not hi - lo > 1e-9 * max(1.0, abs(hi)):
        return np.nan
    edges = np.empty(bins + 1)
    width = (hi - lo) / bins
    for k in range(bins + 1):
        edges[k] = float(k) * width + lo
    edges[bins] = hi
    below = np.searchsorted(x, edges[1:bins])  # scores below each inner edge
    sums = np.empty(bins)
    prev = 0
    for k in range(bins):
        nxt = below[k] if k < bins - 1 else n_x
        sums[k] = float(nxt - prev) * (0.5 * (edges[k] + edges[k + 1]))
        prev = nxt
    total = pairwise_sum(sums)
    best = -np.inf
    k_best = 0
    s0 = 0.0
    for k in range(bins - 1):
        s0 += sums[k]
        w0 = float(below[k])
        w1 = n_x - w0
        if w0 > 0 and w1 > 0:
            d = s0 / w0 - (total - s0) / w1
            between = w0 * w1 * (d * d)
        else:
            between = -1.0
        if between > best or (np.isnan(between) and not np.isnan(best)):
            best = between
            k_best = k
    t = edges[k_best + 1]
    split = below[k_best]
    if split < 2 or n_x - split < 2:
        return np.nan
    m0, v0 = _mean_var(x[:split])
    m1, v1 = _mean_var(x[split:])
    if not abs(m1 - m0) >= min_separation * math.sqrt(0.5 * (v0 + v1)):
        return np.nan
    return t


def _mean_var(a: np.ndarray) -> tuple[float, float]:
    """``(a.mean(), a.var())`` as NumPy computes them (pairwise sums)."""
    mean = pairwise_sum(a) / a.size
    d = np.empty(a.size)
    for i in range(a.size):
        diff = a[i] - mean
        d[i] = diff * diff
    return mean, pairwise_sum(d) / a.size
