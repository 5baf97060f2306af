"""Closed-loop sequences: scenarios, determinism, the effect of the control term, outputs."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.io.mot import read_mot
from avtrack.metrics.mot import evaluate_mot
from avtrack.robot.tracker import RobotTrackerConfig
from avtrack.simulate.robot import (
    ROBOT_SCENARIOS,
    RobotSimConfig,
    simulate_robot,
    track_recording,
    write_robot_sim,
)


@pytest.fixture(scope="module")
def jump2():
    return simulate_robot("jump2", seed=1, duration_s=20)


def test_builtin_scenarios():
    assert {"follow1", "jump2", "jump3"} <= set(ROBOT_SCENARIOS)
    assert ROBOT_SCENARIOS["jump3"].n_people == 3 and ROBOT_SCENARIOS["jump3"].policy == "jump"


def test_run_is_deterministic_and_complete(jump2):
    again = simulate_robot("jump2", seed=1, duration_s=20)
    np.testing.assert_array_equal(again.tracks.boxes, jump2.tracks.boxes)
    np.testing.assert_array_equal(again.servo.target_ids, jump2.servo.target_ids)
    rec = jump2.recording
    assert rec.n_frames == 200 and rec.angles.shape == (200, 2)
    assert len(set(jump2.servo.target_ids.tolist()) - {-1}) == 2  # it jumps between two people
    assert np.degrees(np.ptp(rec.angles[:, 0])) > 30
    assert np.all(jump2.step_times > 0)


def test_control_term_beats_no_control_on_the_same_recording(jump2):
    """Thesis Table 3.3 protocol: the recorded run tracked again with and without C_tn."""
    with_c, _ = track_recording(jump2.recording)
    without, _ = track_recording(jump2.recording, RobotTrackerConfig(control="none"))
    s_with, s_without = evaluate_mot(jump2.gt, with_c), evaluate_mot(jump2.gt, without)
    assert s_with.MOTA > s_without.MOTA + 10
    assert s_with.IDSW < s_without.IDSW
    assert s_with.MOTA > 85


def test_people_and_detections_do_not_depend_on_compensation():
    a = simulate_robot("jump2", seed=3, duration_s=2)
    b = simulate_robot("jump2", seed=3, duration_s=2, compensation=False)
    # the head is still for the first second: identical observations
    for fa, fb in zip(a.recording.faces[:10], b.recording.faces[:10], strict=True):
        np.testing.assert_array_equal(fa.positions, fb.positions)
    assert not b.compensation


def test_follow_mode_keeps_the_face_near_the_image_centre():
    res = simulate_robot("follow1", seed=0, duration_s=15)
    assert np.nanmean(res.servo.distance_px) < 80
    assert np.nanmean(res.servo.true_distance_px) < 80
    assert set(res.servo.target_ids[20:].tolist()) == {1}


def test_write_robot_sim(tmp_path):
    res = simulate_robot("follow1", seed=0, duration_s=3)
    paths = write_robot_sim(res, tmp_path / "out")
    assert [p.name for p in paths] == ["tracks.txt", "gt.txt", "servo.csv"]
    tracks = read_mot(tmp_path / "out" / "tracks.txt", kind="result")
    gt = read_mot(tmp_path / "out" / "gt" / "gt.txt", kind="gt")
    assert len(tracks) == len(res.tracks) and len(gt) == len(res.gt)
    lines = (tmp_path / "out" / "servo.csv").read_text().splitlines()
    assert lines[0] == "frame,target_id,distance_px" and len(lines) == 31
    assert lines[1] == "1,-1,nan"


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"scenario": "dance3"}, ValueError, "unknown robot scenario 'dance3'"),
        ({"seed": -1}, ValueError, "seed must be an integer >= 0"),
        ({"duration_s": 0.0}, ValueError, "duration_s must be a positive number"),
        ({"scenario": 3}, TypeError, "scenario must be a name or a RobotScenario"),
    ],
)
def test_bad_arguments(kwargs, error, message):
    args = {"scenario": "jump2", **kwargs}
    with pytest.raises(error, match=message):
        simulate_robot(**args)


def test_config_validation():
    with pytest.raises(ValueError, match="gain must be in"):
        RobotSimConfig(gain=1.5)
    with pytest.raises(ValueError, match="calibration must be 'estimated' or 'true'"):
        RobotSimConfig(calibration="guess")
    with pytest.raises(TypeError, match="tracker must be a RobotTrackerConfig"):
        RobotSimConfig(tracker={})
