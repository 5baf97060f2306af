"""Tests of avtrack.audio.hrtf: the HRIRSet container and the NAO / KEMAR loaders."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from avtrack.audio.arrays import builtin_array, steering_delays
from avtrack.audio.hrtf import HRIRSet, load_nao_hrir, load_sofa
from avtrack.errors import InputError


def _ring_set(n_taps: int = 8, fs: int = 48000) -> HRIRSet:
    az = -175.0 + 5.0 * np.arange(72)
    irs = np.zeros((72, 2, n_taps))
    irs[:, 0, 1] = 1.0
    irs[:, 1, 3] = np.arange(72)  # mic 1 tells the direction index
    return HRIRSet(az, np.zeros(72), irs, fs)


def _phase_delay(a: np.ndarray, b: np.ndarray, fs: int, f_max: float = 3000.0) -> float:
    """Delay of ``a`` relative to ``b`` (s, positive: ``a`` later) from the phase slope of
    their cross-spectrum between 200 Hz and ``f_max``."""
    n = 1024
    f = np.fft.rfftfreq(n, 1 / fs)
    band = (f > 200) & (f < f_max)
    cross = np.fft.rfft(a, n)[band] * np.conj(np.fft.rfft(b, n)[band])
    phase = np.unwrap(np.angle(cross))
    w = 2 * np.pi * f[band]
    return float(-np.sum(phase * w) / np.sum(w * w))  # phase = -w tau


# ---------------------------------------------------------------------------- HRIRSet


def test_hrirset_shapes_and_readonly():
    h = _ring_set()
    assert (h.n_directions, h.n_mics, h.length) == (72, 2, 8)
    with pytest.raises(ValueError):
        h.irs[0, 0, 0] = 2.0


def test_nearest_wraps_azimuth():
    h = _ring_set()
    idx = h.nearest_index([179.0, -178.0, 540.0, -175.0, 2.4], 0.0)
    np.testing.assert_allclose(h.azimuths_deg[idx], [180, 180, 180, -175, 0])
    assert h.nearest(90.0)[1, 3] == np.flatnonzero(h.azimuths_deg == 90)[0]


def test_nearest_is_great_circle():
    # directions at elevation 80: azimuth differences matter little there
    h = HRIRSet([0.0, 90.0, 0.0], [80.0, 80.0, 0.0], np.eye(3)[:, None, :], 16000)
    assert int(h.nearest_index(60.0, 85.0)) in (0, 1)
    assert int(h.nearest_index(60.0, 10.0)) == 2


def test_resampled_keeps_timing():
    h = _ring_set(n_taps=48, fs=48000)
    irs = np.zeros((72, 2, 48))
    irs[:, :, 24] = 1.0
    h = HRIRSet(h.azimuths_deg, h.elevations_deg, irs, 48000, source="x")
    r = h.resampled(16000)
    assert r.fs == 16000 and r.irs.shape == (72, 2, 16) and r.source == "x"
    assert np.argmax(r.irs[0, 0]) == 8  # 24 samples at 48 kHz = 8 at 16 kHz
    assert h.resampled(48000) is h


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"irs": np.zeros((3, 2))}, "irs must have shape"),
        ({"azimuths_deg": [0.0, 1.0]}, "azimuths_deg and elevations_deg"),
        ({"elevations_deg": [0.0, 95.0, 0.0]}, "elevations_deg must be in"),
        ({"fs": 0}, "fs must be a positive integer"),
        ({"irs": np.full((3, 1, 4), np.nan)}, "finite"),
    ],
)
def test_hrirset_rejects_bad_fields(kwargs, match):
    args = {
        "azimuths_deg": [0.0, 90.0, 180.0],
        "elevations_deg": [0.0, 0.0, 0.0],
        "irs": np.zeros((3, 1, 4)),
        "fs": 16000,
    }
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        HRIRSet(**args)


def test_resampled_rejects_bad_fs():
    with pytest.raises(ValueError, match="fs must be a positive integer"):
        _ring_set().resampled(-1)


# ---------------------------------------------------------------------------- NAO


def test_nao_hrir_shapes(shared_data):
    h = load_nao_hrir(shared_data / "nao/HRIR_NAO_48kHz_-175_5_180_degrees.mat")
    assert h.irs.shape == (72, 4, 32) and h.fs == 48000 and h.source == "nao"
    np.testing.assert_allclose(h.azimuths_deg, -175 + 5 * np.arange(72))
    np.testing.assert_allclose(h.elevations_deg, 0.0)


@pytest.mark.parametrize("az", [60.0, 75.0, 90.0, 105.0])
@pytest.mark.parametrize("side", [1.0, -1.0])
def test_nao_lateral_delay_signs_match_geometry(shared_data, az, side):
    """nao4 order (LOCATA 5, 8, 11, 12): 5 and 12 are on the left (y > 0), 8 and 11 on the
    right. A source on the left (+az, counter-clockwise) reaches the left mics first."""
    h = load_nao_hrir(shared_data / "nao/HRIR_NAO_48kHz_-175_5_180_degrees.mat")
    geo = steering_delays(builtin_array("nao4"), side * az)
    ir = h.nearest(side * az)
    for left, right in ((0, 1), (3, 2)):  # (mic 5, mic 8), (mic 12, mic 11)
        measured = _phase_delay(ir[left], ir[right], h.fs)
        assert np.sign(measured) == np.sign(geo[left] - geo[right]) == -side


@pytest.mark.parametrize("az", [-30.0, -15.0, 0.0, 15.0, 30.0])
def test_nao_front_mics_lead_for_frontal_sources(shared_data, az):
    h = load_nao_hrir(shared_data / "nao/HRIR_NAO_48kHz_-175_5_180_degrees.mat")
    ir = h.nearest(az)
    for front, rear in ((3, 0), (2, 1)):  # (mic 12, mic 5), (mic 11, mic 8)
        assert _phase_delay(ir[front], ir[rear], h.fs) < 0


def test_nao_channel_order_is_the_best_fit(shared_data):
    """Among every channel order and both azimuth senses, the sign agreement of the measured
    inter-mic delays with the nao4 geometry is highest for the order chosen by the loader
    (counter-clockwise) and its mirror image (clockwise, left and right swapped)."""
    h = load_nao_hrir(shared_data / "nao/HRIR_NAO_48kHz_-175_5_180_degrees.mat")
    meas = np.array(
        [
            [[_phase_delay(h.irs[k, i], h.irs[k, j], h.fs) for j in range(4)] for i in range(4)]
            for k in range(72)
        ]
    )
    pos = builtin_array("nao4").positions
    scores = {}
    for perm in itertools.permutations(range(4)):
        for sense in (1.0, -1.0):
            a = np.deg2rad(sense * h.azimuths_deg)
            u = np.stack([np.cos(a), np.sin(a), 0 * a], axis=1)
            q = pos[list(perm)]
            d = -(u @ (q - q.mean(0)).T) / 343.0
            geo = d[:, :, None] - d[:, None, :]
            big = np.abs(geo) > 30e-6
            scores[perm, sense] = np.mean(np.sign(geo[big]) == np.sign(meas[big]))
    ours = scores[(0, 1, 2, 3), 1.0]
    mirror = scores[(1, 0, 3, 2), -1.0]
    others = [v for k, v in scores.items() if k not in {((0, 1, 2, 3), 1.0), ((1, 0, 3, 2), -1.0)}]
    assert ours > 0.8 and abs(ours - mirror) < 0.02
    assert ours > max(others) + 0.05


def test_nao_bad_file(tmp_path):
    bad = tmp_path / "x.mat"
    bad.write_text("not a mat file")
    with pytest.raises(InputError, match=r"x\.mat"):
        load_nao_hrir(bad)
    import scipy.io

    scipy.io.savemat(tmp_path / "y.mat", {"HRIR_NAO": np.zeros((32, 2, 72))})
    with pytest.raises(InputError, match=r"expected shape \(taps, 4, 72\)"):
        load_nao_hrir(tmp_path / "y.mat")


# ---------------------------------------------------------------------------- KEMAR (SOFA)


def test_kemar_sofa_shapes(shared_data):
    h = load_sofa(shared_data / "hrtf/mit_kemar_normal_pinna.sofa")
    assert h.irs.shape == (710, 2, 512) and h.fs == 44100
    assert np.all((h.azimuths_deg > -180) & (h.azimuths_deg <= 180))
    assert h.elevations_deg.min() == -40 and h.elevations_deg.max() == 90


@pytest.mark.parametrize(("az", "louder"), [(90.0, 0), (-90.0, 1), (45.0, 0), (-60.0, 1)])
def test_kemar_near_ear_is_louder(shared_data, az, louder):
    """Receiver 0 is the left ear (y = +0.09 m): a source on the left (+90) is louder there."""
    h = load_sofa(shared_data / "hrtf/mit_kemar_normal_pinna.sofa")
    e = np.sum(h.nearest(az) ** 2, axis=1)
    assert 10 * np.log10(e[louder] / e[1 - louder]) > 6.0


def test_sofa_bad_file(tmp_path):
    bad = tmp_path / "x.sofa"
    bad.write_text("not hdf5")
    with pytest.raises(InputError, match="cannot open the SOFA file"):
        load_sofa(bad)
    import h5py

    with h5py.File(tmp_path / "y.sofa", "w") as f:
        f["Data.IR"] = np.zeros((3, 2, 8))
        f["Data.SamplingRate"] = [44100.0]
    with pytest.raises(InputError, match="SourcePosition"):
        load_sofa(tmp_path / "y.sofa")
