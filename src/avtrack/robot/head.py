r"""Pan/tilt robot head carrying a stereo pair: kinematics and Jacobians (thesis §3.2.4–3.2.5).

Calibration parameters
    Joint ``k`` (1: pan / yaw α, 2: tilt / pitch β) is a revolute joint described by the
    twist :math:`\xi_k = (\omega_k, u_k)` of the *apparent* motion it gives a static scene in
    the home left-camera frame: turning the joint by θ maps the camera coordinates of every
    static point by

    .. math::
        Q(\theta) = e^{\theta\hat\xi_k} = I_4 + \sin\theta\,\hat\xi_k
            + (1-\cos\theta)\,\hat\xi_k^2,\qquad
        \hat\xi_k = \begin{pmatrix}\mathrm{Sk}(\omega_k) & u_k\\ 0 & 0\end{pmatrix}
        \quad\text{(eq. 3.48)}

    with :math:`\|\omega_k\| = 1` and :math:`u_k = p_k \times \omega_k` for a point
    :math:`p_k` of the axis (so :math:`u_k \perp \omega_k`, which makes eq. 3.48 exact).
    :math:`\omega_k` is minus the joint axis: the scene turns the other way.

Forward kinematics
    Pan is the proximal joint, so a static point with home-frame coordinates :math:`X_h` has
    current camera coordinates :math:`X = G(q) X_h` with
    :math:`G(\alpha, \beta) = e^{\beta\hat\xi_2} e^{\alpha\hat\xi_1}`.

Motor-to-world Jacobian (eqs. 3.41–3.44)
    Differentiating, :math:`\dot X = \dot G G^{-1} X = (-\mathrm{Sk}(X)\;\; I_3)\,L(q)\,\dot q`
    with :math:`L(q) = [\mathrm{Ad}_{e^{\beta\hat\xi_2}}\xi_1,\ \xi_2] \in R^{6\times2}`.
    The thesis writes the same Jacobian in the fixed home frame, where the adjoint acts on the
    distal joint (eq. 3.43, :math:`R\omega_2`, :math:`-\mathrm{Sk}(R\omega_2)t + Ru_2`);
    we write it in the current camera frame, where the tracker's states live, so the adjoint
    acts on the proximal joint. At ``q = 0`` the two coincide.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from avtrack.robot.stereo import StereoRig

_UNIT_TOL = 1e-6


def skew(v: np.ndarray) -> np.ndarray:
    r"""Skew-symmetric matrices :math:`\mathrm{Sk}(v)`, :math:`\mathrm{Sk}(v)x = v\times x`.

    Parameters
    ----------
    v : ndarray (..., 3)

    Returns
    -------
    ndarray (..., 3, 3)
    """
    v = np.asarray(v, dtype=float)
    if v.shape[-1:] != (3,):
        raise ValueError(f"v must have shape (..., 3), got {v.shape}")
    out = np.zeros((*v.shape[:-1], 3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def vee(m: np.ndarray) -> np.ndarray:
    """Inverse of :func:`skew` on the antisymmetric part: ``(..., 3, 3) -> (..., 3)``."""
    m = np.asarray(m, dtype=float)
    a = 0.5 * (m - np.swapaxes(m, -1, -2))
    return np.stack([a[..., 2, 1], a[..., 0, 2], a[..., 1, 0]], axis=-1)


def twist_matrix(omega: np.ndarray, u: np.ndarray) -> np.ndarray:
    r""":math:`\hat\xi = \begin{pmatrix}\mathrm{Sk}(\omega) & u\\ 0 & 0\end{pmatrix}`,
    ``(4, 4)``."""
    out = np.zeros((4, 4))
    out[:3, :3] = skew(omega)
    out[:3, 3] = u
    return out


def twist_exp(omega: np.ndarray, u: np.ndarray, theta) -> np.ndarray:
    r"""Rigid motion of a revolute joint turned by ``theta`` (thesis eq. 3.48).

    :math:`e^{\theta\hat\xi} = I_4 + \sin\theta\,\hat\xi + (1-\cos\theta)\,\hat\xi^2`, exact for
    a unit :math:`\omega` and :math:`u \perp \omega`.

    Parameters
    ----------
    omega, u : ndarray (3,)
    theta : float or ndarray (K,)
        Angles, radians.

    Returns
    -------
    ndarray (4, 4), or (K, 4, 4) for an array ``theta``
    """
    xi = twist_matrix(omega, u)
    xi2 = xi @ xi
    th = np.asarray(theta, dtype=float)
    s, c = np.sin(th)[..., None, None], np.cos(th)[..., None, None]
    return np.eye(4) + s * xi + (1 - c) * xi2  # eq. 3.48


def rigid_inverse(g: np.ndarray) -> np.ndarray:
    """Inverse of rigid transforms ``(..., 4, 4)``: ``[Rᵀ, -Rᵀt]``."""
    g = np.asarray(g, dtype=float)
    out = np.zeros_like(g)
    rt = np.swapaxes(g[..., :3, :3], -1, -2)
    out[..., :3, :3] = rt
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", rt, g[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def adjoint(g: np.ndarray) -> np.ndarray:
    r"""Adjoint :math:`\mathrm{Ad}_g = \begin{pmatrix}R & 0\\ \mathrm{Sk}(t)R & R\end{pmatrix}`
    of a rigid transform ``g (4, 4)`` acting on twists stacked as :math:`(\omega; u)`:
    :math:`\mathrm{Ad}_g(\omega, u) = (R\omega, t\times R\omega + Ru)` (the form of eq. 3.43).
    Returns ``(6, 6)``."""
    g = np.asarray(g, dtype=float)
    rot, t = g[:3, :3], g[:3, 3]
    out = np.zeros((6, 6))
    out[:3, :3] = rot
    out[3:, 3:] = rot
    out[3:, :3] = skew(t) @ rot
    return out


def _vec3(name: str, value) -> np.ndarray:
    v = np.array(value, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"HeadCalibration: {name} must be 3 finite numbers, got {value!r}")
    v.setflags(write=False)
    return v


def _check_twist(name_w: str, name_u: str, omega: np.ndarray, u: np.ndarray) -> None:
    n = float(np.linalg.norm(omega))
    if abs(n - 1.0) > _UNIT_TOL:
        raise ValueError(f"HeadCalibration: {name_w} must be a unit vector, got norm {n:.9g}")
    dot = float(omega @ u)
    if abs(dot) > _UNIT_TOL * max(1.0, float(np.linalg.norm(u))):
        raise ValueError(
            f"HeadCalibration: {name_u} must be orthogonal to {name_w} "
            f"(u = p × ω for a point p of the axis), got {name_w}·{name_u} = "
            f"{dot:.3g}"
        )


@dataclass(frozen=True)
class HeadCalibration:
    r"""Motor–camera calibration :math:`(\omega_1, u_1, \omega_2, u_2)` (thesis §3.2.5).

    Attributes
    ----------
    omega1, u1 : ndarray (3,)
        Pan twist: unit rotation axis of the apparent scene motion and :math:`u_1 \perp
        \omega_1` (metres), home left-camera frame.
    omega2, u2 : ndarray (3,)
        Tilt twist, likewise.
    """

    omega1: np.ndarray
    u1: np.ndarray
    omega2: np.ndarray
    u2: np.ndarray

    def __post_init__(self) -> None:
        for name in ("omega1", "u1", "omega2", "u2"):
            object.__setattr__(self, name, _vec3(name, getattr(self, name)))
        _check_twist("omega1", "u1", self.omega1, self.u1)
        _check_twist("omega2", "u2", self.omega2, self.u2)

    @classmethod
    def from_axes(cls, pan_axis, pan_point, tilt_axis, tilt_point) -> HeadCalibration:
        r"""From the physical joint axes (directions of positive rotation, any length) and a
        point of each axis, in the home left-camera frame: :math:`\omega = -a/\|a\|`,
        :math:`u = p \times \omega`."""
        out = []
        for name, axis, point in (("pan", pan_axis, pan_point), ("tilt", tilt_axis, tilt_point)):
            a = np.asarray(axis, dtype=float)
            p = np.asarray(point, dtype=float)
            if a.shape != (3,) or p.shape != (3,) or not np.all(np.isfinite(np.r_[a, p])):
                raise ValueError(f"{name}_axis and {name}_point must be 3 finite numbers each")
            n = float(np.linalg.norm(a))
            if n == 0:
                raise ValueError(f"{name}_axis must be non-zero")
            w = -a / n  # the scene turns against the joint
            out += [w, np.cross(p, w)]  # u = p × ω
        return cls(*out)

    def twists(self) -> np.ndarray:
        r"""``(2, 6)``: :math:`\xi_1 = (\omega_1; u_1)` and :math:`\xi_2 = (\omega_2; u_2)`."""
        return np.stack([np.r_[self.omega1, self.u1], np.r_[self.omega2, self.u2]])

    def axis_points(self) -> np.ndarray:
        r"""``(2, 3)``: the point of each axis nearest the camera, :math:`p = \omega\times u`."""
        return np.stack([np.cross(self.omega1, self.u1), np.cross(self.omega2, self.u2)])


@dataclass(frozen=True)
class RobotHead:
    """A pan/tilt head with a calibrated stereo pair (NAO-like by :func:`nao_head`).

    Attributes
    ----------
    rig : StereoRig
    calibration : HeadCalibration
    pan_limits, tilt_limits : (float, float)
        Joint ranges, radians (``low < 0 < high``: home must be reachable).
    max_speed : (float, float)
        Largest commanded speed of each joint, rad/s.
    """

    rig: StereoRig
    calibration: HeadCalibration
    pan_limits: tuple[float, float] = (-2.0857, 2.0857)
    tilt_limits: tuple[float, float] = (-0.5149, 0.6720)
    max_speed: tuple[float, float] = (3.0, 2.0)

    def __post_init__(self) -> None:
        if not isinstance(self.rig, StereoRig):
            raise TypeError(f"RobotHead: rig must be a StereoRig, got {type(self.rig).__name__}")
        if not isinstance(self.calibration, HeadCalibration):
            raise TypeError(
                "RobotHead: calibration must be a HeadCalibration, got "
                f"{type(self.calibration).__name__}"
            )
        for name in ("pan_limits", "tilt_limits", "max_speed"):
            try:
                a, b = (float(v) for v in getattr(self, name))
            except (TypeError, ValueError):
                raise ValueError(
                    f"RobotHead: {name} must be two numbers, got {getattr(self, name)!r}"
                ) from None
            if not (math.isfinite(a) and math.isfinite(b)):
                raise ValueError(f"RobotHead: {name} must be finite, got {(a, b)!r}")
            if name == "max_speed" and not (a > 0 and b > 0):
                raise ValueError(f"RobotHead: max_speed must be > 0, got {(a, b)!r}")
            if name != "max_speed" and not a < 0 < b:
                raise ValueError(
                    f"RobotHead: {name} must be (low, high) with low < 0 < high, got {(a, b)!r}"
                )
            object.__setattr__(self, name, (a, b))

    # ------------------------------------------------------------------ kinematics
    @property
    def limits(self) -> np.ndarray:
        """``(2, 2)``: ``[[pan_low, pan_high], [tilt_low, tilt_high]]``."""
        return np.array([self.pan_limits, self.tilt_limits])

    def scene_transform(self, angles: np.ndarray) -> np.ndarray:
        r""":math:`G(q) = e^{\beta\hat\xi_2}e^{\alpha\hat\xi_1}` (eq. 3.48 per joint): home-frame
        coordinates of static points → camera coordinates at ``angles (2,)``. ``(4, 4)``."""
        a, b = _angles(angles)
        c = self.calibration
        return twist_exp(c.omega2, c.u2, b) @ twist_exp(c.omega1, c.u1, a)

    def relative_transform(self, angles_from: np.ndarray, angles_to: np.ndarray) -> np.ndarray:
        r""":math:`G(q_1)G(q_0)^{-1}`: camera coordinates of static points at ``angles_from`` →
        at ``angles_to``. ``(4, 4)``."""
        return self.scene_transform(angles_to) @ rigid_inverse(self.scene_transform(angles_from))

    def motion_basis(self, angles: np.ndarray) -> np.ndarray:
        r""":math:`L(q) = [\mathrm{Ad}_{e^{\beta\hat\xi_2}}\xi_1,\ \xi_2]`, ``(6, 2)``
        (eqs. 3.43–3.44 in the current camera frame, see the module notes)."""
        _, b = _angles(angles)
        c = self.calibration
        xi = self.calibration.twists()  # (2, 6)
        pan = adjoint(twist_exp(c.omega2, c.u2, b)) @ xi[0]  # Ad ξ₁, the form of eq. 3.43
        return np.column_stack([pan, xi[1]])

    def motor_to_world_jacobian(self, points: np.ndarray, angles: np.ndarray) -> np.ndarray:
        r"""Velocity of static points per joint velocity, :math:`J_{mw}(X)` (eq. 3.44).

        :math:`\dot X = (-\mathrm{Sk}(X)\;\; I_3)\,L(q)\,\dot q`: each column is
        :math:`\omega \times X + u` (eqs. 3.41–3.42) for the joint's current twist.

        Parameters
        ----------
        points : ndarray (M, 3)
            Current camera-frame points.
        angles : ndarray (2,)

        Returns
        -------
        ndarray (M, 3, 2)
        """
        x = np.asarray(points, dtype=float)
        if x.ndim != 2 or x.shape[1] != 3:
            raise ValueError(f"points must have shape (M, 3), got {x.shape}")
        basis = self.motion_basis(angles)  # (6, 2)
        w, u = basis[:3].T, basis[3:].T  # (2, 3) each
        # -Sk(X) ω + u = ω × X + u, eq. 3.44
        return np.stack([np.cross(w[k], x) + u[k] for k in range(2)], axis=2)

    def joint_jacobian(self, points: np.ndarray, angles: np.ndarray) -> np.ndarray:
        r"""Motor-to-image Jacobian :math:`J(X) = J_{wi}(X) J_{mw}(X)` (eq. 3.46), ``(M, 2, 2)``:
        pixel velocity in the left image per joint velocity."""
        jwi = self.rig.image_jacobian(points)  # eq. 3.40, (M, 2, 3)
        return jwi @ self.motor_to_world_jacobian(points, angles)  # eq. 3.46

    def clip_angles(self, angles: np.ndarray) -> np.ndarray:
        """``angles (2,)`` clipped to the joint ranges."""
        lim = self.limits
        return np.clip(np.asarray(angles, dtype=float), lim[:, 0], lim[:, 1])


def _angles(angles) -> tuple[float, float]:
    q = np.asarray(angles, dtype=float)
    if q.shape != (2,) or not np.all(np.isfinite(q)):
        raise ValueError(f"angles must be 2 finite numbers (pan, tilt) in radians, got {angles!r}")
    return float(q[0]), float(q[1])


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix of ``angle`` (rad) about the unit ``axis`` (Rodrigues)."""
    k = skew(axis)
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def nao_calibration(
    mount_pitch_deg: float = 2.0,
    mount_roll_deg: float = 1.0,
    mount_yaw_deg: float = 0.5,
    baseline: float = 0.1,
) -> HeadCalibration:
    """NAO-like calibration: the pan axis vertical 5 cm behind the cameras, midway between
    them; the tilt axis horizontal 6 cm below and 3 cm behind; the stereo pair mounted with a
    small misalignment (degrees) so that the twists are not axis-aligned.

    In the (upright) camera frame the pan axis points up (``-y``) and the tilt axis along
    ``+x`` (positive tilt looks up); the mount rotation turns both into the camera frame.
    """
    mount = (
        _rotation(np.array([1.0, 0, 0]), math.radians(mount_pitch_deg))
        @ _rotation(np.array([0, 0, 1.0]), math.radians(mount_roll_deg))
        @ _rotation(np.array([0, 1.0, 0]), math.radians(mount_yaw_deg))
    )
    pan_axis, pan_point = np.array([0.0, -1.0, 0.0]), np.array([baseline / 2, 0.0, -0.05])
    tilt_axis, tilt_point = np.array([1.0, 0.0, 0.0]), np.array([baseline / 2, 0.06, -0.03])
    return HeadCalibration.from_axes(
        mount @ pan_axis, mount @ pan_point, mount @ tilt_axis, mount @ tilt_point
    )


def nao_head(
    baseline: float = 0.1,
    hfov_deg: float = 60.97,
    width: int = 640,
    height: int = 480,
    calibration: HeadCalibration | None = None,
    max_speed: tuple[float, float] = (3.0, 2.0),
) -> RobotHead:
    """A NAO-like head: VGA stereo pair (:meth:`StereoRig.nao`), NAO's head joint ranges
    (HeadYaw ±119.5°, HeadPitch −29.5° … +38.5°, here positive = up) and
    :func:`nao_calibration` unless ``calibration`` is given."""
    rig = StereoRig.nao(baseline, hfov_deg, width, height)
    cal = calibration if calibration is not None else nao_calibration(baseline=baseline)
    return RobotHead(rig, cal, max_speed=max_speed)
