r"""Voice activity detection, fused with the person tracker's directional evidence.

The person tracker (:mod:`avtrack.av.persons`) says who speaks at the video's 40 ms frames,
from the localizer's peaks: a person whose direction carries a peak is *heard*. Peaks do not
model speech: they linger on reverberation, skip short syllables and move in 40 ms steps, so
turn ends, turn changes and short pauses are where the error is. This module adds a detector
made for speech and refines the turns at the localizer's 8 ms frame rate:

* :func:`voice_activity` runs the WebRTC voice activity detector (the ``webrtcvad`` module of
  the ``webrtcvad-wheels`` package, a GMM speech/noise model over six sub-bands) on one
  microphone, 10 ms frames at 16 kHz, removes the detector's own hangover from the end of its
  speech runs (:func:`remove_overhang`) and starts each run :data:`ONSET_PAD_S` earlier;
  :func:`voice_activity_blocks` does the same on a signal read in blocks, its level measured
  before by :class:`AmplitudeLevel`;
* :func:`map_delay` measures how far the heat maps trail the speech on the recording itself
  (the localizer's weights are recursive: a direction gains its mass some frames after its
  talker starts and keeps it a while after they stop), and :func:`advance` takes each frame's
  map that much later, so that the directional evidence lines up with the voice activity;
* :func:`fuse_speaking` says a person speaks in an 8 ms frame when the detector says speech
  there **and** the person's direction carries the frame's directional energy: the heat-map
  mass within ``window_deg`` of the person's tracked azimuth (leaving out the directions
  nearer to another candidate's), smoothed over ``smooth_s``, is at least ``share`` of the
  frame's strongest direction's (several persons above it: overlapped speech, kept) and at
  least ``min_mass``; speech nobody carries goes to the candidate within ``window_deg`` of
  the frame's strongest direction. Only persons the tracker heard within ``margin_s`` are
  candidates, so a person is never made a speaker by the detector alone. The defaults were
  chosen on seeds 0-19 of the simulated walkouts and meetings (``benchmarks/bench_vad.py``);
* :func:`unclaimed_speakers` groups the speech no person carries by direction into speakers
  never tracked (labels ``U1, U2, ...``), as :func:`~avtrack.av.diarization.unseen_speakers`
  does for the image-plane model: a talker the tracker merged into a neighbour;
* :func:`activity_segments` turns the per-frame decisions into RTTM turns, bridging a person's
  pauses shorter than ``max_gap`` and dropping turns shorter than ``min_duration``.

Without the ``webrtcvad`` module (:func:`vad_available` is False) the pipelines keep the
tracker's 40 ms turns (:func:`~avtrack.av.diarization.speaking_segments`) and say so once.

Memory: besides the heat maps ``(T, A)`` given, the fusion holds arrays of one value (or one
bit) per audio frame and person, never one per frame, person and direction: the directional
masses are computed person by person and a few directions at a time.
"""

from __future__ import annotations

import importlib
import warnings
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from scipy.ndimage import binary_dilation, uniform_filter1d

from avtrack.audio.stft import FRAME_HOP_S
from avtrack.io.persons import PersonsTable
from avtrack.io.rttm import RTTMSegment

if TYPE_CHECKING:
    from avtrack.localize.grid import DirectionGrid

#: The distribution that ships the detector (its module is ``webrtcvad``).
VAD_PACKAGE = "webrtcvad-wheels"

#: Said once when the detector is missing and the tracker's 40 ms turns are kept.
VAD_MISSING_NOTE = (
    f"voice activity detector not installed (pip install {VAD_PACKAGE}): speaker turns come "
    "from the tracker's speaking probability at the video frame rate"
)

_VAD_FS = 16000
_VAD_FRAME_S = 0.01
#: The WebRTC detector's overhang at 10 ms frames, by mode: (after a run of at most
#: ``_OVERHANG_SHORT_RUN`` speech frames, after a longer one) (``vad_core.c``,
#: ``kOverHangMax1*`` / ``kOverHangMax2*``; ``kMaxSpeechFrames``)
_OVERHANG_FRAMES = {0: (8, 14), 1: (8, 14), 2: (6, 9), 3: (6, 9)}
_OVERHANG_SHORT_RUN = 6
#: :func:`voice_activity` removes the detector's overhang by default
TRIM_OVERHANG = True
#: Seconds added before each speech run (the detector calls a word's first, rising frames
#: noise: its runs started 40 ms after the truth's, median over simulated walkouts; Silero
#: VAD's timestamps pad speech by 30 ms for the same reason)
ONSET_PAD_S = 0.04
#: The detector's input is scaled so that this percentile of the amplitudes is half of the
#: 16-bit full scale (the detector's energy floor is absolute).
LEVEL_PERCENTILE = 99.9
#: Longest delay of the heat maps behind the voice activity that :func:`map_delay` considers,
#: seconds (twice the longest measured: 0.06-0.25 s).
MAX_MAP_DELAY_S = 0.5
#: Weakest correlation between the maps' concentration and the voice activity at which
#: :func:`map_delay` trusts its lag (0.47-0.74 measured on the simulated and the real
#: recordings; two unrelated signals of a few thousand frames stay within a few hundredths).
MIN_DELAY_CORRELATION = 0.1
#: Values per temporary array of the directional masses (memory: 8 bytes each).
_CHUNK_VALUES = 1 << 17
#: Directions (heat-map columns) smoothed at a time.
_COLUMNS = 2


def _vad_module():
    """The ``webrtcvad`` module, or None when it is not installed."""
    try:
        return importlib.import_module("webrtcvad")
    except ImportError:
        return None


def vad_available() -> bool:
    """Whether the voice activity detector can run."""
    return _vad_module() is not None


def warn_vad_missing() -> None:
    """Warn (once per call site) that the detector is missing (:data:`VAD_MISSING_NOTE`)."""
    warnings.warn(VAD_MISSING_NOTE, RuntimeWarning, stacklevel=3)


class AzimuthProfile(NamedTuple):
    """Localizer heat maps reduced to their azimuth profile, with their frame times."""

    weights: np.ndarray  #: (T, A) heat-map mass per frame and azimuth
    time_s: np.ndarray  #: (T,) frame times (the audio frame grid), seconds
    azimuths_deg: np.ndarray  #: (A,) azimuth of each column, degrees
    #: frames: frame ``j``'s map is ``weights[min(j + lead, T - 1)]`` (:func:`advance`)
    lead: int = 0

    def checked(self) -> AzimuthProfile:
        """The same profile as float arrays, or ValueError when the shapes disagree."""
        w = np.asarray(self.weights, dtype=float)
        t = np.asarray(self.time_s, dtype=float)
        az = np.asarray(self.azimuths_deg, dtype=float)
        if w.ndim != 2 or w.shape[0] != t.size or w.shape[1] != az.size:
            raise ValueError(f"heat maps {w.shape} do not match their times ({t.size}) and "
                             f"azimuths ({az.size})")
        lead = self.lead
        if isinstance(lead, bool) or not isinstance(lead, int | np.integer) or lead < 0:
            raise ValueError(f"lead must be a whole number of frames >= 0, got {lead!r}")
        return AzimuthProfile(w, t, az, int(lead))

    @classmethod
    def of_maps(cls, weights: np.ndarray, time_s: np.ndarray, grid: DirectionGrid
                ) -> AzimuthProfile:
        """The profile of heat maps ``(T, D)`` over ``grid``: their sum over the elevations
        (weights that are a distribution over the candidates; the maps themselves on one
        elevation, not copied), as :func:`~avtrack.localize.grid.azimuth_profile` sums them
        but without the elevations' argmax."""
        w = np.asarray(weights)
        if grid.n_elevations > 1:
            w = w.reshape(len(w), grid.n_elevations, grid.n_azimuths).sum(axis=1)
        return cls(w, np.asarray(time_s), grid.azimuth_values)

    def maps(self) -> _Maps:
        """Each frame's map (after :meth:`checked`), read a few rows or columns at a time."""
        return _Maps(self.weights, self.lead)


class _Maps:
    """The heat maps of an :class:`AzimuthProfile`, frame ``j``'s taken ``lead`` frames later
    (the last repeated at the end), read a few rows or columns at a time: the ``(T, A)`` array
    is never copied whole."""

    def __init__(self, weights: np.ndarray, lead: int) -> None:
        self.weights = weights
        self.shape: tuple[int, ...] = weights.shape
        n = weights.shape[0]
        self._rows = None if lead == 0 else np.minimum(np.arange(n) + lead, max(n - 1, 0))

    def rows(self, j0: int, j1: int) -> np.ndarray:
        """Frames ``j0`` to ``j1`` (exclusive): ``(j1 - j0, A)``."""
        if self._rows is None:
            return self.weights[j0:j1]
        return self.weights[self._rows[j0:j1]]

    def columns(self, cols: np.ndarray | int | np.integer) -> np.ndarray:
        """Columns ``cols`` of every frame: ``(T, len(cols))``, or ``(T,)`` for one index."""
        c = self.weights[:, cols]
        return c if self._rows is None else c[self._rows]


@dataclass(frozen=True)
class VoiceActivity:
    """Speech / non-speech of a signal's frames.

    Attributes
    ----------
    time_s : ndarray (M,)
        Frame centres, seconds.
    speech : ndarray (M,) bool
    frame_s : float
        Frame length (and hop), seconds.
    """

    time_s: np.ndarray
    speech: np.ndarray
    frame_s: float

    def at(self, time_s: np.ndarray) -> np.ndarray:
        """Speech at arbitrary times (the frame containing each; False outside)."""
        t = np.asarray(time_s, dtype=float)
        if self.speech.size == 0:
            return np.zeros(t.shape, dtype=bool)
        idx = np.floor((t - (self.time_s[0] - 0.5 * self.frame_s)) / self.frame_s)
        idx = idx.astype(np.int64)
        ok = (idx >= 0) & (idx < self.speech.size)
        out = np.zeros(t.shape, dtype=bool)
        out[ok] = self.speech[idx[ok]]
        return out


def voice_activity(
    signal: np.ndarray, fs: int, aggressiveness: int = 3, min_speech_s: float = 0.03,
    max_pause_s: float = 0.3, trim_overhang: bool = TRIM_OVERHANG,
    onset_pad_s: float = ONSET_PAD_S,
) -> VoiceActivity:
    """WebRTC voice activity of a one-channel signal, 10 ms frames.

    The signal is resampled to 16 kHz and scaled so that its 99.9th amplitude percentile
    (:data:`LEVEL_PERCENTILE`) is half of the 16-bit full scale (the detector's energy floor is
    absolute). The detector's hangover is removed from the end of each speech run
    (``trim_overhang``, :func:`remove_overhang`); then speech runs shorter than
    ``min_speech_s`` are dropped, pauses shorter than ``max_pause_s`` bridged (0.3 s: the
    pauses inside a speaker's turn) and each run started ``onset_pad_s`` earlier
    (:data:`ONSET_PAD_S`); chosen on simulated walkouts and meetings, seeds 0-19 of
    ``benchmarks/bench_vad.py``.

    Parameters
    ----------
    signal : ndarray (n,)
    fs : int
        Sample rate, Hz.
    aggressiveness : int
        0 (least) to 3 (most aggressive in calling frames non-speech).
    trim_overhang : bool
        Remove the detector's hangover (:func:`remove_overhang`).
    onset_pad_s : float
        Seconds of speech added before each run (0: none).

    Raises
    ------
    ImportError
        When the ``webrtcvad`` module is not installed (:func:`vad_available`).
    """
    _check_detector(aggressiveness)
    x = np.asarray(signal, dtype=float).reshape(-1)
    if not fs > 0:
        raise ValueError(f"fs must be > 0, got {fs!r}")
    if fs != _VAD_FS and x.size:
        from fractions import Fraction

        import scipy.signal

        ratio = Fraction(_VAD_FS, int(fs))
        x = scipy.signal.resample_poly(x, ratio.numerator, ratio.denominator)
    top = float(np.percentile(np.abs(x), LEVEL_PERCENTILE)) if x.size else 0.0
    return voice_activity_blocks([x], top, aggressiveness, min_speech_s, max_pause_s,
                                 trim_overhang, onset_pad_s)


def voice_activity_blocks(
    blocks: Iterable[np.ndarray], level: float, aggressiveness: int = 3,
    min_speech_s: float = 0.03, max_pause_s: float = 0.3, trim_overhang: bool = TRIM_OVERHANG,
    onset_pad_s: float = ONSET_PAD_S,
) -> VoiceActivity:
    """:func:`voice_activity` of a 16 kHz signal given in consecutive blocks, whose level (the
    99.9th amplitude percentile of the whole signal, :class:`AmplitudeLevel`) is known: the
    same frames and decisions as the whole signal's, with memory of one block.

    Parameters
    ----------
    blocks : iterable of ndarray (n_k,)
        The signal's samples at 16 kHz, in order; any block lengths.
    level : float
        ``np.percentile(np.abs(signal), 99.9)`` of the whole signal.
    aggressiveness, min_speech_s, max_pause_s, trim_overhang, onset_pad_s
        As :func:`voice_activity`.
    """
    mod = _check_detector(aggressiveness)
    if not onset_pad_s >= 0:
        raise ValueError(f"onset_pad_s must be >= 0, got {onset_pad_s!r}")
    n = int(_VAD_FRAME_S * _VAD_FS)
    scale = 0.5 * 32767 / level if level > 0 else 0.0
    vad = mod.Vad(int(aggressiveness))
    rest = np.zeros(0)
    decisions: list[np.ndarray] = []
    for block in blocks:
        x = np.asarray(block, dtype=float).reshape(-1)
        if rest.size:
            x = np.concatenate([rest, x])
        m = x.size // n
        pcm = np.clip(x[: m * n] * scale, -32768, 32767)
        frames = pcm.astype("<i2").reshape(m, n)
        decisions.append(np.array([vad.is_speech(f.tobytes(), _VAD_FS) for f in frames],
                                  dtype=bool))
        rest = x[m * n :]
    speech = np.concatenate(decisions) if decisions else np.zeros(0, dtype=bool)
    if trim_overhang:
        speech = remove_overhang(speech, aggressiveness)
    speech = _close_open(speech, _VAD_FRAME_S, max_pause_s, min_speech_s)
    pad = round(onset_pad_s / _VAD_FRAME_S)
    if pad > 0:  # each run starts earlier: speech the detector needed some frames to see
        for a, _b in _runs(speech):
            speech[max(0, a - pad):a] = True
    time_s = (np.arange(speech.size) + 0.5) * _VAD_FRAME_S
    return VoiceActivity(time_s, speech, _VAD_FRAME_S)


def remove_overhang(speech: np.ndarray, aggressiveness: int) -> np.ndarray:
    """The WebRTC detector's decisions without its hangover.

    After a run of frames it classifies as speech, the detector keeps saying speech for a
    fixed number of frames (its *overhang*, ``WebRtcVad`` ``vad_core.c``: at 10 ms frames 6
    frames after a run of at most 6 speech frames, else 9 in the aggressive modes 2-3; 8 and
    14 in modes 0-1), so every speech run it reports ends that late. This removes them from
    the end of every run the signal's end does not cut (at least one frame of each run stays);
    pauses shorter than the overhang inside a run stay bridged.

    Parameters
    ----------
    speech : ndarray (J,) bool
        ``is_speech`` of consecutive 10 ms frames.
    aggressiveness : int
        The detector's mode, 0-3.
    """
    short, long = _OVERHANG_FRAMES[int(aggressiveness)]
    out = np.asarray(speech, dtype=bool).copy()
    for a, b in _runs(out):
        if b >= out.size:
            continue  # cut by the end of the signal: no overhang seen
        hang = long if b - a - long > _OVERHANG_SHORT_RUN else short
        out[max(a + 1, b - hang):b] = False
    return out


def _check_detector(aggressiveness: int):
    """The ``webrtcvad`` module, after checking ``aggressiveness``."""
    mod = _vad_module()
    if mod is None:
        raise ImportError(VAD_MISSING_NOTE)
    if aggressiveness not in (0, 1, 2, 3):
        raise ValueError(f"aggressiveness must be 0, 1, 2 or 3, got {aggressiveness!r}")
    return mod


class AmplitudeLevel:
    """The level :func:`voice_activity` scales a signal by, ``np.percentile(np.abs(x), 99.9)``
    (NumPy's default linear interpolation, Hyndman and Fan's definition 7), computed exactly
    over a signal given in blocks while keeping only its largest amplitudes: about 0.1 % of
    the samples, plus two.

    Parameters
    ----------
    n_samples : int
        Length of the whole signal (it fixes which order statistics the percentile reads).
    percentile : float
        In [0, 100] (default :data:`LEVEL_PERCENTILE`).
    """

    def __init__(self, n_samples: int, percentile: float = LEVEL_PERCENTILE) -> None:
        if isinstance(n_samples, bool) or not isinstance(n_samples, int | np.integer) \
                or n_samples < 0:
            raise ValueError(f"AmplitudeLevel: n_samples must be an integer >= 0, got "
                             f"{n_samples!r}")
        if not 0 <= percentile <= 100:
            raise ValueError(f"AmplitudeLevel: percentile must be in [0, 100], got "
                             f"{percentile!r}")
        self.n_samples = int(n_samples)
        n = self.n_samples
        self._virtual = (n - 1) * (percentile / 100)  # position in the sorted sample
        self._below = min(int(np.floor(self._virtual)), n - 1) if n else 0
        self._largest = np.zeros(0)  # the n - _below largest amplitudes seen so far
        self._seen = 0

    def add(self, block: np.ndarray) -> None:
        """The next samples (any shape; taken in order)."""
        a = np.abs(np.asarray(block, dtype=float).reshape(-1))
        self._seen += a.size
        if self._seen > self.n_samples:
            raise ValueError(f"AmplitudeLevel: more than the {self.n_samples} samples announced")
        keep = self.n_samples - self._below
        both = np.concatenate([self._largest, a])
        if both.size > keep:
            both = np.partition(both, both.size - keep)[both.size - keep :]
        self._largest = both

    def value(self) -> float:
        """The percentile of every sample's amplitude (0 for an empty signal)."""
        if self._seen != self.n_samples:
            raise ValueError(f"AmplitudeLevel: {self._seen} of the {self.n_samples} samples "
                             "were given")
        n = self.n_samples
        if n == 0:
            return 0.0
        top = np.sort(self._largest)  # top[0] is the order statistic _below
        if self._virtual >= n - 1:  # at (or past) the last: the largest value
            return float(top[-1])
        a, b = float(top[0]), float(top[1])
        t = self._virtual - self._below
        # NumPy's lerp: a + (b - a) t, from the nearer end (b - (b - a)(1 - t) when t >= 1/2)
        return b - (b - a) * (1 - t) if t >= 0.5 else a + (b - a) * t


def map_delay(
    profile: AzimuthProfile, activity: VoiceActivity, max_delay_s: float = MAX_MAP_DELAY_S
) -> float:
    """How far the heat maps trail the speech, seconds: the lag in whole map frames, from 0 to
    ``max_delay_s``, at which the maps' concentration (each frame's largest azimuth mass)
    correlates most with the voice activity (1 in speech, 0 elsewhere); 0 where either is
    constant or where even that correlation is under :data:`MIN_DELAY_CORRELATION` (maps that
    do not follow the speech: their lag would be noise).

    Why: the maps come from recursive estimators (the thesis's exponentiated-gradient weights,
    eqs. 5.17-5.19, and the DP-RTF features' recursive least squares), so a talker's direction
    gains its mass some frames after they start to speak and keeps it some frames after they
    stop, while the voice activity follows the signal itself. Simulated walkouts and meetings
    give 0.18-0.25 s on ``dprtf-eg`` maps, the real ReSpeaker recordings (talkers at 0.5 m)
    0.06-0.15 s: it depends on the room, the array and the localizer, hence measured on each
    recording rather than assumed.
    """
    profile = profile.checked()
    t = profile.time_s
    if not np.isfinite(max_delay_s) or max_delay_s < 0:
        raise ValueError(f"max_delay_s must be >= 0 seconds, got {max_delay_s!r}")
    if t.size < 2:
        return 0.0
    hop = float(np.median(np.diff(t)))
    w = profile.weights
    conc = w.max(axis=1) if w.shape[1] else np.zeros(t.size)
    if profile.lead:
        conc = conc[np.minimum(np.arange(t.size) + profile.lead, t.size - 1)]
    speech = activity.at(t).astype(float)
    if conc.std() == 0.0 or speech.std() == 0.0:
        return 0.0
    x = (conc - conc.mean()) / conc.std()
    y = (speech - speech.mean()) / speech.std()
    n_lags = min(int(np.floor(max_delay_s / hop + 1e-9)), t.size - 1) + 1
    corr = [float(np.dot(x[k:], y[: t.size - k])) / (t.size - k) for k in range(n_lags)]
    best = int(np.argmax(corr))
    return best * hop if corr[best] >= MIN_DELAY_CORRELATION else 0.0


def advance(profile: AzimuthProfile, delay_s: float) -> AzimuthProfile:
    """The profile with each frame's map taken ``delay_s`` later (rounded to whole frames of
    the profile's hop; the last frame's map repeats at the end): the maps lined up with the
    speech after :func:`map_delay`. Only :attr:`AzimuthProfile.lead` changes: the maps are
    neither copied nor changed."""
    profile = profile.checked()
    if not np.isfinite(delay_s) or delay_s < 0:
        raise ValueError(f"delay_s must be >= 0 seconds, got {delay_s!r}")
    t = profile.time_s
    hop = float(np.median(np.diff(t))) if t.size > 1 else FRAME_HOP_S
    return profile._replace(lead=profile.lead + round(delay_s / hop))


def _runs(mask: np.ndarray) -> np.ndarray:
    """``(R, 2)`` start / stop indices of the runs of True in a 1-D bool mask."""
    d = np.diff(np.r_[0, mask.astype(np.int8), 0])
    return np.stack([np.flatnonzero(d == 1), np.flatnonzero(d == -1)], axis=1)


def _close_open(mask: np.ndarray, hop: float, max_gap: float, min_run: float) -> np.ndarray:
    """Drop runs shorter than ``min_run`` s, then fill inner gaps up to ``max_gap`` s."""
    out = np.asarray(mask, dtype=bool).copy()
    for a, b in _runs(out):
        if (b - a) * hop < min_run - 1e-9:
            out[a:b] = False
    gaps = _runs(~out)
    for a, b in gaps:
        if a > 0 and b < out.size and (b - a) * hop <= max_gap + 1e-9:
            out[a:b] = True
    return out


def _person_azimuth(persons: PersonsTable, pid: int, time_s: np.ndarray) -> np.ndarray:
    """Azimuth of person ``pid`` at ``time_s``, ``(J,)`` degrees, linearly interpolated between
    video frames (unwrapped), NaN outside the person's life."""
    fps = persons.fps
    az = np.full(time_s.size, np.nan)
    rows = np.flatnonzero(persons.ids == pid)
    rows = rows[np.argsort(persons.frames[rows], kind="stable")]
    t = (persons.frames[rows] - 1) / fps
    a = np.rad2deg(np.unwrap(np.deg2rad(persons.azimuth_deg[rows])))
    inside = (time_s >= t[0] - 0.5 / fps) & (time_s < t[-1] + 0.5 / fps)
    az[inside] = np.interp(time_s[inside], t, a)
    return az


def _near(az_grid: np.ndarray, window_deg: float) -> np.ndarray:
    """``(A, A)`` bool: the grid's azimuths within ``window_deg`` of each other."""
    return np.abs((az_grid[:, None] - az_grid[None, :] + 180.0) % 360.0 - 180.0) <= window_deg


def _person_mass(
    w: _Maps, az: np.ndarray, az_grid: np.ndarray, window_deg: float, k: int,
    others: np.ndarray | None = None,
) -> np.ndarray:
    """Heat-map mass within ``window_deg`` of a person's azimuth ``az`` ``(J,)`` (0 outside
    the person's life), smoothed over ``k`` frames: ``(J,)``. ``others`` ``(J, M)``: other
    persons' azimuths (NaN: none); a direction nearer to one of them is not counted. Computed
    a few hundred frames at a time (memory: frames x directions), skipping the frames where
    the person, or another, is not there: the work grows with the persons present at once,
    not with all the persons of the recording."""
    alive = np.isfinite(az)
    a = np.nan_to_num(az)
    mass = np.empty(a.size)
    rows = max(1, _CHUNK_VALUES // max(az_grid.size, 1))
    for j0 in range(0, a.size, rows):
        j1 = j0 + rows
        if not alive[j0:j1].any():  # the person is not there: 0 (below), no work
            mass[j0:j1] = 0.0
            continue
        diff = np.abs((az_grid[None, :] - a[j0:j1, None] + 180.0) % 360.0 - 180.0)
        inside = diff <= window_deg
        if others is not None:
            for o in others[j0:j1].T:
                if np.isnan(o).all():
                    continue  # that person is not a candidate in these frames
                d_o = np.abs((az_grid[None, :] - o[:, None] + 180.0) % 360.0 - 180.0)
                inside &= ~(d_o < diff)  # NaN compares False: no other person there
        mass[j0:j1] = np.einsum("ja,ja->j", w.rows(j0, j1), inside.astype(float))
    mass = np.where(alive, mass, 0.0)
    return uniform_filter1d(mass, size=k, mode="nearest")


def _column_chunks(n: int) -> list[np.ndarray]:
    """Heat-map columns in groups of :data:`_COLUMNS`."""
    return [np.arange(c, min(n, c + _COLUMNS)) for c in range(0, n, _COLUMNS)]


def _window_peak(w: _Maps, near: np.ndarray, k: int) -> np.ndarray:
    """The strongest direction's mass of each frame ``(J,)``: the maximum over directions of
    the heat-map mass within the window of each (``near``), smoothed over ``k`` frames.

    A window's mass adds its columns in increasing order; a few directions at a time."""
    peak = np.full(w.shape[0], -np.inf)
    for cols in _column_chunks(w.shape[1]):
        sums = np.zeros((w.shape[0], cols.size))
        for i, c in enumerate(cols):
            for src in np.flatnonzero(near[:, c]):
                sums[:, i] += w.columns(src)
        sums = uniform_filter1d(sums, size=k, axis=0, mode="nearest")
        np.maximum(peak, sums.max(axis=1), out=peak)
    return peak


def _strongest_direction(w: _Maps, near: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Of the heat maps smoothed over ``k`` frames: each frame's strongest direction (the
    first, on a tie) ``(J,)`` int, and the smoothed mass within its window ``(J,)``, its
    columns added in increasing order. Two passes over a few directions at a time."""
    n_frames = w.shape[0]
    rows = np.arange(n_frames)
    best = np.zeros(n_frames, dtype=np.int64)
    best_value = np.full(n_frames, -np.inf)
    for cols in _column_chunks(w.shape[1]):
        smooth = uniform_filter1d(w.columns(cols), size=k, axis=0, mode="nearest")
        i = smooth.argmax(axis=1)
        v = smooth[rows, i]
        better = (v > best_value) | (np.isnan(v) & ~np.isnan(best_value))  # as argmax
        best[better] = cols[i[better]]
        best_value[better] = v[better]
    mass = np.zeros(n_frames)
    for cols in _column_chunks(w.shape[1]):
        smooth = uniform_filter1d(w.columns(cols), size=k, axis=0, mode="nearest")
        for i, c in enumerate(cols):
            inside = near[c, best]
            mass[inside] += smooth[inside, i]
    return best, mass


def fuse_speaking(
    persons: PersonsTable,
    tracker_speaking: np.ndarray,
    profile: AzimuthProfile,
    activity: VoiceActivity,
    *,
    window_deg: float = 10.0,
    smooth_s: float = 0.2,
    share: float = 0.6,
    min_mass: float = 0.05,
    margin_s: float = 0.3,
    hop_s: float = FRAME_HOP_S,
    frame_peak: bool = True,
    nearest_only: bool = True,
    peak_to_nearest: bool = True,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Who speaks in each audio frame: voice activity AND the person's directional evidence
    (see the module docstring).

    Parameters
    ----------
    persons : PersonsTable
        The tracker's persons (azimuth per video frame).
    tracker_speaking : ndarray (len(persons),) bool
        The tracker's per-frame decision of each row, smoothed into turns (candidates).
    profile : AzimuthProfile
        Localizer heat maps reduced to their azimuth profile ``(T, A)``, their frame times.
    activity : VoiceActivity
    window_deg, smooth_s, share, min_mass, margin_s : float
        See the module docstring.
    hop_s : float
        Audio frame hop (the heat maps'), seconds.
    frame_peak : bool
        ``share`` of the frame's strongest direction (its mass within ``window_deg``, a
        person there or not), else of the strongest person's: speech from where nobody is
        tracked is then nobody's (:func:`unclaimed_speakers`), not the nearest person's.
    nearest_only : bool
        A person's mass leaves out the directions nearer to another candidate's azimuth (the
        circle shared out between the candidates, each direction to the nearest), so that two
        persons closer than ``2 window_deg`` do not both carry the speech between them.
    peak_to_nearest : bool
        In a frame with speech that no person carries, the candidate nearest to the frame's
        strongest direction speaks when that direction is within ``window_deg`` of them (and
        their mass is at least ``min_mass``): the share test compares a person's window with
        the strongest window anywhere, which a talker standing between two grid directions,
        or beside another person, can miss. Speech from further away stays nobody's
        (:func:`unclaimed_speakers`).

    Returns
    -------
    time_s : ndarray (J,)
        Audio frame centres.
    ids : ndarray (N,)
        Person ids.
    speaking : ndarray (J, N) bool
    """
    profile = profile.checked()
    w, t_heat, az_grid = profile.maps(), profile.time_s, profile.azimuths_deg
    spk = np.asarray(tracker_speaking, dtype=bool).reshape(-1)
    if spk.size != len(persons):
        raise ValueError(f"tracker_speaking has {spk.size} rows, persons {len(persons)}")
    if t_heat.size == 0 or len(persons) == 0:
        return t_heat, np.unique(persons.ids), np.zeros((t_heat.size, 0), dtype=bool)
    ids = np.unique(persons.ids)
    k = max(1, round(smooth_s / hop_s))
    heard, frame_of = _heard(persons, spk, ids, t_heat)
    r = round(margin_s / hop_s)
    # each person's azimuth and candidacy per audio frame, (J, N): one value per frame and
    # person
    az_all = np.stack([_person_azimuth(persons, pid, t_heat) for pid in ids.tolist()], axis=1)
    cand_all = np.stack([_candidate(heard[:, n], frame_of, r) for n in range(ids.size)],
                        axis=1) & np.isfinite(az_all)
    # the strongest mass each person is compared with: the frame's strongest direction's
    # (frame_peak) or the strongest candidate's (masses are >= 0)
    top = (_window_peak(w, _near(az_grid, window_deg), k) if frame_peak
           else np.zeros(t_heat.size))
    for n in range(ids.size):
        mass = _person_mass(w, az_all[:, n], az_grid, window_deg, k)
        top = np.maximum(top, np.where(cand_all[:, n], mass, 0.0))
    cand_az = np.where(cand_all, az_all, np.nan) if nearest_only else None
    heard_speech = activity.at(t_heat)
    eligible = np.zeros((t_heat.size, ids.size), dtype=bool)
    speaking = np.zeros((t_heat.size, ids.size), dtype=bool)
    for n in range(ids.size):  # one person's masses at a time in memory
        others = None if cand_az is None else np.delete(cand_az, n, axis=1)
        mass = _person_mass(w, az_all[:, n], az_grid, window_deg, k, others)
        eligible[:, n] = cand_all[:, n] & (mass >= min_mass) & heard_speech
        speaking[:, n] = eligible[:, n] & (mass >= share * top)
    if peak_to_nearest:
        _peak_to_nearest(az_all, w, az_grid, window_deg, k, eligible, speaking)
    return t_heat, ids, speaking


def _peak_to_nearest(
    az_all: np.ndarray, w: _Maps, az_grid: np.ndarray, window_deg: float, k: int,
    eligible: np.ndarray, speaking: np.ndarray
) -> None:
    """In the frames where speech is heard but nobody speaks, the eligible person (``(J, N)``
    bool) nearest to the frame's strongest direction, within ``window_deg`` of it, speaks
    (``speaking`` ``(J, N)`` is set in place); ``az_all`` ``(J, N)``: the persons' azimuths."""
    j = np.flatnonzero(eligible.any(axis=1) & ~speaking.any(axis=1))
    if j.size == 0:
        return
    best, _ = _strongest_direction(w, _near(az_grid, window_deg), k)
    d = np.abs((az_all[j] - az_grid[best[j]][:, None] + 180.0) % 360.0 - 180.0)
    dist = np.where(eligible[j] & np.isfinite(d), d, np.inf)
    pick = dist.argmin(axis=1)
    ok = dist[np.arange(j.size), pick] <= window_deg
    speaking[j[ok], pick[ok]] = True


def _heard(
    persons: PersonsTable, spk: np.ndarray, ids: np.ndarray, t_heat: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Whether the tracker heard each person at each video frame ``(F, N)`` bool (rows:
    1-based frames), and the video frame of each audio frame ``(J,)`` (clipped to the rows)."""
    fps = persons.fps
    frame_of = np.floor(t_heat * fps + 0.5).astype(np.int64) + 1  # 1-based video frame
    col = {int(pid): i for i, pid in enumerate(ids.tolist())}
    heard = np.zeros((int(frame_of.max()) + 2, ids.size), dtype=bool)
    for f, pid, s in zip(persons.frames.tolist(), persons.ids.tolist(), spk.tolist(),
                         strict=True):
        if s and 0 <= f < heard.shape[0]:
            heard[f, col[pid]] = True
    return heard, np.clip(frame_of, 0, heard.shape[0] - 1)


def _candidate(heard: np.ndarray, frame_of: np.ndarray, r: int) -> np.ndarray:
    """``(J,)`` bool: audio frames within ``r`` frames of one where the tracker heard the
    person (``heard`` ``(F,)`` per video frame)."""
    cand = heard[frame_of]
    if r > 0:
        cand = binary_dilation(cand, structure=np.ones(2 * r + 1, dtype=bool))
    return cand


def unclaimed_speakers(
    persons: PersonsTable,
    speaking: np.ndarray,
    profile: AzimuthProfile,
    activity: VoiceActivity,
    *,
    window_deg: float = 10.0,
    smooth_s: float = 0.2,
    min_mass: float = 0.1,
    min_speaker_s: float = 1.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Speech no tracked person carries, grouped by direction into speakers never tracked.

    A frame is *unclaimed* when the voice activity says speech, no person speaks in it
    (``speaking``, :func:`fuse_speaking`), and the strongest direction of the smoothed heat
    map (with a mass within ``window_deg`` of at least ``min_mass``) is farther than ``window_deg``
    from every living person. The unclaimed frames' directions are grouped greedily: the
    commonest direction, with the unclaimed frames within ``window_deg`` of it, is a speaker
    while those frames add up to ``min_speaker_s`` seconds; they are removed and the next one
    is sought.

    Returns
    -------
    centres : ndarray (U,)
        Azimuth of each speaker found, degrees (in the order found).
    speaking : ndarray (J, U) bool
        Whether each speaks in each frame of ``profile.time_s``.
    """
    profile = profile.checked()
    w, t_heat, az_grid = profile.maps(), profile.time_s, profile.azimuths_deg
    hop = float(np.median(np.diff(t_heat))) if t_heat.size > 1 else FRAME_HOP_S
    if t_heat.size == 0:
        return np.zeros(0), np.zeros((0, 0), dtype=bool)
    near = _near(az_grid, window_deg)
    k = max(1, round(smooth_s / hop))
    best, mass = _strongest_direction(w, near, k)  # (its window's mass below)
    peak_az = az_grid[best]
    free = activity.at(t_heat) & ~np.asarray(speaking, dtype=bool).any(axis=1)
    free &= mass >= min_mass
    for pid in np.unique(persons.ids):
        az = _person_azimuth(persons, int(pid), t_heat)
        d = np.abs((peak_az - az + 180.0) % 360.0 - 180.0)
        free &= ~(np.isfinite(az) & (d <= window_deg))
    centres: list[float] = []
    cols: list[np.ndarray] = []
    left = free.copy()
    while left.any():
        c = int(np.bincount(best[left], minlength=az_grid.size).argmax())  # the commonest
        mine = left & near[c, best]  # and the unclaimed frames within window_deg of it
        if mine.sum() * hop < min_speaker_s:
            break
        centres.append(float(az_grid[c]))
        cols.append(mine)
        left &= ~mine
    if not cols:
        return np.zeros(0), np.zeros((t_heat.size, 0), dtype=bool)
    return np.array(centres), np.stack(cols, axis=1)


def activity_segments(
    time_s: np.ndarray,
    ids: np.ndarray,
    speaking: np.ndarray,
    hop_s: float = FRAME_HOP_S,
    *,
    file_id: str = "audio",
    max_gap: float = 0.2,
    min_duration: float = 0.2,
    label: str = "P{}",
) -> list[RTTMSegment]:
    """RTTM turns from per-audio-frame decisions (:func:`fuse_speaking`): frame ``j`` covers
    ``[t_j - hop/2, t_j + hop/2)``; a person's pauses up to ``max_gap`` s are bridged, then
    turns shorter than ``min_duration`` s dropped."""
    t = np.asarray(time_s, dtype=float)
    mask = np.asarray(speaking, dtype=bool)
    if mask.shape != (t.size, np.size(ids)):
        raise ValueError(f"speaking must be ({t.size}, {np.size(ids)}), got {mask.shape}")
    out: list[RTTMSegment] = []
    for k, pid in enumerate(np.asarray(ids).tolist()):
        col = mask[:, k].copy()
        for a, b in _runs(~col):
            if a > 0 and b < col.size and t[b] - t[a - 1] - hop_s <= max_gap + 1e-9:
                col[a:b] = True
        for a, b in _runs(col):
            s = max(t[a] - 0.5 * hop_s, 0.0)
            e = t[b - 1] + 0.5 * hop_s
            if e - s >= max(min_duration, 1e-3):
                out.append(RTTMSegment(file_id, s, e - s, label.format(int(pid))))
    out.sort(key=lambda s: (s.start, s.speaker))
    return out
