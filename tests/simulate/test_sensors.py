"""Tests of avtrack.simulate.sensors and the scenario's ``sensors`` section: gain and delay
mismatch, self-noise, ideal sensors by default, bad fields."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.errors import InputError
from avtrack.io.scenario import dump_scenario, validate_scenario
from avtrack.simulate.scene import simulate_scene
from avtrack.simulate.sensors import SensorDraw, SensorModel, apply_mismatch, white_noise


def _raw(**over) -> dict:
    """A short free-field scene: one talker 1 m from the 4-mic NAO layout, no acoustic noise."""
    raw = {
        "name": "imperfect-microphones",
        "duration": 1.5,
        "seed": 0,
        "room": {"dims": [6.0, 5.0, 3.0], "t60": 0.0},
        "array": {"name": "nao4", "position": [3.0, 2.0, 1.2], "yaw_deg": 0.0},
        "people": [{"motion": {"type": "seated", "position": [4.0, 2.3, 1.3], "sway": 0.0}}],
        "speech": {"utterances": "synthetic", "mean_pause": 0.2},
        "noise": {"diffuse_snr_db": None},
    }
    raw.update(over)
    return raw


def _delay_estimate(y: np.ndarray, x: np.ndarray) -> float:
    """Delay of ``y`` behind ``x`` (samples) from the slope of the cross-spectrum's phase,
    ``arg(Y X^*) = -2 pi k d / N``, fitted below a quarter of the sampling rate."""
    n = x.size
    cross = np.fft.rfft(y) * np.fft.rfft(x).conj()
    k = np.arange(1, n // 4)
    phase = np.angle(cross[k])
    return float(-np.sum(k * phase) / np.sum(k * k) * n / (2 * np.pi))


# --------------------------------------------------------------------------- mismatch


def test_gain_mismatch_is_the_drawn_gain():
    rng = np.random.default_rng(0)
    x = rng.standard_normal((4, 16000))
    draw = SensorModel(gain_mismatch_db=2.0).draw(4, rng)
    assert np.all(draw.delays_samples == 0)
    assert np.std(draw.gains_db) > 0.5  # the draw is not degenerate
    y = apply_mismatch(x, draw)
    measured = 10 * np.log10(np.mean(y**2, axis=1) / np.mean(x**2, axis=1))
    np.testing.assert_allclose(measured, draw.gains_db, atol=1e-9)
    # the level difference between two microphones is the difference of the drawn gains
    assert measured[1] - measured[0] == pytest.approx(draw.gains_db[1] - draw.gains_db[0])


def test_delay_mismatch_is_the_drawn_delay():
    rng = np.random.default_rng(0)
    n = 8192
    x = np.tile(rng.standard_normal(n), (4, 1))
    draw = SensorModel(delay_mismatch_samples=0.4).draw(4, rng)
    assert np.all(draw.gains_db == 0)
    y = apply_mismatch(x, draw)
    for m in range(4):
        assert _delay_estimate(y[m], x[m]) == pytest.approx(draw.delays_samples[m], abs=0.01)
    # power is kept: a pure delay has unit magnitude response
    np.testing.assert_allclose(np.mean(y**2, 1), np.mean(x**2, 1), rtol=0.02)


def test_integer_delay_shifts_samples_exactly():
    x = np.random.default_rng(0).standard_normal((2, 500))
    y = apply_mismatch(x, SensorDraw(np.zeros(2), np.array([3.0, -2.0])))
    np.testing.assert_allclose(y[0, 3:], x[0, :-3], atol=1e-9)  # y[n] = x[n - 3]
    np.testing.assert_allclose(y[1, :-2], x[1, 2:], atol=1e-9)  # y[n] = x[n + 2]


def test_changing_one_spread_keeps_the_other_draw():
    a = SensorModel(1.0, 0.1).draw(4, np.random.default_rng(0))
    b = SensorModel(3.0, 0.1).draw(4, np.random.default_rng(0))
    np.testing.assert_array_equal(a.delays_samples, b.delays_samples)
    np.testing.assert_allclose(b.gains_db, 3 * a.gains_db)


def test_white_noise_is_uncorrelated_between_microphones():
    w = white_noise(4, 64000, np.random.default_rng(0))
    c = np.corrcoef(w)
    assert np.max(np.abs(c - np.eye(4))) < 0.02
    np.testing.assert_allclose(np.var(w, axis=1), 1.0, rtol=0.03)


# --------------------------------------------------------------------------- in a scene


@pytest.fixture(scope="module")
def ideal_scene():
    return simulate_scene(validate_scenario(_raw()))


def test_no_sensors_section_renders_as_before(ideal_scene):
    sc = validate_scenario(_raw())
    assert "sensors" not in sc
    assert "\nsensors:" not in dump_scenario(sc)
    assert ideal_scene.sensors is None
    # an all-default section draws but changes nothing, and no other random stream moves
    explicit = simulate_scene(validate_scenario(_raw(sensors={})))
    np.testing.assert_array_equal(explicit.audio, ideal_scene.audio)
    np.testing.assert_array_equal(
        explicit.detections.appearance, ideal_scene.detections.appearance
    )
    np.testing.assert_array_equal(explicit.sensors.gains_db, np.zeros(4))
    assert validate_scenario(_raw(sensors={}))["sensors"] == {
        "gain_mismatch_db": 0.0,
        "delay_mismatch_samples": 0.0,
        "self_noise_snr_db": None,
    }


def test_scene_self_noise_level(ideal_scene):
    scene = simulate_scene(validate_scenario(_raw(sensors={"self_noise_snr_db": 10.0})))
    # both are peak-normalised: y_noisy = a (s + n), y_ideal = b s with n independent of s,
    # so a / b is the least-squares projection of y_noisy on y_ideal
    s, y = ideal_scene.audio, scene.audio
    ratio = np.sum(y * s) / np.sum(s * s)
    speech, noise = ratio * s, y - ratio * s
    active = np.any(scene.dry != 0, axis=0)
    snr = 10 * np.log10(
        np.sum(np.mean(speech[:, active] ** 2, 1)) / np.sum(np.mean(noise[:, active] ** 2, 1))
    )
    assert snr == pytest.approx(10.0, abs=0.2)
    assert np.max(np.abs(np.corrcoef(noise) - np.eye(4))) < 0.05  # spatially white


def test_scene_gain_mismatch_is_drawn_per_seed(ideal_scene):
    scene = simulate_scene(validate_scenario(_raw(sensors={"gain_mismatch_db": 1.5})))
    g = scene.sensors.gains_db
    # y_m = c 10^(g_m / 20) x_m with one common peak-normalisation factor c
    level = 10 * np.log10(np.mean(scene.audio**2, 1) / np.mean(ideal_scene.audio**2, 1))
    np.testing.assert_allclose(level - level.mean(), g - g.mean(), atol=1e-6)
    other = simulate_scene(validate_scenario(_raw(seed=1, sensors={"gain_mismatch_db": 1.5})))
    assert not np.allclose(other.sensors.gains_db, g)


# --------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    ("sensors", "match"),
    [
        ({"gain_mismatch_db": -1}, r"sensors.gain_mismatch_db: expected a number >= 0, got -1"),
        ({"delay_mismatch_samples": 40}, r"sensors.delay_mismatch_samples: .* <= 16, got 40"),
        ({"self_noise_snr_db": "loud"}, r"sensors.self_noise_snr_db: expected a number"),
        ({"gain_db": 1.0}, r"sensors.gain_db: unknown field \(allowed: delay_mismatch"),
        (3, r"sensors: expected a mapping, got 3"),
    ],
)
def test_bad_sensor_field(sensors, match):
    with pytest.raises(InputError, match=match):
        validate_scenario(_raw(sensors=sensors))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"gain_mismatch_db": -0.5}, "gain_mismatch_db must be >= 0, got -0.5"),
        ({"delay_mismatch_samples": float("nan")}, "delay_mismatch_samples must be a finite"),
        ({"self_noise_snr_db": True}, "self_noise_snr_db must be a finite number or None"),
    ],
)
def test_bad_sensor_model(kwargs, match):
    with pytest.raises(ValueError, match=match):
        SensorModel(**kwargs)


def test_mismatch_shape_is_checked():
    with pytest.raises(ValueError, match=r"x must be \(4, n_samples\), got \(3, 10\)"):
        apply_mismatch(np.zeros((3, 10)), SensorDraw(np.zeros(4), np.zeros(4)))
