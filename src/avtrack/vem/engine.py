r"""The generic variational-EM multi-target engine (thesis ch. 2, Algorithm 1 of ch. 4).

One engine, many observation models: each frame runs ``n_iter`` iterations of

    E-Z (every model, eq. 2.25)  →  E-S (eqs. 2.23–2.24 / 4.26–4.27)  →  M (eqs. 3.29, 2.27)

starting from the E-Z step with :math:`\mu_{tn} = D\mu_{t-1,n}` (thesis §4.6.1). Target
management (birth, visibility, death) lives in the trackers, which call :meth:`add_targets`
and :meth:`remove_targets`.
"""

from __future__ import annotations

import functools
import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from avtrack.vem import _cv_box_kernel
from avtrack.vem.model import DiagonalObservationModel, ObservationModel
from avtrack.vem.updates import (
    _MAX_ITER,
    CVNoise,
    CVStates,
    cv_covariance,
    cv_mean,
    cv_pattern,
    cv_split,
    cv_transition,
    cv_variance,
    e_s_step,
    e_s_step_cv,
    m_step_dynamics,
    m_step_priors,
    predict,
    predict_cv,
    symmetrize,
)


class _Posterior:
    """The targets' Gaussian states ``mu (N, d)`` and ``gamma (N, d, d)``: arrays, or, after
    a constant-velocity step, their :class:`CVStates` (``states``), from which the arrays are
    joined, read-only, when first read. Not changed once made: a new state is a new object."""

    __slots__ = ("_gamma", "_mu", "n_vel", "states")

    def __init__(
        self, mu: np.ndarray | None, gamma: np.ndarray | None, states: CVStates | None = None,
        n_vel: int = 0,
    ):
        self._mu, self._gamma, self.states, self.n_vel = mu, gamma, states, n_vel

    @property
    def mu(self) -> np.ndarray:
        if self._mu is None:
            if self.states is None:
                raise RuntimeError("_Posterior made without arrays or states")
            self._mu = _read_only(cv_mean(self.states, self.n_vel))
        return self._mu

    @property
    def gamma(self) -> np.ndarray:
        if self._gamma is None:
            if self.states is None:
                raise RuntimeError("_Posterior made without arrays or states")
            self._gamma = _read_only(cv_covariance(self.states, self.n_vel))
        return self._gamma

    @property
    def variances(self) -> np.ndarray:
        """The diagonal ``(N, d)`` of ``gamma``."""
        if self._gamma is None:
            if self.states is None:
                raise RuntimeError("_Posterior made without arrays or states")
            return cv_variance(self.states, self.n_vel)
        return self._gamma.diagonal(0, 1, 2)


def _read_only(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


@dataclass(frozen=True)
class FrameInference:
    """What one frame of VEM produced.

    Attributes
    ----------
    mu : ndarray (N, d)
    gamma : ndarray (N, d, d)
        The posterior states (read-only arrays after a constant-velocity step, built when
        first read).
    responsibilities : tuple of ndarray
        One per observation model, as returned by its ``responsibilities`` (``(M, N + 1)`` for
        the plain models, clutter in column 0).
    mass : tuple of ndarray (N + 1,)
        Summed responsibilities per class for each model, clutter first.
    """

    responsibilities: tuple[np.ndarray, ...]
    mass: tuple[np.ndarray, ...]
    _posterior: _Posterior = field(repr=False)

    @property
    def mu(self) -> np.ndarray:
        return self._posterior.mu

    @property
    def gamma(self) -> np.ndarray:
        return self._posterior.gamma


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
        (point-target assumption, :func:`~avtrack.vem.updates.exclusive_projection`).
    marginal_init : bool
        First E-Z step of each frame with the exact predictive assignment likelihood (thesis
        eq. 2.8) instead of the variational one (eq. 2.25); see
        :meth:`ObservationModel.log_likelihood`.

    Notes
    -----
    When ``D`` is a constant-velocity transition
    (:func:`~avtrack.vem.dynamics.constant_velocity_transition`), every model is a
    :class:`~avtrack.vem.model.DiagonalObservationModel` of its position components and
    :math:`\Gamma`, :math:`\Lambda` have the pattern of :func:`~avtrack.vem.updates.cv_pattern`
    (as they do for box trackers), :meth:`step` runs the same updates in the closed forms of
    :func:`~avtrack.vem.updates.predict_cv` and :func:`~avtrack.vem.updates.e_s_step_cv`,
    and keeps the states in that split form between frames: after such a step ``mu`` and
    ``gamma`` are read-only arrays built when first read (assign new arrays, or use
    :meth:`scale_covariances`, to change them).
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
        #: True: the compiled iterations where a model offers them (Numba is available)
        self._compiled = _cv_box_kernel.available()
        d = transition.shape[0]
        self._cv = _constant_velocity(transition, self.models, self.dynamics_mstep)
        # the models of the constant-velocity path (all of them when it applies)
        self._diagonal_models = tuple(
            m for m in self.models if isinstance(m, DiagonalObservationModel))
        if self._cv is not None:
            self._cv_off = ~cv_pattern(d, self._cv[0])  # entries a CV Γ or Λ keeps at 0
        self.ids = np.zeros(0, dtype=np.int64)
        self._post = _Posterior(np.zeros((0, d)), np.zeros((0, d, d)))

    @property
    def dim(self) -> int:
        return self.transition.shape[0]

    @property
    def n_targets(self) -> int:
        return int(self.ids.shape[0])

    @property
    def mu(self) -> np.ndarray:
        """``(N, d)`` posterior means."""
        return self._post.mu

    @mu.setter
    def mu(self, value: np.ndarray) -> None:
        self._post = _Posterior(value, self._post.gamma)

    @property
    def gamma(self) -> np.ndarray:
        """``(N, d, d)`` posterior covariances."""
        return self._post.gamma

    @gamma.setter
    def gamma(self, value: np.ndarray) -> None:
        self._post = _Posterior(self._post.mu, value)

    @property
    def variances(self) -> np.ndarray:
        """``(N, d)`` diagonal of :attr:`gamma` (without building ``gamma`` after a
        constant-velocity step)."""
        return self._post.variances

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
        if not set(ids.tolist()).isdisjoint(self.ids.tolist()):  # (np.isin: 10x slower here)
            raise ValueError(f"target ids already in use: {ids[np.isin(ids, self.ids)]}")
        self.ids = np.concatenate([self.ids, ids])
        self._post = _Posterior(np.vstack([self.mu, mu]),
                                np.concatenate([self.gamma, symmetrize(gamma)]))
        inits = model_inits if model_inits is not None else [None] * len(self.models)
        for model, init in zip(self.models, inits, strict=True):
            model.add_targets(k, init)

    def remove_targets(self, keep: np.ndarray) -> None:
        """Keep only the targets where the boolean mask ``keep (N,)`` is True."""
        keep = np.asarray(keep, dtype=bool).reshape(self.n_targets)
        self.ids = self.ids[keep]
        post = self._post
        if post.states is None:
            self._post = _Posterior(post.mu[keep], post.gamma[keep])
        else:  # (the split form stays: no need to build gamma)
            self._post = _Posterior(
                None if post._mu is None else _read_only(post._mu[keep]),
                None if post._gamma is None else _read_only(post._gamma[keep]),
                CVStates(*(a[keep] for a in post.states)), post.n_vel)
        for model in self.models:
            model.remove_targets(keep)

    def scale_covariances(self, scale: np.ndarray) -> None:
        r""":math:`\Gamma_n \leftarrow S_n\Gamma_n S_n` with :math:`S_n = \mathrm{diag}(s_n)`, for
        ``scale (N, d)`` (e.g. the cap of
        :func:`~avtrack.vem.dynamics.cap_box_covariance`)."""
        scale = np.asarray(scale, dtype=float).reshape(self.n_targets, self.dim)
        states = self._post.states
        if states is None:
            self.gamma = self.gamma * scale[:, :, None] * scale[:, None, :]  # S Γ S
            return
        if self._cv is None:  # split states only come from the constant-velocity path
            raise RuntimeError("split posterior states without a constant-velocity model")
        n_vel, k, _ = self._cv
        s_p = scale[:, :k].copy()  # (contiguous: cheaper products)
        s_v = np.zeros(s_p.shape)
        s_v[:, :n_vel] = scale[:, k:]
        self._post = _Posterior(self._post._mu, None, states._replace(  # (the means stay)
            var_p=states.var_p * s_p * s_p,  # s_p Γ_pp s_p
            var_v=states.var_v * s_v * s_v,  # s_v Γ_vv s_v
            cov=states.cov * s_p * s_v), n_vel)  # s_p Γ_pv s_v

    def step(
        self, observations: Sequence[Any], lam: np.ndarray, control: np.ndarray | None = None,
        transition: np.ndarray | None = None,
        constrain: Callable[[np.ndarray], np.ndarray] | None = None,
    ) -> FrameInference:
        r"""Run one frame of VEM and update the targets' states in place.

        Parameters
        ----------
        observations : sequence
            One frame-observation object per model.
        lam : ndarray (N, d, d) or (N, d)
            Dynamics covariance :math:`\Lambda_{tn}` for this frame, or its diagonal.
        control : ndarray (N, d), optional
            Additive control term of the prediction (ego-motion, thesis eq. 3.34).
        transition : ndarray (N, d, d), optional
            Per-target dynamics matrices :math:`D_{t-1,n}` for this frame, replacing
            :attr:`transition` (state-dependent linearised dynamics, e.g. the unit-direction
            model of thesis eq. 5.27).
        constrain : callable ``mu (N, d) -> mu (N, d)``, optional
            Applied to the posterior means after every E-S step (e.g. renormalising a unit
            direction vector, thesis §5.4.1).

        Returns
        -------
        FrameInference
        """
        if len(observations) != len(self.models):
            raise ValueError(f"expected {len(self.models)} observation sets, "
                             f"got {len(observations)}")
        n, d = self.n_targets, self.dim
        lam = np.asarray(lam, dtype=float)
        if transition is not None or constrain is not None:  # general path only
            return self._step_general(observations, lam, control, transition, constrain)
        if lam.shape == (n, d):  # diagonal Λ
            if self._cv is not None:
                states = self._cached_cv_states()
                if states is not None:
                    return self._step_cv(observations, states, self._cv_diagonal(lam), control)
            lam = lam[:, :, None] * np.eye(d)
        lam = lam.reshape(n, d, d)
        if self._cv is not None and not lam[:, self._cv_off].any():
            states = self._cached_cv_states()
            if states is not None:
                lam_states = cv_split(np.zeros((n, d)), lam, self._cv[0])
                return self._step_cv(observations, states,
                                     CVNoise(None, None, lam_states.var_p,
                                             lam_states.var_v, lam_states.cov), control)
        return self._step_general(observations, lam, control, None, None)

    def _step_general(
        self, observations: Sequence[Any], lam: np.ndarray, control: np.ndarray | None,
        transition: np.ndarray | None,
        constrain: Callable[[np.ndarray], np.ndarray] | None,
    ) -> FrameInference:
        """:meth:`step` with full covariances, optionally per-target transitions and a
        constraint on the means."""
        n, d = self.n_targets, self.dim
        if lam.shape == (n, d):  # diagonal Λ
            lam = lam[:, :, None] * np.eye(d)
        lam = lam.reshape(n, d, d)
        if transition is None:
            dgd = symmetrize(self.transition @ self.gamma @ self.transition.T)  # D Γ_{t-1} Dᵀ
            mu_pred, gamma_pred = predict(self.mu, self.gamma, self.transition, lam, control)
        else:
            tr = np.asarray(transition, dtype=float)
            if tr.shape != (n, d, d):
                raise ValueError(f"transition must have shape ({n}, {d}, {d}) (one D per "
                                 f"target), got {tr.shape}")
            dgd = symmetrize(tr @ self.gamma @ np.swapaxes(tr, 1, 2))  # D_n Γ_{t-1,n} D_nᵀ
            mu_pred = np.einsum("nij,nj->ni", tr, self.mu)  # D_n μ_{t-1,n}
            if control is not None:
                mu_pred = mu_pred + control
            gamma_pred = symmetrize(dgd + lam)  # D_n Γ D_nᵀ + Λ, eq. 2.21
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
            if constrain is not None:
                mu = constrain(mu)
            mass = [m.assigned_mass(r) for m, r in zip(self.models, resps, strict=True)]
            if self.update_priors:  # M step, eq. 3.29
                log_priors = [m_step_priors(a) for a in mass]
            if self.dynamics_mstep and n:  # M step, eq. 2.27
                lam = m_step_dynamics(mu, gamma, mu_pred, dgd, floor)
                prec_pred = symmetrize(np.linalg.inv(dgd + lam))
        return self._finish(observations, _Posterior(mu, gamma), resps, mass)

    def _cached_cv_states(self) -> CVStates | None:
        """The targets as :class:`CVStates` when the constant-velocity path applies, else None."""
        post = self._post
        if post.states is not None:
            return post.states
        if self._cv is None or post.gamma[:, self._cv_off].any():
            return None
        return cv_split(post.mu, post.gamma, self._cv[0])

    def _cv_diagonal(self, lam: np.ndarray) -> CVNoise:
        r"""A diagonal ``lam (N, d)`` as :class:`CVNoise` (``cov`` None:
        :math:`\Lambda_{pv} = 0`) with no control term."""
        if self._cv is None:
            raise RuntimeError("_cv_diagonal: the engine has no constant-velocity states")
        n_vel, k, _ = self._cv
        lam_v = np.zeros((lam.shape[0], k))
        lam_v[:, :n_vel] = lam[:, k:]
        # (copies: contiguous operands make the elementwise updates several times cheaper)
        return CVNoise(None, None, lam[:, :k].copy(), lam_v, None)

    def _step_cv(
        self, observations: Sequence[Any], states: CVStates, lam: CVNoise,
        control: np.ndarray | None,
    ) -> FrameInference:
        """:meth:`step` for constant-velocity states, in the closed forms of ``predict_cv`` and
        ``e_s_step_cv``; ``lam`` holds Λ in the covariance fields."""
        if self._cv is None:
            raise RuntimeError("_step_cv: the engine has no constant-velocity states")
        n_vel, k, dt = self._cv
        n = self.n_targets
        if control is not None:  # the control term c_tn of eq. 3.34 joins Λ in the prediction
            control = np.asarray(control, dtype=float).reshape(n, self.dim)
            c_v = np.zeros((n, k))
            c_v[:, :n_vel] = control[:, k:]
            lam = lam._replace(mu_p=control[:, :k], mu_v=c_v)
        if control is None and lam.cov is None and len(self.models) == 1:
            done = self._iterate_compiled(observations, states, lam, dt)
            if done is not None:
                return self._finish(observations, _Posterior(None, None, done[0], n_vel),
                                    done[1], done[2])
        pred = predict_cv(states, lam, dt)  # D μ + c, D Γ Dᵀ + Λ: eq. 2.21
        iterate = self._iterate_cv_one if len(self.models) == 1 else self._iterate_cv
        post, resps, mass = iterate(observations, pred)
        return self._finish(observations, _Posterior(None, None, post, n_vel), resps, mass)

    def _iterate_cv(
        self, observations: Sequence[Any], pred: CVStates,
    ) -> tuple[CVStates, list[np.ndarray], list[np.ndarray]]:
        """The VEM iterations of :meth:`_step_cv` from the prediction ``pred``: the last
        posterior, and the responsibilities and assigned masses of each model."""
        n = pred.mu_p.shape[0]
        post = pred  # E-Z initialisation, thesis §4.6.1
        pairs = list(zip(self._diagonal_models, observations, strict=True))
        log_priors = [np.full(n + 1, -math.log(n + 1))] * len(pairs)  # η = 1/(N+1)
        resps: list[np.ndarray] = []
        mass: list[np.ndarray] = []
        last, exclusive = self.n_iter - 1, self.exclusive
        for it in range(self.n_iter):
            marginal = self.marginal_init and it == 0
            resps = [  # E-Z step, eq. 2.25 (eq. 2.8 on the prediction)
                model.responsibilities_diagonal(obs, post.mu_p, post.var_p, lp, marginal,
                                                exclusive)
                for (model, obs), lp in zip(pairs, log_priors, strict=True)
            ]
            info, vec = pairs[0][0].information_diagonal(pairs[0][1], resps[0])
            for (model, obs), resp in zip(pairs[1:], resps[1:], strict=True):
                j, h = model.information_diagonal(obs, resp)
                info, vec = info + j, vec + h  # Σ over models of J_n and h_n, eq. 4.26
            # E-S step, eqs. 2.23–2.24 (before the last iteration, only what E-Z reads)
            post = e_s_step_cv(pred, info, vec, observed_only=it < last)
            mass = [model.assigned_mass(r) for (model, _), r in zip(pairs, resps, strict=True)]
            if self.update_priors and it < last:  # M step, eq. 3.29 (unused after the last)
                log_priors = [m_step_priors(a) for a in mass]
        return post, resps, mass

    def _iterate_cv_one(
        self, observations: Sequence[Any], pred: CVStates,
    ) -> tuple[CVStates, list[np.ndarray], list[np.ndarray]]:
        """:meth:`_iterate_cv` for a single observation model, without the per-model lists
        and loops (whose overhead is some 5% of an OVBT frame); the same updates."""
        (model,), (obs,) = self._diagonal_models, observations
        done = self._iterate_compiled(observations, pred, None, 1.0)
        if done is not None:
            return done
        post = pred  # E-Z initialisation, thesis §4.6.1
        log_prior = _uniform_log_prior(pred.mu_p.shape[0] + 1)  # η = 1/(N+1)
        last, exclusive, marginal = self.n_iter - 1, self.exclusive, self.marginal_init
        update = self.update_priors
        for it in range(self.n_iter):
            # E-Z step, eq. 2.25 (eq. 2.8 on the prediction)
            resp = model.responsibilities_diagonal(obs, post.mu_p, post.var_p, log_prior,
                                                   marginal and it == 0, exclusive)
            info, vec = model.information_diagonal(obs, resp)  # J_n and h_n, eq. 4.26
            # E-S step, eqs. 2.23–2.24 (before the last iteration, only what E-Z reads)
            post = e_s_step_cv(pred, info, vec, observed_only=it < last)
            mass = model.assigned_mass(resp)
            if update and it < last:  # M step, eq. 3.29 (unused after the last)
                log_prior = m_step_priors(mass)
        return post, [resp], [mass]

    def _iterate_compiled(
        self, observations: Sequence[Any], states: CVStates, lam: CVNoise | None, dt: float,
    ) -> tuple[CVStates, list[np.ndarray], list[np.ndarray]] | None:
        """:meth:`_iterate_cv_one` in one compiled call (:mod:`avtrack.vem._cv_box_kernel`),
        the same updates, the same results to rounding: from the predicted ``states``, or with
        ``lam`` (diagonal Λ, no control term), from the previous posterior ``states``
        predicted first (``predict_cv``). None where it does not apply (one model offering
        its :meth:`~avtrack.vem.model.DiagonalObservationModel.compiled_terms`, Numba)."""
        kern = _cv_box_kernel.kernel() if self._compiled else None
        n, k = states.mu_p.shape
        terms = None if kern is None else self._diagonal_models[0].compiled_terms(
            observations[0], n)
        if kern is None or terms is None or terms.z.shape[1] != k:
            return None
        m = terms.z.shape[0]
        pred = np.array(states)  # (5, N, k), a copy (predicted in place by the kernel)
        post = np.empty_like(pred)
        resp = np.empty((m, n + 1))
        mass = np.empty(n + 1)
        app = terms.appearance
        unconverged = kern(terms.z, terms.var, terms.inv_var, terms.log_normaliser,
                           terms.log_clutter, _NO_APPEARANCE if app is None else app,
                           app is not None, pred,
                           _NO_LAMBDA if lam is None else np.array((lam.var_p, lam.var_v)), dt,
                           lam is not None, post, self.n_iter, self.marginal_init,
                           self.update_priors, self.exclusive, resp, mass)
        if unconverged:  # as exclusive_projection warns (not seen in testing)
            warnings.warn(f"exclusive_projection: KKT conditions not met after {_MAX_ITER} "
                          "iterations", RuntimeWarning, stacklevel=4)
        return CVStates(*post), [resp], [mass]

    def _finish(
        self, observations: Sequence[Any], post: _Posterior, resps: list[np.ndarray],
        mass: list[np.ndarray],
    ) -> FrameInference:
        """Store the frame's posterior and let the models update their per-target parameters."""
        self._post = post
        for model, obs, resp in zip(self.models, observations, resps, strict=True):
            model.update_targets(obs, resp)
        if post.states is None:  # (writable arrays: the inference keeps its own)
            post = _Posterior(post.mu.copy(), post.gamma.copy())
        return FrameInference(tuple(resps), tuple(mass), post)


#: the compiled iterations' appearance argument when there is none (not read)
_NO_APPEARANCE = np.zeros((1, 1))
#: and its dynamics argument when it does not predict (not read)
_NO_LAMBDA = np.zeros((2, 1, 1))


@functools.lru_cache(maxsize=64)
def _uniform_log_prior(n: int) -> np.ndarray:
    """``(n,)`` read-only array of ``-log n`` (never changed in place: shared)."""
    out = np.full(n, -math.log(n))
    out.flags.writeable = False
    return out


def _constant_velocity(
    transition: np.ndarray, models: Sequence[ObservationModel], dynamics_mstep: bool,
) -> tuple[int, int, float] | None:
    """``(n_vel, k, dt)`` when ``transition`` is ``constant_velocity_transition(k, n_vel, dt)``
    and every model observes the ``k`` leading components with diagonal covariances (the
    pattern :func:`~avtrack.vem.updates.e_s_step_cv` needs); None otherwise. The M step of
    Λ (eq. 2.27) gives full matrices, so it always takes the general path."""
    diagonal = [m for m in models if isinstance(m, DiagonalObservationModel)]
    if dynamics_mstep or len(diagonal) != len(models):
        return None
    k = diagonal[0].observed_dim
    if any(m.observed_dim != k for m in diagonal):
        return None
    cv = cv_transition(transition, k)
    return None if cv is None else (cv[0], k, cv[1])
