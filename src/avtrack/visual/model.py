r"""Visual observation model: boxes plus appearance (thesis §3.1.2–3.1.3).

Observation :math:`o_{tm} = (x, y, w, h)` (box centre and size, pixels) with a diagonal
covariance :math:`\Phi_{tm}` derived from the detected box size (thesis §3.1.5), and an
optional appearance descriptor :math:`h_{tm}`. The state is ``(x, y, w, h, ẋ, ẏ)`` and the
projection ``P = [I_4 0]``.

.. math::
    p(o_{tm}|z_{tm}=n, s_t) = u(o_{tm})^{\delta_{0n}}
        \mathcal{N}(o_{tm}; P s_{tn}, \Phi_{tm})^{1-\delta_{0n}}   \quad\text{(eq. 3.4)}
"""

from __future__ import annotations

import functools
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from functools import cached_property
from itertools import pairwise

import numpy as np

from avtrack.vem.model import CompiledTerms, DiagonalObservationModel, cached_log_clutter
from avtrack.vem.updates import e_z_normalise, exclusive_projection
from avtrack.visual.appearance import AppearanceLikelihood, init_appearance_model

BOX_DIM = 4
STATE_DIM = 6
_LOG_2PI = np.log(2 * np.pi)
_MINUS_HALF = np.full(BOX_DIM, -0.5)


def ltwh_to_xywh(boxes: np.ndarray) -> np.ndarray:
    """``(K, 4)`` (left, top, width, height) -> (centre x, centre y, width, height)."""
    b = np.array(boxes, dtype=float)
    b[:, :2] += 0.5 * b[:, 2:4]  # centre = top-left + size / 2
    return b


def xywh_to_ltwh(boxes: np.ndarray) -> np.ndarray:
    """``(K, 4)`` (centre x, centre y, width, height) -> (left, top, width, height)."""
    b = np.array(boxes, dtype=float)
    b[:, :2] -= 0.5 * b[:, 2:4]  # top-left = centre - size / 2
    return b


def box_observation_variance(z: np.ndarray, pos: float = 0.1, size: float = 0.2):
    r"""Diagonal of :math:`\Phi_{tm}` from the detected box size (thesis §3.1.5).

    Standard deviations ``pos·w, pos·h, size·w, size·h`` (pixels): "the true detection lies,
    more or less, within the width and height of the detected bounding box". The thesis's
    "1/3 of the detected width" is ambiguous (variance or standard deviation); we scale the
    standard deviation with the box, which matches measured detector noise (Faster R-CNN on
    MOT15 TUD-Campus: residual std 0.11·w in x, 0.04·h in y, 0.21·w in width, 0.09·h in
    height).

    Parameters
    ----------
    z : ndarray (M, 4)
        Boxes as (x, y, w, h).

    Returns
    -------
    ndarray (M, 4)
    """
    wh = np.maximum(z[:, 2:4], 1.0)
    return np.concatenate([pos * wh, size * wh], axis=1) ** 2


@dataclass(frozen=True)
class BoxObservations:
    """One frame of box detections.

    Attributes
    ----------
    z : ndarray (M, 4)
        Box centre and size (x, y, w, h), pixels.
    var : ndarray (M, 4)
        Diagonal of each observation covariance :math:`\\Phi_{tm}`.
    appearance : ndarray (M, F) or None
        Appearance descriptors, already normalised by the appearance model.
    scores : ndarray (M,) or None
        Detection confidences (None: not given); they decide which boxes may start a target.
    """

    z: np.ndarray
    var: np.ndarray
    appearance: np.ndarray | None = None
    scores: np.ndarray | None = None

    def __post_init__(self) -> None:
        m = self.z.shape[0]
        if self.z.shape != (m, BOX_DIM) or self.var.shape != (m, BOX_DIM):
            raise ValueError(f"BoxObservations: z and var must be (M, 4), got {self.z.shape} "
                             f"and {self.var.shape}")
        if self.appearance is not None and self.appearance.shape[0] != m:
            raise ValueError(f"BoxObservations: appearance has {self.appearance.shape[0]} rows "
                             f"for {m} boxes")
        if self.scores is not None and self.scores.shape != (m,):
            raise ValueError(f"BoxObservations: scores must be ({m},), got "
                             f"{self.scores.shape}")

    def __len__(self) -> int:
        return int(self.z.shape[0])

    # Per-frame constants of the likelihood and the E-S step, computed once per frame.
    @cached_property
    def inv_var(self) -> np.ndarray:
        r"""``(M, 4)`` diagonal of :math:`\Phi_{tm}^{-1}`."""
        return 1.0 / self.var

    @cached_property
    def information_terms(self) -> np.ndarray:
        r"""``(M, 8)``: the diagonal of :math:`\Phi_{tm}^{-1}` and :math:`\Phi_{tm}^{-1}o_{tm}`,
        side by side (their α-weighted sums are the E-S terms, eqs. 2.23–2.24)."""
        return np.concatenate([self.inv_var, self.z * self.inv_var], axis=1)

    @cached_property
    def log_normaliser(self) -> np.ndarray:
        r"""``(M,)`` :math:`-\frac12\log|2\pi\Phi_{tm}|`, the log normaliser of
        :math:`\mathcal{N}(o_{tm}; \cdot, \Phi_{tm})`."""
        return -0.5 * (np.log(self.var).sum(axis=1) + BOX_DIM * _LOG_2PI)

    def subset(self, idx: np.ndarray) -> BoxObservations:
        """The rows ``idx`` (an index array or a boolean mask)."""
        idx = np.asarray(idx)
        app = None if self.appearance is None else self.appearance[idx]
        sc = None if self.scores is None else self.scores[idx]
        if idx.ndim == 1:  # rows of this validated object: no checks needed
            return _rows(self.z[idx], self.var[idx], app, sc)
        return BoxObservations(self.z[idx], self.var[idx], app, sc)

    def split(self, bounds: Sequence[int]) -> list[BoxObservations]:
        """The frames ``rows bounds[i]:bounds[i + 1]`` of a batch of consecutive frames, with
        their per-frame constants (:attr:`inv_var`, :attr:`information_terms`,
        :attr:`log_normaliser`) already set: rows of the batch's, computed once for all rows
        (they are row-wise, so each frame gets the very numbers it would compute)."""
        return list(self.iter_split(bounds))

    def iter_split(self, bounds: Sequence[int]) -> Iterator[BoxObservations]:
        """:meth:`split`, one frame at a time (memory: one frame's views, not every frame's)."""
        z, var, app, sc = self.z, self.var, self.appearance, self.scores
        inv_var, terms, log_norm = self.inv_var, self.information_terms, self.log_normaliser
        for a, b in pairwise(bounds):
            yield _rows(z[a:b], var[a:b], None if app is None else app[a:b],
                        None if sc is None else sc[a:b], inv_var=inv_var[a:b],
                        information_terms=terms[a:b], log_normaliser=log_norm[a:b])


def _rows(z: np.ndarray, var: np.ndarray, appearance: np.ndarray | None,
          scores: np.ndarray | None = None, **constants: np.ndarray) -> BoxObservations:
    """:class:`BoxObservations` of rows taken from a validated one, without the ``__init__``
    checks (a third of the cost of a frame's observations): the fields, and any per-frame
    constants, are written to the instance dict directly (where ``cached_property`` keeps
    its values)."""
    obs = object.__new__(BoxObservations)
    obs.__dict__.update(z=z, var=var, appearance=appearance, scores=scores, **constants)
    return obs


@functools.lru_cache(maxsize=1024)
def _pairs(m: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The observation and the target ``(M N,)`` of each (observation, target) pair, row-major
    (read-only, shared)."""
    rows, cols = np.repeat(np.arange(m), n), np.tile(np.arange(n), m)
    rows.flags.writeable = cols.flags.writeable = False
    return rows, cols


class BoxObservationModel(DiagonalObservationModel):
    r"""Gaussian box likelihood with a uniform clutter class and optional appearance.

    E-Z (thesis eq. 3.21 / 2.25):

    .. math::
        \tau_{tmn} = \mathcal{N}(o_{tm}; P\mu_{tn}, \Phi_{tm})
            e^{-\frac12\mathrm{tr}(P^\top\Phi_{tm}^{-1}P\Gamma_{tn})}\, b(h_{tm}; h_n),\qquad
        \tau_{tm0} = u(o_{tm})\,u(h_{tm})

    The first E-Z step of a frame, when :math:`q(s_{tn})` is still the prediction, uses the
    exact marginal :math:`\mathcal{N}(o_{tm}; P\mu_{tn}, P\Gamma_{tn}P^\top + \Phi_{tm})`
    (thesis eq. 2.8) so that a lagging track can still claim its detection; the trace form
    above ignores the state uncertainty in the distance and would hand it to clutter.

    E-S contributions (eqs. 2.23–2.24, term #1 of eq. 4.26):
    :math:`\sum_m \alpha_{tmn} P^\top\Phi_{tm}^{-1}P` and
    :math:`\sum_m \alpha_{tmn} P^\top\Phi_{tm}^{-1}o_{tm}`.

    Parameters
    ----------
    log_clutter_density : float
        :math:`\log u(o)`: minus the log volume of the box space (image area × size range).
    appearance : AppearanceLikelihood, optional
        Used when frames carry descriptors.
    appearance_update : float
        Rate ρ of the reference-appearance update after each frame,
        :math:`h_n \leftarrow (1-\rho a_n) h_n + \rho \sum_m \alpha_{tmn} h_{tm}` with
        :math:`a_n = \min(1, \sum_m\alpha_{tmn})`; 0 keeps the birth appearance (the thesis).
    """

    name = "visual"
    observed_dim = BOX_DIM
    log_clutter_density: float
    appearance: AppearanceLikelihood | None
    appearance_update: float
    references: np.ndarray | None  # (N, F)

    def __init__(
        self, log_clutter_density: float, appearance: AppearanceLikelihood | None = None,
        appearance_update: float = 0.0,
    ):
        init_appearance_model(self, log_clutter_density, appearance, appearance_update)
        self._log_clutter_cache: dict[int, np.ndarray] = {}

    def n_observations(self, obs: BoxObservations) -> int:
        return len(obs)

    def log_likelihood(self, obs: BoxObservations, mu: np.ndarray, gamma: np.ndarray,
                       marginal: bool = False):
        if not marginal:  # eq. 3.21 / 2.25 needs only the diagonal of PΓPᵀ
            var = np.diagonal(gamma, axis1=1, axis2=2)[:, :BOX_DIM]
            return self.log_likelihood_diagonal(obs, mu[:, :BOX_DIM], var, False)
        # eq. 2.8: N(o; Pμ, PΓPᵀ + Φ)
        r = obs.z[:, None, :] - mu[None, :, :BOX_DIM]  # (M, N, 4)
        s = gamma[None, :, :BOX_DIM, :BOX_DIM] + obs.var[:, None, :, None] * np.eye(BOX_DIM)
        chol = np.linalg.cholesky(s)  # (M, N, 4, 4)
        y = np.linalg.solve(chol, r[..., None])[..., 0]
        maha = np.einsum("mnk,mnk->mn", y, y)
        logdet = 2 * np.log(np.diagonal(chol, axis1=2, axis2=3)).sum(axis=2)
        log_tau = -0.5 * (maha + logdet + BOX_DIM * _LOG_2PI)
        return self._with_appearance(obs, log_tau), self._log_clutter(len(obs))

    def log_likelihood_diagonal(self, obs: BoxObservations, mu: np.ndarray, var: np.ndarray,
                                marginal: bool = False):
        log_tau = np.empty((len(obs), mu.shape[0]))
        self._log_tau_diagonal(obs, mu, var, marginal, log_tau)
        return log_tau, self._log_clutter(len(obs))

    def compiled_terms(self, obs: BoxObservations, n_targets: int) -> CompiledTerms:
        app = None
        if (self.appearance is not None and obs.appearance is not None
                and self.references is not None and len(self.references) == n_targets):
            app = np.ascontiguousarray(
                self.appearance.log_ratio(obs.appearance, self.references), dtype=float)
        c = np.ascontiguousarray
        return CompiledTerms(c(obs.z, dtype=float), c(obs.var, dtype=float),
                             c(obs.inv_var, dtype=float), c(obs.log_normaliser, dtype=float),
                             float(self.log_clutter_density), app)

    def responsibilities_diagonal(
        self, obs: BoxObservations, mu: np.ndarray, var: np.ndarray, log_prior: np.ndarray,
        marginal: bool = False, exclusive: bool = False,
    ) -> np.ndarray:
        """:meth:`DiagonalObservationModel.responsibilities_diagonal`, with the log-likelihoods
        written straight into the target columns of the E-Z array (the same numbers)."""
        log_post = np.empty((obs.z.shape[0], mu.shape[0] + 1))
        log_post[:, 0] = self.log_clutter_density  # log u(o), clutter
        self._log_tau_diagonal(obs, mu, var, marginal, log_post[:, 1:])
        alpha = e_z_normalise(log_post, log_prior)  # eq. 2.25 (eq. 2.8 if marginal)
        return exclusive_projection(alpha) if exclusive else alpha

    def _log_tau_diagonal(self, obs: BoxObservations, mu: np.ndarray, var: np.ndarray,
                          marginal: bool, out: np.ndarray) -> None:
        r""":math:`\log\tau_{tmn}` of :meth:`log_likelihood_diagonal` into ``out (M, N)``.

        Computed on the ``M N`` (observation, target) pairs, each operand gathered to that
        shape with ``take`` (several times cheaper than broadcasting on such small arrays)."""
        m, n = out.shape
        rows, cols = _pairs(m, n)
        r = obs.z.take(rows, axis=0)
        r -= mu.take(cols, axis=0)  # o - Pμ, (M N, 4)
        r *= r
        # (the sums over the 4 components are products with (-½, -½, -½, -½))
        if marginal:  # eq. 2.8: N(o; Pμ, PΓPᵀ + Φ) with PΓPᵀ + Φ = diag(s)
            s = obs.var.take(rows, axis=0)
            s += var.take(cols, axis=0)
            r /= s
            r += np.log(s)
            np.subtract(r.reshape(m, n, BOX_DIM).dot(_MINUS_HALF), 0.5 * BOX_DIM * _LOG_2PI,
                        out=out)
        else:  # eq. 3.21 / 2.25: N(o; Pμ, Φ) exp(-½ tr(Pᵀ Φ⁻¹ P Γ)), Φ and PΓPᵀ diagonal:
            # -½ Σ_k (r_k² + Γ_kk) / φ_k + log normaliser
            r += var.take(cols, axis=0)
            r *= obs.inv_var.take(rows, axis=0)
            log_tau = r.reshape(m, n, BOX_DIM).dot(_MINUS_HALF)
            log_tau += obs.log_normaliser.take(rows).reshape(m, n)
            out[...] = log_tau
        if (self.appearance is not None and obs.appearance is not None
                and self.references is not None and len(self.references) == out.shape[1]):
            out += self.appearance.log_ratio(obs.appearance, self.references)  # eq. 3.21

    def _log_clutter(self, m: int) -> np.ndarray:
        r"""``(m,)`` read-only array of :math:`\log u(o)`, shared between calls."""
        return cached_log_clutter(self._log_clutter_cache, m, self.log_clutter_density)

    def _with_appearance(self, obs: BoxObservations, log_tau: np.ndarray) -> np.ndarray:
        """``log_tau (M, N)`` times the appearance ratio b(h_m; h_n) / u(h_m), eq. 3.21."""
        if (self.appearance is not None and obs.appearance is not None
                and self.references is not None and len(self.references) == log_tau.shape[1]):
            log_tau = log_tau + self.appearance.log_ratio(obs.appearance, self.references)
        return log_tau

    def information(self, obs: BoxObservations, resp: np.ndarray, dim: int):
        j_diag, h_obs = self.information_diagonal(obs, resp)
        n = j_diag.shape[0]
        h = np.zeros((n, dim))
        h[:, :BOX_DIM] = h_obs
        info = np.zeros((n, dim, dim))
        idx = np.arange(BOX_DIM)
        info[:, idx, idx] = j_diag
        return info, h

    def information_diagonal(self, obs: BoxObservations, resp: np.ndarray):
        a = resp[:, 1:]  # (M, N): targets only, clutter plays no role (§3.1.2)
        terms = a.T.dot(obs.information_terms)  # (N, 8)
        # Σ_m α_mn Pᵀ Φ_m⁻¹ P, Σ_m α_mn Pᵀ Φ_m⁻¹ o_m, as contiguous arrays (the E-S step's
        # elementwise updates run much faster on them than on strided halves)
        return terms[:, :BOX_DIM].copy(), terms[:, BOX_DIM:].copy()

    # --- per-target reference appearances -------------------------------------------------
    def add_targets(self, count: int, init: np.ndarray | None = None) -> None:
        if init is None:
            if self.references is not None and count:
                raise ValueError("new targets need reference appearances: the tracker "
                                 "already has some")
            return
        init = np.asarray(init, dtype=float).reshape(count, -1)
        self.references = init.copy() if self.references is None else np.vstack(
            [self.references, init])

    def remove_targets(self, keep: np.ndarray) -> None:
        if self.references is not None:
            self.references = self.references[keep]

    def update_targets(self, obs: BoxObservations, resp: np.ndarray) -> None:
        if (self.appearance_update <= 0 or self.references is None or obs.appearance is None
                or self.appearance is None or len(obs) == 0):
            return
        a = resp[:, 1:]  # (M, N)
        weight = np.minimum(a.sum(axis=0), 1.0)[:, None]  # (N, 1)
        new = self.appearance_update * (a.T @ obs.appearance)
        self.references = self.appearance.normalize(
            (1 - self.appearance_update * weight) * self.references + new)
