"""MVDR voices (avtrack.audio.beamform) on a small simulated free-field scene."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from avtrack.audio.arrays import builtin_array, steering_delays
from avtrack.audio.beamform import (
    BeamformerConfig,
    VoiceTrack,
    extract_voices,
    mvdr_weights,
    steering_vectors,
    tracks_from_doa,
)
from avtrack.io.doa import DOATable
from avtrack.metrics.voices import si_sdr
from avtrack.simulate import acoustics

FS = 16000


@functools.cache
def two_talkers():
    """A target at azimuth 30 and an interferer at -60 degrees, 1.5 m from a nao4 array in a
    mildly reverberant room, diffuse noise at 30 dB. The interferer talks alone for the first
    1.5 s, then both talk at once: gating cannot separate them, the beamformer must."""
    rng = np.random.default_rng(0)
    n = 5 * FS
    start = int(1.5 * FS)
    target = np.zeros(n)
    target[start:] = 0.7 * rng.standard_normal(n - start)
    interferer = rng.standard_normal(n)
    room = acoustics.Room(np.array([6.0, 5.0, 3.0]), 0.15, FS)
    pose = acoustics.ArrayPose(np.array([3.0, 2.5, 1.2]), 0.0)
    array = builtin_array("nao4")
    srcs = []
    for sig, az in ((target, 30.0), (interferer, -60.0)):
        p = pose.position + 1.5 * np.array([np.cos(np.deg2rad(az)), np.sin(np.deg2rad(az)), 0])
        srcs.append(acoustics.MovingSource(sig, np.array([0.0]), p[None, :]))
    images = acoustics.render_images(room, array, pose, srcs, n_samples=n, rng=1)
    mix = images.sum(axis=0)
    noise = acoustics.diffuse_noise(array, n, FS, rng)
    mix = mix + noise * np.sqrt(np.mean(mix**2) / np.mean(noise**2) / 1000)
    return array, mix, images[0, 0], start


def test_steering_vectors_free_field_are_the_plane_wave_phases():
    array = builtin_array("nao4")
    f = np.array([0.0, 1000.0])
    d = steering_vectors(array, np.array([30.0]), np.array([0.0]), f)
    tau = steering_delays(array, 30.0, 0.0)
    assert d.shape == (1, 2, 4)
    np.testing.assert_allclose(d[0, 0], 1.0)
    np.testing.assert_allclose(d[0, 1], np.exp(-2j * np.pi * 1000 * (tau - tau[0])), atol=1e-12)


def test_mvdr_is_distortionless_and_nulls_a_point_interferer():
    rng = np.random.default_rng(0)
    d = np.exp(1j * rng.uniform(-np.pi, np.pi, 4))
    d[0] = 1
    v = np.exp(1j * rng.uniform(-np.pi, np.pi, 4))
    cov = 100 * np.outer(v, v.conj()) + 0.01 * np.eye(4)
    w = mvdr_weights(cov, d, loading=0.0)
    assert np.vdot(w, d) == pytest.approx(1.0)  # w^H d = 1
    assert abs(np.vdot(w, v)) < 1e-2


def test_beamformer_improves_on_the_reference_microphone():
    array, mix, ref, start = two_talkers()
    track = VoiceTrack(1, np.array([0.0, 5.0]), np.array([30.0, 30.0]), np.zeros(2),
                       np.array([[1.5, 5.0]]))
    voice = extract_voices(mix, FS, array, [track])[1]
    assert voice.shape == (mix.shape[1],)
    assert np.all(voice[: int(1.2 * FS)] == 0)  # silent before the turn
    seg = slice(start + FS // 4, None)  # both talk: only the beamformer separates them
    gain = si_sdr(voice[seg], ref[seg]) - si_sdr(mix[0, seg], ref[seg])
    assert gain > 5.0  # 6.9 dB here


def test_tracks_from_doa_turns_are_the_active_runs():
    t = np.arange(6) * 0.032
    table = DOATable(np.arange(6), t, np.ones(6, int), np.full(6, 10.0), np.zeros(6),
                     np.ones(6), np.array([0, 1, 1, 0, 1, 0], bool))
    (tr,) = tracks_from_doa(table, 0.032)
    np.testing.assert_allclose(tr.turns, [[0.032, 0.096], [0.128, 0.16]])


def test_bad_input():
    array = builtin_array("nao4")
    track = VoiceTrack(1, np.array([0.0]), np.array([0.0]), np.zeros(1), np.zeros((0, 2)))
    with pytest.raises(ValueError, match="audio must have shape"):
        extract_voices(np.zeros((2, FS)), FS, array, [track])
    with pytest.raises(ValueError, match="hop must be"):
        BeamformerConfig(win_len=512, hop=400)
    with pytest.raises(ValueError, match="end >= start"):
        VoiceTrack(1, np.array([0.0]), np.array([0.0]), np.zeros(1), np.array([[2.0, 1.0]]))
    # no turns: a silent voice
    assert not np.any(extract_voices(np.ones((4, FS)), FS, array, [track])[1])
