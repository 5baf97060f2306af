"""Trajectories: interpolation, presence, generators."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avtrack.simulate.trajectory import (
    Trajectory,
    from_azimuth_track,
    random_walk,
    seated,
    waypoint_trajectory,
)


def test_waypoints_interpolate_linearly_and_clamp():
    traj = waypoint_trajectory([[0, 0, 0, 1], [2, 2, 0, 1], [4, 2, 4, 1]])
    got = traj.position([-1.0, 1.0, 3.0, 9.0])
    np.testing.assert_allclose(got, [[0, 0, 1], [1, 0, 1], [2, 2, 1], [2, 4, 1]])


def test_presence_masks_positions():
    traj = Trajectory([0.0, 10.0], [[0, 0, 1], [10, 0, 1]], present=[[1, 3], [5, 6]])
    t = np.array([0.5, 1.0, 2.9, 3.0, 5.5, 7.0])
    np.testing.assert_array_equal(traj.is_present(t), [False, True, True, False, True, False])
    pos = traj.sample(t)
    assert np.isnan(pos[0]).all() and np.isnan(pos[3]).all()
    np.testing.assert_allclose(pos[1], [1, 0, 1])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"times": [0, 0], "positions": [[0, 0, 0], [1, 1, 1]]}, "strictly increasing"),
        ({"times": [0, 1], "positions": [[0, 0, 0]]}, "positions"),
        ({"times": [0], "positions": [[0, 0, np.nan]]}, "finite"),
        ({"times": [0], "positions": [[0, 0, 0]], "present": [[2, 1]]}, "end > start"),
    ],
)
def test_bad_trajectories_raise(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Trajectory(**kwargs)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000), speed=st.floats(0.2, 2.0))
def test_random_walk_stays_in_area_at_walking_speed(seed, speed):
    area = np.array([[1.0, 4.0], [0.5, 3.0]])
    traj = random_walk(np.random.default_rng(seed), 20.0, area, speed=speed)
    assert traj.times[-1] >= 20.0
    xy = traj.positions[:, :2]
    assert np.all(xy >= area[:, 0] - 1e-12) and np.all(xy <= area[:, 1] + 1e-12)
    v = np.linalg.norm(np.diff(traj.positions, axis=0), axis=1) / np.diff(traj.times)
    assert np.all(v <= 1.2 * speed + 1e-9)


def test_seated_sway_is_small():
    traj = seated(np.random.default_rng(0), 30.0, np.array([2.0, 3.0, 1.2]), sway=0.03)
    dev = np.linalg.norm(traj.positions - [2.0, 3.0, 1.2], axis=1)
    assert dev.max() <= 0.03 * np.sqrt(2) + 1e-12
    assert dev.max() > 0.005


def test_azimuth_track_follows_the_recorded_angles():
    frames = np.arange(500)
    az = np.rad2deg(np.angle(np.exp(1j * np.deg2rad(170 + 0.5 * frames))))  # wraps at 180
    centre = np.array([3.0, 4.0, 1.2])
    traj = from_azimuth_track(az, 0.008, centre, yaw_deg=30.0, radius=2.0, height=0.3)
    rel = traj.positions - centre
    np.testing.assert_allclose(np.linalg.norm(rel[:, :2], axis=1), 2.0)
    np.testing.assert_allclose(rel[:, 2], 0.3)
    got = np.rad2deg(np.arctan2(rel[:, 1], rel[:, 0])) - 30.0
    want = az[np.round(traj.times / 0.008).astype(int)]
    np.testing.assert_allclose(np.angle(np.exp(1j * np.deg2rad(got - want))), 0, atol=1e-9)
    # knots are close enough that a 1 m/s walker moves under 5 cm between them
    assert np.diff(traj.times).max() <= 0.05


def test_azimuth_track_window_and_errors():
    az = np.zeros(100)
    traj = from_azimuth_track(az, 0.01, np.zeros(3), start_s=0.2, duration=0.5, decimate=1)
    assert traj.times[0] == 0 and traj.times[-1] == pytest.approx(0.5)
    with pytest.raises(ValueError, match="leaves no frames"):
        from_azimuth_track(az, 0.01, np.zeros(3), start_s=5.0)
    with pytest.raises(ValueError, match="finite"):
        from_azimuth_track(np.array([0.0, np.nan]), 0.01, np.zeros(3))
