"""The azimuth axis: zoomed to the persons' arc, never splitting them at +-180 degrees."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from avtrack.viz.azimuth import AzimuthAxis, azimuth_axis, wrap_deg


def test_talkers_at_175_and_minus_175_sit_on_one_side_of_a_centred_axis():
    axis = azimuth_axis([175.0, 176.0], [-175.0, -178.0])
    assert axis.centre == pytest.approx(180.0)  # the middle of the 10-degree arc
    y = axis.unwrap([175.0, -175.0])
    assert y[1] - y[0] == pytest.approx(10.0)  # neighbours, not 350 degrees apart
    assert axis.lo < y.min() and y.max() < axis.hi
    assert axis.hi - axis.lo == pytest.approx(40.0)  # the narrowest axis: 10 + margins < 40


def test_the_axis_is_zoomed_to_the_persons_with_a_margin():
    axis = azimuth_axis([-25.0, 4.0, 18.0], [np.nan])
    assert (axis.lo, axis.hi) == pytest.approx((-35.0, 28.0))
    assert axis.centre == pytest.approx(-3.5)
    assert (azimuth_axis().lo, azimuth_axis().hi) == (-180.0, 180.0)  # nothing to zoom to
    wide = azimuth_axis([0.0, 100.0, -100.0])  # the 200-degree arc from -100 through 0
    assert (wide.lo, wide.hi) == pytest.approx((-110.0, 110.0))
    full = azimuth_axis(np.arange(-180.0, 180.0, 10.0))  # all round: the whole circle
    assert full.hi - full.lo == pytest.approx(360.0)


def test_tick_labels_are_the_wrapped_azimuths():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    axis = azimuth_axis([170.0, -170.0])
    axis.apply(ax)
    fig.canvas.draw()
    labels = {t.get_text() for t in ax.get_yticklabels()}
    plt.close(fig)
    assert ax.get_ylim() == pytest.approx((axis.lo, axis.hi))
    assert "180" in labels and "-170" in labels and "190" not in labels


def test_bad_axes_are_refused():
    with pytest.raises(ValueError, match="centre - 180 <= lo < hi <= centre \\+ 180"):
        AzimuthAxis(0.0, 10.0, 5.0)
    with pytest.raises(ValueError, match="min_span_deg"):
        azimuth_axis([0.0], min_span_deg=0.0)


@given(st.lists(st.floats(-720, 720), min_size=1, max_size=30))
def test_every_azimuth_lands_inside_the_axis_at_its_true_direction(azimuths):
    axis = azimuth_axis(azimuths)
    y = axis.unwrap(azimuths)
    assert np.all((y >= axis.lo - 1e-6) & (y <= axis.hi + 1e-6))
    assert np.all(np.abs(wrap_deg(y - np.asarray(azimuths))) < 1e-6)  # whole turns moved
