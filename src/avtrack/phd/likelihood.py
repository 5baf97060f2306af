"""Audio-visual measurements and likelihoods of the SMC-PHD filters (Liu et al. eqs. 2–3, 10, 13,
21).

**Visual measurements** are image points ``(x, y)`` in pixels (the speaker's mouth, the point
of AV16.3's ``posGT``): face detections where the shared data have them (sequence 45, camera 1;
mouth = box centre + 0.30 box heights, the offset measured in :mod:`avtrack.io.av163`), else
detections synthesised from the ground truth by :class:`SyntheticFaceDetector`, whose miss,
noise and clutter statistics are those of the real face detector on sequence 45 camera 1.
The visual kernel of a particle at position ``p`` for a measurement ``z`` is
``h = exp(-|p - z|^2 / (2 sigma_v^2))``.

**Audio measurements** are DOA azimuths (degrees) of AV16.3's first circular array. A DOA fixes
the vertical half-plane through the array centre; a speaker's mouth is at about the same height
in every sequence, so the 3-D locus of the speaker is the horizontal ray from the array centre,
at mouth height, in the DOA direction. Its image through the camera calibration (projection
``Pmat @ inv(align_mat)`` and lens distortion, :meth:`AV163Camera.project`) is the *DOA line*
(Kilic et al. 2016, ref. [12] of the seed), fitted as a straight line ``n . p = c``
(``|n| = 1``) to the projected ray. The audio kernel of a particle is
``h = exp(-(n . p - c)^2 / (2 sigma_a^2))``: the distance to the line, in pixels.

Facts about the shared files behind the constants (checked in ``tests/phd/test_likelihood.py``):
``Z_doa`` azimuths are counter-clockwise from the room x axis, seen from
:data:`AV163_ARRAY_CENTRE` = (0, 0.4, 0) m of the ``MouthGT3D`` frame (a free fit of centre and
rotation gives (-0.05…-0.07, 0.39…0.46) m and 0.4…3°; at the nominal centre the median error
between a DOA and the nearest mouth azimuth is 1.8° on sequence 24 and 2.2° on sequence 45);
the same azimuths appear in the three cameras' files at the same times. Mouths are
:data:`AV163_MOUTH_HEIGHT` = 0.8 m above the array plane (median of both sequences; 5–95 %:
0.55–0.96 m).

Both filters run on **fused AV measurements** (:func:`pair_measurements`): each visual point
paired with the DOA line passing closest to it (within a gate), the unpaired points and lines
alone. A fused measurement ``r`` is a pair ``(o_r, u_r)`` of 1-based audio and visual indices,
0 for "none"; it plays the role of ``z_k^r`` in eqs. 11–12 and of a label in eqs. 15–25.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import linear_sum_assignment

from avtrack.io.av163 import (
    AV163_ARRAY_CENTRE,
    AV163_MOUTH_HEIGHT,
    FACE_MOUTH_OFFSET,
    IMAGE_SIZE,
    TEMPLATE_MOUTH_OFFSET,
    AV163Camera,
    AV163Sequence,
    load_av163_faces,
)
from avtrack.io.mot import MOTData

# --------------------------------------------------------------------------- one frame


@dataclass(frozen=True)
class AVFrame:
    """Audio-visual measurements of one video frame.

    Attributes
    ----------
    visual : ndarray (U, 2)
        Visual measurements ``z_breve^u``: image points (pixels).
    doa_deg : ndarray (O,)
        Audio measurements ``z_ring^o``: DOA azimuths (degrees).
    lines : ndarray (O, 3)
        The DOA lines ``(n_x, n_y, c)`` with ``n . p = c`` and ``|n| = 1`` (pixels).
    pairs : ndarray (R, 2) int
        Fused measurements ``(o, u)``, 1-based, 0 = that modality absent; never ``(0, 0)``.
    """

    visual: np.ndarray
    doa_deg: np.ndarray
    lines: np.ndarray
    pairs: np.ndarray

    def __post_init__(self) -> None:
        vis = np.asarray(self.visual, dtype=float).reshape(-1, 2)
        doa = np.asarray(self.doa_deg, dtype=float).ravel()
        lines = np.asarray(self.lines, dtype=float).reshape(-1, 3)
        pairs = np.asarray(self.pairs).reshape(-1, 2)
        if not np.all(np.isfinite(vis)):
            raise ValueError("AVFrame: visual must be finite")
        if lines.shape[0] != doa.shape[0]:
            raise ValueError(
                f"AVFrame: lines must have one row per DOA ({doa.shape[0]}), got {lines.shape}"
            )
        if not (np.all(np.isfinite(lines)) and np.all(np.isfinite(doa))):
            raise ValueError("AVFrame: doa_deg and lines must be finite")
        if lines.size and not np.allclose(np.hypot(lines[:, 0], lines[:, 1]), 1.0):
            raise ValueError("AVFrame: line normals (first two columns) must have unit norm")
        if pairs.size and (
            pairs.dtype.kind not in "iu"
            or np.any(pairs < 0)
            or np.any(pairs[:, 0] > doa.shape[0])
            or np.any(pairs[:, 1] > vis.shape[0])
            or np.any(np.all(pairs == 0, axis=1))
        ):
            raise ValueError(
                f"AVFrame: pairs must be integer (o, u) with 0 <= o <= {doa.shape[0]}, "
                f"0 <= u <= {vis.shape[0]}, not both 0; got {pairs.tolist()}"
            )
        object.__setattr__(self, "visual", vis)
        object.__setattr__(self, "doa_deg", doa)
        object.__setattr__(self, "lines", lines)
        object.__setattr__(self, "pairs", pairs.astype(np.int64))

    @property
    def n_pairs(self) -> int:
        return int(self.pairs.shape[0])


# --------------------------------------------------------------------------- DOA lines


def doa_lines(
    camera: AV163Camera,
    align_mat: np.ndarray,
    azimuth_deg: np.ndarray,
    centre: Sequence[float] = AV163_ARRAY_CENTRE,
    height: float = AV163_MOUTH_HEIGHT,
    image_size: tuple[int, int] = IMAGE_SIZE,
    max_range: float = 5.0,
) -> np.ndarray:
    """Image lines of DOA azimuths (the projected horizontal rays at mouth height).

    Parameters
    ----------
    camera : AV163Camera
    align_mat : ndarray (4, 4)
        The sequence's ``align_mat`` (room positions are mapped by its inverse).
    azimuth_deg : ndarray (O,)
        DOAs, counter-clockwise from the room x axis, seen from ``centre``.
    centre : 3 floats
        Array centre (metres, room frame).
    height : float
        Height of the ray above ``centre`` (metres).
    image_size : (width, height)
        The ray is fitted over its part inside the image enlarged by half its size.
    max_range : float
        Farthest ray point used (metres).

    Returns
    -------
    ndarray (O, 3)
        ``(n_x, n_y, c)`` per DOA with ``n . p = c`` and ``|n| = 1``; NaN rows for rays that
        do not reach the enlarged image.
    """
    az = np.deg2rad(np.asarray(azimuth_deg, dtype=float).ravel())
    c0 = np.asarray(centre, dtype=float)
    if c0.shape != (3,):
        raise ValueError(f"doa_lines: centre must be 3 numbers, got {c0.shape}")
    if az.size == 0:
        return np.zeros((0, 3))
    radii = np.linspace(0.2, max_range, 48)
    dirs = np.stack([np.cos(az), np.sin(az)], axis=1)  # (O, 2)
    pts = np.empty((az.size, radii.size, 3))
    pts[..., :2] = c0[:2] + dirs[:, None, :] * radii[None, :, None]
    pts[..., 2] = c0[2] + height
    pix = camera.project(pts.reshape(-1, 3), align_mat).reshape(az.size, radii.size, 2)
    w, h = image_size
    ok = (
        np.all(np.isfinite(pix), axis=2)
        & (pix[..., 0] > -w / 2) & (pix[..., 0] < 1.5 * w)
        & (pix[..., 1] > -h / 2) & (pix[..., 1] < 1.5 * h)
    )  # fmt: skip
    pix = np.where(ok[..., None], pix, 0.0)
    n_ok = ok.sum(axis=1)
    mean = pix.sum(axis=1) / np.maximum(n_ok, 1)[:, None]
    dev = np.where(ok[..., None], pix - mean[:, None, :], 0.0)
    cov = np.einsum("oki,okj->oij", dev, dev)  # scatter of the projected ray
    _, vecs = np.linalg.eigh(cov)
    normal = vecs[:, :, 0]  # smallest eigenvector: total-least-squares normal
    out = np.column_stack([normal, np.einsum("oi,oi->o", normal, mean)])
    out[n_ok < 2] = np.nan
    return out


def line_distance(points: np.ndarray, lines: np.ndarray) -> np.ndarray:
    """Signed distances ``n . p - c`` (pixels) of points ``(N, 2)`` to lines ``(O, 3)``:
    ``(N, O)``."""
    return points @ lines[:, :2].T - lines[:, 2]


# --------------------------------------------------------------------------- kernels


def visual_kernel(points: np.ndarray, visual: np.ndarray, sigma: float) -> np.ndarray:
    """Visual likelihood ``exp(-|p - z|^2 / (2 sigma^2))`` of points ``(N, 2)`` for
    measurements ``(U, 2)``: ``(N, U)`` in (0, 1]."""
    d2 = np.sum((points[:, None, :] - visual[None, :, :]) ** 2, axis=2)
    return np.exp(-0.5 * d2 / sigma**2)


def audio_kernel(points: np.ndarray, lines: np.ndarray, sigma: float) -> np.ndarray:
    """Audio likelihood ``exp(-(n . p - c)^2 / (2 sigma^2))`` of points ``(N, 2)`` for DOA
    lines ``(O, 3)``: ``(N, O)`` in (0, 1]."""
    return np.exp(-0.5 * (line_distance(points, lines) / sigma) ** 2)


def pair_log_kernels(
    points: np.ndarray, frame: AVFrame, sigma_visual: float, sigma_audio: float
) -> tuple[np.ndarray, np.ndarray]:
    """Log audio and visual kernels of each fused measurement.

    Returns
    -------
    log_audio, log_visual : ndarray (N, R)
        ``log h_ring`` and ``log h_breve`` of each point for measurement ``r``'s line and
        visual point; 0 where the measurement has no such part.
    """
    n, pairs = points.shape[0], frame.pairs
    log_a = np.zeros((n, pairs.shape[0]))
    log_v = np.zeros((n, pairs.shape[0]))
    has_a, has_v = pairs[:, 0] > 0, pairs[:, 1] > 0
    if np.any(has_a):
        d = line_distance(points, frame.lines[pairs[has_a, 0] - 1])
        log_a[:, has_a] = -0.5 * (d / sigma_audio) ** 2
    if np.any(has_v):
        z = frame.visual[pairs[has_v, 1] - 1]
        d2 = np.sum((points[:, None, :] - z[None]) ** 2, axis=2)
        log_v[:, has_v] = -0.5 * d2 / sigma_visual**2
    return log_a, log_v


# --------------------------------------------------------------------------- information form


def visual_information(visual: np.ndarray, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """Quadratic form of the visual log-kernels on the state ``[x, y, vx, vy]``.

    ``log h(m) = -1/2 m^T A m + b^T m + const`` with ``A = H^T H / sigma^2`` and
    ``b = H^T z / sigma^2`` (``H`` selects the position).

    Returns
    -------
    A : ndarray (U, 4, 4)
    b : ndarray (U, 4)
    """
    u = visual.shape[0]
    A = np.zeros((u, 4, 4))
    A[:, 0, 0] = A[:, 1, 1] = 1.0 / sigma**2
    b = np.zeros((u, 4))
    b[:, :2] = visual / sigma**2
    return A, b


def audio_information(lines: np.ndarray, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """Quadratic form of the DOA-line log-kernels on the state ``[x, y, vx, vy]``.

    ``log h(m) = -(n . p - c)^2 / (2 sigma^2)``: ``A = n n^T / sigma^2``, ``b = n c / sigma^2``
    (position block).

    Returns
    -------
    A : ndarray (O, 4, 4)
    b : ndarray (O, 4)
    """
    o = lines.shape[0]
    n = lines[:, :2]
    A = np.zeros((o, 4, 4))
    A[:, :2, :2] = n[:, :, None] * n[:, None, :] / sigma**2
    b = np.zeros((o, 4))
    b[:, :2] = n * lines[:, 2:3] / sigma**2
    return A, b


# --------------------------------------------------------------------------- fusion


def pair_measurements(
    visual: np.ndarray, lines: np.ndarray, sigma_audio: float, gate: float = 3.0
) -> np.ndarray:
    """Fused AV measurements: each visual point with the DOA line nearest to it.

    Lines and points are assigned one-to-one (Hungarian algorithm on the point-to-line
    distances in units of ``sigma_audio``), pairs farther than ``gate`` are split.

    Parameters
    ----------
    visual : ndarray (U, 2)
    lines : ndarray (O, 3)
    sigma_audio : float
        Audio kernel width (pixels).
    gate : float
        Largest pairing distance in units of ``sigma_audio``.

    Returns
    -------
    ndarray (R, 2) int
        ``(o, u)`` 1-based: the pairs, then the unpaired points ``(0, u)``, then the unpaired
        lines ``(o, 0)``.
    """
    n_u, n_o = visual.shape[0], lines.shape[0]
    paired: list[tuple[int, int]] = []
    if n_u and n_o:
        cost = np.abs(line_distance(visual, lines)) / sigma_audio  # (U, O)
        rows, cols = linear_sum_assignment(np.minimum(cost, 10 * gate))
        paired = [(c + 1, r + 1) for r, c in zip(rows, cols, strict=True) if cost[r, c] <= gate]
    used_u = {u for _, u in paired}
    used_o = {o for o, _ in paired}
    out = (
        paired
        + [(0, u) for u in range(1, n_u + 1) if u not in used_u]
        + [(o, 0) for o in range(1, n_o + 1) if o not in used_o]
    )
    return np.array(out, dtype=np.int64).reshape(-1, 2)


def make_frame(
    visual: np.ndarray, doa_deg: np.ndarray, lines: np.ndarray, sigma_audio: float,
    gate: float = 3.0,
) -> AVFrame:  # fmt: skip
    """An :class:`AVFrame` with its fused measurements; DOAs whose line misses the image are
    dropped."""
    visual = np.asarray(visual, dtype=float).reshape(-1, 2)
    keep = np.all(np.isfinite(lines), axis=1)
    doa, lines = np.asarray(doa_deg, dtype=float)[keep], lines[keep]
    return AVFrame(visual, doa, lines, pair_measurements(visual, lines, sigma_audio, gate))


# --------------------------------------------------------------------------- visual sources


def face_measurements(faces: MOTData, n_frames: int) -> list[np.ndarray]:
    """Mouth points of face detections, per frame.

    Parameters
    ----------
    faces : MOTData
        Boxes ``(left, top, width, height)`` with 1-based frames (:func:`load_av163_faces`).
    n_frames : int

    Returns
    -------
    list of T ndarray (U_t, 2)
        ``(left + width / 2, top + 0.8 height)`` per detection.
    """
    frames = np.asarray(faces.frames, dtype=np.int64)
    boxes = np.asarray(faces.boxes, dtype=float).reshape(-1, 4)
    mouth = np.column_stack(
        [boxes[:, 0] + boxes[:, 2] / 2, boxes[:, 1] + FACE_MOUTH_OFFSET * boxes[:, 3]]
    )
    return [mouth[frames == t + 1] for t in range(n_frames)]


@dataclass(frozen=True)
class SyntheticFaceDetector:
    """Face detections synthesised from image ground truth.

    Each present person is detected or missed by a two-state Markov chain (misses come in
    bursts, as when a face turns away); a detection is the true point plus Gaussian noise;
    false alarms are Poisson, uniform over the image. The defaults are the statistics of the
    real face detections of AV16.3 sequence 45, camera 1 against ``posGT`` (1875 detections):
    84 % of present person-frames detected, mean run of detected frames 90.6, mean run of
    missed frames 14.7, per-axis error standard deviation (3.2, 1.7) px, 0.0018 false alarms
    per frame.

    Attributes
    ----------
    mean_hit_run, mean_miss_run : float
        Mean lengths (frames) of detected and missed runs.
    noise_std : (float, float)
        Per-axis position noise (pixels).
    clutter_rate : float
        Mean false alarms per frame.
    image_size : (width, height)
    """

    mean_hit_run: float = 90.6
    mean_miss_run: float = 14.7
    noise_std: tuple[float, float] = (3.2, 1.7)
    clutter_rate: float = 0.0018
    image_size: tuple[int, int] = IMAGE_SIZE

    def __post_init__(self) -> None:
        if not (self.mean_hit_run >= 1 and self.mean_miss_run >= 1):
            raise ValueError(
                "SyntheticFaceDetector: mean_hit_run and mean_miss_run must be >= 1 frame, got "
                f"{self.mean_hit_run} and {self.mean_miss_run}"
            )
        if min(self.noise_std) < 0 or self.clutter_rate < 0:
            raise ValueError("SyntheticFaceDetector: noise_std and clutter_rate must be >= 0")

    @property
    def detection_probability(self) -> float:
        """Stationary probability that a present person is detected."""
        return self.mean_hit_run / (self.mean_hit_run + self.mean_miss_run)

    def detect(
        self, positions: np.ndarray, present: np.ndarray, rng: np.random.Generator
    ) -> list[np.ndarray]:
        """Detections per frame.

        Parameters
        ----------
        positions : ndarray (P, T, 2)
            True image points (NaN where absent).
        present : ndarray (T, P) bool
        rng : numpy.random.Generator

        Returns
        -------
        list of T ndarray (U_t, 2)
        """
        p, t = positions.shape[:2]
        if present.shape != (t, p):
            raise ValueError(
                f"SyntheticFaceDetector.detect: present must have shape ({t}, {p}), "
                f"got {present.shape}"
            )
        leave = (1.0 / self.mean_hit_run, 1.0 / self.mean_miss_run)
        state = rng.random(p) < self.detection_probability  # stationary start
        u_switch = rng.random((t, p))
        noise = rng.normal(size=(t, p, 2)) * np.asarray(self.noise_std)
        n_clutter = rng.poisson(self.clutter_rate, size=t)
        w, h = self.image_size
        out = []
        for k in range(t):
            if k:
                flip = u_switch[k] < np.where(state, leave[0], leave[1])
                state = state ^ flip
            det = state & present[k]
            pts = positions[det, k] + noise[k, det]
            if n_clutter[k]:
                pts = np.vstack([pts, rng.random((n_clutter[k], 2)) * (w, h)])
            out.append(pts)
        return out


def add_clutter(
    visual: Sequence[np.ndarray],
    doa_deg: Sequence[np.ndarray],
    rate_visual: float,
    rate_audio: float,
    rng: np.random.Generator,
    image_size: tuple[int, int] = IMAGE_SIZE,
) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Synthetic false alarms for a clutter stress test.

    Per frame, Poisson(``rate_visual``) visual false alarms uniform over the image and
    Poisson(``rate_audio``) DOA outliers uniform in azimuth over [-180, 180) degrees, appended
    to the frame's measurements.

    Parameters
    ----------
    visual : sequence of T ndarray (U_t, 2)
    doa_deg : sequence of T ndarray (O_t,)
    rate_visual, rate_audio : float
        Mean false alarms per frame (>= 0).
    rng : numpy.random.Generator
    image_size : (width, height)

    Returns
    -------
    visual, doa_deg : lists of T arrays
    """
    if len(visual) != len(doa_deg):
        raise ValueError(
            f"add_clutter: visual and doa_deg must have the same number of frames, got "
            f"{len(visual)} and {len(doa_deg)}"
        )
    for name, v in (("rate_visual", rate_visual), ("rate_audio", rate_audio)):
        if not (np.isfinite(v) and v >= 0):
            raise ValueError(f"add_clutter: {name} must be a finite number >= 0, got {v!r}")
    t = len(visual)
    n_v = rng.poisson(rate_visual, size=t)
    n_a = rng.poisson(rate_audio, size=t)
    w, h = image_size
    vis = [np.vstack([np.asarray(z, dtype=float).reshape(-1, 2), rng.random((k, 2)) * (w, h)])
           for z, k in zip(visual, n_v, strict=True)]
    doa = [np.concatenate([np.asarray(d, dtype=float).ravel(), rng.uniform(-180, 180, k)])
           for d, k in zip(doa_deg, n_a, strict=True)]
    return vis, doa


def av163_frames(
    seq: AV163Sequence,
    visual: Sequence[np.ndarray],
    sigma_audio: float,
    gate: float = 3.0,
    centre: Sequence[float] = AV163_ARRAY_CENTRE,
    height: float = AV163_MOUTH_HEIGHT,
    doa_deg: Sequence[np.ndarray] | None = None,
) -> list[AVFrame]:
    """The fused measurements of every frame of an AV16.3 sequence.

    Parameters
    ----------
    seq : AV163Sequence
    visual : sequence of T ndarray (U_t, 2)
        Visual measurements per frame (:func:`face_measurements` or
        :meth:`SyntheticFaceDetector.detect`).
    sigma_audio : float
        Audio kernel width (pixels), for the pairing gate.
    doa_deg : sequence of T ndarray (O_t,), optional
        DOAs to use instead of the sequence's ``z_doa`` (e.g. with :func:`add_clutter`).

    Returns
    -------
    list of T AVFrame
    """
    z_doa = seq.z_doa if doa_deg is None else doa_deg
    if len(visual) != seq.n_frames or len(z_doa) != seq.n_frames:
        raise ValueError(
            f"av163_frames: visual and doa_deg must have one entry per frame ({seq.n_frames}), "
            f"got {len(visual)} and {len(z_doa)}"
        )
    counts = np.array([np.size(z) for z in z_doa])
    all_doa = np.concatenate([np.zeros(0), *[np.ravel(z) for z in z_doa]])
    lines = doa_lines(seq.camera, seq.align_mat, all_doa, centre, height)
    split = np.split(lines, np.cumsum(counts)[:-1])
    return [
        make_frame(visual[k], np.ravel(z_doa[k]), split[k], sigma_audio, gate)
        for k in range(seq.n_frames)
    ]


VISUAL_SOURCES = ("auto", "faces", "synthetic")



def video_measurements(
    video: str | Path,
    seq: AV163Sequence,
    detector,
) -> list[np.ndarray]:
    """Visual measurements of an AV16.3 sequence computed from its video frames.

    The usual detector is :func:`avtrack.av.av163.av163_detector` (same layer, so the caller
    builds it): ``av163_detector(seq)`` gives the mouths of
    :class:`~avtrack.visual.heads.ForegroundHeadDetector` (the tops of the
    exposure-compensated moving foreground, the mouth a head's height below from the camera
    geometry or on the visible face, scored against the sequence's ``hist_temp_16bins``
    templates); ``av163_detector(seq, "templates")`` the colour-histogram measurements of the
    audio-visual SMC-PHD trackers (one window per template and frame).

    Parameters
    ----------
    video : str or Path
        The sequence's video (one frame per ``Timingcam`` row, 360 x 288).
    seq : AV163Sequence
    detector : object with ``detect(frame) -> (boxes, scores)``
        Boxes (left, top, width, height); the points are at the boxes'
        centre columns and ``detector.mouth_offset`` (default :data:`TEMPLATE_MOUTH_OFFSET`)
        of their heights.

    Returns
    -------
    list of T ndarray (U_t, 2)

    Raises
    ------
    InputError
        The video cannot be read, its size is not the calibration's image size, or its frame
        count differs from the sequence's.
    """
    from avtrack.io.av163 import probe_av163_video
    from avtrack.io.video import iter_frames

    info = probe_av163_video(video, seq)
    offset = getattr(detector, "mouth_offset", TEMPLATE_MOUTH_OFFSET)
    out = []
    for frame in iter_frames(video, info):
        boxes, _ = detector.detect(frame)
        b = np.asarray(boxes, dtype=float).reshape(-1, 4)
        out.append(np.column_stack([b[:, 0] + b[:, 2] / 2, b[:, 1] + offset * b[:, 3]]))
    return out


def av163_visual(
    folder: str | Path,
    seq: AV163Sequence,
    source: str = "auto",
    rng: np.random.Generator | None = None,
    detector: SyntheticFaceDetector | None = None,
) -> tuple[list[np.ndarray], str]:
    """Visual measurements of an AV16.3 sequence / camera.

    Parameters
    ----------
    folder : str or Path
        The AV16.3 folder (for ``face_seqNN_camC.mat``).
    seq : AV163Sequence
    source : {"auto", "faces", "synthetic"}
        ``faces``: the face detections (an InputError when the file is missing);
        ``synthetic``: :class:`SyntheticFaceDetector` on the ground truth; ``auto``: faces
        when the file exists, else synthetic.
    rng : numpy.random.Generator
        For the synthetic detections (required then).
    detector : SyntheticFaceDetector, optional

    Returns
    -------
    visual : list of T ndarray (U_t, 2)
    used : str
        ``"faces"`` or ``"synthetic"``.
    """
    if source not in VISUAL_SOURCES:
        raise ValueError(f"av163_visual: source must be one of {VISUAL_SOURCES}, got {source!r}")
    path = Path(folder) / f"face_seq{seq.seq}_cam{seq.cam}.mat"
    if source == "faces" or (source == "auto" and path.is_file()):
        return face_measurements(load_av163_faces(folder, seq.seq, seq.cam), seq.n_frames), "faces"
    if rng is None:
        raise ValueError("av163_visual: rng is required for synthetic detections")
    det = detector or SyntheticFaceDetector()
    return det.detect(seq.positions, seq.present, rng), "synthetic"


def av163_truth(seq: AV163Sequence) -> list[np.ndarray]:
    """Ground-truth image points of the persons present on each frame: list of ``(m_t, 2)``."""
    return [seq.positions[seq.present[t], t] for t in range(seq.n_frames)]
