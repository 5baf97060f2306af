"""Numba kernels built on first use, with NumPy forms to fall back on.

Importing Numba costs about 0.5 s, so a kernel is compiled (or loaded from Numba's cache) the
first time it is asked for, not at import. Where Numba is missing, ``AVTRACK_NO_JIT`` is set or
the build fails (warned once), the callers use their NumPy forms.
"""

from __future__ import annotations

import functools
import importlib.util
import os
import warnings
from collections.abc import Callable
from typing import Any

__all__ = ["available", "available_once", "build_once"]


def available() -> bool:
    """Numba is installed and ``AVTRACK_NO_JIT`` is not set (then the NumPy forms are used)."""
    if os.environ.get("AVTRACK_NO_JIT", "") not in ("", "0"):
        return False
    return importlib.util.find_spec("numba") is not None


@functools.cache
def available_once() -> bool:
    """:func:`available`, asked once a process (it looks for Numba on every call): for the
    kernels a tracker consults every frame."""
    return available()


def build_once(
    owner: dict[str, Any], build: Callable[[Callable[..., Any], bool], Any], what: str
) -> Any:
    """The kernel held in ``owner["_KERNEL"]`` (a kernel module's globals), built by
    ``build(njit, cache)`` on the first call; None if it cannot be built here.

    Numba caches the machine code beside the module or in ``~/.cache``; without a writable
    location the kernel is compiled without caching. A failure sets ``owner["_FAILED"]`` and
    warns once, naming ``what``; later calls return None without trying again.
    """
    if owner["_KERNEL"] is None and not owner["_FAILED"]:
        try:
            from numba import njit

            try:
                owner["_KERNEL"] = build(njit, True)
            except RuntimeError:  # no writable cache location (read-only install and home)
                owner["_KERNEL"] = build(njit, False)
        except Exception as exc:  # any failure to build: fall back to NumPy, loudly
            owner["_FAILED"] = True
            warnings.warn(
                f"avtrack: the compiled {what} could not be built ({exc!r}); using the NumPy "
                "form (set AVTRACK_NO_JIT=1 to silence this)",
                RuntimeWarning,
                stacklevel=3,
            )
    return owner["_KERNEL"]
