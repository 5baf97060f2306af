"""The visual tracker on all six shared MOT15 sequences, beside SORT, ByteTrack, OC-SORT,
BoT-SORT, C-BIoU and McByte.

Every tracker gets SORT's public Faster R-CNN detections of ADL-Rundle-6, ETH-Bahnhof,
KITTI-13, PETS09-S2L1, TUD-Campus and Venice-2 (``../shared/data/mot15``) and is scored by
:func:`avtrack.metrics.evaluate_mot` (MOT15 preprocessing, sequence length and image size from
``seqinfo.ini``). Peers run as ``benchmarks/bench_mot.py`` runs them, with their defaults
(PyPI ``trackers``: SORT, ByteTrack, OC-SORT, BoT-SORT, C-BIoU, McByte, on the boxes alone;
Bewley's original SORT, ``sort-tracker-py``).
avtrack runs with its defaults (given the frame rate from ``seqinfo.ini``) and with one default
taken out at a time (``CANDIDATES``). Combined rows: MOTA from FP, FN and IDSW summed over the
sequences and divided by the summed ground-truth boxes; mean IDF1 and HOTA; "IDF1 (summed)"
from the summed identity counts (rebuilt from IDR and IDP).

Usage::

    python benchmarks/bench_mot15.py          # about a minute
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import itertools  # noqa: E402
import sys  # noqa: E402
from dataclasses import replace  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from avtrack.io.datasets import read_seqinfo  # noqa: E402
from avtrack.io.mot import read_mot  # noqa: E402
from avtrack.metrics.mot import evaluate_mot  # noqa: E402
from avtrack.visual.ovbt import OVBTConfig, track_mot  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_mot  # noqa: E402

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "mot15"
SEQS = ["ADL-Rundle-6", "ETH-Bahnhof", "KITTI-13", "PETS09-S2L1", "TUD-Campus", "Venice-2"]
PEERS = [("sort-bewley", "SORT (Bewley, original)"), ("sort", "trackers SORT"),
         ("bytetrack", "trackers ByteTrack"), ("ocsort", "trackers OC-SORT"),
         ("botsort", "trackers BoT-SORT"), ("cbiou", "trackers C-BIoU"),
         ("mcbyte", "trackers McByte")]
#: label -> (OVBTConfig, whether the tracker is told the sequence's frame rate). The defaults
#: get the frame rate (seqinfo.ini), as ``avtrack track-mot`` does; the other rows take one
#: default out at a time.
CANDIDATES = {
    "avtrack defaults": (OVBTConfig(), True),
    "avtrack defaults, frame rate not given": (OVBTConfig(), False),
    "avtrack defaults, weak detections show targets": (
        replace(OVBTConfig(), weak_evidence=1.0), True),
    "avtrack defaults, weak detections never show targets": (
        replace(OVBTConfig(), weak_evidence=0.0), True),
    "avtrack defaults, velocity noise not scaled": (
        replace(OVBTConfig(), vel_rate_exponent=0.0), True),
    "avtrack defaults, no score split": (replace(OVBTConfig(), birth_score_split=False), True),
    "avtrack defaults, online output (no rows for a birth's earlier frames)": (
        replace(OVBTConfig(), birth_sequence=False), True),
}
#: the defaults chosen leave one sequence out (``--loso``): name -> values tried
GRID = {"weak_evidence": (0.0, 0.2, 0.5, 1.0), "vel_rate_exponent": (0.0, 0.5, 1.0)}


def load(seq: str) -> dict:
    info = read_seqinfo(DATA / seq / "seqinfo.ini")
    return {"dets": read_mot(DATA / seq / "det" / "det.txt", kind="det"),
            "gt": read_mot(DATA / seq / "gt" / "gt.txt", kind="gt"),
            "fps": float(info["frame_rate"]), "n": int(info["length"]),
            "size": (int(info["width"]), int(info["height"]))}


def row(s) -> dict:
    idtp = s.IDR / 100 * s.n_gt_dets
    n_res = idtp / (s.IDP / 100) if s.IDP > 0 else 0.0
    return {"MOTA": s.MOTA, "IDF1": s.IDF1, "HOTA": s.HOTA, "FP": s.FP, "FN": s.FN,
            "IDSW": s.IDSW, "n_gt": s.n_gt_dets, "idtp": idtp, "n_res": n_res}


def combine(rows: list[dict]) -> dict:
    g = sum(r["n_gt"] for r in rows)
    fp, fn, sw = (sum(r[k] for r in rows) for k in ("FP", "FN", "IDSW"))
    idtp, nres = sum(r["idtp"] for r in rows), sum(r["n_res"] for r in rows)
    return {"MOTA": 100 * (1 - (fp + fn + sw) / g),
            "IDF1": float(np.mean([r["IDF1"] for r in rows])),
            "HOTA": float(np.mean([r["HOTA"] for r in rows])), "FP": fp, "FN": fn, "IDSW": sw,
            "IDF1w": 100 * 2 * idtp / (g + nres)}


def avtrack_rows(data: dict, config: OVBTConfig, with_fps: bool = True) -> dict[str, dict]:
    return {s: row(evaluate_mot(d["gt"], track_mot(
        d["dets"], None, config, d["size"], d["n"], d["fps"] if with_fps else None),
        n_frames=d["n"])) for s, d in data.items()}


def loso(data: dict) -> None:
    """Print the leave-one-sequence-out choice of the ``GRID`` defaults."""
    points = [dict(zip(GRID, values, strict=True)) for values in itertools.product(
        *GRID.values())]
    runs = [avtrack_rows(data, replace(OVBTConfig(), **pt)) for pt in points]
    default = avtrack_rows(data, OVBTConfig())
    names = ", ".join(GRID)
    print(f"\nLeave one sequence out ({names} over {len(points)} grid points; chosen by "
          f"combined MOTA + mean IDF1 + mean HOTA on the other five)\n\n| left out | chosen "
          f"({names}) | left out, chosen | left out, defaults |\n|---|---|---|---|")
    for held in SEQS:
        rest = [s for s in SEQS if s != held]
        best = max(range(len(points)), key=lambda i: sum(
            combine([runs[i][s] for s in rest])[k] for k in ("MOTA", "IDF1", "HOTA")))
        got, ref = runs[best][held], default[held]
        print(f"| {held} | {', '.join(str(v) for v in points[best].values())} | "
              f"{got['MOTA']:.1f} / {got['IDF1']:.1f} / {got['HOTA']:.1f} | "
              f"{ref['MOTA']:.1f} / {ref['IDF1']:.1f} / {ref['HOTA']:.1f} |")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--loso", action="store_true",
                        help="also choose the GRID defaults leave one sequence out")
    args = parser.parse_args(argv)
    data = {s: load(s) for s in SEQS}
    runs: dict[str, dict[str, dict]] = {}
    for key, label in PEERS:
        runs[label] = {}
        for s, d in data.items():
            if key == "sort-bewley":
                loop, to_mot = bench_mot.bewley_sort_runner(d["dets"])
            else:
                loop, to_mot = bench_mot.peer_runner(key, d["dets"])
            runs[label][s] = row(evaluate_mot(d["gt"], to_mot(loop()), n_frames=d["n"]))
    for label, (config, with_fps) in CANDIDATES.items():
        runs[label] = avtrack_rows(data, config, with_fps)
    print("| tracker | " + " | ".join(f"{s} ({data[s]['fps']:.0f} fps)" for s in SEQS) + " |")
    print("|---|" + "---|" * len(SEQS))
    for label, rows in runs.items():
        cells = [f"{r['MOTA']:.1f} / {r['IDF1']:.1f} / {r['HOTA']:.1f}" for r in
                 (rows[s] for s in SEQS)]
        print(f"| {label} | " + " | ".join(cells) + " |")
    for title, seqs in (("six sequences", SEQS),
                        ("five without TUD-Campus", [s for s in SEQS if s != "TUD-Campus"])):
        print(f"\nCombined, {title}\n\n| tracker | MOTA | mean IDF1 | mean HOTA | FP | FN | IDSW "
              f"| IDF1 (summed) |\n|---|---|---|---|---|---|---|---|")
        for label, rows in runs.items():
            c = combine([rows[s] for s in seqs])
            print(f"| {label} | {c['MOTA']:.2f} | {c['IDF1']:.2f} | {c['HOTA']:.2f} | {c['FP']} "
                  f"| {c['FN']} | {c['IDSW']} | {c['IDF1w']:.1f} |")
    if args.loso:
        loso(data)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
