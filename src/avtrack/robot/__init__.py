"""Moving robot head: 3-D tracking with ego-motion compensation, visual servoing and
motor–camera calibration (thesis §3.2).

Modules
-------
- :mod:`~avtrack.robot.base` -- frames and units; data types (:class:`FaceObservations`,
  :class:`HeadMotion`, :class:`TrackedPeople`) and the :class:`ServoPolicy` interface.
- :mod:`~avtrack.robot.stereo` -- rectified stereo pair (:class:`StereoRig`): projection
  (eq. 3.39), world-to-image Jacobian (eq. 3.40), triangulation of face boxes (§3.2.5).
- :mod:`~avtrack.robot.head` -- pan/tilt kinematics from the calibration twists (eq. 3.48),
  motor-to-world and joint Jacobians (eqs. 3.41–3.46); NAO-like defaults.
- :mod:`~avtrack.robot.egomotion` -- the control term :math:`C_{tn}` (eqs. 3.34, 3.45).
- :mod:`~avtrack.robot.tracker` -- :class:`RobotTracker`, the 3-D VEM tracker with control
  (eqs. 3.33–3.38) on the generic engine.
- :mod:`~avtrack.robot.servo` -- motor velocities centring a person (eq. 3.47) and the
  "follow" / "jump" policies.
- :mod:`~avtrack.robot.calibration` -- motor–camera calibration from chessboard extrinsics
  (the Frobenius cost of §3.2.5).

Closed-loop NAO-MPVS-like sequences (``follow1`` ... ``jump3``) are simulated by
:mod:`avtrack.simulate.robot`.

Reference: Y. Ban, *Audio-Visual Multiple-Speaker Tracking for Robot Perception*, PhD thesis,
2019, §3.2.
"""

from avtrack.robot.base import FaceObservations, HeadMotion, ServoPolicy, TrackedPeople
from avtrack.robot.calibration import calibrate_head, calibrate_joint, frobenius_cost
from avtrack.robot.egomotion import control_term, control_vector
from avtrack.robot.head import HeadCalibration, RobotHead, nao_calibration, nao_head
from avtrack.robot.servo import (
    SERVO_POLICIES,
    FollowFirst,
    JumpPolicy,
    VisualServo,
    servo_jacobian,
    servo_velocity,
)
from avtrack.robot.stereo import StereoMatchConfig, StereoRig, match_stereo, stereo_faces
from avtrack.robot.tracker import RobotTracker, RobotTrackerConfig

__all__ = [
    "SERVO_POLICIES",
    "FaceObservations",
    "FollowFirst",
    "HeadCalibration",
    "HeadMotion",
    "JumpPolicy",
    "RobotHead",
    "RobotTracker",
    "RobotTrackerConfig",
    "ServoPolicy",
    "StereoMatchConfig",
    "StereoRig",
    "TrackedPeople",
    "VisualServo",
    "calibrate_head",
    "calibrate_joint",
    "control_term",
    "control_vector",
    "frobenius_cost",
    "match_stereo",
    "nao_calibration",
    "nao_head",
    "servo_jacobian",
    "servo_velocity",
    "stereo_faces",
]
