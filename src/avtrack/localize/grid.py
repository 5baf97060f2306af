"""Candidate directions and the direct-path features predicted for each (thesis §5.3.1, §5.5.1).

A :class:`DirectionGrid` holds ``D`` candidate directions ``theta_d`` laid out as
``n_elevations`` rows of ``n_azimuths`` azimuths (azimuth varies fastest). The thesis uses
``D = 72`` azimuths every 5 degrees in [-175, 180] at elevation 0
(:meth:`DirectionGrid.azimuths`).

Predicted features. :func:`transfer_functions` gives the direct-path transfer function
``h^i_f(theta_d)`` of every microphone:

- free-field arrays: a pure delay, ``h^i = exp(-2j pi f tau_i)`` with the far-field delays of
  :func:`avtrack.audio.arrays.steering_delays`;
- ``"hrtf"`` arrays: the DTFT, at the bin frequencies, of the measured head-related impulse
  response of the nearest measured direction, resampled to the STFT rate.

:func:`dprtf_means` turns them into the CGMM means ``c^{i,d}_f`` of thesis eq. 5.12: the ratio
``r = h^i / h^1`` normalised like the observed features (``r / sqrt(1 + |r|^2)``; a free-field
ratio has modulus 1, so its means have modulus ``1/sqrt(2)``), or only its phase for
pair-wise relative phase (PRP) features. :func:`steering_phases` gives the PHAT steering
vectors of SRP-PHAT.

Shapes: transfer functions ``(n_mics, n_freqs, n_candidates)``; means
``(n_mics - 1, n_freqs, n_candidates)``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from avtrack.audio.arrays import MicArray, steering_delays


@dataclass(frozen=True, eq=False)
class DirectionGrid:
    """Candidate source directions on a regular azimuth x elevation lattice.

    Attributes
    ----------
    azimuth_values : ndarray (n_azimuths,)
        Distinct azimuths in degrees, strictly increasing, in (-180, 180].
    elevation_values : ndarray (n_elevations,)
        Distinct elevations in degrees, strictly increasing, in [-90, 90].

    Candidate ``d = e * n_azimuths + a`` has azimuth ``azimuth_values[a]`` and elevation
    ``elevation_values[e]``. The azimuth axis is *circular* (neighbours wrap around) when the
    azimuths are evenly spaced and cover the full circle.
    """

    azimuth_values: np.ndarray
    elevation_values: np.ndarray

    def __post_init__(self) -> None:
        az = np.array(self.azimuth_values, dtype=float).reshape(-1)
        el = np.array(self.elevation_values, dtype=float).reshape(-1)
        if az.size == 0 or el.size == 0:
            raise ValueError(
                "DirectionGrid: azimuth_values and elevation_values must be non-empty"
            )
        if not (np.all(np.isfinite(az)) and np.all(np.isfinite(el))):
            raise ValueError("DirectionGrid: directions must be finite")
        if np.any(az <= -180.0) or np.any(az > 180.0):
            raise ValueError(
                "DirectionGrid: azimuth_values must lie in (-180, 180], got "
                f"{az.min()}..{az.max()}"
            )
        if np.any(np.abs(el) > 90.0):
            raise ValueError("DirectionGrid: elevation_values must lie in [-90, 90]")
        if np.any(np.diff(az) <= 0) or np.any(np.diff(el) <= 0):
            raise ValueError(
                "DirectionGrid: azimuth_values and elevation_values must be strictly increasing"
            )
        for a in (az, el):
            a.setflags(write=False)
        object.__setattr__(self, "azimuth_values", az)
        object.__setattr__(self, "elevation_values", el)

    @classmethod
    def azimuths(cls, step_deg: float = 5.0, elevation_deg: float = 0.0) -> DirectionGrid:
        """Evenly spaced azimuths ``-180 + step, ..., 180`` at one elevation.

        The default is the thesis grid: 72 azimuths every 5 degrees in [-175, 180].
        """
        n = 360.0 / step_deg if step_deg > 0 else 0.0
        if not (step_deg > 0 and abs(n - round(n)) < 1e-9 and round(n) >= 1):
            raise ValueError(f"DirectionGrid.azimuths: step_deg must divide 360, got {step_deg!r}")
        az = -180.0 + step_deg * np.arange(1, round(n) + 1)
        return cls(az, np.array([float(elevation_deg)]))

    @classmethod
    def sphere(cls, az_step_deg: float = 5.0, elevations_deg=(-30.0, 0.0, 30.0)) -> DirectionGrid:
        """Evenly spaced azimuths (as :meth:`azimuths`) at each of several elevations."""
        base = cls.azimuths(az_step_deg)
        return cls(base.azimuth_values, elevations_deg)

    @classmethod
    def for_array(cls, array: MicArray, step_deg: float = 5.0) -> DirectionGrid:
        """The candidate directions an array can tell apart (:func:`elevation_support`).

        Azimuths every ``step_deg``, at the elevations :data:`ELEVATION_ROWS` gives for the
        array's support: elevation 0 only for a line of microphones (which hears azimuth up
        to a mirror image and no elevation) and for arrays known by their HRIRs (measured at
        one elevation); 0 to 60 degrees for a planar array (which cannot tell a source above
        its plane from its mirror image below, so the upper half stands for both); -40 to 60
        degrees for a three-dimensional array. Searching elevation removes a bias of azimuth
        on a planar array: a talker at elevation ``e`` gives the phase differences of a
        horizontal source scaled by ``cos e``, which no horizontal candidate fits.
        """
        base = cls.azimuths(step_deg)
        return cls(base.azimuth_values, np.asarray(ELEVATION_ROWS[elevation_support(array)]))

    @classmethod
    def from_options(
        cls, step_deg: float, elevations: str | None, array: MicArray
    ) -> DirectionGrid:
        """Azimuths every ``step_deg`` at the comma-separated ``elevations`` in degrees
        (``"0,20,40"``), or at the elevations ``array`` can tell apart when None
        (:meth:`for_array`).

        Raises
        ------
        ValueError
            A step or an elevation out of range, or text that is not comma-separated numbers.
        """
        base = cls.azimuths(step_deg)
        if elevations is None:
            return cls.for_array(array, step_deg)
        try:
            values = sorted({float(v) for v in elevations.split(",") if v.strip()})
            return cls(base.azimuth_values, np.asarray(values))
        except ValueError as exc:
            raise ValueError(
                f"expected comma-separated degrees in [-90, 90], got {elevations!r} ({exc})"
            ) from None

    @property
    def n_azimuths(self) -> int:
        return self.azimuth_values.size

    @property
    def azimuth_step_deg(self) -> float:
        """Width of an azimuth cell, degrees: 360 / n on a circular grid, else the mean gap
        between neighbouring azimuths (360 for a single azimuth)."""
        az = self.azimuth_values
        if self.circular or az.size < 2:
            return 360.0 / az.size
        return float(np.ptp(az)) / (az.size - 1)

    @property
    def n_elevations(self) -> int:
        return self.elevation_values.size

    @property
    def size(self) -> int:
        """``D``, the number of candidates."""
        return self.n_azimuths * self.n_elevations

    @property
    def azimuth_deg(self) -> np.ndarray:
        """``(D,)`` azimuth of each candidate."""
        return np.tile(self.azimuth_values, self.n_elevations)

    @property
    def elevation_deg(self) -> np.ndarray:
        """``(D,)`` elevation of each candidate."""
        return np.repeat(self.elevation_values, self.n_azimuths)

    @property
    def circular(self) -> bool:
        """Whether the azimuths are evenly spaced around the whole circle."""
        az = self.azimuth_values
        if az.size < 3:
            return False
        gaps = np.diff(np.r_[az, az[0] + 360.0])
        return bool(np.allclose(gaps, gaps[0], atol=1e-6))

    @functools.cached_property
    def azimuth_neighbours(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(prev, next, has_prev, has_next)``: index ``(D,)`` of each candidate's azimuth
        neighbours at the same elevation (wrapping around on a circular grid) and 0/1 floats
        saying whether the neighbour exists."""
        a = np.arange(self.n_azimuths)
        base = self.n_azimuths * np.arange(self.n_elevations)[:, None]
        prev = base + (a - 1) % self.n_azimuths
        nxt = base + (a + 1) % self.n_azimuths
        has_prev = np.ones(prev.shape)
        has_next = np.ones(nxt.shape)
        if not self.circular:
            has_prev[:, 0] = 0.0
            has_next[:, -1] = 0.0
        return prev.ravel(), nxt.ravel(), has_prev.ravel(), has_next.ravel()

    def nearest(self, azimuth_deg: np.ndarray | float, elevation_deg=0.0) -> np.ndarray:
        """Index of the candidate nearest (great circle) to each given direction."""
        az, el = np.broadcast_arrays(
            np.asarray(azimuth_deg, dtype=float), np.asarray(elevation_deg, dtype=float)
        )
        u = _unit(az.reshape(-1), el.reshape(-1))
        c = _unit(self.azimuth_deg, self.elevation_deg)
        return np.argmax(u @ c.T, axis=1).reshape(az.shape)


#: Candidate elevations (degrees) searched by :meth:`DirectionGrid.for_array` for each
#: :func:`elevation_support`: 20-degree rows (a 5 cm array's elevation resolution is coarser
#: than that), up to 60 degrees (above it, ``cos e < 0.5`` and azimuth is poorly heard).
ELEVATION_ROWS: dict[str, tuple[float, ...]] = {
    "none": (0.0,),
    "upper": (0.0, 20.0, 40.0, 60.0),
    "full": (-40.0, -20.0, 0.0, 20.0, 40.0, 60.0),
}

#: Relative flatness below which the microphones count as collinear or coplanar: the second
#: (third) singular value of the centred positions below this fraction of the first.
FLAT_RATIO = 0.05


def elevation_support(array: MicArray) -> str:
    """What elevation an array can hear: ``"none"``, ``"upper"`` or ``"full"``.

    From the singular values ``s1 >= s2 >= s3`` of the centred microphone positions:
    collinear microphones (``s2 < FLAT_RATIO s1``) hear no elevation (``"none"``); coplanar
    ones (``s3 < FLAT_RATIO s1``) hear its magnitude but not its sign (``"upper"``); others
    hear both (``"full"``). Arrays described by measured HRIRs (``kind == "hrtf"``) are
    ``"none"``: the NAO set is measured at one elevation, and a binaural head tells elevation
    by spectral cues that the direct-path features do not model.
    """
    if array.kind == "hrtf":
        return "none"
    rel = array.positions - array.centre
    if array.n_mics < 3:
        return "none"
    s = np.linalg.svd(rel, compute_uv=False)
    if s[0] <= 0 or s[1] < FLAT_RATIO * s[0]:
        return "none"
    if s.size < 3 or s[2] < FLAT_RATIO * s[0]:
        return "upper"
    return "full"


def line_axis(array: MicArray) -> np.ndarray | None:
    """The unit axis ``(3,)`` of collinear microphones (two, or more on a line: singular values
    as in :func:`elevation_support`), or None. Such an array hears only the angle between a
    source's direction and its axis: a source above its plane is heard at the horizontal
    direction at the same angle from the axis (the cone of confusion), nearer the axis."""
    rel = array.positions - array.centre
    if array.n_mics < 2:
        return None
    _, s, vt = np.linalg.svd(rel, full_matrices=False)
    if s[0] <= 0 or (s.size > 1 and s[1] >= FLAT_RATIO * s[0]):
        return None
    return vt[0] / np.linalg.norm(vt[0])


def heard_azimuth(direction: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Azimuth (degrees, ``(N,)``) at which a line of microphones along the horizontal unit
    ``axis`` ``(3,)`` hears each direction ``(N, 3)``: the horizontal direction at the same
    angle from the axis, on the same side of it."""
    d = direction / np.linalg.norm(direction, axis=1, keepdims=True)
    a = np.asarray(axis, dtype=float)
    a_h = a[:2] / max(float(np.hypot(a[0], a[1])), 1e-12)
    cos_ang = np.clip(d @ a, -1.0, 1.0)
    side = np.where(a_h[0] * d[:, 1] - a_h[1] * d[:, 0] >= 0.0, 1.0, -1.0)
    az = np.degrees(np.arctan2(a_h[1], a_h[0]) + side * np.arccos(cos_ang))
    return (az + 180.0) % 360.0 - 180.0


#: How :func:`azimuth_profile` reduces the elevations of one azimuth: ``"sum"`` for maps that
#: are distributions over the candidates (CGMM weights), ``"max"`` for power maps (SRP-PHAT).
PROFILE_REDUCTIONS = ("sum", "max")


def azimuth_profile(
    weights: np.ndarray, grid: DirectionGrid, reduce: str = "sum"
) -> tuple[np.ndarray, np.ndarray]:
    """Heat maps over azimuth only, and the elevation each azimuth's mass sits at.

    Parameters
    ----------
    weights : ndarray (n_frames, D)
        Heat maps over ``grid``.
    grid : DirectionGrid
    reduce : {"sum", "max"}
        :data:`PROFILE_REDUCTIONS`.

    Returns
    -------
    profile : ndarray (n_frames, n_azimuths)
        The sum (the marginal of a CGMM's weights) or the largest value over elevations at
        each azimuth; ``weights`` itself when the grid has one elevation.
    elevation : ndarray (n_frames, n_azimuths)
        The elevation of the largest value at each azimuth, degrees.
    """
    w = np.asarray(weights, dtype=float)
    if w.ndim != 2 or w.shape[1] != grid.size:
        raise ValueError(
            f"azimuth_profile: weights must have shape (n_frames, {grid.size}), got {w.shape}"
        )
    if reduce not in PROFILE_REDUCTIONS:
        raise ValueError(f"azimuth_profile: reduce must be one of {PROFILE_REDUCTIONS}, "
                         f"got {reduce!r}")
    g = w.reshape(w.shape[0], grid.n_elevations, grid.n_azimuths)
    elevation = grid.elevation_values[np.argmax(g, axis=1)]
    if grid.n_elevations == 1:
        return g[:, 0, :], elevation
    return (g.sum(axis=1) if reduce == "sum" else g.max(axis=1)), elevation


def _unit(az_deg: np.ndarray, el_deg: np.ndarray) -> np.ndarray:
    az, el = np.deg2rad(az_deg), np.deg2rad(el_deg)
    return np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=-1)


def transfer_functions(
    array: MicArray, grid: DirectionGrid, freqs_hz: np.ndarray, fs: int = 16000
) -> np.ndarray:
    """Direct-path transfer functions ``h^i_f(theta_d)``.

    Parameters
    ----------
    array : MicArray
        Free-field (delays from the positions) or ``"hrtf"`` (measured HRIRs).
    grid : DirectionGrid
    freqs_hz : ndarray (n_freqs,)
        Bin frequencies.
    fs : int
        Sampling rate of the STFT (HRIRs are resampled to it).

    Returns
    -------
    ndarray (n_mics, n_freqs, D), complex
    """
    f = np.asarray(freqs_hz, dtype=float).reshape(-1)
    if not np.all(np.isfinite(f)) or np.any(f < 0):
        raise ValueError("transfer_functions: freqs_hz must be finite and >= 0")
    if array.kind == "hrtf":
        if array.hrir is None:
            raise ValueError(f"transfer_functions: HRTF array {array.name!r} has no HRIRs")
        hrir = array.hrir.resampled(int(fs))
        idx = hrir.nearest_index(grid.azimuth_deg, grid.elevation_deg)  # (D,)
        irs = hrir.irs[idx]  # (D, M, L)
        n = np.arange(irs.shape[2])
        kernel = np.exp(-2j * np.pi * np.outer(f, n) / fs)  # (F, L): DTFT at the bins
        return np.einsum("dml,fl->mfd", irs, kernel)
    tau = steering_delays(array, grid.azimuth_deg, grid.elevation_deg)  # (D, M) seconds
    return np.exp(-2j * np.pi * f[None, :, None] * tau.T[:, None, :])  # h^i = e^{-2j pi f tau_i}


def dprtf_means(h: np.ndarray, phase_only: bool = False) -> np.ndarray:
    """CGMM means ``c^{i,d}_f`` (thesis eq. 5.12) from transfer functions ``(M, F, D)``.

    ``r = h^i / h^1`` for ``i = 2..M``, normalised as the observed features:
    ``r / sqrt(1 + |r|^2)``, or ``(r / |r|) / sqrt(2)`` with ``phase_only``.

    Returns
    -------
    ndarray (M - 1, F, D), complex
    """
    h = np.asarray(h)
    if h.ndim != 3 or h.shape[0] < 2:
        raise ValueError(f"dprtf_means: h must have shape (n_mics >= 2, F, D), got {h.shape}")
    with np.errstate(divide="ignore", invalid="ignore"):
        r = h[1:] / h[:1]
        out = r / (np.abs(r) * np.sqrt(2.0)) if phase_only else r / np.sqrt(1.0 + np.abs(r) ** 2)
    return np.where(np.isfinite(out), out, 0.0)


def steering_phases(h: np.ndarray) -> np.ndarray:
    """PHAT steering vectors ``h / |h|`` ``(M, F, D)`` (0 where ``h == 0``)."""
    h = np.asarray(h)
    mag = np.abs(h)
    return np.divide(h, mag, out=np.zeros_like(h), where=mag > 0)
