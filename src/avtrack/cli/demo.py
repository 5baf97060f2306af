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
import time
from pathlib import Path

from avtrack.cli import progress
from avtrack.cli.base import add_command, add_common, add_options_option
from avtrack.io.base import atomic_write
from avtrack.io.datasets import find_shared_data
from avtrack.io.mot import read_mot, write_mot
from avtrack.metrics.mot import evaluate_mot, format_table
from avtrack.visual.ovbt import track_mot

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
        from avtrack.cli.demo_av import run_av

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
