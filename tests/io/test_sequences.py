"""Tests of avtrack.io.sequences: MOTChallenge sequence folders and benchmark trees laid out as
published (``MOT17/train/MOT17-02-FRCNN/{seqinfo.ini, det/, gt/, img1/}``), and the MOT15
TUD-Campus sequence of the shared data (no ``seqinfo.ini``)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from avtrack.errors import InputError
from avtrack.io.sequences import MOTSequence, list_mot_sequences, load_mot_sequence

SEQINFO = """\
[Sequence]
name={name}
imDir=img1
frameRate=30
seqLength={length}
imWidth=1920
imHeight=1080
imExt=.jpg
"""
DET = (
    "1,-1,10,20,30,40,0.9,-1,-1,-1\n2,-1,11,21,30,40,0.8,-1,-1,-1\n3,-1,12,22,30,40,0.7,-1,-1,-1\n"
)
GT = "1,1,10,20,30,40,1,1,1.0\n2,1,11,21,30,40,1,1,0.8\n1,2,50,60,20,20,0,7,0.1\n"


def make_sequence(
    parent: Path,
    name: str,
    *,
    seqinfo: bool = True,
    gt: bool = True,
    images: int = 0,
    length: int = 5,
) -> Path:
    folder = parent / name
    (folder / "det").mkdir(parents=True)
    (folder / "det" / "det.txt").write_text(DET)
    if seqinfo:
        (folder / "seqinfo.ini").write_text(SEQINFO.format(name=name, length=length))
    if gt:
        (folder / "gt").mkdir()
        (folder / "gt" / "gt.txt").write_text(GT)
    if images:
        (folder / "img1").mkdir()
        for i in range(1, images + 1):
            (folder / "img1" / f"{i:06d}.jpg").write_bytes(b"\xff\xd8\xff\xd9")
    return folder


def make_benchmark(root: Path) -> Path:
    bench = root / "MOT17"
    for name in ("MOT17-02-FRCNN", "MOT17-04-FRCNN"):
        make_sequence(bench / "train", name, images=5)
    make_sequence(bench / "test", "MOT17-01-FRCNN", gt=False)
    (bench / "train" / "README.txt").parent.mkdir(parents=True, exist_ok=True)
    (bench / "train" / "README.txt").write_text("not a sequence")
    (bench / "notes").mkdir()
    return bench


def where(path: Path) -> str:
    return re.escape(f"{path}: ")


def test_full_sequence(tmp_path):
    folder = make_sequence(tmp_path, "MOT17-02-FRCNN", images=5)
    seq = load_mot_sequence(folder)
    assert seq.name == "MOT17-02-FRCNN" and seq.length == 5
    assert seq.image_size == (1920, 1080) and seq.frame_rate == 30.0
    assert seq.image_dir == folder / "img1"
    assert len(seq.detections) == 3
    np.testing.assert_array_equal(seq.ground_truth.frames, [1, 1, 2])  # sorted by frame
    np.testing.assert_array_equal(seq.ground_truth.ids, [1, 2, 1])
    np.testing.assert_allclose(seq.ground_truth.scores, [1, 0, 1])  # the "consider" flag
    assert "image size from seqinfo.ini" in seq.note and "length from seqinfo.ini" in seq.note


def test_no_seqinfo_size_from_argument_or_unknown(tmp_path):
    folder = make_sequence(tmp_path, "TUD-Like", seqinfo=False, gt=False, images=4)
    seq = load_mot_sequence(folder)
    assert seq.image_size is None and seq.width is None and seq.height is None
    assert "image size unknown (no seqinfo.ini; pass image_size=(width, height))" in seq.note
    assert seq.length == 4 and "length from the images in img1/" in seq.note
    assert seq.ground_truth is None and seq.frame_rate is None
    seq = load_mot_sequence(folder, image_size=(640, 480), frame_rate=25)
    assert seq.image_size == (640, 480) and seq.frame_rate == 25
    assert "image size from the image_size argument" in seq.note


def test_argument_contradicting_seqinfo(tmp_path):
    folder = make_sequence(tmp_path, "S")
    with pytest.raises(
        InputError,
        match=where(folder / "seqinfo.ini")
        + r"imWidth x imHeight is 1920 x 1080 but image_size 640 x 480",
    ):
        load_mot_sequence(folder, image_size=(640, 480))
    with pytest.raises(InputError, match=r"frameRate is 30 but frame_rate 25"):
        load_mot_sequence(folder, frame_rate=25)
    assert load_mot_sequence(folder, image_size=(1920, 1080)).width == 1920


@pytest.mark.parametrize("size", [(640,), (0, 480), (640.5, 480), (True, 480)])
def test_bad_image_size_argument(tmp_path, size):
    folder = make_sequence(tmp_path, "S", seqinfo=False)
    with pytest.raises(ValueError, match=r"image_size must be \(width, height\)"):
        load_mot_sequence(folder, image_size=size)


def test_frames_beyond_length(tmp_path):
    folder = make_sequence(tmp_path, "S", length=2)
    with pytest.raises(
        InputError,
        match=where(folder / "det" / "det.txt")
        + r"frame 3 is beyond the sequence length 2 \(length from seqinfo",
    ):
        load_mot_sequence(folder)


def test_missing_and_malformed(tmp_path):
    with pytest.raises(InputError, match="sequence folder not found"):
        load_mot_sequence(tmp_path / "nope")
    folder = make_sequence(tmp_path, "S")
    (folder / "gt" / "gt.txt").write_text("1,1,10,20,30\n")
    with pytest.raises(InputError, match=re.escape(f"{folder / 'gt' / 'gt.txt'}, row 1: ")):
        load_mot_sequence(folder)
    (folder / "seqinfo.ini").write_text("[Sequence]\nimWidth=wide\n")
    with pytest.raises(InputError, match="imWidth must be an integer"):
        load_mot_sequence(folder)
    (folder / "seqinfo.ini").unlink()
    (folder / "det" / "det.txt").unlink()
    with pytest.raises(InputError, match=where(folder / "det" / "det.txt") + "file not found"):
        load_mot_sequence(folder)


def test_list_benchmark_split_and_single(tmp_path):
    bench = make_benchmark(tmp_path)
    names = [p.name for p in list_mot_sequences(bench)]
    assert names == ["MOT17-01-FRCNN", "MOT17-02-FRCNN", "MOT17-04-FRCNN"]
    assert [p.parent.name for p in list_mot_sequences(bench)] == ["test", "train", "train"]
    assert [p.name for p in list_mot_sequences(bench / "train")] == [
        "MOT17-02-FRCNN",
        "MOT17-04-FRCNN",
    ]
    one = bench / "train" / "MOT17-02-FRCNN"
    assert list_mot_sequences(one) == [one]
    seqs = [load_mot_sequence(p) for p in list_mot_sequences(bench)]
    assert [s.ground_truth is None for s in seqs] == [True, False, False]
    with pytest.raises(InputError, match=where(bench / "notes") + "no MOTChallenge sequence"):
        list_mot_sequences(bench / "notes")
    with pytest.raises(InputError, match="folder not found"):
        list_mot_sequences(tmp_path / "MOT20")


def test_dataclass_validation(tmp_path):
    empty = load_mot_sequence(make_sequence(tmp_path, "S")).detections
    with pytest.raises(ValueError, match="both width and height"):
        MOTSequence("s", tmp_path, empty, None, 1, 640, None, None, None)
    with pytest.raises(ValueError, match="length must be >= 0"):
        MOTSequence("s", tmp_path, empty, None, -1, None, None, None, None)


def test_shared_tud_campus(shared_data):
    folder = shared_data / "mot15" / "TUD-Campus"
    seq = load_mot_sequence(folder)
    # the shared folder carries MOT15's seqinfo.ini (71 frames, 640 x 480, 25 fps)
    assert seq.name == "TUD-Campus" and seq.length == 71 and seq.image_size == (640, 480)
    assert seq.frame_rate == 25.0
    assert "image size from seqinfo.ini" in seq.note and "length from seqinfo.ini" in seq.note
    assert seq.image_dir is None
    assert len(seq.detections) == 321 and len(seq.ground_truth) == 359
    np.testing.assert_allclose(seq.detections.boxes[0], [281.931, 187.466, 79.93, 209.537])
    assert seq.detections.scores[0] == pytest.approx(0.997784)
    assert len(np.unique(seq.ground_truth.ids)) > 1
    sized = load_mot_sequence(folder, image_size=(640, 480))  # README: 640 x 480
    assert sized.image_size == (640, 480)
    listed = list_mot_sequences(shared_data / "mot15")
    assert folder in listed and listed == sorted(listed)  # six MOT15 sequences are shared
