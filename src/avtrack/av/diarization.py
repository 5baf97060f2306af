r"""Speaker diarization: who speaks when, from the tracker's audio assignments (thesis §4.6.3).

VAVIT (eq. 4.34): person ``n`` speaks at frame ``t`` when the audio mass assigned to them,
averaged over the :math:`K_t` active sub-bands, reaches a threshold :math:`\gamma`,

.. math::
    \chi_{tn} = \mathbb{1}\Big[\frac{1}{K_t}\sum_{k=1}^{K_t}\sum_{r=1}^R \beta_{tknr}
        \ge \gamma\Big]                                                \quad\text{(eq. 4.34)}

(no speech when :math:`K_t = 0`). :func:`speaking_segments` turns the per-frame decisions of
every track into RTTM speaker turns; as the thesis has no diarization dynamics, the only
smoothing is optional: gaps shorter than ``max_gap`` seconds are bridged and turns shorter than
``min_duration`` are dropped.

:func:`audio_only_diarization` is the audio-only baseline of the DER table (thesis Table 4.5
compares with an audio-only toolkit): it has the same voice activity detection and audio
features but no vision: each speech frame is localised in the image by the GLLiM inverse map of
its sub-bands (the product of their Gaussian posteriors), and the localisations, smoothed over
consecutive speech frames, are clustered (average linkage, distance threshold) into speakers.

:func:`unseen_speakers` extends VAVIT's diarization the same way for the speech no tracked
person claims: in the partial field of view, people who never entered the camera's view are
never tracked (births are visual, thesis §4.6.2), so their speech goes to the audio clutter
class; clustering those frames' localisations names them ``U1, U2, ...``.
"""

from __future__ import annotations

import numpy as np
from scipy.cluster.hierarchy import fcluster, linkage

from avtrack.av.features import AudioFeatures
from avtrack.av.gllim import AudioImageMapping
from avtrack.io.rttm import RTTMSegment


def speaking_status(share: np.ndarray, n_bands: np.ndarray | int, gamma: float) -> np.ndarray:
    r"""Eq. 4.34.

    Parameters
    ----------
    share : ndarray (T, N) or (N,)
        :math:`\frac{1}{K_t}\sum_k\sum_r\beta_{tknr}` per frame and person.
    n_bands : ndarray (T,) or int
        :math:`K_t`; frames with none are silent.
    gamma : float
        Threshold :math:`\gamma \in (0, 1]`.

    Returns
    -------
    ndarray bool, the shape of ``share``
    """
    if not (0 < gamma <= 1):
        raise ValueError(f"gamma must be in (0, 1], got {gamma!r}")
    share = np.asarray(share, dtype=float)
    k = np.asarray(n_bands)
    if share.ndim == 2:
        k = k.reshape(-1, 1)
    return (share >= gamma) & (k > 0)  # χ_tn, eq. 4.34


def speaking_segments(
    frames: np.ndarray,
    ids: np.ndarray,
    speaking: np.ndarray,
    fps: float,
    file_id: str = "audio",
    max_gap: float = 0.0,
    min_duration: float = 0.0,
    label: str = "P{}",
) -> list[RTTMSegment]:
    """RTTM speaker turns from per-frame speaking decisions of tracks.

    Parameters
    ----------
    frames : ndarray (K,) int
        1-based video frame of each row (frame ``f`` covers
        ``[(f - 1.5) / fps, (f - 0.5) / fps)``, centred on its time ``(f - 1) / fps``).
    ids : ndarray (K,) int
        Track id of each row.
    speaking : ndarray (K,) bool
        :math:`\\chi_{tn}` of each row.
    fps : float
    file_id : str
        RTTM file id.
    max_gap, min_duration : float
        Seconds; bridge shorter gaps, then drop shorter turns (0: none).
    label : str
        Speaker label format, filled with the track id.

    Returns
    -------
    list of RTTMSegment, sorted by start time
    """
    frames = np.asarray(frames, dtype=np.int64).reshape(-1)
    ids = np.asarray(ids, dtype=np.int64).reshape(-1)
    speaking = np.asarray(speaking, dtype=bool).reshape(-1)
    if not (frames.shape == ids.shape == speaking.shape):
        raise ValueError(
            f"frames, ids and speaking must have the same length, got {frames.shape}, "
            f"{ids.shape}, {speaking.shape}"
        )
    if not fps > 0:
        raise ValueError(f"fps must be > 0, got {fps!r}")
    if max_gap < 0 or min_duration < 0:
        raise ValueError("max_gap and min_duration must be >= 0")
    out: list[RTTMSegment] = []
    dt = 1.0 / fps
    for tid in np.unique(ids[speaking]):
        f = np.unique(frames[(ids == tid) & speaking])
        starts = np.maximum((f - 1.5) * dt, 0.0)
        ends = (f - 0.5) * dt
        turns: list[list[float]] = []
        for s, e in zip(starts.tolist(), ends.tolist(), strict=True):
            if turns and s - turns[-1][1] <= max_gap + 1e-9:
                turns[-1][1] = e
            else:
                turns.append([s, e])
        for s, e in turns:
            if e - s >= max(min_duration, 1e-3):
                out.append(RTTMSegment(file_id, s, e - s, label.format(int(tid))))
    out.sort(key=lambda s: (s.start, s.speaker))
    return out


def localize_frames(features: AudioFeatures, mapping: AudioImageMapping) -> np.ndarray:
    r"""Image position of the sound in each frame, ``(T, P)`` (NaN without active bands;
    ``P`` the mapping's position dimension).

    The product over active sub-bands of the Gaussian moment-matched GLLiM inverse posteriors
    :math:`p(x | g_{tk})` (:meth:`~avtrack.av.gllim.GLLiM.inverse`): information-weighted
    mean of the per-band means.
    """
    if features.n_bands != mapping.n_bands or features.feature_dim != mapping.feature_dim:
        raise ValueError(
            f"features (K={features.n_bands}, D={features.feature_dim}) do not match the "
            f"mapping (K={mapping.n_bands}, D={mapping.feature_dim})"
        )
    t_, p = len(features), int(mapping.nu.shape[2])
    info = np.zeros((t_, p, p))
    vec = np.zeros((t_, p))
    for k in range(mapping.n_bands):
        rows = np.flatnonzero(features.active[:, k])
        if rows.size == 0:
            continue
        mean, _, cov = mapping.model(k).inverse(features.features[rows, k])
        prec = np.linalg.inv(cov)
        info[rows] += prec
        vec[rows] += np.einsum("tij,tj->ti", prec, mean)
    out = np.full((t_, p), np.nan)
    have = features.active.any(axis=1)
    out[have] = np.linalg.solve(info[have], vec[have][:, :, None])[:, :, 0]
    return out


def audio_only_diarization(
    features: AudioFeatures,
    mapping: AudioImageMapping,
    fps: float,
    distance_px: float = 200.0,
    smooth_frames: int = 11,
    min_cluster_s: float = 1.0,
    file_id: str = "audio",
    max_gap: float = 0.0,
    min_duration: float = 0.0,
    frames: np.ndarray | None = None,
    label: str = "A{}",
) -> list[RTTMSegment]:
    """Audio-only baseline: VAD, GLLiM localisation, clustering of the positions.

    Parameters
    ----------
    features : AudioFeatures
        Audio observations of the recording (speech frames: ``vad`` with active bands).
    mapping : AudioImageMapping
    fps : float
        Video (feature) frame rate.
    distance_px : float
        Average-linkage distance threshold between speakers, pixels (the baseline's settings
        were chosen on a development suite, as VAVIT's).
    smooth_frames : int
        Localisations are averaged over this many consecutive speech frames before clustering
        (odd, >= 1).
    min_cluster_s : float
        Clusters with less speech than this are merged into the nearest larger one.
    file_id, max_gap, min_duration
        As in :func:`speaking_segments`.
    frames : ndarray (T,) bool, optional
        Only these frames (default: all speech frames).
    label : str
        Speaker label format, filled with the cluster number.

    Returns
    -------
    list of RTTMSegment (speakers ``A1, A2, ...``)
    """
    if smooth_frames < 1 or smooth_frames % 2 == 0:
        raise ValueError(f"smooth_frames must be odd and >= 1, got {smooth_frames!r}")
    pos = localize_frames(features, mapping)
    use = features.vad & np.isfinite(pos[:, 0])
    if frames is not None:
        use &= np.asarray(frames, dtype=bool).reshape(len(features))
    speech = np.flatnonzero(use)
    if speech.size == 0:
        return []
    pts = pos[speech]
    if smooth_frames > 1 and speech.size >= smooth_frames:  # running mean over speech frames
        pad = smooth_frames // 2
        padded = np.pad(pts, ((pad, pad), (0, 0)), mode="edge")
        kernel = np.ones(smooth_frames) / smooth_frames
        pts = np.column_stack(
            [np.convolve(padded[:, j], kernel, mode="valid") for j in range(pts.shape[1])]
        )
    if speech.size == 1:
        labels = np.ones(1, dtype=int)
    else:
        labels = fcluster(linkage(pts, method="average"), t=distance_px, criterion="distance")
    # merge small clusters into the nearest large one
    min_frames = max(1, round(min_cluster_s * fps))
    uniq, counts = np.unique(labels, return_counts=True)
    big = uniq[counts >= min_frames]
    if big.size == 0:
        big = uniq[[int(np.argmax(counts))]]
    centres = np.array([pts[labels == c].mean(axis=0) for c in big])
    small = ~np.isin(labels, big)
    if np.any(small):
        nearest = np.argmin(((pts[small][:, None] - centres[None]) ** 2).sum(-1), axis=1)
        labels[small] = big[nearest]
    return speaking_segments(
        speech + 1,
        labels,
        np.ones(speech.size, bool),
        fps,
        file_id,
        max_gap,
        min_duration,
        label=label,
    )


def unseen_speakers(
    features: AudioFeatures,
    mapping: AudioImageMapping,
    fps: float,
    claimed: np.ndarray,
    file_id: str = "audio",
    max_gap: float = 0.0,
    min_duration: float = 0.0,
    **kwargs,
) -> list[RTTMSegment]:
    """Speaker turns of the speech frames in which no tracked person speaks.

    Parameters
    ----------
    features : AudioFeatures
    mapping : AudioImageMapping
    fps : float
    claimed : ndarray (T,) bool
        Frames where some tracked person speaks (eq. 4.34).
    file_id, max_gap, min_duration, **kwargs
        As in :func:`audio_only_diarization`.

    Returns
    -------
    list of RTTMSegment (speakers ``U1, U2, ...``)
    """
    claimed = np.asarray(claimed, dtype=bool).reshape(len(features))
    return audio_only_diarization(
        features,
        mapping,
        fps,
        file_id=file_id,
        max_gap=max_gap,
        min_duration=min_duration,
        frames=~claimed,
        label="U{}",
        **kwargs,
    )
