"""Progress bars of the ``avtrack`` commands (tqdm, on stderr).

Behaviour, the same for every command:

* bars go to stderr; stdout carries only results, so it can be piped;
* ``--quiet`` turns every bar off;
* a bar is drawn only when stderr is a terminal. In a log file, a pipe, CI or a test's
  captured output nothing is written (a tqdm bar there would be one carriage-return update
  after another in the log); what such runs get is the command's one-line summary;
* a finished bar is erased, so a terminal ends up showing the same lines as a log.

Three shapes:

* :func:`bar` -- a tqdm bar over a known number of items (``bar.update(1)`` per item);
* :func:`counting` -- ticks a bar at each call of a method of an object the command made,
  for library loops that call it once per frame or block (``tracker.run`` calling
  ``self.step``): the library's own loop runs unchanged, so the results are identical;
* :func:`activity` -- an elapsed-time bar for one long library call that reports no
  progress (simulating a scene, tracking a whole sequence).
"""

from __future__ import annotations

import contextlib
import sys
import threading
from collections.abc import Callable, Iterator
from typing import Any

from tqdm import tqdm


def stderr_is_terminal() -> bool:
    """Whether bars can be drawn: stderr is an interactive terminal."""
    try:
        return bool(sys.stderr.isatty())
    except (AttributeError, ValueError):  # replaced or closed stream
        return False


def enabled(quiet: bool) -> bool:
    """Whether a command draws progress bars (see the module docstring)."""
    return not quiet and stderr_is_terminal()


def bar(total: int | None = None, desc: str = "", unit: str = "it", quiet: bool = False) -> tqdm:
    """A tqdm bar on stderr; disabled (a no-op) under ``--quiet`` or when stderr is not a
    terminal."""
    return tqdm(
        total=total,
        desc=desc,
        unit=unit,
        file=sys.stderr,
        leave=False,
        dynamic_ncols=True,
        disable=not enabled(quiet),
    )


@contextlib.contextmanager
def counting(
    obj: Any, method: str, total: int | None, desc: str, unit: str = "it", quiet: bool = False
) -> Iterator[tqdm]:
    """Tick a bar at each call of ``obj.method`` inside the ``with`` block.

    The method is wrapped on the instance only (``obj.__dict__``) and restored on exit; it
    must be called as ``self.method(...)`` by the loop being measured.
    """
    progress = bar(total, desc, unit, quiet)
    if progress.disable:
        with progress:
            yield progress
        return
    original = getattr(obj, method)

    def ticking(*args: Any, **kwargs: Any) -> Any:
        out = original(*args, **kwargs)
        progress.update(1)
        return out

    setattr(obj, method, ticking)
    try:
        with progress:
            yield progress
    finally:
        delattr(obj, method)  # back to the class's method


@contextlib.contextmanager
def activity(desc: str, quiet: bool = False, interval_s: float = 0.5) -> Iterator[None]:
    """An elapsed-time bar (``desc: 12.3s``) while the ``with`` block runs one long call."""
    progress = tqdm(
        total=None,
        desc=desc,
        file=sys.stderr,
        leave=False,
        bar_format="{desc}: {elapsed}",
        disable=not enabled(quiet),
    )
    if progress.disable:
        with progress:
            yield
        return
    done = threading.Event()

    def refresh() -> None:
        while not done.wait(interval_s):
            progress.refresh()

    ticker = threading.Thread(target=refresh, name="avtrack-progress", daemon=True)
    ticker.start()
    try:
        yield
    finally:
        done.set()
        ticker.join()  # no refresh after the bar is closed
        progress.close()


@contextlib.contextmanager
def minutes(
    duration_s: float, desc: str, quiet: bool = False
) -> Iterator[Callable[[float], None]]:
    """A bar of the minutes of a recording processed out of its total; yields the callback
    that takes the seconds processed so far (a pipeline's ``progress``)."""
    progress = tqdm(
        total=round(duration_s / 60.0, 2),
        desc=desc,
        unit="min",
        file=sys.stderr,
        leave=False,
        dynamic_ncols=True,
        bar_format="{desc}: {n:.1f}/{total:.1f} min |{bar}| {elapsed}<{remaining}",
        disable=not enabled(quiet),
    )

    def update(seconds: float) -> None:
        progress.update(round(seconds / 60.0, 2) - progress.n)

    with progress:
        yield update
