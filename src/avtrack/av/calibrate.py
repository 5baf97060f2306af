r"""The camera in the microphone array's frame, estimated from the recording itself.

A recording of one's own is tracked in the array's direction space (:mod:`avtrack.av.persons`)
through a :class:`~avtrack.io.camera.PinholeCamera` given *in the array's frame*. People who
talk while the camera sees them tie the two sensors together: the audio direction of a talker
is the direction of one of the head boxes of that frame. :func:`fit_camera` estimates from
these coincidences the camera's yaw, focal length and (when the audio directions carry
elevations) pitch; :func:`check_camera` compares a given camera file with that estimate and
names the likely mistake when they disagree.

Model. The camera sits at ``p`` (array frame, metres; the array's centre unless given), with
no roll, yaw :math:`\psi`, pitch :math:`\theta`, square pixels of focal length :math:`f` and the
principal point at the image centre :math:`(c_x, c_y)`. A head box centred on ``(u, v)`` with
height ``h`` pixels is a head of height ``H`` (:data:`~avtrack.av.geometry.HEAD_HEIGHT_M`) at
the depth :math:`z = f H / h`, i.e. at camera coordinates

.. math::

    X_c = \frac{H}{h}\,(u - c_x,\; v - c_y,\; f), \qquad
    A = R(\psi, \theta)^\top X_c + p,

(``R`` the camera's rotation, rows right, down, forward: :attr:`PinholeCamera.R`), whose
direction from the array is :math:`\mathrm{az} = \operatorname{atan2}(A_y, A_x)`,
:math:`\mathrm{el} = \operatorname{atan2}(A_z, \lVert A_{xy} \rVert)`. An audio direction
``k`` at frame ``t`` is explained by the nearest box of frame ``t``, residual
:math:`r_k = \min_b \operatorname{wrap}(\mathrm{az}_k - \mathrm{az}(b))`, or by none (a talker
out of view, an echo): those are the outliers.

Fit.

1. Exhaustive search (camera at the array's centre, where the yaw only adds to every
   predicted azimuth, or at a position the user measured): yaw every degree, focal lengths of
   horizontal fields of view 20-150 degrees; the score of a hypothesis is the number of audio
   directions within :data:`MATCH_DEG` of a box of their frame, each shared among the boxes
   it matches, less :data:`UNSEEN_TALKER_WEIGHT` for each direction it puts inside the image
   that no box matches; a hypothesis whose matched directions span no more than two match
   windows measures no focal length and is passed over.
2. Least squares with a Cauchy loss from the best hypothesis (``scipy.optimize.least_squares``),
   each audio direction re-associated with its nearest box between rounds; then the inliers
   (residual within 3 robust standard deviations) refitted with a plain quadratic loss.
3. Uncertainty: block bootstrap, the inliers resampled in blocks of :data:`BLOCK_S` seconds
   (consecutive frames of one talker are not independent evidence).

With azimuths only the pitch is hardly observable (it changes a predicted azimuth by a
fraction of a degree for a head near the image's centre row): it is then held (0, or the given
camera's) and reported as not measured, unless the people seen walk towards or away from the
camera: :func:`level_with_horizon` then reads it from the horizon of their heads
(:mod:`avtrack.visual.horizon`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import least_squares

from avtrack.av.geometry import HEAD_HEIGHT_M
from avtrack.io.camera import PinholeCamera
from avtrack.io.doa import wrap_azimuth
from avtrack.io.mot import MOTData
from avtrack.localize.grid import heard_azimuth
from avtrack.visual.horizon import Horizon

#: Residual (degrees) within which an audio direction counts as matching a box in the search.
MATCH_DEG = 4.0

#: Length in seconds of the blocks the bootstrap resamples.
BLOCK_S = 2.0

#: A bias of the audio directions that no fit sees (degrees): about the localizers' error on
#: the real ReSpeaker recordings (2.4-3.2 degrees, BENCHMARKS.md). Directions of the people seen
#: that are heard nearer each other (reverberation pulls them towards the array's axis) fit as
#: well with a longer focal length (:attr:`CameraFit.focal_bias_px`).
AUDIO_BIAS_DEG = 3.0

#: The largest standard deviation (degrees) of a pitch read from the horizon of the heads
#: (:func:`level_with_horizon`) that replaces a held one. The simulated walkouts whose people
#: walk far enough in depth measure it within 2 degrees of the truth (standard deviations
#: 0.3-4.3 degrees), AV16.3 sequence 30 camera 1 within 2 degrees (2.7).
MAX_HORIZON_STD_DEG = 5.0

#: What a direction heard inside a hypothesis's field of view that no box of its frame matches
#: counts against it, in matches (the search with the camera at the array). A wide view that
#: puts a silent person's box on a talker heard out of the view gains every match of that
#: talker; it also leaves the voices of the people it shows unmatched inside it. A fifth of a
#: match: detectors miss people and talkers are hidden. On the simulated seeds 104-123 any
#: weight from 0.05 to 0.35 picks the same cameras (one walkout's 18.9-degree error goes, no
#: other estimate moves); 0.5 takes too narrow a view for one meeting.
UNSEEN_TALKER_WEIGHT = 0.2

#: Fewest audio directions matched to a person in the image for a fit.
MIN_MATCHES = 25

#: Largest number of (audio direction, box) pairs kept (frames thinned evenly beyond it).
MAX_PAIRS = 20000
#: Yaw hypotheses :func:`_search` scores at a time (memory: MAX_PAIRS x this many values).
_YAW_CHUNK = 30


@dataclass(frozen=True)
class CameraEvidence:
    """Candidate pairs (audio direction, head box in the same frame) of a recording.

    Attributes
    ----------
    direction : ndarray (P,) int
        Index of the audio direction of each pair (pairs sorted by it; one direction has as
        many pairs as its frame has boxes).
    azimuth_deg, elevation_deg : ndarray (P,)
        The audio direction (elevation NaN where not measured).
    u, v, h : ndarray (P,)
        The box's centre and height, pixels.
    time_s : ndarray (P,)
    width, height : int
        Image size, pixels.
    n_directions : int
        Audio directions in frames with at least one box.
    line_axis : ndarray (3,) or None
        The axis of a line of microphones (:func:`~avtrack.localize.grid.line_axis`): a box's
        direction is then compared as the line hears it
        (:func:`~avtrack.localize.grid.heard_azimuth`).
    """

    direction: np.ndarray
    azimuth_deg: np.ndarray
    elevation_deg: np.ndarray
    u: np.ndarray
    v: np.ndarray
    h: np.ndarray
    time_s: np.ndarray
    width: int
    height: int
    n_directions: int
    line_axis: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = np.shape(self.direction)[0]
        for name in ("azimuth_deg", "elevation_deg", "u", "v", "h", "time_s"):
            if np.shape(getattr(self, name)) != (n,):
                raise ValueError(f"CameraEvidence: {name} must have shape ({n},), got "
                                 f"{np.shape(getattr(self, name))}")
        if self.width <= 0 or self.height <= 0:
            raise ValueError(f"CameraEvidence: image size must be positive, got "
                             f"{self.width}x{self.height}")

    @property
    def n_pairs(self) -> int:
        return int(self.direction.shape[0])

    @property
    def has_elevation(self) -> bool:
        """Whether enough audio directions carry an elevation to measure the pitch."""
        el = self.elevation_deg
        return bool(np.sum(np.isfinite(el) & (np.abs(el) > 1e-9)) >= MIN_MATCHES)

    def mirrored(self) -> CameraEvidence:
        """The same evidence with every azimuth mirrored (``az -> -az``)."""
        return replace(self, azimuth_deg=wrap_azimuth(-self.azimuth_deg))

    def rotated(self, deg: float) -> CameraEvidence:
        """The same evidence with every azimuth turned by ``deg``."""
        return replace(self, azimuth_deg=wrap_azimuth(self.azimuth_deg + float(deg)))


def camera_evidence(
    detections: MOTData,
    azimuths: list[np.ndarray],
    fps: float,
    image_size: tuple[int, int],
    elevations: list[np.ndarray] | None = None,
    box_height_m: float = HEAD_HEIGHT_M,
    line_axis: np.ndarray | None = None,
) -> CameraEvidence:
    """The pairs (audio direction, box) of a recording.

    Parameters
    ----------
    detections : MOTData
        Head boxes (detections or visual tracks), frames 1-based.
    azimuths : list of ndarray
        Audio directions of each video frame ``0 .. n_frames - 1`` (localizer peaks,
        :func:`~avtrack.av.persons_scene.audio_peaks`, or DOA rows), degrees.
    fps : float
    image_size : (int, int)
        Width and height, pixels.
    elevations : list of ndarray, optional
        Elevations matching ``azimuths`` (NaN: not measured).
    box_height_m : float
        Height in metres of what the boxes outline (a head by default; a face for a face
        detector): the evidence keeps the height of the head box of the same depth.
    line_axis : ndarray (3,), optional
        The array's axis when its microphones are on a line
        (:func:`~avtrack.localize.grid.line_axis`).
    """
    if not (math.isfinite(box_height_m) and box_height_m > 0):
        raise ValueError(f"camera_evidence: box_height_m must be > 0, got {box_height_m!r}")
    if not (math.isfinite(fps) and fps > 0):
        raise ValueError(f"camera_evidence: fps must be > 0, got {fps!r}")
    w, h = (int(s) for s in image_size)
    n_frames = len(azimuths)
    if elevations is not None and len(elevations) != n_frames:
        raise ValueError(f"camera_evidence: elevations cover {len(elevations)} frames, "
                         f"azimuths {n_frames}")
    slices = detections.frame_slices(n_frames)
    frames = [i for i in range(n_frames)
              if len(azimuths[i]) and slices[i].stop > slices[i].start]
    n_pairs = sum(len(azimuths[i]) * (slices[i].stop - slices[i].start) for i in frames)
    if n_pairs > MAX_PAIRS:  # thin the frames evenly
        frames = frames[:: math.ceil(n_pairs / MAX_PAIRS)]
    cols: dict[str, list[np.ndarray]] = {k: [] for k in ("d", "az", "el", "u", "v", "h", "t")}
    k = 0
    for i in frames:
        sl = slices[i]
        b = detections.boxes[sl]
        az = np.asarray(azimuths[i], dtype=float).reshape(-1)
        el = (np.full(az.shape, np.nan) if elevations is None
              else np.asarray(elevations[i], dtype=float).reshape(-1))
        nb = b.shape[0]
        for j in range(az.shape[0]):
            cols["d"].append(np.full(nb, k))
            cols["az"].append(np.full(nb, az[j]))
            cols["el"].append(np.full(nb, el[j]))
            cols["u"].append(b[:, 0] + 0.5 * b[:, 2])
            cols["v"].append(b[:, 1] + 0.5 * b[:, 3])
            cols["h"].append(b[:, 3] * (HEAD_HEIGHT_M / box_height_m))  # head-box height
            cols["t"].append(np.full(nb, i / fps))
            k += 1
    cat = {key: (np.concatenate(v) if v else np.zeros(0)) for key, v in cols.items()}
    ok = np.isfinite(cat["u"]) & np.isfinite(cat["v"]) & (cat["h"] > 0)
    return CameraEvidence(cat["d"][ok].astype(np.int64), cat["az"][ok], cat["el"][ok],
                          cat["u"][ok], cat["v"][ok], cat["h"][ok], cat["t"][ok], w, h, k,
                          None if line_axis is None else np.asarray(line_axis, dtype=float))


def _rotation(yaw_deg: float, pitch_deg: float) -> np.ndarray:
    """Rows right, down, forward of a camera without roll (as :attr:`PinholeCamera.R`)."""
    psi, th = math.radians(yaw_deg), math.radians(pitch_deg)
    cp, sp, ct, st = math.cos(psi), math.sin(psi), math.cos(th), math.sin(th)
    return np.array([[sp, -cp, 0.0], [st * cp, st * sp, -ct], [ct * cp, ct * sp, st]])


def predicted_directions(
    ev: CameraEvidence, yaw_deg: float, pitch_deg: float, focal_px: float,
    position: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Azimuth and elevation (degrees, ``(P,)``) from the array of each pair's box; the
    azimuth as a line of microphones hears it when the evidence has a ``line_axis``."""
    a = _camera_points(ev, focal_px) @ _rotation(yaw_deg, pitch_deg) + position  # Rᵀ X_c + p
    if ev.line_axis is not None:
        az = heard_azimuth(a, ev.line_axis)
    else:
        az = np.degrees(np.arctan2(a[:, 1], a[:, 0]))
    el = np.degrees(np.arctan2(a[:, 2], np.hypot(a[:, 0], a[:, 1])))
    return az, el


def _camera_points(ev: CameraEvidence, focal_px: float) -> np.ndarray:
    """Each pair's head in the camera's frame, ``X_c = (H / h) (u - cx, v - cy, f)``,
    ``(P, 3)`` metres."""
    s = HEAD_HEIGHT_M / np.maximum(ev.h, 1.0)
    return np.column_stack([s * (ev.u - 0.5 * ev.width), s * (ev.v - 0.5 * ev.height),
                            s * focal_px])


def _starts(direction: np.ndarray) -> np.ndarray:
    """First pair of each audio direction (pairs sorted by direction)."""
    return np.flatnonzero(np.r_[True, direction[1:] != direction[:-1]])


def _nearest(ev: CameraEvidence, resid: np.ndarray) -> np.ndarray:
    """Index of the pair with the smallest ``|resid|`` of each audio direction."""
    starts = _starts(ev.direction)
    order = np.lexsort((np.abs(resid), ev.direction))
    return order[starts]


def _search(ev: CameraEvidence, pitch_deg: float,
            position: np.ndarray | None = None) -> tuple[float, float, int]:
    """Yaw and focal length of the hypothesis that explains the most audio directions, and its
    number of matched audio directions (camera at ``position``, default the array's centre).

    A direction matches when a box of its frame is predicted within :data:`MATCH_DEG`; it
    counts ``1 / k`` when ``k`` boxes of its frame are: a camera of a tiny field of view that
    puts every box on the direction heard most gains nothing from matching that direction with
    all of them. (A score of matches less those expected from how often each direction is
    heard fails where people stand still: the true camera puts the boxes exactly where the
    directions are heard, and its matches are then all "expected".)"""
    starts = _starts(ev.direction)
    # each direction's azimuth, unwrapped around the circular mean of all of them
    first = ev.azimuth_deg[starts]
    mean = math.degrees(math.atan2(np.sin(np.radians(first)).sum(),
                                   np.cos(np.radians(first)).sum())) if first.size else 0.0
    heard = wrap_azimuth(first - mean)
    yaws = np.arange(-180.0, 180.0, 1.0)
    pos = np.zeros(3) if position is None else position
    at_centre = not np.any(pos)
    best = (0.0, 1.0, -1)
    best_score = -np.inf
    for hfov in np.arange(20.0, 151.0, 5.0):
        f = 0.5 * ev.width / math.tan(math.radians(hfov) / 2.0)
        if at_centre:  # the yaw only adds to every predicted azimuth
            g, _ = predicted_directions(ev, 0.0, pitch_deg, f, np.zeros(3))
            off = wrap_azimuth(ev.azimuth_deg - g)  # the yaw each pair asks for
        hits, scores = [], []
        for y0 in range(0, yaws.size, _YAW_CHUNK):  # (pairs x yaws arrays, a slice at a time)
            yaw = yaws[y0 : y0 + _YAW_CHUNK]
            if at_centre:
                resid = wrap_azimuth(off[:, None] - yaw[None, :])
            else:
                resid = wrap_azimuth(ev.azimuth_deg[:, None]
                                     - _azimuths_at_yaws(ev, yaw, pitch_deg, f, pos))
            hit = np.abs(resid) < MATCH_DEG
            k = np.add.reduceat(hit.view(np.uint8), starts, axis=0, dtype=np.int64)
            matched = k > 0
            hits.append(matched.sum(axis=0))
            score = (1.0 / np.maximum(k, 1) * matched).sum(axis=0)
            if at_centre:  # heard inside the view where nobody is seen
                inside = (np.abs(wrap_azimuth(first[:, None] - yaw[None, :]))
                          < 0.5 * hfov - MATCH_DEG)
                score -= UNSEEN_TALKER_WEIGHT * (inside & ~matched).sum(axis=0)
            # the directions matched must span more than a match: a field of view so narrow
            # that every box lands on one direction measures no focal length
            span = (np.where(matched, heard[:, None], -np.inf).max(axis=0, initial=-np.inf)
                    - np.where(matched, heard[:, None], np.inf).min(axis=0, initial=np.inf))
            scores.append(np.where(span >= 2.0 * MATCH_DEG, score, -np.inf))
        score = np.concatenate(scores)
        j = int(np.argmax(score))
        if np.isfinite(score[j]) and score[j] > best_score:
            best_score = float(score[j])
            best = (float(yaws[j]), f, int(np.concatenate(hits)[j]))
    return best


def _azimuths_at_yaws(ev: CameraEvidence, yaws: np.ndarray, pitch_deg: float,
                      focal_px: float, position: np.ndarray) -> np.ndarray:
    """Predicted azimuth ``(P, Y)`` (degrees) of each pair's box for a camera at ``position``
    turned to each of ``yaws`` ``(Y,)``: the box's point in the frame of the camera at yaw 0,
    ``B = R(0, pitch)^T X_c``, turned about the vertical, ``A = R_z(yaw) B + p``."""
    b = _camera_points(ev, focal_px) @ _rotation(0.0, pitch_deg)  # (P, 3)
    c, sn = np.cos(np.radians(yaws))[None, :], np.sin(np.radians(yaws))[None, :]
    ax = b[:, :1] * c - b[:, 1:2] * sn + position[0]
    ay = b[:, :1] * sn + b[:, 1:2] * c + position[1]
    if ev.line_axis is None:
        return np.degrees(np.arctan2(ay, ax))
    az = np.broadcast_to(b[:, 2:3] + position[2], ax.shape)
    pts = np.stack([ax, ay, az], axis=-1).reshape(-1, 3)
    return heard_azimuth(pts, ev.line_axis).reshape(ax.shape)


@dataclass(frozen=True)
class CameraFit:
    """A camera estimated from a recording (:func:`fit_camera`).

    Attributes
    ----------
    camera : PinholeCamera
        The estimate, in the array's frame (``fx = fy``, principal point at the image centre).
    yaw_std_deg, pitch_std_deg, focal_std_px : float
        Standard deviations (block bootstrap); ``pitch_std_deg`` NaN when the pitch was held.
    pitch_source : str
        Where the pitch comes from: ``"audio"`` (fitted to the audio directions' elevations),
        ``"heads"`` (the horizon of the people seen walking in depth,
        :func:`level_with_horizon`) or ``"held"`` (0, or the given camera's).
    n_directions : int
        Audio directions in frames with at least one box.
    n_inliers : int
        Audio directions explained by a box.
    residual_deg : float
        RMS azimuth residual of the inliers, degrees.
    focal_bias_px : float
        How far the focal length moves when the audio directions of the people seen are heard
        ``b`` = :data:`AUDIO_BIAS_DEG` nearer each other at their spread ``s`` (the inliers'
        standard deviation of angle from the optical axis): ``f b / (s - b)``, infinite when
        ``s <= b`` (heard further apart, it moves less). Small when the talkers seen span much
        of the image; the bootstrap cannot see it.
    """

    camera: PinholeCamera
    yaw_std_deg: float
    pitch_std_deg: float
    focal_std_px: float
    pitch_source: str
    n_directions: int
    n_inliers: int
    residual_deg: float
    focal_bias_px: float

    @property
    def pitch_fitted(self) -> bool:
        """Whether the pitch was measured (from the audio or the heads) rather than held."""
        return self.pitch_source != "held"

    def summary(self) -> str:
        """One paragraph: the estimate with its uncertainty and the evidence."""
        c = self.camera
        pitch = f"pitch {c.pitch_deg:.1f} deg " + {
            "audio": f"(+-{self.pitch_std_deg:.1f})",
            "heads": f"(+-{self.pitch_std_deg:.1f}, from the horizon of the heads)",
        }.get(self.pitch_source, "(held: the audio directions have no elevation and the "
              "people seen walked too little towards or away from the camera)")
        hfov = 2.0 * math.degrees(math.atan(0.5 * c.width / c.fx))
        return (f"camera in the array's frame: yaw {c.yaw_deg:.1f} deg "
                f"(+-{self.yaw_std_deg:.1f}), {pitch}, focal length {c.fx:.0f} px "
                f"(+-{self.focal_std_px:.0f}; {self.focal_bias_px:+.0f} if the audio "
                f"directions are heard {AUDIO_BIAS_DEG:g} deg nearer each other, as "
                f"reverberation makes them; horizontal field of view {hfov:.0f} deg), from "
                f"{self.n_inliers} of {self.n_directions} audio directions matching a person in "
                f"the image (RMS {self.residual_deg:.1f} deg)")


def _residuals(x: np.ndarray, ev: CameraEvidence, idx: np.ndarray, fit_pitch: bool,
               pitch0: float, position: np.ndarray) -> np.ndarray:
    yaw, logf = x[0], x[1]
    pitch = float(x[2]) if fit_pitch else pitch0
    sub = _take(ev, idx)
    az, el = predicted_directions(sub, yaw, pitch, math.exp(logf), position)
    r = wrap_azimuth(sub.azimuth_deg - az)
    if not fit_pitch:
        return r
    re = sub.elevation_deg - el
    return np.concatenate([r, re[np.isfinite(re)]])


def _take(ev: CameraEvidence, idx: np.ndarray) -> CameraEvidence:
    return replace(ev, direction=ev.direction[idx], azimuth_deg=ev.azimuth_deg[idx],
                   elevation_deg=ev.elevation_deg[idx], u=ev.u[idx], v=ev.v[idx], h=ev.h[idx],
                   time_s=ev.time_s[idx])


def _params(x: np.ndarray, fit_pitch: bool, pitch0: float) -> tuple[float, float, float]:
    """(yaw, pitch, focal) of a parameter vector (yaw, log f[, pitch])."""
    return (float(wrap_azimuth(x[0])), float(np.clip(x[2], -89.0, 89.0)) if fit_pitch
            else pitch0, math.exp(float(x[1])))


def fit_camera(
    ev: CameraEvidence,
    *,
    position: np.ndarray | None = None,
    pitch_deg: float = 0.0,
    fit_pitch: bool | None = None,
    min_matches: int = MIN_MATCHES,
    n_bootstrap: int = 40,
    seed: int = 0,
    start: PinholeCamera | None = None,
    hold_focal: bool = False,
) -> CameraFit:
    """Estimate the camera in the array's frame (see the module docstring).

    Parameters
    ----------
    ev : CameraEvidence
        From :func:`camera_evidence`.
    position : ndarray (3,), optional
        The camera's optical centre in the array's frame, metres (default: the array's centre).
    pitch_deg : float
        The pitch held when it is not fitted (and the start of its fit).
    fit_pitch : bool, optional
        Fit the pitch (default: when the audio directions carry elevations).
    min_matches : int
        Fewest audio directions matching a box for an estimate.
    n_bootstrap : int
        Bootstrap replicas for the uncertainty.
    seed : int
        Seed of the bootstrap.
    start : PinholeCamera, optional
        Start the fit from this camera's yaw and focal length (and ``pitch_deg``) instead of
        the search over hypotheses: to check a given camera.
    hold_focal : bool
        Keep ``start``'s focal length (fit the yaw, and the pitch when fitted): see
        :func:`refine_yaw`.

    Raises
    ------
    ValueError
        When there is too little evidence: too few audio directions coincide with a person in
        the image, or those that do are too close together in the image to measure the focal
        length.
    """
    pos = np.zeros(3) if position is None else np.asarray(position, dtype=float).reshape(3)
    if fit_pitch is None:
        fit_pitch = ev.has_elevation
    if ev.n_pairs == 0:
        raise ValueError(_too_little(0, ev.n_directions, min_matches))
    if start is None:
        if hold_focal:
            raise ValueError("fit_camera: hold_focal needs the camera to start from (start)")
        yaw0, f0, score = _search(ev, pitch_deg, pos)
    else:
        yaw0, f0 = float(start.yaw_deg), float(start.fx)
        at = replace(start, position=pos, pitch_deg=pitch_deg)
        score = round(matched_fraction(ev, at, MATCH_DEG) * ev.n_directions)
    if score < min_matches:
        raise ValueError(_too_little(score, ev.n_directions, min_matches))
    x = np.array([yaw0, math.log(f0)] + ([pitch_deg] if fit_pitch else []))
    # fields of view 170-10°, or the bounds hold log f (least_squares needs lower < upper)
    f_lo, f_hi = ((f0 * (1.0 - 1e-9), f0 * (1.0 + 1e-9)) if hold_focal else
                  (0.5 * ev.width / math.tan(math.radians(a)) for a in (85.0, 5.0)))
    lo = [-np.inf, math.log(f_lo)] + ([-89.0] if fit_pitch else [])
    hi = [np.inf, math.log(f_hi)] + ([89.0] if fit_pitch else [])
    idx = np.zeros(0, dtype=np.int64)
    for _ in range(4):  # associate, fit robustly, re-associate
        yaw, pitch, f = _params(x, fit_pitch, pitch_deg)
        az, _ = predicted_directions(ev, yaw, pitch, f, pos)
        resid = wrap_azimuth(ev.azimuth_deg - az)
        new = _nearest(ev, resid)
        new = new[np.abs(resid[new]) < 4.0 * MATCH_DEG]
        if new.shape[0] < min_matches:
            raise ValueError(_too_little(int(new.shape[0]), ev.n_directions, min_matches))
        if np.array_equal(new, idx):
            break
        idx = new
        sol = least_squares(_residuals, x, bounds=(lo, hi), loss="cauchy",
                            f_scale=MATCH_DEG / 2.0, args=(ev, idx, fit_pitch, pitch_deg, pos))
        x = sol.x
    # inliers: within 3 robust standard deviations (1.4826 MAD), refitted plainly
    r = _residuals(x, ev, idx, False, _params(x, fit_pitch, pitch_deg)[1], pos)
    scale = 1.4826 * float(np.median(np.abs(r)))
    inl = idx[np.abs(r) <= float(np.clip(3.0 * scale, 1.0, 2.5 * MATCH_DEG))]
    if inl.shape[0] < min_matches:
        raise ValueError(_too_little(int(inl.shape[0]), ev.n_directions, min_matches))
    _check_spread(ev, inl)
    args = (ev, inl, fit_pitch, pitch_deg, pos)
    x = least_squares(_residuals, x, bounds=(lo, hi), args=args).x
    r = _residuals(x, *args)[: inl.shape[0]]
    reps = _bootstrap(x, (lo, hi), ev, inl, fit_pitch, pitch_deg, pos, n_bootstrap, seed)
    return _result(x, np.asarray(reps).reshape(-1, x.shape[0]), ev, inl, r, fit_pitch,
                   pitch_deg, pos)


def _result(x: np.ndarray, rep: np.ndarray, ev: CameraEvidence, inl: np.ndarray,
            r: np.ndarray, fit_pitch: bool, pitch_deg: float, pos: np.ndarray) -> CameraFit:
    """:func:`fit_camera`'s estimate ``x`` with the standard deviations of its bootstrap
    replicas ``rep`` ``(R, len(x))``, its inliers ``inl`` and their residuals ``r``."""
    std = rep.std(axis=0, ddof=1) if rep.shape[0] > 1 else np.full(x.shape[0], np.nan)
    yaw, pitch, f = _params(x, fit_pitch, pitch_deg)
    camera = PinholeCamera(f, f, 0.5 * ev.width, 0.5 * ev.height, ev.width, ev.height, pos,
                           yaw, pitch)
    f_std = float(np.std(np.exp(rep[:, 1]), ddof=1)) if rep.shape[0] > 1 else float("nan")
    return CameraFit(
        camera, float(std[0]), float(std[2]) if fit_pitch else float("nan"), f_std,
        "audio" if fit_pitch else "held", ev.n_directions, int(inl.shape[0]),
        float(np.sqrt(np.mean(r**2))),
        _focal_bias(f, ev.u[inl] - 0.5 * ev.width),
    )


def refine_yaw(fit: CameraFit, ev: CameraEvidence, **fit_kw) -> CameraFit:
    """``fit`` with its yaw (and its uncertainty) refitted on other audio directions ``ev`` of
    the same recording, its focal length held.

    A planar array hears a talker above its plane with phase differences that no horizontal
    direction fits, and a map over azimuth alone places them several degrees off to one side
    (2.2 degrees on average on the simulated walkouts); the map over the elevations the array
    can tell apart (:meth:`~avtrack.localize.grid.DirectionGrid.for_array`) removes that
    offset, but its peaks, summed over elevations, spread the people seen further apart or
    nearer each other than the azimuth map's do. So the focal length stays the one ``fit``
    measured on the azimuth map, and the yaw comes from ``ev``, the elevation map's peaks.

    Raises
    ------
    ValueError
        Too little evidence in ``ev`` (as :func:`fit_camera`).
    """
    c = fit.camera
    yaw = fit_camera(ev, position=c.position, pitch_deg=c.pitch_deg, start=c, hold_focal=True,
                     **fit_kw)
    if yaw.pitch_source != "audio":  # the pitch stays fit's, measured or held
        return replace(fit, camera=replace(c, yaw_deg=yaw.camera.yaw_deg),
                       yaw_std_deg=yaw.yaw_std_deg)
    turned = replace(c, yaw_deg=yaw.camera.yaw_deg, pitch_deg=yaw.camera.pitch_deg)
    return replace(fit, camera=turned, yaw_std_deg=yaw.yaw_std_deg,
                   pitch_std_deg=yaw.pitch_std_deg, pitch_source="audio")


def level_with_horizon(fit: CameraFit, ev: CameraEvidence, horizon: Horizon | None,
                       **fit_kw) -> CameraFit:
    """``fit``, whose pitch was held, refitted with the pitch that ``horizon`` gives for its
    focal length (:meth:`~avtrack.visual.horizon.Horizon.pitch_deg`): the search and fit of the
    yaw and focal length again, the pitch held there (with the camera away from the array, a
    pitch turns every predicted azimuth), until the pitch for the new focal length is the one
    held. With azimuths alone the audio hardly sees the pitch (module
    docstring), but the people seen walking towards or away from the camera draw it
    (:mod:`avtrack.visual.horizon`). ``fit`` unchanged when its pitch was measured, when there
    is no horizon, or when the horizon's pitch is less certain than
    :data:`MAX_HORIZON_STD_DEG`.
    """
    if fit.pitch_source != "held" or horizon is None:
        return fit
    c = fit.camera
    std = horizon.pitch_std_deg(c.fx, c.cy)
    if not std <= MAX_HORIZON_STD_DEG:
        return fit
    new = fit
    for _ in range(3):  # the pitch for the focal length, which the pitch moves
        pitch = horizon.pitch_deg(new.camera.fx, c.cy)
        if new is not fit and abs(pitch - new.camera.pitch_deg) < 0.1:
            break
        try:
            new = fit_camera(ev, position=c.position, pitch_deg=pitch, fit_pitch=False,
                             **fit_kw)
        except ValueError:
            return fit
    return replace(new, pitch_std_deg=horizon.pitch_std_deg(new.camera.fx, c.cy),
                   pitch_source="heads")


def _check_spread(ev: CameraEvidence, inl: np.ndarray) -> None:
    """Raise when the inliers ``inl`` lie too close together across the image to measure the
    focal length (within a tenth of its width)."""
    spread = float(np.ptp(ev.u[inl]))
    if spread < 0.1 * ev.width:
        raise ValueError(
            f"too little evidence: the {inl.shape[0]} audio directions that match a person in "
            f"the image all lie within {spread:.0f} px of each other across the image (need "
            f"{0.1 * ev.width:.0f} px, a tenth of its width, to measure the focal length): "
            f"the people seen talking stand in one place of the image")


def _focal_bias(focal_px: float, offset_px: np.ndarray) -> float:
    """:attr:`CameraFit.focal_bias_px` of a focal length whose inliers' boxes lie
    ``offset_px`` ``(N,)`` across from the image centre."""
    spread_deg = float(np.std(np.degrees(np.arctan(offset_px / focal_px))))
    if spread_deg <= AUDIO_BIAS_DEG:
        return math.inf
    return focal_px * AUDIO_BIAS_DEG / (spread_deg - AUDIO_BIAS_DEG)


def _bootstrap(
    x: np.ndarray, bounds: tuple[list[float], list[float]], ev: CameraEvidence,
    inl: np.ndarray, fit_pitch: bool, pitch_deg: float, pos: np.ndarray, n_bootstrap: int,
    seed: int,
) -> list[np.ndarray]:
    """Block bootstrap of the inliers (blocks of ``BLOCK_S``): ``n_bootstrap`` refits from
    ``x``, each yaw unwrapped next to ``x``'s."""
    rng = np.random.default_rng(seed)
    block = np.floor(ev.time_s[inl] / BLOCK_S).astype(np.int64)
    blocks = [np.flatnonzero(block == b) for b in np.unique(block)]
    reps = []
    for _ in range(n_bootstrap):
        pick = rng.integers(0, len(blocks), len(blocks))
        sub = inl[np.concatenate([blocks[j] for j in pick])]
        sol = least_squares(_residuals, x, bounds=bounds,
                            args=(ev, sub, fit_pitch, pitch_deg, pos))
        y = sol.x.copy()
        y[0] = x[0] + float(wrap_azimuth(y[0] - x[0]))
        reps.append(y)
    return reps


def _too_little(n: int, total: int, need: int) -> str:
    return (f"too little evidence to estimate the camera: {n} of {total} audio directions "
            f"match a person in the image (need {need}); it needs people talking while the "
            f"camera sees them")


def matched_fraction(ev: CameraEvidence, camera: PinholeCamera, tol_deg: float) -> float:
    """Fraction of the audio directions within ``tol_deg`` of a box under ``camera``
    (its yaw, pitch, ``fx``, position; principal point and size those of ``ev``)."""
    if ev.n_directions == 0:
        return 0.0
    az, _ = predicted_directions(ev, camera.yaw_deg, camera.pitch_deg, camera.fx,
                                 np.asarray(camera.position))
    resid = np.abs(wrap_azimuth(ev.azimuth_deg - az))
    best = np.minimum.reduceat(resid, _starts(ev.direction)) if ev.n_pairs else np.zeros(0)
    return float(np.sum(best <= tol_deg)) / ev.n_directions


@dataclass(frozen=True)
class CameraCheck:
    """A given camera against the recording (:func:`check_camera`).

    Attributes
    ----------
    fit : CameraFit or None
        The estimate the camera was compared with (None: too little evidence, see ``notes``).
    warnings : tuple of str
        Each likely mistake, with its evidence; empty when the camera agrees.
    notes : tuple of str
        What could not be checked.
    """

    fit: CameraFit | None
    warnings: tuple[str, ...]
    notes: tuple[str, ...] = ()


#: Camera positions farther than this from the array (metres) are read as millimetres.
MM_DISTANCE = 20.0
#: A focal length differing from the recording's fit by more than this fraction is named.
FOCAL_TOLERANCE = 0.3

#: A camera farther than this from the array (metres) is suspected to be in the room's frame
#: when the evidence fits better with it at the array.
ROOM_DISTANCE = 1.0


def _try_fit(ev: CameraEvidence, **kw) -> CameraFit | None:
    try:
        return fit_camera(ev, **kw)
    except ValueError:
        return None


def check_camera(
    camera: PinholeCamera, ev: CameraEvidence, *, name: str = "CAMERA.yaml",
    horizon: Horizon | None = None, **fit_kw
) -> CameraCheck:
    """Compare a camera given in the array's frame with the recording's evidence.

    The recording is fitted (:func:`fit_camera`, with the given camera's position and, when
    the audio has no elevations, its pitch) and, to name the mistake, refitted under the usual
    ones: positions in millimetres (the position divided by 1000), a camera in the room's
    frame (the camera put at the array's centre), swapped microphone channels (every audio
    azimuth mirrored). A difference of yaw, pitch or focal length beyond three standard
    deviations of the fit (and 3 degrees, :data:`FOCAL_TOLERANCE`) is a warning.

    Parameters
    ----------
    camera : PinholeCamera
        The given camera.
    ev : CameraEvidence
    name : str
        How the messages call the camera file.
    horizon : Horizon, optional
        The horizon of the heads (:func:`~avtrack.visual.horizon.estimate_horizon`): when the
        audio has no elevations, the camera's pitch is checked against it (unless its pitch is
        less certain than :data:`MAX_HORIZON_STD_DEG`).
    **fit_kw
        Passed on to :func:`fit_camera`.
    """
    warnings: list[str] = []
    pos = np.asarray(camera.position, dtype=float)
    dist = float(np.linalg.norm(pos))
    if dist > MM_DISTANCE:
        warnings.append(
            f"{name} puts the camera {dist:.0f} m from the array (position "
            f"{_vec(pos)}): are the positions in millimetres rather than metres? (at "
            f"{_vec(pos / 1000.0)} m the audio directions "
            + _match_note(ev, replace(camera, position=pos / 1000.0), camera) + ")")
        pos = pos / 1000.0
        dist /= 1000.0
    kw = {"pitch_deg": camera.pitch_deg, **fit_kw}
    fit = _try_fit(ev, position=pos, **kw)
    if dist > ROOM_DISTANCE:
        fit, room = _far_camera(camera, ev, pos, fit, kw)
        if room is not None:
            warnings.append(
                f"{name} puts the camera {dist:.1f} m from the array, but the audio "
                f"directions of the people seen fit a camera at the array ({room}, at "
                f"{_vec(pos)}): is the camera in the room's frame rather than the array's?")
    mirror = _try_fit(ev.mirrored(), position=pos, **kw)
    beaten = None if mirror is None else _beaten(ev.mirrored(), mirror, ev, fit)
    if beaten is not None:
        warnings.append(
            f"the audio directions of the people seen match the image only mirrored "
            f"({beaten}; mirrored against as recorded): are microphone channels swapped "
            f"(channel k not microphone k of the array), or the array file mirrored?")
        return CameraCheck(mirror, tuple(warnings))
    if fit is None:
        try:
            fit = fit_camera(ev, position=pos, **kw)
        except ValueError as exc:
            return CameraCheck(None, tuple(warnings), (f"{name} not checked: {exc}",))
    est = fit.camera
    dyaw = float(wrap_azimuth(camera.yaw_deg - est.yaw_deg))
    tol = max(3.0 * fit.yaw_std_deg, 3.0)
    if abs(dyaw) > tol and not any("room's frame" in w for w in warnings):
        hint = ("is the camera in the room's frame rather than the array's, or are the "
                "microphone channels rotated (channel k not microphone k of the array)?"
                if dist > ROOM_DISTANCE or abs(camera.pitch_deg) > 30.0 else
                f"are the microphone channels rotated (channel k not microphone k of the "
                f"array), or is the camera in the room's frame rather than the array's? "
                f"(yaw_deg {est.yaw_deg:.1f} would fit)")
        warnings.append(
            f"audio directions of the people seen are {abs(dyaw):.0f} deg "
            f"(+-{fit.yaw_std_deg:.1f}) from where {name} puts them ({name} yaw_deg "
            f"{camera.yaw_deg:.1f}, the recording {est.yaw_deg:.1f}; {fit.n_inliers} audio "
            f"directions): {hint}")
    ratio = camera.fx / est.fx
    # the audio directions' own bias moves the fitted focal length (focal_bias_px; by up to
    # about 20 % on simulated scenes), so only a
    # larger difference (fx for another image size, another zoom) is named
    if abs(ratio - 1.0) > max(3.0 * fit.focal_std_px / est.fx, FOCAL_TOLERANCE):
        warnings.append(
            f"{name} gives the focal length {camera.fx:.0f} px, the recording "
            f"{est.fx:.0f} px (+-{fit.focal_std_px:.0f}): is fx for another image size "
            f"(the video is {ev.width}x{ev.height}) or another lens zoom?")
    fit, pitch_warnings = _check_pitch(camera, fit, horizon, name)
    warnings.extend(pitch_warnings)
    return CameraCheck(fit, tuple(warnings))


def _check_pitch(camera: PinholeCamera, fit: CameraFit, horizon: Horizon | None,
                 name: str) -> tuple[CameraFit, list[str]]:
    """:func:`check_camera`'s pitch: against the audio elevations when ``fit`` measured it,
    else against the heads' ``horizon`` when it is certain enough (its pitch then replaces the
    one ``fit`` held). Returns the fit to report and the warnings."""
    est = fit.camera
    warnings: list[str] = []
    if fit.pitch_fitted:
        dp = camera.pitch_deg - est.pitch_deg
        if abs(dp) > max(3.0 * fit.pitch_std_deg, 3.0):
            warnings.append(
                f"{name} tilts the camera to pitch {camera.pitch_deg:.1f} deg, the audio "
                f"elevations of the people seen to {est.pitch_deg:.1f} deg "
                f"(+-{fit.pitch_std_deg:.1f}): is pitch_deg's sign or the array's up axis "
                f"wrong?")
    elif (horizon is not None
          and horizon.pitch_std_deg(camera.fy, camera.cy) <= MAX_HORIZON_STD_DEG):
        pitch = horizon.pitch_deg(camera.fy, camera.cy)
        std = horizon.pitch_std_deg(camera.fy, camera.cy)
        warnings.extend(_horizon_warning(camera, pitch, std, horizon.row_px, name))
        # the recording's pitch is the horizon's (yaw and focal length fitted at the given one)
        fit = replace(fit, camera=replace(est, pitch_deg=pitch), pitch_std_deg=std,
                      pitch_source="heads")
    return fit, warnings


def _horizon_warning(camera: PinholeCamera, pitch: float, std: float, row: float,
                     name: str) -> list[str]:
    """A warning when ``camera``'s pitch differs from the heads' horizon's ``pitch`` (at the
    camera's own focal length and principal row; standard deviation ``std``, horizon row
    ``row``) by more than three standard deviations and 3 degrees."""
    if not abs(camera.pitch_deg - pitch) > max(3.0 * std, 3.0):
        return []
    hint = ("is pitch_deg's sign wrong? (negative looks down)"
            if abs(camera.pitch_deg + pitch) <= max(3.0 * std, 3.0) else
            f"is pitch_deg wrong? (pitch_deg {pitch:.1f} would fit)")
    return [f"{name} tilts the camera to pitch {camera.pitch_deg:.1f} deg, but the heads of the "
            f"people seen walking towards or away from it meet on the horizon of pitch "
            f"{pitch:.1f} deg (+-{std:.1f}; row {row:.0f}): {hint}"]


def _beaten(
    ev_a: CameraEvidence, a: CameraFit, ev_b: CameraEvidence, b: CameraFit | None
) -> str | None:
    """When fit ``a`` (on ``ev_a``) matches more than 1.25 times the audio directions that
    ``b`` (on ``ev_b``) does, each at the tighter fit's :func:`_tolerance`: the evidence in
    words; else None."""
    tol, m_a, m_b = _shares(ev_a, a, ev_b, b)
    if m_a <= 1.25 * m_b:
        return None
    return (f"{100 * m_a:.0f} % of {ev_a.n_directions} audio directions within {tol:.1f} deg "
            f"of a person, against {100 * m_b:.0f} %")


def _far_camera(
    camera: PinholeCamera, ev: CameraEvidence, pos: np.ndarray, fit: CameraFit | None,
    kw: dict,
) -> tuple[CameraFit | None, str | None]:
    """A given camera metres from the array: the fit started from it where it matches at
    least as many directions as the one searched at its position (the search, a degree and
    5 degrees of field of view apart, can miss a far camera's narrow optimum), then against a
    camera at the array. Returns the fit to compare the
    camera with, and the evidence (None: none) that the camera is in the room's frame."""
    given = _try_fit(ev, position=pos, start=replace(camera, position=pos), **kw)
    if given is not None:
        if fit is None:
            fit = given
        else:
            _, m_given, m_search = _shares(ev, given, ev, fit)
            fit = given if m_given >= m_search else fit
    at_array = _try_fit(ev, position=np.zeros(3), **kw)
    beaten = None if at_array is None else _beaten(ev, at_array, ev, fit)
    return (at_array, beaten) if beaten is not None else (fit, None)


def _tolerance(a: CameraFit, b: CameraFit | None) -> float:
    """The matching tolerance of two rival fits: that of the tighter one (2.5 times its
    residual, between 1.5 degrees and :data:`MATCH_DEG`), so that each is credited with the
    directions it explains as precisely as the better one does."""
    res = a.residual_deg if b is None else min(a.residual_deg, b.residual_deg)
    return float(np.clip(2.5 * res, 1.5, MATCH_DEG))


def _shares(
    ev_a: CameraEvidence, a: CameraFit, ev_b: CameraEvidence, b: CameraFit | None
) -> tuple[float, float, float]:
    """The rivals' :func:`_tolerance` and the shares of the audio directions that ``a`` (on
    ``ev_a``) and ``b`` (on ``ev_b``; 0 without it) match at it."""
    tol = _tolerance(a, b)
    m_b = 0.0 if b is None else matched_fraction(ev_b, b.camera, tol)
    return tol, matched_fraction(ev_a, a.camera, tol), m_b


def _vec(p: np.ndarray) -> str:
    return "[" + ", ".join(f"{v:.3g}" for v in p) + "]"


def _match_note(ev: CameraEvidence, fixed: PinholeCamera, given: PinholeCamera) -> str:
    a = matched_fraction(ev, fixed, MATCH_DEG)
    b = matched_fraction(ev, given, MATCH_DEG)
    return f"match the people seen {100 * a:.0f} % of the time, at the file's {100 * b:.0f} %"
