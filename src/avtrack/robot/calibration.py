r"""Motor–camera calibration from chessboard extrinsics (thesis §3.2.5).

Turning joint ``k`` from :math:`\theta_0` to :math:`\theta_i` maps the camera coordinates of a
static chessboard by :math:`Q_{0\to i} = e^{(\theta_i-\theta_0)\hat\xi_k}` (eq. 3.48). With
:math:`E_i` the board-to-camera extrinsic matrix measured at :math:`\theta_i`,
:math:`\tilde Q_{0\to i} = E_i E_0^{-1}` and :math:`\tilde Q_{i\to 0} = \tilde Q_{0\to i}^{-1}`.
Since :math:`e^{\theta\hat\xi} - e^{-\theta\hat\xi} = 2\sin\theta\,\hat\xi` for a revolute
twist, the calibration minimises

.. math::
    J(\omega, u) = \sum_i \Big\| 2\sin(\theta_i-\theta_0)
        \begin{pmatrix}\mathrm{Sk}(\omega) & u\\ 0 & 0\end{pmatrix}
        - \tilde Q_{0\to i} + \tilde Q_{i\to 0}\Big\|_F^2
    \quad\text{s.t. } \|\omega\| = 1,\ u\perp\omega.

The cost is quadratic in :math:`(\omega, u)` with :math:`\|\mathrm{Sk}(\omega)\|_F^2 =
2\|\omega\|^2`, so the constrained minimiser has a closed form: with
:math:`s_i = \sin(\theta_i-\theta_0)` and :math:`A_i = \tilde Q_{0\to i} - \tilde Q_{i\to 0}`,
:math:`\omega = b/\|b\|` for :math:`b = \sum_i s_i\,\mathrm{vee}(A_i^{3\times3})`, and
:math:`u` is the projection on :math:`\omega^\perp` of :math:`\sum_i s_i a_i / (2\sum_i s_i^2)`
(:math:`a_i` the translation column of :math:`A_i`).

The pan joint is calibrated at the home tilt, the tilt joint at any pan.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from avtrack.robot.head import HeadCalibration, rigid_inverse, twist_matrix, vee


def _extrinsics(name: str, e: np.ndarray) -> np.ndarray:
    a = np.asarray(e, dtype=float)
    if a.ndim != 3 or a.shape[1:] != (4, 4):
        raise ValueError(f"{name} must have shape (K, 4, 4), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite")
    rot = a[:, :3, :3]
    err = np.abs(rot @ np.swapaxes(rot, 1, 2) - np.eye(3)).max(initial=0.0)
    if err > 1e-3:
        raise ValueError(
            f"{name}: the rotation blocks must be orthonormal (max |RRᵀ - I| = {err:.3g})"
        )
    if not np.allclose(a[:, 3], [0.0, 0.0, 0.0, 1.0]):
        raise ValueError(f"{name}: the last row of every matrix must be (0, 0, 0, 1)")
    return a


def relative_extrinsics(extrinsics: np.ndarray, reference: int = 0) -> np.ndarray:
    r""":math:`\tilde Q_{0\to i} = E_i E_0^{-1}` for board-to-camera extrinsics
    ``extrinsics (K, 4, 4)`` and the reference view ``reference``. Returns ``(K, 4, 4)``."""
    e = _extrinsics("extrinsics", extrinsics)
    if not 0 <= reference < e.shape[0]:
        raise ValueError(f"reference must index one of the {e.shape[0]} views, got {reference}")
    return e @ rigid_inverse(e[reference])


@dataclass(frozen=True)
class JointCalibration:
    r"""Twist of one joint estimated by :func:`calibrate_joint`.

    Attributes
    ----------
    omega : ndarray (3,)
        Unit rotation axis of the apparent scene motion.
    u : ndarray (3,)
        :math:`u \perp \omega`, metres.
    cost : float
        The Frobenius cost :math:`J(\omega, u)` at the estimate.
    """

    omega: np.ndarray
    u: np.ndarray
    cost: float


def _check_angles(angles: np.ndarray, n: int) -> np.ndarray:
    a = np.asarray(angles, dtype=float)
    if a.shape != (n,) or not np.all(np.isfinite(a)):
        raise ValueError(f"angles must be {n} finite numbers (one per view), got shape {a.shape}")
    return a


def _pairs(
    angles: np.ndarray, extrinsics: np.ndarray, reference: int | None
) -> tuple[np.ndarray, np.ndarray]:
    """``sin(θ_j - θ_i)`` ``(P,)`` and :math:`\tilde Q_{i\to j}` ``(P, 4, 4)`` for the pairs
    ``(reference, j)`` (thesis) or, with ``reference=None``, every pair ``i < j``."""
    e = _extrinsics("extrinsics", extrinsics)
    a = _check_angles(angles, e.shape[0])
    if e.shape[0] < 2:
        raise ValueError(f"extrinsics: need at least 2 views, got {e.shape[0]}")
    if reference is None:
        i, j = np.triu_indices(e.shape[0], k=1)
    else:
        if not (isinstance(reference, int | np.integer) and 0 <= reference < e.shape[0]):
            raise ValueError(
                f"reference must index one of the {e.shape[0]} views or be None, got {reference!r}"
            )
        j = np.arange(e.shape[0])
        i = np.full_like(j, int(reference))
    q = e[j] @ rigid_inverse(e[i])  # Q̃_{i→j} = E_j E_i⁻¹
    return np.sin(a[j] - a[i]), q


def frobenius_cost(
    omega: np.ndarray,
    u: np.ndarray,
    angles: np.ndarray,
    extrinsics: np.ndarray,
    reference: int | None = 0,
) -> float:
    r"""The calibration cost :math:`J(\omega, u)` of thesis §3.2.5 (see the module docstring).

    Parameters
    ----------
    omega, u : ndarray (3,)
    angles : ndarray (K,)
        Joint angle of each view, radians.
    extrinsics : ndarray (K, 4, 4)
        Board-to-camera extrinsic matrix of each view.
    reference : int or None
        The view playing :math:`\theta_0`; None sums the cost over every pair of views
        ``i < j`` (each view in turn the reference).
    """
    s, q = _pairs(angles, extrinsics, reference)
    diff = q - rigid_inverse(q)  # Q̃_{0→i} - Q̃_{i→0}
    resid = 2 * s[:, None, None] * twist_matrix(omega, u) - diff
    return float((resid**2).sum())  # Σ_i ‖·‖_F²


def calibrate_joint(
    angles: np.ndarray, extrinsics: np.ndarray, reference: int | None = 0
) -> JointCalibration:
    r"""Estimate a joint's twist :math:`(\omega, u)` from chessboard views (thesis §3.2.5).

    Parameters
    ----------
    angles : ndarray (K,)
        Joint angle of each view, radians (the other joint held fixed).
    extrinsics : ndarray (K, 4, 4)
        Board-to-camera extrinsics :math:`E_i` of each view (the board does not move).
    reference : int or None
        The view playing :math:`\theta_0` (the thesis's cost); None uses every pair of views,
        which averages out the noise of any single view (the thesis's cost depends on the
        reference view's error through every term).

    Returns
    -------
    JointCalibration
        The exact minimiser of the Frobenius cost under :math:`\|\omega\|=1`,
        :math:`u\perp\omega`.

    Raises
    ------
    ValueError
        Bad shapes, non-rigid matrices, fewer than two views, or views that all share the
        reference angle (modulo π).
    """
    s, q = _pairs(angles, extrinsics, reference)
    s2 = float(s @ s)
    if s2 < 1e-12:
        raise ValueError("angles: every view has sin(θ_i - θ_0) = 0; rotate the joint")
    diff = q - rigid_inverse(q)  # A_i = Q̃_{0→i} - Q̃_{i→0}, ideally 2 sin(θ_i-θ_0) ξ̂
    b = np.einsum("i,ij->j", s, vee(diff[:, :3, :3]))  # Σ s_i vee(A_i)
    norm = float(np.linalg.norm(b))
    if norm == 0:
        raise ValueError("extrinsics: the views show no rotation")
    omega = b / norm  # minimiser on ‖ω‖ = 1
    u = np.einsum("i,ij->j", s, diff[:, :3, 3]) / (2 * s2)  # Σ s_i a_i / (2 Σ s_i²)
    u = u - (u @ omega) * omega  # projection on ω⊥
    return JointCalibration(omega, u, frobenius_cost(omega, u, angles, extrinsics, reference))


def calibrate_head(
    pan_angles: np.ndarray,
    pan_extrinsics: np.ndarray,
    tilt_angles: np.ndarray,
    tilt_extrinsics: np.ndarray,
    reference: int | None = 0,
) -> HeadCalibration:
    """Both joints by :func:`calibrate_joint`: the pan views at the home tilt, the tilt views
    at a fixed pan. Returns a :class:`~avtrack.robot.head.HeadCalibration`."""
    pan = calibrate_joint(pan_angles, pan_extrinsics, reference)
    tilt = calibrate_joint(tilt_angles, tilt_extrinsics, reference)
    return HeadCalibration(pan.omega, pan.u, tilt.omega, tilt.u)
