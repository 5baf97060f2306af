"""Locating real data and MOTChallenge sequence metadata.

The project's real data (MOT15 TUD-Campus, AV16.3, NAO measurements ...) live outside the
repository, in ``../shared/data`` next to a checkout, or wherever ``$AVTRACK_SHARED_DATA``
points.
"""

from __future__ import annotations

import configparser
import os
from pathlib import Path

from avtrack.errors import InputError

ENV_VAR = "AVTRACK_SHARED_DATA"


def shared_data_candidates() -> list[Path]:
    """Where :func:`find_shared_data` looks, in order."""
    env = os.environ.get(ENV_VAR)
    out = [Path(env)] if env else []
    out.append(Path.cwd() / ".." / "shared" / "data")
    out.append(Path.cwd() / "shared" / "data")
    # an editable install / source checkout: <repo>/src/avtrack/io/datasets.py
    out.append(Path(__file__).resolve().parents[4] / "shared" / "data")
    return out


def find_shared_data() -> Path:
    """The shared real-data folder.

    Raises
    ------
    InputError
        When none of :func:`shared_data_candidates` is a directory.
    """
    for path in shared_data_candidates():
        if path.is_dir():
            return path.resolve()
    looked = ", ".join(str(p) for p in shared_data_candidates())
    raise InputError(f"shared data folder not found (looked in: {looked}); set {ENV_VAR}")


def read_seqinfo(path: str | Path) -> dict[str, int | str]:
    """Read a MOTChallenge ``seqinfo.ini`` (``[Sequence]`` with imWidth, imHeight, seqLength ...).

    Returns
    -------
    dict
        ``name``, ``width``, ``height``, ``length``, ``frame_rate`` (those present).
    """
    path = Path(path)
    parser = configparser.ConfigParser(interpolation=None)
    try:
        parser.read_string(path.read_text())
    except (OSError, UnicodeDecodeError, configparser.Error) as exc:
        raise InputError(f"cannot read seqinfo: {exc}", path) from None
    if "Sequence" not in parser:
        raise InputError("no [Sequence] section", path)
    sec = parser["Sequence"]
    out: dict[str, int | str] = {}
    if "name" in sec:
        out["name"] = sec["name"]
    for key, name in (("imWidth", "width"), ("imHeight", "height"), ("seqLength", "length"),
                      ("frameRate", "frame_rate")):
        if key in sec:
            try:
                value = int(sec[key])
            except ValueError:
                raise InputError(f"{key} must be an integer, got {sec[key]!r}", path) from None
            if value <= 0:
                raise InputError(f"{key} must be > 0, got {value}", path)
            out[name] = value
    return out


def find_seqinfo(det_path: str | Path) -> Path | None:
    """``seqinfo.ini`` of the MOTChallenge sequence holding ``SEQ/det/det.txt``, if any."""
    det_path = Path(det_path).resolve()
    for folder in (det_path.parent, det_path.parent.parent):
        candidate = folder / "seqinfo.ini"
        if candidate.is_file():
            return candidate
    return None
