"""Sub-command registry for the ``avtrack`` CLI, and what every sub-command shares.

Each sub-command module defines ``register(subparsers)`` that adds its parser and sets
``func`` (a callable ``args -> int`` exit status) with ``parser.set_defaults(func=...)``.
Modules are listed in :data:`avtrack.cli.main.COMMAND_MODULES`.

Two files, two names. ``--config FILE.yaml`` always holds the parameters of the command's
algorithm, on the commands that run one (``track-mot``, ``track-phd``, ``localize``,
``track-audio`` ...): the fields of its config dataclass (``OVBTConfig``, ``PHDConfig`` ...),
added by :func:`add_algorithm_config_option` and read by :func:`avtrack.config.load_config`,
which checks the file field by field against the dataclass. ``--options FILE.yaml`` holds a
command's own option values by name, on the commands that run no single algorithm (``demo``,
``simulate``, ``eval``, ``batch``, ``convert``), added by :func:`add_options_option`; there
``--config`` is refused with a line that names ``--options``. Either way the errors have one
wording (that of the scenario and suite files: ``FILE: a.b: what is wrong``), options given on
the command line override the file, and the file is checked before any input is read, so a
bad file fails at once.
"""

from __future__ import annotations

import argparse
import functools
import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from avtrack.config import _number_problem, _show, _unknown, read_config_mapping
from avtrack.errors import InputError


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Keeps the examples block in descriptions/epilogs as written."""


def add_command(
    subparsers: argparse._SubParsersAction,
    name: str,
    help: str,
    description: str | None = None,
    epilog: str | None = None,
    aliases: tuple[str, ...] = (),
) -> argparse.ArgumentParser:
    """A sub-command's parser: one-line ``help`` in the command list, ``description`` and the
    examples block ``epilog`` (kept as written) in its ``--help``; ``aliases``, other names
    of the command."""
    return subparsers.add_parser(
        name, help=help, description=description, epilog=epilog, formatter_class=HelpFormatter,
        aliases=list(aliases),
    )


def add_common(
    parser: argparse.ArgumentParser, func: Callable[[argparse.Namespace], int]
) -> None:
    """Options every sub-command accepts (``-q``, ``-v``), and ``func`` the command runs."""
    g = parser.add_mutually_exclusive_group()
    g.add_argument("-q", "--quiet", action="store_true", help="print only errors")
    g.add_argument("-v", "--verbose", action="store_true", help="print progress details")
    parser.add_argument("--force", action="store_true",
                        help="overwrite existing outputs (without it an existing output file, "
                        "or a non-empty output folder, stops the command before any work)")
    parser.set_defaults(func=func)


def add_output_option(parser: argparse.ArgumentParser, metavar: str, help: str) -> None:
    """The required ``-o/--output`` file or directory of a command."""
    parser.add_argument("-o", "--output", type=Path, required=True, metavar=metavar, help=help)


def add_clipping_option(parser) -> None:
    """``--allow-clipping``: the one switch of the audio-input rules
    (:func:`avtrack.audio.recording.read_array_audio`)."""
    parser.add_argument("--allow-clipping", action="store_true",
                        help="accept recordings with clipped samples")


def add_array_option(
    parser: argparse.ArgumentParser | argparse._ArgumentGroup, required: bool = True,
    note: str = "",
) -> None:
    """``--array ARRAY``: a built-in microphone array name or a JSON array file
    (:func:`avtrack.audio.arrays.load_array` reads it)."""
    from avtrack.audio.arrays import BUILTIN_ARRAYS

    parser.add_argument(
        "--array",
        required=required,
        metavar="ARRAY",
        help=f"built-in array ({', '.join(BUILTIN_ARRAYS)}) or a JSON file{note}",
    )


def add_localizer_option(parser: argparse.ArgumentParser, note: str = "") -> None:
    """``--method NAME``: the localizer of the heat maps (a registered name, default
    :data:`~avtrack.localize.base.DEFAULT_LOCALIZER`); ``note`` adds to the help."""
    from avtrack.localize import DEFAULT_LOCALIZER, LOCALIZERS

    parser.add_argument(
        "--method",
        choices=sorted(LOCALIZERS),
        default=DEFAULT_LOCALIZER,
        help=f"localizer{note}; default: {DEFAULT_LOCALIZER} (DPRTF-EG with position weights "
        "in velocity layers, each frame's map read 0.2 s later through a fixed-lag smoother; "
        "dprtf-eg-fast: the same map without the smoother, no delay; dprtf-eg-static: for "
        "talkers who stay in place; dprtf-eg: the thesis's estimator)",
    )


def add_algorithm_config_option(
    parser: argparse.ArgumentParser, fields: str, note: str = ""
) -> None:
    """``--config FILE.yaml``: the parameters of the command's algorithm, a YAML mapping of the
    fields of its config dataclass (``fields``, in words: ``"OVBTConfig"``; ``note`` adds to
    the help). The command reads it with :func:`avtrack.config.load_config`; options that set
    a field on the command line win over the file."""
    parser.add_argument(
        "--config",
        type=Path,
        metavar="FILE.yaml",
        help=f"the algorithm's parameters: a YAML mapping of {fields} fields{note} (see the "
        "examples below)",
    )


def add_grid_options(parser: argparse.ArgumentParser, example: str, use: str) -> None:
    """``--grid-step DEG`` and ``--elevations E1,E2,...``: a localizer's candidate directions
    (:func:`grid_from_options` builds them); ``example`` and ``use`` complete the help of
    ``--elevations`` (an example value, what the command does with the elevations)."""
    parser.add_argument(
        "--grid-step",
        type=float,
        default=5.0,
        metavar="DEG",
        help="azimuth spacing of the candidate directions (default 5)",
    )
    parser.add_argument(
        "--elevations",
        metavar="E1,E2,...",
        help=f"candidate elevations in degrees, e.g. --elevations={example} (default: "
        "0,20,40,60 for a planar array, -40..60 for a 3-D one, 0 for a line of microphones "
        f"or an HRIR array; {use})",
    )


def grid_from_options(step_deg: float, elevations: str | None, array: Any) -> Any:
    """The :class:`~avtrack.localize.DirectionGrid` of ``--grid-step`` and ``--elevations``
    (default: the elevations the microphone array ``array`` can tell apart,
    :meth:`~avtrack.localize.DirectionGrid.for_array`); a bad value is an error naming its
    option."""
    from avtrack.localize import DirectionGrid  # (avtrack --help imports no NumPy)

    try:
        DirectionGrid.azimuths(step_deg)
    except ValueError as exc:
        raise InputError(f"--grid-step: {exc}") from None
    try:
        return DirectionGrid.from_options(step_deg, elevations, array)
    except ValueError as exc:
        raise InputError(f"--elevations: {exc}") from None


def write_json(path: Path, record: Mapping[str, Any]) -> None:
    """Write ``record`` as JSON indented by 2, with a final newline, atomically (the scores
    files of ``--json`` and the reports)."""
    import json

    from avtrack.io.base import atomic_write  # (avtrack --help imports no NumPy)

    with atomic_write(path) as fh:
        json.dump(record, fh, indent=2)
        fh.write("\n")


# -- options from a file --------------------------------------------------------------------
class _Unset:
    """Default of an option that ``--config`` may set: not given on the command line."""

    def __init__(self, value: Any):
        self.value = value

    def __repr__(self) -> str:
        return repr(self.value)

    def __str__(self) -> str:  # ``%(default)s`` in help texts
        return str(self.value)


#: Action kinds a file can set: a value, or a switch.
_SETTABLE = (argparse._StoreAction, argparse._StoreTrueAction, argparse._StoreFalseAction)
#: Options that are not settings: what to print, how much to print, the file itself.
_NOT_SETTINGS = ("help", "version", "quiet", "verbose", "config", "force")


def _settings(parser: argparse.ArgumentParser, exclude) -> dict[str, argparse.Action]:
    out: dict[str, argparse.Action] = {}
    for action in parser._actions:
        if action.dest in _NOT_SETTINGS or action.dest in exclude or action.required:
            continue
        if not action.option_strings and action.nargs != "?":
            continue  # required positionals: inputs, always on the command line
        if isinstance(action, _SETTABLE):
            out[action.dest] = action
    return out


def _option_value(action: argparse.Action, value: Any, field: str, path) -> Any:
    """A YAML value for an option, checked as the command line would check its text."""
    if isinstance(action, argparse._StoreTrueAction | argparse._StoreFalseAction):
        if not isinstance(value, bool):
            raise InputError(f"{field}: expected true or false, got {_show(value)}", path)
        return value
    kind = action.type
    if kind is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise InputError(f"{field}: expected an integer, got {_show(value)}", path)
    elif kind is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise InputError(f"{field}: {_number_problem(value)}", path)
        value = float(value)  # as from the command line
    elif kind is None or kind is str or kind is Path:
        if not isinstance(value, str) or not value:
            what = "a path" if kind is Path else "a string"
            raise InputError(f"{field}: expected {what}, got {_show(value)}", path)
        value = Path(value) if kind is Path else value
    elif callable(kind):
        if not isinstance(value, str):
            value = str(value)
        try:
            value = kind(value)
        except (TypeError, ValueError, argparse.ArgumentTypeError) as exc:
            raise InputError(f"{field}: {exc}", path) from None
    if action.choices is not None and value not in action.choices:
        raise InputError(
            f"{field}: expected one of {', '.join(map(str, action.choices))}, got "
            f"{_show(value)}",
            path,
        )
    return value


def add_options_option(parser: argparse.ArgumentParser, exclude: tuple[str, ...] = ()) -> None:
    """Add ``--options FILE.yaml`` holding values of this parser's options.

    A key is an option's long name with ``_`` for ``-`` (``--n-frames 10`` is
    ``n_frames: 10``, ``--mot`` is ``mot: true``); an optional positional is a key too. Values
    mean what they mean on the command line (paths relative to the working directory).
    Options given on the command line override the file. Not settable: required options,
    ``--quiet``/``--verbose``, and the ``exclude`` destinations (actions such as ``--print``).
    ``--config`` (an algorithm's parameters elsewhere) is refused with a line naming
    ``--options``.

    Call it last in ``register``, after ``set_defaults(func=...)``: it wraps ``func`` so that
    the command sees the merged options, and the file is checked before the command starts.
    """
    func = parser.get_default("func")
    if func is None:
        raise RuntimeError("add_options_option: call parser.set_defaults(func=...) first")
    settings = _settings(parser, exclude)
    for action in settings.values():
        action.default = _Unset(action.default)
    keys = ", ".join(sorted(settings))
    parser.add_argument(
        "--options",
        type=Path,
        metavar="FILE.yaml",
        help=f"this command's option values from a YAML mapping (keys: {keys}); options "
        "given on the command line win",
    )
    parser.add_argument("--config", type=Path, dest="misplaced_config", help=argparse.SUPPRESS)

    @functools.wraps(func)
    def run_with_options(args: argparse.Namespace) -> int:
        if args.misplaced_config is not None:
            raise InputError(
                "--config holds an algorithm's parameters and this command runs none: give "
                "its option values with --options FILE.yaml", args.misplaced_config)
        apply_options_file(args, settings)
        check_outputs(args)  # the file may have named the outputs
        return func(args)

    parser.set_defaults(func=run_with_options)


def apply_options_file(args: argparse.Namespace, settings: Mapping[str, argparse.Action]) -> None:
    """Fill the options not given on the command line from ``args.options``, else their
    defaults (in place). Every key of the file is checked, overridden or not."""
    path = args.options
    values = {} if path is None else read_config_mapping(path, "option values", "options")
    unknown = sorted(str(k) for k in values if k not in settings)
    if unknown:
        raise InputError(f"{unknown[0]}: {_unknown(settings)}", path)
    checked = {k: _option_value(settings[k], v, k, path) for k, v in values.items()}
    for dest in settings:
        current = getattr(args, dest)
        if isinstance(current, _Unset):
            setattr(args, dest, checked.get(dest, current.value))


#: Arguments that name files a command writes.
OUTPUT_ARGS = ("output", "json", "plot", "markdown", "report")
#: Commands whose ``--output`` is a folder.
FOLDER_OUTPUTS = ("track-av", "demo", "simulate", "batch", "bench", "robot-sim")
#: Commands whose output folder, when not empty, is resumed rather than refused.
RESUMED_OUTPUTS = ("batch", "bench")
#: Output options that are folders in every command.
FOLDER_ARGS = ("report",)


def check_outputs(args: argparse.Namespace) -> None:
    """The output policy, applied before anything is computed.

    - An output that is one of the command's input files is refused (it would destroy it).
    - An existing output file, or a non-empty output folder, is refused unless ``--force``.
    - A file output must not be a folder, and a folder output must not be a file.
    - The output's location must be creatable: its nearest existing parent is a writable
      folder (not a file).
    """
    from avtrack.io.base import is_char_device  # (avtrack --help imports no NumPy)

    raw = {k: (v.value if isinstance(v, _Unset) else v) for k, v in vars(args).items()}
    values = {k: v for k, v in raw.items() if isinstance(v, Path)}
    inputs = [v for k, v in values.items() if k not in OUTPUT_ARGS and v.is_file()]
    force = bool(raw.get("force", False))
    for name in OUTPUT_ARGS:
        out = values.get(name)
        if out is None or str(out) == "-":
            continue
        folder = name in FOLDER_ARGS or (
            name == "output" and getattr(args, "command", None) in FOLDER_OUTPUTS)
        option = "-o" if name == "output" else f"--{name}"
        if not folder and is_char_device(out):
            continue  # /dev/null and other devices take what is written to them
        if out.exists():
            for inp in inputs:
                try:
                    same = out.samefile(inp)
                except OSError:
                    same = False
                if same:
                    raise InputError(f"the output ({name}) is the input {inp}: refusing to "
                                     f"overwrite it", out)
            if folder and not out.is_dir():
                raise InputError(f"{option} must be a folder; this is a file", out)
            if not folder and out.is_dir():
                raise InputError(f"{option} must name a file; this is a folder", out)
            resumed = folder and getattr(args, "command", None) in RESUMED_OUTPUTS
            if not force and not resumed and (not folder or any(out.iterdir())):
                what = "folder is not empty" if folder else "file exists"
                raise InputError(f"the output {what}; give --force to overwrite it", out)
        parent = out if (folder and out.is_dir()) else out.parent
        while not parent.exists() and parent != parent.parent:
            parent = parent.parent
        if not parent.is_dir():
            raise InputError(f"cannot create {option} there: {parent} is a file, not a folder",
                             out)
        if not os.access(parent, os.W_OK | os.X_OK):
            raise InputError(f"cannot write {option} there: {parent} is not writable", out)



__all__ = [
    "HelpFormatter",
    "add_algorithm_config_option",
    "add_array_option",
    "add_clipping_option",
    "add_command",
    "add_common",
    "add_grid_options",
    "add_options_option",
    "add_output_option",
    "apply_options_file",
    "check_outputs",
    "grid_from_options",
    "write_json",
]
