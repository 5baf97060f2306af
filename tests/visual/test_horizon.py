"""The camera's pitch from the horizon of the heads it sees (``avtrack.visual.horizon``)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avtrack.io.camera import PinholeCamera
from avtrack.io.mot import MOTData
from avtrack.simulate.detections import simulate_detections
from avtrack.visual.horizon import Horizon, estimate_horizon, link_tracklets

FPS = 25.0


def _walkers(n_frames=500, heights=(1.55, 1.7, 1.2), still=False, near=(2.0, 3.0, 2.5),
             walk_m=3.5):
    """Head centres ``(T, 3, 3)`` (room frame, metres) of three people walking back and forth
    ``walk_m`` metres away from ``near`` in front of a camera at the origin looking along +x
    (one seated, ``heights``), or standing still there."""
    t = np.arange(n_frames) / FPS
    depth = np.asarray(near)[None, :] + (0.0 if still else 0.5 * walk_m) * (
        1.0 - np.cos(2.0 * math.pi * t[:, None] / 12.0 + np.array([0.0, 2.0, 4.0])))
    side = np.array([-0.6, 0.1, 0.7])[None, :] + 0.2 * np.sin(0.3 * t[:, None])
    return np.stack([depth, side * np.ones_like(depth),
                     np.broadcast_to(np.asarray(heights), depth.shape)], axis=-1)


def _camera(pitch_deg, height_m=1.45):
    return PinholeCamera.from_fov(70.0, 640, 480, np.array([0.0, 0.0, height_m]), 0.0,
                                  pitch_deg)


def test_pitch_of_a_horizon_row_hand_computed():
    hz = Horizon(row_px=100.0, row_std_px=4.0, n_tracklets=2, n_blocks=8)
    assert hz.pitch_deg(400.0, 140.0) == pytest.approx(math.degrees(math.atan(-0.1)))
    # d/dv atan((v - cy) / f) = 1 / (f (1 + t^2)), t = -0.1
    assert hz.pitch_std_deg(400.0, 140.0) == pytest.approx(
        math.degrees(4.0 / 400.0 / 1.01))


@pytest.mark.parametrize("pitch", [-15.0, -5.0, 0.0, 8.0])
def test_horizon_of_simulated_walkers_gives_the_pitch(pitch):
    """The simulator's head detections (noisy boxes, misses, false alarms) of three people
    walking in depth, one of them seated: the pitch within 1.5 degrees."""
    cam = _camera(pitch)
    sim = simulate_detections(cam, _walkers(), np.random.default_rng(3))
    hz = estimate_horizon(sim.detections, FPS, 480)
    assert hz is not None and hz.n_tracklets >= 2
    assert abs(hz.pitch_deg(cam.fy, cam.cy) - pitch) < 1.5
    assert 0.0 < hz.pitch_std_deg(cam.fy, cam.cy) < 1.5


def test_boxes_cut_by_the_image_edge_are_left_out(monkeypatch):
    """A camera 1.25 m high pitched 10 degrees down cuts the heads of people standing near it
    at the image's top: those boxes' rows and heights are the edge's, not the head's (kept,
    they put the pitch 3.3 degrees off; a simulated walkout that loses whole tracklets to the
    edge, 13 degrees)."""
    import avtrack.visual.horizon as horizon

    cam = PinholeCamera.from_fov(60.0, 640, 480, np.array([0.0, 0.0, 1.25]), 0.0, -10.0)
    people = _walkers(heights=(1.8, 1.85, 1.75), near=(1.2, 1.5, 2.0))
    sim = simulate_detections(cam, people, np.random.default_rng(4))
    assert np.mean(sim.detections.boxes[:, 1] <= 0.0) > 0.1
    hz = estimate_horizon(sim.detections, FPS, 480)
    assert hz is not None and abs(hz.pitch_deg(cam.fy, cam.cy) + 10.0) < 1.0
    monkeypatch.setattr(horizon, "EDGE_PX", -1e9)  # keep every box
    cut = estimate_horizon(sim.detections, FPS, 480)
    assert cut is not None and cut.pitch_deg(cam.fy, cam.cy) + 10.0 < -2.5


def test_people_standing_still_give_no_horizon():
    cam = _camera(-10.0)
    sim = simulate_detections(cam, _walkers(still=True), np.random.default_rng(0))
    assert estimate_horizon(sim.detections, FPS, 480) is None


def test_smoothing_removes_the_bias_of_noisy_box_heights(monkeypatch):
    """Heads well above and below the camera walking one metre in depth, box heights 10 %
    noisy: noise in the regressor flattens each person's line (errors in variables) and
    moves the horizon 2.4 degrees; the boxes averaged over half a second keep it within 1."""
    import avtrack.visual.horizon as horizon
    from avtrack.simulate.detections import DetectorConfig

    cam = _camera(-12.0)
    noisy = DetectorConfig(size_noise=0.10, false_alarm_rate=0.0)
    people = _walkers(heights=(1.9, 2.0, 0.9), near=(3.0, 3.4, 3.2), walk_m=1.0)
    sim = simulate_detections(cam, people, np.random.default_rng(1), noisy)
    hz = estimate_horizon(sim.detections, FPS, 480)
    assert hz is not None and abs(hz.pitch_deg(cam.fy, cam.cy) + 12.0) < 1.0
    monkeypatch.setattr(horizon, "SMOOTH_S", 0.04)  # one frame: no averaging
    raw = estimate_horizon(sim.detections, FPS, 480)
    assert raw is not None and raw.pitch_deg(cam.fy, cam.cy) + 12.0 < -2.0


@settings(max_examples=10, deadline=None)
@given(shift=st.floats(-60.0, 60.0))
def test_horizon_moves_with_the_rows(shift):
    """Every box moved down by ``shift`` pixels moves the horizon by as much."""
    sim = simulate_detections(_camera(-6.0), _walkers(n_frames=300), np.random.default_rng(2))
    d = replace(sim.detections, boxes=sim.detections.boxes + np.array([0.0, 100.0, 0.0, 0.0]))
    moved = replace(d, boxes=d.boxes + np.array([0.0, shift, 0.0, 0.0]))
    a = estimate_horizon(d, FPS, 1000, n_bootstrap=2)  # no box near the edges
    b = estimate_horizon(moved, FPS, 1000, n_bootstrap=2)
    assert a is not None and b is not None
    assert b.row_px - a.row_px == pytest.approx(shift, abs=0.05)


def test_tracklets_link_overlapping_boxes_and_break_at_gaps():
    # two heads drifting right, the second missing for frames 4-7 (a gap of 4 > max_gap 2)
    rows = []
    for f in range(1, 11):
        rows.append((f, [100.0 + 2 * f, 50.0, 40.0, 50.0]))
        if not 4 <= f <= 7:
            rows.append((f, [300.0 + 2 * f, 60.0, 40.0, 50.0]))
    d = MOTData(np.array([r[0] for r in rows]), -np.ones(len(rows)),
                np.array([r[1] for r in rows]), np.ones(len(rows)))
    lab = link_tracklets(d)
    first = lab[d.boxes[:, 0] < 200]
    second = lab[d.boxes[:, 0] > 200]
    assert np.all(first == first[0])
    assert len(np.unique(second)) == 2 and first[0] not in second
    with pytest.raises(ValueError, match="min_iou"):
        link_tracklets(d, min_iou=0.0)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(1, 60))
def test_tracklets_never_hold_two_boxes_of_one_frame(seed, n):
    """Random boxes over a few frames: every box gets a label, and no label appears twice
    in a frame (a tracklet is one head)."""
    rng = np.random.default_rng(seed)
    frames = np.sort(rng.integers(1, 8, n))
    boxes = np.column_stack([rng.uniform(0, 200, (n, 2)), rng.uniform(5, 60, (n, 2))])
    lab = link_tracklets(MOTData(frames, -np.ones(n), boxes, np.ones(n)))
    assert lab.shape == (n,) and np.all(lab >= 0)
    for f in np.unique(frames):
        assert len(np.unique(lab[frames == f])) == np.sum(frames == f)


def test_bad_fps_is_a_clear_error():
    d = MOTData(np.array([1]), np.array([-1]), np.array([[0.0, 0.0, 10.0, 10.0]]),
                np.ones(1))
    with pytest.raises(ValueError, match="fps must be > 0"):
        estimate_horizon(d, 0.0, 480)
    with pytest.raises(ValueError, match="image_height must be > 0"):
        estimate_horizon(d, FPS, 0)


def test_no_detections_give_no_horizon():
    empty = MOTData(np.zeros(0), np.zeros(0), np.zeros((0, 4)), np.zeros(0))
    assert estimate_horizon(empty, FPS, 480) is None
