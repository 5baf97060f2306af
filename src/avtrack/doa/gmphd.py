r"""Peer for benchmarks and tests: Stone Soup's GM-PHD tracker on DOA peaks.

Vo & Ma's Gaussian-mixture PHD filter ("The Gaussian mixture probability hypothesis density
filter", IEEE TSP 2006) with Clark, Panta & Vo's tagged components for track continuity, as
implemented by Stone Soup (:class:`stonesoup.tracker.pointprocess.PointProcessMultiTargetTracker`
with :class:`~stonesoup.updater.pointprocess.PHDUpdater`), configured for bearings:

* a DOA :math:`y` is measured as the point :math:`(\cos y, \sin y)` on the unit circle, and the
  state is a nearly-constant-velocity point in that plane, ``[x, ẋ, y, ẏ]``
  (:class:`~stonesoup.models.transition.linear.ConstantVelocity` per axis), so angles never wrap
  inside the filter (the same device as the thesis's unit-vector state, §5.4); the estimate is
  :math:`\operatorname{atan2}(y, x)`;
* measurements: the DOAs given to :meth:`~avtrack.doa.base.DOATracker.step` with a
  confidence ≥ ``min_weight`` (usually the heat-map peaks), linear Gaussian with standard
  deviation ``meas_std`` per axis; clutter uniform over the square :math:`[-1.5, 1.5]^2` with
  ``clutter_rate`` false DOAs per frame;
* one broad birth component centred at the origin covering the circle; components are pruned
  and merged by :class:`~stonesoup.mixturereducer.gaussianmixture.GaussianMixtureReducer`;
  a component with weight above ``extraction_threshold`` is reported, its tag being the track
  identity.

The PHD filter has no speaker-activity model: every extracted component is reported active.
It is registered nowhere (not a CLI choice); it only needs ``stonesoup`` when instantiated.
"""

from __future__ import annotations

import datetime
from dataclasses import dataclass

import numpy as np

from avtrack.doa.base import DOATracker, TrackFrame

_HALF_SIDE = 1.5  # clutter over [-1.5, 1.5]² around the unit circle


@dataclass(frozen=True)
class GMPHDConfig:
    """Parameters of :class:`GMPHDPeer`."""

    meas_std: float = 0.1  #: std of each measured unit-vector coordinate
    process_noise: float = 0.5  #: ConstantVelocity noise diffusion coefficient (units²/s³)
    prob_detection: float = 0.8  #: probability that a speaker yields a DOA in a frame
    prob_survival: float = 0.995  #: per frame
    clutter_rate: float = 1.0  #: expected false DOAs per frame
    birth_weight: float = 0.05  #: expected births per frame
    birth_std_pos: float = 1.0  #: birth component std of each coordinate
    birth_std_vel: float = 1.0  #: birth component std of each velocity, units/s
    extraction_threshold: float = 0.5  #: report components with a larger weight
    prune_threshold: float = 1e-5  #: drop components with a smaller weight
    merge_threshold: float = 4.0  #: merge components closer than this (squared Mahalanobis)
    gate: float = 3.0  #: Mahalanobis gate of the hypothesiser
    min_weight: float = 0.05  #: DOAs with a smaller confidence are not measurements

    def __post_init__(self) -> None:
        for name in (
            "meas_std",
            "process_noise",
            "clutter_rate",
            "birth_weight",
            "birth_std_pos",
            "birth_std_vel",
            "prune_threshold",
            "merge_threshold",
            "gate",
        ):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and np.isfinite(v) and v > 0):
                raise ValueError(f"GMPHDConfig.{name} must be a positive number, got {v!r}")
        for name in ("prob_detection", "prob_survival", "extraction_threshold"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and 0 < v <= 1):
                raise ValueError(f"GMPHDConfig.{name} must be in (0, 1], got {v!r}")
        if not (isinstance(self.min_weight, int | float) and self.min_weight >= 0):
            raise ValueError(f"GMPHDConfig.min_weight must be >= 0, got {self.min_weight!r}")


class GMPHDPeer(DOATracker):
    """Stone Soup GM-PHD tracker on DOAs (see the module docstring).

    Parameters
    ----------
    config : GMPHDConfig, optional
    frame_period_s : float
        Seconds between two :meth:`step` calls.
    """

    name = "gmphd"
    Config = GMPHDConfig

    def _reset_state(self) -> None:
        from stonesoup.hypothesiser.distance import DistanceHypothesiser
        from stonesoup.hypothesiser.gaussianmixture import GaussianMixtureHypothesiser
        from stonesoup.measures import Mahalanobis
        from stonesoup.mixturereducer.gaussianmixture import GaussianMixtureReducer
        from stonesoup.models.measurement.linear import LinearGaussian
        from stonesoup.models.transition.linear import (
            CombinedLinearGaussianTransitionModel,
            ConstantVelocity,
        )
        from stonesoup.predictor.kalman import KalmanPredictor
        from stonesoup.tracker.pointprocess import PointProcessMultiTargetTracker
        from stonesoup.types.state import TaggedWeightedGaussianState
        from stonesoup.updater.kalman import KalmanUpdater
        from stonesoup.updater.pointprocess import PHDUpdater

        cfg: GMPHDConfig = self.config
        transition = CombinedLinearGaussianTransitionModel(
            [ConstantVelocity(cfg.process_noise), ConstantVelocity(cfg.process_noise)]
        )
        self._measurement_model = LinearGaussian(
            ndim_state=4, mapping=(0, 2), noise_covar=np.eye(2) * cfg.meas_std**2
        )
        kalman = KalmanUpdater(self._measurement_model)
        updater = PHDUpdater(
            kalman,
            clutter_spatial_density=cfg.clutter_rate / (2 * _HALF_SIDE) ** 2,
            prob_detection=cfg.prob_detection,
            prob_survival=cfg.prob_survival,
        )
        hypothesiser = GaussianMixtureHypothesiser(
            DistanceHypothesiser(
                KalmanPredictor(transition), kalman, Mahalanobis(), missed_distance=cfg.gate
            ),
            order_by_detection=True,
        )
        reducer = GaussianMixtureReducer(
            prune_threshold=cfg.prune_threshold,
            pruning=True,
            merge_threshold=cfg.merge_threshold,
            merging=True,
        )
        self._t0 = datetime.datetime(2000, 1, 1)
        birth = TaggedWeightedGaussianState(
            np.zeros((4, 1)),
            np.diag([cfg.birth_std_pos**2, cfg.birth_std_vel**2] * 2),
            weight=cfg.birth_weight,
            tag=TaggedWeightedGaussianState.BIRTH,
            timestamp=self._t0,
        )
        self._frames: list[tuple[datetime.datetime, set]] = []
        self._tracker = PointProcessMultiTargetTracker(
            detector=_Feed(self._frames),
            updater=updater,
            hypothesiser=hypothesiser,
            reducer=reducer,
            birth_component=birth,
            extraction_threshold=cfg.extraction_threshold,
        )
        self._iter = iter(self._tracker)
        self._tag_ids: dict[str, int] = {}

    def _step(self, azimuth_rad: np.ndarray, weight: np.ndarray) -> TrackFrame:
        from stonesoup.types.detection import Detection

        cfg: GMPHDConfig = self.config
        ts = self._t0 + datetime.timedelta(seconds=self.frame * self.frame_period_s)
        keep = weight >= cfg.min_weight
        dets = {
            Detection(
                np.array([[np.cos(a)], [np.sin(a)]]),
                timestamp=ts,
                measurement_model=self._measurement_model,
            )
            for a in azimuth_rad[keep]
        }
        self._frames.append((ts, dets))
        next(self._iter)
        best: dict[str, object] = {}  # the heaviest extracted component of each tag
        for c in self._tracker.gaussian_mixture:
            if c.weight > cfg.extraction_threshold and c.tag != c.BIRTH:
                if str(c.tag) not in best or c.weight > best[str(c.tag)].weight:
                    best[str(c.tag)] = c
        comps = list(best.values())
        ids = np.array(
            [self._tag_ids.setdefault(str(c.tag), len(self._tag_ids) + 1) for c in comps],
            dtype=np.int64,
        )
        az = np.array(
            [np.arctan2(float(c.state_vector[2, 0]), float(c.state_vector[0, 0])) for c in comps]
        )
        weights = np.array([float(c.weight) for c in comps])
        return TrackFrame(
            ids, np.rad2deg(az).reshape(-1), np.ones(ids.size, dtype=bool), weights.reshape(-1)
        )


class _Feed:
    """An endless iterable over the frames appended to ``frames`` (Stone Soup's detector)."""

    def __init__(self, frames: list):
        self.frames = frames

    def __iter__(self):
        i = 0
        while True:
            yield self.frames[i]
            i += 1
