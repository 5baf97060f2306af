r"""Persons tracked in the array's direction space: audio carries whoever the camera cannot see.

The image-plane model of thesis ch. 4 (:class:`~avtrack.av.vavit.VAVITracker`) keeps
each person's state on the image plane and creates persons only from visual detections
(§4.6.2): a person who leaves the image has nowhere to be, and a talker never seen never gets
a track. Here every person lives in the space that everything the microphones hear shares:
the *direction from the array*, with the camera's field of view a window inside it
(:mod:`avtrack.av.geometry`).

State and dynamics. Person :math:`n` has the Gaussian state
:math:`s_{tn} = (a, e, \dot a, \dot e) \sim \mathcal N(\mu_{tn}, \Gamma_{tn})` (azimuth and
elevation in degrees, velocities in degrees per frame) with constant-velocity dynamics
:math:`s_{tn} = D s_{t-1,n} + w`, :math:`w \sim \mathcal N(0, Q)` (thesis eq. 2.21 with the
constant-velocity :math:`D` of eq. 4.24).

Observations, per video frame.

* Vision: the visual tracker (OVBT, thesis §3.1) runs on the image plane as it does alone;
  each of its tracks, once *linked* to a person, gives that person the direction of its head
  box (:meth:`~avtrack.av.geometry.CameraGeometry.boxes_to_directions`), noise
  :math:`\sigma_v` on azimuth and elevation, with a known assignment.
* Audio: the peaks :math:`a_{tk}` of the DP-RTF + EG heat map averaged over the frame
  (thesis §5.3, :class:`~avtrack.localize.cgmm_eg.DPRTFEG`), azimuth only (noise
  :math:`\sigma_a`), each assigned to a person or to clutter (uniform over the grid's span).

VEM step (thesis eqs. 2.22–2.29 in direction space, as the audio-only Gaussian tracker of
§5.4 does on the unit circle): E-Z responsibilities of the audio peaks

.. math::

    \alpha_{tkn} \propto \pi_n\,\mathcal N(a_{tk}; \mu_{tn}^{a}, \sigma_a^2)\,
    e^{-\Gamma_{tn}^{aa} / 2\sigma_a^2},\qquad \alpha_{tk0} \propto \pi_0 / |A|,

then the E-S step in information form,
:math:`\Gamma_{tn}^{-1} = (D\Gamma_{t-1,n}D^\top + Q)^{-1} + \sum_k \alpha_{tkn} H_a^\top
\sigma_a^{-2} H_a + [\text{seen}]\,H_v^\top \sigma_v^{-2} H_v` and the matching information
vector, ``n_iter`` times.

Target management (the parts of thesis §3.1.4 and §4.6.2 this space changes).

* *Births from audio*: audio peaks left to clutter are pooled; when ``birth_min_frames`` of the
  last ``birth_window`` frames hold such a peak within ``birth_radius_deg`` of one direction, at
  least ``birth_separation_deg`` from every person, a person is born there with no box
  (the smooth-sequence idea of eq. 3.30 on directions).
* *Births from vision and identity across absences*: a new visual track is linked to a person
  not seen at this frame when its direction is within the gate of that person's prediction
  (widened by the prediction's spread) and its appearance does not contradict the person's, or,
  for a person not seen for ``reid_min_unseen`` frames, when the appearance alone is similar
  enough (``reid_min_cosine``): a person coming back into the image, or first seen after being
  heard, keeps one identity. Otherwise the visual track starts a new person.
* *Death*: a person neither seen nor heard for ``death_s`` seconds ends (``tentative_death_s``
  for a person seen or heard for less than ``established_s`` in all, e.g. a false alarm).
  A person never seen who stays in the camera's view for ``unseen_in_view_death_s`` ends too.
  While unseen, a person's velocity decays (``velocity_decay``, in mean and covariance).
* *Revival*: a person who ended less than ``revive_s`` ago is revived, identity included, by
  an audio birth near where they were last or a visual track that looks like them.
* *Merging*: two persons closer than ``merge_deg`` for ``merge_frames`` frames, neither seen,
  are one person: the older identity takes the better-localised state.
* *Negative information*: a person unseen for ``exclusion_s`` whose direction lies in the
  camera's view is moved just outside it, to the nearest edge: the camera would see them
  there. (Not in the thesis; without it a track carried by audio alone drifts through the
  view and takes the voices of the persons the camera does see.)
* *Lost in view*: a person whose direction is in the camera's view but who has not been seen
  for ``lost_frames`` frames is not where the state says; the azimuth variance grows until
  audio or a visual track finds the person again.

Speaking: the probability that at least one audio peak of the frame belongs to the person,
:math:`1 - \prod_k (1 - \alpha_{tkn})` (the direction-space counterpart of eq. 4.34);
speaking when at least ``speaking_threshold``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np
from scipy.optimize import linear_sum_assignment

from avtrack.av.geometry import DEFAULT_DISTANCE_M, CameraGeometry
from avtrack.io.doa import wrap_azimuth
from avtrack.visual.ovbt import OVBTConfig

STATE_DIM = 4  # (azimuth, elevation, azimuth velocity, elevation velocity)


@dataclass(frozen=True)
class PersonConfig:
    """Parameters of :class:`PersonTracker` (angles in degrees, times in seconds).

    Attributes
    ----------
    sigma_visual_deg : float
        :math:`\\sigma_v`, noise of a head box's direction.
    sigma_audio_deg : float
        :math:`\\sigma_a`, noise of an audio peak's azimuth.
    position_noise_deg, velocity_noise_deg : float
        Standard deviations of the process noise :math:`Q` per frame.
    init_std_deg : float
        Standard deviation of a newborn's position (elevation of an audio-born person: 20).
    clutter_weight : float
        :math:`\\pi_0 / \\pi_n`, prior weight of the clutter class relative to a person.
    n_iter : int
        E-Z / E-S iterations per frame.
    birth_window, birth_min_frames : int
        Audio birth: at least ``birth_min_frames`` of the last ``birth_window`` frames hold an
        unexplained peak near one direction.
    birth_radius_deg, birth_separation_deg : float
        Radius of that neighbourhood; minimum distance of a newborn from every person.
    link_gate_deg : float
        Gate between a new visual track's direction and a person's predicted azimuth (plus
        twice the prediction's standard deviation).
    link_min_cosine : float
        A link within the gate is refused when the appearance cosine is below this.
    reid_min_cosine : float
        Appearance cosine above which a new visual track is a person not seen for
        ``reid_min_unseen`` frames, wherever the prediction is.
    reid_min_unseen : int
    velocity_decay : float
        :math:`\\rho`: for a person not seen at the previous frame the velocity follows
        :math:`v_t = \\rho v_{t-1} + w` (mean and covariance).
    lost_frames : int
        A person whose direction is in the camera's view but who has not been seen for this
        many frames is *lost*: each further frame adds ``lost_noise_deg`` squared to the
        azimuth variance, up to ``lost_max_std_deg`` squared.
    lost_noise_deg, lost_max_std_deg : float
    exclusion_s : float
        Negative information from the camera: a person not seen for this long whose mean
        direction lies in the field of view is moved to the nearest edge of the view,
        ``exclusion_margin_deg`` outside it (the camera would see them there), and a
        velocity pointing back into the view is dropped.
    exclusion_margin_deg : float
    image_hold_s : float
        A person is given an image position (``pixels``, ``in_view``) while the camera has
        seen them within this long: as SORT reports a track only on frames a detection
        updated it, the image shows what the camera confirms. Between, the person keeps its
        direction (and is still heard, tracked and scored out of view); a hold of a few
        frames bridges single missed detections. 0 gives positions only on frames with a
        linked visual track.
    death_s, tentative_death_s, established_s : float
        See the module docstring.
    unseen_in_view_death_s : float
        A person never seen whose direction has been in the camera's view for this long is
        not there (the camera would see them): it ends.
    revive_s, revive_deg : float
        A person who ended less than ``revive_s`` ago (after being seen or heard for at least
        ``established_s``) is *revived*, identity and appearance, by an audio birth within
        ``revive_deg`` of where they were last, or by a new visual track whose appearance
        cosine with theirs is at least ``reid_min_cosine``.
    merge_deg : float
    merge_frames : int
    speaking_threshold : float
    heard_threshold : float
        A person is *heard* at a frame when its speaking probability is at least this.
    appearance_rate : float
        Weight of a new descriptor in the person's running appearance mean.
    visual : OVBTConfig
        The visual tracker whose tracks are linked to persons (by default with the cosine
        appearance model, for re-identification embeddings).
    """

    sigma_visual_deg: float = 1.5
    sigma_audio_deg: float = 5.0
    position_noise_deg: float = 0.3
    velocity_noise_deg: float = 0.1
    init_std_deg: float = 5.0
    clutter_weight: float = 0.5
    n_iter: int = 2
    birth_window: int = 12
    birth_min_frames: int = 6
    birth_radius_deg: float = 8.0
    birth_separation_deg: float = 10.0
    link_gate_deg: float = 15.0
    link_min_cosine: float = 0.3
    reid_min_cosine: float = 0.8
    reid_min_unseen: int = 10
    velocity_decay: float = 0.95
    lost_frames: int = 5
    exclusion_s: float = 1.0
    exclusion_margin_deg: float = 6.0
    image_hold_s: float = 0.1
    lost_noise_deg: float = 3.0
    lost_max_std_deg: float = 25.0
    death_s: float = 15.0
    unseen_in_view_death_s: float = 10.0
    revive_s: float = 60.0
    revive_deg: float = 15.0
    tentative_death_s: float = 1.0
    established_s: float = 0.5
    merge_deg: float = 6.0
    merge_frames: int = 10
    speaking_threshold: float = 0.5
    heard_threshold: float = 0.5
    appearance_rate: float = 0.1
    #: the visual tracker: OVBT with cosine appearance; a weak detection (lower class of the
    #: score split) shows a target as a strong one does (``weak_evidence`` 1), since the boxes
    #: here come from a detector run on the frames, where the weak class is as often a person as
    #: the strong (AV16.3 seq 30 camera 1 with YuNet faces: persons OSPA 14.2 px, 15.8 at 0.2);
    #: no rows for a birth's earlier frames (``birth_sequence``): the persons tracker reads the
    #: visual tracks frame by frame
    visual: OVBTConfig = field(default_factory=lambda: OVBTConfig(
        appearance="cosine", weak_evidence=1.0, birth_sequence=False))

    def __post_init__(self) -> None:
        if not isinstance(self.visual, OVBTConfig):
            raise ValueError(
                f"PersonConfig.visual must be an OVBTConfig, got {type(self.visual).__name__}"
            )
        for f in fields(self):
            if f.name == "visual":
                continue
            v = getattr(self, f.name)
            if isinstance(v, bool) or not isinstance(v, int | float) or not np.isfinite(v):
                raise ValueError(f"PersonConfig.{f.name} must be a finite number, got {v!r}")
        positive = (
            "sigma_visual_deg",
            "sigma_audio_deg",
            "position_noise_deg",
            "velocity_noise_deg",
            "init_std_deg",
            "clutter_weight",
            "birth_radius_deg",
            "link_gate_deg",
            "death_s",
            "tentative_death_s",
            "unseen_in_view_death_s",
            "revive_s",
            "revive_deg",
            "merge_deg",
            "lost_noise_deg",
            "lost_max_std_deg",
            "exclusion_s",
        )
        for name in positive:
            if getattr(self, name) <= 0:
                raise ValueError(f"PersonConfig.{name} must be > 0, got {getattr(self, name)!r}")
        for name in ("n_iter", "birth_window", "birth_min_frames", "merge_frames",
                     "reid_min_unseen", "lost_frames"):
            v = getattr(self, name)
            if not float(v).is_integer() or v < 1:
                raise ValueError(f"PersonConfig.{name} must be an integer >= 1, got {v!r}")
        if self.birth_min_frames > self.birth_window:
            raise ValueError("PersonConfig.birth_min_frames must be <= birth_window")
        for name in ("speaking_threshold", "heard_threshold", "velocity_decay",
                     "appearance_rate"):
            v = getattr(self, name)
            if not 0 < v <= 1:
                raise ValueError(f"PersonConfig.{name} must be in (0, 1], got {v!r}")
        for name in ("link_min_cosine", "reid_min_cosine"):
            v = getattr(self, name)
            if not -1 <= v <= 1:
                raise ValueError(f"PersonConfig.{name} must be in [-1, 1], got {v!r}")
        if self.established_s < 0 or self.birth_separation_deg < 0 or self.image_hold_s < 0:
            raise ValueError(
                "PersonConfig.established_s, birth_separation_deg and image_hold_s must be >= 0"
            )


@dataclass(frozen=True)
class PersonFrame:
    """Every tracked person at one frame.

    Attributes
    ----------
    ids : ndarray (N,) int
    azimuth_deg, elevation_deg : ndarray (N,)
        Direction from the array, azimuth in (-180, 180].
    distance_m : ndarray (N,)
        Distance estimate (from head boxes; a default for persons never seen).
    pixels : ndarray (N, 2)
        Image position of the direction; NaN outside the image.
    in_view : ndarray (N,) bool
        Inside the camera's field of view.
    speaking : ndarray (N,) float
        Speaking probability.
    seen : ndarray (N,) bool
        A linked visual track reported this frame.
    side : ndarray (N,) int
        -1: left of the camera's optical axis, +1: right.
    visual_ids : ndarray (M,) int, person_of_visual : ndarray (M,) int
        The visual tracks of this frame and the person each belongs to.
    """

    ids: np.ndarray
    azimuth_deg: np.ndarray
    elevation_deg: np.ndarray
    distance_m: np.ndarray
    pixels: np.ndarray
    in_view: np.ndarray
    speaking: np.ndarray
    seen: np.ndarray
    side: np.ndarray
    visual_ids: np.ndarray
    person_of_visual: np.ndarray


def _cosine(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cosine similarity ``(len(a), len(b))`` of descriptor rows; NaN rows give NaN."""
    na = np.linalg.norm(a, axis=1, keepdims=True)
    nb = np.linalg.norm(b, axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return (a / na) @ (b / nb).T


class PersonTracker:
    """Online tracker of persons in the array's direction space (see the module docstring).

    Parameters
    ----------
    geometry : CameraGeometry
    config : PersonConfig, optional
    fps : float
        Video frame rate (frames per second).
    fov : (float, float), optional
        Pixel columns the camera sees (default: the whole image width).
    azimuth_span_deg : float
        Width of the audio clutter's uniform density (the localizer grid's span).

    Example
    -------
    >>> tracker = PersonTracker(geometry, fps=25)
    >>> for vis_ids, vis_boxes, vis_app, peak_az in frames:
    ...     out = tracker.step(vis_ids, vis_boxes, vis_app, peak_az)
    """

    def __init__(
        self,
        geometry: CameraGeometry,
        config: PersonConfig | None = None,
        fps: float = 25.0,
        fov: tuple[float, float] | None = None,
        azimuth_span_deg: float = 360.0,
    ):
        if not isinstance(geometry, CameraGeometry):
            raise TypeError("PersonTracker: geometry must be a CameraGeometry")
        if not (np.isfinite(fps) and fps > 0):
            raise ValueError(f"PersonTracker: fps must be > 0, got {fps!r}")
        if not (0 < azimuth_span_deg <= 360):
            raise ValueError(
                f"PersonTracker: azimuth_span_deg must be in (0, 360], got {azimuth_span_deg!r}"
            )
        self.geometry = geometry
        self.config = config or PersonConfig()
        self.fps = float(fps)
        w = geometry.image_size[0]
        lo, hi = (0.0, float(w)) if fov is None else (float(fov[0]), float(fov[1]))
        if not 0 <= lo < hi <= w:
            raise ValueError(f"PersonTracker: fov must be (lo, hi) within [0, {w}], got {fov!r}")
        self.fov = (lo, hi)
        left, right = geometry.view_azimuths(DEFAULT_DISTANCE_M, self.fov)
        self.view_az = (min(left, right), max(left, right))  # azimuths the camera sees
        self.log_clutter = np.log(self.config.clutter_weight / azimuth_span_deg)
        d = np.eye(STATE_DIM)
        d[0, 2] = d[1, 3] = 1.0  # constant velocity, eq. 4.24
        self.transition = d
        c = self.config
        self.process_cov = np.diag(
            [c.position_noise_deg**2] * 2 + [c.velocity_noise_deg**2] * 2
        )
        self.reset()

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        """Forget every person."""
        self.frame = 0
        self.next_id = 1
        self.ids = np.zeros(0, dtype=np.int64)
        self.mu = np.zeros((0, STATE_DIM))
        self.gamma = np.zeros((0, STATE_DIM, STATE_DIM))
        self.distance = np.zeros(0)
        self.appearance: np.ndarray | None = None  # (N, F), NaN rows: unknown
        self.quiet_run = np.zeros(0, dtype=np.int64)  # frames neither seen nor heard
        self.unseen_run = np.zeros(0, dtype=np.int64)
        self.evidence = np.zeros(0, dtype=np.int64)  # frames seen or heard, in all
        self.ever_seen = np.zeros(0, dtype=bool)
        self.in_view_run = np.zeros(0, dtype=np.int64)  # consecutive frames in view
        self.close_run: dict[tuple[int, int], int] = {}
        self.link: dict[int, int] = {}  # visual track id -> person id
        self.pool: list[np.ndarray] = []  # unexplained audio azimuths of recent frames
        # ended persons that may be revived: id -> (frame ended, azimuth, appearance or None)
        self.ended: dict[int, tuple[int, float, np.ndarray | None]] = {}

    @property
    def n_persons(self) -> int:
        return int(self.ids.shape[0])

    def _add(
        self, az: float, el: float, dist: float, el_std: float, app: np.ndarray | None,
        seen: bool = False,
        pid: int | None = None,
    ) -> int:
        c = self.config
        if pid is None:
            pid = self.next_id
            self.next_id += 1
        self.ids = np.r_[self.ids, pid]
        self.mu = np.vstack([self.mu, [[az, el, 0.0, 0.0]]])
        g = np.diag([c.init_std_deg**2, el_std**2, 1.0, 1.0])
        self.gamma = np.concatenate([self.gamma, g[None]])
        self.distance = np.r_[self.distance, dist]
        self.quiet_run = np.r_[self.quiet_run, 0]
        self.unseen_run = np.r_[self.unseen_run, 0]
        self.evidence = np.r_[self.evidence, 1]
        self.ever_seen = np.r_[self.ever_seen, app is not None or seen]
        self.in_view_run = np.r_[self.in_view_run, 0]
        if app is not None:
            row = np.asarray(app, dtype=float)[None]
            if self.appearance is None:
                self.appearance = np.full((self.n_persons - 1, row.shape[1]), np.nan)
            self.appearance = np.vstack([self.appearance, row])
        elif self.appearance is not None:
            self.appearance = np.vstack(
                [self.appearance, np.full((1, self.appearance.shape[1]), np.nan)]
            )
        return pid

    def _keep(self, keep: np.ndarray, died: bool = False) -> None:
        gone = set(self.ids[~keep].tolist())
        if died:  # established persons may be revived (see PersonConfig.revive_s)
            c = self.config
            for i in np.flatnonzero(~keep & (self.evidence >= c.established_s * self.fps)):
                app = None
                if self.appearance is not None and np.all(np.isfinite(self.appearance[i])):
                    app = self.appearance[i].copy()
                self.ended[int(self.ids[i])] = (self.frame, float(self.mu[i, 0]), app)
        self.ids, self.mu, self.gamma = self.ids[keep], self.mu[keep], self.gamma[keep]
        self.distance = self.distance[keep]
        self.quiet_run, self.unseen_run = self.quiet_run[keep], self.unseen_run[keep]
        self.evidence = self.evidence[keep]
        self.ever_seen, self.in_view_run = self.ever_seen[keep], self.in_view_run[keep]
        if self.appearance is not None:
            self.appearance = self.appearance[keep]
        if gone:
            self.link = {v: p for v, p in self.link.items() if p not in gone}
            self.close_run = {
                k: r for k, r in self.close_run.items() if k[0] not in gone and k[1] not in gone
            }

    # ------------------------------------------------------------------ one frame
    def step(
        self,
        visual_ids: np.ndarray,
        visual_boxes: np.ndarray,
        visual_appearance: np.ndarray | None,
        audio_azimuth_deg: np.ndarray,
    ) -> PersonFrame:
        """Process one video frame.

        Parameters
        ----------
        visual_ids : ndarray (M,) int
            Ids of the visual tracks reported at this frame.
        visual_boxes : ndarray (M, 4)
            Their head boxes (left, top, width, height), pixels.
        visual_appearance : ndarray (M, F) or None
            Their appearance descriptors (NaN rows: unknown).
        audio_azimuth_deg : ndarray (K,)
            Azimuths of the audio peaks of this frame (degrees, array frame).
        """
        vids = np.asarray(visual_ids, dtype=np.int64).reshape(-1)
        boxes = np.asarray(visual_boxes, dtype=float).reshape(-1, 4)
        if boxes.shape[0] != vids.shape[0]:
            raise ValueError(
                f"visual_boxes must have one row per visual id ({vids.shape[0]}), got "
                f"{boxes.shape[0]}"
            )
        app = None
        if visual_appearance is not None and vids.size:
            app = np.asarray(visual_appearance, dtype=float).reshape(vids.shape[0], -1)
        audio = np.asarray(audio_azimuth_deg, dtype=float).reshape(-1)
        if not np.all(np.isfinite(audio)):
            raise ValueError("audio_azimuth_deg must be finite")
        self.frame += 1
        self._predict()
        person_of_visual, vis_rows, vis_obs, seen_centre = self._visual_update(
            vids, boxes, app)
        seen = np.zeros(self.n_persons, dtype=bool)
        seen[vis_rows] = True

        # --- VEM iterations: E-Z (audio) and E-S in information form ----------------------
        speaking = np.zeros(self.n_persons)
        unexplained = audio
        if self.n_persons:
            speaking, unexplained = self._vem(seen, vis_rows, vis_obs, audio)
        speaking, seen = self._bookkeeping(speaking, seen)

        # --- births from audio --------------------------------------------------------------
        born = self._audio_birth(unexplained)
        if born:
            speaking = np.r_[speaking, np.zeros(born)]
            seen = np.r_[seen, np.zeros(born, dtype=bool)]
        return self._output(speaking, seen, seen_centre, vids, person_of_visual)

    def _predict(self) -> None:
        """Prediction (eq. 2.21): ``mu <- D mu``, ``Gamma <- D Gamma D^T + Q``."""
        c = self.config
        d = self.transition
        if not self.n_persons:
            return
        # persons not seen at the last frame: velocity as AR(1), v <- ρ v + w (mean and
        # covariance), so that a track carried by audio alone does not wander off
        dn = np.broadcast_to(d, (self.n_persons, STATE_DIM, STATE_DIM)).copy()
        unseen = self.unseen_run > 0
        dn[unseen, 2, 2] = dn[unseen, 3, 3] = c.velocity_decay
        self.mu = np.einsum("nij,nj->ni", dn, self.mu)
        self.gamma = dn @ self.gamma @ np.transpose(dn, (0, 2, 1)) + self.process_cov
        # in view but not seen for a while: the camera says the person is not where the
        # state says, so the azimuth spreads until audio or vision finds them again
        lost = self._in_view_now() & (self.unseen_run >= c.lost_frames)
        if np.any(lost):
            g = self.gamma[lost, 0, 0]  # add at most up to the cap (stays PSD)
            self.gamma[lost, 0, 0] = g + np.clip(
                c.lost_max_std_deg**2 - g, 0.0, c.lost_noise_deg**2
            )

    def _visual_update(
        self, vids: np.ndarray, boxes: np.ndarray, app: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[int, np.ndarray]]:
        """Visual tracks -> persons: link (or start) the person of each visual track, update
        the seen persons' distance and appearance from their boxes. Returns the person id of
        each visual track ``(M,)``, the rows of the seen persons ``(S,)``, their direction
        observations ``(S, 2)`` and their box centres by person id."""
        c = self.config
        v_az, v_el, v_dist = self.geometry.boxes_to_directions(boxes)
        person_of_visual = np.array([self.link.get(int(v), -1) for v in vids], dtype=np.int64)
        new = np.flatnonzero(person_of_visual < 0)
        if new.size:
            person_of_visual[new] = self._link_new(new, vids, person_of_visual, v_az, v_el,
                                                   v_dist, app)
        row_of = {int(p): i for i, p in enumerate(self.ids)}
        seen_rows = np.array([row_of[int(p)] for p in person_of_visual], dtype=np.int64)
        # a person with two visual tracks this frame: use the first
        _, first = np.unique(seen_rows, return_index=True)
        vis_rows, vis_obs = seen_rows[first], np.column_stack([v_az, v_el])[first]
        # box centre of each seen person (by id: rows move with deaths, merges and births)
        seen_centre = dict(zip(self.ids[vis_rows].tolist(),
                               boxes[first, :2] + 0.5 * boxes[first, 2:], strict=True))
        if vis_rows.size:  # distance and appearance from the boxes
            self.distance[vis_rows] = 0.8 * self.distance[vis_rows] + 0.2 * v_dist[first]
            if app is not None and self.appearance is not None:
                a_new = app[first]
                ok = np.all(np.isfinite(a_new), axis=1)
                rows = vis_rows[ok]
                old = self.appearance[rows]
                fresh = ~np.all(np.isfinite(old), axis=1)
                r = c.appearance_rate
                self.appearance[rows] = np.where(
                    fresh[:, None], a_new[ok], (1 - r) * old + r * a_new[ok]
                )
        return person_of_visual, vis_rows, vis_obs, seen_centre

    def _bookkeeping(
        self, speaking: np.ndarray, seen: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Runs of silence and of not being seen, exclusion from the view, deaths and merges;
        returns ``speaking`` and ``seen`` for the persons left."""
        c = self.config
        heard = speaking >= c.heard_threshold
        self.quiet_run = np.where(seen | heard, 0, self.quiet_run + 1)
        self.unseen_run = np.where(seen, 0, self.unseen_run + 1)
        self.evidence = self.evidence + (seen | heard)
        limit = np.where(
            self.evidence >= c.established_s * self.fps, c.death_s, c.tentative_death_s
        ) * self.fps
        self.ever_seen |= seen
        self._exclude(seen)
        self.in_view_run = np.where(self._in_view_now(), self.in_view_run + 1, 0)
        keep = (self.quiet_run < limit) & (
            self.ever_seen | (self.in_view_run < c.unseen_in_view_death_s * self.fps)
        )
        if not np.all(keep):
            speaking, seen = speaking[keep], seen[keep]
            self._keep(keep, died=True)
        horizon = self.frame - c.revive_s * self.fps
        self.ended = {k: v for k, v in self.ended.items() if v[0] >= horizon}
        return self._merge(speaking, seen)

    def _output(
        self, speaking: np.ndarray, seen: np.ndarray, seen_centre: dict[int, np.ndarray],
        vids: np.ndarray, person_of_visual: np.ndarray,
    ) -> PersonFrame:
        """The frame's :class:`PersonFrame` (wraps the azimuths, clips the elevations)."""
        c = self.config
        # --- output -------------------------------------------------------------------------
        az = wrap_azimuth(self.mu[:, 0])
        self.mu[:, 0] = az
        # elevation is a latitude: the linear-Gaussian update can carry it past a pole
        self.mu[:, 1] = np.clip(self.mu[:, 1], -90.0, 90.0)
        el = self.mu[:, 1]
        px, inside = self.geometry.directions_to_pixels(az, el, self.distance)
        # The image shows a person while the camera confirms them: seen within image_hold_s
        # (SORT's output rule, with a hold of a few frames). Where the camera looks and has
        # not seen a person, the person is not: the exclusion above moves them out of an
        # azimuth wedge, which only describes the view of a camera at the array; a camera
        # metres away (AV16.3) needs this too, or tracks carried by audio and fragments of
        # visual tracks stand in the image beside the persons the camera does see.
        inside &= self.unseen_run <= min(c.image_hold_s, c.exclusion_s) * self.fps
        # A person the camera sees this frame is where its visual track's box is: the
        # direction state, smoothed and sent back through a distance estimate, is a worse
        # image position than the measurement it came from (AV16.3's camera, metres from the
        # array: 14.0 px OSPA on sequence 30 camera 1 with the box, 16.9 without).
        for row, pid in enumerate(self.ids.tolist()):
            if pid in seen_centre and self.unseen_run[row] == 0:
                px[row] = seen_centre[pid]
                inside[row] = True
        px = np.where(inside[:, None], px, np.nan)
        in_view = inside & (px[:, 0] >= self.fov[0]) & (px[:, 0] <= self.fov[1])
        alive = set(self.ids.tolist())
        pov = np.array([p if p in alive else -1 for p in person_of_visual.tolist()],
                       dtype=np.int64)
        side = self.geometry.image_side(az, el, self.distance)
        return PersonFrame(
            self.ids.copy(), az, el.copy(), self.distance.copy(), px, in_view,
            np.clip(speaking, 0.0, 1.0), seen, side, vids, pov,
        )

    def _exclude(self, seen: np.ndarray) -> None:
        """Move persons unseen for ``exclusion_s`` out of the camera's view (the nearest
        edge): where the camera looks and sees nobody, nobody is."""
        c = self.config
        lo, hi = self.view_az
        if not self.n_persons or hi - lo >= 359.0:
            return
        rows = np.flatnonzero(
            ~seen & (self.unseen_run >= c.exclusion_s * self.fps) & self._in_view_now()
        )
        for i in rows:
            a = float(self.mu[i, 0])
            if a - lo < hi - a:  # nearer the edge of smaller azimuth (the camera's right)
                self.mu[i, 0] = lo - c.exclusion_margin_deg
                self.mu[i, 2] = min(self.mu[i, 2], 0.0)
            else:
                self.mu[i, 0] = hi + c.exclusion_margin_deg
                self.mu[i, 2] = max(self.mu[i, 2], 0.0)

    def _in_view_now(self) -> np.ndarray:
        """``(N,)`` whether each person's current mean direction is in the field of view."""
        px, inside = self.geometry.directions_to_pixels(
            self.mu[:, 0], self.mu[:, 1], self.distance
        )
        with np.errstate(invalid="ignore"):
            return inside & (px[:, 0] >= self.fov[0]) & (px[:, 0] <= self.fov[1])

    def _link_new(self, new, vids, person_of_visual, v_az, v_el, v_dist, app) -> np.ndarray:
        """Person ids of the new visual tracks ``new``: linked to a person not seen at this
        frame, or new persons."""
        c = self.config
        taken = {int(p) for p in person_of_visual if p >= 0}
        cand = np.array([i for i, p in enumerate(self.ids) if int(p) not in taken],
                        dtype=np.int64)
        out = np.full(new.size, -1, dtype=np.int64)
        if cand.size:
            dz = np.abs(wrap_azimuth(v_az[new][:, None] - self.mu[cand, 0][None, :]))
            var = c.sigma_visual_deg**2 + self.gamma[cand, 0, 0][None, :]
            ok = dz <= c.link_gate_deg + 2.0 * np.sqrt(var)
            cost = dz**2 / var + np.log(var)  # -2 log N(a_v; μ^a, σ_v² + Γ^aa) + const
            if app is not None and self.appearance is not None:
                cos = _cosine(app[new], self.appearance[cand])
                known = np.isfinite(cos)
                ok &= ~known | (cos >= c.link_min_cosine)
                reid = known & (cos >= c.reid_min_cosine) & (
                    self.unseen_run[cand][None, :] >= c.reid_min_unseen
                )
                ok |= reid
                cost = np.where(reid, -100.0 + cost * 1e-3, cost)
            cost = np.where(ok, cost, 1e6)
            r, k = linear_sum_assignment(cost)
            for i, j in zip(r, k, strict=True):
                if ok[i, j]:
                    out[i] = self.ids[cand[j]]
        for i in np.flatnonzero(out < 0):
            m = new[i]
            pid = None
            if app is not None and np.all(np.isfinite(app[m])):
                best = c.reid_min_cosine
                for k, (_, _, a_old) in self.ended.items():
                    if a_old is None:
                        continue
                    cos_old = float(_cosine(app[m][None], a_old[None])[0, 0])
                    if cos_old >= best:
                        best, pid = cos_old, k
                if pid is not None:  # someone who ended lately, back in view
                    del self.ended[pid]
            out[i] = self._add(
                float(v_az[m]), float(v_el[m]), float(v_dist[m]), c.init_std_deg,
                None if app is None else app[m], seen=True, pid=pid,
            )
        for i, m in enumerate(new):
            self.link[int(vids[m])] = int(out[i])
        return out

    def _vem(self, seen, vis_rows, vis_obs, audio):
        """E-Z / E-S iterations; returns the speaking probabilities ``(N,)`` and the audio
        peaks left to clutter."""
        c = self.config
        n = self.n_persons
        pred_mu, pred_gamma = self.mu.copy(), self.gamma.copy()
        prior_info = np.linalg.inv(pred_gamma)  # (D Γ Dᵀ + Q)⁻¹, term of eq. 2.25
        prior_vec = np.einsum("nij,nj->ni", prior_info, pred_mu)
        var_a, var_v = c.sigma_audio_deg**2, c.sigma_visual_deg**2
        # vision: known assignment, H_v = [I 0]
        vis_info = np.zeros((n, STATE_DIM, STATE_DIM))
        vis_vec = np.zeros((n, STATE_DIM))
        if vis_rows.size:
            obs = vis_obs.copy()
            obs[:, 0] = pred_mu[vis_rows, 0] + wrap_azimuth(obs[:, 0] - pred_mu[vis_rows, 0])
            vis_info[vis_rows, 0, 0] = vis_info[vis_rows, 1, 1] = 1.0 / var_v
            vis_vec[vis_rows, 0] = obs[:, 0] / var_v
            vis_vec[vis_rows, 1] = obs[:, 1] / var_v
        k_t = audio.shape[0]
        alpha = np.zeros((k_t, n + 1))
        if k_t == 0:
            info = prior_info + vis_info
            self.gamma = np.linalg.inv(info)
            self.mu = np.einsum("nij,nj->ni", self.gamma, prior_vec + vis_vec)
            return np.zeros(n), audio
        mu, gamma = pred_mu, pred_gamma
        for _ in range(c.n_iter):
            # E-Z: α_kn ∝ π_n N(a_k; μ_n^a, σ_a² + Γ_n^aa); α_k0 ∝ π_0 / |A|
            diff = wrap_azimuth(audio[:, None] - mu[None, :, 0])
            var = var_a + gamma[None, :, 0, 0]
            ll = -0.5 * np.log(2 * np.pi * var) - 0.5 * diff**2 / var
            logits = np.concatenate([np.full((k_t, 1), self.log_clutter), ll], axis=1)
            logits -= logits.max(axis=1, keepdims=True)
            alpha = np.exp(logits)
            alpha /= alpha.sum(axis=1, keepdims=True)
            # E-S: Γ⁻¹ = prior + Σ_k α_kn H_aᵀ σ_a⁻² H_a + vision; information vector alike
            a_n = alpha[:, 1:]
            info = prior_info + vis_info
            info[:, 0, 0] += a_n.sum(axis=0) / var_a
            unwrapped = pred_mu[None, :, 0] + wrap_azimuth(audio[:, None] - pred_mu[None, :, 0])
            vec = prior_vec + vis_vec
            vec[:, 0] += (a_n * unwrapped).sum(axis=0) / var_a
            gamma = np.linalg.inv(info)
            mu = np.einsum("nij,nj->ni", gamma, vec)
        self.mu, self.gamma = mu, 0.5 * (gamma + np.transpose(gamma, (0, 2, 1)))
        speaking = 1.0 - np.prod(1.0 - alpha[:, 1:], axis=0)
        unexplained = audio[alpha[:, 0] >= 0.5]
        return speaking, unexplained

    def _merge(
        self, speaking: np.ndarray, seen: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Merge persons that have been closer than ``merge_deg`` for ``merge_frames`` frames
        and are not both seen: the older identity with the seen one's state."""
        c = self.config
        n = self.n_persons
        if n < 2:
            self.close_run = {}
            return speaking, seen
        dz = np.abs(wrap_azimuth(self.mu[:, 0][:, None] - self.mu[:, 0][None, :]))
        runs: dict[tuple[int, int], int] = {}
        keep = np.ones(n, dtype=bool)
        for i, j in zip(*np.nonzero(np.triu(dz < c.merge_deg, 1)), strict=True):
            if seen[i] or seen[j]:  # a seen person is where the camera says
                continue
            key = (int(self.ids[i]), int(self.ids[j]))
            runs[key] = self.close_run.get(key, 0) + 1
            if runs[key] >= c.merge_frames and keep[i] and keep[j]:
                old, young = (i, j) if self.ids[i] < self.ids[j] else (j, i)
                # the better-localised state
                src = young if self.gamma[young, 0, 0] < self.gamma[old, 0, 0] else old
                self.mu[old], self.gamma[old] = self.mu[src], self.gamma[src]
                self.distance[old] = self.distance[src]
                self.quiet_run[old] = min(self.quiet_run[old], self.quiet_run[young])
                self.unseen_run[old] = min(self.unseen_run[old], self.unseen_run[young])
                self.evidence[old] += self.evidence[young]
                speaking[old] = max(speaking[old], speaking[young])
                if self.appearance is not None and not np.all(
                    np.isfinite(self.appearance[old])
                ):
                    self.appearance[old] = self.appearance[young]
                yid, oid = int(self.ids[young]), int(self.ids[old])
                self.link = {v: (oid if p == yid else p) for v, p in self.link.items()}
                keep[young] = False
        self.close_run = runs
        if not keep.all():
            speaking, seen = speaking[keep], seen[keep]
            self._keep(keep)
        return speaking, seen

    def _audio_birth(self, unexplained: np.ndarray) -> int:
        """Births from audio peaks left to clutter (see the module docstring)."""
        c = self.config
        self.pool.append(np.asarray(unexplained, dtype=float))
        if len(self.pool) > c.birth_window:
            self.pool.pop(0)
        if unexplained.size == 0:
            return 0
        born = 0
        for a in unexplained:
            frames_near = [p[np.abs(wrap_azimuth(p - a)) <= c.birth_radius_deg] for p in self.pool]
            support = sum(1 for f in frames_near if f.size)
            if support < c.birth_min_frames:
                continue
            near = np.concatenate(frames_near)
            centre = float(a + np.median(wrap_azimuth(near - a)))
            if self.n_persons and np.min(
                np.abs(wrap_azimuth(self.mu[:, 0] - centre))
            ) < c.birth_separation_deg:
                continue
            el = float(np.median(self.mu[:, 1])) if self.n_persons else 0.0
            pid, app = None, None
            near_ended = [
                (abs(float(wrap_azimuth(v[1] - centre))), k) for k, v in self.ended.items()
            ]
            near_ended = [x for x in near_ended if x[0] <= c.revive_deg]
            if near_ended:  # someone who ended there lately speaks again
                pid = min(near_ended)[1]
                app = self.ended.pop(pid)[2]
            self._add(wrap_azimuth(centre), el, DEFAULT_DISTANCE_M, 20.0, None, pid=pid)
            if app is not None and self.appearance is not None:
                self.appearance[-1] = app
            self.evidence[-1] = support  # the frames it was heard in before its birth
            born += 1
            self.pool = [p[np.abs(wrap_azimuth(p - centre)) > c.birth_radius_deg]
                         for p in self.pool]
        return born
