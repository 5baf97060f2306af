"""Speaker turns of ``track-av`` with and without the voice activity detector, on simulated
walkouts (full view, as ``bench_persons.py``, and 40 % view) and meetings at 40 % view.

Per scene: DER scored as DIHARD does (no collar, overlapped speech scored), DER with a 0.5 s
collar (0.25 s each side of every reference boundary), and speakers found against the truth,
for the turns from the tracker's speaking probability alone (``--no-vad``'s path, the turns
before the detector) and for the turns fused with the voice activity detector
(:mod:`avtrack.av.vad`). Means over scenes and the pooled DER are printed per suite.

Scenes and their localizer heat maps are cached in ``--work`` (simulated the first time).

Usage::

    python benchmarks/bench_vad.py --work /tmp/avt/bench-vad [--seeds 0-19]
        [--suites walkout,meeting-pfov]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, before NumPy loads BLAS

import argparse  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from _common import parse_seeds  # noqa: E402
from _scenes import scene_dir  # noqa: E402
from avtrack.audio.arrays import load_array  # noqa: E402
from avtrack.av.persons_scene import (  # noqa: E402
    PERSONS_LOCALIZER,
    audio_peak_floor,
    audio_peaks,
    grid_span,
    localizer_grid,
    scene_heat_maps,
    track_scene_persons,
)
from avtrack.io.rttm import read_rttm  # noqa: E402
from avtrack.io.scene import load_scene  # noqa: E402
from avtrack.localize.base import HeatMaps  # noqa: E402
from avtrack.metrics.der import DERComponents, diarization_error_rate  # noqa: E402

SUITES = {"walkout": ("walkout", 1.0), "walkout-pfov": ("walkout", 0.4),
          "meeting-pfov": ("meeting", 0.4), "meeting-ffov": ("meeting", 1.0)}


def cached_localization(d: Path, sc) -> tuple[list[np.ndarray], float, HeatMaps]:
    """The scene's audio peaks, azimuth span and heat maps, computed once (per grid)."""
    grid = localizer_grid(load_array(d / "array.json"))
    cache = d / f"heat-{PERSONS_LOCALIZER}-{grid.n_azimuths}x{grid.n_elevations}.npz"
    if cache.is_file():
        z = np.load(cache, allow_pickle=False)
        heat = HeatMaps(z["frames"], z["time_s"], z["weights"], z["n_obs"])
        counts = z["counts"]
        flat = z["peaks"]
        peaks = np.split(flat, np.cumsum(counts)[:-1])
        return peaks, float(z["span"]), heat
    array = load_array(d / "array.json")
    heat, grid = scene_heat_maps(sc, array)
    span = grid_span(grid)
    peaks = audio_peaks(heat.weights, heat.time_s, grid, sc.fps, sc.n_frames,
                        floor=audio_peak_floor(PERSONS_LOCALIZER))
    np.savez_compressed(
        cache, frames=heat.frames, time_s=heat.time_s, weights=heat.weights.astype(np.float32),
        n_obs=heat.n_observations, span=span, counts=np.array([p.size for p in peaks]),
        peaks=np.concatenate(peaks) if peaks else np.zeros(0),
    )
    return peaks, span, heat


def run_scene(d: Path, fov_fraction: float) -> dict:
    sc = load_scene(d)
    ref = read_rttm(d / "gt" / "speech.rttm")
    peaks, span, heat = cached_localization(d, sc)
    row: dict = {"scene": d.name, "spk_ref": len({s.speaker for s in ref})}
    for name, use_vad in (("old", False), ("vad", True)):
        res = track_scene_persons(sc, fov_fraction=fov_fraction, peaks=peaks, span=span,
                                  heat=heat, vad=use_vad)
        row[name] = {
            "der0": diarization_error_rate(ref, res.speech, collar=0.0),
            "der25": diarization_error_rate(ref, res.speech, collar=0.25),
            "spk": len({s.speaker for s in res.speech}),
        }
    return row


def report(suite: str, rows: list[dict]) -> str:
    lines = [f"### {suite}", "",
             "| scene | DER % (no collar) before / VAD | DER % (0.5 s collar) before / VAD "
             "| speakers before / VAD / truth |", "|---|---|---|---|"]
    for r in rows:
        o, v = r["old"], r["vad"]
        lines.append(
            f"| {r['scene']} | {100 * o['der0'].rate:.1f} / {100 * v['der0'].rate:.1f} | "
            f"{100 * o['der25'].rate:.1f} / {100 * v['der25'].rate:.1f} | "
            f"{o['spk']} / {v['spk']} / {r['spk_ref']} |")
    m = {(k, c): float(np.mean([r[k][c].rate for r in rows])) * 100
         for k in ("old", "vad") for c in ("der0", "der25")}
    p = {(k, c): DERComponents.sum([r[k][c] for r in rows]).rate * 100
         for k in ("old", "vad") for c in ("der0", "der25")}
    ok = {k: sum(r[k]["spk"] == r["spk_ref"] for r in rows) for k in ("old", "vad")}
    lines.append(
        f"| **mean** (pooled) | {m['old', 'der0']:.1f} ({p['old', 'der0']:.1f}) / "
        f"**{m['vad', 'der0']:.1f}** ({p['vad', 'der0']:.1f}) | {m['old', 'der25']:.1f} "
        f"({p['old', 'der25']:.1f}) / **{m['vad', 'der25']:.1f}** ({p['vad', 'der25']:.1f}) | "
        f"exact {ok['old']}/{len(rows)} / {ok['vad']}/{len(rows)} |")
    comp = {k: DERComponents.sum([r[k]["der0"] for r in rows]) for k in ("old", "vad")}
    for k, c in comp.items():
        lines.append(f"\n{k}, no collar, pooled: miss {100 * c.missed / c.total:.1f} %, "
                     f"false alarm {100 * c.false_alarm / c.total:.1f} %, confusion "
                     f"{100 * c.confusion / c.total:.1f} %")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", type=Path, default=Path("/tmp/avt/bench-vad"))
    ap.add_argument("--seeds", default="0-19", help="e.g. 0-19 or 0,3,5")
    ap.add_argument("--duration", type=float, default=40.0)
    ap.add_argument("--suites", default="walkout,walkout-pfov,meeting-pfov",
                    help=f"comma-separated, of {', '.join(SUITES)}")
    args = ap.parse_args(argv)
    seeds = parse_seeds(args.seeds)
    print(f"# bench_vad: {platform.processor() or platform.machine()}, "
          f"{time.strftime('%Y-%m-%d')}, seeds {args.seeds}, {args.duration:g} s scenes")
    args.work.mkdir(parents=True, exist_ok=True)
    for suite in args.suites.split(","):
        kind, fov = SUITES[suite]
        rows = [run_scene(scene_dir(args.work, kind, s, args.duration), fov) for s in seeds]
        print(report(suite, rows), flush=True)
        print()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
