"""A microphone-array recording read from a WAV file, checked and brought to 16 kHz."""

from __future__ import annotations

import sys
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
    import soundfile

    path = Path(path)
    if not path.is_file():
        raise InputError("audio file not found", path)
    try:
        data, fs = soundfile.read(str(path), dtype="float64", always_2d=True)
    except (RuntimeError, soundfile.LibsndfileError, TypeError, ValueError) as exc:
        raise InputError(f"cannot read the audio: {exc}", path) from None
    x = np.ascontiguousarray(data.T)
    if x.shape[0] != array.n_mics:
        raise InputError(
            f"has {x.shape[0]} channel(s) but array {array.name!r} has {array.n_mics} "
            "microphones (WAV channel k is microphone k)",
            path,
        )
    if x.shape[1] == 0:
        raise InputError("has no samples", path)
    if x.shape[1] < MIN_SECONDS * fs:
        raise InputError(f"is too short ({x.shape[1]} samples, {1e3 * x.shape[1] / fs:.0f} ms); "
                         f"localization needs at least {MIN_SECONDS:g} s", path)
    if not np.all(np.isfinite(x)):
        raise InputError("contains NaN or infinite samples", path)
    peak = np.max(np.abs(x))
    if peak == 0:
        raise InputError("is silent (all samples are zero)", path)
    clipped = np.count_nonzero(np.abs(x) >= CLIP_LEVEL) / x.size
    if clipped > CLIP_FRACTION and not allow_clipping:
        raise InputError(
            f"is clipped ({100 * clipped:.2f} % of the samples at full scale); phases of "
            "clipped audio are unreliable (use --allow-clipping to go on anyway)",
            path,
        )
    if fs != FS:
        import scipy.signal

        ratio = Fraction(FS, int(fs))
        if not quiet:
            print(f"avtrack: note: {path} is at {fs} Hz; resampling to {FS} Hz", file=sys.stderr)
        x = scipy.signal.resample_poly(x, ratio.numerator, ratio.denominator, axis=1)
    return x
