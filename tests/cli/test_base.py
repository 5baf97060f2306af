"""``avtrack.cli.base``: ``--options`` files onto a command's options."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from avtrack.cli.base import add_options_option
from avtrack.errors import InputError


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser()
    p.add_argument("name", nargs="?", default="meeting")
    p.add_argument("-o", "--output", type=Path, required=True)
    p.add_argument("--seed", type=int, default=0, help="default %(default)s")
    p.add_argument("--duration", type=float, default=20.0)
    p.add_argument("--mode", choices=("a", "b"), default="a")
    p.add_argument("--fast", action="store_true")
    p.add_argument("--print", dest="print_only", action="store_true")
    p.set_defaults(func=vars)
    add_options_option(p, exclude=("print_only",))
    return p


def _run(argv: list[str]) -> dict:
    args = _parser().parse_args(argv)
    return args.func(args)


def test_options_from_a_file_the_command_line_wins(tmp_path):
    cfg = tmp_path / "o.yaml"
    cfg.write_text("name: walkout\nseed: 3\nduration: 5\nmode: b\nfast: true\n")
    got = _run(["-o", "out", "--options", str(cfg), "--seed", "0"])
    assert (got["name"], got["seed"], got["mode"], got["fast"]) == ("walkout", 0, "b", True)
    assert got["duration"] == 5.0 and isinstance(got["duration"], float)
    got = _run(["-o", "out"])  # no file: the defaults
    assert (got["name"], got["seed"], got["duration"], got["fast"]) == ("meeting", 0, 20.0, False)
    assert got["output"] == Path("out")
    assert "default 0" in _parser().format_help()


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("mode: c\n", "mode: expected one of a, b, got 'c'"),
        ("seed: 1.5\n", "seed: expected an integer, got 1.5"),
        ("fast: 'yes'\n", "fast: expected true or false, got 'yes'"),
        ("output: x\n", "output: unknown field (allowed: duration, fast, mode, name, seed)"),
        ("print_only: true\n", "print_only: unknown field"),
    ],
)
def test_option_file_errors(tmp_path, text, message):
    cfg = tmp_path / "o.yaml"
    cfg.write_text(text)
    with pytest.raises(InputError) as exc:
        _run(["-o", "out", "--options", str(cfg), "--seed", "2"])  # checked even if overridden
    assert str(exc.value).startswith(f"{cfg}: {message}")


def test_add_options_option_needs_the_command_first():
    p = argparse.ArgumentParser()
    with pytest.raises(RuntimeError, match="set_defaults"):
        add_options_option(p)


def test_config_on_a_command_without_an_algorithm_names_options(tmp_path):
    cfg = tmp_path / "o.yaml"
    cfg.write_text("seed: 3\n")
    with pytest.raises(InputError) as exc:
        _run(["-o", "out", "--config", str(cfg)])
    assert str(exc.value) == (f"{cfg}: --config holds an algorithm's parameters and this "
                              "command runs none: give its option values with --options "
                              "FILE.yaml")
