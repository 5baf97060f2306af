"""Simulated loudspeaker calibration and the per-sub-band mapping training."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.audio.arrays import builtin_array
from avtrack.io.camera import PinholeCamera
from avtrack.io.scenario import validate_scenario
from avtrack.simulate.acoustics import Room
from avtrack.simulate.calibration import (
    calibration_points,
    horizontal_array,
    train_mapping,
)
from tests.av.scenes import walkout


def test_calibration_points_cover_the_image_inside_the_room():
    room = Room(np.array([5.0, 4.0, 2.7]), 0.3)
    cam = PinholeCamera.from_fov(90.0, 640, 480, np.array([2.5, 0.5, 1.35]), 90.0)
    pts = calibration_points(cam, room, 60, np.random.default_rng(0))
    assert pts.shape == (60, 3)
    assert room.contains(pts, margin=0.29).all()
    uv, depth = cam.project(pts)
    assert np.all(depth > 0)
    assert uv[:, 0].min() < 80 and uv[:, 0].max() > 560  # spread over the image
    assert uv[:, 1].min() < 80 and uv[:, 1].max() > 400
    with pytest.raises(ValueError, match="n_positions"):
        calibration_points(cam, room, 0, np.random.default_rng(0))


def test_horizontal_arrays():
    assert horizontal_array(builtin_array("nao4"))
    assert not horizontal_array(builtin_array("nao12"))


def test_trained_mapping_layout():
    _, mapping, _ = walkout()
    assert mapping.meta["axes"] == "x"  # nao4 is a horizontal array
    assert mapping.meta["n_mics"] == 4 and mapping.feature_dim == 2 * 8 * 3
    assert mapping.n_bands == 16 and mapping.n_components == 4
    assert np.all(np.linalg.eigvalsh(mapping.sigma) > 0)


def test_train_mapping_checks_arguments():
    from avtrack.simulate.calibration import CalibrationSet

    empty = CalibrationSet(
        np.zeros((0, 2)), np.zeros((0, 16, 4)), np.zeros((0, 16), bool), np.zeros((0, 3))
    )
    with pytest.raises(ValueError, match="empty"):
        train_mapping(empty)
    one = CalibrationSet(
        np.zeros((1, 2)), np.zeros((1, 16, 4)), np.ones((1, 16), bool), np.zeros((1, 3))
    )
    with pytest.raises(ValueError, match="axes"):
        train_mapping(one, axes="z")


def test_scene_mapping_is_trained_once_per_geometry(tmp_path, monkeypatch):
    """The second request for the same geometry reads the cache (no calibration); another
    camera is another geometry."""
    import copy

    from avtrack.simulate import calibration
    from tests.av.scenes import walkout_scenario

    scenario = validate_scenario(walkout_scenario())
    first, cached = calibration.cached_scene_mapping(scenario, None, 8, 2, 5, tmp_path)
    assert not cached and len(list(tmp_path.glob("*.npz"))) == 1

    def no_calibration(*args, **kwargs):
        raise AssertionError("calibrated again")

    monkeypatch.setattr(calibration, "simulate_calibration", no_calibration)
    again, cached = calibration.cached_scene_mapping(scenario, None, 8, 2, 5, tmp_path)
    assert cached and np.array_equal(again.lmat, first.lmat)
    other = copy.deepcopy(scenario)
    other["camera"]["hfov_deg"] = 70.0
    with pytest.raises(AssertionError, match="calibrated again"):
        calibration.cached_scene_mapping(other, None, 8, 2, 5, tmp_path)
