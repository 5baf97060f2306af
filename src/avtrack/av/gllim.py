r"""GLLiM: a piecewise-affine map between image positions and audio features (thesis §4.3.4).

The joint density of a source position :math:`x \in \mathbb{R}^P` (``P = 2``: image
coordinates) and an audio feature :math:`g \in \mathbb{R}^D` is a mixture of ``R`` affine
experts (thesis eqs. 4.13–4.14; Deleforge, Forbes & Horaud 2015, "GLLiM" without latent
output components):

.. math::
    p(g, x) = \sum_{r=1}^R \pi_r\, \mathcal{N}(x; \nu_r, \Omega_r)\,
        \mathcal{N}(g; L_r x + l_r, \Sigma_r)                       \quad\text{(eq. 4.13)}

with :math:`L_r \in \mathbb{R}^{D\times P}`, :math:`l_r \in \mathbb{R}^D`,
:math:`\Sigma_r` ``(D, D)`` and :math:`p(C = r | x) = \pi_r\mathcal{N}(x;\nu_r,\Omega_r) /
\sum_i \pi_i\mathcal{N}(x;\nu_i,\Omega_i)` (eq. 4.16).

**Training** (:func:`fit_gllim`) is closed-form EM on a calibration set
:math:`\{(g_i, x_i)\}` (both observed, so the E step is exact): responsibilities
:math:`r_{ir} \propto \pi_r\mathcal{N}(x_i;\nu_r,\Omega_r)\mathcal{N}(g_i;L_rx_i+l_r,\Sigma_r)`,
then per component a weighted Gaussian fit of ``x`` (π, ν, Ω) and a weighted least-squares
affine regression of ``g`` on ``x`` (L, l) with the residual covariance Σ (``"full"``,
``"diag"`` or ``"iso"``). It starts from k-means on ``x`` (seeded) and stops when the
log-likelihood gains less than ``tol`` per sample.

**Forward and inverse maps.** :meth:`GLLiM.forward` is
:math:`E[g|x] = \sum_r p(r|x)(L_r x + l_r)`. The inverse posterior is again a mixture of
affine experts (Deleforge et al. 2015, eq. 7):

.. math::
    p(x | g) = \sum_r w_r(g)\, \mathcal{N}(x; \Gamma^*_r(L_r^\top\Sigma_r^{-1}(g - l_r)
        + \Omega_r^{-1}\nu_r), \Gamma^*_r),\quad
    \Gamma^*_r = (\Omega_r^{-1} + L_r^\top\Sigma_r^{-1}L_r)^{-1},

:math:`w_r(g) \propto \pi_r \mathcal{N}(g; L_r\nu_r + l_r, \Sigma_r + L_r\Omega_rL_r^\top)`
(:meth:`GLLiM.inverse`).

**Why our own EM.** The maintained ``xllim`` package (Inria, PyPI) implements the same model
and installs here (2.0.11, NumPy 2); ``tests/av/test_gllim.py`` checks that both EMs give the
same parameters from the same starting point when it is installed. We keep a NumPy
implementation because the tracker needs the parameters as arrays stacked over sub-bands (the
audio model vectorises over sub-bands, components and persons), a seeded deterministic
initialisation, covariance regularisation for the small calibration sets, and no compiled
dependency at run time.

A trained audio-to-image mapping, one GLLiM per sub-band with the same ``R``, is an
:class:`AudioImageMapping`, saved and loaded as ``.npz`` (:func:`save_mapping`,
:func:`load_mapping`).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from avtrack.errors import InputError
from avtrack.io.base import atomic_write

COVARIANCE_TYPES = ("full", "diag", "iso")
_LOG_2PI = float(np.log(2 * np.pi))


def _spd_logdet_inv(cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``cov (..., n, n)`` SPD -> ``(log|cov| (...), cov⁻¹ (..., n, n))`` via Cholesky."""
    chol = np.linalg.cholesky(cov)
    logdet = 2.0 * np.log(np.diagonal(chol, axis1=-2, axis2=-1)).sum(axis=-1)
    eye = np.broadcast_to(np.eye(cov.shape[-1]), cov.shape)
    inv_chol = np.linalg.solve(chol, eye)  # C⁻¹
    inv = np.swapaxes(inv_chol, -1, -2) @ inv_chol  # cov⁻¹ = C⁻ᵀ C⁻¹
    return logdet, 0.5 * (inv + np.swapaxes(inv, -1, -2))


def _log_gauss(r: np.ndarray, logdet: np.ndarray, inv: np.ndarray) -> np.ndarray:
    """log N(r; 0, cov) for residuals ``r (..., n)`` with ``log|cov|`` and ``cov⁻¹``."""
    if r.ndim == 3 and inv.ndim == 3:  # (M, R, n) residuals, one covariance per component
        y = np.matmul(r.transpose(1, 0, 2), inv).transpose(1, 0, 2)  # cov⁻¹ r, (M, R, n)
    else:
        y = np.einsum("...ij,...j->...i", inv, r)
    maha = np.sum(y * r, axis=-1)  # rᵀ cov⁻¹ r
    return -0.5 * (maha + logdet + r.shape[-1] * _LOG_2PI)


def _logsumexp(a: np.ndarray, axis: int) -> np.ndarray:
    m = np.max(a, axis=axis, keepdims=True)
    m = np.where(np.isfinite(m), m, 0.0)
    return np.squeeze(m, axis) + np.log(np.sum(np.exp(a - m), axis=axis))


#: The parameters of thesis eq. 4.14, in the order of the constructors and of the ``.npz`` file.
_PARAMETERS = ("pi", "nu", "omega", "lmat", "lvec", "sigma")


@dataclass(frozen=True)
class _Parameters:
    """The parameter arrays of thesis eq. 4.14, of one GLLiM (:class:`GLLiM`, leading axis
    ``R``) or of a stack of them (:class:`AudioImageMapping`, leading axes ``K, R``)."""

    pi: np.ndarray
    nu: np.ndarray
    omega: np.ndarray
    lmat: np.ndarray
    lvec: np.ndarray
    sigma: np.ndarray

    def _checked(self, owner: str, axes: tuple[str, ...]) -> dict[str, np.ndarray]:
        """The six arrays as float arrays, checked: ``pi (*axes)``, ``nu (*axes, P)``,
        ``omega (*axes, P, P)``, ``lmat (*axes, D, P)``, ``lvec (*axes, D)``,
        ``sigma (*axes, D, D)``, every value finite; errors start with ``owner``."""
        n = len(axes)
        pi = np.asarray(self.pi, dtype=float)
        if pi.ndim != n or pi.size < 1:
            raise ValueError(
                f"{owner}: pi must be ({', '.join(axes)}) with sizes >= 1, got shape {pi.shape}"
            )
        lead = pi.shape
        sizes = ", ".join(f"{a}={k}" for a, k in zip(axes, lead, strict=True))
        nu = np.asarray(self.nu, dtype=float)
        if nu.ndim != n + 1 or nu.shape[:n] != lead:
            raise ValueError(f"{owner}: nu must be ({sizes}, P), got shape {nu.shape}")
        lvec = np.asarray(self.lvec, dtype=float)
        if lvec.ndim != n + 1 or lvec.shape[:n] != lead:
            raise ValueError(f"{owner}: lvec must be ({sizes}, D), got shape {lvec.shape}")
        p, d = nu.shape[n], lvec.shape[n]
        arrays = {"pi": pi, "nu": nu, "lvec": lvec}
        shapes = {"omega": (*lead, p, p), "lmat": (*lead, d, p), "sigma": (*lead, d, d)}
        for name, shape in shapes.items():
            a = np.asarray(getattr(self, name), dtype=float)
            if a.shape != shape:
                raise ValueError(f"{owner}: {name} must have shape {shape}, got {a.shape}")
            arrays[name] = a
        for name in _PARAMETERS:
            if not np.all(np.isfinite(arrays[name])):
                raise ValueError(f"{owner}: {name} must be finite")
        return {name: arrays[name] for name in _PARAMETERS}


@dataclass(frozen=True)
class GLLiM(_Parameters):
    r"""One piecewise-affine model (thesis eq. 4.14 parameter set).

    Attributes
    ----------
    pi : ndarray (R,)
        :math:`\pi_r`, positive, summing to 1.
    nu : ndarray (R, P)
        :math:`\nu_r`, centres of the input (position) Gaussians.
    omega : ndarray (R, P, P)
        :math:`\Omega_r`, SPD.
    lmat : ndarray (R, D, P)
        :math:`L_r`.
    lvec : ndarray (R, D)
        :math:`l_r`.
    sigma : ndarray (R, D, D)
        :math:`\Sigma_r`, SPD (stored as full matrices whatever the training constraint).
    """

    def __post_init__(self) -> None:
        for name, a in self._checked("GLLiM", ("R",)).items():
            a = a.copy()
            a.flags.writeable = False
            object.__setattr__(self, name, a)
        pi = self.pi
        if np.any(pi <= 0) or abs(pi.sum() - 1.0) > 1e-6:
            raise ValueError(f"GLLiM: pi must be positive and sum to 1, got {pi}")

    @property
    def n_components(self) -> int:
        """``R``."""
        return int(self.pi.shape[0])

    @property
    def input_dim(self) -> int:
        """``P`` (2 for image positions)."""
        return int(self.nu.shape[1])

    @property
    def output_dim(self) -> int:
        """``D`` (``2 L (n_mics - 1)`` for DP-RTF sub-band features)."""
        return int(self.lvec.shape[1])

    def _check_x(self, x: np.ndarray, name: str = "x") -> np.ndarray:
        x = np.asarray(x, dtype=float)
        if x.ndim != 2 or x.shape[1] != self.input_dim:
            raise ValueError(f"{name} must be (M, {self.input_dim}), got shape {x.shape}")
        return x

    def _check_g(self, g: np.ndarray, name: str = "g") -> np.ndarray:
        g = np.asarray(g, dtype=float)
        if g.ndim != 2 or g.shape[1] != self.output_dim:
            raise ValueError(f"{name} must be (M, {self.output_dim}), got shape {g.shape}")
        return g

    def component_posterior(self, x: np.ndarray) -> np.ndarray:
        r""":math:`p(C = r | x)` (thesis eq. 4.16), ``x (M, P) -> (M, R)``."""
        x = self._check_x(x)
        logdet, inv = _spd_logdet_inv(self.omega)
        log_w = np.log(self.pi) + _log_gauss(x[:, None, :] - self.nu, logdet, inv)
        return np.exp(log_w - _logsumexp(log_w, axis=1)[:, None])  # eq. 4.16

    def forward(self, x: np.ndarray) -> np.ndarray:
        r""":math:`E[g | x] = \sum_r p(r|x)(L_r x + l_r)`, ``x (M, P) -> (M, D)``."""
        w = self.component_posterior(x)
        pred = np.einsum("rdp,mp->mrd", self.lmat, x) + self.lvec  # L_r x + l_r
        return np.einsum("mr,mrd->md", w, pred)

    def inverse_parameters(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        r"""The inverse experts: ``A* (R, P, D)``, ``b* (R, P)``, ``Γ* (R, P, P)`` with
        :math:`E[x | g, r] = A^*_r g + b^*_r` (see the module docstring)."""
        _, sigma_inv = _spd_logdet_inv(self.sigma)
        _, omega_inv = _spd_logdet_inv(self.omega)
        lt_si = np.swapaxes(self.lmat, 1, 2) @ sigma_inv  # Lᵀ Σ⁻¹, (R, P, D)
        gamma_star = np.linalg.inv(omega_inv + lt_si @ self.lmat)  # (Ω⁻¹ + Lᵀ Σ⁻¹ L)⁻¹
        gamma_star = 0.5 * (gamma_star + np.swapaxes(gamma_star, 1, 2))
        a_star = gamma_star @ lt_si  # Γ* Lᵀ Σ⁻¹
        # b* = Γ* (Ω⁻¹ ν - Lᵀ Σ⁻¹ l)
        b_star = np.einsum(
            "rpq,rq->rp",
            gamma_star,
            np.einsum("rpq,rq->rp", omega_inv, self.nu)
            - np.einsum("rpd,rd->rp", lt_si, self.lvec),
        )
        return a_star, b_star, gamma_star

    def inverse(self, g: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        r"""Posterior of the position given a feature, :math:`p(x | g)`.

        Parameters
        ----------
        g : ndarray (M, D)

        Returns
        -------
        mean : ndarray (M, P)
            :math:`E[x | g]`.
        weights : ndarray (M, R)
            :math:`w_r(g) = p(C = r | g)`.
        cov : ndarray (M, P, P)
            :math:`\mathrm{Cov}[x | g]` (mixture covariance).
        """
        g = self._check_g(g)
        a_star, b_star, gamma_star = self.inverse_parameters()
        # w_r(g) ∝ π_r N(g; L_r ν_r + l_r, Σ_r + L_r Ω_r L_rᵀ)
        cov_g = self.sigma + self.lmat @ self.omega @ np.swapaxes(self.lmat, 1, 2)
        logdet, inv = _spd_logdet_inv(cov_g)
        mean_g = np.einsum("rdp,rp->rd", self.lmat, self.nu) + self.lvec
        log_w = np.log(self.pi) + _log_gauss(g[:, None, :] - mean_g, logdet, inv)
        w = np.exp(log_w - _logsumexp(log_w, axis=1)[:, None])
        xr = np.einsum("rpd,md->mrp", a_star, g) + b_star  # A*_r g + b*_r, (M, R, P)
        mean = np.einsum("mr,mrp->mp", w, xr)
        dev = xr - mean[:, None, :]
        cov = np.einsum("mr,rpq->mpq", w, gamma_star) + np.einsum("mr,mrp,mrq->mpq", w, dev, dev)
        return mean, w, cov

    def log_joint(self, x: np.ndarray, g: np.ndarray) -> np.ndarray:
        """``(M,)`` :math:`\\log p(g, x)` (eq. 4.13)."""
        x, g = self._check_x(x), self._check_g(g)
        if x.shape[0] != g.shape[0]:
            raise ValueError(f"x and g must have as many rows, got {x.shape[0]} and {g.shape[0]}")
        return _logsumexp(_log_terms(self, x, g), axis=1)


def _log_terms(model: GLLiM, x: np.ndarray, g: np.ndarray) -> np.ndarray:
    """``(M, R)`` log π_r N(x; ν_r, Ω_r) N(g; L_r x + l_r, Σ_r), the summands of eq. 4.13."""
    ld_o, inv_o = _spd_logdet_inv(model.omega)
    ld_s, inv_s = _spd_logdet_inv(model.sigma)
    res = g[:, None, :] - np.einsum("rdp,mp->mrd", model.lmat, x) - model.lvec
    return (
        np.log(model.pi)
        + _log_gauss(x[:, None, :] - model.nu, ld_o, inv_o)
        + _log_gauss(res, ld_s, inv_s)
    )


@dataclass(frozen=True)
class GLLiMFit:
    """Result of :func:`fit_gllim`.

    Attributes
    ----------
    model : GLLiM
    log_likelihood : ndarray (n_iter + 1,)
        Mean log-likelihood per sample after initialisation and after each EM iteration.
    converged : bool
    """

    model: GLLiM
    log_likelihood: np.ndarray
    converged: bool


def _kmeans(x: np.ndarray, k: int, rng: np.random.Generator, n_iter: int = 50) -> np.ndarray:
    """Labels ``(M,)`` of k-means++ then Lloyd iterations on ``x (M, P)``."""
    m = x.shape[0]
    centres = [x[rng.integers(m)]]
    for _ in range(1, k):
        d2 = np.min(((x[:, None, :] - np.array(centres)[None]) ** 2).sum(-1), axis=1)
        total = d2.sum()
        idx = rng.integers(m) if total <= 0 else rng.choice(m, p=d2 / total)
        centres.append(x[idx])
    c = np.array(centres)
    labels = np.zeros(m, dtype=np.int64)
    for it in range(n_iter):
        new = np.argmin(((x[:, None, :] - c[None]) ** 2).sum(-1), axis=1)
        if it and np.array_equal(new, labels):
            break
        labels = new
        for j in range(k):
            sel = labels == j
            if np.any(sel):
                c[j] = x[sel].mean(axis=0)
    return labels


def m_step(
    x: np.ndarray,
    g: np.ndarray,
    resp: np.ndarray,
    covariance_type: str = "full",
    reg_x: float = 1e-6,
    reg_g: float = 1e-6,
) -> GLLiM:
    r"""Closed-form M step of the GLLiM EM from responsibilities ``resp (M, R)``.

    Per component, with :math:`n_r = \sum_i r_{ir}`:
    :math:`\pi_r = n_r / M`, :math:`\nu_r = \sum_i r_{ir}x_i / n_r`,
    :math:`\Omega_r = \sum_i r_{ir}(x_i-\nu_r)(x_i-\nu_r)^\top / n_r`,
    :math:`L_r = C^{gx}_r (C^{xx}_r)^{-1}` and :math:`l_r = \bar g_r - L_r\nu_r`
    (weighted least squares), :math:`\Sigma_r = \sum_i r_{ir} e_{ir}e_{ir}^\top / n_r` with
    :math:`e_{ir} = g_i - L_rx_i - l_r`, constrained to its diagonal (``"diag"``) or its mean
    variance (``"iso"``). ``reg_x`` and ``reg_g`` (relative to the data variances) are added
    to the diagonals of Ω and Σ.
    """
    n_r = resp.sum(axis=0) + 1e-12  # (R,)
    pi = n_r / n_r.sum()
    nu = resp.T @ x / n_r[:, None]  # (R, P)
    gbar = resp.T @ g / n_r[:, None]  # (R, D)
    xc = x[None, :, :] - nu[:, None, :]  # (R, M, P)
    gc = g[None, :, :] - gbar[:, None, :]  # (R, M, D)
    w = resp.T[:, :, None]  # (R, M, 1)
    cxx = np.einsum("rmp,rmq->rpq", w * xc, xc) / n_r[:, None, None]  # (R, P, P)
    cgx = np.einsum("rmd,rmp->rdp", w * gc, xc) / n_r[:, None, None]  # (R, D, P)
    p = x.shape[1]
    var_x = max(float(np.mean(np.var(x, axis=0))), 1e-300)
    omega = cxx + reg_x * var_x * np.eye(p)
    lmat = np.swapaxes(np.linalg.solve(omega, np.swapaxes(cgx, 1, 2)), 1, 2)  # C_gx Ω⁻¹
    lvec = gbar - np.einsum("rdp,rp->rd", lmat, nu)  # l_r = ḡ_r - L_r ν_r
    res = g[None, :, :] - np.einsum("rdp,mp->rmd", lmat, x) - lvec[:, None, :]  # e_ir
    d = g.shape[1]
    var_g = max(float(np.mean(np.var(g, axis=0))), 1e-300)
    if covariance_type == "full":
        sigma = np.matmul(np.swapaxes(w * res, 1, 2), res) / n_r[:, None, None]
    else:
        diag = np.einsum("rmd,rmd->rd", w * res, res) / n_r[:, None]
        if covariance_type == "iso":
            diag = np.repeat(diag.mean(axis=1, keepdims=True), d, axis=1)
        sigma = diag[:, :, None] * np.eye(d)
    sigma = sigma + reg_g * var_g * np.eye(d)
    return GLLiM(pi, nu, omega, lmat, lvec, sigma)


def e_step(model: GLLiM, x: np.ndarray, g: np.ndarray) -> tuple[np.ndarray, float]:
    """Responsibilities ``(M, R)`` and mean log-likelihood of the calibration pairs."""
    log_t = _log_terms(model, x, g)
    norm = _logsumexp(log_t, axis=1)
    return np.exp(log_t - norm[:, None]), float(norm.mean())


def fit_gllim(
    x: np.ndarray,
    g: np.ndarray,
    n_components: int,
    *,
    covariance_type: str = "full",
    max_iter: int = 100,
    tol: float = 1e-4,
    reg_x: float = 1e-6,
    reg_g: float = 1e-4,
    rng: np.random.Generator | int = 0,
    init: GLLiM | None = None,
) -> GLLiMFit:
    """Train a GLLiM by closed-form EM (thesis eqs. 4.13–4.14; see the module docstring).

    Parameters
    ----------
    x : ndarray (M, P)
        Calibration positions (image coordinates).
    g : ndarray (M, D)
        Audio features recorded at those positions.
    n_components : int
        ``R`` (1 <= R <= M).
    covariance_type : {"full", "diag", "iso"}
        Constraint on :math:`\\Sigma_r`.
    max_iter : int
        Maximum EM iterations (0: the initial M step only).
    tol : float
        Stop when the mean log-likelihood per sample improves by less than this.
    reg_x, reg_g : float
        Diagonal loading of Ω and Σ relative to the data variances (keeps them SPD).
    rng : numpy Generator or int
        Seeds the k-means initialisation.
    init : GLLiM, optional
        Start the EM from these parameters instead of k-means.

    Returns
    -------
    GLLiMFit
    """
    x = np.asarray(x, dtype=float)
    g = np.asarray(g, dtype=float)
    if x.ndim != 2 or x.shape[0] < 1:
        raise ValueError(f"fit_gllim: x must be (M, P) with M >= 1, got shape {x.shape}")
    if g.ndim != 2 or g.shape[0] != x.shape[0]:
        raise ValueError(f"fit_gllim: g must be (M={x.shape[0]}, D), got shape {g.shape}")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(g))):
        raise ValueError("fit_gllim: x and g must be finite (found NaN or inf)")
    if (
        isinstance(n_components, bool)
        or not isinstance(n_components, int | np.integer)
        or not (1 <= n_components <= x.shape[0])
    ):
        raise ValueError(
            f"fit_gllim: n_components must be an integer in [1, {x.shape[0]}], "
            f"got {n_components!r}"
        )
    if covariance_type not in COVARIANCE_TYPES:
        raise ValueError(
            f"fit_gllim: covariance_type must be one of {COVARIANCE_TYPES}, "
            f"got {covariance_type!r}"
        )
    if isinstance(max_iter, bool) or not isinstance(max_iter, int) or max_iter < 0:
        raise ValueError(f"fit_gllim: max_iter must be an integer >= 0, got {max_iter!r}")
    for name, v in (("tol", tol), ("reg_x", reg_x), ("reg_g", reg_g)):
        if not (np.isfinite(v) and v >= 0):
            raise ValueError(f"fit_gllim: {name} must be a number >= 0, got {v!r}")
    if init is None:
        gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        labels = _kmeans(x, int(n_components), gen)
        resp = np.zeros((x.shape[0], int(n_components)))
        resp[np.arange(x.shape[0]), labels] = 1.0
        model = m_step(x, g, resp, covariance_type, reg_x, reg_g)
    else:
        if (
            init.n_components != n_components
            or init.input_dim != x.shape[1]
            or (init.output_dim != g.shape[1])
        ):
            raise ValueError("fit_gllim: init does not match n_components or the data dimensions")
        model = init
    resp, ll = e_step(model, x, g)
    history = [ll]
    converged = False
    for _ in range(max_iter):
        model = m_step(x, g, resp, covariance_type, reg_x, reg_g)
        resp, ll = e_step(model, x, g)
        history.append(ll)
        if abs(history[-1] - history[-2]) < tol:
            converged = True
            break
    return GLLiMFit(model, np.array(history), converged)


# --------------------------------------------------------------------------- sub-band mappings


@dataclass(frozen=True)
class AudioImageMapping(_Parameters):
    r"""One GLLiM per audio sub-band, stacked (thesis §4.3.4: "there are K models").

    Attributes
    ----------
    pi : ndarray (K, R)
    nu : ndarray (K, R, P)
    omega : ndarray (K, R, P, P)
    lmat : ndarray (K, R, D, P)
    lvec : ndarray (K, R, D)
    sigma : ndarray (K, R, D, D)
    meta : dict
        JSON-serialisable description (sub-band layout, array, camera image size, ...).
    """

    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name, a in self._checked("AudioImageMapping", ("K", "R")).items():
            object.__setattr__(self, name, a)
        object.__setattr__(self, "meta", dict(self.meta))

    @classmethod
    def from_models(
        cls,
        models: list[GLLiM],
        meta: dict[str, Any] | None = None,
    ) -> AudioImageMapping:
        """Stack ``K`` GLLiMs with the same ``R``, ``P`` and ``D``."""
        if not models:
            raise ValueError("AudioImageMapping.from_models: need at least one model")
        shapes = {(m.n_components, m.input_dim, m.output_dim) for m in models}
        if len(shapes) != 1:
            raise ValueError(
                f"AudioImageMapping.from_models: models must share (R, P, D), got {sorted(shapes)}"
            )
        pi, nu, omega, lmat, lvec, sigma = (
            np.stack([getattr(m, n) for m in models]) for n in _PARAMETERS
        )
        return cls(pi, nu, omega, lmat, lvec, sigma, meta or {})

    def model(self, k: int) -> GLLiM:
        """The GLLiM of sub-band ``k``."""
        return GLLiM(
            self.pi[k], self.nu[k], self.omega[k], self.lmat[k], self.lvec[k], self.sigma[k]
        )

    @property
    def n_bands(self) -> int:
        return int(self.pi.shape[0])

    @property
    def n_components(self) -> int:
        return int(self.pi.shape[1])

    @property
    def feature_dim(self) -> int:
        return int(self.lvec.shape[2])


FORMAT_VERSION = 1


def save_mapping(path: str | Path, mapping: AudioImageMapping) -> Path:
    """Write ``mapping`` to an ``.npz`` file atomically (arrays plus a JSON ``meta`` string)."""
    path = Path(path)
    meta = json.dumps({"format": "avtrack-gllim", "version": FORMAT_VERSION, **mapping.meta})
    with atomic_write(path, "wb") as fh:
        np.savez(fh, meta=np.array(meta), **{k: getattr(mapping, k) for k in _PARAMETERS})
    return path


def load_mapping(path: str | Path) -> AudioImageMapping:
    """Read a mapping written by :func:`save_mapping`.

    Raises
    ------
    InputError
        Naming ``path`` when it is missing, not an ``.npz`` mapping, or inconsistent.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError("audio-to-image mapping not found", path)
    try:
        with np.load(path, allow_pickle=False) as data:
            missing = [k for k in (*_PARAMETERS, "meta") if k not in data.files]
            if missing:
                raise InputError(f"not an avtrack GLLiM mapping: missing {missing}", path)
            arrays = {k: np.array(data[k]) for k in _PARAMETERS}
            meta = json.loads(str(data["meta"]))
    except InputError:
        raise
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read the mapping ({exc})", path) from None
    if not isinstance(meta, dict) or meta.get("format") != "avtrack-gllim":
        raise InputError("not an avtrack GLLiM mapping (meta.format)", path)
    meta.pop("format")
    meta.pop("version", None)
    try:
        return AudioImageMapping(**arrays, meta=meta)
    except ValueError as exc:
        raise InputError(str(exc), path) from None
