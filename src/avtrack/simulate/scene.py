"""Simulate a whole audio-visual scene from a validated scenario, and write its directory.

The scene directory (the contract of ``SPEC.md``, read back by ``avtrack track-av``)::

    SCENE_DIR/
      scene.yaml        the validated scenario (re-simulate with ``avtrack simulate scene.yaml``)
      audio.wav         (n_samples, n_mics) float32 at ``fs``; channel k is microphone k
      array.json        the microphone array ({"name", "positions", "kind", ...})
      camera.json       the pinhole camera (intrinsics, pose, image size)
      detections.txt    MOTChallenge detections ``frame,-1,left,top,width,height,score,-1,-1,-1``
      appearance.npy    (n_detections, D) one appearance descriptor per detection row
      gt/gt.txt         MOTChallenge ground truth of the head boxes (1-based frames at ``fps``)
      gt/doa.csv        every ``gt_hop_s`` seconds, each person present: azimuth / elevation in
                        the array frame, ``active`` = speaking (frame 0 is t = 0)
      gt/speech.rttm    who speaks when (speaker labels ``P<id>``)
      gt/positions.csv  ``frame,time_s,id,x,y,z`` room-frame head positions per video frame
      gt/voices/<id>.wav  each person's speech as microphone 0 hears it (their image at the
                        reference microphone, on the scale of audio.wav; float32 mono): the
                        reference of a separated voice (``avtrack eval voices``)

Every random draw comes from ``numpy.random.SeedSequence(seed)``, split into independent streams
for motion, speech timing, speech material, noise and detections, so changing (say) the detector
settings leaves the audio unchanged.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.io
import soundfile as sf

from avtrack.audio.arrays import BUILTIN_ARRAYS, MicArray, builtin_array, load_array
from avtrack.errors import InputError
from avtrack.io.base import atomic_write
from avtrack.io.camera import PinholeCamera
from avtrack.io.datasets import find_shared_data
from avtrack.io.doa import DOATable, write_doa_csv
from avtrack.io.mot import write_mot
from avtrack.io.rttm import RTTMSegment, write_rttm
from avtrack.io.scenario import dump_scenario
from avtrack.simulate import acoustics
from avtrack.simulate.detections import DetectorConfig, SimulatedDetections, simulate_detections
from avtrack.simulate.sensors import SensorDraw, SensorModel, apply_mismatch, white_noise
from avtrack.simulate.speech import (
    SpeechSegment,
    fill_segments,
    load_utterances,
    schedule_from_vad,
    turn_taking_schedule,
)
from avtrack.simulate.trajectory import (
    Trajectory,
    from_azimuth_track,
    random_walk,
    seated,
    waypoint_trajectory,
)

#: Frame period of the shared recorded LOCATA / Kinovis-MST tracks.
TRACK_FRAME_S = 0.008
TRACK_FILES = {"locata": "LOCATA", "kinovis": "Kinovis-MST"}


@dataclass(frozen=True)
class Scene:
    """A simulated scene in memory.

    Attributes
    ----------
    scenario : dict
        The validated scenario it was drawn from.
    audio : ndarray (n_mics, n_samples)
        The microphone signals.
    dry : ndarray (P, n_samples)
        Each person's dry (anechoic, unfiltered) speech: exactly 0 outside their segments.
    array : MicArray
    camera : PinholeCamera
    ids : ndarray (P,) int
        Person ids, in the order of the person axis below.
    trajectories : list of Trajectory (P,)
    segments : list of SpeechSegment
        Who speaks when (after clipping to each person's presence).
    video_times : ndarray (T,)
        Time of each video frame (frame f is ``video_times[f - 1]``).
    heads : ndarray (T, P, 3)
        Room-frame head positions per video frame, NaN while a person is absent.
    detections : SimulatedDetections
    doa : DOATable
        Ground-truth directions of arrival.
    sensors : SensorDraw or None
        The drawn per-microphone gain and delay mismatch (None: the scenario has no
        ``sensors`` section).
    references : ndarray (P, n_samples) or None
        Each person's image at microphone 0 (reverberant speech through the same sensor and
        level scaling as ``audio``; zeros for a person who never speaks): ``audio[0]`` is
        their sum plus the noise.
    """

    scenario: dict
    audio: np.ndarray
    dry: np.ndarray
    array: MicArray
    camera: PinholeCamera
    ids: np.ndarray
    trajectories: list[Trajectory]
    segments: list[SpeechSegment]
    video_times: np.ndarray
    heads: np.ndarray
    detections: SimulatedDetections
    doa: DOATable
    sensors: SensorDraw | None = None
    references: np.ndarray | None = None

    @property
    def fs(self) -> int:
        return int(self.scenario["fs"])


def _streams(seed: int) -> dict[str, np.random.Generator]:
    # SeedSequence.spawn keys children by index: appending a stream leaves the others unchanged
    names = ("motion", "schedule", "material", "noise", "detections", "levels", "tails", "sensors")
    children = np.random.SeedSequence(seed).spawn(len(names))
    return {n: np.random.default_rng(c) for n, c in zip(names, children, strict=True)}


def _load_track(kind: str, what: str, data_dir: Path | None) -> np.ndarray:
    root = data_dir if data_dir is not None else find_shared_data()
    path = Path(root) / "nao" / f"{TRACK_FILES[kind]}-speaker{what}.mat"
    if not path.is_file():
        raise InputError(f"recorded {kind} track not found (needed by an azimuth-track)", path)
    key = "speakerPosition" if what == "Position" else "speakerVAD"
    return np.asarray(scipy.io.loadmat(path, squeeze_me=True)[key], dtype=float)


def scene_array(scenario: dict, scenario_path: str | Path | None = None) -> MicArray:
    """The scenario's microphone array: a built-in name or a JSON file.

    A relative JSON path is resolved against the scenario file's folder.
    """
    spec = scenario["array"]
    name = spec["name"]
    if name in BUILTIN_ARRAYS:
        return builtin_array(name, hrir=True) if spec["hrir"] else load_array(name)
    if spec["hrir"]:
        raise InputError(
            f"array.hrir: measured HRIRs exist only for built-in arrays, not {name!r}",
            scenario_path,
        )
    path = Path(name)
    if not path.is_absolute() and scenario_path is not None:
        path = Path(scenario_path).parent / path
    return load_array(path)


def scene_camera(scenario: dict) -> PinholeCamera:
    """The scenario's camera; by default on top of the array, looking along its x axis."""
    cam = scenario["camera"]
    arr = scenario["array"]
    position = (
        cam["position"]
        if cam["position"] is not None
        else [
            arr["position"][0],
            arr["position"][1],
            arr["position"][2] + 0.05,
        ]
    )
    yaw = cam["yaw_deg"] if cam["yaw_deg"] is not None else arr["yaw_deg"]
    return PinholeCamera.from_fov(
        cam["hfov_deg"],
        cam["width"],
        cam["height"],
        np.asarray(position, float),
        yaw,
        cam["pitch_deg"],
    )


def scene_trajectories(
    scenario: dict, rng: np.random.Generator, data_dir: Path | None = None
) -> list[Trajectory]:
    """One trajectory per person, in scenario order."""
    duration = scenario["duration"]
    arr = scenario["array"]
    out = []
    for person in scenario["people"]:
        m = person["motion"]
        present = np.asarray(person.get("present", np.zeros((0, 2))), float).reshape(-1, 2)
        if m["type"] == "seated":
            traj = seated(rng, duration, np.asarray(m["position"]), sway=m["sway"])
        elif m["type"] == "random-walk":
            traj = random_walk(
                rng, duration, np.asarray(m["area"]), m["height"], m["speed"], m["pause_mean"]
            )
        elif m["type"] == "waypoints":
            traj = waypoint_trajectory(m["waypoints"])
        else:
            az = _load_track(m["track"], "Position", data_dir)[:, m["column"]]
            traj = from_azimuth_track(
                az,
                TRACK_FRAME_S,
                np.asarray(arr["position"]),
                arr["yaw_deg"],
                m["radius"],
                m["height"],
                m["start_s"],
                duration,
            )
        out.append(Trajectory(traj.times, traj.positions, present))
    return out


def _utterances(scenario: dict, fs: int, data_dir: Path | None):
    """``(resolved_name, [(name, signal), ...])`` for ``speech.utterances``."""
    choice = scenario["speech"]["utterances"]
    if choice == "synthetic":
        return "synthetic", []
    if choice in ("auto", "shared"):
        try:
            root = data_dir if data_dir is not None else find_shared_data()
        except InputError:
            if choice == "shared":
                raise
            return "synthetic", []
        folder = Path(root) / "audio" / "speech"
        if not folder.is_dir():
            if choice == "shared":
                raise InputError("shared speech utterances not found", folder)
            return "synthetic", []
        return "shared", load_utterances(folder, fs)
    return choice, load_utterances(Path(choice), fs)


def _clip_to_presence(segments, trajectories, ids) -> list[SpeechSegment]:
    by_id = dict(zip(ids.tolist(), trajectories, strict=True))
    out = []
    for seg in segments:
        traj = by_id[seg.speaker]
        ivs = traj.present if traj.present.shape[0] else np.array([[-np.inf, np.inf]])
        for a, b in ivs:
            s, e = max(seg.start, a), min(seg.end, b)
            # on the millisecond grid of RTTM files, so gt/speech.rttm is exact
            s, e = round(float(s), 3), round(float(e), 3)
            if e - s >= 0.2:
                out.append(SpeechSegment(seg.speaker, s, e, seg.utterance))
    return sorted(out, key=lambda s: (s.start, s.speaker))


def scene_schedule(
    scenario: dict,
    trajectories: list[Trajectory],
    rng: np.random.Generator,
    data_dir: Path | None = None,
) -> list[SpeechSegment]:
    """Who speaks when: a turn-taking conversation or the recorded voice activity."""
    ids = np.array([p["id"] for p in scenario["people"]])
    duration = scenario["duration"]
    sp = scenario["speech"]
    if sp["mode"] == "turn-taking":
        segs = turn_taking_schedule(
            len(ids), duration, rng, sp["mean_turn"], sp["mean_pause"], sp["overlap_prob"]
        )
        # the schedule numbers speakers 1..P; map them to the scenario's ids
        segs = [SpeechSegment(int(ids[s.speaker - 1]), s.start, s.end, s.utterance) for s in segs]
    else:
        n_frames = int(np.ceil(duration / TRACK_FRAME_S))
        vad = np.zeros((n_frames, len(ids)), dtype=bool)
        for k, person in enumerate(scenario["people"]):
            m = person["motion"]
            if m["type"] != "azimuth-track":
                continue
            track = _load_track(m["track"], "VAD", data_dir)[:, m["column"]] > 0.5
            first = round(m["start_s"] / TRACK_FRAME_S)
            part = track[first : first + n_frames]
            vad[: part.size, k] = part
        segs = schedule_from_vad(vad, TRACK_FRAME_S)
        segs = [SpeechSegment(int(ids[s.speaker - 1]), s.start, s.end, s.utterance) for s in segs]
    return _clip_to_presence(segs, trajectories, ids)


def _dry_speech(
    ids: np.ndarray,
    segments: list[SpeechSegment],
    utterances,
    fs: int,
    duration: float,
    rngs: dict[str, np.random.Generator],
) -> np.ndarray:
    """Dry speech per person ``(P, n_samples)``: silence outside their segments, levels within
    +-3 dB."""
    local = [
        SpeechSegment(int(np.flatnonzero(ids == s.speaker)[0]) + 1, s.start, s.end, s.utterance)
        for s in segments
    ]
    dry = fill_segments(local, utterances, fs, len(ids), duration, rngs["material"])
    return dry * 10 ** (rngs["levels"].uniform(-3, 3, size=(len(ids), 1)) / 20)


def _render_speech(
    room: acoustics.Room,
    array,
    pose: acoustics.ArrayPose,
    dry: np.ndarray,
    trajectories: list,
    talkers: list[int],
    n_samples: int,
    step_m: float,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray]:
    """The reverberant speech at the microphones ``(n_mics, n_samples)`` and each person's
    image at every microphone ``(P, n_mics, n_samples)`` (zero for those who never talk)."""
    sources = [
        acoustics.MovingSource(dry[k], trajectories[k].times, trajectories[k].positions)
        for k in talkers
    ]
    images = np.zeros((len(dry), array.n_mics, n_samples))  # each person at every microphone
    if sources:
        talker_images = acoustics.render_images(
            room, array, pose, sources, step_m=step_m, n_samples=n_samples, rng=rng)
        speech = talker_images.sum(axis=0)
        images[talkers] = talker_images[:, :, :n_samples]
    else:
        speech = np.zeros((array.n_mics, n_samples))
    return speech[:, :n_samples], images


def _add_noise(
    audio: np.ndarray,
    noise_cfg: dict,
    room: acoustics.Room,
    array,
    pose: acoustics.ArrayPose,
    speech: np.ndarray,
    active: np.ndarray,
    rng: np.random.Generator,
) -> None:
    """Add the diffuse and fan noise, each at its SNR to ``speech``, to ``audio``
    ``(n_mics, n_samples)`` in place."""
    n_samples = speech.shape[1]
    fs = room.fs
    for kind in ("diffuse", "fan"):
        snr = noise_cfg[f"{kind}_snr_db"]
        if snr is None:
            continue
        if kind == "diffuse":
            noise = acoustics.diffuse_noise(array, n_samples, fs, rng)
        else:
            noise = acoustics.fan_noise_image(room, array, pose, n_samples, fs, rng)
        audio += _scaled_noise(speech, noise, snr, active)


def simulate_scene(
    scenario: dict, data_dir: Path | None = None, scenario_path: str | Path | None = None
) -> Scene:
    """Draw the scene a validated scenario describes.

    Parameters
    ----------
    scenario : dict
        Output of :func:`~avtrack.io.scenario.validate_scenario`.
    data_dir : Path, optional
        The shared data folder (speech, HRIRs, recorded tracks); found automatically if omitted.
    scenario_path : Path, optional
        Where the scenario was read from (relative array files are resolved against it).
    """
    scenario = dict(scenario)
    scenario["speech"] = dict(scenario["speech"])
    rngs = _streams(scenario["seed"])
    fs = int(scenario["fs"])
    duration = float(scenario["duration"])
    n_samples = round(duration * fs)
    ids = np.array([p["id"] for p in scenario["people"]], dtype=np.int64)

    array = scene_array(scenario, scenario_path)
    camera = scene_camera(scenario)
    trajectories = scene_trajectories(scenario, rngs["motion"], data_dir)
    segments = scene_schedule(scenario, trajectories, rngs["schedule"], data_dir)
    resolved, utterances = _utterances(scenario, fs, data_dir)
    scenario["speech"]["utterances"] = resolved

    dry = _dry_speech(ids, segments, utterances, fs, duration, rngs)

    room = acoustics.Room(np.asarray(scenario["room"]["dims"]), scenario["room"]["t60"], fs)
    pose = acoustics.ArrayPose(
        np.asarray(scenario["array"]["position"]), scenario["array"]["yaw_deg"]
    )
    talkers = [k for k in range(len(ids)) if np.any(dry[k])]
    speech, images = _render_speech(
        room, array, pose, dry, trajectories, talkers, n_samples, scenario["render"]["step_m"],
        rngs["tails"],
    )
    active = np.any(dry != 0, axis=0)
    audio = speech.copy()
    _add_noise(audio, scenario["noise"], room, array, pose, speech, active, rngs["noise"])
    draw = None
    references = images[:, 0, :].copy()
    if "sensors" in scenario:
        audio, draw = _imperfect_sensors(
            audio, speech, active, scenario["sensors"], rngs["sensors"]
        )
        # the same gain and delay on each person's image (linear: the images still add up)
        for k in talkers:
            references[k] = apply_mismatch(images[k], draw)[0]
    peak = float(np.max(np.abs(audio))) if audio.size else 0.0
    if peak > 0:
        audio *= 0.9 / peak
        references = references * (0.9 / peak)

    n_video = int(np.floor(duration * scenario["fps"] + 1e-9))
    video_times = np.arange(n_video) / scenario["fps"]
    heads = np.stack([t.sample(video_times) for t in trajectories], axis=1)
    detections = simulate_detections(
        camera, heads, rngs["detections"], DetectorConfig(**scenario["detector"])
    )
    # person ids in the detector's output are 1..P in scenario order: map to scenario ids
    detections = _relabel(detections, ids)
    doa = ground_truth_doa(scenario, trajectories, segments, ids, pose)
    return Scene(
        scenario,
        audio,
        dry,
        array,
        camera,
        ids,
        trajectories,
        segments,
        video_times,
        heads,
        detections,
        doa,
        draw,
        references,
    )


#: Distance of the reference talker that sets the noise level when nobody speaks at all.
REFERENCE_DISTANCE_M = 1.5


def _scaled_noise(speech: np.ndarray, noise: np.ndarray, snr_db: float, active: np.ndarray):
    """Noise scaled to ``snr_db`` against the speech while it is active.

    In a scene without any speech the reference is a unit-RMS talker's direct path at
    :data:`REFERENCE_DISTANCE_M` (amplitude ``1/d`` per microphone, the renderer's scale), so
    the noise level does not depend on whether someone happened to talk.
    """
    if np.any(active):
        return acoustics.mix_at_snr(speech, noise, snr_db, active=active)[1]
    p_ref = speech.shape[0] / REFERENCE_DISTANCE_M**2
    p_noise = float(np.sum(np.mean(noise**2, axis=1)))
    return noise * np.sqrt(p_ref / (p_noise * 10 ** (snr_db / 10)))


def _imperfect_sensors(
    audio: np.ndarray,
    speech: np.ndarray,
    active: np.ndarray,
    spec: dict,
    rng: np.random.Generator,
) -> tuple[np.ndarray, SensorDraw]:
    """The microphone signals through imperfect sensors (:mod:`avtrack.simulate.sensors`):
    ``y_m = 10^(g_m / 20) x_m[n - delta_m] + sigma w_m``, the self-noise ``sigma w`` scaled
    against the speech image like the acoustic noise."""
    model = SensorModel(**spec)
    draw = model.draw(audio.shape[0], rng)
    out = apply_mismatch(audio, draw)
    if model.self_noise_snr_db is not None:
        w = white_noise(audio.shape[0], audio.shape[1], rng)
        out += _scaled_noise(speech, w, model.self_noise_snr_db, active)
    return out, draw


def _relabel(det: SimulatedDetections, ids: np.ndarray) -> SimulatedDetections:
    if np.array_equal(ids, np.arange(1, ids.size + 1)):
        return det
    from dataclasses import replace

    gt = det.gt
    gt = type(gt)(gt.frames, ids[gt.ids - 1], gt.boxes, gt.scores, gt.extra)
    who = np.where(det.det_person > 0, ids[np.maximum(det.det_person, 1) - 1], -1)
    return replace(det, gt=gt, det_person=who)


def ground_truth_doa(
    scenario: dict,
    trajectories: list[Trajectory],
    segments: list[SpeechSegment],
    ids: np.ndarray,
    pose,
) -> DOATable:
    """Azimuth / elevation of every present person every ``gt_hop_s`` seconds."""
    hop = scenario["gt_hop_s"]
    times = np.arange(int(np.floor(scenario["duration"] / hop + 1e-9))) * hop
    rows = []
    for pid, traj in zip(ids, trajectories, strict=True):
        here = traj.is_present(times)
        if not np.any(here):
            continue
        t = times[here]
        local = acoustics.room_to_array(pose, traj.position(t))
        az, el = acoustics.azimuth_elevation(local)
        speaking = np.zeros(t.size, dtype=bool)
        for s in segments:
            if s.speaker == pid:
                speaking |= (t >= s.start) & (t < s.end)
        frames = np.flatnonzero(here)
        rows.append((frames, t, np.full(t.size, pid), az, el, speaking))
    if not rows:
        return DOATable(*(np.zeros(0) for _ in range(7)))
    cols = [np.concatenate(c) for c in zip(*rows, strict=True)]
    order = np.lexsort((cols[2], cols[0]))
    frames, t, pid, az, el, speaking = (c[order] for c in cols)
    return DOATable(frames, t, pid, az, el, np.ones(frames.size), speaking)


def write_scene(scene: Scene, out_dir: str | Path) -> Path:
    """Write the scene directory (module docstring) atomically.

    Everything is written into a temporary sibling folder first and renamed onto ``out_dir``
    at the end, so an interrupted run never leaves a half-written scene. An existing
    ``out_dir`` is replaced only if it is empty or is itself a scene directory.
    """
    out_dir = Path(out_dir)
    if out_dir.exists():
        if not out_dir.is_dir():
            raise InputError("output exists and is not a directory", out_dir)
        if any(out_dir.iterdir()) and not (out_dir / "scene.yaml").is_file():
            raise InputError(
                "output directory is not empty and is not a scene directory; "
                "choose another -o or empty it",
                out_dir,
            )
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.", dir=out_dir.parent))
    umask = os.umask(0)
    os.umask(umask)
    tmp.chmod(0o777 & ~umask)  # mkdtemp makes it private; the scene is a normal folder
    try:
        _write_contents(scene, tmp)
        if out_dir.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.old.", dir=out_dir.parent))
            os.replace(out_dir, old / "scene")
            os.replace(tmp, out_dir)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, out_dir)
    except BaseException:
        with contextlib.suppress(OSError):
            shutil.rmtree(tmp)
        raise
    return out_dir


def _write_contents(scene: Scene, d: Path) -> None:
    (d / "gt").mkdir()
    (d / "scene.yaml").write_text(dump_scenario(scene.scenario))
    sf.write(d / "audio.wav", scene.audio.T.astype(np.float32), scene.fs, subtype="FLOAT")
    (d / "array.json").write_text(json.dumps(scene.array.to_json(), indent=2) + "\n")
    (d / "camera.json").write_text(json.dumps(scene.camera.to_json(), indent=2) + "\n")
    write_mot(d / "detections.txt", scene.detections.detections)
    np.save(d / "appearance.npy", scene.detections.appearance.astype(np.float32))
    write_mot(d / "gt" / "gt.txt", scene.detections.gt)
    write_doa_csv(d / "gt" / "doa.csv", scene.doa)
    write_rttm(
        d / "gt" / "speech.rttm",
        [RTTMSegment("audio", s.start, s.end - s.start, f"P{s.speaker}") for s in scene.segments],
    )
    if scene.references is not None:
        (d / "gt" / "voices").mkdir()
        for pid, ref in zip(scene.ids, scene.references, strict=True):
            sf.write(d / "gt" / "voices" / f"{pid}.wav", ref.astype(np.float32), scene.fs,
                     subtype="FLOAT")
    with atomic_write(d / "gt" / "positions.csv") as fh:
        fh.write("frame,time_s,id,x,y,z\n")
        for f, t in enumerate(scene.video_times, start=1):
            for k, pid in enumerate(scene.ids):
                p = scene.heads[f - 1, k]
                if np.all(np.isfinite(p)):
                    fh.write(f"{f},{t:.4f},{pid},{p[0]:.4f},{p[1]:.4f},{p[2]:.4f}\n")
