"""A self-contained HTML report of an audio-visual scene and what the trackers made of it.

Figures are drawn with matplotlib (Agg) and embedded in ``index.html`` as base64 PNGs, so the
report is one file that opens without network access or other files; the video overlay
(:mod:`avtrack.viz.video`) is embedded too when it is small, else linked next to the page.
"""

from __future__ import annotations

import base64
import html
import io
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from avtrack.io.mot import MOTData
from avtrack.io.rttm import RTTMSegment


def _png(fig) -> str:
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _figure(width: float = 9.0, height: float = 3.2):
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt.subplots(figsize=(width, height))


def trajectories_figure(gt: MOTData, tracks: MOTData, fps: float, width: int) -> str:
    """Horizontal image position of every head over time: ground truth (grey) and tracks."""
    fig, ax = _figure()
    for pid in np.unique(gt.ids):
        m = gt.ids == pid
        ax.plot((gt.frames[m] - 1) / fps, gt.boxes[m, 0] + gt.boxes[m, 2] / 2, ".", ms=5,
                color="0.75", label="ground truth" if pid == gt.ids.min() else None)  # fmt: skip
    cmap = __import__("matplotlib").colormaps["tab10"]
    for k, tid in enumerate(np.unique(tracks.ids)):
        m = tracks.ids == tid
        ax.plot((tracks.frames[m] - 1) / fps, tracks.boxes[m, 0] + tracks.boxes[m, 2] / 2,
                ".", ms=2, color=cmap(k % 10), label=f"track {tid}")  # fmt: skip
    ax.set_xlabel("time (s)")
    ax.set_ylabel("box centre x (px)")
    ax.set_ylim(0, width)
    ax.legend(loc="upper right", fontsize=7, ncol=4)
    fig.tight_layout()
    return _png(fig)


def heatmap_figure(
    weights: np.ndarray, times: np.ndarray, azimuths: np.ndarray, truth=None, tracks=None
) -> str:
    """DOA heat map (time x azimuth) with the speaking ground truth and the DOA tracks on top.

    Parameters
    ----------
    weights : ndarray (T, D)
        Heat map of each frame over the candidate azimuths.
    times : ndarray (T,)
    azimuths : ndarray (D,)
        Candidate azimuths, degrees.
    truth : DOATable, optional
        Ground truth; its active (speaking) rows are drawn in white (no track colour is
        near it).
    tracks : DOATable, optional
        Tracker output: speaking estimates as dots coloured by track id, silent ones faint.
    """
    fig, ax = _figure()
    order = np.argsort(azimuths)
    ax.imshow(weights[:, order].T, aspect="auto", origin="lower", cmap="magma",
              extent=(times[0], times[-1], azimuths[order][0], azimuths[order][-1]))  # fmt: skip
    if truth is not None and len(truth):
        on = truth.active
        ax.plot(truth.time_s[on], truth.azimuth_deg[on], ",", color="white",
                label="ground truth (speaking)")
    if tracks is not None and len(tracks):
        cmap = __import__("matplotlib").colormaps["tab10"]
        for k, tid in enumerate(np.unique(tracks.ids)):
            m = tracks.ids == tid
            on, off = m & tracks.active, m & ~tracks.active
            ax.plot(tracks.time_s[on], tracks.azimuth_deg[on], ".", ms=2.5,
                    color=cmap(k % 10), label=f"track {tid}")  # fmt: skip
            ax.plot(tracks.time_s[off], tracks.azimuth_deg[off], ".", ms=1, alpha=0.35,
                    color=cmap(k % 10))  # fmt: skip
        if len(np.unique(tracks.ids)) <= 12:
            ax.legend(loc="upper right", fontsize=7, ncol=6, markerscale=3)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("azimuth (deg)")
    fig.tight_layout()
    return _png(fig)


def persons_figure(persons, truth=None, view_deg: tuple[float, float] | None = None) -> str:
    """Every tracked person's azimuth over time, in view or not: thick where speaking, thin
    where silent; the ground truth in grey (cyan where speaking); the camera's horizontal field
    of view shaded.

    Parameters
    ----------
    persons : PersonsTable
        :class:`avtrack.io.persons.PersonsTable`.
    truth : DOATable, optional
    view_deg : (float, float), optional
        Azimuths of the image's side edges.
    """
    fig, ax = _figure()
    if view_deg is not None:
        ax.axhspan(min(view_deg), max(view_deg), color="0.92", zorder=0,
                   label="camera's view")
    if truth is not None and len(truth):
        ax.plot(truth.time_s, truth.azimuth_deg, ",", color="0.6")
        on = truth.active
        ax.plot(truth.time_s[on], truth.azimuth_deg[on], ",", color="cyan")
    cmap = __import__("matplotlib").colormaps["tab10"]
    t = (persons.frames - 1) / persons.fps
    for k, pid in enumerate(np.unique(persons.ids)):
        m = persons.ids == pid
        talk = m & (persons.speaking >= 0.5)
        ax.plot(t[m], persons.azimuth_deg[m], ".", ms=1.2, color=cmap(k % 10))
        ax.plot(t[talk], persons.azimuth_deg[talk], ".", ms=4, color=cmap(k % 10),
                label=f"person {pid}")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("azimuth from the array (deg)")
    ax.legend(loc="upper right", fontsize=7, ncol=6, markerscale=2)
    fig.tight_layout()
    return _png(fig)


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


def timeline_figure(reference: Sequence[RTTMSegment], hypothesis: Sequence[RTTMSegment]) -> str:
    """Who speaks when (like thesis Fig. 4.4): each true speaker's row (grey) directly above
    the row of the avtrack speaker mapped to it (the optimal one-to-one mapping of the
    diarization error rate), then the avtrack speakers mapped to nobody."""
    fig, ax = _figure(9.0, 2.6)
    mapping = speaker_mapping(reference, hypothesis)
    to_hyp = {r: h for h, r in mapping.items()}
    order: list[tuple[str, str, Sequence[RTTMSegment], str]] = []
    for k, spk in enumerate(sorted({s.speaker for s in reference})):
        order.append((f"truth {spk}", spk, reference, "0.45"))
        if spk in to_hyp:
            h = to_hyp[spk]
            order.append((f"avtrack {h} (= {spk})", h, hypothesis, f"C{k % 10}"))
    for h in sorted({s.speaker for s in hypothesis} - set(mapping)):
        order.append((f"avtrack {h} (no match)", h, hypothesis, "C3"))
    labels = []
    for y, (label, spk, segs, colour) in enumerate(order):
        labels.append(label)
        bars = [(s.start, s.duration) for s in segs if s.speaker == spk]
        ax.broken_barh(bars, (y - 0.35, 0.7), color=colour)
    ax.set_yticks(range(len(labels)), labels, fontsize=7)
    ax.invert_yaxis()
    ax.set_xlabel("time (s)")
    fig.tight_layout()
    return _png(fig)


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

_VIDEO_TYPES = {".webm": "video/webm", ".mp4": "video/mp4"}


def _video_block(path: Path, page_dir: Path, links: Sequence[Path]) -> str:
    """A ``<video>`` element playing ``path`` (embedded when small enough) and links to the
    video files ``links`` (relative to the page)."""
    mime = _VIDEO_TYPES.get(path.suffix.lower())
    if mime is None:
        raise ValueError(f"write_report: video must be .webm or .mp4, got {path.name!r}")
    if path.stat().st_size <= EMBED_VIDEO_MAX_BYTES:
        src = f"data:{mime};base64," + base64.b64encode(path.read_bytes()).decode("ascii")
    else:
        src = html.escape(os.path.relpath(path, page_dir))
    anchors = " ".join(
        f"<a href='{html.escape(os.path.relpath(p, page_dir))}'>{html.escape(p.name)}</a>"
        + (" (MPEG-4 Part 2: plays in VLC and other video players, not in web browsers)"
           if p.suffix.lower() == ".mp4" else " (plays in web browsers)")
        for p in links
    )
    return (
        "<h2>video overlay</h2><video id='overlay' controls muted loop playsinline "
        f"preload='auto' src='{src}'></video>"
        + (f"<p>download: {anchors}</p>" if anchors else "")
    )


def write_report(path, title: str, scores: dict[str, float], figures: dict[str, str],
                 notes: Sequence[str] = (), video: str | Path | None = None,
                 video_links: Sequence[str | Path] = ()) -> None:  # fmt: skip
    """``index.html``: a title, a scores table, notes, the embedded figures and optionally a
    video overlay, written atomically.

    Parameters
    ----------
    path : str or Path
        The page.
    title : str
    scores : dict
        Name -> value (floats shown with 2 decimals).
    figures : dict
        Name -> base64 PNG (as the ``*_figure`` functions return).
    notes : sequence of str
    video : str or Path, optional
        A ``.webm`` (plays in every browser) or ``.mp4`` file shown in a ``<video>`` element:
        embedded as a data URI up to :data:`EMBED_VIDEO_MAX_BYTES`, linked (relative path)
        beyond, so the page never needs the network.
    video_links : sequence of str or Path
        Files linked under the video (e.g. the MP4), relative to the page.
    """
    from avtrack.io.base import atomic_write

    path = Path(path)
    rows = "".join(
        f"<tr><th>{html.escape(k)}</th><td>{f'{v:.2f}' if isinstance(v, float) else v}</td>"
        f"<td class='help'>{html.escape(SCORE_HELP.get(k, ''))}</td></tr>"
        for k, v in scores.items()
    )
    figs = "".join(
        f"<h2>{html.escape(name)}</h2><img alt='{html.escape(name)}' "
        f"src='data:image/png;base64,{data}'>"
        for name, data in figures.items()
    )
    if video is not None:
        figs += _video_block(Path(video), path.parent, [Path(p) for p in video_links])
    items = "".join(f"<li>{html.escape(n)}</li>" for n in notes)
    text = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{html.escape(title)}</title>
<style>body{{font-family:sans-serif;max-width:960px;margin:2em auto;padding:0 8px;color:#222}}
td.help{{color:#555;font-size:90%}}
table{{border-collapse:collapse}}th,td{{border:1px solid #ccc;padding:4px 10px;text-align:left}}
img,video{{max-width:100%}}</style></head>
<body><h1>{html.escape(title)}</h1>
<table id="scores">{rows}</table><ul>{items}</ul>{figs}</body></html>
"""
    with atomic_write(path) as fh:
        fh.write(text)
