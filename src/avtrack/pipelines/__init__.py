"""User paths, one function each, between the library and the command line.

- :func:`localize_recording`: heat maps and their peaks for a microphone-array recording.
- :func:`track_recording`: the speakers of a recording tracked (localizer + VEM tracker).
- :func:`track_mot_sequence`: the people of a MOTChallenge sequence tracked (OVBT), from its
  detections or from a detector run on its video.
- :func:`track_av163`: the speakers of an AV16.3 sequence tracked by an audio-visual SMC-PHD
  filter and scored (OSPA, OSPA-T).
- :func:`track_scene_direction`, :func:`track_scene_image`, :func:`track_av163_sequence`,
  :func:`track_own_recording`: persons tracked and diarized from a camera and a microphone
  array (``avtrack track-av``): a simulated scene directory in the array's direction space or
  on the image plane (VAVIT), an AV16.3 sequence, a recording of one's own.
- :func:`run_demo_meeting`: ``avtrack demo``'s simulated meeting, tracked, diarized,
  localized and scored.

The acoustic paths read their input in blocks and hand their rows to a sink as they come, so
memory stays flat in the recording's length (a recording of one's own is localized block by
block too); the command line only parses options, opens files and prints.

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
    from avtrack.pipelines.av import (
        AV163Run,
        AVRun,
        ImageRun,
        track_av163_sequence,
        track_scene_direction,
        track_scene_image,
    )
    from avtrack.pipelines.av_recording import RecordingInputs, RecordingRun, track_own_recording
    from avtrack.pipelines.demo import DemoRun, run_demo_meeting
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
    "AVRun": "av",
    "ImageRun": "av",
    "AV163Run": "av",
    "track_scene_direction": "av",
    "track_scene_image": "av",
    "track_av163_sequence": "av",
    "RecordingInputs": "av_recording",
    "RecordingRun": "av_recording",
    "track_own_recording": "av_recording",
    "DemoRun": "demo",
    "run_demo_meeting": "demo",
}


def __getattr__(name: str) -> Any:
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f"module 'avtrack.pipelines' has no attribute {name!r}")
    return getattr(importlib.import_module(f"avtrack.pipelines.{module}"), name)


__all__ = [
    "AV163Run",
    "AVRun",
    "DemoRun",
    "ImageRun",
    "LocalizeRun",
    "MOTRun",
    "PHDRun",
    "RecordingInputs",
    "RecordingRun",
    "TrackRun",
    "localize_recording",
    "run_demo_meeting",
    "track_av163",
    "track_av163_sequence",
    "track_mot_sequence",
    "track_own_recording",
    "track_recording",
    "track_scene_direction",
    "track_scene_image",
]
