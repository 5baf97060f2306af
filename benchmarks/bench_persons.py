"""Audio keeps talkers tracked when the camera cannot see them: direction-space persons vs the
visual-only tracker, on simulated scenes.

Suites (40 s scenes, seeds 0-7 by default; the tracker's defaults were chosen on seeds 10-15):

* ``walkout`` -- ``avtrack simulate walkout``: 2-3 people in front of a NAO-like 4-microphone
  array and a camera; each walks out of the camera's view while the conversation goes on, then
  comes back.
* ``meeting-pfov`` -- ``avtrack simulate meeting`` (binaural dummy head, 2-4 people) with the
  camera seeing only the central 40 % of the image width (``--fov-fraction 0.4``): talkers in
  the blind strips are never seen.
* ``meeting-ffov`` -- the same meetings with the full field of view (no regression).

Per scene: MOTA / IDF1 / IDSW of the visual-only tracker (OVBT, ``track-av --no-audio``) and
of the direction-space model (``track-av``, default), DER (collar 0.25 s each side), speakers
found against the truth, identity kept on returns into the image, and the azimuth MAE of
``persons.csv`` for ground-truth persons out of view (with coverage: matched share of those
person-frames, gate 30 degrees). Corpus rows sum components over scenes.

Speed: ``track-av`` (localization included) on one walkout scene with BLAS on one thread, as a
real-time factor and as a ratio to the visual-only tracker; the direction model needs no
calibration or training, so a second run on the same geometry spends 0 s on it.

``--localizer`` picks the heat maps the direction model reads (default: the pipeline's,
``avtrack.av.persons_scene.PERSONS_LOCALIZER``), with their own peak floor
(``audio_peak_floor``).

Usage::

    python benchmarks/bench_persons.py --work /tmp/avt/bench-persons [--seeds 0-7]
        [--localizer dprtf-eg-fast]
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
from avtrack.av.persons_scene import PERSONS_LOCALIZER, track_scene_persons  # noqa: E402
from avtrack.av.vavit import fov_strip, track_scene  # noqa: E402
from avtrack.io.doa import read_doa_csv  # noqa: E402
from avtrack.io.mot import read_mot  # noqa: E402
from avtrack.io.rttm import read_rttm  # noqa: E402
from avtrack.io.scene import load_scene  # noqa: E402
from avtrack.metrics.der import DERComponents, diarization_error_rate  # noqa: E402
from avtrack.metrics.mot import evaluate_mot  # noqa: E402
from avtrack.metrics.persons import (  # noqa: E402
    OffscreenScore,
    identity_on_return,
    offscreen_direction_error,
    truth_per_frame,
)

SUITES = {"walkout": ("walkout", 1.0), "meeting-pfov": ("meeting", 0.4),
          "meeting-ffov": ("meeting", 1.0)}


def gt_directions(d: Path, gt, fps: float, n_frames: int, fov: tuple[float, float]):
    """Ground-truth person azimuth per video frame and whether the camera sees the person."""
    return truth_per_frame(read_doa_csv(d / "gt" / "doa.csv"), gt, fps, n_frames, fov)


def run_scene(d: Path, fov_fraction: float, localizer: str = PERSONS_LOCALIZER) -> dict:
    sc = load_scene(d)
    gt = read_mot(d / "gt" / "gt.txt", kind="gt")
    ref = read_rttm(d / "gt" / "speech.rttm")
    vis = track_scene(d, use_audio=False, fov_fraction=fov_fraction, scene=sc)
    av = track_scene_persons(sc, fov_fraction=fov_fraction, localizer=localizer)
    mv = evaluate_mot(gt, vis.tracks, n_frames=sc.n_frames)
    ma = evaluate_mot(gt, av.tracks, n_frames=sc.n_frames)
    der = diarization_error_rate(ref, av.speech, collar=0.25)
    fov = fov_strip(sc.image_size[0], fov_fraction)
    gf, gi, ga, gv, act = gt_directions(d, gt, sc.fps, sc.n_frames, fov)
    off = offscreen_direction_error(gf, gi, ga, gv, av.persons.frames, av.persons.azimuth_deg)
    off_talk = offscreen_direction_error(gf, gi, ga, gv, av.persons.frames,
                                         av.persons.azimuth_deg, gt_mask=act)
    ret_v = identity_on_return(gt, vis.tracks)
    ret_a = identity_on_return(gt, av.tracks)
    return {
        "scene": d.name, "vis": mv, "av": ma, "der": der, "off": off, "off_talk": off_talk,
        "ret_v": ret_v, "ret_a": ret_a,
        "spk_ref": len({s.speaker for s in ref}), "spk_hyp": len({s.speaker for s in av.speech}),
    }


def fmt(v: float, p: int = 1) -> str:
    return "nan" if not np.isfinite(v) else f"{v:.{p}f}"


def report(suite: str, rows: list[dict]) -> str:
    head = ("| scene | MOTA vis | MOTA av | IDF1 vis | IDF1 av | IDSW vis | IDSW av | DER % "
            "| speakers | returns kept (vis / av) | off-screen MAE deg (coverage) "
            "| ... while talking |")
    lines = [f"### {suite}", "", head, "|" + "---|" * 12]
    for r in rows:
        lines.append(
            f"| {r['scene']} | {r['vis'].MOTA:.1f} | {r['av'].MOTA:.1f} | {r['vis'].IDF1:.1f} | "
            f"{r['av'].IDF1:.1f} | {r['vis'].IDSW} | {r['av'].IDSW} | {100 * r['der'].rate:.1f} | "
            f"{r['spk_hyp']}/{r['spk_ref']} | {r['ret_v'].n_kept}/{r['ret_v'].n_returns} / "
            f"{r['ret_a'].n_kept}/{r['ret_a'].n_returns} | {fmt(r['off'].mae_deg)} "
            f"({fmt(100 * r['off'].coverage, 0)} %) | {fmt(r['off_talk'].mae_deg)} "
            f"({fmt(100 * r['off_talk'].coverage, 0)} %) |"
        )
    der = DERComponents.sum([r["der"] for r in rows])
    off = OffscreenScore.sum([r["off"] for r in rows])
    talk = OffscreenScore.sum([r["off_talk"] for r in rows])
    nr = sum(r["ret_a"].n_returns for r in rows)
    nk = sum(r["ret_a"].n_kept for r in rows)
    nrv = sum(r["ret_v"].n_returns for r in rows)
    nkv = sum(r["ret_v"].n_kept for r in rows)
    spk_ok = sum(r["spk_hyp"] == r["spk_ref"] for r in rows)
    mean = lambda k, a: float(np.mean([getattr(r[k], a) for r in rows]))  # noqa: E731
    lines.append(
        f"| **all** (mean MOTA/IDF1; DER, MAE pooled) | {mean('vis', 'MOTA'):.1f} | "
        f"{mean('av', 'MOTA'):.1f} | {mean('vis', 'IDF1'):.1f} | {mean('av', 'IDF1'):.1f} | "
        f"{sum(r['vis'].IDSW for r in rows)} | {sum(r['av'].IDSW for r in rows)} | "
        f"{100 * der.rate:.1f} | {spk_ok}/{len(rows)} scenes exact | {nkv}/{nrv} / {nk}/{nr} | "
        f"{fmt(off.mae_deg)} ({fmt(100 * off.coverage, 0)} %) | {fmt(talk.mae_deg)} "
        f"({fmt(100 * talk.coverage, 0)} %) |"
    )
    return "\n".join(lines)


def speed(work: Path, repeats: int = 2, localizer: str = PERSONS_LOCALIZER) -> str:
    d = scene_dir(work, "walkout", 0, 40.0)
    sc = load_scene(d)
    t_av, t_vis = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        track_scene_persons(sc, localizer=localizer)
        t_av.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        track_scene(d, use_audio=False, scene=sc)
        t_vis.append(time.perf_counter() - t0)
    dur = sc.n_frames / sc.fps
    a, v = min(t_av), min(t_vis)
    return (f"speed (walkout seed 0, {dur:.0f} s, nao4, BLAS 1 thread, best of {repeats}): "
            f"direction model with localization {a:.2f} s, RF {a / dur:.3f}; visual-only "
            f"{v:.2f} s; ratio {a / v:.1f}x; calibration/training: none (geometric mapping)")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", type=Path, default=Path("/tmp/avt/bench-persons"))
    ap.add_argument("--seeds", default="0-7", help="e.g. 0-7 or 0,3,5")
    ap.add_argument("--duration", type=float, default=40.0)
    ap.add_argument("--suites", default=",".join(SUITES))
    ap.add_argument("--no-speed", action="store_true")
    ap.add_argument("--localizer", default=PERSONS_LOCALIZER,
                    help=f"heat maps of the direction model (default {PERSONS_LOCALIZER})")
    args = ap.parse_args(argv)
    seeds = parse_seeds(args.seeds)
    print(f"# bench_persons: {platform.processor() or platform.machine()}, "
          f"{time.strftime('%Y-%m-%d')}, seeds {args.seeds}, {args.duration:g} s scenes, "
          f"localizer {args.localizer}")
    for suite in args.suites.split(","):
        kind, fov = SUITES[suite]
        rows = [run_scene(scene_dir(args.work, kind, s, args.duration), fov, args.localizer)
                for s in seeds]
        print(report(suite, rows), flush=True)
        print()
    if not args.no_speed:
        print(speed(args.work, localizer=args.localizer))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
