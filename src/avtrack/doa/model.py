r"""Weighted-direction observation model of the Gaussian DOA tracker (thesis §5.4, eq. 5.22).

Every candidate direction :math:`\tilde\theta_{td}` of the localizer's grid is an observation,
described by its unit vector :math:`b_{td} = (\cos\tilde\theta_{td}, \sin\tilde\theta_{td})` and
accompanied by its weight :math:`w_{td}` (the exponentiated-gradient weight of eq. 5.19, the
probability that a speaker is active in that direction). The weight acts as a precision
(the weighted-data GMM of [54]):

.. math::
    p(b_{td} | Z_{td} = n, s_{tn}; w_{td}) =
    \begin{cases}
        \mathcal{N}(b_{td}; M s_{tn}, \Sigma / w_{td}) & n \in \{1..N\} \\
        \mathcal{U}(\mathrm{vol}(\mathcal{B}))          & n = 0
    \end{cases}                                                     \quad\text{(eq. 5.22)}

with :math:`M = [I_2\ 0]` (the state is ``(cos θ, sin θ, θ̇)``) and :math:`\Sigma = \sigma^2 I_2`
(thesis §5.5.1: :math:`\Sigma = 0.03 I_2`). A zero weight gives an infinitely broad Gaussian: the
observation carries no information and goes to clutter.

E-Z (eq. 5.40) and E-S (eqs. 5.36–5.37) terms:

.. math::
    \log\rho_{tdn} = \log\mathcal{N}(b_{td}; M\mu_{tn}, \Sigma/w_{td})
        - \tfrac12\mathrm{tr}(w_{td}M^\top\Sigma^{-1}M\Gamma_{tn}),\qquad
    J_n = \Big(\sum_d \alpha_{tdn}w_{td}\Big) M^\top\Sigma^{-1}M,\qquad
    h_n = M^\top\Sigma^{-1}\sum_d \alpha_{tdn}w_{td}b_{td}.

Shapes: ``M`` observations (candidate directions), ``N`` targets, state dimension ``d = 3``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from avtrack.vem.model import ObservationModel, cached_log_clutter

DIRECTION_DIM = 2
STATE_DIM = 3
#: Weights at or below this carry no information (their covariance Σ/w would overflow).
MIN_WEIGHT = 1e-12
_LOG_2PI = float(np.log(2 * np.pi))
_ONES2 = np.ones(2)


@dataclass(frozen=True, eq=False)
class WeightedDirections:
    """One frame of weighted candidate directions.

    Attributes
    ----------
    directions : ndarray (M, 2)
        Unit vectors :math:`b_{td} = (\\cos\\theta, \\sin\\theta)`.
    weights : ndarray (M,)
        Non-negative weights :math:`w_{td}` (precisions, eq. 5.22).
    """

    directions: np.ndarray
    weights: np.ndarray

    def __post_init__(self) -> None:
        m = np.shape(self.weights)[0] if np.ndim(self.weights) == 1 else -1
        if np.shape(self.directions) != (max(m, 0), DIRECTION_DIM) or m < 0:
            raise ValueError(
                f"WeightedDirections: directions must be (M, 2) and weights (M,), "
                f"got {np.shape(self.directions)} and {np.shape(self.weights)}"
            )

    @classmethod
    def from_azimuths(cls, azimuth_rad: np.ndarray, weights: np.ndarray) -> WeightedDirections:
        """From azimuths ``(M,)`` in radians and weights ``(M,)``.

        Raises
        ------
        ValueError
            Mismatched shapes, non-finite values or negative weights.
        """
        az = np.asarray(azimuth_rad, dtype=float).reshape(-1)
        w = np.asarray(weights, dtype=float).reshape(-1)
        if az.shape != w.shape:
            raise ValueError(
                f"weights must have the shape of the azimuths {az.shape}, got {w.shape}"
            )
        if not (np.all(np.isfinite(az)) and np.all(np.isfinite(w))):
            raise ValueError("azimuths and weights must be finite")
        if w.size and w.min() < 0:
            raise ValueError(f"weights must be >= 0, got min {w.min()}")
        return cls(np.stack([np.cos(az), np.sin(az)], axis=1), w)

    def __len__(self) -> int:
        return int(self.weights.shape[0])

    @cached_property
    def information_terms(self) -> np.ndarray:
        """``(M, 3)``: :math:`w_{td}` and :math:`w_{td} b_{td}` side by side (their
        α-weighted sums are the E-S terms of eqs. 5.36–5.37)."""
        return np.concatenate(
            [self.weights[:, None], self.weights[:, None] * self.directions], axis=1
        )

    @cached_property
    def informative(self) -> np.ndarray:
        """``(M,)`` bool: weight > :data:`MIN_WEIGHT`."""
        return self.weights > MIN_WEIGHT

    def gaussian_terms(self, obs_var: float) -> tuple[np.ndarray, np.ndarray]:
        """``(M,)`` :math:`\\log(w/(2\\pi\\sigma^2))` and :math:`w/(2\\sigma^2)` for
        :math:`\\Sigma = \\sigma^2 I_2` (cached per ``obs_var``); :math:`-\\infty` and 0 for
        uninformative observations."""
        cache = self.__dict__.setdefault("_gaussian_terms", {})
        out = cache.get(obs_var)
        if out is None:
            w = self.weights
            positive = self.informative
            log_norm = np.full(w.shape, -np.inf)
            log_norm[positive] = np.log(w[positive] / (2 * np.pi * obs_var))  # log(w/(2πσ²))
            half_prec = np.where(positive, w, 0.0) / (2 * obs_var)  # w / (2σ²)
            out = cache[obs_var] = (log_norm, half_prec)
        return out

    def subset(self, idx: np.ndarray) -> WeightedDirections:
        """The observations at ``idx``."""
        return WeightedDirections(self.directions[idx], self.weights[idx])


class WeightedDirectionModel(ObservationModel):
    r"""Weight-as-precision Gaussian likelihood of unit direction vectors (eq. 5.22).

    Parameters
    ----------
    obs_var : float
        :math:`\sigma^2` of :math:`\Sigma = \sigma^2 I_2` (thesis: 0.03).
    log_clutter_density : float
        :math:`\log\mathcal{U}(\mathrm{vol}(\mathcal{B}))`, the clutter log density of a
        direction vector.
    """

    name = "doa"

    def __init__(self, obs_var: float = 0.03, log_clutter_density: float = -_LOG_2PI):
        if not (np.isfinite(obs_var) and obs_var > 0):
            raise ValueError(f"obs_var must be a positive number, got {obs_var!r}")
        if not np.isfinite(log_clutter_density):
            raise ValueError(f"log_clutter_density must be finite, got {log_clutter_density!r}")
        self.obs_var = float(obs_var)
        self.log_clutter_density = float(log_clutter_density)
        self._clutter_cache: dict[int, np.ndarray] = {}

    def n_observations(self, obs: WeightedDirections) -> int:
        return len(obs)

    def log_likelihood(
        self, obs: WeightedDirections, mu: np.ndarray, gamma: np.ndarray, marginal: bool = False
    ) -> tuple[np.ndarray, np.ndarray]:
        r"""``log_tau (M, N)`` and ``log_clutter (M,)``.

        ``marginal=False``: eq. 5.40,
        :math:`\log\frac{w}{2\pi\sigma^2} - \frac{w}{2\sigma^2}(\|b - M\mu\|^2 +
        \mathrm{tr}\,M\Gamma M^\top)`. ``marginal=True``: the exact predictive likelihood
        :math:`\log\mathcal{N}(b; M\mu, M\Gamma M^\top + \Sigma/w)` (the EM form of eq. 2.8).
        Observations with a weight ≤ :data:`MIN_WEIGHT` get :math:`-\infty`.
        """
        m = len(obs)
        clutter = self._log_clutter(m)
        u = mu[:, :DIRECTION_DIM]
        # ‖b - Mμ‖² = 1 - 2 bᵀMμ + ‖Mμ‖² for unit vectors b, (M, N)
        r2 = (u * u).dot(_ONES2)[None, :] - 2.0 * obs.directions.dot(u.T) + 1.0
        if not marginal:
            tr = gamma[:, 0, 0] + gamma[:, 1, 1]  # tr(M Γ Mᵀ)
            log_norm, half_prec = obs.gaussian_terms(self.obs_var)
            # eq. 5.40: log N(b; Mμ, Σ/w) - ½ tr(w Σ⁻¹ M Γ Mᵀ)
            return log_norm[:, None] - half_prec[:, None] * (r2 + tr[None, :]), clutter
        # N(b; Mμ, MΓMᵀ + Σ/w): closed-form 2×2 inverse and determinant
        positive = obs.informative
        w = np.where(positive, obs.weights, 1.0)
        s = self.obs_var / w  # σ² / w
        a = gamma[None, :, 0, 0] + s[:, None]
        c = gamma[None, :, 1, 1] + s[:, None]
        b = gamma[None, :, 0, 1]
        r = obs.directions[:, None, :] - u[None, :, :]  # b - Mμ, (M, N, 2)
        det = a * c - b * b
        maha = (c * r[..., 0] ** 2 - 2 * b * r[..., 0] * r[..., 1] + a * r[..., 1] ** 2) / det
        log_tau = -0.5 * (maha + np.log(det)) - _LOG_2PI
        if not positive.all():
            log_tau[~positive] = -np.inf
        return log_tau, clutter

    def _log_clutter(self, m: int) -> np.ndarray:
        """``(m,)`` read-only array of the clutter log density, shared between calls."""
        return cached_log_clutter(self._clutter_cache, m, self.log_clutter_density)

    def information(
        self, obs: WeightedDirections, resp: np.ndarray, dim: int
    ) -> tuple[np.ndarray, np.ndarray]:
        r"""``(N, d, d)`` and ``(N, d)``: the first terms of eqs. 5.36 and 5.37."""
        a = resp[:, 1:]  # (M, N): targets only
        terms = a.T.dot(obs.information_terms) / self.obs_var  # (N, 3)
        n = terms.shape[0]
        info = np.zeros((n, dim, dim))
        info[:, 0, 0] = terms[:, 0]  # (Σ_d α w) Mᵀ Σ⁻¹ M, eq. 5.36
        info[:, 1, 1] = terms[:, 0]
        vec = np.zeros((n, dim))
        vec[:, :DIRECTION_DIM] = terms[:, 1:]  # Mᵀ Σ⁻¹ Σ_d α w b, eq. 5.37
        return info, vec

    def weighted_mass(self, obs: WeightedDirections, resp: np.ndarray) -> np.ndarray:
        r"""``(N,)`` :math:`\sum_d \alpha_{tdn} w_{td}`, the per-frame term of the speaker
        activity statistic (eq. 5.43)."""
        return obs.weights.dot(resp[:, 1:])
