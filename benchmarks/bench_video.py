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

Usage::

    python benchmarks/bench_video.py [--data ../shared/data]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from scipy.optimize import linear_sum_assignment  # noqa: E402

from avtrack.io.datasets import read_seqinfo  # noqa: E402
from avtrack.io.mot import read_mot  # noqa: E402
from avtrack.io.video import iter_frames, probe_video  # noqa: E402
from avtrack.metrics.mot import box_iou, evaluate_mot  # noqa: E402
from avtrack.pipelines.mot import default_config  # noqa: E402
from avtrack.visual.histograms import detection_histograms  # noqa: E402
from avtrack.visual.ovbt import OVBTConfig, track_mot  # noqa: E402

SEQUENCES = {"TUD-Campus": "TUD-Campus.mp4", "PETS09-S2L1": "PETS09-S2L1.avi"}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path,
                    default=Path(__file__).resolve().parents[1] / ".." / "shared" / "data")
    args = ap.parse_args(argv)
    print(f"# bench_video: {platform.machine()}, {time.strftime('%Y-%m-%d')}, one thread\n")
    print("| sequence | input | MOTA | IDF1 | HOTA | IDSW | seconds (decode + histograms, "
          "tracking) | x real time |")
    print("|---|---|---|---|---|---|---|---|")
    for seq, video in SEQUENCES.items():
        folder = args.data / "mot15" / seq
        dets = read_mot(folder / "det" / "det.txt", kind="det")
        gt = read_mot(folder / "gt" / "gt.txt", kind="gt")
        info_ini = read_seqinfo(folder / "seqinfo.ini")
        fps = float(info_ini.get("frame_rate", 25.0))
        t0 = time.perf_counter()
        info = probe_video(folder / video)
        app = detection_histograms(iter_frames(info.path, info), dets, info.n_frames,
                                   descriptor="person")
        t_app = time.perf_counter() - t0
        duration = info.n_frames / fps
        for label, appearance, cfg in (
            ("detections", None, OVBTConfig()),
            ("detections + video", app, default_config(video=True)),
        ):
            t1 = time.perf_counter()
            res = track_mot(dets, appearance, cfg, info.image_size, info.n_frames, fps)
            t_track = time.perf_counter() - t1
            s = evaluate_mot(gt, res, n_frames=info.n_frames)
            spent = t_track + (t_app if appearance is not None else 0.0)
            print(f"| {seq} | {label} | {s.MOTA:.1f} | {s.IDF1:.1f} | {s.HOTA:.1f} | {s.IDSW} | "
                  f"{t_app if appearance is not None else 0:.2f} + {t_track:.2f} | "
                  f"{spent / duration:.3f} |")
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


if __name__ == "__main__":
    raise SystemExit(main())
