"""Acoustic multi-speaker tracking: speaker directions of arrival over time (thesis ch. 5).

Trackers (registered in :data:`TRACKERS`, CLI ``avtrack track-audio --tracker NAME``):

- ``gauss`` -- :class:`~avtrack.doa.gauss.GaussDOATracker`: Gaussian VEM tracker on
  unit-direction states with candidate directions (by default the heat map's peaks) as
  observations weighted by their localizer weight (thesis §5.4, eqs. 5.20–5.43). Li, Ban,
  Girin, Alameda-Pineda, Horaud,
  "Online localization and tracking of multiple moving speakers in reverberant environments",
  IEEE JSTSP 2019.
- ``vonmises`` -- :class:`~avtrack.doa.vonmises.VonMisesDOATracker`: von Mises VEM
  tracker on circular states (thesis §5.6 and appendix A, eqs. 5.44–5.62). Ban,
  Alameda-Pineda, Evers, Horaud, "Tracking multiple audio sources with the von Mises
  distribution and variational EM", IEEE SPL 2019.

Peer (not registered, not a CLI choice; needs ``stonesoup``):
:class:`~avtrack.doa.gmphd.GMPHDPeer`, Vo & Ma, "The Gaussian mixture probability hypothesis
density filter", IEEE TSP 2006, as implemented by Stone Soup.

The interface (:class:`~avtrack.doa.base.DOATracker`), the observation sequences and the
registry are in :mod:`avtrack.doa.base`; the Gaussian tracker's observation model (eqs.
5.20–5.22) in :mod:`avtrack.doa.model`.
"""

from avtrack.doa.base import (
    FRAME_PERIOD_S,
    TRACKERS,
    DOASequence,
    DOATracker,
    TrackFrame,
    make_tracker,
    register_tracker,
)
from avtrack.doa.gauss import GaussConfig, GaussDOATracker
from avtrack.doa.vonmises import VonMisesConfig, VonMisesDOATracker

__all__ = [
    "FRAME_PERIOD_S",
    "TRACKERS",
    "DOASequence",
    "DOATracker",
    "GaussConfig",
    "GaussDOATracker",
    "TrackFrame",
    "VonMisesConfig",
    "VonMisesDOATracker",
    "make_tracker",
    "register_tracker",
]
