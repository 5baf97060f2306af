"""EvidenceGate: heat maps long after the localizer's latest evidence are no observation."""

from __future__ import annotations

from itertools import pairwise

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avtrack.audio.arrays import builtin_array
from avtrack.doa.base import EvidenceGate, map_reading
from avtrack.localize import make_localizer


def test_hand_case_hold_two():
    w = np.arange(1.0, 22.0).reshape(7, 3)  # row sums 6, 15, 24, ...
    ev = np.array([False, True, False, False, False, True, False])
    gate = EvidenceGate(2)
    out = gate.apply(w, ev)
    # frames since the latest evidence: (none yet) 1 0 1 2 3 0 1 -> rows 0 and 4 are stale
    np.testing.assert_allclose(out[0], [2.0, 2.0, 2.0])
    np.testing.assert_allclose(out[4], [14.0, 14.0, 14.0])
    for k in (1, 2, 3, 5, 6):
        np.testing.assert_array_equal(out[k], w[k])
    assert w[0, 0] == 1.0  # the input is not changed
    # the state carries over: two frames after the evidence of row 6's predecessor
    np.testing.assert_array_equal(gate.apply(w[:1], [False]), w[:1])
    np.testing.assert_allclose(gate.apply(w[:1], [False]), [[2.0, 2.0, 2.0]])


def test_hold_zero_keeps_only_frames_with_evidence():
    w = np.eye(4)
    out = EvidenceGate(0).apply(w, [True, False, True, False])
    np.testing.assert_array_equal(out[[0, 2]], w[[0, 2]])
    np.testing.assert_allclose(out[[1, 3]], 0.25)


@settings(max_examples=60, deadline=None)
@given(
    ev=st.lists(st.booleans(), min_size=1, max_size=60),
    hold=st.integers(0, 6),
    cuts=st.lists(st.integers(0, 60), max_size=5),
)
def test_blocks_give_the_rows_of_one_call(ev, hold, cuts):
    rng = np.random.default_rng(len(ev))
    w = rng.random((len(ev), 5))
    ev = np.array(ev)
    whole = EvidenceGate(hold).apply(w, ev)
    gate = EvidenceGate(hold)
    edges = [0, *sorted(c for c in cuts if c < len(ev)), len(ev)]
    parts = [gate.apply(w[a:b], ev[a:b]) for a, b in pairwise(edges)]
    np.testing.assert_array_equal(np.concatenate(parts), whole)
    # every row keeps its total; a stale row is flat
    np.testing.assert_allclose(whole.sum(axis=1), w.sum(axis=1))


def test_bad_inputs_are_refused():
    with pytest.raises(ValueError, match="hold_frames"):
        EvidenceGate(-1)
    with pytest.raises(ValueError, match="hold_s"):
        EvidenceGate.for_hold(float("nan"), 0.008)
    with pytest.raises(ValueError, match=r"\(T, D\)"):
        EvidenceGate(1).apply(np.ones((3, 2)), [True, False])


def test_for_hold_counts_frames_of_the_hop():
    assert EvidenceGate.for_hold(0.2, 0.008).hold_frames == 25


def test_cgmm_localizers_say_which_frames_had_features():
    loc = make_localizer("dprtf-eg-fast", builtin_array("nao4"))
    k = loc.config.min_features
    np.testing.assert_array_equal(loc.evidence(np.array([0, k - 1, k, 3 * k])),
                                  [False, False, True, True])
    srp = make_localizer("srp-phat", builtin_array("nao4"))
    assert srp.evidence(np.array([0, 5])).all()  # memoryless maps: every frame


def test_fast_maps_are_gated_by_default_and_other_maps_not():
    assert map_reading("vonmises", "dprtf-eg-fast").evidence_hold_s == pytest.approx(0.2)
    assert map_reading("gauss", "dprtf-eg-fast").evidence_hold_s == pytest.approx(0.2)
    assert map_reading("vonmises", "dprtf-eg").evidence_hold_s is None
