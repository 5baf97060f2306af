"""``avtrack robot-sim``: a closed-loop robot-head sequence (tracking + visual servoing)."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from avtrack.cli import progress
from avtrack.cli.base import add_command, add_common
from avtrack.config import load_config
from avtrack.errors import InputError
from avtrack.simulate.robot import (
    ROBOT_SCENARIOS,
    RobotSimConfig,
    simulate_robot,
    write_robot_sim,
)

EXAMPLES = (
    "built-in sequences:\n"
    + "\n".join(f"  {name:<9} {s.description}" for name, s in ROBOT_SCENARIOS.items())
    + """

examples:
  avtrack robot-sim jump2 -o runs/jump2
  avtrack robot-sim jump3 --seed 4 --no-compensation -o runs/jump3-wo
  avtrack robot-sim follow1 --duration 20 --control exact -o runs/follow1
  avtrack robot-sim jump2 --config robot.yaml -o runs/jump2-tuned

DIR receives tracks.txt and gt/gt.txt (MOTChallenge, left image) and servo.csv
(frame,target_id,distance_px: the pursued track and its distance to the image centre).
Score with:  avtrack eval mot DIR/gt/gt.txt DIR/tracks.txt

The --config YAML holds RobotSimConfig fields; the detector, stereo matching and tracker
ones under "detector:", "stereo:" and "tracker:" (RobotTrackerConfig), e.g.:
  gain: 0.3
  blur_speed: 2.0
  detector: {miss_rate: 0.2}
  tracker: {death_frames: 20, control: exact}
"""
)


def register(subparsers: argparse._SubParsersAction) -> None:
    p = add_command(
        subparsers,
        "robot-sim",
        help="simulate a moving robot head tracking and servoing people (thesis §3.2)",
        description="""\
Closed-loop NAO-MPVS-like sequence: simulated people seen by a stereo pair on a
pan/tilt head, 3-D multi-person tracking with ego-motion compensation, and visual
servoing whose commands move the head (thesis §3.2).""",
        epilog=EXAMPLES,
    )
    p.add_argument("name", metavar="NAME", help=f"sequence ({', '.join(ROBOT_SCENARIOS)})")
    p.add_argument(
        "-o", "--output", type=Path, required=True, metavar="DIR", help="output directory"
    )
    p.add_argument("--seed", type=int, default=0, metavar="S", help="random seed (default 0)")
    p.add_argument(
        "--no-compensation",
        action="store_true",
        help="track without the control term C_tn (the servo acts on those tracks)",
    )
    p.add_argument(
        "--duration",
        type=float,
        metavar="SECONDS",
        help="sequence length (default: the sequence's, 40 s)",
    )
    p.add_argument(
        "--control",
        choices=("jacobian", "exact"),
        help="form of C_tn: first order (eq. 3.45, default) or exact (eq. 3.48); "
        "overrides tracker.control of --config",
    )
    p.add_argument(
        "--config",
        type=Path,
        metavar="FILE.yaml",
        help="simulation, detector, stereo and tracker parameters (RobotSimConfig fields)",
    )
    add_common(p, run)


def run(args: argparse.Namespace) -> int:
    config = load_config(args.config, RobotSimConfig, overrides={"tracker.control": args.control})
    if args.name not in ROBOT_SCENARIOS:
        raise InputError(f"unknown sequence {args.name!r}; built-in: {', '.join(ROBOT_SCENARIOS)}")
    if args.seed < 0:
        raise InputError(f"--seed must be >= 0, got {args.seed}")
    if args.duration is not None and not (math.isfinite(args.duration) and args.duration > 0):
        raise InputError(f"--duration must be a positive number of seconds, got {args.duration}")
    with progress.activity(f"simulating {args.name}", args.quiet):
        result = simulate_robot(
            args.name,
            seed=args.seed,
            compensation=not args.no_compensation,
            duration_s=args.duration,
            config=config,
        )
    write_robot_sim(result, args.output)
    if not args.quiet:
        from avtrack.metrics.mot import evaluate_mot

        scores = evaluate_mot(result.gt, result.tracks)
        dist = result.servo.distance_px
        mean = float(np.nanmean(dist)) if np.isfinite(dist).any() else float("nan")
        ms = 1000 * float(np.median(result.step_times))
        print(
            f"robot-sim {args.name} (seed {args.seed}, compensation "
            f"{'off' if args.no_compensation else 'on'}): {result.recording.n_frames} frames, "
            f"MOTA {scores.MOTA:.1f}, IDSW {scores.IDSW}, mean servo distance {mean:.1f} px, "
            f"{ms:.2f} ms/step -> {args.output}"
        )
    return 0
