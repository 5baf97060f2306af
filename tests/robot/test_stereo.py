"""Rectified stereo pair: projection (eq. 3.39), triangulation (§3.2.5), face pairing."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.robot.stereo import StereoMatchConfig, StereoRig, match_stereo, stereo_faces


@pytest.fixture
def rig():
    return StereoRig.nao(baseline=0.1)


def test_nao_rig_is_vga_with_nao_field_of_view(rig):
    assert (rig.width, rig.height) == (640, 480)
    assert rig.fx == pytest.approx(320 / np.tan(np.radians(60.97 / 2)))
    np.testing.assert_allclose(rig.K, [[rig.fx, 0, 320], [0, rig.fy, 240]])


def test_triangulation_of_a_known_point(rig):
    x = np.array([[0.3, -0.2, 2.0], [-0.5, 0.1, 1.2], [0.0, 0.0, 6.0]])
    left, right = rig.project(x), rig.project(x, camera="right")
    np.testing.assert_allclose(left[:, 1], right[:, 1])  # rectified: same rows
    np.testing.assert_allclose(left[:, 0] - right[:, 0], rig.fx * 0.1 / x[:, 2])  # disparity
    np.testing.assert_allclose(rig.triangulate(left, right), x, rtol=0, atol=1e-12)
    # hand-computed: a point 2 m ahead on the axis has disparity f b / 2
    d = rig.fx * 0.1 / 2
    np.testing.assert_allclose(
        rig.triangulate([320 + d / 2, 240], [320 - d / 2, 240]),
        [[0.1 * (d / 2) / d, 0.0, 2.0]],
        atol=1e-12,
    )


def test_triangulation_covariance_is_the_propagated_pixel_noise(rig):
    x = np.array([[0.4, -0.3, 2.5]])
    left, right = rig.project(x), rig.project(x, camera="right")
    std = np.array([[1.5, 2.0]])
    cov = rig.triangulation_covariance(left, right, std, std)[0]
    eps = 1e-5
    cols = []  # numerical Jacobian wrt (u_L, v_L, u_R, v_R)
    for k in range(4):
        d = np.zeros(4)
        d[k] = eps
        lp, rp = left + d[:2], right + d[2:]
        lm, rm = left - d[:2], right - d[2:]
        cols.append((rig.triangulate(lp, rp) - rig.triangulate(lm, rm))[0] / (2 * eps))
    jac = np.column_stack(cols)
    expected = jac @ np.diag([1.5**2, 2.0**2, 1.5**2, 2.0**2]) @ jac.T
    np.testing.assert_allclose(cov, expected, rtol=1e-6)
    assert np.all(np.linalg.eigvalsh(cov) > 0)


@pytest.mark.parametrize(
    ("left", "right", "kwargs", "message"),
    [
        ([[300, 200], [310, 200]], [[290, 200]], {}, "left_xy has 2 points but right_xy has 1"),
        ([[300, 200]], [[305, 200]], {}, "point 0 has disparity u_L - u_R = -5"),
        (
            [[300, 200], [330, 200]],
            [[290, 200], [300, 230]],
            {"max_row_difference": 4},
            "point 1 violates the epipolar constraint",
        ),
        ([[300, np.nan]], [[290, 200]], {}, "left_xy must be finite"),
        ([[300, 200, 1]], [[290, 200, 1]], {}, r"left_xy must have shape \(M, 2\)"),
    ],
)
def test_inconsistent_stereo_input_is_rejected(rig, left, right, kwargs, message):
    with pytest.raises(ValueError, match=message):
        rig.triangulate(np.array(left, dtype=float), np.array(right, dtype=float), **kwargs)


def test_rig_rejects_bad_parameters():
    with pytest.raises(ValueError, match="baseline must be a finite number > 0"):
        StereoRig(500, 500, 320, 240, 640, 480, 0.0)
    with pytest.raises(ValueError, match="width must be an integer > 0"):
        StereoRig(500, 500, 320, 240, 640.5, 480, 0.1)
    with pytest.raises(ValueError, match=r"^StereoRig: fy must be a finite number > 0"):
        StereoRig(500, -1, 320, 240, 640, 480, 0.1)
    with pytest.raises(ValueError, match=r"^StereoRig: cy must be finite"):
        StereoRig(500, 500, 320, np.inf, 640, 480, 0.1)
    rig = StereoRig(500, 500, 320, 240, 640.0, 480, 0.1)
    assert rig == StereoRig(500.0, 500.0, 320.0, 240.0, 640, 480, 0.1)
    assert isinstance(rig.width, int) and isinstance(rig.cx, float)
    with pytest.raises(ValueError, match="points must have depth"):
        StereoRig.nao().image_jacobian([[0.0, 0.0, -1.0]])


def _face_boxes(rig, x, camera, size=(0.18, 0.24)):
    uv = rig.project(x, camera)
    wh = np.column_stack([rig.fx * size[0] / x[:, 2], rig.fy * size[1] / x[:, 2]])
    return np.column_stack([uv - wh / 2, wh])


def test_match_stereo_pairs_faces_and_ignores_distractors(rig):
    x = np.array([[-0.6, -0.2, 2.0], [0.5, -0.25, 2.4], [0.05, -0.3, 3.0]])
    left = _face_boxes(rig, x, "left")
    right = _face_boxes(rig, x, "right")[::-1]  # another order
    distractor = np.array([[100.0, 400.0, 40.0, 50.0]])  # nobody in the left image there
    pairs = match_stereo(rig, left, np.vstack([right, distractor]))
    np.testing.assert_array_equal(pairs, [[0, 2], [1, 1], [2, 0]])
    assert match_stereo(rig, left, np.zeros((0, 4))).shape == (0, 2)


def test_stereo_faces_recovers_positions_sizes_and_covariances(rig):
    x = np.array([[-0.6, -0.2, 2.0], [0.5, -0.25, 2.4]])
    left, right = _face_boxes(rig, x, "left"), _face_boxes(rig, x, "right")
    app = np.eye(2)
    faces = stereo_faces(rig, left, right, app, app)
    np.testing.assert_allclose(faces.positions, x, atol=1e-12)
    np.testing.assert_allclose(faces.sizes, left[:, 2:])
    np.testing.assert_allclose(faces.appearance, app)
    assert faces.cov.shape == (2, 5, 5)
    assert np.all(np.linalg.eigvalsh(faces.cov) > 0)
    # a face cut by the image border is dropped
    cut = left.copy()
    cut[0, 0] = 0.0
    assert len(stereo_faces(rig, cut, right)) == 1
    with pytest.raises(ValueError, match="left_appearance must have one row per box"):
        stereo_faces(rig, left, right, np.eye(3), None)
    with pytest.raises(ValueError, match="depth_range must be"):
        StereoMatchConfig(depth_range=(2.0, 1.0))
