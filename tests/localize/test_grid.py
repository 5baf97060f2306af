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


def test_elevation_support_follows_the_array_geometry():
    from avtrack.localize.grid import ELEVATION_ROWS, elevation_support

    line = MicArray("line", [[x, 0.0, 0.0] for x in (-0.05, 0.0, 0.05, 0.1)])
    square = MicArray("square", [[0.02, 0.02, 0], [-0.02, 0.02, 0], [-0.02, -0.02, 0],
                                 [0.02, -0.02, 0]])
    tilted = MicArray("tilted", square.positions @ np.array([[1, 0, 0], [0, 0.8, 0.6],
                                                              [0, -0.6, 0.8]]))
    cube = MicArray("cube", [[0.03, 0, 0], [0, 0.03, 0], [-0.03, 0, 0], [0, 0, 0.03]])
    assert elevation_support(line) == "none"
    assert elevation_support(square) == "upper"
    assert elevation_support(tilted) == "upper"  # a plane in any orientation
    assert elevation_support(cube) == "full"
    irs = np.zeros((2, 4, 8))
    irs[:, :, 0] = 1.0
    head = MicArray("head", square.positions, "hrtf",
                    HRIRSet([0.0, 90.0], [0.0, 30.0], irs, 16000))
    assert elevation_support(head) == "none"  # measured responses: azimuth only
    grid = DirectionGrid.for_array(square, 10.0)
    assert grid.n_azimuths == 36
    assert tuple(grid.elevation_values) == ELEVATION_ROWS["upper"]
    assert DirectionGrid.for_array(line).n_elevations == 1


def test_a_line_of_microphones_hears_an_elevated_source_nearer_its_axis():
    from avtrack.localize.grid import heard_azimuth, line_axis

    pair = MicArray("pair", [[0.0, 0.09, 0.0], [0.0, -0.09, 0.0]])  # axis y, front along x
    axis = line_axis(pair)
    np.testing.assert_allclose(np.abs(axis), [0.0, 1.0, 0.0], atol=1e-12)
    square = MicArray("square", [[0.02, 0.02, 0], [-0.02, 0.02, 0], [-0.02, -0.02, 0],
                                 [0.02, -0.02, 0]])
    assert line_axis(square) is None
    # horizontal sources are heard where they are, either sign of the axis, front and back
    az = np.array([-150.0, -90.0, -30.0, 0.0, 30.0, 90.0, 150.0])
    d = np.column_stack([np.cos(np.radians(az)), np.sin(np.radians(az)), np.zeros(az.size)])
    np.testing.assert_allclose(heard_azimuth(d, axis), az, atol=1e-9)
    np.testing.assert_allclose(heard_azimuth(d, -axis), az, atol=1e-9)
    # 30 degrees to the left, 40 up: the angle from the axis is acos(cos 40 sin 30), so the
    # line hears asin(cos 40 sin 30) = 22.5 degrees
    e, a = np.radians(40.0), np.radians(30.0)
    up = np.array([[np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)]])
    want = np.degrees(np.arcsin(np.cos(e) * np.sin(a)))
    assert heard_azimuth(up, axis)[0] == pytest.approx(want)
    assert want == pytest.approx(22.5, abs=0.1)


def test_azimuth_profile_sums_or_maxes_over_elevations():
    from avtrack.localize.grid import azimuth_profile

    grid = DirectionGrid(np.array([-90.0, 0.0, 90.0, 180.0]), np.array([0.0, 30.0]))
    w = np.array([[0.1, 0.2, 0.0, 0.1, 0.3, 0.1, 0.2, 0.0]])  # rows: elevation 0, then 30
    prof, el = azimuth_profile(w, grid)
    np.testing.assert_allclose(prof, [[0.4, 0.3, 0.2, 0.1]])
    np.testing.assert_array_equal(el, [[30.0, 0.0, 30.0, 0.0]])
    prof_max, _ = azimuth_profile(w, grid, "max")
    np.testing.assert_allclose(prof_max, [[0.3, 0.2, 0.2, 0.1]])
    with pytest.raises(ValueError, match="reduce must be one of"):
        azimuth_profile(w, grid, "mean")
    with pytest.raises(ValueError, match=r"weights must have shape \(n_frames, 8\)"):
        azimuth_profile(w[:, :4], grid)


def test_elevated_talker_on_a_planar_array_is_placed_in_azimuth_and_elevation():
    """A talker 40 degrees above a planar array: its phase differences are those of a
    horizontal source scaled by cos 40; the elevation rows find it."""
    from avtrack.audio.arrays import MicArray, steering_delays
    from avtrack.localize import make_localizer, peak_table

    rng = np.random.default_rng(0)
    h = 0.02285
    array = MicArray("square", [[h, h, 0], [-h, h, 0], [-h, -h, 0], [h, -h, 0]])
    n = 16000
    s = rng.standard_normal(n + 64)
    tau = steering_delays(array, 150.0, 40.0) * 16000  # samples, (4,)
    f = np.fft.rfftfreq(n + 64)
    spec = np.fft.rfft(s)
    x = np.stack([np.fft.irfft(spec * np.exp(-2j * np.pi * f * t), n + 64)[:n] for t in tau])
    x += 0.05 * rng.standard_normal(x.shape)
    loc = make_localizer("dprtf-eg", array)
    assert loc.grid.n_elevations == 4
    table = peak_table(loc.run(x), loc.grid, loc.default_threshold, max_peaks=1)
    late = table.frames > 60
    assert np.median(np.abs(table.azimuth_deg[late] - 150.0)) <= 5.0
    assert np.median(table.elevation_deg[late]) == 40.0
