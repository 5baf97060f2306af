"""Audio-visual SMC-PHD tracking of an AV16.3 sequence (Liu et al., "Labelled non-zero
particle flow for SMC-PHD filtering"), scored as the authors' released evaluation scores it.

The audio measurements are the sequence's DOAs (``Z_doa``) projected into the image as lines;
the visual ones are its face detections, detections synthesised from the ground truth, or
mouths found in its video (:func:`~avtrack.phd.likelihood.av163_visual`,
:func:`~avtrack.phd.likelihood.video_measurements`). The scores are OSPA of the position sets
and OSPA-T of the labelled tracks (:mod:`avtrack.phd.scoring`).
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from avtrack.io.av163 import AV163Sequence, load_av163
from avtrack.phd import PHD_FILTERS, PHDConfig, PHDFilter, PHDResult
from avtrack.phd.likelihood import (
    add_clutter,
    av163_frames,
    av163_truth,
    av163_visual,
    video_measurements,
)
from avtrack.phd.scoring import ospa_of, ospa_t_of

#: Opened around the filter's run, given the filter and the number of frames (e.g. a progress
#: bar that counts the filter's ``step`` calls).
Watch = Callable[[PHDFilter, int], AbstractContextManager[object]]


def no_watch(tracker: PHDFilter, n_frames: int) -> AbstractContextManager[object]:
    """The default :data:`Watch`: shows nothing."""
    return contextlib.nullcontext()


@dataclass(frozen=True, eq=False)
class PHDRun:
    """What :func:`track_av163` did.

    Attributes
    ----------
    sequence : AV163Sequence
        The sequence and camera read.
    result : PHDResult
        The filter's estimates of every frame, ESS, resamplings and time.
    rows : ndarray (K, 4)
        ``frame, id, x, y`` of every estimate (:meth:`PHDResult.rows`, the sequence's frame
        numbers).
    truth : list of T ndarray (m_t, 2)
        Ground-truth image points of the persons present on each frame.
    ospa : ndarray (T, 3)
        Per-frame OSPA: distance, localisation, cardinality (pixels;
        :data:`~avtrack.phd.scoring.OSPA_ORDER`, :data:`~avtrack.phd.scoring.OSPA_CUTOFF`).
    ospa_t : float
        OSPA-T of the labelled tracks (pixels; :data:`~avtrack.phd.scoring.OSPA_T_CUTOFF`,
        :data:`~avtrack.phd.scoring.OSPA_T_LABEL_PENALTY`).
    visual_source : str
        The visual measurements used, in words (``"faces"``, ``"synthetic"``, ``"video
        foreground heads"``, with ``" + R false alarms/frame"`` under clutter).
    """

    sequence: AV163Sequence
    result: PHDResult
    rows: np.ndarray
    truth: list[np.ndarray]
    ospa: np.ndarray
    ospa_t: float
    visual_source: str


def track_av163(
    folder: Path,
    seq: int,
    cam: int,
    filter_name: str,
    config: PHDConfig,
    *,
    seed: int = 0,
    visual: str = "auto",
    video: Path | None = None,
    clutter_rate: float = 0.0,
    watch: Watch = no_watch,
) -> PHDRun:
    """Track the speakers of AV16.3 sequence ``seq`` seen by camera ``cam`` with a registered
    SMC-PHD filter, and score the tracks.

    Parameters
    ----------
    folder : Path
        Folder of the AV16.3 MAT files (:func:`~avtrack.io.av163.load_av163`).
    seq, cam : int
        Sequence number and camera (1, 2 or 3).
    filter_name : str
        A filter of :data:`~avtrack.phd.PHD_FILTERS` (``"lpf"``, ``"npf"``).
    config : PHDConfig
    seed : int
        Seeds the filter and, with ``seq`` and ``cam``, the synthetic detections and clutter.
    visual : {"auto", "faces", "synthetic"}
        The visual measurements without a video (:func:`~avtrack.phd.likelihood.av163_visual`).
    video : Path, optional
        The sequence's video: visual measurements from its frames instead (``visual`` must be
        ``"auto"``).
    clutter_rate : float
        Stress test: this many synthetic visual false alarms and DOA outliers per frame each
        (Poisson); the filter's ``clutter_visual`` and ``clutter_audio`` grow by as much.
    watch : callable, optional
        Opened around the filter's run (see :data:`Watch`).
    """
    if filter_name not in PHD_FILTERS:
        raise ValueError(f"filter_name must be one of {sorted(PHD_FILTERS)}, got "
                         f"{filter_name!r}")
    sequence = load_av163(folder, seq, cam)
    rng = np.random.default_rng([seed, seq, cam])
    if video is not None:
        if visual != "auto":
            raise ValueError(f"visual={visual!r} and a video both choose the visual "
                             "measurements; give one")
        from avtrack.av.av163 import av163_detector  # (the video path's own imports)

        points = video_measurements(video, sequence, av163_detector(sequence))
        used = "video foreground heads"
    else:
        points, used = av163_visual(folder, sequence, visual, rng)
    doa = list(sequence.z_doa)
    if clutter_rate > 0:
        points, doa = add_clutter(points, doa, clutter_rate, clutter_rate,
                                  np.random.default_rng([seed, seq, cam, 7]), config.image_size)
        config = dataclasses.replace(config, clutter_visual=config.clutter_visual + clutter_rate,
                                     clutter_audio=config.clutter_audio + clutter_rate)
        used += f" + {clutter_rate:g} false alarms/frame"
    frames = av163_frames(sequence, points, config.sigma_audio, config.gate, doa_deg=doa)
    tracker = PHD_FILTERS[filter_name](config, seed=seed)
    with watch(tracker, len(frames)):
        result = tracker.run(frames)
    truth = av163_truth(sequence)
    return PHDRun(sequence, result, result.rows(sequence.frames), truth,
                  ospa_of(result, truth), ospa_t_of(result, sequence), used)
