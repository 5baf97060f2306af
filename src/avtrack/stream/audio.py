"""Acoustic-only streaming: localizer + VEM DOA tracker on a live multichannel stream.

Pipeline per block of samples (thesis ch. 5): the localizer's streaming STFT and recursive
DP-RTF + exponentiated-gradient update (§5.2–5.3, one heat map per 8 ms STFT frame), the block
mean of every ``step`` heat maps (§5.5.2: a tracker frame every 32 ms), its candidates or peaks
as observations, and one tracker step (Gaussian §5.4 or von Mises §5.6).

State is bounded: the STFT keeps less than one window of samples, the localizer and the
tracker keep fixed-size recursive statistics, and fewer than ``step`` heat maps wait for their
tracker frame. Fed a signal in blocks of any sizes, :class:`DOAStream` gives exactly the tracks
of ``tracker.run(heatmap_sequence(gate.apply(localizer.run(signal).weights, ...), ...))``
(:class:`~avtrack.doa.base.EvidenceGate`: maps long after the localizer's latest evidence are
no observation).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from avtrack.audio.arrays import MicArray
from avtrack.doa.base import (
    OBSERVATION_MODES,
    PEAK_FLOOR,
    TRACKERS,
    EvidenceGate,
    TrackFrame,
    heatmap_sequence,
    make_tracker,
    map_reading,
)
from avtrack.localize import DEFAULT_LOCALIZER, DirectionGrid, HeatMaps, make_localizer
from avtrack.localize.grid import azimuth_profile


@dataclass(frozen=True, eq=False)
class DOAStreamFrame:
    """The tracks after one tracker frame.

    Attributes
    ----------
    frame : int
        Localizer (STFT) frame the tracker frame is reported at (its block's last frame).
    time_s : float
        Its time in the stream, seconds (window centre).
    tracks : TrackFrame
        Ids ``(K,)``, azimuths ``(K,)`` in degrees, speaking decisions ``(K,)`` and activity
        statistics ``(K,)`` of the tracks alive after the frame.
    """

    frame: int
    time_s: float
    tracks: TrackFrame


class DOAStream:
    """Online localization and tracking of several speakers from a microphone array.

    Parameters
    ----------
    array : MicArray
        The microphone array; channel ``k`` of every block is microphone ``k``.
    method : str
        Localizer (``avtrack.localize.LOCALIZERS``; default
        :data:`~avtrack.localize.base.DEFAULT_LOCALIZER`, ``"dprtf-eg-smooth"``).
    tracker : str
        DOA tracker (``"gauss"`` or ``"vonmises"``; default ``"vonmises"``).
    step : int
        Localizer frames per tracker frame (default 4: 32 ms).
    observations : {"all", "above-median", "peaks", "peaks-over-uniform"}, optional
        Every candidate direction, the same above each frame's median weight, the heat map's
        peaks at or above ``floor``, or those at or above a multiple of the uniform weight
        (default: the tracker's own for ``method``'s maps, :func:`~avtrack.doa.base.map_reading`).
    grid : DirectionGrid, optional
        Candidate directions (default: :meth:`DirectionGrid.for_array`; on a grid of several
        elevations the trackers observe the map over azimuth,
        :func:`~avtrack.localize.grid.azimuth_profile`).
    method_config, tracker_config : optional
        The localizer's and the tracker's ``Config`` dataclasses (default: the localizer's
        defaults, and the tracker's for ``method``'s maps, :func:`~avtrack.doa.base.map_reading`).
    floor : float
        With ``"peaks"`` observations, drop peaks below this weight (default
        :data:`~avtrack.doa.base.PEAK_FLOOR`).
    evidence_hold_s : float or None, optional
        Seconds after the localizer's latest frame with evidence during which its maps are
        observations; later maps are read as none (:class:`~avtrack.doa.base.EvidenceGate`).
        None: every map. Default: ``method``'s own (:func:`~avtrack.doa.base.map_reading`).

    Examples
    --------
    >>> stream = DOAStream(get_array("nao4"))
    >>> for block in blocks:                     # (4, n) float arrays as they arrive
    ...     for out in stream.push(block):       # one DOAStreamFrame every 32 ms
    ...         print(out.time_s, out.tracks.ids, out.tracks.azimuth_deg, out.tracks.active)
    """

    def __init__(
        self,
        array: MicArray,
        *,
        method: str = DEFAULT_LOCALIZER,
        tracker: str = "vonmises",
        step: int = 4,
        observations: str | None = None,
        grid: DirectionGrid | None = None,
        method_config: Any = None,
        tracker_config: Any = None,
        floor: float = PEAK_FLOOR,
        evidence_hold_s: float | str | None = "default",
    ) -> None:
        if isinstance(step, bool) or not isinstance(step, int | np.integer) or step < 1:
            raise ValueError(f"DOAStream: step must be a positive integer, got {step!r}")
        if tracker not in TRACKERS:
            raise ValueError(
                f"DOAStream: tracker must be one of {sorted(TRACKERS)}, got {tracker!r}"
            )
        reading = map_reading(tracker, method)
        observations = observations or reading.observations
        if tracker_config is None:
            tracker_config = reading.config
        if observations not in OBSERVATION_MODES:
            raise ValueError(
                f"DOAStream: observations must be one of {OBSERVATION_MODES}, got "
                f"{observations!r}"
            )
        if not (isinstance(floor, int | float) and np.isfinite(floor) and floor >= 0):
            raise ValueError(f"DOAStream: floor must be a finite number >= 0, got {floor!r}")
        self.localizer = make_localizer(method, array, grid, method_config)
        self.grid = self.localizer.grid
        self.step = int(step)
        self.observations = observations
        self.floor = float(floor)
        self.uniform_floor = reading.uniform_floor
        hop = self.localizer.stft_config.frame_period_s
        self.tracker = make_tracker(tracker, tracker_config, frame_period_s=self.step * hop)
        if evidence_hold_s == "default":
            evidence_hold_s = reading.evidence_hold_s
        elif evidence_hold_s is not None and not isinstance(evidence_hold_s, int | float):
            raise ValueError(f"DOAStream: evidence_hold_s must be seconds, None or 'default', "
                             f"got {evidence_hold_s!r}")
        #: None, or the gate of the maps the tracker reads
        self.gate = None if evidence_hold_s is None else EvidenceGate.for_hold(
            float(evidence_hold_s), hop)  # fmt: skip
        self._azimuths = np.array(self.grid.azimuth_values, dtype=float)
        self._azimuths.setflags(write=False)
        self.reset()

    @property
    def array(self) -> MicArray:
        return self.localizer.array

    @property
    def fs(self) -> int:
        """Sample rate the blocks must have (Hz)."""
        return self.localizer.fs

    @property
    def latency_s(self) -> float:
        """Worst-case delay from a sample's arrival to the tracker frame that includes it:
        one STFT window, the localizer's own lag (a smoothing map,
        :attr:`~avtrack.localize.base.Localizer.latency_frames`) and one tracker block."""
        cfg = self.localizer.stft_config
        lag = self.localizer.latency_frames + self.step - 1
        return (cfg.win_len + lag * cfg.hop) / cfg.fs

    def reset(self) -> None:
        """Start a new stream."""
        self.localizer.reset()
        self.tracker.reset()
        if self.gate is not None:
            self.gate.reset()
        # maps over azimuth waiting for their block
        self._held = np.zeros((0, self.grid.n_azimuths))
        self._held_frames = np.zeros(0, dtype=np.int64)
        self._held_times = np.zeros(0)
        self.samples_in = 0

    def push(self, block: np.ndarray) -> list[DOAStreamFrame]:
        """Feed the next samples; return the tracker frames they complete (maybe none).

        Parameters
        ----------
        block : ndarray (n_mics, n_samples)
            Real, finite samples at :attr:`fs`; any ``n_samples >= 0``.

        Returns
        -------
        list of DOAStreamFrame
            In time order.
        """
        heat = self.localizer.process(block)  # validates the block
        self.samples_in += int(np.shape(block)[1])
        return self._track(heat)

    def finish(self) -> list[DOAStreamFrame]:
        """End the stream: the tracker frames of the maps the localizer still held (a
        smoothing map's last :attr:`~avtrack.localize.base.Localizer.latency_frames`; none
        otherwise). A last part-filled tracker block is dropped, as in :meth:`push`.
        :meth:`reset` before the next stream."""
        return self._track(self.localizer.flush())

    def _track(self, heat: HeatMaps) -> list[DOAStreamFrame]:
        """The tracker frames that ``heat``'s frames complete."""
        if len(heat) == 0:
            return []
        w, _ = azimuth_profile(heat.weights, self.grid, self.localizer.profile_reduce)
        if self.gate is not None:
            w = self.gate.apply(w, self.localizer.evidence(heat.n_observations))
        w = np.concatenate([self._held, w]) if len(self._held) else w
        frames = np.concatenate([self._held_frames, heat.frames])
        times = np.concatenate([self._held_times, heat.time_s])
        n_done = (w.shape[0] // self.step) * self.step
        self._held = w[n_done:].copy()
        self._held_frames = frames[n_done:].copy()
        self._held_times = times[n_done:].copy()
        if n_done == 0:
            return []
        seq = heatmap_sequence(
            w[:n_done],
            self._azimuths,
            frames[:n_done],
            times[:n_done],
            self.step,
            self.observations,
            self.floor,
            self.uniform_floor,
        )
        rows = zip(seq.frames, seq.time_s, seq.azimuth_deg, seq.weight, strict=True)
        return [DOAStreamFrame(int(f), float(t), self.tracker.step(a, w)) for f, t, a, w in rows]
