"""Sub-command registry for the ``avtrack`` CLI.

Each sub-command module defines ``register(subparsers)`` that adds its parser and sets
``func`` (a callable ``args -> int`` exit status) with ``parser.set_defaults(func=...)``.
Modules are listed in :data:`avtrack.cli.main.COMMAND_MODULES`.
"""

from __future__ import annotations

import argparse


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Keeps the examples block in descriptions/epilogs as written."""


def add_common(parser: argparse.ArgumentParser) -> None:
    """Options every sub-command accepts."""
    g = parser.add_mutually_exclusive_group()
    g.add_argument("-q", "--quiet", action="store_true", help="print only errors")
    g.add_argument("-v", "--verbose", action="store_true", help="print progress details")


def read_config_mapping(path, what: str) -> dict:
    """The mapping in a ``--config`` YAML file (``{}`` for an empty file), with clear errors.

    Parameters
    ----------
    path : Path
        The file.
    what : str
        What the mapping holds, for the error message (e.g. ``"OVBTConfig fields"``).
    """
    import yaml

    from avtrack.errors import InputError

    if not path.is_file():
        raise InputError("config file not found", path)
    try:
        loaded = yaml.safe_load(path.read_bytes())
    except yaml.YAMLError as exc:
        raise InputError(f"invalid YAML: {str(exc).splitlines()[0]}", path) from None
    if loaded is None:
        return {}
    if not isinstance(loaded, dict):
        raise InputError(f"expected a mapping of {what}", path)
    return loaded
