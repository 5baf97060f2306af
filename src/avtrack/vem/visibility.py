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

import numpy as np

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
    e = np.exp(-lam * np.maximum(nu, 0.0))  # eq. 3.32: visibility_likelihood, inline
    num1 = np.maximum(1.0 - e, LIKELIHOOD_FLOOR) * prior1
    return num1 / (num1 + np.maximum(e, LIKELIHOOD_FLOOR) * (1 - prior1))
