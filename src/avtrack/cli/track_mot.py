"""``avtrack track-mot``: visual multi-person tracking of MOTChallenge detections (OVBT)."""

from __future__ import annotations

import argparse
import re
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from avtrack.cli import progress
from avtrack.cli.base import add_command, add_common
from avtrack.config import load_config
from avtrack.errors import InputError
from avtrack.io.datasets import find_seqinfo, read_seqinfo
from avtrack.io.mot import read_mot, write_mot
from avtrack.visual.detect import DEFAULT_PERSON_DETECTOR, DETECTORS
from avtrack.visual.ovbt import OVBTConfig, image_size_from_detections, track_mot

#: OVBTConfig fields that ``--video`` changes (before ``--config``): the weight of the person
#: colour histograms in the association (λ of eq. 3.5; IDF1 gains are flat for λ in 4-10) and
#: re-identification of a target that ended lately. Chosen on TUD-Campus and PETS09-S2L1, the
#: two shared sequences with video (BENCHMARKS.md).
VIDEO_DEFAULTS: dict[str, Any] = {"appearance_lambda": 5.0, "reid_log_ratio": 0.2,
                                  "reid_max_age": 25, "reid_max_distance": 4.0}

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
(frame,id,left,top,width,height,conf,-1,-1,-1), conf being the track's visibility probability.""",
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
                     "(appearance_lambda 5, reid_log_ratio 0.2, reid_max_age 25, "
                     "reid_max_distance 4 unless --config says otherwise); image size and "
                     "length from the video")
    p.add_argument("--detector", metavar="NAME",
                   help="without DET.txt: detect people in --video's frames with a built-in "
                   f"detector ({', '.join(DETECTORS)}; default {DEFAULT_PERSON_DETECTOR}, "
                   "people walking, from the avtrack[detectors] extra) or your own as "
                   "module:attribute (an object or factory with detect(frame) -> (boxes ltwh "
                   "(M, 4), scores (M,)))")
    p.add_argument("--report", type=Path, metavar="DIR",
                   help="with --video: write DIR/index.html and DIR/tracks.webm, the tracks "
                   "drawn over the video's own frames (with the scores and the ground truth "
                   "outlined when the sequence folder has gt/gt.txt)")
    p.add_argument("--config", type=Path, metavar="FILE.yaml",
                   help="tracker parameters (OVBTConfig fields)")
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


def _report(args: argparse.Namespace, res, video, n_frames: int) -> None:
    """``--report DIR``: the tracks over the video's frames, scored when the sequence folder
    has ``gt/gt.txt`` (MOTChallenge layout: SEQ/det/det.txt, SEQ/gt/gt.txt)."""
    from avtrack.io.video import iter_frames
    from avtrack.viz.recording import write_recording_report

    gt, scores = None, {}
    if args.detections is not None:
        gt_path = args.detections.resolve().parent.parent / "gt" / "gt.txt"
        if gt_path.is_file():
            from avtrack.metrics.mot import evaluate_mot

            gt = read_mot(gt_path, kind="gt")
            s = evaluate_mot(gt, res, n_frames=n_frames)
            scores = {"MOTA": s.MOTA, "IDF1": s.IDF1, "HOTA": s.HOTA, "IDSW": float(s.IDSW)}
            gt = gt if gt.n_frames <= n_frames else None
    with progress.activity(f"drawing the tracks over {n_frames} frames", args.quiet):
        write_recording_report(args.report, f"avtrack: {video.path.name}", res,
                               iter_frames(video.path, video), video.image_size, video.fps,
                               n_frames, gt=gt, scores=scores)


def parse_image_size(text: str) -> tuple[int, int]:
    m = re.fullmatch(r"\s*(\d+)\s*[xX,]\s*(\d+)\s*", text)
    if not m or int(m[1]) <= 0 or int(m[2]) <= 0:
        raise InputError(f"--image-size must look like 640x480, got {text!r}")
    return int(m[1]), int(m[2])


def load_appearance(path: Path, n_rows: int) -> np.ndarray:
    if not path.is_file():
        raise InputError("appearance file not found", path)
    try:
        app = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:  # EOFError: an empty file
        raise InputError(f"not a .npy array: {exc}", path) from None
    if app.ndim != 2 or app.shape[0] != n_rows:
        raise InputError(f"expected shape ({n_rows}, F) (one row per detection), got "
                         f"{app.shape}", path)
    if not np.all(np.isfinite(app)):
        raise InputError("contains NaN or infinite values", path)
    return app.astype(float)


def detect_in_video(video_path: Path, spec: str, quiet: bool):
    """Detections of a detector (``--detector``) on every frame of a video."""
    from avtrack.io.video import iter_frames, probe_video
    from avtrack.visual.detect import detect_video, load_detector

    info = probe_video(video_path)
    detector = load_detector(spec)
    with progress.activity(f"detecting people in {info.n_frames} frames ({spec})", quiet):
        try:
            return detect_video(detector, iter_frames(info.path, info), info.n_frames)
        except InputError:
            raise
        except Exception as exc:  # a plug-in's own failure, named as such
            raise InputError(f"--detector {spec} failed: {type(exc).__name__}: {exc}",
                             video_path) from None


def check_against_video(dets, video, det_path: Path) -> None:
    """Detections that cannot belong to the video: frames past its last one, boxes entirely
    outside its image."""
    if len(dets) == 0:
        return
    last = int(dets.frames.max())
    if last > video.n_frames:
        raise InputError(f"detections reach frame {last}, the video {video.path} has "
                         f"{video.n_frames} frames", det_path)
    w, h = video.image_size
    b = dets.boxes
    outside = (b[:, 0] >= w) | (b[:, 1] >= h) | (b[:, 0] + b[:, 2] <= 0) | (b[:, 1] + b[:, 3] <= 0)
    if outside.any():
        k = int(np.flatnonzero(outside)[0])
        raise InputError(f"detection of frame {int(dets.frames[k])} lies entirely outside the "
                         f"video's {w}x{h} image (box {b[k].round(1).tolist()})", det_path)


def run(args: argparse.Namespace) -> int:
    from dataclasses import replace

    base = replace(OVBTConfig(), **VIDEO_DEFAULTS) if args.video is not None else OVBTConfig
    config = load_config(args.config, base, overrides={"min_score": args.min_score,
                                                       "birth_min_score": args.birth_min_score})
    if args.fps is not None and not (np.isfinite(args.fps) and 0 < args.fps <= 1000):
        raise InputError(f"--fps must be a frame rate in (0, 1000], got {args.fps}")
    fps = args.fps
    fps_source = "--fps"
    if args.detections is None and args.video is None:
        raise InputError("give DET.txt, or --video (with --detector) to detect in its frames")
    if args.report is not None and args.video is None:
        raise InputError("--report draws the tracks over the video's frames: give --video")
    if args.detections is not None and args.detector is not None:
        raise InputError("--detector detects in the frames: give it without DET.txt")
    if args.detections is None:
        dets = detect_in_video(args.video, args.detector or DEFAULT_PERSON_DETECTOR,
                               args.quiet)
    else:
        dets = read_mot(args.detections, kind="det")
    appearance = None if args.appearance is None else load_appearance(args.appearance,
                                                                      len(dets))
    n_frames = None
    video = None
    if args.video is not None:
        from avtrack.io.video import probe_video

        video = probe_video(args.video)
        check_against_video(dets, video, args.detections or args.video)
        if not fps and video.fps:
            fps, fps_source = video.fps, "the video's header"
        if config.appearance != "bhattacharyya":
            raise InputError("--video gives colour histograms: the config's appearance must be "
                             f"'bhattacharyya', got {config.appearance!r}", args.config)
    if video is not None:
        image_size = video.image_size
        n_frames = video.n_frames
        if args.image_size and parse_image_size(args.image_size) != image_size:
            raise InputError(f"--image-size {args.image_size} differs from the video's "
                             f"{image_size[0]}x{image_size[1]}", args.video)
    else:
        seqinfo = find_seqinfo(args.detections) if args.detections is not None else None
        info = read_seqinfo(seqinfo) if seqinfo else {}
        if args.image_size:
            image_size = parse_image_size(args.image_size)
        elif "width" in info and "height" in info:
            image_size = (int(info["width"]), int(info["height"]))
        else:
            image_size = image_size_from_detections(dets)
        if not args.image_size:
            length = info.get("length")  # (an int: read_seqinfo parses it)
            n_frames = None if length is None else int(length)
        if not fps and info.get("frame_rate"):
            fps, fps_source = info["frame_rate"], f"{seqinfo}"
    if not args.quiet:
        print(f"frame rate: {fps:g} fps (from {fps_source}; --fps sets it)" if fps else
              "frame rate: not known, 25 fps assumed (--fps sets it)")
    if len(dets) == 0 and not args.quiet:
        print(f"avtrack: warning: {args.detections or 'the detector'} found no detections; "
              f"writing empty results", file=sys.stderr)
    t0 = time.perf_counter()
    n = max(dets.n_frames, n_frames or 0)
    if video is not None:
        from avtrack.io.video import iter_frames
        from avtrack.visual.histograms import detection_histograms

        with progress.activity(f"colour histograms of {len(dets)} boxes in {n} frames",
                               args.quiet):
            appearance = detection_histograms(iter_frames(video.path, video), dets, n,
                                              descriptor="person")
    try:
        with progress.activity(f"tracking {n} frames", args.quiet):
            res = track_mot(dets, appearance, config, image_size, n_frames, fps)
    except ValueError as exc:
        raise InputError(str(exc), args.detections or args.video) from None
    elapsed = time.perf_counter() - t0
    write_mot(args.output, res)
    if args.report is not None and video is not None:
        _report(args, res, video, n)
    if not args.quiet:
        print(f"tracked {n} frames, {len(np.unique(res.ids))} tracks, {len(res)} boxes "
              f"-> {args.output} ({n / max(elapsed, 1e-9):.0f} frames/s)")
    return 0
