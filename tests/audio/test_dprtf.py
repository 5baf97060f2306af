"""Online DP-RTF: RLS (Algorithm 2) against least squares, recovery of a known CTF, the
consistency test (eq. 5.11), noise handling and the two solvers' agreement."""

from __future__ import annotations

import sys
from dataclasses import replace

import numpy as np
import pytest

from avtrack.audio import _dprtf_kernel
from avtrack.audio.dprtf import (
    SOLVERS,
    DPRTFConfig,
    DPRTFEstimator,
    dprtf_features,
    forgetting_factor,
    rls_pair_updates,
)
from avtrack.audio.noise import NoiseConfig


def ctf_mixture(seed: int, n_mics: int = 4, n_freqs: int = 12, n_frames: int = 150, q: int = 8):
    """STFT frames of one source through known CTFs, x^i_t = sum_q a^i_q s_{t-q} (eq. 5.1)."""
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((n_mics, q, n_freqs)) + 1j * rng.standard_normal((n_mics, q, n_freqs))
    a *= np.exp(-0.4 * np.arange(q))[None, :, None]  # decaying reverberation
    s = rng.standard_normal((n_freqs, n_frames + q)) + 1j * rng.standard_normal(
        (n_freqs, n_frames + q)
    )
    x = np.zeros((n_mics, n_freqs, n_frames), dtype=complex)
    for k in range(q):
        x += a[:, k, :, None] * s[None, :, q - k : q - k + n_frames]
    return x, a


def test_forgetting_factor_hand_values():
    # I = 4, Q = 8: P = (IQ - 1) / (I(I-1)/2) = 31/6, lambda = (P-1)/(P+1) = 25/37
    assert forgetting_factor(4, 8) == pytest.approx(25 / 37)
    assert forgetting_factor(8, 8) == pytest.approx((63 / 28 - 1) / (63 / 28 + 1))
    assert forgetting_factor(4, 1) == 0.0  # P clipped to 1
    with pytest.raises(ValueError, match="n_mics must be >= 2"):
        forgetting_factor(1, 8)


def test_rls_pair_updates_equal_least_squares():
    """M Sherman-Morrison steps from P = I / delta: a = (delta I + sum x* x^T)^-1 sum x* y."""
    rng = np.random.default_rng(3)
    f_, m_, n_ = 5, 7, 4
    x = rng.standard_normal((f_, m_, n_)) + 1j * rng.standard_normal((f_, m_, n_))
    y = rng.standard_normal((f_, m_)) + 1j * rng.standard_normal((f_, m_))
    delta = 0.3
    a, p = rls_pair_updates(
        np.zeros((f_, n_), complex), np.tile(np.eye(n_) / delta, (f_, 1, 1)).astype(complex), x, y
    )
    for f in range(f_):
        r = delta * np.eye(n_) + x[f].conj().T @ x[f]  # R = sum_m x~^{m*} x~^{mT}   (eq. 5.9)
        rhs = x[f].conj().T @ y[f]
        np.testing.assert_allclose(a[f], np.linalg.solve(r, rhs), atol=1e-10)
        np.testing.assert_allclose(p[f], np.linalg.inv(r), atol=1e-10)


@pytest.mark.parametrize("solver", ["cholesky", "rls"])
def test_rls_recovers_a_known_ctf(solver):
    x, a = ctf_mixture(0)
    est = DPRTFEstimator(4, x.shape[1], config=DPRTFConfig(noise=None, solver=solver))
    out = est.run(x)
    true = a[1:, 0, :] / a[:1, 0, :]  # DP-RTF a^i_0 / a^1_0
    expected = true / np.sqrt(1 + np.abs(true) ** 2)
    assert out.valid[:, :, -1].all()
    np.testing.assert_allclose(out.values[:, :, -1], expected, atol=1e-6)
    # once enough equations have been seen (a few frames), every estimate is right
    assert np.abs(out.values[:, :, 60:] - expected[:, :, None]).max() < 1e-5
    # no feature before a bin has had as many equations as unknowns (P = 31/6 frames)
    assert est.min_frames == 6 and not out.valid[:, :, :5].any()


def test_solvers_agree_frame_by_frame():
    rng = np.random.default_rng(2)
    x = rng.standard_normal((4, 10, 80)) + 1j * rng.standard_normal((4, 10, 80))
    outs = [
        DPRTFEstimator(4, 10, config=DPRTFConfig(noise=None, solver=s)).run(x)
        for s in ("cholesky", "rls")
    ]
    np.testing.assert_array_equal(outs[0].valid, outs[1].valid)
    np.testing.assert_allclose(outs[0].values, outs[1].values, atol=1e-7)


def test_features_do_not_depend_on_the_signal_scale():
    x, _ = ctf_mixture(4, n_frames=60)
    out1 = DPRTFEstimator(4, x.shape[1], config=DPRTFConfig(noise=None)).run(x)
    out2 = DPRTFEstimator(4, x.shape[1], config=DPRTFConfig(noise=None)).run(1e-4 * x)
    np.testing.assert_allclose(out1.values, out2.values, atol=1e-8)


def test_consistency_test_hand_cases():
    # identical estimates: d = 1, feature c / sqrt(1 + |c|^2)
    v, ok, d = dprtf_features(np.array([0.5j]), np.array([0.5j]))
    assert ok[0] and d[0] == pytest.approx(1.0)
    assert v[0] == pytest.approx(0.5j / np.sqrt(1.25))
    # opposite estimates: c_1 = (1, 1), c_2 = (1, -1) are orthogonal, d = 0
    v, ok, d = dprtf_features(np.array([1.0 + 0j]), np.array([-1.0 + 0j]))
    assert not ok[0] and d[0] == pytest.approx(0.0) and v[0] == 0
    # d = |1 + conj(c1) c2| / sqrt((1 + |c1|^2)(1 + |c2|^2)): 1 and 2 give 3 / sqrt(10)
    _, ok, d = dprtf_features(np.array([1.0 + 0j]), np.array([2.0 + 0j]), threshold=0.94)
    assert d[0] == pytest.approx(3 / np.sqrt(10)) and ok[0]
    _, ok, _ = dprtf_features(np.array([1.0 + 0j]), np.array([2.0 + 0j]), threshold=0.95)
    assert not ok[0]
    # phase-only features: modulus 1/sqrt(2); non-finite estimates are rejected
    v, ok, _ = dprtf_features(np.array([3j, np.inf]), np.array([3j, 1.0]), phase_only=True)
    assert v[0] == pytest.approx(1j / np.sqrt(2)) and ok.tolist() == [True, False]


def test_two_sources_in_one_bin_fail_the_consistency_test():
    """Two sources of equal power at every bin: no single CTF explains the frames, and the
    estimates with the two reference channels often disagree."""
    x1, _ = ctf_mixture(10, n_frames=200)
    x2, _ = ctf_mixture(11, n_frames=200)
    single = DPRTFEstimator(4, 12, config=DPRTFConfig(noise=None)).run(x1)
    mixed = DPRTFEstimator(4, 12, config=DPRTFConfig(noise=None)).run(x1 + x2)
    assert single.valid[:, :, 20:].mean() > 0.99
    assert mixed.valid[:, :, 20:].mean() < 0.9


def test_noise_only_input_gives_no_features_and_speech_bins_do():
    rng = np.random.default_rng(7)
    i_, f_, t_ = 4, 16, 400
    noise = 0.1 * (rng.standard_normal((i_, f_, t_)) + 1j * rng.standard_normal((i_, f_, t_)))
    x, _ = ctf_mixture(8, n_freqs=f_, n_frames=t_)
    x[:, :, :250] = 0.0  # the source starts at frame 250
    est = DPRTFEstimator(i_, f_, config=DPRTFConfig(noise=NoiseConfig()))
    out = est.run(noise + x)
    # minimum statistics settles within its 1 s window (125 frames)
    assert out.speech[:, 20:250].mean() < 0.1 and out.speech[:, 150:250].mean() < 0.02
    assert out.valid[:, :, 150:250].mean() < 0.02
    assert out.speech[:, 260:360].mean() > 0.9 and out.valid[:, :, 260:360].mean() > 0.8


def turn_change(gap: int, seed: int = 7, n_freqs: int = 16, n_mics: int = 4):
    """Talker A (frames 150-249), ``gap`` frames of noise only, then talker B for 100 frames:
    two sources with their own CTFs (eq. 5.1), silent outside their turns, in weak noise.
    Returns the STFT and the DP-RTF features ``c / sqrt(1 + |c|^2)`` of A and B."""
    rng = np.random.default_rng(seed)
    i_, q, t_ = n_mics, 8, 250 + gap + 100
    x = 0.1 * (
        rng.standard_normal((i_, n_freqs, t_)) + 1j * rng.standard_normal((i_, n_freqs, t_))
    )
    truth = []
    for start in (150, 250 + gap):
        a = rng.standard_normal((i_, q, n_freqs)) + 1j * rng.standard_normal((i_, q, n_freqs))
        a *= np.exp(-0.4 * np.arange(q))[None, :, None]
        s = np.zeros((n_freqs, t_), dtype=complex)
        s[:, start : start + 100] = rng.standard_normal((n_freqs, 100)) + 1j * rng.standard_normal(
            (n_freqs, 100)
        )
        for lag in range(q):
            x[:, :, lag:] += a[:, lag, :, None] * s[None, :, : t_ - lag]
        r = a[1:, 0, :] / a[:1, 0, :]
        truth.append(r / np.sqrt(1 + np.abs(r) ** 2))
    return x, truth[0], truth[1]


def test_memory_ages_over_noise_frames_so_a_new_talker_is_not_mixed_with_the_last():
    """After a pause, the first features of a new talker are the new talker's DP-RTFs.

    With the RLS memory frozen over the noise frames (``forget_over_noise=False``), the first
    speech frames of B still carry A's equations at full weight: many of B's first features
    are a mixture of the two. Ageing the memory by ``lambda`` per frame of the pause and
    waiting for enough equations of B removes most of them."""
    gap, b0 = 20, 270
    x, _, feat_b = turn_change(gap, seed=9)
    near_b = {}
    for forget in (True, False):
        cfg = DPRTFConfig(noise=NoiseConfig(), forget_over_noise=forget)
        outs = [DPRTFEstimator(4, 16, config=replace(cfg, solver=s)).run(x) for s in SOLVERS]
        # both solvers age the memory the same way (Algorithm 2 divides P by up to
        # lambda^-g = 1e5 after a pause, hence a looser tolerance than without pauses)
        np.testing.assert_array_equal(outs[0].valid, outs[1].valid)
        np.testing.assert_allclose(outs[0].values, outs[1].values, atol=1e-5)
        out = outs[0]
        assert not out.speech[:, b0 - 4 : b0].any()  # the end of the pause is noise
        ok = out.valid[:, :, b0 : b0 + 10]
        err = np.abs(out.values[:, :, b0 : b0 + 10] - feat_b[:, :, None])
        assert ok.sum() > 200
        near_b[forget] = np.mean(err[ok] < 0.1)
    # 0.85 vs 0.66 here; 0.72-0.85 vs 0.52-0.68 over seeds 7-10 and pauses of 20 or 40 frames
    assert near_b[True] > 0.75
    assert near_b[True] > near_b[False] + 0.1


def test_features_wait_for_enough_equations_after_a_pause():
    """A bin's memory after ``g`` frames weighs ``lambda^g``; its features come back only when
    it again holds the equations of ``min_frames`` consecutive speech frames."""
    for gap in (20, 40):  # memory aged (lambda^20 = 4e-4), or faded and restarted
        x, _, _ = turn_change(gap, seed=9)
        est = DPRTFEstimator(4, 16, config=DPRTFConfig(noise=NoiseConfig()))
        lam = est.forgetting
        assert est.min_memory == pytest.approx((1 - lam**6) / (1 - lam))
        out = est.run(x)
        b0 = 250 + gap
        first = out.speech[:, b0:].argmax(axis=1)  # first speech frame of B per bin
        for f in range(16):
            valid_at = np.flatnonzero(out.valid[:, f, b0:].any(axis=0))
            # B's own equations: at least min_frames speech frames before the first feature
            assert valid_at[0] >= first[f] + est.min_frames - 1
        # frozen memory: features right from the first speech frame of B
        frozen = DPRTFEstimator(4, 16, config=DPRTFConfig(forget_over_noise=False)).run(x)
        assert frozen.valid[:, :, b0 : b0 + 2].any()


def test_frequency_range_limits_the_bins():
    x, _ = ctf_mixture(1, n_freqs=8, n_frames=30)
    freqs = np.arange(8) * 100.0
    cfg = DPRTFConfig(noise=None, freq_range_hz=(150.0, 450.0))
    out = DPRTFEstimator(4, 8, freqs, cfg).run(x)
    assert not out.speech[[0, 1, 5, 6, 7]].any() and out.speech[[2, 3, 4]].all()
    with pytest.raises(ValueError, match="freq_range_hz needs freqs_hz"):
        DPRTFEstimator(4, 8, config=cfg)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"ctf_length": 0}, "ctf_length must be a positive integer"),
        ({"forgetting": 1.5}, "forgetting must be in"),
        ({"psd_smoothing": 1.0}, "psd_smoothing must be in"),
        ({"consistency_threshold": 2.0}, "consistency_threshold must be in"),
        ({"solver": "qr"}, "solver must be one of"),
        ({"freq_range_hz": (5.0, 1.0)}, "freq_range_hz must be"),
        ({"forget_over_noise": 1}, "forget_over_noise must be a bool"),
    ],
)
def test_config_validation(kwargs, match):
    with pytest.raises(ValueError, match=match):
        DPRTFConfig(**kwargs)


def test_estimator_validation():
    with pytest.raises(ValueError, match="n_channels must be an integer >= 2"):
        DPRTFEstimator(1, 8)
    est = DPRTFEstimator(3, 8)
    with pytest.raises(ValueError, match="spec must have shape"):
        est.run(np.zeros((4, 8, 3), complex))


# -- the compiled kernel of the Cholesky solver -------------------------------------------------

needs_numba = pytest.mark.skipif(
    not _dprtf_kernel.available(), reason="Numba not installed (or AVTRACK_NO_JIT set)"
)


def _numpy_form(est: DPRTFEstimator) -> DPRTFEstimator:
    est.compiled = False
    return est


@needs_numba
@pytest.mark.parametrize(
    ("n_mics", "q", "with_noise", "phase_only"),
    [
        (4, 8, True, False),
        (4, 8, False, False),
        (3, 4, True, False),
        (6, 8, True, False),
        (4, 1, True, True),
    ],  # the last: PRP-REM's narrow-band phases (lambda = 0)
)
def test_compiled_kernel_matches_the_numpy_form(n_mics, q, with_noise, phase_only):
    """Same features, frame by frame, over turn changes and pauses (bins restarting, bins with
    too little memory, noise bins skipped) as the NumPy form of eq. 5.9."""
    x, _, _ = turn_change(30, seed=11, n_mics=n_mics)
    cfg = DPRTFConfig(
        ctf_length=q, noise=NoiseConfig() if with_noise else None, phase_only=phase_only
    )
    fast = DPRTFEstimator(n_mics, 16, config=cfg)
    assert fast.compiled
    ref = _numpy_form(DPRTFEstimator(n_mics, 16, config=cfg))
    out_fast, out_ref = fast.run(x), ref.run(x)
    np.testing.assert_array_equal(out_fast.speech, out_ref.speech)
    np.testing.assert_array_equal(out_fast.valid, out_ref.valid)
    np.testing.assert_allclose(out_fast.values, out_ref.values, atol=1e-8)
    assert out_fast.valid.sum() > 1000


def test_kernel_without_compilation_gives_the_numpy_forms_numbers():
    """The kernel's arithmetic, run as plain Python on a small case (no Numba needed)."""
    x, _ = ctf_mixture(5, n_mics=3, n_freqs=3, n_frames=25, q=2)
    cfg = DPRTFConfig(ctf_length=2, noise=None)
    ref = _numpy_form(DPRTFEstimator(3, 3, config=cfg)).run(x)
    est = DPRTFEstimator(3, 3, config=cfg)
    original = _dprtf_kernel.kernel
    try:
        _dprtf_kernel.kernel = lambda: _dprtf_kernel.frame_features  # type: ignore[assignment]
        est.compiled = True
        out = est.run(x)
    finally:
        _dprtf_kernel.kernel = original
    np.testing.assert_array_equal(out.valid, ref.valid)
    np.testing.assert_allclose(out.values, ref.values, atol=1e-9)
    assert out.valid.any()


def test_kernel_reports_a_matrix_that_is_not_positive_definite():
    r = np.zeros((1, 4, 4), dtype=complex)
    r[0] = -np.eye(4)  # an indefinite memory (cannot arise from eq. 5.9, but must be caught)
    values = np.zeros((1, 1), dtype=complex)
    valid = np.zeros((1, 1), dtype=bool)
    ok = _dprtf_kernel.frame_features(
        np.zeros((1, 2, 2), dtype=complex),  # phi_hat (F, I, Q): U = 0
        np.array([0]),
        np.array([1, 0]),
        r,
        np.array([True]),  # started: the memory is kept
        np.array([10.0]),  # enough memory to factorise
        np.array([0]),
        1,
        0.9,
        True,
        1.0,
        1e-3,
        1e-12,
        0.75,
        1e-5,
        False,
        values,
        valid,
    )
    assert ok is False


def test_estimator_falls_back_to_the_numpy_form_when_the_kernel_cannot_be_built(monkeypatch):
    """No usable Numba (here: its import fails): one warning, then the NumPy form's features."""
    x, _ = ctf_mixture(6, n_freqs=5, n_frames=30)
    cfg = DPRTFConfig(noise=None)
    ref = _numpy_form(DPRTFEstimator(4, 5, config=cfg)).run(x)
    monkeypatch.setattr(_dprtf_kernel, "_KERNEL", None)
    monkeypatch.setattr(_dprtf_kernel, "_FAILED", False)
    monkeypatch.setitem(sys.modules, "numba", None)  # `from numba import njit` raises
    est = DPRTFEstimator(4, 5, config=cfg)
    est.compiled = True
    with pytest.warns(RuntimeWarning, match="could not be built"):
        out = est.run(x)
    assert not est.compiled
    np.testing.assert_array_equal(out.valid, ref.valid)
    np.testing.assert_array_equal(out.values, ref.values)
    assert _dprtf_kernel.kernel() is None  # decided once per process (no second warning)
