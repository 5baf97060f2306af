"""Tests of avtrack.audio.arrays: built-in arrays, JSON files, steering delays."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import avtrack.io.datasets
from avtrack.audio import hrtf
from avtrack.audio.arrays import (
    BUILTIN_ARRAYS,
    NAO12_POSITIONS,
    SPEED_OF_SOUND,
    MicArray,
    builtin_array,
    load_array,
    steering_delays,
    write_array_json,
)
from avtrack.errors import InputError

# ---------------------------------------------------------------------------- built-ins


def test_nao_subsets():
    assert NAO12_POSITIONS.shape == (12, 3)
    np.testing.assert_allclose(NAO12_POSITIONS[4], [-0.031, 0.023, 0.042])
    nao4 = builtin_array("nao4")
    assert nao4.kind == "free-field" and nao4.hrir is None and nao4.n_mics == 4
    np.testing.assert_allclose(nao4.positions, NAO12_POSITIONS[[4, 7, 10, 11]])
    nao8 = builtin_array("nao8")
    np.testing.assert_allclose(nao8.positions, NAO12_POSITIONS[[0, 2, 3, 4, 7, 9, 10, 11]])
    np.testing.assert_allclose(builtin_array("nao12").positions, NAO12_POSITIONS)


def test_av163_rings():
    a = builtin_array("av163")
    assert a.n_mics == 16 and a.kind == "free-field"
    for ring, centre in ((a.positions[:8], [0, 0.4, 0]), (a.positions[8:], [0, -0.4, 0])):
        rel = ring - centre
        np.testing.assert_allclose(np.linalg.norm(rel, axis=1), 0.1)
        np.testing.assert_allclose(rel[:, 2], 0.0)
        az = np.rad2deg(np.arctan2(rel[:, 1], rel[:, 0]))
        np.testing.assert_allclose(np.mod(az, 360), 45.0 * np.arange(8), atol=1e-9)


def test_hrtf_builtins(shared_data):
    kemar = builtin_array("kemar")
    assert kemar.kind == "hrtf" and kemar.n_mics == 2 and kemar.hrir.source == "kemar"
    np.testing.assert_allclose(kemar.positions, [[0, 0.09, 0], [0, -0.09, 0]])
    assert builtin_array("kemar", hrir=False).kind == "free-field"
    a = builtin_array("nao4", hrir=True)
    b = builtin_array("nao4-hrir")
    assert a.kind == b.kind == "hrtf" and a.name == "nao4-hrir" and a.hrir is b.hrir
    np.testing.assert_allclose(a.positions, builtin_array("nao4").positions)


def test_builtin_errors():
    with pytest.raises(ValueError, match="name must be one of"):
        builtin_array("nao5")
    with pytest.raises(ValueError, match="no measured HRIRs for 'nao8'"):
        builtin_array("nao8", hrir=True)
    with pytest.raises(ValueError, match="hrir must be True, False or None"):
        builtin_array("nao4", hrir="yes")


def test_hrtf_builtin_without_shared_data(monkeypatch):
    def absent():
        raise InputError("shared data folder not found")

    monkeypatch.setattr(avtrack.io.datasets, "find_shared_data", absent)
    hrtf.builtin_hrir.cache_clear()
    try:
        with pytest.raises(InputError, match="'nao' HRIRs need the shared data"):
            builtin_array("nao4-hrir")
        with pytest.raises(InputError, match="'kemar' HRIRs need the shared data"):
            load_array("kemar")
        assert builtin_array("nao4").n_mics == 4  # free-field built-ins need no data
    finally:
        hrtf.builtin_hrir.cache_clear()


@pytest.mark.parametrize("name", [n for n in BUILTIN_ARRAYS if n not in ("kemar", "nao4-hrir")])
def test_load_array_builtin_names(name):
    assert load_array(name).n_mics == builtin_array(name).n_mics


# ---------------------------------------------------------------------------- MicArray


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (("", [[0, 0, 0]]), "name must be a non-empty string"),
        (("a", [[0, 0]]), r"positions must have shape \(n_mics, 3\)"),
        (("a", [[0, 0, np.nan]]), "positions must be finite"),
        (("a", [[0, 0, 0]], "omni"), "kind must be one of"),
        (("a", [[0, 0, 0]], "hrtf"), "kind 'hrtf' needs hrir"),
    ],
)
def test_micarray_validation(args, match):
    with pytest.raises(ValueError, match=match):
        MicArray(*args)


def test_micarray_hrir_count_mismatch():
    h = hrtf.HRIRSet([0.0], [0.0], np.zeros((1, 2, 4)), 16000)
    with pytest.raises(ValueError, match="hrir has 2 microphones but positions has 3"):
        MicArray("a", np.zeros((3, 3)), "hrtf", h)
    with pytest.raises(ValueError, match="hrir must be None"):
        MicArray("a", np.zeros((2, 3)), "free-field", h)
    with pytest.raises(ValueError, match="no source"):
        MicArray("a", np.zeros((2, 3)), "hrtf", h).to_json()


# ---------------------------------------------------------------------------- JSON


def test_json_round_trip_free_field(tmp_path):
    a = builtin_array("av163")
    write_array_json(tmp_path / "sub" / "a.json", a)
    b = load_array(tmp_path / "sub" / "a.json")
    assert (b.name, b.kind) == ("av163", "free-field")
    np.testing.assert_allclose(b.positions, a.positions)
    assert MicArray.from_json(a.to_json()).n_mics == 16


def test_json_round_trip_hrtf(shared_data, tmp_path):
    a = builtin_array("kemar")
    path = tmp_path / "k.json"
    write_array_json(path, a)
    assert json.loads(path.read_text())["hrir"] == {"builtin": "kemar"}
    b = load_array(path)
    assert b.kind == "hrtf" and b.hrir.irs.shape == a.hrir.irs.shape
    # a relative SOFA path is resolved against the JSON file's folder
    sofa = tmp_path / "heads" / "kemar.sofa"
    sofa.parent.mkdir()
    sofa.write_bytes((shared_data / "hrtf/mit_kemar_normal_pinna.sofa").read_bytes())
    d = {"name": "h", "positions": [[0, 0.09, 0], [0, -0.09, 0]], "kind": "hrtf"}
    d["hrir"] = {"sofa": "heads/kemar.sofa"}
    (tmp_path / "h.json").write_text(json.dumps(d))
    c = load_array(tmp_path / "h.json")
    assert c.hrir.n_directions == 710
    assert c.to_json()["hrir"] == {"sofa": str(sofa)}


@pytest.mark.parametrize(
    ("content", "match"),
    [
        ("{", "invalid JSON"),
        ("[1, 2]", "expected a JSON object"),
        ('{"positions": [[0, 0, 0]]}', "field 'name'"),
        ('{"name": "a"}', "field 'positions' is missing"),
        ('{"name": "a", "positions": []}', "field 'positions'"),
        ('{"name": "a", "positions": [[0, 0]]}', "field 'positions'.*entry 0"),
        ('{"name": "a", "positions": [[0, 0, "x"]]}', "field 'positions'.*entry 0"),
        ('{"name": "a", "positions": [[0, 0, 0]], "kind": "omni"}', "field 'kind'"),
        ('{"name": "a", "positions": [[0, 0, 0]], "kind": "hrtf"}', "field 'hrir' is required"),
        (
            '{"name": "a", "positions": [[0, 0, 0]], "kind": "hrtf", "hrir": {"builtin": "x"}}',
            "field 'hrir.builtin'",
        ),
        (
            '{"name": "a", "positions": [[0, 0, 0]], "kind": "hrtf", "hrir": {"sofa": "no.sofa"}}',
            "field 'hrir.sofa': no such file",
        ),
        (
            '{"name": "a", "positions": [[0, 0, 0]], "kind": "hrtf", "hrir": "kemar"}',
            "field 'hrir': expected",
        ),
        ('{"name": "a", "positions": [[0, 0, 0]], "hrir": {"builtin": "nao"}}', "only allowed"),
        ('{"name": "a", "positions": [[0, 0, 0]], "colour": 1}', "unknown field"),
    ],
)
def test_load_array_errors_name_file_and_field(tmp_path, content, match):
    path = tmp_path / "bad_array.json"
    path.write_text(content)
    with pytest.raises(InputError, match=match) as info:
        load_array(path)
    assert "bad_array.json" in str(info.value)


def test_load_array_hrir_mic_count(shared_data, tmp_path):
    path = tmp_path / "a.json"
    d = {"name": "a", "positions": [[0, 0, 0]], "kind": "hrtf", "hrir": {"builtin": "kemar"}}
    path.write_text(json.dumps(d))
    with pytest.raises(InputError, match="2 microphones but 'positions' has 1"):
        load_array(path)


def test_load_array_missing():
    with pytest.raises(InputError, match="not a built-in array"):
        load_array("no_such_array.json")


# ---------------------------------------------------------------------------- steering


def test_steering_delays_hand_computed():
    a = MicArray("pair", [[0.1, 0, 0], [-0.1, 0, 0]])
    np.testing.assert_allclose(
        steering_delays(a, 0.0), [-0.1 / SPEED_OF_SOUND, 0.1 / SPEED_OF_SOUND]
    )
    np.testing.assert_allclose(steering_delays(a, 90.0), [0, 0], atol=1e-15)
    np.testing.assert_allclose(
        steering_delays(a, 180.0, 0.0), np.array([0.1, -0.1]) / SPEED_OF_SOUND
    )
    np.testing.assert_allclose(steering_delays(a, 0.0, 90.0), [0, 0], atol=1e-15)
    b = MicArray("y", [[0, 0.1, 0], [0, -0.1, 0]])
    assert steering_delays(b, 90.0)[0] < 0  # +90 is left (+y): the left mic hears first
    assert steering_delays(b, [0.0, 90.0, -90.0]).shape == (3, 2)


@settings(max_examples=50, deadline=None)
@given(st.floats(-720, 720), st.floats(-90, 90))
def test_steering_delays_invariants(az, el):
    a = builtin_array("nao12")
    tau = steering_delays(a, az, el)
    assert abs(tau.sum()) < 1e-15  # relative to the centre (mean position)
    np.testing.assert_allclose(tau, steering_delays(a, az + 360.0, el), atol=1e-15)
    assert np.max(np.abs(tau)) <= a.radius / SPEED_OF_SOUND + 1e-15


def test_steering_delays_rejects_nan():
    with pytest.raises(ValueError, match="azimuth_deg and elevation_deg must be finite"):
        steering_delays(builtin_array("nao4"), np.nan)
