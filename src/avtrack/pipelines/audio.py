"""Acoustic user paths on a recording: localize it, track its speakers.

Both read the recording in blocks (:class:`~avtrack.audio.recording.ArrayRecording`) and hand
their rows on as they are produced (a ``sink``: e.g. :meth:`avtrack.io.doa.DOACsvWriter.write`),
so memory stays flat in the recording's length; tracking goes through
:class:`~avtrack.stream.DOAStream`, so a file and a live stream give the same tracks.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from avtrack.audio.recording import FS, ArrayRecording
from avtrack.doa.base import frames_to_table
from avtrack.io.doa import DOATable
from avtrack.localize import HeatMaps, Localizer, peak_table
from avtrack.stream.audio import DOAStream

#: Receives each new chunk of rows, in frame order.
Sink = Callable[[DOATable], None]
#: Receives the seconds of audio processed so far.
Progress = Callable[[float], None]


@dataclass(frozen=True, eq=False)
class LocalizeRun:
    """What :func:`localize_recording` did.

    Attributes
    ----------
    n_frames : int
        STFT frames localized.
    frames_with_features : int
        Frames whose heat map came from at least one feature.
    n_active : int
        Peaks at or above the threshold.
    elapsed_s : float
        Seconds spent localizing (reading excluded).
    duration_s : float
        Length of the recording, seconds.
    table : DOATable or None
        Every peak written (when ``keep_table``).
    heat : HeatMaps or None
        Every frame's heat map (when ``keep_heat``: memory grows with the recording).
    """

    n_frames: int
    frames_with_features: int
    n_active: int
    elapsed_s: float
    duration_s: float
    table: DOATable | None
    heat: HeatMaps | None


def blocks_then_end(recording: ArrayRecording) -> Iterator[np.ndarray | None]:
    """The recording's blocks, then None: the end, where a localizer that reads each frame
    some frames late (:attr:`~avtrack.localize.base.Localizer.latency_frames`) gives the maps
    it still holds (``flush``)."""
    yield from recording.blocks()
    yield None


def localize_recording(
    recording: ArrayRecording,
    localizer: Localizer,
    threshold: float,
    *,
    floor: float | None = None,
    max_peaks: int | None = None,
    sink: Sink | None = None,
    keep_table: bool = False,
    keep_heat: bool = False,
    progress: Progress | None = None,
) -> LocalizeRun:
    """Heat maps of every 8 ms frame of ``recording`` and their peaks
    (:func:`~avtrack.localize.peak_table`), block by block.

    Parameters
    ----------
    recording : ArrayRecording
    localizer : Localizer
        Reset first; its array must be the recording's.
    threshold, floor, max_peaks
        As :func:`~avtrack.localize.peak_table`.
    sink : callable, optional
        Given each block's peaks (a :class:`DOATable`).
    keep_table, keep_heat : bool
        Also return every peak / every heat map.
    progress : callable, optional
        Given the seconds processed after each block.
    """
    localizer.reset()
    tables: list[DOATable] = []
    heats: list[HeatMaps] = []
    n_frames = with_features = n_active = 0
    elapsed = 0.0
    done = 0
    for block in blocks_then_end(recording):
        t0 = time.perf_counter()
        heat = localizer.flush() if block is None else localizer.process(block)
        table = peak_table(heat, localizer.grid, threshold, floor, max_peaks,
                           localizer.profile_reduce)
        elapsed += time.perf_counter() - t0
        n_frames += len(heat)
        with_features += int(np.count_nonzero(heat.n_observations > 0))
        n_active += int(table.active.sum())
        if sink is not None:
            sink(table)
        if keep_table:
            tables.append(table)
        if keep_heat:
            heats.append(heat)
        if block is None:  # the maps a smoothing localizer still held
            break
        done += block.shape[1]
        if progress is not None:
            progress(done / FS)
    return LocalizeRun(
        n_frames, with_features, n_active, elapsed, recording.info.duration_s,
        DOATable.concatenate(tables) if keep_table else None,
        HeatMaps.concatenate(heats, localizer.grid.size) if keep_heat else None,
    )


@dataclass(frozen=True, eq=False)
class TrackRun:
    """What :func:`track_recording` did.

    Attributes
    ----------
    n_frames : int
        Tracker frames (32 ms by default).
    track_ids : frozenset of int
        Every track identity reported.
    n_active : int
        Speaking estimates (rows with ``active``).
    elapsed_s : float
        Seconds spent localizing and tracking (reading excluded).
    duration_s : float
        Length of the recording, seconds.
    frame_times : ndarray (n_frames,)
        Time of each tracker frame, seconds.
    table : DOATable or None
        Every row written (when ``keep_table``).
    """

    n_frames: int
    track_ids: frozenset[int]
    n_active: int
    elapsed_s: float
    duration_s: float
    frame_times: np.ndarray
    table: DOATable | None


def track_recording(
    recording: ArrayRecording,
    stream: DOAStream,
    *,
    sink: Sink | None = None,
    keep_table: bool = False,
    progress: Progress | None = None,
) -> TrackRun:
    """Localize and track the speakers of ``recording`` with ``stream`` (reset first): one row
    per alive track per tracker frame (:func:`~avtrack.doa.base.frames_to_table`).

    Parameters
    ----------
    recording : ArrayRecording
    stream : DOAStream
        Localizer, grid, observations and tracker.
    sink : callable, optional
        Given each block's rows (a :class:`DOATable`).
    keep_table : bool
        Also return every row.
    progress : callable, optional
        Given the seconds processed after each block.
    """
    stream.reset()
    tables: list[DOATable] = []
    ids: set[int] = set()
    times: list[np.ndarray] = []
    n_active = 0
    elapsed = 0.0
    done = 0
    for block in blocks_then_end(recording):
        t0 = time.perf_counter()
        outs = stream.finish() if block is None else stream.push(block)
        elapsed += time.perf_counter() - t0
        frames = np.array([o.frame for o in outs], dtype=np.int64)
        t = np.array([o.time_s for o in outs], dtype=float)
        table = frames_to_table([o.tracks for o in outs], frames, t)
        ids.update(table.ids.tolist())
        n_active += int(table.active.sum())
        times.append(t)
        if sink is not None:
            sink(table)
        if keep_table:
            tables.append(table)
        if block is None:  # the frames a smoothing localizer still held
            break
        done += block.shape[1]
        if progress is not None:
            progress(done / FS)
    frame_times = np.concatenate(times) if times else np.zeros(0)
    return TrackRun(
        frame_times.size, frozenset(ids), n_active, elapsed, recording.info.duration_s,
        frame_times, DOATable.concatenate(tables) if keep_table else None,
    )
