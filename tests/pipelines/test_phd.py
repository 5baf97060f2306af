"""The AV16.3 SMC-PHD path: measurements, filter run and scores, on a small synthetic AV16.3
folder (the MAT files' fields and types as in the shared data)."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.io.av163 import load_av163
from avtrack.phd import PHD_FILTERS, PHDConfig
from avtrack.phd.likelihood import av163_frames, av163_truth, av163_visual
from avtrack.phd.scoring import ospa_of, ospa_t_of
from avtrack.pipelines import PHDRun, track_av163
from tests.io.test_av163 import write_av163

CONFIG = PHDConfig(particles_per_target=20)


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return write_av163(tmp_path_factory.mktemp("av") / "av", seq=7, cam=2, n_frames=30)


@pytest.mark.parametrize("name", ["lpf", "npf"])
def test_run_is_the_filter_on_the_sequence_measurements_and_its_scores(folder, name):
    run = track_av163(folder, 7, 2, name, CONFIG, seed=1)
    assert isinstance(run, PHDRun)
    seq = load_av163(folder, 7, 2)
    visual, used = av163_visual(folder, seq, "auto", np.random.default_rng([1, 7, 2]))
    frames = av163_frames(seq, visual, CONFIG.sigma_audio, CONFIG.gate,
                          doa_deg=list(seq.z_doa))
    result = PHD_FILTERS[name](CONFIG, seed=1).run(frames)
    np.testing.assert_array_equal(run.rows, result.rows(seq.frames))
    assert run.visual_source == used == "synthetic"
    truth = av163_truth(seq)
    assert len(run.truth) == len(truth) == run.sequence.n_frames == 30
    np.testing.assert_array_equal(run.ospa, ospa_of(result, truth))
    assert run.ospa.shape == (30, 3)
    assert run.ospa_t == ospa_t_of(result, seq)


def test_same_seed_same_tracks_and_clutter_is_named(folder):
    a = track_av163(folder, 7, 2, "lpf", CONFIG, seed=3)
    b = track_av163(folder, 7, 2, "lpf", CONFIG, seed=3)
    np.testing.assert_array_equal(a.rows, b.rows)
    c = track_av163(folder, 7, 2, "lpf", CONFIG, seed=3, clutter_rate=0.5)
    assert c.visual_source == "synthetic + 0.5 false alarms/frame"


def test_watch_is_opened_around_the_run_with_the_filter(folder):
    seen = []

    def watch(tracker, n_frames):
        seen.append((type(tracker).__name__, n_frames))
        return np.errstate()  # any context manager

    track_av163(folder, 7, 2, "npf", CONFIG, watch=watch)
    assert seen == [("NPFSMCPHD", 30)]


def test_bad_arguments_are_named(folder, tmp_path):
    with pytest.raises(ValueError, match="filter_name must be one of"):
        track_av163(folder, 7, 2, "kalman", CONFIG)
    with pytest.raises(ValueError, match="visual='faces' and a video"):
        track_av163(folder, 7, 2, "lpf", CONFIG, visual="faces", video=tmp_path / "v.avi")
