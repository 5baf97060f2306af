"""Streaming API: feed audio blocks and detections as they arrive, get tracks per frame.

- :class:`~avtrack.stream.audio.DOAStream` -- acoustic-only: a localizer (DP-RTF + EG by
  default, thesis §5.3) and a VEM DOA tracker (§5.4 / §5.6) on a live multichannel stream.
- :class:`~avtrack.stream.av.AVStream` -- audio-visual: VAVIT (thesis ch. 4) on head detections
  per video frame plus the audio stream, with per-frame speaking status (eq. 4.34).
- :func:`~avtrack.stream.wav.wav_blocks` -- blocks of a WAV file or of a live WAV stream on
  standard input (``avtrack stream -``).

Every object here keeps a bounded state: memory does not grow with the length of the stream
(measured over a 20-minute recording in ``BENCHMARKS.md``), and fed the same signal in any
block sizes it gives exactly what the batch functions give on the whole recording.
"""

from avtrack.stream.audio import DOAStream, DOAStreamFrame
from avtrack.stream.av import AVStream, AVStreamFrame
from avtrack.stream.wav import WavStreamInfo, open_wav_stream, wav_blocks

__all__ = [
    "AVStream",
    "AVStreamFrame",
    "DOAStream",
    "DOAStreamFrame",
    "WavStreamInfo",
    "open_wav_stream",
    "wav_blocks",
]
