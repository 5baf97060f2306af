"""What the benchmark scripts share: where the repository and the shared data are, and how a
``--seeds`` and a ``--set`` option read."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
#: The shared data folder beside the repository.
SHARED_DATA = REPO_ROOT / ".." / "shared" / "data"


def shared_data_dir() -> Path:
    """``$AVTRACK_SHARED_DATA`` or ``<repo>/../shared/data`` (as in ``tests/conftest.py``)."""
    env = os.environ.get("AVTRACK_SHARED_DATA")
    return Path(env) if env else SHARED_DATA


def parse_seeds(text: str) -> list[int]:
    """The seeds of a ``--seeds`` option: a range ``"0-7"`` (both ends included) or a list
    ``"0,3,5"``."""
    if "-" in text:
        lo, hi = (int(x) for x in text.split("-"))
        return list(range(lo, hi + 1))
    return [int(x) for x in text.split(",")]


def add_set_option(parser: argparse.ArgumentParser, what: str) -> None:
    """A repeatable ``--set METHOD:FIELD=VALUE`` option (read by :func:`parse_set`)."""
    parser.add_argument("--set", action="append", default=[], metavar="METHOD:FIELD=VALUE",
                        help=f"override one field of a localizer's configuration {what}, e.g. "
                        "dprtf-eg:variance=0.05, dprtf-eg:dprtf.ctf_length=4 or "
                        "dprtf-eg-fast:still_prior=0.3 (repeatable)")


def parse_set(parser: argparse.ArgumentParser, items: list[str]) -> dict:
    """:func:`overrides` of a ``--set`` option; a bad item stops the parser with its message."""
    try:
        return overrides(items)
    except ValueError as exc:
        parser.error(str(exc))


def overrides(items: list[str]) -> dict:
    """``["dprtf-eg:variance=0.05", ...]`` (a ``--set`` option) -> ``{method: config}`` built
    from each method's default configuration with the fields replaced (nested
    ``dprtf.FIELD`` too)."""
    import dataclasses

    from avtrack.localize import LOCALIZERS

    defaults = {name: cls.Config for name, cls in LOCALIZERS.items()
                if dataclasses.is_dataclass(cls.Config)}
    changes: dict[str, dict[str, dict]] = {}
    for item in items:
        method, sep, rest = item.partition(":")
        field, eq, value = rest.partition("=")
        if not (sep and eq) or method not in defaults:
            raise ValueError(f"--set {item!r}: expected METHOD:FIELD=VALUE with METHOD one of "
                             f"{sorted(defaults)}")
        outer, dot, inner = field.partition(".")
        key = ("dprtf", inner) if dot else ("", outer)
        changes.setdefault(method, {}).setdefault(key[0], {})[key[1]] = _number(value)
    configs = {}
    for method, parts in changes.items():
        cfg = defaults[method]()
        try:
            if "dprtf" in parts:
                cfg = dataclasses.replace(cfg, dprtf=dataclasses.replace(cfg.dprtf,
                                                                         **parts["dprtf"]))
            configs[method] = dataclasses.replace(cfg, **parts.get("", {}))
        except TypeError as exc:
            raise ValueError(f"--set {method}: {exc}") from None
    return configs


def _number(text: str) -> int | float | bool | tuple | None:
    """A ``--set`` value: true/false, none, a number, or numbers separated by commas (a
    tuple, e.g. ``position_velocities_deg_s=-30,0,30``)."""
    if "," in text:
        return tuple(_number(part) for part in text.split(",") if part.strip())
    if text.lower() == "none":
        return None
    if text.lower() in ("true", "false"):
        return text.lower() == "true"
    try:
        return int(text)
    except ValueError:
        return float(text)
