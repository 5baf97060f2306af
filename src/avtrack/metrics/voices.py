r"""Scores of separated voices: SI-SDR, its improvement over the reference microphone, and the
matching of tracked identities to ground-truth persons.

Scale-invariant signal-to-distortion ratio (Le Roux, Wisdom, Erdogan and Hershey, "SDR --
half-baked or well done?", ICASSP 2019), with the estimate :math:`\hat s` and the reference
:math:`s` both made zero-mean:

.. math::
    \alpha = \frac{\hat s^\top s}{\|s\|^2}, \qquad
    \mathrm{SI\text{-}SDR} = 10 \log_{10} \frac{\|\alpha s\|^2}{\|\alpha s - \hat s\|^2}

The improvement (SI-SDRi) is the voice's SI-SDR minus that of the reference microphone's
mixture against the same reference.

Identities: every video frame, the ground-truth persons present (``gt/doa.csv``) and the
tracked persons (``persons.csv``, or the rows of a DOA track table) are matched one to one on
azimuth (Hungarian algorithm, matches further apart than ``gate_deg`` refused), as ``avtrack
eval persons`` does; then each ground-truth person is given, one to one, the tracked identity
matched to them in most of the frames where they speak (Hungarian algorithm on those counts).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from avtrack.io.doa import wrap_azimuth


def si_sdr(estimate: np.ndarray, reference: np.ndarray) -> float:
    """SI-SDR in dB of ``estimate`` against ``reference`` (module docstring).

    Parameters
    ----------
    estimate, reference : ndarray (n_samples,)

    Returns
    -------
    float
        ``-inf`` for an all-zero estimate, ``inf`` for a perfect one.
    """
    s_hat = np.asarray(estimate, dtype=float).reshape(-1)
    s = np.asarray(reference, dtype=float).reshape(-1)
    if s_hat.shape != s.shape:
        raise ValueError(f"si_sdr: estimate and reference must have one length, got "
                         f"{s_hat.size} and {s.size}")
    if not (np.all(np.isfinite(s_hat)) and np.all(np.isfinite(s))):
        raise ValueError("si_sdr: estimate and reference must be finite")
    s_hat = s_hat - s_hat.mean()
    s = s - s.mean()
    ref_power = float(s @ s)
    if ref_power == 0:
        raise ValueError("si_sdr: the reference is silent (all samples equal)")
    alpha = float(s_hat @ s) / ref_power  # alpha = <s_hat, s> / ||s||^2
    target = alpha * s
    err = float(np.sum((target - s_hat) ** 2))
    tp = float(target @ target)
    if tp == 0:
        return float("-inf")
    if err == 0:
        return float("inf")
    return 10 * np.log10(tp / err)  # ||alpha s||^2 / ||alpha s - s_hat||^2


@dataclass(frozen=True)
class VoiceScore:
    """One ground-truth person's voice.

    Attributes
    ----------
    person : int
        Ground-truth id.
    track : int or None
        The tracked identity matched to them (None: none).
    si_sdr : float
        SI-SDR of the matched voice, dB (``-inf`` without one).
    si_sdr_mixture : float
        SI-SDR of the reference microphone's signal, dB.
    in_view_share : float
        Share of their speaking frames in which the camera saw them (NaN if unknown).
    """

    person: int
    track: int | None
    si_sdr: float
    si_sdr_mixture: float
    in_view_share: float = float("nan")

    @property
    def improvement(self) -> float:
        """SI-SDRi, dB."""
        return self.si_sdr - self.si_sdr_mixture


def assign_identities(
    gt_frames: np.ndarray,
    gt_ids: np.ndarray,
    gt_azimuth: np.ndarray,
    gt_active: np.ndarray,
    hyp_frames: np.ndarray,
    hyp_ids: np.ndarray,
    hyp_azimuth: np.ndarray,
    gate_deg: float = 30.0,
) -> dict[int, int]:
    """Ground-truth person -> tracked identity (module docstring).

    Parameters
    ----------
    gt_frames, gt_ids, gt_azimuth, gt_active : ndarray (G,)
        One row per ground-truth person per frame; ``gt_active``: the person speaks.
    hyp_frames, hyp_ids, hyp_azimuth : ndarray (H,)
        One row per tracked person per frame (the same frame numbering).
    gate_deg : float
        Largest azimuth difference of a match.

    Returns
    -------
    dict ``{gt id: tracked id}``; ground-truth persons never matched while speaking are absent.
    """
    if not 0 < gate_deg <= 180:
        raise ValueError(f"gate_deg must be in (0, 180] degrees, got {gate_deg!r}")
    gf = np.asarray(gt_frames, dtype=np.int64)
    gi = np.asarray(gt_ids, dtype=np.int64)
    ga = np.asarray(gt_azimuth, dtype=float)
    gs = np.asarray(gt_active, dtype=bool)
    hf = np.asarray(hyp_frames, dtype=np.int64)
    hi = np.asarray(hyp_ids, dtype=np.int64)
    ha = np.asarray(hyp_azimuth, dtype=float)
    if not (gf.shape == gi.shape == ga.shape == gs.shape):
        raise ValueError("gt_frames, gt_ids, gt_azimuth and gt_active must have one shape")
    if not (hf.shape == hi.shape == ha.shape):
        raise ValueError("hyp_frames, hyp_ids and hyp_azimuth must have one shape")
    g_u, h_u = np.unique(gi), np.unique(hi)
    if g_u.size == 0 or h_u.size == 0:
        return {}
    counts = np.zeros((g_u.size, h_u.size))
    order = np.argsort(hf, kind="stable")
    hf_s = hf[order]
    for f in np.unique(gf[gs]):
        g = np.flatnonzero(gf == f)
        lo, up = np.searchsorted(hf_s, [f, f + 1])
        h = order[lo:up]
        if h.size == 0:
            continue
        d = np.abs(wrap_azimuth(ga[g][:, None] - ha[h][None, :]))
        r, k = linear_sum_assignment(np.where(d <= gate_deg, d, 1e6))
        ok = (d[r, k] <= gate_deg) & gs[g[r]]
        np.add.at(counts, (np.searchsorted(g_u, gi[g[r[ok]]]),
                           np.searchsorted(h_u, hi[h[k[ok]]])), 1)
    rows, cols = linear_sum_assignment(-counts)  # most frames matched while speaking
    return {int(g_u[r]): int(h_u[c]) for r, c in zip(rows, cols, strict=True) if counts[r, c] > 0}


def score_voices(
    references: dict[int, np.ndarray],
    mixture: np.ndarray,
    voices: dict[int, np.ndarray],
    identities: dict[int, int],
) -> list[VoiceScore]:
    """SI-SDR and SI-SDRi of each ground-truth person's matched voice.

    Parameters
    ----------
    references : dict ``{gt id: ndarray (n_samples,)}``
        Each person's image at the reference microphone (persons who never speak are skipped).
    mixture : ndarray (n_samples,)
        The reference microphone's signal.
    voices : dict ``{tracked id: ndarray (n_samples,)}``
    identities : dict ``{gt id: tracked id}`` (:func:`assign_identities`)

    Returns
    -------
    list of VoiceScore, by ground-truth id; a person without a matched voice has
    ``track=None`` and ``si_sdr=-inf``.
    """
    mix = np.asarray(mixture, dtype=float).reshape(-1)
    out = []
    for pid in sorted(references):
        ref = np.asarray(references[pid], dtype=float).reshape(-1)
        if not np.any(ref):
            continue
        if ref.size != mix.size:
            raise ValueError(f"reference of person {pid} has {ref.size} samples, the mixture "
                             f"{mix.size}")
        tid = identities.get(pid)
        if tid is not None and tid not in voices:
            raise ValueError(f"person {pid} is matched to track {tid}, which has no voice")
        if tid is None:
            s = float("-inf")
        else:
            v = np.asarray(voices[tid], dtype=float).reshape(-1)
            if v.size != ref.size:
                raise ValueError(f"voice {tid} has {v.size} samples, the reference {ref.size}")
            s = si_sdr(v, ref)
        out.append(VoiceScore(int(pid), tid, s, si_sdr(mix, ref)))
    return out
