"""Tests of avtrack.io.locata: a LOCATA recording folder laid out as published
(``<root>/dev/task6/recording3/dummy/``, tab-separated tables, WAV via soundfile), azimuths
checked by hand in both conventions, every rejected input named, and the shared NAO/Kinovis
azimuth tracks against raw ``loadmat``."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import scipy.io
import soundfile as sf

from avtrack.errors import InputError
from avtrack.io.locata import (
    LOCATATracks,
    load_locata_recording,
    load_locata_tracks,
    locata_source_azimuths,
)

TIME = ["year", "month", "day", "hour", "minute", "second"]
POSE = ["x", "y", "z", "ref_vec_x", "ref_vec_y", "ref_vec_z"] + [
    f"rotation_{i}{j}" for i in range(1, 4) for j in range(1, 4)
]
FS = 1000
N_SAMPLES = 40
#  array frame: local x along world +y (rotation of 90° about z)
ROT = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
ARRAY_POS = np.array([1.0, 2.0, 0.5])
MICS = np.array([[0.1, 0.0, 0.0], [-0.1, 0.0, 0.0]])


def calendar(t: float) -> list[float]:
    """2017-01-25 23:59:59.996 + t seconds (crosses midnight after 4 ms)."""
    base = 86399.996 + t
    day = 25 + int(base // 86400)
    rest = base - (day - 25) * 86400
    hour, rest = divmod(rest, 3600)
    minute, second = divmod(rest, 60)
    return [2017, 1, day, int(hour), int(minute), round(second, 6)]


def write_table(path: Path, columns: list[str], rows) -> None:
    lines = ["\t".join(columns)]
    lines += ["\t".join(f"{v:.10g}" if isinstance(v, float) else str(v) for v in r) for r in rows]
    path.write_text("\n".join(lines) + "\n")


def make_recording(
    root: Path, *, vad: bool = True, sources=("1", "2"), source_times=None, timestamps: bool = True
) -> Path:
    """``<root>/dev/task6/recording3/dummy`` with 2 microphones, 2 talkers, 5 pose rows."""
    folder = root / "dev" / "task6" / "recording3" / "dummy"
    folder.mkdir(parents=True)
    rng = np.random.default_rng(0)
    audio = rng.uniform(-0.5, 0.5, (N_SAMPLES, 2))
    sf.write(folder / "audio_array_dummy.wav", audio, FS, subtype="DOUBLE")
    times = [0.0, 0.008, 0.016, 0.024, 0.032]
    write_table(
        folder / "required_time.txt",
        [*TIME, "valid_flag"],
        [[*calendar(t), v] for t, v in zip(times, [1, 1, 0, 1, 1], strict=True)],
    )
    arr_row = [*ARRAY_POS, *ROT[:, 0], *ROT.ravel()]
    mic_world = ARRAY_POS + MICS @ ROT.T
    write_table(
        folder / "position_array_dummy.txt",
        TIME + POSE + [f"mic{k}_{a}" for k in (1, 2) for a in "xyz"],
        [calendar(t) + arr_row + list(mic_world.ravel()) for t in times],
    )
    # talker 1 at p + world (0, 1, 0): in the array frame (1, 0, 0); talker 2 at p - x_world
    offsets = {"1": [0.0, 1.0, 0.0], "2": [-1.0, 0.0, 0.0], "10": [0.0, -1.0, 0.3]}
    stimes = times if source_times is None else source_times
    for s in sources:
        pos = ARRAY_POS + offsets[s]
        write_table(
            folder / f"position_source_{s}.txt",
            TIME + POSE,
            [[*calendar(t), *pos, 1.0, 0.0, 0.0, *np.eye(3).ravel()] for t in stimes],
        )
        sf.write(folder / f"audio_source_{s}.wav", rng.uniform(-0.1, 0.1, 20), FS)
        if vad:
            write_table(
                folder / f"VAD_dummy_{s}.txt",
                ["VAD"],
                [[int(i >= 10 * int(s[-1]))] for i in range(N_SAMPLES)],
            )
    if timestamps:
        write_table(
            folder / "audio_array_timestamps_dummy.txt",
            TIME,
            [calendar(0.004 + i / FS) for i in range(N_SAMPLES)],
        )
    return folder


def where(path: Path, row: int | None = None) -> str:
    return re.escape(f"{path}, row {row}: " if row is not None else f"{path}: ")


# --------------------------------------------------------------------------- fixture folder


def test_round_trip(tmp_path):
    folder = make_recording(tmp_path)
    rec = load_locata_recording(folder, fs=FS)
    assert rec.array_name == "dummy" and rec.fs == FS
    assert rec.audio.shape == (2, N_SAMPLES) and rec.n_mics == 2
    back, _ = sf.read(folder / "audio_array_dummy.wav", always_2d=True)
    np.testing.assert_array_equal(rec.audio, back.T)
    # times relative to the first required time, across midnight
    np.testing.assert_allclose(rec.required_times, [0, 0.008, 0.016, 0.024, 0.032], atol=1e-9)
    np.testing.assert_array_equal(rec.required_valid, [True, True, False, True, True])
    np.testing.assert_allclose(rec.audio_times, 0.004 + np.arange(N_SAMPLES) / FS, atol=1e-9)
    assert rec.origin == (2017.0, 1.0, 25.0, 23.0, 59.0, 59.996)
    np.testing.assert_allclose(rec.array.times, rec.required_times)
    np.testing.assert_allclose(rec.array.position, np.tile(ARRAY_POS, (5, 1)))
    np.testing.assert_allclose(rec.array.rotation[0], ROT)  # rotation_ij -> [i-1, j-1]
    np.testing.assert_allclose(rec.array.mics[3], ARRAY_POS + MICS @ ROT.T)
    assert rec.source_names == ("1", "2") and rec.n_sources == 2
    assert rec.vad.shape == (2, N_SAMPLES)
    assert rec.vad[0].sum() == N_SAMPLES - 10 and not rec.vad[1, 19] and rec.vad[1, 20]


def test_source_names_in_natural_order(tmp_path):
    rec = load_locata_recording(make_recording(tmp_path, sources=("10", "2", "1"), vad=False))
    assert rec.source_names == ("1", "2", "10")
    assert rec.vad is None


def test_azimuths_by_hand_in_both_conventions(tmp_path):
    rec = load_locata_recording(make_recording(tmp_path, sources=("1", "2", "10")))
    times, az = locata_source_azimuths(rec)
    np.testing.assert_allclose(times, rec.array.times)
    # v = R'(h - p): talker 1 -> (1, 0, 0) = 0°, talker 2 -> (0, 1, 0) = 90°,
    # talker 10 -> (-1, 0, 0.3) = 180°
    np.testing.assert_allclose(az, np.tile([0.0, 90.0, 180.0], (5, 1)), atol=1e-9)
    _, az_locata = locata_source_azimuths(rec, convention="locata")
    np.testing.assert_allclose(az_locata, np.tile([-90.0, 0.0, 90.0], (5, 1)), atol=1e-9)
    with pytest.raises(ValueError, match="convention must be"):
        locata_source_azimuths(rec, convention="matlab")


def test_azimuths_interpolate_other_source_times(tmp_path):
    folder = make_recording(tmp_path, sources=("1",), source_times=[0.004, 0.012, 0.020])
    # move talker 1 linearly from array-frame (1, 0) to (0, 1) between 4 ms and 20 ms
    rows = [
        [*calendar(t), *(ARRAY_POS + np.array([-f, 1 - f, 0])), 1.0, 0, 0, *np.eye(3).ravel()]
        for t, f in ((0.004, 0.0), (0.012, 0.5), (0.020, 1.0))
    ]
    write_table(folder / "position_source_1.txt", TIME + POSE, rows)
    rec = load_locata_recording(folder)
    _, az = locata_source_azimuths(rec)
    # at 8 ms (a quarter of the way) v = (0.75, 0.25); at 16 ms v = (0.25, 0.75)
    expected = np.degrees(np.arctan2([0.25, 0.75], [0.75, 0.25]))
    np.testing.assert_allclose(az[1:3, 0], expected, atol=1e-9)
    assert np.isnan(az[0, 0]) and np.all(np.isnan(az[3:, 0]))  # outside the source's span


def test_nan_positions_kept_or_rejected(tmp_path):
    folder = make_recording(tmp_path)
    path = folder / "position_source_2.txt"
    lines = path.read_text().splitlines()
    parts = lines[3].split("\t")
    parts[6] = "NaN"  # x of the third row
    lines[3] = "\t".join(parts)
    path.write_text("\n".join(lines) + "\n")
    rec = load_locata_recording(folder)
    _, az = locata_source_azimuths(rec)
    assert np.isnan(az[2, 1]) and not np.isnan(az[3, 1])
    with pytest.raises(InputError, match=where(path, 4) + "x is nan, expected a finite"):
        load_locata_recording(folder, allow_nan_positions=False)


# --------------------------------------------------------------------------- rejected input


def test_missing_files_are_named(tmp_path):
    folder = make_recording(tmp_path)
    (folder / "position_array_dummy.txt").unlink()
    with pytest.raises(InputError, match=where(folder / "position_array_dummy.txt") + "file"):
        load_locata_recording(folder)
    with pytest.raises(
        InputError,
        match=r"audio_array_eigenmike\.wav: file not found \(array "
        r"'eigenmike'; array audio here: \['audio_array_dummy",
    ):
        load_locata_recording(folder, array="eigenmike")
    (folder / "required_time.txt").unlink()
    with pytest.raises(InputError, match=where(folder / "required_time.txt") + "file not"):
        load_locata_recording(folder)
    with pytest.raises(InputError, match="recording folder not found"):
        load_locata_recording(tmp_path / "nowhere")


def test_wrong_sample_rate(tmp_path):
    folder = make_recording(tmp_path)
    with pytest.raises(
        InputError,
        match=r"audio_array_dummy\.wav: sample rate is 1000 Hz, "
        r"expected 48000 Hz",
    ):
        load_locata_recording(folder, fs=48000)


def test_microphone_columns_must_match_channels(tmp_path):
    folder = make_recording(tmp_path)
    sf.write(folder / "audio_array_dummy.wav", np.zeros((N_SAMPLES, 3)), FS)
    with pytest.raises(
        InputError,
        match=where(folder / "position_array_dummy.txt", 1)
        + r"microphone columns mic1_x \.\.\. mic3_z expected for the 3 audio "
        r"channels, found microphones \[1, 2\]",
    ):
        load_locata_recording(folder)


def _edit_line(path: Path, line: int, fn) -> None:
    lines = path.read_text().splitlines()
    lines[line - 1] = fn(lines[line - 1])
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize(
    ("name", "line", "edit", "message"),
    [
        (
            "required_time.txt",
            3,
            lambda s: s.rsplit("\t", 1)[0],
            "expected 7 values (one per header column), got 6",
        ),
        (
            "required_time.txt",
            4,
            lambda s: s.rsplit("\t", 1)[0] + "\tyes",
            "column 'valid_flag' is not a number: 'yes'",
        ),
        (
            "required_time.txt",
            5,
            lambda s: s.rsplit("\t", 1)[0] + "\t2",
            "valid_flag must be 0 or 1, got 2.0",
        ),
        (
            "required_time.txt",
            2,
            lambda s: s.replace("2017", "NaN", 1),
            "year is nan, expected a finite number",
        ),
        (
            "position_array_dummy.txt",
            3,
            lambda s: "\t".join(["2017", "2", "30", *s.split()[3:]]),
            "invalid date 2017-2-30",
        ),
        ("VAD_dummy_2.txt", 7, lambda s: "0.5", "VAD must be 0 or 1, got 0.5"),
    ],
)
def test_malformed_rows_are_named(tmp_path, name, line, edit, message):
    folder = make_recording(tmp_path)
    _edit_line(folder / name, line, edit)
    with pytest.raises(InputError, match=where(folder / name, line) + re.escape(message)):
        load_locata_recording(folder)


def test_missing_column_and_empty_table(tmp_path):
    folder = make_recording(tmp_path)
    path = folder / "position_source_1.txt"
    _edit_line(path, 1, lambda s: s.replace("rotation_23", "rot_23"))
    with pytest.raises(
        InputError, match=where(path, 1) + r"missing column\(s\) \['rotation_23'\]"
    ):
        load_locata_recording(folder)
    path.write_text("\t".join(TIME + POSE) + "\n")
    with pytest.raises(InputError, match=where(path) + "no data rows under the header"):
        load_locata_recording(folder)
    path.write_text("")
    with pytest.raises(InputError, match=where(path) + "empty file"):
        load_locata_recording(folder)


def test_vad_and_timestamp_lengths(tmp_path):
    folder = make_recording(tmp_path)
    vad = folder / "VAD_dummy_1.txt"
    vad.write_text("VAD\n" + "1\n" * (N_SAMPLES - 1))
    with pytest.raises(InputError, match=where(vad) + r"39 VAD rows for 40 audio samples"):
        load_locata_recording(folder)
    vad.unlink()
    with pytest.raises(InputError, match=where(vad) + r"file not found \(the other sources"):
        load_locata_recording(folder)
    folder2 = make_recording(tmp_path / "b", vad=False)
    ts = folder2 / "audio_array_timestamps_dummy.txt"
    ts.write_text("\n".join(ts.read_text().splitlines()[:-1]) + "\n")
    with pytest.raises(InputError, match=where(ts) + "39 timestamps for 40 audio samples"):
        load_locata_recording(folder2)


def test_nan_audio_rejected(tmp_path):
    folder = make_recording(tmp_path)
    audio = np.zeros((N_SAMPLES, 2))
    audio[5, 1] = np.nan
    sf.write(folder / "audio_array_dummy.wav", audio, FS, subtype="DOUBLE")
    with pytest.raises(InputError, match=r"audio_array_dummy\.wav: audio holds NaN"):
        load_locata_recording(folder)


# --------------------------------------------------------------------------- shared tracks


@pytest.fixture(scope="module")
def nao(shared_data) -> Path:
    return shared_data / "nao"


@pytest.mark.parametrize(("name", "n_frames"), [("LOCATA", 7875), ("Kinovis-MST", 4908)])
def test_shared_tracks_match_raw(nao, name, n_frames):
    tracks = load_locata_tracks(nao, name)
    raw_az = scipy.io.loadmat(nao / f"{name}-speakerPosition.mat")["speakerPosition"]
    raw_vad = scipy.io.loadmat(nao / f"{name}-speakerVAD.mat")["speakerVAD"]
    assert tracks.azimuth_deg.shape == tracks.vad.shape == (n_frames, 2)
    np.testing.assert_array_equal(tracks.azimuth_deg, raw_az)
    np.testing.assert_array_equal(tracks.vad, raw_vad == 1)
    np.testing.assert_allclose(np.diff(tracks.times), 0.008)
    assert tracks.times[0] == 0 and tracks.vad.dtype == bool
    assert np.all(np.abs(tracks.azimuth_deg) <= 180)
    assert tracks.azimuth_deg.min() < -170 and tracks.azimuth_deg.max() > 170  # full circle


def test_shared_track_entries(shared_data):
    tracks = load_locata_tracks(shared_data)  # the data root: looks in nao/
    np.testing.assert_allclose(tracks.azimuth_deg[0], [-47.763646693338984, -9.866193188264722])
    np.testing.assert_allclose(tracks.azimuth_deg[1000], [-6.348369555020914, 11.582570569665869])
    np.testing.assert_array_equal(tracks.vad[0], [False, False])
    np.testing.assert_array_equal(tracks.vad[1000], [True, True])
    np.testing.assert_allclose(tracks.vad.mean(axis=0), [0.918, 0.946], atol=1e-3)
    assert tracks.times[-1] == pytest.approx(7874 * 0.008)
    kinovis = load_locata_tracks(shared_data / "nao", "Kinovis-MST")
    np.testing.assert_allclose(kinovis.azimuth_deg[0], [26.919107, -89.677799])
    assert kinovis.vad[:, 0].all()


def test_track_files_rejected(tmp_path):
    az = np.zeros((4, 2))
    scipy.io.savemat(tmp_path / "X-speakerPosition.mat", {"speakerPosition": az})
    scipy.io.savemat(tmp_path / "X-speakerVAD.mat", {"speakerVAD": np.ones((3, 2))})
    with pytest.raises(
        InputError,
        match=r"X-speakerVAD\.mat: speakerVAD is 3 × 2 but "
        r"speakerPosition is 4 × 2",
    ):
        load_locata_tracks(tmp_path, "X")
    scipy.io.savemat(tmp_path / "X-speakerVAD.mat", {"speakerVAD": np.full((4, 2), 2.0)})
    with pytest.raises(InputError, match=re.escape("row 1, talker 1: 2.0 is not 0 or 1")):
        load_locata_tracks(tmp_path, "X")
    az[2, 1] = np.nan
    scipy.io.savemat(tmp_path / "X-speakerPosition.mat", {"speakerPosition": az})
    with pytest.raises(
        InputError,
        match=r"speakerPosition row 3, talker 2: nan is not an "
        r"azimuth",
    ):
        load_locata_tracks(tmp_path, "X")
    with pytest.raises(InputError, match=r"Y-speakerPosition\.mat: file not found"):
        load_locata_tracks(tmp_path, "Y")
    with pytest.raises(ValueError, match="frame_s must be > 0"):
        load_locata_tracks(tmp_path, "X", frame_s=0)


def test_tracks_dataclass_validates():
    with pytest.raises(ValueError, match=r"in \[-180, 180\]"):
        LOCATATracks(np.arange(2.0), np.array([[0.0], [190.0]]), np.ones((2, 1)))
    with pytest.raises(ValueError, match="need times"):
        LOCATATracks(np.arange(3.0), np.zeros((2, 1)), np.ones((2, 1)))
