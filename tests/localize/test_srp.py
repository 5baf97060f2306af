"""SRP-PHAT against pyroomacoustics."""

from __future__ import annotations

import numpy as np
import pyroomacoustics as pra
import pytest

from avtrack.audio.arrays import SPEED_OF_SOUND, MicArray
from avtrack.localize.grid import DirectionGrid, steering_phases, transfer_functions
from avtrack.localize.srp import SRPPHAT, srp_phat


def test_srp_phat_matches_pyroomacoustics():
    rng = np.random.default_rng(0)
    m_ = 5
    pos = np.c_[rng.uniform(-0.1, 0.1, (m_, 2)), np.zeros(m_)]
    array = MicArray("random", pos)
    grid = DirectionGrid.azimuths(10.0)
    x = rng.standard_normal((m_, 129, 3)) + 1j * rng.standard_normal((m_, 129, 3))
    bins = np.arange(1, 128)
    freqs = bins * 16000 / 256
    steering = steering_phases(transfer_functions(array, grid, freqs))
    ours = srp_phat(x[:, bins, :], steering).mean(axis=0)

    doa = pra.doa.algorithms["SRP"](
        pos[:, :2].T,
        16000,
        256,
        c=SPEED_OF_SOUND,
        num_src=1,
        azimuth=np.deg2rad(grid.azimuth_deg),
    )
    doa.locate_sources(x, freq_bins=bins)
    n_pairs = m_ * (m_ - 1) / 2
    # pyroomacoustics: (2 sum_{i<j} Re(...) + S M F) / (S F P) = 2 ours + M / P
    np.testing.assert_allclose(doa.grid.values, 2 * ours + m_ / n_pairs, atol=1e-10)


def test_srp_phat_peaks_at_a_plane_wave_direction():
    pos = np.array([[0.05, 0, 0], [-0.05, 0, 0], [0, 0.05, 0], [0, -0.05, 0]])
    array = MicArray("cross", pos)
    grid = DirectionGrid.azimuths(5.0)
    freqs = np.arange(1, 128) * 62.5
    h = transfer_functions(array, grid, freqs)
    x = h[:, :, grid.nearest(-40.0)][:, :, None] * np.exp(1j * np.arange(127))[None, :, None]
    p = srp_phat(x, steering_phases(h))
    assert grid.azimuth_deg[np.argmax(p[0])] == -40.0
    assert np.isclose(p[0].max(), 1.0)  # every pair and bin perfectly coherent


def _small_array_recording(level: float, noise: float, seed: int = 0):
    """A 4.6 cm square array (ReSpeaker-like) hearing a talker at 120 degrees in a reverberant
    room, with its own incoherent sensor noise; the first 0.5 s is noise only."""
    from tests.localize.conftest import FS, SQUARE, bursty_source, render_on_square

    rng = np.random.default_rng(seed)
    src = bursty_source(int(2.5 * FS), rng)
    src[: FS // 2] = 0.0
    y = level * render_on_square([(120.0, 0.0, 1.0, src)], 0.4, int(2.5 * FS))
    array = MicArray("square", SQUARE)
    return array, y + level * noise * rng.standard_normal(y.shape)


@pytest.mark.parametrize("level", [1.0, 1e-3])
def test_relative_srp_map_finds_a_talker_where_the_fixed_threshold_does_not(level):
    from avtrack.localize import peak_table
    from avtrack.localize.srp import SRPConfig

    array, y = _small_array_recording(level, noise=0.5)
    grid = DirectionGrid.azimuths()
    speech = int(0.8 / 0.008)  # after the noise-only start and the smoothing

    def share_on_talker(heat, threshold):
        table = peak_table(heat, grid, threshold)
        on = table.frames >= speech
        err = np.abs((table.azimuth_deg[on] - 120.0 + 180.0) % 360.0 - 180.0)
        return np.unique(table.frames[on][err <= 20.0]).size / (len(heat) - speech), table

    # the thesis's map and its fixed threshold 0.3: a small array's map rarely rises that high
    plain = SRPPHAT(array, grid, SRPConfig(relative=False)).run(y)
    assert share_on_talker(plain, 0.3)[0] < 0.3
    # the same map in units of the recording's noise contrast: the talker stands out
    loc = SRPPHAT(array, grid)
    heat = loc.run(y)
    share, table = share_on_talker(heat, loc.default_threshold)
    assert share > 0.5
    # the noise-only start gives (almost) no peak
    assert np.count_nonzero(table.frames < int(0.5 / 0.008)) < 0.1 * int(0.5 / 0.008)


def test_relative_srp_map_does_not_depend_on_the_level():
    array, y = _small_array_recording(1.0, noise=0.3)
    grid = DirectionGrid.azimuths()
    a = SRPPHAT(array, grid).run(y).weights
    b = SRPPHAT(array, grid).run(1e-3 * y).weights
    np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-9)


def test_srp_config_rejects_bad_floor_settings():
    from avtrack.localize.srp import SRPConfig

    with pytest.raises(ValueError, match="floor_window_s must be a number > 0"):
        SRPConfig(floor_window_s=0)
    with pytest.raises(ValueError, match=r"floor_fraction must be in \(0, 1\]"):
        SRPConfig(floor_fraction=1.5)
    with pytest.raises(ValueError, match="relative must be true or false"):
        SRPConfig(relative=1)  # type: ignore[arg-type]
