"""MOTChallenge accuracy and speed of avtrack against peer trackers on TUD-Campus (MOT15).

Every tracker gets the same public Faster R-CNN detections
(``../shared/data/mot15/TUD-Campus/det/det.txt``) and is scored with
:func:`avtrack.metrics.evaluate_mot` (TrackEval's metrics, MOT15 preprocessing) against the
sequence's ground truth. Peers come from the PyPI ``trackers`` package (``pip install
avtrack[bench]``) with their default parameters: ``SORTTracker``, ``ByteTrackTracker``,
``OCSORTTracker``, ``BoTSORTTracker``, ``CBIoUTracker``, ``McByteTracker``. Each takes one
``supervision.Detections`` per frame and returns detections with a ``tracker_id``; rows with
``tracker_id == -1`` (tracks not yet confirmed) are not output, as in the package's own MOT
writer and evaluator. No image is passed: BoT-SORT's and McByte's camera-motion compensation
(on by default) needs the frames and is then skipped, and McByte's mask manager is off by
default, so these two run on the boxes alone, as every other tracker here does.

Speed is frames per second over the whole sequence, the best of ``--repeats`` runs after one
warm-up run, with the garbage collector paused as ``timeit`` does. The trackers take turns
(one timed run of each, then the next round), so that a load that comes and goes on a shared
machine falls on all of them alike and the ratios stay comparable. Only the tracking loop is
timed: for the peers, creating a tracker and its per-frame ``update`` calls (the detections are
converted to ``supervision.Detections`` beforehand); for avtrack, the call
``track_mot(dets)``, which includes its own per-frame slicing and building the result. Reading
files and scoring are not timed. ``x fastest peer`` is a tracker's fps divided by the highest
peer fps.

Usage::

    python benchmarks/bench_mot.py                      # all trackers
    python benchmarks/bench_mot.py --only sort bytetrack ocsort --repeats 50
    python benchmarks/bench_mot.py --markdown bench_mot.md
"""

from __future__ import annotations

import argparse
import datetime as dt
import gc
import importlib.metadata
import os
import platform
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from avtrack.io.base import atomic_write
from avtrack.io.mot import MOTData, read_mot
from avtrack.metrics.mot import MOTScores, evaluate_mot

REPO_ROOT = Path(__file__).resolve().parents[1]
SEQUENCE = "TUD-Campus"
PEERS = {"sort": "SORTTracker", "bytetrack": "ByteTrackTracker", "ocsort": "OCSORTTracker",
         "botsort": "BoTSORTTracker", "cbiou": "CBIoUTracker", "mcbyte": "McByteTracker",
         "sort-bewley": "Sort"}
TRACKERS = ("avtrack", *PEERS)
LABELS = {
    "avtrack": "avtrack (ovbt)",
    "sort-bewley": "SORT (Bewley, original)",
    "sort": "SORT",
    "bytetrack": "ByteTrack",
    "ocsort": "OC-SORT",
    "botsort": "BoT-SORT",
    "cbiou": "C-BIoU",
    "mcbyte": "McByte",
}


def shared_data_dir() -> Path:
    """``$AVTRACK_SHARED_DATA`` or ``<repo>/../shared/data`` (as in ``tests/conftest.py``)."""
    env = os.environ.get("AVTRACK_SHARED_DATA")
    return Path(env) if env else REPO_ROOT / ".." / "shared" / "data"


@dataclass(frozen=True)
class Run:
    """One tracker's result on the sequence and its timing."""

    name: str
    scores: MOTScores
    fps: float
    times_s: tuple[float, ...]


# --------------------------------------------------------------------------- trackers


def peer_runner(key: str, dets: MOTData) -> tuple[Callable[[], Any], Callable[[Any], MOTData]]:
    """``(loop, to_mot)``: ``loop()`` runs a fresh ``trackers`` peer over ``dets`` (the timed
    part), ``to_mot`` turns its per-frame outputs into a result."""
    import supervision as sv
    import trackers

    cls = getattr(trackers, PEERS[key])
    n_frames = dets.n_frames
    frames = []  # inputs prepared once, outside the timed loop
    for sl in dets.frame_slices(n_frames):
        b = dets.boxes[sl]
        xyxy = np.column_stack([b[:, :2], b[:, :2] + b[:, 2:]])  # (left, top, w, h) -> corners
        frames.append(sv.Detections(xyxy=xyxy, confidence=dets.scores[sl].copy()))

    def loop() -> list:
        tracker = cls()  # default parameters; constructing it is part of the timed run
        return [tracker.update(d) for d in frames]

    def to_mot(outputs: list) -> MOTData:
        rows = []
        for frame, out in enumerate(outputs, start=1):
            keep = out.tracker_id >= 0  # -1: not (yet) a confirmed track
            for xyxy, tid, conf in zip(
                out.xyxy[keep], out.tracker_id[keep], out.confidence[keep], strict=True
            ):
                rows.append(
                    (frame, tid, xyxy[0], xyxy[1], xyxy[2] - xyxy[0], xyxy[3] - xyxy[1], conf)
                )
        a = np.array(rows, dtype=float).reshape(-1, 7)
        return MOTData(a[:, 0], a[:, 1], a[:, 2:6], a[:, 6])

    return loop, to_mot


def bewley_sort_runner(dets: MOTData) -> tuple[Callable[[], Any], Callable[[Any], MOTData]]:
    """The original SORT code (Bewley et al. 2016, packaged on PyPI as ``sort-tracker-py``)
    with its defaults (max_age 1, min_hits 3, IoU 0.3): the tracker whose TUD-Campus scores
    (MOTA 62.7, IDF1 60.6) are the reference to beat. It outputs the Kalman-filtered box of the
    tracks updated in the frame as rows (x1, y1, x2, y2, score, id)."""
    from sort_tracker import Sort

    frames = []
    for sl in dets.frame_slices(dets.n_frames):
        b = dets.boxes[sl]
        frames.append(np.column_stack([b[:, :2], b[:, :2] + b[:, 2:], dets.scores[sl]]))

    def loop() -> list:
        _reset_sort_ids()
        tracker = Sort()
        return [tracker.update(d).copy() for d in frames]

    def to_mot(outputs: list) -> MOTData:
        rows = [(frame, o[5], o[0], o[1], o[2] - o[0], o[3] - o[1], o[4])
                for frame, out in enumerate(outputs, start=1) for o in out]
        a = np.array(rows, dtype=float).reshape(-1, 7)
        return MOTData(a[:, 0], a[:, 1], a[:, 2:6], a[:, 6])

    return loop, to_mot


def _reset_sort_ids() -> None:
    """The package numbers tracks with a class-level counter; restart it for each run so that
    repeated runs give the same ids."""
    from sort_tracker import sort as sort_module

    sort_module.KalmanBoxTracker.count = 0


def avtrack_runner(dets: MOTData) -> tuple[Callable[[], Any], Callable[[Any], MOTData]]:
    from avtrack.visual.ovbt import track_mot

    def loop() -> MOTData:
        return track_mot(dets)

    return loop, lambda out: out


def runner(key: str, dets: MOTData) -> tuple[Callable[[], Any], Callable[[Any], MOTData]]:
    """``(loop, to_mot)`` of tracker ``key`` (see :func:`peer_runner`)."""
    if key == "avtrack":
        return avtrack_runner(dets)
    if key == "sort-bewley":
        return bewley_sort_runner(dets)
    return peer_runner(key, dets)


def run_all(keys: list[str], dets: MOTData, gt: MOTData, repeats: int) -> list[Run]:
    """Score and time the trackers ``keys``: one warm-up run of each (the result scored),
    then ``repeats`` rounds of one timed run of each."""
    loops, firsts, outs = {}, {}, {}
    for key in keys:
        print(f"running {LABELS[key]} ...", file=sys.stderr, flush=True)
        loops[key] = runner(key, dets)
        firsts[key] = loops[key][1](loops[key][0]())  # warm-up run; also the result scored
    times: dict[str, list[float]] = {key: [] for key in keys}
    for _ in range(repeats):
        for key in keys:
            gc.collect()
            gc.disable()
            try:
                t0 = time.perf_counter()
                outs[key] = loops[key][0]()
                times[key].append(time.perf_counter() - t0)
            finally:
                gc.enable()
    runs = []
    for key in keys:
        first, last = firsts[key], loops[key][1](outs[key])
        if not (np.array_equal(first.ids, last.ids) and np.array_equal(first.boxes, last.boxes)):
            raise RuntimeError(f"{key}: two runs on the same input gave different tracks")
        scores = evaluate_mot(gt, first, benchmark="MOT15", n_frames=dets.n_frames)
        runs.append(Run(LABELS[key], scores, dets.n_frames / min(times[key]),
                        tuple(times[key])))
    return runs


# --------------------------------------------------------------------------- report


def machine() -> dict[str, str]:
    cpu = platform.processor() or platform.machine()
    physical: set[tuple[str, str]] = set()
    try:
        with open("/proc/cpuinfo") as fh:
            phys = core = ""
            for line in fh:
                key, _, value = line.partition(":")
                key, value = key.strip(), value.strip()
                if key == "model name":
                    cpu = value
                elif key == "physical id":
                    phys = value
                elif key == "core id":
                    core = value
                    physical.add((phys, core))
    except OSError:
        pass
    logical = os.cpu_count() or 0
    available = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else logical
    cores = f"{logical} logical CPUs, {available} available to this process"
    if physical:
        cores = f"{len(physical)} physical cores, " + cores

    def version(dist: str) -> str:
        try:
            return importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            return "not installed"

    return {
        "date": dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC"),
        "cpu": cpu,
        "cores": cores,
        "os": f"{platform.system()} {platform.release()}",
        "python": platform.python_version(),
        "numpy": np.__version__,
        "versions": ", ".join(
            f"{d} {version(d)}" for d in ("avtrack", "trackers", "supervision", "trackeval",
                                          "sort-tracker-py", "filterpy", "lap")
        ),
    }


def report(runs: list[Run], info: dict[str, str], repeats: int, det_path: Path) -> str:
    peer_names = {LABELS[k] for k in PEERS}
    peer_fps = [r.fps for r in runs if r.name in peer_names]
    fastest = max(peer_fps) if peer_fps else None
    cols = [
        "tracker",
        "MOTA",
        "MOTP",
        "IDF1",
        "HOTA",
        "FP",
        "FN",
        "IDSW",
        "Frag",
        "MT",
        "ML",
        "fps",
        "x fastest peer",
    ]
    lines = [
        f"### {SEQUENCE} (MOT15 train), public detections, default parameters",
        "",
        "| " + " | ".join(cols) + " |",
        "|---|" + "---:|" * (len(cols) - 1),
    ]
    for r in runs:
        s = r.scores
        ratio = f"{r.fps / fastest:.2f}" if fastest else "-"
        cells = [
            r.name,
            *(f"{getattr(s, c):.1f}" for c in ("MOTA", "MOTP", "IDF1", "HOTA")),
            *(str(getattr(s, c)) for c in ("FP", "FN", "IDSW", "Frag", "MT", "ML")),
            f"{r.fps:,.0f}",
            ratio,
        ]
        lines.append("| " + " | ".join(cells) + " |")
    n_frames = runs[0].scores.n_frames if runs else 0
    lines += [
        "",
        f"Detections: `{det_path.name}` of {SEQUENCE} ({n_frames} frames). Scores: "
        "`avtrack.metrics.evaluate_mot` (TrackEval metrics, MOT15 preprocessing). fps: frames "
        f"per second of the tracking loop only, best of {repeats} runs after a warm-up, the "
        "trackers taking turns.",
        "",
        f"Machine: {info['cpu']} ({info['cores']}), {info['os']}; Python {info['python']}, "
        f"NumPy {info['numpy']}; {info['versions']}. Date: {info['date']}.",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description="Accuracy and speed of avtrack and peer trackers on MOT15 TUD-Campus.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="examples:\n  python benchmarks/bench_mot.py --only sort bytetrack ocsort\n"
        "  python benchmarks/bench_mot.py --repeats 50 --markdown bench_mot.md",
    )
    parser.add_argument(
        "--only",
        nargs="+",
        choices=TRACKERS,
        metavar="TRACKER",
        help=f"trackers to run, from {', '.join(TRACKERS)} (default: all)",
    )
    parser.add_argument("--repeats", type=int, default=30, help="timed runs (default: 30)")
    parser.add_argument(
        "--data",
        type=Path,
        default=None,
        help="shared data folder (default: $AVTRACK_SHARED_DATA or ../shared/data)",
    )
    parser.add_argument("--markdown", type=Path, metavar="OUT.md", help="also write the table")
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error(f"--repeats must be >= 1, got {args.repeats}")

    data = args.data if args.data is not None else shared_data_dir()
    det_path = data / "mot15" / SEQUENCE / "det" / "det.txt"
    gt_path = data / "mot15" / SEQUENCE / "gt" / "gt.txt"
    for p in (det_path, gt_path):
        if not p.is_file():
            print(f"bench_mot: {p} not found (set AVTRACK_SHARED_DATA or --data)", file=sys.stderr)
            return 2
    dets = read_mot(det_path, kind="det")
    gt = read_mot(gt_path, kind="gt")

    keys = [k for k in TRACKERS if k in (args.only or TRACKERS)]
    runs = run_all(keys, dets, gt, args.repeats)
    text = report(runs, machine(), args.repeats, det_path)
    print(text)
    if args.markdown is not None:
        with atomic_write(args.markdown) as fh:
            fh.write(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
