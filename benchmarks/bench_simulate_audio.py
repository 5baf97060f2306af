"""Speed of the acoustic scene renderer: 20 s, nao4, 3 walking talkers, T60 = 0.4 s.

The scene of the simulator's speed target: a 6 x 5 x 3 m room at T60 = 0.4 s, the
4-microphone NAO array (``nao4``) near the middle, three talkers walking at 0.5-1 m/s between
random waypoints, 20 s at 16 kHz. Signals are synthetic and speech-like: Gaussian noise under a
syllabic (4-6 Hz) amplitude modulation. Two speech patterns are timed:

- ``continuous``: every talker speaks the whole 20 s (worst case: no silent block to skip);
- ``turns``: the talkers take turns (each speaks about a third of the time, 1-3 s turns).

avtrack renders with :func:`avtrack.simulate.acoustics.render` (a new early RIR every 5 cm of
each path, hybrid image-source / diffuse-tail model). The peer is one full pyroomacoustics
simulation of the same room with the talkers *static* at their starting points
(``ShoeBox(..., materials=Material(alpha), max_order=order)`` with ``alpha, order =
inverse_sabine(0.4, dims)``, then ``simulate()``: every RIR by the image-source method and the
convolutions). ``x pra`` is avtrack's time divided by the peer's: below 1 means faster than a
single static pyroomacoustics simulation of the scene.

Times are the best of ``--repeats`` runs (after a warm-up run) with the garbage collector paused,
measured as CPU time of this process (``time.process_time``) and wall time. Run it on one core:

    taskset -c 0 python benchmarks/bench_simulate_audio.py            # OMP etc. set to 1 here
    taskset -c 0 python benchmarks/bench_simulate_audio.py --arrays nao4 nao4-hrir kemar

The ``*-hrir`` / ``kemar`` arrays need the shared data (``../shared/data``).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # single-threaded BLAS / FFT before NumPy is imported

import argparse  # noqa: E402
import datetime as dt  # noqa: E402
import gc  # noqa: E402
import importlib.metadata  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402

import numpy as np  # noqa: E402
import pyroomacoustics as pra  # noqa: E402

from avtrack.audio.arrays import builtin_array  # noqa: E402
from avtrack.io.base import atomic_write  # noqa: E402
from avtrack.simulate.acoustics import (  # noqa: E402
    ArrayPose,
    MovingSource,
    Room,
    array_to_room,
    render,
)

FS = 16000
DURATION_S = 20.0
DIMS = (6.0, 5.0, 3.0)
T60 = 0.4
ARRAY_POSE = ArrayPose([3.0, 2.5, 1.2], yaw_deg=0.0)
N_TALKERS = 3


def speech_like(n: int, rng: np.random.Generator) -> np.ndarray:
    """Gaussian noise under a syllabic amplitude modulation (4-6 Hz), ``(n,)``."""
    t = np.arange(n) / FS
    rate = rng.uniform(4.0, 6.0)
    env = np.maximum(0.0, np.sin(2 * np.pi * rate * t + rng.uniform(0, 2 * np.pi))) ** 2
    return rng.standard_normal(n) * env


def turn_mask(n: int, talker: int, rng: np.random.Generator) -> np.ndarray:
    """Turn-taking: talkers speak in rotation, turns of 1-3 s; ``(n,)`` bool for ``talker``."""
    mask = np.zeros(n, dtype=bool)
    t, who = 0, 0
    while t < n:
        length = int(rng.uniform(1.0, 3.0) * FS)
        if who == talker:
            mask[t : t + length] = True
        t += length
        who = (who + 1) % N_TALKERS
    return mask


def walk(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Knot times ``(K,)`` and positions ``(K, 3)`` of a walk between random waypoints at
    0.5-1 m/s, mouth height 1.5-1.7 m (>= 0.3 m above the array), waypoints at least 0.5 m
    from the walls and 0.7 m from the array."""
    times, points = [0.0], []
    lo, hi = np.array([0.5, 0.5]), np.array(DIMS[:2]) - 0.5

    def waypoint() -> np.ndarray:
        while True:
            p = rng.uniform(lo, hi)
            if np.linalg.norm(p - ARRAY_POSE.position[:2]) > 0.7:
                return np.array([p[0], p[1], rng.uniform(1.5, 1.7)])

    points.append(waypoint())
    while times[-1] < DURATION_S:
        nxt = waypoint()
        speed = rng.uniform(0.5, 1.0)
        times.append(times[-1] + np.linalg.norm(nxt - points[-1]) / speed)
        points.append(nxt)
    return np.array(times), np.array(points)


def scene(pattern: str, seed: int = 0) -> list[MovingSource]:
    rng = np.random.default_rng(seed)
    n = int(DURATION_S * FS)
    sources = []
    for k in range(N_TALKERS):
        x = speech_like(n, rng)
        if pattern == "turns":
            x = x * turn_mask(n, k, rng)
        times, points = walk(rng)
        sources.append(MovingSource(x, times, points))
    return sources


def peer_simulation(sources: list[MovingSource], mics: np.ndarray) -> Callable[[], np.ndarray]:
    """pyroomacoustics ``simulate()`` of the scene with the talkers at their first positions."""
    alpha, order = pra.inverse_sabine(T60, DIMS)

    def run() -> np.ndarray:
        room = pra.ShoeBox(
            list(DIMS), fs=FS, materials=pra.Material(alpha), max_order=order,
            air_absorption=False,
        )  # fmt: skip
        for s in sources:
            room.add_source(s.positions[0], signal=s.signal)
        room.add_microphone_array(mics.T)
        room.simulate()
        return room.mic_array.signals

    return run


def best_time(fn: Callable[[], object], repeats: int) -> tuple[float, float]:
    """Best CPU and wall time (s) of ``repeats`` runs after a warm-up run."""
    fn()
    cpu, wall = [], []
    for _ in range(repeats):
        gc.collect()
        gc.disable()
        try:
            c0, w0 = time.process_time(), time.perf_counter()
            fn()
            cpu.append(time.process_time() - c0)
            wall.append(time.perf_counter() - w0)
        finally:
            gc.enable()
    return min(cpu), min(wall)


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    try:
        cores = f"{len(os.sched_getaffinity(0))} CPU(s) available to this process"
    except AttributeError:
        cores = f"{os.cpu_count()} CPU(s)"
    return (
        f"{cpu} ({cores}), {platform.system()} {platform.release()}; Python "
        f"{platform.python_version()}, NumPy {np.__version__}, SciPy "
        f"{importlib.metadata.version('scipy')}, pyroomacoustics {pra.__version__}"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--arrays", nargs="+", default=["nao4"])
    parser.add_argument("--patterns", nargs="+", default=["continuous", "turns"])
    parser.add_argument("--markdown", help="also write the table to this file")
    args = parser.parse_args(argv)
    room = Room(DIMS, T60, FS)
    rows = []
    peer_done: dict[str, tuple[float, float]] = {}
    for pattern in args.patterns:
        sources = scene(pattern)
        for name in args.arrays:
            array = builtin_array(name)
            cpu, wall = best_time(lambda a=array, s=sources: render(room, a, ARRAY_POSE, s),
                                  args.repeats)  # fmt: skip
            if pattern not in peer_done:
                mics = array_to_room(ARRAY_POSE, builtin_array("nao4").positions)
                peer_done[pattern] = best_time(peer_simulation(sources, mics), args.repeats)
            p_cpu, p_wall = peer_done[pattern]
            rows.append((pattern, name, cpu, wall, p_cpu, p_wall))
            print(
                f"{pattern:10s} {name:10s} avtrack {cpu:6.2f} s CPU ({wall:6.2f} s wall)  "
                f"pra static simulate() {p_cpu:6.2f} s CPU  x pra {cpu / p_cpu:5.2f}  "
                f"real-time factor {cpu / DURATION_S:5.3f}",
                flush=True,
            )
    lines = [
        f"20 s at {FS} Hz, 3 talkers walking 0.5-1 m/s, {DIMS[0]:g} x {DIMS[1]:g} x "
        f"{DIMS[2]:g} m room, T60 = {T60} s; best of {args.repeats} runs.",
        "",
        "| speech | array | avtrack render, s (CPU) | pra static simulate(), s (CPU) | x pra |",
        "|---|---|---:|---:|---:|",
    ]
    for pattern, name, cpu, _, p_cpu, _ in rows:
        lines.append(f"| {pattern} | {name} | {cpu:.2f} | {p_cpu:.2f} | {cpu / p_cpu:.2f} |")
    stamp = dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines += ["", f"Machine: {machine()}. Date: {stamp}.", ""]
    text = "\n".join(lines)
    print()
    print(text)
    if args.markdown:
        with atomic_write(args.markdown, "w") as fh:
            fh.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
