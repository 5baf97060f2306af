"""Candidate grids and predicted direct-path features."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.audio.arrays import SPEED_OF_SOUND, MicArray, builtin_array
from avtrack.audio.hrtf import HRIRSet
from avtrack.localize.grid import (
    DirectionGrid,
    dprtf_means,
    steering_phases,
    transfer_functions,
)


def test_default_grid_is_the_thesis_grid():
    g = DirectionGrid.azimuths()
    assert g.size == 72 and g.n_elevations == 1 and g.circular
    assert g.azimuth_deg[0] == -175.0 and g.azimuth_deg[-1] == 180.0
    assert np.all(g.elevation_deg == 0)
    assert g.nearest(-178.0) == 71 and g.nearest(2.4) == 35 and g.nearest(181.0) == 71


def test_sphere_grid_layout():
    g = DirectionGrid.sphere(30.0, (-20.0, 0.0, 20.0))
    assert g.size == 36 and (g.n_elevations, g.n_azimuths) == (3, 12)
    assert g.azimuth_deg[13] == g.azimuth_values[1] and g.elevation_deg[13] == 0.0
    assert int(g.nearest(-150.0, 19.0)) == 2 * 12 + 0


def test_non_circular_grid():
    g = DirectionGrid([-60.0, -30.0, 0.0, 30.0], [0.0])
    assert not g.circular


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (([0.0, -10.0], [0.0]), "strictly increasing"),
        (([-180.0], [0.0]), r"\(-180, 180\]"),
        (([0.0], [95.0]), r"\[-90, 90\]"),
        (([], [0.0]), "non-empty"),
    ],
)
def test_grid_validation(args, match):
    with pytest.raises(ValueError, match=match):
        DirectionGrid(*args)
    with pytest.raises(ValueError, match="step_deg must divide 360"):
        DirectionGrid.azimuths(7.0)


def test_free_field_features_are_delay_phases():
    pos = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.1, 0.0]])
    array = MicArray("tri", pos)
    grid = DirectionGrid([0.0, 90.0], [0.0])
    f = np.array([0.0, 500.0, 1000.0])
    h = transfer_functions(array, grid, f)
    assert h.shape == (3, 3, 2)
    np.testing.assert_allclose(np.abs(h), 1.0)
    means = dprtf_means(h)
    # source along +x: mic 2 (x = 0.1) hears it 0.1 / c earlier -> ratio exp(+2j pi f 0.1 / c)
    np.testing.assert_allclose(
        means[0, :, 0], np.exp(2j * np.pi * f * 0.1 / SPEED_OF_SOUND) / np.sqrt(2), atol=1e-12
    )
    np.testing.assert_allclose(means[1, :, 0], 1 / np.sqrt(2), atol=1e-12)  # broadside
    np.testing.assert_allclose(np.abs(dprtf_means(h, phase_only=True)), 1 / np.sqrt(2))
    np.testing.assert_allclose(np.abs(steering_phases(h)), 1.0)


def test_hrtf_features_use_the_nearest_measured_direction():
    irs = np.zeros((4, 2, 8))
    irs[:, 0, 0] = 1.0  # mic 1: a unit impulse from every direction
    for d in range(4):
        irs[d, 1, d] = 0.5  # mic 2: delayed by d samples, half amplitude
    hrir = HRIRSet([0.0, 90.0, 180.0, -90.0], np.zeros(4), irs, 16000)
    array = MicArray("head", np.array([[0, 0.05, 0], [0, -0.05, 0]]), "hrtf", hrir)
    grid = DirectionGrid([-85.0, 5.0, 95.0], [0.0])
    f = np.array([0.0, 1000.0])
    h = transfer_functions(array, grid, f)
    delays = np.array([3, 0, 1])  # -85 -> -90 (index 3), 5 -> 0, 95 -> 90
    ratio = 0.5 * np.exp(-2j * np.pi * f[:, None] * delays[None, :] / 16000)
    np.testing.assert_allclose(h[1] / h[0], ratio, atol=1e-12)
    np.testing.assert_allclose(dprtf_means(h)[0], ratio / np.sqrt(1.25), atol=1e-12)


def test_nao_hrir_means(shared_data):
    array = builtin_array("nao4", hrir=True)
    grid = DirectionGrid.azimuths()
    f = np.arange(128) * 62.5
    means = dprtf_means(transfer_functions(array, grid, f))
    assert means.shape == (3, 128, 72) and np.all(np.abs(means) < 1)
    # direction-dependent: at 2 kHz the 72 candidate means are well apart
    d = np.abs(means[:, 32, :, None] - means[:, 32, None, :]).sum(axis=0)
    assert np.min(d[~np.eye(72, dtype=bool)]) > 0.01
