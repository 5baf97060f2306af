"""One voice per tracked person: SI-SDR of ``track-av --voices`` on simulated scenes.

Scenes (free-field 4-microphone array, ``nao4``): ``walkout`` (people walk out of the camera's
view while talking and come back) and ``meeting`` with the array replaced by ``nao4`` (people
around a table, some outside a partial view). Per seed, the direction-space person tracker runs
on the scene (as ``avtrack track-av``), then :func:`avtrack.audio.beamform.extract_voices`
beamforms each tracked person's voice; voices are matched to ground-truth persons and scored as
``avtrack eval voices`` does (SI-SDR against each person's image at microphone 0, SI-SDRi over
microphone 0).

Two references beside the tracked voices, with the ground truth's directions and turns instead
of the tracker's: ``oracle MVDR`` (the same beamformer) and ``oracle gate`` (microphone 0 kept
during the person's turns, zeros elsewhere: what the gating alone is worth).

Real-time factor: (tracking + voices) seconds over the scene's duration, one thread.

Usage::

    python benchmarks/bench_voices.py                  # walkout and meeting, seeds 1-3
    python benchmarks/bench_voices.py --seeds 1 2 --scenarios walkout
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from avtrack.audio.arrays import load_array  # noqa: E402
from avtrack.audio.beamform import VoiceTrack, extract_voices, tracks_from_persons  # noqa: E402
from avtrack.av.persons_scene import track_scene_persons  # noqa: E402
from avtrack.io.mot import read_mot  # noqa: E402
from avtrack.io.scenario import validate_scenario  # noqa: E402
from avtrack.io.scene import load_scene  # noqa: E402
from avtrack.metrics.persons import truth_per_frame  # noqa: E402
from avtrack.metrics.voices import assign_identities, score_voices, si_sdr  # noqa: E402
from avtrack.simulate.library import named_scenario  # noqa: E402
from avtrack.simulate.scene import simulate_scene, write_scene  # noqa: E402


def scenario(name: str, seed: int, duration: float) -> dict:
    sc = named_scenario(name, seed, duration)
    sc["array"] = {**sc["array"], "name": "nao4", "hrir": False}
    return validate_scenario(sc)


def run_one(name: str, seed: int, duration: float, root: Path) -> list[dict]:
    sim = simulate_scene(scenario(name, seed, duration))
    scene_dir = write_scene(sim, root / f"{name}-{seed}")
    scene = load_scene(scene_dir)
    array = load_array(scene_dir / "array.json")
    t0 = time.process_time()
    res = track_scene_persons(scene)
    t1 = time.process_time()
    voices = extract_voices(scene.audio, scene.fs, array, tracks_from_persons(res.persons,
                                                                              res.speech))
    t2 = time.process_time()
    rtf_track, rtf_voices = (t1 - t0) / duration, (t2 - t1) / duration
    gt = read_mot(scene_dir / "gt" / "gt.txt", kind="gt")
    gf, gi, ga, gv, gs = truth_per_frame(sim.doa, gt, scene.fps, scene.n_frames)
    ids = assign_identities(gf, gi, ga, gs, res.persons.frames, res.persons.ids,
                            res.persons.azimuth_deg)
    refs = {int(p): r for p, r in zip(sim.ids, sim.references, strict=True)}
    scores = score_voices(refs, scene.audio[0], voices, ids)
    # oracle: the ground truth's directions and turns
    oracle_tracks = []
    for pid in sim.ids:
        m = sim.doa.ids == pid
        turns = np.array([(s.start, s.end) for s in sim.segments if s.speaker == pid])
        oracle_tracks.append(VoiceTrack(int(pid), sim.doa.time_s[m], sim.doa.azimuth_deg[m],
                                        sim.doa.elevation_deg[m], turns.reshape(-1, 2)))
    oracle = extract_voices(scene.audio, scene.fs, array, oracle_tracks)
    t = np.arange(scene.audio.shape[1]) / scene.fs
    rows = []
    for sc in scores:
        gate = np.zeros(t.size, bool)
        for s in sim.segments:
            if s.speaker == sc.person:
                gate |= (t >= s.start - 0.1) & (t < s.end + 0.3)
        ref = refs[sc.person]
        talk = (gi == sc.person) & gs
        rows.append({
            "scene": f"{name}-{seed}", "person": sc.person, "track": sc.track,
            "seen": float(np.mean(gv[talk])) if np.any(talk) else float("nan"),
            "mix": sc.si_sdr_mixture, "voice": sc.si_sdr, "sdri": sc.improvement,
            "oracle_mvdr": si_sdr(oracle[sc.person], ref) - sc.si_sdr_mixture,
            "oracle_gate": si_sdr(scene.audio[0] * gate, ref) - sc.si_sdr_mixture,
            "rtf_track": rtf_track, "rtf_voices": rtf_voices,
        })
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--scenarios", nargs="+", default=["walkout", "meeting"])
    ap.add_argument("--duration", type=float, default=20.0)
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.scenarios:
            for seed in args.seeds:
                rows += run_one(name, seed, args.duration, Path(tmp))
    print("SI-SDR in dB (SI-SDRi: improvement over microphone 0); seen: share of the person's "
          "speech in the camera's view")
    print(f"{'scene':<12} {'person':>6} {'track':>5} {'seen':>5} {'mic0':>6} {'voice':>6} "
          f"{'SI-SDRi':>7} {'oracle MVDR':>11} {'oracle gate':>11}")
    for r in rows:
        tr = "-" if r["track"] is None else str(r["track"])
        print(f"{r['scene']:<12} {r['person']:>6} {tr:>5} {100 * r['seen']:4.0f}% "
              f"{r['mix']:6.2f} {r['voice']:6.2f} {r['sdri']:7.2f} {r['oracle_mvdr']:11.2f} "
              f"{r['oracle_gate']:11.2f}")
    matched = [r for r in rows if r["track"] is not None]
    unseen = [r for r in matched if r["seen"] < 0.5]
    print(f"persons: {len(rows)}, with a voice: {len(matched)}")
    for label, sel in (("all matched", matched), ("mostly out of view", unseen)):
        if sel:
            print(f"mean SI-SDRi, {label} ({len(sel)}): {np.mean([r['sdri'] for r in sel]):.2f} dB"
                  f" (oracle MVDR {np.mean([r['oracle_mvdr'] for r in sel]):.2f}, oracle gate "
                  f"{np.mean([r['oracle_gate'] for r in sel]):.2f})")
    worse = [r for r in matched if r["sdri"] < 0]
    print(f"voices worse than microphone 0: {len(worse)}")
    per_scene = {r["scene"]: (r["rtf_track"], r["rtf_voices"]) for r in rows}
    tr = np.mean([v[0] for v in per_scene.values()])
    vo = np.mean([v[1] for v in per_scene.values()])
    print(f"real-time factor (one thread, CPU time): tracking {tr:.3f} + voices {vo:.3f} = "
          f"{tr + vo:.3f}")


if __name__ == "__main__":
    main()
