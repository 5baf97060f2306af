"""``avtrack localize``: frame-wise multiple-speaker localization from a microphone-array WAV.

Runs one of the registered localizers (:data:`avtrack.localize.LOCALIZERS`: DPRTF-EG, the REM
baselines, SRP-PHAT) on the recording, picks the heat-map peaks of every 8 ms frame and writes
them as a DOA CSV (``frame,time_s,id,azimuth_deg,elevation_deg,weight,active``, ``id = -1``).
Optionally draws the heat map (thesis Fig. 5.2 b–e) and scores the peaks against ground truth
(thesis §5.5.1).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from avtrack.audio.arrays import load_array
from avtrack.audio.recording import BLOCK_SECONDS, FS, ArrayRecording
from avtrack.cli import progress
from avtrack.cli.base import (
    add_algorithm_config_option,
    add_array_option,
    add_clipping_option,
    add_command,
    add_common,
    add_grid_options,
    add_localizer_option,
    add_output_option,
    grid_from_options,
)
from avtrack.config import load_config
from avtrack.errors import InputError
from avtrack.io.doa import DOACsvWriter, read_doa_csv
from avtrack.localize import LOCALIZERS, make_localizer
from avtrack.localize.grid import elevation_support
from avtrack.metrics.doa import evaluate_doa, roc_sweep
from avtrack.pipelines import localize_recording
from avtrack.viz.plots import plot_heatmap

#: What :func:`~avtrack.localize.grid.elevation_support` means, for the verbose output.
ELEVATION_HEARING = {
    "none": "no elevation (a line of microphones or measured HRIRs)",
    "upper": "elevation but not its sign (a planar array)",
    "full": "elevation and its sign",
}

EXAMPLES = """\
examples:
  # DPRTF-EG (thesis ch. 5) on a NAO-head recording, peaks to a CSV, heat map to a PNG
  avtrack localize scene/audio.wav --array nao4 -o doa.csv --plot heatmap.png

  # a baseline, a custom array, a stricter peak threshold, at most two peaks per frame
  avtrack localize rec.wav --array my_array.json --method srp-phat -o doa.csv \\
      --threshold 0.2 --max-peaks 2

  # score against ground truth (MD / FA rates, MAE, thesis §5.5.1) and sweep the threshold
  avtrack localize scene/audio.wav --array scene/array.json -o doa.csv \\
      --truth scene/gt/doa.csv --roc

The --config YAML holds the method's parameters, e.g. for dprtf-eg:
  variance: 0.1
  step: 0.07
  entropy: 0.1
  dprtf:
    ctf_length: 8
    noise:
      speech_ratio: 3.0
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    p = add_command(
        subparsers,
        "localize",
        help="frame-wise multi-speaker localization from a microphone-array WAV",
        description="""\
Frame-wise localization of several speakers (thesis ch. 5): heat maps over candidate
azimuths every 8 ms, their peaks written as DOA CSV rows (frame,time_s,id,azimuth_deg,
elevation_deg,weight,active; id -1). Azimuths are in the array frame, counter-clockwise
from x, in (-180, 180]. WAV channel k is microphone k of --array; audio at another
rate than 16 kHz is resampled.""",
        epilog=EXAMPLES,
    )
    p.add_argument("audio", type=Path, metavar="AUDIO.wav", help="multichannel recording")
    add_array_option(p)
    add_localizer_option(p)
    add_output_option(p, "DOA.csv", "peaks, one row per peak (written atomically)")
    p.add_argument(
        "--threshold",
        type=float,
        metavar="T",
        help="peak threshold (default: the method's, e.g. 0.03 for dprtf-eg; for prp-rem "
        "and dprtf-rem 0.05 a 5-degree cell, scaled with --grid-step)",
    )
    p.add_argument(
        "--floor",
        type=float,
        metavar="F",
        help="also write weaker peaks down to F with active=0 (for ROC sweeps)",
    )
    p.add_argument("--max-peaks", type=int, metavar="K", help="at most K peaks per frame")
    add_grid_options(p, "-20,0,20", "peaks are taken over azimuth, at the elevation of "
                     "their largest value")
    add_algorithm_config_option(p, "the --method's Config")
    p.add_argument(
        "--block-size",
        type=int,
        metavar="N",
        help="read and localize the audio in blocks of N samples (default: 4 s); memory "
        "stays at one block whatever the recording's length",
    )
    p.add_argument(
        "--plot",
        type=Path,
        metavar="FILE.png",
        help="draw the heat map over time (needs matplotlib)",
    )
    p.add_argument(
        "--truth",
        type=Path,
        metavar="GT.csv",
        help="ground-truth DOA CSV: print MD/FA rates and MAE (thesis §5.5.1)",
    )
    p.add_argument(
        "--roc",
        action="store_true",
        help="with --truth: sweep the threshold, print the best MD/FA balance",
    )
    add_clipping_option(p)
    add_common(p, run)


def run(args: argparse.Namespace) -> int:
    config = load_config(args.config, LOCALIZERS[args.method].Config)
    array = load_array(args.array)
    if args.max_peaks is not None and args.max_peaks < 1:
        raise InputError(f"--max-peaks must be >= 1, got {args.max_peaks}")
    if args.block_size is not None and args.block_size < 1:
        raise InputError(f"--block-size must be >= 1, got {args.block_size}")
    if args.roc and args.truth is None:
        raise InputError("--roc needs --truth GT.csv")
    grid = grid_from_options(args.grid_step, args.elevations, array)
    truth = read_doa_csv(args.truth) if args.truth is not None else None
    block_s = BLOCK_SECONDS if args.block_size is None else args.block_size / FS
    recording = ArrayRecording(args.audio, array, args.allow_clipping, args.quiet, block_s)
    try:
        localizer = make_localizer(args.method, array, grid, config)
    except (TypeError, ValueError) as exc:
        raise InputError(str(exc), args.config) from None
    threshold = localizer.peak_threshold if args.threshold is None else args.threshold
    floor = threshold if args.floor is None else min(args.floor, threshold)
    if args.roc:
        floor = min(floor, 0.0)
    duration = recording.info.duration_s
    with DOACsvWriter(args.output) as out, progress.minutes(
        duration, f"localizing {args.audio.name}", args.quiet
    ) as update:
        result = localize_recording(
            recording, localizer, threshold, floor=floor, max_peaks=args.max_peaks,
            sink=out.write, keep_table=truth is not None, keep_heat=args.plot is not None,
            progress=update,
        )
    if args.plot is not None and result.heat is not None:
        plot_heatmap(args.plot, result.heat, grid, f"{args.method}: {args.audio.name}", truth)
    if args.verbose:
        print(
            f"{args.method} on array {array.name!r} ({array.kind}, {array.n_mics} mics), "
            f"{grid.size} candidates ({grid.n_azimuths} azimuths x elevations "
            f"{', '.join(f'{e:g}' for e in grid.elevation_values)}; the array hears "
            f"{ELEVATION_HEARING[elevation_support(array)]}); {config}"
        )
        with_obs = result.frames_with_features / max(result.n_frames, 1)
        print(f"frames with features: {100 * with_obs:.1f} %")
    if not args.quiet:
        print(
            f"localized {result.n_frames} frames ({duration:.1f} s) with {args.method}: "
            f"{result.n_active} peaks >= {threshold:g} -> {args.output} "
            f"(real-time factor {result.elapsed_s / max(duration, 1e-9):.3f})"
        )
    if truth is not None and result.table is not None:
        table = result.table
        scores = evaluate_doa(table, truth)
        d = scores.as_dict()
        print(
            f"threshold {threshold:g}: MD {d['MD%']:.1f} %  FA {d['FA%']:.1f} %  "
            f"MAE {d['MAE']:.2f} deg  ({scores.n_actual} speaker-frames)"
        )
        if args.roc:
            curve = roc_sweep(table, truth)
            thr, best = curve.best
            b = best.as_dict()
            print(
                f"ROC best threshold {thr:.4g}: MD {b['MD%']:.1f} %  FA {b['FA%']:.1f} %  "
                f"MAE {b['MAE']:.2f} deg"
            )
    return 0
