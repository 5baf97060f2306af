"""Frame-wise multi-speaker localization: real-time factor and thesis §5.5.1 scores.

Two parts, both running every method of :data:`avtrack.localize.LOCALIZERS` in the same process
(DPRTF-EG, DPRTF-REM, PRP-REM, SRP-PHAT; thesis Tables 5.1 / 5.2):

**Speed** (always). A reverberant two-talker recording is rendered with pyroomacoustics
(6 x 5 x 3 m, T60 0.4 s, talkers at 1.5-2 m taking turns, CMU ARCTIC utterances from the
shared data or band-passed noise bursts without it, sensor noise at 30 dB SNR) for the nao4 and
the nao8 free-field arrays (LOCATA NAO-head geometry, the thesis's 4- and 8-microphone
configurations). Each method processes it with BLAS limited to one thread; the real-time factor
is ``RF = processing time / signal length`` (best of ``--repeats`` runs; STFT, features,
weights; no file I/O), and ``x SRP`` is RF divided by SRP-PHAT's RF on the same array, in the
same run. Targets of the issue: DPRTF-EG RF <= 0.25 with 4 microphones and <= 0.8 with 8.

**Accuracy** (``--scene DIR ...``). For each scene directory (``audio.wav``, ``array.json``,
``gt/doa.csv``, e.g. written by ``avtrack simulate locata-like -o DIR``), every method's heat
maps are reduced to all their peaks; the peak threshold is swept
(:func:`avtrack.metrics.doa.roc_sweep`) and the point of the ROC curve closest to the origin
(MD rate, FA rate) is reported, as in thesis Tables 5.1-5.2, with components summed over the
scenes. The first ``--skip`` seconds (noise statistics warming up) are not scored.

Usage::

    python benchmarks/bench_localize.py                        # speed only
    python benchmarks/bench_localize.py --seconds 20 --repeats 3
    python benchmarks/bench_localize.py --methods dprtf-eg dprtf-eg-fast srp-phat --numpy-form
    python benchmarks/bench_localize.py --scene scenes/locata-0 scenes/locata-1 --no-speed
    python benchmarks/bench_localize.py --scene scenes/kinovis-* --markdown bench_localize.md
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, before NumPy loads BLAS

import argparse  # noqa: E402
import datetime as dt  # noqa: E402
import gc  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import scipy.signal  # noqa: E402

from _common import add_set_option, parse_set, shared_data_dir  # noqa: E402
from avtrack.audio.arrays import MicArray, builtin_array, load_array  # noqa: E402
from avtrack.io.base import atomic_write  # noqa: E402
from avtrack.io.doa import read_doa_csv  # noqa: E402
from avtrack.localize import LOCALIZERS, make_localizer, peak_table  # noqa: E402
from avtrack.metrics.doa import DOAScores, roc_sweep  # noqa: E402

FS = 16000
METHODS = ("srp-phat", "prp-rem", "dprtf-rem", "dprtf-eg")
LABELS = {
    "srp-phat": "SRP-PHAT",
    "prp-rem": "PRP-REM",
    "dprtf-rem": "DPRTF-REM",
    "dprtf-eg": "DPRTF-EG",
}


def talker_signals(seconds: float, rng: np.random.Generator) -> list[np.ndarray]:
    """Two talkers taking turns (2 s turns, 0.3 s pauses): real utterances if available."""
    n = int(seconds * FS)
    speech_dir = shared_data_dir() / "audio" / "speech"
    utterances = []
    if speech_dir.is_dir():
        import soundfile

        for p in sorted(speech_dir.glob("*.wav")):
            x, fs = soundfile.read(p, dtype="float64")
            if fs == FS and x.ndim == 1:
                utterances.append(x / np.std(x))
    if not utterances:  # band-passed noise bursts (syllable-like envelope)
        b, a = scipy.signal.butter(2, [200, 4000], btype="band", fs=FS)
        env = (np.mod(np.arange(3 * FS) / FS, 0.25) < 0.18).astype(float)
        utterances = [scipy.signal.lfilter(b, a, rng.standard_normal(3 * FS)) * env]
    out = [np.zeros(n), np.zeros(n)]
    t, who = 0, 0
    while t < n:
        u = utterances[rng.integers(len(utterances))]
        seg = u[: min(u.size, int(2.0 * FS), n - t)]
        out[who][t : t + seg.size] = seg
        t += seg.size + int(0.3 * FS)
        who = 1 - who
    return out


def render(array: MicArray, seconds: float, seed: int = 0) -> np.ndarray:
    """``(n_mics, n)`` reverberant two-talker recording (see the module docstring)."""
    import pyroomacoustics as pra

    rng = np.random.default_rng(seed)
    dims = np.array([6.0, 5.0, 3.0])
    absorption, max_order = pra.inverse_sabine(0.4, dims)
    room = pra.ShoeBox(dims, fs=FS, materials=pra.Material(absorption), max_order=max_order)
    centre = np.array([3.0, 2.5, 1.3])
    for (az, r), sig in zip(
        ((40.0, 1.5), (-110.0, 2.0)), talker_signals(seconds, rng), strict=True
    ):
        a = np.deg2rad(az)
        room.add_source(centre + r * np.array([np.cos(a), np.sin(a), 0.1]), signal=sig)
    room.add_microphone_array(pra.MicrophoneArray((centre + array.positions).T, FS))
    room.simulate()
    y = room.mic_array.signals[:, : int(seconds * FS)]
    y = y / np.std(y)
    return y + 10 ** (-30 / 20) * rng.standard_normal(y.shape)


def real_time_factor(
    method: str, array: MicArray, x: np.ndarray, repeats: int, numpy_form: bool = False
) -> float:
    """Best-of-``repeats`` RF of ``method``; ``numpy_form``: with the DP-RTF estimator's NumPy
    form instead of its compiled kernel (``AVTRACK_NO_JIT``, read when the estimator is made)."""
    saved = os.environ.get("AVTRACK_NO_JIT")
    if numpy_form:
        os.environ["AVTRACK_NO_JIT"] = "1"
    try:
        loc = make_localizer(method, array)
    finally:
        if saved is None:
            os.environ.pop("AVTRACK_NO_JIT", None)
        else:
            os.environ["AVTRACK_NO_JIT"] = saved
    loc.run(x[:, : 2 * FS])  # warm-up
    best = np.inf
    gc_was = gc.isenabled()
    gc.disable()
    try:
        for _ in range(repeats):
            t0 = time.perf_counter()
            loc.run(x)
            best = min(best, time.perf_counter() - t0)
    finally:
        if gc_was:
            gc.enable()
    return best / (x.shape[1] / FS)


def speed(methods, seconds: float, repeats: int, numpy_form: bool = False) -> list[dict]:
    rows = []
    for name in ("nao4", "nao8"):
        array = builtin_array(name)
        x = render(array, seconds)
        rf = {m: real_time_factor(m, array, x, repeats) for m in methods}
        rf_np = (
            {m: real_time_factor(m, array, x, repeats, numpy_form=True) for m in methods}
            if numpy_form
            else {}
        )
        ref = rf.get("srp-phat", np.nan)
        for m in methods:
            row = {"array": name, "method": m, "RF": rf[m], "x SRP": rf[m] / ref}
            line = f"  {name:5s} {LABELS.get(m, m):10s} RF {rf[m]:.3f}  ({rf[m] / ref:.1f} x SRP)"
            if numpy_form:
                row["RF numpy"] = rf_np[m]
                line += f"  NumPy form RF {rf_np[m]:.3f} ({rf_np[m] / rf[m]:.2f} x)"
            rows.append(row)
            print(line, flush=True)
    return rows


def accuracy(methods, scenes: list[Path], skip_s: float, configs: dict | None = None
             ) -> list[dict]:
    """Best ROC point of each method pooled over ``scenes``; ``configs`` maps a method to its
    localizer configuration (default: the method's defaults)."""
    configs = configs or {}
    rows = []
    for m in methods:
        tables, truths, elapsed, duration = [], [], 0.0, 0.0
        for d in scenes:
            from avtrack.audio.recording import read_array_audio

            array = load_array(d / "array.json")
            x = read_array_audio(d / "audio.wav", array, quiet=True)
            truth = read_doa_csv(d / "gt" / "doa.csv")
            loc = make_localizer(m, array, config=configs.get(m))
            t0 = time.perf_counter()
            heat = loc.run(x)
            elapsed += time.perf_counter() - t0
            duration += x.shape[1] / FS
            tables.append(peak_table(heat, loc.grid, threshold=0.0))
            truths.append(truth)
        all_w = np.concatenate([t.weight for t in tables])
        thr = np.unique(np.quantile(all_w, np.linspace(0.0, 0.999, 80)))
        curves = [
            roc_sweep(t, g, thr, time_range_s=(skip_s, np.inf))
            for t, g in zip(tables, truths, strict=True)
        ]
        summed = [
            sum((c.scores[i] for c in curves), DOAScores(0, 0, 0, 0.0)) for i in range(thr.size)
        ]
        dist = [np.hypot(s.md_rate, s.fa_rate) for s in summed]
        i = int(np.nanargmin(dist))
        s = summed[i]
        rows.append(
            {
                "method": m,
                "threshold": float(thr[i]),
                "MD%": 100 * s.md_rate,
                "FA%": 100 * s.fa_rate,
                "MAE": s.mae,
                "RF": elapsed / duration,
            }
        )
        print(
            f"  {LABELS.get(m, m):10s} MD {100 * s.md_rate:5.1f} %  FA {100 * s.fa_rate:5.1f} %"
            f"  MAE {s.mae:4.2f} deg  RF {elapsed / duration:.3f}  (threshold {thr[i]:.4g})",
            flush=True,
        )
    return rows


def markdown(speed_rows, acc_rows, scenes, args) -> str:
    lines = [
        f"## Localization ({dt.date.today()}, {platform.processor() or platform.machine()},"
        f" Python {platform.python_version()}, one BLAS thread)",
        "",
        f"Command: `python benchmarks/bench_localize.py {' '.join(sys.argv[1:])}`",
        "",
    ]
    if speed_rows:
        with_np = "RF numpy" in speed_rows[0]
        lines += [
            f"Real-time factor on a {args.seconds:g} s two-talker recording "
            "(lower is better; target DPRTF-EG <= 0.25 with 4 mics, <= 0.8 with 8):",
            "",
            "| array | method | RF | x SRP-PHAT |"
            + (" RF, NumPy form | speed-up |" if with_np else ""),
            "|---|---|---:|---:|" + ("---:|---:|" if with_np else ""),
        ]
        lines += [
            f"| {r['array']} | {LABELS.get(r['method'], r['method'])} | {r['RF']:.3f} "
            f"| {r['x SRP']:.1f} |"
            + (f" {r['RF numpy']:.3f} | {r['RF numpy'] / r['RF']:.2f} x |" if with_np else "")
            for r in speed_rows
        ]
        lines.append("")
    if acc_rows:
        lines += [
            f"Scores on {len(scenes)} scene(s) ({', '.join(p.name for p in scenes)}), "
            "best ROC point:",
            "",
            "| method | MD % | FA % | MAE (deg) | RF |",
            "|---|---:|---:|---:|---:|",
        ]
        lines += [
            f"| {LABELS.get(r['method'], r['method'])} | {r['MD%']:.1f} | {r['FA%']:.1f} "
            f"| {r['MAE']:.2f} | {r['RF']:.3f} |"
            for r in acc_rows
        ]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--methods", nargs="+", default=list(METHODS), choices=sorted(LOCALIZERS))
    p.add_argument("--seconds", type=float, default=20.0, help="length of the speed recording")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--no-speed", action="store_true", help="skip the speed part")
    p.add_argument(
        "--numpy-form",
        action="store_true",
        help="also time each method with the DP-RTF estimator's NumPy form (AVTRACK_NO_JIT), "
        "in the same process: the compiled kernel's speed-up",
    )
    p.add_argument("--scene", nargs="*", type=Path, default=[], metavar="DIR")
    p.add_argument(
        "--skip",
        type=float,
        default=1.0,
        metavar="S",
        help="seconds not scored at the start of each scene (default 1)",
    )
    add_set_option(p, "for the scores")
    p.add_argument("--markdown", type=Path, metavar="FILE", help="write the tables here")
    args = p.parse_args(argv)
    configs = parse_set(p, args.set)
    speed_rows, acc_rows = [], []
    if not args.no_speed:
        print("real-time factor (one BLAS thread):", flush=True)
        speed_rows = speed(args.methods, args.seconds, args.repeats, args.numpy_form)
    if args.scene:
        print(f"scores on {len(args.scene)} scene(s):", flush=True)
        acc_rows = accuracy(args.methods, args.scene, args.skip, configs)
    if args.markdown:
        with atomic_write(args.markdown) as fh:
            fh.write(markdown(speed_rows, acc_rows, args.scene, args))
    return 0


if __name__ == "__main__":
    sys.exit(main())
