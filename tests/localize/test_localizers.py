"""Contract tests of every registered localizer on the shared synthetic scene."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.audio.arrays import MicArray
from avtrack.localize import (
    LOCALIZERS,
    DirectionGrid,
    HeatMaps,
    Localizer,
    localize,
    make_localizer,
    register_localizer,
)
from avtrack.localize.cgmm_eg import EGConfig
from avtrack.localize.grid import azimuth_profile
from tests.localize.conftest import SOURCE_AZIMUTH_DEG

METHODS = sorted(LOCALIZERS)


def test_registry_has_the_thesis_methods():
    assert set(METHODS) == {"dprtf-eg", "dprtf-eg-fast", "dprtf-eg-smooth", "dprtf-eg-static",
                            "dprtf-rem", "prp-rem", "srp-phat"}
    for name, cls in LOCALIZERS.items():
        assert cls.name == name and issubclass(cls, Localizer)
    with pytest.raises(ValueError, match="already registered"):
        register_localizer("dprtf-eg")(LOCALIZERS["srp-phat"])


@pytest.mark.parametrize("method", METHODS)
def test_static_source_is_localised_within_5_degrees(method, static_scene):
    array, y = static_scene
    heat = localize(y, array, method)
    assert isinstance(heat, HeatMaps)
    grid = DirectionGrid.for_array(array)  # the default: the elevations the array can tell
    assert grid.n_elevations > 1  # a planar free-field array
    assert heat.weights.shape == (len(heat), grid.size) and np.all(heat.weights >= 0)
    profile, _ = azimuth_profile(heat.weights, grid, LOCALIZERS[method].profile_reduce)
    second_half = profile[len(heat) // 2 :]
    grid = DirectionGrid.azimuths()
    best = grid.azimuth_deg[np.argmax(second_half.mean(axis=0))]
    assert abs(best - SOURCE_AZIMUTH_DEG) <= 5.0
    top = grid.azimuth_deg[np.argmax(second_half, axis=1)]
    assert np.mean(np.abs(top - SOURCE_AZIMUTH_DEG) <= 5.0) > 0.8  # pauses included


@pytest.mark.parametrize("method", METHODS)
def test_block_streaming_equals_whole_file(method, static_scene):
    array, y = static_scene
    y = y[:, :12000]
    loc = make_localizer(method, array)
    whole = loc.run(y)
    cut = 3000 + 128 * loc.latency_frames  # samples fed one by one: the hop is 128
    for block in (1, 1000, 4097):
        streamed = loc.run(y[:, : cut if block == 1 else None], block_size=block)
        # a cut signal's last frames are read with fewer frames after them by a smoother
        n = len(streamed) - (loc.latency_frames if block == 1 else 0)
        assert n > 0
        np.testing.assert_array_equal(streamed.frames[:n], whole.frames[:n])
        np.testing.assert_allclose(streamed.weights[:n], whole.weights[:n], rtol=0, atol=1e-10)
        np.testing.assert_array_equal(streamed.n_observations[:n], whole.n_observations[:n])


@pytest.mark.parametrize("method", METHODS)
def test_process_continues_a_stream_and_reports_frames(method, static_scene):
    array, y = static_scene
    loc = make_localizer(method, array)
    a = loc.process(y[:, :200])  # less than one window
    b = loc.process(y[:, 200:1000])
    assert len(a) == 0 and a.weights.shape == (0, loc.grid.size)
    # a smoothing map holds back its last latency_frames frames until flush()
    np.testing.assert_array_equal(b.frames, np.arange(max(6 - loc.latency_frames, 0)))
    b = HeatMaps.concatenate([b, loc.flush()], loc.grid.size)
    np.testing.assert_array_equal(b.frames, np.arange(6))
    np.testing.assert_allclose(b.time_s, 0.008 * (np.arange(6) + 1))
    if method != "srp-phat":  # CGMM weights are a distribution
        np.testing.assert_allclose(b.weights.sum(axis=1), 1.0)


@pytest.mark.parametrize("method", METHODS)
def test_bad_input_is_rejected(method, static_scene):
    array, y = static_scene
    loc = make_localizer(method, array)
    with pytest.raises(ValueError, match=r"block must have shape \(4, n_samples\)"):
        loc.process(y[:3])
    with pytest.raises(ValueError, match="finite"):
        loc.process(np.full((4, 300), np.nan))
    with pytest.raises(ValueError, match="block_size must be a positive integer"):
        loc.run(y, block_size=0)


def test_constructor_validation():
    array = MicArray("pair", np.array([[0, 0.1, 0], [0, -0.1, 0]]))
    with pytest.raises(ValueError, match="method must be one of"):
        make_localizer("music", array)
    with pytest.raises(TypeError, match="config must be a EGConfig"):
        make_localizer("dprtf-eg", array, config=object())
    with pytest.raises(TypeError, match="array must be a MicArray"):
        make_localizer("srp-phat", np.zeros((2, 3)))
    with pytest.raises(TypeError, match="grid must be a DirectionGrid"):
        make_localizer("srp-phat", array, grid=[0, 90])
    assert isinstance(make_localizer("dprtf-eg", array, config=EGConfig()), Localizer)


@pytest.mark.parametrize("method", ["dprtf-eg", "dprtf-eg-fast", "dprtf-eg-static", "dprtf-rem",
                                    "prp-rem"])
def test_frames_with_too_few_features_relax_to_uniform(method, static_scene):
    array, y = static_scene
    cfg = LOCALIZERS[method].Config(min_features=10**6)
    heat = make_localizer(method, array, config=cfg).run(y[:, :8000])
    np.testing.assert_allclose(heat.weights, 1 / DirectionGrid.for_array(array).size)
    assert heat.n_observations.max() > 0  # features were there, but too few to count
    with pytest.raises(ValueError, match="min_features must be an integer >= 0"):
        LOCALIZERS[method].Config(min_features=-1)


def _two_talkers_on_a_small_array(seed: int = 0):
    """Two talkers 45 degrees apart (180 and 225, 20 and 35 degrees above the plane) at 0.8 m
    from a 4.6 cm square array in a reverberant room, speaking in overlapping bursts."""
    from tests.localize.conftest import FS, SQUARE, bursty_source, render_on_square

    rng = np.random.default_rng(seed)
    n = 4 * FS
    sources = [(az, el, 0.8, np.roll(bursty_source(n, rng), shift))
               for az, el, shift in ((180.0, 20.0, 0), (225.0, 35.0, 2400))]
    y = render_on_square(sources, 0.3, n)
    array = MicArray("square", SQUARE)
    return array, y + 0.1 * rng.standard_normal(y.shape)


def test_fast_map_keeps_two_close_talkers_apart():
    """The fast map's random walk alone (0.4 a cell a frame) blurs two talkers 45 degrees
    apart into each other; its velocity layers with a small walk keep them apart."""
    from avtrack.localize.cgmm_eg import FastEGConfig

    array, y = _two_talkers_on_a_small_array()
    walk = _per_talker("dprtf-eg-fast", array, y, FastEGConfig(
        position_smoothing=0.4, position_velocities_deg_s=None))
    layers = _per_talker("dprtf-eg-fast", array, y, FastEGConfig())
    for (share_w, err_w), (share_l, err_l) in zip(walk, layers, strict=True):
        assert err_l < err_w - 1.0  # each talker placed closer to where it is
        assert share_l > share_w + 0.05  # and found in more frames
    assert layers[0][1] < 5.0 and layers[1][1] < 6.0


def _per_talker(method: str, array, y, config=None,
                azimuths=(180.0, -135.0)) -> list[tuple[float, float]]:
    """Per talker (180 and 225 degrees): the share of frames with a peak within 20 degrees,
    the mean error of the nearest such peak."""
    from avtrack.localize import peak_table

    loc = make_localizer(method, array, config=config)
    heat = loc.run(y)
    table = peak_table(heat, loc.grid, loc.peak_threshold)
    out = []
    for az in azimuths:
        err = np.abs((table.azimuth_deg - az + 180.0) % 360.0 - 180.0)
        ok = err <= 20.0
        frames = np.unique(table.frames[ok])
        best = [err[ok & (table.frames == f)].min() for f in frames]
        out.append((frames.size / len(heat), float(np.mean(best))))
    return out


def test_static_map_places_the_louder_talker_closer_and_finds_the_quieter_more_often():
    """Two talkers 45 degrees apart: the static map's sharper still layer keeps the louder
    talker's peak on it, and its slower relaxation keeps the quieter one between words."""
    array, y = _two_talkers_on_a_small_array()
    fast = _per_talker("dprtf-eg-fast", array, y)
    static = _per_talker("dprtf-eg-static", array, y)
    assert static[0][1] < fast[0][1] - 1.0 and static[0][1] < 3.0
    assert static[0][0] >= fast[0][0]
    assert static[1][0] > fast[1][0] + 0.1
