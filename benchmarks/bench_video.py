"""Visual tracking with appearance from the real frames (``track-mot --video``) against the
detections alone, on the shared MOT15 sequences that have their video (TUD-Campus,
PETS09-S2L1).

For each sequence: MOTA / IDF1 / HOTA / IDSW of OVBT on SORT's public detections without
appearance (the default) and with the video's hue-saturation histograms (thesis eq. 3.5) under
``track-mot --video``'s settings (:func:`avtrack.pipelines.mot.default_config`); and the time
to decode the video, compute the histograms and track, on one core, against the video's own
duration (frames / seqinfo frame rate): below 1 is faster than the video. Last, the built-in
HOG people detector's recall and precision against the ground-truth boxes (IoU >= 0.5, one to
one per frame) and its frames per second.

Camera motion: ``--video`` estimates the camera's motion between frames and adds it to the
prediction (``OVBTConfig.compensate_camera``); the rows "camera still" switch it off. The
shared videos come from still cameras, so each is also tracked as a panning camera would see
it (``--pan``): a window ``2 A`` pixels narrower than the frame slides across it,
``A sin(2 pi t / T)`` pixels off centre (A = 60, T = 40 frames: up to 9.4 pixels a frame,
changing direction every 20 frames), the detections and the ground truth shifted with it
(boxes wholly outside dropped, the others clipped to the window).

Usage::

    python benchmarks/bench_video.py [--data ../shared/data]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from scipy.optimize import linear_sum_assignment  # noqa: E402

from avtrack.io.datasets import read_seqinfo  # noqa: E402
from avtrack.io.mot import MOTData, read_mot  # noqa: E402
from avtrack.io.video import iter_frames, probe_video  # noqa: E402
from avtrack.metrics.mot import box_iou, evaluate_mot  # noqa: E402
from avtrack.pipelines.mot import default_config, frames_appearance  # noqa: E402
from avtrack.visual.ovbt import OVBTConfig, track_mot  # noqa: E402

PAN_A = 60  # pixels
PAN_T = 40.0  # frames


def pan_offsets(n_frames: int) -> np.ndarray:
    """The window's left edge in each frame ``1..n_frames`` (integer pixels: no resampling)."""
    t = np.arange(n_frames)
    return np.round(PAN_A + PAN_A * np.sin(2 * np.pi * t / PAN_T)).astype(int)


def panned_boxes(data: MOTData, offsets: np.ndarray, width: int) -> MOTData:
    """``data`` seen through the sliding window: boxes shifted by each frame's offset, clipped
    to the window, the ones wholly outside dropped."""
    b = data.boxes.copy()
    b[:, 0] -= offsets[data.frames.astype(int) - 1]
    left = np.maximum(b[:, 0], 0.0)
    right = np.minimum(b[:, 0] + b[:, 2], float(width))
    keep = right - left > 1.0
    b[:, 0], b[:, 2] = left, right - left
    return MOTData(data.frames[keep], data.ids[keep], b[keep], data.scores[keep],
                   data.extra[keep])


def panned_frames(frames, offsets: np.ndarray, width: int):
    for k, frame in enumerate(frames):
        yield np.ascontiguousarray(frame[:, offsets[k]:offsets[k] + width])

SEQUENCES = {"TUD-Campus": "TUD-Campus.mp4", "PETS09-S2L1": "PETS09-S2L1.avi"}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path,
                    default=Path(__file__).resolve().parents[1] / ".." / "shared" / "data")
    ap.add_argument("--no-pan", action="store_true", help="only the videos as they are")
    args = ap.parse_args(argv)
    print(f"# bench_video: {platform.machine()}, {time.strftime('%Y-%m-%d')}, one thread\n")
    print("| sequence | input | MOTA | IDF1 | HOTA | IDSW | seconds (decode + histograms, "
          "tracking) | x real time |")
    print("|---|---|---|---|---|---|---|---|")
    for seq, video in SEQUENCES.items():
        for pan in (False,) if args.no_pan else (False, True):
            _track_rows(args.data / "mot15" / seq, seq, video, pan)
    print("\n| sequence | detector | recall (IoU >= 0.5) | precision | frames/s |")
    print("|---|---|---|---|---|")
    from avtrack.visual.detect import DETECTORS, detect_video, load_detector

    for seq, video in SEQUENCES.items():
        folder = args.data / "mot15" / seq
        gt = read_mot(folder / "gt" / "gt.txt", kind="gt")
        info = probe_video(folder / video)
        for name in DETECTORS:
            if name != "hog":  # face boxes cannot match MOT15's whole-body ground truth
                continue
            det = load_detector(name)
            t0 = time.perf_counter()
            found = detect_video(det, iter_frames(info.path, info), info.n_frames)
            elapsed = time.perf_counter() - t0
            hit = 0
            for f in np.unique(gt.frames):
                g, r = gt.boxes[gt.frames == f], found.boxes[found.frames == f]
                if len(r):
                    iou = box_iou(g, r)
                    a, b = linear_sum_assignment(-iou)
                    hit += int((iou[a, b] >= 0.5).sum())
            print(f"| {seq} | {name} | {hit / len(gt):.3f} | {hit / max(len(found), 1):.3f} | "
                  f"{info.n_frames / elapsed:.1f} |")
    return 0


def _track_rows(folder: Path, seq: str, video: str, pan: bool) -> None:
    """One table row per input: detections alone, the video with the camera held still, the
    video with its motion (the default)."""
    dets = read_mot(folder / "det" / "det.txt", kind="det")
    gt = read_mot(folder / "gt" / "gt.txt", kind="gt")
    fps = float(read_seqinfo(folder / "seqinfo.ini").get("frame_rate", 25.0))
    info = probe_video(folder / video)
    n, size = info.n_frames, info.image_size
    frames = iter_frames(info.path, info)
    if pan:
        offsets = pan_offsets(n)
        size = (size[0] - 2 * PAN_A, size[1])
        dets, gt = panned_boxes(dets, offsets, size[0]), panned_boxes(gt, offsets, size[0])
        frames = panned_frames(frames, offsets, size[0])
        seq += f" panned ±{PAN_A} px"
    t0 = time.perf_counter()
    app, motion = frames_appearance(frames, dets, n)
    t_app = time.perf_counter() - t0
    video_cfg = default_config(video=True)
    for label, appearance, cfg, seen in (
        ("detections", None, OVBTConfig(), None),
        ("detections + video, camera still", app,
         dataclasses.replace(video_cfg, compensate_camera=False), None),
        ("detections + video", app, video_cfg, motion),
    ):
        t1 = time.perf_counter()
        res = track_mot(dets, appearance, cfg, size, n, fps, seen)
        t_track = time.perf_counter() - t1
        s = evaluate_mot(gt, res, n_frames=n)
        spent = t_track + (t_app if appearance is not None else 0.0)
        print(f"| {seq} | {label} | {s.MOTA:.1f} | {s.IDF1:.1f} | {s.HOTA:.1f} | {s.IDSW} | "
              f"{t_app if appearance is not None else 0:.2f} + {t_track:.2f} | "
              f"{spent / (n / fps):.3f} |")


if __name__ == "__main__":
    raise SystemExit(main())
