"""Batch runs: a manifest of recordings x commands x parameters, one output folder per item
and one results table, run serially, in local processes or on a Dask distributed cluster,
with identical results; resumable, and tolerant of failing items and dying workers."""

from avtrack.batch.commands import COMMANDS, PATH_FIELDS, BatchCommand
from avtrack.batch.manifest import BUILTIN_MANIFESTS, expand_manifest, load_manifest
from avtrack.batch.runner import (
    MARKER,
    completed_row,
    connect,
    item_folder,
    markdown_table,
    run_item,
    run_items,
    write_csv,
)

__all__ = [
    "BUILTIN_MANIFESTS",
    "COMMANDS",
    "MARKER",
    "PATH_FIELDS",
    "BatchCommand",
    "completed_row",
    "connect",
    "expand_manifest",
    "item_folder",
    "load_manifest",
    "markdown_table",
    "run_item",
    "run_items",
    "write_csv",
]
