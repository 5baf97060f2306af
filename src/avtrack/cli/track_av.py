"""``avtrack track-av``: audio-visual tracking and diarization of a scene directory.

Two models: ``direction`` (default), persons in the array's direction space
(:mod:`avtrack.av.persons`), who stay tracked out of the camera's view and are born from
audio too; ``image``, the thesis's image-plane model (VAVIT, :mod:`avtrack.av.vavit`)
with its learned GLLiM audio-to-image mapping.

Each input (a scene directory, a recording of one's own, an AV16.3 sequence) is one function
of :mod:`avtrack.pipelines.av` / :mod:`avtrack.pipelines.av_recording`; this module parses
the options, prints and writes the files (:func:`write_outputs`).
"""

from __future__ import annotations

import argparse
import sys
import textwrap
from functools import partial
from pathlib import Path

import yaml

from avtrack.audio.arrays import load_array
from avtrack.audio.beamform import write_voices
from avtrack.audio.recording import FS
from avtrack.av.calibrate import CameraCheck, CameraFit
from avtrack.av.gllim import save_mapping
from avtrack.av.persons import PersonConfig
from avtrack.av.vavit import VAVITConfig
from avtrack.cli import progress
from avtrack.cli.base import add_array_option, add_clipping_option, add_command, add_common
from avtrack.config import load_config
from avtrack.errors import InputError
from avtrack.io.base import atomic_write
from avtrack.io.mot import write_mot
from avtrack.io.rttm import write_rttm
from avtrack.io.video import iter_frames, probe_video
from avtrack.pipelines.av import (
    AV163Run,
    AVRun,
    av163_scores,
    track_av163_sequence,
    track_scene_direction,
    track_scene_image,
)
from avtrack.pipelines.av_recording import RecordingInputs, RecordingRun, track_own_recording
from avtrack.pipelines.mot import Stage
from avtrack.visual.detect import DEFAULT_FACE_DETECTOR, DETECTORS
from avtrack.viz.plots import plot_covariances
from avtrack.viz.recording import write_recording_report

EXAMPLES = """\
examples:
  # simulate two people walking out of the camera's view and back, then track and diarize
  # them: persons live in directions from the array, audio carries them while unseen
  avtrack simulate walkout -o scenes/walkout-1 --seed 1 --duration 40
  avtrack track-av scenes/walkout-1 -o out/walkout-1
  avtrack eval der scenes/walkout-1/gt/speech.rttm out/walkout-1/speech.rttm

  # partial field of view: the camera sees the central 40 % of the image; talkers outside
  # it are tracked and diarized from audio alone
  avtrack simulate meeting -o scenes/meeting-1 --seed 1
  avtrack track-av scenes/meeting-1 -o out/pfov --fov-fraction 0.4

  # the thesis's image-plane model (VAVIT): the audio-to-image mapping is trained first on a
  # simulated loudspeaker calibration of the scene's room and saved in OUT_DIR; reuse it,
  # covariance figure
  avtrack track-av scenes/meeting-1 -o out/image --model image
  avtrack track-av scenes/meeting-1 -o out/image2 --model image \\
      --mapping out/image/mapping.npz --plot

  # the visual-only tracker (OVBT) on the same detections
  avtrack track-av scenes/meeting-1 -o out/visual --no-audio

  # then score them
  avtrack eval mot scenes/meeting-1/gt/gt.txt out/meeting-1/tracks.txt

  # one voice per person, out of view too, scored by SI-SDR against the scene's references
  avtrack track-av scenes/walkout-1 -o out/walkout-1 --voices
  avtrack eval voices out/walkout-1 scenes/walkout-1

AV16.3 (the sequence's real video; array 1's DOA measurements; the calibration maps them):
  avtrack track-av ../shared/data/av16.3 --seq 30 --cam 1 \
      --video ../shared/data/av16.3/seq30-2p-1101_cam1_divx_audio.avi -o out/av30
  (default detector: the tops of the moving foreground, scored by the sequence's colour
  templates; or --detector NAME)

Outputs: OUT_DIR/tracks.txt (MOTChallenge results of the head boxes of persons seen in the
image, confidence = visibility probability), OUT_DIR/persons.csv (every tracked person every
frame: frame,time_s,id,azimuth_deg,elevation_deg,x,y,in_view,speaking; x,y and in_view
only while the camera shows the person: in the image and seen in the last 0.1 s),
OUT_DIR/speech.rttm (who speaks when, speakers P<person id>, and U<n> for speech from a
direction where no person is tracked; not with --no-audio),
OUT_DIR/voices/<id>.wav (--voices: each person's voice; score them with avtrack eval voices),
OUT_DIR/mapping.npz (--model image, when trained here), OUT_DIR/covariances.png (--model
image --plot); for a recording of your own and AV16.3, OUT_DIR/index.html, OUT_DIR/tracks.mp4
(H.264) and tracks.webm: the tracks over the video's own frames, or over a plain canvas with
--detections and no video (--no-report: not written).

A recording of your own (no scene directory): a video, the microphone array's WAV (channel k
is microphone k of --array) and a camera file, CAMERA.yaml, in the array's frame (metres,
x axis = azimuth 0, z up; the array's centre at the origin):
  fx: 554.3            # focal lengths and principal point, pixels
  fy: 554.3
  cx: 320.0
  cy: 240.0
  width: 640           # the video's frame size
  height: 480
  position: [0.0, 0.0, 0.05]   # the camera's optical centre
  yaw_deg: 0.0         # its optical axis: azimuth (counter-clockwise from x) ...
  pitch_deg: 0.0       # ... and elevation
  avtrack track-av --video rec.mp4 --audio rec.wav --array nao4 --camera camera.yaml -o out
  avtrack track-av --detections det.txt --fps 25 --doa doa.csv --camera camera.yaml -o out
No camera file: --camera auto estimates yaw, focal length and pitch (from a DOA CSV's
elevations, else from people walking in depth; held level when neither measures it) from the
people seen talking, prints it with its uncertainty and writes
OUT_DIR/CAMERA.yaml; a camera file given is checked against the recording the same way
(a warning names the likely mistake; --strict: exit 2):
  avtrack track-av --video rec.mp4 --audio rec.wav --array nao4 --camera auto -o out
The camera is taken to stand at the array unless --camera-position gives where it is:
  avtrack track-av --video v.mp4 --doa doa.csv --camera auto --camera-position=-1.6,1.6,1.4 -o out

The --config YAML holds PersonConfig fields with --model direction (the visual tracker's under
"visual:"), e.g.:
  sigma_audio_deg: 5.0
  death_s: 15
  visual: {birth_frames: 3, death_frames: 20}
and VAVITConfig fields with --model image, e.g.:
  sigma_scale: 4.0
  diarization_threshold: 0.4
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    p = add_command(
        subparsers,
        "track-av",
        help="audio-visual tracking and diarization of a scene directory",
        description="""\
Variational audio-visual tracking and diarization of several speakers. By default persons
live in directions from the microphone array (the camera's view a window inside them):
head detections enter through the camera geometry, DP-RTF + EG audio peaks directly, so a
person out of view stays tracked while heard and a talker never seen gets a track. Speaker
turns: who the tracker hears, refined at the audio's 8 ms frames by a voice activity detector
(webrtcvad) and each person's share of the frame's directional energy (--no-vad: the
tracker's 40 ms turns only). --model image: the thesis's image-plane model (ch. 4) with a
learned GLLiM mapping. SCENE_DIR is a scene directory as written by 'avtrack simulate'.""",
        epilog=EXAMPLES,
    )
    p.add_argument("scene", type=Path, metavar="SCENE_DIR", nargs="?",
                   help="scene directory (or give a recording with --audio / --camera)")
    _add_recording_options(p)
    av = p.add_argument_group("AV16.3 (SCENE_DIR is a folder of AV16.3 MAT files; with --video)")
    av.add_argument("--seq", type=int, metavar="N", help="AV16.3 sequence number")
    av.add_argument("--cam", type=int, choices=(1, 2, 3), help="AV16.3 camera")
    _add_tracking_options(p)
    add_common(p, run)


def _add_recording_options(p: argparse.ArgumentParser) -> None:
    """The options of a recording of one's own."""
    rec = p.add_argument_group(
        "a recording of your own (instead of SCENE_DIR; direction model)")
    rec.add_argument("--video", type=Path, metavar="FILE",
                     help="the camera's video (its frame rate, length and size are used)")
    rec.add_argument("--audio", type=Path, metavar="FILE.wav",
                     help="the array's recording; WAV channel k is microphone k of --array")
    add_array_option(rec, required=False,
                     note=", the microphones of --audio (positions in the array frame)")
    rec.add_argument("--camera", type=Path, metavar="CAMERA.yaml",
                     help="camera intrinsics, image size and pose in the array frame, checked "
                     "against the recording; 'auto': estimated from the people seen talking "
                     "and written as OUT_DIR/CAMERA.yaml (both below)")
    rec.add_argument("--camera-position", metavar="X,Y,Z",
                     help="--camera auto: where the camera's lens is in the array's frame, "
                     "metres (x towards azimuth 0, z up), for a camera that does not stand "
                     "at the array; a first value below 0 goes after '=': "
                     "--camera-position=-1.6,1.6,1.4")
    rec.add_argument("--strict", action="store_true",
                     help="a camera file that disagrees with the recording is an error (exit "
                     "2), not a warning")
    rec.add_argument("--image-size", metavar="WxH",
                     help="--camera auto without --video: the image size of --detections, "
                     "pixels (e.g. 640x480)")
    rec.add_argument("--detections", type=Path, metavar="DET.txt",
                     help="head or person detections (MOTChallenge det); default: detect in "
                     "--video's frames")
    rec.add_argument("--appearance", type=Path, metavar="APP.npy",
                     help="appearance embeddings, one row per --detections row (default: "
                     "colour histograms from --video, or none)")
    rec.add_argument("--detector", metavar="NAME",
                     help="detector for --video without --detections: a built-in one "
                     f"({', '.join(DETECTORS)}; default {DEFAULT_FACE_DETECTOR}, faces, from "
                     "the avtrack[detectors] extra) or module:attribute")
    rec.add_argument("--doa", type=Path, metavar="DOA.csv",
                     help="directions computed elsewhere (DOA CSV) instead of localizing "
                     "--audio")
    add_clipping_option(rec)
    rec.add_argument("--fps", type=float, metavar="F",
                     help="video frame rate when there is no --video (default: the video's)")


def _add_tracking_options(p: argparse.ArgumentParser) -> None:
    """Output, model and tracking options."""
    p.add_argument(
        "-o",
        "--output",
        type=Path,
        required=True,
        metavar="OUT_DIR",
        help="output directory (created; files written atomically)",
    )
    p.add_argument(
        "--model",
        choices=("direction", "image"),
        default="direction",
        help="state space: directions from the array (default) or the image plane (thesis "
        "ch. 4, VAVIT)",
    )
    p.add_argument(
        "--mapping",
        type=Path,
        metavar="MAP.npz",
        help="--model image: trained audio-to-image mapping (default: train one on a "
        "simulated calibration of the scene's room and save it as OUT_DIR/mapping.npz)",
    )
    p.add_argument(
        "--calibration-positions",
        type=int,
        default=120,
        metavar="N",
        help="--model image: loudspeaker positions of that calibration (default 120)",
    )
    p.add_argument(
        "--no-audio", action="store_true",
        help="visual-only tracking (OVBT, thesis §3.1); no diarization"
    )
    p.add_argument(
        "--no-report", action="store_true",
        help="a recording of your own: do not write OUT_DIR/index.html, tracks.mp4 and "
        "tracks.webm (the tracks drawn over the video's own frames or a plain canvas, the "
        "persons' directions, who speaks when)",
    )
    p.add_argument(
        "--fov-fraction",
        type=float,
        default=1.0,
        metavar="F",
        help="the camera sees the central fraction F of the image width; detections "
        "outside are dropped (partial field of view; default 1)",
    )
    p.add_argument(
        "--threshold",
        type=float,
        metavar="GAMMA",
        help="speaking threshold: of eq. 4.34 with --model image, of the speaking "
        "probability with --model direction (overrides --config)",
    )
    p.add_argument(
        "--voices", action="store_true",
        help="--model direction with audio: also write OUT_DIR/voices/<id>.wav, each person's "
        "speech alone (an MVDR beamformer of the array's microphones steered at the person's "
        "tracked direction, silent outside their speaker turns; as microphone 0 hears it). "
        "The beamformer holds the whole recording in memory (without --voices a recording "
        "of your own is read in blocks)",
    )
    p.add_argument(
        "--no-vad", action="store_true",
        help="--model direction: speaker turns from the tracker's speaking probability at the "
        "video frame rate only (by default they are refined at the audio's 8 ms frames by a "
        "voice activity detector, webrtcvad, when it is installed)",
    )
    p.add_argument(
        "--config", type=Path, metavar="FILE.yaml",
        help="tracker parameters (PersonConfig or VAVITConfig fields, see below)"
    )
    p.add_argument(
        "--plot",
        action="store_true",
        help="--model image: write OUT_DIR/covariances.png, the visual, audio and dynamics "
        "covariances of the tracked persons in four frames (Ban et al., Fig. 1)",
    )


def load_vavit_config(path: Path | None, threshold: float | None) -> VAVITConfig:
    """VAVITConfig from ``--config`` (``visual:`` overrides the default visual fields), with
    ``--threshold`` on top."""
    return load_config(path, VAVITConfig, overrides={"diarization_threshold": threshold})


def load_person_config(path: Path | None, threshold: float | None) -> PersonConfig:
    """PersonConfig from ``--config`` (the visual tracker's fields under ``visual:``), with
    ``--threshold`` on top."""
    return load_config(path, PersonConfig, overrides={"speaking_threshold": threshold})


#: Options that describe a recording of one's own (no SCENE_DIR).
OWN_RECORDING = ("video", "audio", "camera", "detections", "doa", "fps", "detector", "array",
                 "appearance", "image_size", "camera_position")


def run(args: argparse.Namespace) -> int:
    if not 0 < args.fov_fraction <= 1:
        raise InputError(f"--fov-fraction must be in (0, 1], got {args.fov_fraction}")
    own = [o for o in OWN_RECORDING if getattr(args, o) is not None]
    if args.strict:
        own.append("strict")
    if args.voices and (args.model != "direction" or args.no_audio or args.seq is not None
                        or args.cam is not None or (args.scene is None and args.audio is None)):
        raise InputError("--voices beamforms the microphone array's recording: it needs "
                         "--model direction with audio, and a scene directory or --audio with "
                         "--array (not --doa alone, --no-audio or AV16.3)")
    if args.seq is not None or args.cam is not None:
        return run_av163(args)
    if args.scene is None:
        return run_recording(args)
    if own:
        raise InputError(f"--{own[0].replace('_', '-')} describes a recording of your own: "
                         f"give it without SCENE_DIR")
    if args.model == "direction" and not args.no_audio:
        return run_direction(args)
    return run_image(args)


# ------------------------------------------------------------------------------ output tail


def _stage(args: argparse.Namespace) -> Stage:
    """The pipelines' ``stage``: an elapsed-time bar per long step (none with --quiet)."""
    return partial(progress.activity, quiet=args.quiet)


def _check_output(out: Path) -> None:
    """OUT_DIR must be a folder (checked before any work)."""
    if out.exists() and not out.is_dir():
        raise InputError("output exists and is not a directory", out)


def write_outputs(out: Path, res: AVRun) -> None:
    """OUT_DIR/tracks.txt, persons.csv, speech.rttm (with audio) and voices/<id>.wav (when
    beamformed)."""
    out.mkdir(parents=True, exist_ok=True)
    write_mot(out / "tracks.txt", res.tracks)
    _write_text(out / "persons.csv", res.persons.to_csv())
    if res.speech is not None:
        write_rttm(out / "speech.rttm", res.speech)
    if res.voices is not None:
        write_voices(out / "voices", res.voices, res.voices_fs)


def summary(res: AVRun, out: Path) -> str:
    """One line: frames, persons, boxes, speaker turns, output, time and real-time factor."""
    speech = res.speech or []
    speakers = len({s.speaker for s in speech})
    return (f"tracked {res.n_frames} frames ({res.duration_s:.1f} s): {res.n_persons} persons, "
            f"{len(res.tracks)} boxes, {len(speech)} speaker turns of {speakers} speakers -> "
            f"{out} ({res.elapsed_s:.1f} s, real-time factor "
            f"{res.elapsed_s / max(res.duration_s, 1e-9):.2f})")


def _write_text(path: Path, text: str) -> None:
    with atomic_write(path) as fh:
        fh.write(text)


# ------------------------------------------------------------------------- scene directory


def run_direction(args: argparse.Namespace) -> int:
    """--model direction: persons in the array's direction space."""
    if args.plot:
        raise InputError("--plot draws the image-plane model's covariances; use --model image")
    if args.mapping is not None:
        raise InputError("--mapping is the image-plane model's audio-to-image mapping; the "
                         "direction model maps geometrically (use --model image)")
    config = load_person_config(args.config, args.threshold)
    _check_output(args.output)
    res = track_scene_direction(args.scene, config, fov_fraction=args.fov_fraction,
                                vad=not args.no_vad, voices=args.voices, stage=_stage(args))
    write_outputs(args.output, res)
    if not args.quiet:
        print(summary(res, args.output))
    return 0


def run_image(args: argparse.Namespace) -> int:
    """--model image (VAVIT) and --no-audio (OVBT)."""
    config = load_vavit_config(args.config, args.threshold)
    _check_output(args.output)
    res = track_scene_image(args.scene, config, use_audio=not args.no_audio,
                            mapping=args.mapping, calibration_positions=args.calibration_positions,
                            fov_fraction=args.fov_fraction, record_precisions=args.plot,
                            stage=_stage(args))
    if res.mapping_trained and not args.quiet:
        how = (f"read from the cache ({res.mapping_cache})" if res.mapping_cache is not None
               else "trained on a simulated calibration and cached")
        print(f"audio-to-image mapping {how} ({res.mapping_s:.1f} s)", file=sys.stderr)
    write_outputs(args.output, res)
    if res.mapping_trained and res.mapping is not None:
        save_mapping(args.output / "mapping.npz", res.mapping)
    if args.plot:
        plot_covariances(res.result, args.output / "covariances.png", args.no_audio)
    if not args.quiet:
        print(summary(res, args.output))
    return 0


# ------------------------------------------------------------------------------------ AV16.3


def run_av163(args: argparse.Namespace) -> int:
    """SCENE_DIR is an AV16.3 folder: its real video, DOA measurements and calibration."""
    if args.seq is None or args.cam is None or args.scene is None or args.video is None:
        raise InputError("AV16.3: give the folder, --seq N, --cam C and --video FILE")
    if args.seq < 1:
        raise InputError(f"--seq must be a positive integer, got {args.seq}")
    for o in ("audio", "camera", "detections", "doa", "fps", "array", "appearance",
              "mapping", "camera_position"):
        if getattr(args, o) is not None:
            raise InputError(f"--{o} does not apply to AV16.3 (its calibration, DOAs and video "
                             f"are used)")
    if args.model != "direction" or args.no_audio or args.plot:
        raise InputError("AV16.3 is tracked with --model direction, with audio")
    config = load_person_config(args.config, args.threshold)
    _check_output(args.output)
    res = track_av163_sequence(args.scene, args.seq, args.cam, args.video, config,
                               detector=args.detector, stage=_stage(args))
    write_outputs(args.output, res)
    if not args.no_report:
        _av163_report(args, res)
    if not args.quiet:
        print(f"AV16.3 seq {args.seq} cam {args.cam}: {summary(res, args.output)}")
    return 0


def _av163_report(args: argparse.Namespace, res: AV163Run) -> None:
    """index.html of an AV16.3 run: the persons seen in the image against ``posGT``."""
    video = probe_video(args.video)
    with progress.activity(f"drawing the tracks over {video.n_frames} frames", args.quiet):
        write_recording_report(
            args.output, f"avtrack: AV16.3 sequence {args.seq}, camera {args.cam}",
            res.tracks, iter_frames(video.path, video), video.image_size, res.fps,
            res.n_frames, speaking=res.speaking, persons=res.persons, speech=res.speech or [],
            scores=av163_scores(res),
            notes=["OSPA: mean over frames of the OSPA distance (order 2, cut-off 50 px) "
                   "between the persons reported in the image (persons.csv x, y) and the "
                   "mouths of the ground truth (posGT, people present per X_true); lower is "
                   "better"])


# ------------------------------------------------------------------ a recording of one's own


def run_recording(args: argparse.Namespace) -> int:
    """A recording of the user's own: video (or detections), audio (or DOA), camera file."""
    if args.model != "direction":
        raise InputError("a recording of your own is tracked with --model direction (the image "
                         "model's mapping is trained on a simulated calibration of a scene)")
    config = load_person_config(args.config, args.threshold)  # its errors first, as elsewhere
    inputs = _recording_inputs(args)
    _check_output(args.output)
    res = track_own_recording(inputs, config, use_audio=not args.no_audio,
                              vad=not args.no_vad, voices=args.voices, strict=args.strict,
                              stage=_stage(args))
    if not args.quiet:
        source = "the video's header" if res.fps_from_video else "--fps"
        print(f"frame rate: {res.fps:g} fps (from {source}; --fps sets it)")
        if res.audio_fs is not None and res.audio_fs != FS:
            print(f"avtrack: note: {args.audio} is at {res.audio_fs} Hz; resampling to {FS} Hz",
                  file=sys.stderr)
    write_outputs(args.output, res)
    _camera_outputs(args, res)
    if not args.no_report:  # over the video's frames, or a plain canvas without a video
        video = res.video
        frames = None if video is None else iter_frames(video.path, video)
        size = (res.camera.width, res.camera.height) if video is None else video.image_size
        title = video.path.name if video is not None else Path(args.detections).name
        with progress.activity(f"drawing the tracks over {res.n_frames} frames", args.quiet):
            write_recording_report(
                args.output, f"avtrack: {title}", res.tracks, frames, size, res.fps,
                res.n_frames, speaking=res.speaking, persons=res.persons,
                speech=res.speech or [])
    if not args.quiet:
        print(summary(res, args.output))
    return 0


def _recording_inputs(args: argparse.Namespace) -> RecordingInputs:
    """The options of a recording of one's own, checked against each other."""
    if args.camera is None:
        raise InputError("give SCENE_DIR, or a recording: --camera CAMERA.yaml with --video "
                         "or --detections, and --audio --array or --doa")
    if args.plot or args.mapping is not None:
        raise InputError("--plot and --mapping belong to --model image on a scene directory")
    auto = str(args.camera) == "auto" and not args.camera.is_file()
    if auto and args.no_audio:
        raise InputError("--camera auto estimates the camera from the people seen talking: it "
                         "needs the audio (not --no-audio)")
    if args.doa is None and not args.no_audio and (args.audio is None or args.array is None):
        raise InputError("give --audio FILE.wav with --array ARRAY, or --doa DOA.csv (or use "
                         "--no-audio)")
    use_audio = args.audio is not None and not args.no_audio
    if use_audio and args.array is None:
        raise InputError("--audio needs --array (WAV channel k is microphone k)")
    if args.detections is not None and args.detector is not None:
        raise InputError("--detector detects in --video's frames: give it without "
                         "--detections")
    if args.appearance is not None and args.detections is None:
        raise InputError("--appearance gives one row per --detections row: give both")
    return RecordingInputs(
        camera=None if auto else args.camera, video=args.video, detections=args.detections,
        appearance=args.appearance, detector=args.detector,
        audio=args.audio if use_audio else None,
        array=load_array(args.array) if use_audio else None,
        allow_clipping=args.allow_clipping, doa=args.doa,
        fps=args.fps, image_size=_image_size(args, auto),
        camera_position=_camera_position(args, auto))


def _camera_position(args: argparse.Namespace, auto: bool) -> tuple[float, ...] | None:
    """--camera-position X,Y,Z in metres, for --camera auto (three finite numbers: checked by
    :class:`RecordingInputs`)."""
    if args.camera_position is None:
        return None
    if not auto:
        raise InputError("--camera-position is for --camera auto (a camera file gives its "
                         "own position)")
    try:
        return tuple(float(t) for t in args.camera_position.split(","))
    except ValueError:
        raise InputError(f"--camera-position: expected X,Y,Z in metres (e.g. -1.6,1.6,1.4), "
                         f"got {args.camera_position!r}") from None


def _image_size(args: argparse.Namespace, auto: bool) -> tuple[int, int] | None:
    """--image-size: the detections' image size, for --camera auto without --video."""
    if args.image_size is None:
        return None
    if args.video is not None or not auto:
        raise InputError("--image-size is for --camera auto without --video (the video or "
                         "the camera file gives the size otherwise)")
    try:
        w, h = (int(t) for t in args.image_size.lower().split("x"))
    except ValueError:
        raise InputError(f"--image-size: expected WIDTHxHEIGHT in pixels (e.g. 640x480), "
                         f"got {args.image_size!r}") from None
    if w <= 0 or h <= 0:
        raise InputError(f"--image-size must be positive, got {args.image_size!r}")
    return w, h


def _camera_outputs(args: argparse.Namespace, res: RecordingRun) -> None:
    """--camera auto: the estimate printed and written as OUT_DIR/CAMERA.yaml; a camera file:
    what its check against the recording found (warnings on stderr)."""
    if res.camera_fit is not None:
        _write_text(args.output / "CAMERA.yaml", camera_yaml(res.camera_fit))
        if not args.quiet:
            print(f"{res.camera_fit.summary()} -> {args.output / 'CAMERA.yaml'}")
    if res.camera_check is not None:
        _print_check(res.camera_check, args.camera.name, args.quiet)


def _print_check(chk: CameraCheck, name: str, quiet: bool) -> None:
    for msg in chk.warnings:
        print(f"warning: {msg}", file=sys.stderr)
    if not quiet:
        for note in chk.notes:
            print(f"note: {note}", file=sys.stderr)
        if chk.fit is not None and not chk.warnings:
            print(f"{name} agrees with the recording ({chk.fit.summary()})")


def camera_yaml(fit: CameraFit) -> str:
    """CAMERA.yaml of an estimated camera, its uncertainty and evidence as comments."""
    head = "\n".join("# " + line for line in textwrap.wrap(
        "estimated by avtrack track-av --camera auto: " + fit.summary(), 95)) + "\n"
    return head + yaml.safe_dump(fit.camera.to_json(), sort_keys=False)
