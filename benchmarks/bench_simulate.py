"""Speed of the whole scene simulator: ``simulate_scene`` + ``write_scene`` of 20 s scenes.

The target: simulating 20 s of a 4-mic, 3-talker scene takes < 20 s on one core.
Timed scenes (all 20 s, 16 kHz, 25 fps):

- ``3 walkers``: a 6 x 5 x 3 m room at T60 = 0.4 s, the free-field ``nao4`` array, three
  people walking between random waypoints at 0.7 m/s, turn-taking speech, diffuse noise at
  20 dB, the camera and detector;
- ``3 walkers, hrir``: the same with the measured NAO HRIRs (``nao4-hrir``);
- ``kinovis-like``: the named scene (three intermittent talkers, NAO HRIRs, fan + diffuse
  noise, 10 x 10 x 5 m room at T60 = 0.5 s).

The peer, run in the same script, is one pyroomacoustics ``simulate()`` of the first scene
with its three talkers *static* at their starting points (every RIR by the image-source method
at the same absorption and order, then the convolutions): ``x pra`` below 1 means the moving
scene, with everything around it, costs less than pyroomacoustics's static one.

Run on one core (BLAS/FFT threads are set to 1 here):

    taskset -c 0 python benchmarks/bench_simulate.py --repeats 3 --markdown /tmp/sim.md

Needs the shared data (``../shared/data``) for the speech utterances and the NAO HRIRs.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import datetime as dt  # noqa: E402
import gc  # noqa: E402
import platform  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pyroomacoustics as pra  # noqa: E402

from avtrack.io.base import atomic_write  # noqa: E402
from avtrack.io.scenario import validate_scenario  # noqa: E402
from avtrack.simulate.library import named_scenario  # noqa: E402
from avtrack.simulate.scene import scene_array, simulate_scene, write_scene  # noqa: E402


def walkers(hrir: bool, seed: int = 0) -> dict:
    area = [[1.0, 5.0], [1.8, 4.5]]
    return validate_scenario(
        {
            "name": "3 walkers" + (", hrir" if hrir else ""),
            "duration": 20.0,
            "seed": seed,
            "room": {"dims": [6.0, 5.0, 3.0], "t60": 0.4},
            "array": {"name": "nao4", "hrir": hrir, "position": [3.0, 1.0, 1.2], "yaw_deg": 90},
            "people": [
                {"motion": {"type": "random-walk", "area": area, "speed": 0.7, "pause_mean": 0.5}}
                for _ in range(3)
            ],
            "speech": {"utterances": "shared"},
        }
    )


def peer(sc: dict, scene) -> Callable[[], np.ndarray]:
    """pyroomacoustics simulate() of the scene's dry speech with the talkers static."""
    dims = sc["room"]["dims"]
    alpha, order = pra.inverse_sabine(sc["room"]["t60"], dims)
    yaw = np.deg2rad(sc["array"]["yaw_deg"])
    rot = np.array([[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]])
    mics = np.asarray(sc["array"]["position"]) + scene_array(sc).positions @ rot.T

    def run() -> np.ndarray:
        room = pra.ShoeBox(
            dims, fs=sc["fs"], materials=pra.Material(alpha), max_order=order,
            air_absorption=False,
        )  # fmt: skip
        for traj, dry in zip(scene.trajectories, scene.dry, strict=True):
            room.add_source(traj.positions[0], signal=dry)
        room.add_microphone_array(mics.T)
        room.simulate()
        return room.mic_array.signals

    return run


def best_time(fn: Callable[[], object], repeats: int) -> float:
    fn()  # warm-up (imports, HRIR loading, caches)
    best = np.inf
    for _ in range(repeats):
        gc.disable()
        t0 = time.process_time()
        fn()
        best = min(best, time.process_time() - t0)
        gc.enable()
    return best


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--markdown", type=Path, help="also write the table here")
    args = ap.parse_args(argv)

    kinovis = named_scenario("kinovis-like", 0, 20.0)
    kinovis = validate_scenario(
        {**kinovis, "speech": {**kinovis["speech"], "utterances": "shared"}}
    )
    scenes = [
        walkers(False),
        walkers(True),
        kinovis,
    ]
    tmp = Path(tempfile.mkdtemp(prefix="bench-sim-"))
    first = simulate_scene(scenes[0])
    t_peer = best_time(peer(scenes[0], first), args.repeats)
    rows = []
    for k, sc in enumerate(scenes):

        def job(sc=sc, k=k):
            write_scene(simulate_scene(sc), tmp / f"scene{k}")

        t = best_time(job, args.repeats)
        scene = simulate_scene(sc)
        talk = sum(s.end - s.start for s in scene.segments)
        rows.append(
            f"| {sc['name']} | {scene.array.n_mics} | {len(scene.ids)} | {talk:.1f} | "
            f"{t:.2f} | {t / sc['duration']:.3f} | {t / t_peer:.2f} |"
        )
    rows.append(
        f"| pyroomacoustics simulate(), 3 static talkers (peer) | 4 | 3 | - | {t_peer:.2f} | "
        f"{t_peer / 20:.3f} | 1.00 |"
    )
    head = [
        "| scene (20 s) | mics | talkers | speech (s) | CPU s | real-time factor | x pra |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    info = (
        f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, "
        f"Python {platform.python_version()}, NumPy {np.__version__}, pyroomacoustics "
        f"{pra.__version__}; best of {args.repeats} (CPU time of this process); "
        f"{dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M} UTC."
    )
    text = "\n".join([*head, *rows, "", info]) + "\n"
    print(text)
    if args.markdown:
        with atomic_write(args.markdown) as fh:
            fh.write(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
