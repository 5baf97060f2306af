"""Frame-wise multiple-source localization stage (thesis ch. 5, §5.2–5.3 and §5.5.1).

Algorithms (registered in :data:`LOCALIZERS`, CLI ``avtrack localize --method NAME``):

- ``dprtf-eg`` -- :class:`~avtrack.localize.cgmm_eg.DPRTFEG`: online DP-RTF features (RLS over
  microphone pairs, thesis eqs. 5.1–5.11, Algorithm 2), complex Gaussian mixture over candidate
  directions, exponentiated-gradient weight updates with entropy regularisation and spatial
  smoothing (eqs. 5.12–5.19). Li, Ban, Girin, Alameda-Pineda, Horaud, "Online localization and
  tracking of multiple moving speakers in reverberant environments", IEEE JSTSP 2019.
- ``dprtf-eg-fast`` -- :class:`~avtrack.localize.cgmm_eg.DPRTFEGFast`: DPRTF-EG whose peaks
  follow a moving talker: position weights with a larger EG step set the peaks' directions,
  the thesis weights their mass (not in the thesis; README, departures).
- ``dprtf-eg-smooth`` (the default, :data:`DEFAULT_LOCALIZER`) --
  :class:`~avtrack.localize.cgmm_eg.DPRTFEGSmooth`: the same map, each frame's read 0.2 s later
  through a fixed-lag forward-backward smoother of the velocity layers
  (:mod:`avtrack.localize.fixed_lag`), so that a small random walk keeps talkers close to each
  other apart without trailing one who walks (not in the thesis).
- ``dprtf-eg-static`` -- :class:`~avtrack.localize.cgmm_eg.DPRTFEGStatic`: the same for
  talkers who stay in place: a sharper still layer keeps neighbouring talkers apart and the
  map held through the gaps between words keeps quiet ones found (not in the thesis).
- ``dprtf-rem`` -- :class:`~avtrack.localize.rem.DPRTFREM`: the same features and mixture with
  recursive-EM weights (Li et al., [81] of the thesis).
- ``prp-rem`` -- :class:`~avtrack.localize.rem.PRPREM`: pair-wise relative phase features with
  recursive EM (Schwartz & Gannot, "Speaker tracking using recursive EM algorithms", IEEE/ACM
  TASLP 2014).
- ``srp-phat`` -- :class:`~avtrack.localize.srp.SRPPHAT`: steered response power with phase
  transform, recursively smoothed (DiBiase, Silverman, Brandstein 2001).

Candidate directions and predicted features: :mod:`avtrack.localize.grid`; peak selection:
:mod:`avtrack.localize.peaks`; evaluation: :mod:`avtrack.metrics.doa`.
"""

from avtrack.localize.base import (
    DEFAULT_LOCALIZER,
    LOCALIZERS,
    HeatMaps,
    Localizer,
    localize,
    make_localizer,
    register_localizer,
)
from avtrack.localize.cgmm_eg import (
    DPRTFEG,
    DPRTFEGFast,
    DPRTFEGSmooth,
    EGConfig,
    FastEGConfig,
    SmoothEGConfig,
)
from avtrack.localize.grid import DirectionGrid
from avtrack.localize.peaks import find_peaks, local_maxima, peak_table
from avtrack.localize.rem import DPRTFREM, PRPREM, PRPREMConfig, REMConfig
from avtrack.localize.srp import SRPPHAT, SRPConfig

__all__ = [
    "DEFAULT_LOCALIZER",
    "DPRTFEG",
    "DPRTFREM",
    "LOCALIZERS",
    "PRPREM",
    "SRPPHAT",
    "DPRTFEGFast",
    "DPRTFEGSmooth",
    "DirectionGrid",
    "EGConfig",
    "FastEGConfig",
    "HeatMaps",
    "Localizer",
    "PRPREMConfig",
    "REMConfig",
    "SRPConfig",
    "SmoothEGConfig",
    "find_peaks",
    "local_maxima",
    "localize",
    "make_localizer",
    "peak_table",
    "register_localizer",
]
