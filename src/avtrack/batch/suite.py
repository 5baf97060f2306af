"""Benchmark suites: scenes / sequences x tasks x parameters, expanded into work items.

A suite is a YAML file::

    name: my-suite
    items:
      - task: track-mot                 # a registered task (see TASKS)
        inputs: [../shared/data/mot15/TUD-Campus, "walkout:0", "walkout:1"]
        params:                         # every combination of the listed values
          birth_frames: [2, 3]
      - task: localize
        inputs: ["locata-like:0", scenes/locata-1]
        params: {method: [dprtf-eg, srp-phat]}

An input is a folder (a MOTChallenge sequence with ``det/`` and ``gt/``, or a scene directory
written by ``avtrack simulate``) or ``NAME:SEED[:SECONDS]``, a named simulated scene drawn on the
worker (``walkout:3:10`` = ``avtrack simulate walkout --seed 3 --duration 10``).

Each work item is a plain dict (picklable, so it can travel to a process or a Dask worker);
:func:`run_item` computes one result row from it, deterministically.
"""

from __future__ import annotations

import itertools
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from avtrack.errors import InputError
from avtrack.io.base import read_yaml_file
from avtrack.registry import Registry

#: task name -> function(item) -> dict of scores (registered with @register_task).
TASKS: Registry[Callable[[dict], dict[str, Any]]] = Registry("batch task")

#: Decorator registering ``fn(item) -> scores`` as a task under a name.
register_task = TASKS.register


#: Suites usable by name (``avtrack bench smoke``).
BUILTIN_SUITES: dict[str, dict] = {
    "smoke": {
        "name": "smoke",
        "items": [
            {
                "task": "track-mot",
                "inputs": ["walkout:0:10", "walkout:1:10", "meeting:0:10"],
                "params": {"birth_frames": [2, 3]},
            },
            {
                "task": "localize",
                "inputs": ["locata-like:0:10"],
                "params": {"method": ["dprtf-eg", "srp-phat"]},
            },
        ],
    },
}


def load_suite(path: str | Path) -> tuple[str, list[dict]]:
    """A built-in suite by name, or a suite file, expanded into work items."""
    if str(path) in BUILTIN_SUITES:
        return expand_suite(BUILTIN_SUITES[str(path)])
    path = Path(path)
    return expand_suite(read_yaml_file(path, "suite"), path)


def expand_suite(raw: Any, path: str | Path | None = None) -> tuple[str, list[dict]]:
    """Validate a suite mapping and expand it into work items, in a fixed order."""
    if not isinstance(raw, dict):
        raise InputError(f"suite: expected a mapping, got {type(raw).__name__}", path)
    unknown = sorted(set(raw) - {"name", "items"})
    if unknown:
        raise InputError(f"{unknown[0]}: unknown field (allowed: items, name)", path)
    name = raw.get("name", Path(path).stem if path else "suite")
    entries = raw.get("items")
    if not isinstance(entries, list) or not entries:
        raise InputError("items: expected a non-empty list", path)
    base = Path(path).parent if path is not None else Path.cwd()
    items = []
    for i, entry in enumerate(entries):
        field = f"items[{i}]"
        if not isinstance(entry, dict):
            raise InputError(f"{field}: expected a mapping", path)
        extra = sorted(set(entry) - {"task", "inputs", "params"})
        if extra:
            raise InputError(f"{field}.{extra[0]}: unknown field", path)
        task = entry.get("task")
        if task not in TASKS:
            raise InputError(
                f"{field}.task: expected one of {', '.join(TASKS)}, got {task!r}", path
            )
        inputs = entry.get("inputs")
        if not isinstance(inputs, list) or not inputs:
            raise InputError(f"{field}.inputs: expected a non-empty list", path)
        params = entry.get("params") or {}
        if not isinstance(params, dict):
            raise InputError(f"{field}.params: expected a mapping of lists", path)
        grid = {k: v if isinstance(v, list) else [v] for k, v in params.items()}
        for j, spec in enumerate(inputs):
            resolved = _resolve_input(spec, base, path, f"{field}.inputs[{j}]")
            for combo in itertools.product(*grid.values()):
                params_i = dict(zip(grid, combo, strict=True))
                items.append({"task": task, "input": resolved, "params": params_i})
    return str(name), items


def _resolve_input(spec: Any, base: Path, path, field: str) -> str:
    from avtrack.simulate.library import SCENARIOS

    if not isinstance(spec, str) or not spec:
        raise InputError(f"{field}: expected a folder or NAME:SEED, got {spec!r}", path)
    head = spec.split(":")[0]
    if head in SCENARIOS:
        parts = spec.split(":")
        try:
            seed = int(parts[1]) if len(parts) > 1 else 0
            dur = float(parts[2]) if len(parts) > 2 else 20.0
        except ValueError:
            seed, dur = -1, -1.0
        if len(parts) > 3 or seed < 0 or dur <= 0:
            raise InputError(f"{field}: expected NAME:SEED[:SECONDS], got {spec!r}", path)
        return f"{head}:{seed}:{dur:g}"
    folder = Path(spec) if Path(spec).is_absolute() else base / spec
    if not folder.is_dir():
        raise InputError(f"{field}: no such folder and not a named scene: {spec!r}", path)
    return str(folder.resolve())


def materialise(spec: str, workdir: Path) -> Path:
    """The folder of an input: itself, or a named scene simulated into ``workdir``."""
    from avtrack.io.scenario import validate_scenario
    from avtrack.simulate.library import SCENARIOS, named_scenario
    from avtrack.simulate.scene import simulate_scene, write_scene

    name = spec.split(":")[0]
    if name not in SCENARIOS:
        return Path(spec)
    _, seed, dur = spec.split(":")
    out = workdir / spec.replace(":", "_")
    if not (out / "scene.yaml").is_file():
        sc = validate_scenario(named_scenario(name, int(seed), float(dur)))
        write_scene(simulate_scene(sc), out)
    return out


def run_item(item: dict, workdir: str | None = None) -> dict[str, Any]:
    """One result row: the item's task, input and parameters, its scores, and its run time.

    The task runs with one BLAS thread, whatever process runs it (this one, a local worker or a
    Dask worker): a BLAS reduction's order follows its thread count, and the rows of a suite
    must not depend on where it ran. Batch runs spread items, not threads, over the cores.
    """
    from threadpoolctl import threadpool_limits

    task = TASKS[item["task"]]
    with threadpool_limits(limits=1, user_api="blas"), tempfile.TemporaryDirectory(
        prefix="avtrack-bench-"
    ) as tmp:
        wd = Path(workdir) if workdir else Path(tmp)
        t0 = time.perf_counter()
        scores = task({**item, "folder": str(materialise(item["input"], wd))})
        elapsed = time.perf_counter() - t0
    row: dict[str, Any] = {"task": item["task"], "input": _short(item["input"])}
    row.update({f"param.{k}": v for k, v in sorted(item["params"].items())})
    row.update({k: (float(v) if isinstance(v, np.floating) else v) for k, v in scores.items()})
    row["seconds"] = round(elapsed, 3)
    return row


def _short(spec: str) -> str:
    return spec if ":" in spec else Path(spec).name


# ----------------------------------------------------------------------------- built-in tasks
@register_task("track-mot")
def _task_track_mot(item: dict) -> dict[str, Any]:
    """OVBT on a MOTChallenge sequence or a scene directory's detections; MOT scores."""
    from avtrack.config import build_config
    from avtrack.io.datasets import find_seqinfo, read_seqinfo
    from avtrack.io.mot import read_mot
    from avtrack.metrics.mot import evaluate_mot
    from avtrack.visual.ovbt import OVBTConfig, track_mot

    folder = Path(item["folder"])
    params = dict(item["params"])
    if (folder / "scene.yaml").is_file():
        import json

        det = read_mot(folder / "detections.txt", "det")
        gt = read_mot(folder / "gt" / "gt.txt", "gt")
        cam = json.loads((folder / "camera.json").read_text())
        size = (int(cam["width"]), int(cam["height"]))
        app = np.load(folder / "appearance.npy")
        params.setdefault("appearance", "cosine")
        bench = "MOT17"
        fps = cam.get("fps")
    else:
        det = read_mot(folder / "det" / "det.txt", "det")
        gt = read_mot(folder / "gt" / "gt.txt", "gt")
        info = find_seqinfo(folder / "det" / "det.txt")
        seq = read_seqinfo(info) if info else {}
        size = (int(seq["width"]), int(seq["height"])) if "width" in seq else (640, 480)
        app = None
        bench = "MOT15"
        fps = seq.get("frame_rate")
    res = track_mot(det, app, build_config(OVBTConfig, params), image_size=size,
                    fps=float(fps) if fps else None)
    s = evaluate_mot(gt, res, benchmark=bench).as_dict()
    return {k: s[k] for k in ("MOTA", "MOTP", "IDF1", "HOTA", "FP", "FN", "IDSW")}


@register_task("localize")
def _task_localize(item: dict) -> dict[str, Any]:
    """A localizer on a scene directory; thesis §5.5.1 scores at the ROC's best point."""
    from avtrack.audio.arrays import load_array
    from avtrack.io.doa import read_doa_csv
    from avtrack.localize import make_localizer, peak_table
    from avtrack.metrics.doa import roc_sweep

    folder = Path(item["folder"])
    params = dict(item["params"])
    method = params.pop("method", "dprtf-eg-fast")
    if params:
        raise InputError(f"localize: unknown parameters {sorted(params)} (only 'method')")
    import soundfile as sf

    array = load_array(folder / "array.json")
    x, _ = sf.read(folder / "audio.wav", dtype="float64", always_2d=True)
    loc = make_localizer(method, array)
    heat = loc.run(np.ascontiguousarray(x.T))
    table = peak_table(heat, loc.grid, loc.default_threshold, 0.0)
    thr, best = roc_sweep(table, read_doa_csv(folder / "gt" / "doa.csv")).best
    d = best.as_dict()
    return {"MD%": d["MD%"], "FA%": d["FA%"], "MAE": d["MAE"], "threshold": float(thr)}
