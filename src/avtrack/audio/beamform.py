r"""One voice per tracked person: an MVDR beamformer steered at the person's tracked direction.

For person :math:`p`, at STFT frame :math:`t` and frequency :math:`f`, with the microphone
spectra :math:`\mathbf{x}(f, t) \in \mathbb{C}^M` and the steering vector
:math:`\mathbf{d}_p(f, t)` of the person's direction at that frame (relative to microphone 0,
so the output estimates the person's speech as microphone 0 hears it),

.. math::
    \mathbf{w}_p(f, t) = \frac{\boldsymbol{\Phi}_p^{-1}(f, t)\,\mathbf{d}_p(f, t)}
        {\mathbf{d}_p^H(f, t)\,\boldsymbol{\Phi}_p^{-1}(f, t)\,\mathbf{d}_p(f, t)},
    \qquad
    \hat s_p(f, t) = g_p(t)\,\mathbf{w}_p^H(f, t)\,\mathbf{x}(f, t)

(minimum variance distortionless response: Capon, "High-resolution frequency-wavenumber
spectrum analysis", Proc. IEEE, 1969; Van Veen and Buckley, "Beamforming: a versatile approach
to spatial filtering", IEEE ASSP Magazine, 1988). :math:`\boldsymbol{\Phi}_p` is the covariance
of everything but person :math:`p`: the mean of :math:`\mathbf{x}\mathbf{x}^H` over the frames
where the tracker says :math:`p` is silent (at least ``margin_s`` from any of their turns),
within ``context_s`` seconds of frame :math:`t` (the other talkers move), plus diagonal loading
:math:`\delta\,\mathrm{tr}(\boldsymbol{\Phi})/M\,\mathbf{I}` against steering errors
(reverberation, a few degrees of tracking error). :math:`g_p(t)` is 1 during the person's
turns (widened by ``lead_s`` before and ``hangover_s`` after) and ``floor_db`` outside, so the
voice is silent when the person does not speak.

Steering vectors: for a free-field array the plane wave's phases,
:math:`d_m = e^{-j 2\pi f (\tau_m - \tau_0)}` with :math:`\tau_m` from
:func:`~avtrack.audio.arrays.steering_delays`; for an HRIR array the measured transfer
functions of the nearest measured direction, divided by microphone 0's.

Why by hand: pyroomacoustics' ``Beamformer`` designs fixed time-domain filters for source
*positions* known in advance (``rake_mvdr_filters``), with the noise given as positions or a
white level; here the direction changes every frame and the noise covariance is estimated
from the recording, per person, which none of its beamformers does. The STFT and its inverse
are scipy's (``scipy.signal.stft`` / ``istft``).

Shapes: signals ``(n_channels, n_samples)``, STFT ``(n_channels, n_freqs, n_frames)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.signal
import soundfile as sf

from avtrack.audio.arrays import MicArray, steering_delays
from avtrack.io.base import atomic_write
from avtrack.io.doa import DOATable
from avtrack.io.persons import PersonsTable
from avtrack.io.rttm import RTTMSegment


@dataclass(frozen=True)
class BeamformerConfig:
    """Parameters of :func:`extract_voices`.

    Attributes
    ----------
    win_len, hop : int
        STFT window (Hann) and shift, samples (512 and 256: 32 and 16 ms at 16 kHz).
    loading : float
        Diagonal loading :math:`\\delta`, a fraction of the mean noise power per microphone.
    context_s : float
        The noise covariance of a frame averages the person's silent frames within this many
        seconds of it (``inf``: the whole recording).
    margin_s : float
        Frames closer than this to one of the person's turns are not noise frames (the turns
        the tracker reports start late and end early).
    lead_s, hangover_s : float
        The voice opens this long before a turn and closes this long after it.
    floor_db : float
        Gain of the voice outside the person's turns, dB (``-inf``: zeros).
    """

    win_len: int = 512
    hop: int = 256
    loading: float = 1.0
    context_s: float = 10.0
    margin_s: float = 0.3
    lead_s: float = 0.1
    hangover_s: float = 0.3
    floor_db: float = float("-inf")

    def __post_init__(self) -> None:
        for name in ("win_len", "hop"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | np.integer) or v <= 0:
                raise ValueError(f"BeamformerConfig: {name} must be a positive integer, got {v!r}")
        if self.hop > self.win_len // 2:
            raise ValueError(f"BeamformerConfig: hop must be <= win_len / 2 (the inverse STFT "
                             f"needs overlapping windows), got {self.hop}")
        if not (np.isfinite(self.loading) and self.loading >= 0):
            raise ValueError(f"BeamformerConfig: loading must be >= 0, got {self.loading!r}")
        if not self.context_s > 0:
            raise ValueError(f"BeamformerConfig: context_s must be > 0, got {self.context_s!r}")
        for name in ("margin_s", "lead_s", "hangover_s"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise ValueError(f"BeamformerConfig: {name} must be >= 0 seconds, got {v!r}")
        if not self.floor_db <= 0:
            raise ValueError(f"BeamformerConfig: floor_db must be <= 0 dB, got {self.floor_db!r}")


@dataclass(frozen=True)
class VoiceTrack:
    """A tracked person as the beamformer needs them.

    Attributes
    ----------
    id : int
        The tracker's identity.
    time_s : ndarray (K,)
        Times of the track's rows, increasing.
    azimuth_deg, elevation_deg : ndarray (K,)
        The person's direction in the array frame at those times.
    turns : ndarray (S, 2)
        The person's speaker turns, ``(start, end)`` seconds.
    """

    id: int
    time_s: np.ndarray
    azimuth_deg: np.ndarray
    elevation_deg: np.ndarray
    turns: np.ndarray

    def __post_init__(self) -> None:
        t = np.asarray(self.time_s, dtype=float).reshape(-1)
        az = np.asarray(self.azimuth_deg, dtype=float).reshape(-1)
        el = np.asarray(self.elevation_deg, dtype=float).reshape(-1)
        if t.size == 0 or az.shape != t.shape or el.shape != t.shape:
            raise ValueError(f"VoiceTrack {self.id}: time_s, azimuth_deg and elevation_deg must "
                             f"be non-empty and of one length, got {t.size}, {az.size}, {el.size}")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(az)) and np.all(np.isfinite(el))):
            raise ValueError(f"VoiceTrack {self.id}: times and directions must be finite")
        if np.any(np.diff(t) < 0):
            raise ValueError(f"VoiceTrack {self.id}: time_s must be increasing")
        turns = np.asarray(self.turns, dtype=float).reshape(-1, 2)
        if not np.all(turns[:, 1] >= turns[:, 0]):
            raise ValueError(f"VoiceTrack {self.id}: turns must be (start, end) with end >= start")
        object.__setattr__(self, "time_s", t)
        object.__setattr__(self, "azimuth_deg", az)
        object.__setattr__(self, "elevation_deg", el)
        object.__setattr__(self, "turns", turns)


def steering_vectors(
    array: MicArray, azimuth_deg: np.ndarray, elevation_deg: np.ndarray, freqs_hz: np.ndarray
) -> np.ndarray:
    """Steering vectors relative to microphone 0.

    Parameters
    ----------
    array : MicArray
        Free-field (plane-wave phases) or HRIR (measured transfer functions of the nearest
        measured direction).
    azimuth_deg, elevation_deg : ndarray (N,)
        Directions in the array frame.
    freqs_hz : ndarray (F,)
        Frequencies, ``0 <= f <= fs / 2`` for an HRIR array.

    Returns
    -------
    ndarray (N, F, M) complex, ``[..., 0] == 1``
    """
    az = np.atleast_1d(np.asarray(azimuth_deg, dtype=float))
    el = np.broadcast_to(np.asarray(elevation_deg, dtype=float), az.shape)
    f = np.asarray(freqs_hz, dtype=float)
    if array.kind == "free-field":
        tau = steering_delays(array, az, el).reshape(az.size, array.n_mics)  # (N, M)
        rel = tau - tau[:, :1]  # delays relative to microphone 0
        # d_m = exp(-j 2 pi f (tau_m - tau_0))
        return np.exp(-2j * np.pi * f[None, :, None] * rel[:, None, :])
    if array.hrir is None:
        raise ValueError(f"steering_vectors: array {array.name!r} of kind {array.kind!r} has no "
                         f"HRIR set")
    hrir = array.hrir
    fs = hrir.fs
    if np.any(f > fs / 2 + 1e-9) or np.any(f < 0):
        raise ValueError(f"steering_vectors: frequencies must be in [0, {fs / 2:g}] Hz for the "
                         f"HRIR set at {fs} Hz")
    idx = np.array([hrir.nearest_index(a, e) for a, e in zip(az, el, strict=True)])
    n = hrir.length
    k = f * n / fs  # fractional DFT bins of each frequency
    taps = np.arange(n)
    basis = np.exp(-2j * np.pi * np.outer(k, taps) / n)  # (F, L)
    tf = np.einsum("dml,fl->dfm", hrir.irs[idx], basis)  # H_m(f) of each direction
    h0 = tf[:, :, :1]
    eps = 1e-6 * np.max(np.abs(tf), axis=(1, 2), keepdims=True)
    return tf * h0.conj() / (np.abs(h0) ** 2 + eps**2)  # H_m / H_0, regularised


def mvdr_weights(noise_cov: np.ndarray, steering: np.ndarray, loading: float) -> np.ndarray:
    """MVDR weights ``w = Phi^-1 d / (d^H Phi^-1 d)``.

    Parameters
    ----------
    noise_cov : ndarray (..., M, M)
        Hermitian noise covariances.
    steering : ndarray (..., M)
        Steering vectors (broadcast against ``noise_cov``'s leading axes).
    loading : float
        Diagonal loading, a fraction of ``tr(Phi) / M``.

    Returns
    -------
    ndarray (..., M) complex
    """
    m = noise_cov.shape[-1]
    power = np.real(np.trace(noise_cov, axis1=-2, axis2=-1)) / m
    eye = np.eye(m)
    loaded = noise_cov + (loading * power + 1e-12)[..., None, None] * eye  # Phi + delta I
    num = np.linalg.solve(loaded, steering[..., None])[..., 0]  # Phi^-1 d
    den = np.sum(steering.conj() * num, axis=-1)  # d^H Phi^-1 d
    return num / den[..., None]


def _in_turns(times: np.ndarray, turns: np.ndarray, before: float, after: float) -> np.ndarray:
    """Whether each time lies in one of ``turns`` widened by ``before`` and ``after``."""
    out = np.zeros(times.shape, dtype=bool)
    for a, b in turns:
        out |= (times >= a - before) & (times < b + after)
    return out


def _direction_at(track: VoiceTrack, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The track's direction at ``times``: its row nearest in time (azimuths do not wrap
    through an interpolation)."""
    i = np.clip(np.searchsorted(track.time_s, times), 1, max(track.time_s.size - 1, 1))
    if track.time_s.size == 1:
        i = np.zeros(times.shape, dtype=int)
    else:
        left = track.time_s[i - 1]
        i = np.where(np.abs(times - left) <= np.abs(track.time_s[i] - times), i - 1, i)
    return track.azimuth_deg[i], track.elevation_deg[i]


def _local_sums(xx: np.ndarray, weight: np.ndarray, block: int, reach: int):
    """Per block of ``block`` frames, the weighted sum of the outer products over the blocks
    within ``reach`` blocks, and the weights' sum. ``xx`` is the STFT ``(F, T, M)``."""
    n_f, n_t, m = xx.shape
    n_b = -(-n_t // block)
    sums = np.zeros((n_b, n_f, m, m), dtype=complex)
    counts = np.zeros(n_b)
    for b in range(n_b):
        sl = slice(b * block, min((b + 1) * block, n_t))
        xb = xx[:, sl, :]
        wb = weight[sl]
        if not np.any(wb):
            continue
        sums[b] = np.einsum("ftm,ftn->fmn", xb * wb[None, :, None], xb.conj())  # sum x x^H
        counts[b] = wb.sum()
    c_sums = np.concatenate([np.zeros((1, n_f, m, m), complex), np.cumsum(sums, axis=0)])
    c_counts = np.concatenate([[0.0], np.cumsum(counts)])
    lo = np.clip(np.arange(n_b) - reach, 0, n_b)
    hi = np.clip(np.arange(n_b) + reach + 1, 0, n_b)
    return c_sums[hi] - c_sums[lo], c_counts[hi] - c_counts[lo]


def extract_voices(
    audio: np.ndarray,
    fs: int,
    array: MicArray,
    tracks: Sequence[VoiceTrack],
    config: BeamformerConfig | None = None,
) -> dict[int, np.ndarray]:
    """Each tracked person's voice (see the module docstring).

    Parameters
    ----------
    audio : ndarray (n_mics, n_samples)
        The array's recording; channel ``m`` is microphone ``m`` of ``array``.
    fs : int
        Sampling rate, Hz.
    array : MicArray
    tracks : sequence of VoiceTrack
    config : BeamformerConfig, optional

    Returns
    -------
    dict ``{id: ndarray (n_samples,)}``
        Each person's voice as microphone 0 would hear it alone; zeros (or ``floor_db``) outside
        the person's turns and while the person is not tracked.
    """
    cfg = config or BeamformerConfig()
    x = np.asarray(audio, dtype=float)
    if x.ndim != 2 or x.shape[0] != array.n_mics:
        raise ValueError(f"extract_voices: audio must have shape ({array.n_mics}, n_samples) for "
                         f"array {array.name!r}, got {x.shape}")
    if x.shape[1] < cfg.win_len:
        raise ValueError(f"extract_voices: audio must be at least {cfg.win_len} samples long, "
                         f"got {x.shape[1]}")
    if array.kind == "hrtf" and array.hrir is not None and array.hrir.fs != fs:
        array = MicArray(array.name, array.positions, array.kind, array.hrir.resampled(fs))
    n = x.shape[1]
    kw = {"fs": fs, "window": "hann", "nperseg": cfg.win_len, "noverlap": cfg.win_len - cfg.hop}
    freqs, times, spec = scipy.signal.stft(x, **kw)  # (M, F, T)
    xx = np.ascontiguousarray(np.moveaxis(spec, 0, -1))  # (F, T, M)
    block = max(1, round(1.0 * fs / cfg.hop))  # one-second blocks of the noise covariance
    reach = (xx.shape[1] if not np.isfinite(cfg.context_s)
             else max(0, round(cfg.context_s * fs / cfg.hop / block)))
    floor = 10 ** (cfg.floor_db / 20) if np.isfinite(cfg.floor_db) else 0.0
    voices = {}
    for tr in tracks:
        present = (times >= tr.time_s[0] - cfg.lead_s) & (times <= tr.time_s[-1] + cfg.hangover_s)
        speaking = _in_turns(times, tr.turns, cfg.lead_s, cfg.hangover_s) & present
        if not np.any(speaking):
            voices[tr.id] = np.zeros(n)
            continue
        noise = ~_in_turns(times, tr.turns, cfg.margin_s, cfg.margin_s)
        sums, counts = _local_sums(xx, noise.astype(float), block, reach)
        if counts.max() == 0:  # the person speaks all the time: no noise frames at all
            sums, counts = _local_sums(xx, np.ones(times.size), block, reach)
        total = sums.sum(axis=0) / max(counts.sum(), 1.0)  # the whole recording's estimate
        few = counts < block  # under a second of noise frames nearby: use the global one
        cov = np.where(few[:, None, None, None], total[None],
                       sums / np.maximum(counts, 1.0)[:, None, None, None])  # (B, F, M, M)
        out = np.zeros(xx.shape[:2], dtype=complex)
        for b in np.unique(np.flatnonzero(speaking) // block):
            t_idx = b * block + np.flatnonzero(speaking[b * block : (b + 1) * block])
            az, el = _direction_at(tr, times[t_idx])
            d = steering_vectors(array, az, el, freqs)  # (K, F, M)
            w = mvdr_weights(cov[b][None], d, cfg.loading)  # (K, F, M)
            out[:, t_idx] = np.einsum("kfm,fkm->fk", w.conj(), xx[:, t_idx, :])  # w^H x
        gain = np.where(speaking, 1.0, floor)
        if floor > 0:
            # outside the turns: microphone 0 attenuated (there is no steering there)
            out[:, ~speaking] = xx[:, ~speaking, 0]
        out *= gain[None, :]
        _, y = scipy.signal.istft(out, **kw)
        voice = np.zeros(n)
        voice[: min(n, y.size)] = y[:n]
        voices[tr.id] = voice
    return voices


def tracks_from_persons(persons: PersonsTable, speech: Sequence[RTTMSegment]) -> list[VoiceTrack]:
    """One :class:`VoiceTrack` per person of ``persons.csv``, their turns from the speaker
    turns labelled ``P<id>`` (``speech.rttm`` of ``avtrack track-av``)."""
    out = []
    for pid in np.unique(persons.ids):
        m = persons.ids == pid
        turns = [(s.start, s.start + s.duration) for s in speech if s.speaker == f"P{pid}"]
        out.append(VoiceTrack(int(pid), (persons.frames[m] - 1) / persons.fps,
                              persons.azimuth_deg[m], persons.elevation_deg[m],
                              np.array(turns, dtype=float).reshape(-1, 2)))
    return out


def tracks_from_doa(tracks: DOATable, frame_period_s: float) -> list[VoiceTrack]:
    """One :class:`VoiceTrack` per track of a DOA track table (``avtrack track-audio``): its
    turns are the runs of rows with ``active`` set, each row lasting ``frame_period_s``."""
    out = []
    for tid in np.unique(tracks.ids):
        m = np.flatnonzero(tracks.ids == tid)
        t = np.asarray(tracks.time_s, dtype=float)[m]
        act = np.asarray(tracks.active, dtype=bool)[m]
        edges = np.diff(np.concatenate([[0], act.astype(int), [0]]))
        starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
        turns = np.column_stack([t[starts], t[ends] + frame_period_s]) if starts.size else (
            np.zeros((0, 2)))
        out.append(VoiceTrack(int(tid), t, np.asarray(tracks.azimuth_deg, float)[m],
                              np.asarray(tracks.elevation_deg, float)[m], turns))
    return out


def write_voices(folder: str | Path, voices: dict[int, np.ndarray], fs: int) -> list[Path]:
    """Write ``folder/<id>.wav`` (float32 mono) for every voice, each atomically; returns the
    paths."""
    folder = Path(folder)
    paths = []
    for pid, sig in sorted(voices.items()):
        path = folder / f"{pid}.wav"
        with atomic_write(path, "wb") as fh:
            sf.write(fh, np.asarray(sig, dtype=np.float32), int(fs), format="WAV",
                     subtype="FLOAT")
        paths.append(path)
    return paths
