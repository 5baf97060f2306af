"""Shared fixtures of the robot-head tests."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.robot.head import nao_head


@pytest.fixture(scope="module")
def head():
    """A NAO-like head with a slightly misaligned stereo mount."""
    return nao_head()


@pytest.fixture
def rng():
    return np.random.default_rng(0)
