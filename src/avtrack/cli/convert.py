"""``avtrack convert``: a dataset's files as the inputs of a recording of one's own.

Formats (each its own sub-command): ``av16.3`` — an AV16.3 sequence's DOA measurements and
camera calibration as the DOA CSV and CAMERA.yaml of ``track-av --video --doa --camera``
(:mod:`avtrack.io.av163_export`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from avtrack.cli.base import add_command, add_common, add_options_option
from avtrack.errors import InputError
from avtrack.io.av163_export import AV163_EXPORT_ARRAYS

#: The files ``convert av16.3`` writes in OUT_DIR.
AV163_OUTPUTS = ("doa.csv", "camera.yaml")

EXAMPLES = """\
examples:
  avtrack convert av16.3 ../shared/data/av16.3 --seq 30 --cam 1 -o av30
  avtrack convert av16.3 --help
"""

AV163_EXAMPLES = """\
examples:
  # sequence 30 seen by camera 1, in microphone array 1's frame: av30/doa.csv, av30/camera.yaml
  avtrack convert av16.3 ../shared/data/av16.3 --seq 30 --cam 1 --array 1 -o av30

  # then track the video as a recording of your own (default detector: yunet-face) ...
  avtrack track-av --video ../shared/data/av16.3/seq30-2p-1101_cam1_divx_audio.avi \\
      --doa av30/doa.csv --camera av30/camera.yaml -o out/av30-generic

  # ... or face detections of your own, at the video's 25 frames per second
  avtrack track-av --detections det.txt --fps 25 --doa av30/doa.csv \\
      --camera av30/camera.yaml -o out/av30-det

DATA_DIR holds the sequence's data_av_seqNN_camC.mat, DOA_measurements_seqNN_camC.mat and
hist_temp_16bins_seqNN_camC.mat. doa.csv: one row per azimuth of Z_doa, frame k (0-based video
frame) at time k / 25 s, elevation 0 (not measured). camera.yaml: the calibration's pinhole part
in the array's frame (metres); the lens distortion and the roll about the optical axis, which
CAMERA.yaml cannot hold, are named in its comments. Existing outputs are kept unless --force;
an input is never overwritten.
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = add_command(
        subparsers,
        "convert",
        help="a dataset's files as track-av's inputs (DOA CSV, CAMERA.yaml)",
        description="""\
Write a dataset's measurements and calibration as the files a recording of your own is tracked
with (avtrack track-av --video --doa --camera). Choose the dataset below.""",
        epilog=EXAMPLES,
    )
    formats = parser.add_subparsers(dest="convert_format", metavar="FORMAT", required=True)
    _add_av163(formats)


def _add_av163(formats: argparse._SubParsersAction) -> None:
    p = add_command(
        formats,
        "av16.3",
        help="an AV16.3 sequence's DOA measurements and camera as doa.csv and camera.yaml",
        description="""\
Write OUT_DIR/doa.csv (the sequence's DOA measurements, Z_doa of microphone array 1, one row
per azimuth at the video frame it belongs to) and OUT_DIR/camera.yaml (the camera's
calibration as a pinhole camera in the array's frame, metres) from the AV16.3 files as the
SMC-PHD authors distribute them.""",
        epilog=AV163_EXAMPLES,
    )
    p.add_argument("folder", type=Path, metavar="DATA_DIR", help="folder of AV16.3 MAT files")
    p.add_argument("--seq", type=int, required=True, metavar="N", help="sequence number")
    p.add_argument("--cam", type=int, choices=(1, 2, 3), required=True, help="camera")
    p.add_argument("--array", type=int, choices=AV163_EXPORT_ARRAYS, default=1,
                   help="microphone array whose frame the files are in (default 1: the "
                   "DOA_measurements files hold array 1's azimuths)")
    p.add_argument("-o", "--output", dest="out_dir", type=Path, required=True,
                   metavar="OUT_DIR", help="output folder (created), for doa.csv and camera.yaml")
    add_common(p, run_av163)
    add_options_option(p)


def _av163_inputs(folder: Path, seq: int, cam: int) -> list[Path]:
    """The files :func:`~avtrack.io.av163.load_av163` reads, or an InputError naming the
    sequences and cameras the folder has."""
    if not folder.is_dir():
        what = "is not a folder" if folder.exists() else "not found"
        raise InputError(f"AV16.3 folder {what}", folder)
    files = [folder / f"data_av_seq{seq}_cam{cam}.mat",
             folder / f"DOA_measurements_seq{seq}_cam{cam}.mat",
             folder / f"hist_temp_16bins_seq{seq}_cam{cam}.mat"]
    missing = [f.name for f in files if not f.is_file()]
    if missing:
        have = sorted(p.name.removeprefix("data_av_").removesuffix(".mat")
                      for p in folder.glob("data_av_seq*_cam*.mat"))
        there = f"it has {', '.join(have)}" if have else "it has no data_av_seqNN_camC.mat"
        raise InputError(f"no AV16.3 sequence {seq} camera {cam} here: {', '.join(missing)} "
                         f"not found ({there})", folder)
    return files


def _check_outputs(out: Path, inputs: list[Path], force: bool) -> list[Path]:
    """OUT_DIR's files, checked: never an input, existing ones only with --force."""
    if out.exists() and not out.is_dir():
        raise InputError("-o must be a folder; this is a file", out)
    targets = [out / name for name in AV163_OUTPUTS]
    for target in targets:
        if not target.exists():
            continue
        for inp in inputs:
            if target.samefile(inp):
                raise InputError(f"this output is the input {inp}: refusing to overwrite it",
                                 target)
        if target.is_dir():
            raise InputError("this output is a folder", target)
        if not force:
            raise InputError("the output file exists; give --force to overwrite it", target)
    return targets


def run_av163(args: argparse.Namespace) -> int:
    from avtrack.io.av163 import load_av163
    from avtrack.io.av163_export import camera_yaml_from_av163, doa_csv_from_av163

    if args.seq < 1:
        raise InputError(f"--seq must be a positive integer, got {args.seq}")
    inputs = _av163_inputs(args.folder, args.seq, args.cam)
    doa_path, camera_path = _check_outputs(args.out_dir, inputs, args.force)
    seq = load_av163(args.folder, args.seq, args.cam)
    args.out_dir.mkdir(parents=True, exist_ok=True)
    table = doa_csv_from_av163(seq, doa_path, args.array)
    camera = camera_yaml_from_av163(seq, camera_path, args.array)
    if not args.quiet:
        n_frames = len(set(table.frames.tolist()))
        distance = float(sum(v * v for v in camera.position)) ** 0.5
        print(f"AV16.3 sequence {args.seq}, camera {args.cam}, in microphone array "
              f"{args.array}'s frame: {doa_path} ({len(table)} azimuths on {n_frames} of "
              f"{seq.n_frames} frames), {camera_path} (the camera {distance:.2f} m from the "
              f"array, yaw {camera.yaw_deg:.1f} deg, pitch {camera.pitch_deg:.1f} deg)")
        if args.verbose:
            print(f"track it: avtrack track-av --video VIDEO --doa {doa_path} --camera "
                  f"{camera_path} -o OUT_DIR (VIDEO: the sequence's video from camera "
                  f"{args.cam}, {seq.n_frames} frames)")
    return 0
