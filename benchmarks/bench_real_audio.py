"""Localizers and acoustic trackers on real microphone-array recordings with known talkers.

Every WAV under ``--root`` (default ``../shared/data/realaudio``) whose folder names its talkers
as ``a{AZIMUTH}e{ELEVATION}`` joined by ``_`` (e.g. ``a180e20_a225e35``: two talkers, azimuth
counter-clockwise from the array's x axis, elevation above its plane, degrees) and whose array
file (``*.json``) sits in an ancestor folder is run through:

* **every localizer** of :data:`avtrack.localize.LOCALIZERS` at its defaults (its default
  candidate grid for the array, :meth:`~avtrack.localize.grid.DirectionGrid.for_array`, and its
  default peak threshold, as ``avtrack localize`` does). Per file and talker: ``hit%``, the
  share of frames with a peak within 20 degrees of the talker; ``err``, the mean azimuth error
  of the nearest such peak in those frames (the matched error); per file: ``far%``, the share
  of peaks within 20 degrees of no talker. Talkers pause, so a frame without a talker's peak
  may be a pause: compare methods on the same file, not against 100 %.
* **both DOA trackers** at their defaults on the default localizer's maps (``avtrack
  track-audio``'s pipeline, :class:`avtrack.stream.DOAStream`): a talker is *found* when a
  track's circular mean azimuth over its speaking frames is within 20 degrees of it (each track
  counted for one talker at most, nearest first); tracks found for no talker are *extra*
  (tracks speaking in fewer than ``--min-active`` tracker frames, i.e. 0.5 s by default, are
  not counted either way); ``err`` is the error of each found talker's track mean.

Usage::

    python benchmarks/bench_real_audio.py                      # all recordings, all methods
    python benchmarks/bench_real_audio.py --markdown real.md   # also write the tables
    python benchmarks/bench_real_audio.py --methods dprtf-eg-fast prp-rem --no-trackers
    python benchmarks/bench_real_audio.py --methods dprtf-eg-static prp-rem --map dprtf-eg-static
    python benchmarks/bench_real_audio.py --simulated $(seq 0 7) --duration 8 --max-talkers 1 \\
        --array benchmarks/arrays/circle8-r46mm.json       # one talker, an 8-mic circle
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, before NumPy loads BLAS

import argparse  # noqa: E402
import datetime as dt  # noqa: E402
import platform  # noqa: E402
import re  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from _common import add_set_option, parse_set  # noqa: E402
from avtrack.audio.arrays import MicArray, load_array  # noqa: E402
from avtrack.audio.recording import read_array_audio  # noqa: E402
from avtrack.doa import TRACKERS  # noqa: E402
from avtrack.io.doa import wrap_azimuth  # noqa: E402
from avtrack.localize import DEFAULT_LOCALIZER, LOCALIZERS, make_localizer, peak_table  # noqa: E402
from avtrack.stream.audio import DOAStream  # noqa: E402

DEFAULT_ROOT = Path(__file__).resolve().parents[2] / "shared" / "data" / "realaudio"
DEFAULT_METHOD = DEFAULT_LOCALIZER
GATE_DEG = 20.0
MIN_SPEECH_S = 1.0  # simulated talkers who speak less are not counted
#: localizer configurations other than the defaults (``--set``), by method
CONFIGS: dict[str, object] = {}
TALKER = re.compile(r"a(-?\d+(?:\.\d+)?)e(-?\d+(?:\.\d+)?)")


@dataclass(frozen=True)
class Recording:
    path: Path  # the WAV, or a name for a simulated scene
    array_path: Path | None  # None: simulated (``scene``)
    talkers: tuple[tuple[float, float], ...]  # (azimuth, elevation) degrees
    scene: object = None  # a simulated Scene

    @property
    def label(self) -> str:
        if self.scene is not None:
            return str(self.path)
        return f"{self.path.parent.parent.name}/{self.path.parent.name}/{self.path.stem[-8:]}"

    def load(self) -> tuple[MicArray, np.ndarray]:
        """The array and the signal ``(n_mics, n_samples)`` at 16 kHz."""
        if self.scene is not None:
            return self.scene.array, self.scene.audio  # type: ignore[attr-defined]
        assert self.array_path is not None
        array = load_array(self.array_path)
        return array, read_array_audio(self.path, array, quiet=True)


def simulated_recordings(seeds: list[int], duration: float, array: str | None = None,
                         max_talkers: int | None = None) -> list[Recording]:
    """``array-talkers`` scenes (:mod:`avtrack.simulate.library`); the talkers who speak at
    least ``MIN_SPEECH_S`` seconds, at their mean ground-truth direction; labelled with the
    talkers' distance. ``array``: another array than the scene's ReSpeaker (a built-in name or
    an array file); ``max_talkers``: only the scene's first talkers."""
    from avtrack.io.scenario import validate_scenario
    from avtrack.simulate.library import named_scenario
    from avtrack.simulate.scene import simulate_scene

    out = []
    for seed in seeds:
        raw = named_scenario("array-talkers", seed, duration)
        if array is not None:
            raw["array"]["name"] = array
        if max_talkers is not None:
            raw["people"] = raw["people"][:max_talkers]
        scene = simulate_scene(validate_scenario(raw))
        gt = scene.doa
        talkers = []
        for pid in np.unique(gt.ids):
            sel = (gt.ids == pid) & gt.active
            if np.count_nonzero(sel) * scene.scenario["gt_hop_s"] < MIN_SPEECH_S:
                continue  # a talker must speak to be found
            talkers.append((circular_mean_deg(gt.azimuth_deg[sel]),
                            float(np.mean(gt.elevation_deg[sel]))))
        pos = np.asarray(raw["people"][0]["motion"]["position"])
        dist = float(np.linalg.norm(pos - np.asarray(raw["array"]["position"])))
        out.append(Recording(Path(f"array-talkers s{seed} {dist:.1f} m"), None, tuple(talkers),
                             scene))
    return out


def find_recordings(root: Path) -> list[Recording]:
    """The WAVs under ``root`` whose folder names their talkers, with their array file."""
    out = []
    for wav in sorted(root.rglob("*.wav")):
        talkers: tuple[tuple[float, float], ...] = ()
        for folder in wav.parents:
            if folder == root:
                break
            found = TALKER.findall(folder.name)
            if found and "_".join(f"a{a}e{e}" for a, e in found) == folder.name:
                talkers = tuple((float(a), float(e)) for a, e in found)
                break
        arrays = [p for f in wav.parents for p in sorted(f.glob("*.json"))]
        if talkers and arrays:
            out.append(Recording(wav, arrays[0], talkers))
    return out


def angle_error(a: np.ndarray, b: float) -> np.ndarray:
    return np.abs(wrap_azimuth(np.asarray(a, dtype=float) - b))


def localizer_scores(rec: Recording, array: MicArray, x: np.ndarray, method: str) -> dict:
    loc = make_localizer(method, array, config=CONFIGS.get(method))
    t0 = time.perf_counter()
    heat = loc.run(x)
    elapsed = time.perf_counter() - t0
    table = peak_table(heat, loc.grid, loc.peak_threshold, reduce=loc.profile_reduce)
    n = len(heat)
    near_any = np.zeros(len(table), dtype=bool)
    per_talker = []
    for az, _el in rec.talkers:
        err = angle_error(table.azimuth_deg, az)
        ok = err <= GATE_DEG
        near_any |= ok
        frames = np.unique(table.frames[ok])
        best = [float(err[ok & (table.frames == f)].min()) for f in frames]
        per_talker.append((100.0 * frames.size / max(n, 1), float(np.mean(best)) if best
                           else float("nan"), set(frames.tolist())))
    far = 100.0 * float(np.mean(~near_any)) if len(table) else 0.0
    return {"talkers": per_talker, "far": far, "rf": elapsed / (x.shape[1] / loc.fs),
            "elevations": loc.grid.n_elevations}


def tracker_scores(rec: Recording, array: MicArray, x: np.ndarray, tracker: str,
                   min_active: int, method: str = DEFAULT_METHOD) -> dict:
    stream = DOAStream(array, method=method, tracker=tracker, method_config=CONFIGS.get(method))
    outs = stream.push(x) + stream.finish()
    by_id: dict[int, list[float]] = {}
    for out in outs:
        tr = out.tracks
        for i, a, on in zip(tr.ids, tr.azimuth_deg, tr.active, strict=True):
            if on:
                by_id.setdefault(int(i), []).append(float(a))
    means = {i: circular_mean_deg(az) for i, az in by_id.items() if len(az) >= min_active}
    matched = match_talkers(rec.talkers, means)
    return {"found": {k: err for k, (_i, err) in matched.items()},
            "extra": len(means) - len(matched), "tracks": means}


def circular_mean_deg(azimuth_deg) -> float:
    """The circular mean of azimuths, degrees."""
    r = np.deg2rad(np.asarray(azimuth_deg, dtype=float))
    return float(np.rad2deg(np.arctan2(np.sin(r).mean(), np.cos(r).mean())))


def match_talkers(talkers: tuple[tuple[float, float], ...],
                  means: dict[int, float]) -> dict[int, tuple[int, float]]:
    """Talker index -> (track id, error in degrees): each track's mean azimuth given to the
    nearest talker within ``GATE_DEG``, nearest pairs first, one track per talker."""
    pairs = sorted(
        (float(angle_error(m, az)), k, i)
        for k, (az, _el) in enumerate(talkers)
        for i, m in means.items()
    )
    found: dict[int, tuple[int, float]] = {}
    used: set[int] = set()
    for err, k, i in pairs:
        if err <= GATE_DEG and k not in found and i not in used:
            found[k] = (i, err)
            used.add(i)
    return found


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--root", type=Path, default=DEFAULT_ROOT)
    p.add_argument("--methods", nargs="+", default=sorted(LOCALIZERS))
    p.add_argument("--trackers", nargs="+", default=sorted(TRACKERS))
    p.add_argument("--no-trackers", action="store_true")
    p.add_argument("--min-active", type=int, default=16,
                   help="tracker frames (32 ms) a track must speak to count (default 16)")
    p.add_argument("--markdown", type=Path, help="also write the tables to this file")
    p.add_argument("--simulated", type=int, nargs="+", metavar="SEED",
                   help="instead of the recordings, simulated 'array-talkers' scenes of these "
                   "seeds (the same array, 1-3 talkers at 0.5-2.5 m, the recordings' noise)")
    p.add_argument("--duration", type=float, default=6.0,
                   help="seconds per simulated scene (default 6)")
    p.add_argument("--array", metavar="NAME|ARRAY.json",
                   help="with --simulated: this array instead of the ReSpeaker (a built-in name "
                   "or an array file)")
    p.add_argument("--max-talkers", type=int, metavar="N",
                   help="with --simulated: at most the scene's first N talkers")
    p.add_argument("--map", default=DEFAULT_METHOD, choices=sorted(LOCALIZERS),
                   help=f"the localizer whose maps the trackers read (default {DEFAULT_METHOD})")
    add_set_option(p, "(for the --map localizer also the trackers' maps)")
    args = p.parse_args(argv)
    CONFIGS.update(parse_set(p, args.set))
    if (args.array or args.max_talkers) and not args.simulated:
        p.error("--array and --max-talkers need --simulated")
    if args.max_talkers is not None and args.max_talkers < 1:
        p.error(f"--max-talkers must be >= 1, got {args.max_talkers}")
    if args.simulated:
        recs = simulated_recordings(args.simulated, args.duration, args.array, args.max_talkers)
        return report(recs, args, f"Simulated 'array-talkers' scenes, seeds {args.simulated}"
                      + (f", array {args.array}" if args.array else "")
                      + (f", at most {args.max_talkers} talkers" if args.max_talkers else ""))
    if not args.root.is_dir():
        print(f"no recordings: {args.root} is not a folder (shared data absent?)",
              file=sys.stderr)
        return 2
    recs = find_recordings(args.root)
    if not recs:
        print(f"no recordings with talker directions under {args.root}", file=sys.stderr)
        return 2
    return report(recs, args, f"Real recordings: {len(recs)} files under {args.root}")


def report(recs: list[Recording], args: argparse.Namespace, title: str) -> int:
    """Run every method and tracker on ``recs``; print (and write) the tables."""
    lines = [
        f"{title}; "
        f"{dt.datetime.now():%Y-%m-%d %H:%M}, {platform.machine()}, Python "
        f"{platform.python_version()}, one BLAS thread.",
        "",
        "### Localizers at their defaults: hit % / matched error (deg) per talker; far %",
        "",
        "| file | method | elev. rows | " + " | ".join(
            f"talker {k + 1}" for k in range(max(len(r.talkers) for r in recs))) + " | far % |",
        "|---|---|---:|" + "---:|" * max(len(r.talkers) for r in recs) + "---:|",
    ]
    totals: dict[str, list] = {m: [] for m in args.methods}
    track_rows = []
    track_totals = {t: [0, 0, 0, []] for t in args.trackers}  # found, talkers, extra, errs
    rf: dict[str, list[float]] = {m: [] for m in args.methods}
    for rec in recs:
        array, x = rec.load()
        n_t = max(len(r.talkers) for r in recs)
        for m in args.methods:
            s = localizer_scores(rec, array, x, m)
            rf[m].append(s["rf"])
            cells = [f"{h:.0f} / {e:.1f}" for h, e, _ in s["talkers"]]
            cells += [""] * (n_t - len(cells))
            lines.append(f"| {rec.label} | {m} | {s['elevations']} | " + " | ".join(cells)
                         + f" | {s['far']:.0f} |")
            totals[m].append((rec, s))
        if args.no_trackers:
            continue
        for t in args.trackers:
            s = tracker_scores(rec, array, x, t, args.min_active, args.map)
            tot = track_totals[t]
            tot[0] += len(s["found"])
            tot[1] += len(rec.talkers)
            tot[2] += s["extra"]
            tot[3] += list(s["found"].values())
            talk = " ".join(
                f"{az:.0f}:{format(s['found'][k], '.1f') if k in s['found'] else 'missed'}"
                for k, (az, _el) in enumerate(rec.talkers)
            )
            tracks = " ".join(f"{v:.0f}" for v in sorted(s["tracks"].values()))
            track_rows.append(f"| {rec.label} | {t} | {talk} | {s['extra']} | {tracks} |")
        print(f"done {rec.label}", file=sys.stderr, flush=True)

    # per method, pooled: frames with a peak on each talker, relative to PRP-REM's
    lines += ["", "### Pooled over files (talker-frames): hit %, matched error, far %, RF", "",
              "| method | hit % | matched error (deg) | far % | hits vs PRP-REM | RF |",
              "|---|---:|---:|---:|---:|---:|"]
    ref = {}
    if "prp-rem" in totals:
        for rec, s in totals["prp-rem"]:
            for k, (_h, _e, frames) in enumerate(s["talkers"]):
                ref[(rec.path, k)] = len(frames)
    for m, items in totals.items():
        hits = sum(len(f) for _, s in items for _, _, f in s["talkers"])
        n_frames = sum(len(s["talkers"]) for _, s in items)
        errs = [(e, len(f)) for _, s in items for _, e, f in s["talkers"] if f]
        err = sum(e * n for e, n in errs) / max(sum(n for _, n in errs), 1)
        far = float(np.mean([s["far"] for _, s in items]))
        worst = min(
            (len(f) / ref[(rec.path, k)] for rec, s in items
             for k, (_h, _e, f) in enumerate(s["talkers"]) if ref.get((rec.path, k))),
            default=float("nan"),
        )
        share = f"{100.0 * hits / sum(ref.values()):.0f} %" if ref else "n/a"
        lines.append(f"| {m} | {hits / max(n_frames, 1):.0f} frames/talker | {err:.2f} | "
                     f"{far:.1f} | {share} (worst talker {100 * worst:.0f} %) | "
                     f"{np.mean(rf[m]):.3f} |")
    # SRP-PHAT's hits within the default localizer's, single-talker files
    if "srp-phat" in totals and DEFAULT_METHOD in totals:
        srp = {r.path: s for r, s in totals["srp-phat"]}
        lines += ["", f"SRP-PHAT peaks within {GATE_DEG:.0f} deg of the talker in the frames "
                  f"where {DEFAULT_METHOD} finds it (single-talker files):"]
        for rec, s in totals[DEFAULT_METHOD]:
            if len(rec.talkers) != 1:
                continue
            mine = s["talkers"][0][2]
            theirs = srp[rec.path]["talkers"][0][2]
            lines.append(f"- {rec.label}: {100 * len(mine & theirs) / max(len(mine), 1):.0f} %"
                         f" of {len(mine)} frames")
    if not args.no_trackers:
        lines += ["", f"### Trackers on {args.map} maps at their defaults", "",
                  "| file | tracker | talker: error of its track (deg) | extra | track means |",
                  "|---|---|---|---:|---|", *track_rows]
        lines += ["", "| tracker | talkers found | extra tracks | mean error (deg) |",
                  "|---|---:|---:|---:|"]
        for t, (f, n, e, errs) in track_totals.items():
            lines.append(f"| {t} | {f} / {n} ({100 * f / max(n, 1):.0f} %) | {e} "
                         f"({100 * e / max(n, 1):.0f} %) | {np.mean(errs) if errs else 0:.2f} |")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.markdown is not None:
        args.markdown.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
