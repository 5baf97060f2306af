"""Running work items: serially, in local processes, or on a Dask distributed cluster.

Every backend runs the same pure function (:func:`avtrack.batch.suite.run_item`) on the same
items and returns the rows in item order, so the tables are identical whichever ran them (only
the ``seconds`` column differs). Dask is used through ``distributed.Client.map`` -- the
scheduler is a maintained library's job, not ours.
"""

from __future__ import annotations

import csv
import io
import math
import os
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from avtrack.batch.suite import run_item
from avtrack.io.base import atomic_write


def run_items(
    items: Sequence[dict],
    *,
    workers: int = 1,
    scheduler: str | Any | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> list[dict[str, Any]]:
    """Result rows of ``items``, in order.

    Parameters
    ----------
    items : sequence of dict
        Work items from :func:`~avtrack.batch.suite.expand_suite`.
    workers : int
        Local processes (1: in this process).
    scheduler : str or distributed.Client, optional
        A Dask scheduler address (``tcp://host:8786``) or a connected client: run there.
    progress : callable ``(done, total)``, optional
    """
    items = list(items)
    total = len(items)
    if scheduler is not None:
        return _run_dask(items, scheduler, progress)
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    rows: list[dict[str, Any]] = []
    if workers == 1:
        for i, item in enumerate(items):
            rows.append(run_item(item))
            if progress:
                progress(i + 1, total)
        return rows
    with ProcessPoolExecutor(max_workers=min(workers, os.cpu_count() or 1)) as pool:
        for i, row in enumerate(pool.map(run_item, items)):
            rows.append(row)
            if progress:
                progress(i + 1, total)
    return rows


def _run_dask(items: list[dict], scheduler, progress) -> list[dict[str, Any]]:
    from distributed import Client, as_completed

    own = not hasattr(scheduler, "map")
    client = Client(scheduler) if own else scheduler
    try:
        futures = client.map(run_item, items, pure=False)
        for done, _ in enumerate(as_completed(futures), start=1):
            if progress:
                progress(done, len(items))
        return client.gather(futures)  # in item order
    finally:
        if own:
            client.close()


def _columns(rows: list[dict]) -> list[str]:
    cols: list[str] = []
    for row in rows:
        cols += [k for k in row if k not in cols]
    return cols


def write_csv(path: str | Path, rows: list[dict]) -> None:
    """The rows as CSV (atomic)."""
    cols = _columns(rows)
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=cols, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    with atomic_write(path) as fh:
        fh.write(buf.getvalue())


def markdown_table(rows: list[dict], skip: Sequence[str] = ()) -> str:
    """The rows as a markdown table (numbers to 2 decimals)."""
    cols = [c for c in _columns(rows) if c not in skip]

    def fmt(v: Any) -> str:
        if isinstance(v, float):
            return "nan" if math.isnan(v) else f"{v:.2f}"
        return "" if v is None else str(v)

    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    lines += ["| " + " | ".join(fmt(r.get(c)) for c in cols) + " |" for r in rows]
    return "\n".join(lines) + "\n"
