"""``track-av --camera auto`` on simulated scenes: the camera estimated from the recording
against the true one.

Per scene (``avtrack simulate walkout|meeting``, evaluation seeds >= 100): the true camera in
the array's frame (``camera.json`` and the array's pose in ``scene.yaml``, turned into the
array's frame as a user's CAMERA.yaml is), the estimate of :func:`avtrack.av.calibrate.fit_camera`
from the scene's detections and the peaks of its recording's calibration maps
(``CALIBRATION_LOCALIZER``, as ``track-av`` places a camera), the errors of yaw, pitch and
focal length, and MOTA / IDF1 / DER of the direction-space tracker with each camera (the same
detections, appearance, audio peaks of the persons' maps and voice activity, as ``track-av``).

With ``--av163 DATA_DIR``: AV16.3 sequence 30 camera 1 instead, through ``avtrack convert``
and ``track-av --camera auto`` from its DOA CSV and video (the default face detector), the
camera placed where the dataset's calibration puts it (``--camera-position``) and, for
comparison, at the array: yaw and focal length against the calibration's.

Usage::

    python benchmarks/bench_camera_auto.py --work /tmp/avt/camauto [--seeds 100-103]
        [--suites walkout meeting] [--duration 20] [--pitch -10]
    python benchmarks/bench_camera_auto.py --work /tmp/avt/camauto --av163 ../shared/data/av16.3
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, before NumPy loads BLAS

import argparse  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402


def array_frame_camera(scene):
    """The scene's camera in its array's frame (position relative to the array centre, yaw
    relative to the array's x axis)."""
    from avtrack.av.persons_scene import scene_geometry
    from avtrack.io.camera import PinholeCamera

    g = scene_geometry(scene)
    cam = g.camera
    yaw = g.array_yaw_deg
    c, s = np.cos(np.deg2rad(-yaw)), np.sin(np.deg2rad(-yaw))
    rel = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ (cam.position - g.array_position)
    return PinholeCamera(cam.fx, cam.fy, cam.cx, cam.cy, cam.width, cam.height, rel,
                         cam.yaw_deg - yaw, cam.pitch_deg)


def score(scene, res) -> dict:
    from avtrack.io.mot import read_mot
    from avtrack.io.rttm import read_rttm
    from avtrack.metrics.der import diarization_error_rate
    from avtrack.metrics.mot import evaluate_mot

    gt = read_mot(scene.path / "gt" / "gt.txt", kind="gt")
    m = evaluate_mot(gt, res.tracks, n_frames=scene.n_frames)
    der = diarization_error_rate(read_rttm(scene.path / "gt" / "speech.rttm"), res.speech)
    return {"MOTA": m.MOTA, "IDF1": m.IDF1, "DER": 100 * der.rate}


def run_scene(path: Path) -> dict:
    from avtrack.audio.arrays import load_array
    from avtrack.audio.recording import ArrayRecording
    from avtrack.av.calibrate import camera_evidence
    from avtrack.av.geometry import CameraGeometry
    from avtrack.av.persons_scene import track_persons
    from avtrack.io.doa import wrap_azimuth
    from avtrack.io.scene import load_scene
    from avtrack.localize.grid import line_axis
    from avtrack.pipelines.av_recording import estimate_camera, localize_for_persons
    from avtrack.visual.horizon import estimate_horizon

    scene = load_scene(path)
    true = array_frame_camera(scene)
    array = load_array(path / "array.json")
    # one run, as track-av's: the persons' peaks and the peaks that place the camera
    audio = localize_for_persons(ArrayRecording(path / "audio.wav", array, quiet=True),
                                 scene.fps, scene.n_frames, calibration=True, yaw_map=True)
    peaks, span = audio.peaks, audio.span_deg

    def evidence(azimuths):
        return camera_evidence(scene.detections, azimuths, scene.fps, scene.image_size,
                               line_axis=line_axis(array))

    fit = estimate_camera(evidence(audio.calibration_peaks),
                          None if audio.yaw_peaks is None else evidence(audio.yaw_peaks),
                          horizon=estimate_horizon(scene.detections, scene.fps,
                                                           scene.image_size[1]))
    est = fit.camera
    row = {
        "scene": path.name,
        "yaw_err": float(wrap_azimuth(est.yaw_deg - true.yaw_deg)),
        "yaw_std": fit.yaw_std_deg,
        "pitch_err": est.pitch_deg - true.pitch_deg,
        "pitch_from": fit.pitch_source,
        "f_err_pct": 100 * (est.fx / true.fx - 1),
        "f_std_pct": 100 * fit.focal_std_px / true.fx,
        "f_bias_pct": 100 * fit.focal_bias_px / true.fx,
        "inliers": f"{fit.n_inliers}/{fit.n_directions}",
    }
    for name, cam in (("true", true), ("auto", est)):
        res = track_persons(scene.detections, scene.appearance, peaks,
                            CameraGeometry(cam, np.zeros(3), 0.0), scene.fps, scene.n_frames,
                            azimuth_span_deg=span, heat=audio.heat, grid=audio.grid,
                            activity=audio.activity)
        for k, v in score(scene, res).items():
            row[f"{k}_{name}"] = v
    return row


def run_av163(data: Path, work: Path) -> None:
    """Sequence 30 camera 1: the estimate at the calibration's camera position and at the
    array, against the calibration."""
    from avtrack.io.camera import read_camera_file
    from avtrack.io.doa import wrap_azimuth

    video = data / "seq30-2p-1101_cam1_divx_audio.avi"
    conv = work / "av163-seq30-cam1"
    if not (conv / "camera.yaml").is_file():
        subprocess.run([sys.executable, "-m", "avtrack", "convert", "av16.3", str(data),
                        "--seq", "30", "--cam", "1", "-o", str(conv), "-q"], check=True)
    true = read_camera_file(conv / "camera.yaml")
    where = ",".join(f"{v:.2f}" for v in true.position)
    for name, extra in (("measured", [f"--camera-position={where}"]), ("at-array", [])):
        out = work / f"av163-auto-{name}"
        run = subprocess.run([sys.executable, "-m", "avtrack", "track-av", "--video",
                              str(video), "--doa", str(conv / "doa.csv"), "--camera", "auto",
                              *extra, "-o", str(out), "-q", "--no-report", "--force"],
                             capture_output=True, text=True)
        if run.returncode != 0:
            print(f"scene=av163-30-1-{name}  failed: {run.stderr.strip()}")
            continue
        est = read_camera_file(out / "CAMERA.yaml")
        print(f"scene=av163-30-1-{name}  position={where if extra else 'array'}  "
              f"yaw_err={float(wrap_azimuth(est.yaw_deg - true.yaw_deg)):.2f}  "
              f"pitch_err={est.pitch_deg - true.pitch_deg:.2f}  "
              f"f_err_pct={100 * (est.fx / true.fx - 1):.2f} (of fx; "
              f"{100 * (est.fx / true.fy - 1):.2f} of fy)", flush=True)


def scenario(suite: str, seed: int, duration: float, pitch: float | None, work: Path) -> str:
    """The named scenario ``suite``, or its ``seed``'s draw written in ``work`` with its camera
    pitched."""
    if pitch is None:
        return suite
    import yaml

    from avtrack.simulate.library import named_scenario

    cfg = named_scenario(suite, seed, duration)
    cfg["camera"]["pitch_deg"] = float(pitch)
    path = work / f"{suite}-pitch{pitch:g}-{seed}.yaml"
    work.mkdir(parents=True, exist_ok=True)
    path.write_text(yaml.safe_dump(cfg))
    return str(path)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--work", type=Path, required=True)
    p.add_argument("--av163", type=Path, metavar="DATA_DIR",
                   help="AV16.3 sequence 30 camera 1 from this folder instead")
    p.add_argument("--seeds", default="100-103")
    p.add_argument("--suites", nargs="+", default=["walkout", "meeting"])
    p.add_argument("--duration", type=float, default=20.0)
    p.add_argument("--pitch", type=float, metavar="DEG",
                   help="tilt the scenario's camera by this pitch (degrees, negative down)")
    a = p.parse_args()
    if a.av163 is not None:
        run_av163(a.av163, a.work)
        return 0
    lo, _, hi = a.seeds.partition("-")
    seeds = range(int(lo), int(hi or lo) + 1)
    rows = []
    for suite in a.suites:
        for seed in seeds:
            tilt = "" if a.pitch is None else f"-pitch{a.pitch:g}"
            d = a.work / f"{suite}{tilt}-{seed}"
            if not (d / "scene.yaml").is_file():
                subprocess.run([sys.executable, "-m", "avtrack", "simulate",
                                scenario(suite, seed, a.duration, a.pitch, a.work), "-o",
                                str(d), "--seed",
                                str(seed), "--duration", str(a.duration), "-q"], check=True)
            row = run_scene(d)
            rows.append(row)
            print("  ".join(f"{k}={v:.2f}" if isinstance(v, float) else f"{k}={v}"
                            for k, v in row.items()), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
