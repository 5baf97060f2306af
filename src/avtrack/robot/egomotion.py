r"""Ego-motion compensation: the control term :math:`C_{tn}` (thesis eqs. 3.34, 3.45).

The head's commanded joint velocities :math:`\dot q_c = (\dot\alpha_c, \dot\beta_c)` move
every static point of the scene in the camera frame. Evaluated at each target's predicted
position :math:`D\mu_{t-1,n}`, this motion is the translation added to the prediction:

.. math::
    C_{tn} = J_{mw}(D\mu_{t-1,n})\,\dot q_c\,\Delta t \qquad\text{(eq. 3.45)}

padded with zeros for the box size and the velocity (the 8-vector of eq. 3.34), so that the
E-S step uses the mean :math:`D\mu_{t-1,n} + C_{tn}` (eq. 3.38). The first-order form above
is the thesis's; ``exact=True`` uses the finite rigid motion of eq. 3.48 instead,
:math:`C_{tn} = (G(q_t)G(q_{t-1})^{-1} - I)\,D\mu_{t-1,n}`, which cancels a head rotation
exactly for static people (the first-order form leaves an error of order
:math:`\|X\|\,(\|\dot q\|\Delta t)^2`).
"""

from __future__ import annotations

import numpy as np

from avtrack.robot.base import STATE_DIM, HeadMotion
from avtrack.robot.head import RobotHead


def _check(points: np.ndarray, dt: float) -> np.ndarray:
    x = np.asarray(points, dtype=float)
    if x.ndim != 2 or x.shape[1] != 3:
        raise ValueError(f"positions must have shape (N, 3), got {x.shape}")
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a finite number > 0, got {dt!r}")
    return x


def control_term(
    head: RobotHead, positions: np.ndarray, motion: HeadMotion, dt: float, exact: bool = False
) -> np.ndarray:
    r"""Displacement of static points caused by the head's motion over one frame.

    Parameters
    ----------
    head : RobotHead
    positions : ndarray (N, 3)
        Predicted positions :math:`D\mu_{t-1,n}` (camera frame at the previous frame).
    motion : HeadMotion
        Joint angles at the previous frame and the commanded velocities.
    dt : float
        Frame period, seconds.
    exact : bool
        False: eq. 3.45 (first order); True: the finite motion of eq. 3.48.

    Returns
    -------
    ndarray (N, 3)
        :math:`C_{tn}` (metres).
    """
    x = _check(positions, dt)
    if x.shape[0] == 0:
        return np.zeros((0, 3))
    if exact:
        q1 = motion.angles + motion.velocity * dt
        g = head.relative_transform(motion.angles, q1)  # G(q_t) G(q_{t-1})⁻¹, eq. 3.48
        return x @ (g[:3, :3] - np.eye(3)).T + g[:3, 3]  # (G - I) X
    jac = head.motor_to_world_jacobian(x, motion.angles)  # J_mw(Dμ), eq. 3.44
    return jac @ (motion.velocity * dt)  # C = J_mw(Dμ) q̇ Δt, eq. 3.45


def control_vector(
    head: RobotHead, mu_pred: np.ndarray, motion: HeadMotion, dt: float, exact: bool = False
) -> np.ndarray:
    r"""The 8-vector :math:`C_{tn} = [C^X_{tn}, 0_5]` of eq. 3.34 for states ``[X, W, Ẋ]``.

    Parameters
    ----------
    mu_pred : ndarray (N, 8)
        Predicted means :math:`D\mu_{t-1,n}`.

    Returns
    -------
    ndarray (N, 8)
    """
    mu = np.asarray(mu_pred, dtype=float)
    if mu.ndim != 2 or mu.shape[1] != STATE_DIM:
        raise ValueError(f"mu_pred must have shape (N, {STATE_DIM}), got {mu.shape}")
    out = np.zeros_like(mu)
    out[:, :3] = control_term(head, mu[:, :3], motion, dt, exact)  # [C, 0_5], eq. 3.34
    return out


def ego_displacement_scale(positions: np.ndarray, motion: HeadMotion, dt: float) -> np.ndarray:
    r"""``(N,)`` size of the ego-motion over one frame at each point,
    :math:`\|X\|\,\|\dot q_c\|\Delta t` (metres): the scale of the motor-speed term of the
    dynamics covariance (thesis §3.2.5: :math:`\Lambda_n` grows with the motor speed)."""
    x = _check(positions, dt)
    return np.linalg.norm(x, axis=1) * float(np.linalg.norm(motion.velocity)) * dt
