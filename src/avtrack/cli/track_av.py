"""``avtrack track-av``: audio-visual tracking and diarization of a scene directory.

Two models: ``direction`` (default), persons in the array's direction space
(:mod:`avtrack.av.persons`), who stay tracked out of the camera's view and are born from
audio too; ``image``, the thesis's image-plane model (VAVIT, :mod:`avtrack.av.vavit`)
with its learned GLLiM audio-to-image mapping.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from avtrack.cli import progress
from avtrack.cli.base import add_array_option, add_clipping_option, add_command, add_common
from avtrack.config import load_config
from avtrack.errors import InputError
from avtrack.io.camera import read_camera_file
from avtrack.io.mot import write_mot
from avtrack.io.rttm import write_rttm
from avtrack.visual.detect import DEFAULT_FACE_DETECTOR, DETECTORS

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
image --plot); with --video (a recording of your own, AV16.3), OUT_DIR/index.html and
OUT_DIR/tracks.webm: the tracks over the video's own frames (--no-report: not written).

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
No camera file: --camera auto estimates yaw, focal length (and pitch from a DOA CSV's
elevations) from the people seen talking, prints it with its uncertainty and writes
OUT_DIR/CAMERA.yaml; a camera file given is checked against the recording the same way
(a warning names the likely mistake; --strict: exit 2):
  avtrack track-av --video rec.mp4 --audio rec.wav --array nao4 --camera auto -o out

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
    rec = p.add_argument_group(
        "a recording of your own (instead of SCENE_DIR; direction model)")
    rec.add_argument("--video", type=Path, metavar="FILE",
                     help="the camera's video (its frame rate, length and size are used)")
    rec.add_argument("--audio", type=Path, metavar="FILE.wav",
                     help="the array's recording; WAV channel k is microphone k of --array")
    add_array_option(rec, required=False,
                     note=", the microphones of --audio (positions in the array frame)")
    rec.add_argument("--camera", type=Path, metavar="CAMERA.yaml",
                     help="camera intrinsics, image size and pose in the array frame (see "
                     "below), checked against the recording (a warning names a likely mistake); "
                     "'auto': estimate the camera's yaw, pitch (when the DOA CSV has "
                     "elevations) and focal length from the people seen talking, the camera "
                     "at the array's centre, and write it as OUT_DIR/CAMERA.yaml")
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
    av = p.add_argument_group("AV16.3 (SCENE_DIR is a folder of AV16.3 MAT files; with --video)")
    av.add_argument("--seq", type=int, metavar="N", help="AV16.3 sequence number")
    av.add_argument("--cam", type=int, choices=(1, 2, 3), help="AV16.3 camera")
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
        help="with --video: do not write OUT_DIR/index.html and OUT_DIR/tracks.webm (the "
        "tracks drawn over the video's own frames, the persons' directions, who speaks when)",
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
        "tracked direction, silent outside their speaker turns; as microphone 0 hears it)",
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
    add_common(p, run)


def load_vavit_config(path: Path | None, threshold: float | None):
    """VAVITConfig from ``--config`` (``visual:`` overrides the default visual fields), with
    ``--threshold`` on top."""
    from avtrack.av.vavit import VAVITConfig

    return load_config(path, VAVITConfig, overrides={"diarization_threshold": threshold})


def mapping_with_progress(scene, n_positions: int, verbose: bool, quiet: bool = False):
    """:func:`avtrack.simulate.calibration.train_scene_mapping` with a progress note."""
    from avtrack.simulate.calibration import mapping_cache_dir, train_scene_mapping

    t0 = time.perf_counter()
    with progress.activity(
        f"audio-to-image mapping (calibration with {n_positions} loudspeaker positions and "
        f"training, unless cached)", quiet
    ):
        mapping, cached = train_scene_mapping(scene, n_positions)
    if verbose:
        how = (f"read from the cache ({mapping_cache_dir()})" if cached
               else "trained on a simulated calibration and cached")
        print(f"audio-to-image mapping {how} ({time.perf_counter() - t0:.1f} s)",
              file=sys.stderr)
    return mapping


def load_person_config(path: Path | None, threshold: float | None):
    """PersonConfig from ``--config`` (the visual tracker's fields under ``visual:``), with
    ``--threshold`` on top."""
    from avtrack.av.persons import PersonConfig

    return load_config(path, PersonConfig, overrides={"speaking_threshold": threshold})


def run(args: argparse.Namespace) -> int:
    if not 0 < args.fov_fraction <= 1:
        raise InputError(f"--fov-fraction must be in (0, 1], got {args.fov_fraction}")
    own = [o for o in ("video", "audio", "camera", "detections", "doa", "fps", "detector",
                       "array", "appearance", "image_size") if getattr(args, o) is not None]
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
                         f"give it without "
                         f"SCENE_DIR")
    if args.model == "direction" and not args.no_audio:
        return run_direction(args)
    return run_image(args)


def _track_and_write(out: Path, what: str, quiet: bool, speech: bool, track):
    """Check OUT_DIR, run ``track()`` (a PersonsResult; its ValueErrors are input errors),
    write tracks.txt, persons.csv and (``speech``) speech.rttm; returns the result and the
    seconds it took."""
    if out.exists() and not out.is_dir():
        raise InputError("output exists and is not a directory", out)
    t0 = time.perf_counter()
    with progress.activity(what, quiet):
        try:
            res = track()
        except ValueError as exc:
            raise InputError(str(exc)) from None
    elapsed = time.perf_counter() - t0
    out.mkdir(parents=True, exist_ok=True)
    write_mot(out / "tracks.txt", res.tracks)
    _write_text(out / "persons.csv", res.persons.to_csv())
    if speech:
        write_rttm(out / "speech.rttm", res.speech)
    return res, elapsed


def run_av163(args: argparse.Namespace) -> int:
    """SCENE_DIR is an AV16.3 folder: its real video, DOA measurements and calibration."""
    from avtrack.av.av163 import track_av163
    from avtrack.io.av163 import load_av163

    if args.seq is None or args.cam is None or args.scene is None or args.video is None:
        raise InputError("AV16.3: give the folder, --seq N, --cam C and --video FILE")
    if args.seq < 1:
        raise InputError(f"--seq must be a positive integer, got {args.seq}")
    for o in ("audio", "camera", "detections", "doa", "fps", "array", "appearance",
              "mapping"):
        if getattr(args, o) is not None:
            raise InputError(f"--{o} does not apply to AV16.3 (its calibration, DOAs and video "
                             f"are used)")
    if args.model != "direction" or args.no_audio or args.plot:
        raise InputError("AV16.3 is tracked with --model direction, with audio")
    if not args.scene.is_dir():
        raise InputError("AV16.3 folder not found", args.scene)
    config = load_person_config(args.config, args.threshold)
    seq = load_av163(args.scene, args.seq, args.cam)
    detector = None
    if args.detector is not None:
        from avtrack.visual.detect import load_detector

        detector = load_detector(args.detector)
    out = args.output
    res, elapsed = _track_and_write(
        out, f"detecting and tracking {seq.n_frames} frames", args.quiet, True,
        lambda: track_av163(seq, args.video, detector, config=config)[0])
    if not args.no_report:
        _av163_report(args, seq, res)
    if not args.quiet:
        duration = seq.n_frames / res.fps
        print(f"AV16.3 seq {args.seq} cam {args.cam}: tracked {seq.n_frames} frames "
              f"({duration:.1f} s): {len(np.unique(res.persons.ids))} persons, "
              f"{len(res.tracks)} boxes, {len(res.speech)} speaker turns of "
              f"{len({s.speaker for s in res.speech})} speakers -> {out} ({elapsed:.1f} s, "
              f"real-time factor {elapsed / max(duration, 1e-9):.2f})")
    return 0


def _av163_report(args: argparse.Namespace, seq, res) -> None:
    """index.html of an AV16.3 run: the persons seen in the image against ``posGT``."""
    from avtrack.io.video import iter_frames, probe_video
    from avtrack.metrics.ospa import ospa_sequence
    from avtrack.phd.likelihood import av163_truth
    from avtrack.viz.recording import write_recording_report

    P = res.persons
    seen = P.in_view & np.all(np.isfinite(P.pixels), axis=1)
    est = [P.pixels[seen & (P.frames == f)] for f in seq.frames]
    ospa = ospa_sequence(est, av163_truth(seq), 50.0, 2)[:, 0]
    video = probe_video(args.video)
    with progress.activity(f"drawing the tracks over {video.n_frames} frames", args.quiet):
        write_recording_report(
            args.output, f"avtrack: AV16.3 sequence {args.seq}, camera {args.cam}",
            res.tracks, iter_frames(video.path, video), video.image_size, res.fps,
            seq.n_frames, speaking=res.speaking, persons=P, speech=res.speech,
            scores={"OSPA (px)": float(np.mean(ospa)),
                    "persons": float(len(np.unique(P.ids))),
                    "speakers": float(len({s.speaker for s in res.speech}))},
            notes=["OSPA: mean over frames of the OSPA distance (order 2, cut-off 50 px) "
                   "between the persons reported in the image (persons.csv x, y) and the "
                   "mouths of the ground truth (posGT, people present per X_true); lower is "
                   "better"])


def run_direction(args: argparse.Namespace) -> int:
    """--model direction: persons in the array's direction space."""
    from avtrack.av.persons_scene import track_scene_persons
    from avtrack.io.scene import load_scene

    if args.plot:
        raise InputError("--plot draws the image-plane model's covariances; use --model image")
    if args.mapping is not None:
        raise InputError("--mapping is the image-plane model's audio-to-image mapping; the "
                         "direction model maps geometrically (use --model image)")
    config = load_person_config(args.config, args.threshold)
    scene = load_scene(args.scene)
    out = args.output
    if out.exists() and not out.is_dir():
        raise InputError("output exists and is not a directory", out)
    t0 = time.perf_counter()
    try:
        with progress.activity(f"tracking {scene.n_frames} frames", args.quiet):
            res = track_scene_persons(
                scene, fov_fraction=args.fov_fraction, config=config,
                vad=False if args.no_vad else None,
            )
    except InputError:
        raise
    except ValueError as exc:
        raise InputError(str(exc), args.scene) from None
    elapsed = time.perf_counter() - t0
    out.mkdir(parents=True, exist_ok=True)
    write_mot(out / "tracks.txt", res.tracks)
    _write_text(out / "persons.csv", res.persons.to_csv())
    write_rttm(out / "speech.rttm", res.speech)
    if args.voices:
        from avtrack.audio.arrays import load_array

        t0 = time.perf_counter()
        _write_voices(out, scene.audio, scene.fs, load_array(scene.path / "array.json"), res,
                      args.quiet)
        elapsed += time.perf_counter() - t0
    if not args.quiet:
        _print_summary(res, len(np.unique(res.persons.ids)), out, elapsed)
    return 0


def _write_voices(out: Path, audio: np.ndarray, fs: int, array, res, quiet: bool) -> None:
    """OUT_DIR/voices/<id>.wav: each tracked person's voice (:mod:`avtrack.audio.beamform`)."""
    from avtrack.audio.beamform import extract_voices, tracks_from_persons, write_voices

    if audio.shape[0] != array.n_mics:
        raise InputError(f"--voices: the audio has {audio.shape[0]} channels, the array "
                         f"{array.n_mics} microphones")
    tracks = tracks_from_persons(res.persons, res.speech)
    with progress.activity(f"beamforming {len(tracks)} voices", quiet):
        try:
            voices = extract_voices(audio, fs, array, tracks)
        except ValueError as exc:
            raise InputError(f"--voices: {exc}") from None
    write_voices(out / "voices", voices, fs)




def run_recording(args: argparse.Namespace) -> int:
    """A recording of the user's own: video (or detections), audio (or DOA), camera file."""
    from avtrack.audio.arrays import load_array
    from avtrack.audio.recording import read_array_audio
    from avtrack.av.geometry import CameraGeometry
    from avtrack.av.persons_scene import (
        PERSONS_LOCALIZER,
        audio_peak_floor,
        audio_peaks,
        localizer_grid,
        track_persons,
    )
    from avtrack.io.mot import read_mot

    if args.model != "direction":
        raise InputError("a recording of your own is tracked with --model direction (the image "
                         "model's mapping is trained on a simulated calibration of a scene)")
    config = load_person_config(args.config, args.threshold)  # its errors first, as elsewhere
    if args.camera is None:
        raise InputError("give SCENE_DIR, or a recording: --camera CAMERA.yaml with --video "
                         "or --detections, and --audio --array or --doa")
    if args.plot or args.mapping is not None:
        raise InputError("--plot and --mapping belong to --model image on a scene directory")
    auto = str(args.camera) == "auto" and not args.camera.is_file()
    if auto and args.no_audio:
        raise InputError("--camera auto estimates the camera from the people seen talking: it "
                         "needs the audio (not --no-audio)")
    camera = None if auto else read_camera_file(args.camera)
    video = None
    if args.video is not None:
        from avtrack.io.video import probe_video

        video = probe_video(args.video)
        if camera is not None and video.image_size != (camera.width, camera.height):
            raise InputError(f"the camera file says {camera.width}x{camera.height}, the video "
                             f"is {video.width}x{video.height}", args.camera)
    image_size = _image_size(args, video, camera)
    fps = args.fps if args.fps is not None else (video.fps if video is not None else None)
    if fps is None or not (np.isfinite(fps) and 0 < fps <= 1000):
        raise InputError("--fps: give the frame rate (frames per second) when there is no "
                         "--video" if fps is None else f"--fps must be in (0, 1000], got {fps}")
    if not args.quiet:
        source = "--fps" if args.fps is not None else "the video's header"
        print(f"frame rate: {fps:g} fps (from {source}; --fps sets it)")
    # audio: directions computed elsewhere, or the array's recording localized here
    audio = None
    if args.doa is None and not args.no_audio and (args.audio is None or args.array is None):
        raise InputError("give --audio FILE.wav with --array ARRAY, or --doa DOA.csv (or use "
                         "--no-audio)")
    if args.audio is not None and not args.no_audio:
        if args.array is None:
            raise InputError("--audio needs --array (WAV channel k is microphone k)")
        array = load_array(args.array)
        audio = read_array_audio(args.audio, array, args.allow_clipping, quiet=args.quiet)
    # frames
    if video is not None:
        n_frames = video.n_frames
        if audio is not None:
            a_s, v_s = audio.shape[1] / 16000.0, video.n_frames / fps
            if abs(a_s - v_s) > max(1.0, 0.02 * v_s):
                raise InputError(f"the audio lasts {a_s:.2f} s, the video {v_s:.2f} s "
                                 f"({video.n_frames} frames at {fps:g} fps): not one recording?",
                                 args.audio)
    elif audio is not None:
        n_frames = int(np.floor(audio.shape[1] / 16000.0 * fps + 1e-9))
    else:
        n_frames = 0
    # detections
    if args.detections is not None:
        if args.detector is not None:
            raise InputError("--detector detects in --video's frames: give it without "
                             "--detections")
        dets = read_mot(args.detections, kind="det")
        n_frames = max(n_frames, dets.n_frames)
    elif video is not None:
        from avtrack.cli.track_mot import detect_in_video

        dets = detect_in_video(args.video, args.detector or DEFAULT_FACE_DETECTOR, args.quiet)
    else:
        raise InputError("give --video (detections found in its frames) or --detections")
    if n_frames < 1:
        raise InputError("nothing to track: no frames")
    appearance = None
    if args.appearance is not None:
        from avtrack.cli.track_mot import load_appearance

        if args.detections is None:
            raise InputError("--appearance gives one row per --detections row: give both")
        appearance = load_appearance(args.appearance, len(dets))
    if video is not None:
        from avtrack.cli.track_mot import check_against_video
        from avtrack.io.video import iter_frames
        from avtrack.visual.histograms import detection_histograms

        check_against_video(dets, video, args.detections or args.video)
        if appearance is None:
            with progress.activity(f"colour histograms of {len(dets)} boxes", args.quiet):
                appearance = detection_histograms(iter_frames(video.path, video), dets,
                                                  n_frames)
    peaks, span = None, 360.0
    heat = grid = activity = None
    if not args.no_audio:
        if args.doa is not None:
            from avtrack.io.doa import azimuths_per_frame, read_doa_csv

            peaks = azimuths_per_frame(read_doa_csv(args.doa), fps, n_frames)
        else:
            from avtrack.localize import make_localizer

            if audio is None:  # (read above: no --doa needs --audio without --no-audio)
                raise InputError("give --audio (with --array) or --doa DOA.csv")
            grid = localizer_grid(array)
            loc = make_localizer(PERSONS_LOCALIZER, array, grid)
            with progress.activity(f"localizing {audio.shape[1] / 16000:.1f} s", args.quiet):
                heat = loc.run(audio)
            peaks = audio_peaks(heat.weights, heat.time_s, grid, fps, n_frames,
                                floor=audio_peak_floor(PERSONS_LOCALIZER))
            span = 360.0 if grid.circular else float(np.ptp(grid.azimuth_values) + 5.0)
            if not args.no_vad:
                from avtrack.audio.recording import FS
                from avtrack.av.vad import vad_available, voice_activity, warn_vad_missing

                if vad_available():
                    activity = voice_activity(audio[0], FS)
                else:
                    warn_vad_missing()
    if peaks is not None:
        camera = _calibrate(args, camera, dets, peaks, fps, image_size, n_frames)
    if camera is None:
        raise InputError("--camera auto needs the audio's directions")
    geometry = CameraGeometry(camera, np.zeros(3), 0.0)
    vcfg = config.visual
    if args.appearance is None and appearance is not None and vcfg.appearance != "bhattacharyya":
        from dataclasses import replace

        vcfg = replace(vcfg, appearance="bhattacharyya", appearance_lambda=2.0)
    out = args.output
    res, elapsed = _track_and_write(
        out, f"tracking {n_frames} frames", args.quiet, peaks is not None,
        lambda: track_persons(dets, appearance, peaks, geometry, fps, n_frames,
                              visual_config=vcfg, config=config, azimuth_span_deg=span,
                              heat=heat, grid=grid, activity=activity))
    if args.voices:
        if audio is None:
            raise InputError("--voices needs --audio with --array (the microphones to beamform)")
        from avtrack.audio.recording import FS

        _write_voices(out, audio, FS, array, res, args.quiet)
    if video is not None and not args.no_report:
        from avtrack.io.video import iter_frames
        from avtrack.viz.recording import write_recording_report

        with progress.activity(f"drawing the tracks over {n_frames} frames", args.quiet):
            write_recording_report(
                out, f"avtrack: {args.video.name}", res.tracks, iter_frames(video.path, video),
                video.image_size, fps, n_frames, speaking=res.speaking, persons=res.persons,
                speech=res.speech)
    if not args.quiet:
        print(f"tracked {n_frames} frames ({n_frames / fps:.1f} s): "
              f"{len(np.unique(res.persons.ids))} persons, {len(res.tracks)} boxes, "
              f"{len(res.speech)} speaker turns of {len({s.speaker for s in res.speech})} "
              f"speakers -> {out} ({elapsed:.1f} s)")
    return 0


def _image_size(args: argparse.Namespace, video, camera) -> tuple[int, int]:
    """The image size: the video's, the camera file's, or --image-size."""
    if args.image_size is not None:
        if video is not None or camera is not None:
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
    if video is not None:
        return video.image_size
    if camera is not None:
        return camera.width, camera.height
    raise InputError("--camera auto without --video: give the detections' image size with "
                     "--image-size WIDTHxHEIGHT")


def _calibrate(args: argparse.Namespace, camera, dets, peaks, fps: float,
               image_size: tuple[int, int], n_frames: int):
    """--camera auto: the camera estimated from the recording, printed and written as
    OUT_DIR/CAMERA.yaml; a camera file: checked against the recording (warnings; --strict:
    an error). Returns the camera to track with."""
    from avtrack.av.calibrate import camera_evidence, check_camera, fit_camera

    elevations = None
    if args.doa is not None:
        from avtrack.io.doa import directions_per_frame, read_doa_csv

        peaks, elevations = directions_per_frame(read_doa_csv(args.doa), fps, n_frames)
    ev = camera_evidence(dets, peaks, fps, image_size, elevations)
    if camera is None:
        try:
            with progress.activity("estimating the camera from the people seen talking",
                                   args.quiet):
                fit = fit_camera(ev)
        except ValueError as exc:
            raise InputError(f"--camera auto: {exc}") from None
        out = args.output
        if out.exists() and not out.is_dir():
            raise InputError("output exists and is not a directory", out)
        out.mkdir(parents=True, exist_ok=True)
        _write_text(out / "CAMERA.yaml", camera_yaml(fit))
        if not args.quiet:
            print(f"{fit.summary()} -> {out / 'CAMERA.yaml'}")
        return fit.camera
    with progress.activity(f"checking {args.camera.name} against the recording", args.quiet):
        chk = check_camera(camera, ev, name=args.camera.name)
    for msg in chk.warnings:
        if args.strict:
            raise InputError(f"--strict: {msg}", args.camera)
        print(f"warning: {msg}", file=sys.stderr)
    if not args.quiet:
        for note in chk.notes:
            print(f"note: {note}", file=sys.stderr)
        if chk.fit is not None and not chk.warnings:
            print(f"{args.camera.name} agrees with the recording ({chk.fit.summary()})")
    return camera


def camera_yaml(fit) -> str:
    """CAMERA.yaml of an estimated camera, its uncertainty and evidence as comments."""
    import yaml

    head = "\n".join("# " + line for line in _wrap(
        "estimated by avtrack track-av --camera auto: " + fit.summary())) + "\n"
    return head + yaml.safe_dump(fit.camera.to_json(), sort_keys=False)


def _wrap(text: str) -> list[str]:
    import textwrap

    return textwrap.wrap(text, 95)


def _print_summary(res, n_persons: int, out: Path, elapsed: float) -> None:
    """One line: frames, persons, boxes, speaker turns, output, time and real-time factor."""
    duration = res.timing["duration"]
    speakers = len({s.speaker for s in res.speech})
    print(
        f"tracked {res.n_frames} frames ({duration:.1f} s): {n_persons} persons, "
        f"{len(res.tracks)} boxes, {len(res.speech)} speaker turns of {speakers} speakers "
        f"-> {out} ({elapsed:.1f} s, real-time factor {elapsed / max(duration, 1e-9):.2f})"
    )


def _write_text(path: Path, text: str) -> None:
    from avtrack.io.base import atomic_write

    with atomic_write(path) as fh:
        fh.write(text)


def image_persons(res, scene):
    """``persons.csv`` rows of an image-plane result: each reported box's direction."""
    from avtrack.av.persons_scene import PersonsTable, scene_geometry

    tr = res.tracks
    if scene.scenario is None or len(tr) == 0:
        az = el = np.zeros(len(tr))
    else:
        az, el, _ = scene_geometry(scene).boxes_to_directions(tr.boxes)
    centre = tr.boxes[:, :2] + 0.5 * tr.boxes[:, 2:]
    lo, hi = res.fov
    in_view = (centre[:, 0] >= lo) & (centre[:, 0] <= hi)
    return PersonsTable(tr.frames, tr.ids, az, el, centre, in_view,
                        res.speaking.astype(float), res.fps)


def run_image(args: argparse.Namespace) -> int:
    """--model image (VAVIT) and --no-audio (OVBT)."""
    from avtrack.av.gllim import load_mapping, save_mapping
    from avtrack.av.vavit import track_scene
    from avtrack.io.scene import load_scene

    config = load_vavit_config(args.config, args.threshold)
    if args.calibration_positions < 4:
        raise InputError(f"--calibration-positions must be >= 4, got {args.calibration_positions}")
    scene = load_scene(args.scene)
    out = args.output
    if out.exists() and not out.is_dir():
        raise InputError("output exists and is not a directory", out)
    mapping = None
    if not args.no_audio:
        if args.mapping is not None:
            mapping = load_mapping(args.mapping)
        else:
            mapping = mapping_with_progress(
                scene, args.calibration_positions, not args.quiet, args.quiet
            )
            out.mkdir(parents=True, exist_ok=True)
            save_mapping(out / "mapping.npz", mapping)
    t0 = time.perf_counter()
    try:
        with progress.activity(f"tracking {scene.n_frames} frames", args.quiet):
            res = track_scene(
                args.scene,
                mapping,
                config,
                use_audio=not args.no_audio,
                fov_fraction=args.fov_fraction,
                record_precisions=args.plot,
                scene=scene,
            )
    except InputError:
        raise
    except ValueError as exc:  # e.g. detections or features inconsistent with the scene
        raise InputError(str(exc), args.scene) from None
    elapsed = time.perf_counter() - t0
    out.mkdir(parents=True, exist_ok=True)
    write_mot(out / "tracks.txt", res.tracks)
    _write_text(out / "persons.csv", image_persons(res, scene).to_csv())
    if not args.no_audio:
        write_rttm(out / "speech.rttm", res.speech)
    if args.plot:
        from avtrack.viz.plots import plot_covariances

        plot_covariances(res, out / "covariances.png", args.no_audio)
    if not args.quiet:
        _print_summary(res, len(np.unique(res.tracks.ids)), out, elapsed)
    return 0






