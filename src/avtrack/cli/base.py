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
