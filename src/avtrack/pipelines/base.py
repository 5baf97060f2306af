"""What the pipelines share: how a long step is announced."""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from contextlib import AbstractContextManager

#: Wraps each long step of a pipeline: called with what the step does (``"localizing
#: 600.0 s"``), it returns a context manager entered while the step runs (the command line's
#: progress display, :func:`avtrack.cli.progress.activity`).
Step = Callable[[str], AbstractContextManager[object]]


def no_step(what: str) -> AbstractContextManager[object]:
    """The default ``step``: nothing is shown."""
    return contextlib.nullcontext()
