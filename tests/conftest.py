"""Shared test fixtures.

Real data live outside the repository in ``../shared/data`` (or wherever the environment
variable ``AVTRACK_SHARED_DATA`` points); tests that need them take the ``shared_data`` fixture
and are skipped, saying where they looked, when the folder is absent.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]


def shared_data_dir() -> Path:
    """Location of the shared real data: ``$AVTRACK_SHARED_DATA`` or ``<repo>/../shared/data``."""
    env = os.environ.get("AVTRACK_SHARED_DATA")
    if env:
        return Path(env)
    return REPO_ROOT / ".." / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The shared data folder; skips the test when it is missing."""
    path = shared_data_dir()
    if not path.is_dir():
        pytest.skip(f"../shared/data not found: {path.resolve()} (set AVTRACK_SHARED_DATA)")
    return path


@pytest.fixture(autouse=True, scope="session")
def _shared_data_for_the_library():
    """Tests run in working directories of their own, and the package may be installed away
    from the checkout, so the library cannot find ``../shared/data`` by itself: point
    ``$AVTRACK_SHARED_DATA`` at the folder the tests use (when it exists)."""
    old = os.environ.get("AVTRACK_SHARED_DATA")
    path = shared_data_dir()
    if old is None and path.is_dir():
        os.environ["AVTRACK_SHARED_DATA"] = str(path.resolve())
    yield
    if old is None:
        os.environ.pop("AVTRACK_SHARED_DATA", None)


@pytest.fixture(autouse=True, scope="session")
def _private_cache(tmp_path_factory):
    """Trained mappings are cached under ``$AVTRACK_CACHE``: a fresh folder for the test run,
    never the user's cache."""
    old = os.environ.get("AVTRACK_CACHE")
    os.environ["AVTRACK_CACHE"] = str(tmp_path_factory.mktemp("avtrack-cache"))
    yield
    if old is None:
        os.environ.pop("AVTRACK_CACHE", None)
    else:
        os.environ["AVTRACK_CACHE"] = old


@pytest.fixture(autouse=True)
def _own_working_directory(tmp_path_factory, monkeypatch):
    """Each test runs in an empty working directory of its own: what a user left in the
    checkout (``./avtrack-demo`` after ``avtrack demo``, say) cannot change a test's result."""
    monkeypatch.chdir(tmp_path_factory.mktemp("cwd"))
