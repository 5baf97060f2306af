"""The 3-D VEM tracker with control (eqs. 3.33–3.38) and its observation model."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import multivariate_normal

from avtrack.config import build_config
from avtrack.robot.base import FaceObservations, HeadMotion
from avtrack.robot.tracker import FaceObservationModel, RobotTracker, RobotTrackerConfig


def _faces(rng, m):
    pos = rng.uniform([-1, -0.5, 1.5], [1, 0.5, 3.0], size=(m, 3))
    a = rng.normal(size=(m, 5, 5))
    cov = a @ np.swapaxes(a, 1, 2) * 0.01 + np.eye(5) * 0.01
    return FaceObservations(pos, rng.uniform(30, 60, size=(m, 2)), cov)


def test_face_model_likelihoods_are_gaussian(rng):
    obs = _faces(rng, 3)
    mu = rng.normal(size=(2, 8))
    b = rng.normal(size=(2, 8, 8))
    gamma = b @ np.swapaxes(b, 1, 2) * 0.02 + np.eye(8) * 0.01
    model = FaceObservationModel(-12.0)
    log_tau, log_clutter = model.log_likelihood(obs, mu, gamma, marginal=True)  # eq. 2.8
    for m in range(3):
        for n in range(2):
            ref = multivariate_normal(mu[n, :5], gamma[n, :5, :5] + obs.cov[m]).logpdf(obs.z[m])
            assert log_tau[m, n] == pytest.approx(ref, rel=1e-10)
    np.testing.assert_array_equal(log_clutter, -12.0)
    log_tau, _ = model.log_likelihood(obs, mu, gamma)  # eq. 3.21
    m, n = 1, 0
    prec = np.linalg.inv(obs.cov[m])
    ref = multivariate_normal(mu[n, :5], obs.cov[m]).logpdf(obs.z[m]) - 0.5 * np.trace(
        prec @ gamma[n, :5, :5]
    )
    assert log_tau[m, n] == pytest.approx(ref, rel=1e-10)


def test_face_model_information_terms(rng):
    obs = _faces(rng, 3)
    resp = rng.dirichlet(np.ones(3), size=3)  # (M, N + 1), N = 2
    info, vec = FaceObservationModel(-12.0).information(obs, resp, 8)
    prec = np.linalg.inv(obs.cov)
    np.testing.assert_allclose(info[1, :5, :5], np.einsum("m,mij->ij", resp[:, 2], prec))
    np.testing.assert_allclose(vec[0, :5], np.einsum("m,mij,mj->i", resp[:, 1], prec, obs.z))
    assert np.all(info[:, 5:, :] == 0) and np.all(vec[:, 5:] == 0)


def test_tracker_follows_two_people_and_keeps_identities(head, rng):
    tracker = RobotTracker(head, fps=10.0)
    cov = np.diag([1e-3, 1e-3, 4e-3, 4.0, 4.0])
    truth = np.array([[-0.4, -0.2, 2.0], [0.5, -0.25, 2.5]])
    for _ in range(20):
        truth = truth + np.array([[0.02, 0, 0], [-0.01, 0, 0.01]])
        noisy = truth + rng.normal(0, 0.02, size=truth.shape)
        out = tracker.step(
            FaceObservations(noisy, np.full((2, 2), 40.0), np.broadcast_to(cov, (2, 5, 5)))
        )
    assert sorted(out.ids.tolist()) == [1, 2]
    order = np.argsort(out.positions[:, 0])  # match the tracks to the people by x
    np.testing.assert_allclose(out.positions[order], truth, atol=0.06)
    assert out.boxes.shape == (2, 4) and np.all(out.p_visible > 0.5)
    people = tracker.people()
    np.testing.assert_allclose(people.velocities[order, 0], [0.2, -0.1], atol=0.1)


def test_out_of_view_targets_sleep_and_come_back(head):
    """A person the head turns away from is kept (its predicted position leaves the field of
    view) and recovered with its identity when the head turns back."""
    home = np.array([[0.0, -0.2, 2.0]])
    cov = np.broadcast_to(np.diag([1e-4, 1e-4, 1e-3, 4.0, 4.0]), (1, 5, 5))
    tracker = RobotTracker(head, RobotTrackerConfig(control="exact"), fps=10.0)
    q = np.zeros(2)
    motion = None
    schedule = (
        [np.zeros(2)] * 5
        + [np.array([1.5, 0])] * 8
        + [np.zeros(2)] * 30
        + [np.array([-1.5, 0])] * 8
        + [np.zeros(2)] * 5
    )
    for v in schedule:
        g = head.scene_transform(q)
        x = home @ g[:3, :3].T + g[:3, 3]
        visible = np.abs(head.rig.project(x)[0, 0] - 320) < 300
        faces = (
            FaceObservations(x, np.full((1, 2), 40.0), cov)
            if visible
            else FaceObservations.empty()
        )
        out = tracker.step(faces, motion)
        motion = HeadMotion(q, v)
        q = q + v * 0.1
    assert tracker.engine.ids.tolist() == [1]
    assert out.ids.tolist() == [1]


def test_config_and_input_validation(head):
    with pytest.raises(ValueError, match="control must be one of"):
        RobotTrackerConfig(control="magic")
    with pytest.raises(ValueError, match="dyn_std_pos must be a positive number"):
        RobotTrackerConfig(dyn_std_pos=-1.0)
    with pytest.raises(ValueError, match="unknown field"):
        build_config(RobotTrackerConfig, {"gain": 1})
    tracker = RobotTracker(head)
    with pytest.raises(TypeError, match="faces must be FaceObservations"):
        tracker.step(np.zeros((1, 3)))
    with pytest.raises(TypeError, match="motion must be a HeadMotion"):
        tracker.step(FaceObservations.empty(), motion=(0, 0))
    with pytest.raises(ValueError, match=r"positions must be \(M, 3\)"):
        FaceObservations(np.zeros((2, 2)), np.ones((2, 2)), np.zeros((2, 5, 5)))
    with pytest.raises(ValueError, match="fps must be a positive number"):
        RobotTracker(head, fps=0)
