"""Target management shared by the VEM trackers (OVBT, VAVIT, the robot head's 3-D tracker).

Beside the engine's posterior (:class:`~avtrack.vem.engine.VEMEngine`), a tracker keeps a few
arrays with one row per target: the visibility posterior and its evidence window (thesis
eqs. 3.31–3.32), the run lengths that decide a target's death, and the like.
:class:`ManagedTargets` keeps them in the engine's target order: a tracker declares them
(:meth:`ManagedTargets._per_target`), and births (:meth:`ManagedTargets._add_targets`) and
deaths (:meth:`ManagedTargets._remove`) update the engine and every array together.

:func:`births_outside` is the birth gate every tracker of boxes applies before eq. 3.30's
selection: a new person cannot stand inside a tracked person's box (such detection
sequences are partial or duplicate detections of that person).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from avtrack.vem.birth import BirthCandidate
from avtrack.vem.engine import VEMEngine


@dataclass(frozen=True)
class PerTarget:
    """One array with a row per target.

    Attributes
    ----------
    name : str
        The tracker's attribute holding the array.
    born : float
        The value of a newborn target's row.
    shape : tuple of int
        The shape of one row (``()``: one value per target).
    dtype : type
    """

    name: str
    born: float
    shape: tuple[int, ...] = ()
    dtype: type = float


class ManagedTargets:
    """Per-target arrays that follow the targets of ``self.engine``, and target identities.

    A subclass sets ``self.engine`` and calls :meth:`_init_targets` in its ``__init__``; its
    :meth:`_per_target` names its arrays.
    """

    engine: VEMEngine
    _next_id: int

    def _per_target(self) -> tuple[PerTarget, ...]:
        """The tracker's per-target arrays (a subclass adds its own to its parent's)."""
        raise NotImplementedError

    def _init_targets(self) -> None:
        """No target yet: every per-target array empty, identities from 1."""
        self._next_id = 1
        for spec in self._per_target():
            setattr(self, spec.name, np.zeros((0, *spec.shape), dtype=spec.dtype))

    def _new_ids(self, k: int) -> np.ndarray:
        """``k`` identities never used before, ``(k,)`` int."""
        ids = np.arange(self._next_id, self._next_id + k)
        self._next_id += k
        return ids

    def _add_targets(
        self, ids: np.ndarray, mu: np.ndarray, gamma: np.ndarray, inits: Sequence[Any]
    ) -> None:
        """Add targets ``ids`` with means ``(k, d)`` and covariances ``(k, d, d)`` to the
        engine (``inits``: each observation model's initial state, see
        :meth:`~avtrack.vem.engine.VEMEngine.add_targets`), and a newborn row to every
        per-target array."""
        self.engine.add_targets(ids, mu, gamma, list(inits))
        k = len(ids)
        for spec in self._per_target():
            rows: np.ndarray = np.full((k, *spec.shape), spec.born, dtype=spec.dtype)
            setattr(self, spec.name, np.concatenate([getattr(self, spec.name), rows]))

    def _remove(self, keep: np.ndarray) -> None:
        """Keep only the targets where ``keep (N,) bool`` is True, in the engine and in every
        per-target array."""
        self.engine.remove_targets(keep)
        for spec in self._per_target():
            setattr(self, spec.name, getattr(self, spec.name)[keep])


def intersection_over_first(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(K, 4), (N, 4)`` ltwh boxes -> ``(K, N)`` area(a ∩ b) / area(a); 0 for an empty
    box ``a`` (zero width or height)."""
    lt = np.maximum(a[:, None, :2], b[None, :, :2])
    rb = np.minimum(a[:, None, :2] + a[:, None, 2:], b[None, :, :2] + b[None, :, 2:])
    wh = np.maximum(rb - lt, 0.0)  # intersection width and height, (K, N, 2)
    area = a[:, 2] * a[:, 3]
    with np.errstate(invalid="ignore", divide="ignore"):
        out = wh[:, :, 0] * wh[:, :, 1] / area[:, None]
    return np.nan_to_num(out, nan=0.0, posinf=0.0)


def births_outside(
    candidates: list[BirthCandidate],
    boxes: Callable[[np.ndarray], np.ndarray],
    target_boxes: np.ndarray,
    max_overlap: float,
) -> list[BirthCandidate]:
    """The birth candidates whose box lies inside no tracked box by more than ``max_overlap``.

    Parameters
    ----------
    candidates : list of BirthCandidate
    boxes : callable
        Stacked candidate states ``(K, d)`` -> their ltwh boxes ``(K, 4)``.
    target_boxes : ndarray (N, 4)
        The ltwh boxes of the tracked people the gate is against.
    max_overlap : float
        Largest accepted fraction of a candidate's box inside one tracked box.
    """
    if not candidates or len(target_boxes) == 0:
        return candidates
    inside = intersection_over_first(
        boxes(np.stack([c.mu for c in candidates])), target_boxes
    ).max(axis=1)
    return [c for c, o in zip(candidates, inside, strict=True) if not o > max_overlap]
