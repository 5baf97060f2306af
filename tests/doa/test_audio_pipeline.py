"""DPRTF-EG + the DOA trackers on rendered audio: a talker who stops and a talker who walks. The
default map (``dprtf-eg-smooth``) and the same map read without delay (``dprtf-eg-fast``).
A speech-like source (coloured noise bursts, 300 ms on / 100 ms off) at 2 m from
the nao4 array in a 6 x 5 x 3 m room, T60 = 0.3 s, weak sensor noise."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.signal

from avtrack.audio.arrays import builtin_array
from avtrack.doa.base import heatmap_sequence, make_tracker, map_reading
from avtrack.io.doa import wrap_azimuth
from avtrack.localize import DEFAULT_LOCALIZER, LOCALIZERS, DirectionGrid, make_localizer
from avtrack.metrics.doa import angular_error
from avtrack.simulate.acoustics import ArrayPose, MovingSource, Room, render

FS = 16000
CENTRE = np.array([3.0, 2.5, 1.2])
STEP = 4  # localizer frames per tracker frame (32 ms)


def _source(seconds: float, rng: np.random.Generator, on_s: float = 0.3, off_s: float = 0.1):
    """Band-limited noise bursts and their on/off envelope (per sample)."""
    n = int(seconds * FS)
    b, a = scipy.signal.butter(2, [200, 4000], btype="band", fs=FS)
    x = scipy.signal.lfilter(b, a, rng.standard_normal(n))
    t = np.arange(n) / FS
    env = (np.mod(t, on_s + off_s) < on_s).astype(float)
    return x * scipy.signal.convolve(env, np.hanning(160) / 80, mode="same"), env > 0


def _render(src: MovingSource, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    array = builtin_array("nao4")
    y = render(Room([6.0, 5.0, 3.0], 0.3, FS), array, ArrayPose(CENTRE), src, rng=rng)
    y = y / np.std(y)
    return y + 0.01 * rng.standard_normal(y.shape)


def _at(az_deg: np.ndarray | float) -> np.ndarray:
    az = np.deg2rad(np.atleast_1d(az_deg))
    return CENTRE + 2.0 * np.stack([np.cos(az), np.sin(az), 0 * az], axis=1)


@pytest.fixture(scope="module")
def stopping_talker():
    """A talker at 40° who speaks for 2 s and is silent for the last 1.5 s."""
    rng = np.random.default_rng(1)
    x, _ = _source(3.5, rng)
    x[int(2.0 * FS) :] = 0.0
    return _render(MovingSource.static(x, _at(40.0)[0]), 1), 2.0


@pytest.fixture(scope="module")
def walking_talker():
    """A talker walking round the array at 30°/s from -60° for 4 s, speaking in bursts."""
    rng = np.random.default_rng(2)
    x, on = _source(4.0, rng)
    times = np.linspace(0.0, 4.0, 41)
    az = -60.0 + 30.0 * times
    return _render(MovingSource(x, times, _at(az)), 2), on


#: The default localizer (``track-audio``, ``stream``) and the same map without the smoother
METHODS = (DEFAULT_LOCALIZER, "dprtf-eg-fast")


def _gated(method: str):
    """``method``'s map gated by the evidence (EGConfig.output_silence_rate): in frames without
    enough DP-RTF features the map relaxes to uniform at 0.15 per 8 ms frame."""
    return LOCALIZERS[method].Config(output_silence_rate=0.15)


def _track(y: np.ndarray, tracker: str, method: str, config=None):
    """The pipeline of ``track-audio AUDIO.wav --method METHOD --tracker TRACKER``:
    ``method``'s heat maps read by the tracker as ``map_reading`` says."""
    array = builtin_array("nao4")
    grid = DirectionGrid.azimuths()
    h = make_localizer(method, array, grid, config).run(y)
    reading = map_reading(tracker, method)
    seq = heatmap_sequence(
        h.weights, grid.azimuth_deg, h.frames, h.time_s, STEP, reading.observations,
        uniform_floor=reading.uniform_floor,
    )
    return h, seq, make_tracker(tracker, reading.config).run(seq)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("tracker", ["gauss", "vonmises"])
def test_a_talker_who_stops_is_not_reported_after_0_3_s(stopping_talker, tracker, method):
    y, stop_s = stopping_talker
    _, seq, tracks = _track(y, tracker, method, _gated(method))
    # reported while speaking ...
    speaking = tracks.active & (tracks.time_s > 1.0) & (tracks.time_s < stop_s)
    assert np.count_nonzero(speaking) >= 0.8 * np.count_nonzero(
        (seq.time_s > 1.0) & (seq.time_s < stop_s)
    )
    assert np.median(angular_error(tracks.azimuth_deg[speaking], 40.0)) < 5.0
    # ... and no longer 0.3 s after the last sound (the tracker frame stamps its block's end)
    late = tracks.active & (tracks.time_s > stop_s + 0.3)
    assert not late.any(), tracks.time_s[late].min()


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("tracker", ["gauss", "vonmises"])
def test_a_talker_walking_at_30_deg_per_s_is_followed_within_5_deg(walking_talker, tracker,
                                                                   method):
    y, on = walking_talker
    _, seq, tracks = _track(y, tracker, method)
    truth = -60.0 + 30.0 * seq.time_s
    speaking = on[np.minimum((seq.time_s * FS).astype(int), on.size - 1)]
    frames = np.flatnonzero((seq.time_s >= 1.0) & speaking)
    err = []
    for k in frames:
        sel = tracks.active & np.isclose(tracks.time_s, seq.time_s[k])
        err.append(angular_error(tracks.azimuth_deg[sel], truth[k]).min() if sel.any() else 180)
    err = np.array(err)
    assert np.mean(err <= 5.0) >= 0.9, (np.mean(err <= 5.0), np.median(err))
    assert np.mean(err[err <= 15.0]) <= 5.0


@pytest.fixture(scope="module", params=METHODS)
def walking_map(walking_talker, request):
    y, _ = walking_talker
    grid = DirectionGrid.azimuths()
    return request.param, grid, make_localizer(request.param, builtin_array("nao4"), grid).run(y)


@pytest.mark.parametrize("tracker", ["gauss", "vonmises"])
def test_the_lead_compensates_the_maps_delay_on_a_walking_talker(walking_map, tracker):
    """The map's peak trails a talker walking at 30°/s; the default reading reports the
    direction predicted ``lead_s`` ahead, which cuts that bias."""
    method, grid, h = walking_map
    reading = map_reading(tracker, method)
    assert reading.config.lead_s == pytest.approx(0.15)
    seq = heatmap_sequence(
        h.weights, grid.azimuth_deg, h.frames, h.time_s, STEP, reading.observations,
        uniform_floor=reading.uniform_floor,
    )
    bias = {}
    for lead in (0.0, reading.config.lead_s):
        cfg = dataclasses.replace(reading.config, lead_s=lead)
        tracks = make_tracker(tracker, cfg).run(seq)
        sel = tracks.active & (tracks.time_s >= 1.0)
        trail = wrap_azimuth(-60.0 + 30.0 * tracks.time_s[sel] - tracks.azimuth_deg[sel])
        bias[lead] = float(np.mean(trail[np.abs(trail) < 15.0]))  # > 0: the estimate trails
    assert bias[0.0] > 2.0
    assert abs(bias[reading.config.lead_s]) < 0.8 * bias[0.0]
