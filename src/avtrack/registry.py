"""Named registries of interchangeable implementations (localizers, DOA trackers, SMC-PHD
filters, servo policies, batch tasks).

A :class:`Registry` is a mapping ``name -> implementation`` filled by a class (or function)
decorator. It lives in its family's package (``avtrack.localize``, ``avtrack.doa`` ...), whose
``__init__`` imports every module that registers, so the mapping is complete whenever the
package is imported. The command line takes its choices from it and the contract tests are
parametrised over it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

T = TypeVar("T")


class Registry(dict[str, T]):
    """Implementations by name, filled with :meth:`register`.

    Parameters
    ----------
    what : str
        What the entries are (``"localizer"``), named in errors.

    Registering a name twice is an error unless it is the same object again (a module
    imported twice under one name).
    """

    def __init__(self, what: str) -> None:
        super().__init__()
        self.what = what

    def register(self, name: str) -> Callable[[T], T]:
        """Decorator registering its argument under ``name``; a class also gets ``cls.name``."""
        if not isinstance(name, str) or not name:
            raise TypeError(f"{self.what} registry: name must be a non-empty str, got {name!r}")

        def deco(obj: T) -> T:
            if name in self and self[name] is not obj:
                raise ValueError(f"{self.what} {name!r} is already registered")
            if isinstance(obj, type):
                obj.name = name  # type: ignore[attr-defined]
            self[name] = obj
            return obj

        return deco

    def get_or_raise(self, name: str) -> T:
        """The entry ``name``; ``ValueError`` naming the known ones when there is none."""
        try:
            return self[name]
        except KeyError:
            raise ValueError(
                f"unknown {self.what} {name!r} (known: {', '.join(sorted(self))})"
            ) from None
