"""Figures of the command line's ``--plot`` options: heat maps and DOA tracks over time,
SMC-PHD tracks with their OSPA, and the audio-visual tracker's covariances. Each is written
atomically as an image file; matplotlib is imported when a figure is drawn.

A track or person is drawn in the colour of its id (:func:`avtrack.viz.palette.person_colour`),
as in the HTML report and the video overlay; azimuth axes are zoomed to the arc of the tracks
and the ground truth, the wrap at +-180 degrees handled (:mod:`avtrack.viz.azimuth`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from avtrack.errors import InputError
from avtrack.io.base import atomic_write
from avtrack.io.doa import DOATable
from avtrack.localize import DirectionGrid, HeatMaps
from avtrack.phd import PHDResult
from avtrack.viz.azimuth import azimuth_axis
from avtrack.viz.palette import person_colour


# -- output ------------------------------------------------------------------------------
def plot_heatmap(
    path: Path,
    heatmaps: HeatMaps,
    grid: DirectionGrid,
    title: str = "",
    truth: DOATable | None = None,
) -> None:
    """Heat map over time and azimuth (thesis Fig. 5.2 b–e), written atomically as PNG; with
    ``truth``, the azimuth axis is zoomed to the arc of its talkers."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise InputError("--plot needs matplotlib (pip install matplotlib)", path) from None
    w = heatmaps.weights.reshape(len(heatmaps), grid.n_elevations, grid.n_azimuths).max(axis=1)
    axis = azimuth_axis(truth.azimuth_deg) if truth is not None and len(truth) else None
    az = grid.azimuth_values if axis is None else axis.unwrap(grid.azimuth_values)
    order = np.argsort(az, kind="stable")  # columns contiguous around the axis's centre
    az = az[order]
    t0 = heatmaps.time_s[0] if len(heatmaps) else 0.0
    t1 = heatmaps.time_s[-1] if len(heatmaps) else 1.0
    step = float(np.median(np.diff(az))) if az.size > 1 else 1.0
    fig, ax = plt.subplots(figsize=(9, 3.6), dpi=110)
    im = ax.imshow(
        w[:, order].T,
        aspect="auto",
        origin="lower",
        cmap="viridis",
        extent=(t0, t1, az[0] - step / 2, az[-1] + step / 2),
        interpolation="nearest",
    )
    if truth is not None and axis is not None:
        on = truth.active
        ax.plot(
            truth.time_s[on],
            axis.unwrap(truth.azimuth_deg[on]),
            ".",
            ms=1.0,
            color="red",
            label="ground truth (active)",
        )
    if axis is not None:
        axis.apply(ax, "y")
        ax.legend(loc="upper right", fontsize=7, markerscale=8)
    ax.set_xlim(t0, t1)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("azimuth (deg)")
    ax.set_title(title)
    fig.colorbar(im, ax=ax, pad=0.01)
    fig.tight_layout()
    with atomic_write(path, "wb") as fh:
        fig.savefig(fh, format="png")
    plt.close(fig)


def plot_doa_tracks(
    path: Path, tracks: DOATable, truth: DOATable | None = None, title: str = ""
) -> None:
    """Tracks over time coloured by identity (thesis Fig. 5.2 f / 5.5), with the ground truth
    above them when given; written atomically as PNG. Both panels share one azimuth axis,
    zoomed to the arc of the tracks and the ground truth."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise InputError("--plot needs matplotlib (pip install matplotlib)", path) from None
    rows = 2 if truth is not None else 1
    fig, axes = plt.subplots(
        rows, 1, figsize=(9, 2.6 * rows + 0.6), dpi=110, sharex=True, squeeze=False
    )
    panels = [] if truth is None else [(axes[0, 0], truth, "ground truth (speaking)")]
    panels.append((axes[-1, 0], tracks, "tracks (speaking; faint: silent)"))
    axis = azimuth_axis(*(table.azimuth_deg for _, table, _ in panels))
    for ax, table, label in panels:
        for tid in np.unique(table.ids):
            sel = table.ids == tid
            on = sel & table.active
            ax.plot(
                table.time_s[on],
                axis.unwrap(table.azimuth_deg[on]),
                ".",
                ms=2.0,
                color=person_colour(int(tid)),
                label=f"{tid}",
            )
            if table is tracks:
                off = sel & ~table.active
                ax.plot(
                    table.time_s[off],
                    axis.unwrap(table.azimuth_deg[off]),
                    ".",
                    ms=0.8,
                    alpha=0.3,
                    color=person_colour(int(tid)),
                )
        axis.apply(ax, "y")
        ax.set_ylabel("azimuth (deg)")
        ax.set_title(label, fontsize=9)
        if 0 < len(np.unique(table.ids)) <= 12:
            ax.legend(
                loc="upper right", fontsize=6, markerscale=3, ncol=6, title="id", title_fontsize=6
            )
    axes[-1, 0].set_xlabel("time (s)")
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    with atomic_write(path, "wb") as fh:
        fig.savefig(fh, format="png")
    plt.close(fig)


def plot_phd_tracks(
    path: Path,
    result: PHDResult,
    truth: list[np.ndarray],
    frames: np.ndarray,
    ospa: np.ndarray,
    title: str,
    order: int = 2,
    cutoff: float = 50.0,
) -> None:
    """SMC-PHD estimates over the ground truth in the image, each in its track's colour (dark
    grey: no identity), and OSPA over time; written atomically (format from the suffix)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 4.5))
    gt = np.vstack([t for t in truth if len(t)] or [np.zeros((0, 2))])
    ax.scatter(gt[:, 0], gt[:, 1], s=2, c="0.7", label="ground truth")
    rows = result.rows(frames)
    if len(rows):
        ids = rows[:, 1]
        ax.scatter(
            rows[:, 2],
            rows[:, 3],
            s=3,
            c=[person_colour(int(i)) if i >= 0 else "0.3" for i in ids],  # dark grey: no id
            label="estimates",
        )
    ax.set_xlim(0, 360)
    ax.set_ylim(288, 0)
    ax.set_aspect("equal")
    ax.set_xlabel("x (px)")
    ax.set_ylabel("y (px)")
    ax.legend(loc="lower right", fontsize=8)
    ax.set_title(title)
    ax2.plot(frames, ospa[:, 0], lw=0.8, label="OSPA")
    ax2.plot(frames, ospa[:, 2], lw=0.6, label="cardinality part")
    ax2.set_xlabel("frame")
    ax2.set_ylabel(f"OSPA (px, p={order}, c={cutoff:g})")
    ax2.legend(fontsize=8)
    fig.tight_layout()
    with atomic_write(path, "wb") as fh:
        fig.savefig(fh, format=path.suffix.lstrip(".") or "png", dpi=120)
    plt.close(fig)


def _ellipse(ax, centre, cov, color, n_std: float = 2.0) -> None:
    """Draw the ``n_std`` ellipse of ``cov (2, 2)``."""
    from matplotlib.patches import Ellipse

    vals, vecs = np.linalg.eigh(cov)
    if not np.all(np.isfinite(vals)):
        return
    angle = float(np.degrees(np.arctan2(vecs[1, 1], vecs[0, 1])))
    w, h = 2 * n_std * np.sqrt(np.maximum(vals, 0.0))
    ax.add_patch(Ellipse(centre, h, w, angle=angle, fill=False, color=color, lw=1.2))


def _covariance(prec: np.ndarray) -> tuple[np.ndarray, bool]:
    """Covariance of a 2x2 precision; for a precision on x only (audio mapped to x), a very
    tall ellipse stands for "no vertical information"."""
    if prec[1, 1] <= 1e-12 * max(prec[0, 0], 1e-300):
        if prec[0, 0] <= 0:
            return np.full((2, 2), np.nan), False
        return np.diag([1.0 / prec[0, 0], 1e12]), True
    try:
        return np.linalg.inv(prec), True
    except np.linalg.LinAlgError:
        return np.full((2, 2), np.nan), False


def plot_covariances(res, path: Path, no_audio: bool = False) -> None:
    """Four frames, as Fig. 1 of Ban et al., "Variational Bayesian inference for audio-visual
    tracking of multiple speakers" (IEEE TPAMI 2019); rows: tracked head boxes (thick, tagged
    ``<id> speaking`` when speaking, as in the video overlay), and the visual, audio and
    dynamics covariances (inverses of the precision terms #1, #2, #3 of eq. 4.26) of each
    tracked person, each person in their colour (:func:`avtrack.viz.palette.person_colour`)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tracks = res.tracks
    frames = np.unique(tracks.frames)
    w, h = res.image_size
    if frames.size:  # four frames spread over the sequence, after the first births
        picks = frames[np.linspace(frames.size // 10, frames.size - 1, 4).round().astype(int)]
    else:
        picks = np.array([1, 1, 1, 1])
    rows = ["tracks", "visual (#1)", "audio (#2)", "dynamics (#3)"]
    fig, axes = plt.subplots(4, 4, figsize=(13, 10), squeeze=False)
    for c, f in enumerate(picks):
        sel = np.flatnonzero(tracks.frames == f)
        for r, name in enumerate(rows):
            ax = axes[r, c]
            ax.set_xlim(0, w)
            ax.set_ylim(h, 0)
            ax.set_aspect("equal")
            ax.set_xticks([])
            ax.set_yticks([])
            lo, hi = res.fov
            if hi - lo < w:
                ax.axvspan(0, lo, color="0.85")
                ax.axvspan(hi, w, color="0.85")
            if c == 0:
                ax.set_ylabel(name)
            if r == 0:
                ax.set_title(f"frame {int(f)}")
            for i in sel:
                tid = int(tracks.ids[i])
                col = person_colour(tid)
                box = tracks.boxes[i]
                centre = (box[0] + box[2] / 2, box[1] + box[3] / 2)
                if r == 0:
                    speaking = bool(res.speaking[i])
                    ax.add_patch(plt.Rectangle(box[:2], box[2], box[3], fill=False, color=col,
                                               lw=3.0 if speaking else 1.0))
                    ax.text(
                        box[0],
                        box[1] - 8,
                        f"{tid} speaking" if speaking else str(tid),
                        fontsize=10,
                        weight="bold",
                        color=col,
                    )
                    continue
                if res.precisions is None or (no_audio and r == 2):
                    continue
                cov, ok = _covariance(res.precisions[i, r - 1])
                if ok:
                    _ellipse(ax, centre, cov, col)
    fig.tight_layout()
    with atomic_write(path, "wb") as fh:
        fig.savefig(fh, format="png", dpi=80)
    plt.close(fig)
