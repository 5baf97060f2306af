"""``avtrack track-mot``: visual multi-person tracking of MOTChallenge detections (OVBT)."""

from __future__ import annotations

import argparse
import re
import sys
from functools import partial
from pathlib import Path

import numpy as np

from avtrack.cli import progress
from avtrack.cli.base import add_algorithm_config_option, add_command, add_common
from avtrack.config import load_config
from avtrack.errors import InputError
from avtrack.io.mot import write_mot
from avtrack.io.video import VideoInfo, iter_frames
from avtrack.pipelines import mot
from avtrack.pipelines.mot import check_against_video, load_appearance
from avtrack.visual.detect import DEFAULT_PERSON_DETECTOR, DETECTORS

# ``check_against_video``, ``detect_in_video`` and ``load_appearance`` are also what
# ``avtrack track-av`` runs on its own detections.
__all__ = ["check_against_video", "detect_in_video", "load_appearance", "register", "run"]

EXAMPLES = """\
examples:
  # track the public detections of a MOTChallenge sequence (image size from seqinfo.ini,
  # or from the detections' extent)
  avtrack track-mot MOT17-02/det/det.txt -o results/MOT17-02.txt

  # appearance from the real frames: hue-saturation histograms of every detection box
  # (thesis eq. 3.5), image size and length from the video
  avtrack track-mot PETS09-S2L1/det/det.txt -o res.txt --video PETS09-S2L1/PETS09-S2L1.avi

  # no detection file: detect people in the frames (the SSDLite pedestrian network by default,
  # pip install 'avtrack[detectors]'; or --detector hog, or your own as module:attribute),
  # then track
  avtrack track-mot -o res.txt --video TUD-Campus.mp4

  # the same, and a report: the tracks drawn over the video's own frames (index.html,
  # tracks.webm), scored against SEQ/gt/gt.txt when there is one
  avtrack track-mot PETS09-S2L1/det/det.txt -o res.txt --video PETS09-S2L1/PETS09-S2L1.avi \
      --report report/

  # explicit image size, appearance embeddings (one row per detection row), own parameters
  avtrack track-mot det.txt -o res.txt --image-size 640x480 --appearance emb.npy \\
      --config ovbt.yaml

  # then score it
  avtrack eval mot gt/gt.txt res.txt

The --config YAML holds OVBTConfig fields, e.g.:
  birth_frames: 3
  death_frames: 20
  appearance: cosine
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    p = add_command(
        subparsers,
        "track-mot",
        help="track MOTChallenge detections (visual VEM tracker, OVBT)",
        description="""\
Online variational-Bayesian multi-person tracking (thesis §3.1) of MOTChallenge detections
(frame,id,left,top,width,height,conf,...); writes MOTChallenge results
(frame,id,left,top,width,height,conf,-1,-1,-1), conf being the track's visibility probability.
A person is reported from the first of the B + 1 detections their birth was inferred from
(eq. 3.30; B = birth_frames, 2), at those detections with conf 1: the file is written once the
sequence is tracked, so it can hold what an online output gives only B frames late
(birth_sequence: false in --config turns this off).""",
        epilog=EXAMPLES)
    p.add_argument("detections", type=Path, metavar="DET.txt", nargs="?",
                   help="MOTChallenge detections (omit to detect in --video's frames)")
    p.add_argument("-o", "--output", type=Path, required=True, metavar="RES.txt",
                   help="results file (written atomically)")
    p.add_argument("--image-size", metavar="WxH",
                   help="image size in pixels (default: seqinfo.ini next to det/, else the "
                        "detections' extent)")
    app = p.add_mutually_exclusive_group()
    app.add_argument("--appearance", type=Path, metavar="APP.npy",
                     help="appearance descriptors, one row per detection row (.npy, 2-D)")
    app.add_argument("--video", type=Path, metavar="FILE",
                     help="the sequence's video (mp4, avi, ...; frame k is MOT frame k): "
                     "colour histograms of the detection boxes (hue-saturation-value, the inner "
                     "part of each box) become the appearance (thesis eq. 3.5, Bhattacharyya "
                     "likelihood) and re-identify targets that ended lately "
                     f"({_settings(mot.VIDEO_DEFAULTS)} unless --config says otherwise); the "
                     "camera's motion between frames, estimated from the background, is "
                     "compensated in the prediction (compensate_camera: false in --config for a "
                     "camera known to stand still); image size and length from the video")
    p.add_argument("--detector", metavar="NAME",
                   help="without DET.txt: detect people in --video's frames with a built-in "
                   f"detector ({', '.join(DETECTORS)}; default {DEFAULT_PERSON_DETECTOR}, "
                   "people walking, from the avtrack[detectors] extra) or your own as "
                   "module:attribute (an object or factory with detect(frame) -> (boxes ltwh "
                   "(M, 4), scores (M,))); its boxes with low scores show targets as the others "
                   f"do ({_settings(mot.DETECTOR_DEFAULTS)} unless --config says otherwise)")
    p.add_argument("--report", type=Path, metavar="DIR",
                   help="with --video: write DIR/index.html, DIR/tracks.mp4 and tracks.webm, the "
                   "tracks drawn over the video's own frames (with the scores and the ground "
                   "truth outlined when the sequence folder has gt/gt.txt)")
    add_algorithm_config_option(p, "OVBTConfig", "; --min-score and --birth-min-score win over "
                                "the file")
    p.add_argument("--min-score", type=float, metavar="S",
                   help="drop detections with a lower confidence (overrides --config)")
    p.add_argument("--birth-min-score", type=float, metavar="S",
                   help="detections with a lower confidence only update existing tracks, "
                   "never start one (overrides --config; default: the two-class Otsu split of "
                   "the scores seen so far, on any detector's score scale)")
    p.add_argument("--fps", type=float, metavar="F",
                   help="frame rate of the sequence (default: the video's, else frameRate in "
                   "seqinfo.ini next to det/, else 25); the per-frame size noise and birth "
                   "velocity prior scale with 1/fps")
    add_common(p, run)


def _report(args: argparse.Namespace, res: mot.MOTRun, video: VideoInfo) -> None:
    """``--report DIR``: the tracks over the video's frames, scored when the sequence folder
    has ``gt/gt.txt`` (MOTChallenge layout: SEQ/det/det.txt, SEQ/gt/gt.txt)."""
    from avtrack.viz.recording import write_recording_report

    n_frames = res.n_frames
    gt, scores = mot.score_against_sequence(res.tracks, args.detections, n_frames)
    with progress.activity(f"drawing the tracks over {n_frames} frames", args.quiet):
        write_recording_report(args.report, f"avtrack: {video.path.name}", res.tracks,
                               iter_frames(video.path, video), video.image_size, video.fps,
                               n_frames, gt=gt, scores=scores)


def parse_image_size(text: str) -> tuple[int, int]:
    m = re.fullmatch(r"\s*(\d+)\s*[xX,]\s*(\d+)\s*", text)
    if not m or int(m[1]) <= 0 or int(m[2]) <= 0:
        raise InputError(f"--image-size must look like 640x480, got {text!r}")
    return int(m[1]), int(m[2])


def _settings(fields: dict) -> str:
    """``name value, ...`` of a dict of OVBTConfig overrides, for the help."""
    return ", ".join(f"{k} {v:g}" for k, v in fields.items())


def detect_in_video(video_path: Path, spec: str, quiet: bool):
    """:func:`avtrack.pipelines.mot.detect_in_video` with an elapsed-time bar."""
    return mot.detect_in_video(video_path, spec, partial(progress.activity, quiet=quiet))


def run(args: argparse.Namespace) -> int:
    config = load_config(args.config, mot.default_config(args.video is not None,
                                                         detector=args.video is not None
                                                         and args.detections is None),
                         overrides={"min_score": args.min_score,
                                    "birth_min_score": args.birth_min_score})
    if args.fps is not None and not (np.isfinite(args.fps) and 0 < args.fps <= 1000):
        raise InputError(f"--fps must be a frame rate in (0, 1000], got {args.fps}")
    if args.detections is None and args.video is None:
        raise InputError("give DET.txt, or --video (with --detector) to detect in its frames")
    if args.report is not None and args.video is None:
        raise InputError("--report draws the tracks over the video's frames: give --video")
    image_size = parse_image_size(args.image_size) if args.image_size else None
    res = mot.track_mot_sequence(
        config, args.detections, video=args.video, detector=args.detector,
        appearance=args.appearance, image_size=image_size, fps=args.fps,
        config_path=args.config, stage=partial(progress.activity, quiet=args.quiet))
    if not args.quiet:
        print(f"frame rate: {res.fps:g} fps (from {res.fps_source or '--fps'}; --fps sets it)"
              if res.fps else "frame rate: not known, 25 fps assumed (--fps sets it)")
    if len(res.detections) == 0 and not args.quiet:
        print(f"avtrack: warning: {args.detections or 'the detector'} found no detections; "
              f"writing empty results", file=sys.stderr)
    write_mot(args.output, res.tracks)
    if args.report is not None and res.video is not None:
        _report(args, res, res.video)
    if not args.quiet:
        print(f"tracked {res.n_frames} frames, {len(np.unique(res.tracks.ids))} tracks, "
              f"{len(res.tracks)} boxes -> {args.output} "
              f"({res.n_frames / max(res.elapsed_s, 1e-9):.0f} frames/s)")
    return 0
