"""``avtrack demo``'s meeting: simulated, tracked and diarized, localized, and scored.

:func:`run_demo_meeting` writes the simulated scene directory, tracks and diarizes its persons
in the array's direction space (:func:`~avtrack.av.persons_scene.track_scene_persons`, the
speaker turns refined by the voice activity detector as ``track-av`` does), tracks the talkers
from the same heat maps with the von Mises DOA tracker, and scores both against the scene's
ground truth. The command line writes the outputs, the figures and the report.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from avtrack.audio.arrays import MicArray
from avtrack.av.persons_scene import PersonsResult
from avtrack.io.doa import DOATable
from avtrack.io.mot import MOTData
from avtrack.io.rttm import RTTMSegment
from avtrack.io.scene import SceneInputs
from avtrack.localize.base import HeatMaps, Localizer
from avtrack.pipelines.mot import Stage, no_stage
from avtrack.simulate.scene import Scene

#: What each stage of :func:`run_demo_meeting` does, in order (the ``stage`` descriptions).
STAGES = (
    "simulating the meeting",
    "localizing the talkers",
    "tracking and diarizing",
    "tracking the talkers from audio alone",
    "scoring",
)


@dataclass(frozen=True, eq=False)
class DemoRun:
    """:func:`run_demo_meeting`'s result.

    Attributes
    ----------
    scene : Scene
        The simulated meeting.
    scene_dir : Path
        Its scene directory.
    inputs : SceneInputs
        The scene directory as read back.
    array : MicArray
    persons : PersonsResult
        Persons tracked and diarized.
    localizer : Localizer
        The persons' localizer (:data:`~avtrack.av.persons_scene.PERSONS_LOCALIZER`).
    heat : HeatMaps
        Its heat maps of the recording.
    doa : DOATable
        Their frame-wise peaks.
    doa_tracks : DOATable
        The von Mises tracker's tracks of the talkers.
    gt : MOTData
    reference : list of RTTMSegment
    truth : DOATable
        Ground truth: head boxes, speaker turns and talkers' directions.
    scores : dict
        MOTA, IDF1, HOTA, IDSW, DER %, DOA MAE (deg), DOA MD %, DOA FA % and the tracking's
        real-time factor.
    """

    scene: Scene
    scene_dir: Path
    inputs: SceneInputs
    array: MicArray
    persons: PersonsResult
    localizer: Localizer
    heat: HeatMaps
    doa: DOATable
    doa_tracks: DOATable
    gt: MOTData
    reference: list[RTTMSegment]
    truth: DOATable
    scores: dict[str, float | int]


def run_demo_meeting(
    seed: int, duration: float, people: int, out: Path, stage: Stage = no_stage
) -> DemoRun:
    """Simulate ``avtrack demo``'s meeting into ``out / "scene"``, track, diarize, localize
    and score it (see the module docstring). ``stage`` is opened around each of
    :data:`STAGES`."""
    from avtrack.audio.arrays import load_array
    from avtrack.av.persons_scene import track_scene_persons
    from avtrack.io.scene import load_scene
    from avtrack.simulate.library import demo_scenario
    from avtrack.simulate.scene import simulate_scene, write_scene

    with stage(STAGES[0]):
        scene = simulate_scene(demo_scenario(seed, duration, people))
        scene_dir = write_scene(scene, out / "scene")
    t0 = time.perf_counter()
    with stage(STAGES[1]):
        inputs = load_scene(scene_dir)
        array = load_array(scene_dir / "array.json")
        loc, heat, peaks, span = _localize(array, scene.audio, inputs)
    with stage(STAGES[2]):
        res = track_scene_persons(inputs, peaks=peaks, span=span, heat=heat)
    real_time_factor = (time.perf_counter() - t0) / duration
    with stage(STAGES[3]):
        doa, doa_tracks = _track_doa(loc, heat)
    with stage(STAGES[4]):
        gt, ref, truth, scores = _scores(scene_dir, res, doa, real_time_factor)
    return DemoRun(scene, scene_dir, inputs, array, res, loc, heat, doa, doa_tracks, gt, ref,
                   truth, scores)


def _localize(array: MicArray, audio: np.ndarray, inputs: SceneInputs):
    """The persons' localizer, its heat maps of ``audio``, their peaks on the scene's frames
    and the azimuth span of the localizer's grid in degrees."""
    from avtrack.av.persons_scene import (
        PERSONS_LOCALIZER,
        audio_peak_floor,
        audio_peaks,
        grid_span,
        localizer_grid,
    )
    from avtrack.localize import make_localizer

    grid = localizer_grid(array)
    loc = make_localizer(PERSONS_LOCALIZER, array, grid)
    heat = loc.run(audio)
    peaks = audio_peaks(heat.weights, heat.time_s, grid, inputs.fps, inputs.n_frames,
                        floor=audio_peak_floor(PERSONS_LOCALIZER))
    return loc, heat, peaks, grid_span(grid)


def _track_doa(loc: Localizer, heat: HeatMaps) -> tuple[DOATable, DOATable]:
    """The frame-wise DOA estimates of the heat maps and the von Mises tracks of the talkers."""
    from avtrack.av.persons_scene import PERSONS_LOCALIZER
    from avtrack.doa.base import gate_maps, heatmap_sequence, make_tracker, map_reading
    from avtrack.localize import peak_table

    doa = peak_table(heat, loc.grid, loc.peak_threshold)
    reading = map_reading("vonmises", PERSONS_LOCALIZER)  # that localizer's maps
    weights = gate_maps(heat.weights, loc.evidence(heat.n_observations),
                        reading.evidence_hold_s, loc.stft_config.frame_period_s)
    seq = heatmap_sequence(weights, loc.grid.azimuth_deg, heat.frames, heat.time_s, 4,
                           reading.observations, uniform_floor=reading.uniform_floor)  # fmt: skip
    doa_tracks = make_tracker(
        "vonmises", reading.config, frame_period_s=4 * loc.stft_config.frame_period_s
    ).run(seq)
    return doa, doa_tracks


def _scores(scene_dir: Path, res: PersonsResult, doa: DOATable, real_time_factor: float):
    """The ground truth (tracks, speech turns, DOAs) and the demo's scores against it."""
    from avtrack.io.doa import read_doa_csv
    from avtrack.io.mot import read_mot
    from avtrack.io.rttm import read_rttm
    from avtrack.metrics.der import diarization_error_rate
    from avtrack.metrics.doa import evaluate_doa
    from avtrack.metrics.mot import evaluate_mot

    gt = read_mot(scene_dir / "gt" / "gt.txt", "gt")
    mot = evaluate_mot(gt, res.tracks, benchmark="MOT17")
    ref = read_rttm(scene_dir / "gt" / "speech.rttm")
    der = diarization_error_rate(ref, res.speech)
    truth = read_doa_csv(scene_dir / "gt" / "doa.csv")
    doa_scores = evaluate_doa(doa, truth)
    scores: dict[str, float | int] = {
        "MOTA": mot.MOTA,
        "IDF1": mot.IDF1,
        "HOTA": mot.HOTA,
        "IDSW": int(mot.IDSW),
        "DER %": 100.0 * der.rate,
        "DOA MAE (deg)": doa_scores.mae,
        "DOA MD %": 100.0 * doa_scores.md_rate,
        "DOA FA %": 100.0 * doa_scores.fa_rate,
        "real-time factor": real_time_factor,
    }
    return gt, ref, truth, scores
