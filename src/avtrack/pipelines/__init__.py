"""User paths, one function each, between the library and the command line.

- :func:`localize_recording`: heat maps and their peaks for a microphone-array recording.
- :func:`track_recording`: the speakers of a recording tracked (localizer + VEM tracker).

Each reads its input in blocks and hands its rows to a sink as they come, so memory stays
flat in the recording's length; the command line only parses options, opens files and prints.
"""

from avtrack.pipelines.audio import LocalizeRun, TrackRun, localize_recording, track_recording

__all__ = ["LocalizeRun", "TrackRun", "localize_recording", "track_recording"]
