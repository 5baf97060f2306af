"""Single-precision CGMM densities (compiled and NumPy forms) against the double-precision
formula, and the localizer's maps against the maps from double-precision densities."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from avtrack.audio.arrays import builtin_array
from avtrack.localize import _density_kernel, make_localizer
from avtrack.localize.cgmm_eg import (
    densities_from_coefficients,
    density_coefficients,
    mean_ratios,
)


def _case(seed: int = 0, n_rows: int = 12, n_dirs: int = 7, n_feats: int = 5):
    rng = np.random.default_rng(seed)
    means = rng.standard_normal((n_rows, n_dirs)) + 1j * rng.standard_normal((n_rows, n_dirs))
    coef = density_coefficients(means, 0.2)  # (R, 3, D)
    rows = np.sort(rng.choice(n_rows, n_feats, replace=False)).astype(np.int64)
    f = rng.standard_normal(n_feats) + 1j * rng.standard_normal(n_feats)
    return f, rows, coef


def _run(fn, f, rows, coef32):
    out = np.empty((rows.size, coef32.shape[-1]), dtype=np.float32)
    fn(f.real.copy(), f.imag.copy(), rows, coef32, out, np.empty(coef32.shape[-1], np.int32))
    return out


@pytest.mark.parametrize("form", ["python", "numpy"])
def test_densities_match_the_double_precision_formula(form):
    f, rows, coef = _case()
    fn = _density_kernel.densities if form == "python" else _density_kernel.densities_numpy
    out = _run(fn, f, rows, coef.astype(np.float32))
    expected = densities_from_coefficients(f, coef[rows])
    np.testing.assert_allclose(out, expected, rtol=1e-5, atol=1e-6)
    assert np.all(out.max(axis=1) == 1.0)  # every row's maximum is factored out


def test_hand_case_one_feature_two_directions():
    # c = 1 + 1j, means 1 + 1j and 0, sigma^2 = 1: densities 1 and e^-2
    coef = density_coefficients(np.array([[1 + 1j, 0j]]), 1.0).astype(np.float32)
    out = _run(_density_kernel.densities, np.array([1 + 1j]), np.array([0]), coef)
    np.testing.assert_allclose(out, [[1.0, np.exp(-2.0)]], rtol=1e-6)


def test_exponential_matches_numpy_over_the_whole_range():
    """Cephes' expf as written here against numpy.exp, from 0 down to -87 (and below: ~1e-38)."""
    x = np.concatenate([np.linspace(-87.0, 0.0, 20001), [-90.0, -200.0]]).astype(np.float32)
    # one feature, one row of coefficients: l_d = x_d (the constant row), maximum 0
    coef = np.zeros((1, 3, x.size), dtype=np.float32)
    coef[0, 2] = x
    out = _run(_density_kernel.densities, np.array([0j]), np.array([0]), coef)[0]
    ref = np.exp(x.astype(np.float64))
    normal = x >= -87.0
    np.testing.assert_allclose(out[normal], ref[normal], rtol=1e-6)
    assert np.all((out[~normal] > 0) & (out[~normal] < 2e-38))


@pytest.mark.skipif(not _density_kernel.available(),
                    reason="Numba not installed (or AVTRACK_NO_JIT set)")
def test_compiled_kernel_gives_the_python_forms_numbers():
    f, rows, coef = _case(3, n_rows=40, n_dirs=50, n_feats=30)
    c32 = coef.astype(np.float32)
    compiled = _run(_density_kernel.kernel(), f, rows, c32)
    plain = _run(_density_kernel.densities, f, rows, c32)
    np.testing.assert_allclose(compiled, plain, rtol=1e-4, atol=1e-6)


def test_mean_ratios_in_single_precision_match_double():
    rng = np.random.default_rng(2)
    dens = rng.random((30, 20))
    dens /= dens.max(axis=1, keepdims=True)
    w = rng.random(20)
    w /= w.sum()
    single = mean_ratios(dens.astype(np.float32), w)
    assert single.dtype == np.float64
    np.testing.assert_allclose(single, mean_ratios(dens, w), rtol=1e-5)


def _double_precision_densities(loc):
    coef = loc._coef32.astype(np.float64)

    def dens(values, valid):
        rows = np.flatnonzero(valid)
        return densities_from_coefficients(values.ravel()[rows], coef[rows])

    return dens


def _two_sources(n: int = 24000) -> np.ndarray:
    """``(4, n)``: two white sources with different inter-channel delays, and weak noise."""
    rng = np.random.default_rng(4)
    src = rng.standard_normal((2, n))
    delays = [(0, 1, 2, 3), (3, 1, 0, 2)]  # two sources, different inter-channel delays
    x = np.zeros((4, n))
    for s, d in zip(src, delays, strict=True):
        for ch in range(4):
            x[ch] += np.roll(s, d[ch])
    return x + 0.01 * rng.standard_normal(x.shape)


@pytest.mark.parametrize("method", ["dprtf-eg", "dprtf-eg-fast", "prp-rem"])
def test_maps_match_the_maps_from_double_precision_densities(method):
    """A 1.5 s two-source recording on the 4-mic NAO head: the same peaks frame by frame."""
    arr = builtin_array("nao4")
    x = _two_sources()
    single = make_localizer(method, arr).run(x)
    ref = make_localizer(method, arr)
    ref._densities = _double_precision_densities(ref)
    double = ref.run(x)
    np.testing.assert_allclose(single.weights, double.weights, atol=1e-5)
    busy = double.weights.max(axis=1) > 2.0 / double.weights.shape[1]
    assert busy.any()
    np.testing.assert_array_equal(single.weights[busy].argmax(axis=1),
                                  double.weights[busy].argmax(axis=1))


def test_localizer_falls_back_to_numpy_when_the_kernel_cannot_be_built(monkeypatch):
    x = _two_sources(8000)
    arr = builtin_array("nao4")
    usual = make_localizer("dprtf-eg", arr).run(x)
    monkeypatch.setattr(_density_kernel, "_KERNEL", None)
    monkeypatch.setattr(_density_kernel, "_FAILED", False)
    monkeypatch.setitem(sys.modules, "numba", None)  # `from numba import njit` raises
    loc = make_localizer("dprtf-eg", arr)
    loc._compiled = True
    with pytest.warns(RuntimeWarning, match="could not be built"):
        fallback = loc.run(x)
    assert _density_kernel.kernel() is None  # decided once per process (no second warning)
    np.testing.assert_allclose(fallback.weights, usual.weights, atol=1e-5)
