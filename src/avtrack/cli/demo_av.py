"""The audio-visual part of ``avtrack demo`` (see :mod:`avtrack.cli.demo`)."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from avtrack.cli import progress
from avtrack.cli.base import write_json
from avtrack.errors import InputError
from avtrack.io.base import atomic_write

STEPS = (
    "simulating the meeting",
    "localizing the talkers",
    "tracking and diarizing",
    "tracking the talkers from audio alone",
    "scoring and writing the report",
)


def _progress(step: int, quiet: bool) -> float:
    if not quiet:
        bar = "#" * (step + 1) + "." * (len(STEPS) - step - 1)
        print(f"[{bar}] {step + 1}/{len(STEPS)} {STEPS[step]} ...", file=sys.stderr, flush=True)
    return time.perf_counter()


def run_av(args: argparse.Namespace) -> int:
    from avtrack.audio.arrays import load_array
    from avtrack.av.persons_scene import track_scene_persons
    from avtrack.io.mot import write_mot
    from avtrack.io.rttm import write_rttm
    from avtrack.io.scene import load_scene
    from avtrack.simulate.library import demo_scenario
    from avtrack.simulate.scene import simulate_scene, write_scene

    out = _check_arguments(args)
    t_start = _progress(0, args.quiet)
    with progress.activity("rendering the room acoustics", args.quiet):
        scene = simulate_scene(demo_scenario(args.seed, args.duration, args.people))
    scene_dir = write_scene(scene, out / "scene")

    t0 = _progress(1, args.quiet)
    inputs = load_scene(scene_dir)
    array = load_array(scene_dir / "array.json")
    loc, heat, peaks, span = _localize(array, scene.audio, inputs, args.quiet)

    _progress(2, args.quiet)
    with progress.activity(f"tracking {inputs.n_frames} frames", args.quiet):
        res = track_scene_persons(inputs, peaks=peaks, span=span, heat=heat)
    t_track = time.perf_counter() - t0
    write_mot(out / "tracks.txt", res.tracks)
    write_rttm(out / "speech.rttm", res.speech)
    with atomic_write(out / "persons.csv") as fh:
        fh.write(res.persons.to_csv())

    _progress(3, args.quiet)
    doa, doa_tracks = _track_doa(loc, heat)

    _progress(4, args.quiet)
    gt, ref, truth, scores = _scores(scene_dir, res, doa, t_track / args.duration)
    figures = _figures(scene, scene_dir, inputs, res, loc, heat, doa_tracks, gt, ref, truth)
    notes = [
        f"scene: {scene.scenario['name']}, seed {args.seed}, {args.duration:g} s, "
        f"{len(scene.ids)} people, array {array.name}, speech "
        f"{scene.scenario['speech']['utterances']}",
        "files: scene/ (the simulated scene directory), tracks.txt (MOTChallenge), "
        "persons.csv (every person every frame: direction, pixel, in view, speaking), "
        "speech.rttm (diarization), scores.json",
    ]
    _write_report(out, inputs, res, scores, figures, notes, args.quiet)
    if not args.quiet:
        print(f"avtrack demo: {len(scene.ids)} people, {args.duration:g} s meeting, "
              f"done in {time.perf_counter() - t_start:.0f} s")  # fmt: skip
        for k, v in scores.items():
            print(f"  {k:<27} {v:8.2f}" if isinstance(v, float) else f"  {k:<27} {v:8d}")
        print(f"report: {out / 'index.html'}")
    return 0


def _check_arguments(args: argparse.Namespace) -> Path:
    """The output directory, after checking ``--duration``, ``--seed`` and ``-o``."""
    if args.duration <= 0 or args.duration > 600:
        raise InputError(f"--duration must be in (0, 600] seconds, got {args.duration}")
    if args.seed < 0:
        raise InputError(f"--seed must be >= 0, got {args.seed}")
    out = args.output
    if out.exists() and not out.is_dir():
        raise InputError("output exists and is not a directory", out)
    return out


def _localize(array, audio: np.ndarray, inputs, quiet: bool):
    """The persons' localizer, its heat maps of ``audio``, their peaks on the scene's frames
    and the azimuth span of the localizer's grid in degrees."""
    from avtrack.av.persons_scene import (
        PERSONS_LOCALIZER,
        audio_peak_floor,
        audio_peaks,
        localizer_grid,
    )
    from avtrack.localize import make_localizer

    grid = localizer_grid(array)
    loc = make_localizer(PERSONS_LOCALIZER, array, grid)
    with progress.activity(f"localizing {audio.shape[1] / loc.fs:.1f} s", quiet):
        heat = loc.run(audio)
    peaks = audio_peaks(heat.weights, heat.time_s, grid, inputs.fps, inputs.n_frames,
                        floor=audio_peak_floor(PERSONS_LOCALIZER))
    span = 360.0 if grid.circular else float(np.ptp(grid.azimuth_values) + 5.0)
    return loc, heat, peaks, span


def _track_doa(loc, heat):
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


def _scores(scene_dir: Path, res, doa, real_time_factor: float):
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
    scores = {
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


def _figures(scene, scene_dir: Path, inputs, res, loc, heat, doa_tracks, gt, ref, truth):
    """The report's figures by title."""
    from avtrack.av.persons_scene import scene_geometry
    from avtrack.viz import report

    cam = json.loads((scene_dir / "camera.json").read_text())
    return {
        "Head tracks (image x over time)": report.trajectories_figure(
            gt, res.tracks, scene.scenario["fps"], int(cam["width"])
        ),
        "DOA heat map (DPRTF-EG), speaking ground truth (white), von Mises DOA tracks": (
            report.heatmap_figure(
                heat.weights, heat.time_s, loc.grid.azimuth_deg, truth, doa_tracks,
                persons=res.persons,
            )
        ),
        "Every person's direction from the array, in view or not (thick: speaking; grey / "
        "cyan: ground truth / speaking; shaded: the camera's view)": report.persons_figure(
            res.persons, truth, scene_geometry(inputs).view_azimuths()
        ),
        "Who speaks when: ground truth and diarization": report.timeline_figure(ref, res.speech),
    }


def _write_report(
    out: Path, inputs, res, scores: dict, figures: dict, notes: list[str], quiet: bool
) -> None:
    """Write the overlay videos, ``index.html`` and ``scores.json`` into ``out``."""
    from avtrack.viz import report
    from avtrack.viz.video import render_scene_video

    with progress.activity("rendering the video overlay", quiet):
        videos = [render_scene_video(inputs, res, out / f"tracks.{ext}", title="avtrack demo")
                  for ext in ("webm", "mp4")]  # fmt: skip
    notes.append("tracks.webm / tracks.mp4: the tracks, identities and speaking status over "
                 "the rendered camera frames (thin grey: ground truth); persons tracked without "
                 "a box: a ring at their direction, or an arrow at the image edge with their "
                 "azimuth when out of the image")  # fmt: skip
    report.write_report(out / "index.html", "avtrack demo: a simulated meeting", scores,
                        figures, notes, video=videos[0], video_links=videos)  # fmt: skip
    write_json(out / "scores.json", {k: (None if isinstance(v, float) and np.isnan(v) else v)
                                      for k, v in scores.items()})
