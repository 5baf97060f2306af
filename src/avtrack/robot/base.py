r"""Data types and interfaces of the robot-head stage (thesis §3.2).

Frames and units used by every module of :mod:`avtrack.robot`:

* **camera frame** -- the *current* left-camera frame of the stereo pair (OpenCV convention:
  x right, y down, z forward, metres). The tracker's states and the 3-D observations are
  expressed in it ("these variables are expressed in the coordinate frame of the camera
  pair", thesis §3.2.2), so they move when the head moves;
* **home frame** -- the left-camera frame at the home joint angles ``q = (0, 0)``; the thesis's
  "world" (§3.2.4: "the left camera at the initial head's position");
* joint angles ``q = (α, β)`` -- pan (yaw) and tilt (pitch) in radians; joint velocities
  ``q̇`` in rad/s;
* pixels: continuous coordinates, (0, 0) the top-left corner of the image (MOTChallenge).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

#: Observed part of the state ``s = [X, W, Ẋ]``: position (3) and box size (2) (thesis §3.2.2).
OBS_DIM = 5
#: State dimension: ``X`` (3), ``W`` (2), ``Ẋ`` (3).
STATE_DIM = 8
_LOG_2PI = float(np.log(2 * np.pi))


def _as_vector(name: str, value, size: int) -> np.ndarray:
    v = np.array(value, dtype=float)
    if v.shape != (size,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be {size} finite numbers, got {value!r}")
    v.setflags(write=False)
    return v


@dataclass(frozen=True)
class HeadMotion:
    """The head's motion between two frames, as the robot knows it.

    Attributes
    ----------
    angles : ndarray (2,)
        Joint angles ``(α, β)`` (rad) at the previous frame, when the command was issued.
    velocity : ndarray (2,)
        Commanded joint velocities ``(α̇_c, β̇_c)`` (rad/s) held until the current frame
        (thesis eq. 3.47).
    """

    angles: np.ndarray
    velocity: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "angles", _as_vector("HeadMotion.angles", self.angles, 2))
        object.__setattr__(self, "velocity", _as_vector("HeadMotion.velocity", self.velocity, 2))


@dataclass(frozen=True)
class FaceObservations:
    r"""One frame of 3-D face observations :math:`o_{tm} = [X_{tm}, W_{tm}]` (thesis §3.2.5).

    Attributes
    ----------
    positions : ndarray (M, 3)
        Triangulated face centres in the current left-camera frame, metres.
    sizes : ndarray (M, 2)
        Face box width and height in the left image, pixels.
    cov : ndarray (M, 5, 5)
        Observation covariances :math:`\Phi_{tm}` of ``[X, W]`` (symmetric positive definite).
    appearance : ndarray (M, F) or None
        Appearance descriptors.
    left_boxes : ndarray (M, 4)
        The left-image boxes ``(left, top, width, height)`` the observations came from.
    """

    positions: np.ndarray
    sizes: np.ndarray
    cov: np.ndarray
    appearance: np.ndarray | None = None
    left_boxes: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))

    def __post_init__(self) -> None:
        pos = np.asarray(self.positions, dtype=float)
        m = pos.shape[0] if pos.ndim == 2 else -1
        if pos.shape != (m, 3):
            raise ValueError(f"FaceObservations: positions must be (M, 3), got {pos.shape}")
        sizes = np.asarray(self.sizes, dtype=float)
        cov = np.asarray(self.cov, dtype=float)
        if sizes.shape != (m, 2):
            raise ValueError(f"FaceObservations: sizes must be ({m}, 2), got {sizes.shape}")
        if cov.shape != (m, OBS_DIM, OBS_DIM):
            raise ValueError(f"FaceObservations: cov must be ({m}, 5, 5), got {cov.shape}")
        if not (
            np.all(np.isfinite(pos)) and np.all(np.isfinite(sizes)) and np.all(np.isfinite(cov))
        ):
            raise ValueError("FaceObservations: positions, sizes and cov must be finite")
        if m and not np.all(sizes > 0):
            raise ValueError("FaceObservations: sizes must be > 0")
        boxes = np.asarray(self.left_boxes, dtype=float)
        if boxes.size == 0:
            boxes = np.zeros((m, 4))
        if boxes.shape != (m, 4):
            raise ValueError(f"FaceObservations: left_boxes must be ({m}, 4), got {boxes.shape}")
        app = self.appearance
        if app is not None:
            app = np.asarray(app, dtype=float)
            if app.ndim != 2 or app.shape[0] != m:
                raise ValueError(f"FaceObservations: appearance must be ({m}, F), got {app.shape}")
        object.__setattr__(self, "positions", pos)
        object.__setattr__(self, "sizes", sizes)
        object.__setattr__(self, "cov", cov)
        object.__setattr__(self, "left_boxes", boxes)
        object.__setattr__(self, "appearance", app)

    def __len__(self) -> int:
        return int(self.positions.shape[0])

    @classmethod
    def empty(cls, appearance_dim: int | None = None) -> FaceObservations:
        """A frame without observations."""
        app = None if appearance_dim is None else np.zeros((0, appearance_dim))
        return cls(np.zeros((0, 3)), np.zeros((0, 2)), np.zeros((0, OBS_DIM, OBS_DIM)), app)

    # per-frame constants of the likelihood and the E-S step, computed once
    @cached_property
    def z(self) -> np.ndarray:
        """``(M, 5)`` observations ``[X, W]``."""
        return np.concatenate([self.positions, self.sizes], axis=1)

    @cached_property
    def precision(self) -> np.ndarray:
        r"""``(M, 5, 5)`` :math:`\Phi_{tm}^{-1}`."""
        return np.linalg.inv(self.cov)

    @cached_property
    def info_vector(self) -> np.ndarray:
        r"""``(M, 5)`` :math:`\Phi_{tm}^{-1} o_{tm}`."""
        return np.einsum("mij,mj->mi", self.precision, self.z)

    @cached_property
    def log_normaliser(self) -> np.ndarray:
        r"""``(M,)`` :math:`-\frac12\log|2\pi\Phi_{tm}|`."""
        _, logdet = np.linalg.slogdet(self.cov)
        return -0.5 * (logdet + OBS_DIM * _LOG_2PI)

    def subset(self, idx: np.ndarray) -> FaceObservations:
        """The observations ``idx`` (indices or a boolean mask)."""
        app = None if self.appearance is None else self.appearance[idx]
        return FaceObservations(
            self.positions[idx], self.sizes[idx], self.cov[idx], app, self.left_boxes[idx]
        )

    def transformed(self, transform: np.ndarray) -> FaceObservations:
        r"""The same faces in another camera frame: ``X ← R X + t`` and
        :math:`\Phi_{XX} \leftarrow R\Phi_{XX}R^\top` for the rigid ``transform (4, 4)``
        (sizes and their variances are kept)."""
        g = np.asarray(transform, dtype=float)
        if g.shape != (4, 4):
            raise ValueError(f"transform must be (4, 4), got {g.shape}")
        rot, t = g[:3, :3], g[:3, 3]
        big = np.eye(OBS_DIM)
        big[:3, :3] = rot
        cov = big @ self.cov @ big.T  # R Φ Rᵀ on the position block
        return FaceObservations(
            self.positions @ rot.T + t,
            self.sizes,
            0.5 * (cov + np.swapaxes(cov, 1, 2)),
            self.appearance,
            self.left_boxes,
        )


@dataclass(frozen=True)
class TrackedPeople:
    """What a servo policy may look at: every target the tracker holds (visible or not).

    Attributes
    ----------
    ids : ndarray (N,) int
        Target identities, in order of creation.
    positions : ndarray (N, 3)
        Posterior mean positions in the current left-camera frame, metres.
    velocities : ndarray (N, 3)
        Posterior mean velocities, m/s (same frame).
    visible : ndarray (N,) bool
        Whether each target is currently visible (visibility posterior > 0.5).
    """

    ids: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    visible: np.ndarray

    def __post_init__(self) -> None:
        ids = np.asarray(self.ids, dtype=np.int64).reshape(-1)
        n = ids.shape[0]
        pos = np.asarray(self.positions, dtype=float).reshape(n, 3)
        vel = np.asarray(self.velocities, dtype=float).reshape(n, 3)
        vis = np.asarray(self.visible, dtype=bool).reshape(n)
        object.__setattr__(self, "ids", ids)
        object.__setattr__(self, "positions", pos)
        object.__setattr__(self, "velocities", vel)
        object.__setattr__(self, "visible", vis)

    def __len__(self) -> int:
        return int(self.ids.shape[0])


class ServoPolicy(ABC):
    """High-level control rule: which tracked person the head should keep centred
    (thesis §3.2.6: "follow the first tracked person" or "change person every three seconds").

    Policies are stateful (they remember their current choice); :meth:`reset` forgets it.
    """

    #: Registry name (``"follow"``, ``"jump"``).
    name: str = "policy"

    @abstractmethod
    def select(self, time_s: float, people: TrackedPeople) -> int | None:
        """The id of the person to servo at ``time_s`` (seconds), or None for none."""

    def reset(self) -> None:  # noqa: B027
        """Forget the current choice."""
