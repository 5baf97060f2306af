"""AVDIAR audio-visual diarization sequences (Gebru et al., "Audio-visual speaker diarization
based on spatiotemporal Bayesian fusion", IEEE TPAMI 2018; team.inria.fr/perception/avdiar).

The dataset cannot be downloaded from these machines and its page gives no file-format
specification, so the layout below is the one the distributed archive has as documented by its
users (the AVDIAR2ASD conversion tools list the tree and read ``summary.json``,
``face_bb.txt`` and ``speakers.rttm``; other public readers agree on the columns)::

    <root>/SeqNN-kP-SsMm/                 k persons; S, M: the authors' scenario codes
        summary.json                      SequenceName, Length_in_sec, Audio_Channel, Audio_FS,
                                          Video_FPS, Number_of_Image, CalibrationID,
                                          Image_Resoultion_WH (sic, [width, height])
        Audio/SeqNN-kP-SsMm.wav           the microphones of the dummy head (6 channels,
                                          48 kHz in the published files)
        Video/SeqNN-kP-SsMm_CAM1.mp4      (and _CAM2) 720 × 450 at 25 fps; not decoded here
        GroundTruth/face_bb.txt           face boxes
        GroundTruth/person_bb.txt         upper-body boxes
        GroundTruth/speakers.rttm         who speaks when (diarization)
        GroundTruth/vad.rttm              speech activity
        Detection/face_bb.txt, person_bb.txt   detector output (not read here)

Assumptions, each an explicit rule of this reader:

1. ``face_bb.txt`` / ``person_bb.txt`` rows are comma-separated
   ``frame, person, left, top, width, height[, ...]`` in CAM1 pixels, ``person`` 1-based and
   matching the speaker numbers of ``speakers.rttm``. Extra columns are kept in
   :attr:`~avtrack.io.mot.MOTData.extra`.
2. Frame numbers in the box files are 0-based video frame indices (the public readers pair
   frame ``f`` with the ``f``-th decoded image counting from 0, and with time ``f / fps``).
   They are returned as 1-based MOTChallenge frames ``f + 1``; pass ``zero_based=False`` for
   files numbered from 1.
3. ``speakers.rttm`` and ``vad.rttm`` are NIST RTTM: space-separated ``type file channel onset
   duration ortho stype name conf``; ``SPKR-INFO`` (and other ``*-INFO``) lines declare
   speakers and are skipped, ``SPEAKER`` / ``SPEECH`` lines are segments, ``;;`` starts a
   comment. The person number of a speaker is the integer its name ends with
   (``speaker-2`` -> 2); a name without one gets person -1.
4. A frame ``f`` (1-based) is at time ``(f - 1) / fps``; a person speaks at ``t`` when one of
   their segments has ``onset <= t < onset + duration``.
5. ``summary.json`` is optional; when present, the WAV's sample rate and channel count must
   equal ``Audio_FS`` and ``Audio_Channel``, and ``Video_FPS`` gives the frame rate (25
   otherwise). The audio file is ``Audio/<SequenceName>.wav`` (the folder name when there is
   no summary).
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import soundfile as sf

from avtrack.errors import InputError
from avtrack.io.mot import MOTData

DEFAULT_FRAME_RATE = 25.0
_NAME = re.compile(r"Seq(\d+)-(\d+)P-S(\d+)M(\d+)$")
_SEGMENT_TYPES = ("SPEAKER", "SPEECH")


@dataclass(frozen=True)
class SpeechSegments:
    """Speech segments of an RTTM file, in file order.

    Attributes
    ----------
    onset_s : ndarray (K,)
        Start of each segment in seconds.
    duration_s : ndarray (K,)
        Length in seconds (>= 0).
    names : tuple of K str
        RTTM speaker name of each segment.
    person : ndarray (K,) int
        Person number (trailing integer of the name), -1 when the name has none.
    """

    onset_s: np.ndarray
    duration_s: np.ndarray
    names: tuple[str, ...]
    person: np.ndarray

    def __post_init__(self) -> None:
        k = len(self.names)
        for name in ("onset_s", "duration_s"):
            arr = np.asarray(getattr(self, name), dtype=float).reshape(-1)
            if arr.shape != (k,) or not np.all(np.isfinite(arr)):
                raise ValueError(f"SpeechSegments: {name} must be {k} finite numbers")
            object.__setattr__(self, name, arr)
        if np.any(self.duration_s < 0):
            raise ValueError("SpeechSegments: durations must be >= 0")
        person = np.asarray(self.person, dtype=np.int64).reshape(-1)
        if person.shape != (k,):
            raise ValueError(f"SpeechSegments: person must have shape ({k},)")
        object.__setattr__(self, "person", person)

    def __len__(self) -> int:
        return len(self.names)

    @property
    def end_s(self) -> np.ndarray:
        return self.onset_s + self.duration_s

    def active(self, times: np.ndarray, persons: np.ndarray) -> np.ndarray:
        """Who speaks when.

        Parameters
        ----------
        times : ndarray (T,)
            Seconds.
        persons : ndarray (P,) int
            Person numbers.

        Returns
        -------
        ndarray (T, P) bool
            ``onset <= t < onset + duration`` for some segment of that person.
        """
        t = np.asarray(times, dtype=float).reshape(-1, 1)
        out = np.zeros((t.shape[0], len(persons)), dtype=bool)
        for j, p in enumerate(np.asarray(persons)):
            mine = self.person == p
            on, end = self.onset_s[mine], self.end_s[mine]
            out[:, j] = np.any((t >= on) & (t < end), axis=1)
        return out


@dataclass(frozen=True)
class AVDIARSequence:
    """One AVDIAR sequence.

    Attributes
    ----------
    name : str
        ``SeqNN-kP-SsMm``.
    folder : Path
    audio : ndarray (M, n) or None
        Microphone signals (None when read with ``load_audio=False``).
    fs : int
        Audio sample rate in Hz.
    frame_rate : float
        Video frames per second.
    n_frames : int
        Number of video frames (``Number_of_Image``, else the last annotated frame).
    n_persons : int
        From the name (``kP``), else the largest person number in the annotations.
    faces : MOTData
        Ground-truth face boxes: 1-based frames, ``ids`` = person number.
    bodies : MOTData or None
        Ground-truth upper-body boxes (``person_bb.txt``), when present.
    speakers : SpeechSegments
        ``speakers.rttm``: diarization ground truth.
    vad : SpeechSegments or None
        ``vad.rttm``, when present.
    image_size : tuple (width, height) or None
    summary : dict
        ``summary.json`` as read (empty when absent).
    """

    name: str
    folder: Path
    audio: np.ndarray | None
    fs: int
    frame_rate: float
    n_frames: int
    n_persons: int
    faces: MOTData
    bodies: MOTData | None
    speakers: SpeechSegments
    vad: SpeechSegments | None
    image_size: tuple[int, int] | None = None
    summary: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.audio is not None and np.asarray(self.audio).ndim != 2:
            raise ValueError(
                f"AVDIARSequence: audio must have shape (M, n), got {np.asarray(self.audio).shape}"
            )
        if not self.fs > 0 or not self.frame_rate > 0:
            raise ValueError("AVDIARSequence: fs and frame_rate must be > 0")
        if self.n_frames < 0 or self.n_persons < 0:
            raise ValueError("AVDIARSequence: n_frames and n_persons must be >= 0")

    @property
    def frame_times(self) -> np.ndarray:
        """Time of each frame 1..n_frames in seconds, ``(f - 1) / frame_rate``, shape (T,)."""
        return np.arange(self.n_frames) / self.frame_rate

    def speaking(self) -> np.ndarray:
        """Speaking status per frame and person, from ``speakers.rttm``.

        Returns
        -------
        ndarray (n_frames, n_persons) bool
            Column ``p`` is person ``p + 1``.
        """
        return self.speakers.active(self.frame_times, np.arange(1, self.n_persons + 1))


# --------------------------------------------------------------------------- parsers


def _require_file(path: Path) -> None:
    if not path.is_file():
        raise InputError("file not found" if not path.exists() else "not a regular file", path)


def _read_text(path: Path) -> str:
    _require_file(path)
    try:
        return path.read_text()
    except UnicodeDecodeError:
        raise InputError("not a text file (cannot decode as UTF-8)", path) from None


def read_avdiar_boxes(path: str | Path, zero_based: bool = True) -> MOTData:
    """An AVDIAR box file (``face_bb.txt`` / ``person_bb.txt``) as MOTChallenge data.

    Parameters
    ----------
    path : str or Path
        Rows ``frame, person, left, top, width, height[, ...]``.
    zero_based : bool
        Frame numbers start at 0 in the file (the AVDIAR convention); they are shifted to
        1-based frames.

    Returns
    -------
    MOTData
        Rows sorted by frame then person, ``scores`` 1, columns 7+ in ``extra``.

    Raises
    ------
    InputError
        Missing file; a row with fewer than 6 values, a non-number, a NaN, a non-integer or
        negative frame (< 1 when not ``zero_based``), a person number < 1, a non-positive box
        size, or two boxes for one person in one frame (file and line named).
    """
    path = Path(path)
    rows: list[list[float]] = []
    lines: list[int] = []
    first = 0 if zero_based else 1
    for i, line in enumerate(_read_text(path).splitlines(), start=1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        parts = [p.strip() for p in line.replace(",", " ").split()]
        if len(parts) < 6:
            raise InputError(
                f"expected at least 6 values (frame, person, left, top, width, "
                f"height), got {len(parts)}",
                path,
                i,
            )
        try:
            values = [float(p) for p in parts]
        except ValueError:
            bad = next(p for p in parts if not _is_number(p))
            raise InputError(f"not a number: {bad!r}", path, i) from None
        frame, person, _, _, w, h = values[:6]
        for name, v in zip(
            ("frame", "person", "left", "top", "width", "height"), values[:6], strict=True
        ):
            if not math.isfinite(v):
                raise InputError(f"{name} is {v}, expected a finite number", path, i)
        if frame != int(frame) or frame < first:
            raise InputError(f"frame must be an integer >= {first}, got {parts[0]!r}", path, i)
        if person != int(person) or person < 1:
            raise InputError(f"person must be an integer >= 1, got {parts[1]!r}", path, i)
        if w <= 0 or h <= 0:
            raise InputError(f"box width and height must be > 0, got {w:g} x {h:g}", path, i)
        rows.append(values)
        lines.append(i)
    if not rows:
        return MOTData(np.zeros(0), np.zeros(0), np.zeros((0, 4)), np.zeros(0))
    width = max(len(r) for r in rows)
    arr = np.full((len(rows), width), np.nan)
    for k, r in enumerate(rows):
        arr[k, : len(r)] = r
    order = np.lexsort((arr[:, 1], arr[:, 0]))
    arr, line_no = arr[order], np.asarray(lines)[order]
    dup = np.flatnonzero(np.all(np.diff(arr[:, :2], axis=0) == 0, axis=1))
    if dup.size:
        k = dup[0] + 1
        raise InputError(
            f"person {int(arr[k, 1])} has a second box in frame {int(arr[k, 0])}",
            path,
            int(line_no[k]),
        )
    return MOTData(arr[:, 0] + (1 - first), arr[:, 1], arr[:, 2:6], np.ones(len(arr)), arr[:, 6:])


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def read_rttm(path: str | Path) -> SpeechSegments:
    """Speech segments of an RTTM file (``SPEAKER`` / ``SPEECH`` lines).

    Raises
    ------
    InputError
        Missing file; a segment line with fewer than 8 fields, a non-numeric, NaN or negative
        onset or duration, or an unknown line type (file and line named).
    """
    path = Path(path)
    onset, duration, names, persons = [], [], [], []
    for i, line in enumerate(_read_text(path).splitlines(), start=1):
        fields = line.split()
        if not fields or fields[0].startswith(";;"):
            continue
        kind = fields[0].upper()
        if kind.endswith("-INFO"):
            continue
        if kind not in _SEGMENT_TYPES:
            raise InputError(
                f"unknown RTTM line type {fields[0]!r} (expected SPEAKER, SPEECH or *-INFO)",
                path,
                i,
            )
        if len(fields) < 8:
            raise InputError(
                f"expected at least 8 fields (type file channel onset duration "
                f"ortho stype name), got {len(fields)}",
                path,
                i,
            )
        try:
            on, dur = float(fields[3]), float(fields[4])
        except ValueError:
            raise InputError(
                f"onset and duration must be numbers, got {fields[3]!r} and {fields[4]!r}", path, i
            ) from None
        if not (math.isfinite(on) and math.isfinite(dur)) or on < 0 or dur < 0:
            raise InputError(
                f"onset and duration must be finite and >= 0, got {on:g} and {dur:g}", path, i
            )
        name = fields[7]
        m = re.search(r"(\d+)$", name)
        onset.append(on)
        duration.append(dur)
        names.append(name)
        persons.append(int(m.group(1)) if m else -1)
    return SpeechSegments(
        np.array(onset), np.array(duration), tuple(names), np.array(persons, dtype=np.int64)
    )


def _read_summary(path: Path) -> dict[str, Any]:
    if not path.exists():
        return {}
    try:
        summary = json.loads(_read_text(path))
    except json.JSONDecodeError as exc:
        raise InputError(f"invalid JSON: {exc}", path) from None
    if not isinstance(summary, dict):
        raise InputError(f"expected a JSON object, got {type(summary).__name__}", path)
    return summary


def _positive_number(summary: dict[str, Any], key: str, path: Path) -> float | None:
    if key not in summary:
        return None
    try:
        value = float(summary[key])
    except (TypeError, ValueError):
        raise InputError(f"{key} must be a number, got {summary[key]!r}", path) from None
    if not value > 0:
        raise InputError(f"{key} must be > 0, got {summary[key]!r}", path)
    return value


# --------------------------------------------------------------------------- reader


def _audio(wav: Path, summary: dict, summary_path: Path, load_audio: bool):
    """The WAV file's samples ``(n_channels, n_samples)`` (None unless ``load_audio``) and its
    header, checked against ``summary.json``."""
    if not wav.is_file():
        found = sorted(p.name for p in wav.parent.glob("*.wav"))
        raise InputError(f"file not found (WAV files in Audio/: {found})", wav)
    try:
        info = sf.info(wav)
    except (RuntimeError, sf.LibsndfileError) as exc:
        raise InputError(f"cannot read as audio: {exc}", wav) from None
    want_fs = _positive_number(summary, "Audio_FS", summary_path)
    if want_fs is not None and info.samplerate != want_fs:
        raise InputError(
            f"sample rate is {info.samplerate} Hz, but {summary_path.name} gives "
            f"Audio_FS = {want_fs:g} Hz",
            wav,
        )
    want_ch = _positive_number(summary, "Audio_Channel", summary_path)
    if want_ch is not None and info.channels != want_ch:
        raise InputError(
            f"{info.channels} channels, but {summary_path.name} gives Audio_Channel = {want_ch:g}",
            wav,
        )
    audio = None
    if load_audio:
        data, _ = sf.read(wav, dtype="float64", always_2d=True)
        audio = data.T
        if not np.all(np.isfinite(audio)):
            raise InputError("audio holds NaN or inf samples", wav)
    return audio, info


def _frame_count(
    summary: dict, summary_path: Path, gt: Path, faces: MOTData, bodies: MOTData | None
) -> int:
    """``Number_of_Image`` of ``summary.json`` (the last annotated frame if absent); an
    annotation beyond it is an error."""
    last = max(faces.n_frames, bodies.n_frames if bodies is not None else 0)
    n_img = _positive_number(summary, "Number_of_Image", summary_path)
    if n_img is not None:
        n_frames = int(n_img)
        if last > n_frames:
            bad = gt / ("face_bb.txt" if faces.n_frames > n_frames else "person_bb.txt")
            raise InputError(
                f"annotated frame {last} is beyond Number_of_Image = {n_frames} "
                f"(frames counted from 1)",
                bad,
            )
    else:
        n_frames = last
    return n_frames


def _image_size(summary: dict, summary_path: Path) -> tuple[int, int] | None:
    """``(width, height)`` of ``summary.json``'s ``Image_Resoultion_WH``, or None."""
    image_size = None
    wh = summary.get("Image_Resoultion_WH", summary.get("Image_Resolution_WH"))
    if wh is not None:
        try:
            image_size = (int(wh[0]), int(wh[1]))
        except (TypeError, ValueError, IndexError):
            raise InputError(
                f"Image_Resoultion_WH must be [width, height], got {wh!r}", summary_path
            ) from None
    return image_size


def load_avdiar_sequence(
    folder: str | Path, *, load_audio: bool = True, zero_based: bool = True
) -> AVDIARSequence:
    """Read one AVDIAR sequence folder (see the module docstring for the layout).

    Parameters
    ----------
    folder : str or Path
        ``.../SeqNN-kP-SsMm``.
    load_audio : bool
        Read the WAV samples; False reads only its header (``audio`` is None).
    zero_based : bool
        Frame numbering of the box files (see :func:`read_avdiar_boxes`).

    Returns
    -------
    AVDIARSequence

    Raises
    ------
    InputError
        Missing ``GroundTruth/face_bb.txt``, ``GroundTruth/speakers.rttm`` or audio file; a
        malformed row (file and line named); a WAV whose sample rate or channel count differs
        from ``summary.json``; NaN audio samples; annotations beyond ``Number_of_Image``.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(
            "sequence folder not found" if not folder.exists() else "not a folder", folder
        )
    summary_path = folder / "summary.json"
    summary = _read_summary(summary_path)
    name = str(summary.get("SequenceName", folder.name))
    frame_rate = _positive_number(summary, "Video_FPS", summary_path) or DEFAULT_FRAME_RATE

    gt = folder / "GroundTruth"
    faces = read_avdiar_boxes(gt / "face_bb.txt", zero_based)
    bodies = None
    if (gt / "person_bb.txt").exists():
        bodies = read_avdiar_boxes(gt / "person_bb.txt", zero_based)
    speakers = read_rttm(gt / "speakers.rttm")
    vad = read_rttm(gt / "vad.rttm") if (gt / "vad.rttm").exists() else None

    audio, info = _audio(folder / "Audio" / f"{name}.wav", summary, summary_path, load_audio)
    n_frames = _frame_count(summary, summary_path, gt, faces, bodies)

    m = _NAME.match(name)
    ids = [faces.ids, bodies.ids if bodies is not None else np.zeros(0), speakers.person]
    n_persons = int(m.group(2)) if m else int(max((a.max() for a in ids if a.size), default=0))

    image_size = _image_size(summary, summary_path)

    return AVDIARSequence(
        name=name,
        folder=folder,
        audio=audio,
        fs=int(info.samplerate),
        frame_rate=frame_rate,
        n_frames=n_frames,
        n_persons=n_persons,
        faces=faces,
        bodies=bodies,
        speakers=speakers,
        vad=vad,
        image_size=image_size,
        summary=summary,
    )
