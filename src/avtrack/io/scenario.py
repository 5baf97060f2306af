"""Scenario files: the validated description of a simulated audio-visual scene.

A scenario is a YAML mapping (see ``SCENARIO_REFERENCE`` below, also printed by
``avtrack simulate --help-scenario``). :func:`load_scenario` reads one and
:func:`validate_scenario` checks every field, filling in defaults, and raises one
:class:`~avtrack.errors.InputError` per bad field naming the file and the field's path
(``people[2].motion.speed: expected a number > 0, got -1``).

The validated scenario is a plain nested ``dict`` (what ``scene.yaml`` in a scene directory
holds, so that a scene can be re-simulated from its own directory) -- the simulator reads its
fields; nothing else interprets them.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any, NoReturn

import yaml

from avtrack.errors import InputError
from avtrack.io.base import read_yaml_file

SCENARIO_REFERENCE = """\
name: my-scene              # free text
duration: 20.0              # seconds (> 0)
seed: 0                     # every random draw derives from it
fs: 16000                   # audio sample rate (Hz)
fps: 25                     # video frame rate (Hz)
gt_hop_s: 0.008             # period of the ground-truth DOA rows in gt/doa.csv
room:
  dims: [6.0, 5.0, 3.0]     # shoebox, metres
  t60: 0.4                  # seconds; 0 = free field (no reflections)
array:
  name: nao4                # nao4 | nao8 | nao12 | av163 | kemar | respeaker4 | path/to/array.json
  hrir: false               # render with the measured NAO head HRIRs (nao4 only)
  position: [3.0, 1.0, 1.2] # array centre in the room (metres)
  yaw_deg: 90.0             # direction of the array's x axis in the room (ccw from room x)
camera:                     # pinhole camera; defaults: on top of the array, looking along x
  hfov_deg: 70.0
  width: 640
  height: 480
  position: null            # null = array position + 5 cm up
  yaw_deg: null             # null = the array's yaw
  pitch_deg: 0.0
people:                     # one entry per person (head/mouth centre is the sound source)
  - id: 1                   # optional, default 1, 2, ...
    present: [[0, 20]]      # optional [start, end) intervals in the scene; default always
    motion:                 # one of:
      type: seated          #   seated: position [x, y, z], sway (m)
      position: [2.5, 3.0, 1.2]
  - motion: {type: random-walk, area: [[1, 5], [2, 4.5]], height: 1.65, speed: 0.7,
             pause_mean: 1.5}
  - motion: {type: waypoints, waypoints: [[0, 1, 3, 1.6], [10, 4, 3, 1.6]]}
  - motion: {type: azimuth-track, track: locata, column: 0, radius: 1.5, height: 0.4,
             start_s: 0.0}     # recorded LOCATA / Kinovis-MST azimuths around the array
speech:
  mode: turn-taking         # turn-taking | vad (recorded VAD of azimuth-track people)
  utterances: auto          # auto | shared | synthetic | path/to/folder of 16 kHz wavs
  mean_turn: 2.5            # seconds
  mean_pause: 0.6
  overlap_prob: 0.15
noise:
  diffuse_snr_db: 20.0      # spatially diffuse noise; null = none
  fan_snr_db: null          # stationary fan noise 10 cm behind the array centre; null = none
sensors:                    # optional; omitted = ideal, matched, noiseless microphones
  gain_mismatch_db: 0.0     # std of a per-microphone gain drawn per scene (dB, >= 0)
  delay_mismatch_samples: 0.0  # std of a per-microphone delay drawn per scene (samples, >= 0)
  self_noise_snr_db: null   # speech to uncorrelated white self-noise per microphone (dB);
                            # null = none
detector:                   # simulated head detector
  miss_rate: 0.1
  false_alarm_rate: 0.2     # mean false alarms per frame
  centre_noise: 0.05        # fraction of the box width
  size_noise: 0.05          # relative
  occlusion_threshold: 0.5  # covered fraction above which a head is not detected
  appearance_dim: 64
  appearance_noise: 0.3
render:
  step_m: 0.05              # a new room response each time a talker moves this far
"""

MOTION_TYPES = ("seated", "random-walk", "waypoints", "azimuth-track")
SPEECH_MODES = ("turn-taking", "vad")
TRACKS = ("locata", "kinovis")

DEFAULTS: dict[str, Any] = {
    "name": "scene",
    "duration": 20.0,
    "seed": 0,
    "fs": 16000,
    "fps": 25.0,
    "gt_hop_s": 0.008,
    "room": {"dims": [6.0, 5.0, 3.0], "t60": 0.4},
    "array": {"name": "nao4", "hrir": False, "position": [3.0, 1.0, 1.2], "yaw_deg": 90.0},
    "camera": {
        "hfov_deg": 70.0,
        "width": 640,
        "height": 480,
        "position": None,
        "yaw_deg": None,
        "pitch_deg": 0.0,
    },
    "speech": {
        "mode": "turn-taking",
        "utterances": "auto",
        "mean_turn": 2.5,
        "mean_pause": 0.6,
        "overlap_prob": 0.15,
    },
    "noise": {"diffuse_snr_db": 20.0, "fan_snr_db": None},
    "detector": {
        "miss_rate": 0.1,
        "false_alarm_rate": 0.2,
        "centre_noise": 0.05,
        "size_noise": 0.05,
        "occlusion_threshold": 0.5,
        "appearance_dim": 64,
        "appearance_noise": 0.3,
    },
    "render": {"step_m": 0.05},
}

#: Defaults of the optional ``sensors`` section (ideal microphones). The section is kept in the
#: validated scenario only when the file has it, so that scenes without it are written as before.
SENSOR_DEFAULTS: dict[str, Any] = {
    "gain_mismatch_db": 0.0,
    "delay_mismatch_samples": 0.0,
    "self_noise_snr_db": None,
}

MOTION_DEFAULTS: dict[str, dict[str, Any]] = {
    "seated": {"sway": 0.03},
    "random-walk": {"height": 1.65, "speed": 0.7, "pause_mean": 1.5},
    "waypoints": {},
    "azimuth-track": {"column": 0, "radius": 1.5, "height": 0.4, "start_s": 0.0},
}


class _Checker:
    """Field-by-field validation with error messages naming the field's path."""

    def __init__(self, path: str | Path | None):
        self.path = path

    def fail(self, field: str, message: str) -> NoReturn:
        raise InputError(f"{field}: {message}", self.path)

    def mapping(self, value: Any, field: str) -> dict:
        if not isinstance(value, dict):
            self.fail(field, f"expected a mapping, got {_show(value)}")
        return value

    def unknown(self, value: dict, allowed, field: str) -> None:
        extra = sorted(set(value) - set(allowed))
        if extra:
            where = f"{field}." if field else ""
            self.fail(
                f"{where}{extra[0]}",
                f"unknown field (allowed: {', '.join(sorted(allowed))})",
            )

    def number(self, value: Any, field: str, lo=None, hi=None, lo_open=False, hi_open=False):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(field, f"expected a number, got {_show(value)}")
        v = float(value)
        if not math.isfinite(v):
            self.fail(field, f"expected a finite number, got {value}")
        if lo is not None and (v < lo or (lo_open and v == lo)):
            self.fail(field, f"expected a number {'>' if lo_open else '>='} {lo}, got {value}")
        if hi is not None and (v > hi or (hi_open and v == hi)):
            self.fail(field, f"expected a number {'<' if hi_open else '<='} {hi}, got {value}")
        return v

    def integer(self, value: Any, field: str, lo=None, hi=None) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(field, f"expected an integer, got {_show(value)}")
        if lo is not None and value < lo:
            self.fail(field, f"expected an integer >= {lo}, got {value}")
        if hi is not None and value > hi:
            self.fail(field, f"expected an integer <= {hi}, got {value}")
        return int(value)

    def vector(self, value: Any, field: str, n: int = 3) -> list[float]:
        if not isinstance(value, (list, tuple)) or len(value) != n:
            self.fail(field, f"expected a list of {n} numbers, got {_show(value)}")
        return [self.number(v, f"{field}[{i}]") for i, v in enumerate(value)]

    def choice(self, value: Any, field: str, choices) -> str:
        if value not in choices:
            self.fail(field, f"expected one of {', '.join(choices)}, got {_show(value)}")
        return value

    def optional_number(self, value: Any, field: str, **kw):
        return None if value is None else self.number(value, field, **kw)


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _merge(defaults: dict, given: dict) -> dict:
    out = copy.deepcopy(defaults)
    for key, value in given.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def _check_room(ck: _Checker, room: dict) -> None:
    """Check ``room`` in place: its size and reverberation time."""
    room["dims"] = ck.vector(room["dims"], "room.dims")
    for i, d in enumerate(room["dims"]):
        if not 1.0 <= d <= 100.0:
            ck.fail(f"room.dims[{i}]", f"expected a size in [1, 100] metres, got {d}")
    room["t60"] = ck.number(room["t60"], "room.t60", lo=0, hi=3.0)


def _check_array(ck: _Checker, arr: dict, dims: list[float]) -> None:
    """Check ``array`` in place: its name, HRIR flag and pose inside the room ``dims``."""
    if not isinstance(arr["name"], str) or not arr["name"]:
        ck.fail("array.name", f"expected a built-in name or a JSON path, got {_show(arr['name'])}")
    if not isinstance(arr["hrir"], bool):
        ck.fail("array.hrir", f"expected true or false, got {_show(arr['hrir'])}")
    arr["position"] = ck.vector(arr["position"], "array.position")
    _inside(ck, arr["position"], dims, "array.position")
    arr["yaw_deg"] = ck.number(arr["yaw_deg"], "array.yaw_deg", lo=-360, hi=360)


def _check_camera(ck: _Checker, cam: dict, dims: list[float]) -> None:
    """Check ``camera`` in place: field of view, image size and pose inside the room ``dims``."""
    cam["hfov_deg"] = ck.number(cam["hfov_deg"], "camera.hfov_deg", lo=10, hi=170)
    cam["width"] = ck.integer(cam["width"], "camera.width", lo=16, hi=10000)
    cam["height"] = ck.integer(cam["height"], "camera.height", lo=16, hi=10000)
    if cam["position"] is not None:
        cam["position"] = ck.vector(cam["position"], "camera.position")
        _inside(ck, cam["position"], dims, "camera.position")
    if cam["yaw_deg"] is not None:
        cam["yaw_deg"] = ck.number(cam["yaw_deg"], "camera.yaw_deg", lo=-360, hi=360)
    cam["pitch_deg"] = ck.number(cam["pitch_deg"], "camera.pitch_deg", lo=-89, hi=89)


def _check_speech(ck: _Checker, sp: dict) -> None:
    """Check ``speech`` in place: mode, utterances and the turn-taking parameters."""
    sp["mode"] = ck.choice(sp["mode"], "speech.mode", SPEECH_MODES)
    if not isinstance(sp["utterances"], str) or not sp["utterances"]:
        ck.fail(
            "speech.utterances",
            f"expected auto, shared, synthetic or a folder, got {_show(sp['utterances'])}",
        )
    sp["mean_turn"] = ck.number(sp["mean_turn"], "speech.mean_turn", lo=0.2, hi=60)
    sp["mean_pause"] = ck.number(sp["mean_pause"], "speech.mean_pause", lo=0, hi=60)
    sp["overlap_prob"] = ck.number(sp["overlap_prob"], "speech.overlap_prob", lo=0, hi=1)


def _check_noise(ck: _Checker, nz: dict) -> None:
    """Check ``noise`` in place: the optional SNRs."""
    nz["diffuse_snr_db"] = ck.optional_number(
        nz["diffuse_snr_db"], "noise.diffuse_snr_db", lo=-30, hi=100
    )
    nz["fan_snr_db"] = ck.optional_number(nz["fan_snr_db"], "noise.fan_snr_db", lo=-30, hi=100)


def _check_sensors(ck: _Checker, raw_sensors: Any) -> dict:
    """The ``sensors`` mapping checked, with its defaults filled in."""
    ck.unknown(ck.mapping(raw_sensors, "sensors"), SENSOR_DEFAULTS, "sensors")
    sn = _merge(SENSOR_DEFAULTS, raw_sensors)
    sn["gain_mismatch_db"] = ck.number(
        sn["gain_mismatch_db"], "sensors.gain_mismatch_db", lo=0, hi=20
    )
    sn["delay_mismatch_samples"] = ck.number(
        sn["delay_mismatch_samples"], "sensors.delay_mismatch_samples", lo=0, hi=16
    )
    sn["self_noise_snr_db"] = ck.optional_number(
        sn["self_noise_snr_db"], "sensors.self_noise_snr_db", lo=-30, hi=100
    )
    return sn


def _check_detector(ck: _Checker, det: dict) -> None:
    """Check ``detector`` in place: rates, noise levels and the appearance dimension."""
    for key in ("miss_rate", "occlusion_threshold"):
        det[key] = ck.number(det[key], f"detector.{key}", lo=0, hi=1)
    for key in ("false_alarm_rate", "centre_noise", "size_noise", "appearance_noise"):
        det[key] = ck.number(det[key], f"detector.{key}", lo=0, hi=100)
    det["appearance_dim"] = ck.integer(det["appearance_dim"], "detector.appearance_dim", lo=2)


def _check_people(ck: _Checker, people_raw: Any, sc: dict) -> list[dict]:
    """The ``people`` list checked person by person (unique ids), with defaults filled in."""
    if not isinstance(people_raw, list) or not people_raw:
        ck.fail("people", f"expected a non-empty list of people, got {_show(people_raw)}")
    people = []
    seen: set[int] = set()
    for i, person in enumerate(people_raw):
        people.append(_validate_person(ck, person, i, sc))
        pid = people[-1]["id"]
        if pid in seen:
            ck.fail(f"people[{i}].id", f"duplicate id {pid}")
        seen.add(pid)
    vad = sc["speech"]["mode"] == "vad"
    if vad and not any(p["motion"]["type"] == "azimuth-track" for p in people):
        ck.fail("speech.mode", "'vad' needs at least one person with an azimuth-track motion")
    return people


def validate_scenario(raw: Any, path: str | Path | None = None) -> dict:
    """Check a scenario mapping field by field and return it with every default filled in.

    Parameters
    ----------
    raw : dict
        The parsed YAML.
    path : str or Path, optional
        The file it came from (named in errors).

    Raises
    ------
    InputError
        On the first bad field, naming it.
    """
    ck = _Checker(path)
    raw = ck.mapping(raw, "scenario")
    ck.unknown(raw, set(DEFAULTS) | {"people", "sensors"}, "")
    for key in ("room", "array", "camera", "speech", "noise", "detector", "render"):
        if key in raw:
            ck.unknown(ck.mapping(raw[key], key), DEFAULTS[key], key)
    sc = _merge(DEFAULTS, {k: v for k, v in raw.items() if k not in ("people", "sensors")})

    if not isinstance(sc["name"], str) or not sc["name"]:
        ck.fail("name", f"expected a non-empty string, got {_show(sc['name'])}")
    sc["duration"] = ck.number(sc["duration"], "duration", lo=0, lo_open=True, hi=3600)
    sc["seed"] = ck.integer(sc["seed"], "seed", lo=0)
    sc["fs"] = ck.integer(sc["fs"], "fs", lo=8000, hi=96000)
    sc["fps"] = ck.number(sc["fps"], "fps", lo=1, hi=240)
    sc["gt_hop_s"] = ck.number(sc["gt_hop_s"], "gt_hop_s", lo=0.001, hi=1.0)

    _check_room(ck, sc["room"])
    _check_array(ck, sc["array"], sc["room"]["dims"])
    _check_camera(ck, sc["camera"], sc["room"]["dims"])
    _check_speech(ck, sc["speech"])
    _check_noise(ck, sc["noise"])
    if "sensors" in raw:
        sc["sensors"] = _check_sensors(ck, raw["sensors"])
    _check_detector(ck, sc["detector"])
    sc["render"]["step_m"] = ck.number(sc["render"]["step_m"], "render.step_m", lo=0.005, hi=1.0)

    sc["people"] = _check_people(ck, raw.get("people"), sc)
    return sc


def _inside(ck: _Checker, pos: list[float], dims: list[float], field: str) -> None:
    for i, (p, d) in enumerate(zip(pos, dims, strict=True)):
        if not 0.0 < p < d:
            ck.fail(f"{field}[{i}]", f"{p} is outside the room (0, {d})")


def _validate_person(ck: _Checker, person: Any, i: int, sc: dict) -> dict:
    field = f"people[{i}]"
    person = ck.mapping(person, field)
    ck.unknown(person, {"id", "motion", "present"}, field)
    out: dict[str, Any] = {"id": ck.integer(person.get("id", i + 1), f"{field}.id", lo=1)}
    present = person.get("present")
    if present is not None:
        if not isinstance(present, list) or not present:
            ck.fail(f"{field}.present", f"expected a list of [start, end], got {_show(present)}")
        ivs = []
        for j, iv in enumerate(present):
            s, e = ck.vector(iv, f"{field}.present[{j}]", n=2)
            if e <= s:
                ck.fail(f"{field}.present[{j}]", f"expected end > start, got [{s}, {e}]")
            ivs.append([s, e])
        out["present"] = ivs
    motion = ck.mapping(person.get("motion"), f"{field}.motion")
    mtype = ck.choice(motion.get("type"), f"{field}.motion.type", MOTION_TYPES)
    allowed = {"type", *MOTION_DEFAULTS[mtype]} | {
        "seated": {"position"},
        "random-walk": {"area"},
        "waypoints": {"waypoints"},
        "azimuth-track": {"track"},
    }[mtype]
    ck.unknown(motion, allowed, f"{field}.motion")
    m = {**MOTION_DEFAULTS[mtype], **motion}
    f = f"{field}.motion"
    dims = sc["room"]["dims"]
    if mtype == "seated":
        if "position" not in motion:
            ck.fail(f"{f}.position", "required for a seated person")
        m["position"] = ck.vector(m["position"], f"{f}.position")
        _inside(ck, m["position"], dims, f"{f}.position")
        m["sway"] = ck.number(m["sway"], f"{f}.sway", lo=0, hi=0.5)
    elif mtype == "random-walk":
        area = m.get("area")
        if not isinstance(area, list) or len(area) != 2:
            ck.fail(f"{f}.area", f"expected [[x_min, x_max], [y_min, y_max]], got {_show(area)}")
        m["area"] = [ck.vector(a, f"{f}.area[{k}]", n=2) for k, a in enumerate(area)]
        for k, (lo, hi) in enumerate(m["area"]):
            if not 0 < lo < hi < dims[k]:
                ck.fail(f"{f}.area[{k}]", f"expected 0 < min < max < {dims[k]}, got [{lo}, {hi}]")
        m["height"] = ck.number(m["height"], f"{f}.height", lo=0.1, hi=dims[2], hi_open=True)
        m["speed"] = ck.number(m["speed"], f"{f}.speed", lo=0, lo_open=True, hi=5)
        m["pause_mean"] = ck.number(m["pause_mean"], f"{f}.pause_mean", lo=0, hi=60)
    elif mtype == "waypoints":
        wps = m.get("waypoints")
        if not isinstance(wps, list) or not wps:
            ck.fail(f"{f}.waypoints", f"expected a list of [t, x, y, z], got {_show(wps)}")
        rows = [ck.vector(w, f"{f}.waypoints[{k}]", n=4) for k, w in enumerate(wps)]
        for k, row in enumerate(rows):
            _inside(ck, row[1:], dims, f"{f}.waypoints[{k}]")
            if k and row[0] <= rows[k - 1][0]:
                ck.fail(f"{f}.waypoints[{k}]", "times must be strictly increasing")
        m["waypoints"] = rows
    else:
        m["track"] = ck.choice(m.get("track"), f"{f}.track", TRACKS)
        m["column"] = ck.integer(m["column"], f"{f}.column", lo=0, hi=1)
        m["radius"] = ck.number(m["radius"], f"{f}.radius", lo=0.3, hi=20)
        m["height"] = ck.number(m["height"], f"{f}.height", lo=-2, hi=3)
        m["start_s"] = ck.number(m["start_s"], f"{f}.start_s", lo=0)
    out["motion"] = m
    return out


def load_scenario(path: str | Path) -> dict:
    """Read and validate a scenario YAML file (see ``SCENARIO_REFERENCE``)."""
    path = Path(path)
    raw = read_yaml_file(path, "scenario")
    if raw is None:
        raise InputError("empty scenario file", path)
    return validate_scenario(raw, path)


def dump_scenario(scenario: dict) -> str:
    """The scenario as YAML text (block style, keys in definition order)."""
    return yaml.safe_dump(scenario, sort_keys=False, default_flow_style=None, width=99)
