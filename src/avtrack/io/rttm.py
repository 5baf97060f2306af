"""NIST RTTM diarization files: who speaks when.

One ``SPEAKER`` record per line, ten space-separated fields::

    SPEAKER <file-id> <channel> <start> <duration> <NA> <NA> <speaker> <NA> <NA>

with times in seconds. :func:`read_rttm` skips blank lines, ``#`` comments and the other
RTTM record types (``SPKR-INFO``, ``LEXEME``, ...) and raises
:class:`~avtrack.errors.InputError` naming the file and 1-based row for a malformed
``SPEAKER`` record or an unknown record type. :func:`write_rttm` writes atomically.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from avtrack.errors import InputError
from avtrack.io.base import atomic_write, field_count_error, parse_finite

# RTTM record types other than SPEAKER; they carry no speaker turns and are skipped.
OTHER_TYPES = frozenset(
    {
        "SEGMENT",
        "NOSCORE",
        "NO_RT_METADATA",
        "LEXEME",
        "NON-LEX",
        "NON-SPEECH",
        "FILLER",
        "EDIT",
        "IP",
        "SU",
        "CB",
        "A/P",
        "SPKR-INFO",
    }
)


@dataclass(frozen=True)
class SpeechSegment:
    """One speaker talking from ``start`` to ``end`` (seconds).

    Attributes
    ----------
    speaker : int
        1-based person id.
    start, end : float
        Seconds, ``0 <= start < end``.
    utterance : str
        What fills the segment: a file name, ``"synthetic"``, or ``"vad"`` for segments read
        from a voice-activity track.
    """

    speaker: int
    start: float
    end: float
    utterance: str = "synthetic"

    def __post_init__(self) -> None:
        s = self.speaker
        if isinstance(s, bool) or not isinstance(s, int | np.integer) or s < 1:
            raise ValueError(f"SpeechSegment: speaker must be an integer >= 1, got {s!r}")
        object.__setattr__(self, "speaker", int(s))
        start, end = float(self.start), float(self.end)
        if not (math.isfinite(start) and start >= 0):
            raise ValueError(f"SpeechSegment: start must be finite and >= 0, got {self.start!r}")
        if not (math.isfinite(end) and end > start):
            raise ValueError(
                f"SpeechSegment: end must be finite and > start ({start:g}), got {self.end!r}"
            )
        object.__setattr__(self, "start", start)
        object.__setattr__(self, "end", end)
        if not isinstance(self.utterance, str):
            raise ValueError(f"SpeechSegment: utterance must be a str, got {self.utterance!r}")

    @property
    def duration(self) -> float:
        """``end - start`` in seconds."""
        return self.end - self.start


def _label(func: str, name: str, value: object) -> str:
    if not isinstance(value, str) or not value or any(c.isspace() for c in value):
        raise ValueError(
            f"{func}: {name} must be a non-empty string without spaces, got {value!r}"
        )
    return value


@dataclass(frozen=True)
class RTTMSegment:
    """One ``SPEAKER`` record.

    Attributes
    ----------
    file_id : str
        Recording name (no whitespace).
    start : float
        Seconds, >= 0.
    duration : float
        Seconds, > 0.
    speaker : str
        Speaker label (no whitespace); for simulated scenes the 1-based person id as text.
    """

    file_id: str
    start: float
    duration: float
    speaker: str

    def __post_init__(self) -> None:
        _label("RTTMSegment", "file_id", self.file_id)
        _label("RTTMSegment", "speaker", self.speaker)
        start, dur = float(self.start), float(self.duration)
        if not (math.isfinite(start) and start >= 0):
            raise ValueError(f"RTTMSegment: start must be finite and >= 0, got {self.start!r}")
        if not (math.isfinite(dur) and dur > 0):
            raise ValueError(
                f"RTTMSegment: duration must be finite and > 0, got {self.duration!r}"
            )
        object.__setattr__(self, "start", start)
        object.__setattr__(self, "duration", dur)

    @property
    def end(self) -> float:
        """``start + duration``, seconds."""
        return self.start + self.duration


def speech_to_rttm(segments: Iterable[SpeechSegment], file_id: str) -> list[RTTMSegment]:
    """RTTM records of speech segments; the speaker label is the person id as text."""
    _label("speech_to_rttm", "file_id", file_id)
    return [RTTMSegment(file_id, s.start, s.end - s.start, str(s.speaker)) for s in segments]


def rttm_to_speech(
    segments: Iterable[RTTMSegment], speaker_ids: Mapping[str, int] | None = None
) -> list[SpeechSegment]:
    """Speech segments (``utterance`` = the file id) of RTTM records, sorted by start.

    Parameters
    ----------
    segments : iterable of RTTMSegment
    speaker_ids : mapping str -> int, optional
        1-based id of each label. By default labels that are all positive integers keep their
        value, otherwise the sorted distinct labels are numbered 1, 2, ...

    Raises
    ------
    ValueError
        A label missing from ``speaker_ids``.
    """

    segs = list(segments)
    labels = sorted({s.speaker for s in segs})
    if speaker_ids is None:
        if all(lab.isdigit() and int(lab) >= 1 for lab in labels):
            speaker_ids = {lab: int(lab) for lab in labels}
        else:
            speaker_ids = {lab: k for k, lab in enumerate(labels, start=1)}
    missing = [lab for lab in labels if lab not in speaker_ids]
    if missing:
        raise ValueError(f"rttm_to_speech: speaker_ids has no id for label(s) {missing}")
    out = [SpeechSegment(int(speaker_ids[s.speaker]), s.start, s.end, s.file_id) for s in segs]
    out.sort(key=lambda s: (s.start, s.speaker))
    return out


def merge_segments(segments: Iterable[RTTMSegment], gap: float = 0.0) -> list[RTTMSegment]:
    """Merge records of the same file and speaker that overlap or are at most ``gap`` s apart.

    Returns
    -------
    list of RTTMSegment
        Sorted by (file, start, speaker).
    """
    g = float(gap)
    if not (math.isfinite(g) and g >= 0):
        raise ValueError(f"merge_segments: gap must be a finite number >= 0, got {gap!r}")
    segs = sorted(segments, key=lambda s: (s.file_id, s.speaker, s.start))
    out: list[RTTMSegment] = []
    for s in segs:
        last = out[-1] if out else None
        if (
            last is not None
            and last.file_id == s.file_id
            and last.speaker == s.speaker
            and s.start <= last.end + g
        ):
            end = max(last.end, s.end)
            out[-1] = RTTMSegment(last.file_id, last.start, end - last.start, last.speaker)
        else:
            out.append(s)
    out.sort(key=lambda s: (s.file_id, s.start, s.speaker))
    return out


def write_rttm(
    path: str | Path,
    segments: Iterable[RTTMSegment | SpeechSegment],
    file_id: str | None = None,
) -> None:
    """Write ``SPEAKER`` records atomically, times with 3 decimals (milliseconds).

    Parameters
    ----------
    path : str or Path
    segments : iterable of RTTMSegment or SpeechSegment
        Written in the given order. A SpeechSegment is written with ``file_id`` and its
        speaker id as the label; an RTTMSegment keeps its own file id.
    file_id : str, optional
        Required when ``segments`` holds SpeechSegments.

    Raises
    ------
    ValueError
        A SpeechSegment without ``file_id``, or a segment shorter than 1 ms once rounded.
    """

    rows: list[str] = []
    for s in segments:
        if isinstance(s, SpeechSegment):
            if file_id is None:
                raise ValueError("write_rttm: file_id is required to write SpeechSegments")
            s = speech_to_rttm([s], file_id)[0]
        elif not isinstance(s, RTTMSegment):
            raise TypeError(
                f"write_rttm: segments must be RTTMSegment or SpeechSegment, "
                f"got {type(s).__name__}"
            )
        start = round(s.start, 3)
        dur = round(round(s.end, 3) - start, 3)
        if dur <= 0:
            raise ValueError(
                f"write_rttm: segment of {s.speaker!r} at {s.start:g} s is shorter "
                f"than 1 ms once rounded to milliseconds"
            )
        rows.append(
            f"SPEAKER {s.file_id} 1 {start:.3f} {dur:.3f} <NA> <NA> {s.speaker} <NA> <NA>\n"
        )
    with atomic_write(path) as fh:
        fh.writelines(rows)



def read_rttm(path: str | Path) -> list[RTTMSegment]:
    """Read the ``SPEAKER`` records of an RTTM file, in file order.

    Raises
    ------
    InputError
        Missing file, an unknown record type, a ``SPEAKER`` record with fewer than 8 or more
        than 10 fields, a start or duration that is not a finite number, a negative start or
        a duration <= 0.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError("file not found" if not path.exists() else "not a regular file", path)
    try:
        text = path.read_text()
    except UnicodeDecodeError:
        raise InputError("not a text file (cannot decode as UTF-8)", path) from None
    out: list[RTTMSegment] = []
    for row, line in enumerate(text.splitlines(), start=1):
        fields = line.split()
        if not fields or fields[0].startswith("#"):
            continue
        kind = fields[0]
        if kind in OTHER_TYPES:
            continue
        if kind != "SPEAKER":
            raise InputError(f"unknown RTTM record type {kind!r} (expected SPEAKER)", path, row)
        if not 8 <= len(fields) <= 10:
            raise field_count_error(
                "10 space-separated fields (SPEAKER file channel start duration <NA> <NA> "
                "speaker <NA> <NA>)", len(fields), path, row
            )
        start = parse_finite(fields[3], "start (field 4)", path, row)
        dur = parse_finite(fields[4], "duration (field 5)", path, row)
        if start < 0:
            raise InputError(f"start (field 4) must be >= 0, got {fields[3]}", path, row)
        if dur <= 0:
            raise InputError(f"duration (field 5) must be > 0, got {fields[4]}", path, row)
        out.append(RTTMSegment(fields[1], start, dur, fields[7]))
    return out
