"""AV16.3 tracked as a recording of one's own, beside the dataset path.

For every sequence and camera in ``../shared/data/av16.3``:

1. ``avtrack convert av16.3 DIR --seq N --cam C -o TMP`` writes ``doa.csv`` and
   ``camera.yaml`` (:mod:`avtrack.io.av163_export`); the script prints how far the camera file
   puts the 3-D mouths (``MouthGT3D``) from ``posGT`` and how far the DOA rows lie from the
   nearest mouth azimuth of their frame.
2. The generic path, as a user runs it: ``avtrack track-av --video VIDEO --doa TMP/doa.csv
   --camera TMP/camera.yaml`` (the default face detector, ``yunet-face``) where the sequence's
   video is there; ``--detections`` of the file ``face_seqNN_camC.mat`` with ``--fps 25`` (no
   appearance) where only those are.
3. The dataset path on the same video: ``avtrack track-av DIR --seq N --cam C --video VIDEO``
   with its default detector and with ``--detector yunet-face`` (it needs the video).

Score: the dataset path's (``track-av``'s AV16.3 report): OSPA, order 2, cut-off 50 px,
between the persons of ``persons.csv`` shown in the image (``in_view``, finite ``x, y``) and
the ``posGT`` mouths of the persons present, mean over frames; its localisation and
cardinality parts beside it.

Usage::

    python benchmarks/bench_av163_generic.py                  # every run (10 min, 2 cores)
    python benchmarks/bench_av163_generic.py --no-dataset-path
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, before NumPy loads BLAS

import argparse  # noqa: E402
import re  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from _common import shared_data_dir  # noqa: E402
from avtrack.io.av163 import AV163_ARRAY_CENTRE, load_av163, load_av163_faces  # noqa: E402
from avtrack.io.camera import read_camera_file  # noqa: E402
from avtrack.io.doa import read_doa_csv  # noqa: E402
from avtrack.io.mot import write_mot  # noqa: E402
from avtrack.io.persons import read_persons_csv  # noqa: E402
from avtrack.metrics.ospa import ospa_sequence  # noqa: E402
from avtrack.phd.likelihood import av163_truth  # noqa: E402


def run(argv: list[str]) -> tuple[float, str]:
    """``avtrack ARGV`` as a user runs it (``python -m avtrack``): seconds, and its stderr
    (warnings); an exit status other than 0 is an error."""
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "avtrack", *argv], capture_output=True,
                          text=True, check=False)
    if proc.returncode != 0:
        raise RuntimeError(f"avtrack {' '.join(argv)} exited {proc.returncode}: {proc.stderr}")
    return time.perf_counter() - t0, proc.stderr


def persons_ospa(out: Path, seq) -> np.ndarray:
    """Mean OSPA, localisation and cardinality (px) of ``out/persons.csv`` against posGT."""
    P = read_persons_csv(out / "persons.csv", 25.0)
    seen = P.in_view & np.all(np.isfinite(P.pixels), axis=1)
    est = [P.pixels[seen & (P.frames == f)] for f in seq.frames]
    return ospa_sequence(est, av163_truth(seq), 50.0, 2).mean(axis=0)


def camera_error(camera_yaml: Path, seq) -> tuple[float, float]:
    """Median and 90th percentile (px) of the camera file's projection of the mouths of the
    persons present against posGT."""
    cam = read_camera_file(camera_yaml)
    err = []
    for p in range(seq.n_persons):
        mouth = seq.mouth[p]
        idx = seq.frame_index(mouth.time_s)
        ok = seq.present[idx, p]
        uv, _ = cam.project(mouth.xyz[ok] - np.asarray(AV163_ARRAY_CENTRE))
        err.append(np.linalg.norm(uv - seq.positions[p, idx[ok]], axis=1))
    e = np.concatenate(err)
    e = e[np.isfinite(e)]
    return float(np.median(e)), float(np.percentile(e, 90))


def doa_error(doa_csv: Path, seq) -> float:
    """Median (degrees) over the DOA rows of the distance to the nearest mouth azimuth of the
    row's frame (seen from array 1's centre)."""
    t = read_doa_csv(doa_csv)
    az = seq.mouth_azimuths(np.asarray(AV163_ARRAY_CENTRE))
    diff = (t.azimuth_deg[:, None] - az[:, t.frames].T + 180) % 360 - 180
    with np.errstate(all="ignore"):
        return float(np.nanmedian(np.nanmin(np.abs(diff), axis=1)))


def shared_sequences(folder: Path) -> list[tuple[int, int]]:
    pattern = re.compile(r"data_av_seq(\d+)_cam(\d)\.mat$")
    found = (pattern.match(p.name) for p in folder.glob("data_av_seq*_cam*.mat"))
    return sorted((int(m.group(1)), int(m.group(2))) for m in found if m)


def video_of(folder: Path, seq: int, cam: int) -> Path | None:
    videos = sorted(folder.glob(f"seq{seq}-*_cam{cam}_*.avi"))
    return videos[0] if videos else None


def fmt(score: np.ndarray | None) -> str:
    if score is None:
        return "-"
    return f"{score[0]:5.1f} ({score[1]:.1f} + {score[2]:.1f})"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=shared_data_dir() / "av16.3")
    ap.add_argument("--no-dataset-path", action="store_true",
                    help="do not run the dataset path (it detects in the video twice)")
    args = ap.parse_args(argv)
    if not args.data.is_dir():
        print(f"bench_av163_generic: {args.data} not found", file=sys.stderr)
        return 1
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench_av163_generic.") as tmp_dir:
        tmp = Path(tmp_dir)
        for s, c in shared_sequences(args.data):
            name = f"seq{s}_cam{c}"
            conv = tmp / name / "convert"
            run(["convert", "av16.3", str(args.data), "--seq", str(s), "--cam", str(c),
                 "-o", str(conv), "-q"])
            seq = load_av163(args.data, s, c)
            cam_med, cam_p90 = camera_error(conv / "camera.yaml", seq)
            doa_med = doa_error(conv / "doa.csv", seq)
            files = ["--doa", str(conv / "doa.csv"), "--camera", str(conv / "camera.yaml")]
            video = video_of(args.data, s, c)
            faces = args.data / f"face_seq{s}_cam{c}.mat"
            generic = heads = yunet = None
            notes = []
            if video is not None:
                what = f"video {video.name}, yunet-face"
                out = tmp / name / "generic"
                secs, err = run(["track-av", "--video", str(video), *files, "-o", str(out),
                                 "-q", "--no-report"])
                generic = persons_ospa(out, seq)
                notes += [f"generic path ({secs:.0f} s) {line}" for line in err.splitlines()]
                if not args.no_dataset_path:
                    for detector in (None, "yunet-face"):
                        out = tmp / name / f"dataset-{detector or 'default'}"
                        extra = [] if detector is None else ["--detector", detector]
                        run(["track-av", str(args.data), "--seq", str(s), "--cam", str(c),
                             "--video", str(video), *extra, "-o", str(out), "-q",
                             "--no-report"])
                        if detector is None:
                            heads = persons_ospa(out, seq)
                        else:
                            yunet = persons_ospa(out, seq)
            elif faces.is_file():
                what = f"{faces.name} (no video: --detections, --fps 25)"
                det = tmp / name / "det.txt"
                det.parent.mkdir(parents=True, exist_ok=True)
                write_mot(det, load_av163_faces(args.data, s, c))
                out = tmp / name / "generic"
                _, err = run(["track-av", "--detections", str(det), "--fps", "25", *files,
                              "-o", str(out), "-q"])
                generic = persons_ospa(out, seq)
                notes += [f"generic path: {line}" for line in err.splitlines()]
            else:
                what = "no video, no detections: not tracked"
            rows.append((s, c, cam_med, cam_p90, doa_med, what, generic, heads, yunet, notes))
            print(f"{name} done", file=sys.stderr)
    print("AV16.3 as a recording of one's own (avtrack convert av16.3 + track-av --doa --camera)"
          " beside the dataset path (track-av DIR --seq N --cam C --video VIDEO)")
    print("camera.yaml: mouths (MouthGT3D) projected vs posGT, median / 90th percentile px; "
          "doa.csv: median distance to the nearest mouth azimuth of the frame, deg")
    print("OSPA: order 2, cut-off 50 px, persons in the image vs posGT, mean over frames, "
          "px (localisation + cardinality)\n")
    print(f"{'seq':>3} {'cam':>3}  {'camera px':>11}  {'doa deg':>7}  {'generic OSPA':>20}  "
          f"{'dataset path: default':>21}  {'dataset: yunet-face':>20}  input")
    for s, c, cm, cp, dm, what, generic, heads, yunet, _ in rows:
        print(f"{s:>3} {c:>3}  {cm:5.1f} /{cp:5.1f}  {dm:7.2f}  {fmt(generic):>20}  "
              f"{fmt(heads):>21}  {fmt(yunet):>20}  {what}")
    for s, c, *_, notes in rows:
        for note in notes:
            print(f"seq {s} cam {c}: {note}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
