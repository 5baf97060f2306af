"""A microphone-array recording read from a WAV file, checked and brought to 16 kHz."""

from __future__ import annotations

import math
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import numpy as np

from avtrack.audio.arrays import MicArray
from avtrack.errors import InputError

#: Sample rate every localizer and tracker works at, Hz.
FS = 16000
#: A sample at or above this magnitude is clipped ...
CLIP_LEVEL = 0.999
#: ... and more than this fraction of clipped samples rejects the recording.
CLIP_FRACTION = 0.001


# -- input -------------------------------------------------------------------------------
#: Shortest recording worth localizing: a few STFT frames and one tracker block.
MIN_SECONDS = 0.25


class AudioChecks:
    """The audio-input rules of :func:`read_array_audio`, applied block by block to a stream:
    a NaN or infinite sample stops it at once; silence, clipping and a too-short stream are
    judged when it ends (:meth:`finish`)."""

    def __init__(self, source, fs: int, allow_clipping: bool = False) -> None:
        self.source, self.fs, self.allow_clipping = source, int(fs), bool(allow_clipping)
        self.samples = self.values = self.clipped = 0
        self.peak = 0.0

    def block(self, x: np.ndarray) -> None:
        """Check one block ``(n_samples, n_channels)`` or ``(n_channels, n_samples)``."""
        if not np.all(np.isfinite(x)):
            raise InputError(f"contains NaN or infinite samples (after {self.samples} "
                             f"samples)", self.source)
        self.samples += max(x.shape) if x.ndim == 2 else x.size
        self.values += x.size
        self.clipped += int(np.count_nonzero(np.abs(x) >= CLIP_LEVEL))
        if x.size:
            self.peak = max(self.peak, float(np.max(np.abs(x))))

    def finish(self) -> None:
        """InputError when the whole stream was too short, silent or clipped."""
        if self.samples < MIN_SECONDS * self.fs:
            raise InputError(f"is too short ({self.samples} samples); localization needs at "
                             f"least {MIN_SECONDS:g} s", self.source)
        if self.peak == 0:
            raise InputError("is silent (all samples are zero)", self.source)
        frac = self.clipped / max(self.values, 1)
        if frac > CLIP_FRACTION and not self.allow_clipping:
            raise InputError(
                f"is clipped ({100 * frac:.2f} % of the samples at full scale); phases of "
                "clipped audio are unreliable (use --allow-clipping to go on anyway)",
                self.source)
def read_array_audio(
    path: Path, array: MicArray, allow_clipping: bool = False, quiet: bool = False
) -> np.ndarray:
    """Read a WAV for ``array`` as ``(n_mics, n_samples)`` at 16 kHz, with clear errors.

    Raises
    ------
    InputError
        Unreadable file, wrong channel count, empty or shorter than :data:`MIN_SECONDS`,
        NaN/inf, silent, or clipped (more than 0.1 % of the samples at full scale) unless
        ``allow_clipping``. The same rules hold for ``avtrack stream`` (checked as the
        blocks come, see :class:`AudioChecks`).
    """
    return ArrayRecording(path, array, allow_clipping, quiet).read()


#: Seconds of audio per block of :class:`ArrayRecording` (memory: one block).
BLOCK_SECONDS = 4.0


class BlockResampler:
    """``scipy.signal.resample_poly`` over a signal that arrives in blocks, with the output of
    the whole-signal call: each block is filtered with enough of its neighbours' samples
    (the filter's half length) and cropped. Blocks start at multiples of ``down`` input
    samples, so every block's output grid is the whole signal's.

    SciPy has no stateful polyphase resampler (``upfirdn`` and ``resample_poly`` filter a
    whole array), hence this overlap-save wrapper.

    Parameters
    ----------
    fs_in, fs_out : int
        Sample rates, Hz.
    """

    def __init__(self, fs_in: int, fs_out: int) -> None:
        ratio = Fraction(int(fs_out), int(fs_in))
        self.up, self.down = ratio.numerator, ratio.denominator
        half_len = 10 * max(self.up, self.down)  # resample_poly's default filter, in up-rate
        need = half_len // self.up + 2  # input samples each side that reach an output sample
        self.margin = self.down * math.ceil(need / self.down)

    def blocks(self, source: Iterator[np.ndarray], total: int) -> Iterator[np.ndarray]:
        """Resampled blocks ``(channels, m)`` of the blocks ``source`` yields (``total`` input
        samples in all; every block but the last a multiple of ``down`` samples long)."""
        import scipy.signal

        up, down, margin = self.up, self.down, self.margin
        buf = np.zeros((0, 0))
        start = 0  # input index of buf[:, 0]
        done = 0  # input samples whose output has been given
        n_out = -(-total * up // down)
        given = 0
        for block in source:
            buf = block if buf.size == 0 else np.concatenate([buf, block], axis=1)
            end = start + buf.shape[1]
            ready = ((end - margin - done) // down) * down if end < total else end - done
            if ready <= 0:
                continue
            lo = max(done - margin, 0)
            seg = buf[:, lo - start : min(done + ready + margin, end) - start]
            y = scipy.signal.resample_poly(seg, up, down, axis=1)
            first = (done - lo) * up // down
            count = min(ready * up // down if end < total else n_out - given, y.shape[1] - first)
            yield y[:, first : first + count]
            given += count
            done += ready
            keep = max(done - margin, start)
            buf, start = buf[:, keep - start :], keep


@dataclass(frozen=True)
class RecordingInfo:
    """What :class:`ArrayRecording` found in a file: ``fs`` (Hz, before resampling),
    ``samples`` at 16 kHz, ``duration_s``."""

    fs: int
    samples: int
    duration_s: float


class ArrayRecording:
    """A microphone-array WAV read in blocks at 16 kHz, with the rules of
    :func:`read_array_audio` checked before any block is given (one cheap pass over the file),
    so memory stays at one block whatever the recording's length.

    Parameters
    ----------
    path : Path
    array : MicArray
        Channel ``k`` is microphone ``k``.
    allow_clipping, quiet : bool
        As :func:`read_array_audio`.
    block_s : float
        Seconds per block (default :data:`BLOCK_SECONDS`).

    Raises
    ------
    InputError
        As :func:`read_array_audio`, when opened.
    """

    def __init__(
        self,
        path: Path,
        array: MicArray,
        allow_clipping: bool = False,
        quiet: bool = False,
        block_s: float = BLOCK_SECONDS,
    ) -> None:
        import soundfile

        self.path = Path(path)
        if not self.path.is_file():
            raise InputError("audio file not found", self.path)
        if not (block_s > 0):
            raise ValueError(f"ArrayRecording: block_s must be > 0, got {block_s!r}")
        try:
            with soundfile.SoundFile(str(self.path)) as fh:
                fs, channels, frames = int(fh.samplerate), int(fh.channels), int(fh.frames)
        except (RuntimeError, soundfile.LibsndfileError, TypeError, ValueError) as exc:
            raise InputError(f"cannot read the audio: {exc}", self.path) from None
        if channels != array.n_mics:
            raise InputError(
                f"has {channels} channel(s) but array {array.name!r} has {array.n_mics} "
                "microphones (WAV channel k is microphone k)",
                self.path,
            )
        if frames == 0:
            raise InputError("has no samples", self.path)
        if frames < MIN_SECONDS * fs:
            raise InputError(f"is too short ({frames} samples, {1e3 * frames / fs:.0f} ms); "
                             f"localization needs at least {MIN_SECONDS:g} s", self.path)
        self.array = array
        self.fs_in, self.frames_in = fs, frames
        self._resampler = BlockResampler(fs, FS) if fs != FS else None
        step = self._resampler.down if self._resampler else 1
        self.block_in = max(step, round(block_s * fs) // step * step)
        checks = AudioChecks(self.path, fs, allow_clipping)
        for block in self._raw_blocks():
            checks.block(block)
        checks.finish()
        n = frames if fs == FS else -(-frames * FS // fs)
        self.info = RecordingInfo(fs, n, n / FS)
        if fs != FS and not quiet:
            print(f"avtrack: note: {self.path} is at {fs} Hz; resampling to {FS} Hz",
                  file=sys.stderr)

    def _raw_blocks(self) -> Iterator[np.ndarray]:
        import soundfile

        try:
            with soundfile.SoundFile(str(self.path)) as fh:
                while True:
                    data = fh.read(self.block_in, dtype="float64", always_2d=True)
                    if data.shape[0] == 0:
                        return
                    yield np.ascontiguousarray(data.T)
        except (RuntimeError, soundfile.LibsndfileError) as exc:
            raise InputError(f"cannot read the audio: {exc}", self.path) from None

    def blocks(self) -> Iterator[np.ndarray]:
        """Successive blocks ``(n_mics, n)`` at 16 kHz (float64, full scale ±1)."""
        if self._resampler is None:
            yield from self._raw_blocks()
        else:
            yield from self._resampler.blocks(self._raw_blocks(), self.frames_in)

    def read(self) -> np.ndarray:
        """The whole recording ``(n_mics, n_samples)`` at 16 kHz."""
        parts = list(self.blocks())
        return np.concatenate(parts, axis=1)
