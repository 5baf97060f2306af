"""CLI contract of ``avtrack localize``."""

from __future__ import annotations

import numpy as np
import pytest
import soundfile as sf

import avtrack.cli.main as cli_main
from avtrack.io.doa import DOA_HEADER, DOATable, read_doa_csv, write_doa_csv
from tests.cli.commands import register_command
from tests.localize.conftest import SOURCE_AZIMUTH_DEG, render_static_scene


@pytest.fixture(autouse=True)
def with_localize(monkeypatch):
    """``localize`` is added to the CLI by main.py's owner; register it for these tests."""
    register_command(monkeypatch, "localize")


@pytest.fixture(scope="module")
def signal():
    _, y = render_static_scene(SOURCE_AZIMUTH_DEG, seconds=1.5, seed=1)
    return 0.3 * y / np.abs(y).max()


@pytest.fixture
def wav(tmp_path, signal):
    path = tmp_path / "rec.wav"
    sf.write(path, signal.T, 16000, subtype="PCM_16")
    return path


def main(*args: str) -> int:
    return cli_main.main(["localize", *map(str, args)])


def test_writes_peaks_near_the_source(wav, tmp_path, capsys):
    out = tmp_path / "out" / "doa.csv"
    assert main(wav, "--array", "nao4", "-o", out) == 0
    assert out.read_text().splitlines()[0] == DOA_HEADER
    t = read_doa_csv(out)
    assert len(t) > 50 and np.all(t.ids == -1) and np.all(t.active)
    strongest = [
        t.azimuth_deg[t.frames == f][np.argmax(t.weight[t.frames == f])]
        for f in np.unique(t.frames)[-50:]
    ]
    assert np.median(np.abs(np.array(strongest) - SOURCE_AZIMUTH_DEG)) <= 5.0
    assert "localized 186 frames (1.5 s) with dprtf-eg" in capsys.readouterr().out


@pytest.mark.parametrize("method", ["srp-phat", "prp-rem"])
def test_methods_block_size_and_max_peaks(wav, tmp_path, method):
    out = tmp_path / "doa.csv"
    assert (
        main(
            wav,
            "--array",
            "nao4",
            "--method",
            method,
            "-o",
            out,
            "--max-peaks",
            "1",
            "--block-size",
            "777",
            "-q",
        )
        == 0
    )
    t = read_doa_csv(out)
    assert np.all(np.bincount(t.frames) <= 1)


def test_truth_roc_plot_and_config(wav, tmp_path, capsys):
    truth = tmp_path / "gt.csv"
    f = np.arange(187)
    write_doa_csv(
        truth,
        DOATable(
            f,
            0.008 * f,
            np.ones_like(f),
            np.full(f.size, 50.0),
            np.zeros(f.size),
            np.ones(f.size),
            f > 40,
        ),
    )
    cfg = tmp_path / "eg.yaml"
    cfg.write_text("variance: 0.2\ndprtf:\n  noise:\n    speech_ratio: 4.0\n")
    png = tmp_path / "heat.png"
    rc = main(
        wav,
        "--array",
        "nao4",
        "-o",
        tmp_path / "d.csv",
        "--truth",
        truth,
        "--roc",
        "--plot",
        png,
        "--config",
        cfg,
        "-q",
    )
    assert rc == 0
    text = capsys.readouterr().out
    assert "MD" in text and "ROC best threshold" in text
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert not list(tmp_path.glob(".*.tmp"))


def test_elevation_grid(wav, tmp_path):
    out = tmp_path / "d.csv"
    rc = main(wav, "--array", "nao4", "-o", out, "--elevations=-20,0,20", "--grid-step", "10")
    assert rc == 0
    t = read_doa_csv(out)
    assert set(np.unique(t.elevation_deg)) <= {-20.0, 0.0, 20.0} and len(t) > 0


def test_resamples_other_rates_with_a_notice(tmp_path, signal, capsys):
    import scipy.signal

    path = tmp_path / "rec48.wav"
    sf.write(path, scipy.signal.resample_poly(signal, 3, 1, axis=1).T, 48000)
    assert main(path, "--array", "nao4", "-o", tmp_path / "d.csv") == 0
    captured = capsys.readouterr()
    assert "48000 Hz; resampling to 16000 Hz" in captured.err
    assert "localized 186 frames" in captured.out


@pytest.mark.parametrize(
    ("make", "array", "message"),
    [
        (lambda s: s[:3], "nao4", "has 3 channel\\(s\\) but array 'nao4' has 4 microphones"),
        (lambda s: s, "nao12", "but array 'nao12' has 12 microphones"),
        (lambda s: np.zeros_like(s), "nao4", "is silent"),
        (lambda s: np.where(np.arange(s.shape[1]) % 50 == 0, np.nan, s), "nao4", "NaN"),
        (lambda s: np.clip(8 * s, -1, 1), "nao4", "is clipped"),
        (lambda s: s[:, :0], "nao4", "has no samples"),
    ],
)
def test_bad_audio_is_a_clear_error_without_output(tmp_path, signal, capsys, make, array, message):
    path = tmp_path / "bad.wav"
    sf.write(path, make(signal).T, 16000, subtype="FLOAT")
    out = tmp_path / "doa.csv"
    assert main(path, "--array", array, "-o", out) == 2
    err = capsys.readouterr().err
    assert str(path) in err
    assert __import__("re").search(message, err)
    assert not out.exists()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--array", "nao99"], "not a built-in array"),
        (["--array", "nao4", "--max-peaks", "0"], "--max-peaks must be >= 1"),
        (["--array", "nao4", "--grid-step", "7"], "step_deg must divide 360"),
        (["--array", "nao4", "--roc"], "--roc needs --truth"),
        (["--array", "nao4", "--elevations", "0,x"], "--elevations: expected comma-separated"),
    ],
)
def test_bad_options(wav, tmp_path, capsys, args, message):
    assert main(wav, *args, "-o", tmp_path / "d.csv") == 2
    assert message in capsys.readouterr().err


def test_bad_config_file(wav, tmp_path, capsys):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("variance: 0.1\nlearning_rate: 3\n")
    assert main(wav, "--array", "nao4", "-o", tmp_path / "d.csv", "--config", cfg) == 2
    err = capsys.readouterr().err
    assert str(cfg) in err and "learning_rate: unknown field (allowed: dprtf, " in err
    cfg.write_text("variance: -1\n")
    assert main(wav, "--array", "nao4", "-o", tmp_path / "d.csv", "--config", cfg) == 2
    assert "variance must be a finite number > 0" in capsys.readouterr().err


def test_missing_file(tmp_path, capsys):
    assert main(tmp_path / "none.wav", "--array", "nao4", "-o", tmp_path / "d.csv") == 2
    assert "audio file not found" in capsys.readouterr().err
