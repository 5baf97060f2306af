"""Tests of avtrack.io.doa: azimuth wrapping, CSV round trips (Hypothesis), and malformed
files naming their file and row."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avtrack.errors import InputError
from avtrack.io.doa import DOA_HEADER, DOATable, read_doa_csv, wrap_azimuth, write_doa_csv


def where(path: Path, row: int | None = None) -> str:
    return re.escape(f"{path}, row {row}: " if row is not None else f"{path}: ")


def table(**kw) -> DOATable:
    cols = dict(
        frames=[0, 0, 1],
        time_s=[0.0, 0.0, 0.016],
        ids=[-1, -1, 3],
        azimuth_deg=[10.0, -170.5, 180.0],
        elevation_deg=[0.0, 5.0, -12.25],
        weight=[0.5, 0.25, 1.0],
        active=[True, False, True],
    )
    cols.update(kw)
    return DOATable(**{k: np.asarray(v) for k, v in cols.items()})


# ---------------------------------------------------------------------------- wrapping


def test_wrap_azimuth_hand_cases():
    got = wrap_azimuth(np.array([0.0, 180.0, -180.0, 540.0, 190.0, -190.0, 360.0, -0.0, 179.5]))
    np.testing.assert_array_equal(got, [0.0, 180.0, 180.0, 180.0, -170.0, 170.0, 0.0, 0.0, 179.5])
    assert wrap_azimuth(-180.0) == 180.0 and isinstance(wrap_azimuth(-180.0), float)


@given(st.floats(-1e6, 1e6))
def test_wrap_azimuth_range_and_equivalence(x):
    w = wrap_azimuth(x)
    assert -180.0 < w <= 180.0
    d = (w - x) % 360.0
    assert min(d, 360.0 - d) < 1e-6


# ---------------------------------------------------------------------------- round trips


def test_write_format_and_read_back(tmp_path):
    t = table()
    path = tmp_path / "sub" / "doa.csv"
    write_doa_csv(path, t)
    lines = path.read_text().splitlines()
    assert lines[0] == DOA_HEADER
    assert lines[1] == "0,0.0000,-1,10.000,0.000,0.5,1"
    assert lines[3] == "1,0.0160,3,180.000,-12.250,1,1"
    back = read_doa_csv(path)
    for name in ("frames", "ids", "active"):
        np.testing.assert_array_equal(getattr(back, name), getattr(t, name))
    for name in ("time_s", "azimuth_deg", "elevation_deg", "weight"):
        np.testing.assert_allclose(getattr(back, name), getattr(t, name))
    assert back.active.dtype == bool and back.frames.dtype == np.int64


def test_empty_table_round_trip(tmp_path):
    path = tmp_path / "doa.csv"
    write_doa_csv(path, DOATable.empty())
    assert path.read_text() == DOA_HEADER + "\n"
    assert len(read_doa_csv(path)) == 0


def test_table_wraps_azimuth_and_validates():
    t = table(azimuth_deg=[370.0, -180.0, 725.0])
    np.testing.assert_allclose(t.azimuth_deg, [10.0, 180.0, 5.0])
    assert len(t.select(t.active)) == 2
    with pytest.raises(ValueError, match=r"elevation_deg must be in \[-90, 90\]"):
        table(elevation_deg=[0.0, 91.0, 0.0])
    with pytest.raises(ValueError, match="weight must be finite"):
        table(weight=[0.0, np.nan, 0.0])
    with pytest.raises(ValueError, match=r"ids must be >= -1"):
        table(ids=[-2, 0, 0])
    with pytest.raises(ValueError, match=r"time_s must have shape \(K,\)"):
        table(time_s=[0.0, 1.0])
    with pytest.raises(ValueError, match="frames must be integers"):
        table(frames=[0.5, 1.0, 2.0])


rows = st.tuples(
    st.integers(0, 10**6),
    st.floats(0, 1e5),
    st.integers(-1, 1000),
    st.floats(-720, 720),
    st.floats(-90, 90),
    st.floats(-1e6, 1e6, allow_subnormal=False),
    st.booleans(),
)


@settings(max_examples=60, deadline=None)
@given(st.lists(rows, max_size=12))
def test_round_trip_hypothesis(tmp_path_factory, data):
    path = tmp_path_factory.mktemp("doa") / "doa.csv"
    if data:
        cols = [np.array(c) for c in zip(*data, strict=True)]
        t = DOATable(*cols)
    else:
        t = DOATable.empty()
    write_doa_csv(path, t)
    back = read_doa_csv(path)
    np.testing.assert_array_equal(back.frames, t.frames)
    np.testing.assert_array_equal(back.ids, t.ids)
    np.testing.assert_array_equal(back.active, t.active)
    np.testing.assert_allclose(back.time_s, t.time_s, rtol=0, atol=5.1e-5)
    np.testing.assert_allclose(back.elevation_deg, t.elevation_deg, rtol=0, atol=5.1e-4)
    d = np.abs(wrap_azimuth(back.azimuth_deg - t.azimuth_deg))
    assert np.all(d <= 5.1e-4)
    assert np.all((back.azimuth_deg > -180) & (back.azimuth_deg <= 180))
    np.testing.assert_allclose(back.weight, t.weight, rtol=1e-5, atol=1e-300)


# ---------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    ("row", "match"),
    [
        ("0,0.0,-1,10,0,1", "expected 7 comma-separated values"),
        ("x,0.0,-1,10,0,1,1", "frame must be an integer, got 'x'"),
        ("0.5,0.0,-1,10,0,1,1", "frame must be an integer, got '0.5'"),
        ("0,abc,-1,10,0,1,1", "time_s is not a number: 'abc'"),
        ("0,0.0,-1,nan,0,1,1", "azimuth_deg is 'nan', expected a finite number"),
        ("0,0.0,-1,10,0,inf,1", "weight is 'inf', expected a finite number"),
        ("0,0.0,-1,-180,0,1,1", r"azimuth_deg must be in \(-180, 180\], got -180"),
        ("0,0.0,-1,270.5,0,1,1", r"azimuth_deg must be in \(-180, 180\], got 270.5"),
        ("0,0.0,-1,10,-95,1,1", r"elevation_deg must be in \[-90, 90\]"),
        ("0,0.0,-1,10,0,1,yes", "active must be 1 or 0, got 'yes'"),
        ("-1,0.0,-1,10,0,1,1", "frame must be >= 0"),
        ("0,-0.5,-1,10,0,1,1", "time_s must be >= 0"),
        ("0,0.0,-4,10,0,1,1", "id must be >= -1"),
    ],
)
def test_malformed_rows_name_file_and_row(tmp_path, row, match):
    path = tmp_path / "doa.csv"
    path.write_text(f"{DOA_HEADER}\n0,0.0,-1,10,0,1,1\n{row}\n")
    with pytest.raises(InputError, match=where(path, 3) + match):
        read_doa_csv(path)


def test_wrong_header_missing_and_empty_files(tmp_path):
    path = tmp_path / "doa.csv"
    path.write_text("frame,time,id,azimuth_deg,elevation_deg,weight,active\n0,0,-1,1,0,1,1\n")
    with pytest.raises(InputError, match=where(path, 1) + "header must be"):
        read_doa_csv(path)
    path.write_text("")
    with pytest.raises(InputError, match=where(path) + "empty file"):
        read_doa_csv(path)
    with pytest.raises(InputError, match="file not found"):
        read_doa_csv(tmp_path / "missing.csv")


def test_true_false_and_blank_lines_accepted(tmp_path):
    path = tmp_path / "doa.csv"
    path.write_text(f"{DOA_HEADER}\n3,0.024,2,-45,10,0.1,true\n\n4,0.032,2,-44,10,0.1,False\n")
    t = read_doa_csv(path)
    np.testing.assert_array_equal(t.active, [True, False])
    np.testing.assert_array_equal(t.frames, [3, 4])


def test_azimuths_per_frame_takes_active_rows_at_the_nearest_frame():
    from avtrack.io.doa import azimuths_per_frame

    table = DOATable(np.array([0, 1, 2, 3]), np.array([0.0, 0.019, 0.021, 0.5]),
                     np.array([-1, -1, -1, -1]), np.array([10.0, 20.0, 30.0, 40.0]),
                     np.zeros(4), np.ones(4), np.array([True, True, False, True]))
    out = azimuths_per_frame(table, fps=50.0, n_frames=3)  # frames every 0.02 s
    assert [v.tolist() for v in out] == [[10.0], [20.0], []]  # 0.5 s is past frame 2
