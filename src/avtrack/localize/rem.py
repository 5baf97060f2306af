"""Recursive-EM baselines: PRP-REM and DPRTF-REM (thesis §5.5.1, after Schwartz & Gannot [131]).

The same complex Gaussian mixture over candidate directions as DPRTF-EG
(:mod:`avtrack.localize.cgmm_eg`, eq. 5.12), with the weights updated by recursive
expectation-maximisation instead of exponentiated gradient: the E-step posteriors of the
frame's features under ``w_{t-1}``, averaged over the features, are blended into the weights
with the update factor ``alpha`` (0.065 in the thesis),

.. math::

    w_{t,d} = (1 - \\alpha) w_{t-1,d} + \\alpha \\frac{1}{|C_t|} \\sum_{\\hat c \\in C_t}
        \\frac{w_{t-1,d} \\mathcal N_c(\\hat c; c^d, \\sigma^2)}
             {\\sum_{d'} w_{t-1,d'} \\mathcal N_c(\\hat c; c^{d'}, \\sigma^2)}.

There is no entropy regularisation and (by default) no spatial smoothing. Frames without
features relax to uniform as in DPRTF-EG.

- **DPRTF-REM** uses the DP-RTF features of :mod:`avtrack.audio.dprtf` (``Q = 8``).
- **PRP-REM** uses pair-wise relative phase features: the narrow-band (``Q = 1``) estimate of
  the relative transfer function of each microphone to microphone 1, from the same
  noise-reduced PSDs and consistency test, keeping only its phase; the means are the phases
  of the predicted direct-path ratios (thesis §5.5.1: "PRP is ... the CTF with Q = 1").
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from avtrack.audio.dprtf import DPRTFConfig
from avtrack.localize.base import register_localizer
from avtrack.localize.cgmm_eg import CGMMLocalizer, _count, _positive


def rem_update(weights: np.ndarray, ratios: np.ndarray, rate: float) -> np.ndarray:
    """Recursive EM step: ``w_t = (1 - alpha) w_{t-1} + alpha mean_k posterior_k``.

    Parameters
    ----------
    weights : ndarray (D,)
        ``w_{t-1}``, non-negative, summing to one.
    ratios : ndarray (K, D) or (D,)
        :func:`~avtrack.localize.cgmm_eg.cgmm_likelihood_ratios` of the frame's features, so
        that ``weights * ratios[k]`` is feature ``k``'s posterior over directions, or their
        mean over the features (:func:`~avtrack.localize.cgmm_eg.mean_ratios`).
    rate : float
        ``alpha`` in [0, 1].
    """
    r = ratios if ratios.ndim == 1 else ratios.mean(axis=0)
    posterior = weights * r  # E-step, averaged over the features
    return (1.0 - rate) * weights + rate * posterior


@dataclass(frozen=True)
class REMConfig:
    """Parameters of the REM localizers.

    Attributes
    ----------
    variance : float
        ``sigma^2`` of the complex Gaussian components.
    rate : float
        ``alpha``, the REM update factor (0.065 in the thesis).
    silence_rate : float
        Relaxation to uniform in frames without features.
    smoothing : float
        Spatial smoothing coefficient (0: none, as in the thesis's baselines).
    min_features : int
        Frames with fewer features relax to uniform (see :class:`~.cgmm_eg.EGConfig`).
    dprtf : DPRTFConfig
        Feature extraction.
    """

    variance: float = 0.1
    rate: float = 0.065
    silence_rate: float = 0.065
    smoothing: float = 0.0
    min_features: int = 20
    dprtf: DPRTFConfig = field(default_factory=DPRTFConfig)

    def __post_init__(self) -> None:
        _count("REMConfig", "min_features", self.min_features)
        _positive("REMConfig", "variance", self.variance)
        for name in ("rate", "silence_rate", "smoothing"):
            _positive("REMConfig", name, getattr(self, name), allow_zero=True)
            if getattr(self, name) > 1:
                raise ValueError(f"REMConfig: {name} must be <= 1, got {getattr(self, name)!r}")
        if not isinstance(self.dprtf, DPRTFConfig):
            raise TypeError(f"REMConfig: dprtf must be a DPRTFConfig, got {self.dprtf!r}")


def _prp_features() -> DPRTFConfig:
    return DPRTFConfig(ctf_length=1, phase_only=True)


@dataclass(frozen=True)
class PRPREMConfig(REMConfig):
    """:class:`REMConfig` with narrow-band phase features (``ctf_length=1, phase_only=True``)."""

    dprtf: DPRTFConfig = field(default_factory=_prp_features)


class RecursiveEMLocalizer(CGMMLocalizer):
    """A CGMM localizer whose weights follow the recursive-EM update (:func:`rem_update`)."""

    default_threshold: ClassVar[float] = 0.05
    #: the posterior spreads a talker over a fixed angle: 0.05 a 5-degree cell (on the
    #: shared ReSpeaker files a 2.5-degree grid at 0.05 lost 30-100 % of each talker's peaks;
    #: at 0.025, none)
    threshold_cell_deg: ClassVar[float | None] = 5.0

    def _update(self, weights: np.ndarray, ratios: np.ndarray) -> np.ndarray:
        return rem_update(weights, ratios, self.config.rate)


@register_localizer("dprtf-rem")
class DPRTFREM(RecursiveEMLocalizer):
    """DPRTF-REM: DP-RTF features, CGMM, recursive EM weights (thesis §5.5.1 baseline)."""

    Config: ClassVar[type] = REMConfig


@register_localizer("prp-rem")
class PRPREM(RecursiveEMLocalizer):
    """PRP-REM: pair-wise relative phase features, CGMM, recursive EM (thesis §5.5.1)."""

    Config: ClassVar[type] = PRPREMConfig
