"""Every built-in detector on the shared real videos: recall, precision, speed, and tracking.

Videos (``../shared/data``): MOT15 PETS09-S2L1 (795 frames, 768 × 576, people about 75 px
tall) and TUD-Campus (71 frames, 640 × 480), AV16.3 sequence 30 camera 1 (551 frames,
360 × 288, two people in a meeting room).

- **MOT15**: a detection is a true positive when the optimal one-to-one assignment
  (Hungarian, on IoU) pairs it with a ground-truth box at IoU >= 0.5 (``gt/gt.txt`` rows whose
  "consider" flag is set); recall = TP / ground-truth boxes, precision = TP / detections.
- **AV16.3**: a detection's mouth point is within 20 px of a present person's ``posGT``
  (the mouth) under the optimal one-to-one assignment on distance. The mouth point is the
  box's centre column at the detector's ``mouth_offset`` of its height from the top (YuNet:
  0.78); without one, a face box's centre, or 1/10 of a whole-body box from its top (the
  mouth of a standing adult, whose head is about 1/7.5 of the body).
- **frames/s**: time spent in ``detect`` alone (decoding excluded), one thread
  (``OMP_NUM_THREADS=1``, ``cv2.setNumThreads(1)``).
- **Tracking**: ``avtrack track-mot DET.txt --video VIDEO`` on each person detector's
  detections (exactly what ``track-mot --video VIDEO --detector NAME`` runs, without
  detecting twice), scored by :func:`avtrack.metrics.evaluate_mot` (MOTA, IDF1).

Usage::

    python benchmarks/bench_detectors.py                       # all detectors, all videos
    python benchmarks/bench_detectors.py --detectors ssd-person yunet-face --videos TUD-Campus
    python benchmarks/bench_detectors.py --stride 5            # every 5th frame (no tracking)
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from scipy.optimize import linear_sum_assignment  # noqa: E402

from avtrack.errors import InputError  # noqa: E402
from avtrack.io.mot import MOTData, read_mot, write_mot  # noqa: E402
from avtrack.metrics.mot import evaluate_mot  # noqa: E402
from avtrack.pipelines.mot import default_config, track_mot_sequence  # noqa: E402
from avtrack.visual.detect import DETECTORS, load_detector  # noqa: E402

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
VIDEOS = {
    "PETS09-S2L1": DATA / "mot15" / "PETS09-S2L1" / "PETS09-S2L1.avi",
    "TUD-Campus": DATA / "mot15" / "TUD-Campus" / "TUD-Campus.mp4",
    "AV16.3-seq30-cam1": DATA / "av16.3" / "seq30-2p-1101_cam1_divx_audio.avi",
}
#: Detectors whose boxes are faces (the others find whole bodies).
FACE_DETECTORS = {"yunet-face", "haar-face"}
#: Mouth below a whole-body box's top, in box heights (head 1/7.5 of the body, mouth at 0.69
#: of the head).
BODY_MOUTH = 0.1


def read_frames(path: Path) -> list[np.ndarray]:
    from avtrack.io.video import iter_frames, probe_video

    info = probe_video(path)
    return list(iter_frames(info.path, info))


def iou_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """IoU of ltwh boxes ``a (G, 4)`` with ``b (R, 4)``: ``(G, R)``."""
    ax1, ay1 = a[:, 0] + a[:, 2], a[:, 1] + a[:, 3]
    bx1, by1 = b[:, 0] + b[:, 2], b[:, 1] + b[:, 3]
    w = np.clip(np.minimum(ax1[:, None], bx1) - np.maximum(a[:, None, 0], b[:, 0]), 0, None)
    h = np.clip(np.minimum(ay1[:, None], by1) - np.maximum(a[:, None, 1], b[:, 1]), 0, None)
    inter = w * h
    return inter / (a[:, 2:].prod(1)[:, None] + b[:, 2:].prod(1) - inter)


def matches(score: np.ndarray, ok: np.ndarray) -> int:
    """Number of pairs of an optimal one-to-one assignment maximising ``score`` that are
    ``ok``."""
    if score.size == 0:
        return 0
    r, c = linear_sum_assignment(np.where(ok, score, -1e6), maximize=True)
    return int(ok[r, c].sum())


def ground_truth(video: str, n_frames: int):
    """Per frame: MOT15 boxes ``(G, 4)``, or AV16.3 mouths ``(G, 2)``."""
    if video.startswith("AV16.3"):
        from avtrack.io.av163 import load_av163

        seq = load_av163(DATA / "av16.3", 30, 1)
        return [seq.positions[seq.present[k], k] for k in range(n_frames)]
    gt = read_mot(VIDEOS[video].parent / "gt" / "gt.txt", kind="gt")
    keep = gt.scores != 0
    return [gt.boxes[keep & (gt.frames == k + 1)] for k in range(n_frames)]


def score_frame(video: str, top: float, boxes: np.ndarray, gt: np.ndarray) -> int:
    """True positives of one frame; ``top``: the mouth below a box's top, in box heights."""
    if video.startswith("AV16.3"):
        pts = np.column_stack([boxes[:, 0] + boxes[:, 2] / 2, boxes[:, 1] + top * boxes[:, 3]])
        d = np.hypot(gt[:, None, 0] - pts[:, 0], gt[:, None, 1] - pts[:, 1])
        return matches(-d, d <= 20.0)
    iou = iou_matrix(gt, boxes)
    return matches(iou, iou >= 0.5)


def run_detector(det, frames: list[np.ndarray], stride: int):
    fr, bx, sc = [], [], []
    spent = 0.0
    n = 0
    for k in range(0, len(frames), stride):
        t0 = time.perf_counter()
        b, s = det.detect(frames[k])
        spent += time.perf_counter() - t0
        n += 1
        b = np.asarray(b, float).reshape(-1, 4)
        fr.append(np.full(len(b), k + 1))
        bx.append(b)
        sc.append(np.asarray(s, float).reshape(-1))
    dets = MOTData(np.concatenate(fr), -np.ones(sum(len(f) for f in fr)), np.vstack(bx),
                   np.concatenate(sc))
    return dets, n / spent


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--detectors", nargs="+", default=list(DETECTORS), choices=list(DETECTORS))
    ap.add_argument("--videos", nargs="+", default=list(VIDEOS), choices=list(VIDEOS))
    ap.add_argument("--stride", type=int, default=1,
                    help="detect on every STRIDE-th frame only (no tracking unless 1)")
    ap.add_argument("--no-track", action="store_true", help="skip the track-mot runs")
    args = ap.parse_args(argv)
    if not all(p.is_file() for p in VIDEOS.values()):
        print(f"bench_detectors: the shared videos are not under {DATA}", file=sys.stderr)
        return 1
    import cv2

    cv2.setNumThreads(1)
    rows = []
    for video in args.videos:
        frames = read_frames(VIDEOS[video])
        gts = ground_truth(video, len(frames))
        for name in args.detectors:
            try:
                det = load_detector(name)
            except InputError as exc:
                print(f"{name:18s} {video:18s} not run: {exc}", flush=True)
                continue
            dets, fps = run_detector(det, frames, args.stride)
            top = getattr(det, "mouth_offset", 0.5 if name in FACE_DETECTORS else BODY_MOUTH)
            tp = n_gt = 0
            for k in range(0, len(frames), args.stride):
                b = dets.boxes[dets.frames == k + 1]
                n_gt += len(gts[k])
                tp += score_frame(video, top, b, gts[k])
            rec, prec = tp / max(n_gt, 1), tp / max(len(dets), 1)
            mota = idf1 = float("nan")
            if (args.stride == 1 and not args.no_track and not video.startswith("AV16.3")
                    and name not in FACE_DETECTORS):
                mota, idf1 = track(video, dets)
            rows.append((video, name, rec, prec, fps, mota, idf1))
            print(f"{name:18s} {video:18s} recall {100 * rec:5.1f} %  precision "
                  f"{100 * prec:5.1f} %  {fps:6.1f} frames/s  MOTA {mota:6.1f}  IDF1 "
                  f"{idf1:5.1f}", flush=True)
    print("\n| video | detector | recall % | precision % | frames/s | MOTA | IDF1 |")
    print("|---|---|---:|---:|---:|---:|---:|")
    for video, name, rec, prec, fps, mota, idf1 in rows:
        t = "" if np.isnan(mota) else f"{mota:.1f} | {idf1:.1f}"
        print(f"| {video} | {name} | {100 * rec:.1f} | {100 * prec:.1f} | {fps:.1f} | "
              f"{t if t else '- | -'} |")
    return 0


def track(video: str, dets: MOTData) -> tuple[float, float]:
    """MOTA and IDF1 (percent) of ``avtrack track-mot DET.txt --video VIDEO``
    (:func:`~avtrack.pipelines.mot.track_mot_sequence`), scored from its results file."""
    with tempfile.TemporaryDirectory() as tmp:
        det_path, res_path = Path(tmp) / "det.txt", Path(tmp) / "res.txt"
        write_mot(det_path, dets)
        try:
            run = track_mot_sequence(default_config(video=True, detector=True), det_path,
                                     video=VIDEOS[video])
        except InputError:
            return float("nan"), float("nan")
        write_mot(res_path, run.tracks)
        res = read_mot(res_path, kind="result")
    gt = read_mot(VIDEOS[video].parent / "gt" / "gt.txt", kind="gt")
    s = evaluate_mot(gt, res)
    return s.MOTA, s.IDF1


if __name__ == "__main__":
    sys.exit(main())
