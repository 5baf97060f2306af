"""Named scenarios: ready-made scenes, drawn from a seed.

``avtrack simulate NAME -o DIR [--seed S] [--duration SECONDS]`` uses these. Each builder
returns a raw scenario mapping (validated afterwards by
:func:`avtrack.io.scenario.validate_scenario`); the seed decides the number of people,
where they are and how they move, so two seeds give two different scenes and one seed always
gives the same one.

=============  ==============================================================================
name           scene
=============  ==============================================================================
meeting        2-4 people seated or shifting around a table in front of a binaural dummy
               head (KEMAR HRTFs) and a camera, turn-taking conversation -- AVDIAR-like.
locata-like    two talkers walking around a NAO robot head (measured NAO HRIRs, 4 top
               microphones) along the recorded LOCATA task-6 azimuth tracks, speaking when the
               recorded voice-activity track says so, with the robot's fan noise.
kinovis-like   a noisy room (fan at 5 dB, diffuse noise at 10 dB SNR), three talkers who come
               and go around the NAO head, two on the recorded Kinovis-MST tracks.
walkout        2-3 people in front of a 4-microphone array and a camera; each walks out of the
               camera's field of view while the conversation goes on, then comes back.
array-talkers  1-3 talkers standing still around a small free-field array (the ReSpeaker
               4-mic square, 45.7 mm) 0.5-2.5 m away and 15-50 degrees above its plane,
               speaking in short, mostly overlapping turns, in a room of T60 0.2-0.45 s,
               with the microphones' own incoherent noise 10 dB below the speech and no
               diffuse noise: the noise floor, coherence and direct-to-reverberant ratio
               measured on the real ReSpeaker recordings of the shared data (BENCHMARKS.md).
=============  ==============================================================================

:func:`demo_scenario` is the meeting of ``avtrack demo``: the ``meeting`` scene with a given
number of people, heard by a NAO-like 4-microphone array in the free field.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from avtrack.io.scenario import validate_scenario

#: Length in seconds of the shared recorded tracks (8 ms frames).
TRACK_SECONDS = {"locata": 7875 * 0.008, "kinovis": 4908 * 0.008}


def _room_angle(yaw_deg: float, az_deg: float) -> float:
    return np.deg2rad(yaw_deg + az_deg)


def _spread_azimuths(rng: np.random.Generator, n: int, half_width: float, gap: float):
    """``n`` azimuths in [-half_width, half_width] at least ``gap`` degrees apart."""
    for _ in range(1000):
        az = np.sort(rng.uniform(-half_width, half_width, n))
        if n == 1 or np.min(np.diff(az)) >= gap:
            return az
    return np.linspace(-half_width, half_width, n)


def meeting(seed: int, duration: float) -> dict:
    rng = np.random.default_rng([seed, 1])
    n = int(rng.integers(2, 5))
    centre = np.array([3.0, 0.8, 1.3])
    yaw = 90.0
    people = []
    for pid, az in enumerate(_spread_azimuths(rng, n, 26.0, 13.0), start=1):
        dist = rng.uniform(1.5, 2.6)
        height = float(rng.choice([1.2, 1.2, 1.65]))
        ang = _room_angle(yaw, az)
        pos = [centre[0] + dist * np.cos(ang), centre[1] + dist * np.sin(ang), height]
        if height > 1.5 and rng.random() < 0.7:
            # a standing person shifting between two places in view
            ang2 = _room_angle(yaw, np.clip(az + rng.uniform(-12, 12), -28, 28))
            d2 = np.clip(dist + rng.uniform(-0.4, 0.4), 1.4, 2.8)
            pos2 = [centre[0] + d2 * np.cos(ang2), centre[1] + d2 * np.sin(ang2), height]
            t1 = float(rng.uniform(0.2, 0.5) * duration)
            t2 = t1 + max(0.5, float(np.linalg.norm(np.subtract(pos2, pos)) / 0.6))
            motion: dict[str, Any] = {
                "type": "waypoints",
                "waypoints": [
                    [0.0, *pos],
                    [t1, *pos],
                    [t2, *pos2],
                    [max(duration, t2 + 1), *pos2],
                ],
            }
        else:
            motion = {"type": "seated", "position": pos, "sway": 0.03}
        people.append({"id": pid, "motion": _rounded(motion)})
    return {
        "name": "meeting",
        "duration": duration,
        "seed": seed,
        "room": {"dims": [6.0, 5.0, 3.0], "t60": 0.4},
        "array": {"name": "kemar", "position": centre.tolist(), "yaw_deg": yaw},
        "camera": {"hfov_deg": 70.0, "width": 640, "height": 480},
        "people": people,
        "speech": {"mode": "turn-taking", "mean_turn": 2.5, "overlap_prob": 0.15},
        "noise": {"diffuse_snr_db": 20.0, "fan_snr_db": None},
    }


def _track_motion(
    track: str,
    column: int,
    rng: np.random.Generator,
    radius: tuple[float, float],
    height: tuple[float, float],
    start: float,
) -> dict:
    """An ``azimuth-track`` motion following column ``column`` of a recorded track from
    ``start`` seconds, at a radius and height drawn uniformly in the given ranges (metres)."""
    return {
        "type": "azimuth-track",
        "track": track,
        "column": column,
        "radius": round(float(rng.uniform(*radius)), 3),
        "height": round(float(rng.uniform(*height)), 3),
        "start_s": round(start, 3),
    }


def _nao_in_room(
    name: str, seed: int, duration: float, dims: list[float], t60: float, centre: list[float]
) -> dict:
    """The scenario fields of a NAO head (4 microphones with HRIRs, its 60.9-degree camera)
    at ``centre`` in a room of size ``dims`` and reverberation time ``t60``."""
    return {
        "name": name,
        "duration": duration,
        "seed": seed,
        "room": {"dims": dims, "t60": t60},
        "array": {"name": "nao4", "hrir": True, "position": centre, "yaw_deg": 0.0},
        "camera": {"hfov_deg": 60.9, "width": 640, "height": 480},
    }


def locata_like(seed: int, duration: float) -> dict:
    rng = np.random.default_rng([seed, 2])
    dims = [7.1, 9.8, 3.0]
    centre = [3.55, 4.9, 1.4]
    start = float(rng.uniform(0.0, max(0.0, TRACK_SECONDS["locata"] - duration)))
    people = [
        {
            "id": col + 1,
            "motion": _track_motion("locata", col, rng, (1.3, 2.2), (0.1, 0.3), start),
        }
        for col in (0, 1)
    ]
    return {
        **_nao_in_room("locata-like", seed, duration, dims, 0.55, centre),
        "people": people,
        "speech": {"mode": "vad"},
        "noise": {"diffuse_snr_db": 30.0, "fan_snr_db": 15.0},
        "detector": {"miss_rate": 0.15, "false_alarm_rate": 0.3},
    }


def kinovis_like(seed: int, duration: float) -> dict:
    rng = np.random.default_rng([seed, 3])
    dims = [10.0, 10.0, 5.0]
    centre = [5.0, 5.0, 1.5]
    start = float(rng.uniform(0.0, max(0.0, TRACK_SECONDS["kinovis"] - duration)))
    people = []
    for pid in (1, 2, 3):
        if pid < 3:
            motion = _track_motion("kinovis", pid - 1, rng, (1.5, 2.5), (0.05, 0.3), start)
        else:
            motion = {
                "type": "random-walk",
                "area": [[2.5, 7.5], [2.5, 7.5]],
                "height": 1.65,
                "speed": 0.6,
                "pause_mean": 2.0,
            }
        # intermittent: one or two presence intervals covering 50-85 % of the scene
        frac = rng.uniform(0.5, 0.85)
        if rng.random() < 0.5:
            s = rng.uniform(0, (1 - frac) * duration)
            present = [[s, s + frac * duration]]
        else:
            gap = rng.uniform(0.1, 0.5) * (1 - frac) * duration
            first = rng.uniform(0.2, 0.8) * frac * duration
            present = [[0.0, first], [first + gap, min(duration, frac * duration + gap)]]
        present = [[round(float(a), 3), round(float(b), 3)] for a, b in present if b > a + 0.5]
        present = present or [[0.0, round(float(duration), 3)]]
        people.append({"id": pid, "motion": motion, "present": present})
    return {
        **_nao_in_room("kinovis-like", seed, duration, dims, 0.5, centre),
        "people": people,
        "speech": {"mode": "turn-taking", "mean_turn": 2.0, "mean_pause": 0.8},
        "noise": {"diffuse_snr_db": 10.0, "fan_snr_db": 5.0},
        "detector": {"miss_rate": 0.2, "false_alarm_rate": 0.5},
    }


def walkout(seed: int, duration: float) -> dict:
    rng = np.random.default_rng([seed, 4])
    n = int(rng.integers(2, 4))
    centre = np.array([3.0, 0.8, 1.2])
    yaw = 90.0
    hfov = 60.0
    people = []
    slot = duration / n
    for pid, az in enumerate(_spread_azimuths(rng, n, 20.0, 12.0), start=1):
        dist = rng.uniform(1.6, 2.4)
        ang = _room_angle(yaw, az)
        home = [centre[0] + dist * np.cos(ang), centre[1] + dist * np.sin(ang), 1.65]
        # walk out on the nearer side, well past the edge of the field of view
        side = 1.0 if az >= 0 else -1.0
        az_out = side * rng.uniform(hfov / 2 + 20, hfov / 2 + 40)
        ang_out = _room_angle(yaw, az_out)
        away = [centre[0] + dist * np.cos(ang_out), centre[1] + dist * np.sin(ang_out), 1.65]
        away[0] = float(np.clip(away[0], 0.4, 5.6))
        away[1] = float(np.clip(away[1], 0.4, 4.6))
        walk = float(np.linalg.norm(np.subtract(away, home)) / 0.8)
        t_leave = (pid - 1) * slot + rng.uniform(0.1, 0.3) * slot
        t_out = t_leave + walk
        t_back = t_out + rng.uniform(0.25, 0.45) * slot
        t_home = t_back + walk
        wps = [[0.0, *home], [t_leave, *home], [t_out, *away], [t_back, *away], [t_home, *home]]
        if t_home < duration:
            wps.append([duration, *home])
        people.append({"id": pid, "motion": _rounded({"type": "waypoints", "waypoints": wps})})
    return {
        "name": "walkout",
        "duration": duration,
        "seed": seed,
        "room": {"dims": [6.0, 5.0, 3.0], "t60": 0.3},
        "array": {"name": "nao4", "hrir": False, "position": centre.tolist(), "yaw_deg": yaw},
        "camera": {"hfov_deg": hfov, "width": 640, "height": 480},
        "people": people,
        "speech": {"mode": "turn-taking"},
        "noise": {"diffuse_snr_db": 20.0, "fan_snr_db": None},
    }


def array_talkers(seed: int, duration: float) -> dict:
    rng = np.random.default_rng([seed, 5])
    n = int(rng.integers(1, 4))
    dims = [float(rng.uniform(5.0, 7.0)), float(rng.uniform(4.0, 6.0)), 3.0]
    centre = np.array([dims[0] * 0.45, dims[1] * 0.42, 1.0])  # off-centre: no symmetric echoes
    dist = float(rng.uniform(0.5, 2.5))
    az = _spread_azimuths(rng, n, 180.0, 40.0) + rng.uniform(-180.0, 180.0)
    people = []
    for pid, a in enumerate(az, start=1):
        el = np.deg2rad(rng.uniform(15.0, 50.0))
        u = np.array([np.cos(np.deg2rad(a)) * np.cos(el), np.sin(np.deg2rad(a)) * np.cos(el),
                      np.sin(el)])
        pos = centre + dist * u
        pos = np.clip(pos, 0.3, np.asarray(dims) - 0.3)
        people.append({"id": pid, "motion": _rounded({"type": "seated", "position": pos.tolist(),
                                                      "sway": 0.0})})
    return {
        "name": "array-talkers",
        "duration": duration,
        "seed": seed,
        "room": {"dims": _rounded(dims), "t60": round(float(rng.uniform(0.2, 0.45)), 3)},
        "array": {"name": "respeaker4", "position": centre.tolist(), "yaw_deg": 0.0},
        "people": people,
        "speech": {"mode": "turn-taking", "mean_turn": 1.5, "mean_pause": 0.3,
                   "overlap_prob": 0.7},
        "noise": {"diffuse_snr_db": None, "fan_snr_db": None},
        "sensors": {"self_noise_snr_db": 10.0},
    }


def _rounded(value):
    if isinstance(value, dict):
        return {k: _rounded(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_rounded(v) for v in value]
    if isinstance(value, (float, np.floating)):
        return round(float(value), 4)
    return value


#: name -> builder(seed, duration) returning a raw scenario mapping.
SCENARIOS: dict[str, Callable[[int, float], dict]] = {
    "meeting": meeting,
    "locata-like": locata_like,
    "kinovis-like": kinovis_like,
    "walkout": walkout,
    "array-talkers": array_talkers,
}


def named_scenario(name: str, seed: int = 0, duration: float = 20.0) -> dict:
    """The raw scenario mapping of a named scene (see the module docstring)."""
    if name not in SCENARIOS:
        raise ValueError(f"unknown scenario {name!r}; choose from {', '.join(SCENARIOS)}")
    if duration <= 0:
        raise ValueError(f"duration: expected seconds > 0, got {duration}")
    return SCENARIOS[name](int(seed), float(duration))


def demo_scenario(seed: int, duration: float, people: int = 3) -> dict:
    """The meeting of ``avtrack demo``: ``people`` people in front of a NAO-like 4-microphone
    array (free field) and a camera; a validated scenario.

    The ``meeting`` scene draws 2-4 people; the first of the seeds ``seed, seed + 1000, ...``
    that gives ``people`` people is used, so the scene depends on ``seed`` (and ``people``)
    only.
    """
    for k in range(100):
        raw = named_scenario("meeting", seed + 1000 * k, duration)
        if len(raw["people"]) == people:
            break
    raw["seed"] = seed
    raw["name"] = "demo-meeting"
    raw["array"] = {**raw["array"], "name": "nao4", "hrir": False}
    return validate_scenario(raw)
