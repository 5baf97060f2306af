"""Entry point of the ``avtrack`` command line.

Bad input exits with status 2 and one readable line on stderr (``avtrack: error: ...``);
unexpected failures exit with status 1 and a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from avtrack import __version__
from avtrack.cli.base import HelpFormatter
from avtrack.errors import InputError

#: Modules under ``avtrack.cli`` that define ``register(subparsers)``, in help order.
COMMAND_MODULES = (
    "demo",
    "track_mot",
    "simulate",
    "localize",
    "track_audio",
    "stream",
    "track_av",
    "robot_sim",
    "track_phd",
    "eval_cmd",
    "bench",
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="avtrack",
        formatter_class=HelpFormatter,
        description="Track several people from a camera, a microphone array, or both.",
        epilog="Run 'avtrack COMMAND --help' for the options and examples of each command.",
    )
    parser.add_argument("--version", action="version", version=f"avtrack {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        importlib.import_module(f"avtrack.cli.{name}").register(sub)
    return parser


#: Arguments that name files a command writes.
OUTPUT_ARGS = ("output", "json", "plot", "markdown")


def refuse_output_over_input(args: argparse.Namespace) -> None:
    """An output file that is one of the command's input files would destroy that input: refuse
    it before anything is computed."""
    from pathlib import Path

    values = {k: v for k, v in vars(args).items() if isinstance(v, Path)}
    inputs = [v for k, v in values.items() if k not in OUTPUT_ARGS and v.is_file()]
    for name in OUTPUT_ARGS:
        out = values.get(name)
        if out is None or not out.exists():
            continue
        for inp in inputs:
            try:
                same = out.samefile(inp)
            except OSError:
                same = False
            if same:
                raise InputError(f"the output ({name}) is the input {inp}: refusing to "
                                 f"overwrite it", out)


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        refuse_output_over_input(args)
        return int(args.func(args) or 0)
    except InputError as exc:
        print(f"avtrack: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("avtrack: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
