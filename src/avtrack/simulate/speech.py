"""Who speaks when: turn-taking schedules, schedules from voice-activity tracks, and the dry
per-speaker signals that fill them (real utterances or a speech-like synthetic signal).

Times are in seconds from the start of the scene; speakers are 1-based person ids. Signals
follow the project convention ``(n_channels, n_samples)`` — here one row per speaker.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import soundfile as sf
from scipy.signal import istft, resample_poly, stft

from avtrack.errors import InputError
from avtrack.io.rttm import SpeechSegment

AUDIO_SUFFIXES = (".wav", ".flac", ".ogg")

# Formant frequencies (Hz) of five vowels, adult male (Peterson & Barney 1952, rounded).
_VOWELS = np.array(
    [
        [270.0, 2290.0, 3010.0],  # i
        [530.0, 1840.0, 2480.0],  # e
        [730.0, 1090.0, 2440.0],  # a
        [570.0, 840.0, 2410.0],  # o
        [300.0, 870.0, 2240.0],  # u
    ]
)
_BANDWIDTHS = np.array([80.0, 100.0, 150.0])  # formant bandwidths, Hz


# ---------------------------------------------------------------------------- schedules


def _check_positive(func: str, name: str, value: float, allow_zero: bool = False) -> float:
    v = float(value)
    if not math.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{func}: {name} must be a finite number {bound}, got {value!r}")
    return v


def _check_count(func: str, name: str, value: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
        raise ValueError(f"{func}: {name} must be an integer >= 1, got {value!r}")
    return int(value)


def _check_rng(func: str, rng: object) -> None:
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"{func}: rng must be a numpy.random.Generator, got {type(rng).__name__}")


def _as_activity(
    func: str, name: str, mask: np.ndarray, n_speakers: int | None = None
) -> np.ndarray:
    """A ``(F, S)`` bool matrix from bool or 0/1 numbers; anything else is an error."""
    a = np.asarray(mask)
    if a.ndim != 2 or (n_speakers is not None and a.shape[1] != n_speakers):
        want = f"(F, {n_speakers})" if n_speakers is not None else "(F, S)"
        raise ValueError(f"{func}: {name} must have shape {want}, got {a.shape}")
    if a.dtype != bool:
        if not np.issubdtype(a.dtype, np.number) or not np.all((a == 0) | (a == 1)):
            raise ValueError(f"{func}: {name} must be bool or contain only 0 and 1")
        a = a != 0
    return a


def _activity_mask(
    func: str,
    active: Callable[[float], np.ndarray] | np.ndarray | None,
    active_frame_s: float | None,
    dur: float,
    n_s: int,
) -> tuple[np.ndarray | None, float]:
    """Who may talk in each frame, ``(F, n_s)`` bool (None: everyone always), and the frame
    length in seconds, from :func:`turn_taking_schedule`'s ``active`` argument."""
    mask: np.ndarray | None = None
    frame_s = 0.01
    if callable(active):
        grid = np.arange(0.0, dur, frame_s)
        mask = _as_activity(
            func, "active(t) values", np.array([np.asarray(active(float(t))) for t in grid]), n_s
        )
    elif active is not None:
        mask = _as_activity(func, "active", active, n_s)
        frame_s = (
            dur / mask.shape[0]
            if active_frame_s is None
            else _check_positive(func, "active_frame_s", active_frame_s)
        )
    return mask, frame_s


def _draw_turns(
    rng: np.random.Generator,
    n_s: int,
    dur: float,
    mask: np.ndarray | None,
    frame_s: float,
    mean_turn: float,
    mean_pause: float,
    min_turn: float,
    p_overlap: float,
) -> list[SpeechSegment]:
    """The turns of :func:`turn_taking_schedule`'s model, in the order they are drawn."""

    def pause() -> float:
        return rng.gamma(2.0, mean_pause / 2.0) if mean_pause > 0 else 0.0

    if mask is not None:
        n_f = mask.shape[0]
        frame_idx = np.arange(n_f)
        # next_any[i]: first frame >= i in which someone may talk (n_f if none);
        # next_off[i, s]: first frame >= i in which speaker s may not talk (n_f if none).
        next_any = np.minimum.accumulate(np.where(mask.any(axis=1), frame_idx, n_f)[::-1])[::-1]
        next_off = np.minimum.accumulate(np.where(~mask, frame_idx[:, None], n_f)[::-1], axis=0)[
            ::-1
        ]

    def frame_of(time: float) -> int:
        return math.floor(time / frame_s + 1e-9)

    segments: list[SpeechSegment] = []
    everyone = np.ones(n_s, dtype=bool)
    t = pause()
    prev, prev_end = -1, 0.0
    last_end = np.zeros(n_s)  # when each speaker's last turn ends
    while t < dur:
        if mask is None:
            allowed = everyone
        else:
            i = frame_of(t)
            if i >= n_f or next_any[i] == n_f:
                break
            if next_any[i] > i:  # nobody may talk now: wait for someone
                t = next_any[i] * frame_s
                continue
            allowed = mask[i]
        others = np.flatnonzero(allowed & (np.arange(n_s) != prev))
        if others.size:
            spk = int(rng.choice(others))
            # a speaker cut in on by the one who cut in on them: their own turn ends first
            t = max(t, float(last_end[spk]))
        else:  # only the current speaker may talk: a new turn after a pause
            spk = prev
            if t < prev_end:
                t = prev_end + pause()
                continue
        length = max(min_turn, rng.gamma(2.0, mean_turn / 2.0))  # Gamma(2, mean_turn/2)
        end = min(t + length, dur)
        if mask is not None:  # the turn stops when its speaker stops being active
            end = min(end, next_off[frame_of(t), spk] * frame_s)
        if end - t < 1e-3:
            t = end + pause()
            continue
        segments.append(SpeechSegment(spk + 1, t, end))
        prev, prev_end = spk, end
        last_end[spk] = end
        if rng.random() < p_overlap:  # next speaker cuts in before this turn ends
            t = end - min(rng.uniform(0.2, 1.0), 0.5 * (end - t))
        else:
            t = end + pause()
    return segments


def turn_taking_schedule(
    n_speakers: int,
    duration: float,
    rng: np.random.Generator,
    mean_turn: float = 2.5,
    mean_pause: float = 0.6,
    overlap_prob: float = 0.15,
    active: Callable[[float], np.ndarray] | np.ndarray | None = None,
    active_frame_s: float | None = None,
    min_turn: float = 0.3,
) -> list[SpeechSegment]:
    """A conversation: speakers take turns, with pauses and occasional overlaps.

    Model: a turn lasts ``max(min_turn, Gamma(2, mean_turn / 2))`` seconds (mean about
    ``mean_turn``; right-skewed like measured turn lengths). The next speaker is drawn
    uniformly among the speakers allowed to talk other than the current one (the same one only
    when nobody else may talk, and then after a pause). With probability ``overlap_prob`` the
    next turn starts ``U(0.2, 1.0)`` s (at most half the current turn) before the current one
    ends; otherwise after a ``Gamma(2, mean_pause / 2)`` pause.

    Parameters
    ----------
    n_speakers : int
        Number of speakers, ids ``1..n_speakers``.
    duration : float
        Scene length in seconds; segments are clipped to ``[0, duration]``.
    rng : numpy.random.Generator
    mean_turn, mean_pause : float
        Mean turn length and mean pause between turns, seconds.
    overlap_prob : float in [0, 1]
        Probability that a turn change overlaps.
    active : callable or ndarray (F, n_speakers) bool, optional
        Who may talk when: ``active(t) -> (n_speakers,) bool``, or a matrix of frames of
        ``active_frame_s`` seconds (default ``duration / F``; times past the last frame count
        as inactive). A turn ends early when its speaker stops being active. A callable is
        sampled every 10 ms.
    active_frame_s : float, optional
        Frame length of an ``active`` matrix.
    min_turn : float
        Shortest turn, seconds.

    Returns
    -------
    list of SpeechSegment
        Sorted by start (ties by speaker), ``utterance="synthetic"``.
    """
    func = "turn_taking_schedule"
    n_s = _check_count(func, "n_speakers", n_speakers)
    dur = _check_positive(func, "duration", duration)
    _check_rng(func, rng)
    mean_turn = _check_positive(func, "mean_turn", mean_turn)
    mean_pause = _check_positive(func, "mean_pause", mean_pause, allow_zero=True)
    min_turn = _check_positive(func, "min_turn", min_turn)
    p_overlap = float(overlap_prob)
    if not 0.0 <= p_overlap <= 1.0:
        raise ValueError(f"{func}: overlap_prob must be in [0, 1], got {overlap_prob!r}")

    mask, frame_s = _activity_mask(func, active, active_frame_s, dur, n_s)
    segments = _draw_turns(
        rng, n_s, dur, mask, frame_s, mean_turn, mean_pause, min_turn, p_overlap
    )
    segments.sort(key=lambda s: (s.start, s.speaker))
    return segments


def schedule_from_vad(
    vad: np.ndarray,
    frame_s: float,
    min_dur: float = 0.2,
    min_gap: float = 0.0,
    utterance: str = "vad",
) -> list[SpeechSegment]:
    """Segments from a frame-wise voice-activity matrix.

    Frame ``k`` covers ``[k frame_s, (k + 1) frame_s)``; a run of active frames ``a..b``
    becomes the segment ``[a frame_s, (b + 1) frame_s)``. Runs of one speaker separated by
    less than ``min_gap`` seconds are merged first; segments shorter than ``min_dur`` are then
    dropped.

    Parameters
    ----------
    vad : ndarray (F, S) bool or 0/1
        Voice activity of each speaker in each frame (column ``s`` is speaker ``s + 1``), e.g.
        the LOCATA / Kinovis-MST ``speakerVAD`` tracks with 8 ms frames.
    frame_s : float
        Frame length in seconds.
    min_dur, min_gap : float
        Seconds.
    utterance : str
        Stored in every segment.

    Returns
    -------
    list of SpeechSegment
        Sorted by start, ties by speaker.
    """
    func = "schedule_from_vad"
    act = _as_activity(func, "vad", vad)
    frame_s = _check_positive(func, "frame_s", frame_s)
    min_dur = _check_positive(func, "min_dur", min_dur, allow_zero=True)
    min_gap = _check_positive(func, "min_gap", min_gap, allow_zero=True)
    padded = np.zeros((act.shape[0] + 2, act.shape[1]), dtype=np.int8)
    padded[1:-1] = act
    edges = np.diff(padded, axis=0)  # +1 at a run's first frame, -1 after its last
    segments: list[SpeechSegment] = []
    for s in range(act.shape[1]):
        starts = np.flatnonzero(edges[:, s] == 1) * frame_s
        ends = np.flatnonzero(edges[:, s] == -1) * frame_s
        if starts.size and min_gap > 0:
            join = starts[1:] - ends[:-1] < min_gap
            starts = np.concatenate([starts[:1], starts[1:][~join]])
            ends = np.concatenate([ends[:-1][~join], ends[-1:]])
        keep = ends - starts >= min_dur
        segments += [
            SpeechSegment(s + 1, float(a), float(b), utterance)
            for a, b in zip(starts[keep], ends[keep], strict=True)
        ]
    segments.sort(key=lambda seg: (seg.start, seg.speaker))
    return segments


# ---------------------------------------------------------------------------- signals


def load_utterances(folder: str | Path, fs: int = 16000) -> list[tuple[str, np.ndarray]]:
    """Read every mono ``.wav``/``.flac``/``.ogg`` file of a folder, resampled to ``fs``.

    Parameters
    ----------
    folder : str or Path
    fs : int
        Target sample rate; files at another rate are resampled with
        :func:`scipy.signal.resample_poly`.

    Returns
    -------
    list of (str, ndarray (n,))
        ``(file stem, signal)`` sorted by file name.

    Raises
    ------
    InputError
        The folder is missing or holds no audio file, or a file cannot be decoded, is not
        mono, is empty or holds non-finite samples.
    """
    fs = _check_count("load_utterances", "fs", fs)
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(
            "utterance folder not found" if not folder.exists() else "not a folder", folder
        )
    files = sorted(
        p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in AUDIO_SUFFIXES
    )
    if not files:
        raise InputError(f"no audio files ({', '.join(AUDIO_SUFFIXES)}) in the folder", folder)
    out: list[tuple[str, np.ndarray]] = []
    for path in files:
        try:
            x, rate = sf.read(path, dtype="float64", always_2d=True)
        except (sf.SoundFileError, RuntimeError) as exc:
            raise InputError(f"cannot read audio: {exc}", path) from None
        if x.shape[1] != 1:
            raise InputError(f"expected a mono utterance, got {x.shape[1]} channels", path)
        if x.shape[0] == 0:
            raise InputError("empty audio file (0 samples)", path)
        if not np.all(np.isfinite(x)):
            raise InputError("audio holds NaN or infinite samples", path)
        sig = x[:, 0]
        if rate != fs:
            g = math.gcd(int(rate), fs)
            sig = resample_poly(sig, fs // g, int(rate) // g)
        out.append((path.stem, sig))
    return out


def _active_rms(x: np.ndarray, fs: int, floor_db: float = 40.0) -> tuple[float, np.ndarray]:
    """RMS over the 20 ms frames within ``floor_db`` of the loudest, and those frames' mask."""
    hop = max(1, round(0.02 * fs))
    n_frames = max(1, -(-x.size // hop))
    padded = np.zeros(n_frames * hop)
    padded[: x.size] = x
    energy = np.mean(padded.reshape(n_frames, hop) ** 2, axis=1)
    if energy.max() <= 0:
        return 0.0, np.zeros(n_frames, dtype=bool)
    loud = energy >= energy.max() * 10 ** (-floor_db / 10)
    return float(np.sqrt(np.mean(energy[loud]))), loud


def _prepare_utterance(x: np.ndarray, fs: int) -> np.ndarray:
    """Trim leading/trailing silence (20 ms frames 40 dB below the loudest), unit active RMS."""
    rms, loud = _active_rms(x, fs)
    if rms == 0:
        return np.zeros(0)
    hop = max(1, round(0.02 * fs))
    idx = np.flatnonzero(loud)
    y = x[idx[0] * hop : (idx[-1] + 1) * hop]
    return y / rms


def synthetic_speech(
    duration_s: float, fs: int, rng: np.random.Generator, f0: float | None = None
) -> np.ndarray:
    """A speech-like signal, for scenes without real utterances.

    Syllables of ``Gamma(4, 1/16)`` s (about 4 per second, 80–600 ms) alternate with short
    pauses (probability 0.12 per unit, ``Gamma(2, 0.1)`` s). Each syllable is a harmonic
    source (harmonic ``k`` with amplitude ``1/k``, up to ``min(0.45 fs, 5 kHz)``) on an f0
    contour ``f0 · exp(0.08 n_syl)`` with 0.5 % jitter, shaped by three vowel formants
    (cascade of resonators ``|H_i(f)| = F_i^2 / sqrt((F_i^2 - f^2)^2 + (B_i f)^2)``) that
    glide from one syllable's vowel to the next, under a ``sin(π x)^0.6`` envelope. A third
    of the syllables start with an unvoiced burst of high-pass noise (40–120 ms). The signal
    is exactly 0 in pauses and has
    unit RMS over the active samples.

    Parameters
    ----------
    duration_s : float
        Length in seconds (``round(duration_s fs)`` samples).
    fs : int
        Sample rate, Hz.
    rng : numpy.random.Generator
    f0 : float, optional
        Mean fundamental frequency in Hz; by default ``U(100, 220)``.

    Returns
    -------
    ndarray (n,)
    """
    func = "synthetic_speech"
    dur = _check_positive(func, "duration_s", duration_s, allow_zero=True)
    fs = _check_count(func, "fs", fs)
    _check_rng(func, rng)
    f_mean = rng.uniform(100.0, 220.0) if f0 is None else _check_positive(func, "f0", f0)
    n_out = round(dur * fs)
    if n_out == 0:
        return np.zeros(0)
    nper = min(512, max(16, 2 ** int(math.log2(max(16, 0.032 * fs)))))  # STFT frame, ~32 ms
    n = max(n_out, nper, 64)  # samples generated; the first n_out are returned

    # Units: syllables or pauses, laid end to end (each >= 80 ms, so k units suffice).
    k = math.ceil(n / fs / 0.08) + 2
    is_syl = rng.random(k) >= 0.12
    is_syl[0] = True
    length_s = np.where(
        is_syl,
        np.clip(rng.gamma(4.0, 1 / 16, k), 0.08, 0.6),
        np.clip(rng.gamma(2.0, 0.1, k), 0.08, 0.5),
    )
    lengths = np.maximum(1, np.ceil(length_s * fs)).astype(np.int64)
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    i = np.arange(n)
    unit = np.searchsorted(starts, i, side="right") - 1  # unit of each sample
    pos = i - starts[unit]  # sample index within its unit
    x = pos / lengths[unit]
    amp = rng.uniform(0.6, 1.0, k)
    env_v = np.where(is_syl[unit], amp[unit] * np.sin(np.pi * x) ** 0.6, 0.0)
    burst = is_syl & (rng.random(k) < 1 / 3)
    burst_len = np.maximum(1, np.round(rng.uniform(0.04, 0.12, k) * fs)).astype(np.int64)
    in_burst = burst[unit] & (pos < burst_len[unit])
    env_u = np.where(in_burst, 0.3 * np.sin(np.pi * pos / burst_len[unit]), 0.0)

    # f0 contour: one target per unit, glided, with cycle-to-cycle jitter.
    centres = starts + lengths / 2
    f_target = f_mean * np.exp(0.08 * rng.standard_normal(k))
    f_inst = np.interp(i, centres, f_target)
    jitter = np.convolve(rng.standard_normal(n), np.ones(40) / np.sqrt(40), mode="same")
    f_inst *= 1.0 + 0.005 * jitter
    source = _harmonic_source(f_inst, fs)
    noise = rng.standard_normal(n)
    vowel = _VOWELS[rng.integers(0, len(_VOWELS), k)] * (1 + 0.15 * (f_mean - 100) / 120)
    voiced, unvoiced = _shape_formants(source, noise, fs, nper, centres, vowel)

    y = (env_v * voiced + env_u * unvoiced)[:n_out]
    active = ((env_v > 0) | (env_u > 0))[:n_out]
    rms = np.sqrt(np.mean(y[active] ** 2)) if active.any() else 0.0
    return y / rms if rms > 0 else y


def _harmonic_source(f_inst: np.ndarray, fs: int) -> np.ndarray:
    """``(n,)`` harmonic source on the f0 contour ``f_inst`` ``(n,)`` Hz: harmonic ``h`` with
    amplitude ``1/h``, up to ``min(0.45 fs, 5 kHz)``."""
    n = f_inst.shape[0]
    phase = 2 * np.pi * np.cumsum(f_inst) / fs  # φ(t) = 2π ∫ f0
    # Σ_h sin(h φ) / h over the harmonics below min(0.45 fs, 5 kHz) everywhere; e^{i h φ} by
    # repeated multiplication (cheaper than h sines).
    n_harm = max(1, int(min(0.45 * fs, 5000.0) / f_inst.max()))
    z = np.exp(1j * phase)
    zh = z.copy()
    source = np.zeros(n)
    for h in range(1, n_harm + 1):
        source += zh.imag / h
        zh *= z
    return source


def _shape_formants(
    source: np.ndarray,
    noise: np.ndarray,
    fs: int,
    nper: int,
    centres: np.ndarray,
    vowel: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The voiced and unvoiced signals ``(n,)``, each of unit RMS: ``source`` through the
    vowel formants ``vowel`` ``(K, 3)`` Hz (interpolated between the unit ``centres`` ``(K,)``,
    samples), and ``noise`` high-passed, both filtered in the STFT domain."""
    n = source.shape[0]
    # Formant shaping in the STFT domain, formant tracks interpolated between syllables.
    hop = nper // 4
    freqs, times, spec_v = stft(source, fs, nperseg=nper, noverlap=nper - hop)
    _, _, spec_u = stft(noise, fs, nperseg=nper, noverlap=nper - hop)
    tracks = np.stack([np.interp(times * fs, centres, vowel[:, j]) for j in range(3)])  # (3, M)
    fr = freqs[:, None, None]
    fmt = tracks.T[None, :, :]  # (1, M, 3)
    # |H(f)| = Π_i F_i^2 / sqrt((F_i^2 - f^2)^2 + (B_i f)^2)
    gain_v = np.prod(fmt**2 / np.sqrt((fmt**2 - fr**2) ** 2 + (_BANDWIDTHS * fr) ** 2), axis=2)
    f_safe = np.maximum(freqs, 1.0)
    gain_u = 1 / np.sqrt(1 + (2500 / f_safe) ** 4) / np.sqrt(1 + (f_safe / 7000) ** 4)
    _, voiced = istft(spec_v * gain_v, fs, nperseg=nper, noverlap=nper - hop)
    _, unvoiced = istft(spec_u * gain_u[:, None], fs, nperseg=nper, noverlap=nper - hop)
    voiced = _fit(voiced, n)
    unvoiced = _fit(unvoiced, n)
    voiced /= max(np.sqrt(np.mean(voiced**2)), 1e-12)
    unvoiced /= max(np.sqrt(np.mean(unvoiced**2)), 1e-12)
    return voiced, unvoiced


def _fit(x: np.ndarray, n: int) -> np.ndarray:
    """``x`` cut or zero-padded to ``n`` samples."""
    out = np.zeros(n)
    m = min(n, x.size)
    out[:m] = x[:m]
    return out


def fill_segments(
    segments: Sequence[SpeechSegment],
    utterances: Sequence[tuple[str, np.ndarray]],
    fs: int,
    n_speakers: int,
    duration: float,
    rng: np.random.Generator,
) -> np.ndarray:
    """Dry signal of each speaker: speech inside their segments, exact zeros elsewhere.

    Each segment is filled with utterances drawn at random (with replacement) and concatenated
    until it is long enough, then cut to the segment, with 10 ms raised-cosine fades at both
    ends. Utterances are first trimmed of leading and trailing silence (20 ms frames 40 dB
    below the loudest) and scaled to unit RMS over their active frames. Without utterances
    each speaker gets :func:`synthetic_speech` with a voice of their own (f0 ~ U(100, 220) Hz).

    Parameters
    ----------
    segments : sequence of SpeechSegment
        Segments of one speaker must not overlap; parts past ``duration`` are dropped.
    utterances : sequence of (str, ndarray (n,))
        As returned by :func:`load_utterances`, at ``fs``; may be empty.
    fs : int
        Sample rate, Hz.
    n_speakers : int
        Number of output rows; every segment's speaker must be ``<= n_speakers``.
    duration : float
        Scene length, seconds (``round(duration fs)`` samples).
    rng : numpy.random.Generator

    Returns
    -------
    ndarray (n_speakers, n_samples)
    """
    func = "fill_segments"
    fs = _check_count(func, "fs", fs)
    n_s = _check_count(func, "n_speakers", n_speakers)
    dur = _check_positive(func, "duration", duration)
    _check_rng(func, rng)
    segs = list(segments)
    utterances = list(utterances)
    for s in segs:
        if not isinstance(s, SpeechSegment):
            raise TypeError(f"{func}: segments must be SpeechSegment, got {type(s).__name__}")
        if s.speaker > n_s:
            raise ValueError(f"{func}: segment speaker {s.speaker} > n_speakers ({n_s})")
    segs.sort(key=lambda s: (s.speaker, s.start))
    for prev, seg in itertools.pairwise(segs):
        if prev.speaker == seg.speaker and seg.start < prev.end:
            raise ValueError(
                f"{func}: segments of speaker {prev.speaker} overlap "
                f"([{prev.start:g}, {prev.end:g}] and [{seg.start:g}, {seg.end:g}])"
            )
    material: list[np.ndarray] = []
    for item in utterances:
        try:
            name, sig = item
        except (TypeError, ValueError):
            raise ValueError(f"{func}: utterances must be (name, signal) pairs") from None
        x = np.asarray(sig, dtype=float)
        if x.ndim != 1 or x.size == 0 or not np.all(np.isfinite(x)):
            raise ValueError(
                f"{func}: utterance {name!r} must be a non-empty finite 1-D "
                f"signal, got shape {x.shape}"
            )
        y = _prepare_utterance(x, fs)
        if y.size:
            material.append(y)
    if utterances and not material:
        raise ValueError(f"{func}: every utterance is silent")
    voices = None if material else rng.uniform(100.0, 220.0, n_s)

    n = round(dur * fs)
    out = np.zeros((n_s, n))
    n_fade = round(0.01 * fs)
    for s in sorted(segs, key=lambda s: (s.start, s.speaker)):
        a, b = round(s.start * fs), min(round(s.end * fs), n)
        m = b - a
        if m <= 0:
            continue
        if voices is None:
            pieces, total = [], 0
            while total < m:
                piece = material[int(rng.integers(len(material)))]
                pieces.append(piece)
                total += piece.size
            x = np.concatenate(pieces)[:m]
        else:
            x = _fit(synthetic_speech(m / fs, fs, rng, f0=voices[s.speaker - 1]), m)
        nf = min(n_fade, m // 2)
        if nf > 0:
            ramp = 0.5 - 0.5 * np.cos(np.pi * (np.arange(nf) + 0.5) / nf)  # raised cosine
            x[:nf] *= ramp
            x[m - nf :] *= ramp[::-1]
        out[s.speaker - 1, a:b] = x
    return out
