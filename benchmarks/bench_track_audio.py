"""Acoustic multi-speaker tracking: thesis Tables 5.1–5.3 on simulated scenes, and speed.

**Accuracy** (thesis Tables 5.1–5.3). Scenes are simulated with ``avtrack simulate`` (the
``locata-like`` and ``kinovis-like`` scenarios: 4-microphone NAO head with measured HRIRs,
recorded LOCATA / Kinovis-MST azimuth tracks, fan and diffuse noise), seeds ``--seeds``, and
cached in ``--workdir``. Every localizer of :data:`avtrack.localize.LOCALIZERS` computes its heat
maps (8 ms frames). All methods are scored on the same frames, one every 32 ms (the tracker
rate of thesis §5.5.2), after the first ``--skip`` seconds, with the protocol of thesis §5.5.1
(:func:`avtrack.metrics.doa_tracking.evaluate_tracks`: greedy matching, success within 15°,
MD / FA rates, MAE) plus identity switches and OSPA (order 2, cut-off 30°, LOCATA). Components
are summed over the scenes of a dataset.

* frame-wise methods (SRP-PHAT, PRP-REM, DPRTF-REM, DPRTF-EG and its variants): the peaks of
  each frame above a threshold; as in the thesis, the threshold is swept and the point of the
  ROC curve closest to the origin (MD, FA) is reported, per method and dataset;
* trackers on the heat maps of the default localizer ``dprtf-eg-smooth`` (``track-audio``'s and
  ``stream``'s pipeline) and, for reference, of ``dprtf-eg-fast`` (the same map without the
  smoother) and of the thesis's ``dprtf-eg``, with their default parameters for those maps
  (:func:`avtrack.doa.base.map_reading`; chosen on development seeds < 100, not the benchmark
  seeds), and with their activity threshold δ (eqs. 5.43 / 5.62) swept like the peak threshold
  (ROC-best δ, the same protocol as the frame-wise methods): ``VEM + EG``
  (:class:`~avtrack.doa.gauss.GaussDOATracker`, thesis §5.4) and ``vM-VEM + EG``
  (:class:`~avtrack.doa.vonmises.VonMisesDOATracker`, thesis §5.6), each on its default
  observations for the map (fast maps: the peaks at or above 1.15 times the uniform weight, 1.55
  on the smoothed ones; thesis maps: every candidate above the frame's median for the Gaussian
  tracker, the peaks above 1.44 times the uniform weight for the von Mises tracker), and the
  peer ``GM-PHD + EG`` (Stone Soup's GM-PHD tracker, :class:`~avtrack.doa.gmphd.GMPHDPeer`, on
  the peaks above ``PEAK_FLOOR`` = 0.05, the floor it was tuned with).

RF = (localization time + tracking time) / signal length, measured in this process with BLAS
on one thread.

**Speed.** (a) The trackers alone on 2000 frames of synthetic heat maps with 72 candidate
directions and 3 moving talkers (best of 3 after a warm-up pass, CPU time of this process):
frames per second, the target being ≥ 2000 frames/s; Stone Soup's GM-PHD on the peaks of the
same maps as the peer (the × GM-PHD column: speed ratio, less sensitive to the load of a
shared machine).
(b) The full pipeline on a simulated 4-microphone scene: DPRTF-EG localization at 8 ms plus one
tracker update every 32 ms; target RF ≤ 0.3.

Usage::

    python benchmarks/bench_track_audio.py                       # 5 seeds x 20 s, both parts
    python benchmarks/bench_track_audio.py --seeds 0 1 --duration 10 --no-speed
    python benchmarks/bench_track_audio.py --workdir /tmp/avt-bench --markdown track_audio.md
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, before NumPy loads BLAS

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import datetime as dt  # noqa: E402
import hashlib  # noqa: E402
import platform  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from _common import add_set_option, parse_set  # noqa: E402
from avtrack.audio.arrays import load_array  # noqa: E402
from avtrack.audio.recording import read_array_audio  # noqa: E402
from avtrack.doa.base import (  # noqa: E402
    DOASequence,
    circular_peaks,
    gate_maps,
    heatmap_sequence,
    make_tracker,
    map_reading,
)
from avtrack.doa.gmphd import GMPHDPeer  # noqa: E402
from avtrack.io.base import atomic_write  # noqa: E402
from avtrack.io.doa import DOATable, read_doa_csv  # noqa: E402
from avtrack.localize import LOCALIZERS, DirectionGrid, make_localizer  # noqa: E402
from avtrack.metrics.doa import estimate_lag  # noqa: E402
from avtrack.metrics.doa_tracking import TrackingScores, evaluate_tracks  # noqa: E402
from avtrack.simulate.heatmaps import synthetic_heatmaps  # noqa: E402

STEP = 4  # localizer frames per tracker frame (32 ms)
HOP_S = 0.008
METHODS = ("srp-phat", "prp-rem", "dprtf-rem", "dprtf-eg", "dprtf-eg-fast", "dprtf-eg-smooth")
LABELS = {
    "srp-phat": "SRP-PHAT",
    "prp-rem": "PRP-REM",
    "dprtf-rem": "DPRTF-REM",
    "dprtf-eg": "DPRTF-EG",
    "dprtf-eg-fast": "DPRTF-EG-fast",
    "dprtf-eg-static": "DPRTF-EG-static",
    "dprtf-eg-smooth": "DPRTF-EG-smooth",
}
#: localizers scored and read only when asked for (``--methods`` / ``--maps``)
OPTIONAL = ("dprtf-eg-static",)
TRACKERS = (
    ("VEM + EG", "gauss"),
    ("vM-VEM + EG", "vonmises"),
    ("GM-PHD + EG (Stone Soup)", "gmphd"),
)
#: Heat maps the trackers run on: the default pipeline's first, then the thesis's.
TRACKER_MAPS = ("dprtf-eg-smooth", "dprtf-eg-fast", "dprtf-eg")
#: localizer configurations other than the defaults (``--set``), by method
CONFIGS: dict[str, object] = {}
DATASETS = (
    ("locata-like", "Table 5.1 (LOCATA-like)"),
    ("kinovis-like", "Table 5.2 (Kinovis-like)"),
)


# --- data ------------------------------------------------------------------------------------
def scene_dir(workdir: Path, kind: str, seed: int, duration: float) -> Path:
    """Simulate (once) and return the scene directory."""
    d = workdir / f"{kind}-{seed}-{duration:g}s"
    if not (d / "gt" / "doa.csv").is_file():
        subprocess.run(
            [
                sys.executable,
                "-m",
                "avtrack",
                "simulate",
                kind,
                "-o",
                str(d),
                "--seed",
                str(seed),
                "--duration",
                str(duration),
                "-q",
            ],
            check=True,
        )
    return d


def heatmaps(d: Path, method: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, float]:
    """``(weights (T, D), time_s (T,), frames (T,), seconds of localization, duration)``,
    cached in the scene directory."""
    z = _heat_cache(d, method)
    return z["w"], z["t"], z["f"], float(z["elapsed"]), float(z["duration"])


def _heat_cache(d: Path, method: str):
    """The cached localizer run of a scene (``w``, ``t``, ``f``, ``elapsed``, ``duration`` and
    ``evidence``, which frames updated the map), computed once (per ``--set`` configuration)."""
    config = CONFIGS.get(method)
    tag = "" if config is None else "-" + hashlib.sha1(repr(config).encode()).hexdigest()[:10]
    cache = d / f"heat-{method}{tag}.npz"
    if cache.is_file():
        z = np.load(cache)
        if "evidence" in z:
            return z
    array = load_array(d / "array.json")
    x = read_array_audio(d / "audio.wav", array, quiet=True)
    loc = make_localizer(method, array, DirectionGrid.azimuths(), config)
    t0 = time.process_time()
    h = loc.run(x)
    elapsed = time.process_time() - t0
    duration = x.shape[1] / loc.fs
    np.savez(cache, w=h.weights, t=h.time_s, f=h.frames, elapsed=elapsed, duration=duration,
             evidence=loc.evidence(h.n_observations))
    return np.load(cache)


def peak_rows(w: np.ndarray, t: np.ndarray, f: np.ndarray, grid: np.ndarray) -> DOATable:
    """All peaks of the heat maps at the tracker frames (the last of each 32 ms block)."""
    last = np.arange(len(t) // STEP) * STEP + STEP - 1
    ww = w[last]
    r, c = np.nonzero(circular_peaks(ww))
    return DOATable(
        f[last][r],
        t[last][r],
        -np.ones(r.size, int),
        grid[c],
        np.zeros(r.size),
        ww[r, c],
        np.ones(r.size, bool),
    )


# --- evaluation ------------------------------------------------------------------------------
def score(
    tracks: DOATable, truth: DOATable, frame_times: np.ndarray, skip: float
) -> TrackingScores:
    keep = frame_times >= skip
    return evaluate_tracks(tracks, truth, frame_times=frame_times[keep])


MAX_SHIFT = 100  # frames of 8 ms searched by the lag measure, each way


def lag(tracks: DOATable, truth: DOATable, skip: float) -> float:
    """The estimates' lag in 8 ms frames (:func:`avtrack.metrics.doa.estimate_lag`: the time
    shift of the ground truth that minimises the MAE), after ``skip`` seconds; NaN when
    nothing succeeds."""
    res = estimate_lag(tracks, truth, max_shift_frames=MAX_SHIFT, time_range_s=(skip, np.inf))
    return float(res.lag_frames) if np.any(np.isfinite(res.mae)) else float("nan")


@dataclasses.dataclass
class Row:
    """One method on one dataset: summed scores, per-scene scores and lags, RF."""

    label: str
    total: TrackingScores
    per_scene: list[TrackingScores]
    lags: list[float]
    rf: float
    is_tracker: bool

    @property
    def lag(self) -> float:
        """Median of the scenes' lags (frames)."""
        return float(np.nanmedian(self.lags)) if np.any(np.isfinite(self.lags)) else np.nan


def frame_wise(scenes, method: str, skip: float) -> tuple[float, Row]:
    """ROC-best peak threshold of a localizer over the scenes: ``(threshold, row)``."""
    grid = DirectionGrid.azimuths().azimuth_deg
    rows, loc_time, duration = [], 0.0, 0.0
    for d, truth in scenes:
        w, t, f, elapsed, dur = heatmaps(d, method)
        last = np.arange(len(t) // STEP) * STEP + STEP - 1
        rows.append((peak_rows(w, t, f, grid), truth, t[last]))
        loc_time += elapsed
        duration += dur
    all_w = np.concatenate([r[0].weight for r in rows])
    thresholds = np.unique(np.quantile(all_w, np.linspace(0.0, 0.995, 60)))
    best = None
    for thr in thresholds:
        total = None
        for table, truth, ft in rows:
            s = score(table.select(table.weight >= thr), truth, ft, skip)
            total = s if total is None else total + s
        key = np.hypot(total.md_rate, total.fa_rate)
        if best is None or key < best[0]:
            best = (key, float(thr), total)
    thr = best[1]
    chosen = [(table.select(table.weight >= thr), truth, ft) for table, truth, ft in rows]
    per = [score(t, truth, ft, skip) for t, truth, ft in chosen]
    lags = [lag(t, truth, skip) for t, truth, _ in chosen]
    label = f"{LABELS[method]} (peaks >= {thr:.3g})"
    return thr, Row(label, best[2], per, lags, loc_time / duration, False)


def tracked(
    scenes,
    tracker: str,
    skip: float,
    activity_threshold: float | None = None,
    label: str = "",
    method: str = "dprtf-eg-fast",
) -> Row:
    """A tracker on ``method``'s heat maps, read as :func:`map_reading` says (``row.rf``: the
    pipeline's RF)."""
    grid = DirectionGrid.azimuths().azimuth_deg
    total, loc_time, track_time, duration, n_frames = None, 0.0, 0.0, 0.0, 0
    per: list[TrackingScores] = []
    lags: list[float] = []
    for d, truth in scenes:
        w, t, f, elapsed, dur = heatmaps(d, method)
        if tracker == "gmphd":
            seq = heatmap_sequence(w, grid, f, t, STEP, "peaks")
            trk = GMPHDPeer(frame_period_s=STEP * HOP_S)
        else:
            reading = map_reading(tracker, method)
            w = gate_maps(w, _heat_cache(d, method)["evidence"], reading.evidence_hold_s,
                          HOP_S)  # as DOAStream reads the maps
            seq = heatmap_sequence(w, grid, f, t, STEP, reading.observations,
                                   uniform_floor=reading.uniform_floor)  # fmt: skip
            config = reading.config
            if activity_threshold is not None:
                config = dataclasses.replace(config, activity_threshold=activity_threshold)
            trk = make_tracker(tracker, config, frame_period_s=STEP * HOP_S)
        t0 = time.process_time()
        tracks = trk.run(seq)
        track_time += time.process_time() - t0
        s = score(tracks, truth, seq.time_s, skip)
        total = s if total is None else total + s
        per.append(s)
        lags.append(lag(tracks, truth, skip))
        loc_time += elapsed
        duration += dur
        n_frames += len(seq)
    return Row(label or tracker, total, per, lags, (loc_time + track_time) / duration, True)


def tracked_roc(
    scenes, tracker: str, skip: float, label: str, method: str = "dprtf-eg-fast"
) -> tuple[float, Row]:
    """The tracker's own ROC: its activity threshold δ (eqs. 5.43 / 5.62) swept like the peak
    threshold of the frame-wise methods; ``(δ, row)`` at the point closest to the origin
    (MD, FA)."""
    default = map_reading(tracker, method).config.activity_threshold
    best = None
    for thr in default * np.geomspace(0.125, 2.0, 9):
        row = tracked(scenes, tracker, skip, float(thr), method=method)
        key = np.hypot(row.total.md_rate, row.total.fa_rate)
        if best is None or key < best[0]:
            best = (key, float(thr), row)
    row = best[2]
    row.label = f"{label} (ROC-best δ = {best[1]:.3g})"
    return best[1], row


def _cells(s: TrackingScores) -> str:
    d = s.as_dict()
    return f"{d['MD%']:.1f} | {d['FA%']:.1f} | {d['MAE']:.2f}"


def accuracy(args) -> list[str]:
    out = []
    results: dict[str, list[Row]] = {}
    for kind, title in DATASETS:
        scenes = []
        for seed in args.seeds:
            d = scene_dir(args.workdir, kind, seed, args.duration)
            scenes.append((d, read_doa_csv(d / "gt" / "doa.csv")))
        rows: list[Row] = []
        for m in args.methods:
            if m not in LOCALIZERS:
                continue
            rows.append(frame_wise(scenes, m, args.skip)[1])
            print(f"  {kind} {m}: done", file=sys.stderr, flush=True)
        for method in args.maps:
            for label, name in TRACKERS:
                if name not in args.trackers:
                    continue
                label = f"{label} ({LABELS[method]} maps)"
                rows.append(tracked(scenes, name, args.skip, label=label, method=method))
                if name != "gmphd" and not args.no_roc:
                    rows.append(tracked_roc(scenes, name, args.skip, label, method)[1])
                print(f"  {kind} {method} {name}: done", file=sys.stderr, flush=True)
        results[kind] = rows
        out += [
            f"### {title}: seeds {', '.join(map(str, args.seeds))}, {args.duration:g} s each",
            "",
            "| method | MD rate (%) | FA rate (%) | MAE (°) | IDs | OSPA (°) | lag (frames) "
            "| RF |",
            "|---|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for r in rows:
            ids = str(r.total.id_switches) if r.is_tracker else "-"
            out.append(
                f"| {r.label} | {_cells(r.total)} | {ids} | {r.total.ospa:.2f} | {r.lag:.0f} "
                f"| {r.rf:.3f} |"
            )
        out += [
            "",
            f"Per seed ({title}): MD / FA / MAE, OSPA, lag (8 ms frames: the shift of the "
            "ground truth that minimises the MAE; the table's lag is their median).",
            "",
            "| method | " + " | ".join(f"seed {s}" for s in args.seeds) + " |",
            "|---|" + "---|" * len(args.seeds),
        ]
        for r in rows:
            cells = [
                f"{_cells(s).replace(' | ', ' / ')}, {s.ospa:.2f}, {lg:.0f}"
                for s, lg in zip(r.per_scene, r.lags, strict=True)
            ]
            out.append(f"| {r.label} | " + " | ".join(cells) + " |")
        out.append("")
    out += [
        "### Table 5.3 (LOCATA-like): trackers on the same DPRTF-EG observations (each map)",
        "",
        "| method | MD (%) | FA (%) | MAE (°) | IDs | OSPA (°) | lag (frames) |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for r in results["locata-like"]:
        if r.is_tracker:
            out.append(
                f"| {r.label} | {_cells(r.total)} | {r.total.id_switches} | "
                f"{r.total.ospa:.2f} | {r.lag:.0f} |"
            )
    out.append("")
    return out


# --- speed -----------------------------------------------------------------------------------
def tracker_speed(n_frames: int = 2000) -> list[str]:
    rng = np.random.default_rng(0)
    grid = DirectionGrid.azimuths().azimuth_deg
    t = np.arange(n_frames) * STEP * HOP_S
    az = np.stack([-120 + 15 * t, 10 + 5 * np.sin(t), 150 - 10 * t], axis=1)
    az = np.mod(az + 180, 360) - 180
    w = synthetic_heatmaps(az, np.ones(az.shape, bool), grid, rng)
    seq_all = heatmap_sequence(w, grid, time_s=t, step=1, observations="all")
    seq_above = heatmap_sequence(w, grid, time_s=t, step=1, observations="above-median")
    seq_peaks = heatmap_sequence(w, grid, time_s=t, step=1, observations="peaks")
    seq_over = heatmap_sequence(w, grid, time_s=t, step=1, observations="peaks-over-uniform")
    fast = {name: map_reading(name, "dprtf-eg-fast") for name in ("gauss", "vonmises")}
    seq_fast = heatmap_sequence(w, grid, time_s=t, step=1, observations="peaks-over-uniform",
                                uniform_floor=fast["gauss"].uniform_floor)  # fmt: skip
    out = [
        "| tracker | observations per frame | frames/s | × GM-PHD | mean tracks |",
        "|---|---:|---:|---:|---:|",
    ]
    rows = []
    cases = [
        ("gauss (VEM + EG, fast-map default: peaks >= 1.15/D)", "gauss", seq_fast,
         fast["gauss"].config),
        ("gauss (VEM + EG, above-median: dprtf-eg maps' default)", "gauss", seq_above, None),
        ("gauss (VEM + EG, peaks-over-uniform)", "gauss", seq_over, None),
        ("gauss (VEM + EG, all)", "gauss", seq_all, None),
        ("vonmises (vM-VEM)", "vonmises", seq_all, None),
        ("vonmises (vM-VEM, fast-map default: peaks >= 1.15/D)", "vonmises", seq_fast,
         fast["vonmises"].config),
        ("vonmises (vM-VEM, peaks-over-uniform: dprtf-eg maps' default)", "vonmises",
         seq_over, None),
        ("GM-PHD (Stone Soup)", "gmphd", seq_peaks, None),
    ]  # fmt: skip
    for label, name, seq, config in cases:
        trk = (GMPHDPeer(frame_period_s=STEP * HOP_S) if name == "gmphd"
               else make_tracker(name, config))  # fmt: skip
        sub = (
            seq
            if name != "gmphd"
            else DOASequence(
                seq.frames[:300], seq.time_s[:300], seq.azimuth_deg[:300], seq.weight[:300]
            )
        )
        best = np.inf
        if name != "gmphd":
            trk.run(sub)  # warm-up (the first pass in a process runs up to 30% slower)
        for _ in range(3 if name != "gmphd" else 1):
            t0 = time.process_time()
            tracks = trk.run(sub)
            best = min(best, time.process_time() - t0)
        n_obs = np.mean([a.size for a in sub.azimuth_deg])
        rows.append((label, n_obs, len(sub) / best, len(tracks) / len(sub)))
    peer = rows[-1][2]  # GM-PHD, timed in the same process: speed as a ratio to a peer
    for label, n_obs, fps, mean_tracks in rows:
        out.append(f"| {label} | {n_obs:.1f} | {fps:.0f} | {fps / peer:.1f} | {mean_tracks:.2f} |")
    return out


def pipeline_speed(workdir: Path, duration: float) -> list[str]:
    d = scene_dir(workdir, "locata-like", 0, duration)
    array = load_array(d / "array.json")
    x = read_array_audio(d / "audio.wav", array, quiet=True)
    grid = DirectionGrid.azimuths()
    out = [
        "| pipeline (4 mics, localizer + tracker every 32 ms) | localization RF | "
        "tracking RF | total RF |",
        "|---|---:|---:|---:|",
    ]
    # warm-up: the first DP-RTF run in a process loads (or compiles) its Numba kernel
    warm = make_localizer(TRACKER_MAPS[0], array, grid, CONFIGS.get(TRACKER_MAPS[0]))
    warm.run(x[:, : int(warm.fs)])
    for method in TRACKER_MAPS:
        for name in ("gauss", "vonmises"):
            loc = make_localizer(method, array, grid, CONFIGS.get(method))
            t0 = time.process_time()
            h = loc.run(x)
            t_loc = time.process_time() - t0
            t0 = time.process_time()
            reading = map_reading(name, method)
            seq = heatmap_sequence(
                h.weights, grid.azimuth_deg, h.frames, h.time_s, STEP, reading.observations,
                uniform_floor=reading.uniform_floor,
            )
            make_tracker(name, reading.config, frame_period_s=STEP * HOP_S).run(seq)
            t_trk = time.process_time() - t0
            dur = x.shape[1] / loc.fs
            out.append(
                f"| {method} + {name} | {t_loc / dur:.3f} | {t_trk / dur:.4f} | "
                f"{(t_loc + t_trk) / dur:.3f} |"
            )
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    p.add_argument("--duration", type=float, default=20.0, help="seconds per scene")
    p.add_argument("--skip", type=float, default=1.0, help="unscored seconds at the start")
    p.add_argument("--workdir", type=Path, help="scene cache (default: a temporary folder)")
    p.add_argument("--no-speed", action="store_true")
    p.add_argument("--no-accuracy", action="store_true")
    p.add_argument("--no-roc", action="store_true", help="skip the trackers' δ sweeps")
    p.add_argument("--markdown", type=Path, help="also write the tables to this file")
    p.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS + OPTIONAL,
                   help="frame-wise methods to score (default: all)")
    p.add_argument("--maps", nargs="+", default=list(TRACKER_MAPS),
                   choices=TRACKER_MAPS + OPTIONAL,
                   help="heat maps the trackers run on (default: both)")
    p.add_argument("--trackers", nargs="+", default=[n for _, n in TRACKERS],
                   choices=[n for _, n in TRACKERS], help="trackers to score (default: all)")
    add_set_option(p, "for its scores and the maps the trackers read")
    args = p.parse_args(argv)
    CONFIGS.update(parse_set(p, args.set))
    tmp = None
    if args.workdir is None:
        tmp = tempfile.TemporaryDirectory(prefix="avtrack-bench-")
        args.workdir = Path(tmp.name)
    args.workdir.mkdir(parents=True, exist_ok=True)
    lines = [
        f"## Acoustic tracking ({dt.date.today()}, {platform.machine()}, "
        f"{platform.processor() or platform.platform()}, Python "
        f"{platform.python_version()}, BLAS threads 1)",
        "",
        f"Command: `python benchmarks/bench_track_audio.py {' '.join(sys.argv[1:])}`",
        "",
    ]
    if not args.no_accuracy:
        lines += accuracy(args)
    if not args.no_speed:
        lines += [
            "### Speed",
            "",
            *tracker_speed(),
            "",
            *pipeline_speed(args.workdir, args.duration),
            "",
        ]
    text = "\n".join(lines)
    print(text)
    if args.markdown is not None:
        with atomic_write(args.markdown) as fh:
            fh.write(text + "\n")
    if tmp is not None:
        tmp.cleanup()
    return 0


if __name__ == "__main__":
    sys.exit(main())
