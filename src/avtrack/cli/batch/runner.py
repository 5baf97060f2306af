"""Running work items, one output folder each: serially, in local processes, or on a Dask
cluster; resumable, and tolerant of failing items and dying workers.

Every backend runs the same function (:func:`run_item`) on the same items and returns the rows
in item order, so the tables are identical whichever ran them (only the ``seconds`` column
differs). An item's outputs are written into a temporary folder, renamed onto
``OUT/items/ID`` once complete, and ``OUT/items/ID/result.json`` (its row) is written last,
atomically: a folder with that marker is done, and a rerun reuses its row without running it
again; a folder without it (a run killed half-way) is redone. An item that fails gives a row
with its one-line error and no folder; the others go on.

Dask is used through ``distributed.Client``: the scheduler reruns the items of a worker that
dies (up to its ``allowed-failures``); local processes are given a fresh pool for the items of
a pool whose process died, :data:`POOL_RETRIES` times.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import shutil
import time
import uuid
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Any

import numpy as np

from avtrack.cli.batch.commands import COMMANDS, command_line, run_cli
from avtrack.errors import InputError
from avtrack.io.base import atomic_write

#: The completion marker of an item's folder (its result row, written last).
MARKER = "result.json"
#: Seconds to wait for a Dask scheduler to answer.
CONNECT_TIMEOUT_S = 3.0
#: Fresh process pools tried for the items of a pool whose process died.
POOL_RETRIES = 2
#: Columns that go last in the tables, in this order.
TRAILING = ("status", "error", "seconds")

Progress = Callable[[int, int], None]


def item_folder(root: str | Path, item: dict) -> Path:
    """The output folder of ``item`` under the batch's output folder ``root``."""
    return Path(root) / "items" / item["id"]


def completed_row(root: str | Path, item: dict) -> dict[str, Any] | None:
    """The row of an item whose folder is complete (has its marker), else None."""
    marker = item_folder(root, item) / MARKER
    try:
        return json.loads(marker.read_text())
    except (FileNotFoundError, json.JSONDecodeError):
        return None


def run_item(item: dict, root: str, since: float | None = None) -> dict[str, Any]:
    """Run one item into ``root/items/ID`` and return its result row; a failure is the row's
    ``status`` and ``error``, never an exception. An item completed at or after time
    ``since`` (``time.time()``; an earlier try of this batch, whose worker died before its row
    came back) is not run again: its row is returned.

    The command runs with one BLAS thread, whatever process runs it (this one, a local worker
    or a Dask worker): a BLAS reduction's order follows its thread count, and the rows of a
    batch must not depend on where it ran. Batch runs spread items, not threads, over the
    cores.
    """
    from threadpoolctl import threadpool_limits

    folder = item_folder(root, item)
    if since is not None:
        try:
            if (folder / MARKER).stat().st_mtime >= since:
                done = completed_row(root, item)
                if done is not None:
                    return done
        except FileNotFoundError:
            pass
    tmp = folder.parent / f".{item['id']}.{uuid.uuid4().hex[:8]}.tmp"
    row: dict[str, Any] = {"item": item["id"], "command": item["command"],
                           "input": item["label"]}  # fmt: skip
    row.update({f"param.{k}": v for k, v in sorted(item["params"].items())})
    t0 = time.perf_counter()
    try:
        tmp.mkdir(parents=True)
        with threadpool_limits(limits=1, user_api="blas"):
            scores = _run(item, Path(root), tmp)
        row.update({k: _plain(v) for k, v in scores.items()})
        row["status"] = "ok"
    except Exception as exc:  # the item fails, the batch goes on
        row["status"] = "failed"
        row["error"] = one_line(exc).replace(str(tmp), str(folder))
        shutil.rmtree(tmp, ignore_errors=True)
    row["seconds"] = round(time.perf_counter() - t0, 3)
    if row["status"] == "ok":
        if folder.exists():  # a half-written folder, or one redone with --force
            shutil.rmtree(folder)
        os.replace(tmp, folder)
        with atomic_write(folder / MARKER) as fh:
            json.dump(row, fh, indent=1)
    return row


def _run(item: dict, root: Path, folder: Path) -> dict[str, Any]:
    command = COMMANDS[item["command"]]
    paths: dict[str, str] = {}
    params: dict[str, Any] = {}
    if item["input"] is not None:
        paths, params = command.from_folder(materialise(item["input"], root / "scenes"))
    paths = {**paths, **item["paths"]}
    params = {**params, **item["params"]}
    run_cli(command_line(command, paths, params, folder))
    return command.score(paths, folder, params)


def one_line(exc: BaseException) -> str:
    """An exception as one readable line (an :class:`InputError` as it is)."""
    text = " ".join(str(exc).split())
    return text if isinstance(exc, InputError) else f"{type(exc).__name__}: {text}"


def _plain(v: Any) -> Any:
    if isinstance(v, np.floating | np.integer):
        return v.item()
    return v


def materialise(spec: str, scenes: Path) -> Path:
    """The folder of an input: itself, or a named scene simulated once into ``scenes`` (the
    first complete copy wins; a copy is renamed into place only when complete)."""
    from avtrack.simulate.library import SCENARIOS

    name = spec.split(":")[0]
    if name not in SCENARIOS:
        return Path(spec)
    out = scenes / spec.replace(":", "_")
    if (out / "scene.yaml").is_file():
        return out
    from avtrack.io.scenario import validate_scenario
    from avtrack.simulate.library import named_scenario
    from avtrack.simulate.scene import simulate_scene, write_scene

    _, seed, dur = spec.split(":")
    tmp = scenes / f".{out.name}.{uuid.uuid4().hex[:8]}.tmp"
    try:
        sc = validate_scenario(named_scenario(name, int(seed), float(dur)))
        write_scene(simulate_scene(sc), tmp)
        try:
            os.replace(tmp, out)
        except OSError:  # another worker's copy came first (os.replace keeps a full folder)
            if not (out / "scene.yaml").is_file():
                raise
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return out


# ----------------------------------------------------------------------------- the backends
def run_items(
    items: Sequence[dict],
    root: str | Path,
    *,
    workers: int = 1,
    scheduler: str | Any | None = None,
    redo: bool = False,
    progress: Progress | None = None,
) -> tuple[list[dict[str, Any]], int]:
    """Result rows of ``items``, in order, and how many were reused from complete folders.

    Parameters
    ----------
    items : sequence of dict
        Work items from :func:`~avtrack.cli.batch.manifest.load_manifest`.
    root : str or Path
        The output folder (items go to ``root/items/ID``; named scenes to ``root/scenes``).
        On a cluster, a folder every worker sees at the same path.
    workers : int
        Local processes (1: this process); with ``scheduler="local"``, the local cluster's
        workers.
    scheduler : str or distributed.Client, optional
        A Dask scheduler address (``tcp://host:8786``), ``"local"`` (a local cluster of
        ``workers`` processes started here), or a connected client: run there.
    redo : bool
        Run every item again, complete or not.
    progress : callable ``(done, total)``, optional
    """
    items = list(items)
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    root = Path(root).resolve()
    since = time.time()
    (root / "items").mkdir(parents=True, exist_ok=True)
    _remove_temporaries(root)
    rows: list[dict[str, Any] | None] = [
        None if redo else completed_row(root, item) for item in items]
    todo = [i for i, r in enumerate(rows) if r is None]
    reused = len(items) - len(todo)
    done = [reused]

    def finished(i: int, row: dict[str, Any]) -> None:
        rows[i] = row
        done[0] += 1
        if progress:
            progress(done[0], len(items))

    if progress:
        progress(reused, len(items))
    if todo:
        if scheduler is not None:
            _run_dask(items, todo, str(root), since, scheduler, workers, finished)
        elif workers == 1:
            for i in todo:
                finished(i, run_item(items[i], str(root)))
        else:
            _run_processes(items, todo, str(root), since, workers, finished)
    _remove_temporaries(root)
    return [r for r in rows if r is not None], reused


def _remove_temporaries(root: Path) -> None:
    """Folders of runs that were killed half-way (they never count as done)."""
    for sub in ("items", "scenes"):
        for tmp in (root / sub).glob(".*.tmp"):
            shutil.rmtree(tmp, ignore_errors=True)


def _died(item: dict, what: str) -> dict[str, Any]:
    row: dict[str, Any] = {"item": item["id"], "command": item["command"],
                           "input": item["label"]}  # fmt: skip
    row.update({f"param.{k}": v for k, v in sorted(item["params"].items())})
    row.update({"status": "failed", "error": what, "seconds": float("nan")})
    return row


def _run_processes(items, todo, root, since, workers, finished) -> None:
    for _ in range(POOL_RETRIES + 1):
        broken = []
        with ProcessPoolExecutor(max_workers=min(workers, os.cpu_count() or 1)) as pool:
            futures = {pool.submit(run_item, items[i], root, since): i for i in todo}
            pending = set(futures)
            while pending:
                complete, pending = wait(pending, return_when=FIRST_COMPLETED)
                for f in complete:
                    try:
                        finished(futures[f], f.result())
                    except BrokenProcessPool:
                        broken.append(futures[f])
        todo = sorted(broken)
        if not todo:
            return
    for i in todo:
        finished(i, _died(items[i], f"a worker process died running it ({POOL_RETRIES + 1} "
                                    f"tries)"))


def connect(scheduler: str):
    """A Dask client of the scheduler at ``scheduler``; :class:`InputError` within
    :data:`CONNECT_TIMEOUT_S` seconds when it does not answer."""
    from distributed import Client

    try:
        return Client(scheduler, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        raise InputError(f"cannot reach the Dask scheduler {scheduler} within "
                         f"{CONNECT_TIMEOUT_S:g} s ({one_line(exc)})") from None


def _run_dask(items, todo, root, since, scheduler, workers, finished) -> None:
    from distributed import Client, LocalCluster, as_completed

    cluster = None
    if hasattr(scheduler, "map"):
        client = scheduler
    elif scheduler == "local":
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster, set_as_default=False)
    else:
        client = connect(scheduler)
    try:
        futures = client.map(run_item, [items[i] for i in todo], root=root, since=since,
                             pure=False)
        index = {f.key: i for f, i in zip(futures, todo, strict=True)}
        for f in as_completed(futures, loop=client.loop):
            i = index[f.key]
            try:
                finished(i, f.result())
            except Exception as exc:  # the workers running it died, too often
                finished(i, _died(items[i], one_line(exc)))
    finally:
        if client is not scheduler:
            client.close()
        if cluster is not None:
            cluster.close()


# ------------------------------------------------------------------------------- the tables
def columns(rows: list[dict]) -> list[str]:
    """The tables' columns: the item, its command, input and parameters, then the scores in
    first-seen order, :data:`TRAILING` last."""
    cols: list[str] = []
    for row in rows:
        cols += [k for k in row if k not in cols]
    params = [c for c in cols if c.startswith("param.")]
    lead = ["item", "command", "input", *params]
    return ([c for c in lead if c in cols] + [c for c in cols if c not in lead
            and c not in TRAILING] + [c for c in TRAILING if c in cols])  # fmt: skip


def write_csv(path: str | Path, rows: list[dict]) -> None:
    """The rows as CSV (atomic)."""
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=columns(rows), lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    with atomic_write(path) as fh:
        fh.write(buf.getvalue())


def markdown_table(rows: list[dict], skip: Sequence[str] = ()) -> str:
    """The rows as a markdown table (numbers to 2 decimals)."""
    cols = [c for c in columns(rows) if c not in skip]

    def fmt(v: Any) -> str:
        if isinstance(v, float):
            return "nan" if math.isnan(v) else f"{v:.2f}"
        return "" if v is None else str(v).replace("|", "\\|")

    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    lines += ["| " + " | ".join(fmt(r.get(c)) for c in cols) + " |" for r in rows]
    return "\n".join(lines) + "\n"
