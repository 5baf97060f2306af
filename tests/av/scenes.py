"""Seeded audio-visual test scenes and their calibration-trained mappings (built once per run).

``walkout()`` returns a scene directory where one talker walks from near the image centre into
the left side of the image, beyond the central 40 % a partial field of view keeps, talks there
for a few seconds and walks back; and the mapping trained on a simulated loudspeaker
calibration of its room (free-field 4-microphone array, synthetic speech: no shared data).
"""

from __future__ import annotations

import atexit
import functools
import shutil
import tempfile
from pathlib import Path

import numpy as np

from avtrack.av.gllim import AudioImageMapping, save_mapping
from avtrack.io.scenario import validate_scenario
from avtrack.simulate.calibration import scene_setup, simulate_calibration, train_mapping
from avtrack.simulate.scene import simulate_scene, write_scene

ARRAY = [2.5, 0.5, 1.3]
FOV_FRACTION = 0.4


def _place(az_deg: float, dist: float, height: float) -> list[float]:
    ang = np.deg2rad(90.0 + az_deg)
    return [ARRAY[0] + dist * np.cos(ang), ARRAY[1] + dist * np.sin(ang), height]


def _small_room(name: str, seed: int, duration: float, hfov_deg: float) -> dict:
    """The scenario fields the test scenes share: a 5 x 4 m room, the NAO array at ARRAY and a
    640 x 480 camera of horizontal field of view ``hfov_deg``."""
    return {
        "name": name,
        "duration": duration,
        "seed": seed,
        "room": {"dims": [5.0, 4.0, 2.7], "t60": 0.25},
        "array": {"name": "nao4", "position": ARRAY, "yaw_deg": 90.0},
        "camera": {"hfov_deg": hfov_deg, "width": 640, "height": 480},
    }


def walkout_scenario(seed: int = 3, duration: float = 14.0) -> dict:
    home, away = _place(4.0, 2.2, 1.6), _place(38.0, 2.2, 1.6)
    return {
        **_small_room("test-walkout", seed, duration, hfov_deg=90.0),
        "people": [
            {
                "id": 1,
                "motion": {
                    "type": "waypoints",
                    "waypoints": [
                        [0.0, *home],
                        [3.0, *home],
                        [4.5, *away],
                        [10.0, *away],
                        [11.5, *home],
                        [duration, *home],
                    ],
                },
            }
        ],
        "speech": {
            "mode": "turn-taking",
            "utterances": "synthetic",
            "mean_turn": 3.0,
            "mean_pause": 0.3,
        },
        "noise": {"diffuse_snr_db": 25.0, "fan_snr_db": None},
        "detector": {"miss_rate": 0.05, "false_alarm_rate": 0.05},
    }


@functools.cache
def _root() -> Path:
    root = Path(tempfile.mkdtemp(prefix="avtrack-av-tests-"))
    atexit.register(shutil.rmtree, root, True)
    return root


@functools.cache
def walkout() -> tuple[Path, AudioImageMapping, Path]:
    """``(scene_dir, mapping, mapping_path)`` of the walk-out scene."""
    scene_dir = write_scene(
        simulate_scene(validate_scenario(walkout_scenario())), _root() / "walkout"
    )
    from avtrack.io.scene import load_scene

    sc = load_scene(scene_dir)
    setup = scene_setup(sc.scenario, scene_dir / "scene.yaml")
    calib = simulate_calibration(*setup, n_positions=48, clip_s=0.4, settle_s=0.08, rng=0)
    mapping = train_mapping(calib, 4, max_iter=30, rng=0)
    path = save_mapping(_root() / "walkout-mapping.npz", mapping)
    return scene_dir, mapping, path


def out_of_image_scenario(seed: int = 5, duration: float = 16.0) -> dict:
    """Person 1 talks in front of a 60-degree camera, walks out of the whole image (70 degrees
    off its axis), talks there, comes back; person 2 stands at -75 degrees, never seen, and
    talks too."""
    home, away = _place(5.0, 2.0, 1.6), _place(70.0, 2.0, 1.6)
    hidden = _place(-75.0, 2.0, 1.6)
    return {
        **_small_room("test-out-of-image", seed, duration, hfov_deg=60.0),
        "people": [
            {"id": 1, "motion": {"type": "waypoints", "waypoints": [
                [0.0, *home], [3.0, *home], [5.0, *away], [11.0, *away], [13.0, *home],
                [duration, *home]]}},
            {"id": 2, "motion": {"type": "seated", "position": hidden, "sway": 0.0}},
        ],
        "speech": {"mode": "turn-taking", "utterances": "synthetic", "mean_turn": 2.5,
                   "mean_pause": 0.3},
        "noise": {"diffuse_snr_db": 25.0, "fan_snr_db": None},
        "detector": {"miss_rate": 0.05, "false_alarm_rate": 0.0},
    }


@functools.cache
def out_of_image() -> Path:
    """Scene directory of :func:`out_of_image_scenario`."""
    return write_scene(
        simulate_scene(validate_scenario(out_of_image_scenario())), _root() / "out-of-image"
    )
