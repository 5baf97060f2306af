"""Trajectories of simulated people: piecewise-linear paths, random walks, recorded tracks.

A :class:`Trajectory` is a piecewise-linear path of the head / mouth centre in the room frame
(metres, z up) with an optional presence mask: outside its presence intervals the person is
not in the scene (no box, no speech, NaN position).

Generators
----------
- :func:`waypoint_trajectory` -- explicit ``[t, x, y, z]`` waypoints.
- :func:`random_walk` -- a person strolling between random waypoints inside an area with
  pauses, at a walking speed (the usual scripted-walk model of simulated tracking scenes).
- :func:`seated` -- a seated or standing person swaying slightly around a fixed point.
- :func:`from_azimuth_track` -- a recorded azimuth track (LOCATA / Kinovis-MST, 8 ms frames)
  turned into positions on a circle around the array, the way the thesis's NAO recordings
  were made (talkers walking around the robot head).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Trajectory:
    """A piecewise-linear 3-D path with presence intervals.

    Attributes
    ----------
    times : ndarray (K,)
        Strictly increasing knot times in seconds (K >= 1; K == 1 is a static person).
    positions : ndarray (K, 3)
        Room-frame positions (metres) at the knots.
    present : ndarray (P, 2)
        ``[start, end)`` intervals (seconds) in which the person is in the scene; empty means
        always present.
    """

    times: np.ndarray
    positions: np.ndarray
    present: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))

    def __post_init__(self) -> None:
        times = np.atleast_1d(np.asarray(self.times, dtype=float))
        pos = np.asarray(self.positions, dtype=float)
        if times.ndim != 1 or times.size == 0:
            raise ValueError(f"times: expected a non-empty 1-D array, got shape {times.shape}")
        if pos.shape != (times.size, 3):
            raise ValueError(f"positions: expected shape ({times.size}, 3), got {pos.shape}")
        if not (np.all(np.isfinite(times)) and np.all(np.isfinite(pos))):
            raise ValueError("times and positions must be finite")
        if np.any(np.diff(times) <= 0):
            raise ValueError("times must be strictly increasing")
        present = np.asarray(self.present, dtype=float).reshape(-1, 2)
        if np.any(present[:, 1] <= present[:, 0]):
            raise ValueError("present: every interval needs end > start")
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "positions", pos)
        object.__setattr__(self, "present", present)

    def position(self, t: np.ndarray) -> np.ndarray:
        """Interpolated positions, ignoring presence.

        Parameters
        ----------
        t : ndarray (N,)
            Times in seconds; clamped to the knot range.

        Returns
        -------
        ndarray (N, 3)
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return np.stack([np.interp(t, self.times, self.positions[:, d]) for d in range(3)], 1)

    def is_present(self, t: np.ndarray) -> np.ndarray:
        """``(N,)`` bool: whether the person is in the scene at each time."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if self.present.shape[0] == 0:
            return np.ones(t.shape, dtype=bool)
        inside = (t[:, None] >= self.present[None, :, 0]) & (t[:, None] < self.present[None, :, 1])
        return np.asarray(inside.any(axis=1))

    def sample(self, t: np.ndarray) -> np.ndarray:
        """``(N, 3)`` positions with NaN rows where the person is absent."""
        pos = self.position(t)
        pos[~self.is_present(t)] = np.nan
        return pos

    def to_waypoints(self) -> list[list[float]]:
        """``[[t, x, y, z], ...]`` rounded to the millimetre / millisecond, for ``scene.yaml``."""
        rows = np.column_stack([self.times, self.positions])
        return [[round(float(v), 4) for v in row] for row in rows]


def waypoint_trajectory(waypoints, present=None) -> Trajectory:
    """Trajectory through ``[[t, x, y, z], ...]`` waypoints (sorted by time)."""
    wp = np.asarray(waypoints, dtype=float)
    if wp.ndim != 2 or wp.shape[1] != 4 or wp.shape[0] == 0:
        raise ValueError(f"waypoints: expected rows [t, x, y, z], got shape {wp.shape}")
    wp = wp[np.argsort(wp[:, 0], kind="stable")]
    return Trajectory(wp[:, 0], wp[:, 1:], np.zeros((0, 2)) if present is None else present)


def random_walk(
    rng: np.random.Generator,
    duration: float,
    area: np.ndarray,
    height: float = 1.65,
    speed: float = 0.7,
    pause_mean: float = 1.5,
    start: np.ndarray | None = None,
) -> Trajectory:
    """A person walking between uniformly drawn waypoints in a rectangle, pausing at each.

    Parameters
    ----------
    rng : numpy Generator
    duration : float
        Seconds to cover (the last knot is at or after ``duration``).
    area : ndarray (2, 2)
        ``[[x_min, x_max], [y_min, y_max]]`` in metres.
    height : float
        Head height (z) in metres.
    speed : float
        Walking speed in m/s (each leg draws a speed within +-20 %).
    pause_mean : float
        Mean of the exponential pause at each waypoint (0: no pauses).
    start : ndarray (2,), optional
        Starting (x, y); drawn in ``area`` when omitted.
    """
    area = np.asarray(area, dtype=float)
    if area.shape != (2, 2) or np.any(area[:, 1] <= area[:, 0]):
        raise ValueError(f"area: expected [[x_min, x_max], [y_min, y_max]], got {area.tolist()}")
    if speed <= 0 or duration <= 0:
        raise ValueError(f"speed and duration must be > 0, got {speed}, {duration}")
    xy = rng.uniform(area[:, 0], area[:, 1]) if start is None else np.asarray(start, float)
    t = 0.0
    knots = [[t, *xy]]
    while t < duration:
        if pause_mean > 0:
            t += float(rng.exponential(pause_mean))
            knots.append([t, *xy])
        goal = rng.uniform(area[:, 0], area[:, 1])
        leg = float(np.linalg.norm(goal - xy))
        t += leg / (speed * rng.uniform(0.8, 1.2)) if leg > 0 else 0.1
        xy = goal
        knots.append([t, *xy])
    k = np.asarray(knots)
    keep = np.concatenate([[True], np.diff(k[:, 0]) > 1e-9])
    k = k[keep]
    pos = np.column_stack([k[:, 1:3], np.full(k.shape[0], height)])
    return Trajectory(k[:, 0], pos)


def seated(
    rng: np.random.Generator,
    duration: float,
    centre: np.ndarray,
    sway: float = 0.03,
    period: float = 4.0,
) -> Trajectory:
    """A person sitting at ``centre`` (3,) whose head sways by about ``sway`` metres.

    The sway is a sum of two slow sinusoids per horizontal axis with random phases, sampled
    every 0.25 s -- small enough that the acoustics hardly move (<= 5 cm), but enough for the
    detections to wander like real heads do.
    """
    centre = np.asarray(centre, dtype=float)
    if centre.shape != (3,):
        raise ValueError(f"centre: expected (x, y, z), got shape {centre.shape}")
    t = np.arange(0.0, duration + 0.25, 0.25)
    ph = rng.uniform(0, 2 * np.pi, size=(2, 2))
    offs = np.zeros((t.size, 3))
    for axis in range(2):
        offs[:, axis] = 0.6 * sway * np.sin(2 * np.pi * t / period + ph[axis, 0])
        offs[:, axis] += 0.4 * sway * np.sin(2 * np.pi * t / (2.7 * period) + ph[axis, 1])
    return Trajectory(t, centre[None, :] + offs)


def from_azimuth_track(
    azimuth_deg: np.ndarray,
    frame_s: float,
    centre: np.ndarray,
    yaw_deg: float = 0.0,
    radius: float = 1.5,
    height: float = 0.0,
    start_s: float = 0.0,
    duration: float | None = None,
    decimate: int = 6,
) -> Trajectory:
    """Positions on a circle around ``centre`` following a recorded azimuth track.

    Parameters
    ----------
    azimuth_deg : ndarray (F,)
        Recorded azimuths (degrees, counter-clockwise, in the array frame), one per frame.
    frame_s : float
        Frame period of the recording (8 ms for the shared LOCATA / Kinovis-MST tracks).
    centre : ndarray (3,)
        Room-frame position of the array the azimuths refer to.
    yaw_deg : float
        Yaw of the array frame in the room frame.
    radius, height : float
        Horizontal distance from the array and height relative to it (metres).
    start_s, duration : float
        The part of the recording to use, in seconds.
    decimate : int
        Keep every ``decimate``-th frame as a knot (6 x 8 ms = 48 ms: a walker at 1 m/s moves
        under 5 cm between knots, below the renderer's step). Azimuths are unwrapped first so
        the path goes the short way round between knots.
    """
    az = np.asarray(azimuth_deg, dtype=float).ravel()
    if az.size < 2 or not np.all(np.isfinite(az)):
        raise ValueError("azimuth_deg: expected a finite track of at least two frames")
    first = round(start_s / frame_s)
    last = (
        az.size if duration is None else min(az.size, first + int(np.ceil(duration / frame_s)) + 1)
    )
    if first >= last - 1:
        raise ValueError(f"start_s={start_s} leaves no frames of the {az.size}-frame track")
    idx = np.arange(first, last, max(1, int(decimate)))
    if idx[-1] != last - 1:
        idx = np.append(idx, last - 1)
    unwrapped = np.rad2deg(np.unwrap(np.deg2rad(az[first:last])))[idx - first]
    ang = np.deg2rad(unwrapped + yaw_deg)
    centre = np.asarray(centre, dtype=float)
    pos = np.column_stack(
        [
            centre[0] + radius * np.cos(ang),
            centre[1] + radius * np.sin(ang),
            np.full(idx.size, centre[2] + height),
        ]
    )
    return Trajectory((idx - first) * frame_s, pos)
