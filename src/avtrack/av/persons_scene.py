"""Audio-visual tracking of a recording in the array's direction space (batch helper).

:func:`track_persons` runs, over a whole recording,

1. the visual tracker (OVBT, thesis §3.1) on the head detections, on the image plane;
2. the DP-RTF + EG localizer (thesis §5.2–5.3) on the microphone signals, its heat maps
   averaged over each video frame and reduced to their peaks (:func:`audio_peaks`);
3. the direction-space person tracker (:class:`~avtrack.av.persons.PersonTracker`),
   which links the visual tracks to persons and carries persons on audio while the camera
   does not see them;

and returns the MOTChallenge boxes of the persons in the image (the visual tracks, labelled
with their person's identity), every person's direction every frame (``persons.csv``) and the
speaker turns of every person heard, seen or not: the tracker's, at the video frame rate, or,
given the heat maps and the recording's voice activity, refined at the heat maps' 8 ms frames
(:mod:`avtrack.av.vad`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from avtrack.audio.arrays import MicArray
from avtrack.av.diarization import speaking_segments
from avtrack.av.geometry import CameraGeometry
from avtrack.av.persons import PersonConfig, PersonTracker
from avtrack.av.vad import VoiceActivity
from avtrack.io.mot import MOTData
from avtrack.io.persons import PersonsTable
from avtrack.io.rttm import RTTMSegment
from avtrack.localize.base import HeatMaps
from avtrack.localize.grid import DirectionGrid
from avtrack.metrics.mot import box_iou
from avtrack.visual.ovbt import OVBTConfig, track_mot

#: Localizer whose heat maps the persons pipeline reads by default (``track-av``'s direction
#: model, ``avtrack demo``, :func:`track_scene_persons`); see :data:`AUDIO_PEAK_FLOORS`.
PERSONS_LOCALIZER = "dprtf-eg"

#: Localizer whose peaks place the camera (:mod:`avtrack.av.calibrate`): its peaks follow a
#: walking person where the thesis weights trail (seconds behind on a walk out of the image),
#: and a trailing direction matched with the box of a moving person skews the fitted yaw and
#: focal length (simulated walkouts 104-113: focal length within 10 % in 9 of 10 against 7,
#: none off by more than 20 % against 40 and 73 %). Its run also gives the thesis weights
#: (:attr:`~avtrack.localize.cgmm_eg.CGMMLocalizer.presence`), so the persons keep theirs.
CALIBRATION_LOCALIZER = "dprtf-eg-fast"

#: Peaks of a frame-mean DP-RTF + EG heat map below this weight are not observations.
AUDIO_PEAK_FLOOR = 0.05

#: Peak floor of :func:`audio_peaks` per localizer whose maps differ from ``dprtf-eg``'s
#: (others: :data:`AUDIO_PEAK_FLOOR`). ``dprtf-eg-fast`` peaks are lower and wider (as the DOA
#: trackers' :data:`avtrack.doa.base.MAP_READINGS`): 0.035, chosen on development seeds 10-21
#: of the walkout and meeting scenes (0.03-0.04 within 1 DER point; 0.02 floods the binaural
#: meeting maps, whose uniform weight is 1/37). See BENCHMARKS.md (direction-space persons,
#: on ``dprtf-eg-fast`` maps).
AUDIO_PEAK_FLOORS: dict[str, float] = {"dprtf-eg-fast": 0.035, "dprtf-eg-static": 0.035}


def audio_peak_floor(localizer: str | None) -> float:
    """The :func:`audio_peaks` floor for the heat maps of ``localizer`` (None: ``dprtf-eg``)."""
    return AUDIO_PEAK_FLOORS.get(localizer or "", AUDIO_PEAK_FLOOR)


@dataclass(frozen=True)
class PersonsResult:
    """Tracking and diarization of a whole recording.

    Attributes
    ----------
    tracks : MOTData
        Head boxes of the persons seen in the image (ids = person ids).
    speaking : ndarray (len(tracks),) bool
        Whether the person of each row of ``tracks`` speaks at that frame.
    persons : PersonsTable
    speech : list of RTTMSegment
        Speaker turns (labels ``P<person id>``; with the voice activity detector also
        ``U<n>``, speech from a direction no tracked person stands at).
    n_frames : int
    fps : float
    fov : (float, float)
    image_size : (int, int)
    timing : dict
        Seconds spent on ``localization``, ``visual`` tracking and ``persons``, and the
        recording's ``duration``.
    """

    tracks: MOTData
    speaking: np.ndarray
    persons: PersonsTable
    speech: list[RTTMSegment]
    n_frames: int
    fps: float
    fov: tuple[float, float]
    image_size: tuple[int, int]
    timing: dict[str, float]


def localizer_grid(array: MicArray) -> DirectionGrid:
    """Candidate directions for an array: every 5 degrees around; for a two-microphone array
    (a binaural head or a pair) only the frontal half-plane, since a pair cannot tell a source
    in front from its mirror image behind it."""
    if array.n_mics <= 2:
        return DirectionGrid(np.arange(-90.0, 90.0 + 1e-9, 5.0), np.zeros(1))
    return DirectionGrid.azimuths(5.0)


def audio_peaks(
    weights: np.ndarray,
    time_s: np.ndarray,
    grid: DirectionGrid,
    fps: float,
    n_frames: int,
    floor: float = AUDIO_PEAK_FLOOR,
) -> list[np.ndarray]:
    """Azimuths of the peaks of the heat maps averaged over each video frame.

    Parameters
    ----------
    weights : ndarray (T, D)
        Heat maps of the localizer frames.
    time_s : ndarray (T,)
        Their times.
    grid : DirectionGrid
    fps : float
    n_frames : int
        Video frames; frame ``i`` (0-based) averages the localizer frames with times in
        ``[(i - 0.5) / fps, (i + 0.5) / fps)``.
    floor : float
        Minimum weight of a peak.

    Returns
    -------
    list of ndarray, one ``(K_i,)`` array of azimuths (degrees) per video frame
    """
    from avtrack.localize.peaks import local_maxima

    w = np.asarray(weights, dtype=float)
    idx = np.clip(np.floor(np.asarray(time_s) * fps + 0.5).astype(np.int64), 0, n_frames - 1)
    mean = np.zeros((n_frames, w.shape[1]))
    np.add.at(mean, idx, w)
    count = np.bincount(idx, minlength=n_frames)
    mean /= np.maximum(count, 1)[:, None]
    if grid.n_elevations > 1:  # the azimuth profile: sum over elevations
        mean = mean.reshape(n_frames, grid.n_elevations, grid.n_azimuths).sum(axis=1)
        grid = DirectionGrid(grid.azimuth_values, np.zeros(1))
    peak = local_maxima(mean, grid) & (mean >= floor)
    az = grid.azimuth_deg
    return [az[row] for row in peak]


def _visual_appearance(
    tracks: MOTData, dets: MOTData, appearance: np.ndarray | None, n_frames: int
) -> np.ndarray | None:
    """Descriptor of each track row: that of the detection it overlaps most (IoU >= 0.3) in
    its frame; NaN when none does."""
    if appearance is None:
        return None
    out = np.full((len(tracks), appearance.shape[1]), np.nan)
    t_sl, d_sl = tracks.frame_slices(n_frames), dets.frame_slices(n_frames)
    for ts, ds in zip(t_sl, d_sl, strict=True):
        if ts.stop == ts.start or ds.stop == ds.start:
            continue
        iou = box_iou(tracks.boxes[ts], dets.boxes[ds])
        best = iou.argmax(axis=1)
        ok = iou[np.arange(iou.shape[0]), best] >= 0.3
        rows = np.arange(ts.start, ts.stop)[ok]
        out[rows] = appearance[ds.start + best[ok]]
    return out


def track_persons(
    detections: MOTData,
    appearance: np.ndarray | None,
    peaks: list[np.ndarray] | None,
    geometry: CameraGeometry,
    fps: float,
    n_frames: int,
    *,
    visual_config: OVBTConfig | None = None,
    config: PersonConfig | None = None,
    fov: tuple[float, float] | None = None,
    azimuth_span_deg: float = 360.0,
    diarization_gap: float = 0.4,
    diarization_min: float = 0.3,
    min_speaker_s: float = 1.0,
    heat: HeatMaps | None = None,
    grid: DirectionGrid | None = None,
    activity: VoiceActivity | None = None,
) -> PersonsResult:
    """Track persons through a recording (see the module docstring).

    Parameters
    ----------
    detections : MOTData
        Head detections inside the camera's field of view.
    appearance : ndarray (len(detections), F) or None
    peaks : list of ndarray or None
        Audio peak azimuths per video frame (:func:`audio_peaks`); None: no audio.
    geometry : CameraGeometry
    fps : float
    n_frames : int
    visual_config : OVBTConfig, optional
        The visual tracker's parameters (default: ``config.visual``).
    config : PersonConfig, optional
    fov : (float, float), optional
        Pixel columns the camera sees.
    azimuth_span_deg : float
        Span of the localizer's candidate azimuths.
    diarization_gap, diarization_min : float
        Smoothing of the speaker turns (:func:`~avtrack.av.diarization.speaking_segments`).
    min_speaker_s : float
        Persons with less speech than this in all are not reported as speakers (a short-lived
        duplicate or a burst of reverberation rather than a talker).
    heat, grid, activity : optional
        The localizer's heat maps (the ones ``peaks`` came from), their grid and the voice
        activity of the recording (:func:`avtrack.av.vad.voice_activity`): given all three,
        the speaker turns are the tracker's refined at the heat maps' frame rate by the voice
        activity and each person's directional evidence (:func:`avtrack.av.vad.fuse_speaking`);
        without them, the tracker's turns at the video frame rate.
    """
    if peaks is not None and len(peaks) < n_frames:
        raise ValueError(f"audio peaks cover {len(peaks)} frames, the recording has {n_frames}")
    config = config or PersonConfig()
    vcfg = visual_config or config.visual
    t0 = time.perf_counter()
    vis = track_mot(detections, appearance, vcfg, geometry.image_size, n_frames, fps)
    vis_app = _visual_appearance(vis, detections, appearance, n_frames)
    t1 = time.perf_counter()
    tracker = PersonTracker(geometry, config, fps, fov, azimuth_span_deg)
    persons, person_ids = _track_frames(tracker, vis, vis_app, peaks, n_frames, fps)
    t2 = time.perf_counter()
    tracks = _person_boxes(vis, person_ids)
    # speaking flag of each box: its person's at that frame
    thr = tracker.config.speaking_threshold
    key = {(int(f), int(i)): s >= thr for f, i, s in zip(
        persons.frames, persons.ids, persons.speaking, strict=True)}
    speaking = np.array([key.get((int(f), int(i)), False) for f, i in zip(
        tracks.frames, tracks.ids, strict=True)], dtype=bool)
    speech: list[RTTMSegment] = []
    if peaks is not None:
        speech = _speaker_turns(persons, thr, diarization_gap, diarization_min, min_speaker_s,
                                heat, grid, activity)
    timing = {"duration": n_frames / fps, "visual": t1 - t0, "persons": t2 - t1}
    w = geometry.image_size[0]
    return PersonsResult(tracks, speaking, persons, speech, n_frames, fps,
                         fov if fov is not None else (0.0, float(w)),
                         (geometry.image_size[0], geometry.image_size[1]), timing)


#: Frames whose rows :func:`_track_frames` gathers into one array per column (thousands of
#: small per-frame arrays cost more memory than their rows).
_ROWS_BATCH = 512


def _track_frames(
    tracker: PersonTracker, vis: MOTData, vis_app: np.ndarray | None,
    peaks: list[np.ndarray] | None, n_frames: int, fps: float,
) -> tuple[PersonsTable, np.ndarray]:
    """Step ``tracker`` through every frame: every person every frame, and the person of
    each row of the visual tracks ``vis`` ``(len(vis),)`` (-1: merged away)."""
    no_audio = np.zeros(0)
    person_ids = np.zeros(len(vis), dtype=np.int64)
    names = ("frames", "ids", "az", "el", "px", "view", "speak", "side")
    cols: dict[str, list[np.ndarray]] = {k: [] for k in names}
    done: dict[str, list[np.ndarray]] = {k: [] for k in names}
    for i, sl in enumerate(vis.frame_slices(n_frames)):
        out = tracker.step(
            vis.ids[sl], vis.boxes[sl], None if vis_app is None else vis_app[sl],
            no_audio if peaks is None else peaks[i],
        )
        person_ids[sl] = out.person_of_visual
        cols["frames"].append(np.full(out.ids.shape[0], i + 1))
        cols["ids"].append(out.ids)
        cols["az"].append(out.azimuth_deg)
        cols["el"].append(out.elevation_deg)
        cols["px"].append(out.pixels)
        cols["view"].append(out.in_view)
        cols["speak"].append(out.speaking)
        cols["side"].append(out.side)
        if len(cols["ids"]) == _ROWS_BATCH:
            for k in names:
                done[k].append(np.concatenate(cols[k]))
                cols[k].clear()
    parts = {k: done[k] + cols[k] for k in names}
    cat = {k: (np.concatenate(v) if v else np.zeros(0)) for k, v in parts.items()}
    persons = PersonsTable(
        cat["frames"].astype(np.int64), cat["ids"].astype(np.int64), cat["az"], cat["el"],
        cat["px"].reshape(-1, 2), cat["view"].astype(bool), cat["speak"], fps,
        cat["side"].astype(np.int64),
    )
    return persons, person_ids


def _person_boxes(vis: MOTData, person_ids: np.ndarray) -> MOTData:
    """The visual tracks' boxes under their persons' ids ``(len(vis),)``: one box per person
    and frame (a MOT result never repeats an id in a frame): when two visual tracks stand for
    one person, the tracker used the first; so does the output."""
    keep = person_ids >= 0  # a person merged away in the frame its track was linked
    row_key = vis.frames.astype(np.int64) * (int(person_ids.max(initial=0)) + 2) + person_ids
    _, first = np.unique(np.where(keep, row_key, -1 - np.arange(len(row_key))),
                         return_index=True)
    dup = np.ones(len(row_key), dtype=bool)
    dup[first] = False
    keep &= ~dup
    return MOTData(vis.frames[keep], person_ids[keep], vis.boxes[keep], vis.scores[keep])


def _speaker_turns(
    persons: PersonsTable, threshold: float, gap: float, min_duration: float,
    min_speaker_s: float, heat: HeatMaps | None, grid: DirectionGrid | None,
    activity: VoiceActivity | None,
) -> list[RTTMSegment]:
    """Speaker turns of the persons speaking at or above ``threshold`` (fused with the voice
    activity when ``heat``, ``grid`` and ``activity`` are all given); speakers with less than
    ``min_speaker_s`` of speech in all are dropped."""
    speech = speaking_segments(
        persons.frames, persons.ids, persons.speaking >= threshold,
        persons.fps, max_gap=gap, min_duration=min_duration,
    )
    if heat is not None and grid is not None and activity is not None:
        speech = _fused_speech(persons, speech, heat, grid, activity)
    total: dict[str, float] = {}
    for seg in speech:
        total[seg.speaker] = total.get(seg.speaker, 0.0) + seg.duration
    return [seg for seg in speech if total[seg.speaker] >= min_speaker_s]


def _fused_speech(
    persons: PersonsTable, turns: list[RTTMSegment], heat: HeatMaps, grid: DirectionGrid,
    activity: VoiceActivity,
) -> list[RTTMSegment]:
    """The tracker's ``turns`` refined by the voice activity at the heat maps' frame rate, the
    maps first advanced by their delay behind the speech (:func:`~avtrack.av.vad.map_delay`)."""
    from avtrack.av.vad import (
        AzimuthProfile,
        activity_segments,
        advance,
        fuse_speaking,
        map_delay,
        unclaimed_speakers,
    )

    t_row = (persons.frames - 1) / persons.fps
    in_turn = np.zeros(len(persons), dtype=bool)
    for seg in turns:
        rows = persons.ids == int(seg.speaker[1:])
        in_turn |= rows & (t_row >= seg.start) & (t_row < seg.start + seg.duration)
    profile = AzimuthProfile.of_maps(heat.weights, heat.time_s, grid)
    profile = advance(profile, map_delay(profile, activity))  # lined up with the speech
    time_s, ids, speaking = fuse_speaking(persons, in_turn, profile, activity)
    centres, unseen = unclaimed_speakers(persons, speaking, profile, activity)
    return sorted(
        activity_segments(time_s, ids, speaking)
        + activity_segments(time_s, np.arange(1, centres.size + 1), unseen, label="U{}"),
        key=lambda s: (s.start, s.speaker))


def scene_geometry(scene) -> CameraGeometry:
    """The camera and array geometry of a simulated scene directory (``camera.json`` and the
    array pose in ``scene.yaml``)."""
    import json

    from avtrack.errors import InputError
    from avtrack.io.camera import PinholeCamera

    if scene.scenario is None:
        raise InputError("no scene.yaml: the array's pose relative to the camera is unknown",
                         scene.path)
    cam_path = scene.path / "camera.json"
    cam = PinholeCamera.from_json(json.loads(cam_path.read_text()), cam_path)
    return CameraGeometry.from_scenario(scene.scenario, cam)


def scene_heat_maps(
    scene, array: MicArray, localizer: str = PERSONS_LOCALIZER
) -> tuple[HeatMaps, DirectionGrid]:
    """Heat maps of the registered ``localizer`` on a scene's recording (resampled to the
    STFT's 16 kHz as ``avtrack localize`` does), and their grid."""
    from avtrack.localize import make_localizer

    grid = localizer_grid(array)
    loc = make_localizer(localizer, array, grid)
    audio = scene.audio
    if scene.fs != loc.fs:
        from fractions import Fraction

        import scipy.signal

        ratio = Fraction(loc.fs, int(scene.fs))
        audio = scipy.signal.resample_poly(audio, ratio.numerator, ratio.denominator, axis=1)
    return loc.run(audio), grid


def grid_span(grid: DirectionGrid) -> float:
    """Span in degrees of a localizer grid's azimuths (360 when circular)."""
    return 360.0 if grid.circular else float(np.ptp(grid.azimuth_values) + 5.0)


def localize_scene(
    scene, array: MicArray, n_frames: int, localizer: str = PERSONS_LOCALIZER
) -> tuple[list[np.ndarray], float]:
    """Audio peaks of a scene's recording per video frame (heat maps of the registered
    ``localizer``, peaks at or above :func:`audio_peak_floor`), and the localizer grid's
    azimuth span in degrees."""
    heat, grid = scene_heat_maps(scene, array, localizer)
    peaks = audio_peaks(heat.weights, heat.time_s, grid, scene.fps, n_frames,
                        floor=audio_peak_floor(localizer))
    return peaks, grid_span(grid)


def track_scene_persons(
    scene,
    *,
    use_audio: bool = True,
    fov_fraction: float = 1.0,
    config: PersonConfig | None = None,
    visual_config: OVBTConfig | None = None,
    peaks: list[np.ndarray] | None = None,
    span: float = 360.0,
    localizer: str = PERSONS_LOCALIZER,
    heat: HeatMaps | None = None,
    vad: bool | None = None,
) -> PersonsResult:
    """:func:`track_persons` on a loaded scene directory
    (:func:`avtrack.io.scene.load_scene`); ``peaks`` reuses audio peaks computed before
    (with their grid ``span``, and ``heat`` the heat maps they came from), else the heat maps
    of ``localizer`` give them (:func:`localize_scene`).

    ``vad``: refine the speaker turns with the voice activity of microphone 0
    (:mod:`avtrack.av.vad`); None (default) when the detector is installed, with a warning
    when it is not; it needs the heat maps (computed here, or ``heat`` with ``peaks``).
    """
    from avtrack.audio.arrays import load_array
    from avtrack.av.vad import vad_available, voice_activity, warn_vad_missing
    from avtrack.av.vavit import fov_strip, restrict_fov

    geometry = scene_geometry(scene)
    fov = fov_strip(scene.image_size[0], fov_fraction)
    dets, app = restrict_fov(scene.detections, scene.appearance, fov)
    if vad is None:
        vad = vad_available()
        if use_audio and not vad:
            warn_vad_missing()
    t0 = time.perf_counter()
    grid: DirectionGrid | None = None
    activity: VoiceActivity | None = None
    if use_audio and (peaks is None or (vad and heat is not None)):
        array = load_array(scene.path / "array.json")
        if array.n_mics != scene.audio.shape[0]:
            from avtrack.errors import InputError

            raise InputError(
                f"audio has {scene.audio.shape[0]} channels, array.json has {array.n_mics} "
                f"microphones", scene.path / "audio.wav",
            )
        grid = localizer_grid(array)
        if peaks is None:
            heat, grid = scene_heat_maps(scene, array, localizer)
            span = grid_span(grid)
            peaks = audio_peaks(heat.weights, heat.time_s, grid, scene.fps, scene.n_frames,
                                floor=audio_peak_floor(localizer))
        if vad:
            activity = voice_activity(scene.audio[0], int(scene.fs))
    t_loc = time.perf_counter() - t0
    res = track_persons(
        dets, app, peaks if use_audio else None, geometry, scene.fps, scene.n_frames,
        visual_config=visual_config, config=config, fov=fov, azimuth_span_deg=span,
        heat=heat, grid=grid, activity=activity,
    )
    res.timing["localization"] = t_loc
    return res
