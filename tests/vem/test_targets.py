"""Target management shared by the VEM trackers: per-target arrays, identities, birth gate."""

import numpy as np
import pytest

from avtrack.vem.birth import BirthCandidate
from avtrack.vem.dynamics import constant_velocity_transition
from avtrack.vem.engine import VEMEngine
from avtrack.vem.targets import (
    ManagedTargets,
    PerTarget,
    births_outside,
    intersection_over_first,
)
from avtrack.visual.model import BoxObservationModel


class _Tracker(ManagedTargets):
    def __init__(self):
        self.engine = VEMEngine(constant_velocity_transition(4, 2), [BoxObservationModel(-20.0)])
        self._init_targets()

    def _per_target(self):
        return (
            PerTarget("p_visible", 1.0),
            PerTarget("run", 0, dtype=np.int64),
            PerTarget("history", 1.0, (3,)),
        )


def test_arrays_follow_births_and_deaths():
    trk = _Tracker()
    assert trk.p_visible.shape == (0,) and trk.run.dtype == np.int64
    assert trk.history.shape == (0, 3)
    mu = np.array([[10.0, 20.0, 5.0, 8.0, 0.0, 0.0], [50.0, 60.0, 5.0, 8.0, 0.0, 0.0]])
    gamma = np.stack([np.eye(6)] * 2)
    ids = trk._new_ids(2)
    trk._add_targets(ids, mu, gamma, [None])
    np.testing.assert_array_equal(trk.engine.ids, [1, 2])
    trk.p_visible[0], trk.run[1] = 0.25, 7
    trk._remove(np.array([False, True]))
    np.testing.assert_array_equal(trk.engine.ids, [2])
    np.testing.assert_array_equal(trk.p_visible, [1.0])
    np.testing.assert_array_equal(trk.run, [7])
    assert trk.history.shape == (1, 3)
    np.testing.assert_array_equal(trk._new_ids(1), [3])  # identities are never reused


def test_intersection_over_first_by_hand_and_for_empty_boxes():
    a = np.array([[0.0, 0.0, 10.0, 10.0], [5.0, 5.0, 0.0, 4.0]])
    b = np.array([[5.0, 0.0, 10.0, 10.0], [100.0, 100.0, 1.0, 1.0]])
    np.testing.assert_allclose(intersection_over_first(a, b), [[0.5, 0.0], [0.0, 0.0]])


def test_births_inside_a_tracked_box_are_refused():
    def cand(x):
        return BirthCandidate(np.array([0]), 1.0, np.array([x, 0.0, 10.0, 10.0]), np.eye(4))

    cands = [cand(0.0), cand(8.0)]
    tracked = np.array([[0.0, 0.0, 10.0, 10.0]])
    kept = births_outside(cands, lambda mu: mu[:, :4], tracked, max_overlap=0.5)
    assert kept == [cands[1]]
    assert births_outside(cands, lambda mu: mu[:, :4], np.zeros((0, 4)), 0.5) == cands
    assert births_outside([], lambda mu: mu, tracked, 0.5) == []


def test_a_tracker_must_declare_its_arrays():
    with pytest.raises(NotImplementedError):
        ManagedTargets()._per_target()
