"""CLI contract of ``avtrack robot-sim``."""

from __future__ import annotations

import pytest

from avtrack.io.mot import read_mot
from tests.cli.commands import register_command


@pytest.fixture
def main(monkeypatch):
    """``avtrack.cli.main.main`` with the robot-sim command registered."""
    return register_command(monkeypatch, "robot_sim")


def test_robot_sim_writes_tracks_gt_and_servo_log(main, tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["robot-sim", "jump2", "--seed", "2", "--duration", "6", "-o", str(out)]) == 0
    tracks = read_mot(out / "tracks.txt", kind="result")
    gt = read_mot(out / "gt" / "gt.txt", kind="gt")
    assert len(tracks) > 20 and len(gt) > 20
    lines = (out / "servo.csv").read_text().splitlines()
    assert lines[0] == "frame,target_id,distance_px" and len(lines) == 61
    msg = capsys.readouterr().out
    assert "robot-sim jump2 (seed 2, compensation on): 60 frames, MOTA" in msg


def test_robot_sim_without_compensation_and_quiet(main, tmp_path, capsys):
    out = tmp_path / "wo"
    rc = main(
        [
            "robot-sim",
            "follow1",
            "--duration",
            "3",
            "--no-compensation",
            "--control",
            "exact",
            "-q",
            "-o",
            str(out),
        ]
    )
    assert rc == 0 and (out / "servo.csv").is_file()
    assert capsys.readouterr().out == ""


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["dance9"], "unknown sequence 'dance9'; built-in: follow1"),
        (["jump2", "--duration", "-1"], "--duration must be a positive number"),
        (["jump2", "--seed", "-3"], "--seed must be >= 0"),
    ],
)
def test_robot_sim_bad_input_gives_one_line_errors(main, tmp_path, capsys, args, message):
    out = tmp_path / "bad"
    assert main(["robot-sim", *args, "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err
    assert not out.exists()


def test_robot_sim_help_lists_the_sequences(main, capsys):
    with pytest.raises(SystemExit):
        main(["robot-sim", "--help"])
    assert "jump3" in capsys.readouterr().out
