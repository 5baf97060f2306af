"""One contract for every ``avtrack`` sub-command.

The commands are found by walking :func:`avtrack.cli.main.build_parser`, so a new command is
checked without being listed here: ``--help`` with runnable examples, ``--quiet`` /
``--verbose``, and a settings file whose errors are one line naming the file and the field,
raised before any input is read (the inputs given here do not exist): ``--config FILE.yaml``
(the algorithm's parameters) on a command that runs one, ``--options FILE.yaml`` (the
command's own option values) on the others, where ``--config`` is refused naming ``--options``.
"""

from __future__ import annotations

import argparse
import re
import shlex
from pathlib import Path

import numpy as np
import pytest
import yaml

from avtrack.cli import progress
from avtrack.cli.main import build_parser, main
from avtrack.io.doa import DOATable, write_doa_csv


def _subcommands(parser: argparse.ArgumentParser, path: tuple[str, ...] = ()):
    """``(path, parser)`` of every sub-command, groups (``eval``) included."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield (*path, name), sub
                yield from _subcommands(sub, (*path, name))


def _is_group(parser: argparse.ArgumentParser) -> bool:
    return any(isinstance(a, argparse._SubParsersAction) for a in parser._actions)


ALL = dict(_subcommands(build_parser()))
COMMANDS = sorted(path for path, p in ALL.items() if not _is_group(p))
ids = " ".join


def _file_option(path: tuple[str, ...]) -> str:
    """``--options`` where the command takes its option values from a file, else
    ``--config``."""
    options = {s for a in ALL[path]._actions for s in a.option_strings}
    return "--options" if "--options" in options else "--config"


def _argv(path: tuple[str, ...], tmp_path: Path) -> list[str]:
    """A command line that argparse accepts: every required argument gets a dummy value (a
    file that does not exist, the first choice, or 1)."""
    argv = list(path)
    for action in ALL[path]._actions:
        if isinstance(action, argparse._SubParsersAction):
            continue
        if action.option_strings and not action.required:
            continue
        if not action.option_strings and action.nargs in ("?", "*"):
            continue
        if action.choices:
            value = str(next(iter(action.choices)))
        elif action.type in (int, float):
            value = "1"
        else:
            value = str(tmp_path / f"missing-{action.dest}")
        argv += [action.option_strings[0], value] if action.option_strings else [value]
    return argv


def _error_line(capsys) -> str:
    """The only line on stderr (stdout empty)."""
    out, err = capsys.readouterr()
    assert out == ""
    assert err.count("\n") == 1 and err.endswith("\n"), err
    assert err.startswith("avtrack: error: ")
    return err.rstrip("\n")


def _examples(help_text: str) -> list[list[str]]:
    """The arguments of the ``avtrack ...`` lines of the examples block (continuations
    joined, comments and leading ``VAR=value`` settings dropped)."""
    block = help_text[help_text.lower().index("examples:") :]
    commands = []
    for line in block.replace("\\\n", " ").splitlines():
        if not re.match(r"\s*([A-Z_]+=\S+\s+)*avtrack\s", line):
            continue  # prose, YAML, or "Score with:  avtrack ..."
        words = shlex.split(line, comments=True)
        commands.append(words[words.index("avtrack") + 1 :])
    return commands


@pytest.mark.parametrize("path", sorted(ALL), ids=ids)
def test_help_has_runnable_examples(path, capsys):
    with pytest.raises(SystemExit) as exc:
        main([*path, "--help"])
    assert exc.value.code == 0
    text = capsys.readouterr().out
    assert "examples:" in text.lower()
    commands = _examples(text)
    assert any(c[: len(path)] == list(path) for c in commands), commands
    for argv in commands:  # every example parses with today's options
        try:
            build_parser().parse_args(argv)
        except SystemExit as stop:  # "--help" examples exit 0; a bad option exits 2
            assert stop.code == 0, f"example does not parse: avtrack {shlex.join(argv)}"
    capsys.readouterr()


@pytest.mark.parametrize("path", COMMANDS, ids=ids)
def test_quiet_verbose_and_config_options(path, tmp_path):
    parser = build_parser()
    argv = _argv(path, tmp_path)
    assert parser.parse_args([*argv, "--quiet"]).quiet is True
    assert parser.parse_args([*argv, "--verbose"]).verbose is True
    assert parser.parse_args([*argv, "-q"]).verbose is False
    visible = {s for a in ALL[path]._actions if a.help != argparse.SUPPRESS
               for s in a.option_strings}
    assert ("--config" in visible) != ("--options" in visible), visible  # exactly one


@pytest.mark.parametrize("path", [p for p in COMMANDS if _file_option(p) == "--options"],
                         ids=ids)
def test_config_on_an_options_command_is_one_line_naming_options(path, tmp_path, capsys):
    cfg = tmp_path / "algo.yaml"
    cfg.write_text("seed: 1\n")
    assert main([*_argv(path, tmp_path), "--config", str(cfg)]) == 2
    line = _error_line(capsys)
    assert line.startswith(f"avtrack: error: {cfg}: --config holds an algorithm's parameters")
    assert "--options FILE.yaml" in line


def _allowed_fields(path, tmp_path, capsys) -> list[str]:
    cfg = tmp_path / "unknown.yaml"
    cfg.write_text("no_such_field: 1\n")
    assert main([*_argv(path, tmp_path), _file_option(path), str(cfg)]) == 2
    line = _error_line(capsys)
    prefix = f"avtrack: error: {cfg}: no_such_field: unknown field (allowed: "
    assert line.startswith(prefix) and line.endswith(")"), line
    return line[len(prefix) : -1].split(", ")


@pytest.mark.parametrize("path", COMMANDS, ids=ids)
def test_config_unknown_field_is_one_line_naming_it(path, tmp_path, capsys):
    assert _allowed_fields(path, tmp_path, capsys)


@pytest.mark.parametrize("path", COMMANDS, ids=ids)
def test_config_wrong_type_is_one_line_naming_the_field(path, tmp_path, capsys):
    cfg = tmp_path / "wrong.yaml"
    for field in _allowed_fields(path, tmp_path, capsys):
        # a list of lists is no number, switch, string, path, tuple or mapping
        cfg.write_text(yaml.safe_dump({field: [[[]]]}))
        assert main([*_argv(path, tmp_path), _file_option(path), str(cfg)]) == 2, field
        line = _error_line(capsys)
        assert line.startswith(f"avtrack: error: {cfg}: {field}"), line


@pytest.mark.parametrize("path", COMMANDS, ids=ids)
def test_missing_config_file_is_one_line(path, tmp_path, capsys):
    cfg = tmp_path / "none.yaml"
    option = _file_option(path)
    assert main([*_argv(path, tmp_path), option, str(cfg)]) == 2
    kind = option.lstrip("-")
    assert _error_line(capsys) == f"avtrack: error: {cfg}: {kind} file not found"


def test_command_line_options_override_the_options_file(tmp_path, capsys):
    cfg = tmp_path / "sim.yaml"
    cfg.write_text("scenario: walkout\nseed: 4\nduration: 7\n")
    assert main(["simulate", "--print", "--options", str(cfg), "--seed", "5"]) == 0
    scenario = yaml.safe_load(capsys.readouterr().out)
    assert (scenario["seed"], scenario["duration"]) == (5, 7.0)  # --seed wins, file's duration
    assert scenario["name"].startswith("walkout")


@pytest.fixture
def doa_csv(tmp_path) -> Path:
    """40 tracker inputs (8 ms frames) of one talker at 30 degrees."""
    n = 160
    frames = np.arange(n)
    path = tmp_path / "doa.csv"
    ones = np.ones(n)
    table = DOATable(frames, 0.008 * frames, -np.ones(n, int), 30 * ones, 0 * ones, ones,
                     ones > 0)  # fmt: skip
    write_doa_csv(path, table)
    return path


@pytest.fixture
def terminal(monkeypatch):
    """Pretend stderr is a terminal, so that progress bars are drawn."""
    monkeypatch.setattr(progress, "stderr_is_terminal", lambda: True)


def test_quiet_prints_nothing_even_on_a_terminal(doa_csv, tmp_path, terminal, capsys):
    out = tmp_path / "tracks.csv"
    assert main(["track-audio", "--doa", str(doa_csv), "-o", str(out), "--quiet"]) == 0
    assert capsys.readouterr() == ("", "")
    assert out.is_file()


def test_progress_bar_on_a_terminal_only(doa_csv, tmp_path, terminal, capsys, monkeypatch):
    out = tmp_path / "tracks.csv"
    assert main(["track-audio", "--doa", str(doa_csv), "-o", str(out)]) == 0
    printed = capsys.readouterr()
    assert "tracking:" in printed.err and "/40 " in printed.err  # tqdm, 40 tracker frames
    assert printed.err.endswith("\r")  # erased when done
    assert printed.out.startswith("tracked 40 frames")
    monkeypatch.setattr(progress, "stderr_is_terminal", lambda: False)  # a log file
    assert main(["track-audio", "--doa", str(doa_csv), "-o", str(out), "--force"]) == 0
    assert capsys.readouterr().err == ""


def test_top_level_help_imports_no_command():
    """``avtrack --help`` lists every command from :data:`COMMAND_HELP` without importing the
    commands (and NumPy, SciPy, OpenCV with them): it answers at once."""
    import subprocess
    import sys

    code = ("import sys\nfrom avtrack.cli.main import main\ntry:\n    main(['--help'])\n"
            "except SystemExit:\n    pass\n"
            "heavy = [m for m in sys.modules if m.split('.')[0] in "
            "('numpy', 'scipy', 'cv2', 'matplotlib')]\nprint('HEAVY', heavy)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert "HEAVY []" in out
    for name in ("track-mot", "track-av", "eval", "batch"):
        assert f"\n    {name}" in out


def test_command_help_lines_match_the_modules():
    import argparse
    import importlib

    from avtrack.cli.main import COMMAND_HELP, COMMAND_MODULES, command_name

    for module in COMMAND_MODULES:
        parser = argparse.ArgumentParser()
        sub = parser.add_subparsers()
        importlib.import_module(f"avtrack.cli.{module}").register(sub)
        helps = {a.dest: a.help for a in sub._choices_actions}
        assert helps[command_name(module)] == COMMAND_HELP[command_name(module)], module
