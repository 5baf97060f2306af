"""CLI contract of ``avtrack track-mot`` and ``avtrack demo``."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.cli.main import main
from avtrack.io.mot import read_mot, write_mot
from tests.visual.synthetic import crossing_scene


@pytest.fixture
def det_file(tmp_path):
    _, dets, app = crossing_scene(0)
    path = tmp_path / "det.txt"
    write_mot(path, dets)
    np.save(tmp_path / "app.npy", app)
    return path


def test_track_mot_writes_results(det_file, tmp_path, capsys):
    out = tmp_path / "res" / "res.txt"
    assert main(["track-mot", str(det_file), "-o", str(out), "--image-size", "640x480"]) == 0
    res = read_mot(out, kind="result")
    assert len(res) > 100 and set(np.unique(res.ids)) <= set(range(1, 20))
    assert "tracked 60 frames" in capsys.readouterr().out


def test_track_mot_with_appearance_and_config(det_file, tmp_path):
    cfg = tmp_path / "ovbt.yaml"
    cfg.write_text("birth_frames: 3\ndeath_frames: 20\n")
    out = tmp_path / "res.txt"
    rc = main(["track-mot", str(det_file), "-o", str(out), "--appearance",
               str(tmp_path / "app.npy"), "--config", str(cfg), "-q"])
    assert rc == 0 and out.is_file()


@pytest.mark.parametrize(
    ("content", "message"),
    [("1,-1,5,5,0,10,1\n", "row 1: box width and height must be > 0"),
     ("1,-1,5,5,4,10,1\n1,-1,5,nan,4,10,1\n", "row 2: top is nan"),
     ("2,-1,5,5,4,10,1\n1,-1,5,5,4,10,1\n", "row 2: frame numbers must not decrease"),
     ("1,-1,5,5\n", "row 1: expected at least 6"),
     ("1,-1,a,5,4,10,1\n", "row 1: column 3 is not a number")],
)
def test_track_mot_bad_rows_give_one_line_errors(tmp_path, capsys, content, message):
    det = tmp_path / "det.txt"
    det.write_text(content)
    out = tmp_path / "res.txt"
    assert main(["track-mot", str(det), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err and str(det) in err
    assert not out.exists()


def test_track_mot_bad_options(det_file, tmp_path, capsys):
    out = tmp_path / "res.txt"
    assert main(["track-mot", str(det_file), "-o", str(out), "--image-size", "big"]) == 2
    assert "--image-size" in capsys.readouterr().err
    cfg = tmp_path / "bad.yaml"
    cfg.write_text("n_iter: 0\n")
    assert main(["track-mot", str(det_file), "-o", str(out), "--config", str(cfg)]) == 2
    assert "n_iter" in capsys.readouterr().err
    bad_app = tmp_path / "app.npy"
    np.save(bad_app, np.zeros((3, 4)))
    assert main(["track-mot", str(det_file), "-o", str(out), "--appearance", str(bad_app)]) == 2
    assert "one row per detection" in capsys.readouterr().err
    assert not out.exists()


def test_track_mot_missing_file(tmp_path, capsys):
    assert main(["track-mot", str(tmp_path / "none.txt"), "-o", str(tmp_path / "r.txt")]) == 2
    assert "file not found" in capsys.readouterr().err


def test_track_mot_empty_detections_give_empty_results(tmp_path, capsys):
    det = tmp_path / "det.txt"
    det.write_text("")
    out = tmp_path / "res.txt"
    assert main(["track-mot", str(det), "-o", str(out)]) == 0
    assert out.read_text() == ""
    assert "no detections" in capsys.readouterr().err


def test_track_mot_reads_seqinfo(tmp_path):
    det = _crossing_sequence(tmp_path)
    out = tmp_path / "res.txt"
    assert main(["track-mot", str(det), "-o", str(out), "-q"]) == 0


def test_help_has_examples(capsys):
    for cmd in (["track-mot", "--help"], ["demo", "--help"], ["--help"]):
        with pytest.raises(SystemExit) as exc:
            main(cmd)
        assert exc.value.code == 0
    assert "examples:" in capsys.readouterr().out


def test_demo_prints_scores(shared_data, tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("AVTRACK_SHARED_DATA", str(shared_data))
    assert main(["demo", "--mot", "-o", str(tmp_path / "demo")]) == 0
    out = capsys.readouterr().out
    assert "MOTA" in out and "IDF1" in out
    assert (tmp_path / "demo" / "TUD-Campus.txt").is_file()
    assert (tmp_path / "demo" / "scores.json").is_file()


def _crossing_sequence(tmp_path, seqinfo_extra: str = ""):
    """``SEQ/det/det.txt`` of a synthetic crossing with its ``seqinfo.ini`` (640 x 480, 70
    frames, then the lines ``seqinfo_extra``)."""
    seq = tmp_path / "SEQ"
    (seq / "det").mkdir(parents=True)
    _, dets, _ = crossing_scene(1)
    write_mot(seq / "det" / "det.txt", dets)
    (seq / "seqinfo.ini").write_text(
        "[Sequence]\nname=SEQ\nimWidth=640\nimHeight=480\nseqLength=70\n" + seqinfo_extra)
    return seq / "det" / "det.txt"


def _sequence_at_7_fps(tmp_path):
    """``SEQ/det/det.txt`` of a synthetic crossing with its ``seqinfo.ini`` (7 fps)."""
    return _crossing_sequence(tmp_path, "frameRate=7\n")


def test_track_mot_frame_rate_from_seqinfo_and_option(tmp_path, monkeypatch):
    """--fps, else seqinfo.ini's frameRate, reaches the tracker; a bad --fps is one line."""
    import avtrack.visual.ovbt as ovbt

    seen = []
    real = ovbt.track_mot

    def spy(*args, **kwargs):
        seen.append(args[5] if len(args) > 5 else kwargs.get("fps"))
        return real(*args, **kwargs)

    monkeypatch.setattr(ovbt, "track_mot", spy)
    import avtrack.pipelines.mot as pipeline
    monkeypatch.setattr(pipeline, "track_mot", spy)
    det = str(_sequence_at_7_fps(tmp_path))
    assert main(["track-mot", det, "-o", str(tmp_path / "a.txt"), "-q"]) == 0
    assert main(["track-mot", det, "-o", str(tmp_path / "b.txt"), "-q", "--fps", "30"]) == 0
    assert seen == [7, 30.0]
    assert main(["track-mot", det, "-o", str(tmp_path / "c.txt"), "-q", "--fps", "0"]) == 2
    assert not (tmp_path / "c.txt").exists()


def test_track_mot_birth_min_score_option(det_file, tmp_path):
    """Every detection below --birth-min-score: nothing can start a track."""
    out = tmp_path / "res.txt"
    assert main(["track-mot", str(det_file), "-o", str(out), "--image-size", "640x480", "-q",
                 "--birth-min-score", "2"]) == 0
    assert out.read_text() == ""


def test_track_mot_says_which_frame_rate_it_uses_and_where_from(tmp_path, capsys):
    det = str(_sequence_at_7_fps(tmp_path))
    assert main(["track-mot", det, "-o", str(tmp_path / "a.txt")]) == 0
    assert "frame rate: 7 fps (from " in capsys.readouterr().out
    assert main(["track-mot", det, "-o", str(tmp_path / "b.txt"), "--fps", "12.5"]) == 0
    assert "frame rate: 12.5 fps (from --fps" in capsys.readouterr().out
