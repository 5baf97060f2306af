"""A recording of one's own (``avtrack track-av --video/--detections --audio/--doa --camera``):
persons tracked in the microphone array's direction space.

:func:`track_own_recording` reads the array's WAV in blocks
(:class:`~avtrack.audio.recording.ArrayRecording`) and localizes it block by block
(:func:`localize_for_persons`), keeping per 8 ms frame only the heat map the speaker turns are
refined with and per video frame its peaks; the voice activity is found in a second pass over
the blocks. Memory grows with the recording by those maps (72 directions x 8 bytes per 8 ms,
about 43 MB for ten minutes; half as much again in single precision for the maps that place or
check the camera) and the tables of tracks, not by its samples. ``voices`` is the
exception: the beamformer reads the whole recording at once.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from avtrack.audio.arrays import MicArray
from avtrack.audio.recording import BLOCK_SECONDS, FS, ArrayRecording
from avtrack.av.calibrate import (
    MM_DISTANCE,
    CameraCheck,
    CameraEvidence,
    CameraFit,
    camera_evidence,
    check_camera,
    fit_camera,
    level_with_horizon,
    refine_yaw,
)
from avtrack.av.geometry import HEAD_HEIGHT_M, CameraGeometry
from avtrack.av.persons import PersonConfig
from avtrack.av.persons_scene import (
    CALIBRATION_LOCALIZER,
    PERSONS_LOCALIZER,
    audio_peak_floor,
    audio_peaks,
    grid_span,
    localizer_grid,
    track_persons,
)
from avtrack.av.vad import (
    AmplitudeLevel,
    AzimuthProfile,
    VoiceActivity,
    map_delay,
    vad_available,
    voice_activity_blocks,
    warn_vad_missing,
)
from avtrack.errors import InputError
from avtrack.io.camera import PinholeCamera, read_camera_file
from avtrack.io.doa import azimuths_per_frame, directions_per_frame, read_doa_csv
from avtrack.io.mot import MOTData, read_mot
from avtrack.io.video import VideoInfo, iter_frames, probe_video
from avtrack.localize import HeatMaps, make_localizer
from avtrack.localize.base import Localizer
from avtrack.localize.cgmm_eg import CGMMLocalizer
from avtrack.localize.grid import DirectionGrid, azimuth_profile, line_axis
from avtrack.pipelines.audio import blocks_then_end
from avtrack.pipelines.av import AVRun, beamform_voices
from avtrack.pipelines.mot import (
    Stage,
    check_against_video,
    detect_in_video,
    load_appearance,
    no_stage,
)
from avtrack.visual.detect import BOX_HEIGHT_M, DEFAULT_FACE_DETECTOR
from avtrack.visual.histograms import detection_histograms
from avtrack.visual.horizon import Horizon, estimate_horizon


@dataclass(frozen=True)
class RecordingInputs:
    """A recording of one's own, as ``track-av`` takes it.

    Attributes
    ----------
    camera : Path or None
        CAMERA.yaml: intrinsics, image size and pose in the array's frame; None: estimate the
        camera from the people seen talking (needs the audio).
    video : Path or None
        The camera's video (its frame rate, length and size are used).
    detections : Path or None
        Head or person detections (MOTChallenge det); default: detected in ``video``.
    appearance : Path or None
        Appearance descriptors (``.npy``), one row per detection; default: colour histograms
        from ``video``, or none.
    detector : str or None
        Detector for ``video`` without ``detections`` (default
        :data:`~avtrack.visual.detect.DEFAULT_FACE_DETECTOR`).
    audio : Path or None
        The microphone array's WAV (channel ``k`` is microphone ``k`` of ``array``).
    array : MicArray or None
        The array of ``audio``.
    allow_clipping : bool
        Accept a clipped recording (:func:`~avtrack.audio.recording.read_array_audio`).
    doa : Path or None
        Directions computed elsewhere (DOA CSV) instead of localizing ``audio``.
    fps : float or None
        Frame rate (default: the video's).
    image_size : (int, int) or None
        Image size of ``detections`` when neither a video nor a camera file gives it.
    camera_position : ndarray (3,) or None
        Where the camera to estimate stands in the array's frame, metres (None: at the array's
        centre); only without ``camera``, whose file gives the position. Three numbers in
        any sequence are taken.
    """

    camera: Path | None
    video: Path | None = None
    detections: Path | None = None
    appearance: Path | None = None
    detector: str | None = None
    audio: Path | None = None
    array: MicArray | None = None
    allow_clipping: bool = False
    doa: Path | None = None
    fps: float | None = None
    image_size: tuple[int, int] | None = None
    camera_position: np.ndarray | Sequence[float] | None = None

    def __post_init__(self) -> None:
        if self.camera_position is None:
            return
        pos = np.asarray(self.camera_position, dtype=float)
        if pos.shape != (3,) or not np.all(np.isfinite(pos)):
            raise InputError(f"the camera position must be three finite numbers (X,Y,Z in "
                             f"metres, in the array's frame), got {self.camera_position!r}")
        if self.camera is not None:
            raise InputError("a camera position is for a camera estimated from the recording: "
                             "the camera file gives its own", self.camera)
        if float(np.linalg.norm(pos)) > MM_DISTANCE:
            raise InputError(f"the camera position {self.camera_position!r} is "
                             f"{float(np.linalg.norm(pos)):.0f} m from the array: give it in "
                             f"metres, not millimetres")
        object.__setattr__(self, "camera_position", pos)


@dataclass(frozen=True, eq=False)
class RecordingRun(AVRun):
    """:func:`track_own_recording`'s result: an :class:`~avtrack.pipelines.av.AVRun` and

    Attributes
    ----------
    camera : PinholeCamera
        The camera tracked with (given, or estimated).
    camera_fit : CameraFit or None
        The estimate, when the camera was estimated here.
    camera_check : CameraCheck or None
        The given camera against the recording (None without audio or when estimated).
    video : VideoInfo or None
    fps_from_video : bool
        The frame rate is the video's (not given).
    audio_fs : int or None
        Sample rate of the WAV before resampling to 16 kHz (None without one).
    """

    camera: PinholeCamera
    camera_fit: CameraFit | None
    camera_check: CameraCheck | None
    video: VideoInfo | None
    fps_from_video: bool
    audio_fs: int | None


@dataclass(frozen=True, eq=False)
class PersonsAudio:
    """What the person tracker takes from a recording's audio (:func:`localize_for_persons`).

    Attributes
    ----------
    peaks : list of ndarray
        Peak azimuths of each video frame's mean heat map, degrees.
    heat : HeatMaps or None
        The localizer's heat map of every 8 ms frame (None without ``activity``: only the
        peaks are needed then).
    grid : DirectionGrid
    span_deg : float
        Span of the grid's azimuths.
    activity : VoiceActivity or None
        Voice activity of microphone 0 (None when not asked for or not installed).
    calibration_peaks : list of ndarray or None
        Peak azimuths per video frame of :data:`CALIBRATION_LOCALIZER`'s maps, which place
        the camera (None when not asked for).
    yaw_peaks : list of ndarray or None
        The same on the elevations the array can tell apart
        (:meth:`~avtrack.localize.grid.DirectionGrid.for_array`), which turn the camera
        (:func:`~avtrack.av.calibrate.refine_yaw`); None when not asked for or when the array
        hears no elevation (a line of microphones, an array known by its HRIRs).
    """

    peaks: list[np.ndarray]
    heat: HeatMaps | None
    grid: DirectionGrid
    span_deg: float
    activity: VoiceActivity | None
    calibration_peaks: list[np.ndarray] | None = None
    yaw_peaks: list[np.ndarray] | None = None


def localize_for_persons(
    recording: ArrayRecording,
    fps: float,
    n_frames: int,
    *,
    vad: bool = True,
    localizer: str = PERSONS_LOCALIZER,
    calibration: bool = False,
    yaw_map: bool = False,
    stage: Stage = no_stage,
) -> PersonsAudio:
    """The recording's heat maps and their peaks per video frame
    (:func:`~avtrack.av.persons_scene.audio_peaks`), localized block by block, with the voice
    activity of microphone 0 (``vad``, when the detector is installed; a warning when not)
    found in a second pass: what the whole signal gives, with memory of one block besides the
    heat maps. ``calibration``: also the peaks of :data:`CALIBRATION_LOCALIZER` (from the
    same run when ``localizer`` is the map it keeps as :attr:`presence`, ``dprtf-eg``), read
    at the times its maps describe when the voice activity is found (:func:`_calibration_peaks`),
    and, with ``yaw_map``, of its maps over the elevations the array hears (kept as their
    profile over azimuth: :attr:`PersonsAudio.yaw_peaks`).

    Parameters
    ----------
    recording : ArrayRecording
    fps : float
        Video frame rate.
    n_frames : int
        Video frames.
    vad : bool
    localizer : str
        A registered localizer.
    stage : Stage
    """
    grid = localizer_grid(recording.array)
    locs = _localizers(localizer, calibration, recording.array, grid)
    with_vad = vad and vad_available()
    if vad and not with_vad:
        warn_vad_missing()
    level = AmplitudeLevel(recording.info.samples) if with_vad else None
    n = locs[0].stft_config.n_frames(recording.info.samples)
    weights = np.empty((n, grid.size))
    calib = np.empty((n, grid.size), dtype=np.float32) if calibration else None
    yaw_loc = _yaw_localizer(recording.array) if calibration and yaw_map else None
    yaw_maps = None if yaw_loc is None else np.empty((n, grid.n_azimuths), dtype=np.float32)
    n_obs = np.empty(n, dtype=np.int64)
    done = 0
    for loc in [*locs, yaw_loc]:
        if loc is not None:
            loc.reset()
    with stage(f"localizing {recording.info.samples / FS:.1f} s"):
        for block in blocks_then_end(recording):
            parts = [loc.flush() if block is None else loc.process(block) for loc in locs]
            if yaw_loc is not None and yaw_maps is not None:  # (both or neither)
                part = yaw_loc.flush() if block is None else yaw_loc.process(block)
                yaw_maps[part.frames] = azimuth_profile(part.weights, yaw_loc.grid)[0]
            if calib is not None:
                calib[parts[-1].frames] = parts[-1].weights
                if len(locs) == 1 and len(parts[0]):  # the thesis weights of the same run
                    parts[0] = replace(parts[0], weights=locs[0].presence)
            weights[parts[0].frames] = parts[0].weights
            n_obs[parts[0].frames] = parts[0].n_observations
            done += len(parts[0])
            if block is None:
                break
            if level is not None:
                level.add(block[0])
    if done != n:
        raise RuntimeError(f"localize_for_persons: {done} STFT frames, {n} expected")
    frames = np.arange(n)
    heat = HeatMaps(frames, locs[0].stft_config.frame_times(frames), weights, n_obs)
    peaks = audio_peaks(heat.weights, heat.time_s, grid, fps, n_frames,
                        floor=audio_peak_floor(localizer))
    activity = None
    if level is not None:
        with stage("voice activity"):
            activity = voice_activity_blocks((b[0] for b in recording.blocks()), level.value())
    calibration_peaks = None if calib is None else _calibration_peaks(
        calib, heat.time_s, grid, fps, n_frames, activity)
    yaw_peaks = None if yaw_maps is None else _calibration_peaks(
        yaw_maps, heat.time_s, DirectionGrid(grid.azimuth_values, np.zeros(1)), fps, n_frames,
        activity)
    return PersonsAudio(peaks, heat if activity is not None else None, grid, grid_span(grid),
                        activity, calibration_peaks, yaw_peaks)


def estimate_camera(
    ev: CameraEvidence, yaw_ev: CameraEvidence | None, position: np.ndarray | None = None,
    horizon: Horizon | None = None,
) -> CameraFit:
    """``--camera auto``'s camera: fitted on ``ev`` (:attr:`PersonsAudio.calibration_peaks`
    and the boxes, :func:`~avtrack.av.calibrate.fit_camera`, the camera at ``position``), its
    pitch read from the heads' ``horizon`` (:func:`~avtrack.visual.horizon.estimate_horizon`,
    :func:`~avtrack.av.calibrate.level_with_horizon`) when the audio does not measure it, its
    yaw refitted on ``yaw_ev`` (:attr:`PersonsAudio.yaw_peaks`,
    :func:`~avtrack.av.calibrate.refine_yaw`) unless that has too little evidence.

    Raises
    ------
    ValueError
        Too little evidence in ``ev``.
    """
    fit = level_with_horizon(fit_camera(ev, position=position), ev, horizon)
    if yaw_ev is None:
        return fit
    try:
        return refine_yaw(fit, yaw_ev)
    except ValueError:
        return fit


def _yaw_localizer(array: MicArray) -> Localizer | None:
    """:data:`CALIBRATION_LOCALIZER` on the elevations ``array`` can tell apart
    (:meth:`~avtrack.localize.grid.DirectionGrid.for_array`), or None when it hears none."""
    grid = DirectionGrid.for_array(array)  # one row for a line of microphones or HRIRs
    if grid.n_elevations == 1:
        return None
    return make_localizer(CALIBRATION_LOCALIZER, array, grid)


def _calibration_peaks(
    calib: np.ndarray, time_s: np.ndarray, grid: DirectionGrid, fps: float, n_frames: int,
    activity: VoiceActivity | None,
) -> list[np.ndarray]:
    """Peak azimuths per video frame of :data:`CALIBRATION_LOCALIZER`'s maps ``calib``
    ``(T, D)``, each map read at the time it describes: ``time_s`` less the maps' delay behind
    the speech (:func:`~avtrack.av.vad.map_delay`, 0 without ``activity``). A walking talker's
    box is matched with the direction they spoke from, not the one the maps still hold some
    tenths of a second later (simulated walkouts and meetings, seeds 104-113: mean focal length
    error 6.3 -> 5.4 %, BENCHMARKS.md)."""
    delay = 0.0
    if activity is not None:
        delay = map_delay(AzimuthProfile.of_maps(calib, time_s, grid), activity)
    return audio_peaks(calib, time_s - delay, grid, fps, n_frames,
                       floor=audio_peak_floor(CALIBRATION_LOCALIZER))


def _localizers(localizer: str, calibration: bool, array: MicArray,
                grid: DirectionGrid) -> list:
    """The localizers :func:`localize_for_persons` runs: ``localizer``'s; with
    ``calibration`` also :data:`CALIBRATION_LOCALIZER`'s, last, or that one alone keeping
    its thesis weights when they are ``localizer``'s map."""
    if not calibration:
        return [make_localizer(localizer, array, grid)]
    calib = make_localizer(CALIBRATION_LOCALIZER, array, grid)
    if localizer == "dprtf-eg" and isinstance(calib, CGMMLocalizer):
        calib.keep_presence = True
        return [calib]
    return [make_localizer(localizer, array, grid), calib]


def track_own_recording(
    inputs: RecordingInputs,
    config: PersonConfig,
    *,
    use_audio: bool = True,
    vad: bool = True,
    voices: bool = False,
    strict: bool = False,
    block_s: float = BLOCK_SECONDS,
    stage: Stage = no_stage,
) -> RecordingRun:
    """Persons of a recording of one's own, tracked in the array's direction space
    (:func:`~avtrack.av.persons_scene.track_persons`): see the module docstring.

    Parameters
    ----------
    inputs : RecordingInputs
        Detections (or a video to detect in), audio (or a DOA CSV) and camera.
    config : PersonConfig
    use_audio : bool
        False: the visual tracker alone (no speaker turns).
    vad : bool
        Refine the speaker turns with the voice activity detector (when installed).
    voices : bool
        Also beamform each person's voice (reads the whole recording at once).
    strict : bool
        A camera file that disagrees with the recording is an error, not a warning.
    block_s : float
        Seconds of audio read at a time.
    stage : Stage

    Raises
    ------
    InputError
        Inputs that do not fit together (sizes, lengths, frames), or bad files.
    """
    if voices and (inputs.audio is None or not use_audio):
        raise InputError("--voices needs --audio with --array (the microphones to beamform)")
    camera = None if inputs.camera is None else read_camera_file(inputs.camera)
    video = None if inputs.video is None else probe_video(inputs.video)
    if video is not None and camera is not None and video.image_size != (camera.width,
                                                                          camera.height):
        raise InputError(f"the camera file says {camera.width}x{camera.height}, the video "
                         f"is {video.width}x{video.height}", inputs.camera)
    image_size = _image_size(inputs, video, camera)
    fps = _frame_rate(inputs.fps, video)
    recording = _open_recording(inputs, block_s) if use_audio else None
    n_frames = _frame_count(recording, video, fps)
    dets, n_frames, appearance = _visual_inputs(inputs, video, n_frames, stage)
    peaks, audio = None, None
    if use_audio and inputs.doa is not None:
        peaks = azimuths_per_frame(read_doa_csv(inputs.doa), fps, n_frames)
    elif recording is not None:
        audio = localize_for_persons(recording, fps, n_frames, vad=vad, calibration=True,
                                     yaw_map=camera is None, stage=stage)
        peaks = audio.peaks
    fit = check = None
    if peaks is not None:
        placing = peaks if audio is None or audio.calibration_peaks is None else (
            audio.calibration_peaks)
        camera, fit, check = _calibrate(inputs, camera, dets, placing, fps, image_size,
                                        n_frames, strict, stage,
                                        None if audio is None else audio.yaw_peaks)
    if camera is None:
        raise InputError("--camera auto needs the audio's directions")
    vcfg = config.visual
    if inputs.appearance is None and appearance is not None and vcfg.appearance != "bhattacharyya":
        vcfg = replace(vcfg, appearance="bhattacharyya", appearance_lambda=2.0)
    t0 = time.perf_counter()
    with stage(f"tracking {n_frames} frames"):
        try:
            geometry = CameraGeometry(camera, np.zeros(3), 0.0, box_height(inputs))
            res = track_persons(
                dets, appearance, peaks, geometry, fps,
                n_frames, visual_config=vcfg, config=config,
                azimuth_span_deg=360.0 if audio is None else audio.span_deg,
                heat=None if audio is None else audio.heat,
                grid=None if audio is None else audio.grid,
                activity=None if audio is None else audio.activity)
        except ValueError as exc:
            raise InputError(str(exc)) from None
    elapsed = time.perf_counter() - t0
    out_voices = None
    if voices and recording is not None:
        t0 = time.perf_counter()
        out_voices = beamform_voices(recording.read(), FS, recording.array, res.persons,
                                     res.speech, stage)
        elapsed += time.perf_counter() - t0
    return RecordingRun(
        res.tracks, res.speaking, res.persons, res.speech if peaks is not None else None,
        n_frames, fps, elapsed, out_voices, FS, camera=camera, camera_fit=fit,
        camera_check=check, video=video, fps_from_video=inputs.fps is None,
        audio_fs=None if recording is None else recording.info.fs)


def _open_recording(inputs: RecordingInputs, block_s: float) -> ArrayRecording | None:
    """The array's WAV opened (its rules checked in one pass), or None without one."""
    if inputs.audio is None:
        return None
    if inputs.array is None:
        raise InputError("--audio needs --array (WAV channel k is microphone k)")
    return ArrayRecording(inputs.audio, inputs.array, inputs.allow_clipping, quiet=True,
                          block_s=block_s)


def _image_size(
    inputs: RecordingInputs, video: VideoInfo | None, camera: PinholeCamera | None
) -> tuple[int, int]:
    """The image size: the video's, the camera file's, or the one given."""
    if video is not None:
        return video.image_size
    if camera is not None:
        return camera.width, camera.height
    if inputs.image_size is None:
        raise InputError("--camera auto without --video: give the detections' image size with "
                         "--image-size WIDTHxHEIGHT")
    return inputs.image_size


def _frame_rate(fps: float | None, video: VideoInfo | None) -> float:
    """The frame rate given, else the video's."""
    if fps is None and video is not None:
        fps = video.fps
    if fps is None:
        raise InputError("--fps: give the frame rate (frames per second) when there is no "
                         "--video")
    if not (np.isfinite(fps) and 0 < fps <= 1000):
        raise InputError(f"--fps must be in (0, 1000], got {fps}")
    return float(fps)


def _frame_count(recording: ArrayRecording | None, video: VideoInfo | None, fps: float) -> int:
    """Video frames: the video's (its length checked against the audio's), else as many as
    the audio lasts, else 0 (then the detections say)."""
    if video is not None:
        if recording is not None:
            a_s, v_s = recording.info.samples / FS, video.n_frames / fps
            if abs(a_s - v_s) > max(1.0, 0.02 * v_s):
                raise InputError(f"the audio lasts {a_s:.2f} s, the video {v_s:.2f} s "
                                 f"({video.n_frames} frames at {fps:g} fps): not one recording?",
                                 recording.path)
        return video.n_frames
    if recording is not None:
        return int(np.floor(recording.info.samples / FS * fps + 1e-9))
    return 0


def box_height(inputs: RecordingInputs) -> float:
    """Height in metres of what the boxes outline: the detector's
    (:data:`~avtrack.visual.detect.BOX_HEIGHT_M`) when it runs on the video, else a head's
    (detections from a file are head boxes)."""
    if inputs.detections is None and inputs.video is not None:
        return BOX_HEIGHT_M.get(inputs.detector or DEFAULT_FACE_DETECTOR, HEAD_HEIGHT_M)
    return HEAD_HEIGHT_M


def _visual_inputs(
    inputs: RecordingInputs, video: VideoInfo | None, n_frames: int, stage: Stage
) -> tuple[MOTData, int, np.ndarray | None]:
    """The detections (read, or found in the video's frames), the frame count they give
    with ``n_frames``, and their appearance (read, or colour histograms from the video)."""
    if inputs.detections is not None:
        dets = read_mot(inputs.detections, kind="det")
        n_frames = max(n_frames, dets.n_frames)
    elif inputs.video is not None:
        dets = detect_in_video(inputs.video, inputs.detector or DEFAULT_FACE_DETECTOR, stage)
    else:
        raise InputError("give --video (detections found in its frames) or --detections")
    if n_frames < 1:
        raise InputError("nothing to track: no frames")
    appearance = None
    if inputs.appearance is not None:
        appearance = load_appearance(inputs.appearance, len(dets))
    if video is not None:
        check_against_video(dets, video,
                            video.path if inputs.detections is None else inputs.detections)
        if appearance is None:
            with stage(f"colour histograms of {len(dets)} boxes"):
                appearance = detection_histograms(iter_frames(video.path, video), dets,
                                                  n_frames)
    return dets, n_frames, appearance


def _calibrate(
    inputs: RecordingInputs, camera: PinholeCamera | None, dets: MOTData,
    peaks: list[np.ndarray], fps: float, image_size: tuple[int, int], n_frames: int,
    strict: bool, stage: Stage, yaw_peaks: list[np.ndarray] | None = None,
) -> tuple[PinholeCamera, CameraFit | None, CameraCheck | None]:
    """No camera: the camera estimated from the people seen talking (its yaw refitted on
    ``yaw_peaks`` when given, :func:`~avtrack.av.calibrate.refine_yaw`); a camera file: checked
    against the recording (``strict``: its first warning is an error). Returns the camera
    to track with, the estimate and the check."""
    elevations = None
    if inputs.doa is not None:
        peaks, elevations = directions_per_frame(read_doa_csv(inputs.doa), fps, n_frames)
    axis = None if inputs.array is None else line_axis(inputs.array)
    ev = camera_evidence(dets, peaks, fps, image_size, elevations, box_height(inputs), axis)
    if camera is None:
        try:
            with stage("estimating the camera from the people seen talking"):
                fit = estimate_camera(
                    ev, None if yaw_peaks is None else camera_evidence(
                        dets, yaw_peaks, fps, image_size, None, box_height(inputs), axis),
                    position=None if inputs.camera_position is None
                    else np.asarray(inputs.camera_position, dtype=float),
                    horizon=estimate_horizon(dets, fps, image_size[1]))
        except ValueError as exc:
            raise InputError(f"--camera auto: {exc}") from None
        return fit.camera, fit, None
    path = inputs.camera if inputs.camera is not None else Path("CAMERA.yaml")
    with stage(f"checking {path.name} against the recording"):
        chk = check_camera(camera, ev, name=path.name,
                           horizon=estimate_horizon(dets, fps, image_size[1]))
    if strict and chk.warnings:
        raise InputError(f"--strict: {chk.warnings[0]}", path)
    return camera, None, chk
