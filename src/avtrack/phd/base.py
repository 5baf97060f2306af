"""Interface of the audio-visual SMC-PHD filters: configuration, per-frame output, registry.

A filter is an online object: :meth:`PHDFilter.step` takes one frame's
:class:`~avtrack.phd.likelihood.AVFrame` and returns a :class:`PHDEstimate`;
:meth:`PHDFilter.run` is the batch helper returning a :class:`PHDResult`. Filters are
registered by name (``"npf"``, ``"lpf"``) with :func:`register_phd_filter`; the CLI and the
contract tests iterate :data:`PHD_FILTERS`.
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np

from avtrack.io.av163 import IMAGE_SIZE
from avtrack.phd.likelihood import AVFrame
from avtrack.registry import Registry

FLOW_PRIORS = ("transition", "label")
RESAMPLE_RULES = ("population", "label")
ASSOCIATIONS = ("face", "phd", "clutter")


@dataclass(frozen=True)
class PHDConfig:
    """Parameters shared by the AV SMC-PHD filters (Liu et al.; state ``[x, y, vx, vy]``,
    pixels and pixels per frame).

    Where a default departs from the seed paper the reason is given in a sentence; the
    measurements behind each choice are in BENCHMARKS.md ("Audio-visual SMC-PHD filters on
    AV16.3"), the departures from the printed equations in the README.

    Attributes
    ----------
    particles_per_target : int
        Particles per estimated speaker after resampling (seed §4: 50).
    n_birth : int
        ``N_B``, birth particles per frame (seed §4: 50), shared among the measurements that
        no surviving particle explains.
    birth_mass : float
        PHD mass given to the birth particles of one measurement (eq. 5: ``gamma_k``).
    birth_std : float
        Position spread of the birth density around a visual measurement (eq. 13), pixels.
    birth_velocity_std : float
        Velocity spread of birth particles (pixels per frame).
    p_survival : float
        Survival probability (eq. 4 with the transition as proposal).
    p_detect_audio, p_detect_visual : float
        ``p_D`` of the audio and visual measurements. The seed (§4) uses 0.98; the defaults
        are the detection rates measured on the AV16.3 DOA and face files. A fused
        measurement ``(o, u)`` has ``p_D = p_ring p_breve``, a visual point alone
        ``(1 - p_ring) p_breve``, a line alone ``p_ring (1 - p_breve)``; no measurement
        ``(1 - p_ring)(1 - p_breve)``.
    clutter_audio, clutter_visual : float
        False alarms per frame of the DOA estimator and of the face detector (Poisson). The
        clutter intensities ``kappa`` of eqs. 11 and 22 follow in the units of the normalised
        likelihoods: ``kappa_breve = clutter_visual / (W H)`` per pixel^2 (uniform over the
        image), ``kappa_ring = clutter_audio / sqrt(W^2 + H^2)`` per pixel of line offset, and
        ``kappa_ring kappa_breve`` for a fused pair.
    sigma_visual, sigma_audio : float
        Standard deviations of the visual likelihood ``N(z; p, sigma_v^2 I)`` (pixel^-2) and of
        the DOA-line likelihood ``N(n . p - c; 0, sigma_a^2)`` (pixel^-1), from the errors of
        the AV16.3 face detections and DOA lines about the annotated mouths.
    weight_audio, weight_visual : float
        Modality weights of eq. 10.
    gate : float
        Association gate in kernel widths (labels of eqs. 15–16, pairing, birth).
    position_std, velocity_std : float
        Process noise of the constant-velocity model per frame (eq. 1).
    motion_correlation : float
        Correlation of the position and velocity noise of one axis
        (:func:`~avtrack.phd.smc_phd.constant_velocity`; ``sqrt(3)/2`` for integrated white
        acceleration); with it a detection also corrects each particle's velocity in the flow.
    flow_steps : int
        Number of pseudo-time steps of the flow (eqs. 6–7).
    flow_step_ratio : float
        Growth ratio of consecutive ``Delta lambda``.
    diffusion : float
        ``v`` of eq. 7 in the labelled flow (the NPF's flow is deterministic). 1 makes the
        affine flow carry a Gaussian prior exactly onto its posterior; the weights are the
        flow's importance weights for any value (:func:`~avtrack.phd.flow.affine_flow_map`).
    flow_prior : {"transition", "label"}
        The prior covariance ``P_{k|k-1}`` of eq. 9 in the labelled flow. ``"label"``
        (default): the weighted covariance of the particles sharing the label (eqs. 18–20)
        scaled by ``label_prior_scale``, plus ``Q``. ``"transition"``: the particle's own
        ``Q``; with ``diffusion = 1`` the flow then samples the posterior given the parent
        and the label's likelihood exactly (the optimal proposal).
    label_prior_scale : float
        ``beta`` of ``flow_prior="label"``: ``P = beta Sigma_l + Q``. 1 is the seed's, 0 the
        transition prior; 0.25 by default, because the full label covariance moves each
        particle by the label-wide gain, far beyond its own transition noise, and labels swap
        at crossings, while a fraction of it still lets a label learn its speaker's velocity.
    faceless_velocity_decay : float
        LPF, ``a`` in ``[0, 1]`` (not in the seed): a label whose last update had no face
        point (a DOA line alone, or no measurement; not an occluded label) is predicted with
        ``v_k = a v_{k-1}``, a mean-reverting velocity (Singer 1970). A DOA line does not
        measure the distance along the line, so without it a label entering a face gap
        keeps running along the line; 1 is the constant-velocity model.
    marginal_weights : bool
        LPF: weight each particle of a label for the label's predicted intensity
        ``D(m) = sum_j w_j phi(m | m_{k-1}^j)`` (eq. 4 over the parents) against the mixture
        of the flows of all its parents, ``u_i = D(m_i) / sum_j q_j(m_i)``
        (:func:`~avtrack.phd.flow.marginal_log_weights`; the marginal particle filter's
        unbiased weight) instead of the per-parent ``w_i phi(m_i | m_{k-1}^i) / q_i(m_i)``,
        which carries each parent's own predictive likelihood and degenerates faster.
    resample_rule : {"population", "label"}
        LPF: when to resample. ``"population"`` (default, Algorithm 1): when the ESS of all
        the particles kept falls below ``resample_fraction`` of their number; every label is
        then resampled on its own (its weight unchanged). ``"label"``: each label when its own
        ESS falls below ``resample_fraction`` of its particles.
    association : {"face", "phd", "clutter"}
        LPF: which label-measurement pairs the association (eqs. 15–16 per label) may use,
        and how it scores them. ``"clutter"``: only pairs with ``G_lr > kappa_r``, scored
        ``log(G_lr / kappa_r)`` (a birth whose mass gives ``G_lr < kappa_r`` never takes its
        speaker's next detection). ``"phd"``: every gated pair, scored by the measurement's
        factor in eq. 11, ``log((kappa_r + G_lr) / kappa_r)``, so a birth gathers evidence
        over frames. ``"face"`` (default): ``"phd"`` for measurements with a face point,
        ``"clutter"`` for a DOA line alone (a line crosses the whole image: fed weakly by
        lines, lost labels would linger and come back as false speakers).
    coast_frames : int
        A confirmed speaker (label weight once ``>= xi``) is still reported, at its particles'
        mean, for up to this many frames in which its weight stays below ``xi`` (LPF). 0 by
        default: the coasted estimate drifts, and the label itself survives gaps by relinking.
    relabel_distance : float
        A birth within this distance (pixels) of a confirmed label that takes no measurement
        of the frame takes that label instead of a new one (LPF; 0: never; not in the seed,
        whose labels are new at every birth); also the reach of a dropped label at a gap of
        0 frames (below).
    relink_frames, relink_speed : int, float
        A confirmed label dropped (its weight gone) is remembered for ``relink_frames``
        frames at the position where it was last confirmed; a birth within
        ``relabel_distance + relink_speed * gap`` pixels of it (``gap`` frames later) takes
        it back (LPF): a speaker who was missed for long, or left and came back, keeps the
        label.
    relink_rule : {"likelihood", "reach"}
        Which dropped (or confirmed, unmeasured) label a birth takes when several are in
        reach (LPF). ``"likelihood"`` (default): the one under whose spread since it was
        dropped the birth is most likely — an isotropic Gaussian about its last confirmed
        position with standard deviation ``reach / 2``, normalised, so a longer gap spreads a
        label thinner rather than making it more attractive; ``"reach"``: the smallest
        ``distance / reach`` (old labels, with the larger reach, win over recent nearer ones).
    relink_gate : float
        ``"likelihood"``: a label is a candidate within this many standard deviations
        (``reach / 2``) of the birth; 2 (default) is the reach of ``"reach"``.
    ambiguity_ratio : float
        LPF, occlusion rule (not in the seed; :meth:`~avtrack.phd.lpf.LPFSMCPHD._ambiguous`):
        when the best assignment of the frame's faces to the labels (eq. 12 with the visual
        likelihood) is less than this many times more likely than the best one without one
        of its (confirmed label, face) pairs, and the two differ only in confirmed labels,
        those labels take no measurement on the frame (``p_D = 0``) and coast on their
        transitions: two speakers crossing with one face detected cannot be told apart.
        1: never.
    occlusion_frames : int
        LPF: a label coasts by the occlusion rule for at most this many frames in a row
        (0: never).
    prune_weight : float
        A label that is neither reported nor coasting is dropped when its weight falls
        below this (LPF).
    extraction_threshold : float
        ``xi``: a speaker is reported when its weight is at least this (seed §3: 0.5).
    resample_fraction : float
        Resample when the effective sample size falls below this fraction of the particles
        (seed §2: 1/2).
    image_size : (int, int)
        Width and height (pixels).
    """

    particles_per_target: int = 50
    n_birth: int = 50
    birth_mass: float = 0.01
    birth_std: float = 6.0
    birth_velocity_std: float = 1.5
    p_survival: float = 0.99
    p_detect_audio: float = 0.8
    p_detect_visual: float = 0.8
    clutter_audio: float = 0.15
    clutter_visual: float = 0.1
    sigma_visual: float = 4.0
    sigma_audio: float = 10.0
    weight_audio: float = 1.0
    weight_visual: float = 1.0
    gate: float = 4.0
    position_std: float = 2.0
    velocity_std: float = 0.5
    motion_correlation: float = 0.8
    flow_steps: int = 10
    flow_step_ratio: float = 1.2
    diffusion: float = 1.0
    flow_prior: str = "label"
    label_prior_scale: float = 0.25
    faceless_velocity_decay: float = 0.8
    marginal_weights: bool = True
    coast_frames: int = 0
    ambiguity_ratio: float = 6.0
    occlusion_frames: int = 25
    prune_weight: float = 1e-3
    relabel_distance: float = 120.0
    relink_frames: int = 250
    relink_speed: float = 1.0
    relink_rule: str = "likelihood"
    relink_gate: float = 2.0
    extraction_threshold: float = 0.5
    resample_fraction: float = 0.5
    resample_rule: str = "population"
    association: str = "face"
    image_size: tuple[int, int] = IMAGE_SIZE

    def __post_init__(self) -> None:
        for name in ("particles_per_target", "n_birth", "flow_steps"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | np.integer) or v < 1:
                raise ValueError(f"PHDConfig: {name} must be an integer >= 1, got {v!r}")
        for name in ("coast_frames", "relink_frames", "occlusion_frames"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | np.integer) or v < 0:
                raise ValueError(f"PHDConfig: {name} must be an integer >= 0, got {v!r}")
        if not 0 <= self.prune_weight < self.extraction_threshold:
            raise ValueError(
                f"PHDConfig: prune_weight must be in [0, extraction_threshold), got "
                f"{self.prune_weight!r}"
            )
        for name in ("p_survival", "p_detect_audio", "p_detect_visual", "resample_fraction"):
            v = getattr(self, name)
            if not 0 < v <= 1:
                raise ValueError(f"PHDConfig: {name} must be in (0, 1], got {v!r}")
        for name in (
            "birth_mass", "birth_std", "birth_velocity_std", "clutter_audio", "clutter_visual",
            "sigma_visual", "sigma_audio", "gate", "position_std", "velocity_std",
            "flow_step_ratio",
        ):  # fmt: skip
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"PHDConfig: {name} must be a finite number > 0, got {v!r}")
        for name in ("diffusion", "weight_audio", "weight_visual", "relabel_distance",
                     "relink_speed", "label_prior_scale"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise ValueError(f"PHDConfig: {name} must be a finite number >= 0, got {v!r}")
        if not (np.isfinite(self.ambiguity_ratio) and self.ambiguity_ratio >= 1):
            raise ValueError(
                f"PHDConfig: ambiguity_ratio must be a finite number >= 1, got "
                f"{self.ambiguity_ratio!r}"
            )
        intervals: tuple[tuple[str, Callable[[float], bool], str], ...] = (
            ("extraction_threshold", lambda v: 0 < v < 1, "(0, 1)"),
            ("motion_correlation", lambda v: -1 < v < 1, "(-1, 1)"),
            ("faceless_velocity_decay", lambda v: 0 <= v <= 1, "[0, 1]"),
        )
        for name, inside, interval in intervals:
            v = getattr(self, name)
            if not inside(v):
                raise ValueError(f"PHDConfig: {name} must be in {interval}, got {v!r}")
        for name, choices in (("flow_prior", FLOW_PRIORS), ("resample_rule", RESAMPLE_RULES)):
            v = getattr(self, name)
            if v not in choices:
                raise ValueError(f"PHDConfig: {name} must be one of {choices}, got {v!r}")
        if self.relink_rule not in ("likelihood", "reach"):
            raise ValueError(
                f"PHDConfig: relink_rule must be 'likelihood' or 'reach', got "
                f"{self.relink_rule!r}"
            )
        if not (np.isfinite(self.relink_gate) and self.relink_gate > 0):
            raise ValueError(
                f"PHDConfig: relink_gate must be a finite number > 0, got {self.relink_gate!r}"
            )
        if self.association not in ASSOCIATIONS:
            raise ValueError(
                f"PHDConfig: association must be one of {ASSOCIATIONS}, got "
                f"{self.association!r}"
            )
        if not isinstance(self.marginal_weights, bool | np.bool_):
            raise TypeError(
                f"PHDConfig: marginal_weights must be a bool, got {self.marginal_weights!r}"
            )
        if len(self.image_size) != 2 or min(self.image_size) <= 0:
            raise ValueError(
                f"PHDConfig: image_size must be (width, height) > 0, got {self.image_size!r}"
            )


@dataclass(frozen=True)
class PHDEstimate:
    """Output of one filter step.

    Attributes
    ----------
    states : ndarray (J, 4)
        Speaker states ``[x, y, vx, vy]``.
    weights : ndarray (J,)
        Speaker weights (eq. 25 / cluster mass).
    ids : ndarray (J,) int
        Track identities, -1 where the filter gives none.
    ess : float
        Effective sample size of the updated particle weights (before any resampling).
    n_particles : int
        Particles after the update (before resampling).
    resampled : bool
    cardinality : float
        Estimated number of speakers, the sum of the particle weights.
    """

    states: np.ndarray
    weights: np.ndarray
    ids: np.ndarray
    ess: float
    n_particles: int
    resampled: bool
    cardinality: float

    def __post_init__(self) -> None:
        states = np.asarray(self.states, dtype=float).reshape(-1, 4)
        j = states.shape[0]
        weights = np.asarray(self.weights, dtype=float).reshape(j)
        ids = np.asarray(self.ids, dtype=np.int64).reshape(j)
        object.__setattr__(self, "states", states)
        object.__setattr__(self, "weights", weights)
        object.__setattr__(self, "ids", ids)

    @property
    def positions(self) -> np.ndarray:
        """Speaker positions ``(J, 2)`` (pixels)."""
        return self.states[:, :2]


@dataclass(frozen=True)
class PHDResult:
    """A filter run over a sequence.

    Attributes
    ----------
    estimates : tuple of T PHDEstimate
    time_s : float
        Wall-clock time of the filter steps (measurement preparation excluded).
    """

    estimates: tuple[PHDEstimate, ...]
    time_s: float

    @property
    def mean_ess(self) -> float:
        """Mean effective sample size over the frames (seed Table 2, "ESS")."""
        return float(np.mean([e.ess for e in self.estimates])) if self.estimates else 0.0

    @property
    def n_resamplings(self) -> int:
        """Number of frames on which the particles were resampled (seed Table 2)."""
        return int(sum(e.resampled for e in self.estimates))

    def positions(self) -> list[np.ndarray]:
        """Estimated positions per frame, list of ``(J_t, 2)``."""
        return [e.positions for e in self.estimates]

    def rows(self, frames: np.ndarray | None = None) -> np.ndarray:
        """Rows ``frame, id, x, y`` of every estimate: ``(K, 4)`` (frames 1-based unless
        given)."""
        if frames is None:
            frames = np.arange(1, len(self.estimates) + 1)
        out = [
            np.column_stack([np.full(len(e.ids), f), e.ids, e.positions])
            for f, e in zip(frames, self.estimates, strict=True)
        ]
        return np.vstack(out) if out else np.zeros((0, 4))


class PHDFilter(ABC):
    """An online audio-visual SMC-PHD filter."""

    name: str = ""

    def __init__(self, config: PHDConfig | None = None, seed: int | None = 0) -> None:
        if config is not None and not isinstance(config, PHDConfig):
            raise TypeError(f"config must be a PHDConfig, got {type(config).__name__}")
        self.config = config or PHDConfig()
        self.rng = np.random.default_rng(seed)

    def step(self, frame: AVFrame) -> PHDEstimate:
        """Process one frame's measurements; returns the speakers of that frame."""
        if not isinstance(frame, AVFrame):
            raise TypeError(f"step: frame must be an AVFrame, got {type(frame).__name__}")
        return self._step(frame)

    def run(self, frames: Iterable[AVFrame]) -> PHDResult:
        """Filter a whole sequence from the current state."""
        frames = list(frames)
        t0 = time.perf_counter()
        out = tuple(self.step(f) for f in frames)
        return PHDResult(out, time.perf_counter() - t0)

    @abstractmethod
    def _step(self, frame: AVFrame) -> PHDEstimate: ...


#: Registered filters by name.
PHD_FILTERS: Registry[type[PHDFilter]] = Registry("SMC-PHD filter")

#: Class decorator adding a filter to :data:`PHD_FILTERS` under a name.
register_phd_filter = PHD_FILTERS.register


def write_tracks_csv(path, rows: np.ndarray) -> None:
    """Rows ``frame, id, x, y`` (:meth:`PHDResult.rows`) as CSV with a header, atomically."""
    from avtrack.io.base import atomic_write

    with atomic_write(path) as fh:
        fh.write("frame,id,x,y\n")
        for f, i, x, y in rows:
            fh.write(f"{int(f)},{int(i)},{x:.2f},{y:.2f}\n")
