"""AV-LPF-SMC-PHD vs AV-NPF-SMC-PHD on the shared AV16.3 sequences (Liu et al.,
labelled non-zero particle flow SMC-PHD filtering, Tables 1–2).

Both filters (:mod:`avtrack.phd`) run on the same measurements, in the same process, with BLAS
limited to one thread, on the six sequence / camera pairs of ``../shared/data/av16.3``
(sequences 24 and 45, cameras 1–3), for ``--seeds`` seeds each (Liu et al.: 10):

- audio: the DOA measurements ``Z_doa`` of the files, projected into the image as DOA lines;
- visual: the real face detections for sequence 45 camera 1; for the other five pairs, face
  detections synthesised from ``posGT`` by :class:`~avtrack.phd.SyntheticFaceDetector`
  (misses in bursts, noise and clutter measured on the real detector), drawn anew for every
  seed. For a given seed both filters see identical measurements.

Scores: OSPA (order 2, cut-off 50 px, Euclidean in pixels) against ``posGT`` on every frame,
averaged over the frames of a sequence, then over the seeds (Table 1), beside OSPA-T (order 2,
cut-off 65 px, label penalty 25 px, :func:`avtrack.metrics.ospa.ospa_t`) and the number of
distinct track labels per true person; the mean effective
sample size, the number of resamplings and the running time of the filter steps (Table 2, for
sequence 45 camera 1 as in the seed, plus the means over the six pairs).

Optionally (``--vem``) a third row: the visual VEM tracker (:class:`avtrack.visual.ovbt.
OVBTracker`, thesis §3.1) on the same visual measurements, as fixed-size face boxes (no audio).

Usage::

    python benchmarks/bench_phd.py                      # 10 seeds, both filters
    python benchmarks/bench_phd.py --seeds 2 --pairs 45:1 24:1
    python benchmarks/bench_phd.py --vem
    python benchmarks/bench_phd.py --vem --clutter-rate 0.5  # + false alarms, DOA outliers
    python benchmarks/bench_phd.py --set coast_frames=6 birth_mass=0.1  # PHDConfig fields
    python benchmarks/bench_phd.py --set marginal_weights=false resample_rule=label
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, before NumPy loads BLAS

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from _common import SHARED_DATA  # noqa: E402
from avtrack.io.av163 import load_av163  # noqa: E402
from avtrack.metrics.ospa import ospa_sequence, ospa_t  # noqa: E402
from avtrack.phd import PHD_FILTERS, PHDConfig  # noqa: E402
from avtrack.phd.likelihood import (  # noqa: E402
    add_clutter,
    av163_frames,
    av163_truth,
    av163_visual,
)

PAIRS = [(24, 1), (24, 2), (24, 3), (45, 1), (45, 2), (45, 3)]
CUTOFF = 50.0
ORDER = 2
#: OSPA-T as the SMC-PHD authors' released evaluation: order 2, cut-off 65 px, penalty 25 px.
T_CUTOFF, T_PENALTY = 65.0, 25.0


def labelled_truth(seq) -> list[np.ndarray]:
    """True tracks per frame for OSPA-T: ``(P, 2)`` with NaN rows for absent persons."""
    return [np.where(seq.present[t][:, None], seq.positions[:, t], np.nan)
            for t in range(seq.n_frames)]


def scores(ids_pos: list[tuple[np.ndarray, np.ndarray]], seq) -> tuple[float, float, float]:
    """OSPA (50 px), OSPA-T (65 px, 25 px) and distinct labels per true person; estimates
    without identity (id < 0) are each a track of their own."""
    nxt = max((int(i.max()) for i, _ in ids_pos if len(i)), default=0) + 1
    est = []
    for ids, pos in ids_pos:
        ids = np.asarray(ids, dtype=np.int64).copy()
        neg = ids < 0
        ids[neg] = nxt + np.arange(int(neg.sum()))
        nxt += int(neg.sum())
        est.append((ids, pos))
    o = ospa_sequence([p for _, p in ids_pos], av163_truth(seq), CUTOFF, ORDER)[:, 0].mean()
    ot = ospa_t(est, labelled_truth(seq), T_CUTOFF, ORDER, T_PENALTY).mean
    n_labels = len({int(i) for ids, _ in est for i in ids})
    persons = int(np.sum(seq.present.any(axis=0)))
    return float(o), float(ot), n_labels / max(persons, 1)
FACE_BOX = (18.0, 25.0)  # median face box of seq45 cam1 (w, h), for the VEM row


def run_vem(
    visual: list[np.ndarray], n_frames: int
) -> tuple[list[tuple[np.ndarray, np.ndarray]], float]:
    """The OVBT visual VEM tracker on fixed-size boxes around the visual points."""
    from avtrack.visual.ovbt import OVBTracker

    w, h = FACE_BOX
    tracker = OVBTracker(image_size=(360, 288))
    out = []
    t0 = time.perf_counter()
    for k in range(n_frames):
        z = visual[k]
        boxes = (
            np.column_stack(
                [z[:, 0] - w / 2, z[:, 1] - 0.8 * h, np.full(len(z), w), np.full(len(z), h)]
            )
            if len(z)
            else np.zeros((0, 4))
        )
        res = tracker.step(boxes, np.ones(len(z)))
        b = np.asarray(res.boxes, dtype=float).reshape(-1, 4)
        out.append((np.asarray(res.ids, dtype=np.int64),
                    np.column_stack([b[:, 0] + b[:, 2] / 2, b[:, 1] + 0.8 * b[:, 3]])))
    return out, time.perf_counter() - t0


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--data",
        type=Path,
        default=SHARED_DATA / "av16.3",
        help="folder of the AV16.3 MAT files",
    )
    ap.add_argument("--seeds", type=int, default=10, help="seeds per sequence (default 10)")
    ap.add_argument(
        "--pairs",
        nargs="*",
        default=None,
        metavar="SEQ:CAM",
        help="sequence:camera pairs (default: all six)",
    )
    ap.add_argument("--filters", default="lpf,npf", help="comma-separated filter names")
    ap.add_argument("--vem", action="store_true", help="add the visual VEM (OVBT) row")
    ap.add_argument(
        "--clutter-rate",
        type=float,
        default=0.0,
        help="synthetic visual false alarms per frame, plus as many DOA outliers (uniform "
        "azimuth) per frame; the filters' clutter_visual / clutter_audio grow by the same rate",
    )
    ap.add_argument(
        "--set",
        nargs="*",
        default=[],
        metavar="FIELD=VALUE",
        help="PHDConfig fields (numbers), e.g. coast_frames=20 diffusion=0",
    )
    return ap


def _config(args: argparse.Namespace) -> tuple[PHDConfig, dict]:
    """The filters' configuration: the defaults, ``--set`` and the clutter rate; and the
    overrides."""
    config = PHDConfig()
    over = {}
    for item in args.set:
        k, v = item.split("=", 1)
        cur = getattr(config, k)
        if isinstance(cur, bool):
            over[k] = v.lower() in ("1", "true", "yes")
        else:
            over[k] = v if isinstance(cur, str) else int(v) if isinstance(cur, int) else float(v)
    if args.clutter_rate:
        over.setdefault("clutter_visual", config.clutter_visual + args.clutter_rate)
        over.setdefault("clutter_audio", config.clutter_audio + args.clutter_rate)
    config = dataclasses.replace(config, **over)

    return config, over


def _run(args: argparse.Namespace, pairs: list, names: list[str], config: PHDConfig
         ) -> tuple[dict, dict]:
    """Every filter (and the visual VEM) on every pair and seed: ``results[name][pair]``, a
    list of (OSPA, ESS, resamplings, time, OSPA-T, labels) per seed, and each pair's visual
    source."""
    # results[name][(seq, cam)] = list of (ospa, ess, resamplings, time) per seed
    results: dict[str, dict[tuple[int, int], list[tuple[float, ...]]]] = {
        n: {p: [] for p in pairs} for n in [*names, *(["vem"] if args.vem else [])]
    }
    sources = {}
    for seq_no, cam in pairs:
        seq = load_av163(args.data, seq_no, cam)

        for s in range(args.seeds):
            visual, sources[seq_no, cam] = av163_visual(
                args.data, seq, rng=np.random.default_rng([s, seq_no, cam])
            )
            doa = list(seq.z_doa)
            if args.clutter_rate:
                visual, doa = add_clutter(visual, doa, args.clutter_rate, args.clutter_rate,
                                          np.random.default_rng([s, seq_no, cam, 7]))
            frames = av163_frames(seq, visual, config.sigma_audio, config.gate, doa_deg=doa)
            for name in names:
                res = PHD_FILTERS[name](config, seed=s).run(frames)
                o, ot, lab = scores([(e.ids, e.positions) for e in res.estimates], seq)
                results[name][seq_no, cam].append(
                    (o, res.mean_ess, res.n_resamplings, res.time_s, ot, lab))
            if args.vem and (s == 0 or sources[seq_no, cam] == "synthetic" or args.clutter_rate):
                est, t = run_vem(visual, seq.n_frames)
                o, ot, lab = scores(est, seq)
                results["vem"][seq_no, cam].append((o, np.nan, np.nan, t, ot, lab))
            print(
                f"# {seq_no} ({cam}) seed {s}: "
                + ", ".join(
                    f"{n} {results[n][seq_no, cam][-1][0]:.2f}"
                    for n in results
                    if results[n][seq_no, cam]
                ),
                file=sys.stderr,
                flush=True,
            )
    return results, sources


def _report(args: argparse.Namespace, pairs: list, results: dict, sources: dict, over: dict
            ) -> None:
    """Print Tables 1 and 2."""
    label = {"lpf": "LPF", "npf": "NPF", "vem": "VEM (OVBT, visual)"}
    cols = list(results)
    print(
        f"Machine: {platform.processor() or platform.machine()}, Python "
        f"{platform.python_version()}, NumPy {np.__version__}, one BLAS thread; "
        f"{args.seeds} seeds; OSPA order {ORDER}, cut-off {CUTOFF:g} px; OSPA-T order "
        f"{ORDER}, cut-off {T_CUTOFF:g} px, label penalty {T_PENALTY:g} px; "
        f"clutter rate {args.clutter_rate:g}/frame; config overrides {over}\n"
    )
    print("Table 1 — OSPA / OSPA-T (px) / labels per true person, mean over frames and seeds\n")
    print("| Seq (Cam) | visual | " + " | ".join(label[c] for c in cols) + " |")
    print("|---|---|" + "---|" * len(cols))
    means = {c: [] for c in cols}
    t_means = {c: [] for c in cols}
    l_means = {c: [] for c in cols}
    for p in pairs:
        row = []
        for c in cols:
            v = np.mean([r[0] for r in results[c][p]])
            vt = np.mean([r[4] for r in results[c][p]])
            lab = np.mean([r[5] for r in results[c][p]])
            means[c].append(v)
            t_means[c].append(vt)
            l_means[c].append(lab)
            row.append(f"{v:.2f} / {vt:.2f} / {lab:.1f}")
        print(f"| {p[0]} ({p[1]}) | {sources[p]} | " + " | ".join(row) + " |")
    print("| Average | | " + " | ".join(
        f"{np.mean(means[c]):.2f} / {np.mean(t_means[c]):.2f} / {np.mean(l_means[c]):.1f}"
        for c in cols) + " |")
    if "lpf" in cols and "npf" in cols:
        print(f"\nLPF / NPF average OSPA: {np.mean(means['lpf']) / np.mean(means['npf']):.3f}")

    print("\nTable 2 — ESS, resamplings, running time (s), mean over seeds\n")
    print("| Filter | pair | ESS | Resampling | Time (s) | frames |")
    print("|---|---|---|---|---|---|")
    for c in [c for c in cols if c != "vem"]:
        for p in pairs:
            r = np.array(results[c][p], dtype=float)
            print(f"| {label[c]} | {p[0]} ({p[1]}) | {r[:, 1].mean():.1f} | {r[:, 2].mean():.1f} "
                  f"| {r[:, 3].mean():.2f} | {load_av163(args.data, *p).n_frames} |")
    n_frames = {p: load_av163(args.data, *p).n_frames for p in pairs}

    def fmt(v: float, digits: int) -> str:
        return "–" if np.isnan(v) else f"{v:.{digits}f}"

    for c in cols:
        rows = [("45 (1)", results[c][p]) for p in pairs if p == (45, 1)]
        rows.append((f"mean of {len(pairs)}", [x for p in pairs for x in results[c][p]]))
        for where, runs in rows:
            r = np.array(runs, dtype=float)
            n = n_frames[45, 1] if where == "45 (1)" else np.mean(list(n_frames.values()))
            print(
                f"| {label[c]} | {where} | {fmt(r[:, 1].mean(), 1)} | {fmt(r[:, 2].mean(), 1)} "
                f"| {r[:, 3].mean():.2f} | {n:.0f} |"
            )
    if "lpf" in cols and "npf" in cols:
        t_l = np.mean([x[3] for p in pairs for x in results["lpf"][p]])
        t_n = np.mean([x[3] for p in pairs for x in results["npf"][p]])
        print(f"\nLPF / NPF running time (all pairs): {t_l / t_n:.3f}")
        for p in pairs:
            if p[0] == 45:
                t = np.mean([x[3] for x in results["lpf"][p]])
                print(f"LPF time, sequence 45 camera {p[1]} ({n_frames[p]} frames): {t:.2f} s")


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if not args.data.is_dir():
        print(f"bench_phd: AV16.3 folder not found: {args.data}", file=sys.stderr)
        return 2
    pairs = PAIRS if not args.pairs else [tuple(map(int, p.split(":"))) for p in args.pairs]
    config, over = _config(args)
    results, sources = _run(args, pairs, args.filters.split(","), config)
    _report(args, pairs, results, sources, over)
    return 0

if __name__ == "__main__":
    sys.exit(main())
