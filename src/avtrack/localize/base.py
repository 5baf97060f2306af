"""The frame-wise localizer interface, its registry and its result type.

A :class:`Localizer` is an online object: :meth:`Localizer.process` takes the next block of
multichannel audio (any number of samples), runs the STFT front-end
(:class:`avtrack.audio.stft.StreamingSTFT`) and returns the heat maps of the frames the block
completes -- one value per candidate direction of its :class:`~avtrack.localize.grid.DirectionGrid`
per STFT frame. A localizer whose map of a frame also reads the frames after it (a fixed-lag
smoother, :attr:`Localizer.latency_frames` > 0) returns each frame's map that many frames
later, and :meth:`Localizer.flush` gives the maps still held back at the end of the signal.
Blocks of any size give exactly the frames of the whole signal processed at once.
:meth:`Localizer.run` (and :func:`localize`) is the batch helper.

Implementations register under the name used by the CLI
(``@register_localizer("dprtf-eg")``); :data:`LOCALIZERS` maps names to classes.
The base class validates every block, then hands the STFT frames to the subclass's
:meth:`Localizer._process_stft`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from avtrack.audio.arrays import MicArray
from avtrack.audio.stft import STFTConfig, StreamingSTFT
from avtrack.localize.grid import DirectionGrid
from avtrack.registry import Registry

LOCALIZERS: Registry[type[Localizer]] = Registry("localizer")
"""Registered localizer classes by name (``"dprtf-eg"``, ``"dprtf-rem"``, ...)."""

#: Class decorator registering a :class:`Localizer` subclass under a name.
register_localizer = LOCALIZERS.register

#: The localizer of the audio commands and APIs (``localize``, ``track-audio``, ``stream``,
#: :func:`localize`, :class:`avtrack.stream.DOAStream`) when none is named: DPRTF-EG with
#: position weights in velocity layers, read 0.2 s late through a fixed-lag smoother
#: (:class:`avtrack.localize.cgmm_eg.DPRTFEGSmooth`).
DEFAULT_LOCALIZER = "dprtf-eg-smooth"


@dataclass(frozen=True, eq=False)
class HeatMaps:
    """Frame-wise heat maps (CGMM weights or smoothed SRP) over the candidate directions.

    Attributes
    ----------
    frames : ndarray (n_frames,) int
        STFT frame indices (0 is the first frame of the signal).
    time_s : ndarray (n_frames,) float
        Frame times (window centres), seconds.
    weights : ndarray (n_frames, n_candidates) float
        Heat-map value of each candidate direction at each frame (non-negative; CGMM weights
        sum to one).
    n_observations : ndarray (n_frames,) int
        Number of features used at each frame (``|C_t|`` for the CGMM methods; the number of
        bins for SRP-PHAT).
    """

    frames: np.ndarray
    time_s: np.ndarray
    weights: np.ndarray
    n_observations: np.ndarray

    def __post_init__(self) -> None:
        w = np.asarray(self.weights, dtype=float)
        if w.ndim != 2:
            raise ValueError(f"HeatMaps: weights must be 2-D (n_frames, D), got {w.shape}")
        t_ = w.shape[0]
        for name in ("frames", "time_s", "n_observations"):
            if np.shape(getattr(self, name)) != (t_,):
                raise ValueError(
                    f"HeatMaps: {name} must have shape ({t_},), "
                    f"got {np.shape(getattr(self, name))}"
                )
        object.__setattr__(self, "weights", w)
        object.__setattr__(self, "frames", np.asarray(self.frames, dtype=np.int64))
        object.__setattr__(self, "time_s", np.asarray(self.time_s, dtype=float))
        object.__setattr__(self, "n_observations", np.asarray(self.n_observations, dtype=np.int64))

    def __len__(self) -> int:
        return int(self.frames.shape[0])

    @classmethod
    def concatenate(cls, parts: list[HeatMaps], n_candidates: int) -> HeatMaps:
        """Frames of several consecutive results, in order."""
        if not parts:
            return cls(
                np.zeros(0, int), np.zeros(0), np.zeros((0, n_candidates)), np.zeros(0, int)
            )
        return cls(
            np.concatenate([p.frames for p in parts]),
            np.concatenate([p.time_s for p in parts]),
            np.concatenate([p.weights for p in parts], axis=0),
            np.concatenate([p.n_observations for p in parts]),
        )


class Localizer(ABC):
    """Online frame-wise multiple-source localizer.

    Parameters
    ----------
    array : MicArray
        The microphone array; WAV channel ``k`` is microphone ``k``.
    grid : DirectionGrid, optional
        Candidate directions (default: :meth:`DirectionGrid.for_array`, 72 azimuths every 5
        degrees, thesis §5.5.1, at the elevations the array can tell apart).
    config : optional
        The implementation's parameters (its ``Config`` dataclass); default ``Config()``.
    stft : STFTConfig, optional
        Front-end (default: 16 kHz, 16 ms Hann window, 8 ms hop, 128 bins).
    """

    name: ClassVar[str] = ""
    Config: ClassVar[type] = type(None)
    default_threshold: ClassVar[float] = 0.0
    """Peak threshold giving a reasonable MD/FA balance on simulated rooms (CLI default)."""
    threshold_cell_deg: ClassVar[float | None] = None
    """None: ``default_threshold`` holds on any grid. Degrees: the azimuth step it was set
    for, on maps that spread a talker's mass over a fixed angle, so that the mass of a cell
    grows with its width: :attr:`peak_threshold` scales it with the grid's step."""
    profile_reduce: ClassVar[str] = "sum"
    """How the elevations of one azimuth combine in the map over azimuth
    (:func:`~avtrack.localize.grid.azimuth_profile`): ``"sum"`` for weights that are a
    distribution over the candidates, ``"max"`` for power maps."""

    def __init__(
        self,
        array: MicArray,
        grid: DirectionGrid | None = None,
        config: Any = None,
        stft: STFTConfig | None = None,
    ) -> None:
        if not isinstance(array, MicArray):
            raise TypeError(f"{type(self).__name__}: array must be a MicArray, got {array!r}")
        if array.n_mics < 2:
            raise ValueError(
                f"{type(self).__name__}: the array needs at least 2 microphones, "
                f"got {array.n_mics}"
            )
        grid = DirectionGrid.for_array(array) if grid is None else grid
        if not isinstance(grid, DirectionGrid):
            raise TypeError(f"{type(self).__name__}: grid must be a DirectionGrid, got {grid!r}")
        config = self.Config() if config is None else config
        if not isinstance(config, self.Config):
            raise TypeError(
                f"{type(self).__name__}: config must be a {self.Config.__name__}, "
                f"got {type(config).__name__}"
            )
        self.array = array
        self.grid = grid
        self.config: Any = config
        self.stft_config = STFTConfig() if stft is None else stft
        self._stft = StreamingSTFT(array.n_mics, self.stft_config)
        self._setup()
        self.reset()

    @property
    def peak_threshold(self) -> float:
        """The default peak threshold on this localizer's grid: ``default_threshold``, times
        the grid's azimuth step over ``threshold_cell_deg`` when that is set."""
        if self.threshold_cell_deg is None:
            return self.default_threshold
        return self.default_threshold * self.grid.azimuth_step_deg / self.threshold_cell_deg

    @property
    def n_channels(self) -> int:
        return self.array.n_mics

    @property
    def fs(self) -> int:
        return self.stft_config.fs

    def evidence(self, n_observations: np.ndarray) -> np.ndarray:
        """Which frames brought new evidence to their heat map ``(T,)`` bool, from
        :attr:`HeatMaps.n_observations`: every frame here (a memoryless map); localizers whose
        map keeps a memory of earlier frames say which frames updated it."""
        return np.ones(np.shape(n_observations), dtype=bool)

    @property
    def latency_frames(self) -> int:
        """STFT frames by which a frame's heat map follows the frame itself: 0 for a causal
        map; a fixed-lag smoother's lag otherwise (:meth:`flush` ends the signal)."""
        return 0

    def reset(self) -> None:
        """Start a new signal: clears the STFT buffer and the algorithm's state."""
        self._stft.reset()
        self._frames_out = 0
        self._reset_state()

    def _heat_maps(self, weights: np.ndarray, n_obs: np.ndarray) -> HeatMaps:
        """The next ``len(weights)`` frames' maps, numbered on from the frames given so far."""
        frames = np.arange(self._frames_out, self._frames_out + weights.shape[0])
        self._frames_out += weights.shape[0]
        return HeatMaps(frames, self.stft_config.frame_times(frames), weights, n_obs)

    def process(self, block: np.ndarray) -> HeatMaps:
        """Feed the next samples; return the heat maps of the frames they complete.

        Parameters
        ----------
        block : ndarray (n_channels, n_samples)
            Real, finite samples at ``fs``; any ``n_samples >= 0``.

        Returns
        -------
        HeatMaps
            The maps of the new STFT frames (may be none); with a :attr:`latency_frames` of
            ``L``, of the frames up to ``L`` before the newest.
        """
        block = np.asarray(block)
        if block.ndim != 2 or block.shape[0] != self.n_channels:
            raise ValueError(
                f"{type(self).__name__}.process: block must have shape ({self.n_channels}, "
                f"n_samples) for array {self.array.name!r}, got {block.shape}"
            )
        spec = self._stft.process(block)  # validates dtype and finiteness
        if spec.shape[2] == 0:
            return self._heat_maps(np.zeros((0, self.grid.size)), np.zeros(0, dtype=np.int64))
        return self._heat_maps(*self._process_stft(spec))

    def flush(self) -> HeatMaps:
        """End the signal: the heat maps of the frames still held back (the last
        :attr:`latency_frames` frames, read with the frames there are; none for a causal
        map). :meth:`reset` before the next signal."""
        return self._heat_maps(*self._flush())

    def run(self, signal: np.ndarray, block_size: int | None = None) -> HeatMaps:
        """Batch helper: reset, then process a whole signal ``(n_channels, n_samples)``.

        ``block_size`` (samples) feeds it in blocks, as a stream would; the result is the same.
        """
        self.reset()
        signal = np.asarray(signal)
        if block_size is None:
            return HeatMaps.concatenate([self.process(signal), self.flush()], self.grid.size)
        if isinstance(block_size, bool) or not isinstance(block_size, int) or block_size < 1:
            raise ValueError(f"run: block_size must be a positive integer, got {block_size!r}")
        if signal.ndim != 2:
            raise ValueError(
                f"run: signal must be 2-D (n_channels, n_samples), got {signal.shape}"
            )
        parts = [
            self.process(signal[:, i : i + block_size])
            for i in range(0, signal.shape[1], block_size)
        ]
        return HeatMaps.concatenate([*parts, self.flush()], self.grid.size)

    # -- implementation hooks -------------------------------------------------------------
    def _setup(self) -> None:  # noqa: B027 - optional hook
        """Precompute what depends only on the array, grid and configuration."""

    @abstractmethod
    def _reset_state(self) -> None:
        """Clear the algorithm's recursive state."""

    @abstractmethod
    def _process_stft(self, spec: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Heat maps of consecutive STFT frames.

        Parameters
        ----------
        spec : ndarray (n_channels, n_freqs, n_frames), complex, n_frames >= 1

        Returns
        -------
        weights : ndarray (n_frames, n_candidates)
        n_observations : ndarray (n_frames,) int
            Of the frames whose maps are ready: all ``n_frames`` of ``spec`` for a causal
            map; with a :attr:`latency_frames` of ``L``, the frames held back before and up to
            ``L`` before the newest.
        """

    def _flush(self) -> tuple[np.ndarray, np.ndarray]:
        """The maps ``(n, D)`` and feature counts ``(n,)`` of the frames still held back at
        the end of the signal (none for a causal map)."""
        return np.zeros((0, self.grid.size)), np.zeros(0, dtype=np.int64)


def make_localizer(
    method: str,
    array: MicArray,
    grid: DirectionGrid | None = None,
    config: Any = None,
    stft: STFTConfig | None = None,
) -> Localizer:
    """Instantiate the localizer registered as ``method`` (see :data:`LOCALIZERS`)."""
    if method not in LOCALIZERS:
        raise ValueError(
            f"make_localizer: method must be one of {sorted(LOCALIZERS)}, got {method!r}"
        )
    return LOCALIZERS[method](array, grid, config, stft)


def localize(
    signal: np.ndarray,
    array: MicArray,
    method: str = DEFAULT_LOCALIZER,
    grid: DirectionGrid | None = None,
    config: Any = None,
    stft: STFTConfig | None = None,
) -> HeatMaps:
    """Heat maps of a whole signal ``(n_channels, n_samples)`` with the named method."""
    return make_localizer(method, array, grid, config, stft).run(signal)
