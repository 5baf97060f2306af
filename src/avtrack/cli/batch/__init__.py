"""Batch runs: a manifest of recordings x commands x parameters, one output folder per item
and one results table, run serially, in local processes or on a Dask distributed cluster,
with identical results; resumable, and tolerant of failing items and dying workers.

Every item is a command line run through that command's own parser, so the batch belongs to
the command-line layer (:mod:`avtrack.cli.batch.command` registers ``avtrack batch``).
"""

from avtrack.cli.batch.command import register, run
from avtrack.cli.batch.commands import COMMANDS, PATH_FIELDS, BatchCommand
from avtrack.cli.batch.manifest import BUILTIN_MANIFESTS, expand_manifest, load_manifest
from avtrack.cli.batch.runner import (
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
    "register",
    "run",
    "run_item",
    "run_items",
    "write_csv",
]
