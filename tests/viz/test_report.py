"""The HTML report: scores explained, readable on a narrow screen, diarization rows aligned,
one colour per person on every figure, azimuth axes zoomed across the wrap, the video's
sources."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.io.doa import DOATable
from avtrack.io.mot import MOTData
from avtrack.io.persons import PersonsTable
from avtrack.io.rttm import RTTMSegment
from avtrack.viz import report
from avtrack.viz.palette import person_bgr, person_colour
from avtrack.viz.report import SCORE_HELP, speaker_mapping, write_report


def seg(spk, start, dur):
    return RTTMSegment("rec", start, dur, spk)


def test_speaker_mapping_is_the_optimal_one_to_one_overlap():
    ref = [seg("P1", 0, 4), seg("P2", 4, 4), seg("P3", 8, 1)]
    hyp = [seg("P2", 0, 3.5), seg("P7", 4.5, 3.5), seg("P9", 3.0, 1.5), seg("P5", 20, 1)]
    # P2 <-> P1 (3.5 s), P7 <-> P2 (3.5 s); P9 overlaps P1 and P2 a little but both are
    # taken by better matches; P5 overlaps nobody
    assert speaker_mapping(ref, hyp) == {"P2": "P1", "P7": "P2"}
    assert speaker_mapping([], hyp) == {} and speaker_mapping(ref, []) == {}


def test_every_demo_score_says_what_it_means_and_the_page_fits_a_phone(tmp_path):
    scores = {"MOTA": 90.0, "IDF1": 80.0, "HOTA": 70.0, "IDSW": 2, "DER %": 10.0,
              "DOA MAE (deg)": 3.0, "DOA MD %": 20.0, "DOA FA %": 10.0,
              "real-time factor": 0.5}
    assert set(scores) <= set(SCORE_HELP)
    page = tmp_path / "index.html"
    write_report(page, "demo", scores, {})
    text = page.read_text()
    assert '<meta name="viewport" content="width=device-width, initial-scale=1">' in text
    for k in scores:
        assert SCORE_HELP[k].split(" (")[0].replace("'", "&#x27;") in text
    assert text.count("better") >= 8  # which way is good, beside each score


# ----------------------------------------------------------------- figures: colours, axes

FPS = 10.0
N = 20  # frames


def _persons(azimuths: dict[int, float]) -> PersonsTable:
    """Persons standing still at ``{id: azimuth}``, every frame, all speaking."""
    ids = np.tile(sorted(azimuths), N)
    k = ids.size
    return PersonsTable(np.repeat(np.arange(1, N + 1), len(azimuths)), ids,
                        np.array([azimuths[i] for i in ids]), np.zeros(k),
                        np.full((k, 2), np.nan), np.zeros(k, bool), np.ones(k), FPS)  # fmt: skip


def _doa(azimuths: dict[int, float]) -> DOATable:
    """DOA tracks at ``{id: azimuth}`` on the persons' frame times."""
    ids = np.tile(sorted(azimuths), N)
    frames = np.repeat(np.arange(N), len(azimuths))
    k = ids.size
    return DOATable(frames, frames / FPS, ids, np.array([azimuths[i] for i in ids]),
                    np.zeros(k), np.ones(k), np.ones(k, bool))  # fmt: skip


def _drawn(monkeypatch) -> list:
    """The figures ``report`` draws (kept when it closes them), in order."""
    import matplotlib.pyplot as plt

    figs: list = []
    close = plt.close

    def keep(fig=None):
        figs.append(fig)
        close(fig)

    monkeypatch.setattr(plt, "close", keep)
    return figs


def _line_colour(fig, label: str) -> str:
    from matplotlib.colors import to_hex

    (line,) = [ln for ln in fig.axes[0].lines if ln.get_label() == label]
    return to_hex(line.get_color())


def test_a_person_has_one_colour_on_every_panel_and_in_the_video(monkeypatch):
    """Person 3 (with person 1 beside them) in the image tracks, the heat map's overlay (a
    DOA track of another id following them), their directions, the diarization and the
    video's boxes: always person_colour(3), never the colour of a rank."""
    from matplotlib.colors import to_hex

    from avtrack.viz.video import render_overlay_frames

    figs = _drawn(monkeypatch)
    frames = np.repeat(np.arange(1, N + 1), 2)
    ids = np.tile([1, 3], N)
    boxes = np.tile([[40.0, 60, 40, 50], [200.0, 60, 40, 50]], (N, 1))
    tracks = MOTData(frames, ids, boxes, np.ones(2 * N))
    persons = _persons({1: -20.0, 3: 25.0})
    speech = [RTTMSegment("rec", 0.0, 1.0, "P3"), RTTMSegment("rec", 1.0, 0.5, "P1")]
    ref = [RTTMSegment("rec", 0.0, 1.1, "A")]

    report.trajectories_figure(tracks, tracks, FPS, 320)
    report.heatmap_figure(np.ones((N, 72)), np.arange(N) / FPS, np.arange(-180.0, 180.0, 5.0),
                          tracks=_doa({7: 24.0, 8: -21.0}), persons=persons)  # fmt: skip
    report.persons_figure(persons)
    report.timeline_figure(ref, speech)
    wide = figs[0::2]  # each figure twice: wide, narrow
    assert len(figs) == 8
    want = person_colour(3)
    assert want != person_colour(1)
    assert _line_colour(wide[0], "track 3") == want
    assert _line_colour(wide[1], "DOA track 7 = person 3") == want
    assert _line_colour(wide[1], "DOA track 8 = person 1") == person_colour(1)
    assert _line_colour(wide[2], "person 3") == want
    ax = wide[3].axes[0]
    rows = [t.get_text() for t in ax.get_yticklabels()]
    assert rows == ["truth A", "avtrack P3 (= A)", "avtrack P1 (no match)"]
    bars = [to_hex(c.get_facecolor()[0]) for c in ax.collections]
    assert bars[1] == want and bars[2] == person_colour(1)
    img = next(iter(render_overlay_frames(tracks, None, (320, 240), FPS)))
    assert tuple(img[85, 200]) == person_bgr(3)  # the left edge of person 3's box


def test_tracks_across_180_degrees_are_drawn_together(monkeypatch):
    """Talkers at 175 and -175 degrees: both figures centre the axis on 180, so the two
    tracks lie 10 degrees apart inside it, and the heat map's columns are rolled with them."""
    figs = _drawn(monkeypatch)
    persons = _persons({1: 175.0, 2: -175.0})
    az = np.arange(-180.0, 180.0, 5.0)
    heat = np.zeros((N, az.size))
    heat[:, az == 175.0] = 1.0  # the peak of person 1's column
    report.persons_figure(persons)
    report.heatmap_figure(heat, np.arange(N) / FPS, az, tracks=_doa({1: 175.0, 2: -175.0}),
                          persons=persons)  # fmt: skip
    for fig in (figs[0], figs[2]):
        ax = fig.axes[0]
        lo, hi = ax.get_ylim()
        assert lo < 170 and hi > 190 and hi - lo < 60, (lo, hi)  # centred near 180, zoomed
        for line in ax.lines:
            y = np.asarray(line.get_ydata(), dtype=float)
            assert np.all((y > lo) & (y < hi)), (line.get_label(), y[:3])
        ys = {round(float(np.mean(ln.get_ydata()))) for ln in ax.lines if len(ln.get_ydata())}
        assert ys == {175, 185}, ys
    image = figs[2].axes[0].images[0]
    top = image.get_extent()[3]
    column = np.argmax(image.get_array()[:, 0])  # row of the peak in the drawn image
    bottom = image.get_extent()[2]
    step = (top - bottom) / image.get_array().shape[0]
    assert bottom + (column + 0.5) * step == pytest.approx(175.0)


def test_figures_are_readable_on_a_phone_by_design():
    """Both renditions' smallest text, scaled to the widths they are shown at: at least
    MIN_SCREEN_FONT_PX from a 360 px phone (344 px of content) up to the page's width."""
    fig = report.persons_figure(_persons({1: -20.0, 3: 25.0}))
    assert isinstance(fig, str) and isinstance(fig, report.FigureImage)
    narrow_px = report.NARROW.width_in * report.NARROW.dpi
    wide_px = report.WIDE.width_in * report.WIDE.dpi
    assert fig.narrow_font_px * (360 - 16) / narrow_px >= report.MIN_SCREEN_FONT_PX
    assert fig.font_px * (report.NARROW_MAX_PX + 1 - 16) / wide_px >= report.MIN_SCREEN_FONT_PX
    assert fig.font_px == pytest.approx(report.SMALL_FONT_PT * report.WIDE.dpi / 72)


# ----------------------------------------------------------------- the video's sources


def _videos(tmp_path):
    from avtrack.viz.video import render_overlay_video

    tracks = MOTData([1, 2], [1, 1], [[10.0, 10, 20, 20], [12.0, 10, 20, 20]], [1, 1])
    paths = {}
    for name, codec in (("a.webm", None), ("a.mp4", None), ("part2.mp4", "mp4v")):
        paths[name] = render_overlay_video(tmp_path / name, tracks, None, (64, 48), 10.0,
                                           codec=codec)  # fmt: skip
    return paths


def test_the_h264_mp4_is_offered_first_and_mpeg4_part_2_not_at_all(tmp_path):
    from avtrack.viz.video import h264_available, html_video_type

    if not h264_available():
        pytest.skip("PyAV with libx264 is not installed")
    v = _videos(tmp_path)
    assert html_video_type(v["part2.mp4"]) is None
    page = tmp_path / "index.html"
    write_report(page, "t", {}, {}, video=v["a.webm"],
                 video_links=[v["a.webm"], v["part2.mp4"], v["a.mp4"]])  # fmt: skip
    text = page.read_text()
    mp4, webm = text.index("<source src='data:video/mp4;"), text.index("data:video/webm")
    assert mp4 < webm and "type='video/mp4; codecs=&quot;avc1." in text
    assert "part2.mp4" not in text and "Part 2" not in text
    assert text.index(">a.mp4</a>") < text.index(">a.webm</a>")
    with pytest.raises(ValueError, match=r"'part2\.mp4' is not a WebM"):
        write_report(page, "t", {}, {}, video=v["part2.mp4"])
