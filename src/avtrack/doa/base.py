r"""DOA tracker interface, registry and data shared by every acoustic tracker (thesis ch. 5).

The trackers themselves are listed in :mod:`avtrack.doa`.

A tracker is an online object: :meth:`DOATracker.step` takes one frame of observations --
azimuths ``(M,)`` in degrees and their weights / confidences ``(M,)`` -- and returns the
:class:`TrackFrame` of the tracks alive after it, with their speaker-activity decision
(eqs. 5.43 / 5.62). :meth:`DOATracker.run` is the batch helper over a :class:`DOASequence`
(built from heat maps ``(T, D)`` over candidate azimuths ``(D,)`` or from a DOA CSV) and returns
a :class:`~avtrack.io.doa.DOATable` (``id`` ≥ 1, ``active`` = speaking).

Angles are in degrees in the public API, wrapped to (−180, 180].
"""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from avtrack.audio.stft import FRAME_HOP_S
from avtrack.io.doa import DOATable, wrap_azimuth
from avtrack.registry import Registry


def check_config_fields(
    config: Any,
    positive: tuple[str, ...] = (),
    finite: tuple[str, ...] = (),
    counts: tuple[str, ...] = (),
    non_negative: tuple[str, ...] = (),
) -> None:
    """Validate a tracker config's numeric fields, naming the class and field on failure.

    ``positive``: finite numbers > 0; ``finite``: finite numbers; ``counts``: integers >= 1;
    ``non_negative``: finite numbers >= 0 (e.g. ``lead_s``). Booleans are rejected everywhere
    (``True`` is not a number of iterations).
    """
    owner = type(config).__name__
    for name in positive:
        v = getattr(config, name)
        if isinstance(v, bool) or not (isinstance(v, int | float) and np.isfinite(v) and v > 0):
            raise ValueError(f"{owner}.{name} must be a positive number, got {v!r}")
    for name in finite:
        v = getattr(config, name)
        if isinstance(v, bool) or not (isinstance(v, int | float) and np.isfinite(v)):
            raise ValueError(f"{owner}.{name} must be a finite number, got {v!r}")
    for name in counts:
        v = getattr(config, name)
        if isinstance(v, bool) or not (isinstance(v, int) and v >= 1):
            raise ValueError(f"{owner}.{name} must be an integer >= 1, got {v!r}")
    for name in non_negative:
        v = getattr(config, name)
        if isinstance(v, bool) or not (isinstance(v, int | float) and np.isfinite(v) and v >= 0):
            raise ValueError(f"{owner}.{name} must be a finite number >= 0, got {v!r}")


TRACKERS: Registry[type[DOATracker]] = Registry("DOA tracker")
"""Registered DOA tracker classes by name (``"gauss"``, ``"vonmises"``); the package
:mod:`avtrack.doa` imports every built-in tracker, so it is complete once ``avtrack.doa`` is
imported."""

#: Tracker update period of thesis §5.5.2: one update every 32 ms (4 STFT hops of 8 ms).
FRAME_PERIOD_S = 0.032

#: How a tracker can observe a heat map (:func:`heatmap_sequence`): every candidate direction
#: with its weight (``"all"``, thesis §5.4 as written), every candidate with the frame's median
#: weight subtracted and clipped at 0 (``"above-median"``), only the peaks of the heat map at or
#: above a fixed weight (``"peaks"``, the peak lists of §5.6.5), or only the peaks at or above
#: :data:`UNIFORM_PEAK_FLOOR` times the uniform weight ``1/D`` of the ``D`` candidates in the
#: block's last localizer frame (``"peaks-over-uniform"``: a floor that does not depend on how
#: high a heat map's peaks are, and the frame that peak picking reports, without the 1.5 frames
#: of delay of a 4-frame mean). The other modes take the block's mean weights.
OBSERVATION_MODES = ("all", "above-median", "peaks", "peaks-over-uniform")

#: What each tracker observes by default. The von Mises tracker takes the peaks of the heat map
#: above 1.44 times the uniform weight (a peak floor fixed at 0.05 hid a third of the speech
#: frames from it). The Gaussian tracker takes every candidate without the frame's median
#: weight: the EG weights keep a near-uniform floor (the entropy regularisation of eq. 5.19),
#: and with every weight acting as a precision (eq. 5.22) that floor pins a silent track where
#: it is and spreads its activity mass (eq. 5.43) over ±40°. Its direction is then the centroid
#: of the whole lobe, which trails a moving talker by 10-20 frames of 8 ms and adds about 1° of
#: error; ``"peaks-over-uniform"`` with ``GaussConfig(obs_var=0.0003)`` removes that, but raises
#: its miss rate above peak picking's on LOCATA-like scenes, so it is an option (see
#: BENCHMARKS.md).
DEFAULT_OBSERVATIONS = {"gauss": "above-median", "vonmises": "peaks-over-uniform"}

#: Peaks of a block-mean heat map below this weight are not observations (mode ``"peaks"``).
PEAK_FLOOR = 0.05

#: Mode ``"peaks-over-uniform"``: peaks below this multiple of the uniform weight ``1/D`` are
#: not observations (1.44 / 72 = 0.02 on the default 5° grid).
UNIFORM_PEAK_FLOOR = 1.44

#: The same multiple for the lower, wider peaks of ``dprtf-eg-fast`` heat maps (1.15 / 72 ≈
#: 0.016), part of :data:`MAP_READINGS` for that localizer.
FAST_MAP_UNIFORM_PEAK_FLOOR = 1.15

#: Seconds ahead that trackers report on ``dprtf-eg-fast`` maps (``lead_s`` of both Configs):
#: the map's peaks trail a moving talker by 18-21 frames of 8 ms (median lag on simulated
#: LOCATA-like and Kinovis-like scenes); reporting the direction the trackers' dynamics predict
#: 0.15 s ahead brings their median lag on LOCATA-like scenes to 8-10 frames (0.2 s overshoots
#: a talker walking steadily at 30°/s by 2-3°; BENCHMARKS.md, acoustic tracking).
FAST_MAP_LEAD_S = 0.15


@dataclass(frozen=True)
class MapReading:
    """How a tracker reads one localizer's heat maps by default (:func:`map_reading`).

    Attributes
    ----------
    observations : str
        One of :data:`OBSERVATION_MODES`.
    uniform_floor : float
        Peak floor of ``"peaks-over-uniform"``, as a multiple of the uniform weight ``1/D``.
    config : dataclass
        The tracker's ``Config``.
    evidence_hold_s : float or None
        None: every heat map is an observation. Seconds: a map more than this long after the
        latest frame with new evidence (:meth:`avtrack.localize.base.Localizer.evidence`) is
        read as uniform, i.e. no observation (:class:`EvidenceGate`).
    """

    observations: str
    uniform_floor: float
    config: Any
    evidence_hold_s: float | None = None


#: Tracker settings per localizer whose maps differ from ``dprtf-eg``'s, as field overrides on
#: the tracker's ``Config`` (other localizers: the ``Config`` defaults with
#: :data:`DEFAULT_OBSERVATIONS` and :data:`UNIFORM_PEAK_FLOOR`). ``dprtf-eg-fast`` maps have
#: lower, wider and faster peaks: both trackers take the peaks at or above 1.15 / D of the
#: block's last frame and report the direction predicted :data:`FAST_MAP_LEAD_S` ahead by the
#: track's angular velocity (``lead_s``: it compensates the map's own delay). The Gaussian
#: tracker, on peaks rather than whole lobes, uses a smaller observation variance (0.0006),
#: keeps more of its angular velocity from frame to frame (0.98) and a lower activity threshold
#: δ (0.02, for the peaks' lower weights) over L' = 2 frames of eq. 5.43, not 3 (on simulated
#: Kinovis-like scenes FA 22.0 % at MD 33.3 % against 25.4 / 31.7 over 3 frames: the activity
#: of a talker who stops ends sooner). The von Mises tracker lets DOAs from 0.03 start a
#: source, 10° (not 20°) from another (20° kept a talker who reappeared near a stale track
#: unborn), is active above δ = 0.032, keeps its angular velocity through short pauses (0.95
#: of it per silent frame, not 0.8: a talker who pauses while walking goes on walking), and
#: starts from an observation concentration κ_y of 400
#: for a confidence-1 DOA (a peak of weight 0.06 then has κ = 24, about 12° of spread; from
#: 120, about 21°, a quieter talker 45° from a louder one on a small array was drawn into the
#: louder one's track). Chosen on development seeds 10-15 of both simulated scene kinds and
#: on the shared real array recordings (BENCHMARKS.md, acoustic tracking). ``dprtf-eg-static``
#: maps are the same kind of map and are read the same way.
FAST_MAP_OVERRIDES: dict[str, dict[str, Any]] = {
    "gauss": {
        "obs_var": 0.0006,
        "velocity_decay": 0.98,
        "activity_threshold": 0.02,
        "activity_frames": 2,
        "lead_s": FAST_MAP_LEAD_S,
    },
    "vonmises": {
        "birth_floor": 0.03,
        "birth_min_separation_deg": 10.0,
        "activity_threshold": 0.032,
        "kappa_y": 400.0,
        "silent_velocity_decay": 0.95,
        "lead_s": FAST_MAP_LEAD_S,
    },
}

#: Seconds for which the trackers read a ``dprtf-eg-fast`` map as evidence after the latest
#: frame with enough DP-RTF features (:class:`EvidenceGate`). Once the talker stops, the map
#: keeps its peak while the weights relax to uniform at ``silence_rate`` (0.065 a frame) and
#: the trackers followed that memory for up to 0.6 s, most of their false alarms on simulated
#: Kinovis-like scenes. 0.2 s is the hangover of speech activity detectors: the pauses inside a
#: turn stay spoken, the tail after it is cut (BENCHMARKS.md, acoustic tracking).
FAST_MAP_EVIDENCE_HOLD_S = 0.2

#: How much higher the trackers' peak floor and activity and birth thresholds stand on
#: ``dprtf-eg-smooth`` maps than on ``dprtf-eg-fast`` maps. Smoothed over the next 0.2 s, a
#: talker's peak is narrower and higher: the peak threshold at the best point of peak picking
#: rises from 0.017-0.026 to 0.033-0.036 on simulated LOCATA-like and Kinovis-like scenes, and
#: the trackers read at the fast map's thresholds took the smoothed maps' side lobes for
#: talkers (Kinovis-like FA 44.6 / 39.3 %). Chosen between 1.2 and 1.35 on seeds 0-4 and 20-24
#: of both scene kinds (BENCHMARKS.md, acoustic tracking).
SMOOTH_MAP_PEAK_SCALE = 1.35

#: The trackers' thresholds that :data:`SMOOTH_MAP_PEAK_SCALE` raises.
_PEAK_FIELDS = ("activity_threshold", "birth_floor")

#: :data:`FAST_MAP_OVERRIDES` for ``dprtf-eg-smooth`` maps, thresholds raised by
#: :data:`SMOOTH_MAP_PEAK_SCALE`.
SMOOTH_MAP_OVERRIDES: dict[str, dict[str, Any]] = {
    tracker: {k: v * SMOOTH_MAP_PEAK_SCALE if k in _PEAK_FIELDS else v
              for k, v in fields.items()}
    for tracker, fields in FAST_MAP_OVERRIDES.items()
}

#: Seconds for which the trackers read a ``dprtf-eg-smooth`` map as evidence after the latest
#: frame with enough features: the map itself holds its peaks through pauses (relaxing at 0.04
#: a frame, ``SmoothEGConfig.output_silence_rate``), so the gate ends sooner than on the fast
#: map (0.1 s gave Kinovis-like MD 38.6 / 39.0 %, 0.2 s FA 26.8 / 24.2 %; BENCHMARKS.md).
SMOOTH_MAP_EVIDENCE_HOLD_S = 0.15

#: ``{method: ("peaks-over-uniform" floor, {tracker: Config overrides})}``
MAP_READINGS: dict[str, tuple[float, dict[str, dict[str, Any]]]] = {
    "dprtf-eg-fast": (FAST_MAP_UNIFORM_PEAK_FLOOR, FAST_MAP_OVERRIDES),
    "dprtf-eg-static": (FAST_MAP_UNIFORM_PEAK_FLOOR, FAST_MAP_OVERRIDES),
    "dprtf-eg-smooth": (FAST_MAP_UNIFORM_PEAK_FLOOR * SMOOTH_MAP_PEAK_SCALE,
                        SMOOTH_MAP_OVERRIDES),
}

#: ``{method: MapReading.evidence_hold_s}`` of the maps of :data:`MAP_READINGS` that have one.
MAP_EVIDENCE_HOLD_S: dict[str, float] = {
    "dprtf-eg-fast": FAST_MAP_EVIDENCE_HOLD_S, "dprtf-eg-static": FAST_MAP_EVIDENCE_HOLD_S,
    "dprtf-eg-smooth": SMOOTH_MAP_EVIDENCE_HOLD_S,
}


def map_reading(tracker: str, method: str | None = None) -> MapReading:
    """The default observations, peak floor and ``Config`` of ``tracker`` on heat maps of the
    localizer ``method`` (None: a DOA table or a map of unknown origin, read as ``dprtf-eg``'s).

    Every tracker takes ``"peaks-over-uniform"`` observations on the maps of
    :data:`MAP_READINGS`; elsewhere its :data:`DEFAULT_OBSERVATIONS`.
    """
    if tracker not in TRACKERS:
        raise ValueError(
            f"map_reading: tracker must be one of {sorted(TRACKERS)}, got {tracker!r}"
        )
    cls = TRACKERS[tracker].Config
    if method in MAP_READINGS:
        floor, overrides = MAP_READINGS[method]
        config = dataclasses.replace(cls(), **overrides.get(tracker, {}))
        return MapReading("peaks-over-uniform", floor, config, MAP_EVIDENCE_HOLD_S.get(method))
    return MapReading(DEFAULT_OBSERVATIONS.get(tracker, "all"), UNIFORM_PEAK_FLOOR, cls())


#: Class decorator registering a :class:`DOATracker` subclass under a name.
register_tracker = TRACKERS.register


def make_tracker(
    name: str, config: Any = None, frame_period_s: float = FRAME_PERIOD_S
) -> DOATracker:
    """Instantiate the tracker registered as ``name`` (see :data:`TRACKERS`)."""
    if name not in TRACKERS:
        raise ValueError(f"make_tracker: name must be one of {sorted(TRACKERS)}, got {name!r}")
    return TRACKERS[name](config, frame_period_s)


@dataclass(frozen=True, eq=False)
class TrackFrame:
    """The tracks alive after one frame.

    Attributes
    ----------
    ids : ndarray (K,) int
        Track identities (≥ 1).
    azimuth_deg : ndarray (K,)
        Posterior mean directions, degrees in (−180, 180].
    active : ndarray (K,) bool
        Speaker-activity decision (eq. 5.43 / 5.62).
    activity : ndarray (K,)
        The activity statistic compared with the threshold.
    """

    ids: np.ndarray
    azimuth_deg: np.ndarray
    active: np.ndarray
    activity: np.ndarray

    def __len__(self) -> int:
        return int(self.ids.shape[0])


@dataclass(frozen=True, eq=False)
class DOASequence:
    """Frames of DOA observations for a tracker.

    Attributes
    ----------
    frames : ndarray (T,) int
        Frame index of each tracker frame (the localizer's frame it is reported at).
    time_s : ndarray (T,)
        Time of each frame, seconds.
    azimuth_deg : tuple of T ndarrays (M_t,)
        Observed azimuths (candidate directions or peaks), degrees.
    weight : tuple of T ndarrays (M_t,)
        Their weights / confidences, ≥ 0.
    """

    frames: np.ndarray
    time_s: np.ndarray
    azimuth_deg: tuple[np.ndarray, ...]
    weight: tuple[np.ndarray, ...]

    def __post_init__(self) -> None:
        t_ = np.shape(self.frames)[0] if np.ndim(self.frames) == 1 else -1
        if t_ < 0 or np.shape(self.time_s) != (t_,):
            raise ValueError(
                f"DOASequence: frames and time_s must be (T,), got "
                f"{np.shape(self.frames)} and {np.shape(self.time_s)}"
            )
        if len(self.azimuth_deg) != t_ or len(self.weight) != t_:
            raise ValueError(
                f"DOASequence: azimuth_deg and weight need one array per frame "
                f"({t_}), got {len(self.azimuth_deg)} and {len(self.weight)}"
            )
        for k, (a, w) in enumerate(zip(self.azimuth_deg, self.weight, strict=True)):
            if np.ndim(a) != 1 or np.shape(a) != np.shape(w):
                raise ValueError(
                    f"DOASequence: frame {k}: azimuth_deg and weight must be "
                    f"(M,) arrays of one length, got {np.shape(a)}, {np.shape(w)}"
                )
        object.__setattr__(self, "frames", np.asarray(self.frames, dtype=np.int64))
        object.__setattr__(self, "time_s", np.asarray(self.time_s, dtype=float))

    def __len__(self) -> int:
        return int(self.frames.shape[0])

    @classmethod
    def from_weights(
        cls,
        weights: np.ndarray,
        azimuth_deg: np.ndarray,
        frames: np.ndarray | None = None,
        time_s: np.ndarray | None = None,
        step: int = 1,
        mode: str = "mean",
        peaks_only: bool = False,
        floor: float = 0.0,
        frame_period_s: float = FRAME_HOP_S,
        baseline: str = "none",
    ) -> DOASequence:
        """Observations from heat maps over fixed candidate directions.

        Parameters
        ----------
        weights : ndarray (T, D)
            Weight of each candidate at each localizer frame (e.g. EG weights, eq. 5.19).
        azimuth_deg : ndarray (D,)
            Candidate azimuths, degrees.
        frames, time_s : ndarray (T,), optional
            Localizer frame indices and times (default ``0..T-1`` and ``frames *
            frame_period_s``).
        step : int
            One tracker frame per ``step`` localizer frames (thesis §5.5.2: 4, i.e. 32 ms),
            reported at the last frame of each block; a last incomplete block is dropped.
        mode : {"mean", "last"}
            The block's weights: their mean, or those of its last frame.
        peaks_only : bool
            Keep only the circular local maxima of each frame's weights (the peak lists of
            thesis §5.6.5) instead of every candidate.
        floor : float
            Drop observations with a weight below ``floor``.
        frame_period_s : float
            Localizer frame period, for the default times.
        baseline : {"none", "median"}
            ``"median"``: subtract each tracker frame's median weight from its weights and clip
            at 0 (before ``floor`` and ``peaks_only``), removing the uniform floor of a heat map.
        """
        w = np.asarray(weights, dtype=float)
        az = np.asarray(azimuth_deg, dtype=float).reshape(-1)
        if w.ndim != 2 or w.shape[1] != az.size:
            raise ValueError(
                f"weights must have shape (T, {az.size}) for {az.size} candidate "
                f"azimuths, got {w.shape}"
            )
        if not (np.all(np.isfinite(w)) and np.all(np.isfinite(az))):
            raise ValueError("weights and azimuth_deg must be finite")
        if w.size and w.min() < 0:
            raise ValueError(f"weights must be >= 0, got min {w.min()}")
        if isinstance(step, bool) or not isinstance(step, int | np.integer) or step < 1:
            raise ValueError(f"step must be a positive integer, got {step!r}")
        if mode not in ("mean", "last"):
            raise ValueError(f"mode must be 'mean' or 'last', got {mode!r}")
        if baseline not in ("none", "median"):
            raise ValueError(f"baseline must be 'none' or 'median', got {baseline!r}")
        t_ = w.shape[0]
        frames = np.arange(t_) if frames is None else np.asarray(frames, dtype=np.int64)
        time_s = frames * frame_period_s if time_s is None else np.asarray(time_s, dtype=float)
        if frames.shape != (t_,) or time_s.shape != (t_,):
            raise ValueError(
                f"frames and time_s must have shape ({t_},), got {frames.shape} and {time_s.shape}"
            )
        n_blocks = t_ // step
        last = np.arange(n_blocks) * step + step - 1
        if mode == "mean":
            w = w[: n_blocks * step].reshape(n_blocks, step, -1).mean(axis=1)
        else:
            w = w[last]
        if baseline == "median" and w.size:
            w = np.maximum(w - np.median(w, axis=1, keepdims=True), 0.0)
        keep: np.ndarray = np.asarray(w >= floor) if floor > 0 else np.ones(w.shape, dtype=bool)
        if peaks_only:
            keep &= circular_peaks(w)
        az.setflags(write=False)
        full = np.asarray(keep.all(axis=1))
        azs = tuple(az if full[k] else az[keep[k]] for k in range(n_blocks))
        ws = tuple(w[k] if full[k] else w[k, keep[k]] for k in range(n_blocks))
        return cls(frames[last], time_s[last], azs, ws)

    @classmethod
    def from_table(
        cls, table: DOATable, step: int = 1, frame_period_s: float | None = None
    ) -> DOASequence:
        """Observations from a DOA CSV table (e.g. another localizer's peaks).

        Every localizer frame from the first to the last frame of ``table`` is covered; the
        rows of each block of ``step`` frames are pooled, each keeping its weight as its
        confidence, and reported at the block's last frame. Only rows with ``active`` set are
        used.

        Parameters
        ----------
        table : DOATable
        step : int
            Localizer frames per tracker frame.
        frame_period_s : float, optional
            Localizer frame period (default: from the table's frames and times, else 8 ms).
        """
        if not isinstance(table, DOATable):
            raise TypeError(f"table must be a DOATable, got {type(table).__name__}")
        if isinstance(step, bool) or not isinstance(step, int | np.integer) or step < 1:
            raise ValueError(f"step must be a positive integer, got {step!r}")
        rows = table.select(table.active)
        if len(rows) == 0:
            empty = np.zeros(0)
            return cls(np.zeros(0, np.int64), empty, (), ())
        f = rows.frames
        if frame_period_s is None:
            uf, first = np.unique(f, return_index=True)
            if uf.size > 1:
                frame_period_s = float(np.median(np.diff(rows.time_s[first]) / np.diff(uf)))
            else:
                frame_period_s = FRAME_HOP_S
        if not frame_period_s > 0:
            raise ValueError(f"frame_period_s must be > 0, got {frame_period_s!r}")
        offset = float(np.median(rows.time_s - f * frame_period_s))
        f0 = int(f.min())
        block = (f - f0) // step
        n_blocks = int(block.max()) + 1
        order = np.argsort(block, kind="stable")
        starts = np.searchsorted(block[order], np.arange(n_blocks + 1))
        az, w = rows.azimuth_deg[order], rows.weight[order]
        if w.size and w.min() < 0:
            raise ValueError("DOA table weights must be >= 0 to be used as confidences")
        frames = f0 + np.arange(n_blocks) * step + step - 1
        azs = tuple(az[starts[k] : starts[k + 1]] for k in range(n_blocks))
        ws = tuple(w[starts[k] : starts[k + 1]] for k in range(n_blocks))
        return cls(frames, np.maximum(offset + frames * frame_period_s, 0.0), azs, ws)


def heatmap_sequence(
    weights: np.ndarray,
    azimuth_deg: np.ndarray,
    frames: np.ndarray | None = None,
    time_s: np.ndarray | None = None,
    step: int = 4,
    observations: str = "all",
    floor: float = PEAK_FLOOR,
    uniform_floor: float = UNIFORM_PEAK_FLOOR,
) -> DOASequence:
    """Tracker observations from heat maps ``(T, D)`` in one of :data:`OBSERVATION_MODES`.

    One tracker frame per ``step`` localizer frames (thesis §5.5.2: 4, i.e. 32 ms) with the
    block's mean weights, or its last frame's for ``"peaks-over-uniform"``; ``"peaks"`` keeps
    the peaks at or above ``floor`` (the other modes ignore it), ``"peaks-over-uniform"`` those
    at or above ``uniform_floor / D`` (default :data:`UNIFORM_PEAK_FLOOR`; for
    ``dprtf-eg-fast`` maps :data:`FAST_MAP_UNIFORM_PEAK_FLOOR`).
    Use ``DEFAULT_OBSERVATIONS[tracker]`` for a tracker's default.
    """
    if observations not in OBSERVATION_MODES:
        raise ValueError(
            f"observations must be one of {OBSERVATION_MODES}, got {observations!r}"
        )
    peaks = observations.startswith("peaks")
    if observations == "peaks-over-uniform":
        if not (np.isfinite(uniform_floor) and uniform_floor >= 0):
            raise ValueError(f"uniform_floor must be finite and >= 0, got {uniform_floor!r}")
        floor = uniform_floor / max(int(np.shape(weights)[-1]), 1)
    return DOASequence.from_weights(
        weights,
        azimuth_deg,
        frames,
        time_s,
        step=step,
        mode="last" if observations == "peaks-over-uniform" else "mean",
        peaks_only=peaks,
        floor=floor if peaks else 0.0,
        baseline="median" if observations == "above-median" else "none",
    )


class EvidenceGate:
    """Heat maps read as no observation once their localizer has had no evidence for a while.

    A localizer with memory (the CGMM weights, thesis eqs. 5.17-5.19) keeps its peaks after a
    talker stops and relaxes them slowly; a tracker reading those maps keeps the talker active
    for that long. The gate replaces each map row more than ``hold_frames`` frames after the
    latest frame with new evidence by the uniform map of the same total weight (no peak, and
    nothing above the median). Fed in blocks it gives the rows it gives fed at once.

    Parameters
    ----------
    hold_frames : int
        Frames after a frame with evidence during which the maps pass unchanged (>= 0).
    """

    def __init__(self, hold_frames: int) -> None:
        if isinstance(hold_frames, bool) or not isinstance(hold_frames, int | np.integer) or (
                hold_frames < 0):
            raise ValueError(f"EvidenceGate: hold_frames must be an integer >= 0, "
                             f"got {hold_frames!r}")
        self.hold_frames = int(hold_frames)
        self.reset()

    @classmethod
    def for_hold(cls, hold_s: float, frame_period_s: float) -> EvidenceGate:
        """The gate holding ``hold_s`` seconds of frames ``frame_period_s`` apart."""
        if not (np.isfinite(hold_s) and hold_s >= 0):
            raise ValueError(f"EvidenceGate: hold_s must be finite and >= 0, got {hold_s!r}")
        return cls(round(hold_s / frame_period_s))

    def reset(self) -> None:
        """Start a new signal (no evidence seen yet: maps are stale until the first)."""
        self._since = self.hold_frames + 1  # frames since the latest frame with evidence

    def apply(self, weights: np.ndarray, evidence: np.ndarray) -> np.ndarray:
        """The maps ``(T, D)`` with stale rows made uniform, given which frames had evidence
        ``(T,)`` bool; a new array (``weights`` is not changed)."""
        w = np.array(weights, dtype=float)
        ev = np.asarray(evidence, dtype=bool)
        if w.ndim != 2 or ev.shape != (w.shape[0],):
            raise ValueError(f"EvidenceGate.apply: weights must be (T, D) and evidence (T,), "
                             f"got {w.shape} and {ev.shape}")
        t_ = ev.size
        if t_ == 0:
            return w
        idx = np.arange(t_)
        last = np.maximum.accumulate(np.where(ev, idx, -1 - self._since))
        since = idx - last
        stale = since > self.hold_frames
        if np.any(stale) and w.shape[1]:
            w[stale] = w[stale].sum(axis=1, keepdims=True) / w.shape[1]
        self._since = int(since[-1])
        return w


def gate_maps(weights: np.ndarray, evidence: np.ndarray, hold_s: float | None,
              frame_period_s: float) -> np.ndarray:
    """A whole signal's maps ``(T, D)`` as a tracker reads them: unchanged when ``hold_s`` is
    None, else through a new :class:`EvidenceGate` of ``hold_s`` (``evidence (T,)``: which
    frames had any, :meth:`avtrack.localize.base.Localizer.evidence`)."""
    if hold_s is None:
        return np.asarray(weights)
    return EvidenceGate.for_hold(hold_s, frame_period_s).apply(weights, evidence)


def circular_peaks(weights: np.ndarray) -> np.ndarray:
    """Mask ``(T, D)`` of the local maxima of each row, neighbours wrapping around (a plateau
    gives one peak, a constant row none)."""
    w = np.asarray(weights, dtype=float)
    return (w > np.roll(w, 1, axis=-1)) & (w >= np.roll(w, -1, axis=-1))


class SpeakerActivity:
    r"""Speaker-activity detection from the weighted assignment mass (eqs. 5.43 and 5.62).

    Track ``n`` is active at frame ``t`` when
    :math:`\sum_{i=t-L'+1}^{t}\sum_d \alpha_{idn} w_{id} > \delta`.

    Parameters
    ----------
    window : int
        :math:`L'` (eq. 5.43: 3) or :math:`D + 1` (eq. 5.62: ``D = 2``).
    threshold : float
        :math:`\delta`.
    """

    def __init__(self, window: int, threshold: float):
        if isinstance(window, bool) or not isinstance(window, int) or window < 1:
            raise ValueError(f"window must be an integer >= 1, got {window!r}")
        if not np.isfinite(threshold):
            raise ValueError(f"threshold must be finite, got {threshold!r}")
        self.window = window
        self.threshold = float(threshold)
        self.history = np.zeros((0, window))  # a ring buffer over the last L' frames
        self.silent_frames = np.zeros(0, dtype=np.int64)
        self._slot = 0

    def update(self, mass: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Push this frame's ``mass (N,)``; return the statistic ``(N,)`` and the decision."""
        self.history[:, self._slot] = mass
        self._slot = (self._slot + 1) % self.window
        score = self.history.sum(axis=1)  # Σ over the last L' frames, eq. 5.43
        active = score > self.threshold
        self.silent_frames = np.where(active, 0, self.silent_frames + 1)
        return score, active

    def add(self, count: int, mass: float = 0.0) -> None:
        """Append ``count`` new tracks with ``mass`` in every slot of their window."""
        self.history = np.vstack([self.history, np.full((count, self.window), mass)])
        self.silent_frames = np.concatenate([self.silent_frames, np.zeros(count, dtype=np.int64)])

    def remove(self, keep: np.ndarray) -> None:
        """Keep the tracks where ``keep (N,)`` is True."""
        self.history = self.history[keep]
        self.silent_frames = self.silent_frames[keep]


class DOATracker(ABC):
    """Online multi-speaker DOA tracker.

    Parameters
    ----------
    config : optional
        The implementation's parameters (its ``Config`` dataclass); default ``Config()``.
    frame_period_s : float
        Time between two :meth:`step` calls, seconds (thesis §5.5.2: 32 ms).
    """

    name: ClassVar[str] = ""
    Config: ClassVar[type] = type(None)

    def __init__(self, config: Any = None, frame_period_s: float = FRAME_PERIOD_S):
        config = self.Config() if config is None else config
        if not isinstance(config, self.Config):
            raise TypeError(
                f"{type(self).__name__}: config must be a {self.Config.__name__}, "
                f"got {type(config).__name__}"
            )
        if not (
            isinstance(frame_period_s, int | float)
            and np.isfinite(frame_period_s)
            and frame_period_s > 0
        ):
            raise ValueError(
                f"frame_period_s must be a positive number of seconds, got {frame_period_s!r}"
            )
        self.config: Any = config
        self.frame_period_s = float(frame_period_s)
        self.reset()

    def reset(self) -> None:
        """Forget every track (a new recording)."""
        self.frame = 0
        self._next_id = 1
        self._azimuths: tuple[np.ndarray, np.ndarray] | None = None
        self._reset_state()

    def _new_ids(self, count: int) -> np.ndarray:
        ids = np.arange(self._next_id, self._next_id + count, dtype=np.int64)
        self._next_id += count
        return ids

    def step(self, azimuth_deg: np.ndarray, weight: np.ndarray) -> TrackFrame:
        """Process one frame of observations.

        Parameters
        ----------
        azimuth_deg : ndarray (M,)
            Observed azimuths, degrees (any finite value; wrapped internally).
        weight : ndarray (M,)
            Their weights / confidences, ≥ 0.

        Returns
        -------
        TrackFrame
            The tracks alive after this frame.
        """
        w = np.asarray(weight, dtype=float)
        cached = self._azimuths
        if cached is not None and azimuth_deg is cached[0]:
            az, rad = cached  # the same read-only candidate directions as the last frame
        else:
            az = np.asarray(azimuth_deg, dtype=float)
            if az.ndim != 1 or not np.all(np.isfinite(az)):
                raise ValueError(f"azimuth_deg must be a finite (M,) array, got shape {az.shape}")
            rad = np.deg2rad(az)
            if isinstance(azimuth_deg, np.ndarray) and not azimuth_deg.flags.writeable:
                rad.flags.writeable = False
                self._azimuths = (azimuth_deg, rad)
        if w.shape != az.shape:
            raise ValueError(
                f"azimuth_deg and weight must be (M,) arrays of one length, got "
                f"{az.shape} and {w.shape}"
            )
        if w.size and not w.min() >= 0:  # also rejects NaN
            raise ValueError(f"weight must be finite and >= 0, got min {w.min()}")
        if w.size and not np.isfinite(w.max()):
            raise ValueError("weight must be finite")
        self.frame += 1
        return self._step(rad, w)

    def run(self, sequence: DOASequence) -> DOATable:
        """Track a whole sequence from a fresh state (batch helper around :meth:`step`).

        Returns
        -------
        DOATable
            One row per alive track per frame: ``id`` ≥ 1, ``weight`` the activity statistic,
            ``active`` the speaker-activity decision.
        """
        if not isinstance(sequence, DOASequence):
            raise TypeError(f"sequence must be a DOASequence, got {type(sequence).__name__}")
        self.reset()
        outs = [
            self.step(a, w) for a, w in zip(sequence.azimuth_deg, sequence.weight, strict=True)
        ]
        return frames_to_table(outs, sequence.frames, sequence.time_s)

    @abstractmethod
    def _reset_state(self) -> None:
        """Clear the tracks and the learned parameters."""

    @abstractmethod
    def _step(self, azimuth_rad: np.ndarray, weight: np.ndarray) -> TrackFrame:
        """One frame on validated observations (azimuths in radians)."""


def frames_to_table(outs: list[TrackFrame], frames: np.ndarray, time_s: np.ndarray) -> DOATable:
    """Per-frame :class:`TrackFrame` results as a :class:`~avtrack.io.doa.DOATable`."""
    counts = np.array([len(o) for o in outs], dtype=np.int64)
    if counts.sum() == 0:
        return DOATable.empty()
    cat = np.concatenate
    return DOATable(
        np.repeat(np.asarray(frames, dtype=np.int64), counts),
        np.repeat(np.asarray(time_s, dtype=float), counts),
        cat([o.ids for o in outs]),
        wrap_azimuth(cat([o.azimuth_deg for o in outs])),
        np.zeros(int(counts.sum())),
        cat([o.activity for o in outs]),
        cat([o.active for o in outs]),
    )
