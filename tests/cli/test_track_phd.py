"""CLI contract of ``avtrack track-phd``."""

from __future__ import annotations

import numpy as np
import pytest

from tests.cli.commands import register_command
from tests.io.test_av163 import write_av163


@pytest.fixture
def main(monkeypatch):
    return register_command(monkeypatch, "track_phd")


@pytest.fixture
def small(tmp_path):
    return write_av163(tmp_path / "av", seq=7, cam=2, n_frames=30)


def read_tracks(path):
    lines = path.read_text().splitlines()
    assert lines[0] == "frame,id,x,y"
    return np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]]).reshape(-1, 4)


@pytest.mark.parametrize("name", ["lpf", "npf"])
def test_writes_tracks(main, small, tmp_path, capsys, name):
    out = tmp_path / "res" / "tracks.csv"
    rc = main(["track-phd", str(small), "--seq", "7", "--cam", "2", "--filter", name,
               "--seed", "1", "-o", str(out)])  # fmt: skip
    assert rc == 0
    rows = read_tracks(out)
    assert rows.shape[1] == 4 and np.all((rows[:, 0] >= 1) & (rows[:, 0] <= 30))
    msg = capsys.readouterr().out
    assert f"{name}: seq 7 cam 2, 30 frames, visual synthetic; OSPA" in msg
    assert "p=2, c=50" in msg


def test_plot_and_config(main, small, tmp_path):
    cfg = tmp_path / "phd.yaml"
    cfg.write_text("particles_per_target: 20\nflow_prior: transition\n")
    out, fig = tmp_path / "t.csv", tmp_path / "t.png"
    rc = main(["track-phd", str(small), "--seq", "7", "--cam", "2", "-o", str(out),
               "--plot", str(fig), "--config", str(cfg), "-q"])  # fmt: skip
    assert rc == 0 and out.is_file() and fig.stat().st_size > 1000


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--seq", "8", "--cam", "2"], "data_av_seq8_cam2.mat: file not found"),
        (["--seq", "7", "--cam", "2", "--visual", "faces"], "face_seq7_cam2.mat: file not found"),
        (["--seq", "0", "--cam", "2"], "--seq must be a positive integer"),
    ],
)
def test_bad_input_gives_one_line_errors(main, small, tmp_path, capsys, args, message):
    out = tmp_path / "t.csv"
    assert main(["track-phd", str(small), *args, "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err
    assert not out.exists()


def test_missing_folder_and_bad_config(main, tmp_path, small, capsys):
    out = tmp_path / "t.csv"
    assert main(["track-phd", str(tmp_path / "nope"), "--seq", "7", "--cam", "2", "-o",
                 str(out)]) == 2  # fmt: skip
    assert "nope: AV16.3 folder not found" in capsys.readouterr().err
    cfg = tmp_path / "bad.yaml"
    cfg.write_text("sigma: 3\n")
    assert main(["track-phd", str(small), "--seq", "7", "--cam", "2", "-o", str(out),
                 "--config", str(cfg)]) == 2  # fmt: skip
    err = capsys.readouterr().err
    assert "bad.yaml: sigma: unknown field (allowed: " in err
    assert not out.exists()


@pytest.mark.slow
def test_real_sequence(main, shared_data, tmp_path, capsys):
    out = tmp_path / "t.csv"
    rc = main(["track-phd", str(shared_data / "av16.3"), "--seq", "45", "--cam", "1", "-o",
               str(out)])  # fmt: skip
    assert rc == 0
    rows = read_tracks(out)
    assert set(np.unique(rows[:, 1])) <= set(range(1, 10_000)) | {-1}
    msg = capsys.readouterr().out
    assert "lpf: seq 45 cam 1, 1101 frames, visual faces" in msg
    ospa = float(msg.split("OSPA ")[1].split(" px")[0])
    assert ospa < 16.0


def write_av163_video(path, n_frames=30, size=(360, 288)):
    """An MJPG AVI in AV16.3's size: a saturated blue patch walking right on grey."""
    import cv2

    w, h = size
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 25.0, (w, h))
    for k in range(n_frames):
        img = np.full((h, w, 3), 128, np.uint8)
        img[100:148, 40 + 5 * k : 72 + 5 * k] = (200, 60, 30)
        writer.write(img)
    writer.release()
    return path


def test_video_measurements_from_frames(main, small, tmp_path, capsys):
    video = write_av163_video(tmp_path / "v.avi")
    out = tmp_path / "t.csv"
    rc = main(["track-phd", str(small), "--seq", "7", "--cam", "2", "--video", str(video),
               "-o", str(out)])  # fmt: skip
    assert rc == 0 and out.is_file()
    msg = capsys.readouterr().out
    assert "visual video foreground heads; OSPA" in msg and "OSPA-T" in msg


@pytest.mark.parametrize(
    ("video_args", "extra", "message"),
    [
        ({"n_frames": 12}, [], "the video has 12 frames, sequence 7 camera 2 has 30"),
        ({"size": (320, 240)}, [], "the video is 320x240, the AV16.3 calibration is for 360x288"),
        ({}, ["--visual", "synthetic"], "--visual synthetic and --video both choose"),
    ],
)
def test_video_that_does_not_fit_the_sequence(main, small, tmp_path, capsys, video_args, extra,
                                              message):
    video = write_av163_video(tmp_path / "v.avi", **video_args)
    out = tmp_path / "t.csv"
    rc = main(["track-phd", str(small), "--seq", "7", "--cam", "2", "--video", str(video),
               "-o", str(out), *extra])  # fmt: skip
    assert rc == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err
    assert not out.exists()


def test_clutter_rate(main, small, tmp_path, capsys):
    out = tmp_path / "c.csv"
    rc = main(["track-phd", str(small), "--seq", "7", "--cam", "2", "--clutter-rate", "0.5",
               "-o", str(out)])  # fmt: skip
    assert rc == 0 and out.is_file()
    msg = capsys.readouterr().out
    assert "visual synthetic + 0.5 false alarms/frame; OSPA" in msg
    assert "ESS" in msg and "resamplings" in msg
    for bad in ("-1", "nan"):
        assert main(["track-phd", str(small), "--seq", "7", "--cam", "2", "--clutter-rate", bad,
                     "-o", str(tmp_path / "x.csv")]) == 2  # fmt: skip
        assert "--clutter-rate must be a number in [0, 100]" in capsys.readouterr().err
