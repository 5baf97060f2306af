"""One audio-input policy for localize, track-audio and stream: NaN, silence, clipping and a
recording too short to localize are refused in one line, with no output left behind."""

from __future__ import annotations

import numpy as np
import pytest
import soundfile as sf

from avtrack.cli.main import main


def _wav(path, kind: str):
    rng = np.random.default_rng(0)
    x = 0.1 * rng.standard_normal((16000, 4))
    if kind == "nan":
        x[500, 1] = np.nan
    elif kind == "silent":
        x[:] = 0.0
    elif kind == "clipped":
        x = np.clip(30 * x, -1.0, 1.0)
    elif kind == "short":
        x = x[:100]
    sf.write(path, x, 16000, subtype="FLOAT")
    return path


@pytest.mark.parametrize("command", ["localize", "track-audio", "stream"])
@pytest.mark.parametrize(("kind", "message"), [
    ("nan", "contains NaN or infinite samples"),
    ("silent", "is silent (all samples are zero)"),
    ("clipped", "is clipped ("),
    ("short", "is too short (100 samples"),
])
def test_bad_audio_is_refused_alike(tmp_path, capsys, command, kind, message):
    wav = _wav(tmp_path / f"{kind}.wav", kind)
    out = tmp_path / "out.csv"
    assert main([command, str(wav), "--array", "nao4", "-o", str(out), "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == [wav.name]


@pytest.mark.parametrize("command", ["localize", "track-audio", "stream"])
def test_clipping_allowed_on_request_and_a_quarter_second_is_enough(tmp_path, command):
    wav = _wav(tmp_path / "clipped.wav", "clipped")
    assert main([command, str(wav), "--array", "nao4", "-o", str(tmp_path / "a.csv"), "-q",
                 "--allow-clipping"]) == 0
    short = tmp_path / "short.wav"
    sf.write(short, 0.1 * np.random.default_rng(1).standard_normal((4000, 4)), 16000)
    assert main([command, str(short), "--array", "nao4", "-o", str(tmp_path / "b.csv"),
                 "-q"]) == 0


@pytest.mark.parametrize(("scale", "message"), [
    (100.0, "positions are in metres (are these centimetres or millimetres?)"),
    (0.0, "microphones are at one point"),
])
def test_array_file_in_centimetres_or_at_one_point(tmp_path, capsys, scale, message):
    import json

    from avtrack.audio.arrays import builtin_array

    d = builtin_array("nao4").to_json()
    d["positions"] = [[scale * v for v in p] for p in d["positions"]]
    array = tmp_path / "array.json"
    array.write_text(json.dumps(d))
    wav = _wav(tmp_path / "ok.wav", "ok")
    out = tmp_path / "out.csv"
    assert main(["localize", str(wav), "--array", str(array), "-o", str(out), "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err, err
    assert not out.exists()
