"""CLI contract of ``avtrack track-audio``."""

from __future__ import annotations

import argparse

import numpy as np
import pytest
import soundfile as sf

import avtrack.cli.main as cli_main
from avtrack.cli import track_audio
from avtrack.io.doa import DOA_HEADER, DOATable, read_doa_csv, write_doa_csv
from avtrack.simulate.heatmaps import synthetic_heatmaps
from tests.cli.commands import register_command
from tests.localize.conftest import SOURCE_AZIMUTH_DEG, render_static_scene

GRID = -180.0 + 5.0 * np.arange(1, 73)


@pytest.fixture(autouse=True)
def with_track_audio(monkeypatch):
    """``track_audio`` is added to the CLI by main.py's owner; register it for these tests."""
    register_command(monkeypatch, "track_audio")


def main(*args) -> int:
    return cli_main.main(["track-audio", *map(str, args)])


@pytest.fixture
def doa_files(tmp_path):
    """Peaks of synthetic 8 ms heat maps of one source moving 20°/s (doa.csv) and its truth."""
    n = 1000
    t = np.arange(n) * 0.008
    az = (-30.0 + 20.0 * t)[:, None]
    w = synthetic_heatmaps(az, np.ones(az.shape, bool), GRID, np.random.default_rng(0))
    peaks = (w > np.roll(w, 1, axis=1)) & (w >= np.roll(w, -1, axis=1)) & (w > 0.05)
    r, c = np.nonzero(peaks)
    doa = tmp_path / "doa.csv"
    write_doa_csv(
        doa,
        DOATable(
            r,
            t[r],
            -np.ones(r.size, int),
            GRID[c],
            np.zeros(r.size),
            w[r, c],
            np.ones(r.size, bool),
        ),
    )
    gt = tmp_path / "gt.csv"
    write_doa_csv(
        gt,
        DOATable(
            np.arange(n), t, np.ones(n, int), az[:, 0], np.zeros(n), np.ones(n), np.ones(n, bool)
        ),
    )
    return doa, gt


def test_parser_from_register():
    parser = argparse.ArgumentParser()
    track_audio.register(parser.add_subparsers())
    args = parser.parse_args(
        ["track-audio", "rec.wav", "--array", "nao4", "-o", "t.csv", "--tracker", "vonmises"]
    )
    assert args.tracker == "vonmises" and args.step == 4 and args.func is track_audio.run


@pytest.mark.parametrize("tracker", ["gauss", "vonmises"])
def test_tracks_an_external_doa_csv(doa_files, tmp_path, capsys, tracker):
    doa, gt = doa_files
    out = tmp_path / "out" / "tracks.csv"
    png = tmp_path / "tracks.png"
    assert main("--doa", doa, "--tracker", tracker, "-o", out, "--truth", gt, "--plot", png) == 0
    assert out.read_text().splitlines()[0] == DOA_HEADER
    tracks = read_doa_csv(out)
    on = tracks.active
    assert on.sum() > 200 and np.all(tracks.ids >= 1)
    assert np.unique(tracks.frames % 4).tolist() == [3]  # one update per 32 ms
    truth = -30.0 + 20.0 * tracks.time_s[on]
    assert np.median(np.abs(tracks.azimuth_deg[on] - truth)) < 3.0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    printed = capsys.readouterr().out
    assert f"with {tracker}" in printed and "MD " in printed and "OSPA(30 deg)" in printed


def test_localizes_and_tracks_a_recording(tmp_path, capsys):
    _, y = render_static_scene(SOURCE_AZIMUTH_DEG, seconds=1.5, seed=1)
    wav = tmp_path / "rec.wav"
    sf.write(wav, (0.3 * y / np.abs(y).max()).T, 16000, subtype="PCM_16")
    out = tmp_path / "tracks.csv"
    cfg = tmp_path / "vm.yaml"
    cfg.write_text("activity_threshold: 0.1\n")
    assert main(wav, "--array", "nao4", "--tracker", "vonmises", "--config", cfg, "-o", out,
                "--voices", tmp_path / "voices") == 0
    tracks = read_doa_csv(out)
    wavs = sorted((tmp_path / "voices").glob("*.wav"))
    assert {int(w.stem) for w in wavs} == {int(i) for i in np.unique(tracks.ids)}
    assert all(sf.info(w).frames == y.shape[1] for w in wavs)
    late = tracks.active & (tracks.time_s > 0.75)
    assert late.sum() > 5
    assert np.median(np.abs(tracks.azimuth_deg[late] - SOURCE_AZIMUTH_DEG)) <= 6.0
    assert "real-time factor" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ((), "give AUDIO.wav"),
        (("rec.wav",), "--array is required"),
        (("rec.wav", "--doa", "doa.csv"), "not both"),
        (("--doa", "missing.csv"), "file not found"),
        (("--doa", "doa.csv", "--step", "0"), "--step must be >= 1"),
        (("--doa", "doa.csv", "--config", "bad.yaml"), "bad.yaml: sigma: unknown field"),
        (("--doa", "doa.csv", "--voices", "v"), "--voices beamforms"),
    ],
)
def test_bad_input_exits_2_with_one_line(doa_files, tmp_path, capsys, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "bad.yaml").write_text("sigma: 1\n")
    (tmp_path / "rec.wav").write_bytes(b"")
    assert main(*args, "-o", tmp_path / "t.csv") == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert not (tmp_path / "t.csv").exists()
