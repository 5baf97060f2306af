"""``avtrack track-audio``: acoustic multi-speaker tracking from a microphone-array WAV.

Localizes every 8 ms frame (a registered localizer, ``dprtf-eg-smooth`` by default: DPRTF-EG
with its peaks placed by position weights in velocity layers, each frame's map read 0.2 s
later through a fixed-lag smoother; heat maps over the candidate azimuths), then
tracks the speakers with a VEM tracker updated every 32 ms (thesis
§5.5.2): ``--tracker gauss`` (thesis §5.4) or ``vonmises`` (thesis §5.6). With ``--doa`` the
observations come from a DOA CSV instead (any localizer's peaks), so tracking can follow any
localizer. Writes one row per alive track per tracker frame
(``frame,time_s,id,azimuth_deg,elevation_deg,weight,active``; ``active`` = speaking,
``weight`` = the speaker-activity statistic of eq. 5.43 / 5.62).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from avtrack.audio.stft import FRAME_HOP_S
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
from avtrack.doa.base import (
    OBSERVATION_MODES,
    TRACKERS,
    DOASequence,
    MapReading,
    make_tracker,
    map_reading,
)
from avtrack.errors import InputError
from avtrack.io.doa import DOACsvWriter, DOATable, read_doa_csv, write_doa_csv
from avtrack.pipelines import TrackRun, track_recording

HOP_S = FRAME_HOP_S

EXAMPLES = """\
examples:
  # DPRTF-EG (fast) localization + Gaussian VEM tracking on a NAO-head recording, with a figure
  avtrack track-audio scene/audio.wav --array scene/array.json -o tracks.csv --plot tracks.png

  # the von Mises tracker, scored against ground truth (MD / FA / MAE / IDs / OSPA)
  avtrack track-audio scene/audio.wav --array nao4 --tracker vonmises -o tracks.csv \\
      --truth scene/gt/doa.csv

  # track the peaks another localizer wrote (no audio needed)
  avtrack localize rec.wav --array av163 --method srp-phat -o doa.csv --threshold 0.0
  avtrack track-audio --doa doa.csv --tracker vonmises -o tracks.csv

The --config YAML holds the tracker's parameters (GaussConfig / VonMisesConfig fields, over
the defaults for the --method's heat maps), e.g.:
  activity_threshold: 0.5
  death_s: 20
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    p = add_command(
        subparsers,
        "track-audio",
        help="acoustic multi-speaker tracking (localization + VEM tracker)",
        description="""\
Track several speakers from a microphone-array recording (thesis ch. 5): frame-wise
localization every 8 ms, then a variational-EM tracker every 32 ms that keeps the
identities through speech pauses and says who is speaking. On dprtf-eg-smooth maps (the
default; each frame's map comes 0.2 s after the frame), dprtf-eg-fast and dprtf-eg-static maps
the tracker reads a map only up to 0.15-0.2 s after the localizer's latest frame with speech
features, so tracks fall silent soon after talking stops. Azimuths are in the array
frame, counter-clockwise from x, in (-180, 180].""",
        epilog=EXAMPLES,
    )
    p.add_argument(
        "audio",
        type=Path,
        nargs="?",
        metavar="AUDIO.wav",
        help="multichannel recording (not needed with --doa)",
    )
    add_array_option(p, required=False, note=" (required with AUDIO.wav)")
    p.add_argument(
        "--tracker", choices=sorted(TRACKERS), default="gauss", help="default: gauss"
    )
    add_output_option(p, "TRACKS.csv",
                      "tracks, one row per track per tracker frame (written atomically)")
    p.add_argument(
        "--doa",
        type=Path,
        metavar="DOA.csv",
        help="track the DOAs of this CSV (rows with active=1, weight = confidence) "
        "instead of localizing AUDIO.wav",
    )
    add_localizer_option(p, " of AUDIO.wav (as avtrack localize)")
    add_grid_options(p, "0 for azimuth only", "the trackers follow the map summed over "
                     "elevation")
    p.add_argument(
        "--observations",
        choices=OBSERVATION_MODES,
        help="from heat maps: every candidate direction with its weight (all), the same with "
        "each frame's median weight removed (above-median), only the peaks >= 0.05 (peaks), "
        "or only the peaks >= F x the uniform weight (peaks-over-uniform; F = 1.55 on "
        "dprtf-eg-smooth maps, 1.15 on dprtf-eg-fast and -static maps, else 1.44); default: "
        "peaks-over-uniform on those, else above-median for gauss and peaks-over-uniform for "
        "vonmises",
    )
    p.add_argument(
        "--step",
        type=int,
        default=4,
        metavar="K",
        help="one tracker update per K localizer frames (default 4 = 32 ms)",
    )
    add_algorithm_config_option(
        p, "the --tracker's GaussConfig / VonMisesConfig",
        ", over its defaults for the localizer's maps (on dprtf-eg-smooth, -fast and -static "
        "maps the trackers report the direction predicted 0.15 s ahead, latency compensation; "
        "'lead_s: 0' reports the filtered one)")
    p.add_argument(
        "--plot",
        type=Path,
        metavar="FILE.png",
        help="draw the tracks over time (thesis Fig. 5.2 f; needs matplotlib)",
    )
    p.add_argument(
        "--truth",
        type=Path,
        metavar="GT.csv",
        help="ground-truth DOA CSV: print MD/FA rates, MAE, identity switches and "
        "OSPA (thesis §5.5.1)",
    )
    p.add_argument(
        "--voices",
        type=Path,
        metavar="DIR",
        help="also write DIR/<id>.wav, each track's speech alone (an MVDR beamformer steered at "
        "the track's direction, silent while it is not active); needs AUDIO.wav",
    )
    add_clipping_option(p)
    add_common(p, run)


def reading_for(args: argparse.Namespace) -> MapReading:
    """The tracker's default reading of the input: of ``--method``'s heat maps for AUDIO.wav,
    of ``dprtf-eg``'s (the ``Config`` defaults) for a ``--doa`` table."""
    if args.tracker not in TRACKERS:
        raise InputError(f"--tracker must be one of {sorted(TRACKERS)}, got {args.tracker!r}")
    return map_reading(args.tracker, args.method if args.doa is None else None)


def run(args: argparse.Namespace) -> int:
    reading = reading_for(args)
    config = load_config(args.config, reading.config)
    if args.step < 1:
        raise InputError(f"--step must be >= 1, got {args.step}")
    if args.doa is None and args.audio is None:
        raise InputError("give AUDIO.wav (with --array) or --doa DOA.csv")
    if args.doa is not None and args.audio is not None:
        raise InputError("give either AUDIO.wav or --doa DOA.csv, not both")
    if args.voices is not None and args.audio is None:
        raise InputError("--voices beamforms the microphone array's recording: give AUDIO.wav "
                         "with --array (not --doa)")
    if args.voices is not None and args.voices.exists() and not args.voices.is_dir():
        raise InputError("--voices must name a folder", args.voices)
    truth = read_doa_csv(args.truth) if args.truth is not None else None
    observations = args.observations or reading.observations
    if args.doa is not None:
        tracks, frame_times, elapsed, duration = _track_doa_table(args, config)
        n_ids, n_active, n_frames = len(np.unique(tracks.ids)), int(tracks.active.sum()), len(
            frame_times)
        source = args.doa.name
    else:
        run_ = _track_audio_file(args, config, observations, keep=truth is not None or bool(
            args.plot) or args.voices is not None)
        tracks = run_.table if run_.table is not None else DOATable.empty()
        frame_times, elapsed, duration = run_.frame_times, run_.elapsed_s, run_.duration_s
        n_ids, n_active, n_frames = len(run_.track_ids), run_.n_active, run_.n_frames
        source = args.audio.name
    if args.voices is not None:
        from avtrack.audio.arrays import load_array
        from avtrack.audio.beamform import extract_voices, tracks_from_doa, write_voices
        from avtrack.audio.recording import FS, read_array_audio

        array = load_array(args.array)
        x = read_array_audio(args.audio, array, args.allow_clipping, True)
        with progress.activity("beamforming the voices", args.quiet):
            voices = extract_voices(x, FS, array, tracks_from_doa(tracks, args.step * HOP_S))
        write_voices(args.voices, voices, FS)
    if args.plot is not None:
        from avtrack.viz.plots import plot_doa_tracks

        plot_doa_tracks(args.plot, tracks, truth, f"{args.tracker}: {source}")
    if not args.quiet:
        rf = elapsed / max(duration, 1e-9)
        print(
            f"tracked {n_frames} frames ({duration:.1f} s) with {args.tracker}: {n_ids} "
            f"track(s), {n_active} active estimates -> {args.output} (real-time factor "
            f"{rf:.3f})"
        )
    if truth is not None:
        from avtrack.metrics.doa_tracking import evaluate_tracks

        d = evaluate_tracks(tracks, truth, frame_times=frame_times).as_dict()
        print(
            f"MD {d['MD%']:.1f} %  FA {d['FA%']:.1f} %  MAE {d['MAE']:.2f} deg  "
            f"IDs {d['IDs']}  OSPA(30 deg) {d['OSPA']:.2f} deg  ({d['actual']} "
            f"speaker-frames)"
        )
    if n_frames == 0 and not args.quiet:
        print("avtrack: warning: no observations; wrote an empty track file", file=sys.stderr)
    return 0


def _track_doa_table(
    args: argparse.Namespace, config: Any
) -> tuple[DOATable, np.ndarray, float, float]:
    """Track the DOAs of ``--doa``; writes the tracks, returns them with the frame times, the
    tracking time and the duration (seconds)."""
    table = read_doa_csv(args.doa)
    try:
        seq = DOASequence.from_table(table, args.step)
    except ValueError as exc:
        raise InputError(str(exc), args.doa) from None
    hop = HOP_S
    if len(seq) > 1:
        hop = float(np.median(np.diff(seq.time_s))) / args.step
    duration = float(seq.time_s[-1] + hop) if len(seq) else 0.0
    tracker = make_tracker(args.tracker, config, frame_period_s=args.step * hop)
    t0 = time.perf_counter()
    with progress.counting(tracker, "step", len(seq), "tracking", "frame", args.quiet):
        tracks = tracker.run(seq)
    elapsed = time.perf_counter() - t0
    write_doa_csv(args.output, tracks)
    return tracks, seq.time_s, elapsed, duration


def _track_audio_file(
    args: argparse.Namespace, config: Any, observations: str, keep: bool
) -> TrackRun:
    """Localize and track ``args.audio`` in blocks, writing the tracks as they come."""
    from avtrack.audio.arrays import load_array
    from avtrack.audio.recording import ArrayRecording
    from avtrack.localize import LOCALIZERS
    from avtrack.stream import DOAStream

    if args.array is None:
        raise InputError("--array is required to localize AUDIO.wav")
    if args.method not in LOCALIZERS:
        raise InputError(f"--method must be one of {sorted(LOCALIZERS)}, got {args.method!r}")
    array = load_array(args.array)
    grid = grid_from_options(args.grid_step, args.elevations, array)
    recording = ArrayRecording(args.audio, array, args.allow_clipping, args.quiet)
    stream = DOAStream(
        array, method=args.method, tracker=args.tracker, step=args.step,
        observations=observations, grid=grid,
        method_config=LOCALIZERS[args.method].Config(), tracker_config=config,
    )
    with DOACsvWriter(args.output) as out, progress.minutes(
        recording.info.duration_s, f"tracking {args.audio.name}", args.quiet
    ) as update:
        return track_recording(recording, stream, sink=out.write, keep_table=keep,
                               progress=update)
