"""``avtrack.cli.progress``: bars on a terminal's stderr only, never under ``--quiet``."""

from __future__ import annotations

import pytest

from avtrack.cli import progress


@pytest.fixture
def terminal(monkeypatch):
    monkeypatch.setattr(progress, "stderr_is_terminal", lambda: True)


class Counter:
    def step(self, x: int) -> int:
        return 2 * x

    def run(self, n: int) -> list[int]:
        return [self.step(i) for i in range(n)]


def test_enabled_only_on_a_terminal_without_quiet(monkeypatch):
    monkeypatch.setattr(progress, "stderr_is_terminal", lambda: False)
    assert not progress.enabled(quiet=False) and not progress.enabled(quiet=True)
    monkeypatch.setattr(progress, "stderr_is_terminal", lambda: True)
    assert progress.enabled(quiet=False) and not progress.enabled(quiet=True)


def test_quiet_disables_every_helper(terminal, capsys):
    assert progress.bar(10, "x", quiet=True).disable
    c = Counter()
    with progress.counting(c, "step", 5, "steps", quiet=True) as bar:
        assert "step" not in vars(c)  # not even wrapped
        assert c.run(5) == [0, 2, 4, 6, 8]
    assert bar.disable
    with progress.activity("working", quiet=True):
        pass
    assert capsys.readouterr() == ("", "")


def test_counting_ticks_per_call_and_restores_the_method(terminal, capsys):
    c = Counter()
    with progress.counting(c, "step", 5, "steps", "frame") as bar:
        assert c.run(5) == [0, 2, 4, 6, 8]
        assert bar.n == 5
    assert "step" not in vars(c)
    err = capsys.readouterr().err
    assert "steps:" in err and err.endswith("\r")  # drawn on stderr, erased when done


def test_activity_shows_the_elapsed_time(terminal, capsys):
    with progress.activity("simulating", interval_s=0.01):
        pass
    out, err = capsys.readouterr()
    assert out == "" and "simulating: 00:00" in err


def test_not_a_terminal_writes_nothing(monkeypatch, capsys):
    monkeypatch.setattr(progress, "stderr_is_terminal", lambda: False)
    with progress.bar(3, "x") as bar:
        bar.update(3)
    with progress.activity("working"):
        pass
    assert capsys.readouterr() == ("", "")
