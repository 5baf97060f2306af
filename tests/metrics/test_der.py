"""Diarization error rate (NIST, optimal mapping, collars): hand cases and pyannote parity."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from avtrack.io.rttm import RTTMSegment
from avtrack.metrics.der import DERComponents, diarization_error_rate


def seg(start, end, spk):
    return RTTMSegment("f", start, end - start, spk)


REF = [seg(0, 10, "a"), seg(10, 20, "b")]


def test_perfect_and_relabelled_hypotheses_score_zero():
    hyp = [seg(0, 10, "x"), seg(10, 20, "y")]
    d = diarization_error_rate(REF, hyp, collar=0.0)
    assert d == DERComponents(20.0, 0.0, 0.0, 0.0) and d.rate == 0.0


def test_hand_computed_components():
    # x covers a for 0-8 and b for 12-15; y covers b for 15-20; nothing 8-12
    hyp = [seg(0, 8, "x"), seg(12, 15, "x"), seg(15, 20, "y"), seg(25, 26, "z")]
    d = diarization_error_rate(REF, hyp, collar=0.0)
    # mapping a->x (8 s), b->y (5 s); 12-15 is b spoken by x: confusion
    assert d.total == pytest.approx(20.0)
    assert d.missed == pytest.approx(4.0)  # 8-12
    assert d.false_alarm == pytest.approx(1.0)  # 25-26
    assert d.confusion == pytest.approx(3.0)
    assert d.rate == pytest.approx(8.0 / 20.0)


def test_collar_removes_time_around_reference_boundaries():
    hyp = [seg(0, 9.8, "x"), seg(9.8, 20, "y")]  # boundary 0.2 s early
    assert diarization_error_rate(REF, hyp, collar=0.0).errors == pytest.approx(0.2)
    d = diarization_error_rate(REF, hyp, collar=0.25)
    assert d.errors == pytest.approx(0.0)
    # scored: 0.25-9.75 and 10.25-19.75 (the collars at 0, 10 and 20 are not)
    assert d.total == pytest.approx(19.0)


def test_overlap_and_skip_overlap():
    ref = [seg(0, 10, "a"), seg(5, 10, "b")]
    hyp = [seg(0, 10, "x")]
    d = diarization_error_rate(ref, hyp, collar=0.0)
    assert d.total == pytest.approx(15.0) and d.missed == pytest.approx(5.0)
    d = diarization_error_rate(ref, hyp, collar=0.0, skip_overlap=True)
    assert d.total == pytest.approx(5.0) and d.errors == pytest.approx(0.0)


def test_empty_inputs_and_corpus_sum():
    assert diarization_error_rate([], []).total == 0.0
    assert np.isnan(diarization_error_rate([], []).rate)
    d = diarization_error_rate(REF, [], collar=0.0)
    assert d.missed == pytest.approx(20.0) and d.rate == pytest.approx(1.0)
    total = DERComponents.sum([d, DERComponents(10.0, 0.0, 1.0, 0.0)])
    assert total == DERComponents(30.0, 20.0, 1.0, 0.0)
    with pytest.raises(ValueError, match="collar"):
        diarization_error_rate(REF, REF, collar=-1.0)
    with pytest.raises(TypeError, match="RTTMSegment"):
        diarization_error_rate([(0, 1, "a")], REF)


def random_turns(rng, n_speakers: int, prefix: str) -> list[RTTMSegment]:
    out = []
    for k in range(n_speakers):
        t = rng.uniform(0, 5)
        while t < 60:
            d = rng.uniform(0.3, 5)
            out.append(RTTMSegment("f", round(t, 3), round(d, 3), f"{prefix}{k}"))
            t += d + rng.uniform(0.1, 8)
    return out


def test_matches_pyannote_metrics():
    pytest.importorskip("pyannote.metrics")
    from pyannote.core import Annotation, Segment
    from pyannote.metrics.diarization import DiarizationErrorRate

    def annotation(segs):
        a = Annotation()
        for i, s in enumerate(segs):
            a[Segment(s.start, s.end), i] = s.speaker
        return a

    rng = np.random.default_rng(0)
    for _ in range(15):
        ref = random_turns(rng, int(rng.integers(1, 5)), "r")
        hyp = random_turns(rng, int(rng.integers(0, 6)), "h")
        for collar in (0.0, 0.25):
            for skip in (False, True):
                metric = DiarizationErrorRate(collar=2 * collar, skip_overlap=skip)
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")  # uem approximated by the extents
                    ref_d = metric(annotation(ref), annotation(hyp), detailed=True)
                mine = diarization_error_rate(ref, hyp, collar=collar, skip_overlap=skip)
                assert mine.total == pytest.approx(ref_d["total"], abs=1e-9)
                assert mine.missed == pytest.approx(ref_d["missed detection"], abs=1e-9)
                assert mine.false_alarm == pytest.approx(ref_d["false alarm"], abs=1e-9)
                assert mine.confusion == pytest.approx(ref_d["confusion"], abs=1e-9)
