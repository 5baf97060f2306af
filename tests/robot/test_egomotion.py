"""The control term C_tn (eqs. 3.34, 3.45): exact cancellation of the head's own motion."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.robot.base import FaceObservations, HeadMotion
from avtrack.robot.egomotion import control_term, control_vector
from avtrack.robot.tracker import RobotTracker, RobotTrackerConfig

FPS = 10.0
DT = 1 / FPS


def _rotation_schedule(n):
    """Joint velocities of a head panning and tilting back and forth (rad/s)."""
    t = np.arange(n) * DT
    return np.column_stack([1.2 * np.sin(2 * np.pi * t / 2.0), 0.5 * np.cos(2 * np.pi * t / 3.0)])


def _static_scene(head, n, home):
    """Camera-frame positions (T, P, 3) of static points and the head's motions."""
    velocity = _rotation_schedule(n)
    q = np.zeros(2)
    positions, motions = [], []
    for k in range(n):
        g = head.scene_transform(q)
        positions.append(home @ g[:3, :3].T + g[:3, 3])
        motions.append(HeadMotion(q, velocity[k]))
        q = q + velocity[k] * DT
    return np.array(positions), motions


def test_exact_control_term_cancels_pure_head_rotation(head, rng):
    home = rng.uniform([-1.0, -0.5, 1.0], [1.0, 0.5, 4.0], size=(5, 3))
    positions, motions = _static_scene(head, 20, home)
    for k in range(19):
        c = control_term(head, positions[k], motions[k], DT, exact=True)
        np.testing.assert_allclose(positions[k] + c, positions[k + 1], rtol=0, atol=1e-13)


def test_first_order_control_term_has_second_order_error(head, rng):
    x = rng.uniform([-1.0, -0.5, 1.0], [1.0, 0.5, 4.0], size=(5, 3))
    q = np.array([0.3, -0.1])
    errors = []
    for dt in (0.02, 0.01):
        motion = HeadMotion(q, np.array([1.0, 0.6]))
        exact = control_term(head, x, motion, dt, exact=True)
        first = control_term(head, x, motion, dt)  # eq. 3.45
        errors.append(np.abs(exact - first).max())
    assert errors[0] / errors[1] == pytest.approx(4.0, rel=0.05)  # O(Δt²)


def test_control_vector_pads_size_and_velocity_with_zeros(head):
    mu = np.zeros((2, 8))
    mu[:, 2] = 2.0
    c = control_vector(head, mu, HeadMotion([0, 0], [0.5, 0.2]), DT)
    assert c.shape == (2, 8)
    assert np.all(c[:, 3:] == 0) and np.all(np.abs(c[:, :3]).sum(axis=1) > 0)
    with pytest.raises(ValueError, match=r"mu_pred must have shape \(N, 8\)"):
        control_vector(head, np.zeros((2, 6)), HeadMotion([0, 0], [0, 0]), DT)
    with pytest.raises(ValueError, match="dt must be a finite number > 0"):
        control_term(head, mu[:, :3], HeadMotion([0, 0], [0, 0]), 0.0)
    with pytest.raises(ValueError, match=r"HeadMotion\.velocity must be 2 finite numbers"):
        HeadMotion([0, 0], [np.nan, 0])


def _track_noise_free(head, control, positions, motions):
    n, p, _ = positions.shape
    cov = np.broadcast_to(np.diag([1e-4, 1e-4, 1e-4, 4.0, 4.0]), (p, 5, 5))
    sizes = np.full((p, 2), 40.0)
    tracker = RobotTracker(head, RobotTrackerConfig(control=control), FPS)
    errors, ids = [], []
    motion = None
    for k in range(n):
        tracker.step(FaceObservations(positions[k], sizes, cov), motion)
        motion = motions[k]
        mu = tracker.engine.mu
        ids.append(tracker.engine.ids.tolist())
        if tracker.n_targets == p:
            errors.append((np.abs(mu[:, :3] - positions[k]).max(), np.abs(mu[:, 5:]).max()))
    return np.array(errors), ids


def test_tracker_with_exact_control_sees_static_people_as_static(head, rng):
    """Noise-free scene, static people, a rotating head: with the exact control term the
    tracked positions are the true ones and every velocity stays zero."""
    home = np.array([[-0.4, -0.3, 2.0], [0.5, -0.35, 2.6]])
    positions, motions = _static_scene(head, 40, home)
    assert np.abs(np.diff(positions, axis=0)).max() > 0.1  # the head does move the scene
    errors, ids = _track_noise_free(head, "exact", positions, motions)
    assert len(errors) > 30
    assert errors[:, 0].max() < 1e-9 and errors[:, 1].max() < 1e-8
    assert ids[-1] == [1, 2]
    # without the control term the head's motion leaks into the states
    errors_none, _ = _track_noise_free(head, "none", positions, motions)
    assert errors_none[:, 0].max() > 0.01 and errors_none[:, 1].max() > 0.05
