"""Tests of avtrack.simulate.acoustics: geometry, the hybrid RIR, time-varying rendering, noise."""

from __future__ import annotations

import numpy as np
import pyroomacoustics as pra
import pytest
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

from avtrack.audio.arrays import SPEED_OF_SOUND, MicArray, builtin_array
from avtrack.simulate.acoustics import (
    ArrayPose,
    MovingSource,
    Room,
    array_to_room,
    azimuth_elevation,
    diffuse_noise,
    fan_noise,
    fan_noise_image,
    measure_t60,
    mix_at_snr,
    point_noise,
    render,
    render_images,
    room_impulse_response,
    room_to_array,
    speech_activity,
)

FS = 16000
ROOM_DIMS = (6.0, 5.0, 3.0)


def _noise(n: int, seed: int = 1) -> np.ndarray:
    return np.random.default_rng(seed).standard_normal(n)


def _source_at(pose: ArrayPose, az_deg: float, dist: float, z: float) -> np.ndarray:
    """Room-frame point at array-frame azimuth ``az_deg`` from the array origin."""
    a = np.deg2rad(az_deg)
    p = array_to_room(pose, [dist * np.cos(a), dist * np.sin(a), 0.0])[0]
    p[2] = z
    return p


def _gcc_phat_lag(a: np.ndarray, b: np.ndarray, max_lag: float, up: int = 16) -> float:
    """Delay of ``a`` relative to ``b`` in samples (positive: ``a`` later), GCC-PHAT."""
    n = 2 * len(a)
    cross = np.fft.rfft(a, n) * np.conj(np.fft.rfft(b, n))
    cc = np.fft.irfft(cross / (np.abs(cross) + 1e-12), n * up)
    k = int(np.ceil(max_lag * up))
    cc = np.concatenate([cc[-k:], cc[: k + 1]])
    return (np.argmax(cc) - k) / up


# ---------------------------------------------------------------------------- frames


def test_room_to_array_hand_computed():
    pose = ArrayPose([1.0, 2.0, 0.0], yaw_deg=90.0)  # the array looks along room +y
    p = room_to_array(pose, [[1.0, 3.0, 0.0], [0.0, 2.0, 0.0], [1.0, 1.0, 0.5]])
    np.testing.assert_allclose(p, [[1, 0, 0], [0, 1, 0], [-1, 0, 0.5]], atol=1e-12)
    az, el = azimuth_elevation(p)
    np.testing.assert_allclose(az, [0, 90, 180], atol=1e-12)
    np.testing.assert_allclose(el, [0, 0, np.rad2deg(np.arctan2(0.5, 1))], atol=1e-12)
    az, _ = azimuth_elevation([[-1.0, -0.0, 0.0]])
    assert az[0] == 180.0  # (-180, 180]


@settings(max_examples=50, deadline=None)
@given(
    st.lists(st.floats(-10, 10), min_size=3, max_size=3),
    st.lists(st.floats(-10, 10), min_size=3, max_size=3),
    st.floats(-720, 720),
)
def test_room_array_round_trip(p, c, yaw):
    pose = ArrayPose(c, yaw)
    q = room_to_array(pose, [p])
    np.testing.assert_allclose(array_to_room(pose, q)[0], p, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(q), np.linalg.norm(np.subtract(p, c)), atol=1e-9)
    az, el = azimuth_elevation(q)
    assert -180 < az[0] <= 180 and -90 <= el[0] <= 90


# ---------------------------------------------------------------------------- (a) free field


def test_free_field_delays_and_gains_match_geometry():
    arr = builtin_array("nao12")
    room = Room(ROOM_DIMS, 0.0)
    pose = ArrayPose([3.0, 2.5, 1.2], yaw_deg=20.0)
    src = np.array([1.2, 3.9, 1.7])
    x = np.zeros(2000)
    x[100] = 1.0
    y = render(room, arr, pose, MovingSource.static(x, src))
    mics = array_to_room(pose, arr.positions)
    d = np.linalg.norm(mics - src, axis=1)
    expected = 100 + d / SPEED_OF_SOUND * FS
    # sub-sample peak: band-limited interpolation (x32) of the rendered impulse
    up = 32
    fine = scipy.signal.resample(y, y.shape[1] * up, axis=1)
    peak = np.argmax(fine, axis=1) / up
    tdoa = peak - peak[0]
    np.testing.assert_allclose(tdoa, expected - expected[0], atol=0.1)  # << 1 sample
    np.testing.assert_allclose(peak, expected, atol=0.1)
    np.testing.assert_allclose(np.max(fine, axis=1), 1 / d, rtol=0.05)  # 1/r, as pra


def test_early_part_and_drr_match_pyroomacoustics():
    """Parity with the full image-source RIR of pyroomacoustics (same absorption and order,
    its 10 Hz high-pass, its 40-sample fractional-delay offset removed): the first 40 ms
    coincide, and the direct-to-reverberant ratio of the hybrid RIR is within 1 dB."""
    room = Room(ROOM_DIMS, 0.3)
    pair = MicArray("pair", [[0, 0.05, 0], [0, -0.05, 0]])
    pose = ArrayPose([3.2, 2.4, 1.2])
    src = np.array([1.5, 3.5, 1.6])
    ours = room_impulse_response(room, pair, pose, src)[0]
    ref = pra.ShoeBox(
        list(ROOM_DIMS),
        fs=FS,
        materials=pra.Material(room.absorption),
        max_order=room.max_order,
        air_absorption=False,
    )
    ref.add_source(src)
    ref.add_microphone_array(array_to_room(pose, pair.positions).T)
    ref.compute_rir()
    theirs = np.asarray(ref.rir[0][0])[pra.constants.get("frac_delay_length") // 2 :]
    n = int(0.04 * FS)
    a, b = ours[:n], theirs[:n]
    assert np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b)) > 0.99
    assert abs(10 * np.log10(np.sum(a**2) / np.sum(b**2))) < 0.3

    def drr(h: np.ndarray) -> float:
        k = np.argmax(np.abs(h)) + int(0.0025 * FS)
        return 10 * np.log10(np.sum(h[:k] ** 2) / np.sum(h[k:] ** 2))

    assert abs(drr(ours) - drr(theirs)) < 1.0


# ---------------------------------------------------------------------------- (b) SRP-PHAT


@pytest.mark.parametrize("az_true", [70.0, -120.0, 10.0])
def test_srp_phat_finds_rendered_source(az_true):
    ring = MicArray("ring", builtin_array("av163").positions[:8])  # centred at (0, 0.4, 0)
    room = Room(ROOM_DIMS, 0.3)
    pose = ArrayPose([3.0, 2.5, 1.0], yaw_deg=30.0)
    centre = np.array([0.0, 0.4, 0.0])
    a = np.deg2rad(az_true)
    src = array_to_room(pose, centre + 1.5 * np.array([np.cos(a), np.sin(a), 0.0]))[0]
    src[2] = 1.3
    y = render(room, ring, pose, MovingSource.static(_noise(FS), src))
    stft = np.array([pra.transform.stft.analysis(ch, 256, 128).T for ch in y])
    doa = pra.doa.algorithms["SRP"](ring.positions[:, :2].T, FS, 256, c=SPEED_OF_SOUND)
    doa.locate_sources(stft, freq_range=[300, 3500])
    err = (np.rad2deg(doa.azimuth_recon[0]) - az_true + 180) % 360 - 180
    assert abs(err) <= 5.0


# ---------------------------------------------------------------------------- (c) moving


@pytest.mark.parametrize("t60", [0.0, 0.2])
def test_direct_path_delay_follows_moving_source(t60):
    pair = MicArray("pair", [[0.0, 0.15, 0.0], [0.0, -0.15, 0.0]])
    room = Room(ROOM_DIMS, t60)
    pose = ArrayPose([2.0, 2.5, 1.2])
    start, end = np.array([3.5, 1.0, 1.2]), np.array([3.5, 4.0, 1.2])  # az -45 -> +45
    x = _noise(3 * FS, seed=2)
    y = render(room, pair, pose, MovingSource(x, [0.0, 3.0], [start, end]))
    block = FS // 10
    errors = []
    for b in range(1, 29):
        s = b * block
        t = (s + block / 2) / FS
        p = start + (end - start) * t / 3.0
        d = np.linalg.norm(array_to_room(pose, pair.positions) - p, axis=1)
        geo = (d[0] - d[1]) / SPEED_OF_SOUND * FS
        lag = _gcc_phat_lag(y[0, s : s + block], y[1, s : s + block], max_lag=16)
        errors.append(lag - geo)
    errors = np.abs(errors)
    assert np.max(errors) < 1.0 and np.median(errors) < 0.3


# ---------------------------------------------------------------------------- (d) SNR


def test_mix_at_snr_meets_request():
    arr = builtin_array("nao4")
    room = Room(ROOM_DIMS, 0.3)
    pose = ArrayPose([3.0, 2.5, 1.2])
    x = _noise(2 * FS, seed=3)
    x[FS // 2 : FS] = 0.0  # a pause
    x[int(1.6 * FS) :] = 0.0
    image = render(room, arr, pose, MovingSource.static(x, [1.5, 1.5, 1.6]))
    noise = diffuse_noise(arr, image.shape[1], FS, 4)
    for snr in (-5.0, 5.0, 20.0):
        mix, scaled = mix_at_snr(image, noise, snr)
        np.testing.assert_allclose(mix - image, scaled, atol=1e-12)
        dry_active = x != 0
        p_s = np.sum(np.mean(image[:, dry_active] ** 2, axis=1))
        p_v = np.sum(np.mean(scaled[:, dry_active] ** 2, axis=1))
        assert abs(10 * np.log10(p_s / p_v) - snr) < 1.0
        _, exact = mix_at_snr(image, noise, snr, active=dry_active)
        p_v = np.sum(np.mean(exact[:, dry_active] ** 2, axis=1))
        np.testing.assert_allclose(10 * np.log10(p_s / p_v), snr, atol=1e-9)


def test_speech_activity_threshold():
    s = np.zeros((2, 3200))
    s[:, 640:1280] = 1.0
    s[:, 2000:2100] = 1e-4  # 80 dB below: inactive
    act = speech_activity(s, frame=320)
    assert act[640:1280].all() and not act[:640].any() and not act[1920:].any()


# ---------------------------------------------------------------------------- (e) T60


@pytest.mark.parametrize("t60", [0.3, 0.6])
def test_rendered_rir_has_requested_t60(t60):
    room = Room(ROOM_DIMS, t60)
    pose = ArrayPose([3.2, 2.4, 1.2], 30.0)
    rir = room_impulse_response(room, builtin_array("nao4"), pose, [1.5, 3.5, 1.6])
    measured = measure_t60(rir, FS)
    assert measured.shape == (4,)
    assert np.all(np.abs(measured / t60 - 1) < 0.15)


def test_measure_t60_on_exponential_decay():
    t = np.arange(FS) / FS
    h = _noise(FS, seed=5) * 10 ** (-3 * t / 0.5)  # amplitude: -60 dB in 0.5 s
    assert abs(measure_t60(h, FS) - 0.5) < 0.02
    assert abs(measure_t60(h, FS, decay_db=20) - 0.5) < 0.03
    with pytest.raises(ValueError, match="never reaches"):
        measure_t60(np.r_[np.zeros(10), 1.0], FS)  # all energy in the last tap


def test_rir_length_and_anechoic_has_no_tail():
    pose = ArrayPose([3.0, 2.5, 1.2])
    rir = room_impulse_response(Room(ROOM_DIMS, 0.0), builtin_array("nao4"), pose, [1, 1, 1])
    late = int(0.02 * FS)  # only the high-pass's slow undershoot after the direct path
    assert rir.shape[0] == 4 and np.sum(rir[:, late:] ** 2) < 2e-3 * np.sum(rir**2)
    rir = room_impulse_response(Room(ROOM_DIMS, 0.4), builtin_array("nao4"), pose, [1, 1, 1])
    assert rir.shape[1] >= 0.4 * FS


# ---------------------------------------------------------------------------- (f) static


@pytest.mark.parametrize("name", ["nao4", "kemar"])
def test_static_source_equals_one_shot_convolution(name, request):
    if name == "kemar":
        request.getfixturevalue("shared_data")
    arr = builtin_array(name)
    room = Room(ROOM_DIMS, 0.3)
    pose = ArrayPose([3.0, 2.5, 1.3], -40.0)
    p = np.array([1.7, 3.6, 1.5])
    x = _noise(FS, seed=6)
    x[3000:9000] = 0.0  # skipped blocks
    rir = room_impulse_response(room, arr, pose, p, rng=7)
    expected = scipy.signal.oaconvolve(x[None, :], rir, axes=1)[:, : x.size]
    y = render(room, arr, pose, MovingSource.static(x, p), rng=7)
    np.testing.assert_allclose(y, expected, atol=1e-9 * np.max(np.abs(expected)))
    # several knots at the same place: still one RIR
    y3 = render(room, arr, pose, MovingSource(x, [0.0, 0.2, 0.5], [p, p, p]), rng=7)
    np.testing.assert_allclose(y3, y, atol=1e-12)


def test_rendered_impulse_is_the_rir():
    """An impulse rendered into a longer output gives the whole RIR (tail included)."""
    arr = builtin_array("nao4")
    room = Room(ROOM_DIMS, 0.4)
    pose = ArrayPose([3.0, 2.5, 1.2], 10.0)
    p = [4.5, 1.0, 1.6]
    rir = room_impulse_response(room, arr, pose, p, rng=3)
    y = render(room, arr, pose, MovingSource.static([1.0], p), n_samples=rir.shape[1], rng=3)
    np.testing.assert_allclose(y, rir, atol=1e-9 * np.max(np.abs(rir)))


def test_crossfade_interpolates_between_update_points():
    """A source moving 0.5 m in 1 s along x with step_m = 0.05 gets a new RIR every 0.1 s
    (1600 samples). An impulse emitted at an update point gets exactly that point's RIR,
    one emitted half-way the mean of its two neighbours' RIRs (anechoic: no shared tail)."""
    arr = builtin_array("nao4")
    room = Room(ROOM_DIMS, 0.0)
    pose = ArrayPose([3.0, 2.5, 1.2])
    p0, p1 = np.array([1.0, 1.0, 1.5]), np.array([1.5, 1.0, 1.5])
    n = FS + 2000

    def rendered_impulse(at: int) -> np.ndarray:
        x = np.zeros(n)
        x[at] = 1.0
        y = render(room, arr, pose, MovingSource(x, [0.0, 1.0], [p0, p1]), step_m=0.05)
        return y[:, at : at + 1200]

    def rir(t: float) -> np.ndarray:
        h = room_impulse_response(room, arr, pose, p0 + (p1 - p0) * t)
        return np.pad(h, ((0, 0), (0, 1200)))[:, :1200]

    np.testing.assert_allclose(rendered_impulse(3200), rir(0.2), atol=1e-12)
    np.testing.assert_allclose(rendered_impulse(4000), 0.5 * (rir(0.2) + rir(0.3)), atol=1e-12)


def test_images_sum_to_mix():
    arr = builtin_array("nao4")
    room = Room(ROOM_DIMS, 0.2)
    pose = ArrayPose([3.0, 2.5, 1.2])
    s1 = MovingSource.static(_noise(4000, 1), [1, 1, 1.5])
    s2 = MovingSource(_noise(6000, 2), [0.0, 0.3], [[5, 4, 1.5], [4.8, 3.9, 1.6]])
    mix = render(room, arr, pose, [s1, s2], n_samples=5000)
    images = render_images(room, arr, pose, [s1, s2], n_samples=5000)
    assert mix.shape == (4, 5000) and images.shape == (2, 4, 5000)
    np.testing.assert_allclose(images.sum(axis=0), mix)
    np.testing.assert_allclose(images[0], render(room, arr, pose, s1, n_samples=5000, rng=0))


# ---------------------------------------------------------------------------- (g) bad input


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: Room([6, 5], 0.3), "dims must be 3 finite lengths"),
        (lambda: Room([6, 5, -3], 0.3), "dims must be 3 finite lengths"),
        (lambda: Room(ROOM_DIMS, -0.1), "t60 must be >= 0"),
        (lambda: Room(ROOM_DIMS, float("nan")), "t60 must be finite"),
        (lambda: Room([30, 30, 10], 0.05), "too short"),
        (lambda: Room(ROOM_DIMS, 0.3, fs=0), "fs must be a positive integer"),
        (lambda: ArrayPose([1, 2], 0), "position must be 3 finite numbers"),
        (lambda: ArrayPose([1, 2, 3], "x"), "yaw_deg must be a number"),
        (lambda: MovingSource([], [0], [[1, 1, 1]]), "signal must be 1-D and non-empty"),
        (lambda: MovingSource([1.0, np.nan], [0], [[1, 1, 1]]), "NaN"),
        (lambda: MovingSource([1.0], [0, 0], [[1, 1, 1]] * 2), "strictly increasing"),
        (lambda: MovingSource([1.0], [0, 1], [[1, 1, 1]]), r"shape \(2, 3\)"),
    ],
)
def test_bad_construction(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_render_rejects_bad_scenes():
    arr = builtin_array("nao4")
    room = Room(ROOM_DIMS, 0.3)
    pose = ArrayPose([3.0, 2.5, 1.2])
    src = MovingSource.static(np.ones(100), [1, 1, 1])
    with pytest.raises(ValueError, match=r"sources\[1\].positions: every knot must be inside"):
        render(room, arr, pose, [src, MovingSource.static(np.ones(10), [7, 1, 1])])
    with pytest.raises(ValueError, match="microphones must be inside"):
        render(room, arr, ArrayPose([6.0, 2.5, 1.2]), src)
    with pytest.raises(ValueError, match="step_m must be > 0"):
        render(room, arr, pose, src, step_m=0.0)
    with pytest.raises(ValueError, match="expected at least one MovingSource"):
        render(room, arr, pose, [])
    with pytest.raises(ValueError, match="n_samples must be a positive integer"):
        render(room, arr, pose, src, n_samples=0)
    with pytest.raises(ValueError, match="early_s must be >"):
        render(room, arr, pose, src, early_s=0.001)
    with pytest.raises(ValueError, match="rng must be"):
        render(room, arr, pose, src, rng="seed")
    with pytest.raises(ValueError, match="array must be a MicArray"):
        render(room, "nao4", pose, src)
    with pytest.raises(ValueError, match="closer than 1 cm"):
        mic = array_to_room(pose, arr.positions)[0]
        render(room, arr, pose, MovingSource.static(np.ones(10), mic + 0.001))


def test_noise_and_mix_reject_bad_input():
    arr = builtin_array("nao4")
    with pytest.raises(ValueError, match="n_samples must be a positive integer"):
        diffuse_noise(arr, 0, FS, 0)
    with pytest.raises(ValueError, match="signal must be a finite, non-silent 1-D array"):
        diffuse_noise(arr, 100, FS, 0, signal=np.zeros(50))
    with pytest.raises(ValueError, match="hum_hz \\* n_harmonics"):
        fan_noise(100, FS, 0, hum_hz=3000.0, n_harmonics=4)
    s = np.ones((4, 100))
    with pytest.raises(ValueError, match=r"noise must have shape \(4, 100\)"):
        mix_at_snr(s, np.ones((4, 99)), 0.0)
    with pytest.raises(ValueError, match="speech_image is silent"):
        mix_at_snr(np.zeros((4, 100)), s, 0.0)
    with pytest.raises(ValueError, match="noise is silent"):
        mix_at_snr(s, np.zeros((4, 100)), 0.0)
    with pytest.raises(ValueError, match="active must be a bool array"):
        mix_at_snr(s, s, 0.0, active=np.ones(100))
    with pytest.raises(ValueError, match="offset must be 3 finite numbers"):
        point_noise(Room(ROOM_DIMS, 0.0), arr, ArrayPose([3, 2, 1]), np.ones(10), offset=[1])
    with pytest.raises(ValueError, match="rir is all zeros"):
        measure_t60(np.zeros(100), FS)


# ---------------------------------------------------------------------------- (h) HRIRs


@pytest.mark.parametrize("t60", [0.0, 0.3])
def test_kemar_rendering_left_right_levels(shared_data, t60):
    arr = builtin_array("kemar")
    room = Room(ROOM_DIMS, t60)
    pose = ArrayPose([3.0, 2.5, 1.4], 30.0)
    x = _noise(FS // 2, seed=8)
    for az, near in ((90.0, 0), (-90.0, 1)):
        y = render(room, arr, pose, MovingSource.static(x, _source_at(pose, az, 1.5, 1.4)))
        e = np.sum(y**2, axis=1)
        assert 10 * np.log10(e[near] / e[1 - near]) > (6.0 if t60 == 0 else 1.5)


def test_nao4_hrir_rendering_left_right_levels(shared_data):
    arr = builtin_array("nao4-hrir")  # mics 5, 8, 11, 12: left = 0 and 3, right = 1 and 2
    room = Room(ROOM_DIMS, 0.0)
    pose = ArrayPose([3.0, 2.5, 1.4], -60.0)
    x = _noise(FS // 2, seed=9)
    for az, sign in ((90.0, 1.0), (-90.0, -1.0)):
        y = render(room, arr, pose, MovingSource.static(x, _source_at(pose, az, 1.5, 1.4)))
        e = np.sum(y**2, axis=1)
        assert sign * 10 * np.log10((e[0] + e[3]) / (e[1] + e[2])) > 2.0


# ---------------------------------------------------------------------------- noise


def test_diffuse_noise_coherence_free_field():
    d = 0.1
    arr = MicArray("pair", [[0, 0, 0], [d, 0, 0]])
    v = diffuse_noise(arr, 10 * FS, FS, np.random.default_rng(10))
    assert v.shape == (2, 10 * FS)
    np.testing.assert_allclose(np.mean(v**2), 1.0)
    np.testing.assert_allclose(np.mean(v**2, axis=1), 1.0, atol=0.05)
    f, pxy = scipy.signal.csd(v[0], v[1], FS, nperseg=512)
    _, pxx = scipy.signal.welch(v[0], FS, nperseg=512)
    _, pyy = scipy.signal.welch(v[1], FS, nperseg=512)
    coherence = np.real(pxy / np.sqrt(pxx * pyy))
    band = (f > 100) & (f < 7000)
    target = np.sinc(2 * f * d / SPEED_OF_SOUND)  # sin(kd) / (kd)
    assert np.max(np.abs(coherence[band] - target[band])) < 0.1


def test_diffuse_noise_from_recording_keeps_spectrum():
    rec = scipy.signal.lfilter([1.0], [1.0, -0.95], _noise(4 * FS, 11))  # low-pass colour
    v = diffuse_noise(builtin_array("nao4"), 2 * FS, FS, 0, signal=rec)
    f, p = scipy.signal.welch(v, FS, nperseg=512)
    low, high = p[:, (f > 100) & (f < 300)].mean(), p[:, (f > 4000) & (f < 6000)].mean()
    assert 10 * np.log10(low / high) > 15


def test_diffuse_noise_through_a_head(shared_data):
    v = diffuse_noise(builtin_array("kemar"), 4 * FS, FS, 12)
    p = np.mean(v**2, axis=1)
    assert abs(10 * np.log10(p[0] / p[1])) < 1.0  # no ear favoured on average
    f, pxy = scipy.signal.csd(v[0], v[1], FS, nperseg=512)
    _, pxx = scipy.signal.welch(v[0], FS, nperseg=512)
    _, pyy = scipy.signal.welch(v[1], FS, nperseg=512)
    coh = np.abs(pxy) / np.sqrt(pxx * pyy)
    assert coh[(f > 50) & (f < 150)].mean() > 0.8  # the ears are coherent at low frequency
    assert coh[(f > 3000) & (f < 7000)].mean() < 0.4


def test_fan_noise_spectrum():
    v = fan_noise(4 * FS, FS, 13, hum_hz=140.0)
    assert v.shape == (4 * FS,)
    np.testing.assert_allclose(np.sqrt(np.mean(v**2)), 1.0)
    f, p = scipy.signal.welch(v, FS, nperseg=4096)

    def level(hz: float) -> float:
        return 10 * np.log10(p[np.argmin(np.abs(f - hz))])

    assert level(140) > level(170) + 10 and level(280) > level(250) + 6
    assert level(300) > level(5000) + 15  # low-pass broadband part


def test_point_noise_behind_the_head_is_louder_at_the_rear_mics():
    arr = builtin_array("nao4")  # mics 5, 8 at the rear, 11, 12 at the front
    pose = ArrayPose([3.0, 2.5, 1.2], 45.0)
    v = point_noise(Room(ROOM_DIMS, 0.3), arr, pose, fan_noise(FS // 2, FS, 14))
    e = np.sum(v**2, axis=1)
    assert v.shape == (4, FS // 2) and min(e[:2]) > max(e[2:])


def test_fan_noise_image():
    room = Room(ROOM_DIMS, 0.3)
    pose = ArrayPose([3.0, 2.5, 1.2])
    arr = builtin_array("nao4")
    v = fan_noise_image(room, arr, pose, FS // 4, FS, 15)
    gen = np.random.default_rng(15)
    expected = point_noise(room, arr, pose, fan_noise(FS // 4, FS, gen), rng=gen)
    np.testing.assert_allclose(v, expected)
    with pytest.raises(ValueError, match=r"fs \(8000\) must equal room.fs \(16000\)"):
        fan_noise_image(room, arr, pose, 100, 8000, 0)
