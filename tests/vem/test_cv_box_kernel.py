"""The compiled VEM iterations (avtrack.vem._cv_box_kernel) against the NumPy path."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avtrack.vem import _cv_box_kernel as K
from avtrack.vem.dynamics import box_dynamics_variance, constant_velocity_transition
from avtrack.vem.engine import VEMEngine
from avtrack.vem.updates import CLUTTER_FLOOR, _kl_projection
from avtrack.visual.appearance import BhattacharyyaAppearance
from avtrack.visual.model import BoxObservationModel, BoxObservations, box_observation_variance

D = constant_velocity_transition(4, 2)

pytestmark = pytest.mark.skipif(K.kernel() is None, reason="Numba cannot build the kernel here")


def _engines(rng, appearance: bool, **kwargs) -> tuple[VEMEngine, VEMEngine]:
    """Two engines with the same targets: the compiled path, and the NumPy one."""
    out = []
    mu = np.column_stack([rng.uniform(50, 300, (4, 2)), rng.uniform(30, 60, (4, 2)),
                          rng.normal(size=(4, 2))])
    gamma = np.stack([np.diag(rng.uniform(1, 9, 6)) for _ in range(4)])
    refs = rng.uniform(size=(4, 5))
    for compiled in (True, False):
        model = (BoxObservationModel(-20.0, BhattacharyyaAppearance(), appearance_update=0.1)
                 if appearance else BoxObservationModel(-20.0))
        engine = VEMEngine(D, [model], **kwargs)
        engine._compiled = compiled
        engine.add_targets([1, 2, 3, 4], mu, gamma, [refs] if appearance else None)
        out.append(engine)
    return out[0], out[1]


@pytest.mark.parametrize("appearance", [False, True])
@pytest.mark.parametrize("exclusive", [False, True])
@pytest.mark.parametrize("marginal_init", [False, True])
def test_compiled_frames_equal_the_numpy_path_to_rounding(appearance, exclusive, marginal_init):
    """Crowded frames (two detections of one target, a stray one, a missing target), several
    in a row: posteriors, responsibilities and masses agree to rounding."""
    rng = np.random.default_rng(7)
    fast, slow = _engines(rng, appearance, n_iter=3, exclusive=exclusive,
                          marginal_init=marginal_init)
    crowded = 0
    for _ in range(6):
        mu = slow.mu
        z = np.vstack([mu[[0, 0, 2, 3], :4] + rng.normal(scale=2.0, size=(4, 4)),
                       [400, 50, 40, 40]])
        app = rng.uniform(size=(5, 5)) if appearance else None
        obs = BoxObservations(z, box_observation_variance(z), app)
        a = fast.step([obs], box_dynamics_variance(fast.mu))
        b = slow.step([obs], box_dynamics_variance(slow.mu))
        np.testing.assert_allclose(a.mu, b.mu, rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(a.gamma, b.gamma, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(a.responsibilities[0], b.responsibilities[0], atol=1e-12)
        np.testing.assert_allclose(a.mass[0], b.mass[0], atol=1e-12)
        crowded += bool(b.responsibilities[0][:, 1].sum() > 1.0 + 1e-9) or exclusive
    assert crowded  # the case the exclusive projection changes is exercised


def test_no_detection_and_no_target_frames():
    rng = np.random.default_rng(8)
    fast, slow = _engines(rng, False, exclusive=True)
    empty = BoxObservations(np.zeros((0, 4)), np.ones((0, 4)))
    a = fast.step([empty], box_dynamics_variance(fast.mu))
    b = slow.step([empty], box_dynamics_variance(slow.mu))
    np.testing.assert_allclose(a.mu, b.mu, rtol=1e-13)
    np.testing.assert_allclose(a.gamma, b.gamma, rtol=1e-13)
    for e in (fast, slow):
        e.remove_targets(np.zeros(4, dtype=bool))
    z = np.array([[100.0, 100.0, 40.0, 80.0]])
    obs = BoxObservations(z, box_observation_variance(z))
    a = fast.step([obs], np.zeros((0, 6)))
    b = slow.step([obs], np.zeros((0, 6)))
    np.testing.assert_array_equal(a.responsibilities[0], b.responsibilities[0])


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), m=st.integers(1, 6), n=st.integers(1, 5),
       spread=st.floats(0.5, 8.0))
def test_compiled_projection_equals_the_numpy_one(seed, m, n, spread):
    """The compiled exclusive projection gives the NumPy one's projection (rows sum to one,
    target columns to at most one) and agrees with it to rounding."""
    rng = np.random.default_rng(seed)
    alpha = np.exp(spread * rng.normal(size=(m, n + 1)))
    alpha /= alpha.sum(axis=1, keepdims=True)
    alpha[:, 0] = np.maximum(alpha[:, 0], CLUTTER_FLOOR)
    expected, _ = _kl_projection(alpha)
    K.kernel()
    q = np.empty_like(alpha)
    assert K._kl_projection_c(np.ascontiguousarray(alpha), q)
    np.testing.assert_allclose(q.sum(axis=1), 1.0, atol=1e-12)
    assert q[:, 1:].sum(axis=0).max() <= 1.0 + 1e-9
    np.testing.assert_allclose(q, expected, atol=1e-9)


def test_compiled_frames_with_a_control_term_equal_the_numpy_path():
    """With a control term (ego-motion, eq. 3.34) the prediction stays in NumPy and the
    compiled iterations start from it."""
    rng = np.random.default_rng(9)
    fast, slow = _engines(rng, False, exclusive=True)
    control = rng.normal(scale=3.0, size=(4, 6))
    z = slow.mu[:, :4] + control[:, :4] + rng.normal(scale=2.0, size=(4, 4))
    obs = BoxObservations(z, box_observation_variance(z))
    a = fast.step([obs], box_dynamics_variance(fast.mu), control=control)
    b = slow.step([obs], box_dynamics_variance(slow.mu), control=control)
    np.testing.assert_allclose(a.mu, b.mu, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(a.gamma, b.gamma, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(a.responsibilities[0], b.responsibilities[0], atol=1e-12)
