"""A self-contained HTML report of an audio-visual scene and what the trackers made of it.

Figures are drawn with matplotlib (Agg) and embedded in ``index.html`` as base64 PNGs, so the
report is one file that opens without network access or other files; the video overlay
(:mod:`avtrack.viz.video`) is embedded too when it is small, else linked next to the page.

The page reads on a phone as on a desktop. Each figure is drawn twice, laid out for each
(:class:`FigureImage`): a wide rendition (legend beside the axes) and a narrow one (legend
under them, fewer ticks) that a ``<picture>`` shows on screens up to :data:`NARROW_MAX_PX`
CSS pixels wide; both are drawn at a size whose smallest text stays at least
:data:`MIN_SCREEN_FONT_PX` on screen when the image is scaled to the page's width. Each
person has one colour on every figure and in the video (:mod:`avtrack.viz.palette`), and the
azimuth axes are zoomed to where the persons are, the wrap at +-180 degrees handled
(:mod:`avtrack.viz.azimuth`). The video is offered as an H.264 MP4 first (where one was
written) and a WebM second; an MP4 of MPEG-4 Part 2, which browsers do not play, is left out.
"""

from __future__ import annotations

import base64
import html
import io
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from avtrack.io.mot import MOTData
from avtrack.io.rttm import RTTMSegment
from avtrack.viz.azimuth import AzimuthAxis, azimuth_axis, wrap_deg
from avtrack.viz.palette import person_colour, speaker_colour

#: Screens (CSS pixels) up to this width get each figure's narrow rendition.
NARROW_MAX_PX = 760
#: The page's content is at most this wide (CSS pixels), padding included.
PAGE_MAX_PX = 960
#: The smallest text of a figure is at least this tall on screen (CSS pixels) at any width
#: from 360 pixels up.
MIN_SCREEN_FONT_PX = 10.0

#: Colour of a DOA track following no person on the heat map (light cyan: no person's).
DOA_TRACK_HEX = "#a6f0ff"

#: Font sizes of the figures, points: text and the smallest (tick labels, legends).
FONT_PT = 10.0
SMALL_FONT_PT = 9.0


@dataclass(frozen=True)
class _Rendition:
    """One layout of the figures: width in inches, resolution, and whether narrow."""

    width_in: float
    dpi: int
    narrow: bool


#: 1350 pixels wide, shown at 760..944 CSS pixels: 9 pt = 18.75 px -> 10.6..13.1 px on screen.
WIDE = _Rendition(9.0, 150, narrow=False)
#: 800 pixels wide, shown at 344..744 CSS pixels: 9 pt = 25 px -> 10.8..23 px on screen.
NARROW = _Rendition(4.0, 200, narrow=True)


class FigureImage(str):
    """A figure of the report: the string is its wide rendition, a base64 PNG (so it serves
    wherever one is expected), with the narrow rendition and each one's smallest font size.

    Attributes
    ----------
    narrow : str
        The narrow rendition, a base64 PNG.
    font_px, narrow_font_px : float
        Height of the smallest text of each rendition, in that image's own pixels (the
        size on screen is this times the displayed width over the image's width).
    """

    narrow: str
    font_px: float
    narrow_font_px: float

    def __new__(cls, wide: str, narrow: str, font_px: float, narrow_font_px: float):
        obj = super().__new__(cls, wide)
        obj.narrow, obj.font_px, obj.narrow_font_px = narrow, font_px, narrow_font_px
        return obj


def _smallest_font_px(fig, dpi: int) -> float:
    """Height of the smallest visible text of a drawn figure, pixels at ``dpi``."""
    from matplotlib.text import Text

    sizes = [t.get_fontsize() for t in fig.findobj(Text)
             if t.get_visible() and t.get_text().strip()]  # fmt: skip
    return float(min(sizes, default=FONT_PT)) * dpi / 72.0


def _render(draw: Callable, height_in: float, narrow_height_in: float) -> FigureImage:
    """``draw(fig, ax, narrow)`` in both renditions, as a :class:`FigureImage`."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    out: list[tuple[str, float]] = []
    for rend, h in ((WIDE, height_in), (NARROW, narrow_height_in)):
        with plt.rc_context({"font.size": FONT_PT, "axes.labelsize": FONT_PT,
                             "axes.titlesize": FONT_PT, "xtick.labelsize": SMALL_FONT_PT,
                             "ytick.labelsize": SMALL_FONT_PT, "legend.fontsize": SMALL_FONT_PT,
                             "legend.title_fontsize": SMALL_FONT_PT}):  # fmt: skip
            fig, ax = plt.subplots(figsize=(rend.width_in, h), dpi=rend.dpi, layout="constrained")
            try:
                draw(fig, ax, rend.narrow)
                fig.canvas.draw()
                font_px = _smallest_font_px(fig, rend.dpi)
                buf = io.BytesIO()
                fig.savefig(buf, format="png", dpi=rend.dpi)
            finally:
                plt.close(fig)
        out.append((base64.b64encode(buf.getvalue()).decode("ascii"), font_px))
    (wide, wide_px), (narrow, narrow_px) = out
    return FigureImage(wide, narrow, wide_px, narrow_px)


def _legend(fig, ax, narrow: bool, markerscale: float = 3.0, dark: bool = False) -> None:
    """The axes' legend outside them: on the right (wide), underneath (narrow); ``dark``: on
    a dark ground, for white entries."""
    handles, labels = ax.get_legend_handles_labels()
    if not handles:
        return
    style = {"facecolor": "0.2", "edgecolor": "0.2", "labelcolor": "white"} if dark else {}
    if narrow:
        fig.legend(handles, labels, loc="outside lower center", ncol=min(len(handles), 3),
                   markerscale=markerscale, columnspacing=1.0, handletextpad=0.3, **style)
    else:
        fig.legend(handles, labels, loc="outside right upper", markerscale=markerscale,
                   **style)


def _time_ticks(ax, narrow: bool) -> None:
    from matplotlib.ticker import MaxNLocator

    ax.xaxis.set_major_locator(MaxNLocator(nbins=5 if narrow else 10))


def trajectories_figure(gt: MOTData, tracks: MOTData, fps: float, width: int) -> FigureImage:
    """Horizontal image position of every head over time: ground truth (grey) and tracks,
    each in its person's colour (:func:`avtrack.viz.palette.person_colour`)."""

    def draw(fig, ax, narrow: bool) -> None:
        for k, pid in enumerate(np.unique(gt.ids)):
            m = gt.ids == pid
            ax.plot((gt.frames[m] - 1) / fps, gt.boxes[m, 0] + gt.boxes[m, 2] / 2, ".", ms=5,
                    color="0.75", label="ground truth" if k == 0 else None)  # fmt: skip
        for tid in np.unique(tracks.ids):
            m = tracks.ids == tid
            ax.plot((tracks.frames[m] - 1) / fps, tracks.boxes[m, 0] + tracks.boxes[m, 2] / 2,
                    ".", ms=2, color=person_colour(int(tid)), label=f"track {tid}")  # fmt: skip
        ax.set_xlabel("time (s)")
        ax.set_ylabel("box centre x (px)")
        ax.set_ylim(0, width)
        _time_ticks(ax, narrow)
        _legend(fig, ax, narrow)

    return _render(draw, 3.2, 3.8)


def _doa_track_persons(tracks, persons, max_deg: float = 20.0) -> dict[int, int]:
    """DOA track id -> the person whose azimuth it follows: the smallest median angular
    distance over the track's rows (the person's azimuth at the nearest video frame), when
    below ``max_deg``; tracks following nobody are absent."""
    out: dict[int, int] = {}
    if persons is None or not len(persons) or tracks is None or not len(tracks):
        return out
    frame = np.rint(np.asarray(tracks.time_s) * persons.fps).astype(np.int64) + 1
    by_person = {}
    for pid in np.unique(persons.ids):
        m = persons.ids == pid
        by_person[int(pid)] = dict(zip(persons.frames[m].tolist(),
                                       persons.azimuth_deg[m].tolist(), strict=True))
    for tid in np.unique(tracks.ids):
        rows = np.flatnonzero(tracks.ids == tid)
        best, best_d = None, max_deg
        for pid, az in by_person.items():
            pairs = [(tracks.azimuth_deg[r], az[frame[r]]) for r in rows if frame[r] in az]
            if not pairs:
                continue
            a, b = np.asarray(pairs, dtype=float).T
            d = float(np.median(np.abs(wrap_deg(a - b))))
            if d < best_d:
                best, best_d = pid, d
        if best is not None:
            out[int(tid)] = best
    return out


def _heatmap_image(ax, weights: np.ndarray, times: np.ndarray, azimuths: np.ndarray,
                   axis: AzimuthAxis) -> None:  # fmt: skip
    """The heat map with its azimuth columns unwrapped around the axis's centre."""
    az = axis.unwrap(azimuths)
    order = np.argsort(az, kind="stable")
    az = az[order]
    step = float(np.median(np.diff(az))) if az.size > 1 else 1.0
    t0, t1 = (float(times[0]), float(times[-1])) if len(times) else (0.0, 1.0)
    ax.imshow(weights[:, order].T, aspect="auto", origin="lower", cmap="magma",
              interpolation="nearest",
              extent=(t0, t1, az[0] - step / 2, az[-1] + step / 2))  # fmt: skip


def heatmap_figure(
    weights: np.ndarray, times: np.ndarray, azimuths: np.ndarray, truth=None, tracks=None,
    *, persons=None,
) -> FigureImage:  # fmt: skip
    """DOA heat map (time x azimuth) with the speaking ground truth and the DOA tracks on top.

    The azimuth axis is zoomed to the arc of the tracks, the ground truth and the persons
    (:func:`avtrack.viz.azimuth.azimuth_axis`; the whole heat map when none is given).

    Parameters
    ----------
    weights : ndarray (T, D)
        Heat map of each frame over the candidate azimuths.
    times : ndarray (T,)
    azimuths : ndarray (D,)
        Candidate azimuths, degrees.
    truth : DOATable, optional
        Ground truth; its active (speaking) rows are drawn in white (no person's colour is
        near it).
    tracks : DOATable, optional
        Tracker output: speaking estimates as dots, silent ones faint. A DOA track is not a
        person: with ``persons`` it takes the colour of the person it follows (the smallest
        median angular distance, under 20 degrees); otherwise, and when it follows nobody, it
        is drawn in light cyan, one marker shape per track.
    persons : PersonsTable, optional
        The tracked persons (:class:`avtrack.io.persons.PersonsTable`), to colour the DOA
        tracks by person.
    """
    weights, times, azimuths = np.asarray(weights), np.asarray(times), np.asarray(azimuths)
    owner = _doa_track_persons(tracks, persons)
    axis = azimuth_axis(*(t.azimuth_deg for t in (truth, tracks, persons)
                          if t is not None and len(t)))  # fmt: skip

    def draw(fig, ax, narrow: bool) -> None:
        _heatmap_image(ax, weights, times, azimuths, axis)
        if truth is not None and len(truth):
            on = truth.active
            ax.plot(truth.time_s[on], axis.unwrap(truth.azimuth_deg[on]), ".", ms=1.0,
                    color="white", label="ground truth (speaking)")  # fmt: skip
        if tracks is not None and len(tracks):
            ids = np.unique(tracks.ids)
            for k, tid in enumerate(ids):
                m = tracks.ids == tid
                on, off = m & tracks.active, m & ~tracks.active
                pid = owner.get(int(tid))
                colour = DOA_TRACK_HEX if pid is None else person_colour(pid)
                marker = "." if pid is not None else "os^Dv<>p"[k % 8]
                label = (f"DOA track {tid}" + ("" if pid is None else f" = person {pid}")
                         if len(ids) <= 12 else None)  # fmt: skip
                ax.plot(tracks.time_s[on], axis.unwrap(tracks.azimuth_deg[on]), marker,
                        ms=2.5 if pid is not None else 2.0, color=colour, label=label)
                ax.plot(tracks.time_s[off], axis.unwrap(tracks.azimuth_deg[off]), marker,
                        ms=1, alpha=0.35, color=colour)  # fmt: skip
        axis.apply(ax, "y")
        ax.set_xlabel("time (s)")
        ax.set_ylabel("azimuth (deg)")
        _time_ticks(ax, narrow)
        _legend(fig, ax, narrow, dark=True)

    return _render(draw, 3.2, 3.8)


def persons_figure(
    persons, truth=None, view_deg: tuple[float, float] | None = None
) -> FigureImage:
    """Every tracked person's azimuth over time, in view or not: thick where speaking, thin
    where silent, each in their colour (:func:`avtrack.viz.palette.person_colour`); the
    ground truth in grey (cyan where speaking); the camera's horizontal field of view shaded.
    The azimuth axis is zoomed to the arc of the persons and the ground truth, the wrap at
    +-180 degrees handled (:func:`avtrack.viz.azimuth.azimuth_axis`).

    Parameters
    ----------
    persons : PersonsTable
        :class:`avtrack.io.persons.PersonsTable`.
    truth : DOATable, optional
    view_deg : (float, float), optional
        Azimuths of the image's side edges.
    """
    axis = azimuth_axis(persons.azimuth_deg,
                        *(() if truth is None else (truth.azimuth_deg,)))  # fmt: skip
    t = (persons.frames - 1) / persons.fps

    def draw(fig, ax, narrow: bool) -> None:
        if view_deg is not None:
            lo, hi = sorted(axis.unwrap(np.asarray(view_deg, dtype=float)).tolist())
            ax.axhspan(lo, hi, color="0.92", zorder=0, label="camera's view")
        if truth is not None and len(truth):
            ax.plot(truth.time_s, axis.unwrap(truth.azimuth_deg), ".", ms=0.6, color="0.6")
            on = truth.active
            ax.plot(truth.time_s[on], axis.unwrap(truth.azimuth_deg[on]), ".", ms=0.6,
                    color="cyan")
        for pid in np.unique(persons.ids):
            m = persons.ids == pid
            talk = m & (persons.speaking >= 0.5)
            colour = person_colour(int(pid))
            ax.plot(t[m], axis.unwrap(persons.azimuth_deg[m]), ".", ms=1.2, color=colour)
            ax.plot(t[talk], axis.unwrap(persons.azimuth_deg[talk]), ".", ms=4, color=colour,
                    label=f"person {pid}")
        axis.apply(ax, "y")
        ax.set_xlabel("time (s)")
        ax.set_ylabel("azimuth from the array (deg)")
        _time_ticks(ax, narrow)
        _legend(fig, ax, narrow, markerscale=2)

    return _render(draw, 3.2, 3.8)


def speaker_mapping(reference: Sequence[RTTMSegment],
                    hypothesis: Sequence[RTTMSegment]) -> dict[str, str]:
    """Hypothesis speaker -> the reference speaker it overlaps most in one optimal one-to-one
    assignment (the mapping the diarization error rate uses); unmatched speakers are absent."""
    from scipy.optimize import linear_sum_assignment

    ref = sorted({s.speaker for s in reference})
    hyp = sorted({s.speaker for s in hypothesis})
    if not ref or not hyp:
        return {}
    overlap = np.zeros((len(hyp), len(ref)))
    for h in hypothesis:
        for r in reference:
            o = min(h.start + h.duration, r.start + r.duration) - max(h.start, r.start)
            if o > 0:
                overlap[hyp.index(h.speaker), ref.index(r.speaker)] += o
    rows, cols = linear_sum_assignment(-overlap)
    return {hyp[i]: ref[j] for i, j in zip(rows, cols, strict=True) if overlap[i, j] > 0}


def timeline_figure(
    reference: Sequence[RTTMSegment], hypothesis: Sequence[RTTMSegment]
) -> FigureImage:
    """Who speaks when (like thesis Fig. 4.4): each true speaker's row (grey) directly above
    the row of the avtrack speaker mapped to it (the optimal one-to-one mapping of the
    diarization error rate), then the avtrack speakers mapped to nobody. An avtrack speaker's
    row has its person's colour (:func:`avtrack.viz.palette.speaker_colour`: ``P3`` is person
    3), as on the other figures."""
    mapping = speaker_mapping(reference, hypothesis)
    to_hyp = {r: h for h, r in mapping.items()}
    order: list[tuple[str, str, Sequence[RTTMSegment], str]] = []
    for spk in sorted({s.speaker for s in reference}):
        order.append((f"truth {spk}", spk, reference, "0.45"))
        if spk in to_hyp:
            h = to_hyp[spk]
            order.append((f"avtrack {h} (= {spk})", h, hypothesis, speaker_colour(h)))
    for h in sorted({s.speaker for s in hypothesis} - set(mapping)):
        order.append((f"avtrack {h} (no match)", h, hypothesis, speaker_colour(h)))

    def draw(fig, ax, narrow: bool) -> None:
        labels = []
        for y, (label, spk, segs, colour) in enumerate(order):
            labels.append(label)
            bars = [(s.start, s.duration) for s in segs if s.speaker == spk]
            ax.broken_barh(bars, (y - 0.35, 0.7), color=colour)
        ax.set_yticks(range(len(labels)), labels)
        ax.set_ylim(len(labels) - 0.5, -0.5)  # the first row on top
        ax.set_xlabel("time (s)")
        _time_ticks(ax, narrow)

    rows = max(len(order), 1)
    return _render(draw, 1.0 + 0.4 * rows, 1.2 + 0.45 * rows)


#: What each score of a report means and which way is better (shown beside the value).
SCORE_HELP = {
    "MOTA": "multi-object tracking accuracy, % (misses, false boxes and identity switches "
            "together; higher is better, 100 is perfect)",
    "IDF1": "share of boxes given the right identity over the whole sequence, % (higher is "
            "better)",
    "HOTA": "higher-order tracking accuracy, % (detection and association balanced; higher "
            "is better)",
    "IDSW": "identity switches: a true person's track changes id (lower is better)",
    "DER %": "diarization error rate: missed speech, false speech and speaker confusion, % of "
             "speech time (lower is better, 0 is perfect)",
    "DOA MAE (deg)": "mean error of the detected directions of the talkers, degrees (lower is "
                     "better)",
    "DOA MD %": "talkers not found by the localizer, % of talker-frames (lower is better)",
    "DOA FA %": "directions reported where nobody talks, % (lower is better)",
    "real-time factor": "seconds of computing per second of recording (below 1: faster than "
                        "real time)",
}


#: Videos up to this size are embedded in the page (data URI); larger ones are linked.
EMBED_VIDEO_MAX_BYTES = 16 * 2**20

_VIDEO_MIME = {".webm": "video/webm", ".mp4": "video/mp4"}
_VIDEO_NOTES = {".mp4": "H.264: plays in web browsers and video players",
                ".webm": "VP8 WebM: plays in Chromium, Firefox and VLC"}  # fmt: skip


def _playable_videos(videos: Sequence[Path]) -> list[tuple[Path, str]]:
    """The video files that web browsers play, each with its ``<source>`` type, the MP4s
    first (Safari plays no WebM); an MP4 of MPEG-4 Part 2 is left out."""
    from avtrack.viz.video import html_video_type

    out = []
    for p in dict.fromkeys(videos):  # unique, in order
        kind = html_video_type(p)
        if kind is not None:
            out.append((p, kind))
    return sorted(out, key=lambda pk: pk[0].suffix.lower() != ".mp4")


def _video_block(path: Path, page_dir: Path, links: Sequence[Path]) -> str:
    """A ``<video>`` element with one ``<source>`` per browser-playable file among ``path``
    and the videos of ``links`` (H.264 MP4 first; each embedded when small enough), and links
    to the files ``links`` (relative to the page) but those browsers cannot play."""
    if path.suffix.lower() not in _VIDEO_MIME:
        raise ValueError(f"write_report: video must be .webm or .mp4, got {path.name!r}")
    videos = [path, *(p for p in links if p.suffix.lower() in _VIDEO_MIME)]
    sources = _playable_videos(videos)
    if path not in {p for p, _ in sources}:
        raise ValueError(f"write_report: video {path.name!r} is not a WebM (VP8, VP9) nor an "
                         "H.264 MP4, which web browsers play")
    tags = []
    for p, kind in sources:
        if p.stat().st_size <= EMBED_VIDEO_MAX_BYTES:
            src = (f"data:{_VIDEO_MIME[p.suffix.lower()]};base64,"
                   + base64.b64encode(p.read_bytes()).decode("ascii"))  # fmt: skip
        else:
            src = html.escape(os.path.relpath(p, page_dir))
        tags.append(f"<source src='{src}' type='{html.escape(kind)}'>")
    offered = [p for p, _ in sources if p in links]  # the MP4 first, as in the player
    anchors = " ".join(
        f"<a href='{html.escape(os.path.relpath(p, page_dir))}'>{html.escape(p.name)}</a>"
        + (f" ({_VIDEO_NOTES[p.suffix.lower()]})" if p.suffix.lower() in _VIDEO_NOTES else "")
        for p in dict.fromkeys([*offered, *(q for q in links
                                            if q.suffix.lower() not in _VIDEO_MIME)])
    )  # fmt: skip
    return (
        "<section><h2>video overlay</h2><video id='overlay' controls muted loop playsinline "
        f"preload='auto'>{''.join(tags)}</video>"
        + (f"<p>download: {anchors}</p>" if anchors else "")
        + "</section>"
    )


def _figure_block(name: str, data: str) -> str:
    """A figure under its title: a ``<picture>`` of both renditions of a
    :class:`FigureImage` (the narrow one up to :data:`NARROW_MAX_PX`), or one image. Each
    image carries ``data-font-px``, its smallest text in its own pixels."""
    alt = html.escape(name)
    if not isinstance(data, FigureImage):
        return f"<figure><h2>{alt}</h2><img alt='{alt}' src='data:image/png;base64,{data}'>" \
               "</figure>"
    return (
        f"<figure><h2>{alt}</h2><picture>"
        f"<source media='(max-width: {NARROW_MAX_PX}px)' data-font-px='{data.narrow_font_px:.2f}'"
        f" srcset='data:image/png;base64,{data.narrow}'>"
        f"<img alt='{alt}' data-font-px='{data.font_px:.2f}' "
        f"src='data:image/png;base64,{data}'></picture></figure>"
    )


_CSS = f"""*{{box-sizing:border-box}}
body{{font-family:sans-serif;line-height:1.4;max-width:{PAGE_MAX_PX}px;margin:1em auto;
padding:0 8px;color:#222;overflow-wrap:break-word}}
h1{{font-size:1.5em}}h2{{font-size:1.1em;margin:1.5em 0 .4em}}
table{{border-collapse:collapse;width:100%}}
th,td{{border:1px solid #ccc;padding:4px 10px;text-align:left;vertical-align:top}}
td.help{{color:#555;font-size:90%}}
figure{{margin:0}}ul{{padding-left:1.3em}}
img,video{{display:block;width:100%;height:auto}}
@media (max-width:{NARROW_MAX_PX}px){{body{{margin:.5em auto}}th,td{{padding:3px 5px}}}}"""


def write_report(path, title: str, scores: dict[str, float], figures: dict[str, str],
                 notes: Sequence[str] = (), video: str | Path | None = None,
                 video_links: Sequence[str | Path] = ()) -> None:  # fmt: skip
    """``index.html``: a title, a scores table, notes, the embedded figures and optionally a
    video overlay, written atomically.

    The page's figures and video fill its width (at most :data:`PAGE_MAX_PX` CSS pixels) one
    under another; on screens up to :data:`NARROW_MAX_PX` wide the figures show their narrow
    rendition. Nothing is fetched from the network.

    Parameters
    ----------
    path : str or Path
        The page.
    title : str
    scores : dict
        Name -> value (floats shown with 2 decimals).
    figures : dict
        Name -> base64 PNG: a :class:`FigureImage` (as the ``*_figure`` functions return)
        gives both renditions, a plain string one image.
    notes : sequence of str
    video : str or Path, optional
        A ``.webm`` or H.264 ``.mp4`` file shown in a ``<video>`` element, together with the
        other browser-playable videos of ``video_links`` (an H.264 MP4 listed first): each
        embedded as a data URI up to :data:`EMBED_VIDEO_MAX_BYTES`, linked (relative path)
        beyond, so the page never needs the network.
    video_links : sequence of str or Path
        Files linked under the video (e.g. the MP4), relative to the page; a video that
        browsers do not play (an MP4 of MPEG-4 Part 2) is neither linked nor played.

    Raises
    ------
    ValueError
        When ``video`` is not a video web browsers play.
    """
    from avtrack.io.base import atomic_write

    path = Path(path)
    rows = "".join(
        f"<tr><th>{html.escape(k)}</th><td>{f'{v:.2f}' if isinstance(v, float) else v}</td>"
        f"<td class='help'>{html.escape(SCORE_HELP.get(k, ''))}</td></tr>"
        for k, v in scores.items()
    )
    figs = "".join(_figure_block(name, data) for name, data in figures.items())
    if video is not None:
        figs += _video_block(Path(video), path.parent, [Path(p) for p in video_links])
    items = "".join(f"<li>{html.escape(n)}</li>" for n in notes)
    text = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{html.escape(title)}</title>
<style>{_CSS}</style></head>
<body><h1>{html.escape(title)}</h1>
<table id="scores">{rows}</table><ul>{items}</ul>{figs}</body></html>
"""
    with atomic_write(path) as fh:
        fh.write(text)
