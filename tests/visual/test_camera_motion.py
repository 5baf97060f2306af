"""Camera motion between frames and its compensation in the visual tracker."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.io.mot import MOTData
from avtrack.visual.camera_motion import IDENTITY, CameraMotion, apply_motion, frame_motions
from avtrack.visual.ovbt import OVBTConfig, track_mot


def _texture(seed: int, h: int = 240, w: int = 320) -> np.ndarray:
    """A textured BGR image: smoothed noise (corners everywhere)."""
    import cv2

    rng = np.random.default_rng(seed)
    img = cv2.GaussianBlur(rng.uniform(0, 255, (h, w)).astype(np.float32), (0, 0), 2.0)
    img = cv2.normalize(img, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
    return np.repeat(img[:, :, None], 3, axis=2)


def _window(img: np.ndarray, x0: int, y0: int, w: int = 240, h: int = 180) -> np.ndarray:
    return np.ascontiguousarray(img[y0:y0 + h, x0:x0 + w])


@pytest.mark.parametrize("downscale", [1, 2])
def test_a_shifted_view_gives_its_translation(downscale):
    img = _texture(1)
    est = CameraMotion(downscale=downscale)
    assert est.push(_window(img, 40, 30)) is IDENTITY  # the first frame
    m = est.push(_window(img, 47, 26))  # the window moves right 7 and up 4: content -7, +4
    np.testing.assert_allclose(m[:, 2], [-7.0, 4.0], atol=0.3)
    np.testing.assert_allclose(m[:, :2], np.eye(2), atol=0.01)


def test_a_still_camera_and_a_blank_view():
    img = _texture(2)
    motions = list(frame_motions([_window(img, 40, 30)] * 3, [None] * 3))
    assert all(m is IDENTITY for m in motions)  # a still camera: below min_shift
    blank = np.full((180, 240, 3), 128, dtype=np.uint8)
    est = CameraMotion()
    est.push(blank)
    assert est.push(blank) is IDENTITY  # no corner: no compensation rather than a wrong one


def test_corners_inside_the_detection_boxes_are_not_used():
    """A person (a textured box) walking across a still background does not move the camera:
    the corners inside the detection box are left out."""
    bg = _texture(3)[:180, :240].copy()
    person = _texture(4, 80, 40)
    est = CameraMotion()
    for k in range(4):
        frame = bg.copy()
        x = 60 + 12 * k
        frame[50:130, x:x + 40] = person
        m = est.push(frame, np.array([[x - 2.0, 48.0, 44.0, 84.0]]))
        assert np.abs(m[:, 2]).max() < 0.3


def test_apply_motion_maps_centres_and_scales_sizes_and_velocities():
    mu = np.array([[100.0, 50.0, 20.0, 40.0, 1.0, -2.0]])
    shift = np.array([[1.0, 0.0, 5.0], [0.0, 1.0, -3.0]])
    np.testing.assert_allclose(apply_motion(shift, mu), [[105.0, 47.0, 20.0, 40.0, 1.0, -2.0]])
    zoom = np.array([[2.0, 0.0, 0.0], [0.0, 2.0, 0.0]])
    np.testing.assert_allclose(apply_motion(zoom, mu), [[200.0, 100.0, 40.0, 80.0, 2.0, -4.0]])
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])  # a quarter turn
    np.testing.assert_allclose(apply_motion(turn, mu)[0, [0, 1, 4, 5]], [-50.0, 100.0, 2.0, 1.0])


def _shaken_scene(seed: int, n: int = 40) -> tuple[MOTData, np.ndarray]:
    """Three people standing 45 px apart, seen by a camera that jumps up to 25 px a frame:
    their detections, and the camera's motion into each frame."""
    rng = np.random.default_rng(seed)
    offset = np.cumsum(rng.uniform(-25, 25, n))  # the camera's position
    rows = []
    for f in range(n):
        for p in range(3):
            rows.append((f + 1, -1, 200 + 45 * p - offset[f] + rng.normal(0, 1.0),
                         100 + rng.normal(0, 1.0), 30.0, 80.0, 0.9))
    a = np.array(rows)
    dets = MOTData(a[:, 0], a[:, 1], a[:, 2:6], a[:, 6])
    motion = np.repeat(IDENTITY[None], n, axis=0).copy()
    motion[1:, 0, 2] = -np.diff(offset)
    return dets, motion


def test_the_camera_motion_keeps_people_apart_under_a_shaking_camera():
    dets, motion = _shaken_scene(5)
    size = (800, 400)
    still = track_mot(dets, image_size=size, motion=None)
    moved = track_mot(dets, image_size=size, motion=motion)
    assert np.unique(moved.ids).size == 3  # one identity each, every frame
    assert np.all(np.bincount(moved.frames.astype(int))[1:] == 3)
    assert np.unique(still.ids).size > 3  # without it, identities break
    off = track_mot(dets, None, OVBTConfig(compensate_camera=False), size, motion=motion)
    np.testing.assert_array_equal(off.ids, still.ids)  # the option switches it off


def test_bad_motion_is_refused():
    dets, _ = _shaken_scene(6, 5)
    with pytest.raises(ValueError, match=r"motion must be \(n_frames, 2, 3\)"):
        track_mot(dets, motion=np.zeros((5, 3, 3)))
    with pytest.raises(ValueError, match="downscale must be an integer >= 1"):
        CameraMotion(downscale=0)


def test_a_person_who_appears_under_a_shaking_camera_is_born():
    """The birth pool's older detections are read where the camera sees them now: with the
    camera jumping 40 px back and forth every frame, a person who appears at frame 12 is born
    at once (three detections that no constant velocity fits unless the jumps are undone)."""
    n = 30
    offset = np.where(np.arange(n) % 2 == 0, 0.0, 40.0)  # the camera's position
    rng = np.random.default_rng(3)
    rows = []
    for f in range(n):
        for x in [200.0, 245.0, 290.0] + ([420.0] if f >= 11 else []):
            rows.append((f + 1, -1, x - offset[f] + rng.normal(0, 1.0),
                         100 + rng.normal(0, 1.0), 30.0, 80.0, 0.9))
    a = np.array(rows)
    dets = MOTData(a[:, 0], a[:, 1], a[:, 2:6], a[:, 6])
    motion = np.repeat(IDENTITY[None], n, axis=0).copy()
    motion[1:, 0, 2] = -np.diff(offset)
    res = track_mot(dets, image_size=(900, 400), motion=motion)
    ids = np.unique(res.ids)
    assert ids.size == 4
    assert sorted(int(res.frames[res.ids == i].min()) for i in ids) == [1, 1, 1, 12]
