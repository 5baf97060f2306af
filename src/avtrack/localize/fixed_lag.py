"""Fixed-lag forward-backward smoothing of a grid filter's layered weights.

The position weights of :class:`~avtrack.localize.cgmm_eg.DPRTFEGFast` are a grid filter: a
linear prediction ``pi_t = P alpha_{t-1}`` (each velocity layer's drift, the random walk, the
velocity switch) and a multiplicative update ``alpha_t = r_t * pi_t`` (eqs. 5.17-5.19 of the
thesis with the fixed share: ``r_t = alpha_t / pi_t`` is the factor the frame's features
applied). Read as a hidden Markov model whose likelihoods are those factors, the filter's map of
frame ``t`` uses the frames up to ``t`` only, so a talker who moves is trailed, and a small
random walk, which keeps two standing talkers apart, trails further. The smoothed weights of
frame ``t`` given the frames up to ``t + L`` (the backward recursion of the forward-backward
algorithm, L. R. Rabiner, "A tutorial on hidden Markov models", Proc. IEEE 77(2), 1989, eqs.
24-25, run over a fixed lag; not in the thesis) are ``alpha_t * beta_t`` with

``beta_{t+L} = 1``, ``beta_s = P^T (r_{s+1} * beta_{s+1})`` for ``s = t+L-1, ..., t``,

so the map is delayed by ``L`` frames and no longer trails. The recursion is cut at frames
deep in a silence (``gap`` frames or more since the last frame with features, where
``beta = 1``): what a talker says after a pause says nothing of where the one before stood.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

_TINY = 1e-300
#: frames smoothed at once (their arrays stay in the processor's cache)
_CHUNK = 32


class FixedLagSmoother:
    """Smoothed layered weights ``(U, D)`` of a grid filter, ``lag`` frames behind it.

    Feed each frame's filtered weights, predicted weights and evidence with :meth:`add`; take
    the frames whose ``lag`` successors have arrived with :meth:`ready` (all of them, the last
    read with the frames there are, with ``final=True``).

    Parameters
    ----------
    lag : int
        ``L``, frames (0: the filter itself).
    gap : int
        Frames without evidence after which the backward recursion is cut (>= 1).
    backward : callable
        ``P^T`` of the filter's prediction, applied to ``(..., U, D)`` arrays.
    """

    def __init__(
        self, lag: int, gap: int, backward: Callable[[np.ndarray], np.ndarray]
    ) -> None:
        if isinstance(lag, bool) or not isinstance(lag, int | np.integer) or lag < 0:
            raise ValueError(f"FixedLagSmoother: lag must be an integer >= 0, got {lag!r}")
        if isinstance(gap, bool) or not isinstance(gap, int | np.integer) or gap < 1:
            raise ValueError(f"FixedLagSmoother: gap must be an integer >= 1, got {gap!r}")
        self.lag = int(lag)
        self.gap = int(gap)
        self.backward = backward
        self.reset()

    def reset(self) -> None:
        """Start a new signal."""
        self._alpha: list[np.ndarray] = []
        self._ratio: list[np.ndarray] = []
        self._silent_run: list[int] = []
        self._extra: list[tuple] = []
        self._run = 0
        self._shape: tuple[int, ...] = (0, 0)  # of a frame's weights, once one has come

    def add(self, alpha: np.ndarray, predicted: np.ndarray, evidence: bool,
            extra: tuple = ()) -> None:
        """One frame: the filtered weights ``alpha_t`` and the prediction ``pi_t`` they were
        updated from (both ``(U, D)``, positive), whether the frame had evidence, and anything
        to hand back with the frame (``extra``)."""
        self._shape = alpha.shape
        self._alpha.append(alpha)
        self._ratio.append(alpha / np.maximum(predicted, _TINY))
        self._run = 0 if evidence else self._run + 1
        self._silent_run.append(self._run)
        self._extra.append(extra)

    def __len__(self) -> int:
        """Frames held."""
        return len(self._alpha)

    def ready(self, final: bool = False) -> tuple[np.ndarray, list[tuple]]:
        """The smoothed weights ``(n, U, D)`` (each frame's summing to one) of the frames now
        ready, oldest first, and their ``extra``; those frames are dropped."""
        n_held = len(self._alpha)
        n_out = n_held if final else max(n_held - self.lag, 0)
        if n_out == 0:
            return np.zeros((0, *self._shape)), []
        alpha = np.asarray(self._alpha[:n_out])
        if self.lag:
            ratio = np.asarray(self._ratio)
            cut = np.asarray(self._silent_run) >= self.gap
            for c0 in range(0, n_out, _CHUNK):  # a chunk of frames at a time: cache-sized
                c1 = min(c0 + _CHUNK, n_out)
                alpha[c0:c1] *= self._beta(ratio, cut, c0, c1)
        alpha /= alpha.sum(axis=(-2, -1), keepdims=True)
        extra = self._extra[:n_out]
        for buf in (self._alpha, self._ratio, self._silent_run, self._extra):
            del buf[:n_out]
        return alpha, extra

    def _beta(self, ratio: np.ndarray, cut: np.ndarray, first: int, stop: int) -> np.ndarray:
        """``beta_t`` ``(stop - first, U, D)`` of frames ``first <= t < stop`` from the held
        frames' ratios ``r`` and cuts (each frame's scaled to a largest value of one)."""
        n_held = ratio.shape[0]
        beta = np.ones((stop - first, *ratio.shape[1:]))
        for k in range(self.lag, 0, -1):  # beta_s from s = t+L-1 down to t
            m = min(stop, n_held - k) - first  # frames t whose t + k has arrived
            if m <= 0:
                continue
            s0 = first + k
            b = self.backward(ratio[s0 : s0 + m] * beta[:m])
            b[cut[s0 : s0 + m]] = 1.0
            beta[:m] = b / b.max(axis=(-2, -1), keepdims=True)
        return beta
