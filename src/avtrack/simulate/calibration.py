r"""Simulated audio-visual calibration sets and the training of the audio-to-image mapping.

AVDIAR's training sets :math:`\mathcal{T}_1, \mathcal{T}_2` (thesis §4.7.1) were recorded by
placing a loudspeaker emitting white noise at many positions in front of the sensor unit and
annotating its image position. :func:`simulate_calibration` does the same in a simulated room:
``n_positions`` loudspeaker positions spread over the image (each the camera ray through a
jittered grid pixel, at a random depth inside the room), one after the other, each emitting
``clip_s`` seconds of white noise rendered with the room's impulse response
(:func:`avtrack.simulate.acoustics.room_impulse_response`, the scene renderer's RIRs) into one
continuous recording, plus diffuse background noise. The recording goes through the tracker's
audio front end (:mod:`avtrack.av.features`), and every video frame of a clip whose estimator
has had ``settle_s`` to forget the previous position gives one training pair
:math:`(g_{tk}, x)` per active sub-band, ``x`` the projected loudspeaker position.

:func:`train_mapping` fits one GLLiM per sub-band (thesis eqs. 4.13–4.14, "there are K
models that need be trained") and returns the stacked
:class:`~avtrack.av.gllim.AudioImageMapping`. :func:`scene_setup` reads the room, array pose
and camera of a scene directory's ``scene.yaml``, so a mapping can be trained for the room of a
simulated scene (one calibration set per room, as in AVDIAR).

Stationary white noise would be classed as background by the minimum-statistics speech
detector, so the front end runs with ``calibration_feature_config`` (no noise tracking: every
bin is a "speech" bin) on a recording at high SNR; everything else (STFT, DP-RTF, averaging,
sub-bands) is the tracker's.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import scipy.signal

from avtrack.audio.arrays import MicArray
from avtrack.audio.dprtf import DPRTFConfig
from avtrack.av.features import AudioFeatureConfig, extract_audio_features
from avtrack.av.gllim import AudioImageMapping, fit_gllim
from avtrack.errors import InputError
from avtrack.io.camera import PinholeCamera
from avtrack.io.scene import SceneInputs
from avtrack.simulate import acoustics


@dataclass(frozen=True)
class CalibrationSet:
    """Training pairs of the audio-to-image mapping.

    Attributes
    ----------
    positions : ndarray (M, 2)
        Image position (u, v) of the loudspeaker in each training frame, pixels.
    features : ndarray (M, K, D)
        Audio observations of that frame.
    active : ndarray (M, K) bool
        Active sub-bands.
    points : ndarray (M, 3)
        Room-frame loudspeaker position, metres.
    meta : dict
        The recording setup (array name, number of microphones, whether the array is
        horizontal, image size, room), copied into the trained mapping.
    """

    positions: np.ndarray
    features: np.ndarray
    active: np.ndarray
    points: np.ndarray
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        m = self.positions.shape[0]
        if self.positions.shape != (m, 2):
            raise ValueError(
                f"CalibrationSet: positions must be (M, 2), got {self.positions.shape}"
            )
        if self.features.ndim != 3 or self.features.shape[0] != m:
            raise ValueError(f"CalibrationSet: features must be (M={m}, K, D)")
        if self.active.shape != self.features.shape[:2] or self.points.shape != (m, 3):
            raise ValueError("CalibrationSet: active must be (M, K) and points (M, 3)")

    def __len__(self) -> int:
        return int(self.positions.shape[0])


def calibration_feature_config(config: AudioFeatureConfig | None = None) -> AudioFeatureConfig:
    """The front end for white-noise calibration: ``config`` without noise tracking."""
    config = config or AudioFeatureConfig()
    dprtf = dataclasses.replace(config.dprtf or DPRTFConfig(), noise=None)
    return dataclasses.replace(config, dprtf=dprtf, vad_min_fraction=0.0)


def calibration_points(
    camera: PinholeCamera,
    room: acoustics.Room,
    n_positions: int,
    rng: np.random.Generator,
    depth_m: tuple[float, float] = (1.5, 3.5),
    margin_px: float = 8.0,
    wall_margin_m: float = 0.3,
) -> np.ndarray:
    """Loudspeaker positions ``(n_positions, 3)`` covering the image.

    A jittered grid of pixels over the image (as square as the image allows), each pixel's
    camera ray at a depth drawn in ``depth_m`` and shortened until the point is at least
    ``wall_margin_m`` inside the room.
    """
    if isinstance(n_positions, bool) or not isinstance(n_positions, int) or n_positions < 1:
        raise ValueError(f"n_positions must be an integer >= 1, got {n_positions!r}")
    lo, hi = depth_m
    if not 0 < lo <= hi:
        raise ValueError(f"depth_m must be (lo, hi) with 0 < lo <= hi, got {depth_m!r}")
    w, h = camera.width - 2 * margin_px, camera.height - 2 * margin_px
    nu = max(1, round(np.sqrt(n_positions * w / h)))
    nv = max(1, int(np.ceil(n_positions / nu)))
    cells = np.array([(i, j) for j in range(nv) for i in range(nu)])[:n_positions]
    uv = np.column_stack(
        [
            margin_px + (cells[:, 0] + rng.uniform(0, 1, len(cells))) * w / nu,
            margin_px + (cells[:, 1] + rng.uniform(0, 1, len(cells))) * h / nv,
        ]
    )
    # camera ray of each pixel in the room frame: R^T K^-1 (u, v, 1), scaled to unit depth
    rays = (
        np.column_stack(
            [
                (uv[:, 0] - camera.cx) / camera.fx,
                (uv[:, 1] - camera.cy) / camera.fy,
                np.ones(len(uv)),
            ]
        )
        @ camera.R
    )
    depth = rng.uniform(lo, hi, len(uv))
    points = camera.position + depth[:, None] * rays
    for _ in range(60):  # pull points that fall outside the room towards the camera
        out = ~room.contains(points, margin=wall_margin_m)
        if not np.any(out):
            break
        depth[out] *= 0.95
        points[out] = camera.position + depth[out, None] * rays[out]
    else:
        raise ValueError("calibration_points: the camera's view does not fit in the room")
    return points


def simulate_calibration(
    room: acoustics.Room,
    array: MicArray,
    pose: acoustics.ArrayPose,
    camera: PinholeCamera,
    *,
    n_positions: int = 240,
    clip_s: float = 0.6,
    settle_s: float = 0.12,
    snr_db: float = 30.0,
    rng: np.random.Generator | int = 0,
    config: AudioFeatureConfig | None = None,
) -> CalibrationSet:
    """A white-noise loudspeaker calibration recording and its training pairs.

    Parameters
    ----------
    room, array, pose, camera
        The recording setup (as a scene's, see :func:`scene_setup`).
    n_positions : int
        Loudspeaker positions.
    clip_s : float
        Seconds of white noise per position.
    settle_s : float
        Frames in the first ``settle_s`` of each clip are not used (the recursive DP-RTF
        estimator still remembers the previous position).
    snr_db : float
        Diffuse background noise level against the loudspeaker.
    rng : numpy Generator or int
    config : AudioFeatureConfig, optional
        The tracker's front end; noise tracking is switched off
        (:func:`calibration_feature_config`).

    Returns
    -------
    CalibrationSet
    """
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    if not (clip_s > 0 and 0 <= settle_s < clip_s):
        raise ValueError(
            f"need clip_s > 0 and 0 <= settle_s < clip_s, got {clip_s!r} and {settle_s!r}"
        )
    cfg = calibration_feature_config(config)
    fs = room.fs
    points = calibration_points(camera, room, n_positions, gen)
    uv, _ = camera.project(points)
    clip = round(clip_s * fs)
    total = clip * len(points)
    audio = np.zeros((array.n_mics, total + fs))
    for q, p in enumerate(points):
        rir = acoustics.room_impulse_response(room, array, pose, p, rng=gen)
        noise = gen.standard_normal(clip)
        wet = scipy.signal.oaconvolve(noise[None, :], rir, axes=1)
        end = min(audio.shape[1], q * clip + wet.shape[1])
        audio[:, q * clip : end] += wet[:, : end - q * clip]
    audio = audio[:, :total]
    speech_power = float(np.mean(audio**2))
    bg = acoustics.diffuse_noise(array, total, fs, gen)
    audio += bg * np.sqrt(speech_power / (np.mean(bg**2) * 10 ** (snr_db / 10)))
    n_video = int(np.floor(total / fs * cfg.fps))
    feats = extract_audio_features(audio, fs, n_video, cfg)
    times = np.arange(n_video) / cfg.fps
    slot = np.floor(times / clip_s + 1e-9).astype(int)
    into = times - slot * clip_s
    # keep frames whose whole STFT support lies inside one clip, after the settling time
    half = 0.5 / cfg.fps + cfg.stft.win_len / fs
    use = (slot < len(points)) & (into >= settle_s + half) & (into <= clip_s - half)
    use &= feats.active.any(axis=1)
    meta = {
        "array": array.name,
        "n_mics": int(array.n_mics),
        "horizontal_array": horizontal_array(array),
        "image_size": [int(camera.width), int(camera.height)],
        "room_dims": [float(v) for v in room.dims],
        "t60": float(room.t60),
        "band_size": int(cfg.band_size),
        "n_bands": int(cfg.n_bands),
    }
    return CalibrationSet(
        uv[slot[use]], feats.features[use], feats.active[use], points[slot[use]], meta
    )


def horizontal_array(array: MicArray, tol: float = 0.1) -> bool:
    """Whether the microphones lie (nearly) in a horizontal plane: vertical spread at most
    ``tol`` times the horizontal one (a binaural head, NAO's four top microphones, a table
    array). Such arrays resolve azimuth, not elevation."""
    spread = np.ptp(array.positions, axis=0)
    return bool(spread[2] <= tol * max(spread[0], spread[1]))


def train_mapping(
    calib: CalibrationSet,
    n_components: int = 8,
    *,
    axes: str = "auto",
    covariance_type: str = "full",
    max_iter: int = 100,
    reg_g: float = 1e-3,
    rng: np.random.Generator | int = 0,
    meta: dict | None = None,
) -> AudioImageMapping:
    r"""One GLLiM per sub-band from a calibration set (thesis eqs. 4.13–4.14).

    Sub-band ``k`` is trained on the frames where it is active. A sub-band with fewer than
    ``4 * n_components`` active frames gets the GLLiM of all its frames with a single-
    component fallback replicated ``R`` times, so every sub-band has the same ``R`` (its
    observations then carry the weak information they have).

    ``axes="xy"`` maps the image position (thesis §4.3.4); ``axes="x"`` only its horizontal
    coordinate, for arrays that cannot resolve elevation (a binaural head, a horizontal
    array): the vertical position then stays with vision and the dynamics, and the spread of
    the features over heights and depths goes into :math:`\Sigma_{kr}`. ``"auto"``: ``"x"``
    when the calibration's array is horizontal (``calib.meta["horizontal_array"]``), else
    ``"xy"``. (With the binaural head of the benchmark, the 2-D map's vertical estimates are
    off by 100-160 px at run time and drag audio-only tracks away; see ``bench_vavit.py``.)
    """
    if len(calib) == 0:
        raise ValueError("train_mapping: the calibration set is empty")
    if axes not in ("xy", "x", "auto"):
        raise ValueError(f"train_mapping: axes must be 'xy', 'x' or 'auto', got {axes!r}")
    if axes == "auto":
        axes = "x" if calib.meta.get("horizontal_array", False) else "xy"
    positions = calib.positions if axes == "xy" else calib.positions[:, :1]
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    models = []
    for k in range(calib.features.shape[1]):
        sel = calib.active[:, k]
        x, g = positions[sel], calib.features[sel, k]
        if sel.sum() >= 4 * n_components:
            fit = fit_gllim(
                x,
                g,
                n_components,
                covariance_type=covariance_type,
                max_iter=max_iter,
                reg_g=reg_g,
                rng=gen,
            )
            models.append(fit.model)
            continue
        if sel.sum() < 3:  # nothing to learn from: all frames, all bands pooled
            x, g = positions, calib.features[:, k]
        one = fit_gllim(x, g, 1, covariance_type=covariance_type, max_iter=0, reg_g=reg_g).model
        models.append(
            type(one)(
                np.full(n_components, 1.0 / n_components),
                np.repeat(one.nu, n_components, 0),
                np.repeat(one.omega, n_components, 0),
                np.repeat(one.lmat, n_components, 0),
                np.repeat(one.lvec, n_components, 0),
                np.repeat(one.sigma, n_components, 0),
            )
        )
    info = {
        "n_bands": int(calib.features.shape[1]),
        "feature_dim": int(calib.features.shape[2]),
        "n_calibration_frames": len(calib),
        "n_components": int(n_components),
        "covariance_type": covariance_type,
        "axes": axes,
    }
    return AudioImageMapping.from_models(models, {**calib.meta, **info, **(meta or {})})


def scene_setup(
    scenario: dict, scenario_path: str | Path | None = None
) -> tuple[acoustics.Room, MicArray, acoustics.ArrayPose, PinholeCamera]:
    """Room, array, array pose and camera of a validated scenario (a scene's ``scene.yaml``)."""
    from avtrack.simulate.scene import scene_array, scene_camera

    room = acoustics.Room(
        np.asarray(scenario["room"]["dims"]), scenario["room"]["t60"], int(scenario["fs"])
    )
    pose = acoustics.ArrayPose(
        np.asarray(scenario["array"]["position"]), scenario["array"]["yaw_deg"]
    )
    return room, scene_array(scenario, scenario_path), pose, scene_camera(scenario)


def mapping_cache_dir() -> Path:
    """Where trained scene mappings are kept: ``$AVTRACK_CACHE/mappings``, else
    ``$XDG_CACHE_HOME/avtrack/mappings``, else ``~/.cache/avtrack/mappings``."""
    import os

    root = os.environ.get("AVTRACK_CACHE")
    if root:
        return Path(root) / "mappings"
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "avtrack" / "mappings"


def geometry_key(
    scenario: dict, n_positions: int, n_components: int, max_iter: int,
    array: MicArray | None = None,
) -> str:
    """A hash of everything a scene mapping depends on: the room, array (its microphone
    positions and kind when ``array`` is given: a JSON array file may change under one name),
    camera and their poses, and the calibration and training settings (not the people, speech
    or noise)."""
    import hashlib
    import json

    from avtrack import __version__

    spec = {
        "room": scenario["room"],
        "array": scenario["array"],
        "camera": scenario["camera"],
        "fs": scenario.get("fs"),
        "fps": scenario.get("fps"),
        "n_positions": n_positions,
        "n_components": n_components,
        "max_iter": max_iter,
        "version": __version__,
        "mics": None if array is None else [array.kind, np.asarray(array.positions).tolist()],
    }
    text = json.dumps(spec, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def cached_scene_mapping(
    scenario: dict,
    scenario_path: str | Path | None,
    n_positions: int = 120,
    n_components: int = 8,
    max_iter: int = 50,
    cache_dir: str | Path | None = None,
    meta: dict | None = None,
) -> tuple[AudioImageMapping, bool]:
    """The audio-to-image mapping of a scene's geometry: simulated calibration and GLLiM
    training (thesis §4.4) the first time, read from the cache afterwards.

    Returns
    -------
    (AudioImageMapping, bool)
        The mapping and whether it came from the cache.
    """
    from avtrack.av.gllim import load_mapping, save_mapping
    from avtrack.errors import InputError

    setup = scene_setup(scenario, scenario_path)
    folder = Path(cache_dir) if cache_dir is not None else mapping_cache_dir()
    key = geometry_key(scenario, n_positions, n_components, max_iter, setup[1])
    path = folder / f"{key}.npz"
    if path.is_file():
        try:
            return load_mapping(path), True
        except InputError:
            pass  # a damaged cache entry: train again and replace it
    calib = simulate_calibration(*setup, n_positions=n_positions, rng=0)
    mapping = train_mapping(calib, n_components, max_iter=max_iter, meta=meta)
    try:
        save_mapping(path, mapping)
    except OSError:
        pass  # a read-only cache costs time, not results
    return mapping, False


def train_scene_mapping(
    scene: SceneInputs, n_positions: int = 120
) -> tuple[AudioImageMapping, bool]:
    """The audio-to-image mapping of a scene directory's geometry (its ``scene.yaml``):
    calibrated with a simulated loudspeaker and trained the first time, then read from the
    cache (:func:`cached_scene_mapping`). Returns the mapping and whether it came from the
    cache.

    Raises
    ------
    InputError
        The scene has no ``scene.yaml`` (its room cannot be simulated).
    """
    if scene.scenario is None:
        raise InputError(
            "no scene.yaml: cannot simulate a calibration of this scene's room; pass --mapping",
            scene.path,
        )
    return cached_scene_mapping(
        scene.scenario, scene.path / "scene.yaml", n_positions, meta={"scene": scene.path.name}
    )
