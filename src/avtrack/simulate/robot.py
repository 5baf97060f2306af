r"""Closed-loop NAO-MPVS-like sequences: people, a moving stereo head, tracking and servoing.

Each frame (10 FPS, as the thesis's system):

1. the people's head centres (room frame, :mod:`avtrack.simulate.trajectory`) are expressed
   in the current left-camera frame through the head's *true* kinematics,
   :math:`X = G(q_t)X_h` (:meth:`RobotHead.scene_transform`, eq. 3.48);
2. both cameras detect the faces (:func:`avtrack.simulate.detections.simulate_detections`:
   misses, false alarms, occlusion, box noise), and :func:`stereo_faces` pairs and
   triangulates them;
3. the tracker (:class:`RobotTracker`) steps with the head motion of the last frame
   (joint angles and commanded velocities), the servo (:class:`VisualServo`) picks a person
   by its policy and commands joint velocities (eq. 3.47);
4. the head executes the command (with a relative speed error ``motor_noise``) within its
   speed and range limits, which changes what the cameras see next.

The tracker and the servo use the head model of the *estimated* calibration (from simulated
chessboard views, :func:`simulate_chessboard_extrinsics` + :func:`calibrate_head`) unless
``RobotSimConfig.calibration`` is ``"true"``.

Scenarios (:data:`ROBOT_SCENARIOS`): ``followN`` -- N people walking around the room, the head
follows the first tracked one; ``jumpN`` -- N people standing and shifting around spread
azimuths, the head changes person every 3 s (thesis NAO-MPVS-N{F,J}). The ground truth is
the left image: every face whose whole box lies inside it (the face detector does not fire on
cut faces, see ``StereoMatchConfig.border``); the tracker's output is evaluated likewise, on
the tracks whose whole box lies inside the image.

Table 3.3's protocol (recorded sequences evaluated with and without :math:`C_{tn}`) is
:func:`track_recording` on the :class:`RobotRecording` of a closed-loop run: the same
observations and head motion, tracked again offline.
"""

from __future__ import annotations

import csv
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from avtrack.io.base import atomic_write
from avtrack.io.camera import PinholeCamera
from avtrack.io.mot import MOTData, write_mot
from avtrack.robot.base import FaceObservations, HeadMotion, TrackedPeople
from avtrack.robot.calibration import calibrate_head
from avtrack.robot.head import HeadCalibration, RobotHead, nao_head, twist_exp
from avtrack.robot.servo import (
    JumpPolicy,
    ServoCommand,
    ServoPolicy,
    VisualServo,
    make_policy,
)
from avtrack.robot.stereo import StereoMatchConfig, StereoRig, stereo_faces
from avtrack.robot.tracker import RobotFrameTracks, RobotTracker, RobotTrackerConfig
from avtrack.simulate.detections import DetectorConfig, simulate_detections
from avtrack.simulate.trajectory import Trajectory, random_walk

#: Rotation room → home left-camera frame (camera at the room origin, looking along +x).
_HOME_R = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])


# --------------------------------------------------------------------------- scenarios
@dataclass(frozen=True)
class RobotScenario:
    """A named closed-loop sequence.

    Attributes
    ----------
    name : str
    policy : {"follow", "jump"}
    n_people : int
    duration_s : float
    description : str
    """

    name: str
    policy: str
    n_people: int
    duration_s: float = 40.0
    description: str = ""


def _walkers(rng: np.random.Generator, n: int, duration: float) -> list[Trajectory]:
    """``n`` people walking around the room in front of the robot (follow scenarios)."""
    starts = [(2.0, 0.0), (2.6, 0.8), (2.4, -0.9)]
    areas = [[[1.6, 2.8], [-1.6, 1.6]], [[1.8, 3.2], [-1.2, 1.8]], [[1.8, 3.2], [-1.8, 1.2]]]
    speeds = [0.5, 0.4, 0.4]
    return [
        random_walk(
            rng,
            duration,
            np.array(areas[k]),
            height=rng.uniform(1.5, 1.75),
            speed=speeds[k],
            pause_mean=2.0,
            start=np.array(starts[k]),
        )
        for k in range(n)
    ]


#: Jump scenarios: half-size of the square each person shifts in (m), walking speed (m/s),
#: mean pause (s).
_JUMP_AREA, _JUMP_SPEED, _JUMP_PAUSE = 0.35, 0.35, 2.5


def _standing(rng: np.random.Generator, n: int, duration: float) -> list[Trajectory]:
    """``n`` people standing at spread azimuths and shifting around (jump scenarios)."""
    azimuths = {1: [5.0], 2: [24.0, -24.0], 3: [34.0, 0.0, -34.0]}[n]
    out = []
    for az in azimuths:
        r = rng.uniform(1.9, 2.6)
        a = math.radians(az)
        centre = np.array([r * math.cos(a), r * math.sin(a)])
        area = np.column_stack([centre - _JUMP_AREA, centre + _JUMP_AREA])
        start = centre * (1.0 - 0.3 * (abs(az) > 20))  # the outer people start a bit inward
        out.append(
            random_walk(
                rng,
                duration,
                area,
                height=rng.uniform(1.5, 1.75),
                speed=_JUMP_SPEED,
                pause_mean=_JUMP_PAUSE,
                start=start,
            )
        )
    return out


_BUILDERS: dict[str, Callable[[np.random.Generator, int, float], list[Trajectory]]] = {
    "follow": _walkers,
    "jump": _standing,
}

#: Built-in scenarios by name.
ROBOT_SCENARIOS: dict[str, RobotScenario] = {
    f"{policy}{n}": RobotScenario(
        f"{policy}{n}",
        policy,
        n,
        description=(
            f"{n} {'person' if n == 1 else 'people'} "
            + (
                "walking around; the head follows the first tracked person"
                if policy == "follow"
                else "standing at spread azimuths; the head changes person every 3 s"
            )
        ),
    )
    for policy in ("follow", "jump")
    for n in (1, 2, 3)
}


def scenario_people(
    scenario: RobotScenario, rng: np.random.Generator, duration_s: float | None = None
) -> list[Trajectory]:
    """The people's trajectories (room frame: robot at the origin facing +x, z up)."""
    duration = scenario.duration_s if duration_s is None else duration_s
    return _BUILDERS[scenario.policy](rng, scenario.n_people, duration)


# --------------------------------------------------------------------------- configuration
def _default_detector() -> DetectorConfig:
    return DetectorConfig(
        miss_rate=0.1, false_alarm_rate=0.3, centre_noise=0.03, size_noise=0.05, appearance_dim=1
    )


@dataclass(frozen=True)
class RobotSimConfig:
    """Parameters of :func:`simulate_robot`.

    Attributes
    ----------
    fps : float
        Frame rate (the thesis: 10 FPS).
    baseline : float
        Stereo baseline, metres.
    camera_height : float
        Height of the home left camera above the floor, metres.
    detector : DetectorConfig
        Each camera's face detector (its appearance fields are not used, see
        ``appearance_dim``).
    appearance_dim : int
        Length of the appearance descriptors. Each person has a fixed unit signature; a
        detection's descriptor is ``normalise(a_p + appearance_noise · n / sqrt(D))`` and a
        false alarm's is random, as in ``simulate_detections`` (whose signatures would be
        redrawn at each per-frame call).
    appearance_noise : float
        See ``appearance_dim``; large values model illumination and pose changes.
    stereo : StereoMatchConfig
    tracker : RobotTrackerConfig
    gain : float
        γ of eq. 3.47.
    max_speed : (float, float)
        Largest commanded pan and tilt speeds, rad/s.
    servo_start_s : float
        The head holds still this long at the start (the robot looks at the scene before
        choosing a person), so that the people in view are tracked first.
    jump_period_s : float
        Switch period of the "jump" policy.
    motor_noise : float
        Relative standard deviation of the executed joint velocity around the command.
    blur_speed : float or None
        Motion blur: while the head turns at ``ω`` rad/s, a face is detected with probability
        ``(1 - miss_rate) · exp(-ω / blur_speed)`` (None: no blur).
    calibration : {"estimated", "true"}
        Head model used by the tracker and the servo.
    chessboard_views : int
        Views per joint for the estimated calibration.
    chessboard_noise : (float, float)
        Extrinsic noise of each view: rotation (degrees) and translation (metres).
    """

    fps: float = 10.0
    baseline: float = 0.1
    camera_height: float = 1.2
    detector: DetectorConfig = field(default_factory=_default_detector)
    appearance_dim: int = 32
    appearance_noise: float = 1.0
    stereo: StereoMatchConfig = field(default_factory=StereoMatchConfig)
    tracker: RobotTrackerConfig = field(default_factory=RobotTrackerConfig)
    gain: float = 0.4
    max_speed: tuple[float, float] = (1.5, 1.0)
    servo_start_s: float = 1.0
    jump_period_s: float = 3.0
    motor_noise: float = 0.05
    blur_speed: float | None = None
    calibration: str = "estimated"
    chessboard_views: int = 40
    chessboard_noise: tuple[float, float] = (0.05, 0.0005)

    def __post_init__(self) -> None:
        if not self.servo_start_s >= 0:
            raise ValueError(
                f"RobotSimConfig.servo_start_s must be >= 0, got {self.servo_start_s!r}"
            )
        for name in ("fps", "baseline", "camera_height", "jump_period_s"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise ValueError(f"RobotSimConfig.{name} must be a positive number, got {v!r}")
        if not 0 < self.gain <= 1:
            raise ValueError(f"RobotSimConfig.gain must be in (0, 1], got {self.gain!r}")
        for name in ("motor_noise", "appearance_noise"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise ValueError(f"RobotSimConfig.{name} must be >= 0, got {v!r}")
        if self.blur_speed is not None and not (
            isinstance(self.blur_speed, int | float) and self.blur_speed > 0
        ):
            raise ValueError(
                f"RobotSimConfig.blur_speed must be > 0 or None, got {self.blur_speed!r}"
            )
        if self.calibration not in ("estimated", "true"):
            raise ValueError(
                f"RobotSimConfig.calibration must be 'estimated' or 'true', got "
                f"{self.calibration!r}"
            )
        for name in ("appearance_dim", "chessboard_views"):
            v = getattr(self, name)
            if not (isinstance(v, int) and v >= (3 if name == "chessboard_views" else 1)):
                raise ValueError(
                    f"RobotSimConfig.{name} must be an integer >= "
                    f"{3 if name == 'chessboard_views' else 1}, got {v!r}"
                )
        for type_, name in (
            (DetectorConfig, "detector"),
            (StereoMatchConfig, "stereo"),
            (RobotTrackerConfig, "tracker"),
        ):
            if not isinstance(getattr(self, name), type_):
                raise TypeError(f"RobotSimConfig.{name} must be a {type_.__name__}")


# --------------------------------------------------------------------------- calibration
def simulate_chessboard_extrinsics(
    calibration: HeadCalibration,
    joint: str,
    angles: np.ndarray,
    rng: np.random.Generator,
    rotation_noise_deg: float = 0.05,
    translation_noise_m: float = 0.0005,
    board_position: tuple[float, float, float] = (0.05, 0.02, 0.7),
) -> np.ndarray:
    r"""Board-to-camera extrinsics of a static chessboard seen while one joint turns.

    :math:`E_i = \Delta_i\, e^{\theta_i\hat\xi_k} E_h` with :math:`E_h` the board facing the
    home camera at ``board_position`` and :math:`\Delta_i` the estimation error of one view:
    a rotation about the board centre with angle :math:`\mathcal{N}(0, \sigma_r^2)` per axis and
    a translation :math:`\mathcal{N}(0, \sigma_t^2 I_3)`.

    Parameters
    ----------
    calibration : HeadCalibration
        The true twists.
    joint : {"pan", "tilt"}
    angles : ndarray (K,)
        Joint angles of the views, radians (the other joint at 0).
    rng : numpy.random.Generator
    rotation_noise_deg, translation_noise_m : float
        :math:`\sigma_r` (degrees) and :math:`\sigma_t` (metres).

    Returns
    -------
    ndarray (K, 4, 4)
    """
    if joint not in ("pan", "tilt"):
        raise ValueError(f"joint must be 'pan' or 'tilt', got {joint!r}")
    if not (rotation_noise_deg >= 0 and translation_noise_m >= 0):
        raise ValueError("rotation_noise_deg and translation_noise_m must be >= 0")
    a = np.asarray(angles, dtype=float).reshape(-1)
    omega, u = (
        (calibration.omega1, calibration.u1)
        if joint == "pan"
        else (calibration.omega2, calibration.u2)
    )
    board = np.eye(4)
    board[:3, 3] = board_position
    e = twist_exp(omega, u, a) @ board  # E_i = e^{θ_i ξ̂} E_h, eq. 3.48
    k = a.shape[0]
    rot_noise = rng.normal(0.0, math.radians(rotation_noise_deg), (k, 3))
    out = e.copy()
    for i in range(k):
        theta = float(np.linalg.norm(rot_noise[i]))
        axis = rot_noise[i] / theta if theta > 0 else np.array([1.0, 0, 0])
        r = twist_exp(axis, np.zeros(3), theta)[:3, :3]
        out[i, :3, :3] = r @ e[i, :3, :3]  # rotation about the board centre
    out[:, :3, 3] += rng.normal(0.0, translation_noise_m, (k, 3))
    return out


def estimate_calibration(
    calibration: HeadCalibration,
    rng: np.random.Generator,
    views: int = 40,
    rotation_noise_deg: float = 0.05,
    translation_noise_m: float = 0.0005,
    all_pairs: bool = True,
) -> HeadCalibration:
    """Simulated calibration session: ``views`` chessboard views per joint (pan over ±30°,
    tilt over −25°…+30°) with noisy extrinsics, then :func:`calibrate_head` with the middle
    view as the reference (``all_pairs=False``, the thesis's cost) or over every pair of
    views."""
    pan = np.radians(np.linspace(-30.0, 30.0, views))
    tilt = np.radians(np.linspace(-25.0, 30.0, views))
    ref = views // 2
    pan[ref] = tilt[ref] = 0.0  # the reference view at home
    e_pan = simulate_chessboard_extrinsics(
        calibration, "pan", pan, rng, rotation_noise_deg, translation_noise_m
    )
    e_tilt = simulate_chessboard_extrinsics(
        calibration, "tilt", tilt, rng, rotation_noise_deg, translation_noise_m
    )
    return calibrate_head(pan, e_pan, tilt, e_tilt, reference=None if all_pairs else ref)


# --------------------------------------------------------------------------- results
@dataclass(frozen=True)
class RobotRecording:
    """What the robot recorded in a closed-loop run (enough to track it again offline).

    Attributes
    ----------
    scenario : str
    seed : int
    fps : float
    faces : tuple of FaceObservations
        The 3-D observations of each frame (T).
    angles : ndarray (T, 2)
        Joint angles at each frame, radians.
    commands : ndarray (T, 2)
        Joint velocities commanded after each frame, rad/s.
    gt : MOTData
        Left-image ground truth (MOTChallenge; class 1 and visibility in ``extra``).
    true_positions : ndarray (T, P, 3)
        Each person's head centre in the left-camera frame at each frame, NaN when absent.
    head : RobotHead
        The head model the robot used (estimated calibration).
    """

    scenario: str
    seed: int
    fps: float
    faces: tuple[FaceObservations, ...]
    angles: np.ndarray
    commands: np.ndarray
    gt: MOTData
    true_positions: np.ndarray
    head: RobotHead

    @property
    def n_frames(self) -> int:
        return len(self.faces)


@dataclass(frozen=True)
class ServoLog:
    """Servo decisions of a run.

    Attributes
    ----------
    frames : ndarray (T,) int
        1-based frame numbers.
    target_ids : ndarray (T,) int
        Pursued track id, -1 for none.
    distance_px : ndarray (T,)
        Distance from the left image centre to the pursued person as tracked (projection of
        its 3-D estimate), pixels; NaN without a target (the thesis's Fig. 3.8 measure).
    true_distance_px : ndarray (T,)
        The same for the true face of the person the target track follows (the true head
        within 0.5 m of the estimate), NaN when there is none.
    """

    frames: np.ndarray
    target_ids: np.ndarray
    distance_px: np.ndarray
    true_distance_px: np.ndarray


@dataclass(frozen=True)
class RobotSimResult:
    """Output of :func:`simulate_robot`.

    Attributes
    ----------
    tracks : MOTData
        Tracker output in the left image (MOTChallenge results; conf = visibility).
    gt : MOTData
        Left-image ground truth.
    servo : ServoLog
    recording : RobotRecording
    step_times : ndarray (T,)
        Seconds spent in the tracker step plus the servo command of each frame.
    compensation : bool
        Whether the tracker used the control term.
    """

    tracks: MOTData
    gt: MOTData
    servo: ServoLog
    recording: RobotRecording
    step_times: np.ndarray
    compensation: bool


# --------------------------------------------------------------------------- simulation
def _unit(x: np.ndarray) -> np.ndarray:
    return x / np.linalg.norm(x, axis=-1, keepdims=True)


def _appearance(
    det_person: np.ndarray, signatures: np.ndarray, noise: float, rng: np.random.Generator
) -> np.ndarray:
    """``(R, D)`` descriptors: ``normalise(a_p + noise · n / sqrt(D))`` for detections of
    person ``p`` (1-based), random unit vectors for false alarms (-1). The draws depend only
    on the number of people and of rows, not on who is visible."""
    n_p, dim = signatures.shape
    e = rng.standard_normal((n_p, dim))  # one draw per person, whether seen or not
    true = det_person > 0
    out = np.empty((det_person.shape[0], dim))
    out[~true] = _unit(rng.standard_normal((int((~true).sum()), dim)))  # false alarms
    p = det_person[true] - 1
    out[true] = _unit(signatures[p] + noise * e[p] / math.sqrt(dim))
    return out


def _people_positions(people: list[Trajectory], times: np.ndarray, height: float) -> np.ndarray:
    """``(T, P, 3)`` head centres in the home left-camera frame, NaN when absent."""
    out = np.full((times.shape[0], len(people), 3), np.nan)
    origin = np.array([0.0, 0.0, height])
    for p, traj in enumerate(people):
        pos = traj.position(times)
        pos[~traj.is_present(times)] = np.nan
        out[:, p] = (pos - origin) @ _HOME_R.T  # X_h = R (X_room - C)
    return out


def _nearest_person(position: np.ndarray, truth: np.ndarray, radius: float = 0.5) -> int:
    """Index of the true head within ``radius`` metres of ``position``, or -1."""
    d = np.linalg.norm(truth - position, axis=1)
    d = np.where(np.isfinite(d), d, np.inf)
    k = int(np.argmin(d)) if d.size else -1
    return k if k >= 0 and d[k] <= radius else -1


def resolve_scenario(name: str) -> RobotScenario:
    """A built-in scenario by name (ValueError listing the names otherwise)."""
    if name not in ROBOT_SCENARIOS:
        raise ValueError(
            f"unknown robot scenario {name!r}; built-in: {', '.join(ROBOT_SCENARIOS)}"
        )
    return ROBOT_SCENARIOS[name]


def _check_run_arguments(
    scenario: str | RobotScenario, seed: int, duration_s: float | None
) -> tuple[RobotScenario, float]:
    """The scenario and the duration in seconds of a run, after checking the arguments."""
    scen = resolve_scenario(scenario) if isinstance(scenario, str) else scenario
    if not isinstance(scen, RobotScenario):
        raise TypeError(
            f"scenario must be a name or a RobotScenario, got {type(scenario).__name__}"
        )
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    duration = scen.duration_s if duration_s is None else float(duration_s)
    if not (math.isfinite(duration) and duration > 0):
        raise ValueError(f"duration_s must be a positive number, got {duration_s!r}")
    return scen, duration


def _tracker_config(tracker_cfg: RobotTrackerConfig, compensation: bool) -> RobotTrackerConfig:
    """The tracker's configuration with or without the control term :math:`C_{tn}`."""
    if not compensation:
        return replace(tracker_cfg, control="none")
    if tracker_cfg.control == "none":
        return replace(tracker_cfg, control="jacobian")
    return tracker_cfg


def _heads(cfg: RobotSimConfig, rng_cal: np.random.Generator) -> tuple[RobotHead, RobotHead]:
    """The true head and the tracker's model of it (its calibration estimated or exact)."""
    true_head = nao_head(baseline=cfg.baseline, max_speed=cfg.max_speed)
    model_head = true_head
    if cfg.calibration == "estimated":
        cal = estimate_calibration(
            true_head.calibration, rng_cal, cfg.chessboard_views, *cfg.chessboard_noise
        )
        model_head = replace(true_head, calibration=cal)
    return true_head, model_head


def _servo(head: RobotHead, scen: RobotScenario, cfg: RobotSimConfig) -> VisualServo:
    """The visual servo of ``head`` with the scenario's target-choice policy."""
    policy: ServoPolicy = (
        JumpPolicy(cfg.jump_period_s) if scen.policy == "jump" else make_policy(scen.policy)
    )
    return VisualServo(head, policy, cfg.gain, cfg.fps)


def _blurred_detector(cfg: RobotSimConfig, speed: float) -> DetectorConfig:
    """The detector with more misses while the head turns at ``speed`` rad/s (motion blur)."""
    detector = cfg.detector
    if cfg.blur_speed is not None and speed > 0:  # motion blur: more misses
        hit = (1 - detector.miss_rate) * math.exp(-speed / cfg.blur_speed)
        detector = replace(detector, miss_rate=1.0 - hit)
    return detector


def _observe_faces(
    cfg: RobotSimConfig,
    rig: StereoRig,
    cameras: tuple[PinholeCamera, PinholeCamera],
    canon: np.ndarray,
    speed: float,
    rngs: tuple[np.random.Generator, np.random.Generator, np.random.Generator],
    signatures: np.ndarray,
) -> tuple[FaceObservations, MOTData]:
    """One frame's stereo face observations, and the left camera's true boxes.

    ``canon`` ``(1, P, 3)``: the heads in the canonical frame; ``rngs``: the left and right
    detectors' and the appearance generators; ``signatures`` ``(P, D)``: the persons' looks.
    """
    rng_left, rng_right, rng_app = rngs
    detector = _blurred_detector(cfg, speed)
    left = simulate_detections(cameras[0], canon, rng_left, detector)
    right = simulate_detections(cameras[1], canon, rng_right, detector)
    app_l = _appearance(left.det_person, signatures, cfg.appearance_noise, rng_app)
    app_r = _appearance(right.det_person, signatures, cfg.appearance_noise, rng_app)
    faces = stereo_faces(
        rig, left.detections.boxes, right.detections.boxes, app_l, app_r, cfg.stereo
    )
    return faces, left.gt


def _servo_command(
    servo: VisualServo, start_s: float, time_s: float, people: TrackedPeople, q: np.ndarray
) -> ServoCommand:
    """The servo's command at ``time_s``: none (target -1, zero velocity) before ``start_s``."""
    if time_s < start_s - 1e-9:
        return ServoCommand(-1, np.zeros(2))
    return servo.command(time_s, people, q)


def _target_distances(
    rig: StereoRig, people: TrackedPeople, target_id: int, x_cam: np.ndarray
) -> tuple[float, float]:
    """Image distances of the servo's target from the image centre: estimated and true.

    The true distance is that of the true head nearest the estimate (NaN if none is near).
    """
    k = int(np.flatnonzero(people.ids == target_id)[0])
    est = people.positions[k]
    uv = rig.project(est[None])[0]
    dist = float(np.linalg.norm(uv - rig.centre))
    true_dist = np.nan
    p = _nearest_person(est, x_cam)
    if p >= 0:
        uv_true = rig.project(x_cam[p][None])[0]
        true_dist = float(np.linalg.norm(uv_true - rig.centre))
    return dist, true_dist


def simulate_robot(
    scenario: str | RobotScenario,
    seed: int = 0,
    compensation: bool = True,
    duration_s: float | None = None,
    config: RobotSimConfig | None = None,
) -> RobotSimResult:
    """Run one closed-loop sequence: simulated people and cameras, tracker, servo, head.

    Parameters
    ----------
    scenario : str or RobotScenario
        A name of :data:`ROBOT_SCENARIOS` or a scenario.
    seed : int
        Seeds every random stream (people, detections, appearance, motors, calibration); the
        people and the detector noise do not depend on ``compensation``.
    compensation : bool
        Whether the tracker uses the control term :math:`C_{tn}` (False: ``control="none"``);
        the servo then acts on the uncompensated tracks.
    duration_s : float, optional
        Overrides the scenario's duration.
    config : RobotSimConfig, optional

    Returns
    -------
    RobotSimResult
    """
    scen, duration = _check_run_arguments(scenario, seed, duration_s)
    cfg = config or RobotSimConfig()
    tracker_cfg = _tracker_config(cfg.tracker, compensation)

    streams = [np.random.default_rng(s) for s in np.random.SeedSequence(int(seed)).spawn(6)]
    rng_people, rng_left, rng_right, rng_app, rng_motor, rng_cal = streams
    true_head, model_head = _heads(cfg, rng_cal)
    rig = true_head.rig
    left_cam, right_cam = rig.pinhole_cameras()

    dt = 1.0 / cfg.fps
    n_frames = max(round(duration * cfg.fps), 1)
    times = np.arange(n_frames) * dt
    people = scenario_people(scen, rng_people, duration)
    home = _people_positions(people, times, cfg.camera_height)  # (T, P, 3)
    n_p = home.shape[1]
    signatures = _unit(rng_app.standard_normal((n_p, cfg.appearance_dim)))

    tracker = RobotTracker(model_head, tracker_cfg, cfg.fps)
    servo = _servo(model_head, scen, cfg)

    q = np.zeros(2)
    speed = 0.0  # angular speed of the head during the last frame interval, rad/s
    motion: HeadMotion | None = None
    faces_log: list[FaceObservations] = []
    angles = np.zeros((n_frames, 2))
    commands = np.zeros((n_frames, 2))
    truth = np.full((n_frames, n_p, 3), np.nan)
    gt_rows: list[MOTData] = []
    out_frames: list[RobotFrameTracks] = []
    targets = np.full(n_frames, -1, dtype=np.int64)
    dist = np.full(n_frames, np.nan)
    true_dist = np.full(n_frames, np.nan)
    step_times = np.zeros(n_frames)
    for t in range(n_frames):
        g = true_head.scene_transform(q)  # G(q_t), eq. 3.48
        x_cam = home[t] @ g[:3, :3].T + g[:3, 3]  # (P, 3), NaN rows stay NaN
        truth[t], angles[t] = x_cam, q
        canon = rig.to_canonical(x_cam)[None]
        faces, left_gt = _observe_faces(
            cfg, rig, (left_cam, right_cam), canon, speed, (rng_left, rng_right, rng_app),
            signatures,
        )
        faces_log.append(faces)
        gt_rows.append(
            _frame_gt(left_gt, x_cam, rig, cfg.detector.head_size, t + 1, cfg.stereo.border)
        )

        t0 = time.perf_counter()
        out = tracker.step(faces, motion)
        people_now = tracker.people()
        cmd = _servo_command(servo, cfg.servo_start_s, t * dt, people_now, q)
        step_times[t] = time.perf_counter() - t0
        out_frames.append(out)

        commands[t], targets[t] = cmd.velocity, cmd.target_id
        if cmd.target_id >= 0:
            dist[t], true_dist[t] = _target_distances(rig, people_now, cmd.target_id, x_cam)
        motion = HeadMotion(q, cmd.velocity)
        executed = cmd.velocity * (1.0 + cfg.motor_noise * rng_motor.standard_normal(2))
        q_next = true_head.clip_angles(q + executed * dt)
        speed = float(np.linalg.norm(q_next - q)) / dt
        q = q_next

    gt = _concat_mot(gt_rows, extra_cols=2)
    tracks = _tracks_to_mot(out_frames, rig, cfg.stereo.border)
    recording = RobotRecording(
        scen.name, int(seed), cfg.fps, tuple(faces_log), angles, commands, gt, truth, model_head
    )
    servo_log = ServoLog(np.arange(1, n_frames + 1), targets, dist, true_dist)
    return RobotSimResult(tracks, gt, servo_log, recording, step_times, bool(compensation))


def _fully_inside(centres: np.ndarray, sizes: np.ndarray, rig, margin: float) -> np.ndarray:
    """``(K,)`` whether the boxes of centres ``(K, 2)`` and sizes ``(K, 2)`` lie inside the
    image with ``margin`` pixels to spare (False for NaN)."""
    lo = centres - 0.5 * sizes
    hi = centres + 0.5 * sizes
    with np.errstate(invalid="ignore"):
        return (
            (lo[:, 0] >= margin)
            & (lo[:, 1] >= margin)
            & (hi[:, 0] <= rig.width - margin)
            & (hi[:, 1] <= rig.height - margin)
        )


def _frame_gt(
    gt: MOTData, x_cam: np.ndarray, rig, head_size, frame: int, margin: float
) -> MOTData:
    """One frame of left-image ground truth: the faces whose whole box is in the image."""
    if not len(gt):
        return gt
    x = x_cam[gt.ids - 1]
    uv = rig.project(x)
    size = np.column_stack([rig.fx * head_size[0] / x[:, 2], rig.fy * head_size[1] / x[:, 2]])
    keep = _fully_inside(uv, size, rig, margin)
    return MOTData(
        np.full(int(keep.sum()), frame),
        gt.ids[keep],
        gt.boxes[keep],
        gt.scores[keep],
        gt.extra[keep],
    )


def _concat_mot(parts: list[MOTData], extra_cols: int = 0) -> MOTData:
    parts = [p for p in parts if len(p)]
    if not parts:
        return MOTData(
            np.zeros(0), np.zeros(0), np.zeros((0, 4)), np.zeros(0), np.zeros((0, extra_cols))
        )
    return MOTData(
        np.concatenate([p.frames for p in parts]),
        np.concatenate([p.ids for p in parts]),
        np.concatenate([p.boxes for p in parts]),
        np.concatenate([p.scores for p in parts]),
        np.concatenate([p.extra for p in parts]),
    )


def _tracks_to_mot(frames: list[RobotFrameTracks], rig, margin: float) -> MOTData:
    """Tracker output in MOTChallenge form: the tracks whose whole box is in the image."""
    rows = []
    for t, out in enumerate(frames):
        ok = _fully_inside(rig.project(out.positions), out.sizes, rig, margin)
        k = int(ok.sum())
        rows.append(MOTData(np.full(k, t + 1), out.ids[ok], out.boxes[ok], out.p_visible[ok]))
    return _concat_mot(rows)


def track_recording(
    recording: RobotRecording,
    config: RobotTrackerConfig | None = None,
    head: RobotHead | None = None,
    border: float = 1.0,
) -> tuple[MOTData, np.ndarray]:
    """Track a recorded sequence again, offline (the protocol of thesis Table 3.3).

    Parameters
    ----------
    recording : RobotRecording
    config : RobotTrackerConfig, optional
        E.g. ``RobotTrackerConfig(control="none")`` for the "w/o" rows.
    head : RobotHead, optional
        Defaults to the head model of the recording.
    border : float
        Tracks are output when their whole box keeps this many pixels from the image border
        (as the ground truth, see :func:`simulate_robot`).

    Returns
    -------
    tracks : MOTData
        Left-image results.
    step_times : ndarray (T,)
        Seconds per tracker step.
    """
    if not isinstance(recording, RobotRecording):
        raise TypeError(f"recording must be a RobotRecording, got {type(recording).__name__}")
    tracker = RobotTracker(head or recording.head, config, recording.fps)
    outs, times = [], np.zeros(recording.n_frames)
    motion = None
    for t, faces in enumerate(recording.faces):
        t0 = time.perf_counter()
        outs.append(tracker.step(faces, motion))
        times[t] = time.perf_counter() - t0
        motion = HeadMotion(recording.angles[t], recording.commands[t])
    return _tracks_to_mot(outs, tracker.head.rig, border), times


def write_robot_sim(result: RobotSimResult, out_dir: str | Path) -> list[Path]:
    """Write ``tracks.txt`` and ``gt/gt.txt`` (MOTChallenge, left image) and ``servo.csv``
    (``frame,target_id,distance_px``; ``nan`` without a target) under ``out_dir``, each file
    atomically. Returns the paths written."""
    out = Path(out_dir)
    tracks, gt_path, servo_path = out / "tracks.txt", out / "gt" / "gt.txt", out / "servo.csv"
    write_mot(tracks, result.tracks)
    write_mot(gt_path, result.gt)
    log = result.servo
    with atomic_write(servo_path) as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(["frame", "target_id", "distance_px"])
        for f, i, d in zip(log.frames, log.target_ids, log.distance_px, strict=True):
            w.writerow([int(f), int(i), "nan" if not np.isfinite(d) else f"{d:.2f}"])
    return [tracks, gt_path, servo_path]
