"""Peak selection on heat maps."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.localize.base import HeatMaps
from avtrack.localize.grid import DirectionGrid
from avtrack.localize.peaks import find_peaks, local_maxima, peak_table


def heat(weights):
    w = np.atleast_2d(np.asarray(weights, dtype=float))
    t = np.arange(w.shape[0])
    return HeatMaps(t, 0.008 * (t + 1), w, np.zeros(t.size, int))


def test_circular_local_maxima_plateaus_and_flat_maps():
    g = DirectionGrid.azimuths(60.0)  # -120, -60, 0, 60, 120, 180
    w = np.array(
        [
            [5, 1, 2, 2, 1, 4],  # 5 at -120 beats 4 at 180 across the wrap; plateau 2,2 -> one
            [1, 1, 1, 1, 1, 1],  # flat: no peak
            [0, 0, 0, 0, 0, 3],  # the last azimuth is a peak (wraps to the first)
        ]
    )
    m = local_maxima(w, g)
    np.testing.assert_array_equal(np.nonzero(m[0])[0], [0, 2])
    assert not m[1].any()
    np.testing.assert_array_equal(np.nonzero(m[2])[0], [5])


def test_non_circular_and_two_dimensional_grids():
    g = DirectionGrid([-30.0, 0.0, 30.0], [0.0])
    np.testing.assert_array_equal(local_maxima(np.array([3.0, 1.0, 2.0]), g), [1, 0, 1])
    g2 = DirectionGrid.sphere(90.0, (-30.0, 30.0))  # 2 x 4
    w = np.array([1, 2, 1, 1, 1, 3, 1, 5], dtype=float)
    # 2 (row 0) is below 3 (row 1, same azimuth); 3 and 5 are maxima of their neighbourhoods
    np.testing.assert_array_equal(np.nonzero(local_maxima(w, g2))[0], [5, 7])


def test_find_peaks_threshold_order_and_max_peaks():
    g = DirectionGrid.azimuths(60.0)
    h = heat([[0.1, 0.5, 0.1, 0.3, 0.1, 0.2], [0.9, 0.1, 0.1, 0.1, 0.1, 0.1]])
    rows, cand, vals = find_peaks(h, g, 0.25)
    np.testing.assert_array_equal(rows, [0, 0, 1])
    np.testing.assert_array_equal(cand, [1, 3, 0])
    np.testing.assert_allclose(vals, [0.5, 0.3, 0.9])
    rows, cand, _ = find_peaks(h, g, 0.0, max_peaks=1)
    np.testing.assert_array_equal(cand, [1, 0])
    with pytest.raises(ValueError, match="max_peaks must be a positive integer"):
        find_peaks(h, g, 0.0, max_peaks=0)


def test_peak_table_rows():
    g = DirectionGrid.azimuths(60.0)
    h = heat([[0.1, 0.5, 0.1, 0.3, 0.1, 0.2]])
    t = peak_table(h, g, threshold=0.4, floor=0.15)
    np.testing.assert_allclose(t.azimuth_deg, [-60.0, 60.0, 180.0])
    np.testing.assert_array_equal(t.active, [True, False, False])
    assert np.all(t.ids == -1) and np.all(t.frames == 0)
    np.testing.assert_allclose(t.time_s, 0.008)
    assert len(peak_table(h, g, threshold=0.4)) == 1


def test_local_maxima_validation():
    with pytest.raises(ValueError, match=r"weights must have shape \(n_frames, 72\)"):
        local_maxima(np.zeros((2, 5)), DirectionGrid.azimuths())
