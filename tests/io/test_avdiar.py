"""Tests of avtrack.io.avdiar on a sequence folder laid out as the AVDIAR archive is
(``summary.json``, ``Audio/``, ``Video/``, ``GroundTruth/`` with box files and RTTM), with
every rejected input named."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from avtrack.errors import InputError
from avtrack.io.avdiar import (
    SpeechSegments,
    load_avdiar_sequence,
    read_avdiar_boxes,
    read_rttm,
)

NAME = "Seq12-2P-S1M1"
FS = 48000
N_FRAMES = 10  # 0.4 s at 25 fps

FACES = """\
0,1,100.5,50,40,48
0,2,400,60,38,46
1,1,101.5,51,40,48
1,2,401,61,38,46
2,2,402,62,38,46
3,1,103.5,53,40,48
"""
BODIES = """\
0,1,80,40,90,160
1,1,81,41,90,160
"""
SPEAKERS = f"""\
SPKR-INFO {NAME} 1 <NA> <NA> <NA> unknown speaker-1 <NA>
SPKR-INFO {NAME} 1 <NA> <NA> <NA> unknown speaker-2 <NA>
SPEAKER {NAME} 1 0.00 0.10 <NA> <NA> speaker-1 <NA>
SPEAKER {NAME} 1 0.20 0.12 <NA> <NA> speaker-2 <NA>
SPEAKER {NAME} 1 0.30 1.00 <NA> <NA> speaker-1 <NA>
"""
VAD = f"""\
;; speech activity
SPEAKER {NAME} 1 0.00 0.10 <NA> <NA> speech <NA>
SPEAKER {NAME} 1 0.20 1.10 <NA> <NA> speech <NA>
"""


def make_sequence(
    root: Path, *, channels: int = 6, fs: int = FS, summary: bool = True, faces: str = FACES
) -> Path:
    folder = root / NAME
    for sub in ("Audio", "Video", "GroundTruth", "Detection"):
        (folder / sub).mkdir(parents=True)
    rng = np.random.default_rng(0)
    sf.write(
        folder / "Audio" / f"{NAME}.wav",
        rng.uniform(-0.3, 0.3, (fs // 10, channels)),
        fs,
        subtype="FLOAT",
    )
    for cam in (1, 2):
        (folder / "Video" / f"{NAME}_CAM{cam}.mp4").write_bytes(b"")
    (folder / "GroundTruth" / "face_bb.txt").write_text(faces)
    (folder / "GroundTruth" / "person_bb.txt").write_text(BODIES)
    (folder / "GroundTruth" / "speakers.rttm").write_text(SPEAKERS)
    (folder / "GroundTruth" / "vad.rttm").write_text(VAD)
    (folder / "Detection" / "face_bb.txt").write_text(FACES)
    if summary:
        (folder / "summary.json").write_text(
            json.dumps(
                {
                    "SequenceName": NAME,
                    "Length_in_sec": 0.4,
                    "Audio_Channel": 6,
                    "Audio_FS": FS,
                    "Video_FPS": 25,
                    "Number_of_Image": N_FRAMES,
                    "CalibrationID": 2,
                    "Image_Resoultion_WH": [720, 450],
                }
            )
        )
    return folder


def where(path: Path, row: int | None = None) -> str:
    return re.escape(f"{path}, row {row}: " if row is not None else f"{path}: ")


def test_round_trip(tmp_path):
    seq = load_avdiar_sequence(make_sequence(tmp_path))
    assert seq.name == NAME and seq.n_persons == 2 and seq.n_frames == N_FRAMES
    assert seq.fs == FS and seq.audio.shape == (6, FS // 10)
    assert seq.frame_rate == 25 and seq.image_size == (720, 450)
    assert seq.summary["CalibrationID"] == 2
    # 0-based file frames become 1-based MOT frames
    np.testing.assert_array_equal(seq.faces.frames, [1, 1, 2, 2, 3, 4])
    np.testing.assert_array_equal(seq.faces.ids, [1, 2, 1, 2, 2, 1])
    np.testing.assert_array_equal(seq.faces.boxes[0], [100.5, 50, 40, 48])
    np.testing.assert_array_equal(seq.faces.scores, 1.0)
    np.testing.assert_array_equal(seq.bodies.frames, [1, 2])
    assert len(seq.speakers) == 3 and len(seq.vad) == 2
    np.testing.assert_array_equal(seq.speakers.person, [1, 2, 1])
    np.testing.assert_allclose(seq.speakers.end_s, [0.1, 0.32, 1.3])
    assert seq.vad.names == ("speech", "speech")
    np.testing.assert_array_equal(seq.vad.person, [-1, -1])


def test_speaking_status_by_hand(tmp_path):
    seq = load_avdiar_sequence(make_sequence(tmp_path))
    np.testing.assert_allclose(seq.frame_times, np.arange(10) * 0.04)
    # person 1: [0, 0.1) -> frames at 0, 0.04, 0.08; [0.3, 1.3) -> 0.32 ... 0.36
    # person 2: [0.2, 0.32) -> 0.2, 0.24, 0.28
    expected = np.zeros((10, 2), dtype=bool)
    expected[[0, 1, 2, 8, 9], 0] = True
    expected[[5, 6, 7], 1] = True
    np.testing.assert_array_equal(seq.speaking(), expected)


def test_header_only_audio_and_no_summary(tmp_path):
    folder = make_sequence(tmp_path, summary=False)
    (folder / "GroundTruth" / "person_bb.txt").unlink()
    (folder / "GroundTruth" / "vad.rttm").unlink()
    seq = load_avdiar_sequence(folder, load_audio=False)
    assert seq.audio is None and seq.fs == FS
    assert seq.bodies is None and seq.vad is None
    assert seq.frame_rate == 25 and seq.image_size is None and seq.summary == {}
    assert seq.n_frames == 4  # last annotated frame without Number_of_Image
    assert seq.n_persons == 2  # from the name


def test_one_based_files(tmp_path):
    path = tmp_path / "face_bb.txt"
    path.write_text("1,1,10,10,5,5\n2,1,10,10,5,5,0.9,7\n")
    data = read_avdiar_boxes(path, zero_based=False)
    np.testing.assert_array_equal(data.frames, [1, 2])
    assert data.extra.shape == (2, 2) and np.isnan(data.extra[0, 0])
    path.write_text("0,1,10,10,5,5\n")
    with pytest.raises(InputError, match=where(path, 1) + "frame must be an integer >= 1"):
        read_avdiar_boxes(path, zero_based=False)


#: (text, row, message) of malformed face_bb.txt rows and speakers.rttm lines
BAD_BOX_ROWS = [
    ("0,1,1,1,5,5\n1,1,1,1,5\n", 2, "expected at least 6 values"),
    ("0,1,1,1,5,5\n\n1,x,1,1,5,5\n", 3, "not a number: 'x'"),
    ("0,1,nan,1,5,5\n", 1, "left is nan, expected a finite number"),
    ("0,1,1,1,0,5\n", 1, "box width and height must be > 0, got 0 x 5"),
    ("-1,1,1,1,5,5\n", 1, "frame must be an integer >= 0, got '-1'"),
    ("0,1.5,1,1,5,5\n", 1, "person must be an integer >= 1, got '1.5'"),
    ("0,0,1,1,5,5\n", 1, "person must be an integer >= 1, got '0'"),
    ("0,2,1,1,5,5\n1,2,1,1,5,5\n0,2,3,3,5,5\n", 3, "person 2 has a second box in frame 0"),
]
BAD_RTTM_LINES = [
    (
        "SPEAKER f 1 0.5 <NA> <NA> <NA> speaker-1 <NA>\n",
        1,
        "onset and duration must be numbers, got '0.5' and '<NA>'",
    ),
    (
        ";; c\nSPEAKER f 1 0.5 -1 <NA> <NA> speaker-1 <NA>\n",
        2,
        "onset and duration must be finite and >= 0, got 0.5 and -1",
    ),
    ("SPEAKER f 1 0.5 1\n", 1, "expected at least 8 fields"),
    ("LEXEME f 1 0.5 1 hello word speaker-1 <NA>\n", 1, "unknown RTTM line type 'LEXEME'"),
]


@pytest.mark.parametrize(
    ("name", "reader", "text", "row", "message"),
    [("face_bb.txt", read_avdiar_boxes, *case) for case in BAD_BOX_ROWS]
    + [("speakers.rttm", read_rttm, *case) for case in BAD_RTTM_LINES],
)
def test_bad_rows_are_named(tmp_path, name, reader, text, row, message):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(InputError, match=where(path, row) + re.escape(message)):
        reader(path)


def test_rttm_person_numbers():
    segs = SpeechSegments(
        np.array([0.0, 1.0]), np.array([1.0, 0.5]), ("spk10", "x"), np.array([10, -1])
    )
    np.testing.assert_array_equal(
        segs.active([0.5, 1.2, 1.5], [10, -1]), [[True, False], [False, True], [False, False]]
    )
    with pytest.raises(ValueError, match="durations must be >= 0"):
        SpeechSegments(np.array([0.0]), np.array([-1.0]), ("a",), np.array([1]))


def test_missing_files_are_named(tmp_path):
    folder = make_sequence(tmp_path)
    wav = folder / "Audio" / f"{NAME}.wav"
    wav.rename(folder / "Audio" / f"{NAME}_binaural.wav")
    with pytest.raises(
        InputError,
        match=where(wav)
        + re.escape(f"file not found (WAV files in Audio/: ['{NAME}_binaural.wav'])"),
    ):
        load_avdiar_sequence(folder)
    for name in ("speakers.rttm", "face_bb.txt"):
        (folder / "GroundTruth" / name).unlink()
        with pytest.raises(InputError, match=where(folder / "GroundTruth" / name) + "file not"):
            load_avdiar_sequence(folder)
    with pytest.raises(InputError, match="sequence folder not found"):
        load_avdiar_sequence(tmp_path / "Seq99-1P-S0M0")


def test_sample_rate_and_channels_checked_against_summary(tmp_path):
    folder = make_sequence(tmp_path / "a", fs=44100)
    wav = folder / "Audio" / f"{NAME}.wav"
    with pytest.raises(
        InputError,
        match=where(wav)
        + re.escape("sample rate is 44100 Hz, but summary.json gives Audio_FS = 48000 Hz"),
    ):
        load_avdiar_sequence(folder)
    folder = make_sequence(tmp_path / "b", channels=2)
    with pytest.raises(
        InputError, match=re.escape("2 channels, but summary.json gives Audio_Channel = 6")
    ):
        load_avdiar_sequence(folder, load_audio=False)


def test_summary_problems(tmp_path):
    folder = make_sequence(tmp_path)
    summary = folder / "summary.json"
    summary.write_text("{not json")
    with pytest.raises(InputError, match=where(summary) + "invalid JSON"):
        load_avdiar_sequence(folder)
    summary.write_text(json.dumps({"SequenceName": NAME, "Video_FPS": 0}))
    with pytest.raises(InputError, match=where(summary) + "Video_FPS must be > 0"):
        load_avdiar_sequence(folder)
    summary.write_text(json.dumps({"SequenceName": NAME, "Number_of_Image": 3}))
    with pytest.raises(
        InputError, match=re.escape("face_bb.txt: annotated frame 4 is beyond Number_of_Image = 3")
    ):
        load_avdiar_sequence(folder)


def test_nan_audio_rejected(tmp_path):
    folder = make_sequence(tmp_path)
    audio = np.zeros((100, 6))
    audio[3, 2] = np.nan
    sf.write(folder / "Audio" / f"{NAME}.wav", audio, FS, subtype="FLOAT")
    with pytest.raises(InputError, match="audio holds NaN"):
        load_avdiar_sequence(folder)
