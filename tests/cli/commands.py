"""Registering a command module with the CLI for the tests of that command."""

from __future__ import annotations

from collections.abc import Callable

import pytest

import avtrack.cli.main as cli_main


def register_command(monkeypatch: pytest.MonkeyPatch, module: str) -> Callable[..., int]:
    """Add ``avtrack.cli.<module>`` to the CLI's commands (for this test only) if it is not
    there yet; ``avtrack.cli.main.main``."""
    if module not in cli_main.COMMAND_MODULES:
        monkeypatch.setattr(cli_main, "COMMAND_MODULES", (*cli_main.COMMAND_MODULES, module))
    return cli_main.main
