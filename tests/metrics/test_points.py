"""Point matches of a detector against true points."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.metrics.points import point_matches


def test_hand_computed_counts():
    points = [np.array([[0.0, 0.0], [100.0, 0.0]]), np.zeros((0, 2))]
    truths = [np.array([[10.0, 0.0], [0.0, 30.0]]), np.array([[5.0, 5.0]])]
    m = point_matches(points, truths)
    # frame 0: (10, 0) has a point 10 px away (found), (0, 30) none within 20 px; frame 1: none
    assert (m.n_true, m.n_found) == (3, 1)
    # (0, 0) is 10 px from a true point (near); (100, 0) is 90 px from the nearest
    assert (m.n_points, m.n_near) == (2, 1)
    assert m.recall == pytest.approx(1 / 3) and m.precision == pytest.approx(0.5)


def test_empty_sequence_and_bad_lengths():
    m = point_matches([], [])
    assert m.recall == 0.0 and m.precision == 0.0
    with pytest.raises(ValueError, match="same number of frames"):
        point_matches([np.zeros((0, 2))], [])
