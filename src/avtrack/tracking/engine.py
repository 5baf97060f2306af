r"""The generic variational-EM multi-target engine (thesis ch. 2, Algorithm 1 of ch. 4).

One engine, many observation models: each frame runs ``n_iter`` iterations of

    E-Z (every model, eq. 2.25)  →  E-S (eqs. 2.23–2.24 / 4.26–4.27)  →  M (eqs. 3.29, 2.27)

starting from the E-Z step with :math:`\mu_{tn} = D\mu_{t-1,n}` (thesis §4.6.1). Target
management (birth, visibility, death) lives in the trackers, which call :meth:`add_targets`
and :meth:`remove_targets`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from avtrack.models.base import ObservationModel
from avtrack.tracking.vem import e_s_step, m_step_dynamics, m_step_priors, predict, symmetrize


@dataclass(frozen=True)
class FrameInference:
    """What one frame of VEM produced.

    Attributes
    ----------
    mu : ndarray (N, d)
    gamma : ndarray (N, d, d)
    responsibilities : tuple of ndarray
        One per observation model, as returned by its ``responsibilities`` (``(M, N + 1)`` for
        the plain models, clutter in column 0).
    mass : tuple of ndarray (N + 1,)
        Summed responsibilities per class for each model, clutter first.
    """

    mu: np.ndarray
    gamma: np.ndarray
    responsibilities: tuple[np.ndarray, ...]
    mass: tuple[np.ndarray, ...]


class VEMEngine:
    r"""Variational-EM filtering of ``N`` Gaussian targets under several observation models.

    Parameters
    ----------
    transition : ndarray (d, d)
        Dynamics matrix ``D`` (eq. 2.6).
    models : sequence of ObservationModel
        Observation models; :meth:`step` takes one observation object per model.
    n_iter : int
        VEM iterations per frame (≥ 1).
    update_priors : bool
        Re-estimate the assignment priors :math:`a_{tn}` by eq. 3.29 after each iteration
        (otherwise uniform :math:`\eta = 1/(N+1)`, eq. 2.4).
    dynamics_mstep : bool
        Re-estimate :math:`\Lambda_{tn}` by eq. 2.27 after each iteration, starting from the
        covariance passed to :meth:`step`; it is floored at ``dynamics_floor`` times the
        smallest variance of that covariance.
    dynamics_floor : float
        See ``dynamics_mstep``.
    exclusive : bool
        Constrain every target to explain at most one observation of each model per frame
        (point-target assumption, :func:`~avtrack.tracking.vem.exclusive_projection`).
    marginal_init : bool
        First E-Z step of each frame with the exact predictive assignment likelihood (thesis
        eq. 2.8) instead of the variational one (eq. 2.25); see
        :meth:`ObservationModel.log_likelihood`.
    """

    def __init__(
        self, transition: np.ndarray, models: Sequence[ObservationModel], n_iter: int = 3,
        update_priors: bool = True, dynamics_mstep: bool = False, dynamics_floor: float = 0.1,
        marginal_init: bool = True, exclusive: bool = False,
    ):
        transition = np.asarray(transition, dtype=float)
        if transition.ndim != 2 or transition.shape[0] != transition.shape[1]:
            raise ValueError(f"transition must be square (d, d), got {transition.shape}")
        if int(n_iter) < 1:
            raise ValueError(f"n_iter must be >= 1, got {n_iter}")
        if not models:
            raise ValueError("at least one observation model is needed")
        if not dynamics_floor > 0:
            raise ValueError(f"dynamics_floor must be > 0, got {dynamics_floor}")
        self.transition = transition
        self.models = tuple(models)
        self.n_iter = int(n_iter)
        self.update_priors = bool(update_priors)
        self.dynamics_mstep = bool(dynamics_mstep)
        self.dynamics_floor = float(dynamics_floor)
        self.marginal_init = bool(marginal_init)
        self.exclusive = bool(exclusive)
        d = transition.shape[0]
        self.ids = np.zeros(0, dtype=np.int64)
        self.mu = np.zeros((0, d))
        self.gamma = np.zeros((0, d, d))

    @property
    def dim(self) -> int:
        return self.transition.shape[0]

    @property
    def n_targets(self) -> int:
        return int(self.ids.shape[0])

    def add_targets(
        self, ids: np.ndarray, mu: np.ndarray, gamma: np.ndarray,
        model_inits: Sequence[Any] | None = None,
    ) -> None:
        """Append targets ``ids`` ``(K,)`` with states ``mu (K, d)``, ``gamma (K, d, d)``.

        ``model_inits[i]`` is passed to ``models[i].add_targets`` (e.g. reference appearances).
        """
        ids = np.asarray(ids, dtype=np.int64).reshape(-1)
        k, d = ids.shape[0], self.dim
        mu = np.asarray(mu, dtype=float).reshape(k, d)
        gamma = np.asarray(gamma, dtype=float).reshape(k, d, d)
        if np.isin(ids, self.ids).any():
            raise ValueError(f"target ids already in use: {ids[np.isin(ids, self.ids)]}")
        self.ids = np.concatenate([self.ids, ids])
        self.mu = np.vstack([self.mu, mu])
        self.gamma = np.concatenate([self.gamma, symmetrize(gamma)])
        inits = model_inits if model_inits is not None else [None] * len(self.models)
        for model, init in zip(self.models, inits, strict=True):
            model.add_targets(k, init)

    def remove_targets(self, keep: np.ndarray) -> None:
        """Keep only the targets where the boolean mask ``keep (N,)`` is True."""
        keep = np.asarray(keep, dtype=bool).reshape(self.n_targets)
        self.ids, self.mu, self.gamma = self.ids[keep], self.mu[keep], self.gamma[keep]
        for model in self.models:
            model.remove_targets(keep)

    def step(
        self, observations: Sequence[Any], lam: np.ndarray, control: np.ndarray | None = None,
    ) -> FrameInference:
        r"""Run one frame of VEM and update the targets' states in place.

        Parameters
        ----------
        observations : sequence
            One frame-observation object per model.
        lam : ndarray (N, d, d)
            Dynamics covariance :math:`\Lambda_{tn}` for this frame.
        control : ndarray (N, d), optional
            Additive control term of the prediction (ego-motion, thesis eq. 3.34).

        Returns
        -------
        FrameInference
        """
        if len(observations) != len(self.models):
            raise ValueError(f"expected {len(self.models)} observation sets, "
                             f"got {len(observations)}")
        n, d = self.n_targets, self.dim
        lam = np.asarray(lam, dtype=float).reshape(n, d, d)
        dgd = symmetrize(self.transition @ self.gamma @ self.transition.T)  # D Γ_{t-1} Dᵀ
        mu_pred, gamma_pred = predict(self.mu, self.gamma, self.transition, lam, control)
        prec_pred = symmetrize(np.linalg.inv(gamma_pred))  # term #3 of eq. 4.26
        mu, gamma = mu_pred, gamma_pred  # E-Z initialisation, thesis §4.6.1
        log_priors = [np.full(n + 1, -np.log(n + 1))] * len(self.models)  # η = 1/(N+1)
        floor = self.dynamics_floor * np.diagonal(lam, axis1=1, axis2=2).min(axis=1)
        resps: list[np.ndarray] = []
        for it in range(self.n_iter):
            marginal = self.marginal_init and it == 0
            resps = [  # E-Z step, eq. 2.25 (eq. 2.8 on the prediction)
                model.responsibilities(obs, mu, gamma, lp, marginal, self.exclusive)
                for model, obs, lp in zip(self.models, observations, log_priors, strict=True)
            ]
            info = np.zeros((n, d, d))
            vec = np.zeros((n, d))
            for model, obs, resp in zip(self.models, observations, resps, strict=True):
                j, h = model.information(obs, resp, d)
                info += j
                vec += h
            mu, gamma = e_s_step(mu_pred, prec_pred, info, vec)  # E-S step, eqs. 2.23–2.24
            if self.update_priors:  # M step, eq. 3.29
                log_priors = [m_step_priors(m.assigned_mass(r))
                              for m, r in zip(self.models, resps, strict=True)]
            if self.dynamics_mstep and n:  # M step, eq. 2.27
                lam = m_step_dynamics(mu, gamma, mu_pred, dgd, floor)
                prec_pred = symmetrize(np.linalg.inv(dgd + lam))
        self.mu, self.gamma = mu, gamma
        for model, obs, resp in zip(self.models, observations, resps, strict=True):
            model.update_targets(obs, resp)
        mass = tuple(m.assigned_mass(r) for m, r in zip(self.models, resps, strict=True))
        return FrameInference(mu.copy(), gamma.copy(), tuple(resps), mass)
