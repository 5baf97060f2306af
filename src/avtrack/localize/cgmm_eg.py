"""Complex-Gaussian-mixture localization with exponentiated-gradient weight updates (DPRTF-EG).

Thesis §5.3 (eqs. 5.12–5.19), after Li et al. [78, 81]. Each DP-RTF feature ``ĉ^i_{t,f}``
(:mod:`avtrack.audio.dprtf`) is drawn from a complex Gaussian mixture over the ``D`` candidate
directions, with fixed means -- the features predicted for each direction
(:func:`avtrack.localize.grid.dprtf_means`) -- and a common variance ``sigma^2``:

.. math::

    p(\\hat c^i_{t,f}) = \\sum_{d=1}^D w_d\\, \\mathcal N_c(\\hat c^i_{t,f}; c^{i,d}_f, \\sigma^2)
    \\qquad (5.12)

The weights ``w_t`` are the only parameters; they are updated once per frame by exponentiated
gradient on the normalised negative log-likelihood of the frame's features ``L_t`` (5.13) plus
an entropy penalty ``gamma H`` (5.14) that favours sparse weights:

.. math::

    \\partial L_t / \\partial w_d = -\\frac{1}{|C_t|} \\sum_{\\hat c \\in C_t}
        \\frac{\\mathcal N_c(\\hat c; c^d, \\sigma^2)}{\\sum_{d'} w_{t-1,d'}
        \\mathcal N_c(\\hat c; c^{d'}, \\sigma^2)},
    \\qquad \\partial H / \\partial w_d = -(1 + \\log w_{t-1,d})          (5.17)

    r_{t-1,d} = \\exp(-\\eta (\\partial L_t / \\partial w_d
                           + \\gamma \\partial H / \\partial w_d)),
    \\qquad w_{t,d} = r_{t-1,d} w_{t-1,d} / \\sum_{d'} r_{t-1,d'} w_{t-1,d'}   (5.18, 5.19)

(the thesis prints ``∂(-L_t)`` in (5.18); the descent direction of the objective (5.15) is the
one written here: weights of well-explained directions grow). When a frame has no feature
(silence), the weights relax to uniform, ``w_t = (1 - eta') w_{t-1} + eta' / D``. After each
frame the weights are smoothed along azimuth,
``w_d <- (w_d + 0.02 w_{d-1} + 0.02 w_{d+1}) / 1.04``.

Thesis settings (§5.5.1): ``eta = 0.07``, ``eta' = 0.065``, ``gamma = 0.1``, ``Q = 8``,
``rho = 1``. The thesis does not give ``sigma^2``; the default here (0.1) was chosen on
simulated reverberant rooms (``benchmarks/bench_localize.py``), as was ``min_features``.
"""

from __future__ import annotations

from abc import abstractmethod
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from avtrack.audio.dprtf import DPRTFConfig, DPRTFEstimator
from avtrack.localize import _density_kernel
from avtrack.localize.base import Localizer, register_localizer
from avtrack.localize.fixed_lag import FixedLagSmoother
from avtrack.localize.grid import DirectionGrid, dprtf_means, transfer_functions

_TINY = 1e-300
_F32_BIG = 1e30  # below float32's largest value: 1/denominator stays finite


def _positive(owner: str, name: str, value: float, allow_zero: bool = False) -> None:
    ok = isinstance(value, int | float) and not isinstance(value, bool) and np.isfinite(value)
    ok = ok and (value >= 0 if allow_zero else value > 0)
    if not ok:
        bound = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{owner}: {name} must be a finite number {bound}, got {value!r}")


def _count(owner: str, name: str, value: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 0:
        raise ValueError(f"{owner}: {name} must be an integer >= 0, got {value!r}")


def density_coefficients(means: np.ndarray, variance: float) -> np.ndarray:
    """The terms of ``log N_c(ĉ; c, sigma^2)`` (eq. 5.12) that do not depend on the feature,
    computed once per localizer: ``(..., 3, D)`` with rows ``2 Re(c) / sigma^2``,
    ``2 Im(c) / sigma^2`` and ``-|c|^2 / sigma^2``, so that ``log N = [Re ĉ, Im ĉ, 1] . row``
    up to a constant per feature (``-|ĉ|^2 / sigma^2``, which the ratios of eq. 5.17 do not
    see).

    Parameters
    ----------
    means : ndarray (..., D), complex
    variance : float
    """
    m = np.asarray(means)
    coef = np.stack([2.0 * m.real, 2.0 * m.imag, -(m.real**2 + m.imag**2)], axis=-2)
    return np.ascontiguousarray(coef / variance)


def densities_from_coefficients(features: np.ndarray, coef: np.ndarray) -> np.ndarray:
    """:func:`cgmm_densities` from :func:`density_coefficients`: features ``(K,)`` complex and
    their coefficients ``(K, 3, D)``; returns ``(K, D)`` in (0, 1], a 1 in every row."""
    f = np.asarray(features)
    lhs = np.empty((f.size, 1, 3))
    lhs[:, 0, 0] = f.real
    lhs[:, 0, 1] = f.imag
    lhs[:, 0, 2] = 1.0
    log_n = np.matmul(lhs, coef)[:, 0, :]  # (K, D): one small product per feature
    log_n -= log_n.max(axis=1, keepdims=True)
    return np.exp(log_n, out=log_n)


def cgmm_densities(features: np.ndarray, means: np.ndarray, variance: float) -> np.ndarray:
    """``N_c(ĉ_k; c_{k,d}, sigma^2)`` (eq. 5.12) up to a factor per feature ``k``.

    Each row is divided by its largest entry (the largest exponent factored out), so that no
    likelihood under- or overflows; the ratios of eq. 5.17 do not depend on that factor.

    Parameters
    ----------
    features : ndarray (K,), complex
    means : ndarray (K, D), complex
    variance : float

    Returns
    -------
    ndarray (K, D), in (0, 1], with a 1 in every row.
    """
    # log N_c(ĉ; c, s2) = -|ĉ - c|^2 / s2 + const = (2 Re(ĉ* c) - |c|^2) / s2 + const_k
    return densities_from_coefficients(features, density_coefficients(means, variance))


def ratios_from_densities(dens: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``N_kd / sum_d' w_d' N_kd'`` (eq. 5.17) from :func:`cgmm_densities` ``(K, D)``."""
    denom = dens @ weights  # sum_d' w_d' N_kd'
    return dens / np.maximum(denom, _TINY)[:, None]


def mean_ratios(dens: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``(1/K) sum_k N_kd / sum_d' w_d' N_kd'`` ``(D,)``: the mean over the features of
    :func:`ratios_from_densities`, which is all eqs. 5.17-5.19 use (two matrix-vector
    products instead of a ``(K, D)`` division). Densities in single precision (as the
    localizers compute them) give the products in single precision (no ``(K, D)`` copy) and
    the mean in double."""
    if dens.dtype == np.float32:
        denom = (dens @ weights.astype(np.float32)).astype(np.float64)
        inv = np.minimum(1.0 / np.maximum(denom, _TINY), _F32_BIG).astype(np.float32)
        return (inv @ dens).astype(np.float64) / dens.shape[0]
    inv = 1.0 / np.maximum(dens @ weights, _TINY)  # 1 / sum_d' w_d' N_kd'   (K,)
    return (inv @ dens) / dens.shape[0]


def _mean_ratio(ratios: np.ndarray) -> np.ndarray:
    """The mean ratio ``(D,)`` from ratios ``(K, D)``, or the mean itself."""
    return ratios if ratios.ndim == 1 else ratios.mean(axis=0)


def cgmm_likelihood_ratios(
    features: np.ndarray, means: np.ndarray, weights: np.ndarray, variance: float
) -> np.ndarray:
    """``N_c(ĉ_k; c_{k,d}, sigma^2) / sum_d' w_d' N_c(ĉ_k; c_{k,d'}, sigma^2)`` (eq. 5.17).

    Computed with the largest exponent of each feature factored out, so that no likelihood
    under- or overflows.

    Parameters
    ----------
    features : ndarray (K,), complex
    means : ndarray (K, D), complex
        The mean of each component for each feature (``c^{i,d}_f`` at the feature's ``i, f``).
    weights : ndarray (D,)
        Current mixture weights ``w_{t-1}`` (positive, summing to one).
    variance : float
        ``sigma^2``.

    Returns
    -------
    ndarray (K, D)
    """
    return ratios_from_densities(cgmm_densities(features, means, variance), weights)


def eg_update(weights: np.ndarray, ratios: np.ndarray, step: float, entropy: float) -> np.ndarray:
    """Exponentiated-gradient step with entropy regularisation (eqs. 5.17–5.19).

    Parameters
    ----------
    weights : ndarray (D,)
        ``w_{t-1}``, positive, summing to one.
    ratios : ndarray (K, D) or (D,)
        :func:`cgmm_likelihood_ratios` of the frame's ``K >= 1`` features, or their mean over
        the features (:func:`mean_ratios`).
    step, entropy : float
        ``eta`` and ``gamma``.

    Returns
    -------
    ndarray (D,)
        ``w_t``, positive and summing to one (computed in the log domain).
    """
    log_w = np.log(np.maximum(weights, _TINY))
    grad_l = -_mean_ratio(ratios)  # dL_t/dw_d                       (eq. 5.17)
    grad_h = -(1.0 + log_w)  # dH/dw_d                               (eq. 5.17)
    log_w = log_w - step * (grad_l + entropy * grad_h)  # log(r w)  (eq. 5.18)
    log_w -= log_w.max()
    w = np.exp(log_w)
    return w / w.sum()  # w_t = r w / sum(r w)                      (eq. 5.19)


def evidence_change(weights: np.ndarray, ratios: np.ndarray) -> float:
    """How far the frame's features move the weights: ``TV(p, w) = ½ Σ_d |p_d − w_d|`` in
    [0, 1], with ``p_d = w_d (1/K) Σ_k ratios_kd`` the mean posterior of the frame's features
    over the directions (the responsibilities of eq. 5.16 under ``w_{t-1}``; ``p`` sums to
    one). Near 0 when the features agree with the weights, near 1 when they come from
    directions the weights do not hold.
    """
    post = weights * _mean_ratio(ratios)
    return float(0.5 * np.abs(post - weights).sum())


def decay_to_uniform(weights: np.ndarray, rate: float) -> np.ndarray:
    """Silent frame: ``w_t = (1 - eta') w_{t-1} + eta' / D`` (thesis §5.3.2)."""
    return (1.0 - rate) * weights + rate / weights.shape[-1]


def spatial_smoothing(weights: np.ndarray, grid: DirectionGrid, coef: float) -> np.ndarray:
    """``w_d <- (w_d + coef w_{d-1} + coef w_{d+1}) / (1 + 2 coef)`` along azimuth (§5.3.2).

    Neighbours wrap around on a circular azimuth grid; at the ends of a non-circular one the
    missing neighbour is left out. The result is renormalised to the input's sum.
    """
    if coef == 0:
        return weights
    prev, nxt, has_prev, has_next = grid.azimuth_neighbours
    out = weights + coef * (weights[prev] * has_prev + weights[nxt] * has_next)
    return out * (weights.sum() / out.sum())


def local_mass(weights: np.ndarray, grid: DirectionGrid, reach: int) -> np.ndarray:
    """``sum_{|j| <= reach} w_{d+j}``: the weight within ``reach`` azimuth cells of each
    candidate, at the same elevation (wrapping around on a circular grid; at the ends of a
    non-circular one, the cells that exist).

    Parameters
    ----------
    weights : ndarray (D,)
    grid : DirectionGrid
    reach : int
        Cells on each side (0: the weights themselves).
    """
    prev, nxt, has_prev, has_next = grid.azimuth_neighbours
    out = weights.copy()
    left = weights
    right = weights
    for _ in range(reach):
        left = left[prev] * has_prev  # left[d] = w[d - j]
        right = right[nxt] * has_next  # right[d] = w[d + j]
        out += left + right
    return out


def local_max(values: np.ndarray, grid: DirectionGrid, reach: int) -> np.ndarray:
    """``max_{|j| <= reach} x_{d+j}`` along azimuth, at the same elevation (wrapping around on
    a circular grid; at the ends of a non-circular one, over the cells that exist).

    Parameters
    ----------
    values : ndarray (D,)
    grid : DirectionGrid
    reach : int
        Cells on each side.
    """
    prev, nxt, has_prev, has_next = grid.azimuth_neighbours
    out = values.copy()
    left = values
    right = values
    for _ in range(reach):
        left = np.where(has_prev > 0, left[prev], -np.inf)  # left[d] = x[d - j]
        right = np.where(has_next > 0, right[nxt], -np.inf)  # right[d] = x[d + j]
        out = np.maximum(out, np.maximum(left, right))
    return out


def place_presence(
    position: np.ndarray, presence: np.ndarray, grid: DirectionGrid, reach: int
) -> np.ndarray:
    """Heat map with the peaks of ``position`` and the local mass of ``presence``:
    ``h_d = v_d P_d(w) / P_d(v)`` with ``P_d(x) = max_{|j| <= r} M_{d+j}(x)``, ``M`` the
    :func:`local_mass` within ``r = reach`` cells (:func:`local_max` of it).

    Near a peak of the position weights ``v``, ``P(v)`` is the peak's mass and ``P(w)`` the
    largest mass of the presence weights ``w`` within ``2 r`` cells, both flat across the peak,
    so the map keeps ``v``'s shape -- and its peak's direction -- scaled so that the peak
    carries ``w``'s mass; where ``w`` holds no more mass than its floor, nothing stands out,
    whatever ``v`` says.

    Parameters
    ----------
    position, presence : ndarray (D,)
        ``v`` and ``w``, non-negative.
    grid : DirectionGrid
    reach : int

    Returns
    -------
    ndarray (D,), non-negative.
    """
    return position * presence_ratio(position, presence, grid, reach)


def presence_ratio(
    position: np.ndarray, presence: np.ndarray, grid: DirectionGrid, reach: int
) -> np.ndarray:
    """``P_d(w) / P_d(v)`` of :func:`place_presence` ``(D,)``."""
    p_w = local_max(local_mass(presence, grid, reach), grid, reach)
    p_v = local_max(local_mass(position, grid, reach), grid, reach)
    return p_w / np.maximum(p_v, _TINY)  # h_d = v_d P_d(w) / P_d(v)


def uphill(values: np.ndarray, grid: DirectionGrid) -> np.ndarray:
    """For each candidate, the local maximum along azimuth (same elevation) that climbing
    from it reaches: ``(D,)`` indices (each step to the larger neighbour, ties kept)."""
    prev, nxt, has_prev, has_next = grid.azimuth_neighbours
    d = np.arange(values.size)
    vp = np.where(has_prev > 0, values[prev], -np.inf)
    vn = np.where(has_next > 0, values[nxt], -np.inf)
    up = np.where((vn > values) & (vn >= vp), nxt, np.where(vp > values, prev, d))
    for _ in range(max(1, int(np.ceil(np.log2(max(grid.n_azimuths, 2)))) + 1)):
        up = up[up]  # pointer jumping: log2(n) rounds reach the top of every slope
    return up


def place_presence_by_peak(
    position: np.ndarray, presence: np.ndarray, grid: DirectionGrid, reach: int
) -> np.ndarray:
    """:func:`place_presence` with one scale per peak of ``position``: every candidate on the
    slopes of a peak ``p`` of ``v`` gets ``h_d = v_d P_p(w) / P_p(v)``, the ratio taken at the
    peak. ``v``'s shape is kept exactly, so its peaks stay where they are (a ratio that varies
    across a peak -- the mass of a neighbouring talker within reach -- would tilt it towards
    that talker).

    Parameters
    ----------
    position, presence : ndarray (D,)
    grid : DirectionGrid
    reach : int

    Returns
    -------
    ndarray (D,), non-negative.
    """
    return position * presence_ratio(position, presence, grid, reach)[uphill(position, grid)]


def snap_to_presence(
    heat: np.ndarray, position: np.ndarray, presence: np.ndarray, grid: DirectionGrid,
    reach: int
) -> np.ndarray:
    """Move each peak of the heat map to the peak of the slow weights beside it: the cells on
    the slopes of a peak ``p`` of ``v`` (``position``) shift along azimuth, as one block, to
    the peak ``q`` of ``w`` (``presence``) that climbing ``w`` from ``p`` reaches, when ``q``
    lies within ``reach`` cells of ``p``; peaks with no such ``q`` stay.

    Why: ``v``'s short memory and random walk let its peaks follow a moving talker, but they
    also blur two talkers close to each other into peaks pulled towards each other (on a
    4.6 cm array, talkers 45 degrees apart were each placed 5-8 degrees towards the other),
    while ``w``, the thesis's weights, converges to the maximum-likelihood mixture, which
    keeps them apart. A standing talker's two peaks lie within a cell or two, and ``w``'s is
    the better estimate; a moving talker's ``w`` trails further than ``reach`` and ``v``'s
    peak is kept. The map's values are not changed, only moved.

    Parameters
    ----------
    heat, position, presence : ndarray (D,)
        The map (:func:`place_presence` of ``v`` and ``w``), ``v`` and ``w``.
    grid : DirectionGrid
    reach : int
        Azimuth cells (0: the map unchanged).

    Returns
    -------
    ndarray (D,), the same total as ``heat``.
    """
    if reach == 0:
        return heat
    n = grid.n_azimuths
    up_v = uphill(position, grid)
    peaks = np.unique(up_v)
    shift = uphill(presence, grid)[peaks] % n - peaks % n
    if grid.circular:
        shift = (shift + n // 2) % n - n // 2
    shift[np.abs(shift) > reach] = 0
    if not shift.any():
        return heat
    by_cell = np.zeros(grid.size, dtype=np.int64)
    by_cell[peaks] = shift
    d = np.arange(grid.size)
    az = d % n + by_cell[up_v]
    az = az % n if grid.circular else np.clip(az, 0, n - 1)
    out = np.zeros_like(heat)
    np.add.at(out, d - d % n + az, heat)
    return out


def drift(weights: np.ndarray, grid: DirectionGrid, cells) -> np.ndarray:
    """Move the weights ``cells`` azimuth cells along the grid (``|cells| <= 1``; positive:
    towards larger azimuths), sharing each cell's mass between its own and the next cell by
    linear interpolation, ``w'_d = (1 - |s|) w_d + |s| w_{d - sign(s)}``. Mass that would
    leave the end of a non-circular grid is lost.

    Parameters
    ----------
    weights : ndarray (..., D)
    grid : DirectionGrid
    cells : float or ndarray (...,)
        One shift for all rows, or one per row of ``weights``.
    """
    c = np.asarray(cells, dtype=float)
    if not np.all(np.abs(c) <= 1.0):
        raise ValueError(f"drift: cells must be in [-1, 1], got {cells!r}")
    c = c[..., None]
    prev, nxt, has_prev, has_next = grid.azimuth_neighbours
    src = np.where(c > 0, weights[..., prev] * has_prev, weights[..., nxt] * has_next)
    return (1.0 - np.abs(c)) * weights + np.abs(c) * src


def _from_previous(y: np.ndarray, circular: bool) -> np.ndarray:
    """``y`` of each cell's previous azimuth along the last axis (0 before the first on a grid
    that does not wrap)."""
    out = np.empty_like(y)
    out[..., 1:] = y[..., :-1]
    out[..., 0] = y[..., -1] if circular else 0.0
    return out


def _from_next(y: np.ndarray, circular: bool) -> np.ndarray:
    """``y`` of each cell's next azimuth along the last axis (0 after the last on a grid that
    does not wrap)."""
    out = np.empty_like(y)
    out[..., :-1] = y[..., 1:]
    out[..., -1] = y[..., 0] if circular else 0.0
    return out


def eg_update_layers(
    layers: np.ndarray, ratios: np.ndarray, step: float, entropy: float
) -> np.ndarray:
    """Eqs. 5.17-5.19 on weights split into velocity layers ``(U, D)``: the mixture weight of
    direction ``d`` is ``sum_u v_{u,d}``, so every layer of ``d`` receives the gradient of
    ``d`` (``ratios`` are computed with the marginal); the entropy term and the normalisation
    are over all ``U D`` cells."""
    log_v = np.log(np.maximum(layers, _TINY))
    grad_l = -_mean_ratio(ratios)  # dL_t/dv_{u,d} = dL_t/dw_d              (eq. 5.17)
    log_v = log_v - step * (grad_l[None, :] - entropy * (1.0 + log_v))  # (eq. 5.18)
    log_v -= log_v.max()
    v = np.exp(log_v)
    return v / v.sum()  # (eq. 5.19)


@dataclass(frozen=True)
class EGConfig:
    """Parameters of :class:`DPRTFEG` (thesis §5.5.1 unless stated).

    Attributes
    ----------
    variance : float
        ``sigma^2`` of the complex Gaussian components (not given in the thesis).
    step : float
        ``eta``, the exponentiated-gradient step (0.07).
    entropy : float
        ``gamma``, the entropy regularisation weight (0.1).
    silence_rate : float
        ``eta'``, relaxation to uniform in frames without features (0.065).
    smoothing : float
        Spatial smoothing coefficient (0.02, thesis §5.3.2). It also sets how fast a peak of
        ``w`` can move: the log-domain step of eq. 5.18 shifts a peak of width ``s`` by about
        ``s^2 eta`` times the slope of the likelihood ratios, so sharp weights follow a moving
        talker slowly. Read as the prediction step of a random walk over the candidate
        directions (a fixed share restricted to neighbouring directions), a larger coefficient
        widens the peaks and roughly halves the lag on moving talkers (0.25, on development seeds),
        at a cost in miss rate on LOCATA-like scenes.
    share : float
        ``alpha`` of a fixed-share step after each EG update, ``w <- (1 - alpha) w + alpha / D``
        (Herbster & Warmuth, "Tracking the best expert", 1998); not in the thesis (0 there).
        It keeps every weight above ``alpha / D``, so a talker who appears where the weights
        were near zero is picked up in a few frames.
    step_boost : float
        ``kappa`` of the adaptive step ``eta_t = eta (1 + kappa TV(p_t, w_{t-1}))``
        (:func:`evidence_change`): slow while the features agree with the weights, up to
        ``(1 + kappa) eta`` when they come from elsewhere (a talker who moves or starts). Not
        in the thesis (0 there: a fixed ``eta``).
    output_silence_rate : float or None
        None (the thesis): the heat map is ``w_t``. A rate in (0, 1]: in frames with fewer
        than ``min_features`` features the heat map relaxes to uniform at this rate, from the
        last map that had evidence, while the weights keep their slower ``eta'`` memory for
        the next frame with features (evidence-gated output).
    position_step : float or None
        None (the thesis): the heat map is ``w_t``. A step ``eta_v``: position and presence
        are estimated apart. Second weights ``v_t``, the *position weights*, follow the same
        features by the same update (eqs. 5.17–5.19, entropy ``gamma``, relaxation ``eta'``)
        with this larger step, ``position_smoothing`` and ``position_share``, so that their
        peaks keep up with a moving talker; the thesis weights ``w_t`` keep their slow memory
        and only say *whether* someone speaks near a direction. The heat map is
        :func:`place_presence`: ``v_t``'s shape, each peak scaled to the mass of ``w_t``
        around it (``presence_reach``). Not in the thesis.
    position_smoothing : float
        Spatial smoothing coefficient of ``v_t`` (the random walk that lets its peaks move).
    position_share : float
        Fixed share ``alpha`` of ``v_t`` after each update (see ``share``).
    position_velocities_deg_s : tuple of float or None
        None: the position weights' prediction is the symmetric random walk of
        ``position_smoothing`` alone. A tuple of angular velocities (degrees per second): the
        position weights are split into one layer per velocity, ``v_t = sum_u v_{u,t}``, and
        each layer's prediction moves its mass at its velocity (:func:`drift`) before the
        random walk, as in a multiple-model grid filter (X. R. Li and V. P. Jilkov, "Survey
        of maneuvering target tracking. Part V: multiple-model methods", IEEE TAES 41(4),
        2005). A talker who moves keeps the layer of its velocity; a talker who stands keeps
        the zero layer, whose peaks a small random walk leaves sharp, so that talkers close to
        each other stay apart. Not in the thesis.
    still_smoothing : float or None
        With velocity layers: the random walk of the zero-velocity layer (None: the same
        ``position_smoothing`` as the moving layers). A standing talker needs no walk to be
        followed, and a smaller one keeps its peak on the talker.
    velocity_switch : float
        Share of each layer's mass handed to the other layers every frame (equally), the
        chance of a change of velocity.
    still_prior : float or None
        With velocity layers: where the velocity switch sends the mass it moves. None: to the
        other layers equally, so that without evidence every layer holds the same share (with
        five layers, four fifths of a talker's mass move). A share in (0, 1): the switch
        spreads a direction's mass over the layers in these proportions, this share to the
        zero-velocity layer and the rest equally to the moving ones (the stationary
        distribution of the layers' Markov chain, as in an IMM filter's transition matrix:
        Li and Jilkov 2005). A moving layer then holds mass only as long as the features
        follow it, and the peaks of a standing talker in a reverberant room no longer wander
        along the moving layers. The costs: a talker who moves steadily is trailed by the mass
        the still layer keeps behind it, and a quiet talker beside a louder one is placed
        further towards it; so this is an option for seated talkers (meetings), not the
        default (BENCHMARKS.md, acoustic tracking).
    presence_reach : int
        ``r`` of :func:`place_presence`, in azimuth cells: the masses are summed within ``r``
        cells and the largest taken within ``r`` cells more, so the slow weights may trail a
        peak of ``v_t`` by up to ``2 r`` cells (3 cells: 30 degrees on the default grid).
    presence_by_peak : bool
        False: each candidate scaled by the ratio at itself (:func:`place_presence`); True:
        by the ratio at the peak of ``v_t`` whose slope it is on
        (:func:`place_presence_by_peak`), which keeps the peaks of ``v_t`` in place.
    snap_reach : int
        With the position weights: a peak of the map moves to the peak of ``w_t`` beside it
        when that lies within this many azimuth cells (:func:`snap_to_presence`; 0: the
        peaks stay at ``v_t``'s).
    smoother_lag_s : float or None
        None: the heat map of a frame is the filter's (causal). Seconds: with velocity layers,
        the heat map of frame ``t`` is drawn from the layers smoothed over the frames up to
        this long after it (:class:`~avtrack.localize.fixed_lag.FixedLagSmoother`), and is
        given that much later (:attr:`Localizer.latency_frames`). Not in the thesis.
    smoother_gap_s : float
        With ``smoother_lag_s``: the smoothing does not reach back over a run of frames without
        enough features this long or longer (a pause between talkers).
    min_features : int
        Frames with fewer features are treated as silent (relax to uniform); 20 by default,
        chosen on simulated rooms. The thesis relaxes only when there is no feature at all
        (0); with noise, a few stray noise bins
        pass the speech test in most silent frames, and since the gradient is normalised by
        ``|C_t|`` they would otherwise steer the weights as strongly as a speech frame.
    dprtf : DPRTFConfig
        DP-RTF feature extraction (``Q = 8``, ``rho = 1``, consistency threshold 0.75).
    """

    variance: float = 0.1
    step: float = 0.07
    entropy: float = 0.1
    silence_rate: float = 0.065
    smoothing: float = 0.02
    min_features: int = 20
    share: float = 0.0
    step_boost: float = 0.0
    output_silence_rate: float | None = None
    position_step: float | None = None
    position_smoothing: float = 0.4
    position_share: float = 0.01
    position_velocities_deg_s: tuple[float, ...] | None = None
    still_smoothing: float | None = None
    velocity_switch: float = 0.01
    still_prior: float | None = None
    presence_reach: int = 3
    presence_by_peak: bool = False
    snap_reach: int = 0
    smoother_lag_s: float | None = None
    smoother_gap_s: float = 0.08
    dprtf: DPRTFConfig = field(default_factory=DPRTFConfig)

    def __post_init__(self) -> None:
        _count("EGConfig", "min_features", self.min_features)
        _count("EGConfig", "presence_reach", self.presence_reach)
        _count("EGConfig", "snap_reach", self.snap_reach)
        if self.position_step is not None:
            _positive("EGConfig", "position_step", self.position_step)
        _positive("EGConfig", "variance", self.variance)
        _positive("EGConfig", "step", self.step)
        _positive("EGConfig", "entropy", self.entropy, allow_zero=True)
        _positive("EGConfig", "step_boost", self.step_boost, allow_zero=True)
        if self.output_silence_rate is not None:
            _positive("EGConfig", "output_silence_rate", self.output_silence_rate)
            if self.output_silence_rate > 1:
                raise ValueError(
                    f"EGConfig: output_silence_rate must be <= 1, got {self.output_silence_rate!r}"
                )
        if self.position_velocities_deg_s is not None:
            vel = tuple(self.position_velocities_deg_s)
            if not vel or not all(
                isinstance(x, int | float) and not isinstance(x, bool) and np.isfinite(x)
                for x in vel
            ):
                raise ValueError(
                    "EGConfig: position_velocities_deg_s must be a non-empty list of finite "
                    f"numbers, got {self.position_velocities_deg_s!r}"
                )
            object.__setattr__(self, "position_velocities_deg_s", tuple(float(x) for x in vel))
        if self.still_prior is not None and (
                isinstance(self.still_prior, bool) or not isinstance(self.still_prior, int | float)
                or not 0.0 < self.still_prior < 1.0):
            raise ValueError(f"EGConfig: still_prior must be None or in (0, 1), "
                             f"got {self.still_prior!r}")
        vel_set = set(self.position_velocities_deg_s or ())
        if self.still_prior is not None and not (0.0 in vel_set and len(vel_set) > 1):
            raise ValueError("EGConfig: still_prior needs position_velocities_deg_s with a zero "
                             f"and a non-zero velocity, got {self.position_velocities_deg_s!r}")
        if self.still_smoothing is not None:
            _positive("EGConfig", "still_smoothing", self.still_smoothing, allow_zero=True)
            if self.still_smoothing > 1:
                raise ValueError(
                    f"EGConfig: still_smoothing must be <= 1, got {self.still_smoothing!r}")
        if self.smoother_lag_s is not None:
            _positive("EGConfig", "smoother_lag_s", self.smoother_lag_s, allow_zero=True)
            if self.position_step is None or self.position_velocities_deg_s is None:
                raise ValueError("EGConfig: smoother_lag_s needs the position weights in velocity "
                                 "layers (position_step and position_velocities_deg_s)")
        _positive("EGConfig", "smoother_gap_s", self.smoother_gap_s)
        for name in ("silence_rate", "smoothing", "share", "position_smoothing", "position_share",
                     "velocity_switch"):
            _positive("EGConfig", name, getattr(self, name), allow_zero=True)
            if getattr(self, name) > 1:
                raise ValueError(f"EGConfig: {name} must be <= 1, got {getattr(self, name)!r}")
        if not isinstance(self.dprtf, DPRTFConfig):
            raise TypeError(f"EGConfig: dprtf must be a DPRTFConfig, got {self.dprtf!r}")


class CGMMLocalizer(Localizer):
    """Common part of the CGMM localizers: DP-RTF (or PRP) features and the mixture means.

    Subclasses define :meth:`_update` (how the weights follow the frame's likelihood ratios).
    Their ``Config`` must have ``variance``, ``silence_rate``, ``smoothing``,
    ``min_features`` and ``dprtf``.

    Set :attr:`keep_presence` to also keep, after each :meth:`process`, the weights ``w_t``
    of its frames in :attr:`presence` ``(T, D)``: for a map that is not ``w_t`` itself (the
    position weights of :class:`DPRTFEGFast`), the thesis's map of the same run.
    """

    #: keep ``w_t`` of every frame of the last :meth:`process` in :attr:`presence`
    keep_presence: bool = False
    #: ``(T, D)`` weights ``w_t`` of the last :meth:`process`'s frames (with keep_presence)
    presence: np.ndarray | None = None

    def _setup(self) -> None:
        freqs = self.stft_config.freqs_hz
        h = transfer_functions(self.array, self.grid, freqs, self.fs)
        # (I-1, F, D): boolean indexing with a feature mask (I-1, F) gives (K, D)
        self._means = np.ascontiguousarray(dprtf_means(h, self.config.dprtf.phase_only))
        #: :func:`density_coefficients` of the means, once, in single precision, one row per
        #: (pair, bin) in the order of a feature mask's ``flatnonzero``: (R, 3, D)
        coef = density_coefficients(self._means, self.config.variance)
        self._coef32 = coef.astype(np.float32).reshape(-1, 3, coef.shape[-1])
        #: True: the compiled densities (:mod:`avtrack.localize._density_kernel`)
        self._compiled = _density_kernel.available()
        self._estimator = DPRTFEstimator(
            self.n_channels, self.stft_config.n_freqs, freqs, self.config.dprtf
        )

    def evidence(self, n_observations: np.ndarray) -> np.ndarray:
        """Frames with at least ``min_features`` features (and one): the frames whose features
        updated the weights; in the others the map only relaxes to uniform (``silence_rate``)."""
        n = np.asarray(n_observations)
        return n >= max(int(self.config.min_features), 1)

    def _reset_state(self) -> None:
        self._estimator.reset()
        self.weights = np.full(self.grid.size, 1.0 / self.grid.size)  #: current w_t (D,)

    def _process_stft(self, spec: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        cfg = self.config
        t_ = spec.shape[2]
        out = np.empty((t_, self.grid.size))
        n_obs = np.zeros(t_, dtype=np.int64)
        w = self.weights
        kept = np.empty((t_, self.grid.size)) if self.keep_presence else None
        for t in range(t_):
            values, valid = self._estimator.step(spec[:, :, t])
            k = int(np.count_nonzero(valid))
            dens = None
            if k and k >= cfg.min_features:
                dens = self._densities(values, valid)
            w, out[t] = self._frame(w, dens)
            n_obs[t] = k
            if kept is not None:
                kept[t] = w
        self.weights = w
        self.presence = kept
        return out, n_obs

    def _densities(self, values: np.ndarray, valid: np.ndarray) -> np.ndarray:
        """:func:`densities_from_coefficients` of the frame's valid features, in single
        precision (:mod:`avtrack.localize._density_kernel`): ``values`` and ``valid``
        ``(I-1, F)`` as the DP-RTF estimator gives them; returns ``(K, D)`` float32."""
        rows = np.flatnonzero(valid)
        f = values.ravel()[rows]
        n_dirs = self._coef32.shape[-1]
        out = np.empty((rows.size, n_dirs), dtype=np.float32)
        kern = _density_kernel.kernel() if self._compiled else None
        form = _density_kernel.densities_numpy if kern is None else kern
        form(np.ascontiguousarray(f.real), np.ascontiguousarray(f.imag), rows, self._coef32, out,
             np.empty(n_dirs, dtype=np.int32))
        return out

    def _frame(
        self, weights: np.ndarray, dens: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """One frame of the recursion: ``(w_t, heat map)`` from ``w_{t-1}`` ``(D,)`` and the
        frame's :func:`cgmm_densities` ``(K, D)`` (None: too few features, relax to uniform)."""
        cfg = self.config
        if dens is None:
            w = decay_to_uniform(weights, cfg.silence_rate)
        else:
            w = self._update(weights, mean_ratios(dens, weights))
        w = spatial_smoothing(w, self.grid, cfg.smoothing)
        return w, self._emit(w, dens)

    def _emit(self, weights: np.ndarray, dens: np.ndarray | None) -> np.ndarray:
        """The heat map of a frame from ``w_t`` and the frame's :func:`cgmm_densities`
        ``(K, D)`` (None: too few features); by default the weights themselves."""
        return weights

    @abstractmethod
    def _update(self, weights: np.ndarray, ratios: np.ndarray) -> np.ndarray:
        """New weights ``(D,)`` from ``w_{t-1}`` and the frame's mean likelihood ratio ``(D,)``
        (:func:`mean_ratios`)."""


@register_localizer("dprtf-eg")
class DPRTFEG(CGMMLocalizer):
    """DPRTF-EG: online DP-RTF features, CGMM, exponentiated gradient (thesis §5.2–5.3).

    See the module docstring for the model (eqs. 5.12–5.19). Heat maps are the weights
    ``w_t`` ``(D,)`` after each frame (positive, summing to one), or with
    ``EGConfig.position_step`` set, the position weights' peaks carrying the local mass of
    ``w_t`` (:func:`place_presence`; non-negative, summing to about one).
    """

    Config: ClassVar[type] = EGConfig
    default_threshold: ClassVar[float] = 0.03

    def _drift_per_frame(self) -> np.ndarray:
        """Azimuth cells each velocity layer moves a frame ``(U,)`` (one layer at 0 without
        ``position_velocities_deg_s``)."""
        vel = self.config.position_velocities_deg_s
        if self.config.position_step is None or vel is None:
            return np.zeros(1)
        az = self.grid.azimuth_values
        step_deg = 360.0 / az.size if self.grid.circular else (
            float(np.min(np.diff(az))) if az.size > 1 else 1.0)
        cells = np.asarray(vel) * self.stft_config.frame_period_s / step_deg
        if np.any(np.abs(cells) > 1.0):
            raise ValueError(
                f"{type(self).__name__}: position_velocities_deg_s must move at most one "
                f"azimuth cell ({step_deg:g} deg) a frame, got {vel!r}"
            )
        return cells

    def _reset_state(self) -> None:
        super()._reset_state()
        self._heat = self.weights.copy()
        self._drift_cells = self._drift_per_frame()
        u_ = self._drift_cells.size
        #: random walk of each layer (U, 1): the still layer's may be its own
        walk = np.full(u_, self.config.position_smoothing)
        if self.config.still_smoothing is not None:
            walk[self._drift_cells == 0] = self.config.still_smoothing
        self._walk = walk[:, None]
        #: the velocity switch's destination shares (U, 1), or None: the other layers equally
        self._switch_to: np.ndarray | None = None
        still = self._drift_cells == 0
        if self.config.still_prior is not None and still.any() and not still.all():
            self._switch_to = np.where(still, self.config.still_prior / np.count_nonzero(still),
                                       (1.0 - self.config.still_prior) / np.count_nonzero(~still)
                                       )[:, None]
        #: position weights per velocity layer v_{u,t} (U, D)
        self.position_layers = np.full((u_, self.grid.size), 1.0 / (u_ * self.grid.size))
        self.position = self.weights.copy()  #: position weights v_t (D,)
        #: the fixed-lag smoother of the layers, or None (a causal map)
        self._smoother: FixedLagSmoother | None = None
        # P^T's coefficients (U, 1, 1): the walk (None: none), the share of each cell kept by
        # the drift's transpose and those taken from the previous / next azimuth (None: none)
        cells = -self._drift_cells[:, None, None]  # the drift's transpose: the other way
        self._circular = self.grid.circular
        self._backward_coefficients = (
            self._walk[:, :, None] if np.any(self._walk) else None,
            1.0 - np.abs(cells),
            np.where(cells > 0, cells, 0.0) if np.any(cells > 0) else None,
            np.where(cells < 0, -cells, 0.0) if np.any(cells < 0) else None,
        )
        self._held_counts: list[int] = []  # feature counts of the frames the smoother holds
        if self.config.smoother_lag_s is not None:
            period = self.stft_config.frame_period_s
            self._smoother = FixedLagSmoother(
                self.latency_frames, max(round(self.config.smoother_gap_s / period), 1),
                self._predict_layers_transposed)

    @property
    def latency_frames(self) -> int:
        lag = self.config.smoother_lag_s
        return 0 if lag is None else round(lag / self.stft_config.frame_period_s)

    def _update(self, weights: np.ndarray, ratios: np.ndarray) -> np.ndarray:
        cfg = self.config
        step = cfg.step
        if cfg.step_boost:
            step *= 1.0 + cfg.step_boost * evidence_change(weights, ratios)
        w = eg_update(weights, ratios, step, cfg.entropy)
        if cfg.share:
            w = decay_to_uniform(w, cfg.share)  # fixed share (Herbster & Warmuth 1998)
        return w

    def _position_walk(self, dens: np.ndarray | None) -> np.ndarray:
        """``v_t`` from ``v_{t-1}``: eqs. 5.17-5.19 with the step ``eta_v``, a fixed share and
        the random walk."""
        cfg = self.config
        v = self.position
        if dens is None:
            v = decay_to_uniform(v, cfg.silence_rate)
        else:
            v = eg_update(v, mean_ratios(dens, v), cfg.position_step, cfg.entropy)
            v = decay_to_uniform(v, cfg.position_share)
        return spatial_smoothing(v, self.grid, cfg.position_smoothing)

    def _position_step(
        self, dens: np.ndarray | None, presence: np.ndarray | None = None
    ) -> np.ndarray:
        """``v_t = sum_u v_{u,t}`` from the velocity layers ``v_{u,t-1}`` ``(U, D)``: eqs.
        5.17-5.19 on the layers (:func:`eg_update_layers`) and a fixed share, then each
        layer's prediction (:func:`drift` at its velocity, the random walk) and the velocity
        switch. With the smoother, the updated layers, the prediction they came from and the
        frame's ``w_t`` (``presence``) go to it."""
        cfg = self.config
        predicted = self.position_layers
        n_cells = predicted.size
        if dens is None:
            layers = (1.0 - cfg.silence_rate) * predicted + cfg.silence_rate / n_cells
        else:
            ratios = mean_ratios(dens, predicted.sum(axis=0))
            layers = eg_update_layers(predicted, ratios, cfg.position_step, cfg.entropy)
            layers = (1.0 - cfg.position_share) * layers + cfg.position_share / n_cells
        if self._smoother is not None:
            self._smoother.add(layers, predicted, dens is not None,
                               (self.weights if presence is None else presence,))
        self.position_layers = self._predict_layers(layers)
        return self.position_layers.sum(axis=0)

    def _predict_layers(self, layers: np.ndarray) -> np.ndarray:
        """The prediction ``P`` of the velocity layers ``(U, D)``: each layer's :func:`drift`
        at its velocity, the random walk, the velocity switch."""
        cfg = self.config
        # each layer: drift at its velocity, then the random walk (spatial_smoothing of each
        # row, all rows at once)
        layers = drift(layers, self.grid, self._drift_cells)
        prev, nxt, has_prev, has_next = self.grid.azimuth_neighbours
        coef = self._walk
        if np.any(coef):
            walked = layers + coef * (layers[:, prev] * has_prev + layers[:, nxt] * has_next)
            scale = layers.sum(axis=1) / np.maximum(walked.sum(axis=1), _TINY)
            layers = walked * scale[:, None]
        u_ = layers.shape[0]
        if u_ > 1 and cfg.velocity_switch:
            rho = cfg.velocity_switch
            if self._switch_to is None:  # to the other layers equally
                layers = (1.0 - rho) * layers + rho * (layers.sum(axis=0) - layers) / (u_ - 1)
            else:  # spread by the layers' stationary shares
                layers = (1.0 - rho) * layers + rho * self._switch_to * layers.sum(axis=0)
        return layers

    def _predict_layers_transposed(self, x: np.ndarray) -> np.ndarray:
        """``P^T x`` for :meth:`_predict_layers` on ``(..., U, D)`` arrays (the backward
        recursion of :class:`~avtrack.localize.fixed_lag.FixedLagSmoother`): the switch's
        transpose, the random walk (symmetric; its normalisation taken as ``1 / (1 + 2 c)``,
        exact on a circular azimuth grid), the drift at the opposite velocity. The azimuth
        neighbours are taken by slicing the ``(elevation, azimuth)`` layout of the grid."""
        cfg = self.config
        u_ = x.shape[-2]
        rho = cfg.velocity_switch
        if u_ > 1 and rho:
            if self._switch_to is None:
                total = x.sum(axis=-2, keepdims=True)
                x = (1.0 - rho) * x + rho * (total - x) / (u_ - 1)
            else:
                x = (1.0 - rho) * x + rho * (self._switch_to * x).sum(axis=-2, keepdims=True)
        grid = self.grid
        y = x.reshape(*x.shape[:-1], grid.n_elevations, grid.n_azimuths)
        walk, keep, from_prev, from_next = self._backward_coefficients
        circular = self._circular
        if walk is not None:
            y = (y + walk * (_from_previous(y, circular) + _from_next(y, circular))) / (
                1.0 + 2.0 * walk)
        out = keep * y
        if from_prev is not None:
            out += from_prev * _from_previous(y, circular)
        if from_next is not None:
            out += from_next * _from_next(y, circular)
        return out.reshape(x.shape)

    def _emit(self, weights: np.ndarray, dens: np.ndarray | None) -> np.ndarray:
        cfg = self.config
        if cfg.position_step is None:
            return self._hold(weights, dens is not None)
        if cfg.position_velocities_deg_s is None:
            v = self._position_walk(dens)
        else:
            v = self._position_step(dens, weights)
        self.position = v
        if self._smoother is not None:
            return v  # not the map: that comes from the smoother (_process_stft)
        return self._hold(self._place(v, weights), dens is not None)

    def _place(self, position: np.ndarray, presence: np.ndarray) -> np.ndarray:
        """The heat map of position weights ``v`` and thesis weights ``w`` (both ``(D,)``):
        ``v``'s peaks carrying ``w``'s local mass."""
        cfg = self.config
        place = place_presence_by_peak if cfg.presence_by_peak else place_presence
        heat = place(position, presence, self.grid, cfg.presence_reach)
        return snap_to_presence(heat, position, presence, self.grid, cfg.snap_reach)

    def _hold(self, heat: np.ndarray, evidence: bool) -> np.ndarray:
        """The map of a frame from its ``heat`` ``(D,)``: itself, or with
        ``output_silence_rate`` and no evidence, the last map relaxed towards uniform."""
        rate = self.config.output_silence_rate
        if rate is None:
            return heat
        self._heat = heat if evidence else decay_to_uniform(self._heat, rate)
        return self._heat

    def _process_stft(self, spec: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if self._smoother is None:
            return super()._process_stft(spec)
        _, n_obs = super()._process_stft(spec)  # the filter; its frames go to the smoother
        self._held_counts.extend(n_obs.tolist())
        return self._smoothed(final=False)

    def _flush(self) -> tuple[np.ndarray, np.ndarray]:
        if self._smoother is None:
            return super()._flush()
        return self._smoothed(final=True)

    def _smoothed(self, final: bool) -> tuple[np.ndarray, np.ndarray]:
        """The maps ``(n, D)`` and feature counts ``(n,)`` of the frames the smoother gives
        now (:meth:`FixedLagSmoother.ready`); with ``keep_presence``, their ``w_t`` in
        :attr:`presence`."""
        if self._smoother is None:
            raise RuntimeError(f"{type(self).__name__}: no smoother (smoother_lag_s is None)")
        layers, extra = self._smoother.ready(final)
        n = len(extra)
        counts = np.asarray(self._held_counts[:n], dtype=np.int64)
        del self._held_counts[:n]
        evidence = self.evidence(counts)
        heat = np.empty((n, self.grid.size))
        for t in range(n):
            heat[t] = self._hold(self._place(layers[t].sum(axis=0), extra[t][0]), evidence[t])
        if self.keep_presence:
            self.presence = (np.asarray([e[0] for e in extra]) if n
                             else np.zeros((0, self.grid.size)))
        return heat, counts


@dataclass(frozen=True)
class FastEGConfig(EGConfig):
    """:class:`EGConfig` with the position weights on (``position_step = 0.3``, share 0.01,
    presence reach 3 cells) in five velocity layers (-60, -30, 0, 30 and 60 degrees per
    second) with a random walk of 0.07 a cell a frame.

    A random walk alone must be wide to let the peaks follow a moving talker (0.4 a cell a
    frame keeps a talker walking at 30 degrees per second within 10 frames), and so wide a
    walk blurs talkers close to each other into one peak between them: on a real 4.6 cm
    array, two talkers 45 degrees apart were each placed 5-8 degrees towards the other. The
    velocity layers follow the walking talker within a few frames with a walk of 0.07, which
    keeps such talkers apart (chosen between 0.05 and 0.1 on development seeds of the
    simulated scenes and the shared real recordings: BENCHMARKS.md, acoustic localization,
    real microphone-array recordings).
    """

    position_step: float | None = 0.3
    position_smoothing: float = 0.07
    position_velocities_deg_s: tuple[float, ...] | None = (-60.0, -30.0, 0.0, 30.0, 60.0)


@register_localizer("dprtf-eg-fast")
class DPRTFEGFast(DPRTFEG):
    """DPRTF-EG whose heat-map peaks follow a moving talker (not in the thesis).

    The thesis weights ``w_t`` (eqs. 5.15–5.19, :class:`DPRTFEG`) keep their slow memory and
    say *how much* talker there is near each direction; position weights ``v_t``, updated by
    the same eqs. 5.17–5.19 from the same features with a larger step, wider spatial
    smoothing and a fixed share, say *where*. The heat map is :func:`place_presence`:
    ``v_t``'s peaks carrying ``w_t``'s local mass (non-negative, summing to about one; peaks
    as wide as ``v_t``'s). See :class:`FastEGConfig`.
    """

    Config: ClassVar[type] = FastEGConfig


@dataclass(frozen=True)
class StaticEGConfig(FastEGConfig):
    """:class:`FastEGConfig` for talkers who stay in place: the zero-velocity layer's random
    walk is 0.03 a cell a frame (``still_smoothing``), and in frames without enough features
    the heat map relaxes from the last map with evidence at 0.02 a frame
    (``output_silence_rate``) while the weights keep the thesis's relaxation.

    The fast map's walk of 0.07 lets the layers' mass drift from a standing talker towards a
    neighbour, and a talker's peak is pulled towards the other (real 4-mic recordings, talkers
    45 degrees apart: 4-8 degrees). The thesis relaxes the weights only when a frame has no
    feature at all; here a frame with fewer than ``min_features`` counts as silent, which in
    real speech includes the gaps between words (about half the frames of the shared
    recordings): at 0.065 a frame a peak halves in 80 ms and the map loses a talker between
    words; the map held at 0.02 halves in 0.27 s, about the hangover of a speech activity
    detector. (Relaxing the weights themselves that slowly keeps stray peaks alive as well:
    one talker on a 4.6 cm 8-microphone circle then gave duplicate tracks.) The cost: the
    still layer keeps mass behind a talker who walks, so trackers on these maps trail moving
    talkers (BENCHMARKS.md, acoustic tracking).
    """

    output_silence_rate: float | None = 0.02
    still_smoothing: float | None = 0.03


@register_localizer("dprtf-eg-static")
class DPRTFEGStatic(DPRTFEGFast):
    """:class:`DPRTFEGFast` for talkers who stay in place (seated meetings, talkers at fixed
    positions around a robot or a smart speaker): see :class:`StaticEGConfig`. Not in the
    thesis."""

    Config: ClassVar[type] = StaticEGConfig


@dataclass(frozen=True)
class SmoothEGConfig(FastEGConfig):
    """:class:`FastEGConfig` read 0.2 s late through a fixed-lag smoother
    (``smoother_lag_s``; the smoothing stops at pauses of 80 ms or more, ``smoother_gap_s``),
    with the zero-velocity layer's random walk at 0.03 a cell a frame (``still_smoothing``)
    and, in frames without enough features, the map relaxing from the last map with evidence
    at 0.04 a frame (``output_silence_rate``; a peak halves in 0.14 s, within the 0.2 s
    hangover of a speech activity detector).

    The fast map's walk of 0.07 lets a standing talker's mass drift towards a neighbour (real
    4-mic recordings, talkers 45 degrees apart: peaks 4-8 degrees towards the other); a
    smaller walk keeps them apart but trails a talker who walks, since the filter's map of a
    frame knows only the frames before it. Read 0.2 s late, the map of a frame also knows
    where the talker went next: a talker walking steadily at 30 degrees per second is trailed
    by 18 frames instead of 33 (the fast map: 2), which the trackers' 0.15 s lead covers
    (BENCHMARKS.md, acoustic localization and tracking: real recordings and simulated
    LOCATA-like scenes).
    """

    still_smoothing: float | None = 0.03
    output_silence_rate: float | None = 0.04
    smoother_lag_s: float | None = 0.2


@register_localizer("dprtf-eg-smooth")
class DPRTFEGSmooth(DPRTFEGFast):
    """:class:`DPRTFEGFast` smoothed over the next 0.2 s: each frame's heat map comes 0.2 s
    after the frame (:attr:`latency_frames`; :meth:`flush` gives the last ones). See
    :class:`SmoothEGConfig` and :mod:`avtrack.localize.fixed_lag`. Not in the thesis."""

    Config: ClassVar[type] = SmoothEGConfig
