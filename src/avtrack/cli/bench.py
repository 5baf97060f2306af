"""``avtrack bench``: run a suite of scenes x tasks x parameters and write one results table."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from avtrack.cli import progress
from avtrack.cli.base import add_command, add_common, add_config_option
from avtrack.errors import InputError

EXAMPLES = """\
examples:
  avtrack bench smoke -o results/smoke                  # built-in suite, this process
  avtrack bench suite.yaml -o results/ --workers 2      # local processes
  avtrack bench suite.yaml -o results/ --scheduler tcp://10.0.0.5:8786   # a Dask cluster
  avtrack bench suite.yaml -o results/ --config bench.yaml   # workers / scheduler from a file

A suite file:
  name: tud-and-walkout
  items:
    - task: track-mot                       # tasks: track-mot, localize
      inputs: [../shared/data/mot15/TUD-Campus, "walkout:0", "walkout:1:10"]
      params: {birth_frames: [2, 3]}        # every combination is run
    - task: localize
      inputs: ["locata-like:0"]             # NAME:SEED[:SECONDS] = a simulated scene
      params: {method: [dprtf-eg, srp-phat]}

The --config YAML holds option values by name, e.g.:
  workers: 4
  scheduler: tcp://10.0.0.5:8786

Writes OUT/results.csv and OUT/results.md (one row per input x parameter combination). The
rows are the same whichever backend ran them (only the 'seconds' column differs).
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    p = add_command(
        subparsers,
        "bench",
        help="run a suite of scenes x tasks x parameters (locally or on a Dask cluster)",
        description="""\
Batch evaluation: a suite of inputs x tasks x parameters, one results table.""",
        epilog=EXAMPLES,
    )
    p.add_argument("suite", metavar="SUITE", help="a suite YAML file, or a built-in: smoke")
    p.add_argument("-o", "--output", type=Path, required=True, metavar="DIR")
    p.add_argument("--workers", type=int, default=1, metavar="N", help="local processes")
    p.add_argument(
        "--scheduler", metavar="ADDRESS", help="Dask scheduler address (tcp://host:port)"
    )
    add_common(p, run)
    add_config_option(p)


def run(args: argparse.Namespace) -> int:
    from avtrack.batch import load_suite, markdown_table, run_items, write_csv

    if args.workers < 1:
        raise InputError(f"--workers must be >= 1, got {args.workers}")
    name, items = load_suite(args.suite)
    t0 = time.perf_counter()
    try:
        with progress.bar(len(items), name, "run", args.quiet) as bar:

            def advance(done: int, total: int) -> None:
                bar.update(done - bar.n)

            rows = run_items(
                items, workers=args.workers, scheduler=args.scheduler, progress=advance
            )
    except OSError as exc:
        raise InputError(f"cannot reach the scheduler {args.scheduler}: {exc}") from None
    args.output.mkdir(parents=True, exist_ok=True)
    write_csv(args.output / "results.csv", rows)
    from avtrack.io.base import atomic_write

    with atomic_write(args.output / "results.md") as fh:
        fh.write(f"## {name}\n\n" + markdown_table(rows))
    if not args.quiet:
        print(markdown_table(rows, skip=("seconds",)), end="")
        print(f"{len(rows)} runs in {time.perf_counter() - t0:.1f} s -> {args.output}")
    return 0
