"""Acoustic pipelines on a recording read in blocks: the rows of the whole-signal computation,
handed on as they come, and the reader's rules checked before any block."""

from __future__ import annotations

import numpy as np
import pytest
import soundfile as sf

from avtrack.audio.recording import ArrayRecording, BlockResampler, read_array_audio
from avtrack.doa.base import frames_to_table
from avtrack.errors import InputError
from avtrack.io.doa import DOATable
from avtrack.localize import make_localizer, peak_table
from avtrack.pipelines import localize_recording, track_recording
from avtrack.stream import DOAStream
from tests.stream.test_stream import batch_doa_tracks, meeting


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    array, x = meeting()
    path = tmp_path_factory.mktemp("rec") / "meeting.wav"
    sf.write(path, x.T, 16000, subtype="DOUBLE")
    return array, x, path


def _same_table(a: DOATable, b: DOATable) -> None:
    for name in ("frames", "time_s", "ids", "azimuth_deg", "elevation_deg", "weight", "active"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


@pytest.mark.parametrize(("method", "block_s"), [("dprtf-eg", 0.05), ("dprtf-eg", 1.0),
                                                  ("dprtf-eg-smooth", 0.05)])
def test_localize_recording_gives_the_whole_signal_peaks(recording, method, block_s):
    """Block by block, the peaks of the whole signal's maps; a smoothing map's last frames
    (held back 0.2 s) come at the end."""
    array, x, path = recording
    loc = make_localizer(method, array)
    heat = loc.run(x)
    expected = peak_table(heat, loc.grid, 0.05, None, None, loc.profile_reduce)
    chunks: list[DOATable] = []
    run = localize_recording(ArrayRecording(path, array, block_s=block_s), loc, 0.05,
                             sink=chunks.append, keep_table=True)
    assert len(chunks) > 1  # handed on block by block
    _same_table(DOATable.concatenate(chunks), expected)
    _same_table(run.table, expected)
    assert run.n_frames == len(heat) and run.n_active == int(expected.active.sum())
    assert run.heat is None


def test_track_recording_gives_the_batch_tracks(recording):
    array, x, path = recording
    seq, outs = batch_doa_tracks(array, x, "vonmises")
    expected = frames_to_table(outs, seq.frames, seq.time_s)
    seen: list[float] = []
    run = track_recording(ArrayRecording(path, array, block_s=0.5),
                          DOAStream(array, tracker="vonmises"), keep_table=True,
                          progress=seen.append)
    _same_table(run.table, expected)
    assert run.n_frames == len(seq) and run.track_ids == frozenset(expected.ids.tolist())
    assert seen == sorted(seen) and seen[-1] == pytest.approx(x.shape[1] / 16000)


@pytest.mark.parametrize("fs", [8000, 22050, 44100, 48000])
def test_block_resampler_matches_resample_poly(fs):
    import scipy.signal

    rng = np.random.default_rng(0)
    x = rng.standard_normal((2, fs + 123))
    whole = scipy.signal.resample_poly(x, *_ratio(fs), axis=1)
    res = BlockResampler(fs, 16000)
    for size in (res.down, 7 * res.down, 10 * res.down + 0, x.shape[1]):
        parts = list(res.blocks(iter([x[:, i : i + size] for i in range(0, x.shape[1], size)]),
                                x.shape[1]))
        np.testing.assert_allclose(np.concatenate(parts, axis=1), whole, rtol=0, atol=1e-12)


def _ratio(fs: int) -> tuple[int, int]:
    from fractions import Fraction

    r = Fraction(16000, fs)
    return r.numerator, r.denominator


def test_resampled_recording_in_blocks_equals_the_whole_file(tmp_path):
    from avtrack.audio.arrays import builtin_array

    array = builtin_array("respeaker4")
    rng = np.random.default_rng(1)
    x = 0.1 * rng.standard_normal((4, 44100 + 555))
    path = tmp_path / "a.wav"
    sf.write(path, x.T, 44100, subtype="FLOAT")
    whole = read_array_audio(path, array, quiet=True)
    blocks = list(ArrayRecording(path, array, quiet=True, block_s=0.1).blocks())
    assert len(blocks) > 5
    np.testing.assert_allclose(np.concatenate(blocks, axis=1), whole, rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda x: x[:, :100], "too short"),
        (lambda x: 0 * x, "silent"),
        (lambda x: np.clip(50 * x, -1, 1), "clipped"),
        (lambda x: x[:3], "3 channel"),
    ],
)
def test_recording_rules_are_checked_before_any_block(tmp_path, make, match):
    from avtrack.audio.arrays import builtin_array

    array = builtin_array("respeaker4")
    x = 0.1 * np.random.default_rng(2).standard_normal((4, 16000))
    x[:, -10:] = make(x)[:, -10:] if make(x).shape == x.shape else x[:, -10:]
    bad = make(x)
    path = tmp_path / "bad.wav"
    sf.write(path, bad.T, 16000, subtype="FLOAT")
    with pytest.raises(InputError, match=match):
        ArrayRecording(path, array)
