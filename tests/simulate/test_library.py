"""Named scenarios: valid, seeded, and within their documented ranges."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.audio.arrays import builtin_array
from avtrack.io.scenario import validate_scenario
from avtrack.simulate.library import SCENARIOS, demo_scenario, named_scenario


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_every_named_scenario_is_valid(name, shared_data):
    sc = validate_scenario(named_scenario(name, 3, 5.0))
    assert sc["duration"] == 5.0 and sc["seed"] == 3


@pytest.mark.parametrize("seed", range(8))
def test_array_talkers_are_still_talkers_around_a_respeaker_array(seed):
    raw = named_scenario("array-talkers", seed, 6.0)
    sc = validate_scenario(raw)
    assert sc["array"]["name"] == "respeaker4" and sc["sensors"]["self_noise_snr_db"] == 10.0
    assert sc["noise"]["diffuse_snr_db"] is None and 0.2 <= sc["room"]["t60"] <= 0.45
    centre = np.asarray(sc["array"]["position"])
    people = sc["people"]
    assert 1 <= len(people) <= 3
    az = []
    for p in people:
        rel = np.asarray(p["motion"]["position"]) - centre
        dist = np.linalg.norm(rel)
        el = np.degrees(np.arcsin(rel[2] / dist))
        assert 0.3 <= dist <= 2.5 + 1e-6 and 0.0 < el <= 50.0 + 1e-6
        az.append(np.degrees(np.arctan2(rel[1], rel[0])))
    gaps = np.abs((np.subtract.outer(az, az) + 180) % 360 - 180)[np.triu_indices(len(az), 1)]
    assert np.all(gaps >= 35.0)  # 40 degrees apart before the walls clip a position
    assert raw == named_scenario("array-talkers", seed, 6.0)  # the seed decides everything
    side = np.linalg.norm(np.diff(builtin_array("respeaker4").positions, axis=0), axis=1)
    np.testing.assert_allclose(side, 0.0457)


def test_demo_scenario_has_three_people_and_nao4():
    for seed in (0, 1, 7):
        sc = demo_scenario(seed, 10.0)
        assert len(sc["people"]) == 3 and sc["array"]["name"] == "nao4"
        assert sc["seed"] == seed
    assert demo_scenario(2, 10.0) == demo_scenario(2, 10.0)
    for people in (2, 4):  # avtrack demo --people N
        assert len(demo_scenario(0, 10.0, people)["people"]) == people
