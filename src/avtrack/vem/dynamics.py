r"""Constant-velocity dynamics (thesis §3.1.2 eq. 3.11, §2.2.5 eq. 2.6).

State layout used by every Gaussian tracker of the package: ``s = [p, v]`` where ``p`` has
``n_obs`` components (observed) and ``v`` holds a velocity for the first ``n_vel`` of them.
For image boxes ``p = (x, y, w, h)`` (centre, size) and ``v = (ẋ, ẏ)``: ``d = 6``.
"""

from __future__ import annotations

import functools

import numpy as np


def constant_velocity_transition(n_obs: int, n_vel: int, dt: float = 1.0) -> np.ndarray:
    r"""Transition matrix ``D`` of shape ``(n_obs + n_vel, n_obs + n_vel)``.

    :math:`p_t = p_{t-1} + \Delta t\,[v_{t-1}; 0]`, :math:`v_t = v_{t-1}`. (The printed
    eq. 3.11 shows a zero velocity block, which would make the velocity unobservable and the
    model not constant-velocity; eq. 2.6 has the intended form.)
    """
    if n_vel > n_obs or n_obs < 1 or n_vel < 0:
        raise ValueError(f"need 0 <= n_vel <= n_obs and n_obs >= 1, got {n_obs=}, {n_vel=}")
    if not dt > 0:
        raise ValueError(f"dt must be > 0, got {dt}")
    d = n_obs + n_vel
    transition = np.eye(d)
    transition[np.arange(n_vel), n_obs + np.arange(n_vel)] = dt
    return transition


def box_dynamics_covariance(
    mu: np.ndarray, pos: float = 0.05, size: float = 0.05, vel: float = 0.05,
) -> np.ndarray:
    r"""Size-adaptive dynamics covariance :math:`\Lambda_n` for box states (thesis §3.1.5).

    Diagonal, with standard deviations ``pos·w, pos·h`` (centre), ``size·w, size·h`` (size)
    and ``vel·w, vel·h`` (velocity), in pixels per frame, where ``w, h`` is the target's
    current box size. The thesis sets the diagonal to "1, 1 and 1/2 of the detected width"
    without saying whether variance or standard deviation is meant; scaling the standard
    deviation keeps the model invariant to image scale (a person twice as close moves and
    jitters twice as many pixels), which is what real detections show.

    Parameters
    ----------
    mu : ndarray (N, 6)
        Box states ``(x, y, w, h, ẋ, ẏ)``.

    Returns
    -------
    ndarray (N, 6, 6)
    """
    diag = box_dynamics_variance(mu, pos, size, vel)
    out = np.zeros((mu.shape[0], 6, 6))
    idx = np.arange(6)
    out[:, idx, idx] = diag
    return out


def box_dynamics_variance(
    mu: np.ndarray, pos: float = 0.05, size: float = 0.05, vel: float = 0.05,
) -> np.ndarray:
    """Diagonal ``(N, 6)`` of :func:`box_dynamics_covariance` (the whole of it: Λ is diagonal)."""
    out = mu.take(_SIZES, axis=1)  # (w, h, w, h, w, h)
    np.maximum(out, 1.0, out=out)
    out *= _stds(pos, size, vel)  # std · size
    out *= out  # (std · size)²
    return out


def cap_box_covariance(mu: np.ndarray, gamma: np.ndarray, max_std: float) -> np.ndarray:
    r"""Bound the uncertainty of box states: every standard deviation ≤ ``max_std`` × size.

    A target that receives no observation sees its covariance grow by :math:`\Lambda` each
    frame; once it is larger than a person, its predictive density covers several people and
    it swallows their detections. We rescale :math:`\Gamma \leftarrow S\Gamma S` with
    :math:`S = \mathrm{diag}(\min(1, c_k/\sqrt{\Gamma_{kk}}))`, :math:`c = \texttt{max\_std}
    \cdot(w, h, w, h, w, h)`, which keeps correlations and positive definiteness.

    Parameters
    ----------
    mu : ndarray (N, 6)
    gamma : ndarray (N, 6, 6)
    max_std : float
        > 0.

    Returns
    -------
    ndarray (N, 6, 6)
    """
    scale = cap_box_scale(mu, np.diagonal(gamma, axis1=1, axis2=2), max_std)
    return gamma * scale[:, :, None] * scale[:, None, :]  # S Γ S


def cap_box_scale(mu: np.ndarray, variances: np.ndarray, max_std: float) -> np.ndarray:
    """The diagonal ``(N, 6)`` of ``S`` in :func:`cap_box_covariance`, from the box states
    ``mu (N, 6)`` and the variances ``(N, 6)`` (the diagonal of Γ)."""
    if not max_std > 0:
        raise ValueError(f"max_std must be > 0, got {max_std}")
    scale = mu.take(_SIZES, axis=1)  # (w, h, w, h, w, h)
    np.maximum(scale, 1.0, out=scale)
    scale *= max_std  # c = max_std (w, h, w, h, w, h)
    std = np.maximum(variances, 1e-300)
    scale /= np.sqrt(std, out=std)
    return np.minimum(scale, 1.0, out=scale)  # S = min(1, c / sqrt(Γ_kk))


#: Columns of the box size (w, h) of a box state, once per group of components of
#: :func:`box_dynamics_variance` and :func:`cap_box_scale` (gathered in one ``take``: faster
#: than slicing and concatenating on these small arrays).
_SIZES = np.array([2, 3, 2, 3, 2, 3])
_SIZES.flags.writeable = False


@functools.lru_cache(maxsize=16)
def _stds(pos: float, size: float, vel: float) -> np.ndarray:
    """``(pos, pos, size, size, vel, vel)``, read-only."""
    out = np.array([pos, pos, size, size, vel, vel], dtype=float)
    out.flags.writeable = False
    return out
