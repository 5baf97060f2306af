"""Shared I/O helpers: atomic output files, number parsing and YAML files with errors naming
the file and row."""

from __future__ import annotations

import contextlib
import math
import os
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

from avtrack.errors import InputError


def parse_finite(text: str, name: str, path, row: int) -> float:
    """The finite number in a text field, or an InputError naming the file, row and field."""

    try:
        v = float(text)
    except ValueError:
        raise InputError(f"{name} is not a number: {text!r}", path, row) from None
    if not math.isfinite(v):
        raise InputError(f"{name} is {text!r}, expected a finite number", path, row)
    return v


#: Frame numbers a file may reach whatever its length (about 9 hours at 30 frames/s) ...
FRAME_SPAN_FLOOR = 1_000_000
#: ... and beyond that, this many frames per row of the file: trackers step through every
#: frame up to the last, so a frame number far past what the rows could describe (a typo,
#: a timestamp in a frame column) is refused instead of costing hours and gigabytes.
FRAME_SPAN_PER_ROW = 1_000


def check_frame_span(last: float, n_rows: int, path, what: str = "frame",
                     per_unit: float = 1.0) -> None:
    """InputError when the last frame number (or time, with ``per_unit`` frames per unit)
    cannot belong to a file of ``n_rows`` rows: beyond
    ``max(FRAME_SPAN_FLOOR, FRAME_SPAN_PER_ROW * n_rows) / per_unit``."""
    from avtrack.errors import InputError

    limit = max(FRAME_SPAN_FLOOR, FRAME_SPAN_PER_ROW * int(n_rows)) / per_unit
    if last > limit:
        fmt = ".0f" if what == "frame" else "g"
        raise InputError(
            f"{what} {last:{fmt}} lies far past what {n_rows} row(s) can describe (at most "
            f"{limit:{fmt}} here); is there a typo, or a timestamp in the {what} column?", path)


def field_count_error(expected: str, got: int, path, row: int) -> InputError:
    """The error of a row with the wrong number of fields: ``expected`` says how many and
    which (``"7 comma-separated values (frame,time_s,...)"``)."""
    return InputError(f"expected {expected}, got {got}", path, row)


def temp_output(path: Path, suffix: str = ".tmp") -> tuple[int, str]:
    """``(fd, name)`` of a new temporary file next to ``path``, for writing then renaming
    onto it (:func:`os.replace` is atomic within a directory).

    :func:`tempfile.mkstemp` creates the file private (mode 0600); it is given the mode a
    plain ``open()`` would (0666 less the umask), so outputs are readable as usual.
    """
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    umask = os.umask(0)
    os.umask(umask)
    with contextlib.suppress(OSError):
        os.fchmod(fd, 0o666 & ~umask)
    return fd, tmp


def is_char_device(path: str | Path) -> bool:
    """Whether ``path`` is a character device (``/dev/null``, a terminal)."""
    try:
        return stat.S_ISCHR(os.stat(path).st_mode)
    except OSError:
        return False


@contextlib.contextmanager
def atomic_write(path: str | Path, mode: str = "w", **kwargs) -> Iterator[IO]:
    """Open a temporary file next to ``path`` and rename it onto ``path`` on success.

    If the body raises (or the process is killed), ``path`` is left untouched: either the old
    content or nothing — never a half-written file.

    Parameters
    ----------
    path : str or Path
        Final destination. Its parent directory is created if needed.
    mode : {"w", "wb"}
        Text or binary mode.
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_write: mode must be 'w' or 'wb', got {mode!r}")
    path = Path(path)
    if is_char_device(path):
        # /dev/null, a terminal, a named device: written as it is (there is no file to
        # replace, and renaming a temporary file onto a device would replace the device)
        with open(path, mode, **kwargs) as fh:
            yield fh
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = temp_output(path)
    try:
        with os.fdopen(fd, mode, **kwargs) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def read_yaml_file(path: str | Path, what: str) -> Any:
    """The content of a YAML file (None when empty); :class:`InputError` naming the file, and
    the row of a syntax error, when it is missing or not YAML. ``what`` names the file's kind
    (``"scenario"``) in the not-found message."""
    import yaml

    path = Path(path)
    if not path.is_file():
        raise InputError(f"{what} file not found", path)
    try:
        return yaml.safe_load(path.read_bytes())
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        row = None if mark is None else mark.line + 1
        problem = getattr(exc, "problem", None) or " ".join(str(exc).split())
        raise InputError(f"not valid YAML ({problem})", path, row) from None


def read_audio_file(path: Path, missing: str = "file not found") -> tuple[Any, int]:
    """The samples ``(n_samples, n_channels)`` (float64) of the audio file at ``path`` and its
    sample rate; an InputError naming ``path`` (with the message ``missing`` when there is no
    such file) if it cannot be read."""
    import soundfile as sf

    if not path.is_file():
        raise InputError(missing, path)
    try:
        x, rate = sf.read(path, always_2d=True)
    except (RuntimeError, sf.LibsndfileError) as exc:
        raise InputError(f"cannot read audio: {exc}", path) from None
    return x, rate
