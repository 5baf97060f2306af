"""One output policy for every command: no output over an input, no overwrite without
--force, the location checked before any work, one-line OS errors, SIGTERM cleaned up like
Ctrl-C."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from avtrack.cli.main import main

DET = "1,-1,10,10,20,40,0.9\n2,-1,12,10,20,40,0.9\n"


@pytest.fixture
def det(tmp_path):
    path = tmp_path / "det.txt"
    path.write_text(DET)
    return path


def one_line_error(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("avtrack: error: "), err
    return err


def test_existing_output_file_needs_force(det, tmp_path, capsys):
    out = tmp_path / "res.txt"
    out.write_text("keep me\n")
    assert main(["track-mot", str(det), "-o", str(out), "-q"]) == 2
    assert "the output file exists; give --force to overwrite it" in one_line_error(capsys)
    assert out.read_text() == "keep me\n"
    assert main(["track-mot", str(det), "-o", str(out), "-q", "--force"]) == 0
    assert out.read_text() != "keep me\n"


def test_non_empty_output_folder_needs_force(tmp_path, capsys):
    scene = tmp_path / "scene"
    scene.mkdir()
    args = ["simulate", "walkout", "-o", str(scene), "--utterances", "synthetic",
            "--duration", "1", "-q"]
    assert main(args) == 0  # an empty folder is fine
    assert main(args) == 2
    assert "the output folder is not empty; give --force" in one_line_error(capsys)
    assert main([*args, "--force"]) == 0


@pytest.mark.parametrize("kind", ["under_a_file", "file_is_a_folder", "folder_is_a_file"])
def test_output_location_checked_before_any_work(det, tmp_path, capsys, kind):
    blocker = tmp_path / "blocker"
    if kind == "under_a_file":
        blocker.write_text("x")
        argv = ["track-mot", str(det), "-o", str(blocker / "sub" / "res.txt")]
        message = "is a file, not a folder"
    elif kind == "file_is_a_folder":
        blocker.mkdir()
        argv = ["track-mot", str(det), "-o", str(blocker)]
        message = "-o must name a file; this is a folder"
    else:
        blocker.write_text("x")
        argv = ["simulate", "walkout", "-o", str(blocker), "--duration", "1"]
        message = "-o must be a folder; this is a file"
    assert main(argv) == 2
    assert message in one_line_error(capsys)


def test_os_error_during_a_command_is_one_line(det, tmp_path, capsys, monkeypatch):
    """An OS error the checks cannot foresee (a full disk, a file system gone read-only)."""
    import avtrack.io.mot as mot

    def full(*args, **kwargs):
        raise OSError(28, "No space left on device", str(tmp_path / "res.txt"))

    monkeypatch.setattr(mot, "write_mot", full)
    import avtrack.cli.track_mot as track_mot

    monkeypatch.setattr(track_mot, "write_mot", full, raising=False)
    assert main(["track-mot", str(det), "-o", str(tmp_path / "res.txt"), "-q"]) == 2
    assert "No space left on device" in one_line_error(capsys)


def test_sigterm_leaves_the_old_output_and_no_temporary(tmp_path):
    det = tmp_path / "det.txt"
    det.write_text("".join(f"{f},-1,{100 + f},{50 + (k * 97) % 300},40,90,0.9,-1,-1,-1\n"
                           for f in range(1, 4001) for k in range(6)))
    res = tmp_path / "res.txt"
    res.write_text("old\n")
    proc = subprocess.Popen(
        [sys.executable, "-m", "avtrack.cli.main", "track-mot", str(det), "-o", str(res),
         "--image-size", "640x480", "-q", "--force"],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    time.sleep(2.0)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    if proc.returncode == 143:
        assert res.read_text() == "old\n"
        assert err.strip() == "avtrack: terminated"
    else:  # finished before the signal
        assert proc.returncode == 0 and res.read_text().count("\n") > 1000
    assert sorted(p.name for p in tmp_path.iterdir()) == ["det.txt", "res.txt"]


def test_negative_seed_of_a_named_scene_is_one_line(tmp_path, capsys):
    assert main(["simulate", "walkout", "-o", str(tmp_path / "s"), "--seed", "-1"]) == 2
    assert "--seed must be >= 0, got -1" in one_line_error(capsys)
    assert not (tmp_path / "s").exists()


def test_reader_gone_from_the_pipe_stops_quietly(tmp_path):
    """``avtrack stream rec.wav -o - | head -n 2``: rows on stdout, and no BrokenPipeError
    traceback when the reader goes away."""
    scene = tmp_path / "scene"
    assert main(["simulate", "walkout", "-o", str(scene), "--duration", "8",
                 "--utterances", "synthetic", "-q"]) == 0
    proc = subprocess.Popen(
        [sys.executable, "-m", "avtrack.cli.main", "stream", str(scene / "audio.wav"),
         "--array", str(scene / "array.json"), "-o", "-", "-q"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert proc.stdout.readline().startswith(b"frame,time_s,")
    proc.stdout.close()  # the reader goes away
    err = proc.stderr.read().decode()
    proc.wait(timeout=120)
    assert "Traceback" not in err and "BrokenPipeError" not in err, err
    assert proc.returncode == 0
    assert not (tmp_path / "-").exists() and not (Path.cwd() / "-").exists()


@pytest.mark.skipif(not Path("/dev/null").exists(), reason="no /dev/null on this system")
def test_output_to_a_character_device_is_written_through(tmp_path):
    """``-o /dev/null`` (a device, not a file to replace) is accepted without --force, and
    stays a device: nothing is renamed onto it."""
    import os
    import stat

    from avtrack.io.base import atomic_write, is_char_device
    from avtrack.io.mot import write_mot
    from tests.visual.synthetic import crossing_scene

    _, dets, _ = crossing_scene(1)
    det = tmp_path / "det.txt"
    write_mot(det, dets)
    assert main(["track-mot", str(det), "-o", "/dev/null", "--image-size", "640x480",
                 "-q"]) == 0
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode) and is_char_device("/dev/null")
    with atomic_write("/dev/null") as fh:
        fh.write("discarded\n")
    assert is_char_device("/dev/null") and not is_char_device(det)
    assert not list(Path("/dev").glob("null*.tmp"))
