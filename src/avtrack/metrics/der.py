r"""Diarization error rate (NIST RT definition) with optimal speaker mapping and collars.

For one recording, with :math:`N_{ref}(t)` and :math:`N_{hyp}(t)` the numbers of reference and
hypothesis speakers active at time ``t`` and :math:`N_{correct}(t)` the number of reference
speakers active at ``t`` whose mapped hypothesis speaker is active too,

.. math::
    \mathrm{DER} = \frac{\int \max(N_{ref}, N_{hyp}) - N_{correct}\,dt}{\int N_{ref}\,dt}
    = \frac{\text{missed} + \text{false alarm} + \text{confusion}}{\text{total}}

with missed :math:`= \int\max(0, N_{ref} - N_{hyp})`, false alarm
:math:`= \int\max(0, N_{hyp} - N_{ref})`, confusion :math:`= \int\min(N_{ref}, N_{hyp}) -
N_{correct}`. The one-to-one speaker mapping maximises the total time during which mapped
speakers are both active (Hungarian algorithm), as in NIST ``md-eval`` and
``pyannote.metrics``. Time within ``collar`` seconds of any reference segment boundary (start
or end) is not scored (NIST's ``-c 0.25``; ``pyannote.metrics`` takes the collar's *total*
width, so ``collar=0.25`` here is ``DiarizationErrorRate(collar=0.5)`` there, which
``tests/metrics/test_der.py`` checks to 1e-9). The scored region ``uem`` defaults to the span
of the reference and hypothesis segments together (pyannote's default); ``skip_overlap``
also removes reference overlap. Overlapping speech is scored (each speaker counts).

A corpus DER sums the components over recordings (:meth:`DERComponents.sum`), as
``pyannote.metrics`` accumulates them, rather than averaging per-recording rates.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from avtrack.io.rttm import RTTMSegment


@dataclass(frozen=True)
class DERComponents:
    """Durations (seconds) behind a DER.

    Attributes
    ----------
    total : float
        Scored reference speech, speaker-seconds.
    missed, false_alarm, confusion : float
        Error durations.
    """

    total: float
    missed: float
    false_alarm: float
    confusion: float

    @property
    def errors(self) -> float:
        return self.missed + self.false_alarm + self.confusion

    @property
    def rate(self) -> float:
        """DER as a fraction (NaN without scored reference speech)."""
        return self.errors / self.total if self.total > 0 else float("nan")

    @staticmethod
    def sum(parts: Iterable[DERComponents]) -> DERComponents:
        """Components of several recordings added up (the corpus DER)."""
        parts = list(parts)
        return DERComponents(
            *(
                float(sum(getattr(p, n) for p in parts))
                for n in ("total", "missed", "false_alarm", "confusion")
            )
        )


def _by_speaker(segments: Sequence[RTTMSegment], name: str) -> dict[str, np.ndarray]:
    """``{speaker: (S, 2)}`` merged (non-overlapping, sorted) turns of each speaker."""
    out: dict[str, list[tuple[float, float]]] = {}
    for s in segments:
        if not isinstance(s, RTTMSegment):
            raise TypeError(f"{name} must hold RTTMSegment records, got {type(s).__name__}")
        out.setdefault(s.speaker, []).append((s.start, s.end))
    merged = {}
    for spk, turns in out.items():
        turns.sort()
        m = [list(turns[0])]
        for a, b in turns[1:]:
            if a <= m[-1][1]:
                m[-1][1] = max(m[-1][1], b)
            else:
                m.append([a, b])
        merged[spk] = np.array(m, dtype=float)
    return merged


def _active(turns: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Whether times ``t`` fall inside the sorted disjoint ``turns (S, 2)``."""
    i = np.searchsorted(turns[:, 0], t, side="right") - 1
    ok = i >= 0
    out = np.zeros(t.shape, dtype=bool)
    out[ok] = t[ok] < turns[i[ok], 1]
    return out


def diarization_error_rate(
    reference: Sequence[RTTMSegment],
    hypothesis: Sequence[RTTMSegment],
    collar: float = 0.25,
    uem: tuple[float, float] | None = None,
    skip_overlap: bool = False,
) -> DERComponents:
    """DER components of one recording (see the module docstring).

    Parameters
    ----------
    reference, hypothesis : sequence of RTTMSegment
        Speaker turns of one recording (file ids are not compared; speaker labels of the two
        sides need not match).
    collar : float
        Seconds not scored on each side of every reference boundary (NIST: 0.25).
    uem : (float, float), optional
        Scored time span; default the span of all segments.
    skip_overlap : bool
        Do not score where several reference speakers talk.

    Returns
    -------
    DERComponents
    """
    if not (np.isfinite(collar) and collar >= 0):
        raise ValueError(f"collar must be a number >= 0 (seconds), got {collar!r}")
    ref = _by_speaker(list(reference), "reference")
    hyp = _by_speaker(list(hypothesis), "hypothesis")
    all_turns = [t for d in (ref, hyp) for t in d.values()]
    if uem is None:
        if not all_turns:
            return DERComponents(0.0, 0.0, 0.0, 0.0)
        stacked = np.vstack(all_turns)
        uem = (float(stacked[:, 0].min()), float(stacked[:, 1].max()))
    lo, hi = float(uem[0]), float(uem[1])
    if not hi >= lo:
        raise ValueError(f"uem must be (start, end) with end >= start, got {uem!r}")
    bounds = [np.array([lo, hi])]
    ref_edges = np.concatenate([t.ravel() for t in ref.values()]) if ref else np.zeros(0)
    bounds += [t.ravel() for t in all_turns]
    if collar > 0:
        bounds += [ref_edges - collar, ref_edges + collar]
    edges = np.unique(np.clip(np.concatenate(bounds), lo, hi))
    if edges.size < 2:
        return DERComponents(0.0, 0.0, 0.0, 0.0)
    mid = 0.5 * (edges[:-1] + edges[1:])
    dur = np.diff(edges)
    scored = dur > 0
    if collar > 0 and ref_edges.size:  # drop the collars around reference boundaries
        near = np.abs(mid[:, None] - ref_edges[None, :]).min(axis=1) < collar
        scored &= ~near
    r_act = (
        np.column_stack([_active(t, mid) for t in ref.values()])
        if ref
        else np.zeros((mid.size, 0), bool)
    )
    h_act = (
        np.column_stack([_active(t, mid) for t in hyp.values()])
        if hyp
        else np.zeros((mid.size, 0), bool)
    )
    if skip_overlap:
        scored &= r_act.sum(axis=1) <= 1
    w = np.where(scored, dur, 0.0)
    n_ref = r_act.sum(axis=1)
    n_hyp = h_act.sum(axis=1)
    correct = np.zeros(mid.size)
    if r_act.shape[1] and h_act.shape[1]:
        co = (r_act * w[:, None]).T.astype(float) @ h_act.astype(float)  # co-occurrence
        rows, cols = linear_sum_assignment(-co)  # optimal one-to-one mapping
        keep = co[rows, cols] > 0
        for r_, c_ in zip(rows[keep], cols[keep], strict=True):
            correct += r_act[:, r_] & h_act[:, c_]
    return DERComponents(
        total=float(w @ n_ref),
        missed=float(w @ np.maximum(0, n_ref - n_hyp)),
        false_alarm=float(w @ np.maximum(0, n_hyp - n_ref)),
        confusion=float(w @ (np.minimum(n_ref, n_hyp) - correct)),
    )
