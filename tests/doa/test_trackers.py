"""Contract tests of every registered DOA tracker on one shared synthetic scene."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from avtrack.config import build_config
from avtrack.doa import TRACKERS, DOATracker, TrackFrame, make_tracker
from avtrack.doa.base import (
    DEFAULT_OBSERVATIONS,
    FAST_MAP_OVERRIDES,
    FRAME_PERIOD_S,
    UNIFORM_PEAK_FLOOR,
    heatmap_sequence,
    map_reading,
)
from avtrack.doa.vonmises import FAST_MAP_CONFIG
from avtrack.io.doa import DOATable, wrap_azimuth
from avtrack.metrics.doa_tracking import evaluate_tracks
from avtrack.simulate.heatmaps import synthetic_heatmaps

NAMES = sorted(TRACKERS)
GRID = -180.0 + 5.0 * np.arange(1, 73)


@pytest.fixture(scope="module")
def crossing_scene():
    """Two sources 6 s long, one walking through the other's direction; heat maps every 32 ms."""
    n = 190
    t = np.arange(n) * FRAME_PERIOD_S
    az = np.stack([wrap_azimuth(-60.0 + 20.0 * t), np.full(n, 30.0)], axis=1)
    on = np.ones(az.shape, bool)
    w = synthetic_heatmaps(az, on, GRID, np.random.default_rng(0))
    truth = DOATable(np.repeat(np.arange(n), 2), np.repeat(t, 2), np.tile([1, 2], n),
                     az.ravel(), np.zeros(az.size), np.ones(az.size), on.ravel())
    return w, t, truth


def test_registry_has_the_thesis_trackers():
    assert set(NAMES) == {"gauss", "vonmises"}
    for name, cls in TRACKERS.items():
        assert cls.name == name and issubclass(cls, DOATracker)
        assert dataclasses.is_dataclass(cls.Config)
        assert name in DEFAULT_OBSERVATIONS


@pytest.mark.parametrize("name", NAMES)
def test_tracks_two_sources_with_their_identities(name, crossing_scene):
    w, t, truth = crossing_scene
    seq = heatmap_sequence(w, GRID, np.arange(len(t)), t, 1, DEFAULT_OBSERVATIONS[name])
    tracks = make_tracker(name).run(seq)
    assert isinstance(tracks, DOATable) and len(tracks)
    assert tracks.ids.min() >= 1
    assert np.all((tracks.azimuth_deg > -180.0) & (tracks.azimuth_deg <= 180.0))
    late = evaluate_tracks(tracks, truth, time_range_s=(1.0, t[-1]))
    assert late.mae < 5.0 and late.md_rate < 0.25 and late.fa_rate < 0.25


@pytest.mark.parametrize("name", NAMES)
def test_run_equals_stepping_and_starts_afresh(name, crossing_scene):
    w, t, _ = crossing_scene
    seq = heatmap_sequence(w, GRID, np.arange(len(t)), t, 1, DEFAULT_OBSERVATIONS[name])
    tracker = make_tracker(name)
    first = tracker.run(seq)
    again = tracker.run(seq)  # run resets the tracker
    np.testing.assert_array_equal(first.ids, again.ids)
    np.testing.assert_array_equal(first.azimuth_deg, again.azimuth_deg)
    tracker.reset()
    frames = [tracker.step(a, w) for a, w in zip(seq.azimuth_deg, seq.weight, strict=True)]
    assert all(isinstance(f, TrackFrame) for f in frames)
    assert sum(len(f.ids) for f in frames) == len(first)


@pytest.mark.parametrize("name", NAMES)
def test_bad_input_is_refused_by_name(name):
    tracker = make_tracker(name)
    with pytest.raises(ValueError, match="azimuth_deg"):
        tracker.step(np.array([np.nan]), np.array([1.0]))
    with pytest.raises(ValueError, match="weight"):
        tracker.step(np.array([10.0]), np.array([-1.0]))
    with pytest.raises(TypeError, match="config must be"):
        TRACKERS[name](config=object())
    with pytest.raises(ValueError, match="unknown field"):
        build_config(TRACKERS[name].Config, {"no_such_field": 1})
    with pytest.raises(ValueError, match="make_tracker"):
        make_tracker("no-such-tracker")


def test_map_reading_per_localizer():
    """dprtf-eg-fast maps: peaks over 1.15/D and the fast-map Config fields; other maps (and a
    DOA table, method None): the tracker's DEFAULT_OBSERVATIONS, 1.44/D and Config defaults."""
    for name in ("gauss", "vonmises"):
        cls = TRACKERS[name].Config
        fast = map_reading(name, "dprtf-eg-fast")
        assert (fast.observations, fast.uniform_floor) == ("peaks-over-uniform", 1.15)
        assert fast.config == dataclasses.replace(cls(), **FAST_MAP_OVERRIDES[name])
        assert fast.config != cls()
        assert map_reading(name, "dprtf-eg-static") == fast  # the same kind of map
        for method in ("dprtf-eg", "srp-phat", None):
            r = map_reading(name, method)
            assert r.observations == DEFAULT_OBSERVATIONS[name]
            assert r.uniform_floor == UNIFORM_PEAK_FLOOR
            assert r.config == cls()
    assert map_reading("vonmises", "dprtf-eg-fast").config == FAST_MAP_CONFIG
    assert map_reading("gauss", "dprtf-eg-fast").config.obs_var == 0.0006
    with pytest.raises(ValueError, match="tracker must be one of"):
        map_reading("kalman", "dprtf-eg-fast")
