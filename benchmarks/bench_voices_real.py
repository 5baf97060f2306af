"""Voices on real microphone-array recordings: the level of each talker's direction.

On a real recording there is no clean reference of each talker, so SI-SDR cannot be computed
(``bench_voices.py`` scores it on simulated scenes). What can be measured is how much of each
talker a voice keeps and how much of the others it lets through. Every WAV of
``bench_real_audio.py``'s layout (folders named ``a{AZ}e{EL}_...`` for the talkers' known
directions, an array file above them; default ``../shared/data/realaudio``) is run as:

* ``track-audio --voices`` does (``voice``): the default localizer and Gaussian tracker
  (:class:`avtrack.stream.DOAStream`), then :func:`avtrack.audio.beamform.extract_voices` on
  :func:`~avtrack.audio.beamform.tracks_from_doa`: MVDR steered at the track, silent outside its
  turns. A track stands for the talker within 20 degrees of its mean direction (nearest first).
* the same MVDR at the talker's **known** direction with no gating (``mvdr``): its weights from
  the frames where the talker is not heard; and delay-and-sum at that direction (``ds``: MVDR
  weights with a white noise covariance), the spatial filters alone.

Who talks when is read from PRP-REM's peaks (0.0-1.1 degrees from the talkers on these files,
``bench_real_audio.py``): an 8 ms frame is *talker k's* when PRP-REM has a peak within 10
degrees of k at least three times as high as any peak near another talker (talkers overlap
much on the multi-talker files), *quiet* when it has no peak. For each output and each talker
j: the output's energy over j's frames over microphone 0's energy on the same samples, in dB
(microphone 0: 0 dB for everyone). A good voice of talker k keeps k near 0 dB and puts the others
(``others``: their energy pooled) and the quiet frames far below. ``sel``: own level minus the
others' level, the voice's selectivity in dB (0 for microphone 0).

Usage::

    python benchmarks/bench_voices_real.py
    python benchmarks/bench_voices_real.py --root DIR --markdown voices_real.md
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import datetime as dt  # noqa: E402
import platform  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import scipy.ndimage  # noqa: E402
import scipy.signal  # noqa: E402

from avtrack.audio.arrays import MicArray  # noqa: E402
from avtrack.audio.beamform import (  # noqa: E402
    BeamformerConfig,
    extract_voices,
    mvdr_weights,
    steering_vectors,
    tracks_from_doa,
)
from avtrack.audio.recording import FS  # noqa: E402
from avtrack.audio.stft import FRAME_HOP_S as HOP_S  # noqa: E402
from avtrack.doa.base import frames_to_table  # noqa: E402
from avtrack.localize import make_localizer, peak_table  # noqa: E402
from avtrack.stream.audio import DOAStream  # noqa: E402
from bench_real_audio import (  # noqa: E402
    DEFAULT_ROOT,
    Recording,
    angle_error,
    circular_mean_deg,
    find_recordings,
    match_talkers,
)

LABEL_GATE_DEG = 10.0  # a PRP-REM peak this close to a talker says the talker is heard
FLOOR_DB = -60.0  # levels below this are written as this (a gated voice is exactly zero)
DOMINANCE = 3.0  # a talker dominates a frame when its peak is this many times the others'
MIN_SOLO_S = 0.5  # a talker dominating fewer seconds is too little to measure a level on


def solo_masks(rec: Recording, array: MicArray,
               x: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray], np.ndarray]:
    """Per talker, the samples of the 8 ms frames where that talker dominates PRP-REM's
    peaks (``DOMINANCE``), and where PRP-REM hears that talker at all; the samples of the
    frames where it hears nobody."""
    loc = make_localizer("prp-rem", array)
    heat = loc.run(x)
    table = peak_table(heat, loc.grid, loc.peak_threshold, reduce=loc.profile_reduce)
    weight = np.zeros((len(rec.talkers), len(heat)))  # each talker's strongest peak
    row = {int(f): i for i, f in enumerate(heat.frames)}
    for k, (az, _el) in enumerate(rec.talkers):
        near = angle_error(table.azimuth_deg, az) <= LABEL_GATE_DEG
        np.maximum.at(weight[k], [row[int(f)] for f in table.frames[near]], table.weight[near])
    heard = weight > 0
    any_peak = np.zeros(len(heat), dtype=bool)
    any_peak[[row[int(f)] for f in table.frames]] = True
    half = round(HOP_S * FS / 2)
    centre = np.round(np.asarray(heat.time_s) * FS).astype(int)

    def to_samples(frames: np.ndarray) -> np.ndarray:
        mask = np.zeros(x.shape[1], dtype=bool)
        for c in centre[frames]:
            mask[max(c - half, 0): c + half] = True
        return mask

    others = np.array([np.max(np.delete(weight, k, axis=0), axis=0, initial=0.0)
                       for k in range(len(rec.talkers))])
    alone = heard & (weight >= DOMINANCE * others)
    return ([to_samples(alone[k]) for k in range(len(rec.talkers))],
            [to_samples(heard[k]) for k in range(len(rec.talkers))], to_samples(~any_peak))


def level_db(y: np.ndarray, ref: np.ndarray, mask: np.ndarray) -> float:
    """Energy of ``y`` over ``ref``'s on the samples of ``mask``, dB (nan on under
    ``MIN_SOLO_S`` seconds of samples)."""
    if mask.sum() < MIN_SOLO_S * FS:
        return float("nan")
    num, den = float(np.sum(y[mask] ** 2)), float(np.sum(ref[mask] ** 2))
    return max(10 * np.log10(max(num, 1e-30) / max(den, 1e-30)), FLOOR_DB)


def fixed_beams(array: MicArray, x: np.ndarray, direction: tuple[float, float],
                noise: np.ndarray, cfg: BeamformerConfig,
                others: list[tuple[float, float]]) -> list[tuple[np.ndarray, float]]:
    """MVDR (noise covariance over the samples of ``noise``) and delay-and-sum, both steered at
    a fixed ``(azimuth, elevation)`` for the whole recording. Each: its output
    ``(n_samples,)``, as microphone 0 would hear the steered source, and its plane-wave gain
    towards the ``others`` directions, dB: ``|w_f^H d_f|^2`` averaged over the other
    directions and over frequency weighted by microphone 0's power spectrum (nan with no
    other direction)."""
    kw = {"fs": FS, "window": "hann", "nperseg": cfg.win_len, "noverlap": cfg.win_len - cfg.hop}
    freqs, times, spec = scipy.signal.stft(x, **kw)  # (M, F, T)
    xx = np.moveaxis(spec, 0, -1)  # (F, T, M)
    at = np.clip(np.round(times * FS).astype(int), 0, x.shape[1] - 1)
    quiet = noise[at]
    cov = np.einsum("ftm,ftn->fmn", xx[:, quiet], xx[:, quiet].conj()) / max(quiet.sum(), 1)
    d = steering_vectors(array, np.array([direction[0]]), np.array([direction[1]]), freqs)[0]
    power = np.mean(np.abs(xx[:, :, 0]) ** 2, axis=1)  # (F,)
    d_others = steering_vectors(array, np.array([o[0] for o in others]),
                                np.array([o[1] for o in others]), freqs)  # (J, F, M)
    out = []
    for w in (mvdr_weights(cov, d, cfg.loading),
              mvdr_weights(np.broadcast_to(np.eye(array.n_mics), cov.shape), d, 0.0)):
        y = np.einsum("fm,ftm->ft", w.conj(), xx)
        gain = np.abs(np.einsum("fm,jfm->jf", w.conj(), d_others)) ** 2  # (J, F)
        beam = (10 * np.log10(np.mean(gain @ power) / power.sum()) if others
                else float("nan"))
        out.append((scipy.signal.istft(y, **kw)[1][: x.shape[1]], beam))
    return out


def tracked_voices(rec: Recording, array: MicArray, x: np.ndarray,
                   cfg: BeamformerConfig) -> dict[int, np.ndarray]:
    """``track-audio --voices`` at its defaults: talker index -> the voice of its track."""
    stream = DOAStream(array)
    outs = stream.push(x)
    frames = np.array([o.frame for o in outs], dtype=np.int64)
    table = frames_to_table([o.tracks for o in outs], frames,
                            np.array([o.time_s for o in outs], dtype=float))
    tracks = [t for t in tracks_from_doa(table, stream.step * HOP_S) if t.turns.size]
    voices = extract_voices(x, FS, array, tracks, cfg)
    means = {}
    for t in tracks:
        on = np.zeros(t.time_s.shape, dtype=bool)
        for start, end in t.turns:
            on |= (t.time_s >= start) & (t.time_s < end)
        means[t.id] = circular_mean_deg(t.azimuth_deg[on])
    out = {k: voices[i] for k, (i, _err) in match_talkers(rec.talkers, means).items()}
    return out


def score_file(rec: Recording, cfg: BeamformerConfig) -> list[dict]:
    array, x = rec.load()
    solo, heard, quiet = solo_masks(rec, array, x)
    voices = tracked_voices(rec, array, x, cfg)
    rows = []
    for k, direction in enumerate(rec.talkers):
        others = np.zeros(x.shape[1], dtype=bool)
        for j in range(len(rec.talkers)):
            if j != k:
                others |= solo[j]
        (mvdr, mvdr_beam), (ds, ds_beam) = fixed_beams(
            array, x, direction, ~_widen(heard[k]), cfg,
            [d for j, d in enumerate(rec.talkers) if j != k])
        outputs = {"mvdr": mvdr, "ds": ds}
        beams = {"mvdr": mvdr_beam, "ds": ds_beam}
        if k in voices:
            outputs["voice"] = voices[k]
        for name, y in outputs.items():
            own = level_db(y, x[0], solo[k])
            oth = level_db(y, x[0], others)
            rows.append({"file": rec.label, "talker": f"{direction[0]:.0f}", "output": name,
                         "solo_s": solo[k].sum() / FS, "own": own, "others": oth,
                         "quiet": level_db(y, x[0], quiet), "sel": own - oth,
                         "beam": beams.get(name, float("nan"))})
        if k not in voices:
            rows.append({"file": rec.label, "talker": f"{direction[0]:.0f}", "output": "voice",
                         "solo_s": solo[k].sum() / FS, "own": float("nan"),
                         "others": float("nan"), "quiet": float("nan"), "sel": float("nan"),
                         "beam": float("nan")})
    return rows


def _widen(mask: np.ndarray, seconds: float = 0.3) -> np.ndarray:
    """``mask`` grown by ``seconds`` each side (turns start before and end after the frames
    PRP-REM hears)."""
    n = int(seconds * FS)
    return scipy.ndimage.maximum_filter1d(mask.astype(np.uint8), size=2 * n + 1) > 0


def _median(rows: list[dict], key: str) -> str:
    vals = [r[key] for r in rows if np.isfinite(r[key])]
    return f"{np.median(vals):.1f} ({len(vals)})" if vals else ""


def fmt(v: float) -> str:
    return "" if not np.isfinite(v) else f"{v:.1f}"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--root", type=Path, default=DEFAULT_ROOT)
    p.add_argument("--markdown", type=Path, help="also write the tables to this file")
    p.add_argument("--loading", type=float, default=BeamformerConfig.loading,
                   help="the MVDR's diagonal loading, a fraction of the mean noise power "
                        "(default %(default)s, BeamformerConfig's)")
    args = p.parse_args(argv)
    cfg = BeamformerConfig(loading=args.loading)
    recs = find_recordings(args.root)
    if not recs:
        p.error(f"no recordings with known talkers under {args.root}")
    rows = [r for rec in recs for r in score_file(rec, cfg)]
    head = "| file | talker | own s | output | own dB | others dB | quiet dB | sel dB | beam dB |"
    lines = [f"Real recordings: {len(recs)} files under {args.root}; "
             f"{dt.datetime.now():%Y-%m-%d %H:%M}, {platform.machine()}, one BLAS thread; MVDR "
             f"loading {cfg.loading:g}. A level on under {MIN_SOLO_S} s of a talker's "
             f"frames is left blank.", "",
             head,
             "|---|---:|---:|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['file']} | {r['talker']} | {r['solo_s']:.2f} | {r['output']} | "
                     f"{fmt(r['own'])} | {fmt(r['others'])} | {fmt(r['quiet'])} | "
                     f"{fmt(r['sel'])} | {fmt(r['beam'])} |")
    lines += ["", "Medians over the talkers where each level is measured (count beside; a "
              "gated voice reads -60 dB):", "",
              "| output | own dB | others dB | quiet dB | sel dB | beam dB |",
              "|---|---:|---:|---:|---:|---:|"]
    for name in ("voice", "mvdr", "ds"):
        mine = [r for r in rows if r["output"] == name]
        lines.append(f"| {name} | " + " | ".join(
            _median(mine, key) for key in ("own", "others", "quiet", "sel", "beam")) + " |")
    text = "\n".join(lines)
    print(text)
    if args.markdown is not None:
        args.markdown.write_text(text + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
