r"""A calibrated, rectified stereo pair: projection, its Jacobian and triangulation of faces.

Thesis §3.2.5: "The position of the bounding box from the left and right camera images is
combined by means of epipolar geometry, and triangulation to recover 3D face position."

The pair is rectified: both cameras have the intrinsics :math:`K` and the right camera sits
``baseline`` metres along the left camera's x axis, so a point :math:`X = (X_1, X_2, X_3)`
(left-camera frame) projects to

.. math::
    V_L = K\frac{1}{X_3}X \quad\text{(eq. 3.39)},\qquad
    V_R = V_L - \Big(\frac{f_x b}{X_3}, 0\Big),

i.e. on the same image row, shifted left by the disparity :math:`d = f_x b / X_3`.
Triangulation inverts this: :math:`X_3 = f_x b / d`, :math:`X_1 = b (u_L - c_x) / d`,
:math:`X_2 = (f_x/f_y)\, b\, (\bar v - c_y) / d` with :math:`\bar v` the mean row.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from avtrack.io.camera import Intrinsics, PinholeCamera
from avtrack.robot.base import OBS_DIM, FaceObservations

#: Rotation home-camera → room of the canonical :class:`PinholeCamera` (position 0, yaw 0,
#: pitch 0): its rows are the camera's right, down and forward axes in room coordinates.
_CANONICAL_R = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])


def _positive(name: str, value: float) -> float:
    v = float(value)
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"StereoRig: {name} must be a finite number > 0, got {value!r}")
    return v


def _points(name: str, x: np.ndarray, width: int) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.ndim == 1 and a.shape[0] == width:
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] != width:
        raise ValueError(f"{name} must have shape (M, {width}), got {np.shape(x)}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite")
    return a


@dataclass(frozen=True)
class StereoRig(Intrinsics):
    """Rectified stereo pair (left camera = reference), pinhole intrinsics shared.

    Attributes
    ----------
    fx, fy, cx, cy, width, height
        The :class:`~avtrack.io.camera.Intrinsics` of both cameras (pixels).
    baseline : float
        Distance between the optical centres, metres (right camera at ``+baseline`` along x).
    """

    baseline: float

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "baseline", _positive("baseline", self.baseline))

    @classmethod
    def nao(
        cls, baseline: float = 0.1, hfov_deg: float = 60.97, width: int = 640, height: int = 480
    ) -> StereoRig:
        """NAO-like VGA pair: square pixels, centred principal point, NAO's horizontal field
        of view (60.97°) and a configurable baseline."""
        h = float(hfov_deg)
        if not 0 < h < 180:
            raise ValueError(f"StereoRig.nao: hfov_deg must be in (0, 180), got {hfov_deg!r}")
        f = 0.5 * width / math.tan(math.radians(h) / 2)
        return cls(f, f, width / 2, height / 2, width, height, baseline)

    @property
    def centre(self) -> np.ndarray:
        """``(2,)`` image centre ``(width / 2, height / 2)``, pixels."""
        return np.array([self.width / 2, self.height / 2])

    @property
    def K(self) -> np.ndarray:
        """``(2, 3)`` intrinsic matrix of eq. 3.39 (the first two rows of the usual 3×3)."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy]])

    # ------------------------------------------------------------------ projection
    def project(self, points: np.ndarray, camera: str = "left") -> np.ndarray:
        """Pixel coordinates of left-camera-frame ``points (M, 3)``: ``(M, 2)``, NaN for
        points at depth ≤ 0 (thesis eq. 3.39)."""
        if camera not in ("left", "right"):
            raise ValueError(f"camera must be 'left' or 'right', got {camera!r}")
        x = _points("points", points, 3)
        out = np.full((x.shape[0], 2), np.nan)
        front = x[:, 2] > 0
        z = x[front, 2]
        shift = self.baseline if camera == "right" else 0.0
        out[front, 0] = self.fx * (x[front, 0] - shift) / z + self.cx  # V = K X / X_3
        out[front, 1] = self.fy * x[front, 1] / z + self.cy
        return out

    def image_jacobian(self, points: np.ndarray) -> np.ndarray:
        r"""World-to-image Jacobian :math:`J_{wi}(X) = \partial V_L / \partial X` (eq. 3.40).

        .. math::
            J_{wi}(X) = \begin{pmatrix} f_x & 0 \\ 0 & f_y \end{pmatrix}
            \begin{pmatrix} 1/X_3 & 0 & -X_1/X_3^2 \\ 0 & 1/X_3 & -X_2/X_3^2 \end{pmatrix}

        (eq. 3.40 prints ":math:`K` times the 2×3 matrix"; with :math:`K \in R^{2\times3}`
        that product is the one above, the principal point dropping out).

        Parameters
        ----------
        points : ndarray (M, 3)
            Left-camera-frame points with depth > 0.

        Returns
        -------
        ndarray (M, 2, 3)
        """
        x = _points("points", points, 3)
        if np.any(x[:, 2] <= 0):
            raise ValueError("points must have depth X_3 > 0 for the image Jacobian")
        inv_z = 1.0 / x[:, 2]
        jac = np.zeros((x.shape[0], 2, 3))
        jac[:, 0, 0] = self.fx * inv_z  # f_x / X_3
        jac[:, 0, 2] = -self.fx * x[:, 0] * inv_z**2  # -f_x X_1 / X_3²
        jac[:, 1, 1] = self.fy * inv_z
        jac[:, 1, 2] = -self.fy * x[:, 1] * inv_z**2
        return jac

    # ------------------------------------------------------------------ simulation helpers
    def pinhole_cameras(self) -> tuple[PinholeCamera, PinholeCamera]:
        """The left and right cameras as :class:`~avtrack.io.camera.PinholeCamera` in the
        *canonical room*: the frame in which the left camera sits at the origin looking along
        +x with no pitch. Map left-camera-frame points there with :meth:`to_canonical`."""
        left = PinholeCamera(
            self.fx, self.fy, self.cx, self.cy, self.width, self.height, np.zeros(3)
        )
        right_pos = self.to_canonical(np.array([[self.baseline, 0.0, 0.0]]))[0]
        right = PinholeCamera(
            self.fx, self.fy, self.cx, self.cy, self.width, self.height, right_pos
        )
        return left, right

    @staticmethod
    def to_canonical(points: np.ndarray) -> np.ndarray:
        """Left-camera-frame points ``(..., 3)`` in the canonical room of
        :meth:`pinhole_cameras` (``Y = R₀ᵀ X``); NaN rows stay NaN."""
        return np.asarray(points, dtype=float) @ _CANONICAL_R

    # ------------------------------------------------------------------ triangulation
    def triangulate(
        self, left_xy: np.ndarray, right_xy: np.ndarray, max_row_difference: float = np.inf
    ) -> np.ndarray:
        """3-D points from matched left/right pixel coordinates (rectified pair).

        Parameters
        ----------
        left_xy, right_xy : ndarray (M, 2)
            Matched image points ``(u, v)`` in the left and right images, pixels.
        max_row_difference : float
            Largest accepted ``|v_L - v_R|`` (epipolar constraint), pixels.

        Returns
        -------
        ndarray (M, 3)
            Left-camera-frame points, metres.

        Raises
        ------
        ValueError
            Inconsistent stereo input: different numbers of points, a disparity
            ``u_L - u_R <= 0`` (a point at or behind infinity), or rows further apart than
            ``max_row_difference``; the message names the first offending row.
        """
        left = _points("left_xy", left_xy, 2)
        right = _points("right_xy", right_xy, 2)
        if left.shape != right.shape:
            raise ValueError(
                f"inconsistent stereo input: left_xy has {left.shape[0]} points "
                f"but right_xy has {right.shape[0]}"
            )
        disparity = left[:, 0] - right[:, 0]  # d = u_L - u_R
        bad = np.flatnonzero(disparity <= 0)
        if bad.size:
            k = int(bad[0])
            raise ValueError(
                f"inconsistent stereo input: point {k} has disparity u_L - u_R = "
                f"{disparity[k]:.3g} px; it must be > 0 (the right-image point "
                "lies left of the left-image point)"
            )
        rows = np.abs(left[:, 1] - right[:, 1])
        bad = np.flatnonzero(rows > max_row_difference)
        if bad.size:
            k = int(bad[0])
            raise ValueError(
                f"inconsistent stereo input: point {k} violates the epipolar "
                f"constraint, |v_L - v_R| = {rows[k]:.3g} px > "
                f"max_row_difference = {max_row_difference:.3g} px"
            )
        b = self.baseline
        v_bar = 0.5 * (left[:, 1] + right[:, 1])
        z = self.fx * b / disparity  # X_3 = f_x b / d
        x = b * (left[:, 0] - self.cx) / disparity  # X_1 = b (u_L - c_x) / d
        y = (self.fx / self.fy) * b * (v_bar - self.cy) / disparity  # X_2 = (f_x/f_y) b (v̄-c_y)/d
        return np.column_stack([x, y, z])

    def triangulation_covariance(
        self,
        left_xy: np.ndarray,
        right_xy: np.ndarray,
        left_std: np.ndarray,
        right_std: np.ndarray,
    ) -> np.ndarray:
        r"""First-order covariance of :meth:`triangulate`, :math:`J\,\Sigma_{px}J^\top`.

        Parameters
        ----------
        left_xy, right_xy : ndarray (M, 2)
            Matched pixel coordinates (disparity > 0).
        left_std, right_std : ndarray (M, 2)
            Standard deviations of ``(u, v)`` in each image, pixels.

        Returns
        -------
        ndarray (M, 3, 3)
        """
        left = _points("left_xy", left_xy, 2)
        right = _points("right_xy", right_xy, 2)
        sl = _points("left_std", left_std, 2)
        sr = _points("right_std", right_std, 2)
        if not (left.shape == right.shape == sl.shape == sr.shape):
            raise ValueError(
                "left_xy, right_xy, left_std and right_std must have the same "
                f"shape, got {left.shape}, {right.shape}, {sl.shape}, {sr.shape}"
            )
        d = left[:, 0] - right[:, 0]
        if np.any(d <= 0):
            raise ValueError("triangulation_covariance: every disparity must be > 0")
        b, r = self.baseline, self.fx / self.fy
        v_bar = 0.5 * (left[:, 1] + right[:, 1])
        m = left.shape[0]
        # J = ∂(X_1, X_2, X_3) / ∂(u_L, u_R, v̄)
        jac = np.zeros((m, 3, 3))
        jac[:, 0, 0] = b / d - b * (left[:, 0] - self.cx) / d**2
        jac[:, 0, 1] = b * (left[:, 0] - self.cx) / d**2
        jac[:, 1, 0] = -r * b * (v_bar - self.cy) / d**2
        jac[:, 1, 1] = r * b * (v_bar - self.cy) / d**2
        jac[:, 1, 2] = r * b / d
        jac[:, 2, 0] = -self.fx * b / d**2
        jac[:, 2, 1] = self.fx * b / d**2
        var = np.column_stack(
            [sl[:, 0] ** 2, sr[:, 0] ** 2, 0.25 * (sl[:, 1] ** 2 + sr[:, 1] ** 2)]
        )  # var(v̄) = (σ_L²+σ_R²)/4
        cov = np.einsum("mik,mk,mjk->mij", jac, var, jac)  # J Σ Jᵀ
        return 0.5 * (cov + np.swapaxes(cov, 1, 2))


@dataclass(frozen=True)
class StereoMatchConfig:
    """Gates of :func:`match_stereo` and the noise model of :func:`stereo_faces`.

    Attributes
    ----------
    max_row_difference : float
        Largest ``|v_L - v_R|`` as a fraction of the mean box height (epipolar gate).
    depth_range : (float, float)
        Accepted depths (metres): the disparity must lie in ``f_x b / depth_range``.
    max_size_ratio : float
        Largest ratio between the left and right box widths (and heights), ≥ 1.
    centre_std : float
        Standard deviation of a detected box centre as a fraction of the box size.
    size_std : float
        Standard deviation of the box size as a fraction of the size.
    floor_std : float
        Isotropic standard deviation (metres) added to every triangulated position (model
        error: the box centre is not exactly the head centre).
    border : float
        Boxes within this many pixels of the image border are dropped (the face may be cut,
        and a cut box has a biased centre and disparity).
    """

    max_row_difference: float = 0.25
    depth_range: tuple[float, float] = (0.4, 8.0)
    max_size_ratio: float = 1.35
    centre_std: float = 0.05
    size_std: float = 0.1
    floor_std: float = 0.01
    border: float = 1.0

    def __post_init__(self) -> None:
        near, far = (float(v) for v in self.depth_range)
        if not 0 < near < far:
            raise ValueError(
                f"StereoMatchConfig: depth_range must be (near, far) with "
                f"0 < near < far, got {self.depth_range!r}"
            )
        object.__setattr__(self, "depth_range", (near, far))
        for name in ("max_row_difference", "centre_std", "size_std"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"StereoMatchConfig: {name} must be > 0, got {v!r}")
        if not self.max_size_ratio >= 1:
            raise ValueError(
                f"StereoMatchConfig: max_size_ratio must be >= 1, got {self.max_size_ratio!r}"
            )
        if not (self.floor_std >= 0 and self.border >= 0):
            raise ValueError("StereoMatchConfig: floor_std and border must be >= 0")


def _boxes(name: str, boxes: np.ndarray) -> np.ndarray:
    b = np.asarray(boxes, dtype=float).reshape(-1, 4) if np.size(boxes) else np.zeros((0, 4))
    if not np.all(np.isfinite(b)):
        raise ValueError(f"{name} must be finite")
    if b.shape[0] and not np.all(b[:, 2:] > 0):
        raise ValueError(f"{name}: box width and height must be > 0")
    return b


def match_stereo(
    rig: StereoRig,
    left_boxes: np.ndarray,
    right_boxes: np.ndarray,
    config: StereoMatchConfig | None = None,
) -> np.ndarray:
    """Pair left and right face boxes under the epipolar, disparity and size gates.

    Optimal assignment (Hungarian) of the cost ``(Δrow / h̄)² + log²(w_L / w_R)`` over the pairs
    that pass every gate of ``config``.

    Parameters
    ----------
    rig : StereoRig
    left_boxes : ndarray (M_L, 4)
    right_boxes : ndarray (M_R, 4)
        ``(left, top, width, height)``, pixels.
    config : StereoMatchConfig, optional

    Returns
    -------
    ndarray (K, 2) int
        ``(left index, right index)`` pairs, sorted by left index.
    """
    cfg = config or StereoMatchConfig()
    lb, rb = _boxes("left_boxes", left_boxes), _boxes("right_boxes", right_boxes)
    if lb.shape[0] == 0 or rb.shape[0] == 0:
        return np.zeros((0, 2), dtype=np.int64)
    lc = lb[:, :2] + 0.5 * lb[:, 2:]
    rc = rb[:, :2] + 0.5 * rb[:, 2:]
    disparity = lc[:, None, 0] - rc[None, :, 0]  # (M_L, M_R)
    h_mean = 0.5 * (lb[:, None, 3] + rb[None, :, 3])
    row = np.abs(lc[:, None, 1] - rc[None, :, 1]) / h_mean
    log_w = np.log(lb[:, None, 2] / rb[None, :, 2])
    log_h = np.log(lb[:, None, 3] / rb[None, :, 3])
    near, far = cfg.depth_range
    d_min, d_max = rig.fx * rig.baseline / far, rig.fx * rig.baseline / near
    limit = math.log(cfg.max_size_ratio)
    ok = (
        (row <= cfg.max_row_difference)
        & (disparity >= d_min)
        & (disparity <= d_max)
        & (np.abs(log_w) <= limit)
        & (np.abs(log_h) <= limit)
    )
    if not ok.any():
        return np.zeros((0, 2), dtype=np.int64)
    cost = np.where(ok, row**2 + log_w**2, 1e6)
    li, ri = linear_sum_assignment(cost)
    keep = ok[li, ri]
    return np.column_stack([li[keep], ri[keep]]).astype(np.int64)


def stereo_faces(
    rig: StereoRig,
    left_boxes: np.ndarray,
    right_boxes: np.ndarray,
    left_appearance: np.ndarray | None = None,
    right_appearance: np.ndarray | None = None,
    config: StereoMatchConfig | None = None,
) -> FaceObservations:
    r"""3-D face observations from one frame of left/right face boxes (thesis §3.2.5).

    Boxes touching the image border are dropped, the rest are paired by
    :func:`match_stereo`, and each pair gives :math:`o = [X, W]`: the triangulated box centre
    and the mean of the two box sizes, with :math:`\Phi = \mathrm{blockdiag}(J\Sigma J^\top +
    \sigma_0^2 I_3, \mathrm{diag}(\sigma_w^2, \sigma_h^2))` where :math:`J\Sigma J^\top` is
    the first-order triangulation covariance of the centres' pixel noise
    (:meth:`StereoRig.triangulation_covariance`). The appearance of an observation is the mean
    of its two descriptors when both images have them, else the left one.

    Parameters
    ----------
    rig : StereoRig
    left_boxes, right_boxes : ndarray (M_L, 4), (M_R, 4)
        ``(left, top, width, height)``, pixels.
    left_appearance, right_appearance : ndarray (M_L, F), (M_R, F), optional
    config : StereoMatchConfig, optional

    Returns
    -------
    FaceObservations
    """
    cfg = config or StereoMatchConfig()
    lb, rb = _boxes("left_boxes", left_boxes), _boxes("right_boxes", right_boxes)
    la = None if left_appearance is None else np.asarray(left_appearance, dtype=float)
    ra = None if right_appearance is None else np.asarray(right_appearance, dtype=float)
    for name, app, boxes in (("left_appearance", la, lb), ("right_appearance", ra, rb)):
        if app is not None and (app.ndim != 2 or app.shape[0] != boxes.shape[0]):
            raise ValueError(
                f"{name} must have one row per box ({boxes.shape[0]}), got shape {app.shape}"
            )
    inner_l = _inside(lb, rig, cfg.border)
    inner_r = _inside(rb, rig, cfg.border)
    li_all, ri_all = np.flatnonzero(inner_l), np.flatnonzero(inner_r)
    pairs = match_stereo(rig, lb[li_all], rb[ri_all], cfg)
    dim = None if la is None else la.shape[1]
    if pairs.shape[0] == 0:
        return FaceObservations.empty(dim)
    li, ri = li_all[pairs[:, 0]], ri_all[pairs[:, 1]]
    l_box, r_box = lb[li], rb[ri]
    lc = l_box[:, :2] + 0.5 * l_box[:, 2:]
    rc = r_box[:, :2] + 0.5 * r_box[:, 2:]
    positions = rig.triangulate(lc, rc)
    cov_x = rig.triangulation_covariance(
        lc, rc, cfg.centre_std * l_box[:, 2:], cfg.centre_std * r_box[:, 2:]
    )
    cov_x += cfg.floor_std**2 * np.eye(3)
    sizes = 0.5 * (l_box[:, 2:] + r_box[:, 2:])
    m = li.shape[0]
    cov = np.zeros((m, OBS_DIM, OBS_DIM))
    cov[:, :3, :3] = cov_x
    # the mean of two sizes with relative std size_std each
    cov[:, 3, 3], cov[:, 4, 4] = ((cfg.size_std * sizes) ** 2 / 2).T
    app = None
    if la is not None:
        app = la[li] if ra is None else 0.5 * (la[li] + ra[ri])
    return FaceObservations(positions, sizes, cov, app, l_box)


def _inside(boxes: np.ndarray, rig: StereoRig, border: float) -> np.ndarray:
    """``(M,)`` whether each box keeps ``border`` pixels from every image edge."""
    return (
        (boxes[:, 0] >= border)
        & (boxes[:, 1] >= border)
        & (boxes[:, 0] + boxes[:, 2] <= rig.width - border)
        & (boxes[:, 1] + boxes[:, 3] <= rig.height - border)
    )
