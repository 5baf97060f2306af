"""Memory and speed of the streaming API over a long simulated recording.

The target: a 20-minute simulated recording is processed by the streaming API with memory
that stays flat. The script

1. simulates the demo meeting (3 people, NAO-like 4-mic array in free field, camera and head
   detector; :func:`avtrack.simulate.library.demo_scenario`) for ``--minutes`` minutes and writes
   it as a scene directory (cached in ``--work``), then trains the audio-to-image mapping on a
   simulated loudspeaker calibration of its room;
2. runs each pipeline in a fresh process that reads the recording as a stream and samples its
   resident set size (``VmRSS``) every 30 s of stream time:

   - ``doa``: :class:`avtrack.stream.DOAStream` (DP-RTF + EG localizer, von Mises tracker) on
     the WAV piped into standard input, read in 20 ms blocks -- exactly what
     ``cat audio.wav | avtrack stream - --array nao4`` does;
   - ``av``: :class:`avtrack.stream.AVStream` (VAVIT) with the detections of each video frame
     pushed as the frame's 40 ms of audio arrive (the detections file is read up front: it is
     the camera's input, not the tracker's state).

Reported per pipeline: RSS after the first minute and at the end, the least-squares growth
from minute 2 on (MB per minute), and the real-time factor (processing time / stream time).

    python benchmarks/bench_stream.py --minutes 20 --markdown /tmp/stream.md
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import datetime as dt  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

SAMPLE_EVERY_S = 30.0


def rss_mb() -> float:
    """Resident set size of this process, MB (Linux ``/proc/self/status``)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    raise RuntimeError("no VmRSS in /proc/self/status (Linux only)")


# ---------------------------------------------------------------------------- children
def child_doa(scene: Path) -> dict:
    """DOAStream on the WAV arriving on standard input."""
    from avtrack.audio.arrays import builtin_array
    from avtrack.stream import DOAStream, open_wav_stream, wav_blocks

    stream = DOAStream(builtin_array("nao4"))
    samples, next_sample, rows, frames = [], 0, 0, 0
    t0 = time.perf_counter()
    with open_wav_stream("-", fs=stream.fs, channels=4) as (info, handle):
        block = int(0.020 * info.fs)
        for x in wav_blocks(handle, block):
            for f in stream.push(x):
                frames += 1
                rows += len(f.tracks)
            if stream.samples_in >= next_sample:
                samples.append((stream.samples_in / info.fs, rss_mb()))
                next_sample += int(SAMPLE_EVERY_S * info.fs)
    elapsed = time.perf_counter() - t0
    samples.append((stream.samples_in / info.fs, rss_mb()))
    return {"samples": samples, "elapsed": elapsed, "stream_s": stream.samples_in / info.fs,
            "frames": frames, "rows": rows}


def child_av(scene: Path, mapping_path: Path) -> dict:
    """AVStream with the detections of each frame pushed as its audio arrives."""
    import yaml

    from avtrack.av.gllim import load_mapping
    from avtrack.io.mot import read_mot
    from avtrack.stream import AVStream, open_wav_stream, wav_blocks

    scenario = yaml.safe_load((scene / "scene.yaml").read_text())
    fps = float(scenario["fps"])
    size = (int(scenario["camera"]["width"]), int(scenario["camera"]["height"]))
    dets = read_mot(scene / "detections.txt", kind="det")
    app = np.load(scene / "appearance.npy") if (scene / "appearance.npy").is_file() else None
    n_frames = int(np.floor(scenario["duration"] * fps + 1e-9))
    slices = dets.frame_slices(n_frames)
    mapping = load_mapping(mapping_path)
    stream = AVStream(mapping, size, 4, fps=fps)
    samples, next_sample, speaking, out_frames = [], 0, 0, 0
    t0 = time.perf_counter()
    with open_wav_stream(scene / "audio.wav", fs=16000, channels=4) as (info, handle):
        hop = round(info.fs / fps)
        for t, x in enumerate(wav_blocks(handle, hop)):
            outs = []
            if t < n_frames:
                sl = slices[t]
                outs += stream.push_detections(
                    dets.boxes[sl], dets.scores[sl], None if app is None else app[sl]
                )
            outs += stream.push_audio(x)
            out_frames += len(outs)
            speaking += sum(int(o.tracks.speaking.sum()) for o in outs)
            done = (t + 1) * hop
            if done >= next_sample:
                samples.append((done / info.fs, rss_mb()))
                next_sample += int(SAMPLE_EVERY_S * info.fs)
        outs = stream.close(n_frames)
        out_frames += len(outs)
    elapsed = time.perf_counter() - t0
    samples.append((n_frames / fps, rss_mb()))
    return {"samples": samples, "elapsed": elapsed, "stream_s": n_frames / fps,
            "frames": out_frames, "speaking_rows": speaking, "stats": stream.stats}


# ---------------------------------------------------------------------------- parent
def prepare(work: Path, minutes: float, seed: int) -> tuple[Path, Path]:
    from avtrack.av.gllim import save_mapping
    from avtrack.simulate.calibration import scene_setup, simulate_calibration, train_mapping
    from avtrack.simulate.library import demo_scenario
    from avtrack.simulate.scene import simulate_scene, write_scene

    scene = work / f"meeting-{minutes:g}min-seed{seed}"
    mapping = work / f"mapping-seed{seed}.npz"
    if not (scene / "audio.wav").is_file():
        t0 = time.perf_counter()
        scenario = demo_scenario(seed, minutes * 60.0)
        write_scene(simulate_scene(scenario), scene)
        print(f"simulated {minutes:g} min in {time.perf_counter() - t0:.0f} s -> {scene}",
              flush=True)
    if not mapping.is_file():
        import yaml

        scenario = yaml.safe_load((scene / "scene.yaml").read_text())
        setup = scene_setup(scenario, scene / "scene.yaml")
        calib = simulate_calibration(*setup, n_positions=120, rng=0)
        save_mapping(mapping, train_mapping(calib, 8, max_iter=50))
    return scene, mapping


def growth_mb_per_min(samples: list[tuple[float, float]]) -> float:
    s = np.array([p for p in samples if p[0] >= 120.0])
    if len(s) < 3:
        return float("nan")
    return float(np.polyfit(s[:, 0] / 60.0, s[:, 1], 1)[0])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=20.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--work", type=Path, default=Path("/tmp/avtrack-stream-bench"))
    ap.add_argument("--markdown", type=Path)
    ap.add_argument("--child", choices=["doa", "av"], help=argparse.SUPPRESS)
    ap.add_argument("--scene", type=Path, help=argparse.SUPPRESS)
    ap.add_argument("--mapping", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child == "doa":
        print(json.dumps(child_doa(args.scene)))
        return 0
    if args.child == "av":
        print(json.dumps(child_av(args.scene, args.mapping)))
        return 0
    args.work.mkdir(parents=True, exist_ok=True)
    scene, mapping = prepare(args.work, args.minutes, args.seed)
    results = {}
    for mode in ("doa", "av"):
        cmd = [sys.executable, __file__, "--child", mode, "--scene", str(scene),
               "--mapping", str(mapping)]
        # the recording arrives through a pipe, as from `arecord ... | avtrack stream -`
        feeder = subprocess.Popen(["cat", str(scene / "audio.wav")], stdout=subprocess.PIPE)
        try:
            done = subprocess.run(cmd, stdin=feeder.stdout if mode == "doa" else None,
                                  capture_output=True, text=True, check=True)
        finally:
            feeder.stdout.close()
            feeder.wait()
        results[mode] = json.loads(done.stdout.strip().splitlines()[-1])
        r = results[mode]
        s = r["samples"]
        first = next(v for t, v in s if t >= 60.0)
        print(f"{mode}: {r['stream_s'] / 60:.1f} min streamed in {r['elapsed']:.0f} s "
              f"(RF {r['elapsed'] / r['stream_s']:.3f}); RSS {first:.1f} MB at 1 min, "
              f"{s[-1][1]:.1f} MB at the end, max {max(v for _, v in s):.1f} MB; growth "
              f"{growth_mb_per_min(s):+.3f} MB/min", flush=True)
    if args.markdown:
        lines = [
            f"Machine: {platform.processor() or platform.machine()}, "
            f"{os.cpu_count()} cores, Python {platform.python_version()}; "
            f"{dt.date.today().isoformat()}; `python benchmarks/bench_stream.py --minutes "
            f"{args.minutes:g}`",
            "",
            "| pipeline | stream | RSS at 1 min (MB) | RSS at end (MB) | max RSS (MB) | "
            "growth from min 2 (MB/min) | real-time factor |",
            "|---|---|---|---|---|---|---|",
        ]
        for mode, label in (("doa", "DOAStream (stdin WAV, 20 ms blocks)"),
                            ("av", "AVStream (VAVIT, detections + 40 ms audio)")):
            r = results[mode]
            s = r["samples"]
            first = next(v for t, v in s if t >= 60.0)
            lines.append(
                f"| {label} | {r['stream_s'] / 60:.1f} min | {first:.1f} | {s[-1][1]:.1f} | "
                f"{max(v for _, v in s):.1f} | {growth_mb_per_min(s):+.3f} | "
                f"{r['elapsed'] / r['stream_s']:.3f} |"
            )
        lines.append("")
        lines.append("RSS every 30 s of stream time (MB):")
        lines.append("")
        for mode in ("doa", "av"):
            vals = " ".join(f"{v:.0f}" for _, v in results[mode]["samples"])
            lines.append(f"- {mode}: {vals}")
        args.markdown.write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
