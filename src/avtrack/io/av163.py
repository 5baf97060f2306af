"""AV16.3 meeting-room recordings as prepared for the audio-visual SMC-PHD trackers.

The files are those distributed with Kilic et al., "Mean-shift and sparse sampling-based
SMC-PHD filtering for audio informed visual speaker tracking", IEEE TMM 2016 (the data family
of Liu et al.'s tables), one folder of MATLAB v5 files per corpus, for sequence ``NN`` and camera
``C``:

- ``data_av_seqNN_camC.mat`` — struct ``Data`` with ``cam`` (the three calibrated cameras),
  ``posGT`` (per-frame image ground truth), ``MouthGT3D`` (3-D mouth positions),
  ``align_mat``, ``Timingcam`` and ``experiment`` (per-speaker DOA);
- ``DOA_measurements_seqNN_camC.mat`` — ``Z_doa``, one cell per video frame with the audio
  DOA measurements (degrees) of the two circular arrays;
- ``hist_temp_16bins_seqNN_camC.mat`` — ``hist_temp``, reference 16×16 colour histograms;
- ``face_seq45_cam1.mat`` — ``face``, per-frame face detections (sequence 45, camera 1 only).

Images are 360×288 pixels at 25 frames per second.

What the files hold, as established on the shared copies (each point is checked by
``tests/io/test_av163.py``):

**Timing.** ``Timingcam`` has rows ``timecode, frame``. The timecode is *not* seconds: it is
``seconds.ff`` with ``ff`` the frame within the second (00–24). It reads 12.12, 12.13, ...,
12.24, 13.00 (steps of 0.01 then 0.76); decoded as ``seconds + ff / 25`` it advances by
exactly 0.04 s per frame. :attr:`AV163Sequence.time_s` holds the decoded times; they are on the
same clock as ``MouthGT3D`` and ``experiment`` (whose time columns advance by 0.04 s and
0.01 s in true seconds).

**Presence.** ``posGT.personK`` rows are ``frame, x, y`` and never contain 0 in the shared
files: while a person is out of view the row holds a stale or off-image position (e.g. x =
-48.2). The absence marker is ``posGT.X_true`` (5 × n_frames × n_persons, uint16, rows
``round(x), 0, round(y), 0, 0``), all zero while the person is absent; the number of non-zero
persons equals ``N_speaker`` on every frame but 16 of seq45 cam2 (a person at the image
border). A person is *present* when its ``X_true`` column is non-zero and its ``(x, y)`` is
not ``(0, 0)``; positions of absent frames are NaN.

**Projection.** A mouth position ``X`` (metres, ``MouthGT3D``) lands on ``posGT`` as
``u = distort(Pmat @ inv(align_mat) @ [X; 1])``, where ``distort`` applies the radial and
tangential lens distortion ``kc = (k1, k2, p1, p2)`` (Bouguet's camera-calibration-toolbox
model) in the normalised coordinates of ``K``, with the mouth sample at time ``t`` matched to
the frame whose decoded time is ``t``. Over all six files the median error is 0.25–0.30 px
(90th percentile 1.1–5.6 px); without ``inv(align_mat)`` it is 1.3–1.7 px, without the
distortion 1.7–2.9 px, and one frame of time offset gives 1.2–2.1 px. See
:meth:`AV163Camera.project` and :meth:`AV163Sequence.project_mouth`.

**Face boxes.** Rows of ``face`` are ``x1, y1, x2, y2, score``: two corners (top-left,
bottom-right) in pixels and a detector score (0.04–17.8, not a probability). Evidence, over
the 1875 detections of seq45 cam1: ``x2 > x1`` and ``y2 > y1`` on every row; the corner reading
gives face-sized boxes (median 18 × 25 px), their centres lie a median 8.2 px from the nearest
mouth ground truth (97 % within 15 px), the mouth sits at the box's horizontal centre (median
offset 0.9 px) and 0.30 box heights below its centre, and 99.5 % of the matched mouths fall
inside the box. Read as ``left, top, width, height`` instead, the boxes would be 70–350 px
wide and the centre-to-mouth distance would be 84 px. :func:`load_av163_faces` returns them as
MOTChallenge ``(left, top, width, height)``.

**Histograms.** ``hist_temp`` holds 10 cells; the first ``n_persons`` are float 16×16
histograms summing to 1 (one per person); the others are uint8 one-hot placeholders.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import scipy.io

from avtrack.errors import InputError
from avtrack.io.camera import PinholeCamera
from avtrack.io.mot import MOTData

FRAME_RATE = 25
IMAGE_SIZE = (360, 288)
_PERSON = re.compile(r"person(\d+)$")


# --------------------------------------------------------------------------- data types


#: Centre of AV16.3 microphone array 1 in the ``MouthGT3D`` room frame (metres).
AV163_ARRAY_CENTRE = (0.0, 0.4, 0.0)
#: Height of the speakers' mouths above the array plane (metres).
AV163_MOUTH_HEIGHT = 0.8
#: Mouth position in a face box (x1, y1, x2, y2): horizontal centre, 0.8 box heights down.
FACE_MOUTH_OFFSET = 0.8
#: Mouth point in a colour-template window: horizontal centre, this fraction of the height
#: down (the offset that fits ``posGT`` best on sequence 30, camera 1).
TEMPLATE_MOUTH_OFFSET = 0.69

@dataclass(frozen=True)
class AV163Camera:
    """One calibrated AV16.3 camera.

    Attributes
    ----------
    pmat : ndarray (3, 4)
        Projection matrix ``Pmat`` from the calibration frame to undistorted pixels.
    K : ndarray (3, 3)
        Intrinsic matrix.
    kc : ndarray (4,) or (5,)
        Distortion ``(k1, k2, p1, p2[, k3])`` of Bouguet's calibration toolbox.
    alpha_c : float
        Skew coefficient, as stored (its effect is already in ``K[0, 1]``).
    """

    pmat: np.ndarray
    K: np.ndarray
    kc: np.ndarray
    alpha_c: float

    def __post_init__(self) -> None:
        for name, shape in (("pmat", (3, 4)), ("K", (3, 3))):
            arr = np.asarray(getattr(self, name), dtype=float)
            if arr.shape != shape:
                raise ValueError(f"AV163Camera: {name} must have shape {shape}, got {arr.shape}")
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"AV163Camera: {name} must be finite")
            object.__setattr__(self, name, arr)
        kc = np.asarray(self.kc, dtype=float).ravel()
        if kc.shape not in ((4,), (5,)) or not np.all(np.isfinite(kc)):
            raise ValueError(f"AV163Camera: kc must be 4 or 5 finite numbers, got {kc}")
        object.__setattr__(self, "kc", kc)
        object.__setattr__(self, "alpha_c", float(self.alpha_c))

    def distort(self, pixels: np.ndarray) -> np.ndarray:
        """Apply the lens distortion to undistorted pixel positions ``(N, 2)``."""
        pix = np.asarray(pixels, dtype=float).reshape(-1, 2)
        # normalised coordinates: [x, y, 1] = K^-1 [u, v, 1]
        norm = np.linalg.solve(self.K, np.column_stack([pix, np.ones(len(pix))]).T)
        x, y = norm[0] / norm[2], norm[1] / norm[2]
        k1, k2, p1, p2 = self.kc[:4]
        k3 = self.kc[4] if self.kc.size == 5 else 0.0
        r2 = x * x + y * y
        radial = 1 + k1 * r2 + k2 * r2**2 + k3 * r2**3  # 1 + k1 r^2 + k2 r^4 + k3 r^6
        xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)  # + tangential (Brown)
        yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
        out = self.K @ np.vstack([xd, yd, np.ones_like(xd)])
        return (out[:2] / out[2]).T

    def project(
        self, points: np.ndarray, align_mat: np.ndarray | None = None, distort: bool = True
    ) -> np.ndarray:
        """Image positions of 3-D points.

        ``u = distort(Pmat @ inv(align_mat) @ [X; 1])`` (the recipe verified on the shared
        files, see the module docstring).

        Parameters
        ----------
        points : ndarray (N, 3)
            Room positions in metres (the ``MouthGT3D`` frame).
        align_mat : ndarray (4, 4), optional
            The sequence's ``align_mat``; its inverse maps room positions to the camera
            calibration frame. ``None`` projects the points as they are.
        distort : bool
            Apply the lens distortion (``posGT`` is in distorted image pixels).

        Returns
        -------
        ndarray (N, 2)
            Pixels; NaN for points at or behind the camera.
        """
        pts = np.asarray(points, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise ValueError(
                f"AV163Camera.project: points must have shape (N, 3), got {pts.shape}"
            )
        homog = np.column_stack([pts, np.ones(len(pts))]).T
        if align_mat is not None:
            align = np.asarray(align_mat, dtype=float)
            if align.shape != (4, 4):
                raise ValueError(
                    f"AV163Camera.project: align_mat must have shape (4, 4), got {align.shape}"
                )
            homog = np.linalg.solve(align, homog)  # X_cal = align_mat^-1 X
        uvw = self.pmat @ homog  # [u, v, w] = Pmat X_cal
        with np.errstate(divide="ignore", invalid="ignore"):
            pix = (uvw[:2] / uvw[2]).T
        pix[uvw[2] <= 0] = np.nan
        if distort:
            ok = np.all(np.isfinite(pix), axis=1)
            pix[ok] = self.distort(pix[ok])
        return pix

    def decompose(self, align_mat: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The camera in the ``MouthGT3D`` room frame: ``Pmat @ inv(align_mat) = K [R | -R C]``.

        Parameters
        ----------
        align_mat : ndarray (4, 4)
            The sequence's ``align_mat``.

        Returns
        -------
        K : ndarray (3, 3)
            Intrinsics, scaled to ``K[2, 2] = 1``.
        R : ndarray (3, 3)
            Rotation room -> camera (rows: the camera's x right, y down and z forward axes in
            room coordinates), a proper rotation (``det R = +1``).
        centre : ndarray (3,)
            Optical centre ``C``, metres, room frame.
        """
        import cv2

        align = np.asarray(align_mat, dtype=float)
        if align.shape != (4, 4):
            raise ValueError(
                f"AV163Camera.decompose: align_mat must have shape (4, 4), got {align.shape}"
            )
        proj = self.pmat @ np.linalg.inv(align)  # room -> undistorted pixels
        K, R, c_h = cv2.decomposeProjectionMatrix(proj)[:3]
        K = K / K[2, 2]
        if np.linalg.det(R) < 0:  # a mirrored decomposition: flip it back
            R, K = -R, -K
        return K, R, c_h[:3, 0] / c_h[3, 0]


@dataclass(frozen=True)
class AV163Mouth:
    """3-D mouth ground truth of one person (``MouthGT3D.personK``).

    Attributes
    ----------
    time_s : ndarray (n,)
        Seconds, on the clock of :attr:`AV163Sequence.time_s`.
    flag : ndarray (n,) int
        The file's flag column (1 on every row of the shared files).
    xyz : ndarray (n, 3)
        Mouth position in metres, room frame.
    """

    time_s: np.ndarray
    flag: np.ndarray
    xyz: np.ndarray

    def __post_init__(self) -> None:
        n = np.asarray(self.time_s).shape[0]
        object.__setattr__(self, "time_s", np.asarray(self.time_s, dtype=float).reshape(n))
        object.__setattr__(self, "flag", np.asarray(self.flag, dtype=np.int64).reshape(n))
        object.__setattr__(self, "xyz", np.asarray(self.xyz, dtype=float).reshape(n, 3))


@dataclass(frozen=True)
class AV163Sequence:
    """One AV16.3 sequence seen from one camera, with its audio measurements.

    ``T`` is the number of video frames, ``P`` the number of persons.

    Attributes
    ----------
    seq, cam : int
        Sequence number and camera (1, 2 or 3).
    cameras : tuple of 3 AV163Camera
        All three calibrated cameras (``cameras[cam - 1]`` is this one, see :attr:`camera`).
    align_mat : ndarray (4, 4)
        Maps calibration-frame positions to the ``MouthGT3D`` room frame.
    frames : ndarray (T,) int
        1-based frame numbers (``Timingcam`` column 2).
    timecode : ndarray (T,)
        ``Timingcam`` column 1 as stored (``seconds.ff``).
    time_s : ndarray (T,)
        Decoded frame times in seconds, ``seconds + ff / 25``.
    n_speakers : ndarray (T,) int
        ``posGT.N_speaker``: number of persons in view.
    present : ndarray (T, P) bool
        Person in view (see the module docstring).
    positions : ndarray (P, T, 2)
        Image ground truth ``(x, y)`` in pixels (mouth / head), NaN where absent.
    mouth : tuple of P AV163Mouth
        3-D mouth ground truth per person.
    doa_gt, doa_measured : tuple of ndarray (n_k, 2)
        Per speaker ``experiment.ExGTk`` / ``ExDatak``: rows ``time_s, azimuth_deg``.
    z_doa : tuple of T ndarray (m_t,)
        Audio DOA measurements of each frame in degrees (``Z_doa``), 0–3 per frame.
    histograms : ndarray (H, 16, 16)
        ``hist_temp`` reference colour histograms.
    histogram_is_placeholder : ndarray (H,) bool
        True for the integer one-hot placeholder cells.
    """

    seq: int
    cam: int
    cameras: tuple[AV163Camera, ...]
    align_mat: np.ndarray
    frames: np.ndarray
    timecode: np.ndarray
    time_s: np.ndarray
    n_speakers: np.ndarray
    present: np.ndarray
    positions: np.ndarray
    mouth: tuple[AV163Mouth, ...]
    doa_gt: tuple[np.ndarray, ...]
    doa_measured: tuple[np.ndarray, ...]
    z_doa: tuple[np.ndarray, ...]
    histograms: np.ndarray
    histogram_is_placeholder: np.ndarray

    def __post_init__(self) -> None:
        t = np.asarray(self.frames).shape[0]
        present = np.asarray(self.present, dtype=bool)
        if present.ndim != 2 or present.shape[0] != t:
            raise ValueError(
                f"AV163Sequence: present must have shape ({t}, P), got {present.shape}"
            )
        p = present.shape[1]
        positions = np.asarray(self.positions, dtype=float)
        if positions.shape != (p, t, 2):
            raise ValueError(
                f"AV163Sequence: positions must have shape ({p}, {t}, 2), got {positions.shape}"
            )
        if not np.all(np.isfinite(positions[present.T])):
            raise ValueError("AV163Sequence: positions must be finite where present")
        for name in ("timecode", "time_s", "n_speakers"):
            if np.asarray(getattr(self, name)).shape != (t,):
                raise ValueError(f"AV163Sequence: {name} must have shape ({t},)")
        if len(self.z_doa) != t:
            raise ValueError(f"AV163Sequence: z_doa must have {t} entries, got {len(self.z_doa)}")
        if len(self.mouth) != p:
            raise ValueError(f"AV163Sequence: mouth must have {p} entries, got {len(self.mouth)}")
        if not 1 <= self.cam <= len(self.cameras):
            raise ValueError(
                f"AV163Sequence: cam must be in 1..{len(self.cameras)}, got {self.cam}"
            )
        object.__setattr__(self, "present", present)
        object.__setattr__(self, "positions", positions)
        object.__setattr__(self, "frames", np.asarray(self.frames, dtype=np.int64))
        object.__setattr__(self, "n_speakers", np.asarray(self.n_speakers, dtype=np.int64))

    @property
    def n_frames(self) -> int:
        return int(self.frames.shape[0])

    @property
    def n_persons(self) -> int:
        return int(self.present.shape[1])

    @property
    def camera(self) -> AV163Camera:
        """The camera this sequence's image ground truth refers to."""
        return self.cameras[self.cam - 1]

    def frame_index(self, times: np.ndarray) -> np.ndarray:
        """0-based index of the frame at each time (seconds), -1 when none is within 20 ms."""
        t = np.asarray(times, dtype=float)
        idx = np.rint((t - self.time_s[0]) * FRAME_RATE).astype(np.int64)
        ok = (idx >= 0) & (idx < self.n_frames)
        ok[ok] &= np.abs(self.time_s[idx[ok]] - t[ok]) < 0.5 / FRAME_RATE
        return np.where(ok, idx, -1)

    def mouth_azimuths(self, centre: np.ndarray) -> np.ndarray:
        """Azimuth (degrees, counter-clockwise from the room's x axis) of each person's mouth
        seen from ``centre`` (3,) metres, e.g. :data:`AV163_ARRAY_CENTRE`: ``(P, T)``, NaN on
        frames without a mouth sample."""
        out = np.full((self.n_persons, self.n_frames), np.nan)
        for p in range(self.n_persons):
            idx = self.frame_index(self.mouth[p].time_s)
            d = self.mouth[p].xyz[idx >= 0] - np.asarray(centre, dtype=float).reshape(3)
            out[p, idx[idx >= 0]] = np.degrees(np.arctan2(d[:, 1], d[:, 0]))
        return out

    def project_mouth(self, person: int, distort: bool = True) -> np.ndarray:
        """3-D mouth ground truth of ``person`` (0-based) projected into this camera.

        Returns
        -------
        ndarray (T, 2)
            Pixels per frame; NaN on frames without a mouth sample.
        """
        if not 0 <= person < self.n_persons:
            raise ValueError(
                f"project_mouth: person must be in 0..{self.n_persons - 1}, got {person}"
            )
        mouth = self.mouth[person]
        out = np.full((self.n_frames, 2), np.nan)
        idx = self.frame_index(mouth.time_s)
        keep = idx >= 0
        out[idx[keep]] = self.camera.project(mouth.xyz[keep], self.align_mat, distort)
        return out


# --------------------------------------------------------------------------- MAT helpers


def _loadmat(path: Path, variable: str) -> Any:
    if not path.is_file():
        raise InputError("file not found" if not path.exists() else "not a regular file", path)
    try:
        mat = scipy.io.loadmat(path, squeeze_me=True, struct_as_record=False)
    except Exception as exc:  # scipy raises several types for a damaged file
        raise InputError(f"cannot read as a MATLAB file: {exc}", path) from None
    if variable not in mat:
        found = sorted(k for k in mat if not k.startswith("__"))
        raise InputError(f"no variable {variable!r} (found {found})", path)
    return mat[variable]


def _field(parent: Any, dotted: str, path: Path) -> Any:
    """Attribute ``dotted``'s last component of ``parent``, or an InputError naming
    ``dotted`` (the full field name, e.g. ``Data.posGT.person1``)."""
    name = dotted.rsplit(".", 1)[-1]
    if not hasattr(parent, name):
        raise InputError(f"missing field {dotted}", path)
    return getattr(parent, name)


def _numeric(
    value: Any, name: str, path: Path, shape: tuple[int | None, ...], finite: bool = True
) -> np.ndarray:
    """``value`` as a float array of ``shape`` (None = any size), else InputError."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name} is not numeric", path) from None
    if len(shape) == 2 and arr.ndim == 1 and shape[1] is not None and arr.size == shape[1]:
        arr = arr.reshape(1, -1)  # a single row squeezed by loadmat
    if arr.ndim != len(shape) or any(
        s is not None and s != a for s, a in zip(shape, arr.shape, strict=True)
    ):
        want = "×".join("n" if s is None else str(s) for s in shape)
        raise InputError(f"{name} must be {want}, got shape {arr.shape}", path)
    if finite and not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        where = f" row {bad[0] + 1}" if arr.ndim >= 1 else ""
        raise InputError(f"{name}{where} holds a NaN or inf", path)
    return arr


def _cells(value: Any) -> list[Any]:
    """The cells of a MATLAB cell array read with ``squeeze_me`` (a 1-cell array is squeezed
    to its content)."""
    if isinstance(value, np.ndarray) and value.dtype == object:
        return list(value.ravel())
    return [value]


def _numbered(obj: Any, pattern: re.Pattern[str]) -> list[tuple[int, str]]:
    names = getattr(obj, "_fieldnames", [])
    out = [(int(m.group(1)), n) for n in names if (m := pattern.match(n))]
    return sorted(out)


def _check_seq_cam(seq: int, cam: int) -> None:
    if isinstance(seq, bool) or not isinstance(seq, int | np.integer) or seq < 1:
        raise ValueError(f"seq must be a positive integer, got {seq!r}")
    if isinstance(cam, bool) or not isinstance(cam, int | np.integer) or cam not in (1, 2, 3):
        raise ValueError(f"cam must be 1, 2 or 3, got {cam!r}")


def decode_timecode(timecode: np.ndarray) -> np.ndarray:
    """Seconds from AV16.3 ``seconds.ff`` timecodes (``ff`` = frame 0–24 at 25 fps).

    Raises
    ------
    ValueError
        A value whose hundredths are not an integer frame 0–24.
    """
    tc = np.asarray(timecode, dtype=float)
    sec = np.floor(tc + 1e-9)
    ff = (tc - sec) * 100
    ffr = np.rint(ff)
    bad = (np.abs(ff - ffr) > 1e-4) | (ffr < 0) | (ffr >= FRAME_RATE) | ~np.isfinite(tc)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise ValueError(
            f"row {i + 1}: {float(tc.flat[i])!r} is not a seconds.ff timecode (ff = frame 00-24)"
        )
    return sec + ffr / FRAME_RATE


# --------------------------------------------------------------------------- readers


def _camera(obj: Any, k: int, path: Path) -> AV163Camera:
    name = f"Data.cam[{k}]"
    fields = {f: _field(obj, f"{name}.{f}", path) for f in ("Pmat", "K", "kc", "alpha_c")}
    kc = _numeric(fields["kc"], f"{name}.kc", path, (None,))
    if kc.size not in (4, 5):
        raise InputError(f"{name}.kc must hold 4 or 5 numbers, got {kc.size}", path)
    return AV163Camera(
        pmat=_numeric(fields["Pmat"], f"{name}.Pmat", path, (3, 4)),
        K=_numeric(fields["K"], f"{name}.K", path, (3, 3)),
        kc=kc,
        alpha_c=float(_numeric(fields["alpha_c"], f"{name}.alpha_c", path, ())),
    )


def load_av163_doa(folder: str | Path, seq: int, cam: int) -> tuple[np.ndarray, ...]:
    """Per-frame audio DOA measurements ``Z_doa`` of ``DOA_measurements_seqNN_camC.mat``.

    Returns
    -------
    tuple of ndarray (m_t,)
        One entry per video frame, each a 1-D array of 0–3 azimuths in degrees.
    """
    _check_seq_cam(seq, cam)
    path = Path(folder) / f"DOA_measurements_seq{seq}_cam{cam}.mat"
    out = []
    for i, cell in enumerate(_cells(_loadmat(path, "Z_doa"))):
        try:
            arr = np.atleast_1d(np.asarray(cell, dtype=float)).ravel()
        except (TypeError, ValueError):
            raise InputError(f"Z_doa cell {i + 1} is not numeric", path) from None
        if not np.all(np.isfinite(arr)):
            raise InputError(f"Z_doa cell {i + 1} (frame {i + 1}) holds a NaN or inf", path)
        out.append(arr)
    return tuple(out)


def load_av163_histograms(folder: str | Path, seq: int, cam: int) -> tuple[np.ndarray, np.ndarray]:
    """Reference colour histograms ``hist_temp`` of ``hist_temp_16bins_seqNN_camC.mat``.

    Returns
    -------
    histograms : ndarray (H, 16, 16)
    is_placeholder : ndarray (H,) bool
        True for cells stored as integers with a single 1 (placeholders, not histograms).
    """
    _check_seq_cam(seq, cam)
    path = Path(folder) / f"hist_temp_16bins_seq{seq}_cam{cam}.mat"
    cells = _cells(_loadmat(path, "hist_temp"))
    hists, placeholder = [], []
    for i, cell in enumerate(cells):
        arr = np.asarray(cell)
        h = _numeric(arr, f"hist_temp cell {i + 1}", path, (16, 16))
        if np.any(h < 0):
            raise InputError(f"hist_temp cell {i + 1} has negative bins", path)
        hists.append(h)
        placeholder.append(arr.dtype.kind in "iub" and np.count_nonzero(h) == 1)
    return np.array(hists).reshape(-1, 16, 16), np.array(placeholder, dtype=bool)


def _timing(data, path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``Data.Timingcam`` ``(T, 2)``, its times in seconds ``(T,)`` and frame numbers ``(T,)``."""
    timing = _numeric(_field(data, "Data.Timingcam", path), "Data.Timingcam", path, (None, 2))
    try:
        time_s = decode_timecode(timing[:, 0])
    except ValueError as exc:
        raise InputError(f"Data.Timingcam {exc}", path) from None
    frames = timing[:, 1]
    if np.any(frames != np.rint(frames)) or np.any(np.diff(frames) <= 0) or frames[0] < 1:
        raise InputError("Data.Timingcam frame numbers must be increasing integers >= 1", path)
    return timing, time_s, frames


def _ground_truth(data, path: Path, frames: np.ndarray):
    """``Data.posGT``: the ``personK`` fields, the number of speakers ``(T,)``, who is present
    ``(T, P)`` and the image positions ``(P, T, 2)`` (NaN where absent)."""
    t = frames.shape[0]
    pos_gt = _field(data, "Data.posGT", path)
    n_spk = _numeric(
        _field(pos_gt, "Data.posGT.N_speaker", path), "Data.posGT.N_speaker", path, (t,)
    )
    persons = _numbered(pos_gt, _PERSON)
    if not persons:
        raise InputError("Data.posGT has no personK fields", path)
    p = len(persons)
    positions = np.empty((p, t, 2))
    present = np.ones((t, p), dtype=bool)
    for k, (_, name) in enumerate(persons):
        rows = _numeric(getattr(pos_gt, name), f"Data.posGT.{name}", path, (t, 3))
        if np.any(rows[:, 0] != frames):
            i = int(np.argmax(rows[:, 0] != frames))
            raise InputError(
                f"Data.posGT.{name} row {i + 1}: frame {rows[i, 0]:g} differs "
                f"from Data.Timingcam frame {frames[i]:g}",
                path,
            )
        positions[k] = rows[:, 1:3]
        present[:, k] = ~np.all(rows[:, 1:3] == 0, axis=1)  # (0, 0) = absent
    if hasattr(pos_gt, "X_true"):
        x_true = _numeric(
            pos_gt.X_true, "Data.posGT.X_true", path, (None, t, p) if p > 1 else (None, t)
        )
        x_true = x_true.reshape(x_true.shape[0], t, p)
        present &= np.any(x_true != 0, axis=0)  # all-zero state = absent
    positions[~present.T] = np.nan
    return persons, n_spk, present, positions


def _mouths(data, persons: list[tuple[int, str]], path: Path) -> list[AV163Mouth]:
    """``Data.MouthGT3D``: each person's 3-D mouth track."""
    mouth_gt = _field(data, "Data.MouthGT3D", path)
    mouth = []
    for _, name in persons:
        rows = _numeric(
            _field(mouth_gt, f"Data.MouthGT3D.{name}", path),
            f"Data.MouthGT3D.{name}",
            path,
            (None, 5),
        )
        mouth.append(AV163Mouth(rows[:, 0], rows[:, 1], rows[:, 2:5]))
    return mouth


def _experiment_doa(data, path: Path) -> dict[str, tuple[np.ndarray, ...]]:
    """``Data.experiment``: the ``ExGT`` and ``ExData`` DOA tables."""
    experiment = _field(data, "Data.experiment", path)
    doa = {}
    for prefix in ("ExGT", "ExData"):
        entries = _numbered(experiment, re.compile(prefix + r"(\d+)$"))
        doa[prefix] = tuple(
            _numeric(getattr(experiment, n), f"Data.experiment.{n}", path, (None, 2))
            for _, n in entries
        )
    return doa


def load_av163(folder: str | Path, seq: int, cam: int) -> AV163Sequence:
    """Read one AV16.3 sequence / camera: calibration, ground truth, DOA, histograms.

    Parameters
    ----------
    folder : str or Path
        The folder holding ``data_av_seqNN_camC.mat``, ``DOA_measurements_seqNN_camC.mat``
        and ``hist_temp_16bins_seqNN_camC.mat``.
    seq : int
        Sequence number (24 and 45 in the shared data).
    cam : int
        Camera, 1–3.

    Returns
    -------
    AV163Sequence

    Raises
    ------
    InputError
        A missing or unreadable file, a missing field, a field of the wrong shape, a NaN, a
        timecode that is not ``seconds.ff``, frame numbers that disagree between ``Timingcam``
        and ``posGT``, or a ``Z_doa`` whose length is not the number of frames.
    """
    _check_seq_cam(seq, cam)
    folder = Path(folder)
    path = folder / f"data_av_seq{seq}_cam{cam}.mat"
    data = _loadmat(path, "Data")

    cams = np.atleast_1d(np.asarray(_field(data, "Data.cam", path), dtype=object)).ravel()
    if cams.size != 3:
        raise InputError(f"Data.cam must hold 3 cameras, got {cams.size}", path)
    cameras = tuple(_camera(c, k, path) for k, c in enumerate(cams))
    align = _numeric(_field(data, "Data.align_mat", path), "Data.align_mat", path, (4, 4))
    if abs(np.linalg.det(align)) < 1e-12:
        raise InputError("Data.align_mat is singular", path)

    timing, time_s, frames = _timing(data, path)
    t = timing.shape[0]
    persons, n_spk, present, positions = _ground_truth(data, path, frames)
    mouth = _mouths(data, persons, path)
    doa = _experiment_doa(data, path)

    z_doa = load_av163_doa(folder, seq, cam)
    if len(z_doa) != t:
        raise InputError(
            f"Z_doa has {len(z_doa)} cells, expected one per frame ({t}, from {path.name})",
            folder / f"DOA_measurements_seq{seq}_cam{cam}.mat",
        )
    hists, placeholder = load_av163_histograms(folder, seq, cam)

    return AV163Sequence(
        seq=int(seq),
        cam=int(cam),
        cameras=cameras,
        align_mat=align,
        frames=frames.astype(np.int64),
        timecode=timing[:, 0],
        time_s=time_s,
        n_speakers=n_spk.astype(np.int64),
        present=present,
        positions=positions,
        mouth=tuple(mouth),
        doa_gt=doa["ExGT"],
        doa_measured=doa["ExData"],
        z_doa=z_doa,
        histograms=hists,
        histogram_is_placeholder=placeholder,
    )


def load_av163_faces(folder: str | Path, seq: int = 45, cam: int = 1) -> MOTData:
    """Face detections of ``face_seqNN_camC.mat`` as MOTChallenge boxes.

    The file stores per frame rows ``x1, y1, x2, y2, score`` (corners, see the module
    docstring for the evidence); they are returned as ``(left, top, width, height)``.

    Returns
    -------
    MOTData
        1-based frames (cell k is frame k), ids -1, the detector score in ``scores``.

    Raises
    ------
    InputError
        Missing file, a row that is not 5 numbers, a NaN, or a box with x2 <= x1 or y2 <= y1.
    """
    _check_seq_cam(seq, cam)
    path = Path(folder) / f"face_seq{seq}_cam{cam}.mat"
    cells = _cells(_loadmat(path, "face"))
    frames, rows = [], []
    for i, cell in enumerate(cells):
        arr = np.asarray(cell, dtype=float)
        if arr.size == 0:
            continue
        arr = _numeric(arr, f"face cell {i + 1} (frame {i + 1})", path, (None, 5))
        rows.append(arr)
        frames.append(np.full(len(arr), i + 1))
    if not rows:
        return MOTData(np.zeros(0), np.zeros(0), np.zeros((0, 4)), np.zeros(0))
    r = np.vstack(rows)
    f = np.concatenate(frames)
    bad = (r[:, 2] <= r[:, 0]) | (r[:, 3] <= r[:, 1])
    if np.any(bad):
        i = int(np.argmax(bad))
        raise InputError(
            f"face cell {f[i]}: box {r[i, :4].tolist()} is not x1, y1, x2, y2 "
            f"with x2 > x1 and y2 > y1",
            path,
        )
    boxes = np.column_stack([r[:, 0], r[:, 1], r[:, 2] - r[:, 0], r[:, 3] - r[:, 1]])
    return MOTData(f, -np.ones(len(f)), boxes, r[:, 4])


def probe_av163_video(video: str | Path, seq: AV163Sequence):
    """The header of a sequence's video (:class:`~avtrack.io.video.VideoInfo`), checked
    against the sequence: the calibration's image size and one frame per ``Timingcam`` row.

    Raises
    ------
    InputError
        Unreadable video, another size or another number of frames.
    """
    from avtrack.io.video import probe_video

    info = probe_video(video)
    if tuple(info.image_size) != tuple(IMAGE_SIZE):
        raise InputError(f"the video is {info.width}x{info.height}, the AV16.3 calibration "
                         f"is for {IMAGE_SIZE[0]}x{IMAGE_SIZE[1]}", video)
    if info.n_frames != seq.n_frames:
        raise InputError(f"the video has {info.n_frames} frames, sequence {seq.seq} camera "
                         f"{seq.cam} has {seq.n_frames} (is it the video of another sequence "
                         f"or camera?)", video)
    return info


def av163_pinhole(seq: AV163Sequence, array_centre=AV163_ARRAY_CENTRE) -> PinholeCamera:
    """The sequence's camera as a :class:`~avtrack.io.camera.PinholeCamera` in the array's
    frame: the pinhole part of the calibration, without its lens distortion and roll.

    ``Pmat @ inv(align_mat)`` is decomposed (:meth:`AV163Camera.decompose`); the pinhole keeps
    its focal lengths, principal point, optical centre (less ``array_centre``: the array frame
    is the ``MouthGT3D`` room frame moved to the array's centre, the frame of ``Z_doa``) and
    optical axis (yaw, pitch). What a roll-free, distortion-free camera cannot hold is
    dropped: the lens distortion ``kc`` and the rotation about the optical axis (3.6 degrees
    for camera 1, under 1 degree for cameras 2 and 3).
    :class:`avtrack.av.av163.AV163View` adds both back.

    Parameters
    ----------
    seq : AV163Sequence
    array_centre : (float, float, float)
        Array centre in the ``MouthGT3D`` frame (metres).

    Returns
    -------
    PinholeCamera
        Image size :data:`IMAGE_SIZE`.
    """
    centre = np.asarray(array_centre, dtype=float)
    if centre.shape != (3,) or not np.all(np.isfinite(centre)):
        raise ValueError(f"av163_pinhole: array_centre must be 3 finite numbers, got "
                         f"{array_centre!r}")
    K, R, optical_centre = seq.camera.decompose(seq.align_mat)
    forward = R[2]  # the optical axis in room coordinates
    yaw = float(np.degrees(np.arctan2(forward[1], forward[0])))
    pitch = float(np.degrees(np.arcsin(np.clip(forward[2], -1.0, 1.0))))
    width, height = IMAGE_SIZE
    return PinholeCamera(fx=float(K[0, 0]), fy=float(K[1, 1]), cx=float(K[0, 2]),
                         cy=float(K[1, 2]), width=width, height=height,
                         position=optical_centre - centre, yaw_deg=yaw, pitch_deg=pitch)


def av163_roll(seq: AV163Sequence, pinhole: PinholeCamera) -> np.ndarray:
    """The rotation about the optical axis that :func:`av163_pinhole` drops: ``(2, 2)``, with
    the calibration's rotation ``R = R_roll R_pinhole`` (``R_roll`` acting on normalised image
    coordinates). Its angle is ``degrees(atan2(r[1, 0], r[0, 0]))``."""
    R = seq.camera.decompose(seq.align_mat)[1]
    roll = R @ pinhole.R.T  # R_roll = R R_pinhole^T
    return roll[:2, :2]


def av163_templates(seq: AV163Sequence) -> np.ndarray:
    """The sequence's colour templates without the placeholder cells: ``(K, 16, 16)``;
    InputError when there is none."""
    templates = seq.histograms[~seq.histogram_is_placeholder]
    if len(templates) == 0:
        raise InputError(f"hist_temp of sequence {seq.seq} camera {seq.cam} holds no template "
                         f"(only placeholders): give a detector")
    return templates
