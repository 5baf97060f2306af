"""Peak memory of the file commands against the recording's length.

Builds long 4-microphone recordings by repeating the shared real ReSpeaker recordings (all
six files one after the other, as many times as needed; 16-bit PCM like the originals), runs
``avtrack localize``, ``avtrack track-audio`` and ``avtrack track-av`` (a recording of one's own:
the WAV, head detections at 25 fps and a camera file) on each length in a fresh process, and
prints the process's peak resident memory (``ru_maxrss``) with the ratio of each length's peak
to the shortest one's. An 8-microphone recording is made the same way from a free-field simulation
when ``--eight`` is given (one ring of AV16.3: 8 microphones, radius 10 cm).

    python benchmarks/bench_memory.py --minutes 1 10
    python benchmarks/bench_memory.py --minutes 1 10 --commands track-av
    python benchmarks/bench_memory.py --minutes 1 20 --eight
    python benchmarks/bench_memory.py --minutes 1 120 --commands track-audio --eight-only

A length's peak should be close to the shortest one's: the commands read the audio in blocks
and write their rows as they are produced.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import soundfile as sf

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT / ".." / "shared" / "data" / "realaudio" / "respeaker"

CHILD = """
import resource, subprocess, sys, time
t0 = time.perf_counter()
rc = subprocess.run([sys.executable, "-m", "avtrack", *sys.argv[1:]]).returncode
wall = time.perf_counter() - t0
peak_kib = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
print("__PEAK__", rc, peak_kib, wall)
"""


def build(out: Path, sources: list[np.ndarray], fs: int, minutes: float) -> Path:
    """A 16-bit WAV of ``minutes`` made of ``sources`` ``(channels, n)`` repeated, written
    block by block."""
    n_total = int(minutes * 60 * fs)
    with sf.SoundFile(out, "w", fs, sources[0].shape[0], "PCM_16") as fh:
        done, k = 0, 0
        while done < n_total:
            x = sources[k % len(sources)]
            take = min(x.shape[1], n_total - done)
            fh.write(x[:, :take].T)
            done, k = done + take, k + 1
    return out


#: Frame rate of the detections of ``track-av``.
FPS = 25.0

#: The camera of ``track-av``, in the array's frame, where the detections' heads agree with the
#: ReSpeaker recordings' talkers (no warning from the camera check).
CAMERA_YAML = """\
fx: 554.3
fy: 554.3
cx: 320.0
cy: 240.0
width: 640
height: 480
position: [0.0, 0.0, 0.05]
yaw_deg: -160.0
pitch_deg: 20.0
"""


def write_detections(out: Path, minutes: float) -> Path:
    """MOTChallenge detections of two heads swaying slowly at 25 fps for ``minutes``."""
    n = round(minutes * 60 * FPS)
    f = np.arange(1, n + 1)
    sway = 40.0 * np.sin(2 * np.pi * f / (FPS * 12.0))
    with open(out, "w") as fh:
        for k, dx in zip(f.tolist(), sway.tolist(), strict=True):
            for x0 in (180.0, 420.0):
                fh.write(f"{k},-1,{x0 + dx:.1f},150.0,60.0,80.0,0.9,-1,-1,-1\n")
    return out


def command_argv(command: str, wav: Path, array, work: Path, minutes: float) -> list[str]:
    """The ``avtrack`` command line measured for ``command`` on ``wav``."""
    if command == "track-av":
        det = write_detections(work / f"det-{minutes:g}.txt", minutes)
        cam = work / "camera.yaml"
        cam.write_text(CAMERA_YAML)
        return ["track-av", "--audio", str(wav), "--array", str(array), "--detections",
                str(det), "--fps", f"{FPS:g}", "--camera", str(cam), "-o",
                str(work / f"av-{minutes:g}"), "--quiet", "--force"]
    extra = ["--tracker", "vonmises"] if command == "track-audio" else []
    return [command, str(wav), "--array", str(array), "-o", str(work / "out.csv"), "--quiet",
            "--force", *extra]


def run(argv: list[str]) -> tuple[float, float]:
    """Peak RSS (MB) and wall time (s) of ``avtrack argv`` in a fresh process."""
    proc = subprocess.run([sys.executable, "-c", CHILD, *argv], capture_output=True, text=True,
                          check=False)
    line = [x for x in proc.stdout.splitlines() if x.startswith("__PEAK__")]
    if proc.returncode or not line:
        raise SystemExit(f"avtrack {' '.join(argv)} failed:\n{proc.stderr[-2000:]}")
    _, rc, kib, wall = line[-1].split()
    if int(rc) != 0:
        raise SystemExit(f"avtrack {' '.join(argv)} exited {rc}:\n{proc.stderr[-2000:]}")
    return int(kib) / 1024.0, float(wall)


def real_sources() -> tuple[list[np.ndarray], int, Path]:
    files = sorted(SHARED.glob("*/*/*.wav"))
    if not files:
        raise SystemExit(f"no ReSpeaker recordings under {SHARED.resolve()}")
    xs, fs = [], 16000
    for f in files:
        x, fs = sf.read(f, dtype="float64", always_2d=True)
        xs.append(x.T)
    return xs, fs, SHARED / "respeaker4.json"


def eight_sources(work: Path) -> tuple[list[np.ndarray], int, str]:
    """A 30 s simulated meeting recorded by an 8-microphone circle: one of AV16.3's two rings
    (radius 10 cm), written to ``work`` as an array file (the built-in ``av163`` is both rings,
    16 microphones)."""
    from avtrack.audio.arrays import AV163_RADIUS, MicArray, write_array_json
    from avtrack.io.scenario import validate_scenario
    from avtrack.simulate.library import named_scenario
    from avtrack.simulate.scene import simulate_scene

    phi = np.deg2rad(45.0 * np.arange(8))
    ring = AV163_RADIUS * np.stack([np.cos(phi), np.sin(phi), np.zeros(8)], axis=1)
    path = work / "circle8.json"
    write_array_json(path, MicArray("circle8", ring))
    raw = named_scenario("meeting", 0, 30.0)
    raw["array"] = {**raw["array"], "name": str(path), "hrir": False}
    scene = simulate_scene(validate_scenario(raw))
    return [scene.audio / max(1.0, float(np.abs(scene.audio).max()) * 1.01)], 16000, str(path)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--minutes", type=float, nargs="+", default=[1.0, 10.0])
    p.add_argument("--commands", nargs="+", default=["localize", "track-audio", "track-av"],
                   choices=["localize", "track-audio", "track-av"])
    p.add_argument("--eight", action="store_true", help="also an 8-microphone recording")
    p.add_argument("--eight-only", action="store_true",
                   help="only the 8-microphone recording (e.g. --minutes 1 120 --commands "
                        "track-audio --eight-only)")
    args = p.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        sets = [] if args.eight_only else [("ReSpeaker 4-mic (real, repeated)", *real_sources())]
        if args.eight or args.eight_only:
            sets.append(("8-mic circle, AV16.3 ring (simulated, repeated)", *eight_sources(work)))
        print("| recording | command | minutes | peak RSS (MB) | vs shortest | wall (s) | RF |")
        print("|---|---|---:|---:|---:|---:|---:|")
        for label, sources, fs, array in sets:
            for command in args.commands:
                first = None
                for minutes in args.minutes:
                    wav = build(work / f"rec-{minutes:g}.wav", sources, fs, minutes)
                    peak, wall = run(command_argv(command, wav, array, work, minutes))
                    first = first or peak
                    print(f"| {label} | {command} | {minutes:g} | {peak:.0f} | "
                          f"{peak / first:.2f} | {wall:.0f} | {wall / (60 * minutes):.3f} |",
                          flush=True)
                    wav.unlink()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
