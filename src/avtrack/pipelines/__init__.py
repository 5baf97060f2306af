"""User paths, one function each, between the library and the command line.

- :func:`localize_recording`: heat maps and their peaks for a microphone-array recording.
- :func:`track_recording`: the speakers of a recording tracked (localizer + VEM tracker).
- :func:`track_mot_sequence`: the people of a MOTChallenge sequence tracked (OVBT), from its
  detections or from a detector run on its video.
- :func:`track_av163`: the speakers of an AV16.3 sequence tracked by an audio-visual SMC-PHD
  filter and scored (OSPA, OSPA-T).

The acoustic paths read their input in blocks and hand their rows to a sink as they come, so
memory stays flat in the recording's length; the command line only parses options, opens
files and prints.

Each path's module is imported when one of its names is first used, so that a command loads
only what its own path needs (the acoustic paths bring SciPy's signal processing, the visual
one does not).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from avtrack.pipelines.audio import (
        LocalizeRun,
        TrackRun,
        localize_recording,
        track_recording,
    )
    from avtrack.pipelines.mot import MOTRun, track_mot_sequence
    from avtrack.pipelines.phd import PHDRun, track_av163

#: Public name -> the module of :mod:`avtrack.pipelines` that defines it.
_MODULE_OF = {
    "LocalizeRun": "audio",
    "TrackRun": "audio",
    "localize_recording": "audio",
    "track_recording": "audio",
    "MOTRun": "mot",
    "track_mot_sequence": "mot",
    "PHDRun": "phd",
    "track_av163": "phd",
}


def __getattr__(name: str) -> Any:
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f"module 'avtrack.pipelines' has no attribute {name!r}")
    return getattr(importlib.import_module(f"avtrack.pipelines.{module}"), name)


__all__ = [
    "LocalizeRun",
    "MOTRun",
    "PHDRun",
    "TrackRun",
    "localize_recording",
    "track_av163",
    "track_mot_sequence",
    "track_recording",
]
