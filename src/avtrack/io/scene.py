"""A scene directory as the trackers read it: detections, appearance, audio, camera, scene.yaml.

The directory is what ``avtrack simulate`` writes (:mod:`avtrack.simulate.scene`) and what
``avtrack track-av`` reads; its files are listed in the README. :func:`load_scene` reads the
inputs of the trackers with errors naming the file at fault.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from avtrack.errors import InputError
from avtrack.io.base import read_audio_file
from avtrack.io.camera import PinholeCamera
from avtrack.io.mot import MOTData, read_mot
from avtrack.io.scenario import validate_scenario


@dataclass(frozen=True)
class SceneInputs:
    """What the trackers read from a scene directory (see :mod:`avtrack.simulate.scene`).

    Attributes
    ----------
    detections : MOTData
    appearance : ndarray (len(detections), F) or None
    audio : ndarray (n_mics, n_samples)
    fs : int
    fps : float
    n_frames : int
    image_size : (int, int)
    scenario : dict or None
        The validated ``scene.yaml`` (None when absent).
    path : Path
    """

    detections: MOTData
    appearance: np.ndarray | None
    audio: np.ndarray
    fs: int
    fps: float
    n_frames: int
    image_size: tuple[int, int]
    scenario: dict | None
    path: Path


def load_scene(scene_dir: str | Path) -> SceneInputs:
    """Read the inputs of a scene directory, with errors naming the file at fault."""
    d = Path(scene_dir)
    if not d.is_dir():
        raise InputError("scene directory not found", d)
    scenario = None
    if (d / "scene.yaml").is_file():
        try:
            raw = yaml.safe_load((d / "scene.yaml").read_text())
        except yaml.YAMLError as exc:
            raise InputError(
                f"invalid YAML: {str(exc).splitlines()[0]}", d / "scene.yaml"
            ) from None
        scenario = validate_scenario(raw, d / "scene.yaml")
    cam_path = d / "camera.json"
    if not cam_path.is_file():
        raise InputError("camera.json not found (needed for the image size)", cam_path)
    try:
        cam = PinholeCamera.from_json(json.loads(cam_path.read_text()), cam_path)
    except json.JSONDecodeError as exc:
        raise InputError(f"invalid JSON: {exc}", cam_path) from None
    dets = read_mot(d / "detections.txt", kind="det")
    app = None
    if (d / "appearance.npy").is_file():
        try:
            app = np.load(d / "appearance.npy", allow_pickle=False)
        except (OSError, ValueError) as exc:
            raise InputError(f"not a .npy array: {exc}", d / "appearance.npy") from None
        if app.ndim != 2 or app.shape[0] != len(dets):
            raise InputError(
                f"expected shape ({len(dets)}, F), one row per detection, got {app.shape}",
                d / "appearance.npy",
            )
        if not np.all(np.isfinite(app)):
            raise InputError("contains NaN or infinite values", d / "appearance.npy")
        app = app.astype(float)
    wav = d / "audio.wav"
    audio, fs = read_audio_file(wav, missing="audio.wav not found")
    audio = audio.T
    if audio.shape[1] == 0:
        raise InputError("audio.wav is empty", wav)
    if not np.all(np.isfinite(audio)):
        raise InputError("audio.wav contains NaN or infinite samples", wav)
    fps = float(scenario["fps"]) if scenario else 25.0
    if scenario:
        n_frames = int(np.floor(scenario["duration"] * fps + 1e-9))
    else:
        n_frames = int(np.floor(audio.shape[1] / fs * fps + 1e-9))
    n_frames = max(n_frames, dets.n_frames)
    return SceneInputs(
        dets, app, audio, int(fs), fps, n_frames, (cam.width, cam.height), scenario, d
    )
