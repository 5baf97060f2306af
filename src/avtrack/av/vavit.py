r"""VAVIT: variational audio-visual tracking and diarization of several speakers (thesis ch. 4).

The VEM engine (:class:`~avtrack.vem.engine.VEMEngine`) with two observation models
feeding one state per person :math:`s_{tn} = (x, y, w, h, \dot x, \dot y)` (thesis §4.3.1):

* vision: head boxes and appearance, :class:`~avtrack.visual.model.BoxObservationModel`,
  E-Z step eq. 4.28, precision term #1 of eq. 4.26;
* audio: GLLiM-mapped DP-RTF sub-band features with the joint (person, affine component)
  assignment, :class:`~avtrack.av.audio_model.AudioGLLiMModel`, E-Z eqs. 4.29–4.30 at the
  naive prediction :math:`\tilde x_{tn} = x_{t-1,n} + y_{t-1,n}`, precision term #2;

and the dynamics (term #3, eqs. 4.24, 4.26–4.27). Per frame (thesis Algorithm 1): VAD and
audio features, E-Z initialised at :math:`\mu_{tn} = D\mu_{t-1,n}` (§4.6.1), ``n_iter``
iterations of E-Z (vision, audio) → E-S → M, then birth (§4.6.2: smooth sequences of ``B + 1``
visual detections left to clutter, eq. 4.31, :mod:`avtrack.vem.birth`) and the speaking
status of each person (eq. 4.34, :mod:`avtrack.av.diarization`). Persons start with the birth
process (the thesis's initial non-informative states are replaced by the births themselves).

**Tracks out of view continue on audio.** The tracker knows the camera's visual field of view
(the image, or a central strip of it, ``fov``). Target management follows OVBT (visibility HMM,
eqs. 3.31–3.32; death after ``death_frames`` invisible frames), with the evidence
:math:`\nu_{tn}` = visual mass + ``audio_visibility_weight`` × audio share
(:math:`\frac1{K_t}\sum_{k,r}\beta_{tknr}`), except that for a person whose position is outside
the visual field of view the absence of detections is no evidence: their visibility is only
updated when they are heard, and they are deleted after ``out_of_view_death_frames`` frames
neither seen nor heard. Tracks whose centre leaves the image are not reported.

**Departures from the printed model**, each a parameter of :class:`VAVITConfig` (or of the
mapping), all measured in ``benchmarks/bench_vavit.py``:

* audio-to-image mappings of horizontal arrays (a binaural head) map to the horizontal image
  coordinate only (:func:`avtrack.simulate.calibration.train_mapping`, ``axes``): their vertical
  estimates are biased by 100-160 px at run time and dragged audio-only tracks off;
* the audio clutter density is the GLLiM marginal of the features, "a source at an unknown
  position", rather than a uniform density (the voice of someone not tracked goes to clutter
  instead of pulling a tracked person towards it);
* the calibrated noise covariances are scaled by ``sigma_scale`` and the summed audio
  information of the E-S step by ``audio_information_scale`` (speech features are noisier than
  white-noise calibration features, and the sub-bands of a frame share their errors);
* a person not seen loses velocity (``coast_velocity_decay``), and a newborn whose appearance
  matches a person not seen lately takes that person's identity (``reid_log_ratio``);
* in diarization, speech claimed by no tracked person can be clustered as unseen speakers
  (``track_scene(..., unseen_speakers=True)``).

``track_scene`` runs the tracker on a scene directory (read by :mod:`avtrack.io.scene`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from avtrack.av.audio_model import AudioGLLiMModel, AudioObservations
from avtrack.av.diarization import speaking_segments, speaking_status
from avtrack.av.diarization import unseen_speakers as diarize_unseen
from avtrack.av.features import AudioFeatureConfig, AudioFeatures, extract_audio_features
from avtrack.av.gllim import AudioImageMapping
from avtrack.errors import InputError
from avtrack.io.mot import MOTData
from avtrack.io.rttm import RTTMSegment
from avtrack.io.scene import SceneInputs, load_scene
from avtrack.vem.dynamics import cap_box_scale
from avtrack.vem.engine import VEMEngine
from avtrack.vem.targets import PerTarget
from avtrack.vem.visibility import visibility_filter
from avtrack.visual.model import BOX_DIM, BoxObservations, xywh_to_ltwh
from avtrack.visual.ovbt import FrameTracks, OVBTConfig, OVBTracker, track_mot

POS_DIM = 2


@dataclass(frozen=True)
class VAVITConfig:
    """Parameters of VAVIT (the visual ones in ``visual``, shared with OVBT).

    Attributes
    ----------
    visual : OVBTConfig
        Visual model, dynamics, birth, visibility and death parameters; by default with the
        cosine appearance model, for person re-identification embeddings (thesis §4.7.3).
    sigma_scale : float
        Multiplies the GLLiM noise covariances :math:`\\Sigma_{kr}` at run time: speech
        features averaged over five STFT frames are noisier than the white-noise calibration
        features (on the benchmark's binaural scenes a sub-band's position error is about twice
        its calibrated standard deviation).
    audio_log_clutter : float or None
        Log density of the audio clutter class (None: uniform over the unit discs of the
        DP-RTFs).
    audio_clutter_distance : float or None
        Per-sub-band audio clutter density relative to the model (see
        :class:`~avtrack.av.audio_model.AudioGLLiMModel`); overrides ``audio_log_clutter``.
    audio_marginal_clutter : bool
        Audio clutter density = the GLLiM marginal of the features (a source at an unknown
        position; overrides the two above).
    audio_information_scale : float
        Multiplies the audio terms of the E-S step (see
        :class:`~avtrack.av.audio_model.AudioGLLiMModel`): the sub-bands of a frame share
        their errors, and a frame's position error over all sub-bands is 3-4 times the
        independent-sub-band prediction. ``sigma_scale``, this and ``coast_velocity_decay``
        were chosen on a development suite separate from the benchmark's scenes.
    learn_audio_prior : bool
        M-step of the audio assignment priors (thesis: uniform :math:`\\rho_{kn}`).
    audio_visibility_weight : float
        Weight of the audio share in the visibility evidence.
    heard_threshold : float
        A person is *heard* at a frame when their audio share is at least this.
    out_of_view_death_frames : int
        Delete a person outside the visual field of view after this many frames neither
        seen nor heard.
    coast_velocity_decay : float
        Each frame a person is not seen, their velocity mean is multiplied by this (1:
        constant-velocity coasting). Out of view, audio alone gives jumpy positions whose
        differences would otherwise turn into a velocity that carries the track away.
    reid_log_ratio : float or None
        A person born from a new sequence of detections whose appearance log-likelihood ratio
        against a person not seen for ``reid_min_unseen`` frames (typically one who left the
        field of view and came back in silence, so that audio could not follow them) exceeds
        this is that person: the known identity moves to the new state. None: never.
    reid_min_unseen : int
        See ``reid_log_ratio``.
    diarization_threshold : float
        :math:`\\gamma` of eq. 4.34.
    """

    #: weak detections show targets as strong ones do (``weak_evidence`` 1), as in
    #: :class:`~avtrack.av.persons.PersonConfig`: the boxes come from a detector run on the
    #: frames; no rows for a birth's earlier frames (``birth_sequence``): tracks are read frame
    #: by frame beside the audio
    visual: OVBTConfig = field(default_factory=lambda: OVBTConfig(
        appearance="cosine", weak_evidence=1.0, birth_sequence=False))
    sigma_scale: float = 4.0
    audio_log_clutter: float | None = None
    audio_clutter_distance: float | None = None
    audio_marginal_clutter: bool = True
    audio_information_scale: float = 0.25
    learn_audio_prior: bool = False
    audio_visibility_weight: float = 1.0
    heard_threshold: float = 0.3
    out_of_view_death_frames: int = 250
    coast_velocity_decay: float = 0.9
    reid_log_ratio: float | None = 2.0
    reid_min_unseen: int = 10
    diarization_threshold: float = 0.4

    def __post_init__(self) -> None:
        if not isinstance(self.visual, OVBTConfig):
            raise ValueError(
                f"VAVITConfig.visual must be an OVBTConfig, got {type(self.visual).__name__}"
            )
        for name in ("sigma_scale", "audio_information_scale"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and np.isfinite(v) and v > 0):
                raise ValueError(f"VAVITConfig.{name} must be a positive number, got {v!r}")
        for name in ("audio_visibility_weight",):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and np.isfinite(v) and v >= 0):
                raise ValueError(f"VAVITConfig.{name} must be a number >= 0, got {v!r}")
        for name in ("heard_threshold", "diarization_threshold", "coast_velocity_decay"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and 0 < v <= 1):
                raise ValueError(f"VAVITConfig.{name} must be in (0, 1], got {v!r}")
        v = self.out_of_view_death_frames
        if isinstance(v, bool) or not isinstance(v, int) or v < 1:
            raise ValueError(
                f"VAVITConfig.out_of_view_death_frames must be an integer >= 1, got {v!r}"
            )
        v = self.reid_min_unseen
        if isinstance(v, bool) or not isinstance(v, int) or v < 1:
            raise ValueError(f"VAVITConfig.reid_min_unseen must be an integer >= 1, got {v!r}")
        if self.reid_log_ratio is not None and not np.isfinite(self.reid_log_ratio):
            raise ValueError("VAVITConfig.reid_log_ratio must be finite or None")
        if self.audio_log_clutter is not None and not np.isfinite(self.audio_log_clutter):
            raise ValueError("VAVITConfig.audio_log_clutter must be finite or None")


@dataclass(frozen=True)
class AVFrameTracks(FrameTracks):
    """Output of one frame: :class:`~avtrack.visual.ovbt.FrameTracks` (the return type of
    the :meth:`OVBTracker.step` it overrides) with the audio-visual fields.

    Attributes
    ----------
    ids : ndarray (K,) int
        Reported persons (visible, centre inside the image).
    boxes : ndarray (K, 4)
        (left, top, width, height) of their heads.
    p_visible : ndarray (K,)
    speaking : ndarray (K,) bool
        :math:`\\chi_{tn}` (eq. 4.34).
    audio_share : ndarray (K,)
        :math:`\\frac{1}{K_t}\\sum_k\\sum_r\\beta_{tknr}`.
    in_view : ndarray (K,) bool
        Inside the visual field of view.
    precisions : ndarray (K, 3, 2, 2) or None
        Position blocks of the visual, audio and dynamics precision terms #1, #2, #3 of
        eq. 4.26 (with ``record_precisions``).
    """

    ids: np.ndarray
    boxes: np.ndarray
    p_visible: np.ndarray  # (required here: no default, unlike FrameTracks)
    speaking: np.ndarray
    audio_share: np.ndarray
    in_view: np.ndarray
    precisions: np.ndarray | None = None


class VAVITracker(OVBTracker):
    """Online audio-visual multi-speaker tracker (thesis ch. 4, Algorithm 1).

    Parameters
    ----------
    mapping : AudioImageMapping
        Audio-to-image mapping, one GLLiM per sub-band.
    config : VAVITConfig, optional
    image_size : (width, height)
    fov : (float, float), optional
        Horizontal pixel range ``[lo, hi]`` the camera sees (default: the whole width).
    record_precisions : bool
        Report the three precision terms of eq. 4.26 per person (for figures).

    Example
    -------
    >>> tracker = VAVITracker(mapping, image_size=(640, 480))
    >>> for boxes, app, (bands, g) in frames:
    ...     out = tracker.step(boxes, appearance=app, bands=bands, g=g)
    """

    unseen_run: np.ndarray

    def __init__(
        self,
        mapping: AudioImageMapping,
        config: VAVITConfig | None = None,
        image_size: tuple[int, int] = (1920, 1080),
        fov: tuple[float, float] | None = None,
        record_precisions: bool = False,
    ):
        self.av_config = config or VAVITConfig()
        super().__init__(self.av_config.visual, image_size)
        cfg, vcfg = self.av_config, self.av_config.visual
        self.audio_model = AudioGLLiMModel(
            mapping,
            cfg.audio_log_clutter,
            cfg.sigma_scale,
            cfg.learn_audio_prior,
            cfg.audio_clutter_distance,
            cfg.audio_marginal_clutter,
            cfg.audio_information_scale,
        )
        self.engine = VEMEngine(
            self.transition,
            [self.model, self.audio_model],
            n_iter=vcfg.n_iter,
            update_priors=vcfg.update_priors,
            dynamics_mstep=vcfg.dynamics_mstep,
            marginal_init=vcfg.marginal_init,
            exclusive=vcfg.exclusive,
        )
        w = self.image_size[0]
        lo, hi = (0.0, w) if fov is None else (float(fov[0]), float(fov[1]))
        if not (0 <= lo < hi <= w):
            raise ValueError(f"fov must be (lo, hi) with 0 <= lo < hi <= {w:g}, got {fov!r}")
        self.fov = (lo, hi)
        self.record_precisions = bool(record_precisions)

    # ------------------------------------------------------------------ public step
    def step(
        self,
        boxes: np.ndarray,
        scores: np.ndarray | None = None,
        appearance: np.ndarray | None = None,
        bands: np.ndarray | None = None,
        g: np.ndarray | None = None,
    ) -> AVFrameTracks:
        """Process one frame of detections and audio observations.

        Parameters
        ----------
        boxes : ndarray (M, 4)
            Head boxes (left, top, width, height), pixels.
        scores : ndarray (M,), optional
        appearance : ndarray (M, F), optional
        bands : ndarray (K_t,) int, optional
            Active sub-bands (none: no audio observation this frame).
        g : ndarray (K_t, D), optional
            Their features.
        """
        obs = self._observations(boxes, scores, appearance)
        if bands is None:
            bands = np.zeros(0, dtype=np.int64)
            g = np.zeros((0, self.audio_model.mapping.feature_dim))
        return self._step_av(obs, np.asarray(bands), np.asarray(g, dtype=float))

    # ------------------------------------------------------------------ one frame
    def _in_view(self, mu: np.ndarray) -> np.ndarray:
        x = mu[:, 0]
        return (x >= self.fov[0]) & (x <= self.fov[1])

    def _in_image(self, mu: np.ndarray) -> np.ndarray:
        w, h = self.image_size
        return (mu[:, 0] >= 0) & (mu[:, 0] <= w) & (mu[:, 1] >= 0) & (mu[:, 1] <= h)

    def _step_av(self, obs: BoxObservations, bands: np.ndarray, g: np.ndarray) -> AVFrameTracks:
        cfg, vcfg = self.av_config, self.av_config.visual
        self.frame += 1
        eng = self.engine
        n = eng.n_targets
        share = np.zeros(n)
        prec = np.zeros((n, 3, 2, 2)) if self.record_precisions else None
        k_t = int(bands.shape[0])
        if n:
            mu_prev, gamma_prev = eng.mu, eng.gamma
            pred = mu_prev @ self.transition.T  # D μ_{t-1}: x̃_tn = x_{t-1,n} + y_{t-1,n}
            aobs = self.audio_model.observations(bands, g, pred[:, : self.audio_model.p])
            lam = self._dyn_var(mu_prev)  # Λ_tn (diagonal)
            inf = eng.step([obs, aobs], lam)  # E-Z / E-S / M iterations
            scale = cap_box_scale(
                eng.mu, np.diagonal(eng.gamma, axis1=1, axis2=2), vcfg.max_state_std
            )
            if scale.min() < 1.0:
                eng.scale_covariances(scale)
            resp, mass_v = inf.responsibilities[0], inf.mass[0][1:]
            beta = inf.responsibilities[1]
            if k_t:  # (1 / K_t) Σ_k Σ_r β_tknr, eq. 4.34
                share = AudioGLLiMModel.person_mass(beta).sum(axis=0) / k_t
            unassigned = np.flatnonzero(resp.argmax(axis=1) == 0)
            if self.record_precisions:
                prec = self._precisions(obs, resp, aobs, beta, gamma_prev, lam)
            heard = share >= cfg.heard_threshold
            seen = mass_v >= 0.5
            # --- visibility (eqs. 3.31–3.32) with audio evidence; death ---------------------
            evidence = mass_v + cfg.audio_visibility_weight * share
            if vcfg.visibility_window == 1:
                self.mass_history, nu = evidence[:, None], evidence
            else:
                self.mass_history = np.concatenate(
                    [evidence[:, None], self.mass_history[:, :-1]], 1
                )
                nu = self.mass_history.sum(axis=1)
            p_new = visibility_filter(
                self.p_visible, nu, vcfg.visibility_stay, vcfg.visibility_lambda
            )
            in_view = self._in_view(eng.mu) & self._in_image(eng.mu)
            # outside the field of view, missing detections say nothing: update when heard
            self.p_visible = np.where(in_view | heard, p_new, self.p_visible)
            self.invisible_run = np.where(self.p_visible > 0.5, 0, self.invisible_run + 1)
            self.unseen_run = np.where(seen | heard, 0, self.unseen_run + 1)
            if cfg.coast_velocity_decay < 1.0 and not np.all(seen):
                mu = eng.mu.copy()
                mu[~seen, BOX_DIM:] *= cfg.coast_velocity_decay
                eng.mu = mu
            keep = (self.invisible_run < vcfg.death_frames) & (
                self.unseen_run < cfg.out_of_view_death_frames
            )
            if not np.all(keep):
                share = share[keep]
                if prec is not None:
                    prec = prec[keep]
                self._remove(keep)
        else:
            unassigned = np.arange(len(obs))
        # --- birth (§4.6.2, eq. 4.31) ----------------------------------------------------------
        n_before = eng.n_targets
        if obs.scores is not None:  # weak detections only update targets (OVBTConfig)
            unassigned = unassigned[self._can_birth(obs.scores)[unassigned]]
        self._add_to_pool(obs if unassigned.shape[0] == len(obs) else obs.subset(unassigned))
        if len(self._pool) == vcfg.birth_frames + 1 or (
            vcfg.startup_birth and len(self._pool) == self.frame >= 2
        ):
            self._birth()
        born = eng.n_targets - n_before
        if born:
            share = np.concatenate([share, np.zeros(born)])
            if prec is not None:
                prec = np.concatenate([prec, np.zeros((born, 3, 2, 2))])
        out = (self.p_visible > 0.5) & self._in_image(eng.mu)
        speaking = speaking_status(share, k_t, cfg.diarization_threshold)
        return AVFrameTracks(
            eng.ids[out],
            xywh_to_ltwh(eng.mu[out, :BOX_DIM]),
            self.p_visible[out],
            speaking[out],
            share[out],
            self._in_view(eng.mu[out]),
            None if prec is None else prec[out],
        )

    def _per_target(self) -> tuple[PerTarget, ...]:
        """OVBT's, and the frames neither seen nor heard in a row."""
        return (*super()._per_target(), PerTarget("unseen_run", 0, dtype=np.int64))

    def _birth(self) -> None:
        """Birth (§4.6.2), then re-identification of newborns with persons not seen lately."""
        eng = self.engine
        n_before = eng.n_targets
        super()._birth()
        born = eng.n_targets - n_before
        if not born:
            return
        cfg = self.av_config
        refs = self.model.references
        if cfg.reid_log_ratio is None or refs is None or n_before == 0:
            return
        old = np.flatnonzero(self.unseen_run[:n_before] >= cfg.reid_min_unseen)
        if old.size == 0:
            return
        new = np.arange(n_before, eng.n_targets)
        score = self._appearance.log_ratio(refs[new], refs[old])  # log b(h_new; h_old) / u
        mu, gamma = eng.mu.copy(), eng.gamma.copy()
        keep = np.ones(eng.n_targets, dtype=bool)
        while score.size and score.max() > cfg.reid_log_ratio:  # greedy, best pair first
            i, j = np.unravel_index(int(np.argmax(score)), score.shape)
            b, o = new[i], old[j]
            mu[o], gamma[o] = mu[b], gamma[b]  # the known person, where the newborn is
            self.p_visible[o], self.invisible_run[o], self.unseen_run[o] = 1.0, 0, 0
            self.mass_history[o] = 1.0
            keep[b] = False
            score[i, :] = -np.inf
            score[:, j] = -np.inf
        if not keep.all():
            eng.mu, eng.gamma = mu, gamma
            self._remove(keep)

    def _precisions(
        self,
        obs: BoxObservations,
        resp: np.ndarray,
        aobs: AudioObservations,
        beta: np.ndarray,
        gamma_prev: np.ndarray,
        lam: np.ndarray,
    ) -> np.ndarray:
        """``(N, 3, 2, 2)``: position blocks of terms #1, #2 and #3 of eq. 4.26."""
        n = resp.shape[1] - 1
        out = np.zeros((n, 3, POS_DIM, POS_DIM))
        vis = resp[:, 1:].T @ obs.inv_var[:, :POS_DIM]  # Σ_m α_mn Φ_m⁻¹ (diagonal), #1
        out[:, 0, 0, 0], out[:, 0, 1, 1] = vis[:, 0], vis[:, 1]
        p = self.audio_model.p
        out[:, 1, :p, :p] = self.audio_model.information_xy(aobs, beta)[0]  # #2
        d = self.transition
        pred_cov = d @ gamma_prev @ d.T + lam[:, :, None] * np.eye(d.shape[0])
        out[:, 2] = np.linalg.inv(pred_cov)[:, :POS_DIM, :POS_DIM]  # (Λ + D Γ Dᵀ)⁻¹, #3
        return out


# --------------------------------------------------------------------------- scenes


@dataclass(frozen=True)
class AVSceneResult:
    """Tracking and diarization of a whole scene.

    Attributes
    ----------
    tracks : MOTData
        Head boxes per frame (confidence = visibility probability).
    speaking : ndarray (len(tracks),) bool
        :math:`\\chi_{tn}` of each row of ``tracks``.
    speech : list of RTTMSegment
        Diarization (speaker label ``P<track id>``).
    precisions : ndarray (len(tracks), 3, 2, 2) or None
        Terms #1, #2, #3 of eq. 4.26 of each row (with ``record_precisions``).
    n_frames : int
    fps : float
    image_size : (int, int)
    fov : (float, float)
        Visual field of view (pixel columns).
    timing : dict
        Seconds spent on ``features`` and ``tracking``, and the scene ``duration``.
    """

    tracks: MOTData
    speaking: np.ndarray
    speech: list[RTTMSegment]
    precisions: np.ndarray | None
    n_frames: int
    fps: float
    image_size: tuple[int, int]
    fov: tuple[float, float]
    timing: dict[str, float]


def fov_strip(width: float, fraction: float) -> tuple[float, float]:
    """Pixel columns ``(lo, hi)`` of the central ``fraction`` of an image ``width`` wide."""
    if not (isinstance(fraction, int | float) and 0 < fraction <= 1):
        raise ValueError(f"fov fraction must be in (0, 1], got {fraction!r}")
    half = 0.5 * width * fraction
    return 0.5 * width - half, 0.5 * width + half


def restrict_fov(
    dets: MOTData, appearance: np.ndarray | None, fov: tuple[float, float]
) -> tuple[MOTData, np.ndarray | None]:
    """Drop the detections whose box centre lies outside the pixel columns ``fov``."""
    centre = dets.boxes[:, 0] + 0.5 * dets.boxes[:, 2]
    keep = (centre >= fov[0]) & (centre <= fov[1])
    return dets.select(keep), None if appearance is None else appearance[keep]


def track_scene(
    scene_dir: str | Path,
    mapping: AudioImageMapping | None = None,
    config: VAVITConfig | None = None,
    *,
    use_audio: bool = True,
    fov_fraction: float = 1.0,
    features: AudioFeatures | None = None,
    feature_config: AudioFeatureConfig | None = None,
    record_precisions: bool = False,
    diarization_gap: float = 0.4,
    diarization_min: float = 0.3,
    unseen_speakers: bool = False,
    scene: SceneInputs | None = None,
) -> AVSceneResult:
    """Track (and diarize) the people of a scene directory.

    Parameters
    ----------
    scene_dir : str or Path
        A scene directory (``detections.txt``, ``appearance.npy``, ``audio.wav``,
        ``camera.json``, ``scene.yaml``).
    mapping : AudioImageMapping, optional
        Required with ``use_audio``.
    config : VAVITConfig, optional
    use_audio : bool
        False: the visual-only tracker (OVBT, thesis §3.1) with ``config.visual``.
    fov_fraction : float
        The camera sees the central ``fov_fraction`` of the image width (detections outside are
        dropped), the partial-field-of-view configuration of thesis §4.7.4.
    features : AudioFeatures, optional
        Precomputed audio observations (default: extracted from ``audio.wav``).
    feature_config : AudioFeatureConfig, optional
    record_precisions : bool
        Keep the three precision terms of eq. 4.26 per output row.
    diarization_gap, diarization_min : float
        Smoothing of the speaker turns (:func:`~avtrack.av.diarization.speaking_segments`).
    unseen_speakers : bool
        Also diarize the speech no tracked person claims, by clustering its audio
        localisations (:func:`~avtrack.av.diarization.unseen_speakers`): people who never
        entered the camera's view.
    scene : SceneInputs, optional
        Already-loaded inputs (saves reading the directory again).

    Returns
    -------
    AVSceneResult
    """
    config = config or VAVITConfig()
    sc = scene if scene is not None else load_scene(scene_dir)
    fov = fov_strip(sc.image_size[0], fov_fraction)
    dets, app = restrict_fov(sc.detections, sc.appearance, fov)
    timing = {"duration": sc.n_frames / sc.fps, "features": 0.0, "tracking": 0.0}
    if not use_audio:
        t0 = time.perf_counter()
        res = track_mot(dets, app, config.visual, sc.image_size, sc.n_frames, sc.fps)
        timing["tracking"] = time.perf_counter() - t0
        return AVSceneResult(
            res,
            np.zeros(len(res), bool),
            [],
            None,
            sc.n_frames,
            sc.fps,
            sc.image_size,
            fov,
            timing,
        )
    if mapping is None:
        raise ValueError("track_scene: use_audio needs an audio-to-image mapping")
    features = _scene_features(sc, mapping, features, feature_config, timing)
    t0 = time.perf_counter()
    tracker = VAVITracker(mapping, config, sc.image_size, fov, record_precisions)
    frames = tracker._frame_observations(dets, app, sc.n_frames)
    rows: list[AVFrameTracks] = []
    for t, obs in enumerate(frames):
        bands, g = features.frame(t)
        rows.append(tracker._step_av(obs, bands, g))
    timing["tracking"] = time.perf_counter() - t0
    tracks, speaking, prec = _stack_rows(rows, record_precisions)
    speech = speaking_segments(
        tracks.frames,
        tracks.ids,
        speaking,
        sc.fps,
        max_gap=diarization_gap,
        min_duration=diarization_min,
    )
    if unseen_speakers:  # speech no tracked person claims: people never seen
        claimed = np.zeros(len(features), bool)  # len(features) >= n_frames, checked above
        claimed[tracks.frames[speaking] - 1] = True
        unseen = diarize_unseen(features, mapping, sc.fps, claimed)
        speech = sorted(speech + unseen, key=lambda s: (s.start, s.speaker))
    return AVSceneResult(
        tracks, speaking, speech, prec, sc.n_frames, sc.fps, sc.image_size, fov, timing
    )


def _scene_features(
    sc: SceneInputs, mapping: AudioImageMapping, features: AudioFeatures | None,
    feature_config: AudioFeatureConfig | None, timing: dict[str, float],
) -> AudioFeatures:
    """The scene's audio observations (extracted from its audio unless given), checked
    against the mapping; the extraction's time goes to ``timing["features"]``."""
    fcfg = feature_config or AudioFeatureConfig(fps=sc.fps)
    if features is None:
        expected = mapping.meta.get("n_mics")
        if expected is not None and int(expected) != sc.audio.shape[0]:
            raise InputError(
                f"audio has {sc.audio.shape[0]} channels, the mapping was trained for "
                f"{expected} microphones",
                sc.path / "audio.wav",
            )
        if sc.fs != fcfg.stft.fs:
            raise InputError(
                f"sample rate {sc.fs} Hz, expected {fcfg.stft.fs} Hz", sc.path / "audio.wav"
            )
        t0 = time.perf_counter()
        features = extract_audio_features(sc.audio, sc.fs, sc.n_frames, fcfg)
        timing["features"] = time.perf_counter() - t0
    if len(features) < sc.n_frames:
        raise ValueError(f"features cover {len(features)} frames, the scene has {sc.n_frames}")
    if features.feature_dim != mapping.feature_dim or features.n_bands != mapping.n_bands:
        raise InputError(
            f"audio features (K={features.n_bands}, D={features.feature_dim}) do not match the "
            f"mapping (K={mapping.n_bands}, D={mapping.feature_dim}); was it trained for "
            f"another microphone array?",
            sc.path / "audio.wav",
        )
    return features


def _stack_rows(
    rows: list[AVFrameTracks], record_precisions: bool
) -> tuple[MOTData, np.ndarray, np.ndarray | None]:
    """The per-frame outputs as one table: tracks, speaking flags ``(N,)`` and (with
    ``record_precisions``) the precision terms ``(N, 3, 2, 2)``."""
    counts = [len(r.ids) for r in rows]
    if not (rows and sum(counts)):
        empty = MOTData(np.zeros(0), np.zeros(0), np.zeros((0, 4)), np.zeros(0))
        return empty, np.zeros(0, bool), np.zeros((0, 3, 2, 2)) if record_precisions else None
    frame_no = np.repeat(np.arange(1, len(rows) + 1), counts)

    def cat(name: str) -> np.ndarray:
        return np.concatenate([getattr(r, name) for r in rows])

    tracks = MOTData(frame_no, cat("ids"), np.vstack([r.boxes for r in rows]), cat("p_visible"))
    prec = np.concatenate([r.precisions for r in rows]) if record_precisions else None
    return tracks, cat("speaking"), prec


def with_visual(config: VAVITConfig, **visual) -> VAVITConfig:
    """``config`` with some visual (OVBT) parameters replaced."""
    return replace(config, visual=replace(config.visual, **visual))
