"""``avtrack eval``: score a result against ground truth.

Tasks (each its own sub-command): ``mot`` — MOTChallenge visual tracking (MOTA, IDF1, HOTA ...).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from avtrack.cli.base import HelpFormatter, add_common
from avtrack.errors import InputError
from avtrack.io.base import atomic_write
from avtrack.io.mot import read_mot
from avtrack.metrics.mot import BENCHMARKS, TABLE_COLUMNS, evaluate_mot, format_table

EVAL_EXAMPLES = """\
examples:
  avtrack eval mot gt/gt.txt results/TUD-Campus.txt
  avtrack eval mot --help
"""

MOT_EXAMPLES = """\
examples:
  # MOT15 sequence: ground truth and a tracker result, both MOTChallenge text files
  avtrack eval mot ../shared/data/mot15/TUD-Campus/gt/gt.txt out/TUD-Campus.txt

  # MOT17 ground truth (classes in column 8, distractors removed) and the scores as JSON
  avtrack eval mot MOT17-02/gt/gt.txt MOT17-02.txt --benchmark MOT17 --json scores.json

  # all scores (IDP, IDR, DetA, AssA, PT ...), or nothing but the JSON file
  avtrack eval mot gt.txt res.txt -v
  avtrack eval mot gt.txt res.txt -q --json scores.json
"""

#: Extra columns printed with ``--verbose``.
VERBOSE_COLUMNS = ("IDP", "IDR", "DetA", "AssA", "PT", "n_gt_ids", "n_frames")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "eval",
        help="score a result against ground truth",
        description="Score a result against ground truth. Choose the task below.",
        epilog=EVAL_EXAMPLES,
        formatter_class=HelpFormatter,
    )
    tasks = parser.add_subparsers(dest="eval_task", metavar="TASK", required=True)

    mot = tasks.add_parser(
        "mot",
        help="MOTChallenge tracking scores: MOTA, MOTP, IDF1, HOTA, FP, FN, IDSW ...",
        description=(
            "Score a tracker result against MOTChallenge ground truth, exactly as the official\n"
            "TrackEval kit does (CLEAR-MOT, identity and HOTA metrics; a match needs IoU >= 0.5)."
            "\nFiles are MOTChallenge text: frame,id,left,top,width,height,conf,... (1-based "
            "frames)."
        ),
        epilog=MOT_EXAMPLES,
        formatter_class=HelpFormatter,
    )
    mot.add_argument("gt", type=Path, metavar="GT.txt", help="ground-truth file (gt/gt.txt)")
    mot.add_argument("result", type=Path, metavar="RES.txt", help="tracker result file")
    mot.add_argument(
        "--benchmark",
        choices=BENCHMARKS,
        default="MOT15",
        help="which preprocessing to apply: MOT15 ignores rows flagged 0 in column 7; "
        "MOT16/17/20 also drop results on distractors and keep pedestrian gt only "
        "(default: %(default)s)",
    )
    mot.add_argument(
        "--n-frames",
        type=int,
        metavar="N",
        help="sequence length (default: the last frame in either file)",
    )
    mot.add_argument("--json", type=Path, metavar="OUT.json", help="also write the scores as JSON")
    add_common(mot)
    mot.set_defaults(func=run_mot)


def run_mot(args: argparse.Namespace) -> int:
    gt = read_mot(args.gt, kind="gt")
    res = read_mot(args.result, kind="result")
    if args.json is not None and args.json.is_dir():
        raise InputError("--json must name a file, got a directory", args.json)
    try:
        scores = evaluate_mot(gt, res, benchmark=args.benchmark, n_frames=args.n_frames)
    except ValueError as exc:
        raise InputError(f"cannot score {args.result} against {args.gt}: {exc}") from None
    if args.json is not None:
        record = {
            "gt": str(args.gt),
            "result": str(args.result),
            "benchmark": args.benchmark,
            "scores": scores.as_dict(),
        }
        with atomic_write(args.json) as fh:
            json.dump(record, fh, indent=2)
            fh.write("\n")
    if not args.quiet:
        columns = TABLE_COLUMNS + (VERBOSE_COLUMNS if args.verbose else ())
        print(
            f"{args.benchmark} scores of {args.result} against {args.gt} "
            f"({scores.n_frames} frames, {scores.n_gt_ids} ground-truth identities)"
        )
        print(format_table({args.result.stem: scores}, columns=columns))
        if args.json is not None and args.verbose:
            print(f"wrote {args.json}")
    return 0
