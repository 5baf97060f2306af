"""``avtrack track-phd``: audio-visual SMC-PHD tracking of an AV16.3 sequence
(Liu et al., labelled non-zero particle flow SMC-PHD filtering)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from avtrack.cli import progress
from avtrack.cli.base import (
    add_algorithm_config_option,
    add_command,
    add_common,
    add_output_option,
)
from avtrack.config import load_config
from avtrack.errors import InputError
from avtrack.phd import PHD_FILTERS, PHDConfig
from avtrack.phd.base import write_tracks_csv
from avtrack.phd.likelihood import VISUAL_SOURCES
from avtrack.phd.scoring import OSPA_CUTOFF, OSPA_ORDER, OSPA_T_CUTOFF, OSPA_T_LABEL_PENALTY
from avtrack.pipelines.phd import track_av163

EXAMPLES = """\
examples:
  # labelled particle flow on sequence 45, camera 1 (real face detections + DOA lines)
  avtrack track-phd ../shared/data/av16.3 --seq 45 --cam 1 --filter lpf -o tracks.csv

  # the clustering baseline, another seed, synthetic face detections, with a figure
  avtrack track-phd av16.3/ --seq 24 --cam 2 --filter npf --seed 3 -o npf.csv --plot npf.png

  # clutter stress test: 0.5 visual false alarms and 0.5 DOA outliers per frame
  avtrack track-phd av16.3/ --seq 24 --cam 1 --clutter-rate 0.5 -o lpf_clutter.csv

  # from the real video: mouths below the tops of the moving foreground (or on the face)
  avtrack track-phd av16.3/ --seq 30 --cam 1 \
      --video av16.3/seq30-2p-1101_cam1_divx_audio.avi -o lpf30.csv

The folder holds files named as in the AV16.3 release used by Liu et al.:
  data_av_seqNN_camC.mat, DOA_measurements_seqNN_camC.mat, hist_temp_16bins_seqNN_camC.mat
  and, where available, face_seqNN_camC.mat (face detections).
Output rows: frame,id,x,y (image pixels of the mouth; id -1 when the filter gives none).
The --config YAML holds PHDConfig fields, e.g.:
  particles_per_target: 50
  sigma_visual: 4.0
  flow_prior: label
  marginal_weights: true
  resample_rule: population
  association: face
  ambiguity_ratio: 6
  occlusion_frames: 25
  coast_frames: 0
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    p = add_command(
        subparsers,
        "track-phd",
        help="audio-visual SMC-PHD tracking of AV16.3 (particle flow, Liu et al.)",
        description=(
            "Track the speakers of an AV16.3 sequence in the image with the "
            "AV-LPF-SMC-PHD (labelled\nparticle flow) or AV-NPF-SMC-PHD (particle "
            "flow with k-means) filter; writes rows\nframe,id,x,y and prints OSPA "
            f"(order {OSPA_ORDER}, cut-off {OSPA_CUTOFF:g} px), OSPA-T (labelled tracks, "
            f"cut-off {OSPA_T_CUTOFF:g} px,\nlabel penalty {OSPA_T_LABEL_PENALTY:g} px), ESS, "
            "resamplings and time."
        ),
        epilog=EXAMPLES,
    )
    p.add_argument("folder", type=Path, metavar="AV163_DIR", help="folder of AV16.3 MAT files")
    p.add_argument("--seq", type=int, required=True, help="sequence number (e.g. 24, 45)")
    p.add_argument("--cam", type=int, required=True, choices=(1, 2, 3), help="camera")
    p.add_argument(
        "--filter",
        default="lpf",
        choices=sorted(PHD_FILTERS),
        help="lpf (labelled flow, default) or npf (flow + k-means)",
    )
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument(
        "--visual",
        default="auto",
        choices=VISUAL_SOURCES,
        help="visual measurements: face detections, detections synthesised from "
        "the ground truth, or faces when the file exists (default)",
    )
    p.add_argument(
        "--video",
        type=Path,
        metavar="FILE.avi",
        help="the sequence's video: visual measurements from its frames (mouths below the "
        "head tops of the exposure-compensated moving foreground, or on the visible face, "
        "scored against the hist_temp_16bins templates) instead of face detections",
    )
    p.add_argument(
        "--clutter-rate",
        type=float,
        default=0.0,
        metavar="PER_FRAME",
        help="clutter stress test: add synthetic visual false alarms (uniform over the image) "
        "and as many DOA outliers (uniform azimuth), this many per frame each (Poisson); the "
        "filter's clutter_visual and clutter_audio grow by the same rate (default 0)",
    )
    add_algorithm_config_option(p, "PHDConfig")
    add_output_option(p, "TRACKS.csv", "output CSV (written atomically)")
    p.add_argument(
        "--plot",
        type=Path,
        metavar="FIG.png",
        help="also draw the tracks, ground truth and OSPA over time",
    )
    add_common(p, run)


def run(args: argparse.Namespace) -> int:
    config = load_config(args.config, PHDConfig)
    if not args.folder.is_dir():
        raise InputError("AV16.3 folder not found", args.folder)
    if args.seq < 1:
        raise InputError(f"--seq must be a positive integer, got {args.seq}")
    if not (np.isfinite(args.clutter_rate) and 0 <= args.clutter_rate <= 100):
        raise InputError(f"--clutter-rate must be a number in [0, 100], got {args.clutter_rate}")
    if args.video is not None and args.visual != "auto":
        raise InputError(f"--visual {args.visual} and --video both choose the visual "
                         f"measurements; give one")

    def watch(tracker, n_frames):
        return progress.counting(tracker, "step", n_frames, args.filter, "frame", args.quiet)

    res = track_av163(args.folder, args.seq, args.cam, args.filter, config, seed=args.seed,
                      visual=args.visual, video=args.video, clutter_rate=args.clutter_rate,
                      watch=watch)
    write_tracks_csv(args.output, res.rows)
    result, ospa = res.result, res.ospa
    if args.plot:
        from avtrack.viz.plots import plot_phd_tracks

        plot_phd_tracks(args.plot, result, res.truth, res.sequence.frames, ospa,
                        f"{args.filter.upper()} seq {args.seq} cam {args.cam} "
                        f"({res.visual_source})", OSPA_ORDER, OSPA_CUTOFF)
    if not args.quiet:
        print(
            f"{args.filter}: seq {args.seq} cam {args.cam}, {res.sequence.n_frames} frames, "
            f"visual {res.visual_source}; OSPA {ospa[:, 0].mean():.2f} px (p={OSPA_ORDER}, "
            f"c={OSPA_CUTOFF:g}), OSPA-T {res.ospa_t:.2f} px (c={OSPA_T_CUTOFF:g}, label "
            f"{OSPA_T_LABEL_PENALTY:g}), ESS {result.mean_ess:.1f}, {result.n_resamplings} "
            f"resamplings, {result.time_s:.2f} s -> {args.output}"
        )
    if args.verbose:
        print(
            f"  localisation {ospa[:, 1].mean():.2f} px, cardinality {ospa[:, 2].mean():.2f} px",
            file=sys.stderr,
        )
    return 0
