"""A pinhole camera placed in the room: projection of 3-D points and of head boxes.

Room frame: metres, z up. Camera frame (OpenCV convention): x right, y down, z forward along
the optical axis. A point ``X`` (room) maps to ``X_c = R (X - C)`` (camera) and to the pixel

.. math::

    u = f_x \\frac{x_c}{z_c} + c_x, \\qquad v = f_y \\frac{y_c}{z_c} + c_y,

i.e. ``[u, v, 1]^T ~ P [X; 1]`` with ``P = K [R | t]``, ``t = -R C``. Pixel coordinates are
continuous with (0, 0) the top-left corner of the image and (width, height) its bottom-right
corner, the convention of MOTChallenge boxes.

The pose has no roll: ``yaw_deg`` turns the optical axis about room z (0 = looking along +x,
90 = along +y) and ``pitch_deg`` tilts it (positive = looking up). With yaw ψ and pitch θ the
camera axes in room coordinates are

.. math::

    f = (\\cos θ \\cos ψ, \\cos θ \\sin ψ, \\sin θ),\\quad
    r = (\\sin ψ, -\\cos ψ, 0),\\quad
    d = f \\times r = (\\sin θ \\cos ψ, \\sin θ \\sin ψ, -\\cos θ),

and ``R`` has rows ``r, d, f`` (forward, right, down; ``r × d = f``).
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from avtrack.errors import InputError

_JSON_FIELDS = ("fx", "fy", "cx", "cy", "width", "height", "position", "yaw_deg", "pitch_deg")


def _positive(name: str, value: float, owner: str = "PinholeCamera") -> float:
    v = float(value)
    if not math.isfinite(v) or v <= 0:
        raise ValueError(f"{owner}: {name} must be a finite number > 0, got {value!r}")
    return v


def _finite(name: str, value: float, owner: str = "PinholeCamera") -> float:
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{owner}: {name} must be finite, got {value!r}")
    return v


def _as_points(points: np.ndarray, name: str = "points") -> np.ndarray:
    p = np.asarray(points, dtype=float)
    if p.ndim == 1 and p.shape[0] == 3:
        p = p[None, :]
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3), got {np.shape(points)}")
    return p


@dataclass(frozen=True, eq=False)
class Intrinsics:
    """Pinhole intrinsics and image size, checked: what a camera in the room
    (:class:`PinholeCamera`) and a rectified stereo pair
    (:class:`~avtrack.robot.stereo.StereoRig`) share. Errors name the subclass.

    Attributes
    ----------
    fx, fy : float
        Focal lengths in pixels (> 0).
    cx, cy : float
        Principal point in pixels.
    width, height : int
        Image size in pixels (> 0).
    """

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int

    def __post_init__(self) -> None:
        owner = type(self).__name__
        for name in ("fx", "fy"):
            object.__setattr__(self, name, _positive(name, getattr(self, name), owner))
        for name in ("cx", "cy"):
            object.__setattr__(self, name, _finite(name, getattr(self, name), owner))
        for name in ("width", "height"):
            v = getattr(self, name)
            if isinstance(v, bool) or not float(v).is_integer() or v <= 0:
                raise ValueError(f"{owner}: {name} must be an integer > 0, got {v!r}")
            object.__setattr__(self, name, int(v))


@dataclass(frozen=True, eq=False)
class PinholeCamera(Intrinsics):
    """Ideal pinhole camera (no distortion, no roll) in the room frame.

    Attributes
    ----------
    fx, fy, cx, cy, width, height
        The :class:`Intrinsics`.
    position : ndarray (3,)
        Optical centre ``C`` in the room frame, metres.
    yaw_deg : float
        Azimuth of the optical axis about room z, counter-clockwise from +x, degrees.
    pitch_deg : float
        Elevation of the optical axis in [-90, 90] degrees, positive looking up.
    """

    position: np.ndarray
    yaw_deg: float = 0.0
    pitch_deg: float = 0.0

    def __post_init__(self) -> None:
        super().__post_init__()
        pos = np.array(self.position, dtype=float)
        if pos.shape != (3,) or not np.all(np.isfinite(pos)):
            raise ValueError(
                f"PinholeCamera: position must be 3 finite numbers, got {self.position!r}"
            )
        pos.setflags(write=False)
        object.__setattr__(self, "position", pos)
        object.__setattr__(self, "yaw_deg", _finite("yaw_deg", self.yaw_deg))
        pitch = _finite("pitch_deg", self.pitch_deg)
        if not -90.0 <= pitch <= 90.0:
            raise ValueError(f"PinholeCamera: pitch_deg must be in [-90, 90], got {pitch!r}")
        object.__setattr__(self, "pitch_deg", pitch)

    # ------------------------------------------------------------------ construction

    @classmethod
    def from_fov(
        cls,
        hfov_deg: float,
        width: int,
        height: int,
        position: Sequence[float] | np.ndarray,
        yaw_deg: float = 0.0,
        pitch_deg: float = 0.0,
    ) -> PinholeCamera:
        """Camera with square pixels, the principal point at the image centre and the given
        horizontal field of view: ``fx = fy = (width / 2) / tan(hfov / 2)``."""
        h = float(hfov_deg)
        if not 0.0 < h < 180.0:
            raise ValueError(f"PinholeCamera.from_fov: hfov_deg must be in (0, 180), got {h!r}")
        _positive("width", width)
        f = 0.5 * float(width) / math.tan(math.radians(h) / 2.0)
        return cls(
            f, f, width / 2.0, height / 2.0, width, height, np.asarray(position), yaw_deg,
            pitch_deg,
        )

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, PinholeCamera):
            return NotImplemented
        return self.to_json() == other.to_json()

    # ------------------------------------------------------------------ geometry

    @property
    def K(self) -> np.ndarray:
        """Intrinsic matrix, ndarray (3, 3)."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def R(self) -> np.ndarray:
        """Rotation room → camera, ndarray (3, 3); rows are the camera's right, down and
        forward axes in room coordinates."""
        psi = math.radians(self.yaw_deg)
        th = math.radians(self.pitch_deg)
        cp, sp, ct, st = math.cos(psi), math.sin(psi), math.cos(th), math.sin(th)
        right = [sp, -cp, 0.0]  # r = (sin ψ, -cos ψ, 0)
        down = [st * cp, st * sp, -ct]  # d = f × r
        forward = [ct * cp, ct * sp, st]  # f = (cos θ cos ψ, cos θ sin ψ, sin θ)
        return np.array([right, down, forward])

    @property
    def t(self) -> np.ndarray:
        """Translation ``t = -R C``, ndarray (3,)."""
        return -self.R @ self.position

    def projection_matrix(self) -> np.ndarray:
        """``P = K [R | t]``, ndarray (3, 4)."""
        return self.K @ np.column_stack([self.R, self.t])

    def to_camera(self, points: np.ndarray) -> np.ndarray:
        """Room points ``(N, 3)`` in camera coordinates ``X_c = R (X - C)``, ``(N, 3)``."""
        p = _as_points(points)
        return (p - self.position) @ self.R.T

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Project room points onto the image.

        Parameters
        ----------
        points : ndarray (N, 3)
            Room-frame points, metres.

        Returns
        -------
        uv : ndarray (N, 2)
            Pixel coordinates; NaN for points with depth <= 0 (behind the camera).
        depth : ndarray (N,)
            Coordinate along the optical axis ``z_c`` (negative behind the camera).
        """
        xc = self.to_camera(points)
        depth = xc[:, 2]
        uv = np.full((xc.shape[0], 2), np.nan)
        front = depth > 0
        z = depth[front]
        uv[front, 0] = self.fx * xc[front, 0] / z + self.cx  # u = fx x/z + cx
        uv[front, 1] = self.fy * xc[front, 1] / z + self.cy  # v = fy y/z + cy
        return uv, depth

    def in_view(self, points: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """Whether each point is in front of the camera and projects inside the image.

        Parameters
        ----------
        points : ndarray (N, 3)
            Room-frame points.
        margin : float
            Pixels the projection must keep from the image border (a negative margin accepts
            points up to ``-margin`` pixels outside the image).

        Returns
        -------
        ndarray (N,) bool
        """
        m = float(margin)
        if not math.isfinite(m):
            raise ValueError(f"in_view: margin must be finite, got {margin!r}")
        uv, depth = self.project(points)
        with np.errstate(invalid="ignore"):
            inside = (
                (uv[:, 0] >= m)
                & (uv[:, 0] <= self.width - m)
                & (uv[:, 1] >= m)
                & (uv[:, 1] <= self.height - m)
            )
        return (depth > 0) & inside

    def head_box(
        self, head_centres: np.ndarray, head_size: tuple[float, float] = (0.18, 0.24)
    ) -> np.ndarray:
        """Image box of each head, modelled as a fronto-parallel rectangle.

        The head is a ``width × height`` metre rectangle parallel to the image plane (its sides
        along the camera's x and y axes) centred on the 3-D head centre, so its image is the
        axis-aligned box centred on the projected centre with size ``(fx w / z, fy h / z)``.
        Boxes partly outside the image are clipped to it.

        Parameters
        ----------
        head_centres : ndarray (N, 3)
            Room-frame head centres; NaN rows are allowed (absent people).
        head_size : (float, float)
            Head width and height in metres.

        Returns
        -------
        ndarray (N, 4)
            ``(left, top, width, height)`` in pixels; a NaN row for heads behind the camera,
            entirely outside the image, or NaN.
        """
        hw, hh = (float(s) for s in head_size)
        if not (hw > 0 and hh > 0 and math.isfinite(hw) and math.isfinite(hh)):
            raise ValueError(f"head_box: head_size must be two positive numbers, got {head_size}")
        uv, depth = self.project(head_centres)
        out = np.full((uv.shape[0], 4), np.nan)
        ok = np.isfinite(uv).all(axis=1)
        z = depth[ok]
        half_w = 0.5 * self.fx * hw / z  # fx (w/2) / z
        half_h = 0.5 * self.fy * hh / z
        left = np.maximum(uv[ok, 0] - half_w, 0.0)
        right = np.minimum(uv[ok, 0] + half_w, float(self.width))
        top = np.maximum(uv[ok, 1] - half_h, 0.0)
        bottom = np.minimum(uv[ok, 1] + half_h, float(self.height))
        boxes = np.column_stack([left, top, right - left, bottom - top])
        boxes[(boxes[:, 2] <= 0) | (boxes[:, 3] <= 0)] = np.nan
        out[ok] = boxes
        return out

    # ------------------------------------------------------------------ JSON

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict (``camera.json`` of a scene directory)."""
        return {
            "fx": self.fx,
            "fy": self.fy,
            "cx": self.cx,
            "cy": self.cy,
            "width": self.width,
            "height": self.height,
            "position": [float(v) for v in self.position],
            "yaw_deg": self.yaw_deg,
            "pitch_deg": self.pitch_deg,
        }

    @classmethod
    def from_json(cls, d: Mapping[str, Any], path: str | Path | None = None) -> PinholeCamera:
        """Camera from a dict as written by :meth:`to_json`; unknown keys are ignored.

        Raises
        ------
        InputError
            (naming ``path``) when ``d`` is not a mapping, a field is missing, not a number,
            or out of range.
        """
        if not isinstance(d, Mapping):
            raise InputError(f"camera: expected a JSON object, got {type(d).__name__}", path)
        missing = [k for k in _JSON_FIELDS if k not in d]
        if missing:
            raise InputError(f"camera: missing field(s) {', '.join(missing)}", path)
        values: dict[str, Any] = {}
        for k in _JSON_FIELDS:
            v = d[k]
            if k == "position":
                ok = (
                    isinstance(v, list | tuple)
                    and len(v) == 3
                    and all(isinstance(x, int | float) and not isinstance(x, bool) for x in v)
                )
                if not ok:
                    raise InputError(
                        f"camera: position must be a list of 3 numbers, got {v!r}", path
                    )
            elif not isinstance(v, int | float) or isinstance(v, bool):
                raise InputError(f"camera: {k} must be a number, got {v!r}", path)
            values[k] = v
        try:
            return cls(**values)
        except ValueError as exc:
            raise InputError(str(exc).replace("PinholeCamera: ", "camera: "), path) from None


def read_camera_file(path: str | Path) -> PinholeCamera:
    """CAMERA.yaml (or .json, a subset of YAML): a :class:`PinholeCamera` in the array's frame,
    with errors naming the file and field."""
    import yaml

    path = Path(path)
    if not path.is_file():
        raise InputError("camera file not found", path)
    try:
        raw = yaml.safe_load(path.read_text())
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise InputError(f"invalid YAML: {str(exc).splitlines()[0]}", path) from None
    if isinstance(raw, Mapping):
        unknown = [str(k) for k in raw if k not in _JSON_FIELDS]
        if unknown:
            hints = []
            for k in unknown:
                close = difflib.get_close_matches(k, _JSON_FIELDS, n=1, cutoff=0.5)
                hints.append(f"{k!r} (did you mean {close[0]!r}?)" if close else repr(k))
            raise InputError(
                f"camera: unknown field(s) {', '.join(hints)}; the fields are "
                f"{', '.join(_JSON_FIELDS)}",
                path,
            )
    return PinholeCamera.from_json(raw, path)
