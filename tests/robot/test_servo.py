"""Visual servoing (eq. 3.47) and the follow / jump policies."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from avtrack.robot.base import TrackedPeople
from avtrack.robot.servo import (
    SERVO_POLICIES,
    FollowFirst,
    JumpPolicy,
    VisualServo,
    limit_velocity,
    make_policy,
    servo_jacobian,
    servo_velocity,
)

DT = 0.1


def _people(ids, positions=None):
    n = len(ids)
    pos = np.tile([0.0, 0.0, 2.0], (n, 1)) if positions is None else np.asarray(positions)
    return TrackedPeople(ids, pos, np.zeros((n, 3)), np.ones(n, dtype=bool))


def test_servo_brings_a_static_person_to_the_image_centre(head):
    home = np.array([0.6, -0.4, 2.0])  # right and above the centre
    q = np.zeros(2)
    distances = []
    for _ in range(25):
        g = head.scene_transform(q)
        x = g[:3, :3] @ home + g[:3, 3]
        distances.append(np.linalg.norm(head.rig.project(x[None])[0] - head.rig.centre))
        q = q + servo_velocity(head, x, q, DT, gain=0.5) * DT  # eq. 3.47
    assert distances[0] > 150
    assert distances[-1] < 0.5
    assert all(b < a for a, b in itertools.pairwise(distances[:11]))


def test_servo_step_is_gamma_times_the_jacobian_inverse(head):
    x = np.array([0.05, -0.02, 2.0])
    q = np.array([0.1, 0.05])
    v = servo_velocity(head, x, q, DT, gain=0.3)
    shift = head.rig.centre - head.rig.project(x[None])[0]
    np.testing.assert_allclose(servo_jacobian(head, x, q) @ v * DT, 0.3 * shift, atol=1e-9)


def test_commands_respect_speed_and_range_limits(head):
    q = np.array([head.pan_limits[1] - 0.01, 0.0])
    v = limit_velocity(head, q, np.array([10.0, -3.0]), DT)
    assert v[0] <= 0.01 / DT + 1e-12
    v = limit_velocity(head, np.zeros(2), np.array([-30.0, 10.0]), DT)
    np.testing.assert_allclose(v, [-head.max_speed[0], head.max_speed[0] / 3])
    behind = servo_velocity(head, np.array([1.0, 0.0, -0.5]), np.zeros(2), DT)
    assert behind[1] == 0 and abs(behind[0]) == pytest.approx(head.max_speed[0])
    with pytest.raises(ValueError, match="gain must be in"):
        servo_velocity(head, np.array([0, 0, 2.0]), np.zeros(2), DT, gain=0.0)
    with pytest.raises(ValueError, match="target must be 3 finite numbers"):
        servo_velocity(head, np.array([0, 0]), np.zeros(2), DT)


def test_follow_first_keeps_the_oldest_person():
    policy = FollowFirst()
    assert policy.select(0.0, _people([])) is None
    assert policy.select(0.0, _people([3, 5])) == 3
    assert policy.select(5.0, _people([2, 3, 5])) == 3  # keeps its choice
    assert policy.select(6.0, _people([5, 7])) == 5  # the oldest remaining one


def test_jump_policy_changes_person_every_period():
    policy = JumpPolicy(3.0)
    people = _people([1, 2, 4])
    chosen = [policy.select(t, people) for t in np.arange(0, 12.01, 0.1)]
    changes = [k for k in range(1, len(chosen)) if chosen[k] != chosen[k - 1]]
    np.testing.assert_allclose(np.array(changes) * 0.1, [3.0, 6.0, 9.0, 12.0], atol=1e-9)
    assert chosen[0] == 1 and chosen[31] == 2 and chosen[61] == 4 and chosen[91] == 1
    assert policy.select(12.5, _people([4])) == 4
    with pytest.raises(ValueError, match="period_s must be a positive number"):
        JumpPolicy(0)


def test_registry_and_visual_servo(head):
    assert set(SERVO_POLICIES) == {"follow", "jump"}
    assert isinstance(make_policy("follow"), FollowFirst)
    with pytest.raises(ValueError, match="policy must be one of"):
        make_policy("wander")
    servo = VisualServo(head, make_policy("follow"), gain=0.5)
    cmd = servo.command(0.0, _people([2], [[0.3, 0.0, 2.0]]), np.zeros(2))
    assert cmd.target_id == 2 and cmd.velocity[0] < 0  # turn right, towards the person
    assert servo.command(0.0, _people([]), np.zeros(2)).target_id == -1
