"""``avtrack demo``: the simulated audio-visual meeting and its HTML report."""

from __future__ import annotations

import json
import re

import pytest

from avtrack.cli.main import main


def test_demo_writes_scores_and_a_self_contained_report(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "-o", str(out), "--duration", "4", "--seed", "1"]) == 0
    printed = capsys.readouterr()
    for key in ("MOTA", "IDF1", "DER %", "DOA MAE"):
        assert key in printed.out
    assert "1/6 simulating the meeting" in printed.err  # progress, every step to the last
    assert "6/6 writing the report" in printed.err
    scores = json.loads((out / "scores.json").read_text())
    assert 0 < scores["MOTA"] <= 100
    page = (out / "index.html").read_text()
    assert page.startswith("<!DOCTYPE html>") and page.rstrip().endswith("</html>")
    assert len(re.findall(r"src='data:image/png;base64,", page)) == 4  # with the persons
    assert "http://" not in page and "https://" not in page  # nothing to fetch
    for name in ("tracks.txt", "speech.rttm", "scene/audio.wav", "scene/gt/gt.txt"):
        assert (out / name).is_file(), name


@pytest.mark.parametrize(("args", "match"), [(["--duration", "0"], "--duration"),
                                              (["--seed", "-1"], "--seed")])  # fmt: skip
def test_demo_bad_arguments(tmp_path, capsys, args, match):
    assert main(["demo", "-o", str(tmp_path / "d"), *args]) == 2
    assert match in capsys.readouterr().err
