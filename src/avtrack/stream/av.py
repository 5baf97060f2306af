"""Audio-visual streaming: VAVIT on head detections per video frame plus a live audio stream.

Two inputs arrive independently -- the detections of each video frame (from a detector or a
robot's middleware) and blocks of microphone samples -- and each video frame is tracked once
both its detections and its audio observations are in (thesis ch. 4, Algorithm 1: the E-Z,
E-S and M steps of one frame on the frame's boxes and the DP-RTF features of its sub-bands,
eqs. 4.15–4.34). The audio observations of video frame ``t`` are complete once an STFT frame of
frame ``t + 1`` has arrived, so the audio side lags the video by about one video frame plus
one STFT window (:attr:`AVStream.audio_latency_s`).

Latency and memory are bounded: when one input runs more than ``max_lag`` frames ahead of the
other (a stalled microphone or camera), the oldest waiting frame is tracked with what there is
-- detections without audio, or audio with no detections -- and the late input for that frame
is dropped when it comes; :attr:`AVStream.stats` counts both cases. Fed in order with no
stall, the frames are exactly those of :func:`avtrack.av.vavit.track_scene`.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from avtrack.av.features import AudioFeatureConfig, AudioFeatureExtractor, AudioFeatures
from avtrack.av.gllim import AudioImageMapping
from avtrack.av.vavit import AVFrameTracks, VAVITConfig, VAVITracker


@dataclass(frozen=True, eq=False)
class AVStreamFrame:
    """The tracks after one video frame.

    Attributes
    ----------
    frame : int
        Video frame, 0-based (frame ``t`` is at ``t / fps`` seconds).
    time_s : float
    tracks : AVFrameTracks
        Ids ``(K,)``, head boxes ``(K, 4)`` (left, top, width, height), visibility, speaking
        status ``(K,)`` (eq. 4.34), ...
    had_audio : bool
        The frame's audio observations were used (False when the audio was late).
    had_detections : bool
        The frame's detections were used (False when the camera was late).
    """

    frame: int
    time_s: float
    tracks: AVFrameTracks
    had_audio: bool
    had_detections: bool


class AVStream:
    """Online audio-visual tracking and speaker diarization.

    Parameters
    ----------
    mapping : AudioImageMapping
        Trained audio-to-image mapping (``avtrack track-av`` saves one as ``mapping.npz``).
    image_size : (width, height)
        Camera image size, pixels.
    n_channels : int
        Microphones; channel 0 is the reference.
    fps : float
        Video frame rate.
    fs : int
        Audio sample rate (that of ``feature_config.stft``, 16 kHz by default).
    config : VAVITConfig, optional
    feature_config : AudioFeatureConfig, optional
        Default: the standard features at ``fps``.
    fov : (float, float), optional
        Horizontal pixel range the camera sees (default: the whole width).
    max_lag : int
        Frames one input may run ahead of the other before frames are tracked without it
        (default 50: 2 s at 25 fps).

    Examples
    --------
    >>> stream = AVStream(mapping, (640, 480), n_channels=4, fps=25)
    >>> stream.push_detections(boxes, scores, appearance)   # video frame 0
    >>> for out in stream.push_audio(block):                # (4, n) samples
    ...     print(out.frame, out.tracks.ids, out.tracks.speaking)
    >>> rest = stream.close()                               # end of both streams
    """

    def __init__(
        self,
        mapping: AudioImageMapping,
        image_size: tuple[int, int],
        n_channels: int,
        fps: float = 25.0,
        fs: int = 16000,
        config: VAVITConfig | None = None,
        feature_config: AudioFeatureConfig | None = None,
        fov: tuple[float, float] | None = None,
        max_lag: int = 50,
    ) -> None:
        if not isinstance(mapping, AudioImageMapping):
            raise TypeError(f"AVStream: mapping must be an AudioImageMapping, got {mapping!r}")
        if not (isinstance(fps, int | float) and np.isfinite(fps) and fps > 0):
            raise ValueError(f"AVStream: fps must be a positive number, got {fps!r}")
        if isinstance(max_lag, bool) or not isinstance(max_lag, int) or max_lag < 1:
            raise ValueError(f"AVStream: max_lag must be an integer >= 1, got {max_lag!r}")
        fcfg = feature_config or AudioFeatureConfig(fps=float(fps))
        if abs(fcfg.fps - fps) > 1e-9:
            raise ValueError(
                f"AVStream: feature_config.fps ({fcfg.fps}) differs from fps ({fps})"
            )
        expected = mapping.meta.get("n_mics")
        if expected is not None and int(expected) != n_channels:
            raise ValueError(
                f"AVStream: the mapping was trained for {expected} microphones, "
                f"got n_channels={n_channels}"
            )
        self.mapping = mapping
        self.fps = float(fps)
        self.extractor = AudioFeatureExtractor(n_channels, fs, fcfg)
        if (self.extractor.dim, fcfg.n_bands) != (mapping.feature_dim, mapping.n_bands):
            raise ValueError(
                f"AVStream: audio features (K={fcfg.n_bands}, D={self.extractor.dim}) do not "
                f"match the mapping (K={mapping.n_bands}, D={mapping.feature_dim})"
            )
        self.tracker = VAVITracker(mapping, config, image_size, fov)
        self.max_lag = int(max_lag)
        self._dets: deque[tuple] = deque()  # detections of frames not yet tracked
        self._audio: deque[tuple[np.ndarray, np.ndarray]] = deque()  # (bands, g) per frame
        self._det_frames_in = 0  # video frames whose detections have arrived
        self._audio_frames_in = 0  # video frames whose audio observations have arrived
        self.frames_out = 0  # video frames tracked
        self.stats = {"frames_without_audio": 0, "frames_without_detections": 0}

    @property
    def audio_latency_s(self) -> float:
        """Time after a video frame's instant until its audio observations are complete: half
        a video frame, then one STFT window."""
        stft = self.extractor.config.stft
        return 0.5 / self.fps + stft.win_len / stft.fs

    def push_detections(
        self,
        boxes: np.ndarray,
        scores: np.ndarray | None = None,
        appearance: np.ndarray | None = None,
    ) -> list[AVStreamFrame]:
        """Detections of the next video frame; return the frames that can now be tracked.

        ``boxes``, ``scores`` and ``appearance`` are those of
        :meth:`VAVITracker.step <avtrack.av.vavit.VAVITracker.step>`; ``appearance`` is given
        for every frame or for none.
        """
        boxes = np.asarray(boxes, dtype=float)
        if boxes.size == 0:
            boxes = boxes.reshape(0, 4)
        if boxes.ndim != 2 or boxes.shape[1] != 4:
            raise ValueError(f"AVStream: boxes must have shape (M, 4), got {boxes.shape}")
        if self._det_frames_in >= self.frames_out:  # else: already tracked without them
            self._dets.append((boxes, scores, appearance))
        self._det_frames_in += 1
        return self._drain()

    def push_audio(self, block: np.ndarray) -> list[AVStreamFrame]:
        """The next microphone samples ``(n_channels, n_samples)``; return the frames that can
        now be tracked."""
        self._add_audio(self.extractor.process(block))
        return self._drain()

    def close(self, n_frames: int | None = None) -> list[AVStreamFrame]:
        """End of both streams: track every frame still waiting.

        ``n_frames`` (default: the frames whose detections arrived) is the stream's length in
        video frames; audio observations run out at the end of the audio.
        """
        n = self._det_frames_in if n_frames is None else int(n_frames)
        self._add_audio(self.extractor.flush(max(n, self.extractor.frames_done)))
        out = []
        while self.frames_out < n:
            out.extend(self._track_one(allow_missing=True))
        return out

    # ------------------------------------------------------------------ internals
    def _add_audio(self, feats: AudioFeatures) -> None:
        for t in range(len(feats)):
            if self._audio_frames_in >= self.frames_out:
                self._audio.append(feats.frame(t))
            self._audio_frames_in += 1

    def _drain(self) -> list[AVStreamFrame]:
        out: list[AVStreamFrame] = []
        while self._dets and self._audio:
            out.extend(self._track_one())
        # one input stalled: track the oldest frames with what there is
        while len(self._dets) > self.max_lag or len(self._audio) > self.max_lag:
            out.extend(self._track_one(allow_missing=True))
        return out

    def _track_one(self, allow_missing: bool = False) -> list[AVStreamFrame]:
        has_dets, has_audio = bool(self._dets), bool(self._audio)
        if not (has_dets and has_audio) and not allow_missing:
            return []
        if has_dets:
            boxes, scores, app = self._dets.popleft()
        else:  # an empty frame; with appearance, an empty (0,) array keeps the length known
            boxes, scores, app = np.zeros((0, 4)), None, None
            if self.tracker._has_appearance:
                app = np.zeros(0)
        if has_audio:
            bands, g = self._audio.popleft()
        else:
            bands, g = None, None
        self.stats["frames_without_audio"] += int(not has_audio)
        self.stats["frames_without_detections"] += int(not has_dets)
        tracks = self.tracker.step(boxes, scores, app, bands, g)
        frame = self.frames_out
        self.frames_out += 1
        return [AVStreamFrame(frame, frame / self.fps, tracks, has_audio, has_dets)]
