"""SI-SDR and the identity matching of avtrack.metrics.voices."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.metrics.voices import assign_identities, score_voices, si_sdr


def test_si_sdr_hand_computed():
    # zero-mean reference s = (1, -1, 1, -1), estimate = s + e with e = (1, 1, -1, -1) / 2:
    # <s_hat, s> = 4, alpha = 1, target = s, error = e with ||e||^2 = 1: 10 log10(4 / 1)
    s = np.array([1.0, -1.0, 1.0, -1.0])
    e = np.array([1.0, 1.0, -1.0, -1.0]) / 2
    assert si_sdr(s + e, s) == pytest.approx(10 * np.log10(4.0))
    assert si_sdr(3 * (s + e), s) == pytest.approx(10 * np.log10(4.0))  # scale-invariant
    assert si_sdr(s, s) == np.inf
    assert si_sdr(np.zeros(4), s) == -np.inf


def test_si_sdr_bad_input():
    with pytest.raises(ValueError, match="one length"):
        si_sdr(np.zeros(3), np.ones(4))
    with pytest.raises(ValueError, match="silent"):
        si_sdr(np.ones(4), np.ones(4))


def test_assign_identities_by_frames_matched_while_speaking():
    frames = np.repeat(np.arange(1, 11), 2)
    gt_ids = np.tile([1, 2], 10)
    gt_az = np.tile([30.0, -60.0], 10)
    active = np.tile([True, False], 10)
    active[1::2][5:] = True  # person 2 speaks in frames 6-10
    # track 7 follows person 1, track 9 person 2; track 8 near person 2 but never speaking
    hf = np.concatenate([np.arange(1, 11), np.arange(1, 11), np.arange(1, 4)])
    hi = np.concatenate([np.full(10, 7), np.full(10, 9), np.full(3, 8)])
    ha = np.concatenate([np.full(10, 32.0), np.full(10, -58.0), np.full(3, -61.0)])
    assert assign_identities(frames, gt_ids, gt_az, active, hf, hi, ha) == {1: 7, 2: 9}
    # relabelling the tracks relabels the answer
    assert assign_identities(frames, gt_ids, gt_az, active, hf, hi + 100, ha) == {1: 107, 2: 109}
    # beyond the gate: no match
    assert assign_identities(frames, gt_ids, gt_az, active, hf, hi, ha + 180) == {}


def test_score_voices_improvement_and_missing_voice():
    rng = np.random.default_rng(0)
    a, b = rng.standard_normal(1000), rng.standard_normal(1000)
    scores = score_voices({1: a, 2: b, 3: np.zeros(1000)}, a + b, {5: a + 0.1 * b}, {1: 5})
    assert [s.person for s in scores] == [1, 2]  # a person who never speaks is not scored
    assert scores[0].improvement == pytest.approx(si_sdr(a + 0.1 * b, a) - si_sdr(a + b, a))
    assert scores[0].improvement > 15
    assert scores[1].track is None and scores[1].si_sdr == -np.inf
