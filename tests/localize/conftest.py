"""One shared synthetic scene for all localizer tests: a static source in a reverberant room.

A speech-like source (coloured noise in 300 ms bursts separated by 200 ms pauses) at 2 m
from the nao4 array (free-field LOCATA geometry), azimuth 50 degrees, elevation ~0, in a
6 x 5 x 3 m room with T60 = 0.3 s (pyroomacoustics image sources), plus weak sensor noise.
"""

from __future__ import annotations

import numpy as np
import pyroomacoustics as pra
import pytest
import scipy.signal

from avtrack.audio.arrays import builtin_array

SOURCE_AZIMUTH_DEG = 50.0
FS = 16000


def bursty_source(n: int, rng: np.random.Generator) -> np.ndarray:
    """Speech-like test signal: low-passed noise bursts (300 ms on, 200 ms off)."""
    b, a = scipy.signal.butter(2, [200, 4000], btype="band", fs=FS)
    x = scipy.signal.lfilter(b, a, rng.standard_normal(n))
    t = np.arange(n) / FS
    env = (np.mod(t, 0.5) < 0.3).astype(float)
    return x * scipy.signal.convolve(env, np.hanning(160) / 80, mode="same")


def render_static_scene(az_deg: float, seconds: float = 2.5, seed: int = 0):
    rng = np.random.default_rng(seed)
    array = builtin_array("nao4")
    room_dim = np.array([6.0, 5.0, 3.0])
    absorption, max_order = pra.inverse_sabine(0.3, room_dim)
    room = pra.ShoeBox(room_dim, fs=FS, materials=pra.Material(absorption), max_order=max_order)
    centre = np.array([3.0, 2.5, 1.2])
    az = np.deg2rad(az_deg)
    room.add_source(
        centre + 2.0 * np.array([np.cos(az), np.sin(az), 0.0]),
        signal=bursty_source(int(seconds * FS), rng),
    )
    room.add_microphone_array(pra.MicrophoneArray((centre + array.positions).T, FS))
    room.simulate()
    y = room.mic_array.signals[:, : int(seconds * FS)]
    y = y / np.std(y)
    return array, y + 0.01 * rng.standard_normal(y.shape)


@pytest.fixture(scope="session")
def static_scene():
    """``(array, signal (4, n))`` of the module's scene."""
    return render_static_scene(SOURCE_AZIMUTH_DEG)


#: A 4.6 cm square of four microphones (the ReSpeaker 4-mic geometry).
SQUARE = 0.02285 * np.array(
    [[1.0, 1.0, 0.0], [-1.0, 1.0, 0.0], [-1.0, -1.0, 0.0], [1.0, -1.0, 0.0]]
)


def render_on_square(sources, t60: float, n: int) -> np.ndarray:
    """``n`` samples ``(4, n)`` of the :data:`SQUARE` array at (2.5, 2.0, 1.0) in a 5 x 4 x 3 m
    room of reverberation time ``t60``, hearing ``sources``: ``(azimuth_deg, elevation_deg,
    distance_m, signal)`` each; normalised to unit standard deviation."""
    room_dim = np.array([5.0, 4.0, 3.0])
    absorption, max_order = pra.inverse_sabine(t60, room_dim)
    room = pra.ShoeBox(room_dim, fs=FS, materials=pra.Material(absorption), max_order=max_order)
    centre = np.array([2.5, 2.0, 1.0])
    for az, el, dist, signal in sources:
        a, e = np.deg2rad(az), np.deg2rad(el)
        u = np.array([np.cos(a) * np.cos(e), np.sin(a) * np.cos(e), np.sin(e)])
        room.add_source(centre + dist * u, signal=signal)
    room.add_microphone_array(pra.MicrophoneArray((centre + SQUARE).T, FS))
    room.simulate()
    y = room.mic_array.signals[:, :n]
    return y / np.std(y)
