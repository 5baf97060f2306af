"""Entry point of the ``avtrack`` command line.

Bad input exits with status 2 and one readable line on stderr (``avtrack: error: ...``);
unexpected failures exit with status 1 and a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from avtrack import __version__
from avtrack.cli.base import HelpFormatter, check_outputs
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
    "convert",
    "batch",
)

#: Other names of commands: alias -> command.
ALIASES = {"bench": "batch"}


#: One line of help per command, for ``avtrack --help`` without importing every command
#: (and NumPy, SciPy ... with them); a test keeps these equal to what the modules register.
COMMAND_HELP = {
    "demo": "simulate a meeting, track and diarize it, print the scores, write a report",
    "track-mot": "track MOTChallenge detections (visual VEM tracker, OVBT)",
    "simulate": "simulate an audio-visual scene (room acoustics, camera, detections, ground "
                "truth)",
    "localize": "frame-wise multi-speaker localization from a microphone-array WAV",
    "track-audio": "acoustic multi-speaker tracking (localization + VEM tracker)",
    "stream": "localize and track speakers on a live WAV stream (stdin or a file)",
    "track-av": "audio-visual tracking and diarization of a scene directory",
    "robot-sim": "simulate a moving robot head tracking and servoing people (thesis §3.2)",
    "track-phd": "audio-visual SMC-PHD tracking of AV16.3 (particle flow, Liu et al.)",
    "eval": "score a result against ground truth",
    "convert": "a dataset's files as track-av's inputs (DOA CSV, CAMERA.yaml)",
    "batch": "run a manifest of recordings x commands x parameters (serially, in processes or "
             "on a Dask cluster), scored, resumable",
}


def command_name(module: str) -> str:
    """The sub-command a module of :data:`COMMAND_MODULES` registers."""
    return module.removesuffix("_cmd").replace("_", "-")


def module_of(command: str) -> str:
    """The module of :data:`COMMAND_MODULES` that registers ``command`` (or its alias)."""
    command = ALIASES.get(command, command)
    for m in COMMAND_MODULES:
        if command_name(m) == command:
            return m
    raise ValueError(f"unknown command {command!r}")


def build_parser(only: tuple[str, ...] | None = None) -> argparse.ArgumentParser:
    """The command-line parser. ``only``: the modules to import and register in full (the
    others get a stub with their one-line help); default all of them."""
    parser = argparse.ArgumentParser(
        prog="avtrack",
        formatter_class=HelpFormatter,
        description="Track several people from a camera, a microphone array, or both.",
        epilog="Run 'avtrack COMMAND --help' for the options and examples of each command.",
    )
    parser.add_argument("--version", action="version", version=f"avtrack {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        if only is None or name in only:
            importlib.import_module(f"avtrack.cli.{name}").register(sub)
        else:
            cmd = command_name(name)
            sub.add_parser(cmd, help=COMMAND_HELP.get(cmd), add_help=False,
                           aliases=[a for a, c in ALIASES.items() if c == cmd])
    return parser


def _modules_for(argv: list[str]) -> tuple[str, ...]:
    """The command module that ``argv`` calls (none for ``avtrack --help`` and the like)."""
    first = next((a for a in argv if not a.startswith("-")), None)
    first = ALIASES.get(first, first) if first else first
    return tuple(m for m in COMMAND_MODULES if command_name(m) == first)


class Terminated(KeyboardInterrupt):
    """SIGTERM, turned into the same unwinding as Ctrl-C so that temporaries are removed."""


def _terminate(signum, frame) -> None:
    raise Terminated()


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(_modules_for(argv))
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    import signal
    import threading

    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, _terminate)
    try:
        check_outputs(args)
        return int(args.func(args) or 0)
    except InputError as exc:
        print(f"avtrack: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # the reader of our output went away (``... -o - | head``): stop quietly
        import os

        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    except OSError as exc:
        # the system refused (disk full, permissions, a path that is a folder ...): one line
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"avtrack: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return 2
    except Terminated:
        print("avtrack: terminated", file=sys.stderr)
        return 143
    except KeyboardInterrupt:
        print("avtrack: interrupted", file=sys.stderr)
        return 130
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":
    sys.exit(main())
