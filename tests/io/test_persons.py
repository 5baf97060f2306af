"""persons.csv: written by track-av, read back by eval persons."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.errors import InputError
from avtrack.io.persons import PERSONS_HEADER, PersonsTable, read_persons_csv


def table() -> PersonsTable:
    return PersonsTable(
        np.array([1, 1, 2]), np.array([1, 2, 1]), np.array([-20.0, 75.5, -19.0]),
        np.array([10.0, 0.0, 10.5]), np.array([[320.0, 100.0], [np.nan, np.nan], [318.0, 99.0]]),
        np.array([True, False, True]), np.array([0.0, 0.9, 0.25]), 25.0,
    )


def test_round_trip(tmp_path):
    path = tmp_path / "persons.csv"
    path.write_text(table().to_csv())
    lines = path.read_text().splitlines()
    assert lines[0] == PERSONS_HEADER and lines[2] == "1,0.0000,2,75.50,0.00,,,0,0.900"
    back = read_persons_csv(path)
    assert back.fps == pytest.approx(25.0)
    np.testing.assert_array_equal(back.ids, [1, 2, 1])
    np.testing.assert_allclose(back.azimuth_deg, [-20.0, 75.5, -19.0])
    assert np.isnan(back.pixels[1]).all() and back.in_view.tolist() == [True, False, True]


@pytest.mark.parametrize(
    ("row", "message"),
    [
        ("1,0.0,1,-20,10,320,", "expected 9 comma-separated values"),
        ("0,0.0,1,-20,10,320,100,1,0.5", "frame must be >= 1"),
        ("1,0.0,x,-20,10,320,100,1,0.5", "integers"),
        ("1,0.0,1,200,10,320,100,1,0.5", "azimuth_deg must be in"),
        ("1,0.0,1,-20,10,320,,1,0.5", "x and y must both"),
        ("1,0.0,1,-20,10,320,100,2,0.5", "in_view must be 0 or 1"),
        ("1,0.0,1,-20,10,320,100,1,1.5", "speaking must be a probability"),
        ("1,0.0,1,nan,10,320,100,1,0.5", "azimuth_deg is 'nan'"),
    ],
)
def test_bad_rows_name_file_row_and_field(tmp_path, row, message):
    path = tmp_path / "p.csv"
    path.write_text(PERSONS_HEADER + "\n" + row + "\n")
    with pytest.raises(InputError, match=message) as err:
        read_persons_csv(path)
    assert "row 2" in str(err.value) and "p.csv" in str(err.value)


def test_bad_files(tmp_path):
    with pytest.raises(InputError, match="file not found"):
        read_persons_csv(tmp_path / "none.csv")
    (tmp_path / "e.csv").write_text("")
    with pytest.raises(InputError, match="empty file"):
        read_persons_csv(tmp_path / "e.csv")
    (tmp_path / "h.csv").write_text("frame,id\n")
    with pytest.raises(InputError, match="header must be"):
        read_persons_csv(tmp_path / "h.csv")
    (tmp_path / "only.csv").write_text(PERSONS_HEADER + "\n")
    assert len(read_persons_csv(tmp_path / "only.csv")) == 0
