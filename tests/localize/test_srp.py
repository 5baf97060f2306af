"""SRP-PHAT against pyroomacoustics."""

from __future__ import annotations

import numpy as np
import pyroomacoustics as pra

from avtrack.audio.arrays import SPEED_OF_SOUND, MicArray
from avtrack.localize.grid import DirectionGrid, steering_phases, transfer_functions
from avtrack.localize.srp import srp_phat


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
