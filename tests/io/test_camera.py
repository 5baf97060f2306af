"""Tests of avtrack.io.camera: hand-computed projections, P = K[R|t] against project(),
head boxes, the view frustum (Hypothesis) and JSON validation."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avtrack.errors import InputError
from avtrack.io.camera import PinholeCamera


def cam(**kw) -> PinholeCamera:
    args = dict(
        fx=500.0,
        fy=500.0,
        cx=320.0,
        cy=240.0,
        width=640,
        height=480,
        position=[0.0, 0.0, 1.5],
        yaw_deg=0.0,
        pitch_deg=0.0,
    )
    args.update(kw)
    return PinholeCamera(**args)


def test_hand_computed_projection():
    c = cam()
    # Looking along +x: room (X, Y, Z) -> camera (x, y, z) = (-(Y - 0), -(Z - 1.5), X).
    uv, depth = c.project(np.array([[2.0, -0.4, 1.7], [4.0, 0.0, 1.5]]))
    # u = 500 * 0.4 / 2 + 320 = 420, v = 500 * (-0.2) / 2 + 240 = 190
    np.testing.assert_allclose(uv, [[420.0, 190.0], [320.0, 240.0]], atol=1e-12)
    np.testing.assert_allclose(depth, [2.0, 4.0])


def test_yaw_and_pitch_rotate_the_optical_axis():
    c = cam(yaw_deg=90.0)  # looking along +y; right is +x
    uv, depth = c.project(np.array([[0.5, 2.0, 1.5]]))
    np.testing.assert_allclose(depth, [2.0], atol=1e-12)
    np.testing.assert_allclose(uv, [[320.0 + 500 * 0.25, 240.0]], atol=1e-9)
    up = cam(pitch_deg=30.0)
    axis = np.array([[math.cos(math.radians(30)), 0.0, 1.5 + math.sin(math.radians(30))]])
    uv, depth = up.project(axis)
    np.testing.assert_allclose(uv, [[320.0, 240.0]], atol=1e-9)
    np.testing.assert_allclose(depth, [1.0])
    # Elevation 56 deg (above the 30 deg axis) projects above the principal point, 27 deg below.
    uv, _ = up.project(np.array([[1.0, 0.0, 3.0], [1.0, 0.0, 2.0]]))
    assert uv[0, 1] < 240.0 < uv[1, 1]


def test_rotation_is_orthonormal_right_handed():
    for yaw, pitch in [(0, 0), (37, -12), (-150, 80), (90, -90)]:
        r = cam(yaw_deg=yaw, pitch_deg=pitch).R
        np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(r) == pytest.approx(1.0)


def test_projection_matrix_matches_project():
    c = cam(position=[0.3, -1.0, 1.2], yaw_deg=25.0, pitch_deg=-10.0, cx=300.0, fy=520.0)
    rng = np.random.default_rng(0)
    pts = rng.uniform([1, -3, 0], [6, 3, 2.5], (50, 3))
    uv, depth = c.project(pts)
    hom = c.projection_matrix() @ np.column_stack([pts, np.ones(len(pts))]).T  # (3, N)
    front = depth > 0
    np.testing.assert_allclose((hom[:2] / hom[2]).T[front], uv[front], rtol=1e-10)
    np.testing.assert_allclose(hom[2], depth, rtol=1e-10)


def test_points_behind_camera_have_nan_uv():
    uv, depth = cam().project(np.array([[-1.0, 0.0, 1.5], [0.0, 1.0, 1.5]]))
    assert np.all(np.isnan(uv))
    assert depth[0] == pytest.approx(-1.0) and depth[1] == pytest.approx(0.0)
    assert not cam().in_view(np.array([[-1.0, 0.0, 1.5]]))[0]


def test_from_fov():
    c = PinholeCamera.from_fov(90.0, 640, 480, [0, 0, 1])
    assert c.fx == pytest.approx(320.0) and c.fy == pytest.approx(320.0)
    assert (c.cx, c.cy) == (320.0, 240.0)
    # The edge of a 90-degree field of view is at 45 degrees.
    uv, _ = c.project(np.array([[1.0, -1.0, 1.0]]))
    np.testing.assert_allclose(uv, [[640.0, 240.0]], atol=1e-9)


def test_head_box_centre_and_size():
    c = cam()
    heads = np.array([[2.0, 0.1, 1.6], [4.0, 0.1, 1.6], [3.0, -0.5, 1.4]])
    boxes = c.head_box(heads)
    uv, depth = c.project(heads)
    centres = boxes[:, :2] + boxes[:, 2:] / 2
    np.testing.assert_allclose(centres, uv, atol=1e-9)
    np.testing.assert_allclose(boxes[:, 2], 500 * 0.18 / depth)
    np.testing.assert_allclose(boxes[:, 3], 500 * 0.24 / depth)
    assert boxes[0, 2] / boxes[1, 2] == pytest.approx(2.0)  # size ∝ 1/depth


def test_head_box_clipped_or_nan_outside():
    c = cam()
    # Centre exactly on the left image border (u = 0): half the box remains.
    x = 2.0
    y_edge = 320.0 * x / 500.0
    boxes = c.head_box(
        np.array([[x, y_edge, 1.5], [x, 5.0, 1.5], [-2.0, 0.0, 1.5], [np.nan, np.nan, np.nan]])
    )
    full_w = 500 * 0.18 / x
    np.testing.assert_allclose(
        boxes[0], [0.0, 240 - 500 * 0.12 / x, full_w / 2, 500 * 0.24 / x], atol=1e-9
    )
    assert np.all(np.isnan(boxes[1:]))


def test_in_view_margin():
    c = cam()
    p = np.array([[2.0, -0.2, 1.5]])  # u = 370
    assert c.in_view(p)[0]
    assert c.in_view(p, margin=-10.0)[0]
    assert not c.in_view(np.array([[2.0, -1.3, 1.5]]))[0]  # u = 645
    assert c.in_view(np.array([[2.0, -1.3, 1.5]]), margin=-10)[0]
    assert not c.in_view(np.array([[2.0, -1.2, 1.5]]), margin=30)[0]  # u = 620 > 640 - 30


@settings(max_examples=150, deadline=None)
@given(
    yaw=st.floats(-180, 180),
    pitch=st.floats(-60, 60),
    hfov=st.floats(30, 120),
    point=st.tuples(*[st.floats(-10, 10)] * 3),
)
def test_in_view_iff_inside_frustum(yaw, pitch, hfov, point):
    c = PinholeCamera.from_fov(hfov, 640, 480, [0.5, -0.2, 1.2], yaw, pitch)
    d = np.asarray(point) - c.position
    # The frustum from first principles: angles of the ray against the forward axis.
    psi, th = math.radians(yaw), math.radians(pitch)
    forward = np.array([math.cos(th) * math.cos(psi), math.cos(th) * math.sin(psi), math.sin(th)])
    right = np.array([math.sin(psi), -math.cos(psi), 0.0])
    up = np.cross(right, forward)
    z = d @ forward
    tan_h = math.tan(math.radians(hfov) / 2)
    tan_v = tan_h * 480 / 640
    if z > 1e-6:
        sx, sy = abs(d @ right) / z, abs(d @ up) / z
        if abs(sx - tan_h) < 1e-9 or abs(sy - tan_v) < 1e-9:
            return  # on the boundary: either answer is right
        inside = sx <= tan_h and sy <= tan_v
    else:
        inside = False
    assert bool(c.in_view(np.array([point]))[0]) == inside


def test_json_round_trip():
    c = cam(position=[1.0, 2.0, 3.0], yaw_deg=-30.0, pitch_deg=5.0)
    d = json.loads(json.dumps(c.to_json()))
    back = PinholeCamera.from_json(d)
    assert back == c
    np.testing.assert_array_equal(back.R, c.R)


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"fx": None}, "missing field"),
        ({"fx": "500"}, "fx must be a number"),
        ({"fx": -1.0}, "fx must be a finite number > 0"),
        ({"width": 0}, "width must be an integer > 0"),
        ({"width": 640.5}, "width must be an integer > 0"),
        ({"position": [0, 0]}, "position must be a list of 3 numbers"),
        ({"pitch_deg": 95.0}, r"pitch_deg must be in \[-90, 90\]"),
    ],
)
def test_from_json_rejects_bad_fields(tmp_path, change, match):
    d = cam().to_json()
    for k, v in change.items():
        if v is None:
            del d[k]
        else:
            d[k] = v
    path = tmp_path / "camera.json"
    with pytest.raises(InputError, match=match) as err:
        PinholeCamera.from_json(d, path)
    assert str(path) in str(err.value)


def test_constructor_rejects_bad_arguments():
    with pytest.raises(ValueError, match="fy must be a finite number > 0"):
        cam(fy=float("nan"))
    with pytest.raises(ValueError, match="position must be 3 finite numbers"):
        cam(position=[0, 0, np.inf])
    with pytest.raises(ValueError, match="hfov_deg must be in"):
        PinholeCamera.from_fov(180.0, 640, 480, [0, 0, 0])
    with pytest.raises(ValueError, match="points must have shape"):
        cam().project(np.zeros((4, 2)))
    with pytest.raises(ValueError, match=r"^PinholeCamera: cx must be finite, got nan"):
        cam(cx=float("nan"))
    with pytest.raises(ValueError, match=r"^PinholeCamera: height must be an integer > 0"):
        cam(height=True)


def test_camera_file_names_an_unknown_field_and_the_one_meant(tmp_path):
    from avtrack.errors import InputError
    from avtrack.io.camera import read_camera_file

    good = "fx: 500\nfy: 500\ncx: 320\ncy: 240\nwidth: 640\nheight: 480\nposition: [0, 0, 0.05]\n"
    path = tmp_path / "camera.yaml"
    path.write_text(good + "yaw: 10\npitch_deg: 0\n")
    with pytest.raises(InputError, match=r"unknown field\(s\) 'yaw' \(did you mean 'yaw_deg'\?\)"):
        read_camera_file(path)
    path.write_text(good + "yaw_deg: 10\npitch_deg: 0\n")
    assert read_camera_file(path).yaw_deg == 10.0
