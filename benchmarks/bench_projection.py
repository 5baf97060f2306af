"""Cost and accuracy of the point-target projection on the E-Z steps of a TUD-Campus run.

Records every ``alpha`` that :func:`avtrack.vem.updates.exclusive_projection` receives while
``track_mot`` runs over TUD-Campus (MOT15, public detections; see ``bench_mot.py``), then
projects the recorded set with the exact solver (the default) and with the alternating
projections that preceded it (``n_iter=1000, tol=1e-6``), and prints per method the largest
target column sum of the results, the calls left over ``1 + 1e-6``, and the time of the
whole set (best of ``--repeats``, garbage collector paused). The iterations now run in a
plain reference loop, several times slower than the specialised float loops that ran the
same iterates before the exact solver replaced them: their time here is not the old cost.

Usage::

    python benchmarks/bench_projection.py --repeats 20
"""

from __future__ import annotations

import argparse
import gc
import sys
import time
from collections.abc import Callable

import numpy as np

import avtrack.vem.model as models_base
from _common import shared_data_dir  # (the script's own folder is on sys.path)
from avtrack.io.mot import read_mot
from avtrack.vem import updates as vem
from bench_mot import SEQUENCE


def record_inputs() -> list[np.ndarray]:
    """The ``alpha`` of every projection call of one ``track_mot`` run over the sequence."""
    from avtrack.visual.ovbt import track_mot

    dets = read_mot(shared_data_dir() / "mot15" / SEQUENCE / "det" / "det.txt")
    calls: list[np.ndarray] = []
    original = models_base.exclusive_projection

    def recording(alpha: np.ndarray, *args, **kwargs) -> np.ndarray:
        calls.append(alpha.copy())
        return original(alpha, *args, **kwargs)

    models_base.exclusive_projection = recording
    try:
        track_mot(dets)
    finally:
        models_base.exclusive_projection = original
    return calls


def best_time(project: Callable[[np.ndarray], np.ndarray], calls: list[np.ndarray],
              repeats: int) -> float:
    """Seconds to project all ``calls``, best of ``repeats`` after a warm-up."""
    for alpha in calls:
        project(alpha)
    times = []
    gc.disable()
    try:
        for _ in range(repeats):
            start = time.perf_counter()
            for alpha in calls:
                project(alpha)
            times.append(time.perf_counter() - start)
    finally:
        gc.enable()
    return min(times)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=20)
    args = parser.parse_args(argv)
    calls = [a for a in record_inputs() if a.shape[1] > 1]
    projected = sum(a[:, 1:].sum(axis=0).max() > 1.0 for a in calls)
    print(f"{SEQUENCE}: {len(calls)} calls, {projected} with a target column over 1")
    methods = {
        "exact (default)": vem.exclusive_projection,
        "iterations (n_iter=1000, reference loop)": (
            lambda a: vem.exclusive_projection(a, n_iter=1000)
        ),
    }
    print("| method | max column sum - 1 | calls over 1 + 1e-6 | time of all calls (ms) |")
    print("|---|---:|---:|---:|")
    for name, project in methods.items():
        excess = np.array([project(a)[:, 1:].sum(axis=0).max() - 1.0 for a in calls])
        seconds = best_time(project, calls, args.repeats)
        print(f"| {name} | {excess.max():.2e} | {int((excess > 1e-6).sum())} "
              f"| {seconds * 1e3:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
