r"""Audio observation model of VAVIT: GLLiM-mapped sub-band features (thesis §4.3.4, §4.5).

Observations at frame ``t`` are the active sub-band features :math:`g_{tk} \in \mathbb{R}^D`,
:math:`k \in \mathcal{K}_t` (:mod:`avtrack.av.features`). Each is assigned jointly to a person
``n`` (or to nobody, ``n = 0``) and to an affine component ``r`` of the sub-band's GLLiM
(:class:`~avtrack.av.gllim.AudioImageMapping`):

.. math::
    p(g_{tk} | x_{tn}, B_{tk}=n, C_{tk}=r) = \mathcal{N}(g_{tk}; L_{kr}x_{tn} + l_{kr},
        \Sigma_{kr})\ (n \ge 1),\qquad \mathcal{U}(g_{tk}; \mathrm{vol}(\mathcal{G}))\ (n = 0)
        \quad\text{(eq. 4.15)}

with :math:`x_{tn} = P_g s_{tn}`, :math:`P_g = [I_2\ 0]` (the head centre).

**E-Z step** (eqs. 4.29–4.30): :math:`\beta_{tknr} \propto \kappa_{tknr}\rho_{kn}` with

.. math::
    \log\kappa_{tknr} = \log\mathcal{N}(g_{tk}; L_{kr}P_g\mu_{tn} + l_{kr}, \Sigma_{kr})
        - \tfrac12\mathrm{tr}(P_g^\top L_{kr}^\top\Sigma_{kr}^{-1}L_{kr}P_g\Gamma_{tn})
        + \log p(C_{tk}=r | \tilde x_{tn})

where :math:`p(C=r|\tilde x)` is eq. 4.16 at the "naive" prediction
:math:`\tilde x_{tn} = x_{t-1,n} + y_{t-1,n}` (thesis §4.5). Two readings of the printed
equations: eq. 4.29 multiplies by :math:`\pi_r` and eq. 4.30 by
:math:`\mathcal{N}(\tilde x_{tn};\nu_r,\Omega_r)`, which is eq. 4.16 without its denominator
:math:`\sum_i\pi_i\mathcal{N}(\tilde x_{tn};\nu_i,\Omega_i)`; that denominator depends on the
person, so we keep it (the probability of eq. 4.16 itself): otherwise a person standing where
the calibration set was sparse could hardly claim any audio. The assignment prior
:math:`\rho_{kn} = 1/(N+1)` is uniform (thesis §4.3.2) unless ``learn_prior``. With
``marginal=True`` (the engine's first E-Z step of a frame, on the prediction) the Gaussian is the
predictive marginal :math:`\mathcal{N}(g; L\mu + l, \Sigma + L\Gamma L^\top)` (cf. eq. 2.8),
computed in 2-D by the Woodbury identity. Sub-bands are not exclusive: a person emits many.

**E-S contribution** (term #2 of eqs. 4.26–4.27):
:math:`J_n = \sum_{k,r}\beta_{tknr}P_g^\top L_{kr}^\top\Sigma_{kr}^{-1}L_{kr}P_g` and
:math:`h_n = \sum_{k,r}\beta_{tknr}P_g^\top L_{kr}^\top\Sigma_{kr}^{-1}(g_{tk} - l_{kr})`.

Responsibilities are returned as ``beta (K_t, N + 1, R)``: ``beta[k, n, r]`` for persons
``n >= 1``; the clutter probability is ``beta[k, 0, 0]`` (``beta[k, 0, 1:] = 0``).

``sigma_scale`` multiplies every :math:`\Sigma_{kr}`: features at run time (speech, five STFT
frames, other talkers) are noisier than the white-noise calibration features the covariances
were learned from.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from avtrack.av.gllim import AudioImageMapping
from avtrack.vem.model import ObservationModel
from avtrack.vem.updates import symmetrize

_LOG_2PI = float(np.log(2 * np.pi))


@dataclass(frozen=True, eq=False)
class AudioObservations:
    """One frame of audio observations.

    Attributes
    ----------
    bands : ndarray (K_t,) int
        Active sub-band indices.
    g : ndarray (K_t, D)
        Their features :math:`g_{tk}`.
    x_tilde : ndarray (N, P)
        Naive position predictions :math:`\\tilde x_{tn}` of the current targets (eq. 4.30),
        ``P`` the mapping's position dimension.
    """

    bands: np.ndarray
    g: np.ndarray
    x_tilde: np.ndarray
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self) -> None:
        bands = np.asarray(self.bands, dtype=np.int64).reshape(-1)
        g = np.asarray(self.g, dtype=float)
        if g.ndim != 2 or g.shape[0] != bands.shape[0]:
            raise ValueError(
                f"AudioObservations: g must be (K_t={bands.shape[0]}, D), got {g.shape}"
            )
        x = np.asarray(self.x_tilde, dtype=float)
        if x.ndim != 2 or x.shape[1] not in (1, 2):
            raise ValueError(
                f"AudioObservations: x_tilde must be (N, P), P = 1 or 2, got {x.shape}"
            )
        if not (np.all(np.isfinite(g)) and np.all(np.isfinite(x))):
            raise ValueError("AudioObservations: g and x_tilde must be finite")
        object.__setattr__(self, "bands", bands)
        object.__setattr__(self, "g", g)
        object.__setattr__(self, "x_tilde", x)

    def __len__(self) -> int:
        return int(self.bands.shape[0])


class AudioGLLiMModel(ObservationModel):
    """Joint (person, affine component) audio assignments (thesis eqs. 4.15–4.16, 4.29–4.30).

    Parameters
    ----------
    mapping : AudioImageMapping
        One GLLiM per sub-band, position dimension 2.
    log_clutter_density : float, optional
        :math:`\\log\\mathcal{U}(g; \\mathrm{vol}(\\mathcal{G}))`; default: DP-RTFs lie in the
        unit disc, so each of the ``D / 2`` complex entries has volume π.
    sigma_scale : float
        Multiplies every :math:`\\Sigma_{kr}` (see the module docstring).
    learn_prior : bool
        Use the engine's M-step priors for :math:`\\rho_{kn}` instead of 1/(N+1).
    clutter_distance : float, optional
        Instead of ``log_clutter_density``, a clutter density per sub-band equal to the
        (π-weighted) model density of a feature at squared Mahalanobis distance
        ``clutter_distance * D`` from its prediction: features farther than that from every
        person's prediction go to the clutter class.
    marginal_clutter : bool
        The clutter density of :math:`g_{tk}` is the GLLiM's marginal
        :math:`p(g) = \\sum_r\\pi_r\\mathcal{N}(g; L_r\\nu_r + l_r, \\Sigma_r +
        L_r\\Omega_rL_r^\\top)`: "a source somewhere in the calibrated field of view" instead of
        a uniform density over the feature space. A feature then goes to a person only when
        that person's position explains it better than an unknown position does (e.g. not
        the voice of someone the tracker does not know of). Overrides the other two.
    information_scale : float
        Multiplies the audio terms of the E-S step (#2 of eqs. 4.26–4.27). Eq. 4.12 treats the
        sub-bands of a frame as independent, which is harmless for the per-sub-band
        assignments :math:`\\beta_{tknr}` but counts their shared errors (reverberation, the
        talker's head, the mapping's bias) ``K_t`` times when their information is summed.
    """

    name = "audio"

    def __init__(
        self,
        mapping: AudioImageMapping,
        log_clutter_density: float | None = None,
        sigma_scale: float = 1.0,
        learn_prior: bool = False,
        clutter_distance: float | None = None,
        marginal_clutter: bool = False,
        information_scale: float = 1.0,
    ):
        if not isinstance(mapping, AudioImageMapping):
            raise TypeError(f"mapping must be an AudioImageMapping, got {type(mapping).__name__}")
        if mapping.nu.shape[2] not in (1, 2):
            raise ValueError(
                f"mapping must map image positions (x, y) or x alone, got P={mapping.nu.shape[2]}"
            )
        #: position dimension P: 2 (x, y) as in the thesis, or 1 (x only, see the docstring)
        self.p = int(mapping.nu.shape[2])
        if not (np.isfinite(sigma_scale) and sigma_scale > 0):
            raise ValueError(f"sigma_scale must be > 0, got {sigma_scale!r}")
        d = mapping.feature_dim
        if log_clutter_density is None:
            log_clutter_density = -0.5 * d * np.log(np.pi)  # vol(G) = π^{D/2}
        if not np.isfinite(log_clutter_density):
            raise ValueError(f"log_clutter_density must be finite, got {log_clutter_density!r}")
        self.mapping = mapping
        self.log_clutter_density = float(log_clutter_density)
        self.sigma_scale = float(sigma_scale)
        self.learn_prior = bool(learn_prior)
        if not (np.isfinite(information_scale) and information_scale > 0):
            raise ValueError(f"information_scale must be > 0, got {information_scale!r}")
        self.information_scale = float(information_scale)
        sigma = mapping.sigma * self.sigma_scale
        chol = np.linalg.cholesky(sigma)
        self._logdet_sigma = 2 * np.log(np.diagonal(chol, axis1=-2, axis2=-1)).sum(-1)  # (K, R)
        eye = np.broadcast_to(np.eye(d), sigma.shape)
        inv_chol = np.linalg.solve(chol, eye)
        self._sigma_inv = symmetrize(np.swapaxes(inv_chol, -1, -2) @ inv_chol)  # Σ⁻¹
        self._lt_si = np.swapaxes(mapping.lmat, -1, -2) @ self._sigma_inv  # Lᵀ Σ⁻¹, (K,R,2,D)
        self._a = symmetrize(self._lt_si @ mapping.lmat)  # Lᵀ Σ⁻¹ L, (K, R, P, P)
        self._omega_inv = np.linalg.inv(mapping.omega)  # (K, R, P, P)
        self._logdet_omega = np.linalg.slogdet(mapping.omega)[1]  # (K, R)
        self._log_pi = np.log(mapping.pi)
        self._norm = -0.5 * (self._logdet_sigma + d * _LOG_2PI)  # log normaliser of N(g; ., Σ)
        k = mapping.n_bands
        self.marginal_clutter = bool(marginal_clutter)
        if self.marginal_clutter:  # p(g) = Σ_r π_r N(g; L ν + l, Σ + L Ω Lᵀ)
            cov_g = sigma + mapping.lmat @ mapping.omega @ np.swapaxes(mapping.lmat, -1, -2)
            chol_g = np.linalg.cholesky(cov_g)
            inv_chol_g = np.linalg.solve(chol_g, eye)
            self._marg_inv = symmetrize(np.swapaxes(inv_chol_g, -1, -2) @ inv_chol_g)
            self._marg_mean = np.einsum("krdp,krp->krd", mapping.lmat, mapping.nu) + mapping.lvec
            self._marg_norm = self._log_pi - 0.5 * (
                2 * np.log(np.diagonal(chol_g, axis1=-2, axis2=-1)).sum(-1) + d * _LOG_2PI
            )
        if clutter_distance is None:
            self._log_clutter = np.full(k, self.log_clutter_density)  # U(g; vol(G)), eq. 4.15
        else:
            if not (np.isfinite(clutter_distance) and clutter_distance > 0):
                raise ValueError(f"clutter_distance must be > 0, got {clutter_distance!r}")
            top = (self._log_pi + self._norm).max(axis=1, keepdims=True)
            log_mix = top[:, 0] + np.log(np.exp(self._log_pi + self._norm - top).sum(axis=1))
            self._log_clutter = log_mix - 0.5 * clutter_distance * d

    @property
    def n_components(self) -> int:
        return self.mapping.n_components

    def n_observations(self, obs: AudioObservations) -> int:
        return len(obs)

    def observations(
        self,
        bands: np.ndarray,
        g: np.ndarray,
        x_tilde: np.ndarray,
    ) -> AudioObservations:
        """Build a frame's observations, checking the sub-band indices and feature size."""
        obs = AudioObservations(bands, g, x_tilde)
        if len(obs) and (obs.bands.min() < 0 or obs.bands.max() >= self.mapping.n_bands):
            raise ValueError(
                f"bands must be in [0, {self.mapping.n_bands}), got {obs.bands.tolist()}"
            )
        if len(obs) and obs.g.shape[1] != self.mapping.feature_dim:
            raise ValueError(
                f"audio features have dimension {obs.g.shape[1]}, the mapping expects "
                f"{self.mapping.feature_dim} (another array or sub-band size?)"
            )
        return obs

    # ------------------------------------------------------------------ frame constants
    def _terms(self, obs: AudioObservations) -> _FrameTerms:
        """The frame's constants, computed once per (observations, model) pair."""
        terms = obs._cache.get(id(self))
        if terms is None:
            terms = obs._cache[id(self)] = _FrameTerms(self, obs)
        return terms

    def component_log_posterior(self, obs: AudioObservations) -> np.ndarray:
        r"""``(K_t, N, R)`` :math:`\log p(C_{tk}=r|\tilde x_{tn})`, eq. 4.16 at the naive
        predictions."""
        bands = obs.bands
        dev = obs.x_tilde[None, :, None, :] - self.mapping.nu[bands][:, None]  # (K_t, N, R, P)
        oi = self._omega_inv[bands]  # (K_t, R, P, P)
        maha = np.einsum("knri,krij,knrj->knr", dev, oi, dev)
        log_w = self._log_pi[bands][:, None] - 0.5 * (
            maha + self._logdet_omega[bands][:, None] + self.p * _LOG_2PI
        )  # log π_r N(x̃; ν_r, Ω_r)
        top = log_w.max(axis=2, keepdims=True)
        return log_w - top - np.log(np.exp(log_w - top).sum(axis=2, keepdims=True))  # eq. 4.16

    # ------------------------------------------------------------------ E-Z
    def log_likelihood(
        self, obs: AudioObservations, mu: np.ndarray, gamma: np.ndarray, marginal: bool = False
    ) -> tuple[np.ndarray, np.ndarray]:
        r"""``log κ (K_t, N, R)`` of eq. 4.30 (with eq. 4.16 normalised, see the module
        docstring) and the clutter log density ``(K_t,)``."""
        k_t, n = len(obs), mu.shape[0]
        clutter = (
            self._terms(obs).clutter if self.marginal_clutter else self._log_clutter[obs.bands]
        )
        if k_t == 0 or n == 0:
            return np.zeros((k_t, n, self.n_components)), clutter
        terms = self._terms(obs)
        p = self.p
        x = mu[:, :p]  # P_g μ, (N, P)
        gxx = gamma[:, :p, :p]  # P_g Γ P_gᵀ, (N, P, P)
        a = terms.a  # (K_t, R, P, P)
        ax = np.einsum("krij,nj->knri", a, x)  # Lᵀ Σ⁻¹ L x, (K_t, N, R, P)
        # (g - l - L x)ᵀ Σ⁻¹ (g - l - L x) = q - 2 cᵀ x + xᵀ A x
        maha = terms.q[:, None, :] - 2 * np.einsum("kri,ni->knr", terms.c, x)
        maha += np.einsum("knri,ni->knr", ax, x)
        if not marginal:  # eq. 4.30: N(g; L P_g μ + l, Σ) exp(-½ tr(P_gᵀ Lᵀ Σ⁻¹ L P_g Γ))
            trace = np.einsum("krij,nji->knr", a, gxx)
            log_kappa = terms.norm[:, None, :] - 0.5 * (maha + trace)
        else:  # N(g; L μ + l, Σ + L Γ Lᵀ) by Woodbury: u = Lᵀ Σ⁻¹ (g - l - L μ)
            u = terms.c[:, None] - ax  # (K_t, N, R, P)
            s = np.eye(p) + np.einsum("nij,krjl->knril", gxx, a)  # I + Γ A
            gu = np.einsum("nij,knrj->knri", gxx, u)  # Γ u
            # (Γ⁻¹ + A)⁻¹ u = (I + Γ A)⁻¹ Γ u, |Σ + L Γ Lᵀ| = |Σ| |I + Γ A|
            if p == 1:
                det = s[..., 0, 0]
                sol = gu / det[..., None]
            else:  # 2 x 2 inverse in closed form
                det = s[..., 0, 0] * s[..., 1, 1] - s[..., 0, 1] * s[..., 1, 0]
                sol = (
                    np.stack(
                        [
                            s[..., 1, 1] * gu[..., 0] - s[..., 0, 1] * gu[..., 1],
                            -s[..., 1, 0] * gu[..., 0] + s[..., 0, 0] * gu[..., 1],
                        ],
                        axis=-1,
                    )
                    / det[..., None]
                )
            maha = maha - np.sum(u * sol, axis=-1)
            log_kappa = terms.norm[:, None, :] - 0.5 * (maha + np.log(det))
        log_kappa += self.component_log_posterior(obs)  # log p(C = r | x̃_n), eq. 4.16
        return log_kappa, clutter

    def responsibilities(
        self,
        obs: AudioObservations,
        mu: np.ndarray,
        gamma: np.ndarray,
        log_prior: np.ndarray,
        marginal: bool = False,
        exclusive: bool = False,
    ) -> np.ndarray:
        r""":math:`\beta_{tknr}` (eq. 4.29) as ``(K_t, N + 1, R)``; ``exclusive`` is ignored."""
        log_kappa, clutter = self.log_likelihood(obs, mu, gamma, marginal)
        k_t, n, r = log_kappa.shape
        if not self.learn_prior:
            log_prior = np.full(n + 1, -np.log(n + 1))  # ρ_kn = 1 / (N + 1)
        log_post = np.full((k_t, n + 1, r), -np.inf)
        log_post[:, 0, 0] = clutter + log_prior[0]
        log_post[:, 1:, :] = log_kappa + np.asarray(log_prior)[1:, None]  # κ ρ (π in eq. 4.16)
        flat = log_post.reshape(k_t, (n + 1) * r)
        top = flat.max(axis=1, keepdims=True) if k_t else np.zeros((0, 1))
        post = np.exp(flat - top)
        post /= post.sum(axis=1, keepdims=True)  # eq. 4.29
        return post.reshape(k_t, n + 1, r)

    def assigned_mass(self, resp: np.ndarray) -> np.ndarray:
        """``(N + 1,)``: :math:`\\sum_k\\sum_r\\beta_{tknr}` per person, clutter first."""
        return resp.sum(axis=(0, 2))

    @staticmethod
    def person_mass(resp: np.ndarray) -> np.ndarray:
        r"""``(K_t, N)`` :math:`\sum_r \beta_{tknr}` (eq. 4.33)."""
        return resp[:, 1:, :].sum(axis=2)

    # ------------------------------------------------------------------ E-S
    def information_xy(
        self,
        obs: AudioObservations,
        resp: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Term #2 of eqs. 4.26–4.27 on the position block: ``J (N, P, P)``, ``h (N, P)``."""
        n = resp.shape[1] - 1
        if len(obs) == 0 or n == 0:
            return np.zeros((n, self.p, self.p)), np.zeros((n, self.p))
        terms = self._terms(obs)
        b = resp[:, 1:, :]  # β_tknr, (K_t, N, R)
        j = np.einsum("knr,krij->nij", b, terms.a)  # Σ β Lᵀ Σ⁻¹ L
        h = np.einsum("knr,kri->ni", b, terms.c)  # Σ β Lᵀ Σ⁻¹ (g - l)
        if self.information_scale != 1.0:  # sub-bands sharing their errors, see the docstring
            j, h = j * self.information_scale, h * self.information_scale
        return j, h

    def information(
        self, obs: AudioObservations, resp: np.ndarray, dim: int
    ) -> tuple[np.ndarray, np.ndarray]:
        j, h = self.information_xy(obs, resp)
        n = j.shape[0]
        info = np.zeros((n, dim, dim))
        info[:, : self.p, : self.p] = j  # P_gᵀ (.) P_g
        vec = np.zeros((n, dim))
        vec[:, : self.p] = h
        return info, vec


class _FrameTerms:
    """Per-frame constants: ``q (K_t, R)`` = (g-l)ᵀΣ⁻¹(g-l), ``c (K_t, R, P)`` = LᵀΣ⁻¹(g-l),
    ``a (K_t, R, P, P)`` = LᵀΣ⁻¹L, ``norm (K_t, R)`` the Gaussian log normalisers."""

    def __init__(self, model: AudioGLLiMModel, obs: AudioObservations):
        k = obs.bands
        e = obs.g[:, None, :] - model.mapping.lvec[k]  # g - l_kr, (K_t, R, D)
        si_e = np.einsum("krde,kre->krd", model._sigma_inv[k], e)  # Σ⁻¹ (g - l)
        self.q = np.einsum("krd,krd->kr", e, si_e)
        self.c = np.einsum("krid,krd->kri", model.mapping.lmat[k].swapaxes(-1, -2), si_e)
        self.a = model._a[k]
        self.norm = model._norm[k]
        if model.marginal_clutter:  # log p(g_tk), the GLLiM marginal (K_t,)
            e_m = obs.g[:, None, :] - model._marg_mean[k]
            maha = np.einsum("krd,krde,kre->kr", e_m, model._marg_inv[k], e_m)
            terms = model._marg_norm[k] - 0.5 * maha
            top = terms.max(axis=1, keepdims=True)
            self.clutter = top[:, 0] + np.log(np.exp(terms - top).sum(axis=1))
