"""How close simulated scenes are to real recordings of the same array: a table, real vs simulated.

The real recordings are the six ReSpeaker 4-mic files of the shared data
(``realaudio/respeaker/``: a free-field square of side 45.7 mm, 16 kHz, 1-3 talkers at 0.5 m in
the directions of the folder names). The simulated scenes put the same array
(``respeaker4.json``) in a shoebox room with the same number of talkers, 0.5 m away in the same
directions, for the same 5.6 s (:func:`scenario_for`), rendered twice: ``sim``, as the
simulator renders by default (ideal microphones, diffuse noise at 20 dB SNR), and
``sim+sensors``, with the scenario's ``sensors`` section (``--gain-mismatch``,
``--delay-mismatch``, ``--self-noise``: gain and delay mismatch, self-noise) and the diffuse noise
of ``--sensors-diffuse-snr`` (none by default). Each statistic is computed the same way on all:

(a) ``msc``: the magnitude-squared coherence ``|E X_i X_j^*|^2 / (E|X_i|^2 E|X_j|^2)`` between
    microphone pairs over the quietest 15 % of the frames (no talker), per frequency band,
    averaged over the pairs of one spacing (side 45.7 mm, diagonal 64.6 mm), next to the
    spherically isotropic (diffuse) model ``sinc^2(2 f d / c)`` (Cook et al., "Measurement of
    correlation coefficients in reverberant sound fields", JASA 27(6), 1955). Uncorrelated
    (self-) noise pulls it towards the estimator's floor ``~1 / n_frames``; a directional noise
    source pushes it towards 1.
(b) ``gain``: in the loudest 20 % of the frames of the one-talker files (``a180e20``), the
    level of each microphone (200-4000 Hz) relative to the mean over the microphones, after
    removing the direct path's ``1 / r`` difference for a talker at 0.5 m in the labelled
    direction; the root mean square over microphones in dB. ``delay``: the per-microphone
    delay (samples) that fits the inter-microphone phase residual ``arg(X_i X_j^* e^{j w (tau_i
    - tau_j)})`` (``tau`` the near-field direct-path delays) below 2 kHz, rms over microphones.
    ``phase spread``: the circular standard deviation ``sqrt(-2 ln R)`` of that residual over
    the time-frequency bins of a band (degrees), averaged over the pairs.
(c) ``snr``: ``10 log10((P90 - P10) / P10)`` of the frame energies (summed over the
    microphones, 100-7000 Hz): the loud frames' excess over the floor, relative to the floor.
(d) ``cdr``: the coherent-to-diffuse power ratio in the loudest 20 % of the one-talker frames
    from the complex coherence ``Gamma_x`` of the diagonal pairs, 1-4 kHz, with the known
    direct-path coherence ``Gamma_s = e^{j w (tau_j - tau_i)}`` and the diffuse model
    ``Gamma_n = sinc(2 f d / c)``: ``CDR = Re{(Gamma_n - Gamma_x) / (Gamma_x - Gamma_s)}``
    (Thiergart, Del Galdo & Habets, "Signal-to-reverberant ratio estimation based on the complex
    spatial coherence between omnidirectional microphones", ICASSP 2012, eq. 9), the median over
    bins in dB. It is a direct-to-reverberant ratio where the noise is negligible; noise counts
    as diffuse in it.

Run (one core, about a minute):

    OMP_NUM_THREADS=1 python benchmarks/bench_sim_vs_real.py
    OMP_NUM_THREADS=1 python benchmarks/bench_sim_vs_real.py --t60 0.5 --seeds 0 1 2 3 \
        --self-noise 12 --gain-mismatch 0.1 --no-baseline

The shared data (``../shared/data`` or ``AVTRACK_SHARED_DATA``) are needed.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # single-threaded BLAS / FFT before NumPy is imported

import argparse  # noqa: E402
import re  # noqa: E402
import sys  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import soundfile as sf  # noqa: E402

from avtrack.audio.arrays import SPEED_OF_SOUND, MicArray, direction_vectors, load_array  # noqa: E402
from avtrack.io.datasets import find_shared_data  # noqa: E402
from avtrack.io.scenario import validate_scenario  # noqa: E402
from avtrack.simulate.scene import simulate_scene  # noqa: E402

NFFT = 512  # 32 ms frames at 16 kHz
HOP = 256
QUIET_FRACTION = 0.15
LOUD_FRACTION = 0.20
TALKER_DISTANCE_M = 0.5
MSC_BANDS = ((100, 500), (500, 1000), (1000, 2000), (2000, 4000), (4000, 7000))
PHASE_BANDS = ((200, 1000), (1000, 2000), (2000, 4000))


@dataclass
class Recording:
    label: str
    audio: np.ndarray  # (n_mics, n_samples)
    fs: int
    directions: list[tuple[float, float]]  # (azimuth, elevation) degrees per talker


# --------------------------------------------------------------------------- statistics


def spectra(x: np.ndarray, fs: int) -> tuple[np.ndarray, np.ndarray]:
    """Hann STFT ``(n_mics, n_freqs, n_frames)`` of ``x (n_mics, n_samples)`` and its
    frequencies."""
    x = x - x.mean(axis=1, keepdims=True)
    n_frames = 1 + (x.shape[1] - NFFT) // HOP
    idx = np.arange(NFFT)[None, :] + HOP * np.arange(n_frames)[:, None]
    frames = x[:, idx] * np.hanning(NFFT)  # (M, T, N)
    spec = np.fft.rfft(frames, axis=2).transpose(0, 2, 1)
    return spec, np.fft.rfftfreq(NFFT, 1.0 / fs)


def frame_energy(spec: np.ndarray, f: np.ndarray) -> np.ndarray:
    """``(n_frames,)`` energy summed over microphones and 100-7000 Hz."""
    band = (f >= 100) & (f <= 7000)
    return np.sum(np.abs(spec[:, band, :]) ** 2, axis=(0, 1))


def pair_groups(positions: np.ndarray) -> dict[float, list[tuple[int, int]]]:
    """Microphone pairs grouped by spacing (rounded to 0.1 mm)."""
    groups: dict[float, list[tuple[int, int]]] = {}
    m = positions.shape[0]
    for i in range(m):
        for j in range(i + 1, m):
            d = round(float(np.linalg.norm(positions[i] - positions[j])), 4)
            groups.setdefault(d, []).append((i, j))
    return dict(sorted(groups.items()))


def noise_msc(spec: np.ndarray, f: np.ndarray, positions: np.ndarray) -> dict:
    """(a) MSC of the quietest frames per spacing and band, with the diffuse model."""
    e = frame_energy(spec, f)
    quiet = e <= np.quantile(e, QUIET_FRACTION)
    x = spec[:, :, quiet]
    out = {}
    for d, pairs in pair_groups(positions).items():
        rows = []
        for lo, hi in MSC_BANDS:
            band = (f >= lo) & (f < hi)
            msc = [
                np.abs(np.sum(x[i, band] * x[j, band].conj(), axis=1)) ** 2
                / (np.sum(np.abs(x[i, band]) ** 2, 1) * np.sum(np.abs(x[j, band]) ** 2, 1))
                for i, j in pairs
            ]
            # diffuse model Gamma = sinc(2 f d / c) (np.sinc(x) = sin(pi x) / (pi x))
            model = np.sinc(2 * f[band] * d / SPEED_OF_SOUND) ** 2
            rows.append((float(np.mean(msc)), float(np.mean(model))))
        out[d] = rows
    return out


def direct_delays(positions: np.ndarray, az: float, el: float) -> tuple[np.ndarray, np.ndarray]:
    """Near-field direct-path delays (s) and distances (m) from a talker at 0.5 m."""
    src = TALKER_DISTANCE_M * direction_vectors(np.array(az), np.array(el))
    r = np.linalg.norm(positions - positions.mean(axis=0) - src, axis=1)
    return r / SPEED_OF_SOUND, r


def direct_path_stats(spec: np.ndarray, f: np.ndarray, fs: int, positions: np.ndarray,
                      az: float, el: float) -> dict:
    """(b) gain mismatch, delay mismatch, phase spread; (d) CDR, in the loud frames."""
    e = frame_energy(spec, f)
    x = spec[:, :, e >= np.quantile(e, 1 - LOUD_FRACTION)]
    tau, r = direct_delays(positions, az, el)
    m = positions.shape[0]
    w = 2 * np.pi * f

    band = (f >= 200) & (f <= 4000)
    level = 10 * np.log10(np.mean(np.abs(x[:, band]) ** 2, axis=(1, 2)))
    level -= 20 * np.log10(r.mean() / r)  # remove the direct path's 1/r difference
    level -= level.mean()

    # residual phase of every pair: arg(X_i X_j^* e^{j w (tau_i - tau_j)})
    pairs = [(i, j) for i in range(m) for j in range(i + 1, m)]
    spread = np.zeros(len(PHASE_BANDS))
    rows, rhs = [], []
    low = (f >= 200) & (f <= 2000)
    for i, j in pairs:
        cross = x[i] * x[j].conj() * np.exp(1j * w * (tau[i] - tau[j]))[:, None]
        unit = cross / np.maximum(np.abs(cross), 1e-30)
        for b, (lo, hi) in enumerate(PHASE_BANDS):
            sel = (f >= lo) & (f < hi)
            big_r = np.abs(np.mean(unit[sel]))
            spread[b] += np.degrees(np.sqrt(-2 * np.log(big_r))) / len(pairs)
        # mean residual phase per bin -> delay: phi(f) = -w (d_i - d_j), least squares over f
        phi = np.angle(np.sum(cross[low], axis=1))
        delta = -np.sum(w[low] * phi) / np.sum(w[low] ** 2)  # seconds
        row = np.zeros(m)
        row[i], row[j] = 1.0, -1.0
        rows.append(row)
        rhs.append(delta)
    rows.append(np.ones(m))  # delays relative to their mean
    rhs.append(0.0)
    d_mic = np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)[0] * fs

    # (d) coherent-to-diffuse ratio of the largest-spacing pairs (Thiergart et al. 2012, eq. 9)
    groups = pair_groups(positions)
    d_max = max(groups)
    sel = (f >= 1000) & (f <= 4000)
    cdr = []
    for i, j in groups[d_max]:
        gx = np.sum(x[i, sel] * x[j, sel].conj(), 1) / np.sqrt(
            np.sum(np.abs(x[i, sel]) ** 2, 1) * np.sum(np.abs(x[j, sel]) ** 2, 1)
        )
        gs = np.exp(-1j * w[sel] * (tau[i] - tau[j]))  # X_i X_j^* of the direct path alone
        gn = np.sinc(2 * f[sel] * d_max / SPEED_OF_SOUND)
        cdr.append(np.real((gn - gx) / (gx - gs)))
    cdr_lin = max(float(np.median(np.concatenate(cdr))), 1e-3)
    return {
        "gain_db": level,
        "gain_rms_db": float(np.sqrt(np.mean(level**2))),
        "delay_samples": d_mic,
        "delay_rms_samples": float(np.sqrt(np.mean(d_mic**2))),
        "phase_spread_deg": spread,
        "cdr_db": 10 * np.log10(cdr_lin),
    }


def snr_percentiles(spec: np.ndarray, f: np.ndarray) -> float:
    """(c) ``10 log10((P90 - P10) / P10)`` of the frame energies."""
    p10, p90 = np.quantile(frame_energy(spec, f), [0.10, 0.90])
    return float(10 * np.log10(max(p90 - p10, 1e-30) / p10))


def measure(recs: list[Recording], positions: np.ndarray) -> dict:
    """Every statistic, averaged over the recordings (b, d: over the one-talker ones)."""
    msc, snr, single = [], [], []
    for rec in recs:
        spec, f = spectra(rec.audio, rec.fs)
        msc.append(noise_msc(spec, f, positions))
        snr.append(snr_percentiles(spec, f))
        if len(rec.directions) == 1:
            single.append(direct_path_stats(spec, f, rec.fs, positions, *rec.directions[0]))
    out: dict = {
        "msc": {d: np.mean([m[d] for m in msc], axis=0) for d in msc[0]},
        "snr_db": float(np.mean(snr)),
        "n": len(recs),
    }
    for key in ("gain_rms_db", "delay_rms_samples", "cdr_db"):
        out[key] = float(np.mean([s[key] for s in single]))
    out["phase_spread_deg"] = np.mean([s["phase_spread_deg"] for s in single], axis=0)
    out["gain_db"] = np.mean([s["gain_db"] for s in single], axis=0)
    out["delay_samples"] = np.mean([s["delay_samples"] for s in single], axis=0)
    return out


# --------------------------------------------------------------------------- data


def parse_directions(folder: str) -> list[tuple[float, float]]:
    """``a180e20_a225e35`` -> ``[(180, 20), (225, 35)]``."""
    return [(float(a), float(e)) for a, e in re.findall(r"a(\d+)e(\d+)", folder)]


def real_recordings(root: Path) -> list[Recording]:
    recs = []
    for wav in sorted(root.glob("*/50cm/*.wav")):
        x, fs = sf.read(wav, dtype="float64", always_2d=True)
        recs.append(Recording(wav.stem, x.T, int(fs), parse_directions(wav.parents[1].name)))
    return recs


def scenario_for(rec: Recording, array_path: Path, seed: int, t60: float,
                 diffuse_snr_db: float | None, sensors: dict | None) -> dict:
    """A scene like ``rec``: the same array and talker directions at 0.5 m, the same length."""
    centre = np.array([2.6, 2.2, 1.1])  # off the room's centre (no symmetric reflections)
    people = []
    for k, (az, el) in enumerate(rec.directions, start=1):
        pos = centre + TALKER_DISTANCE_M * direction_vectors(np.array(az), np.array(el))
        people.append({"id": k, "motion": {"type": "seated", "position": pos.tolist(),
                                           "sway": 0.0}})
    raw = {
        "name": f"like-{rec.label}",
        "duration": round(rec.audio.shape[1] / rec.fs, 3),
        "seed": seed,
        "fs": rec.fs,
        "room": {"dims": [6.0, 5.0, 3.0], "t60": t60},
        "array": {"name": str(array_path), "position": centre.tolist(), "yaw_deg": 0.0},
        "people": people,
        "speech": {"mode": "turn-taking", "utterances": "shared", "overlap_prob": 0.5},
        "noise": {"diffuse_snr_db": diffuse_snr_db, "fan_snr_db": None},
    }
    if sensors is not None:
        raw["sensors"] = sensors
    return validate_scenario(raw)


def simulated_recordings(recs: list[Recording], array_path: Path, seeds: list[int], t60: float,
                         diffuse_snr_db: float | None, sensors: dict | None) -> list[Recording]:
    out = []
    for rec in recs:
        for seed in seeds:
            sc = scenario_for(rec, array_path, seed, t60, diffuse_snr_db, sensors)
            scene = simulate_scene(sc)
            out.append(Recording(f"{rec.label}-s{seed}", scene.audio, scene.fs, rec.directions))
    return out


# --------------------------------------------------------------------------- report


def table(results: dict[str, dict], spacings: list[float]) -> str:
    names = list(results)
    lines = ["| statistic | " + " | ".join(names) + " |", "|---" * (len(names) + 1) + "|"]

    def row(label: str, values: list[str]) -> None:
        lines.append(f"| {label} | " + " | ".join(values) + " |")

    first = results[names[0]]
    for d in spacings:
        for b, (lo, hi) in enumerate(MSC_BANDS):
            model = first["msc"][d][b][1]
            row(f"(a) noise MSC d={1000 * d:.1f} mm {lo}-{hi} Hz (diffuse {model:.2f})",
                [f"{r['msc'][d][b][0]:.2f}" for r in results.values()])
    row("(b) gain mismatch rms, dB", [f"{r['gain_rms_db']:.2f}" for r in results.values()])
    row("(b) per-mic gain, dB",
        [" ".join(f"{g:+.2f}" for g in r["gain_db"]) for r in results.values()])
    row("(b) delay mismatch rms, samples",
        [f"{r['delay_rms_samples']:.3f}" for r in results.values()])
    row("(b) per-mic delay, samples",
        [" ".join(f"{g:+.3f}" for g in r["delay_samples"]) for r in results.values()])
    for b, (lo, hi) in enumerate(PHASE_BANDS):
        row(f"(b/d) phase residual spread {lo}-{hi} Hz, deg",
            [f"{r['phase_spread_deg'][b]:.1f}" for r in results.values()])
    row("(c) SNR (P90-P10)/P10, dB", [f"{r['snr_db']:.1f}" for r in results.values()])
    row("(d) CDR 1-4 kHz (diagonal pairs), dB", [f"{r['cdr_db']:.1f}" for r in results.values()])
    row("files", [str(r["n"]) for r in results.values()])
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    ap.add_argument("--t60", type=float, default=0.3, help="simulated room T60, s")
    ap.add_argument("--diffuse-snr", type=float, default=20.0,
                    help="simulated diffuse noise SNR, dB (the scenario default)")
    ap.add_argument("--real-only", action="store_true", help="measure the real files only")
    ap.add_argument("--no-baseline", action="store_true", help="leave out the 'sim' column")
    ap.add_argument("--gain-mismatch", type=float, default=0.0, metavar="DB",
                    help="sim+sensors: sensors.gain_mismatch_db")
    ap.add_argument("--delay-mismatch", type=float, default=0.0, metavar="SAMPLES",
                    help="sim+sensors: sensors.delay_mismatch_samples")
    ap.add_argument("--self-noise", type=float, default=14.0, metavar="DB",
                    help="sim+sensors: sensors.self_noise_snr_db")
    ap.add_argument("--sensors-diffuse-snr", type=float, default=None, metavar="DB",
                    help="sim+sensors: noise.diffuse_snr_db (default: no diffuse noise)")
    args = ap.parse_args(argv)
    sensors = {
        "gain_mismatch_db": args.gain_mismatch,
        "delay_mismatch_samples": args.delay_mismatch,
        "self_noise_snr_db": args.self_noise,
    }

    root = find_shared_data() / "realaudio" / "respeaker"
    array_path = root / "respeaker4.json"
    array: MicArray = load_array(array_path)
    recs = real_recordings(root)
    results = {"real": measure(recs, array.positions)}
    if not (args.real_only or args.no_baseline):
        sim = simulated_recordings(recs, array_path, args.seeds, args.t60, args.diffuse_snr,
                                   None)
        results["sim"] = measure(sim, array.positions)
    if not args.real_only:
        sim_s = simulated_recordings(recs, array_path, args.seeds, args.t60,
                                     args.sensors_diffuse_snr, sensors)
        results["sim+sensors"] = measure(sim_s, array.positions)
    print(f"# T60 {args.t60} s, seeds {args.seeds}; sim: diffuse noise {args.diffuse_snr} dB; "
          f"sim+sensors: diffuse noise {args.sensors_diffuse_snr} dB, sensors {sensors}")
    print(table(results, list(results["real"]["msc"])))
    return 0


if __name__ == "__main__":
    sys.exit(main())
