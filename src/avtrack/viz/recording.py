"""The report of a real recording: ``index.html`` beside ``tracks.txt``, ``persons.csv`` and
``speech.rttm``, with the tracks drawn over the recording's own video.

Used by ``avtrack track-av`` (a recording of one's own, or an AV16.3 sequence) and by
``avtrack track-mot --report`` (visual tracking of a video). The page holds the scores there
are (none without ground truth), the persons' directions over time, who speaks when, and a video
of the real frames with the boxes, identities and speaking status drawn in: ``tracks.mp4``
(H.264, where PyAV has the encoder) and ``tracks.webm`` (VP8), written in one pass. Without the
recording's frames (tracks from a detections file alone) they are drawn over a plain canvas.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

import numpy as np

from avtrack.io.mot import MOTData
from avtrack.io.rttm import RTTMSegment
from avtrack.viz import report
from avtrack.viz.video import h264_available, render_overlay_video


def write_recording_report(
    out: str | Path,
    title: str,
    tracks: MOTData,
    frames: Iterable[np.ndarray] | None,
    image_size: tuple[int, int],
    fps: float,
    n_frames: int,
    *,
    speaking: np.ndarray | None = None,
    persons=None,
    speech: Sequence[RTTMSegment] = (),
    reference: Sequence[RTTMSegment] = (),
    gt: MOTData | None = None,
    scores: Mapping[str, float] | None = None,
    notes: Sequence[str] = (),
    quiet: bool = True,
) -> Path:
    """Write ``out/index.html``, ``out/tracks.webm`` and, where :func:`avtrack.viz.video.
    h264_available`, ``out/tracks.mp4`` (tracks over the real frames).

    Parameters
    ----------
    out : str or Path
        The output folder (created if needed).
    title : str
    tracks : MOTData
        Boxes ``(left, top, width, height)`` in the video's pixels, 1-based frames.
    frames : iterable of ndarray (height, width, 3) uint8, or None
        The video's BGR frames ``1 .. n_frames``, read one at a time (once); None: the
        tracks are drawn over a plain canvas of ``image_size`` (tracks from detections
        without the video).
    image_size : (int, int)
        The video's ``(width, height)``.
    fps : float
    n_frames : int
    speaking : ndarray (len(tracks),) bool, optional
        Whether each box's person speaks at that frame.
    persons : PersonsTable, optional
        Every tracked person every frame: their directions are plotted, and those without a
        box are drawn in the video as a ring at their pixel or an arrow at the image edge.
    speech : sequence of RTTMSegment
        The speaker turns found.
    reference : sequence of RTTMSegment
        True speaker turns, when known (drawn above the turns found).
    gt : MOTData, optional
        Ground-truth boxes: outlined in thin grey in the video.
    scores : mapping, optional
        Name -> value for the scores table.
    notes : sequence of str
    quiet : bool
        No progress bar.

    Returns
    -------
    Path
        The page.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    figures: dict[str, str] = {}
    if persons is not None and len(persons):
        figures["persons: azimuth from the array over time (thick: speaking)"] = (
            report.persons_figure(persons))
    if speech or reference:
        figures["who speaks when"] = report.timeline_figure(list(reference), list(speech))
    mp4 = [out / "tracks.mp4"] if h264_available() else []
    video = render_overlay_video(
        out / "tracks.webm", tracks, speaking, image_size, fps, n_frames=n_frames, gt=gt,
        title=title, progress=not quiet, persons=persons, frames=frames, also_to=mp4)
    names = " / ".join(p.name for p in (*mp4, video))
    ground = "the recording's own frames" if frames is not None else "a plain canvas"
    page_notes = [
        f"{names}: {ground} with the tracked boxes, their identities and "
        "who speaks (a bubble)" + ("; persons tracked without a box: a ring at their "
                                   "direction, or an arrow at the image edge with their "
                                   "azimuth" if persons is not None else "")
        + ("; thin grey: ground truth" if gt is not None else ""),
        *notes,
    ]
    page = out / "index.html"
    report.write_report(page, title, dict(scores or {}), figures, page_notes, video=video,
                        video_links=[*mp4, video])
    return page
