"""An azimuth axis zoomed to where the persons are, with the wrap at +-180 degrees handled.

Azimuths live on a circle: talkers at 175 and -175 degrees are 10 degrees apart, yet on an
axis from -180 to 180 they sit at its two edges. :func:`azimuth_axis` finds the smallest arc
of the circle that holds every azimuth given (the complement of the largest gap between
neighbouring azimuths), centres the axis on that arc, and draws every azimuth unwrapped
relative to the centre ``c``,

.. math::

    \\tilde\\theta = c + ((\\theta - c + 180) \\bmod 360) - 180 \\in [c - 180, c + 180),

so that the arc is one contiguous band of the axis; its tick labels show the azimuths wrapped
back into (-180, 180]. When the azimuths gather in one cluster, the arc's centre is close to
their circular mean; unlike the mean, the arc is defined for any spread and never splits the
azimuths between the axis's edges.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Room left on each side of the persons' arc, degrees.
MARGIN_DEG = 10.0
#: Narrowest axis, degrees (persons all at one azimuth still get some context).
MIN_SPAN_DEG = 40.0


def wrap_deg(azimuth_deg):
    """Azimuths wrapped into ``[-180, 180)`` degrees (arrays or scalars)."""
    return (np.asarray(azimuth_deg, dtype=float) + 180.0) % 360.0 - 180.0


@dataclass(frozen=True)
class AzimuthAxis:
    """An azimuth axis: limits ``lo < hi`` in degrees unwrapped relative to ``centre``.

    Attributes
    ----------
    centre : float
        Azimuth of the axis's middle, degrees in (-180, 180].
    lo, hi : float
        Axis limits, ``centre - 180 <= lo < hi <= centre + 180``.
    """

    centre: float
    lo: float
    hi: float

    def __post_init__(self) -> None:
        c, lo, hi = self.centre, self.lo, self.hi
        if not (np.isfinite([c, lo, hi]).all() and c - 180 - 1e-9 <= lo < hi <= c + 180 + 1e-9):
            raise ValueError(
                f"AzimuthAxis: need finite centre - 180 <= lo < hi <= centre + 180, got "
                f"centre={c!r}, lo={lo!r}, hi={hi!r}"
            )

    def unwrap(self, azimuth_deg) -> np.ndarray:
        """Azimuths (degrees, any wrap) moved by whole turns into ``[centre - 180,
        centre + 180)``: the positions to draw them at on this axis."""
        # theta~ = c + ((theta - c + 180) mod 360) - 180
        return self.centre + wrap_deg(np.asarray(azimuth_deg, dtype=float) - self.centre)

    def apply(self, ax, which: str = "y") -> None:
        """Set a matplotlib axes' limits to ``(lo, hi)`` and its tick labels to the wrapped
        azimuths (``which``: ``"y"`` or ``"x"``)."""
        from matplotlib.ticker import FuncFormatter, MaxNLocator

        if which not in ("x", "y"):
            raise ValueError(f"which must be 'x' or 'y', got {which!r}")
        axis = ax.yaxis if which == "y" else ax.xaxis
        (ax.set_ylim if which == "y" else ax.set_xlim)(self.lo, self.hi)
        axis.set_major_locator(MaxNLocator(nbins=6, steps=[1, 2, 2.5, 3, 5, 10]))
        axis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{_label(v):g}"))


def _label(v: float) -> float:
    """Tick value wrapped into (-180, 180] and rounded off float noise."""
    w = float(np.round(-wrap_deg(-v), 6))  # (-180, 180]: 180 stays 180
    return 0.0 if w == 0 else w


def azimuth_axis(
    *azimuths_deg, margin_deg: float = MARGIN_DEG, min_span_deg: float = MIN_SPAN_DEG
) -> AzimuthAxis:
    """The axis holding every finite azimuth of ``azimuths_deg`` on one side of the wrap.

    Parameters
    ----------
    *azimuths_deg : array_like
        Azimuths in degrees (any shapes, any wrap; NaN ignored), e.g. the persons' tracks and
        the ground truth.
    margin_deg : float
        Room left beyond the outermost azimuths on each side.
    min_span_deg : float
        Narrowest axis.

    Returns
    -------
    AzimuthAxis
        Centred on the middle of the smallest arc holding the azimuths; the full circle
        (centred there) when the arc and its margins reach 360 degrees, and -180..180 when no
        azimuth is given.
    """
    if margin_deg < 0 or min_span_deg <= 0 or min_span_deg > 360:
        raise ValueError(
            f"azimuth_axis: need margin_deg >= 0 and 0 < min_span_deg <= 360, got "
            f"margin_deg={margin_deg!r}, min_span_deg={min_span_deg!r}"
        )
    arrays = [np.asarray(a, dtype=float).ravel() for a in azimuths_deg]
    values = np.concatenate(arrays) if arrays else np.zeros(0)
    values = values[np.isfinite(values)]
    if values.size == 0:
        return AzimuthAxis(0.0, -180.0, 180.0)
    a = np.unique(np.round(values % 360.0, 6) % 360.0)  # sorted points on [0, 360)
    gaps = np.diff(np.r_[a, a[0] + 360.0])  # gap after each point, the last one wrapping
    k = int(np.argmax(gaps))
    start = a[(k + 1) % a.size]  # the arc begins after the largest gap ...
    length = 360.0 - gaps[k]  # ... and runs to the point before it
    centre = float(-wrap_deg(-(start + length / 2)))  # in (-180, 180]: 180 stays 180
    half = max(length / 2 + margin_deg, min_span_deg / 2)
    if half >= 180.0:
        return AzimuthAxis(centre, centre - 180.0, centre + 180.0)
    return AzimuthAxis(centre, centre - half, centre + half)
