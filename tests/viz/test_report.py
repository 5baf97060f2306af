"""The HTML report: scores explained, readable on a narrow screen, diarization rows aligned."""

from __future__ import annotations

from avtrack.io.rttm import RTTMSegment
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
