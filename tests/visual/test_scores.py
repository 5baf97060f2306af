"""Births from the upper class of the detector's scores (visual/scores.py) and the frame-rate
scaling of the visual tracker's per-frame motion parameters."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avtrack.io.mot import MOTData
from avtrack.visual.ovbt import REFERENCE_FPS, OVBTConfig, OVBTracker, track_mot
from avtrack.visual.scores import BINS, MIN_SCORES, MIN_SEPARATION, ScoreSplit, otsu_threshold
from tests.visual.synthetic import crossing_scene


def test_otsu_splits_two_clusters_between_them():
    scores = np.array([0.1, 0.12, 0.15, 0.11, 0.9, 0.92, 0.95, 0.91])
    t = otsu_threshold(scores)
    assert 0.15 < t <= 0.9
    assert np.array_equal(scores >= t, scores > 0.5)


def test_otsu_has_no_split_for_one_value_or_too_few():
    assert otsu_threshold(np.full(100, 0.7)) is None
    assert otsu_threshold(np.array([0.3])) is None
    assert otsu_threshold(np.array([np.nan, np.nan, 0.5])) is None


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 10_000), scale=st.floats(0.01, 100.0), shift=st.floats(-50.0, 50.0))
def test_split_does_not_depend_on_the_score_scale(seed, scale, shift):
    """Any detector's confidences: an increasing affine change of the scores changes nothing."""
    rng = np.random.default_rng(seed)
    scores = np.r_[rng.normal(0.8, 0.1, 80), rng.normal(0.35, 0.15, 20)]
    t1, t2 = otsu_threshold(scores), otsu_threshold(scale * scores + shift)
    assert (t1 is None) == (t2 is None)  # the same decision to split or not
    if t1 is None or t2 is None:
        return
    upper1 = scores >= t1
    upper2 = scale * scores + shift >= t2
    # the same split up to scores lying within rounding of the threshold
    assert np.count_nonzero(upper1 != upper2) <= 1


def test_one_class_of_scores_is_not_split():
    """A detector whose scores form one bell (no false alarms to tell apart): no threshold,
    every detection may start a target; the same bell with a cluster of low-scoring false
    alarms is split between the two."""
    rng = np.random.default_rng(0)
    people = np.clip(rng.normal(0.8, 0.1, 3000), 0.5, 1.0)
    assert otsu_threshold(people) is None
    with_fa = np.r_[people, np.clip(rng.normal(0.3, 0.08, 300), 0.0, 1.0)]
    t = otsu_threshold(with_fa)
    assert t is not None and 0.4 < t < 0.65
    split = ScoreSplit()
    for k in range(0, 3000, 10):
        assert split.update(people[k:k + 10]).all()


def test_running_split_lets_every_detection_start_a_target_until_enough_scores():
    split = ScoreSplit()
    assert split.update(np.array([0.9, 0.1, 0.5])).all()  # 3 < MIN_SCORES scores
    rng = np.random.default_rng(0)
    for _ in range(MIN_SCORES // 5 + 1):
        split.update(np.r_[rng.normal(0.9, 0.03, 4), rng.normal(0.3, 0.05, 1)])
    assert split.threshold is not None and 0.4 < split.threshold < 0.85
    assert split.update(np.array([0.95, 0.2])).tolist() == [True, False]
    assert split.update(np.zeros(0)).shape == (0,)


def _scene_with_weak_false_alarm(n=80):
    """One person (strong detections) walking, a weak false alarm flickering at random places in
    frames 1-29 (so that the running split has seen both kinds of score), then a weak false alarm
    at a fixed place in every frame from 30 on."""
    rng = np.random.default_rng(1)
    rows = []
    for f in range(1, n + 1):
        rows.append((f, [100.0 + 3 * f, 200.0, 50.0, 120.0], 0.95))
        if f < 30:
            rows.append((f, [rng.uniform(0, 500), rng.uniform(0, 300), 40.0, 100.0], 0.55))
        else:
            rows.append((f, [400.0, 100.0, 40.0, 100.0], 0.55))
    frames = np.array([r[0] for r in rows], float)
    boxes = np.array([r[1] for r in rows])
    scores = np.array([r[2] for r in rows])
    return MOTData(frames, np.full(len(rows), -1.0), boxes, scores)


def test_weak_detections_never_start_a_target_but_strong_ones_do():
    dets = _scene_with_weak_false_alarm()
    cfg = replace(OVBTConfig(), startup_birth=False)
    res = track_mot(dets, config=cfg, image_size=(640, 480))
    centres = res.boxes[:, 0] + res.boxes[:, 2] / 2
    assert len(res) > 30 and np.all(np.abs(centres - 420.0) > 50)  # no track on the weak one
    # the same scene without the split: the weak false alarm becomes a track
    off = track_mot(dets, config=replace(cfg, birth_score_split=False), image_size=(640, 480))
    assert np.any(np.abs(off.boxes[:, 0] + off.boxes[:, 2] / 2 - 420.0) < 5)
    # a fixed threshold does the same as the split here
    fixed = track_mot(dets, config=replace(cfg, birth_min_score=0.9), image_size=(640, 480))
    assert len(fixed) > 30 and np.all(np.abs(fixed.boxes[:, 0] + fixed.boxes[:, 2] / 2
                                             - 420.0) > 50)


def test_a_weak_detection_still_updates_its_target():
    """Once a target exists, its detections turning weak update it and keep it alive (they are
    used by the association, only not by births); they show it only with weak_evidence 1."""
    def run(cfg, n_weak):
        tr = OVBTracker(cfg, image_size=(640, 480))
        outs = []
        for f in range(10 + n_weak + 5):
            score = 0.3 if 10 <= f < 10 + n_weak else 0.95
            outs.append(tr.step(np.array([[100.0 + 2 * f, 200.0, 50.0, 120.0]]),
                                np.array([score])))
        return tr, outs

    cfg = replace(OVBTConfig(), birth_min_score=0.9)
    tr, outs = run(replace(cfg, weak_evidence=1.0), 30)
    assert outs[39].ids.tolist() == [1]  # shown through the weak detections
    assert abs(outs[39].boxes[0, 0] - (100.0 + 2 * 39)) < 5
    tr, outs = run(cfg, 30)  # default: followed, not shown, shown again with its identity
    assert outs[39].ids.tolist() == [] and tr.engine.ids.tolist() == [1]
    assert abs(tr.engine.mu[0, 0] - (125.0 + 2 * 44)) < 5  # box centre x, followed all along
    assert outs[-1].ids.tolist() == [1] and abs(outs[-1].boxes[0, 0] - (100.0 + 2 * 44)) < 5


@pytest.mark.parametrize("weak_evidence", [1.0, 0.0])
def test_weak_evidence_one_and_no_velocity_scaling_are_the_previous_tracker(weak_evidence):
    """weak_evidence 1 shows targets on every detection's evidence: the visibility it outputs
    is the one that decides deaths."""
    dets = _scene_with_weak_false_alarm()
    tr = OVBTracker(replace(OVBTConfig(), weak_evidence=weak_evidence), image_size=(640, 480))
    for sl in dets.frame_slices(dets.n_frames):
        out = tr.step(dets.boxes[sl], dets.scores[sl])
        if weak_evidence == 1.0:
            assert np.array_equal(tr.p_shown, tr.p_visible)
        assert np.all(out.p_visible > 0.5)


def test_scores_must_be_finite():
    tr = OVBTracker(image_size=(640, 480))
    with pytest.raises(ValueError, match="finite"):
        tr.step(np.array([[1.0, 1.0, 10.0, 20.0]]), np.array([np.nan]))


def test_frame_rate_scales_size_noise_and_birth_velocity():
    cfg = OVBTConfig()
    slow = OVBTracker(cfg, (640, 480), fps=REFERENCE_FPS / 2)
    ref = OVBTracker(cfg, (640, 480))
    assert slow._dyn_std_size == pytest.approx(2 * cfg.dyn_std_size)
    assert slow._birth_velocity_std == pytest.approx(2 * cfg.birth_velocity_std)
    assert ref._dyn_std_size == cfg.dyn_std_size
    mu = np.array([[100.0, 100.0, 40.0, 80.0, 0.0, 0.0]])
    assert np.allclose(slow._dyn_var(mu)[0, 2:4], 4 * ref._dyn_var(mu)[0, 2:4])
    assert np.allclose(slow._dyn_var(mu)[0, :2], ref._dyn_var(mu)[0, :2])  # position noise kept


@pytest.mark.parametrize("fps", [0.0, -5.0, float("nan"), 5000.0])
def test_bad_frame_rate_is_refused(fps):
    with pytest.raises(ValueError, match="fps"):
        OVBTracker(image_size=(640, 480), fps=fps)


def test_reference_frame_rate_is_the_default():
    _, dets, _ = crossing_scene(3)
    a = track_mot(dets, image_size=(640, 480))
    b = track_mot(dets, image_size=(640, 480), fps=REFERENCE_FPS)
    assert np.array_equal(a.ids, b.ids) and np.array_equal(a.boxes, b.boxes)


def _otsu_by_histogram(x: np.ndarray) -> float | None:
    """Otsu's threshold from ``np.histogram`` and boolean masks, as written in the textbook."""
    counts, edges = np.histogram(x, bins=BINS, range=(x.min(), x.max()))
    centres = 0.5 * (edges[:-1] + edges[1:])
    w0 = np.cumsum(counts)[:-1].astype(float)
    s0 = np.cumsum(counts * centres)[:-1]
    w1, total = x.size - w0, float((counts * centres).sum())
    between = w0 * w1 * (s0 / w0 - (total - s0) / w1) ** 2
    t = float(edges[1:-1][int(np.argmax(between))])
    lower, upper = x[x < t], x[x >= t]
    spread = np.sqrt(0.5 * (lower.var() + upper.var()))
    return t if abs(upper.mean() - lower.mean()) >= MIN_SEPARATION * spread else None


def test_otsu_on_sorted_scores_equals_the_histogram_computation():
    rng = np.random.default_rng(0)
    for k in range(300):
        n = int(rng.integers(60, 600))
        x = (np.r_[rng.normal(0.3, 0.1, n // 3), rng.normal(0.9, 0.05, n)] if k % 3 else
             np.round(rng.random(n), 2))
        assert otsu_threshold(x) == _otsu_by_histogram(x)


def test_running_split_is_the_split_of_the_scores_when_last_due():
    """The split is due again once the scores seen have grown by 5 %; it is then Otsu's
    threshold of all the scores so far."""
    rng = np.random.default_rng(2)
    split, seen, at_split = ScoreSplit(), [], None
    for _ in range(60):
        frame = np.r_[rng.normal(0.9, 0.04, 5), rng.normal(0.4, 0.1, 2)]
        seen.append(frame)
        n = sum(f.size for f in seen)
        if n >= MIN_SCORES and (at_split is None or n >= 1.05 * at_split):
            at_split = n
        got = split.update(frame)
        t = None if at_split is None else otsu_threshold(np.concatenate(seen)[:at_split])
        assert split.threshold == t
        assert got.tolist() == (frame >= t if t is not None else np.ones(7, bool)).tolist()
