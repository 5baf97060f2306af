r"""Visual servoing of the head onto a chosen person (thesis §3.2.4, eqs. 3.46–3.47).

The motor velocities that bring the servo position :math:`X_s` (the chosen person's tracked
3-D position) to the image centre are

.. math::
    \begin{pmatrix}\dot\alpha_c\\ \dot\beta_c\end{pmatrix}
        = \frac{\gamma}{\Delta t}\,J^{-1}(X_s)\,\Delta V \qquad\text{(eq. 3.47)}

with the joint Jacobian :math:`J = J_{wi}J_{mw}` (eq. 3.46), :math:`\Delta V` the pixel shift
from the person's projection to the image centre and :math:`0 < \gamma < 1` the fraction of
the shift corrected per frame (eq. 3.47's scale factor, here made a velocity by
:math:`1/\Delta t`). The commands are then limited to the joints' speeds and ranges. The same
velocities give the control term :math:`C_{tn}` of the next frame (eq. 3.45).

Policies (thesis §3.2.6): :class:`FollowFirst` ("servo the first tracked person") and
:class:`JumpPolicy` ("change the pursued person every three seconds"), registered in
:data:`SERVO_POLICIES`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from avtrack.registry import Registry
from avtrack.robot.base import ServoPolicy, TrackedPeople
from avtrack.robot.head import RobotHead

#: Registry of servo policies by name.
SERVO_POLICIES: Registry[type[ServoPolicy]] = Registry("servo policy")

#: Class decorator adding a :class:`ServoPolicy` to :data:`SERVO_POLICIES` under a name.
register_policy = SERVO_POLICIES.register


@register_policy("follow")
class FollowFirst(ServoPolicy):
    """Servo the first tracked person: the oldest target still held; keep it while it lives,
    then move to the oldest remaining one."""

    def __init__(self) -> None:
        self.current: int | None = None

    def select(self, time_s: float, people: TrackedPeople) -> int | None:
        if len(people) == 0:
            self.current = None
        elif self.current not in set(people.ids.tolist()):
            self.current = int(people.ids.min())
        return self.current

    def reset(self) -> None:
        self.current = None


@register_policy("jump")
class JumpPolicy(ServoPolicy):
    """Change the pursued person every ``period_s`` seconds, cycling through the tracked people
    in order of identity (thesis: every three seconds).

    Parameters
    ----------
    period_s : float
        Seconds between switches (> 0).
    """

    def __init__(self, period_s: float = 3.0) -> None:
        if not (isinstance(period_s, int | float) and math.isfinite(period_s) and period_s > 0):
            raise ValueError(f"period_s must be a positive number, got {period_s!r}")
        self.period_s = float(period_s)
        self.current: int | None = None
        self.since: float = 0.0

    def select(self, time_s: float, people: TrackedPeople) -> int | None:
        if len(people) == 0:
            self.current = None
            return None
        ids = np.sort(people.ids)
        if self.current not in set(ids.tolist()):
            later = ids[ids > self.current] if self.current is not None else ids
            self.current = int(later[0] if later.size else ids[0])
            self.since = time_s
        elif time_s - self.since >= self.period_s - 1e-9:
            later = ids[ids > self.current]
            self.current = int(later[0] if later.size else ids[0])  # the next one, cyclically
            self.since = time_s
        return self.current

    def reset(self) -> None:
        self.current = None
        self.since = 0.0


def make_policy(name: str, **kwargs) -> ServoPolicy:
    """A new policy by registry name (``"follow"``, ``"jump"``)."""
    if name not in SERVO_POLICIES:
        raise ValueError(f"policy must be one of {sorted(SERVO_POLICIES)}, got {name!r}")
    return SERVO_POLICIES[name](**kwargs)


def servo_jacobian(head: RobotHead, target: np.ndarray, angles: np.ndarray) -> np.ndarray:
    r"""Joint motor-to-image Jacobian :math:`J(X_s)` at one point (eq. 3.46), ``(2, 2)``."""
    x = np.asarray(target, dtype=float).reshape(1, 3)
    return head.joint_jacobian(x, angles)[0]


def limit_velocity(
    head: RobotHead, angles: np.ndarray, velocity: np.ndarray, dt: float
) -> np.ndarray:
    """``velocity (2,)`` scaled down to the joints' maximum speeds (direction kept), then
    clipped so that ``angles + velocity·dt`` stays in the joint ranges."""
    v = np.asarray(velocity, dtype=float)
    q = np.asarray(angles, dtype=float)
    vmax = np.asarray(head.max_speed)
    over = np.abs(v) / vmax
    if over.max() > 1.0:
        v = v / over.max()
    lim = head.limits
    return np.clip(v, (lim[:, 0] - q) / dt, (lim[:, 1] - q) / dt)


def servo_velocity(
    head: RobotHead,
    target: np.ndarray,
    angles: np.ndarray,
    dt: float,
    gain: float = 0.5,
    goal: np.ndarray | None = None,
) -> np.ndarray:
    r"""Joint velocities bringing ``target`` towards ``goal`` in the left image (eq. 3.47).

    Parameters
    ----------
    head : RobotHead
    target : ndarray (3,)
        Servo position :math:`X_s`, current left-camera frame, metres.
    angles : ndarray (2,)
        Current joint angles, radians.
    dt : float
        Time until the next command, seconds.
    gain : float
        :math:`\gamma \in (0, 1]`, fraction of the pixel error corrected per frame.
    goal : ndarray (2,), optional
        Target pixel (default: the image centre).

    Returns
    -------
    ndarray (2,)
        :math:`(\dot\alpha_c, \dot\beta_c)`, rad/s, within the speed and range limits. A
        target at depth below 5 cm (beside or behind the head, where eq. 3.39 is undefined)
        gets a pan at full speed towards its side.
    """
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a finite number > 0, got {dt!r}")
    if not 0 < gain <= 1:
        raise ValueError(f"gain must be in (0, 1], got {gain!r}")
    x = np.asarray(target, dtype=float)
    if x.shape != (3,) or not np.all(np.isfinite(x)):
        raise ValueError(f"target must be 3 finite numbers, got {target!r}")
    rig = head.rig
    g = rig.centre if goal is None else np.asarray(goal, dtype=float)
    if g.shape != (2,):
        raise ValueError(f"goal must be 2 numbers (pixels), got {goal!r}")
    if x[2] < 0.05:  # outside the pinhole's domain: turn towards the person's side
        # the scene moves by ω₁ × X: pick the pan direction that moves X towards +z
        jac = head.motor_to_world_jacobian(x[None], angles)[0]  # (3, 2)
        direction = math.copysign(1.0, jac[2, 0]) if jac[2, 0] != 0 else 1.0
        return limit_velocity(head, angles, np.array([direction * head.max_speed[0], 0.0]), dt)
    shift = g - rig.project(x[None])[0]  # ΔV
    jac = servo_jacobian(head, x, angles)  # eq. 3.46
    try:
        step = np.linalg.solve(jac, shift)  # J⁻¹ ΔV
    except np.linalg.LinAlgError:
        step = np.linalg.lstsq(jac, shift, rcond=None)[0]
    return limit_velocity(head, angles, gain * step / dt, dt)  # γ J⁻¹ ΔV / Δt, eq. 3.47


@dataclass(frozen=True)
class ServoCommand:
    """One servo decision.

    Attributes
    ----------
    target_id : int
        The pursued person's track id, -1 for none.
    velocity : ndarray (2,)
        Commanded joint velocities, rad/s (zeros without a target).
    """

    target_id: int
    velocity: np.ndarray


class VisualServo:
    """Policy + eq. 3.47: one command per frame from the tracker's people.

    Parameters
    ----------
    head : RobotHead
    policy : ServoPolicy
    gain : float
        γ of eq. 3.47.
    fps : float
        Command rate (one per tracked frame).
    lead : bool
        Servo the position predicted one frame ahead, :math:`X + \\dot X\\Delta t`, instead of
        the current estimate (compensates the one-frame actuation delay).
    """

    def __init__(
        self,
        head: RobotHead,
        policy: ServoPolicy,
        gain: float = 0.5,
        fps: float = 10.0,
        lead: bool = True,
    ):
        if not isinstance(policy, ServoPolicy):
            raise TypeError(f"policy must be a ServoPolicy, got {type(policy).__name__}")
        if not 0 < gain <= 1:
            raise ValueError(f"gain must be in (0, 1], got {gain!r}")
        if not (math.isfinite(fps) and fps > 0):
            raise ValueError(f"fps must be a positive number, got {fps!r}")
        self.head, self.policy, self.gain = head, policy, float(gain)
        self.dt = 1.0 / float(fps)
        self.lead = bool(lead)

    def command(self, time_s: float, people: TrackedPeople, angles: np.ndarray) -> ServoCommand:
        """The target and the joint velocities to hold until the next frame."""
        target = self.policy.select(time_s, people)
        if target is None:
            return ServoCommand(-1, np.zeros(2))
        k = int(np.flatnonzero(people.ids == target)[0])
        x = people.positions[k] + (people.velocities[k] * self.dt if self.lead else 0.0)
        v = servo_velocity(self.head, x, angles, self.dt, self.gain)
        return ServoCommand(int(target), v)
