"""AV16.3 from its real video: colour-histogram visual measurements for the SMC-PHD filters.

Sequence 30, camera 1 (the one sequence whose video is in ``../shared/data/av16.3``): the
visual measurements come from the frames (``--detector heads``, the default:
:class:`avtrack.visual.heads.ForegroundHeadDetector`, the tops of the exposure-compensated
moving foreground with the camera's head sizes, the face placing the mouth where visible;
``--detector templates``: :class:`avtrack.visual.colour.ColourTemplateDetector` with the
sequence's ``hist_temp_16bins`` templates, foreground windows only), the audio ones
are the file's DOA measurements as DOA lines. Beside them, the same filters on detections
synthesised from the ground truth (:class:`avtrack.phd.likelihood.SyntheticFaceDetector`), and
the visual VEM tracker (OVBT) on the same visual points as fixed-size boxes.

Scores against ``posGT`` (presence from ``X_true``), mean over frames then seeds:

- OSPA-T as the SMC-PHD authors' released evaluation computes it (order 2, cut-off 65 px,
  label penalty 25 px, tracks assigned to true tracks globally): :func:`avtrack.metrics.ospa.
  ospa_t`;
- plain OSPA (order 2, cut-off 50 px, no labels).

Also: the detector's recall (a point within 20 px of a present person's mouth), the share of
its points within 40 px of one, and decoding + detection time as a fraction of the video's
duration (one core).

Usage::

    python benchmarks/bench_av163_video.py            # 10 seeds
    python benchmarks/bench_av163_video.py --seeds 3
    python benchmarks/bench_av163_video.py --seeds 3 --detector templates --video-only
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, before NumPy loads BLAS

import argparse  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from _common import SHARED_DATA  # noqa: E402
from avtrack.av.av163 import av163_detector  # noqa: E402
from avtrack.io.av163 import load_av163  # noqa: E402
from avtrack.io.video import iter_frames, probe_video  # noqa: E402
from avtrack.metrics.ospa import ospa_sequence, ospa_t  # noqa: E402
from avtrack.metrics.points import point_matches  # noqa: E402
from avtrack.phd import PHD_FILTERS, PHDConfig  # noqa: E402
from avtrack.phd.likelihood import (  # noqa: E402
    TEMPLATE_MOUTH_OFFSET,
    SyntheticFaceDetector,
    av163_frames,
    av163_truth,
)

VIDEO = "seq30-2p-1101_cam1_divx_audio.avi"
FACE_BOX = (18.0, 25.0)  # face box (w, h) the VEM row draws around a point


def detect_video(folder: Path, seq, name: str) -> tuple[list[np.ndarray], float, float]:
    """Mouth points per frame, decode + detect seconds, video duration (s)."""
    video = folder / VIDEO
    info = probe_video(video)
    t0 = time.perf_counter()
    det = av163_detector(seq, name)
    offset = getattr(det, "mouth_offset", TEMPLATE_MOUTH_OFFSET)
    out = []
    for frame in iter_frames(video, info):
        b, _ = det.detect(frame)
        out.append(np.column_stack([b[:, 0] + b[:, 2] / 2, b[:, 1] + offset * b[:, 3]]))
    return out, time.perf_counter() - t0, info.n_frames / info.fps


def detector_rates(visual: list[np.ndarray], seq) -> tuple[float, float]:
    """Recall and precision of the mouth points against the ground truth."""
    m = point_matches(visual, [seq.positions[seq.present[t], t] for t in range(len(visual))])
    return m.recall, m.precision


def labelled_truth(seq) -> list[np.ndarray]:
    return [np.where(seq.present[t][:, None], seq.positions[:, t], np.nan)
            for t in range(seq.n_frames)]


def phd_scores(name: str, config: PHDConfig, frames, seq, seed: int) -> tuple[float, float]:
    res = PHD_FILTERS[name](config, seed=seed).run(frames)
    rows = res.rows(seq.frames)
    ids = rows[:, 1].astype(np.int64)
    unlabelled = ids < 0  # no identity (NPF): a track of its own
    ids[unlabelled] = ids.max(initial=0) + 1 + np.arange(int(unlabelled.sum()))
    est = [(ids[rows[:, 0] == f], rows[rows[:, 0] == f, 2:4]) for f in seq.frames]
    return (ospa_t(est, labelled_truth(seq), 65.0, 2, 25.0).mean,
            ospa_sequence(res.positions(), av163_truth(seq), 50.0, 2)[:, 0].mean())


def vem_scores(visual: list[np.ndarray], seq) -> tuple[float, float]:
    from avtrack.visual.ovbt import OVBTracker

    w, h = FACE_BOX
    tracker = OVBTracker(image_size=(360, 288))
    est, pos = [], []
    for z in visual:
        boxes = np.column_stack([z[:, 0] - w / 2, z[:, 1] - 0.8 * h, np.full(len(z), w),
                                 np.full(len(z), h)]) if len(z) else np.zeros((0, 4))
        out = tracker.step(boxes, np.ones(len(z)))
        b = np.asarray(out.boxes, dtype=float).reshape(-1, 4)
        p = np.column_stack([b[:, 0] + b[:, 2] / 2, b[:, 1] + 0.8 * b[:, 3]])
        est.append((np.asarray(out.ids, dtype=int), p))
        pos.append(p)
    return (ospa_t(est, labelled_truth(seq), 65.0, 2, 25.0).mean,
            ospa_sequence(pos, av163_truth(seq), 50.0, 2)[:, 0].mean())


def persons_scores(folder: Path, seq, detector: str) -> tuple[float, float, int, int, float]:
    """``track-av`` on the video: OSPA-T and OSPA of persons.csv's image positions (persons
    in view), persons, speakers, seconds."""
    from avtrack.av.av163 import track_av163

    t0 = time.perf_counter()
    res, _ = track_av163(seq, folder / VIDEO, av163_detector(seq, detector))
    elapsed = time.perf_counter() - t0
    P = res.persons
    est, pos = [], []
    for f in seq.frames:
        m = (P.frames == f) & P.in_view & np.all(np.isfinite(P.pixels), axis=1)
        est.append((P.ids[m], P.pixels[m]))
        pos.append(P.pixels[m])
    return (ospa_t(est, labelled_truth(seq), 65.0, 2, 25.0).mean,
            ospa_sequence(pos, av163_truth(seq), 50.0, 2)[:, 0].mean(),
            len(np.unique(P.ids)), len({s.speaker for s in res.speech}), elapsed)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=SHARED_DATA / "av16.3")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--detector", choices=("heads", "templates"), default="heads",
                    help="visual detector on the frames: foreground head tops (default) or "
                    "the colour-template windows (the earlier default)")
    ap.add_argument("--video-only", action="store_true",
                    help="skip the rows on detections synthesised from the ground truth")
    args = ap.parse_args(argv)
    if not (args.data / VIDEO).is_file():
        print(f"bench_av163_video: {args.data / VIDEO} not found", file=sys.stderr)
        return 2
    seq = load_av163(args.data, 30, 1)
    config = PHDConfig()
    video_pts, t_detect, duration = detect_video(args.data, seq, args.detector)
    recall, precision = detector_rates(video_pts, seq)
    video_frames = av163_frames(seq, video_pts, config.sigma_audio, config.gate)
    rows: dict[tuple[str, str], list[tuple[float, float]]] = {}
    for s in range(args.seeds):
        synth = SyntheticFaceDetector().detect(seq.positions, seq.present,
                                               np.random.default_rng([s, 30, 1]))
        synth_frames = av163_frames(seq, synth, config.sigma_audio, config.gate)
        sources = [("video", video_frames)]
        if not args.video_only:
            sources.append(("synthetic", synth_frames))
        for source, frames in sources:
            for name in ("lpf", "npf"):
                rows.setdefault((source, name), []).append(
                    phd_scores(name, config, frames, seq, s))
        if not args.video_only:
            rows.setdefault(("synthetic", "vem"), []).append(vem_scores(synth, seq))
        print(f"# seed {s}: " + ", ".join(f"{k[0]}/{k[1]} {v[-1][0]:.2f}"
                                          for k, v in rows.items()), file=sys.stderr, flush=True)
    rows[("video", "vem")] = [vem_scores(video_pts, seq)]
    av = persons_scores(args.data, seq, args.detector)
    print(f"Machine: {platform.processor() or platform.machine()}, Python "
          f"{platform.python_version()}, NumPy {np.__version__}, one BLAS thread; "
          f"{args.seeds} seeds; detector {args.detector}; AV16.3 sequence 30 camera 1 "
          f"({seq.n_frames} frames)\n")
    print("| visual measurements | filter | OSPA-T (c 65, label 25) | OSPA (c 50) |")
    print("|---|---|---:|---:|")
    label = {"lpf": "LPF", "npf": "NPF", "vem": "VEM (OVBT, visual only)"}
    for (source, name), v in sorted(rows.items()):
        a = np.array(v)
        print(f"| {source} | {label[name]} | {a[:, 0].mean():.2f} | {a[:, 1].mean():.2f} |")
    print(f"| video | track-av (persons.csv, in view) | {av[0]:.2f} | {av[1]:.2f} |")
    print(f"\ntrack-av: {av[2]} persons, {av[3]} speakers (2 people in the sequence), "
          f"{av[4]:.1f} s for {duration:.1f} s of video (detection, histograms, tracking)")
    print(f"\nDetector ({args.detector}): recall (20 px) {recall:.3f}, points within 40 px of a "
          f"person {precision:.3f}; decode + detect {t_detect:.1f} s for {duration:.1f} s of "
          f"video ({t_detect / duration:.2f} x real time, {seq.n_frames / t_detect:.1f} "
          f"frames/s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
