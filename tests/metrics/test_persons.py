"""Off-screen direction accuracy and identity on return (hand-computed cases)."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.io.mot import MOTData
from avtrack.metrics.persons import OffscreenScore, identity_on_return, offscreen_direction_error


def test_offscreen_error_matches_one_to_one_and_scores_out_of_view_only():
    # frame 1: person 1 in view at 0, person 2 out at 170; hypotheses at 2 and -175 (wraps)
    # frame 2: person 2 out at 60, the only hypothesis at 100 (beyond the 30-degree gate)
    s = offscreen_direction_error(
        np.array([1, 1, 2]), np.array([1, 2, 2]), np.array([0.0, 170.0, 60.0]),
        np.array([True, False, False]), np.array([1, 1, 2]), np.array([2.0, -175.0, 100.0]),
    )
    assert s.mae_deg == pytest.approx(15.0) and s.coverage == pytest.approx(0.5)
    assert s.n_frames == 2 and s.n_matched == 1
    pooled = OffscreenScore.sum([s, s])
    assert pooled.mae_deg == pytest.approx(15.0) and pooled.n_frames == 4


def _track(frames, ids, x):
    n = len(frames)
    return MOTData(np.array(frames), np.array(ids), np.column_stack(
        [np.array(x, float), np.zeros(n), np.full(n, 10.0), np.full(n, 10.0)]), np.ones(n))


def test_identity_on_return():
    gt = _track([1, 2, 40, 41], [1, 1, 1, 1], [0, 0, 0, 0])
    kept = _track([1, 2, 40, 41], [5, 5, 5, 5], [0, 0, 0, 0])
    changed = _track([1, 2, 40, 41], [5, 5, 6, 6], [0, 0, 0, 0])
    assert identity_on_return(gt, kept).rate == 1.0
    r = identity_on_return(gt, changed)
    assert (r.n_returns, r.n_kept) == (1, 0)
    assert identity_on_return(gt, kept, min_absence=50).n_returns == 0


def test_offscreen_error_scores_only_the_masked_rows():
    # both persons out of view; only person 2's row is scored, person 1 still takes part in
    # the matching (so person 2 cannot take person 1's hypothesis)
    args = (np.array([1, 1]), np.array([1, 2]), np.array([0.0, 20.0]), np.array([False, False]),
            np.array([1, 1]), np.array([1.0, 25.0]))
    s = offscreen_direction_error(*args, gt_mask=np.array([False, True]))
    assert s.mae_deg == pytest.approx(5.0) and s.n_frames == 1
    assert offscreen_direction_error(*args).mae_deg == pytest.approx(3.0)
