"""What the benchmark scripts share: where the repository and the shared data are, and how a
``--seeds`` option reads."""

from __future__ import annotations

import os
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
#: The shared data folder beside the repository.
SHARED_DATA = REPO_ROOT / ".." / "shared" / "data"


def shared_data_dir() -> Path:
    """``$AVTRACK_SHARED_DATA`` or ``<repo>/../shared/data`` (as in ``tests/conftest.py``)."""
    env = os.environ.get("AVTRACK_SHARED_DATA")
    return Path(env) if env else SHARED_DATA


def parse_seeds(text: str) -> list[int]:
    """The seeds of a ``--seeds`` option: a range ``"0-7"`` (both ends included) or a list
    ``"0,3,5"``."""
    if "-" in text:
        lo, hi = (int(x) for x in text.split("-"))
        return list(range(lo, hi + 1))
    return [int(x) for x in text.split(",")]
