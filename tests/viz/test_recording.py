"""The report of a recording: over its own frames, or over a plain canvas without them."""

from __future__ import annotations

import numpy as np

from avtrack.io.mot import MOTData
from avtrack.io.rttm import RTTMSegment
from avtrack.viz.recording import write_recording_report
from avtrack.viz.video import h264_available


def test_tracks_from_detections_alone_are_reported_over_a_plain_canvas(tmp_path):
    import cv2

    frames = np.arange(1, 11)
    tracks = MOTData(frames, np.ones(10), [[20.0 + 4 * k, 30, 30, 40] for k in range(10)],
                     np.ones(10))  # fmt: skip
    speech = [RTTMSegment("rec", 0.2, 0.4, "P1")]
    page = write_recording_report(tmp_path / "out", "detections", tracks, None, (160, 120),
                                  10.0, 10, speech=speech)  # fmt: skip
    text = page.read_text()
    assert "a plain canvas" in text and "who speaks when" in text
    assert "data:video/webm" in text and ("data:video/mp4" in text) == h264_available()
    cap = cv2.VideoCapture(str(tmp_path / "out" / "tracks.webm"))
    n = 0
    while cap.read()[0]:
        n += 1
    cap.release()
    assert n == 10
    assert (tmp_path / "out" / "tracks.mp4").is_file() == h264_available()
