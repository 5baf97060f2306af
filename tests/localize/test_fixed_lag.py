"""The fixed-lag smoother of a grid filter's layered weights, against the forward-backward
algorithm worked out by enumerating every path of a small hidden Markov model."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avtrack.localize.fixed_lag import FixedLagSmoother

#: a 3-state chain (one layer of 3 cells): P[i, j] = p(x_t = i | x_{t-1} = j)
P = np.array([[0.8, 0.1, 0.2], [0.15, 0.7, 0.1], [0.05, 0.2, 0.7]])


def _filter(lik: np.ndarray, prior: np.ndarray):
    """The forward pass: ``(alpha_t, pi_t)`` per frame, shaped ``(1, 3)`` (one layer)."""
    out, alpha = [], None
    for t, ell in enumerate(lik):
        pred = prior if t == 0 else P @ alpha
        alpha = ell * pred / np.sum(ell * pred)
        out.append((alpha[None], pred[None]))
    return out


def _brute_force(lik: np.ndarray, prior: np.ndarray) -> np.ndarray:
    """p(x_t | y_1..y_T) for every t, summing over all paths ``(T, 3)``."""
    t_ = len(lik)
    post = np.zeros((t_, 3))
    for path in itertools.product(range(3), repeat=t_):
        p = prior[path[0]] * lik[0, path[0]]
        for t in range(1, t_):
            p *= P[path[t], path[t - 1]] * lik[t, path[t]]
        for t in range(t_):
            post[t, path[t]] += p
    return post / post.sum(axis=1, keepdims=True)


def _smoother(lag: int, gap: int = 1000) -> FixedLagSmoother:
    return FixedLagSmoother(lag, gap, lambda x: x @ P)  # (P^T x) of each row: x P


LIK = np.array([[0.9, 0.3, 0.1], [0.2, 0.8, 0.4], [0.1, 0.3, 0.9], [0.5, 0.5, 0.2],
                [0.05, 0.9, 0.3]])
PRIOR = np.array([0.5, 0.3, 0.2])


def test_a_lag_as_long_as_the_signal_is_the_forward_backward_smoother():
    sm = _smoother(lag=10)
    for alpha, pred in _filter(LIK, PRIOR):
        sm.add(alpha, pred, True, ("x",))
    out, extra = sm.ready()
    assert out.shape == (0, 1, 3) and extra == [] and len(sm) == 5  # all held back
    out, extra = sm.ready(final=True)
    np.testing.assert_allclose(out[:, 0], _brute_force(LIK, PRIOR), rtol=1e-10)
    assert extra == [("x",)] * 5 and len(sm) == 0


@pytest.mark.parametrize("lag", [0, 1, 2])
def test_each_frame_is_smoothed_over_the_next_lag_frames(lag):
    """Frame t's output is p(x_t | y_1..y_{t+L}): the brute force on the signal cut at t+L."""
    sm = _smoother(lag)
    got = []
    for alpha, pred in _filter(LIK, PRIOR):
        sm.add(alpha, pred, True)
        got.extend(sm.ready()[0][:, 0])
    assert len(got) == len(LIK) - lag
    got.extend(sm.ready(final=True)[0][:, 0])
    for t, row in enumerate(got):
        cut = min(t + lag, len(LIK) - 1) + 1
        np.testing.assert_allclose(row, _brute_force(LIK[:cut], PRIOR)[t], rtol=1e-10)


def test_a_pause_longer_than_the_gap_stops_the_smoothing():
    """What comes from the frame ``gap`` frames into a pause on says nothing about the frames
    before it: they are smoothed as if the signal ended there."""
    sm = _smoother(lag=4, gap=2)
    evidence = [True, False, False, True, True]  # frame 2 is 2 frames into the pause
    for (alpha, pred), ev in zip(_filter(LIK, PRIOR), evidence, strict=True):
        sm.add(alpha, pred, ev)
    out = sm.ready(final=True)[0][:, 0]
    np.testing.assert_allclose(out[:2], _brute_force(LIK[:2], PRIOR), rtol=1e-10)
    np.testing.assert_allclose(out[2:], _brute_force(LIK, PRIOR)[2:], rtol=1e-10)
    # without the cut, frame 0 would have been moved by the later frames
    assert not np.allclose(_brute_force(LIK, PRIOR)[0], out[0], atol=1e-3)


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError, match="lag must be an integer >= 0"):
        FixedLagSmoother(-1, 1, lambda x: x)
    with pytest.raises(ValueError, match="gap must be an integer >= 1"):
        FixedLagSmoother(3, 0, lambda x: x)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 6), st.integers(1, 4), st.integers(0, 2**32 - 1))
def test_outputs_are_distributions_in_order(lag, gap, seed):
    rng = np.random.default_rng(seed)
    sm = FixedLagSmoother(lag, gap, lambda x: x)
    n, got = 12, []
    for t in range(n):
        sm.add(rng.dirichlet(np.ones(6)).reshape(2, 3), rng.uniform(0.1, 1, (2, 3)),
               bool(rng.random() < 0.7), (t,))
        out, extra = sm.ready()
        got += [e[0] for e in extra]
        assert np.all(out >= 0) and np.allclose(out.sum(axis=(1, 2)), 1.0)
    got += [e[0] for e in sm.ready(final=True)[1]]
    assert got == list(range(n))
