"""``avtrack track-av`` (registered here through ``COMMAND_MODULES``)."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

import avtrack.cli.main as cli_main
from avtrack.io.mot import read_mot
from avtrack.io.rttm import read_rttm
from tests.av.scenes import walkout


@pytest.fixture
def main(monkeypatch):
    if "track_av" not in cli_main.COMMAND_MODULES:
        monkeypatch.setattr(cli_main, "COMMAND_MODULES", (*cli_main.COMMAND_MODULES, "track_av"))
    return cli_main.main


def test_track_av_writes_tracks_rttm_and_figure(main, tmp_path, capsys):
    scene_dir, _, mapping_path = walkout()
    out = tmp_path / "out"
    args = ["track-av", str(scene_dir), "-o", str(out), "--mapping", str(mapping_path)]
    assert main([*args, "--fov-fraction", "0.4", "--plot", "--threshold", "0.3"]) == 0
    tracks = read_mot(out / "tracks.txt", kind="result")
    assert np.unique(tracks.ids).tolist() == [1]
    turns = read_rttm(out / "speech.rttm")
    assert turns and {t.speaker for t in turns} == {"P1"}
    assert (out / "covariances.png").stat().st_size > 1000
    assert "tracked 350 frames" in capsys.readouterr().out


def test_track_av_no_audio_is_the_visual_tracker(main, tmp_path):
    scene_dir, _, _ = walkout()
    out = tmp_path / "vis"
    assert (
        main(
            [
                "track-av",
                str(scene_dir),
                "-o",
                str(out),
                "--no-audio",
                "-q",
                "--fov-fraction",
                "0.4",
            ]
        )
        == 0
    )
    assert len(np.unique(read_mot(out / "tracks.txt", kind="result").ids)) == 2
    assert not (out / "speech.rttm").exists()


def test_track_av_bad_input(main, tmp_path, capsys):
    scene_dir, _, mapping_path = walkout()
    assert main(["track-av", str(tmp_path / "none"), "-o", str(tmp_path / "o")]) == 2
    assert "scene directory not found" in capsys.readouterr().err
    out = str(tmp_path / "o")
    assert main(["track-av", str(scene_dir), "-o", out, "--fov-fraction", "1.5"]) == 2
    assert "--fov-fraction" in capsys.readouterr().err
    assert main(["track-av", str(scene_dir), "-o", out, "--mapping", str(tmp_path / "m.npz")]) == 2
    assert "mapping not found" in capsys.readouterr().err
    cfg = tmp_path / "cfg.yaml"
    cfg.write_text("sigma: 3\n")
    assert main(["track-av", str(scene_dir), "-o", out, "--config", str(cfg)]) == 2
    assert "cfg.yaml: sigma: unknown field (allowed: " in capsys.readouterr().err
    # a scene whose audio has another number of channels than the mapping's array
    other = tmp_path / "stereo"
    shutil.copytree(scene_dir, other)
    import soundfile as sf

    audio, fs = sf.read(other / "audio.wav")
    sf.write(other / "audio.wav", audio[:, :2], fs)
    assert main(["track-av", str(other), "-o", out, "--mapping", str(mapping_path)]) == 2
    assert "2 channels" in capsys.readouterr().err
    assert not (tmp_path / "o" / "tracks.txt").exists()  # nothing half-written


def test_track_av_trains_and_saves_a_mapping(main, tmp_path):
    scene_dir, _, _ = walkout()
    out = tmp_path / "trained"
    args = ["track-av", str(scene_dir), "-o", str(out), "-q", "--calibration-positions", "16"]
    assert main(args) == 0
    from avtrack.av.gllim import load_mapping

    mapping = load_mapping(out / "mapping.npz")
    assert mapping.meta["scene"] == scene_dir.name and mapping.meta["n_mics"] == 4
    assert (out / "tracks.txt").is_file() and (out / "speech.rttm").is_file()
