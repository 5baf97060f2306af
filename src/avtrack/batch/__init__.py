"""Batch evaluation: suites of scenes / sequences x tasks x parameters, run serially, in local
processes or on a Dask distributed cluster, with identical results."""

from avtrack.batch.runner import markdown_table, run_items, write_csv
from avtrack.batch.suite import BUILTIN_SUITES, TASKS, expand_suite, load_suite, run_item

__all__ = [
    "BUILTIN_SUITES",
    "TASKS",
    "expand_suite",
    "load_suite",
    "markdown_table",
    "run_item",
    "run_items",
    "write_csv",
]
