"""Tests of avtrack.io.rttm: round trips, conversions to and from SpeechSegment, merging, and
malformed records naming their file and row."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from avtrack.errors import InputError
from avtrack.io.rttm import (
    RTTMSegment,
    SpeechSegment,
    merge_segments,
    read_rttm,
    rttm_to_speech,
    speech_to_rttm,
    write_rttm,
)


def where(path: Path, row: int) -> str:
    return re.escape(f"{path}, row {row}: ")


def test_round_trip_speech_segments(tmp_path):
    segs = [SpeechSegment(1, 0.25, 2.0), SpeechSegment(2, 1.5, 3.1254), SpeechSegment(1, 4.0, 4.5)]
    path = tmp_path / "out" / "speech.rttm"
    write_rttm(path, segs, "scene01")
    lines = path.read_text().splitlines()
    assert lines[0] == "SPEAKER scene01 1 0.250 1.750 <NA> <NA> 1 <NA> <NA>"
    assert lines[1] == "SPEAKER scene01 1 1.500 1.625 <NA> <NA> 2 <NA> <NA>"
    back = read_rttm(path)
    assert back[0] == RTTMSegment("scene01", 0.25, 1.75, "1")
    speech = rttm_to_speech(back)
    assert [s.speaker for s in speech] == [1, 2, 1]
    assert [v for s in speech for v in (s.start, s.end)] == pytest.approx(
        [0.25, 2.0, 1.5, 3.125, 4.0, 4.5]
    )
    assert all(s.utterance == "scene01" for s in speech)


def test_round_trip_rttm_segments(tmp_path):
    segs = [RTTMSegment("a", 0.0, 1.0, "alice"), RTTMSegment("b", 2.5, 0.5, "bob")]
    path = tmp_path / "x.rttm"
    write_rttm(path, segs)
    assert read_rttm(path) == segs


def test_label_mapping():
    segs = [RTTMSegment("f", 1.0, 1.0, "spk_b"), RTTMSegment("f", 0.0, 1.0, "spk_a")]
    out = rttm_to_speech(segs)
    assert [(s.speaker, s.start) for s in out] == [(1, 0.0), (2, 1.0)]
    out = rttm_to_speech(segs, {"spk_a": 7, "spk_b": 3})
    assert [s.speaker for s in out] == [7, 3]
    with pytest.raises(ValueError, match="no id for label"):
        rttm_to_speech(segs, {"spk_a": 1})
    assert speech_to_rttm([SpeechSegment(4, 1.0, 2.0)], "f") == [RTTMSegment("f", 1.0, 1.0, "4")]


def test_merge_segments():
    segs = [
        RTTMSegment("f", 0.0, 1.0, "A"),
        RTTMSegment("f", 0.5, 1.0, "A"),  # overlap
        RTTMSegment("f", 1.6, 0.4, "A"),  # 0.1 s gap
        RTTMSegment("f", 0.2, 0.3, "B"),
        RTTMSegment("g", 0.0, 1.0, "A"),
    ]
    merged = merge_segments(segs)
    want = [("f", "A", 0.0, 1.5), ("f", "B", 0.2, 0.5), ("f", "A", 1.6, 2.0), ("g", "A", 0.0, 1.0)]
    assert [(s.file_id, s.speaker) for s in merged] == [w[:2] for w in want]
    assert [v for s in merged for v in (s.start, s.end)] == pytest.approx(
        [v for w in want for v in w[2:]]
    )
    merged = [s for s in merge_segments(segs, gap=0.2) if s.file_id == "f"]
    assert [s.speaker for s in merged] == ["A", "B"]
    assert [v for s in merged for v in (s.start, s.end)] == pytest.approx([0.0, 2.0, 0.2, 0.5])


def test_reader_skips_comments_and_other_types(tmp_path):
    path = tmp_path / "a.rttm"
    path.write_text(
        "# a comment\n\n"
        "SPKR-INFO f 1 <NA> <NA> <NA> adult_male A <NA> <NA>\n"
        "SPEAKER f 1 0.5 1.25 <NA> <NA> A <NA> <NA>\n"
        "SPEAKER f 1 3 1 <NA> <NA> B\n"  # 8 fields are enough
    )
    assert read_rttm(path) == [RTTMSegment("f", 0.5, 1.25, "A"), RTTMSegment("f", 3.0, 1.0, "B")]
    empty = tmp_path / "empty.rttm"
    empty.write_text("")
    assert read_rttm(empty) == []


@pytest.mark.parametrize(
    ("line", "match"),
    [
        ("SPEAKR f 1 0 1 <NA> <NA> A <NA> <NA>", "unknown RTTM record type 'SPEAKR'"),
        ("SPEAKER f 1 0 1", "expected 10 space-separated fields"),
        ("SPEAKER f 1 zero 1 <NA> <NA> A <NA> <NA>", r"start \(field 4\) is not a number"),
        ("SPEAKER f 1 0 nan <NA> <NA> A <NA> <NA>", r"duration \(field 5\) is 'nan'"),
        ("SPEAKER f 1 -1 1 <NA> <NA> A <NA> <NA>", r"start \(field 4\) must be >= 0"),
        ("SPEAKER f 1 0 0 <NA> <NA> A <NA> <NA>", r"duration \(field 5\) must be > 0"),
        ("SPEAKER f 1 0 1 <NA> <NA> A <NA> <NA> extra", "expected 10 space-separated.*got 11"),
    ],
)
def test_malformed_rows_name_file_and_row(tmp_path, line, match):
    path = tmp_path / "bad.rttm"
    path.write_text("SPEAKER f 1 0 1 <NA> <NA> A <NA> <NA>\n" + line + "\n")
    with pytest.raises(InputError, match=where(path, 2) + match):
        read_rttm(path)


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match="file not found"):
        read_rttm(tmp_path / "nope.rttm")


def test_writer_rejects_bad_segments(tmp_path):
    path = tmp_path / "x.rttm"
    with pytest.raises(ValueError, match="file_id is required"):
        write_rttm(path, [SpeechSegment(1, 0.0, 1.0)])
    with pytest.raises(ValueError, match="shorter than 1 ms"):
        write_rttm(path, [RTTMSegment("f", 1.0, 0.0004, "A")])
    assert not path.exists()  # nothing half-written
    with pytest.raises(ValueError, match="file_id must be a non-empty string without spaces"):
        RTTMSegment("my file", 0.0, 1.0, "A")
    with pytest.raises(ValueError, match="duration must be finite and > 0"):
        RTTMSegment("f", 0.0, -1.0, "A")
