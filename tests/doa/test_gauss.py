"""Gaussian VEM DOA tracker (thesis §5.4), its engine extension and the shared DOA interface."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avtrack.config import build_config
from avtrack.doa.base import (
    DEFAULT_OBSERVATIONS,
    FRAME_PERIOD_S,
    TRACKERS,
    UNIFORM_PEAK_FLOOR,
    DOASequence,
    SpeakerActivity,
    circular_peaks,
    heatmap_sequence,
    make_tracker,
)
from avtrack.doa.gauss import (
    GaussConfig,
    GaussDOATracker,
    birth_log_ratio,
    direction_transition,
    lead_gain,
    normalize_direction,
)
from avtrack.doa.model import WeightedDirectionModel, WeightedDirections
from avtrack.io.doa import DOATable, wrap_azimuth
from avtrack.metrics.doa_tracking import evaluate_tracks
from avtrack.simulate.heatmaps import synthetic_heatmaps
from avtrack.vem.engine import VEMEngine
from tests.doa.synthetic import (
    GRID,
    assert_one_track_across_180,
    heatmaps_and_truth,
    moving,
)

OBS = DEFAULT_OBSERVATIONS["gauss"]  # how the tracker observes a heat map by default


def scene(az: np.ndarray, on: np.ndarray, seed: int = 0, observations: str = OBS, **kw):
    """Heat maps of sources ``az (T, K)`` and the matching ground truth (32 ms frames)."""
    w, t, truth = heatmaps_and_truth(az, on, seed, **kw)
    return heatmap_sequence(w, GRID, time_s=t, step=1, observations=observations), truth


def matched_ids(tracks: DOATable, truth: DOATable, speaker: int, frames: np.ndarray):
    """Track ids within 15° of ``speaker`` at the given frames."""
    out = []
    for f in frames:
        gt = truth.azimuth_deg[(truth.frames == f) & (truth.ids == speaker)][0]
        sel = (tracks.frames == f) & tracks.active
        d = np.abs(wrap_azimuth(tracks.azimuth_deg[sel] - gt))
        out.extend(tracks.ids[sel][d <= 15].tolist())
    return out


def test_registry_and_make_tracker():
    assert {"gauss", "vonmises"} <= set(TRACKERS)
    assert isinstance(make_tracker("gauss"), GaussDOATracker)
    with pytest.raises(ValueError, match="name must be one of"):
        make_tracker("kalman")
    with pytest.raises(TypeError, match="config must be a GaussConfig"):
        GaussDOATracker(config=object())
    with pytest.raises(ValueError, match="frame_period_s"):
        GaussDOATracker(frame_period_s=0.0)


def test_single_moving_source_mae_below_3_degrees():
    az = moving(-60.0, 20.0)[:, None]
    seq, truth = scene(az, np.ones(az.shape, bool))
    tracks = make_tracker("gauss").run(seq)
    s = evaluate_tracks(tracks, truth)
    assert s.mae < 3.0
    assert s.md_rate < 0.1 and s.fa_rate < 0.05
    assert len(np.unique(tracks.ids[tracks.active])) == 1


def test_silent_gap_of_one_second_keeps_the_identity():
    az = moving(30.0, 8.0, 300)[:, None]
    on = np.ones(az.shape, bool)
    on[100:131] = False  # 31 frames × 32 ms ≈ 1 s of silence
    seq, truth = scene(az, on, seed=1)
    tracks = make_tracker("gauss").run(seq)
    before = set(matched_ids(tracks, truth, 1, np.arange(60, 100)))
    after = set(matched_ids(tracks, truth, 1, np.arange(140, 300)))
    assert len(before) == 1 and after == before
    silent = (tracks.frames >= 110) & (tracks.frames < 131)
    assert not tracks.active[silent].any()  # eq. 5.43: silent while the speaker pauses


def test_two_crossing_sources_are_tracked():
    az = np.stack([moving(-40.0, 15.0, 300), moving(40.0, -15.0, 300)], axis=1)
    seq, truth = scene(az, np.ones(az.shape, bool), seed=2)
    tracks = make_tracker("gauss").run(seq)
    s = evaluate_tracks(tracks, truth)
    assert s.md_rate < 0.2 and s.fa_rate < 0.2 and s.mae < 4.0
    assert s.id_switches <= 2
    # both speakers are tracked after the crossing (frame ~167), each by one track
    late = np.arange(230, 300)
    ids1, ids2 = matched_ids(tracks, truth, 1, late), matched_ids(tracks, truth, 2, late)
    assert len(ids1) > 0.8 * late.size and len(ids2) > 0.8 * late.size


@settings(max_examples=8, deadline=None)
@given(start=st.floats(150.0, 179.0), speed=st.floats(-40.0, -10.0), seed=st.integers(0, 999))
def test_angles_wrap_at_180(start, speed, seed):
    az = moving(start, -speed, 160)[:, None]  # crosses +180 -> -180 after < 1 s
    seq, truth = scene(az, np.ones(az.shape, bool), seed=seed)
    assert_one_track_across_180(make_tracker("gauss").run(seq), truth)


def test_transition_is_eq_5_27_and_normalisation():
    theta = np.array([0.3, -2.0])
    mu = np.stack([2 * np.cos(theta), 2 * np.sin(theta), [0.5, -1.0]], axis=1)
    d = direction_transition(mu, 0.032)
    for k, th in enumerate(theta):
        expected = np.array([[1, 0, -np.sin(th) * 0.032], [0, 1, np.cos(th) * 0.032], [0, 0, 1]])
        assert np.allclose(d[k], expected)
    u = normalize_direction(mu)
    assert np.allclose(np.hypot(u[:, 0], u[:, 1]), 1.0) and np.allclose(u[:, 2], mu[:, 2])


def test_engine_per_target_transition_and_constraint():
    """The additive engine extension: one D per target and a constraint after every E-S step
    give the same frame as the hand-written eqs. 5.34, 5.36–5.40 with renormalisation."""
    rng = np.random.default_rng(5)
    model = WeightedDirectionModel(obs_var=0.01, log_clutter_density=-1.0)
    engine = VEMEngine(np.eye(3), [model], n_iter=2, update_priors=False, marginal_init=False)
    mu0 = normalize_direction(rng.normal(size=(2, 3)))
    gamma0 = np.stack([np.diag([0.01, 0.01, 0.1])] * 2)
    engine.add_targets(np.array([1, 2]), mu0, gamma0)
    obs = WeightedDirections.from_azimuths(np.deg2rad(GRID), rng.dirichlet(np.ones(72)))
    lam = np.diag([1e-3, 1e-3, 1e-2])
    tr = direction_transition(mu0, 0.032)
    calls = []

    def constrain(mu):
        calls.append(1)
        return normalize_direction(mu)

    engine.step([obs], np.stack([lam, lam]), transition=tr, constrain=constrain)
    assert len(calls) == 2
    # by hand
    mu_pred = np.einsum("nij,nj->ni", tr, mu0)  # D μ, eq. 5.34
    prec_pred = np.linalg.inv(tr @ gamma0 @ np.swapaxes(tr, 1, 2) + lam)
    mu, gamma = mu_pred, np.linalg.inv(prec_pred)
    for _ in range(2):
        log_tau, log_clutter = model.log_likelihood(obs, mu, gamma)  # eq. 5.40
        logits = np.concatenate([log_clutter[:, None], log_tau], axis=1) - np.log(3)
        alpha = np.exp(logits - logits.max(axis=1, keepdims=True))
        alpha /= alpha.sum(axis=1, keepdims=True)  # eq. 5.39
        info, vec = model.information(obs, alpha, 3)
        gamma = np.linalg.inv(info + prec_pred)  # eq. 5.36
        mu = normalize_direction(
            np.einsum("nij,nj->ni", gamma, vec + np.einsum("nij,nj->ni", prec_pred, mu_pred))
        )  # eq. 5.37, then renormalised
    assert np.allclose(engine.mu, mu) and np.allclose(engine.gamma, gamma)
    with pytest.raises(ValueError, match="transition must have shape"):
        engine.step([obs], np.stack([lam, lam]), transition=np.eye(3))


def test_birth_statistic_prefers_smooth_sequences_and_is_rotation_invariant():
    lam = np.diag([1e-3, 1e-3, 1e-2])
    theta = np.deg2rad([10.0, 10.5, 11.0, 11.5])
    b = np.stack([np.cos(theta), np.sin(theta)], axis=1)
    w = np.full(4, 0.3)
    llr, mu, gamma = birth_log_ratio(b, w, 0.003, lam, 0.032, 0.1, -1.0)
    assert llr > 5 and np.degrees(np.arctan2(mu[1], mu[0])) == pytest.approx(11.5, abs=1.0)
    assert np.all(np.linalg.eigvalsh(gamma) > 0)
    rot = theta + 2.0
    llr_rot, _, _ = birth_log_ratio(
        np.stack([np.cos(rot), np.sin(rot)], axis=1), w, 0.003, lam, 0.032, 0.1, -1.0
    )
    assert llr_rot == pytest.approx(llr, rel=1e-9)
    jumpy = np.deg2rad([10.0, 100.0, -50.0, 170.0])
    llr_noise, _, _ = birth_log_ratio(
        np.stack([np.cos(jumpy), np.sin(jumpy)], axis=1), w, 0.003, lam, 0.032, 0.1, -1.0
    )
    assert llr_noise < 0
    with pytest.raises(ValueError, match="weights of a birth sequence"):
        birth_log_ratio(b, np.zeros(4), 0.003, lam, 0.032, 0.1, -1.0)


def test_speaker_activity_window_eq_5_43():
    act = SpeakerActivity(window=3, threshold=0.15)
    act.add(2)
    scores = [act.update(np.array(m))[0] for m in ([0.1, 0.0], [0.1, 0.0], [0.0, 0.2])]
    assert np.allclose(scores[-1], [0.2, 0.2])
    _, active = act.update(np.array([0.0, 0.0]))
    assert active.tolist() == [False, True]
    with pytest.raises(ValueError, match="window"):
        SpeakerActivity(0, 0.1)


def test_sequences_from_weights_and_tables():
    w = np.random.default_rng(0).dirichlet(np.ones(72), size=10)
    seq = DOASequence.from_weights(w, GRID, step=4)
    assert len(seq) == 2 and seq.frames.tolist() == [3, 7]
    assert np.allclose(seq.weight[0], w[:4].mean(axis=0))
    last = DOASequence.from_weights(w, GRID, step=4, mode="last", peaks_only=True)
    assert np.allclose(last.weight[1], w[7][circular_peaks(w[7])])
    table = DOATable(
        np.array([0, 1, 1, 5]),
        np.array([0.0, 0.008, 0.008, 0.04]),
        -np.ones(4, int),
        np.array([10.0, 20.0, 30.0, 40.0]),
        np.zeros(4),
        np.array([0.4, 0.2, 0.8, 0.4]),
        np.array([1, 1, 1, 1], bool),
    )
    pooled = DOASequence.from_table(table, step=2)
    assert pooled.frames.tolist() == [1, 3, 5]
    assert pooled.time_s == pytest.approx([0.008, 0.024, 0.04])
    assert pooled.azimuth_deg[0].tolist() == [10.0, 20.0, 30.0]
    assert pooled.weight[0] == pytest.approx([0.4, 0.2, 0.8]) and pooled.weight[1].size == 0
    with pytest.raises(ValueError, match="weights must have shape"):
        DOASequence.from_weights(w, GRID[:5])
    with pytest.raises(ValueError, match="step"):
        DOASequence.from_weights(w, GRID, step=0)
    with pytest.raises(ValueError, match="mode"):
        DOASequence.from_weights(w, GRID, mode="max")


def test_step_and_config_validation():
    tracker = GaussDOATracker()
    with pytest.raises(ValueError, match="weight must be finite and >= 0"):
        tracker.step(np.zeros(2), np.array([0.5, -0.1]))
    with pytest.raises(ValueError, match="one length"):
        tracker.step(np.zeros(2), np.zeros(3))
    with pytest.raises(ValueError, match="finite"):
        tracker.step(np.array([np.inf]), np.ones(1))
    assert len(tracker.step(np.zeros(0), np.zeros(0))) == 0  # an empty frame is fine
    with pytest.raises(ValueError, match=r"GaussConfig\.obs_var"):
        GaussConfig(obs_var=-1.0)
    with pytest.raises(ValueError, match=r"GaussConfig\.n_iter"):
        GaussConfig(n_iter=0)
    with pytest.raises(ValueError, match="velocity_decay"):
        GaussConfig(velocity_decay=1.5)
    with pytest.raises(ValueError, match="unknown field"):
        build_config(GaussConfig, {"sigma": 1.0})


def test_lead_gain_is_eq_5_27_iterated():
    # two frames of 32 ms with velocity decay 0.98: the direction moves v·Δt (1 + 0.98)
    assert lead_gain(0.032, 0.98, 0.064) == pytest.approx(0.032 * 1.98)
    assert lead_gain(0.032, 1.0, 0.2) == 0.2  # constant velocity: v · lead
    assert lead_gain(0.032, 0.5, 0.0) == 0.0
    # many frames: the geometric sum tends to Δt / (1 − a)
    assert lead_gain(0.032, 0.5, 100.0) == pytest.approx(0.064)
    # Δt of the recursion applied n = lead / Δt times, checked against the transition matrix
    mu = np.array([[1.0, 0.0, 0.7]])
    state = mu.copy()
    for _ in range(5):
        state = normalize_direction((direction_transition(state, 0.032, 0.9)[0] @ state[0])[None])
    # the linearised step is a tangent move; for small angles it matches the rotation
    assert np.arctan2(state[0, 1], state[0, 0]) == pytest.approx(
        0.7 * lead_gain(0.032, 0.9, 0.16), rel=2e-3
    )


def test_lead_reports_the_predicted_direction_and_changes_nothing_else():
    az = moving(-60.0, 20.0)[:, None]
    seq, _ = scene(az, np.ones(az.shape, bool))
    cfg = GaussConfig(velocity_decay=0.95)
    plain = GaussDOATracker(cfg)
    ahead = GaussDOATracker(GaussConfig(velocity_decay=0.95, lead_s=0.3))
    gain = lead_gain(FRAME_PERIOD_S, 0.95, 0.3)
    for a, w in zip(seq.azimuth_deg, seq.weight, strict=True):
        p, q = plain.step(a, w), ahead.step(a, w)
        np.testing.assert_array_equal(p.ids, q.ids)
        np.testing.assert_array_equal(p.active, q.active)
        np.testing.assert_allclose(ahead.engine.mu, plain.engine.mu)
        shift = wrap_azimuth(q.azimuth_deg - p.azimuth_deg)
        np.testing.assert_allclose(shift, np.rad2deg(gain * plain.engine.mu[:, 2]), atol=1e-9)
    for bad in (-1.0, np.nan, True):
        with pytest.raises(ValueError, match=r"GaussConfig\.lead_s"):
            GaussConfig(lead_s=bad)


def test_stonesoup_gmphd_peer_tracks_a_source():
    pytest.importorskip("stonesoup")
    from avtrack.doa.gmphd import GMPHDConfig, GMPHDPeer

    az = moving(100.0, 15.0, 80)[:, None]
    rng = np.random.default_rng(3)
    w = synthetic_heatmaps(az, np.ones(az.shape, bool), GRID, rng)
    t = np.arange(80) * FRAME_PERIOD_S
    seq = DOASequence.from_weights(w, GRID, time_s=t, peaks_only=True, floor=0.05)
    _, truth = scene(az, np.ones(az.shape, bool))
    tracks = GMPHDPeer().run(seq)
    s = evaluate_tracks(tracks, truth, time_range_s=(0.5, 3.0))
    assert s.mae < 4.0 and s.md_rate < 0.2
    with pytest.raises(ValueError, match=r"GMPHDConfig\.prob_detection"):
        GMPHDConfig(prob_detection=0.0)


def test_heatmap_sequence_above_median_removes_the_floor():
    # two tracker frames of 4 candidates, step 2: block means, then minus each frame's median
    w = np.array(
        [[0.1, 0.2, 0.3, 0.4], [0.1, 0.2, 0.3, 0.4], [0.4, 0.3, 0.2, 0.1], [0.2, 0.1, 0.4, 0.3]]
    )
    az = np.array([-90.0, 0.0, 90.0, 180.0])
    seq = heatmap_sequence(w, az, step=2, observations="above-median")
    np.testing.assert_allclose(seq.weight[0], [0.0, 0.0, 0.05, 0.15], atol=1e-12)
    np.testing.assert_allclose(seq.weight[1], [0.05, 0.0, 0.05, 0.0], atol=1e-12)
    assert all(a.size == 4 for a in seq.azimuth_deg)  # every candidate stays an observation
    raw = heatmap_sequence(w, az, step=2, observations="all")
    np.testing.assert_allclose(raw.weight[0], [0.1, 0.2, 0.3, 0.4])
    peaks = heatmap_sequence(w, az, step=2, observations="peaks", floor=0.35)
    np.testing.assert_allclose(peaks.azimuth_deg[0], [180.0])
    # peaks of each block's last frame at or above 1.44 x the uniform weight 1/4 = 0.36
    over = heatmap_sequence(w, az, step=2, observations="peaks-over-uniform")
    assert UNIFORM_PEAK_FLOOR / 4 == pytest.approx(0.36)
    np.testing.assert_allclose(over.azimuth_deg[0], [180.0])  # [.1 .2 .3 .4]: 0.4 >= 0.36
    np.testing.assert_allclose(over.weight[0], [0.4])
    np.testing.assert_allclose(over.azimuth_deg[1], [90.0])  # [.2 .1 .4 .3], not the mean
    scaled = heatmap_sequence(0.5 * w + 0.5 / 4, az, step=2, observations="peaks-over-uniform")
    assert all(a.size == 0 for a in scaled.azimuth_deg)  # pulled halfway to uniform: 0.325
    with pytest.raises(ValueError, match="observations must be one of"):
        heatmap_sequence(w, az, observations="median")
    with pytest.raises(ValueError, match="baseline must be"):
        DOASequence.from_weights(w, az, baseline="mean")


def test_tracks_moving_apart_in_velocity_are_not_merged():
    # two tracks at one direction, one moving +20°/s and one -20°/s, observed at both
    tracker = GaussDOATracker()
    eng = tracker.engine
    v = np.deg2rad(20.0)
    ids = tracker._new_ids(2)
    mu = np.array([[1.0, 0.0, v], [1.0, 0.0, -v]])
    eng.add_targets(ids, mu, np.tile(np.diag([1e-4, 1e-4, 1e-4]), (2, 1, 1)))
    tracker.activity.add(2, 1.0)
    tracker.shadowed = np.zeros(2, dtype=np.int64)
    for k in range(1, 30):  # ~1 s, longer than merge_s
        a = np.array([20.0, -20.0]) * k * FRAME_PERIOD_S
        out = tracker.step(a, np.array([0.5, 0.5]))
    assert set(out.ids) == set(ids)
    end = 20 * 29 * FRAME_PERIOD_S
    np.testing.assert_allclose(np.sort(out.azimuth_deg), [-end, end], atol=3.0)


def test_zero_weight_candidates_change_nothing():
    # eq. 5.22: a weight-0 candidate has precision 0 (pure clutter), so leaving the zeros of
    # "above-median" out of each frame must give the same tracks and activity statistics
    az = np.stack([moving(-60, 20), moving(80, -15)], axis=1)
    seq, _ = scene(az, np.ones(az.shape, bool), seed=3, observations="above-median")
    assert any((w == 0).any() for w in seq.weight)
    keep = [w > 0 for w in seq.weight]
    sparse = DOASequence(
        seq.frames,
        seq.time_s,
        tuple(a[k] for a, k in zip(seq.azimuth_deg, keep, strict=True)),
        tuple(w[k] for w, k in zip(seq.weight, keep, strict=True)),
    )
    full, thin = GaussDOATracker().run(seq), GaussDOATracker().run(sparse)
    assert len(full) > 0
    np.testing.assert_array_equal(full.ids, thin.ids)
    np.testing.assert_array_equal(full.active, thin.active)
    np.testing.assert_allclose(full.azimuth_deg, thin.azimuth_deg, atol=1e-9)
    np.testing.assert_allclose(full.weight, thin.weight, atol=1e-12)
