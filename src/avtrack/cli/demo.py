"""``avtrack demo``: the one-command tour.

By default: simulate a meeting (3 people, a 4-microphone NAO-like array and a camera), track
and diarize it with the audio-visual tracker, localize the talkers, print MOTA, IDF1, DER and
DOA MAE and write a report folder with ``index.html``. It needs no data: without
``../shared/data`` the talkers speak synthetic speech. ``--mot`` instead tracks the real MOT15
TUD-Campus detections of the shared data folder.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from avtrack.cli import progress
from avtrack.cli.base import add_command, add_common, add_options_option, write_json
from avtrack.errors import InputError
from avtrack.io.base import atomic_write
from avtrack.io.datasets import find_shared_data
from avtrack.io.mot import read_mot, write_mot
from avtrack.metrics.mot import evaluate_mot, format_table
from avtrack.visual.ovbt import track_mot

if TYPE_CHECKING:
    from avtrack.pipelines.demo import DemoRun
    from avtrack.pipelines.mot import Stage

EXAMPLES = """\
examples:
  avtrack demo                  # simulated meeting; report in ./avtrack-demo/index.html
  avtrack demo -o /tmp/demo --seed 3 --duration 30 --people 4
  avtrack demo --options demo.yaml --seed 5   # the file's settings, another seed
  avtrack demo --mot            # the real MOT15 TUD-Campus sequence (needs ../shared/data)
  AVTRACK_SHARED_DATA=/data/shared/data avtrack demo --mot

The --options YAML holds option values by name, e.g.:
  output: runs/demo
  seed: 3
  duration: 30
  people: 2
"""

SEQUENCE = "TUD-Campus"
IMAGE_SIZE = (640, 480)  # MOT15 TUD-Campus


def register(subparsers: argparse._SubParsersAction) -> None:
    p = add_command(
        subparsers,
        "demo",
        help="simulate a meeting, track and diarize it, print the scores, write a report",
        description="""\
Simulate a meeting (3 people, NAO-like 4-microphone array, camera), track and diarize it with
the audio-visual VEM tracker, localize the talkers, print MOTA, IDF1, DER and DOA MAE,
and write DIR/index.html. With --mot: track the real MOT15 TUD-Campus detections
(../shared/data or $AVTRACK_SHARED_DATA) with the visual tracker instead.""",
        epilog=EXAMPLES)
    p.add_argument("-o", "--output", type=Path, default=Path("avtrack-demo"), metavar="DIR",
                   help="output folder (default: %(default)s)")
    p.add_argument("--mot", action="store_true", help="the MOT15 TUD-Campus visual demo")
    p.add_argument("--seed", type=int, default=0, metavar="S", help="scene seed (default 0)")
    p.add_argument("--duration", type=float, default=20.0, metavar="SECONDS",
                   help="scene length (default 20)")
    p.add_argument("--people", type=int, default=3, choices=(2, 3, 4), metavar="N",
                   help="people in the meeting: 2, 3 or 4 (default 3)")
    add_common(p, run)
    add_options_option(p)


def run(args: argparse.Namespace) -> int:
    if not args.mot:
        return run_av(args)
    seq = find_shared_data() / "mot15" / SEQUENCE
    dets = read_mot(seq / "det" / "det.txt", kind="det")
    gt = read_mot(seq / "gt" / "gt.txt", kind="gt")
    t0 = time.perf_counter()
    with progress.activity(f"tracking {gt.n_frames} frames", args.quiet):
        res = track_mot(dets, image_size=IMAGE_SIZE, n_frames=gt.n_frames)
    elapsed = time.perf_counter() - t0
    scores = evaluate_mot(gt, res, benchmark="MOT15")
    out = Path(args.output)
    write_mot(out / f"{SEQUENCE}.txt", res)
    with atomic_write(out / "scores.json") as fh:
        json.dump({"sequence": SEQUENCE, "scores": scores.as_dict(),
                   "frames_per_second": gt.n_frames / max(elapsed, 1e-9)}, fh, indent=2)
        fh.write("\n")
    if not args.quiet:
        print(f"avtrack demo: visual VEM tracking of MOT15 {SEQUENCE} ({gt.n_frames} frames, "
              f"{len(dets)} detections) at {gt.n_frames / max(elapsed, 1e-9):.0f} frames/s")
        print(format_table({"avtrack (OVBT)": scores}))
        print(f"results: {out / (SEQUENCE + '.txt')}, {out / 'scores.json'}")
    return 0


# ------------------------------------------------------------------ the simulated meeting

#: The last step's description, after the pipeline's stages.
REPORT_STEP = "writing the report"


def run_av(args: argparse.Namespace) -> int:
    """The simulated meeting (:func:`avtrack.pipelines.demo.run_demo_meeting`): its outputs,
    scores and report."""
    from avtrack.io.mot import write_mot
    from avtrack.io.rttm import write_rttm
    from avtrack.pipelines.demo import STAGES, run_demo_meeting

    out = _check_arguments(args)
    n_steps = len(STAGES) + 1
    t_start = time.perf_counter()
    done = run_demo_meeting(args.seed, args.duration, args.people, out,
                            stage=_steps(n_steps, args.quiet))
    res = done.persons
    write_mot(out / "tracks.txt", res.tracks)
    write_rttm(out / "speech.rttm", res.speech)
    with atomic_write(out / "persons.csv") as fh:
        fh.write(res.persons.to_csv())
    with _steps(n_steps, args.quiet, first=n_steps - 1)(REPORT_STEP):
        _write_report(out, done)
    if not args.quiet:
        print(f"avtrack demo: {len(done.scene.ids)} people, {args.duration:g} s meeting, "
              f"done in {time.perf_counter() - t_start:.0f} s")  # fmt: skip
        for k, v in done.scores.items():
            print(f"  {k:<27} {v:8.2f}" if isinstance(v, float) else f"  {k:<27} {v:8d}")
        print(f"report: {out / 'index.html'}")
    return 0


def _steps(n_steps: int, quiet: bool, first: int = 0) -> Stage:
    """The pipeline's ``stage``: a numbered line per step (``[##...] 2/6 localizing the
    talkers ...``) and an elapsed-time bar while it runs."""
    count = [first]

    @contextmanager
    def stage(desc: str) -> Iterator[None]:
        i = count[0]
        count[0] += 1
        if not quiet:
            bar = "#" * (i + 1) + "." * (n_steps - i - 1)
            print(f"[{bar}] {i + 1}/{n_steps} {desc} ...", file=sys.stderr, flush=True)
        with progress.activity(desc, quiet):
            yield

    return stage


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


def _figures(done: DemoRun) -> dict:
    """The report's figures by title."""
    from avtrack.av.persons_scene import scene_geometry
    from avtrack.viz import report

    cam = json.loads((done.scene_dir / "camera.json").read_text())
    res = done.persons
    return {
        "Head tracks (image x over time)": report.trajectories_figure(
            done.gt, res.tracks, done.scene.scenario["fps"], int(cam["width"])
        ),
        "DOA heat map (DPRTF-EG), speaking ground truth (white), von Mises DOA tracks": (
            report.heatmap_figure(
                done.heat.weights, done.heat.time_s, done.localizer.grid.azimuth_deg,
                done.truth, done.doa_tracks, persons=res.persons,
            )
        ),
        "Every person's direction from the array, in view or not (thick: speaking; grey / "
        "cyan: ground truth / speaking; shaded: the camera's view)": report.persons_figure(
            res.persons, done.truth, scene_geometry(done.inputs).view_azimuths()
        ),
        "Who speaks when: ground truth and diarization": report.timeline_figure(
            done.reference, res.speech),
    }


def _write_report(out: Path, done: DemoRun) -> None:
    """Write the overlay videos, ``index.html`` and ``scores.json`` into ``out``."""
    from avtrack.viz import report
    from avtrack.viz.video import render_scene_video

    scene = done.scene
    notes = [
        f"scene: {scene.scenario['name']}, seed {scene.scenario['seed']}, "
        f"{scene.scenario['duration']:g} s, {len(scene.ids)} people, array {done.array.name}, "
        f"speech {scene.scenario['speech']['utterances']}",
        "files: scene/ (the simulated scene directory), tracks.txt (MOTChallenge), "
        "persons.csv (every person every frame: direction, pixel, in view, speaking), "
        "speech.rttm (diarization), scores.json",
    ]
    figures = _figures(done)
    videos = [render_scene_video(done.inputs, done.persons, out / f"tracks.{ext}",
                                 title="avtrack demo") for ext in ("webm", "mp4")]
    notes.append("tracks.webm / tracks.mp4: the tracks, identities and speaking status over "
                 "the rendered camera frames (thin grey: ground truth); persons tracked without "
                 "a box: a ring at their direction, or an arrow at the image edge with their "
                 "azimuth when out of the image")  # fmt: skip
    report.write_report(out / "index.html", "avtrack demo: a simulated meeting", done.scores,
                        figures, notes, video=videos[0], video_links=videos)  # fmt: skip
    write_json(out / "scores.json", {k: (None if isinstance(v, float) and np.isnan(v) else v)
                                      for k, v in done.scores.items()})
