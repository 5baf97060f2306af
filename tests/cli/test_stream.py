"""CLI contract of ``avtrack stream``: a WAV stream on stdin, rows as they come, the same
tracks as ``avtrack track-audio``, clear errors, interrupted runs keep complete rows."""

from __future__ import annotations

import signal
import struct
import subprocess
import sys
import time

import numpy as np
import pytest
import soundfile as sf

from avtrack.cli.main import main
from avtrack.io.doa import DOA_HEADER, read_doa_csv
from tests.localize.conftest import SOURCE_AZIMUTH_DEG, render_static_scene

CLI = [sys.executable, "-m", "avtrack.cli.main"]


@pytest.fixture(scope="module")
def wav(tmp_path_factory):
    """A 2.5 s, 4-channel 16-bit recording of one static talker at 50 degrees (nao4)."""
    _, x = render_static_scene(SOURCE_AZIMUTH_DEG)
    path = tmp_path_factory.mktemp("stream") / "rec.wav"
    sf.write(path, (0.3 * x / np.abs(x).max()).T, 16000, subtype="PCM_16")
    return path


def live(data: bytes) -> bytes:
    """The WAV with the unknown-length header of a live recorder (``arecord``): RIFF and data
    chunk sizes 0xFFFFFFFF, so the stream ends only when the pipe closes."""
    b = bytearray(data)
    i = b.index(b"data")
    b[4:8] = b[i + 4 : i + 8] = struct.pack("<I", 0xFFFFFFFF)
    return bytes(b)


def test_stdin_stream_gives_the_tracks_of_track_audio(wav, tmp_path):
    ref = tmp_path / "ref.csv"
    assert main(["track-audio", str(wav), "--array", "nao4", "--tracker", "vonmises",
                 "-o", str(ref), "-q"]) == 0  # fmt: skip
    out = tmp_path / "stream.csv"
    with wav.open("rb") as fh:
        data = fh.read()
    done = subprocess.run(
        [*CLI, "stream", "-", "--array", "nao4", "-o", str(out), "--block-ms", "7"],
        input=data, capture_output=True, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr.decode()
    assert b"streamed 2.5 s of audio" in done.stderr
    assert out.read_text() == ref.read_text()
    table = read_doa_csv(out)
    on = table.active
    assert on.any()
    err = np.abs((table.azimuth_deg[on] - SOURCE_AZIMUTH_DEG + 180) % 360 - 180)
    assert np.median(err) < 5.0


def test_rows_go_to_stdout_as_they_come(wav):
    proc = subprocess.Popen(
        [*CLI, "stream", "-", "--array", "nao4", "-q"],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
    )  # fmt: skip
    data = live(wav.read_bytes())
    proc.stdin.write(data[: len(data) // 2])  # half the recording; the pipe stays open
    proc.stdin.flush()
    header = proc.stdout.readline().decode().strip()
    first = proc.stdout.readline().decode().strip()  # arrives before the stream ends
    assert header == DOA_HEADER
    assert len(first.split(",")) == 7
    proc.stdin.write(data[len(data) // 2 :])
    proc.stdin.close()
    proc.stdout.read()
    assert proc.wait(timeout=60) == 0
    assert proc.stderr.read() == b""


def test_interrupted_stream_keeps_complete_rows(wav, tmp_path):
    out = tmp_path / "live.csv"
    proc = subprocess.Popen(
        [*CLI, "stream", "-", "--array", "nao4", "-o", str(out)],
        stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
        # Ctrl-C as in a terminal, also when the suite itself runs as a background job (a
        # non-interactive shell starts those with SIGINT ignored, and children inherit that)
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )  # fmt: skip
    proc.stdin.write(live(wav.read_bytes()))  # the recording; the stream does not end
    proc.stdin.flush()
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not any(tmp_path.glob(".live.csv.*.tmp")):
        time.sleep(0.05)
    time.sleep(2.0)
    assert not out.exists()  # nothing at the final path while the stream runs
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err.decode()
    assert b"interrupted" in err
    table = read_doa_csv(out)  # a complete, readable file
    assert len(table) > 0
    assert not list(tmp_path.glob(".live.csv.*.tmp"))


@pytest.mark.parametrize(
    ("setup", "args", "message"),
    [
        ("wav", ["--array", "nao8"], "4 channel(s), expected 8"),
        ("text", ["--array", "nao4"], "not a readable WAV stream"),
        ("missing", ["--array", "nao4"], "file not found"),
        ("wav", ["--array", "nao4", "--block-ms", "0"], "--block-ms must be > 0"),
        ("config", ["--array", "nao4"], "tracker.no_such_field: unknown field"),
    ],
)
def test_bad_input_exits_2_with_one_line(wav, tmp_path, capsys, setup, args, message):
    path = wav
    extra = []
    if setup == "text":
        path = tmp_path / "notes.wav"
        path.write_text("not audio\n")
    elif setup == "missing":
        path = tmp_path / "nope.wav"
    elif setup == "config":
        cfg = tmp_path / "c.yaml"
        cfg.write_text("tracker: {no_such_field: 1}\n")
        extra = ["--config", str(cfg)]
    assert main(["stream", str(path), *args, *extra, "-o", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not (tmp_path / "o.csv").exists()
