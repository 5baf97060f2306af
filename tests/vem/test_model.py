"""Tests of avtrack.vem.model: the shared clutter column of the observation models."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.vem.model import cached_log_clutter


def test_cached_log_clutter_is_read_only_made_once_per_length_and_kept_in_the_cache():
    cache: dict[int, np.ndarray] = {}
    a = cached_log_clutter(cache, 3, -1.5)
    np.testing.assert_array_equal(a, [-1.5, -1.5, -1.5])
    assert not a.flags.writeable
    assert cached_log_clutter(cache, 3, -1.5) is a  # shared between calls
    b = cached_log_clutter(cache, 0, -1.5)
    assert b.shape == (0,) and set(cache) == {0, 3}
    with pytest.raises(ValueError, match="read-only"):
        a[0] = 0.0
