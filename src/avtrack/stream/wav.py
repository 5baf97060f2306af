"""Blocks of a WAV file or of a live WAV stream on standard input.

``soundfile`` (libsndfile) reads WAV from a pipe when it is given the file descriptor (its
Python file-object path needs ``seek``/``tell``, which a pipe lacks), so a live stream such as
``arecord -f S16_LE -c 4 -r 16000 -t wav | avtrack stream - --array nao4`` is read as it
arrives, block by block, with no hand-written RIFF parsing. A stream's header may declare an
unknown (0 or maximal) length; reading simply goes on until end of file.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

import numpy as np
import soundfile as sf

from avtrack.errors import InputError


@dataclass(frozen=True)
class WavStreamInfo:
    """What the WAV header says.

    Attributes
    ----------
    name : str
        ``"<stdin>"`` or the file path.
    fs : int
        Sample rate, Hz.
    channels : int
    subtype : str
        libsndfile's sample format (``"PCM_16"``, ``"FLOAT"``, ...).
    """

    name: str
    fs: int
    channels: int
    subtype: str


@contextlib.contextmanager
def open_wav_stream(
    source: str | Path | BinaryIO,
    fs: int | None = None,
    channels: int | None = None,
) -> Iterator[tuple[WavStreamInfo, sf.SoundFile]]:
    """Open ``source`` (a path, ``"-"`` for standard input, or a binary file with a file
    descriptor) and check its header.

    Parameters
    ----------
    source : str, Path or binary file
    fs, channels : int, optional
        Required sample rate and channel count (a mismatch raises InputError).

    Yields
    ------
    (WavStreamInfo, soundfile.SoundFile)
    """
    if isinstance(source, str) and source == "-":
        source = sys.stdin.buffer
    if isinstance(source, str | Path):
        name = str(source)
        if not Path(source).is_file():
            raise InputError("file not found", source)
        target: object = str(source)
        closefd = True
    else:
        name = getattr(source, "name", "<stream>")
        name = "<stdin>" if name in ("<stdin>", 0) else str(name)
        try:
            target = source.fileno()  # a pipe: libsndfile reads it without seeking
        except (AttributeError, OSError, ValueError):
            target = source  # an in-memory, seekable file object
        closefd = False
    try:
        handle = sf.SoundFile(target, closefd=closefd)
    except (sf.LibsndfileError, RuntimeError, TypeError) as exc:
        raise InputError(f"not a readable WAV stream ({exc})", name) from None
    with handle:
        info = WavStreamInfo(name, int(handle.samplerate), int(handle.channels), handle.subtype)
        if fs is not None and info.fs != fs:
            raise InputError(f"sample rate {info.fs} Hz, expected {fs} Hz", name)
        if channels is not None and info.channels != channels:
            raise InputError(
                f"{info.channels} channel(s), expected {channels} (one per microphone)", name
            )
        yield info, handle


def wav_blocks(handle: sf.SoundFile, block_samples: int) -> Iterator[np.ndarray]:
    """Successive blocks ``(channels, n)`` (float64, full scale ±1) of an open WAV stream.

    Every block has ``block_samples`` samples except possibly the last; nothing is read ahead,
    so memory stays at one block whatever the length of the stream.
    """
    if isinstance(block_samples, bool) or not isinstance(block_samples, int) or block_samples < 1:
        raise ValueError(f"block_samples must be a positive integer, got {block_samples!r}")
    while True:
        block = handle.read(block_samples, dtype="float64", always_2d=True)
        if block.shape[0] == 0:
            return
        yield block.T
