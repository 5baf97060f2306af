"""Tests of avtrack.io.mot and avtrack.io.base: MOTChallenge round trip, every rejected input
naming its file and row, sorting of ground truth, and atomic writes."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from avtrack.errors import InputError
from avtrack.io.base import atomic_write
from avtrack.io.mot import MOTData, read_mot, write_mot


def write(tmp_path: Path, text: str, name: str = "det.txt") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def where(path: Path, row: int | None = None) -> str:
    """Regex for the ``<file>, row <n>: `` prefix of an InputError."""
    return re.escape(f"{path}, row {row}: " if row is not None else f"{path}: ")


# --------------------------------------------------------------------------- round trip


def test_write_read_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    k = 7
    data = MOTData(
        frames=np.sort(rng.integers(1, 5, k)),
        ids=rng.integers(1, 4, k),
        boxes=np.round(np.column_stack([rng.uniform(-20, 600, (k, 2)),
                                        rng.uniform(5, 200, (k, 2))]), 2),
        scores=np.round(rng.uniform(0, 1, k), 3),
    )
    path = tmp_path / "out" / "res.txt"  # parent is created
    write_mot(path, data)
    back = read_mot(path, kind="result")
    np.testing.assert_array_equal(back.frames, data.frames)
    np.testing.assert_array_equal(back.ids, data.ids)
    np.testing.assert_allclose(back.boxes, data.boxes, rtol=0, atol=1e-9)
    np.testing.assert_allclose(back.scores, data.scores, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(back.extra, -np.ones((k, 3)))
    assert path.read_text().splitlines()[0].count(",") == 9


def test_six_column_rows_get_confidence_one(tmp_path):
    path = write(tmp_path, "1,-1,10,20,30,40\n2,-1,11,21,30,40,\n")  # trailing comma allowed
    data = read_mot(path)
    np.testing.assert_array_equal(data.scores, [1.0, 1.0])
    np.testing.assert_array_equal(data.boxes, [[10, 20, 30, 40], [11, 21, 30, 40]])
    assert data.extra.shape == (2, 0)


def test_blank_and_comment_lines_are_skipped(tmp_path):
    path = write(tmp_path, "# header\n\n1,-1,10,20,30,40,0.9\n")
    assert len(read_mot(path)) == 1


def test_empty_file_yields_zero_rows(tmp_path):
    data = read_mot(write(tmp_path, ""))
    assert len(data) == 0
    assert data.n_frames == 0
    assert data.boxes.shape == (0, 4)


def test_gt_sorted_by_id_is_sorted_by_frame(tmp_path):
    text = ("1,1,10,10,5,5,1,1,1\n2,1,11,10,5,5,1,1,1\n3,1,12,10,5,5,1,1,1\n"
            "1,2,50,10,5,5,1,1,1\n2,2,51,10,5,5,1,1,1\n")
    data = read_mot(write(tmp_path, text, "gt.txt"), kind="gt")
    np.testing.assert_array_equal(data.frames, [1, 1, 2, 2, 3])
    np.testing.assert_array_equal(data.ids, [1, 2, 1, 2, 1])  # stable within a frame
    np.testing.assert_array_equal(data.boxes[:, 0], [10, 50, 11, 51, 12])
    assert data.frame_slices() == [slice(0, 2), slice(2, 4), slice(4, 5)]


# --------------------------------------------------------------------------- bad input


def test_missing_file(tmp_path):
    path = tmp_path / "nope.txt"
    with pytest.raises(InputError, match=where(path) + "file not found"):
        read_mot(path)


def test_directory_is_not_a_file(tmp_path):
    with pytest.raises(InputError, match=where(tmp_path) + "not a regular file"):
        read_mot(tmp_path)


@pytest.mark.parametrize(("line", "message"), [
    ("1,-1,10,20,30", "expected at least 6 comma-separated values"),
    ("1,-1,10,abc,30,40,1", "column 4 is not a number: 'abc'"),
    ("1,-1,nan,20,30,40,1", "left is nan, expected a finite number"),
    ("1,-1,10,inf,30,40,1", "top is inf, expected a finite number"),
    ("1,-1,10,20,0,40,1", "box width and height must be > 0, got 0 x 40"),
    ("1,-1,10,20,30,-5,1", "box width and height must be > 0, got 30 x -5"),
    ("1.5,-1,10,20,30,40,1", "frame must be an integer >= 1, got '1.5'"),
    ("0,-1,10,20,30,40,1", "frame must be an integer >= 1, got '0'"),
    ("1,-1,10,20,30,40,nan", r"confidence \(column 7\) is NaN"),
])
def test_bad_row_names_file_and_row(tmp_path, line, message):
    path = write(tmp_path, f"1,-1,1,1,5,5,1\n\n{line}\n")  # the bad row is line 3
    with pytest.raises(InputError, match=where(path, 3) + message) as err:
        read_mot(path)
    assert err.value.path == path
    assert err.value.row == 3


def test_decreasing_frame_in_det_file(tmp_path):
    path = write(tmp_path, "2,-1,1,1,5,5,1\n3,-1,1,1,5,5,1\n1,-1,1,1,5,5,1\n")
    message = r"frame numbers must not decrease \(frame 1 after 3\)"
    with pytest.raises(InputError, match=where(path, 3) + message):
        read_mot(path, kind="det")
    assert read_mot(path, kind="result").frames.tolist() == [1, 2, 3]


def test_bad_kind():
    with pytest.raises(ValueError, match="kind must be 'det', 'gt' or 'result', got 'res'"):
        read_mot("whatever.txt", kind="res")


def test_binary_file(tmp_path):
    path = tmp_path / "det.bin"
    path.write_bytes(b"\xff\xfe\x00\x01")
    with pytest.raises(InputError, match=where(path) + "not a text file"):
        read_mot(path)


def test_non_integer_id_is_rejected(tmp_path):
    path = write(tmp_path, "1,2.7,10,20,30,40,1,1,1\n", "gt.txt")
    with pytest.raises(InputError, match=where(path, 1) + "id"):
        read_mot(path, kind="gt")
    nan_id = write(tmp_path, "1,nan,10,20,30,40,1\n", "gt2.txt")
    with pytest.raises(InputError, match=where(nan_id, 1) + "id"):
        read_mot(nan_id, kind="gt")


def test_motdata_validation():
    with pytest.raises(ValueError, match="rows must be sorted by frame"):
        MOTData(np.array([2, 1]), np.zeros(2), np.ones((2, 4)), np.ones(2))
    with pytest.raises(ValueError, match="width and height must be > 0"):
        MOTData(np.array([1]), np.zeros(1), np.array([[0, 0, 0, 1.0]]), np.ones(1))


# --------------------------------------------------------------------------- atomic_write


def test_atomic_write_keeps_old_file_when_body_raises(tmp_path):
    path = tmp_path / "res.txt"
    path.write_text("old content\n")
    with pytest.raises(RuntimeError, match="boom"), atomic_write(path) as fh:
        fh.write("half-written")
        raise RuntimeError("boom")
    assert path.read_text() == "old content\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["res.txt"]  # no temp file left


def test_atomic_write_gives_the_mode_of_a_plain_open(tmp_path):
    import os
    import stat

    old = os.umask(0o022)
    try:
        with atomic_write(tmp_path / "out.txt") as fh:
            fh.write("x")
        (tmp_path / "plain.txt").write_text("x")
    finally:
        os.umask(old)
    mode = stat.S_IMODE((tmp_path / "out.txt").stat().st_mode)
    assert mode == stat.S_IMODE((tmp_path / "plain.txt").stat().st_mode) == 0o644


def test_atomic_write_replaces_on_success(tmp_path):
    path = tmp_path / "res.bin"
    path.write_bytes(b"old")
    with atomic_write(path, "wb") as fh:
        fh.write(b"new")
    assert path.read_bytes() == b"new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["res.bin"]


def test_atomic_write_bad_mode(tmp_path):
    with pytest.raises(ValueError, match="mode must be 'w' or 'wb', got 'a'"), \
            atomic_write(tmp_path / "x.txt", "a"):
        pass
