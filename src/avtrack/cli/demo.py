"""``avtrack demo``: the one-command tour.

Until the scene simulator exists, the demo tracks the real MOT15 TUD-Campus detections in the
shared data folder and scores the result against the ground truth.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from avtrack.cli.base import HelpFormatter, add_common
from avtrack.io.base import atomic_write
from avtrack.io.datasets import find_shared_data
from avtrack.io.mot import read_mot, write_mot
from avtrack.metrics.mot import evaluate_mot, format_table
from avtrack.tracking.ovbt import track_mot

EXAMPLES = """\
examples:
  avtrack demo                  # results in ./avtrack-demo/
  avtrack demo -o /tmp/demo     # elsewhere
  AVTRACK_SHARED_DATA=/data/shared/data avtrack demo
"""

SEQUENCE = "TUD-Campus"
IMAGE_SIZE = (640, 480)  # MOT15 TUD-Campus


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "demo", help="track a real sequence (MOT15 TUD-Campus) and print the scores",
        description=("Track the public detections of MOT15 TUD-Campus with the visual VEM "
                     "tracker and score\nthe result with TrackEval (MOTA, IDF1, HOTA ...). The "
                     "data come from the shared data\nfolder (../shared/data, or "
                     "$AVTRACK_SHARED_DATA)."),
        epilog=EXAMPLES, formatter_class=HelpFormatter)
    p.add_argument("-o", "--output", type=Path, default=Path("avtrack-demo"), metavar="DIR",
                   help="output folder (default: %(default)s)")
    add_common(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    seq = find_shared_data() / "mot15" / SEQUENCE
    dets = read_mot(seq / "det" / "det.txt", kind="det")
    gt = read_mot(seq / "gt" / "gt.txt", kind="gt")
    t0 = time.perf_counter()
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
