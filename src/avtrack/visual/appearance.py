r"""Appearance likelihoods: colour histograms (thesis eq. 3.5) or embeddings.

Each returns, for ``M`` observed descriptors and ``N`` reference descriptors, the log ratio
:math:`\log b(h_m; h_n) - \log u(h_m)` of the target's appearance density to the clutter's
(uniform) one: appearance enters the E-Z step (eq. 3.21) as a multiplicative factor and the
clutter class gets :math:`u(h)`, so only the ratio matters.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np


class AppearanceLikelihood(ABC):
    """Log-likelihood ratio of observed to reference descriptors."""

    @abstractmethod
    def log_ratio(self, observed: np.ndarray, reference: np.ndarray) -> np.ndarray:
        """``(M, F), (N, F) -> (M, N)``."""

    @abstractmethod
    def normalize(self, descriptors: np.ndarray) -> np.ndarray:
        """Put descriptors ``(K, F)`` in the form :meth:`log_ratio` expects."""


@dataclass(frozen=True)
class BhattacharyyaAppearance(AppearanceLikelihood):
    r"""Bhattacharyya appearance model (thesis eq. 3.5).

    :math:`b(h_m; h_n) = W_\lambda^{-1}\exp(-\lambda\, d_B(h_m, h_n))` with the Bhattacharyya
    distance :math:`d_B = \sqrt{1 - \sum_k \sqrt{h_{mk} h_{nk}}}` between normalised
    histograms. The constants :math:`W_\lambda` and :math:`u(h)` are folded into
    ``neutral_distance`` :math:`d_0`: the log ratio is :math:`-\lambda (d_B - d_0)`, so a
    descriptor at distance :math:`d_0` is as likely under the target as under clutter.

    Parameters
    ----------
    lam : float
        Skewness :math:`\lambda > 0`.
    neutral_distance : float
        :math:`d_0 \in (0, 1)`.
    """

    lam: float = 10.0
    neutral_distance: float = 0.4

    def __post_init__(self) -> None:
        if not self.lam > 0:
            raise ValueError(f"BhattacharyyaAppearance: lam must be > 0, got {self.lam}")
        if not 0 < self.neutral_distance < 1:
            raise ValueError("BhattacharyyaAppearance: neutral_distance must be in (0, 1), "
                             f"got {self.neutral_distance}")

    def normalize(self, descriptors: np.ndarray) -> np.ndarray:
        h = np.asarray(descriptors, dtype=float)
        if np.any(h < 0):
            raise ValueError("colour histograms must be non-negative")
        s = h.sum(axis=1, keepdims=True)
        return np.divide(h, s, out=np.full_like(h, 1.0 / max(h.shape[1], 1)), where=s > 0)

    def log_ratio(self, observed: np.ndarray, reference: np.ndarray) -> np.ndarray:
        bc = np.sqrt(observed) @ np.sqrt(reference).T  # Bhattacharyya coefficient
        d_b = np.sqrt(np.clip(1.0 - bc, 0.0, 1.0))
        return -self.lam * (d_b - self.neutral_distance)  # log b - log u, eq. 3.5


@dataclass(frozen=True)
class CosineAppearance(AppearanceLikelihood):
    r"""Embedding appearance model: :math:`\log b - \log u = \kappa(\cos(h_m, h_n) - c_0)`.

    A von Mises–Fisher density on the unit sphere around the reference embedding, with the
    normaliser and the clutter density folded into the neutral similarity :math:`c_0`.
    """

    kappa: float = 10.0
    neutral_similarity: float = 0.5

    def __post_init__(self) -> None:
        if not self.kappa > 0:
            raise ValueError(f"CosineAppearance: kappa must be > 0, got {self.kappa}")
        if not -1 < self.neutral_similarity < 1:
            raise ValueError("CosineAppearance: neutral_similarity must be in (-1, 1), "
                             f"got {self.neutral_similarity}")

    def normalize(self, descriptors: np.ndarray) -> np.ndarray:
        e = np.asarray(descriptors, dtype=float)
        n = np.linalg.norm(e, axis=1, keepdims=True)
        return np.divide(e, n, out=np.zeros_like(e), where=n > 0)

    def log_ratio(self, observed: np.ndarray, reference: np.ndarray) -> np.ndarray:
        return self.kappa * (observed @ reference.T - self.neutral_similarity)


APPEARANCE_MODELS: dict[str, Callable[[float], AppearanceLikelihood]] = {
    "bhattacharyya": BhattacharyyaAppearance,
    "cosine": CosineAppearance,
}


def init_appearance_model(
    model: Any,
    log_clutter_density: float,
    appearance: AppearanceLikelihood | None,
    appearance_update: float,
) -> None:
    """Set the attributes every observation model with appearance shares, checked: the clutter
    log-density, the appearance likelihood (eq. 3.5), the reference update rate in [0, 1] and
    no reference yet (``references (N, F)`` once targets exist)."""
    if not np.isfinite(log_clutter_density):
        raise ValueError(f"log_clutter_density must be finite, got {log_clutter_density}")
    if not 0.0 <= appearance_update <= 1.0:
        raise ValueError(f"appearance_update must be in [0, 1], got {appearance_update}")
    model.log_clutter_density = float(log_clutter_density)
    model.appearance = appearance
    model.appearance_update = float(appearance_update)
    model.references = None
