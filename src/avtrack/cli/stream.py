"""``avtrack stream``: localize and track speakers on a live WAV stream (stdin or a file)."""

from __future__ import annotations

import argparse
import contextlib
import sys
from pathlib import Path

import numpy as np

from avtrack.audio.recording import AudioChecks
from avtrack.cli.base import (
    add_array_option,
    add_clipping_option,
    add_command,
    add_common,
    add_localizer_option,
)
from avtrack.config import build_config, read_config_mapping
from avtrack.errors import InputError
from avtrack.io.base import atomic_write
from avtrack.io.doa import DOA_HEADER, format_doa_row

EXAMPLES = """\
examples:
  # a live 4-channel recording from ALSA (arecord writes a WAV stream to its stdout):
  arecord -D hw:1 -f S16_LE -c 4 -r 16000 -t wav | avtrack stream - --array nao4

  # the same from a file, as if it were live, tracks also saved to a CSV file
  cat scenes/meeting-1/audio.wav | avtrack stream - --array nao4 -o tracks.csv

  # the Gaussian tracker, 40 ms blocks, parameters from a file
  avtrack stream scenes/meeting-1/audio.wav --array nao4 --tracker gauss --block-ms 40 \\
      --config stream.yaml

Output: one CSV row per alive track per tracker frame (every 32 ms), columns
frame,time_s,id,azimuth_deg,elevation_deg,weight,active (as 'avtrack track-audio' writes them;
active = speaking), on stdout as they come (flushed every frame), or to -o FILE: written as the
stream goes into a temporary file next to FILE, renamed onto FILE at the end of the stream or on
Ctrl-C (complete rows only; a killed run leaves FILE untouched).

The --config YAML has two optional sections, e.g.:
  localizer: {step: 0.06, entropy: 0.02}      # the --method's Config fields
  tracker: {activity_threshold: 0.3}          # the --tracker's Config fields

Python API: avtrack.stream.DOAStream (this command) and avtrack.stream.AVStream (audio +
video detections).
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    from avtrack.doa.base import TRACKERS

    p = add_command(
        subparsers,
        "stream",
        help="localize and track speakers on a live WAV stream (stdin or a file)",
        description="""\
Online multi-speaker localization and tracking of a multichannel WAV stream read
as it arrives (e.g. from a microphone array on stdin): DP-RTF + exponentiated-
gradient localization every 8 ms (dprtf-eg-smooth by default: each frame's map
0.2 s after the frame), a VEM DOA tracker every 32 ms, one output row per track
per frame with bounded latency and memory.""",
        epilog=EXAMPLES,
    )
    p.add_argument("audio", metavar="AUDIO.wav|-", help="WAV file, or - for standard input")
    add_array_option(p)
    add_localizer_option(p)
    p.add_argument(
        "--tracker",
        choices=sorted(TRACKERS),
        default="vonmises",
        help="default: vonmises",
    )
    p.add_argument(
        "--block-ms",
        type=float,
        default=20.0,
        metavar="MS",
        help="read the stream in blocks of MS milliseconds (default 20)",
    )
    p.add_argument(
        "-o",
        "--output",
        type=Path,
        metavar="TRACKS.csv",
        help="write the rows to this file instead of stdout ('-': stdout)",
    )
    add_clipping_option(p)
    p.add_argument(
        "--config", type=Path, metavar="FILE.yaml", help="localizer: and tracker: parameters"
    )
    add_common(p, run)


def load_stream_config(path: Path | None, method: str, tracker: str) -> tuple[object, object]:
    """The localizer's and the tracker's Config from the ``--config`` file (defaults
    without one: the tracker's for ``method``'s heat maps, ``map_reading``); errors name the
    field, e.g. ``FILE: tracker.kappa_birth: ...``."""
    from avtrack.doa.base import map_reading
    from avtrack.localize import LOCALIZERS

    loc_cls = LOCALIZERS[method].Config
    trk_base = map_reading(tracker, method).config
    if path is None:
        return loc_cls(), trk_base
    values = read_config_mapping(path, "sections 'localizer' and 'tracker'")
    unknown = sorted(str(k) for k in values if k not in ("localizer", "tracker"))
    if unknown:
        raise InputError(f"{unknown[0]}: unknown field (allowed: localizer, tracker)", path)
    loc = build_config(loc_cls, values.get("localizer") or {}, path, "localizer")
    trk = build_config(trk_base, values.get("tracker") or {}, path, "tracker")
    return loc, trk


def run(args: argparse.Namespace) -> int:
    import time

    from avtrack.audio.arrays import load_array
    from avtrack.stream import DOAStream, open_wav_stream, wav_blocks

    if not (np.isfinite(args.block_ms) and args.block_ms > 0):
        raise InputError(f"--block-ms must be > 0, got {args.block_ms}")
    method_config, tracker_config = load_stream_config(args.config, args.method, args.tracker)
    array = load_array(args.array)
    stream = DOAStream(
        array,
        method=args.method,
        tracker=args.tracker,
        method_config=method_config,
        tracker_config=tracker_config,
    )
    source = args.audio if args.audio == "-" else Path(args.audio)
    frames = rows = 0
    t0 = time.perf_counter()
    with open_wav_stream(source, fs=stream.fs, channels=array.n_mics) as (info, handle):
        block = max(1, round(args.block_ms * 1e-3 * info.fs))
        if args.verbose:
            print(
                f"reading {info.name}: {info.channels} channels at {info.fs} Hz "
                f"({info.subtype}), blocks of {block} samples; latency "
                f"{stream.latency_s * 1e3:.0f} ms",
                file=sys.stderr,
            )
        # -o: rows go to a temporary file renamed onto the output when the stream ends -- also
        # on Ctrl-C, caught inside the block (complete rows only); a killed run leaves no file
        to_stdout = args.output is None or str(args.output) == "-"
        sink_cm = contextlib.nullcontext(sys.stdout) if to_stdout else atomic_write(args.output)
        with sink_cm as sink:
            sink.write(DOA_HEADER + "\n")
            checks = AudioChecks(info.name, info.fs, args.allow_clipping)
            def write(outs: list) -> None:
                nonlocal frames, rows
                for f in outs:
                    trk = f.tracks
                    sink.writelines(
                        format_doa_row(f.frame, f.time_s, i, a, 0.0, w, on)
                        for i, a, w, on in zip(
                            trk.ids, trk.azimuth_deg, trk.activity, trk.active, strict=True
                        )
                    )
                    sink.flush()
                    frames += 1
                    rows += len(trk)

            try:
                for x in wav_blocks(handle, block):
                    checks.block(x)
                    write(stream.push(x))
                write(stream.finish())  # the frames a smoothing localizer still held
            except KeyboardInterrupt:
                if not args.quiet:
                    print("avtrack: interrupted; kept the rows so far", file=sys.stderr)
                return 130
            checks.finish()  # before the output is kept: silent, clipped or too short
    if not args.quiet:
        seconds = stream.samples_in / stream.fs
        elapsed = time.perf_counter() - t0
        print(
            f"streamed {seconds:.1f} s of audio: {frames} tracker frames, {rows} track rows"
            + (f" -> {args.output}" if args.output and str(args.output) != "-" else "")
            + f" (real-time factor {elapsed / max(seconds, 1e-9):.3f})",
            file=sys.stderr,
        )
    return 0
