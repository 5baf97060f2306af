r"""Visibility process: a two-state HMM per target (thesis §3.1.4, eqs. 3.31–3.32).

:math:`V_{tn} \in \{0, 1\}` with transition :math:`p(V_t=j|V_{t-1}=i) = \pi_v^{\delta_{ij}}
(1-\pi_v)^{1-\delta_{ij}}`, filtered with the visibility observation :math:`\nu_{tn}`, the
assignment mass summed over a window of frames.

Two deliberate readings of the printed equations:

* eq. 3.32 as printed gives :math:`e^{-\lambda\nu}` to the *visible* state, contradicting the
  text right after it ("when ν is high, the likelihood is large if v = 1"); we use the stated
  intent, :math:`p(\nu|v=1) = 1 - e^{-\lambda\nu}`, :math:`p(\nu|v=0) = e^{-\lambda\nu}`,
  with a small floor so a single empty window does not make the filter certain;
* the thesis window :math:`\nu_{tn} = \sum_{l=0}^{L} a_{t+l,n}` looks into the future; an online
  tracker uses the past window :math:`\sum_{l=0}^{L-1} m_{t-l,n}` of assignment masses
  :math:`m_{tn} = \sum_m \alpha_{tmn}` (the numerator of eq. 3.29, which is 1 for a target
  that took one detection whatever the number of detections in the frame).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from avtrack._jit import available_once as _compiled
from avtrack._jit import build_once

LIKELIHOOD_FLOOR = 1e-3


def visibility_likelihood(nu: np.ndarray, lam: float) -> tuple[np.ndarray, np.ndarray]:
    """``p(ν|v=0), p(ν|v=1)`` for evidence ``nu (N,)`` (eq. 3.32, see module notes)."""
    e = np.exp(-lam * np.maximum(nu, 0.0))
    return np.maximum(e, LIKELIHOOD_FLOOR), np.maximum(1.0 - e, LIKELIHOOD_FLOOR)


def visibility_filter(p_visible: np.ndarray, nu: np.ndarray, stay: float, lam: float):
    r"""One step of the visibility filter (thesis eq. 3.31).

    Parameters
    ----------
    p_visible : ndarray (N,)
        :math:`p(V_{t-1,n} = 1 | \nu_{1:t-1,n})`.
    nu : ndarray (N,)
        Visibility evidence :math:`\nu_{tn} \ge 0`.
    stay : float
        :math:`\pi_v`, probability of keeping the same state, in (0, 1).
    lam : float
        :math:`\lambda > 0` of eq. 3.32.

    Returns
    -------
    ndarray (N,)
        :math:`p(V_{tn} = 1 | \nu_{1:t,n})`.
    """
    if not 0 < stay < 1:
        raise ValueError(f"stay must be in (0, 1), got {stay}")
    if not lam > 0:
        raise ValueError(f"lam must be > 0, got {lam}")
    return visibility_step(p_visible, nu, stay, lam)


def visibility_step(p_visible: np.ndarray, nu: np.ndarray, stay: float, lam: float):
    """:func:`visibility_filter` without checking ``stay`` and ``lam`` (for callers whose
    configuration has checked them: a tracker's every frame)."""
    # Σ_v p(v_t|v_{t-1}) p(v_{t-1}) = π_v p + (1 - π_v)(1 - p)
    prior1 = (1 - stay) + (2 * stay - 1) * p_visible
    l0, l1 = visibility_likelihood(nu, lam)
    num1 = l1 * prior1
    return num1 / (num1 + l0 * (1 - prior1))


def windowed_visibility_step(
    p_visible: np.ndarray, history: np.ndarray, mass: np.ndarray, stay: float, lam: float,
) -> tuple[np.ndarray, np.ndarray]:
    r"""One frame of the visibility filter with its evidence window: ``mass (N,)`` joins the
    front of each target's window ``history (N, L)`` (the oldest leaves), :math:`\nu_{tn}` is
    the window's sum, and :func:`visibility_step` updates ``p_visible (N,)``. Returns the new
    posteriors ``(N,)`` and the new window ``(N, L)``; the inputs are not changed.

    Compiled with Numba where it is available (:mod:`avtrack._jit`): a tracker calls this twice
    a frame on arrays of a few targets, where NumPy's per-call overhead is most of the cost.
    The compiled form gives the same windows and the posteriors to rounding (tested)."""
    kern = _window_kernel() if _compiled() else None
    if kern is not None:
        return kern(np.ascontiguousarray(p_visible, dtype=float),
                    np.ascontiguousarray(history, dtype=float),
                    np.ascontiguousarray(mass, dtype=float), float(stay), float(lam))
    return _windowed_visibility_step(p_visible, history, mass, stay, lam)


def _windowed_visibility_step(
    p_visible: np.ndarray, history: np.ndarray, mass: np.ndarray, stay: float, lam: float,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`windowed_visibility_step` with NumPy."""
    window = np.concatenate([mass[:, None], history[:, :-1]], 1)
    return visibility_step(p_visible, window.sum(axis=1), stay, lam), window


def _windowed_loop(
    p_visible: np.ndarray, history: np.ndarray, mass: np.ndarray, stay: float, lam: float,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`windowed_visibility_step` written element by element (the form Numba compiles;
    the same operations as :func:`visibility_step`)."""
    n, width = history.shape
    window = np.empty((n, width))
    out = np.empty(n)
    for i in range(n):
        window[i, 0] = mass[i]
        nu = mass[i]
        for k in range(1, width):
            window[i, k] = history[i, k - 1]
            nu += history[i, k - 1]
        prior1 = (1 - stay) + (2 * stay - 1) * p_visible[i]
        e = math.exp(-lam * max(nu, 0.0))
        num1 = max(1.0 - e, LIKELIHOOD_FLOOR) * prior1
        out[i] = num1 / (num1 + max(e, LIKELIHOOD_FLOOR) * (1 - prior1))
    return out, window


_KERNEL: Callable[..., tuple[np.ndarray, np.ndarray]] | None = None
_FAILED = False



def _window_kernel() -> Callable[..., tuple[np.ndarray, np.ndarray]] | None:
    """The compiled :func:`_windowed_loop`, or None where Numba cannot build it (warned once)."""
    return build_once(globals(), _compile, "visibility filter")


def _compile(njit: Callable[..., Any], cache: bool) -> Callable[..., Any]:
    return njit("Tuple((f8[::1], f8[:, ::1]))(f8[::1], f8[:, ::1], f8[::1], f8, f8)",
                cache=cache, nogil=True)(_windowed_loop)
