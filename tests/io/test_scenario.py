"""Scenario validation and the named-scenario library."""

from __future__ import annotations

import copy

import pytest
import yaml

from avtrack.errors import InputError
from avtrack.io.scenario import (
    SCENARIO_REFERENCE,
    dump_scenario,
    load_scenario,
    validate_scenario,
)
from avtrack.simulate.library import SCENARIOS, named_scenario

MINIMAL = {"people": [{"motion": {"type": "seated", "position": [2.0, 3.0, 1.2]}}]}


def test_minimal_scenario_gets_defaults():
    sc = validate_scenario(MINIMAL)
    assert sc["duration"] == 20.0 and sc["fs"] == 16000 and sc["room"]["t60"] == 0.4
    assert sc["people"][0]["id"] == 1
    assert sc["people"][0]["motion"]["sway"] == 0.03


def test_reference_text_is_a_valid_scenario():
    sc = validate_scenario(yaml.safe_load(SCENARIO_REFERENCE))
    assert len(sc["people"]) == 4


def _with(path: str, value):
    raw = copy.deepcopy(MINIMAL)
    node = raw
    keys = path.split(".")
    for k in keys[:-1]:
        node = node.setdefault(k, {}) if not k.isdigit() else node[int(k)]
    node[keys[-1]] = value
    return raw


@pytest.mark.parametrize(
    ("path", "value", "match"),
    [
        ("duration", -1, r"duration: expected a number > 0"),
        ("duration", "long", r"duration: expected a number, got 'long'"),
        ("seed", 1.5, r"seed: expected an integer"),
        ("room.dims", [6, 5], r"room.dims: expected a list of 3 numbers"),
        ("room.dims", [6, 0.5, 3], r"room.dims\[1\]: expected a size in \[1, 100\]"),
        ("room.t60", -0.1, r"room.t60: expected a number >= 0"),
        ("room.volume", 3, r"room.volume: unknown field"),
        ("array.position", [9, 1, 1], r"array.position\[0\]: 9.0 is outside the room"),
        ("array.hrir", "yes", r"array.hrir: expected true or false"),
        ("camera.hfov_deg", 200, r"camera.hfov_deg: expected a number <= 170"),
        ("speech.mode", "chat", r"speech.mode: expected one of turn-taking, vad"),
        ("speech.mode", "vad", r"speech.mode: 'vad' needs at least one person"),
        ("noise.fan_snr_db", "loud", r"noise.fan_snr_db: expected a number"),
        ("detector.miss_rate", 1.5, r"detector.miss_rate: expected a number <= 1"),
        ("colour", "red", r"colour: unknown field"),
        ("people", [], r"people: expected a non-empty list"),
        ("people.0.motion", {"type": "fly"}, r"people\[0\].motion.type: expected one of"),
        ("people.0.motion", {"type": "seated"}, r"people\[0\].motion.position: required"),
        (
            "people.0.motion",
            {"type": "random-walk", "area": [[1, 9], [1, 2]]},
            r"people\[0\].motion.area\[0\]: expected 0 < min < max < 6.0",
        ),
        (
            "people.0.motion",
            {"type": "waypoints", "waypoints": [[0, 1, 1, 1], [0, 2, 2, 1]]},
            r"people\[0\].motion.waypoints\[1\]: times must be strictly increasing",
        ),
        (
            "people.0.motion",
            {"type": "azimuth-track", "track": "locata", "column": 2},
            r"people\[0\].motion.column: expected an integer <= 1",
        ),
        ("people.0.present", [[3, 1]], r"people\[0\].present\[0\]: expected end > start"),
        ("people.0.speed", 1, r"people\[0\].speed: unknown field"),
    ],
)
def test_each_bad_field_is_named(path, value, match):
    with pytest.raises(InputError, match=match):
        validate_scenario(_with(path, value), "s.yaml")


def test_duplicate_ids_rejected():
    raw = {"people": [MINIMAL["people"][0] | {"id": 3}, MINIMAL["people"][0] | {"id": 3}]}
    with pytest.raises(InputError, match=r"people\[1\].id: duplicate id 3"):
        validate_scenario(raw)


def test_load_scenario_errors_name_the_file(tmp_path):
    with pytest.raises(InputError, match="not found"):
        load_scenario(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("room: [unclosed\n")
    with pytest.raises(InputError, match=r"bad.yaml.*not valid YAML"):
        load_scenario(bad)
    empty = tmp_path / "empty.yaml"
    empty.write_text("")
    with pytest.raises(InputError, match="empty scenario"):
        load_scenario(empty)
    wrong = tmp_path / "wrong.yaml"
    wrong.write_text(yaml.safe_dump(_with("room.t60", "x")))
    with pytest.raises(InputError, match=r"wrong.yaml: room.t60"):
        load_scenario(wrong)


def test_dump_round_trips(tmp_path):
    sc = validate_scenario(named_scenario("walkout", seed=1))
    path = tmp_path / "scene.yaml"
    path.write_text(dump_scenario(sc))
    assert load_scenario(path) == sc


@pytest.mark.parametrize("name", list(SCENARIOS))
def test_named_scenarios_valid_for_many_seeds(name):
    for seed in range(25):
        for duration in (5.0, 20.0):
            sc = validate_scenario(named_scenario(name, seed, duration))
            assert sc["seed"] == seed and sc["duration"] == duration


@pytest.mark.parametrize("name", list(SCENARIOS))
def test_named_scenarios_are_seeded(name):
    assert named_scenario(name, 4) == named_scenario(name, 4)
    assert any(named_scenario(name, 4) != named_scenario(name, s) for s in range(5, 9))


def test_meeting_has_two_to_four_people():
    counts = {len(named_scenario("meeting", s)["people"]) for s in range(40)}
    assert counts == {2, 3, 4}


def test_unknown_named_scenario():
    with pytest.raises(ValueError, match="unknown scenario 'party'"):
        named_scenario("party")
