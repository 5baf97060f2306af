"""An output that is one of the inputs is refused before anything runs, and the input stays."""

from __future__ import annotations

import numpy as np
import soundfile as sf

from avtrack.cli.main import main
from avtrack.io.mot import MOTData, write_mot


def test_output_over_an_input_is_refused(tmp_path, capsys):
    det = tmp_path / "det.txt"
    write_mot(det, MOTData(np.array([1, 2]), -np.ones(2),
                           np.array([[10.0, 10, 20, 40], [11.0, 10, 20, 40]]), np.ones(2)))
    before = det.read_bytes()
    assert main(["track-mot", str(det), "-o", str(det)]) == 2
    assert "is the input" in capsys.readouterr().err and det.read_bytes() == before
    wav = tmp_path / "rec.wav"
    sf.write(wav, np.random.default_rng(0).normal(0, 0.1, (16000, 4)), 16000)
    before = wav.read_bytes()
    assert main(["localize", str(wav), "--array", "nao4", "-o", str(wav)]) == 2
    assert "is the input" in capsys.readouterr().err and wav.read_bytes() == before
    ref = tmp_path / "ref.rttm"
    ref.write_text("SPEAKER rec 1 0.000 1.000 <NA> <NA> A <NA> <NA>\n")
    before = ref.read_bytes()
    assert main(["eval", "der", str(ref), str(ref), "--json", str(ref)]) == 2
    assert ref.read_bytes() == before
    # a different output is fine
    assert main(["track-mot", str(det), "-o", str(tmp_path / "res.txt"), "-q"]) == 0
