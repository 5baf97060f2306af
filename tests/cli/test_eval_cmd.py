"""Tests of ``avtrack eval`` (avtrack.cli.eval_cmd), run through avtrack.cli.main.main with only
this command registered, so they do not depend on the other sub-commands."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from avtrack.cli import main as cli_main

GT = """\
1,1,10,20,100,100,1,-1,-1,-1
2,1,12,20,100,100,1,-1,-1,-1
3,1,14,20,100,100,1,-1,-1,-1
4,1,16,20,100,100,1,-1,-1,-1
"""
# one identity switch (frame 3) and one false positive (frame 4)
RES = """\
1,5,10,20,100,100,0.9,-1,-1,-1
2,5,12,20,100,100,0.9,-1,-1,-1
3,6,14,20,100,100,0.9,-1,-1,-1
4,6,16,20,100,100,0.9,-1,-1,-1
4,7,400,300,30,60,0.5,-1,-1,-1
"""


@pytest.fixture(autouse=True)
def only_eval(monkeypatch):
    monkeypatch.setattr(cli_main, "COMMAND_MODULES", ("eval_cmd",))


@pytest.fixture
def files(tmp_path: Path) -> tuple[Path, Path]:
    gt, res = tmp_path / "gt.txt", tmp_path / "res.txt"
    gt.write_text(GT)
    res.write_text(RES)
    return gt, res


def test_eval_mot_prints_table(files, capsys):
    gt, res = files
    assert cli_main.main(["eval", "mot", str(gt), str(res)]) == 0
    out = capsys.readouterr().out
    header, row = out.splitlines()[1:3]
    assert header.split() == "MOTA MOTP IDF1 HOTA FP FN IDSW Frag MT ML".split()
    # MOTA = (TP - FP - IDSW) / n_gt = (4 - 1 - 1) / 4; IDF1 = 2 IDTP / (2 IDTP + IDFP + IDFN)
    # = 4 / (4 + 3 + 2); HOTA (column 4) is checked against TrackEval in tests/metrics
    cells = row.split()
    del cells[4]
    assert cells == "res 50.0 100.0 44.4 1 0 1 0 1 0".split()
    assert "MOT15 scores" in out and "4 frames, 1 ground-truth identities" in out


def test_eval_mot_json(files, tmp_path, capsys):
    gt, res = files
    out_json = tmp_path / "sub" / "scores.json"
    rc = cli_main.main(
        ["eval", "mot", str(gt), str(res), "--json", str(out_json), "-q", "--benchmark", "MOT15"]
    )
    assert rc == 0
    assert capsys.readouterr().out == ""
    record = json.loads(out_json.read_text())
    assert record["benchmark"] == "MOT15" and record["result"] == str(res)
    assert record["scores"]["MOTA"] == pytest.approx(50.0)
    assert record["scores"]["IDSW"] == 1 and record["scores"]["FP"] == 1


def test_eval_mot_verbose_shows_more_columns(files, capsys):
    gt, res = files
    assert cli_main.main(["eval", "mot", str(gt), str(res), "-v"]) == 0
    header = capsys.readouterr().out.splitlines()[1]
    for col in ("IDP", "IDR", "DetA", "AssA", "PT", "n_gt_ids", "n_frames"):
        assert col in header.split()


def test_eval_help_has_examples(capsys):
    with pytest.raises(SystemExit) as exc:
        cli_main.main(["eval", "mot", "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "examples:" in out and "--benchmark MOT17" in out and "--json" in out
    with pytest.raises(SystemExit):
        cli_main.main(["eval", "--help"])
    assert "mot" in capsys.readouterr().out


def test_eval_requires_a_task(capsys):
    with pytest.raises(SystemExit) as exc:
        cli_main.main(["eval"])
    assert exc.value.code == 2
    assert "TASK" in capsys.readouterr().err


def test_missing_file_is_one_line_error(files, tmp_path, capsys):
    gt, _ = files
    missing = tmp_path / "nope.txt"
    assert cli_main.main(["eval", "mot", str(gt), str(missing)]) == 2
    err = capsys.readouterr().err
    assert err == f"avtrack: error: {missing}: file not found\n"


def _one_line_error(capsys, argv: list[str]) -> str:
    """The error message of ``avtrack argv``, checked to be one line and to exit with 2."""
    assert cli_main.main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    return err


def test_malformed_file_is_one_line_error(files, tmp_path, capsys):
    gt, _ = files
    bad = tmp_path / "bad.txt"
    bad.write_text("1,1,10,20,100,100,1\n2,1,abc,20,100,100,1\n")
    err = _one_line_error(capsys, ["eval", "mot", str(gt), str(bad)])
    assert err.startswith(f"avtrack: error: {bad}, row 2: column 3 is not a number")


def test_unscorable_result_is_one_line_error(files, tmp_path, capsys):
    gt, _ = files
    dup = tmp_path / "dup.txt"
    dup.write_text("1,5,10,20,100,100,1\n1,5,50,20,100,100,1\n")
    err = _one_line_error(capsys, ["eval", "mot", str(gt), str(dup)])
    assert f"cannot score {dup} against {gt}" in err and "id 5 more than once in frame 1" in err


def test_json_to_directory_is_an_error(files, tmp_path, capsys):
    gt, res = files
    assert cli_main.main(["eval", "mot", str(gt), str(res), "--json", str(tmp_path)]) == 2
    assert "--json must name a file" in capsys.readouterr().err


def test_bad_benchmark_is_rejected_by_argparse(files, capsys):
    gt, res = files
    with pytest.raises(SystemExit) as exc:
        cli_main.main(["eval", "mot", str(gt), str(res), "--benchmark", "MOT99"])
    assert exc.value.code == 2
    assert "invalid choice" in capsys.readouterr().err


def test_eval_doa_by_hand(tmp_path, capsys):
    import json as _json

    from avtrack.io.doa import DOATable, write_doa_csv

    t = np.arange(4) * 0.008
    truth = DOATable(np.arange(4), t, np.ones(4, int), np.full(4, 10.0), np.zeros(4),
                     np.ones(4), np.array([True, True, True, False]))  # fmt: skip
    # frames 0-1: right within 2 degrees; frame 2: 40 degrees off (miss + false alarm);
    # frame 3: nobody speaks, an estimate there is a false alarm
    est = DOATable(np.arange(4), t, -np.ones(4, int), np.array([12.0, 8.0, 50.0, 0.0]),
                   np.zeros(4), np.ones(4), np.ones(4, bool))  # fmt: skip
    write_doa_csv(tmp_path / "gt.csv", truth)
    write_doa_csv(tmp_path / "est.csv", est)
    out = tmp_path / "s.json"
    assert cli_main.main(["eval", "doa", str(tmp_path / "gt.csv"), str(tmp_path / "est.csv"),
                 "--json", str(out)]) == 0  # fmt: skip
    scores = _json.loads(out.read_text())["scores"]
    assert scores["actual"] == 3 and scores["success"] == 2
    assert scores["MD%"] == pytest.approx(100 / 3)
    assert scores["MAE"] == pytest.approx(2.0)
    assert "MD% 33.33" in capsys.readouterr().out


def test_eval_doa_reports_the_lag_of_late_estimates(tmp_path, capsys):
    """Estimates of a talker turning at 30°/s, 12 frames (96 ms) late: lag 12."""
    import json as _json

    from avtrack.io.doa import DOATable, write_doa_csv

    n = 400
    t = np.arange(n) * 0.008
    ones = np.ones(n)
    truth = DOATable(np.arange(n), t, ones.astype(int), -60 + 30 * t, 0 * ones, ones,
                     ones.astype(bool))  # fmt: skip
    late = -60 + 30 * np.maximum(t - 12 * 0.008, 0)
    est = DOATable(np.arange(n), t, -ones.astype(int), late, 0 * ones, ones, ones.astype(bool))
    write_doa_csv(tmp_path / "gt.csv", truth)
    write_doa_csv(tmp_path / "est.csv", est)
    out = tmp_path / "s.json"
    assert cli_main.main(["eval", "doa", str(tmp_path / "gt.csv"), str(tmp_path / "est.csv"),
                          "--max-shift", "30", "--json", str(out)]) == 0  # fmt: skip
    scores = _json.loads(out.read_text())["scores"]
    assert scores["lag_frames"] == 12
    assert scores["lag_s"] == pytest.approx(0.096)
    assert scores["MAE_at_lag"] < 0.01 < scores["MAE"]
    assert "lag 12 frames (96 ms)" in capsys.readouterr().out
    assert cli_main.main(["eval", "doa", str(tmp_path / "gt.csv"), str(tmp_path / "est.csv"),
                          "--max-shift", "-1"]) == 2  # fmt: skip


def test_eval_doa_bad_input(tmp_path, capsys):
    (tmp_path / "gt.csv").write_text("frame,time_s\n")
    assert cli_main.main(["eval", "doa", str(tmp_path / "gt.csv"), str(tmp_path / "gt.csv")]) == 2
    assert "gt.csv" in capsys.readouterr().err


def test_eval_der_matches_pyannote(tmp_path, capsys):
    """``avtrack eval der`` with pyannote.metrics' collar (total width) and overlap options."""
    import json

    pytest.importorskip("pyannote.metrics")
    from pyannote.core import Annotation, Segment
    from pyannote.metrics.diarization import DiarizationErrorRate

    from avtrack.cli.main import main

    ref_turns = [("A", 0.0, 4.0), ("B", 3.5, 7.0), ("A", 8.0, 10.0)]
    hyp_turns = [("x", 0.2, 3.0), ("y", 3.0, 7.5), ("x", 7.8, 9.0), ("z", 9.0, 10.5)]
    for name, turns in (("ref", ref_turns), ("hyp", hyp_turns)):
        (tmp_path / f"{name}.rttm").write_text("".join(
            f"SPEAKER rec 1 {s:.3f} {e - s:.3f} <NA> <NA> {spk} <NA> <NA>\n"
            for spk, s, e in turns))
    for collar, skip in ((0.0, False), (0.5, False), (0.5, True)):
        out = tmp_path / "der.json"
        args = ["eval", "der", str(tmp_path / "ref.rttm"), str(tmp_path / "hyp.rttm"),
                "--collar", str(collar), "--json", str(out), "-q", "--force"]
        assert main([*args, *(["--skip-overlap"] if skip else [])]) == 0
        ours = json.loads(out.read_text())["scores"]["DER"]
        ref, hyp = Annotation(), Annotation()
        for ann, turns in ((ref, ref_turns), (hyp, hyp_turns)):
            for spk, s, e in turns:
                ann[Segment(s, e)] = spk
        theirs = 100 * DiarizationErrorRate(collar=collar, skip_overlap=skip)(ref, hyp)
        assert ours == pytest.approx(theirs, abs=1e-6)
    assert main(["eval", "der", str(tmp_path / "ref.rttm"), str(tmp_path / "hyp.rttm")]) == 0
    assert "lower is better" in capsys.readouterr().out
    assert main(["eval", "der", str(tmp_path / "none.rttm"), str(tmp_path / "hyp.rttm")]) == 2


def test_eval_der_with_and_without_collar(tmp_path, capsys):
    """Reference A talks 0-10 s, the hypothesis 0-9 s. No collar: 1 s missed of 10 s (10 %).
    Collar 0.5 s (0.25 s each side of the boundaries at 0 and 10 s): 9.5 s scored, 0.75 s
    (9-9.75 s) missed: 7.894... %."""
    from avtrack.cli.main import main

    (tmp_path / "ref.rttm").write_text("SPEAKER rec 1 0.000 10.000 <NA> <NA> A <NA> <NA>\n")
    (tmp_path / "hyp.rttm").write_text("SPEAKER rec 1 0.000 9.000 <NA> <NA> x <NA> <NA>\n")
    out = tmp_path / "der.json"
    assert main(["eval", "der", str(tmp_path / "ref.rttm"), str(tmp_path / "hyp.rttm"),
                 "--json", str(out)]) == 0
    scores = json.loads(out.read_text())["scores"]
    assert scores["no_collar"]["DER"] == pytest.approx(10.0)
    assert scores["no_collar"]["missed"] == pytest.approx(10.0)
    assert scores["DER"] == pytest.approx(100 * 0.75 / 9.5)
    assert scores["missed"] == pytest.approx(100 * 0.75 / 9.5)
    assert scores["false_alarm"] == scores["confusion"] == 0
    text = capsys.readouterr().out
    assert "no collar, overlap scored (DIHARD)" in text and "collar 0.5 s" in text


def test_eval_voices_bad_input(tmp_path, capsys):
    from avtrack.cli.main import main

    assert main(["eval", "voices", str(tmp_path), str(tmp_path / "none")]) == 2
    assert "scene directory not found" in capsys.readouterr().err
    assert main(["eval", "voices", str(tmp_path), str(tmp_path), "--gate", "0"]) == 2
    assert "--gate" in capsys.readouterr().err
