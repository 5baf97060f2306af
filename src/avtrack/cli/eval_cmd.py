"""``avtrack eval``: score a result against ground truth.

Tasks (each its own sub-command): ``mot`` — MOTChallenge visual tracking (MOTA, IDF1, HOTA ...);
``doa`` — frame-wise speaker localization (thesis §5.5.1: MD and FA rates, MAE); ``der`` —
diarization error rate of an RTTM file; ``persons`` — direction accuracy of ``persons.csv``
while persons are out of the camera's view; ``voices`` — SI-SDR of the voices of
``track-av --voices``.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path
from typing import Any

from avtrack.audio.stft import FRAME_HOP_S
from avtrack.cli.base import add_command, add_common, add_options_option, write_json
from avtrack.errors import InputError
from avtrack.io.base import read_audio_file
from avtrack.io.mot import read_mot
from avtrack.metrics.mot import BENCHMARKS, TABLE_COLUMNS, evaluate_mot, format_table

EVAL_EXAMPLES = """\
examples:
  avtrack eval mot gt/gt.txt results/TUD-Campus.txt
  avtrack eval doa scene/gt/doa.csv doa.csv --success-deg 10
  avtrack eval der scene/gt/speech.rttm out/speech.rttm
  avtrack eval voices out/walkout-1 scenes/walkout-1
  avtrack eval mot --help
"""

VOICES_EXAMPLES = """\
examples:
  avtrack simulate walkout -o scenes/walkout-1 --seed 1
  avtrack track-av scenes/walkout-1 -o out/walkout-1 --voices
  avtrack eval voices out/walkout-1 scenes/walkout-1 --json voices.json

SI-SDR (Le Roux et al., ICASSP 2019) of each voice against the person's image at microphone 0
(SCENE_DIR/gt/voices/<id>.wav, written by avtrack simulate), and its improvement (SI-SDRi)
over microphone 0's own signal. Tracked identities are matched to ground-truth persons as
'avtrack eval persons' matches them (azimuths, one to one per frame, within --gate); each
person then gets the identity matched to them in most of the frames where they speak.
"""

PERSONS_EXAMPLES = """\
examples:
  avtrack track-av scenes/walkout-1 -o out/walkout-1
  avtrack eval persons scenes/walkout-1 out/walkout-1/persons.csv
  avtrack eval persons scenes/meeting-1 out/pfov/persons.csv --fov-fraction 0.4
"""

DER_EXAMPLES = """\
examples:
  avtrack eval der scene/gt/speech.rttm out/speech.rttm
  # no collar, overlapping speech not scored, scores as JSON
  avtrack eval der ref.rttm hyp.rttm --collar 0 --skip-overlap --json der.json

The collar is pyannote.metrics' (its total width: 0.5 s forgives 0.25 s on each side of every
reference boundary, NIST md-eval's "-c 0.25"). Speakers are mapped one to one to maximise the
time they agree (Hungarian algorithm); components are summed over the recordings (file ids) of
the reference, as pyannote.metrics accumulates them.
"""

MOT_EXAMPLES = """\
examples:
  # MOT15 sequence: ground truth and a tracker result, both MOTChallenge text files
  avtrack eval mot ../shared/data/mot15/TUD-Campus/gt/gt.txt out/TUD-Campus.txt

  # MOT17 ground truth (classes in column 8, distractors removed) and the scores as JSON
  avtrack eval mot MOT17-02/gt/gt.txt MOT17-02.txt --benchmark MOT17 --json scores.json

  # all scores (IDP, IDR, DetA, AssA, PT ...), or nothing but the JSON file
  avtrack eval mot gt.txt res.txt -v
  avtrack eval mot gt.txt res.txt -q --json scores.json

  # the options from a file (keys: benchmark, n_frames, json), e.g. "benchmark: MOT17"
  avtrack eval mot MOT17-02/gt/gt.txt MOT17-02.txt --options eval.yaml

Matches need IoU >= 0.5 (CLEAR-MOT, identity) or are averaged over IoU 0.05..0.95 (HOTA), as
in TrackEval; the threshold is part of the metrics' definitions, not an option.
"""

#: Extra columns printed with ``--verbose``.
VERBOSE_COLUMNS = ("IDP", "IDR", "DetA", "AssA", "PT", "n_gt_ids", "n_frames")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = add_command(
        subparsers,
        "eval",
        help="score a result against ground truth",
        description="""\
Score a result against ground truth. Choose the task below.""",
        epilog=EVAL_EXAMPLES,
    )
    tasks = parser.add_subparsers(dest="eval_task", metavar="TASK", required=True)
    _add_mot_task(tasks)
    _add_doa_task(tasks)
    _add_der_task(tasks)
    _add_persons_task(tasks)
    _add_voices_task(tasks)


def _add_scores_outputs(
    parser: argparse.ArgumentParser, run: Callable[[argparse.Namespace], int]
) -> None:
    """Add the options every eval task shares (``--json``, common, ``--options``) to *parser*."""
    parser.add_argument(
        "--json", type=Path, metavar="OUT.json", help="also write the scores as JSON"
    )
    add_common(parser, run)
    add_options_option(parser)


def _add_mot_task(tasks: argparse._SubParsersAction) -> None:
    """Add the ``eval mot`` task: MOTChallenge tracking scores."""
    mot = add_command(
        tasks,
        "mot",
        help="MOTChallenge tracking scores: MOTA, MOTP, IDF1, HOTA, FP, FN, IDSW ...",
        description="""\
Score a tracker result against MOTChallenge ground truth, exactly as the official
TrackEval kit does (CLEAR-MOT, identity and HOTA metrics; a match needs IoU >= 0.5).
Files are MOTChallenge text: frame,id,left,top,width,height,conf,... (1-based frames).""",
        epilog=MOT_EXAMPLES,
    )
    mot.add_argument("gt", type=Path, metavar="GT.txt", help="ground-truth file (gt/gt.txt)")
    mot.add_argument("result", type=Path, metavar="RES.txt", help="tracker result file")
    mot.add_argument(
        "--benchmark",
        choices=BENCHMARKS,
        default="MOT15",
        help="which preprocessing to apply: MOT15 ignores rows flagged 0 in column 7; "
        "MOT16/17/20 also drop results on distractors and keep pedestrian gt only "
        "(default: %(default)s)",
    )
    mot.add_argument(
        "--n-frames",
        type=int,
        metavar="N",
        help="sequence length (default: the last frame in either file)",
    )
    _add_scores_outputs(mot, run_mot)


def _add_doa_task(tasks: argparse._SubParsersAction) -> None:
    """Add the ``eval doa`` task: speaker localization scores."""
    doa = add_command(
        tasks,
        "doa",
        help="speaker localization scores: miss-detection and false-alarm rates, MAE",
        description="""\
Score frame-wise DOA estimates against ground truth as thesis §5.5.1 does: per
frame, estimates and active speakers are matched greedily; a match within 15
degrees is a success (MAE over successes), unmatched speakers are misses,
unmatched estimates false alarms. Both files are DOA CSV
(frame,time_s,id,azimuth_deg,elevation_deg,weight,active); frames are aligned by
time.""",
        epilog=DOA_EXAMPLES,
    )
    doa.add_argument("gt", type=Path, metavar="GT.csv", help="ground truth (gt/doa.csv)")
    doa.add_argument("estimates", type=Path, metavar="DOA.csv", help="localizer output")
    doa.add_argument(
        "--threshold",
        type=float,
        metavar="T",
        help="use the estimates with weight >= T (default: the rows with active = 1)",
    )
    doa.add_argument(
        "--roc", action="store_true", help="sweep the threshold and report the best point"
    )
    doa.add_argument(
        "--success-deg", type=float, default=15.0, metavar="DEG", help="default: %(default)s"
    )
    doa.add_argument(
        "--max-shift",
        type=int,
        default=75,
        metavar="FRAMES",
        help="the lag (the time shift of the ground truth, in frames of --period, that "
        "minimises the MAE; > 0: the estimates come late) is searched within ±FRAMES "
        "(default: %(default)s; 0: no lag)",
    )
    doa.add_argument(
        "--period",
        type=float,
        default=FRAME_HOP_S,
        metavar="SECONDS",
        help="frame period used to align the files by time (default: %(default)s)",
    )
    _add_scores_outputs(doa, run_doa)


def _add_der_task(tasks: argparse._SubParsersAction) -> None:
    """Add the ``eval der`` task: diarization error rate."""
    der = add_command(
        tasks,
        "der",
        help="diarization error rate of an RTTM file (missed, false alarm, confusion)",
        description="""\
Diarization error rate (NIST RT definition, as pyannote.metrics computes it) of a
hypothesis RTTM against a reference RTTM: (missed + false alarm + speaker
confusion) / total reference speech. Printed twice, side by side: without a collar with
overlapping speech scored (DIHARD's scoring), and with --collar (and --skip-overlap).""",
        epilog=DER_EXAMPLES,
    )
    der.add_argument("reference", type=Path, metavar="REF.rttm", help="reference speaker turns")
    der.add_argument("hypothesis", type=Path, metavar="HYP.rttm", help="hypothesis turns")
    der.add_argument(
        "--collar", type=float, default=0.5, metavar="SECONDS",
        help="total width of the unscored collar around each reference boundary, as in "
        "pyannote.metrics (default: %(default)s, i.e. 0.25 s on each side)",
    )
    der.add_argument(
        "--skip-overlap", action="store_true",
        help="do not score regions where reference speakers overlap",
    )
    _add_scores_outputs(der, run_der)


def _add_persons_task(tasks: argparse._SubParsersAction) -> None:
    """Add the ``eval persons`` task: out-of-view direction accuracy."""
    per = add_command(
        tasks,
        "persons",
        help="direction accuracy of persons.csv while persons are out of the camera's view",
        description="""\
Score the directions of persons.csv (avtrack track-av) against a scene's ground
truth (SCENE_DIR/gt/doa.csv, SCENE_DIR/gt/gt.txt) for the persons the camera does
not see: at every frame, ground-truth persons and tracked persons are matched one
to one on azimuth (matches beyond --gate refused); the mean absolute azimuth error
of the out-of-view persons (lower is better) and the share of their frames matched
(coverage, higher is better).""",
        epilog=PERSONS_EXAMPLES,
    )
    per.add_argument("scene", type=Path, metavar="SCENE_DIR", help="scene directory")
    per.add_argument("persons", type=Path, metavar="PERSONS.csv", help="track-av output")
    per.add_argument("--fov-fraction", type=float, default=1.0, metavar="F",
                     help="the camera saw the central fraction F of the image width, as given "
                     "to track-av (default 1)")
    per.add_argument("--gate", type=float, default=30.0, metavar="DEG",
                     help="largest azimuth difference of a match (default %(default)s)")
    _add_scores_outputs(per, run_persons)


def _add_voices_task(tasks: argparse._SubParsersAction) -> None:
    """Add the ``eval voices`` task: SI-SDR of separated voices."""
    voi = add_command(
        tasks,
        "voices",
        help="SI-SDR of the voices of track-av --voices, and their improvement (SI-SDRi)",
        description="""\
Score the voices OUT_DIR/voices/<id>.wav of 'avtrack track-av --voices' against a simulated
scene's references SCENE_DIR/gt/voices/<id>.wav (each person as microphone 0 hears them):
per person the SI-SDR of their voice and its improvement over microphone 0 (SI-SDRi; both in
dB, higher is better).""",
        epilog=VOICES_EXAMPLES,
    )
    voi.add_argument("result_dir", type=Path, metavar="OUT_DIR", help="track-av --voices output")
    voi.add_argument("scene", type=Path, metavar="SCENE_DIR", help="scene directory")
    voi.add_argument("--gate", type=float, default=30.0, metavar="DEG",
                     help="largest azimuth difference of a match (default %(default)s)")
    _add_scores_outputs(voi, run_voices)


DOA_EXAMPLES = """\
examples:
  avtrack localize scene/audio.wav --array scene/array.json -o doa.csv --floor 0.005
  avtrack eval doa scene/gt/doa.csv doa.csv
  avtrack eval doa scene/gt/doa.csv doa.csv --roc --json scores.json

  # thresholds from a file (keys: json, roc, success_deg, threshold), e.g.
  #   success_deg: 10
  #   threshold: 0.05
  avtrack eval doa scene/gt/doa.csv doa.csv --options doa-eval.yaml
"""


def run_doa(args: argparse.Namespace) -> int:
    import numpy as np

    from avtrack.io.doa import read_doa_csv
    from avtrack.metrics.doa import estimate_lag, evaluate_doa, roc_sweep

    if not args.success_deg > 0:
        raise InputError(f"--success-deg must be > 0, got {args.success_deg}")
    if not 0 <= args.max_shift <= 2000:
        raise InputError(f"--max-shift must be an integer in [0, 2000], got {args.max_shift}")
    if not (args.period > 0 and args.period < float("inf")):
        raise InputError(f"--period must be a number of seconds > 0, got {args.period}")
    truth = read_doa_csv(args.gt)
    est = read_doa_csv(args.estimates)
    kw = {"success_deg": args.success_deg, "period_s": args.period}
    if args.roc:
        threshold, scores = roc_sweep(est, truth, **kw).best
    else:
        threshold = args.threshold
        scores = evaluate_doa(est, truth, threshold=threshold, **kw)
    d = scores.as_dict()
    lag = None
    if args.max_shift:
        res = estimate_lag(est, truth, max_shift_frames=args.max_shift, threshold=threshold, **kw)
        if np.any(np.isfinite(res.mae)):
            lag = res.lag_frames
            d["lag_frames"] = lag
            d["lag_s"] = res.lag_s
            d["MAE_at_lag"] = float(res.mae[res.shifts == lag][0])
    if args.json is not None:
        write_json(args.json, {"gt": str(args.gt), "estimates": str(args.estimates),
                               "threshold": threshold, "scores": d})
    if not args.quiet:
        which = "active rows" if threshold is None else f"weight >= {threshold:.4g}"
        print(f"DOA scores of {args.estimates} against {args.gt} ({which}):")
        print("  " + "  ".join(f"{k} {v:.2f}" if isinstance(v, float) else f"{k} {v}"
                               for k, v in scores.as_dict().items()))  # fmt: skip
        if args.max_shift:
            if lag is None:
                print("  lag: no successful estimate")
            else:
                edge = " (at the edge of --max-shift)" if abs(lag) == args.max_shift else ""
                print(f"  lag {lag} frames ({1000 * d['lag_s']:.0f} ms){edge}: MAE "
                      f"{d['MAE_at_lag']:.2f} with the ground truth shifted by it")  # fmt: skip
    return 0


def run_mot(args: argparse.Namespace) -> int:
    gt = read_mot(args.gt, kind="gt")
    res = read_mot(args.result, kind="result")
    if args.json is not None and args.json.is_dir():
        raise InputError("--json must name a file, got a directory", args.json)
    try:
        scores = evaluate_mot(gt, res, benchmark=args.benchmark, n_frames=args.n_frames)
    except ValueError as exc:
        raise InputError(f"cannot score {args.result} against {args.gt}: {exc}") from None
    if args.json is not None:
        write_json(args.json, {"gt": str(args.gt), "result": str(args.result),
                               "benchmark": args.benchmark, "scores": scores.as_dict()})
    if not args.quiet:
        columns = TABLE_COLUMNS + (VERBOSE_COLUMNS if args.verbose else ())
        print(
            f"{args.benchmark} scores of {args.result} against {args.gt} "
            f"({scores.n_frames} frames, {scores.n_gt_ids} ground-truth identities)"
        )
        print(format_table({args.result.stem: scores}, columns=columns))
        if args.json is not None and args.verbose:
            print(f"wrote {args.json}")
    return 0


def _der_scores(ref, hyp, collar: float, skip_overlap: bool) -> dict:
    """DER and its components (percent of the scored reference speech), summed over the file
    ids of ``ref``; ``collar`` is pyannote's total width."""
    from avtrack.metrics.der import DERComponents, diarization_error_rate

    files = sorted({s.file_id for s in ref})
    parts = []
    for file_id in files:
        r = [s for s in ref if s.file_id == file_id]
        h = [s for s in hyp if s.file_id == file_id] if len(files) > 1 else hyp
        # pyannote's collar is the total width; ours is per side
        parts.append(diarization_error_rate(r, h, collar=collar / 2, skip_overlap=skip_overlap))
    c = DERComponents.sum(parts)
    pct = (lambda v: 100 * v / c.total) if c.total else (lambda v: float("nan"))
    return {"DER": 100 * c.rate, "missed": pct(c.missed), "false_alarm": pct(c.false_alarm),
            "confusion": pct(c.confusion), "total_s": c.total}


def run_der(args: argparse.Namespace) -> int:
    from avtrack.io.rttm import read_rttm

    if not (args.collar >= 0 and args.collar < float("inf")):
        raise InputError(f"--collar must be a number of seconds >= 0, got {args.collar}")
    if args.json is not None and args.json.is_dir():
        raise InputError("--json must name a file, got a directory", args.json)
    ref = read_rttm(args.reference)
    hyp = read_rttm(args.hypothesis)
    if not ref:
        raise InputError("no speaker turns: the DER needs reference speech", args.reference)
    # DIHARD's scoring (no collar, overlap scored) beside the chosen collar
    settings = {"no_collar": (0.0, False), "collar": (args.collar, args.skip_overlap)}
    if args.collar == 0 and not args.skip_overlap:
        settings = {"no_collar": (0.0, False)}
    table = {k: _der_scores(ref, hyp, c, o) for k, (c, o) in settings.items()}
    scores = dict(table["collar" if "collar" in table else "no_collar"])
    scores["reference_speakers"] = len({s.speaker for s in ref})
    scores["hypothesis_speakers"] = len({s.speaker for s in hyp})
    scores["no_collar"] = table["no_collar"]
    if args.json is not None:
        write_json(args.json, {"reference": str(args.reference),
                               "hypothesis": str(args.hypothesis), "collar": args.collar,
                               "skip_overlap": args.skip_overlap, "scores": scores})
    if not args.quiet:
        print(f"DER of {args.hypothesis} against {args.reference} (percent of the scored "
              f"reference speech; lower is better; speakers: {scores['hypothesis_speakers']} "
              f"found, {scores['reference_speakers']} in the reference):")
        labels = {"no_collar": "no collar, overlap scored (DIHARD)",
                  "collar": f"collar {args.collar:g} s"
                  + (", overlap skipped" if args.skip_overlap else ", overlap scored")}
        width = max(len(labels[k]) for k in table)
        print(f"  {'':{width}}  {'DER':>6}  {'missed':>6}  {'FA':>6}  {'conf.':>6}  speech")
        for k, d in table.items():
            print(f"  {labels[k]:{width}}  {d['DER']:6.2f}  {d['missed']:6.2f}  "
                  f"{d['false_alarm']:6.2f}  {d['confusion']:6.2f}  {d['total_s']:.1f} s")
    return 0


def run_persons(args: argparse.Namespace) -> int:
    from avtrack.av.vavit import fov_strip
    from avtrack.io.doa import read_doa_csv
    from avtrack.io.persons import read_persons_csv
    from avtrack.io.scene import load_scene
    from avtrack.metrics.persons import offscreen_direction_error, truth_per_frame

    if not 0 < args.fov_fraction <= 1:
        raise InputError(f"--fov-fraction must be in (0, 1], got {args.fov_fraction}")
    if not 0 < args.gate <= 180:
        raise InputError(f"--gate must be in (0, 180] degrees, got {args.gate}")
    if args.json is not None and args.json.is_dir():
        raise InputError("--json must name a file, got a directory", args.json)
    scene = load_scene(args.scene)
    truth = read_doa_csv(args.scene / "gt" / "doa.csv")
    gt = read_mot(args.scene / "gt" / "gt.txt", kind="gt")
    persons = read_persons_csv(args.persons, fps=scene.fps)
    if len(persons) and int(persons.frames.max()) > scene.n_frames:
        raise InputError(f"frame {int(persons.frames.max())} is past the scene's last frame "
                         f"({scene.n_frames})", args.persons)
    fov = fov_strip(scene.image_size[0], args.fov_fraction)
    gf, gi, ga, gv, _ = truth_per_frame(truth, gt, scene.fps, scene.n_frames, fov)
    s = offscreen_direction_error(gf, gi, ga, gv, persons.frames, persons.azimuth_deg,
                                  gate_deg=args.gate)
    scores = {"offscreen_mae_deg": s.mae_deg, "coverage": s.coverage,
              "offscreen_person_frames": s.n_frames, "matched": s.n_matched}
    if args.json is not None:
        write_json(args.json, {"scene": str(args.scene), "persons": str(args.persons),
                               "fov_fraction": args.fov_fraction, "gate_deg": args.gate,
                               "scores": {k: (None if isinstance(v, float) and v != v else v)
                                          for k, v in scores.items()}})
    if not args.quiet:
        if s.n_frames == 0:
            print(f"{args.scene}: every person is in the camera's view at every frame; nothing "
                  f"to score out of view")
        else:
            print(f"persons out of view in {args.scene}: azimuth MAE {s.mae_deg:.2f} deg (lower "
                  f"is better) over {s.n_matched} of {s.n_frames} person-frames matched "
                  f"(coverage {100 * s.coverage:.1f} %, higher is better; gate {args.gate:g} deg)")
    return 0


def _read_mono(path: Path, fs: int | None = None):
    import numpy as np

    x, rate = read_audio_file(path)
    if x.shape[1] != 1:
        raise InputError(f"expected one channel, got {x.shape[1]}", path)
    if fs is not None and rate != fs:
        raise InputError(f"sampled at {rate} Hz, the scene at {fs} Hz", path)
    if not np.all(np.isfinite(x)):
        raise InputError("contains NaN or infinite samples", path)
    return x[:, 0]


def run_voices(args: argparse.Namespace) -> int:
    import numpy as np

    from avtrack.io.doa import read_doa_csv
    from avtrack.io.persons import read_persons_csv
    from avtrack.io.scene import load_scene
    from avtrack.metrics.persons import truth_per_frame
    from avtrack.metrics.voices import assign_identities, score_voices

    if not 0 < args.gate <= 180:
        raise InputError(f"--gate must be in (0, 180] degrees, got {args.gate}")
    if args.json is not None and args.json.is_dir():
        raise InputError("--json must name a file, got a directory", args.json)
    scene = load_scene(args.scene)
    ref_dir = args.scene / "gt" / "voices"
    if not ref_dir.is_dir():
        raise InputError("no reference voices (gt/voices/<id>.wav): simulate the scene again "
                         "with this version of avtrack simulate", args.scene)
    voice_dir = args.result_dir / "voices"
    if not voice_dir.is_dir():
        raise InputError("no voices/ folder: run avtrack track-av with --voices", args.result_dir)
    n = scene.audio.shape[1]
    refs = {}
    for path in sorted(ref_dir.glob("*.wav")):
        if not path.stem.isdigit():
            raise InputError("expected <person id>.wav", path)
        refs[int(path.stem)] = _read_mono(path, scene.fs)
    voices = {}
    for path in sorted(voice_dir.glob("*.wav")):
        if not path.stem.isdigit():
            raise InputError("expected <person id>.wav", path)
        voices[int(path.stem)] = _read_mono(path, scene.fs)
    for what, d, folder in (("reference", refs, ref_dir), ("voice", voices, voice_dir)):
        for pid, x in d.items():
            if x.size != n:
                raise InputError(f"{what} has {x.size} samples, the scene's audio {n}",
                                 folder / f"{pid}.wav")
    truth = read_doa_csv(args.scene / "gt" / "doa.csv")
    gt = read_mot(args.scene / "gt" / "gt.txt", kind="gt")
    persons = read_persons_csv(args.result_dir / "persons.csv", fps=scene.fps)
    gf, gi, ga, gv, gs = truth_per_frame(truth, gt, scene.fps, scene.n_frames)
    ids = assign_identities(gf, gi, ga, gs, persons.frames, persons.ids, persons.azimuth_deg,
                            gate_deg=args.gate)
    try:
        scores = score_voices(refs, scene.audio[0], voices, ids)
    except ValueError as exc:
        raise InputError(str(exc), args.result_dir) from None
    rows: list[dict[str, Any]] = []
    for sc in scores:
        talk = (gi == sc.person) & gs
        seen = float(np.mean(gv[talk])) if np.any(talk) else float("nan")
        rows.append({"person": sc.person, "track": sc.track, "si_sdr_db": sc.si_sdr,
                     "mixture_si_sdr_db": sc.si_sdr_mixture, "si_sdri_db": sc.improvement,
                     "in_view_share": seen})
    matched = [r for r in rows if r["track"] is not None]
    mean = float(np.mean([r["si_sdri_db"] for r in matched])) if matched else float("nan")
    if args.json is not None:
        def clean(v):
            return None if isinstance(v, float) and not np.isfinite(v) else v

        write_json(args.json, {"output": str(args.result_dir), "scene": str(args.scene),
                               "gate_deg": args.gate, "mean_si_sdri_db": clean(mean),
                               "persons": [{k: clean(v) for k, v in r.items()}
                                           for r in rows]})
    if not args.quiet:
        print(f"voices of {args.result_dir} against {args.scene} (dB, higher is better):")
        print("  person  track  SI-SDR  mic 0  SI-SDRi  seen while speaking")
        for r in rows:
            tr = "-" if r["track"] is None else str(r["track"])
            print(f"  {r['person']:>6}  {tr:>5}  {r['si_sdr_db']:6.2f}  "
                  f"{r['mixture_si_sdr_db']:5.2f}  {r['si_sdri_db']:7.2f}  "
                  f"{100 * r['in_view_share']:5.1f} %")
        missing = len(rows) - len(matched)
        print(f"  mean SI-SDRi {mean:.2f} dB over {len(matched)} matched persons"
              + (f"; {missing} person(s) without a voice" if missing else ""))
    return 0
