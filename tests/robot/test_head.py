"""Kinematics of the pan/tilt head: eq. 3.48, the Jacobians of eqs. 3.40–3.46."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

from avtrack.robot.head import (
    HeadCalibration,
    RobotHead,
    adjoint,
    nao_calibration,
    rigid_inverse,
    skew,
    twist_exp,
    twist_matrix,
    vee,
)
from avtrack.robot.stereo import StereoRig


def _static_points(head, q, home):
    g = head.scene_transform(q)
    return home @ g[:3, :3].T + g[:3, 3]


def test_skew_is_the_cross_product_and_vee_inverts_it(rng):
    a, b = rng.normal(size=(2, 5, 3))
    np.testing.assert_allclose(np.einsum("nij,nj->ni", skew(a), b), np.cross(a, b), atol=1e-14)
    np.testing.assert_allclose(vee(skew(a)), a, atol=1e-15)


def test_eq_3_48_is_the_matrix_exponential_of_a_revolute_twist(rng):
    cal = nao_calibration()
    for omega, u in ((cal.omega1, cal.u1), (cal.omega2, cal.u2)):
        for theta in (-1.3, 0.2, 2.5):
            np.testing.assert_allclose(
                twist_exp(omega, u, theta), expm(theta * twist_matrix(omega, u)), atol=1e-12
            )
    batch = twist_exp(cal.omega1, cal.u1, np.array([0.1, -0.4]))
    assert batch.shape == (2, 4, 4)


def test_adjoint_conjugates_twists(rng):
    cal = nao_calibration()
    g = twist_exp(cal.omega2, cal.u2, 0.7) @ twist_exp(cal.omega1, cal.u1, -0.3)
    xi = rng.normal(size=6)
    lhs = twist_matrix(*np.split(adjoint(g) @ xi, 2))
    rhs = g @ twist_matrix(xi[:3], xi[3:]) @ rigid_inverse(g)  # Ad_g ξ̂ = g ξ̂ g⁻¹
    np.testing.assert_allclose(lhs, rhs, atol=1e-12)


def test_calibration_from_axes_gives_the_apparent_motion():
    # pan axis "up" (camera -y): turning left moves the scene to the right (+x) in the image
    cal = HeadCalibration.from_axes([0, -1, 0], [0, 0, -0.05], [1, 0, 0], [0, 0.06, -0.03])
    np.testing.assert_allclose(cal.omega1, [0, 1, 0])
    point = np.array([0.0, 0.0, 2.0])
    assert (np.cross(cal.omega1, point) + cal.u1)[0] > 0
    np.testing.assert_allclose(cal.axis_points()[0], [0, 0, -0.05], atol=1e-15)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"omega1": [0, 2.0, 0]}, "omega1 must be a unit vector"),
        ({"u1": [0, 0.3, 0]}, "u1 must be orthogonal to omega1"),
        ({"u2": [np.nan, 0, 0]}, "u2 must be 3 finite numbers"),
    ],
)
def test_calibration_rejects_bad_twists(kwargs, message):
    base = {
        "omega1": [0, 1.0, 0],
        "u1": [0.05, 0, 0],
        "omega2": [-1.0, 0, 0],
        "u2": [0, 0.03, 0.06],
    }
    base.update(kwargs)
    with pytest.raises(ValueError, match=message):
        HeadCalibration(**base)


def test_head_rejects_bad_limits():
    rig, cal = StereoRig.nao(), nao_calibration()
    with pytest.raises(ValueError, match="pan_limits must be"):
        RobotHead(rig, cal, pan_limits=(0.1, 1.0))
    with pytest.raises(ValueError, match="max_speed must be > 0"):
        RobotHead(rig, cal, max_speed=(1.0, 0.0))
    with pytest.raises(TypeError, match="rig must be a StereoRig"):
        RobotHead("rig", cal)
    with pytest.raises(ValueError, match="angles must be 2 finite numbers"):
        RobotHead(rig, cal).scene_transform([0.1])


@pytest.mark.parametrize("q", [(0.0, 0.0), (0.4, -0.2), (-1.1, 0.5)])
def test_motor_to_world_jacobian_matches_finite_differences(head, rng, q):
    q = np.array(q)
    home = rng.uniform([-1.5, -0.8, 0.5], [1.5, 0.8, 4.0], size=(6, 3))
    x = _static_points(head, q, home)
    jac = head.motor_to_world_jacobian(x, q)  # eq. 3.44
    eps = 1e-6
    for k in range(2):
        dq = np.zeros(2)
        dq[k] = eps
        fd = (_static_points(head, q + dq, home) - _static_points(head, q - dq, home)) / (2 * eps)
        np.testing.assert_allclose(jac[:, :, k], fd, rtol=0, atol=1e-8)


def test_motion_basis_at_home_is_the_calibration(head):
    np.testing.assert_allclose(
        head.motion_basis([0.0, 0.0]).T, head.calibration.twists(), atol=1e-15
    )


def test_image_and_joint_jacobians_match_finite_differences(head, rng):
    q = np.array([0.3, 0.15])
    home = rng.uniform([-1.0, -0.6, 1.5], [1.0, 0.6, 3.0], size=(4, 3))
    x = _static_points(head, q, home)
    rig = head.rig
    eps = 1e-6
    jwi = rig.image_jacobian(x)  # eq. 3.40
    for k in range(3):
        d = np.zeros(3)
        d[k] = eps
        fd = (rig.project(x + d) - rig.project(x - d)) / (2 * eps)
        np.testing.assert_allclose(jwi[:, :, k], fd, rtol=1e-7, atol=1e-6)
    jac = head.joint_jacobian(x, q)  # eq. 3.46
    for k in range(2):
        dq = np.zeros(2)
        dq[k] = eps
        fd = (
            rig.project(_static_points(head, q + dq, home))
            - rig.project(_static_points(head, q - dq, home))
        ) / (2 * eps)
        np.testing.assert_allclose(jac[:, :, k], fd, rtol=1e-6, atol=1e-4)


def test_relative_transform_composes(head):
    q0, q1 = np.array([0.2, -0.1]), np.array([-0.5, 0.3])
    np.testing.assert_allclose(
        head.relative_transform(q0, q1) @ head.scene_transform(q0),
        head.scene_transform(q1),
        atol=1e-12,
    )
    np.testing.assert_allclose(
        head.clip_angles([5.0, -5.0]), [head.pan_limits[1], head.tilt_limits[0]]
    )
