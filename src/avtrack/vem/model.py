r"""Interface of an observation model plugged into :class:`~avtrack.vem.engine.VEMEngine`.

An observation model owns one kind of observation (boxes, audio features, DOAs ...) and its
assignment variables. Per VEM iteration the engine asks it for

1. its E-Z responsibilities given the current :math:`q(s_t)` (thesis eqs. 2.25, 4.28, 4.29),
2. its contribution to the precision and the information vector of each target
   (the "#1 / #2" terms of thesis eqs. 4.26–4.27),
3. the assignment mass per class, :math:`\sum_m \alpha_{tmn}`, used by the M-step of the
   priors (eq. 3.29), the visibility process (§3.1.4) and the birth pool.

Models may keep per-target parameters (e.g. reference appearances); the engine tells them
when targets are added or removed.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any, NamedTuple

import numpy as np

from avtrack.vem.updates import e_z_step, exclusive_projection, ones


def cached_log_clutter(
    cache: dict[int, np.ndarray], m: int, log_density: float,
) -> np.ndarray:
    """``(m,)`` read-only array of the constant clutter log density ``log_density``, made once
    per ``m`` and kept in ``cache`` (a model's own dict), so that the calls of a frame share it.
    """
    out = cache.get(m)
    if out is None:
        out = np.full(m, log_density)
        out.flags.writeable = False
        cache[m] = out
    return out


class CompiledTerms(NamedTuple):
    r"""One frame of a diagonal Gaussian observation model with a uniform clutter class, as the
    compiled VEM iterations read it (C-contiguous float64 arrays): :math:`\log\tau_{tmn}` is
    eq. 2.25 / 2.8 of ``z`` against the targets' observed means plus ``appearance``."""

    z: np.ndarray  #: (M, k) observations
    var: np.ndarray  #: (M, k) diagonals of their covariances
    inv_var: np.ndarray  #: (M, k) and of the inverses
    log_normaliser: np.ndarray  #: (M,) log normalisers of their Gaussians
    log_clutter: float  #: log density of the clutter class
    appearance: np.ndarray | None  #: (M, N) log ratios added to every target's, or None


class ObservationModel(ABC):
    """Base class of observation models. Shapes: N targets, M observations, d state dim."""

    #: Short name used in diagnostics.
    name: str = "observation"

    @abstractmethod
    def log_likelihood(
        self, obs: Any, mu: np.ndarray, gamma: np.ndarray, marginal: bool = False,
    ) -> tuple[np.ndarray, np.ndarray]:
        r"""Log-likelihoods :math:`\log\tau_{tmn}` and the clutter log density.

        Parameters
        ----------
        obs : model-specific frame observations
        mu : ndarray (N, d)
        gamma : ndarray (N, d, d)
        marginal : bool
            False: the variational form of eq. 2.25, with :math:`q(s_{tn})` entering through
            its mean and a trace penalty. True: the exact assignment likelihood under a
            Gaussian :math:`\mathcal{N}(\mu, \Gamma)` (the EM form of eq. 2.8, the
            observation density marginalised over the state); the engine uses it for the first
            E-Z step of a frame, when :math:`q(s_{tn})` is the prediction.

        Returns
        -------
        log_tau : ndarray (M, N)
        log_clutter : ndarray (M,)
        """

    @abstractmethod
    def information(
        self, obs: Any, resp: np.ndarray, dim: int,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Precision and information-vector contributions to each target's E-S step.

        Parameters
        ----------
        obs : model-specific frame observations
        resp : ndarray
            Responsibilities returned by :meth:`responsibilities`.
        dim : int
            State dimension ``d``.

        Returns
        -------
        info_matrix : ndarray (N, d, d)
        info_vector : ndarray (N, d)
        """

    @abstractmethod
    def n_observations(self, obs: Any) -> int:
        """Number ``M`` of observations in ``obs``."""

    def responsibilities(
        self, obs: Any, mu: np.ndarray, gamma: np.ndarray, log_prior: np.ndarray,
        marginal: bool = False, exclusive: bool = False,
    ) -> np.ndarray:
        """E-Z step (thesis eq. 2.25, or eq. 2.8 when ``marginal``): ``(M, N + 1)`` posteriors,
        clutter in column 0; with ``exclusive``, projected so that each target takes at most
        one observation in expectation (:func:`~avtrack.vem.updates.exclusive_projection`)."""
        log_tau, log_clutter = self.log_likelihood(obs, mu, gamma, marginal)
        alpha = e_z_step(log_tau, log_clutter, log_prior)
        return exclusive_projection(alpha) if exclusive else alpha

    def assigned_mass(self, resp: np.ndarray) -> np.ndarray:
        """``(N + 1,)`` summed responsibilities per class, clutter first."""
        return ones(resp.shape[0]).dot(resp)

    # Per-target parameter hooks (no-ops by default).
    def add_targets(self, count: int, init: Any = None) -> None:  # noqa: B027
        """Targets were appended at the end of the target list."""

    def remove_targets(self, keep: np.ndarray) -> None:  # noqa: B027
        """Targets where ``keep`` is False were removed."""

    def update_targets(self, obs: Any, resp: np.ndarray) -> None:  # noqa: B027
        """End of the frame: update per-target parameters from the final responsibilities."""


class DiagonalObservationModel(ObservationModel):
    r"""An observation model that sees the first ``observed_dim`` state components,
    :math:`P = [I_k\ 0]`, with diagonal observation covariances :math:`\Phi_{tm}`.

    When :math:`P\Gamma_{tn}P^\top` is diagonal too (constant-velocity states, see
    :func:`~avtrack.vem.updates.cv_pattern`), its E-Z and E-S quantities need only the
    observed means and variances: the engine then calls the ``*_diagonal`` methods, which give
    the same numbers as :meth:`log_likelihood` and :meth:`information` with less work.
    """

    #: Number ``k`` of observed (leading) state components.
    observed_dim: int

    @abstractmethod
    def log_likelihood_diagonal(
        self, obs: Any, mu: np.ndarray, var: np.ndarray, marginal: bool = False,
    ) -> tuple[np.ndarray, np.ndarray]:
        r""":meth:`log_likelihood` when :math:`P\Gamma_{tn}P^\top` is diagonal.

        Parameters
        ----------
        obs : model-specific frame observations
        mu : ndarray (N, k)
            Observed part :math:`P\mu_{tn}` of the means.
        var : ndarray (N, k)
            Diagonal of :math:`P\Gamma_{tn}P^\top`.
        marginal : bool
            As in :meth:`log_likelihood`.

        Returns
        -------
        log_tau : ndarray (M, N)
        log_clutter : ndarray (M,)
        """

    @abstractmethod
    def information_diagonal(self, obs: Any, resp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`information` restricted to the observed components, whose precision is
        diagonal: ``info_diag (N, k)`` and ``info_vector (N, k)``."""

    def compiled_terms(self, obs: Any, n_targets: int) -> CompiledTerms | None:
        """The frame's terms for the compiled VEM iterations
        (:mod:`avtrack.vem._cv_box_kernel`), or None (the default) when this model's
        likelihood is not the diagonal Gaussian with uniform clutter they compute."""
        return None

    def responsibilities_diagonal(
        self, obs: Any, mu: np.ndarray, var: np.ndarray, log_prior: np.ndarray,
        marginal: bool = False, exclusive: bool = False,
    ) -> np.ndarray:
        """:meth:`responsibilities` from :meth:`log_likelihood_diagonal`."""
        log_tau, log_clutter = self.log_likelihood_diagonal(obs, mu, var, marginal)
        alpha = e_z_step(log_tau, log_clutter, log_prior)  # eq. 2.25 (eq. 2.8 if marginal)
        return exclusive_projection(alpha) if exclusive else alpha
