"""VAVIT vs the visual-only tracker on simulated AVDIAR-like meetings (Ban et al.,
"Variational Bayesian inference for audio-visual tracking of multiple speakers", Tables I-V).

The suite: seeded AVDIAR-like recordings (:func:`avdiar_like`) in two rooms, a *living room*
(7 x 6 x 3 m, T60 0.5 s) and a *meeting room* (5.5 x 4.5 x 2.8 m, T60 0.35 s), with 1-4
people at 1.8-3.4 m from a binaural dummy head (KEMAR HRTFs) and a 97-degree 1920x1200 camera
(AVDIAR's), taking speech turns; some sit, some walk from the centre of the image to its side
and back. One white-noise loudspeaker calibration set is simulated per room
(:func:`avtrack.simulate.calibration.simulate_calibration`, as AVDIAR's T1 / T2) and a GLLiM
mapping
trained on it (:func:`avtrack.simulate.calibration.train_mapping`).

Every scene is tracked by the visual-only tracker (OVBT, ``use_audio=False``), by VAVIT and, as
an ablation, by VAVIT with its audio observations removed (its field-of-view-aware target
management alone), in the two configurations of thesis §4.7.4: full camera field of view (FFOV)
and partial field of view (PFOV: only the central 40 % of the image width is seen, detections
elsewhere are dropped; the audio covers everything). Scores as in thesis §4.7.5: CLEAR-MOT with
an overlap threshold of 0.1, and, in PFOV, ground truth in the blind strips matched with "the
expected localisation accuracy relaxed by a factor of two" (both boxes scaled x2 about their
centres); FP and FN in % of the ground truth, IDs and FM counts, MT / ML in % of the people;
per room, components summed over its scenes. Diarization (Table V): DER (NIST, collar 0.25 s,
optimal speaker mapping, :mod:`avtrack.metrics.der`) of VAVIT (FFOV and PFOV) and of the audio-
only baseline (:func:`avtrack.av.diarization.audio_only_diarization`), per scene and overall.
In PFOV, VAVIT's speech that no tracked person claims (people who never entered the camera's
view, whom the visual birth process cannot create) is clustered as in the baseline
(``unseen_speakers``); the last column leaves those turns out (eq. 4.34 alone).

VAVIT's run-time constants (``sigma_scale``, ``audio_information_scale``,
``coast_velocity_decay``, the diarization threshold) and the baseline's clustering threshold
were chosen on a separate development suite (the same generator, seeds 101-106), not on these
scenes.

Speed: VAVIT (features included) and the visual-only tracker on a 4-microphone (nao4) scene,
BLAS on one thread; real-time factor = processing time / scene duration, and VAVIT's time as
a ratio to the visual-only tracker's.

Usage::

    python benchmarks/bench_vavit.py                          # everything, text tables
    python benchmarks/bench_vavit.py --markdown out.md        # also write Markdown tables
    python benchmarks/bench_vavit.py --work /tmp/vavit-bench  # keep scenes / mappings there
    python benchmarks/bench_vavit.py --no-speed
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, before NumPy loads BLAS

import argparse  # noqa: E402
import contextlib  # noqa: E402
import dataclasses  # noqa: E402
import platform  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from avtrack.av.diarization import audio_only_diarization  # noqa: E402
from avtrack.av.features import (  # noqa: E402
    AudioFeatureConfig,
    extract_audio_features,
)
from avtrack.av.gllim import AudioImageMapping, load_mapping, save_mapping  # noqa: E402
from avtrack.av.vavit import (  # noqa: E402
    VAVITConfig,
    fov_strip,
    load_scene,
    track_scene,
)
from avtrack.io.base import atomic_write  # noqa: E402
from avtrack.io.mot import MOTData, read_mot  # noqa: E402
from avtrack.io.rttm import read_rttm  # noqa: E402
from avtrack.io.scenario import validate_scenario  # noqa: E402
from avtrack.metrics.der import DERComponents, diarization_error_rate  # noqa: E402
from avtrack.metrics.mot import box_iou, evaluate_mot  # noqa: E402
from avtrack.simulate.calibration import scene_setup, simulate_calibration, train_mapping  # noqa: E402
from avtrack.simulate.scene import simulate_scene, write_scene  # noqa: E402

#: The two AVDIAR-like rooms: dims (m), T60 (s), array (dummy head) position.
ROOMS = {
    "living-room": {"dims": [7.0, 6.0, 3.0], "t60": 0.5, "array": [3.5, 0.5, 1.3]},
    "meeting-room": {"dims": [5.5, 4.5, 2.8], "t60": 0.35, "array": [2.75, 0.5, 1.3]},
}
HFOV_DEG = 97.0
IMAGE = (1920, 1200)
PFOV_FRACTION = 0.4
#: (name, room, seed, number of people) of the fixed suite.
SUITE = (
    ("L1-1P", "living-room", 1, 1),
    ("L2-3P", "living-room", 2, 3),
    ("L3-4P", "living-room", 3, 4),
    ("L4-2P", "living-room", 4, 2),
    ("M1-2P", "meeting-room", 5, 2),
    ("M2-3P", "meeting-room", 6, 3),
    ("M3-4P", "meeting-room", 7, 4),
    ("M4-1P", "meeting-room", 8, 1),
)
DURATION_S = 30.0
#: rows of Tables I-IV: (name, use_audio, features); "muted": VAVIT's target management with
#: no audio observation (an ablation: what the audio itself brings)
METHODS = (
    ("visual-only (OVBT)", False, "audio"),
    ("VAVIT", True, "audio"),
    ("VAVIT, no audio obs. (ablation)", True, "muted"),
)


def _place(array: list[float], az_deg: float, dist: float, height: float) -> list[float]:
    """Room point at azimuth ``az_deg`` (0: straight ahead, +: left) and distance ``dist``
    from a dummy head looking along +y."""
    ang = np.deg2rad(90.0 + az_deg)
    return [array[0] + dist * np.cos(ang), array[1] + dist * np.sin(ang), height]


def avdiar_like(room: str, seed: int, n_people: int, duration: float = DURATION_S) -> dict:
    """A raw AVDIAR-like scenario: ``n_people`` in ``room``, seeded.

    Person 1 walks from near the image centre to one side of the image (beyond the central
    40 %), stays and talks, and walks back; the others either sit (anywhere in the image) or do
    the same walk at another time.
    """
    spec = ROOMS[room]
    rng = np.random.default_rng([seed, 1003])
    arr = spec["array"]
    half = HFOV_DEG / 2
    strip = np.rad2deg(np.arctan(PFOV_FRACTION * np.tan(np.deg2rad(half))))
    people = []
    used: list[float] = []

    def free_azimuth(lo: float, hi: float) -> float:
        for _ in range(200):
            az = float(rng.uniform(lo, hi) * rng.choice([-1, 1]))
            if all(abs(az - u) >= 12.0 for u in used):
                used.append(az)
                return az
        az = float(rng.uniform(lo, hi))
        used.append(az)
        return az

    for pid in range(1, n_people + 1):
        walker = pid == 1 or rng.random() < 0.35
        dist = float(rng.uniform(1.8, 3.4 if room == "living-room" else 3.0))
        if walker:
            home_az = free_azimuth(0.0, strip - 6.0)
            side = 1.0 if home_az >= 0 else -1.0
            out_az = side * float(rng.uniform(strip + 8.0, half - 8.0))
            home = _place(arr, home_az, dist, 1.65)
            away = _place(arr, out_az, dist * float(rng.uniform(0.9, 1.1)), 1.65)
            walk = float(np.linalg.norm(np.subtract(away, home)) / rng.uniform(0.5, 0.8))
            t_leave = float(rng.uniform(0.1, 0.4) * duration)
            t_out = t_leave + walk
            t_back = t_out + float(rng.uniform(0.2, 0.35) * duration)
            t_home = t_back + walk
            wps = [
                [0.0, *home],
                [t_leave, *home],
                [t_out, *away],
                [t_back, *away],
                [t_home, *home],
            ]
            if t_home < duration:
                wps.append([duration, *home])
            motion = {"type": "waypoints", "waypoints": wps}
        else:
            az = free_azimuth(0.0, half - 6.0)
            motion = {"type": "seated", "position": _place(arr, az, dist, 1.2), "sway": 0.03}
        people.append({"id": pid, "motion": _round(motion)})
    return {
        "name": f"avdiar-like-{room}",
        "duration": duration,
        "seed": seed,
        "room": {"dims": spec["dims"], "t60": spec["t60"]},
        "array": {"name": "kemar", "position": arr, "yaw_deg": 90.0},
        "camera": {"hfov_deg": HFOV_DEG, "width": IMAGE[0], "height": IMAGE[1]},
        "people": people,
        "speech": {"mode": "turn-taking", "mean_turn": 2.5, "overlap_prob": 0.15},
        "noise": {"diffuse_snr_db": 20.0, "fan_snr_db": None},
        "detector": {"miss_rate": 0.1, "false_alarm_rate": 0.2},
    }


def _round(value):
    if isinstance(value, dict):
        return {k: _round(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_round(v) for v in value]
    if isinstance(value, float | np.floating):
        return round(float(value), 4)
    return value


# --------------------------------------------------------------------------- scoring


@dataclass
class Counts:
    """CLEAR-MOT components summed over scenes."""

    gt: int = 0
    fp: int = 0
    fn: int = 0
    ids: int = 0
    fm: int = 0
    mt: int = 0
    ml: int = 0
    n_tracks: int = 0

    def add(self, other: Counts) -> None:
        for k in self.__dataclass_fields__:
            setattr(self, k, getattr(self, k) + getattr(other, k))

    def row(self) -> dict[str, float]:
        g = max(self.gt, 1)
        return {
            "MOTA": 100.0 * (1 - (self.fp + self.fn + self.ids) / g),  # eq. 4.35
            "FP": 100.0 * self.fp / g,
            "FN": 100.0 * self.fn / g,
            "IDs": self.ids,
            "FM": self.fm,
            "MT": 100.0 * self.mt / max(self.n_tracks, 1),
            "ML": 100.0 * self.ml / max(self.n_tracks, 1),
        }


def _scaled(boxes: np.ndarray, factor: float) -> np.ndarray:
    """``(K, 4)`` ltwh boxes scaled by ``factor`` about their centres."""
    c = boxes[:, :2] + 0.5 * boxes[:, 2:]
    wh = boxes[:, 2:] * factor
    return np.column_stack([c - 0.5 * wh, wh])


def clear_counts(
    gt: MOTData,
    res: MOTData,
    n_frames: int,
    blind: tuple[float, float] | None = None,
    threshold: float = 0.1,
    relax: float = 2.0,
) -> Counts:
    """CLEAR-MOT (TrackEval, via :func:`avtrack.metrics.mot.evaluate_mot`) with overlap
    threshold ``threshold`` (thesis §4.7.5: 0.1).

    Ground-truth boxes whose centre lies outside the visible columns ``blind = (lo, hi)`` are
    matched with both boxes scaled by ``relax`` about their centres (the thesis relaxes the
    localisation accuracy of audio-only tracking by a factor of two).
    """

    def similarity(gb: np.ndarray, rb: np.ndarray) -> np.ndarray:
        sim = box_iou(gb, rb)
        if blind is not None and len(gb) and len(rb):
            cx = gb[:, 0] + 0.5 * gb[:, 2]
            out = (cx < blind[0]) | (cx > blind[1])
            if np.any(out):
                sim[out] = box_iou(_scaled(gb[out], relax), _scaled(rb, relax))
        return sim

    s = evaluate_mot(gt, res, n_frames=n_frames, threshold=threshold, similarity=similarity)
    return Counts(s.n_gt_dets, s.FP, s.FN, s.IDSW, s.Frag, s.MT, s.ML, s.n_gt_ids)


# --------------------------------------------------------------------------- running


def build_suite(work: Path) -> dict[str, Path]:
    """Simulate (or reuse) the scenes of :data:`SUITE` under ``work``."""
    out = {}
    for name, room, seed, n in SUITE:
        d = work / "scenes" / name
        if not (d / "scene.yaml").is_file():
            scene = simulate_scene(validate_scenario(avdiar_like(room, seed, n)))
            write_scene(scene, d)
        out[name] = d
    return out


def room_mapping(
    work: Path, room: str, scene_dir: Path, n_positions: int = 160, n_components: int = 8
) -> AudioImageMapping:
    """The calibration-trained mapping of ``room`` (cached as ``work/mapping-<room>.npz``)."""
    path = work / f"mapping-{room}.npz"
    if path.is_file():
        return load_mapping(path)
    sc = load_scene(scene_dir)
    setup = scene_setup(sc.scenario, scene_dir / "scene.yaml")
    calib = simulate_calibration(*setup, n_positions=n_positions, rng=0)
    mapping = train_mapping(calib, n_components, max_iter=50, meta={"room": room})
    save_mapping(path, mapping)
    return mapping


def der_of(ref_path: Path, hyp) -> DERComponents:
    return diarization_error_rate(read_rttm(ref_path), hyp, collar=0.25)


def run_accuracy(work: Path, config: VAVITConfig) -> dict:
    scenes = build_suite(work)
    mappings = {}
    mot: dict[tuple[str, str, str], Counts] = {}
    der_rows: dict[str, dict[str, DERComponents]] = {}
    for name, room, _, _ in SUITE:
        d = scenes[name]
        if room not in mappings:
            mappings[room] = room_mapping(work, room, d)
        mapping = mappings[room]
        sc = load_scene(d)
        gt = read_mot(d / "gt" / "gt.txt", kind="gt")
        feats = extract_audio_features(
            sc.audio, sc.fs, sc.n_frames, AudioFeatureConfig(fps=sc.fps)
        )
        der_rows[name] = {
            "audio-only": der_of(
                d / "gt" / "speech.rttm", audio_only_diarization(feats, mapping, sc.fps)
            )
        }
        ref_rttm = d / "gt" / "speech.rttm"
        muted = dataclasses.replace(
            feats, active=np.zeros_like(feats.active), vad=np.zeros_like(feats.vad)
        )
        for fov_name, frac in (("FFOV", 1.0), ("PFOV", PFOV_FRACTION)):
            vis = fov_strip(sc.image_size[0], frac)
            blind = None if frac == 1.0 else vis
            for method, use_audio, f in METHODS:
                r = track_scene(
                    d,
                    mapping,
                    config,
                    use_audio=use_audio,
                    fov_fraction=frac,
                    features=muted if f == "muted" else feats,
                    scene=sc,
                    unseen_speakers=fov_name == "PFOV",
                )
                c = clear_counts(gt, r.tracks, r.n_frames, blind)
                mot.setdefault((room, fov_name, method), Counts()).add(c)
                print(
                    f"  {name} {fov_name} {method}: MOTA {c.row()['MOTA']:.1f} FP {c.fp} "
                    f"FN {c.fn} IDs {c.ids}",
                    flush=True,
                )
                if method == "VAVIT":
                    der_rows[name][f"VAVIT ({fov_name})"] = der_of(ref_rttm, r.speech)
                    if fov_name == "PFOV":  # the same without the unseen-speaker clustering
                        tracked_only = [t for t in r.speech if not t.speaker.startswith("U")]
                        der_rows[name]["VAVIT (PFOV, tracked only)"] = der_of(
                            ref_rttm, tracked_only
                        )
    return {"mot": mot, "der": der_rows}


def format_mot_tables(mot: dict, markdown: bool) -> str:
    cols = ("MOTA", "FP", "FN", "IDs", "FM", "MT", "ML")
    out = []
    titles = {
        ("living-room", "FFOV"): "Table I: living room, full field of view",
        ("meeting-room", "FFOV"): "Table II: meeting room, full field of view",
        ("living-room", "PFOV"): "Table III: living room, partial field of view",
        ("meeting-room", "PFOV"): "Table IV: meeting room, partial field of view",
    }
    for (room, fov), title in titles.items():
        rows = {m: c.row() for (r, f, m), c in mot.items() if r == room and f == fov}
        out.append(title)
        out.append(_table(rows, cols, markdown, percent=("FP", "FN", "MT", "ML")))
        out.append("")
    return "\n".join(out)


def format_der_table(der: dict, markdown: bool) -> str:
    methods = ("audio-only", "VAVIT (FFOV)", "VAVIT (PFOV)", "VAVIT (PFOV, tracked only)")
    rows = {name: {m: 100 * der[name][m].rate for m in methods} for name in der}
    total = {m: DERComponents.sum([der[n][m] for n in der]) for m in methods}
    rows["Overall"] = {m: 100 * total[m].rate for m in methods}
    return "Table V: DER (%)\n" + _table(rows, methods, markdown)


def _table(rows: dict, cols, markdown: bool, percent=()) -> str:
    def fmt(c, v):
        if isinstance(v, int | np.integer):
            return str(int(v))
        return f"{v:.1f}%" if c in percent else f"{v:.2f}"

    body = [[name, *(fmt(c, r[c]) for c in cols)] for name, r in rows.items()]
    header = ["", *cols]
    if markdown:
        lines = [
            "| " + " | ".join(header) + " |",
            "|" + "|".join(["---"] + ["---:"] * len(cols)) + "|",
        ]
        return "\n".join(lines + ["| " + " | ".join(b) + " |" for b in body])
    widths = [max(len(x[i]) for x in [header, *body]) for i in range(len(header))]
    return "\n".join(
        "  ".join(
            c.ljust(w) if i == 0 else c.rjust(w)
            for i, (c, w) in enumerate(zip(x, widths, strict=True))
        )
        for x in [header, *body]
    )


# --------------------------------------------------------------------------- speed


def run_speed(work: Path, config: VAVITConfig, repeats: int = 3) -> dict:
    """Real-time factors on a 4-microphone scene (the living room, nao4 free-field array)."""
    d = work / "speed-nao4"
    if not (d / "scene.yaml").is_file():
        raw = avdiar_like("living-room", 11, 3, 20.0)
        raw["array"] = {"name": "nao4", "position": ROOMS["living-room"]["array"], "yaw_deg": 90.0}
        write_scene(simulate_scene(validate_scenario(raw)), d)
    mapping = room_mapping(work, "living-room-nao4", d, n_positions=100, n_components=6)
    sc = load_scene(d)
    best = {"visual": np.inf, "vavit": np.inf, "features": np.inf}
    for _ in range(repeats):
        t0 = time.perf_counter()
        track_scene(d, mapping, config, use_audio=False, scene=sc)
        best["visual"] = min(best["visual"], time.perf_counter() - t0)
        t0 = time.perf_counter()
        r = track_scene(d, mapping, config, use_audio=True, scene=sc)
        best["vavit"] = min(best["vavit"], time.perf_counter() - t0)
        best["features"] = min(best["features"], r.timing["features"])
    dur = sc.n_frames / sc.fps
    return {
        "duration_s": dur,
        "n_mics": sc.audio.shape[0],
        **best,
        "rf_vavit": best["vavit"] / dur,
        "rf_visual": best["visual"] / dur,
        "rf_features": best["features"] / dur,
        "ratio": best["vavit"] / best["visual"],
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", type=Path, help="folder for scenes and mappings (kept)")
    ap.add_argument("--markdown", type=Path, help="also write the tables as Markdown here")
    ap.add_argument("--no-speed", action="store_true")
    ap.add_argument("--no-accuracy", action="store_true")
    args = ap.parse_args(argv)
    config = VAVITConfig()
    with contextlib.ExitStack() as stack:
        work = args.work or Path(stack.enter_context(tempfile.TemporaryDirectory()))
        work.mkdir(parents=True, exist_ok=True)
        text, md = [], []
        if not args.no_accuracy:
            res = run_accuracy(work, config)
            for markdown, dest in ((False, text), (True, md)):
                dest.append(format_mot_tables(res["mot"], markdown))
                dest.append(format_der_table(res["der"], markdown))
        if not args.no_speed:
            s = run_speed(work, config)
            line = (
                f"Speed ({s['n_mics']} mics, {s['duration_s']:.0f} s scene, one thread, "
                f"{platform.processor() or platform.machine()}): VAVIT RF "
                f"{s['rf_vavit']:.3f} (features {s['rf_features']:.3f}), visual-only RF "
                f"{s['rf_visual']:.4f}; VAVIT / visual-only = {s['ratio']:.1f}x"
            )
            text.append(line)
            md.append(line)
        print("\n\n".join(text))
        if args.markdown:
            with atomic_write(args.markdown) as fh:
                fh.write("\n\n".join(md) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
