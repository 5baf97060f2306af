"""Tests of avtrack.simulate.detections: exact boxes without noise, miss and false-alarm
rates, occlusion (hand-computed union areas), out-of-view people, determinism by seed and
appearance descriptors."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.io.camera import PinholeCamera
from avtrack.simulate.detections import (
    DetectorConfig,
    SimulatedDetections,
    occluded_fraction,
    simulate_detections,
)

CAMERA = PinholeCamera.from_fov(70.0, 640, 480, [0.0, 0.0, 1.5])  # looking along +x
EXACT = DetectorConfig(
    miss_rate=0.0, false_alarm_rate=0.0, centre_noise=0.0, size_noise=0.0, occlusion_threshold=1.0
)


def walkers(n_t: int = 40) -> np.ndarray:
    """Three people walking across the view at different depths, one absent at times."""
    s = np.linspace(0.0, 1.0, n_t)
    pos = np.stack(
        [
            np.column_stack([np.full(n_t, 2.5), -1.5 + 3.0 * s, np.full(n_t, 1.6)]),
            np.column_stack([np.full(n_t, 4.0), 1.5 - 3.0 * s, np.full(n_t, 1.7)]),
            np.column_stack([3.0 + s, np.full(n_t, 0.4), np.full(n_t, 1.5)]),
        ],
        axis=1,
    )
    pos[:10, 2] = np.nan  # person 3 enters at frame 11
    return pos


def test_zero_noise_detections_equal_ground_truth():
    out = simulate_detections(CAMERA, walkers(), np.random.default_rng(0), EXACT)
    assert isinstance(out, SimulatedDetections)
    assert np.all(out.det_person > 0) and len(out.detections) == len(out.gt)
    gt = {(f, i): b for f, i, b in zip(out.gt.frames, out.gt.ids, out.gt.boxes, strict=True)}
    got = {
        (f, i): b
        for f, i, b in zip(
            out.detections.frames, out.det_person, out.detections.boxes, strict=True
        )
    }
    assert gt.keys() == got.keys()
    for key, box in gt.items():
        np.testing.assert_array_equal(got[key], box)
    assert not any(i == 3 and f <= 10 for f, i in gt)  # absent person
    np.testing.assert_array_equal(out.detections.ids, -1)
    assert out.detections.extra.shape == (len(out.detections), 3)
    np.testing.assert_array_equal(out.gt.scores, 1.0)
    np.testing.assert_array_equal(out.gt.extra[:, 0], 1.0)
    assert np.all((out.gt.extra[:, 1] >= 0) & (out.gt.extra[:, 1] <= 1))
    assert np.all((out.detections.scores > 0) & (out.detections.scores <= 1))
    # Within a frame, detections come by decreasing score.
    for sl in out.detections.frame_slices():
        assert np.all(np.diff(out.detections.scores[sl]) <= 0)


def test_miss_and_false_alarm_rates():
    n_t = 4000
    pos = np.tile([[3.0, 0.0, 1.6]], (n_t, 1, 1))
    cfg = DetectorConfig(miss_rate=0.1, false_alarm_rate=0.3)
    out = simulate_detections(CAMERA, pos, np.random.default_rng(1), cfg)
    n_true = int(np.sum(out.det_person == 1))
    n_fa = int(np.sum(out.det_person == -1))
    # Binomial(4000, 0.9): sd 19; Poisson(1200): sd 35 — 4 sd tolerances.
    assert abs(n_true - 0.9 * n_t) < 4 * np.sqrt(n_t * 0.09)
    assert abs(n_fa - 0.3 * n_t) < 4 * np.sqrt(0.3 * n_t)
    fa = out.detections.boxes[out.det_person == -1]
    assert np.all(fa[:, :2] >= 0)
    assert np.all(fa[:, 0] + fa[:, 2] <= 640) and np.all(fa[:, 1] + fa[:, 3] <= 480)
    # Plausible head sizes: a 0.18 m head between 1 and 6 m away.
    f = CAMERA.fx
    assert np.all((fa[:, 2] >= f * 0.18 / 6 - 1e-9) & (fa[:, 2] <= f * 0.18 / 1 + 1e-9))
    # False alarms score lower on average.
    assert (
        out.detections.scores[out.det_person == -1].mean()
        < out.detections.scores[out.det_person == 1].mean() - 0.2
    )


def test_person_fully_behind_another_is_not_detected():
    pos = np.array([[[2.0, 0.0, 1.6], [4.0, 0.0, 1.6], [3.0, 0.6, 1.6]]])
    cfg = DetectorConfig(miss_rate=0.0, false_alarm_rate=0.0)
    out = simulate_detections(CAMERA, pos, np.random.default_rng(2), cfg)
    assert set(out.det_person.tolist()) == {1, 3}
    vis = dict(zip(out.gt.ids.tolist(), out.gt.extra[:, 1].tolist(), strict=True))
    assert vis[2] == pytest.approx(0.0, abs=1e-12)
    assert vis[1] == 1.0 and vis[3] == 1.0


def test_partial_occlusion_visibility():
    # Person 2 twice as far, shifted so that person 1 covers exactly the left half of it.
    # Box 1 (depth 2): width fx*0.18/2; box 2 (depth 4): width fx*0.18/4. Shift person 2 so
    # that its centre is on box 1's right edge: u2 = cx + fx*0.09/2.
    f = CAMERA.fx
    y2 = -(f * 0.09 / 2) * 4 / f  # camera x is -room y
    pos = np.array([[[2.0, 0.0, 1.5], [4.0, y2, 1.5]]])
    out = simulate_detections(CAMERA, pos, np.random.default_rng(0), EXACT)
    vis = dict(zip(out.gt.ids.tolist(), out.gt.extra[:, 1].tolist(), strict=True))
    assert vis[2] == pytest.approx(0.5, abs=1e-9)
    cfg = DetectorConfig(miss_rate=0.0, false_alarm_rate=0.0, occlusion_threshold=0.4)
    out = simulate_detections(CAMERA, pos, np.random.default_rng(0), cfg)
    assert out.det_person.tolist() == [1]


def test_occluded_fraction_hand_cases():
    boxes = np.array([[0, 0, 10, 10], [5, 0, 10, 10], [0, 0, 20, 10], [100, 100, 5, 5]], float)
    depth = np.array([1.0, 2.0, 3.0, 0.5])
    # B is half under A; C (20 x 10) is under A ∪ B = [0, 15] x [0, 10]; D is apart.
    np.testing.assert_allclose(occluded_fraction(boxes, depth), [0.0, 0.5, 0.75, 0.0])
    # Overlapping occluders are not double counted; equal depths do not occlude.
    boxes = np.array([[0, 0, 4, 4], [2, 2, 4, 4], [1, 1, 4, 4]], float)
    np.testing.assert_allclose(
        occluded_fraction(boxes, np.array([1.0, 1.0, 2.0])), [0.0, 0.0, (9 + 9 - 4) / 16]
    )
    assert occluded_fraction(np.zeros((0, 4)), np.zeros(0)).shape == (0,)


def test_out_of_view_people_are_absent():
    pos = np.array([[[3.0, 0.0, 1.6], [-2.0, 0.0, 1.6], [1.0, 8.0, 1.6]]] * 5)
    out = simulate_detections(CAMERA, pos, np.random.default_rng(3), EXACT)
    assert set(out.gt.ids.tolist()) == {1}
    assert set(out.det_person.tolist()) == {1}


def test_a_sub_pixel_sliver_at_the_edge_is_not_seen(tmp_path):
    """A head cut by the image's edge to a box under a pixel wide is in neither the ground
    truth nor the detections (MOTChallenge files would write it as 0 pixels wide, which
    readers refuse); one a few pixels wide is in both, and the files read back."""
    from avtrack.io.mot import read_mot, write_mot
    from avtrack.simulate.detections import MIN_BOX_PX

    size = DetectorConfig().head_size

    def width(y: float) -> float:
        b = CAMERA.head_box(np.array([[3.0, y, 1.6]]), size)[0]
        return 0.0 if np.isnan(b[2]) else float(b[2])

    lo, hi = 0.0, 5.0  # the box's width shrinks to nothing as the head leaves the view
    for _ in range(60):  # bisection for a box 0.3 px wide
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if width(mid) > 0.3 else (lo, mid)
    y_sliver = lo
    assert 0.0 < width(y_sliver) < MIN_BOX_PX
    for y, expect in ((y_sliver, False), (y_sliver - 0.05, True)):
        out = simulate_detections(CAMERA, np.array([[[3.0, y, 1.6]]] * 3),
                                  np.random.default_rng(0), EXACT)
        assert (len(out.gt) > 0) is expect and (out.det_person.size > 0) is expect
        write_mot(tmp_path / "gt.txt", out.gt)
        write_mot(tmp_path / "det.txt", out.detections)
        assert len(read_mot(tmp_path / "gt.txt", kind="gt")) == len(out.gt)
        assert len(read_mot(tmp_path / "det.txt", kind="det")) == len(out.detections)


def test_same_seed_same_output():
    cfg = DetectorConfig(false_alarm_rate=1.0)
    a = simulate_detections(CAMERA, walkers(), np.random.default_rng(7), cfg)
    b = simulate_detections(CAMERA, walkers(), np.random.default_rng(7), cfg)
    c = simulate_detections(CAMERA, walkers(), np.random.default_rng(8), cfg)
    for x, y in ((a.detections, b.detections), (a.gt, b.gt)):
        for field in ("frames", "ids", "boxes", "scores", "extra"):
            np.testing.assert_array_equal(getattr(x, field), getattr(y, field))
    np.testing.assert_array_equal(a.appearance, b.appearance)
    np.testing.assert_array_equal(a.det_person, b.det_person)
    assert len(a.detections) != len(c.detections) or not np.array_equal(
        a.detections.boxes, c.detections.boxes
    )


def test_appearance_separates_people():
    cfg = DetectorConfig(miss_rate=0.0, false_alarm_rate=0.5)
    out = simulate_detections(CAMERA, walkers(60), np.random.default_rng(4), cfg)
    app, who = out.appearance, out.det_person
    assert app.shape == (len(out.detections), 64)
    np.testing.assert_allclose(np.linalg.norm(app, axis=1), 1.0)
    sim = app @ app.T
    same = (who[:, None] == who[None, :]) & (who[:, None] > 0) & ~np.eye(len(who), dtype=bool)
    diff = (who[:, None] != who[None, :]) & (who[:, None] > 0) & (who[None, :] > 0)
    assert sim[same].mean() > 0.85
    assert abs(sim[diff].mean()) < 0.3
    assert sim[same].min() > sim[diff].max()


def test_bad_arguments():
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match=r"head_positions must have shape \(T, P, 3\)"):
        simulate_detections(CAMERA, np.zeros((3, 3)), rng)
    with pytest.raises(TypeError, match=r"rng must be a numpy\.random\.Generator"):
        simulate_detections(CAMERA, np.zeros((1, 1, 3)), 0)
    with pytest.raises(ValueError, match=r"miss_rate must be in \[0, 1\]"):
        DetectorConfig(miss_rate=1.5)
    with pytest.raises(ValueError, match="false_alarm_rate must be a finite number >= 0"):
        DetectorConfig(false_alarm_rate=-1.0)
    with pytest.raises(ValueError, match="appearance_dim must be an integer >= 1"):
        DetectorConfig(appearance_dim=0)
