"""``avtrack batch`` (alias ``bench``): run a manifest of recordings x commands x parameters,
one output folder per item and one results table."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from avtrack.cli import progress
from avtrack.cli.base import add_command, add_common, add_options_option
from avtrack.errors import InputError

EXAMPLES = """\
examples:
  avtrack batch recordings.yaml -o results/                 # serially, in this process
  avtrack batch recordings.csv -o results/ --workers 2      # local processes
  avtrack batch recordings.yaml -o results/ --scheduler local --workers 4   # a local Dask cluster
  avtrack batch recordings.yaml -o results/ --scheduler tcp://10.0.0.5:8786 # a Dask cluster
  avtrack batch smoke -o results/smoke                      # the built-in simulated manifest
  avtrack bench smoke -o results/smoke                      # bench: another name of batch

A manifest (YAML; paths relative to it):
  name: office
  items:
    - id: office-1                      # optional: names the output folder
      command: track-audio              # track-av, track-audio, localize, track-mot, track-phd
      audio: office-1/audio.wav
      array: respeaker4
      gt: office-1/doa.csv              # ground truth given: the item is scored
      params: {tracker: [gauss, vonmises]}   # every combination is run
    - command: track-av
      video: office-1/video.mp4
      audio: office-1/audio.wav
      array: respeaker4
      camera: office-1/camera.yaml
      detections: office-1/det.txt
    - command: track-mot
      inputs: [../shared/data/mot15/TUD-Campus, "walkout:0:10"]  # folders fill the paths;
      params: {birth_frames: [2, 3]}                             # NAME:SEED[:SECONDS] simulates

The same as CSV (one item per row; empty cells not given; ';' separates the values of a
parameter):
  id,command,audio,array,gt,param.tracker
  office-1,track-audio,office-1/audio.wav,respeaker4,office-1/doa.csv,gauss;vonmises

Path fields: video, audio, detections, appearance, array, camera, doa, config (a --config file
the parameters are added to), gt (MOT gt.txt or DOA CSV), gt_speech (RTTM). A parameter is the
command's option (tracker: gauss is --tracker gauss) or else a field of its --config
(birth_frames: 3; visual.birth_frames: 3).

Writes OUT/items/ID/ for each item (the command's outputs, the scores' JSON, and result.json
written last) and OUT/results.csv and OUT/results.md: one row per item, its scores when
ground truth is given, status ok or failed with the one-line error. A failing item does not
stop the others; the exit status is then 1. Run again with the same OUT, only the items not
complete are run (--force: all). The rows are the same whichever backend ran them (only the
'seconds' column differs). On a remote cluster, OUT and the inputs must be at the same paths
on every worker.

The --options YAML holds option values by name, e.g.:
  workers: 4
  scheduler: tcp://10.0.0.5:8786
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    p = add_command(
        subparsers,
        "batch",
        help="run a manifest of recordings x commands x parameters (serially, in processes or "
        "on a Dask cluster), scored, resumable",
        description="""\
Run a manifest of your recordings x commands (track-av, track-audio, localize, track-mot,
track-phd) x parameters; one output folder per item, one results table, scores where ground
truth is given. Resumes: items already complete are not run again.""",
        epilog=EXAMPLES,
        aliases=("bench",),
    )
    p.add_argument("manifest", metavar="MANIFEST",
                   help="a manifest file (.yaml or .csv), or a built-in: smoke")
    p.add_argument("-o", "--output", type=Path, required=True, metavar="DIR",
                   help="output folder (items/, results.csv, results.md); resumed when it "
                   "holds an earlier run")
    p.add_argument("--workers", type=int, default=1, metavar="N",
                   help="local processes (default 1: this process), or the workers of "
                   "--scheduler local")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run on a Dask cluster: its scheduler's address (tcp://host:port), or "
                   "'local' for a local cluster of --workers processes")
    add_common(p, run)
    add_options_option(p)


def run(args: argparse.Namespace) -> int:
    from avtrack.cli.batch.manifest import load_manifest
    from avtrack.cli.batch.runner import markdown_table, run_items, write_csv
    from avtrack.io.base import atomic_write

    if args.workers < 1:
        raise InputError(f"--workers must be >= 1, got {args.workers}")
    name, items = load_manifest(args.manifest)
    t0 = time.perf_counter()
    with progress.bar(len(items), name, "item", args.quiet) as bar:

        def advance(done: int, total: int) -> None:
            bar.update(done - bar.n)

        rows, reused = run_items(items, args.output, workers=args.workers,
                                 scheduler=args.scheduler, redo=args.force, progress=advance)
    write_csv(args.output / "results.csv", rows)
    with atomic_write(args.output / "results.md") as fh:
        fh.write(f"## {name}\n\n" + markdown_table(rows))
    failed = sum(r["status"] != "ok" for r in rows)
    if not args.quiet:
        print(markdown_table(rows, skip=("item", "seconds")), end="")
        print(f"{len(rows)} items ({reused} complete before, {failed} failed) in "
              f"{time.perf_counter() - t0:.1f} s -> {args.output}")
    return 1 if failed else 0
