r"""Directions from the microphone array and pixels of the camera: one geometric mapping.

A person's position is kept as a *direction from the array* (azimuth, elevation, degrees; the
array frame of the DOA CSV: azimuth counter-clockwise from the array's x axis, elevation up
from its horizontal plane) plus a distance. The camera's image is a window inside that space:
a pixel is a ray from the camera's optical centre, and a direction at a distance is a 3-D point
that the camera projects.

Frames. Room frame: metres, z up. The array sits at ``array_position`` with its x axis turned
``array_yaw_deg`` about room z (the convention of :mod:`avtrack.simulate.scene`). The camera is
a :class:`~avtrack.io.camera.PinholeCamera` (room frame, OpenCV axes). A point ``X``
(room) has array coordinates :math:`A = R_z(-\psi)(X - P)` and

.. math::

    \mathrm{az} = \operatorname{atan2}(A_y, A_x), \qquad
    \mathrm{el} = \operatorname{atan2}(A_z, \sqrt{A_x^2 + A_y^2}).

Pixel to direction: the back-projected ray :math:`X = C + z\,R^\top K^{-1}[u, v, 1]^\top` at the
depth ``z`` along the optical axis (from the head box height and a nominal head height, or a
default distance) expressed in the array frame. Direction to pixel: the point at distance ``r``
along the direction, projected by the camera. When the camera sits at the array (the usual
robot head) the distance hardly matters; when it is metres away it does, which is why every
person keeps a distance estimate.

This mapping needs only the camera's intrinsics and pose relative to the array, so it works on
a real recording without any calibration recording (unlike the learned GLLiM mapping of thesis
§4.4, which stays available for the image-plane model).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from avtrack.io.camera import PinholeCamera
from avtrack.io.doa import wrap_azimuth

#: Head height in metres assumed when turning a head box's pixel height into a depth
#: (the simulator's head boxes are 0.18 x 0.24 m).
HEAD_HEIGHT_M = 0.24

#: Distance in metres assumed for a direction never seen by the camera.
DEFAULT_DISTANCE_M = 2.0


def _rz(deg: float) -> np.ndarray:
    c, s = np.cos(np.deg2rad(deg)), np.sin(np.deg2rad(deg))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@dataclass(frozen=True, eq=False)
class CameraGeometry:
    """A camera and a microphone array in one room frame.

    Attributes
    ----------
    camera : PinholeCamera
    array_position : ndarray (3,)
        Array centre in the room frame, metres.
    array_yaw_deg : float
        Rotation of the array's x axis about room z, degrees.
    box_height_m : float
        Height in metres of what a box outlines: a head (:data:`HEAD_HEIGHT_M`) by default, a
        face for a face detector (:data:`avtrack.visual.detect.BOX_HEIGHT_M`); a box's depth
        is ``f_y box_height_m / h``.
    """

    camera: PinholeCamera
    array_position: np.ndarray
    array_yaw_deg: float = 0.0
    box_height_m: float = HEAD_HEIGHT_M
    #: ``R_z(-ψ)``, room to array axes (set from ``array_yaw_deg``)
    _to_array: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not isinstance(self.camera, PinholeCamera):
            raise TypeError(
                f"CameraGeometry.camera must be a PinholeCamera, got {type(self.camera).__name__}"
            )
        p = np.array(self.array_position, dtype=float)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise ValueError(
                f"CameraGeometry.array_position must be 3 finite numbers, got "
                f"{self.array_position!r}"
            )
        p.setflags(write=False)
        object.__setattr__(self, "array_position", p)
        yaw = float(self.array_yaw_deg)
        if not np.isfinite(yaw):
            raise ValueError(f"CameraGeometry.array_yaw_deg must be finite, got {yaw!r}")
        object.__setattr__(self, "array_yaw_deg", yaw)
        object.__setattr__(self, "_to_array", _rz(-yaw))
        bh = float(self.box_height_m)
        if not (np.isfinite(bh) and bh > 0):
            raise ValueError(f"CameraGeometry.box_height_m must be > 0, got {self.box_height_m!r}")
        object.__setattr__(self, "box_height_m", bh)

    @classmethod
    def from_scenario(cls, scenario: dict, camera: PinholeCamera) -> CameraGeometry:
        """The geometry of a validated scenario (``array.position``, ``array.yaw_deg``)."""
        arr = scenario["array"]
        return cls(camera, np.asarray(arr["position"], float), float(arr["yaw_deg"]))

    @property
    def image_size(self) -> tuple[int, int]:
        return self.camera.width, self.camera.height

    # ------------------------------------------------------------------ room <-> array
    def room_to_direction(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Azimuth, elevation (degrees) and distance (metres) from the array of room points
        ``(N, 3)``; each output ``(N,)``."""
        x = np.atleast_2d(np.asarray(points, dtype=float))
        a = (x - self.array_position) @ self._to_array.T  # A = R_z(-ψ)(X - P)
        horiz = np.hypot(a[:, 0], a[:, 1])
        az = np.degrees(np.arctan2(a[:, 1], a[:, 0]))
        el = np.degrees(np.arctan2(a[:, 2], horiz))
        return wrap_azimuth(az), el, np.linalg.norm(a, axis=1)

    def direction_to_room(
        self, az_deg: np.ndarray, el_deg: np.ndarray, distance: np.ndarray
    ) -> np.ndarray:
        """Room points ``(N, 3)`` at ``distance`` metres along each direction (degrees)."""
        az, el = np.deg2rad(np.atleast_1d(az_deg)), np.deg2rad(np.atleast_1d(el_deg))
        r = np.broadcast_to(np.asarray(distance, dtype=float), az.shape)
        unit = np.column_stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
        return (r[:, None] * unit) @ self._to_array + self.array_position  # R_z(ψ) A + P

    # ------------------------------------------------------------------ pixels
    def boxes_to_directions(
        self, boxes: np.ndarray, head_height: float | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Directions from the array of head boxes ``(N, 4)`` (left, top, width, height).

        The box centre is back-projected at the depth :math:`z = f_y H / h` of a head of height
        ``head_height`` metres (default ``box_height_m``). Returns azimuth, elevation (degrees)
        and distance (metres), each ``(N,)``.
        """
        if head_height is None:
            head_height = self.box_height_m
        b = np.asarray(boxes, dtype=float).reshape(-1, 4)
        cam = self.camera
        u = b[:, 0] + 0.5 * b[:, 2]
        v = b[:, 1] + 0.5 * b[:, 3]
        z = cam.fy * head_height / np.maximum(b[:, 3], 1.0)  # depth along the optical axis
        ray = np.column_stack([(u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, np.ones_like(u)])
        points = (z[:, None] * ray) @ cam.R + cam.position  # X = C + z Rᵀ K⁻¹ [u, v, 1]ᵀ
        return self.room_to_direction(points)

    def directions_to_pixels(
        self, az_deg: np.ndarray, el_deg: np.ndarray, distance: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Pixels ``(N, 2)`` of directions at distances, and whether each lies in front of the
        camera and inside the image ``(N,)`` (NaN pixels behind the camera)."""
        pts = self.direction_to_room(az_deg, el_deg, distance)
        uv, depth = self.camera.project(pts)
        w, h = self.image_size
        inside = (
            np.isfinite(uv).all(axis=1)
            & (depth > 0)
            & (uv[:, 0] >= 0)
            & (uv[:, 0] <= w)
            & (uv[:, 1] >= 0)
            & (uv[:, 1] <= h)
        )
        return uv, inside

    def view_azimuths(
        self, distance: float = DEFAULT_DISTANCE_M, columns: tuple[float, float] | None = None
    ) -> tuple[float, float]:
        """Azimuths (degrees) of the left and right edges of the image (or of the pixel
        ``columns``) on the principal row, for a head ``distance`` metres away."""
        cam = self.camera
        lo, hi = (0.0, float(cam.width)) if columns is None else columns
        h = cam.fy * self.box_height_m / distance  # a box's height at that depth
        boxes = np.array([[lo - 0.5, cam.cy - h / 2, 1.0, h],
                          [hi - 0.5, cam.cy - h / 2, 1.0, h]])
        az, _, _ = self.boxes_to_directions(boxes)
        return float(az[0]), float(az[1])

    def image_side(
        self, az_deg: np.ndarray, el_deg: np.ndarray, distance: np.ndarray
    ) -> np.ndarray:
        """``(N,)`` -1 for directions to the left of the camera's optical axis, +1 to its
        right (where to point at a person outside the image)."""
        xc = self.camera.to_camera(self.direction_to_room(az_deg, el_deg, distance))
        return np.where(xc[:, 0] < 0, -1, 1)
