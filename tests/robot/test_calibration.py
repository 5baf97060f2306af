"""Motor–camera calibration by the Frobenius cost of thesis §3.2.5."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.robot.calibration import (
    calibrate_head,
    calibrate_joint,
    frobenius_cost,
    relative_extrinsics,
)
from avtrack.robot.head import nao_calibration, twist_exp
from avtrack.simulate.robot import estimate_calibration, simulate_chessboard_extrinsics


def _angle_deg(a, b):
    return np.degrees(np.arccos(np.clip(a @ b, -1, 1)))


def test_noise_free_extrinsics_give_the_exact_twists(rng):
    cal = nao_calibration()
    angles = np.radians(np.linspace(-30, 30, 7))
    for joint, (omega, u) in (("pan", (cal.omega1, cal.u1)), ("tilt", (cal.omega2, cal.u2))):
        e = simulate_chessboard_extrinsics(cal, joint, angles, rng, 0.0, 0.0)
        q = relative_extrinsics(e, 3)
        np.testing.assert_allclose(q, twist_exp(omega, u, angles - angles[3]), atol=1e-12)
        est = calibrate_joint(angles, e, reference=3)
        np.testing.assert_allclose(est.omega, omega, atol=1e-12)
        np.testing.assert_allclose(est.u, u, atol=1e-12)
        assert est.cost < 1e-20


def test_noisy_extrinsics_give_the_twists_within_1_degree_and_1_mm(rng):
    cal = nao_calibration()
    for _ in range(3):
        est = estimate_calibration(
            cal, rng, views=40, rotation_noise_deg=0.05, translation_noise_m=0.0005
        )
        assert _angle_deg(est.omega1, cal.omega1) < 1.0
        assert _angle_deg(est.omega2, cal.omega2) < 1.0
        assert np.linalg.norm(est.u1 - cal.u1) < 1e-3
        assert np.linalg.norm(est.u2 - cal.u2) < 1e-3


def test_closed_form_minimises_the_frobenius_cost(rng):
    cal = nao_calibration()
    angles = np.radians(np.linspace(-25, 25, 9))
    e = simulate_chessboard_extrinsics(cal, "pan", angles, rng, 0.3, 0.003)
    est = calibrate_joint(angles, e, reference=4)
    assert est.cost == pytest.approx(frobenius_cost(est.omega, est.u, angles, e, 4))
    for _ in range(50):  # feasible perturbations (unit ω, u ⟂ ω) never do better
        w = est.omega + 0.02 * rng.normal(size=3)
        w /= np.linalg.norm(w)
        u = est.u + 0.002 * rng.normal(size=3)
        u -= (u @ w) * w
        assert frobenius_cost(w, u, angles, e, 4) >= est.cost


def test_calibrate_head_and_bad_input(rng):
    cal = nao_calibration()
    angles = np.radians([-20.0, 0.0, 20.0])
    pan = simulate_chessboard_extrinsics(cal, "pan", angles, rng, 0.0, 0.0)
    tilt = simulate_chessboard_extrinsics(cal, "tilt", angles, rng, 0.0, 0.0)
    est = calibrate_head(angles, pan, angles, tilt, reference=1)
    np.testing.assert_allclose(est.u2, cal.u2, atol=1e-12)
    with pytest.raises(ValueError, match=r"extrinsics must have shape \(K, 4, 4\)"):
        calibrate_joint(angles, pan[:, :3])
    with pytest.raises(ValueError, match="angles must be 3 finite numbers"):
        calibrate_joint(angles[:2], pan)
    with pytest.raises(ValueError, match="rotate the joint"):
        calibrate_joint(np.zeros(3), pan)
    bad = pan.copy()
    bad[0, :3, :3] *= 2
    with pytest.raises(ValueError, match="rotation blocks must be orthonormal"):
        calibrate_joint(angles, bad)
    with pytest.raises(ValueError, match="joint must be 'pan' or 'tilt'"):
        simulate_chessboard_extrinsics(cal, "roll", angles, rng)
