"""Audio-visual user paths (``avtrack track-av``), one function each.

- :func:`track_scene_direction`: persons in the microphone array's direction space
  (:mod:`avtrack.av.persons`) on a simulated scene directory, heard out of the camera's view;
- :func:`track_scene_image`: the image-plane model (VAVIT, thesis ch. 4, :mod:`avtrack.av.vavit`)
  with its learned audio-to-image mapping, or without audio the visual tracker (OVBT), on a
  scene directory;
- :func:`track_av163_sequence`: an AV16.3 sequence from its real video, DOA measurements and
  calibration;
- :func:`~avtrack.pipelines.av_recording.track_own_recording`: a recording of one's own (video
  or detections; the array's WAV read in blocks, or a DOA CSV; a camera file or the camera
  estimated from the recording).

Each takes paths, configurations and options, returns an :class:`AVRun` (or a subclass with
what its path adds) and writes nothing: the command line writes the files. Long steps are
announced through ``stage`` (:data:`~avtrack.pipelines.mot.Stage`); bad input raises
:class:`~avtrack.errors.InputError`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from avtrack.audio.arrays import MicArray, load_array
from avtrack.audio.beamform import extract_voices, tracks_from_persons
from avtrack.av.av163 import track_av163
from avtrack.av.gllim import AudioImageMapping, load_mapping
from avtrack.av.persons import PersonConfig
from avtrack.av.persons_scene import scene_geometry, track_scene_persons
from avtrack.av.vavit import AVSceneResult, VAVITConfig, track_scene
from avtrack.errors import InputError
from avtrack.io.av163 import AV163Sequence, load_av163
from avtrack.io.mot import MOTData
from avtrack.io.persons import PersonsTable
from avtrack.io.rttm import RTTMSegment
from avtrack.io.scene import SceneInputs, load_scene
from avtrack.metrics.ospa import ospa_sequence
from avtrack.phd.likelihood import av163_truth
from avtrack.pipelines.mot import Stage, no_stage
from avtrack.visual.detect import load_detector


@dataclass(frozen=True, eq=False)
class AVRun:
    """What every path of ``track-av`` gives: the contents of ``tracks.txt``, ``persons.csv``,
    ``speech.rttm`` and ``voices/``.

    Attributes
    ----------
    tracks, speaking, persons
        As in :class:`avtrack.av.persons_scene.PersonsResult`: the persons' boxes in the image,
        whether each box's person speaks, every tracked person every frame.
    speech : list of RTTMSegment or None
        Speaker turns; None without audio (no ``speech.rttm``).
    n_frames : int
    fps : float
    elapsed_s : float
        Seconds spent tracking (and beamforming the voices).
    voices : dict {id: ndarray (n_samples,)} or None
        Each person's voice (asked for), at ``voices_fs``.
    voices_fs : int
        Sample rate of ``voices``, Hz.
    """

    tracks: MOTData
    speaking: np.ndarray
    persons: PersonsTable
    speech: list[RTTMSegment] | None
    n_frames: int
    fps: float
    elapsed_s: float
    voices: dict[int, np.ndarray] | None
    voices_fs: int

    @property
    def duration_s(self) -> float:
        """Length of the tracked recording, seconds."""
        return self.n_frames / self.fps

    @property
    def n_persons(self) -> int:
        """Persons tracked (distinct ids of ``persons``)."""
        return int(np.unique(self.persons.ids).size)


def beamform_voices(
    audio: np.ndarray, fs: int, array: MicArray, persons: PersonsTable,
    speech: list[RTTMSegment], stage: Stage = no_stage,
) -> dict[int, np.ndarray]:
    """Each tracked person's voice (:func:`avtrack.audio.beamform.extract_voices`): an MVDR
    beamformer of ``audio`` ``(n_mics, n_samples)`` steered at the person's direction,
    silent outside their speaker turns."""
    if audio.shape[0] != array.n_mics:
        raise InputError(f"--voices: the audio has {audio.shape[0]} channels, the array "
                         f"{array.n_mics} microphones")
    tracks = tracks_from_persons(persons, speech)
    with stage(f"beamforming {len(tracks)} voices"):
        try:
            return extract_voices(audio, fs, array, tracks)
        except ValueError as exc:
            raise InputError(f"--voices: {exc}") from None


# -------------------------------------------------------------------------- scene directory


def track_scene_direction(
    scene_dir: Path,
    config: PersonConfig,
    *,
    fov_fraction: float = 1.0,
    vad: bool = True,
    voices: bool = False,
    stage: Stage = no_stage,
) -> AVRun:
    """Persons in the array's direction space on a scene directory
    (:func:`avtrack.av.persons_scene.track_scene_persons`).

    Parameters
    ----------
    scene_dir : Path
        As written by ``avtrack simulate``.
    config : PersonConfig
    fov_fraction : float
        The camera sees the central fraction of the image width.
    vad : bool
        Refine the speaker turns with the voice activity detector when it is installed (a
        warning when it is not); False: the tracker's turns.
    voices : bool
        Also beamform each person's voice from the scene's recording.
    stage : Stage
    """
    scene = load_scene(scene_dir)
    t0 = time.perf_counter()
    try:
        with stage(f"tracking {scene.n_frames} frames"):
            res = track_scene_persons(scene, fov_fraction=fov_fraction, config=config,
                                      vad=None if vad else False)
    except InputError:
        raise
    except ValueError as exc:
        raise InputError(str(exc), scene_dir) from None
    elapsed = time.perf_counter() - t0
    out_voices = None
    if voices:
        t0 = time.perf_counter()
        out_voices = beamform_voices(scene.audio, scene.fs, load_array(scene.path / "array.json"),
                                     res.persons, res.speech, stage)
        elapsed += time.perf_counter() - t0
    return AVRun(res.tracks, res.speaking, res.persons, res.speech, res.n_frames, res.fps,
                 elapsed, out_voices, scene.fs)


@dataclass(frozen=True, eq=False)
class ImageRun(AVRun):
    """:func:`track_scene_image`'s result: an :class:`AVRun` and

    Attributes
    ----------
    result : AVSceneResult
        The image-plane tracker's own result (its covariances with ``record_precisions``).
    mapping : AudioImageMapping or None
        The audio-to-image mapping used (None without audio).
    mapping_trained : bool
        Trained (or read from the cache) here rather than read from a file: worth saving.
    mapping_cache : Path or None
        The cache folder it was read from (None when trained now or read from a file).
    mapping_s : float
        Seconds spent training or reading it from the cache.
    """

    result: AVSceneResult
    mapping: AudioImageMapping | None
    mapping_trained: bool
    mapping_cache: Path | None
    mapping_s: float


def track_scene_image(
    scene_dir: Path,
    config: VAVITConfig,
    *,
    use_audio: bool = True,
    mapping: Path | None = None,
    calibration_positions: int = 120,
    fov_fraction: float = 1.0,
    record_precisions: bool = False,
    stage: Stage = no_stage,
) -> ImageRun:
    """The image-plane model (VAVIT, :func:`avtrack.av.vavit.track_scene`) on a scene
    directory; without audio the visual tracker (OVBT).

    Parameters
    ----------
    scene_dir : Path
    config : VAVITConfig
    use_audio : bool
    mapping : Path, optional
        A trained audio-to-image mapping (``.npz``); default: trained on a simulated
        loudspeaker calibration of the scene's room with ``calibration_positions`` positions
        (or read from the cache).
    calibration_positions : int
    fov_fraction : float
    record_precisions : bool
        Keep each box's covariance terms (for the covariance figure).
    stage : Stage
    """
    if calibration_positions < 4:
        raise InputError(f"--calibration-positions must be >= 4, got {calibration_positions}")
    scene = load_scene(scene_dir)
    mp, cache, mapping_s = None, None, 0.0
    if use_audio:
        if mapping is not None:
            mp = load_mapping(mapping)
        else:
            mp, cache, mapping_s = _scene_mapping(scene, calibration_positions, stage)
    t0 = time.perf_counter()
    try:
        with stage(f"tracking {scene.n_frames} frames"):
            res = track_scene(scene_dir, mp, config, use_audio=use_audio,
                              fov_fraction=fov_fraction, record_precisions=record_precisions,
                              scene=scene)
    except InputError:
        raise
    except ValueError as exc:  # e.g. detections or features inconsistent with the scene
        raise InputError(str(exc), scene_dir) from None
    elapsed = time.perf_counter() - t0
    return ImageRun(res.tracks, res.speaking, image_persons(res, scene),
                    res.speech if use_audio else None, res.n_frames, res.fps, elapsed, None,
                    scene.fs, result=res, mapping=mp,
                    mapping_trained=use_audio and mapping is None, mapping_cache=cache,
                    mapping_s=mapping_s)


def _scene_mapping(
    scene: SceneInputs, n_positions: int, stage: Stage
) -> tuple[AudioImageMapping, Path | None, float]:
    """The scene's audio-to-image mapping, trained on a simulated calibration or read from
    the cache; the cache folder when read from it, and the seconds it took."""
    # (the room simulator is imported only when a mapping is trained)
    from avtrack.simulate.calibration import mapping_cache_dir, train_scene_mapping

    t0 = time.perf_counter()
    with stage(f"audio-to-image mapping (calibration with {n_positions} loudspeaker positions "
              f"and training, unless cached)"):
        mp, cached = train_scene_mapping(scene, n_positions)
    return mp, mapping_cache_dir() if cached else None, time.perf_counter() - t0


def image_persons(res: AVSceneResult, scene: SceneInputs) -> PersonsTable:
    """``persons.csv`` rows of an image-plane result: each reported box's direction."""
    tr = res.tracks
    if scene.scenario is None or len(tr) == 0:
        az = el = np.zeros(len(tr))
    else:
        az, el, _ = scene_geometry(scene).boxes_to_directions(tr.boxes)
    centre = tr.boxes[:, :2] + 0.5 * tr.boxes[:, 2:]
    lo, hi = res.fov
    in_view = (centre[:, 0] >= lo) & (centre[:, 0] <= hi)
    return PersonsTable(tr.frames, tr.ids, az, el, centre, in_view,
                        res.speaking.astype(float), res.fps)


# ------------------------------------------------------------------------------------ AV16.3


@dataclass(frozen=True, eq=False)
class AV163Run(AVRun):
    """:func:`track_av163_sequence`'s result: an :class:`AVRun` and the ``sequence`` read
    (:class:`~avtrack.io.av163.AV163Sequence`: its ground truth scores the run)."""

    sequence: AV163Sequence


def track_av163_sequence(
    folder: Path,
    seq: int,
    cam: int,
    video: Path,
    config: PersonConfig,
    *,
    detector: str | None = None,
    stage: Stage = no_stage,
) -> AV163Run:
    """The direction-space persons of AV16.3 sequence ``seq`` seen by camera ``cam``, from its
    real video, array 1's DOA measurements and the calibration
    (:func:`avtrack.av.av163.track_av163`).

    Parameters
    ----------
    folder : Path
        The AV16.3 MAT files.
    seq, cam : int
    video : Path
        The sequence's video from that camera.
    config : PersonConfig
    detector : str, optional
        A detector name or ``module:attribute`` (default: the tops of the moving foreground,
        scored by the sequence's colour templates).
    stage : Stage
    """
    if not folder.is_dir():
        raise InputError("AV16.3 folder not found", folder)
    sequence = load_av163(folder, seq, cam)
    det = load_detector(detector) if detector is not None else None
    t0 = time.perf_counter()
    with stage(f"detecting and tracking {sequence.n_frames} frames"):
        try:
            res = track_av163(sequence, video, det, config=config)[0]
        except ValueError as exc:
            raise InputError(str(exc)) from None
    elapsed = time.perf_counter() - t0
    return AV163Run(res.tracks, res.speaking, res.persons, res.speech, res.n_frames, res.fps,
                    elapsed, None, 0, sequence=sequence)


def av163_scores(run: AV163Run) -> dict[str, float]:
    """Scores of an AV16.3 run: the mean over frames of the OSPA distance (order 2, cut-off
    50 px) between the persons reported in the image and the mouths of the ground truth
    (``posGT``), and the numbers of persons and speakers."""
    P = run.persons
    seen = P.in_view & np.all(np.isfinite(P.pixels), axis=1)
    est = [P.pixels[seen & (P.frames == f)] for f in run.sequence.frames]
    ospa = ospa_sequence(est, av163_truth(run.sequence), 50.0, 2)[:, 0]
    return {"OSPA (px)": float(np.mean(ospa)),
            "persons": float(len(np.unique(P.ids))),
            "speakers": float(len({s.speaker for s in run.speech or []}))}
