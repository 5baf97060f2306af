"""What the benchmark scripts share: where the repository and the shared data are."""

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
