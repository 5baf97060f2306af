r"""Audio observations for audio-visual tracking (thesis §4.7.2) and voice activity.

Pipeline, per the thesis: STFT of every microphone (16 ms Hann window, 8 ms hop at 16 kHz:
128 bins, 125 frames/s, :mod:`avtrack.audio.stft`), DP-RTF features robust to noise and
reverberation (:mod:`avtrack.audio.dprtf`, thesis §5.2), **averaged over the STFT frames of
each video frame** (five at 25 fps), then split into ``K = 16`` sub-bands of ``L = 8``
consecutive frequencies. Sub-band ``k`` of video frame ``t`` gives the observation

.. math::
    g_{tk} = \big(\Re\hat c_{t,f}^{i},\ \Im\hat c_{t,f}^{i}\big)_{i=2..I,\ f\in\text{band }k}
        \in \mathbb{R}^{D},\qquad D = 2L(I-1)

(:math:`\hat c^i_{t,f}` the DP-RTF of microphone ``i`` against microphone 1; ``D = 2L = 16``
for a binaural head, as in thesis §4.3.1, and ``48`` for a 4-microphone array).

**Low-energy sub-bands are dropped.** A time-frequency bin enters the average only when the
DP-RTF estimator classed it as speech (reference power at least ``speech_ratio`` times the
minimum-statistics noise level, :mod:`avtrack.audio.noise`) and its estimate passed the
consistency test; a sub-band is *active* when every one of its bins has at least one such
STFT frame in the video frame and at least ``min_valid_fraction`` of its cells do, and when
its mean reference power is within ``max_band_drop_db`` of the loudest sub-band of that
video frame. This leaves the :math:`K_t \le K` observations of thesis §4.3.1.

**Voice activity** (Algorithm 1, "perform voice activity detection"): a video frame is a
speech frame when at least ``vad_min_fraction`` of its bins between ``vad_band_hz`` are
speech bins; audio observations of non-speech frames are discarded (``K_t = 0``).

With two microphones the DP-RTF consistency test (which needs a third channel) is disabled.
Shapes: signals ``(n_channels, n_samples)``; features ``(n_frames, K, D)``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from avtrack.audio.dprtf import DPRTFConfig, DPRTFEstimator
from avtrack.audio.stft import STFTConfig, StreamingSTFT


@dataclass(frozen=True)
class AudioFeatureConfig:
    """Parameters of the audio observations (thesis §4.7.2).

    Attributes
    ----------
    fps : float
        Video frame rate; the DP-RTFs are averaged over the STFT frames of each video frame.
    n_bands : int
        ``K`` sub-bands (16 in the thesis).
    band_size : int
        ``L`` frequencies per sub-band (8); ``n_bands * band_size <= stft.n_freqs``.
    first_bin : int
        Lowest STFT bin of sub-band 0.
    min_valid_fraction : float
        Fraction of a sub-band's (channel, bin, STFT frame) cells that must hold a valid
        DP-RTF for the sub-band to be active, in (0, 1].
    max_band_drop_db : float
        A sub-band more than this many dB below the loudest sub-band of the frame is dropped.
    vad_min_fraction : float
        A video frame is a speech frame when this fraction of its bins in ``vad_band_hz`` are
        speech bins.
    vad_band_hz : (float, float)
        Frequency range of the voice activity decision.
    stft : STFTConfig
    dprtf : DPRTFConfig or None
        None: :class:`~avtrack.audio.dprtf.DPRTFConfig` defaults (consistency test off for two
        microphones).
    """

    fps: float = 25.0
    n_bands: int = 16
    band_size: int = 8
    first_bin: int = 0
    min_valid_fraction: float = 0.4
    max_band_drop_db: float = 30.0
    vad_min_fraction: float = 0.2
    vad_band_hz: tuple[float, float] = (200.0, 4000.0)
    stft: STFTConfig = field(default_factory=STFTConfig)
    dprtf: DPRTFConfig | None = None

    def __post_init__(self) -> None:
        if not (isinstance(self.fps, int | float) and np.isfinite(self.fps) and self.fps > 0):
            raise ValueError(f"AudioFeatureConfig: fps must be > 0, got {self.fps!r}")
        for name in ("n_bands", "band_size"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ValueError(f"AudioFeatureConfig: {name} must be an integer >= 1, got {v!r}")
        if (
            isinstance(self.first_bin, bool)
            or not isinstance(self.first_bin, int)
            or (self.first_bin < 0)
        ):
            raise ValueError(
                f"AudioFeatureConfig: first_bin must be an integer >= 0, got {self.first_bin!r}"
            )
        last = self.first_bin + self.n_bands * self.band_size
        if last > self.stft.n_freqs:
            raise ValueError(
                f"AudioFeatureConfig: first_bin + n_bands * band_size = {last} exceeds the "
                f"{self.stft.n_freqs} STFT bins"
            )
        if not 0 < self.min_valid_fraction <= 1:
            raise ValueError(
                "AudioFeatureConfig: min_valid_fraction must be in (0, 1], "
                f"got {self.min_valid_fraction!r}"
            )
        if not (np.isfinite(self.max_band_drop_db) and self.max_band_drop_db > 0):
            raise ValueError(
                f"AudioFeatureConfig: max_band_drop_db must be > 0, got {self.max_band_drop_db!r}"
            )
        if not 0 <= self.vad_min_fraction <= 1:
            raise ValueError(
                "AudioFeatureConfig: vad_min_fraction must be in [0, 1], "
                f"got {self.vad_min_fraction!r}"
            )
        lo, hi = self.vad_band_hz
        if not 0 <= lo < hi:
            raise ValueError(
                f"AudioFeatureConfig: vad_band_hz must be (lo, hi) with 0 <= lo < hi, "
                f"got {self.vad_band_hz!r}"
            )

    def feature_dim(self, n_channels: int) -> int:
        """``D = 2 L (n_channels - 1)``."""
        return 2 * self.band_size * (n_channels - 1)

    def band_bins(self) -> np.ndarray:
        """``(K, L)`` STFT bin indices of each sub-band."""
        return self.first_bin + np.arange(self.n_bands * self.band_size).reshape(
            self.n_bands, self.band_size
        )

    def dprtf_config(self, n_channels: int) -> DPRTFConfig:
        """The DP-RTF configuration used with ``n_channels`` microphones."""
        cfg = self.dprtf if self.dprtf is not None else DPRTFConfig()
        if n_channels < 3 and cfg.consistency_threshold > 0:
            cfg = dataclasses.replace(cfg, consistency_threshold=0.0)
        return cfg


@dataclass(frozen=True)
class AudioFeatures:
    """Audio observations of a run of video frames.

    Attributes
    ----------
    features : ndarray (T, K, D)
        :math:`g_{tk}`; 0 where the sub-band is not active.
    active : ndarray (T, K) bool
        Active sub-bands (already False in non-speech frames).
    vad : ndarray (T,) bool
        Voice activity of each video frame.
    speech_fraction : ndarray (T,)
        Fraction of speech bins in the VAD band (the VAD statistic).
    band_power : ndarray (T, K)
        Mean reference-microphone power of each sub-band (linear).
    """

    features: np.ndarray
    active: np.ndarray
    vad: np.ndarray
    speech_fraction: np.ndarray
    band_power: np.ndarray

    def __post_init__(self) -> None:
        t = self.features.shape[0] if self.features.ndim == 3 else -1
        if t < 0 or self.active.shape != self.features.shape[:2]:
            raise ValueError(
                f"AudioFeatures: features must be (T, K, D) and active (T, K), got "
                f"{self.features.shape} and {self.active.shape}"
            )
        for name in ("vad", "speech_fraction"):
            if getattr(self, name).shape != (t,):
                raise ValueError(f"AudioFeatures: {name} must be ({t},)")
        if self.band_power.shape != self.active.shape:
            raise ValueError(f"AudioFeatures: band_power must be {self.active.shape}")

    def __len__(self) -> int:
        return int(self.features.shape[0])

    @property
    def n_bands(self) -> int:
        return int(self.features.shape[1])

    @property
    def feature_dim(self) -> int:
        return int(self.features.shape[2])

    def frame(self, t: int) -> tuple[np.ndarray, np.ndarray]:
        """Observations of video frame ``t`` (0-based): band indices ``(K_t,)`` and
        features ``(K_t, D)``."""
        bands = np.flatnonzero(self.active[t])
        return bands, self.features[t, bands]

    @classmethod
    def concatenate(cls, parts: list[AudioFeatures], n_bands: int, dim: int) -> AudioFeatures:
        """Frames of several runs, in order."""
        if not parts:
            return cls(
                np.zeros((0, n_bands, dim)),
                np.zeros((0, n_bands), dtype=bool),
                np.zeros(0, dtype=bool),
                np.zeros(0),
                np.zeros((0, n_bands)),
            )
        return cls(
            *(
                np.concatenate([getattr(p, n) for p in parts])
                for n in ("features", "active", "vad", "speech_fraction", "band_power")
            )
        )


def video_frame_index(stft_frames: np.ndarray, config: AudioFeatureConfig) -> np.ndarray:
    """0-based video frame of each STFT frame: the nearest video frame to its centre time
    (video frame ``f`` is at ``f / fps`` seconds)."""
    centres = config.stft.frame_times(stft_frames)
    return np.floor(centres * config.fps + 0.5).astype(np.int64)


def aggregate_frames(
    values: np.ndarray,
    valid: np.ndarray,
    speech: np.ndarray,
    power: np.ndarray,
    index: np.ndarray,
    n_video: int,
    first_video: int,
    config: AudioFeatureConfig,
) -> AudioFeatures:
    """Average DP-RTFs over video frames and split them into sub-band observations.

    Parameters
    ----------
    values : ndarray (I - 1, F, T), complex
        DP-RTF features per STFT frame (0 where not valid).
    valid : ndarray (I - 1, F, T) bool
    speech : ndarray (F, T) bool
        Speech bins.
    power : ndarray (F, T)
        Reference-microphone power :math:`|x^1_{t,f}|^2`.
    index : ndarray (T,) int
        Video frame of each STFT frame (non-decreasing).
    n_video : int
        Video frames to produce, ``first_video .. first_video + n_video - 1``.
    first_video : int
    config : AudioFeatureConfig

    Returns
    -------
    AudioFeatures (``n_video`` frames)
    """
    n_ch = values.shape[0]
    k, l_ = config.n_bands, config.band_size
    local = index - first_video
    keep = (local >= 0) & (local < n_video)
    local = local[keep]
    counts = np.bincount(local, minlength=n_video)  # STFT frames per video frame
    ok = valid[:, :, keep] & valid[:, :, keep].all(axis=0, keepdims=True)  # all channels
    # Σ over the STFT frames of each video frame, by one matrix product with the indicator
    onehot = np.zeros((local.size, n_video))
    onehot[np.arange(local.size), local] = 1.0
    n_valid = ok[0].astype(float) @ onehot  # (F, n_video)
    sums = np.where(ok, values[:, :, keep], 0.0) @ onehot  # (I-1, F, n_video)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = sums / n_valid[None]  # the DP-RTFs averaged over the video frame
    bins = config.band_bins()  # (K, L)
    lo, hi = config.vad_band_hz
    freqs = config.stft.freqs_hz
    vad_bins = (freqs >= lo) & (freqs <= hi)
    sp = speech[:, keep].astype(float) @ onehot  # speech bins per video frame, (F, n_video)
    denom = np.maximum(counts, 1) * max(int(vad_bins.sum()), 1)
    speech_fraction = sp[vad_bins].sum(axis=0) / denom
    vad = (speech_fraction >= config.vad_min_fraction) & (counts > 0)
    band_power = (power[:, keep] @ onehot)[bins].mean(axis=1).T / np.maximum(counts, 1)[:, None]
    cells = n_valid[bins]  # (K, L, n_video) valid STFT frames per bin
    frac = cells.sum(axis=1) / (l_ * np.maximum(counts, 1))  # (K, n_video)
    loud = band_power.max(axis=1, keepdims=True)
    with np.errstate(divide="ignore"):
        drop_db = 10 * np.log10(np.maximum(loud, 1e-300) / np.maximum(band_power, 1e-300))
    active = (
        (cells.min(axis=1) > 0).T
        & (frac.T >= config.min_valid_fraction)
        & (drop_db <= config.max_band_drop_db)
        & vad[:, None]
    )
    # g_tk = (Re ĉ, Im ĉ) over channels and the band's bins: (n_video, K, 2 (I-1) L)
    band = mean[:, bins, :]  # (I-1, K, L, n_video)
    band = np.transpose(band, (3, 1, 0, 2)).reshape(n_video, k, n_ch * l_)
    feats = np.concatenate([band.real, band.imag], axis=2)
    feats = np.where(active[:, :, None], np.nan_to_num(feats), 0.0)
    return AudioFeatures(feats, active, vad, speech_fraction, band_power)


class AudioFeatureExtractor:
    """Streaming audio observations: feed sample blocks, get finished video frames.

    Parameters
    ----------
    n_channels : int
        Microphones (>= 2); channel 0 is the reference.
    fs : int
        Sample rate; must equal ``config.stft.fs``.
    config : AudioFeatureConfig, optional

    Examples
    --------
    >>> ext = AudioFeatureExtractor(4, 16000)
    >>> frames = ext.process(block)      # AudioFeatures of the video frames completed so far
    >>> last = ext.flush(n_video_frames) # the rest, up to a known number of frames
    """

    def __init__(self, n_channels: int, fs: int, config: AudioFeatureConfig | None = None):
        self.config = config or AudioFeatureConfig()
        if isinstance(n_channels, bool) or not isinstance(n_channels, int) or n_channels < 2:
            raise ValueError(f"n_channels must be an integer >= 2, got {n_channels!r}")
        if int(fs) != self.config.stft.fs:
            raise ValueError(
                f"fs must be the STFT sample rate {self.config.stft.fs} Hz, got {fs!r}"
            )
        self.n_channels = n_channels
        self.dim = self.config.feature_dim(n_channels)
        self._stft = StreamingSTFT(n_channels, self.config.stft)
        self._dprtf = DPRTFEstimator(
            n_channels,
            self.config.stft.n_freqs,
            self.config.stft.freqs_hz,
            self.config.dprtf_config(n_channels),
        )
        self._pending: list[tuple[np.ndarray, ...]] = []  # STFT frames of unfinished frames
        self.frames_done = 0  #: video frames returned so far

    def process(self, block: np.ndarray) -> AudioFeatures:
        """Add samples ``(n_channels, n_samples)``; return the video frames they complete."""
        spec = self._stft.process(block)
        t0 = self._stft.frames_done - spec.shape[2]
        if spec.shape[2]:
            run = self._dprtf.run(spec)
            idx = video_frame_index(np.arange(t0, t0 + spec.shape[2]), self.config)
            power = np.abs(spec[0]) ** 2
            self._pending.append((run.values, run.valid, run.speech, power, idx))
        if not self._pending:
            return self._empty()
        latest = int(self._pending[-1][4][-1])
        # a video frame is complete once an STFT frame of a later video frame has arrived
        return self._emit(latest - self.frames_done)

    def flush(self, n_frames: int | None = None) -> AudioFeatures:
        """The remaining video frames, up to ``n_frames`` frames in total (default: those
        with at least one STFT frame)."""
        if n_frames is None:
            n_frames = int(self._pending[-1][4][-1]) + 1 if self._pending else self.frames_done
        return self._emit(max(0, n_frames - self.frames_done))

    def _empty(self) -> AudioFeatures:
        return AudioFeatures.concatenate([], self.config.n_bands, self.dim)

    def _emit(self, n: int) -> AudioFeatures:
        if n <= 0:
            return self._empty()
        if self._pending:
            values, valid, speech, power, idx = (
                np.concatenate([p[i] for p in self._pending], axis=-1) for i in range(5)
            )
        else:
            f_ = self.config.stft.n_freqs
            values = np.zeros((self.n_channels - 1, f_, 0), dtype=complex)
            valid = np.zeros(values.shape, dtype=bool)
            speech, power, idx = np.zeros((f_, 0), bool), np.zeros((f_, 0)), np.zeros(0, int)
        out = aggregate_frames(values, valid, speech, power, idx, n, self.frames_done, self.config)
        self.frames_done += n
        rest = idx >= self.frames_done
        self._pending = (
            [(values[..., rest], valid[..., rest], speech[:, rest], power[:, rest], idx[rest])]
            if np.any(rest)
            else []
        )
        return out


def extract_audio_features(
    audio: np.ndarray, fs: int, n_frames: int, config: AudioFeatureConfig | None = None
) -> AudioFeatures:
    """Audio observations of ``n_frames`` video frames from a whole recording.

    Parameters
    ----------
    audio : ndarray (n_channels, n_samples)
        Microphone signals; channel 0 is the reference.
    fs : int
        Sample rate (the STFT's, 16 kHz by default).
    n_frames : int
        Number of video frames (frame ``f`` at ``f / fps`` s).
    config : AudioFeatureConfig, optional

    Returns
    -------
    AudioFeatures with ``n_frames`` frames (frames past the end of the audio are inactive).
    """
    audio = np.asarray(audio)
    if audio.ndim != 2 or audio.shape[0] < 2:
        raise ValueError(f"audio must be (n_channels >= 2, n_samples), got shape {audio.shape}")
    if isinstance(n_frames, bool) or not isinstance(n_frames, int | np.integer) or n_frames < 0:
        raise ValueError(f"n_frames must be an integer >= 0, got {n_frames!r}")
    ext = AudioFeatureExtractor(int(audio.shape[0]), fs, config)
    first = ext.process(audio)
    if len(first) > n_frames:
        return AudioFeatures(
            *(
                getattr(first, n)[:n_frames]
                for n in ("features", "active", "vad", "speech_fraction", "band_power")
            )
        )
    rest = ext.flush(int(n_frames))
    return AudioFeatures.concatenate([first, rest], ext.config.n_bands, ext.dim)
