"""Short-time Fourier transform, whole-signal and streaming (thesis §5.5.1 front-end).

The thesis's front-end: 16 kHz audio, a 16 ms window (256 samples) shifted by 8 ms (128
samples), so 125 frames per second; the lowest ``n_freqs = 128`` bins of the 256-point FFT are
kept (0 Hz to 7.9375 kHz; the Nyquist bin is dropped). The thesis uses a Hamming window, the
project's specification a Hann window (the default here; both are available).

Frame ``t`` covers samples ``[t * hop, t * hop + win_len)``: there is no padding, so a signal of
``n`` samples has ``max(0, (n - win_len) // hop + 1)`` frames, and a partial window at the end
is not transformed. Its time stamp is the window centre, ``(t * hop + win_len / 2) / fs``
(``0.008 (t + 1)`` s with the defaults).

:class:`StreamingSTFT` accepts blocks of any size (including 0 samples) and keeps the samples
that do not yet fill a window; the frames it returns are exactly those of :func:`stft` on the
concatenated signal.

Shapes: signals ``(n_channels, n_samples)``, STFT ``(n_channels, n_freqs, n_frames)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.signal

WINDOWS = ("hann", "hamming")


#: Time between STFT frames of the default configuration (128 samples at 16 kHz), seconds:
#: the frame period of every localizer's heat maps and DOA tables.
FRAME_HOP_S = 128 / 16000


@dataclass(frozen=True)
class STFTConfig:
    """STFT parameters.

    Attributes
    ----------
    fs : int
        Sampling rate in Hz.
    win_len : int
        Window length (and FFT length) in samples; 256 = 16 ms at 16 kHz.
    hop : int
        Frame shift in samples; 128 = 8 ms at 16 kHz.
    n_freqs : int
        Number of bins kept, ``1 <= n_freqs <= win_len // 2 + 1``, from 0 Hz upwards.
    window : {"hann", "hamming"}
        Periodic analysis window.
    """

    fs: int = 16000
    win_len: int = 256
    hop: int = 128
    n_freqs: int = 128
    window: str = "hann"

    def __post_init__(self) -> None:
        for name in ("fs", "win_len", "hop", "n_freqs"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value <= 0:
                raise ValueError(f"STFTConfig: {name} must be a positive integer, got {value!r}")
        if self.hop > self.win_len:
            raise ValueError(
                f"STFTConfig: hop must be <= win_len ({self.win_len}), got {self.hop}"
            )
        if self.n_freqs > self.win_len // 2 + 1:
            raise ValueError(
                f"STFTConfig: n_freqs must be <= win_len // 2 + 1 = {self.win_len // 2 + 1}, "
                f"got {self.n_freqs}"
            )
        if self.window not in WINDOWS:
            raise ValueError(f"STFTConfig: window must be one of {WINDOWS}, got {self.window!r}")

    @property
    def frame_period_s(self) -> float:
        """Time between frames, ``hop / fs`` seconds."""
        return self.hop / self.fs

    @property
    def freqs_hz(self) -> np.ndarray:
        """``(n_freqs,)`` centre frequency of each kept bin, ``k fs / win_len``."""
        return np.arange(self.n_freqs) * (self.fs / self.win_len)

    def window_samples(self) -> np.ndarray:
        """``(win_len,)`` the periodic analysis window."""
        return scipy.signal.get_window(self.window, self.win_len, fftbins=True)

    def frame_times(self, frames: np.ndarray | int) -> np.ndarray:
        """Time stamps (window centres, seconds) of the given frame indices."""
        return (np.asarray(frames, dtype=float) * self.hop + self.win_len / 2) / self.fs

    def n_frames(self, n_samples: int) -> int:
        """Number of complete frames in a signal of ``n_samples`` samples."""
        if n_samples < self.win_len:
            return 0
        return (n_samples - self.win_len) // self.hop + 1


def _check_signal(x: np.ndarray, name: str, n_channels: int | None = None) -> np.ndarray:
    x = np.asarray(x)
    if x.ndim != 2:
        raise ValueError(f"{name}: expected a 2-D array (n_channels, n_samples), got {x.shape}")
    if not np.issubdtype(x.dtype, np.floating) and not np.issubdtype(x.dtype, np.integer):
        raise TypeError(f"{name}: expected real samples, got dtype {x.dtype}")
    if n_channels is not None and x.shape[0] != n_channels:
        raise ValueError(
            f"{name}: expected {n_channels} channels (rows), got {x.shape[0]} "
            f"(shape {x.shape}; signals are (n_channels, n_samples))"
        )
    x = x.astype(float, copy=False)
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name}: samples must be finite (found NaN or inf)")
    return x


def _frames_fft(x: np.ndarray, n_frames: int, config: STFTConfig, window: np.ndarray):
    """STFT of the first ``n_frames`` frames of ``x (C, n)`` -> ``(C, F, n_frames)``."""
    if n_frames == 0:
        return np.zeros((x.shape[0], config.n_freqs, 0), dtype=complex)
    span = (n_frames - 1) * config.hop + config.win_len
    win = np.lib.stride_tricks.sliding_window_view(x[:, :span], config.win_len, axis=1)
    win = win[:, :: config.hop]  # (C, T, win_len)
    spec = np.fft.rfft(win * window, axis=2)[:, :, : config.n_freqs]  # (C, T, F)
    return np.ascontiguousarray(spec.transpose(0, 2, 1))


def stft(x: np.ndarray, config: STFTConfig | None = None) -> np.ndarray:
    """STFT of a whole multichannel signal.

    Parameters
    ----------
    x : ndarray (n_channels, n_samples)
        Real signal.
    config : STFTConfig, optional
        Default: the thesis front-end at 16 kHz.

    Returns
    -------
    ndarray (n_channels, n_freqs, n_frames), complex
        ``X[c, k, t] = sum_n w[n] x[c, t hop + n] exp(-2j pi k n / win_len)``.
    """
    config = STFTConfig() if config is None else config
    x = _check_signal(x, "stft: x")
    return _frames_fft(x, config.n_frames(x.shape[1]), config, config.window_samples())


class StreamingSTFT:
    """STFT of a signal that arrives in blocks of any size.

    Parameters
    ----------
    n_channels : int
        Number of channels of every block.
    config : STFTConfig, optional
        Default: the thesis front-end at 16 kHz.

    Examples
    --------
    >>> s = StreamingSTFT(2)
    >>> s.process(np.zeros((2, 200))).shape   # not yet a full window
    (2, 128, 0)
    >>> s.process(np.zeros((2, 200))).shape   # 400 samples: frames 0 and 1
    (2, 128, 2)
    """

    def __init__(self, n_channels: int, config: STFTConfig | None = None) -> None:
        if isinstance(n_channels, bool) or not isinstance(n_channels, int) or n_channels < 1:
            raise ValueError(
                f"StreamingSTFT: n_channels must be a positive integer, got {n_channels!r}"
            )
        self.n_channels = n_channels
        self.config = STFTConfig() if config is None else config
        self._window = self.config.window_samples()
        self.reset()

    def reset(self) -> None:
        """Forget buffered samples; the next sample is sample 0 of a new signal."""
        self._buffer = np.zeros((self.n_channels, 0))
        self.frames_done = 0  #: number of frames returned so far
        self.samples_seen = 0  #: number of samples received so far

    def process(self, block: np.ndarray) -> np.ndarray:
        """Add samples; return the frames they complete.

        Parameters
        ----------
        block : ndarray (n_channels, n_samples)
            The next samples (any number, 0 included).

        Returns
        -------
        ndarray (n_channels, n_freqs, n_new_frames), complex
            Frames ``frames_done_before .. frames_done - 1``.
        """
        block = _check_signal(block, "StreamingSTFT.process: block", self.n_channels)
        self.samples_seen += block.shape[1]
        buf = np.concatenate([self._buffer, block], axis=1) if self._buffer.size else block
        n_new = self.config.n_frames(buf.shape[1])
        out = _frames_fft(buf, n_new, self.config, self._window)
        self._buffer = buf[:, n_new * self.config.hop :].copy()
        self.frames_done += n_new
        return out
