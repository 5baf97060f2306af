"""Frame numbers and times that no file of that length can hold are refused, not allocated."""

from __future__ import annotations

import pytest

from avtrack.errors import InputError
from avtrack.io.base import FRAME_SPAN_FLOOR, FRAME_SPAN_PER_ROW, check_frame_span
from avtrack.io.doa import DOA_HEADER, read_doa_csv
from avtrack.io.mot import read_mot


def test_the_bound_grows_with_the_rows():
    check_frame_span(FRAME_SPAN_FLOOR, 1, "f")
    check_frame_span(FRAME_SPAN_PER_ROW * 5000, 5000, "f")
    with pytest.raises(InputError, match="frame 1000001 lies far past what 1 row"):
        check_frame_span(FRAME_SPAN_FLOOR + 1, 1, "f")
    with pytest.raises(InputError, match="time_s"):
        check_frame_span(1e9, 10, "f", "time_s")


@pytest.mark.parametrize("kind", ["det", "gt", "result"])
def test_mot_file_with_an_absurd_frame(tmp_path, kind):
    path = tmp_path / "det.txt"
    path.write_text("1,-1,10,10,20,40,0.9\n999999999,-1,10,10,20,40,0.9\n")
    with pytest.raises(InputError, match="frame 999999999 lies far past what 2 row"):
        read_mot(path, kind)
    path.write_text("1,-1,10,10,20,40,0.9\n900000,-1,10,10,20,40,0.9\n")  # long, but possible
    assert read_mot(path, kind).n_frames == 900000


def test_doa_csv_with_an_absurd_frame_or_time(tmp_path):
    path = tmp_path / "doa.csv"
    path.write_text(f"{DOA_HEADER}\n999999999,1.0,0,10,0,1,1\n")
    with pytest.raises(InputError, match="frame 999999999"):
        read_doa_csv(path)
    path.write_text(f"{DOA_HEADER}\n1,1e9,0,10,0,1,1\n")
    with pytest.raises(InputError, match="time_s 1e\\+09"):
        read_doa_csv(path)


@pytest.mark.parametrize(
    "argv",
    [
        ["track-mot", "{det}", "-o", "{out}"],
        ["eval", "mot", "{det}", "{det}"],
        ["track-audio", "--doa", "{doa}", "-o", "{out}"],
    ],
)
def test_commands_refuse_absurd_frames_in_one_line(tmp_path, capsys, argv):
    from avtrack.cli.main import main

    det = tmp_path / "det.txt"
    det.write_text("999999999,-1,10,10,20,40,0.9\n")
    doa = tmp_path / "doa.csv"
    doa.write_text(f"{DOA_HEADER}\n999999999,1.0,0,10,0,1,1\n")
    out = tmp_path / "out.csv"
    args = [a.format(det=det, doa=doa, out=out) for a in argv]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "lies far past" in err
    assert not out.exists()
