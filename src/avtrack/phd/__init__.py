"""Audio-visual SMC-PHD filters with particle flow (Liu et al., "Labelled non-zero particle
flow for SMC-PHD filtering"; section, equation and table numbers below are that paper's).

- :class:`~avtrack.phd.npf.NPFSMCPHD` (``"npf"``) — AV-NPF-SMC-PHD, the baseline: non-zero
  diffusion particle flow (eqs. 6–10) with k-means clustering (ref. [9] of Liu et al.).
- :class:`~avtrack.phd.lpf.LPFSMCPHD` (``"lpf"``) — AV-LPF-SMC-PHD: labelled particle flow
  (eqs. 13–25), no clustering.

Shared pieces: :mod:`~avtrack.phd.smc_phd` (prediction, birth, PHD update, ESS, resampling),
:mod:`~avtrack.phd.flow` (the flow and its Jacobian determinants),
:mod:`~avtrack.phd.likelihood` (visual and DOA-line kernels, measurement fusion, AV16.3
measurements), :mod:`~avtrack.phd.base` (config, results, registry).
"""

from avtrack.phd.base import PHD_FILTERS, PHDConfig, PHDEstimate, PHDFilter, PHDResult
from avtrack.phd.likelihood import (
    AVFrame,
    SyntheticFaceDetector,
    av163_frames,
    doa_lines,
    face_measurements,
    make_frame,
)
from avtrack.phd.lpf import LPFSMCPHD
from avtrack.phd.npf import NPFSMCPHD

__all__ = [
    "LPFSMCPHD",
    "NPFSMCPHD",
    "PHD_FILTERS",
    "AVFrame",
    "PHDConfig",
    "PHDEstimate",
    "PHDFilter",
    "PHDResult",
    "SyntheticFaceDetector",
    "av163_frames",
    "doa_lines",
    "face_measurements",
    "make_frame",
]
