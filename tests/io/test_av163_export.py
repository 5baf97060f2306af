"""Tests of avtrack.io.av163_export: an AV16.3 sequence as the DOA CSV and CAMERA.yaml of
``track-av``, on small MAT fixtures checked by hand and on every shared sequence (the camera
file projects the 3-D mouths onto ``posGT``; the DOA rows land on their video frames)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.io

from avtrack.io.av163 import (
    AV163_ARRAY_CENTRE,
    AV163Camera,
    av163_pinhole,
    av163_roll,
    load_av163,
)
from avtrack.io.av163_export import (
    av163_camera,
    av163_camera_yaml,
    av163_doa_table,
    camera_yaml_from_av163,
    doa_csv_from_av163,
)
from avtrack.io.camera import read_camera_file
from avtrack.io.doa import azimuths_per_frame, read_doa_csv
from tests.io.test_av163 import SEQ_CAMS, write_av163

ALL_SEQ_CAMS = sorted([*SEQ_CAMS, (30, 1)])

# A camera by hand: optical centre C = (1, 2.4, 1.5) m (room = calibration frame), looking
# along +y (yaw 90 deg) and 20 deg down (pitch -20), fx 400, fy 420, principal point (180, 150).
C = np.array([1.0, 2.4, 1.5])
K = np.array([[400.0, 0, 180], [0, 420, 150], [0, 0, 1]])
_S, _C = math.sin(math.radians(-20.0)), math.cos(math.radians(-20.0))
R = np.array([
    [1.0, 0.0, 0.0],  # right   r = (sin ψ, -cos ψ, 0), ψ = 90 deg
    [0.0, _S, -_C],  # down     d = (sin θ cos ψ, sin θ sin ψ, -cos θ)
    [0.0, _C, _S],  # forward   f = (cos θ cos ψ, cos θ sin ψ, sin θ)
])


def _pmat(rotation: np.ndarray, scale: float = 2.5) -> np.ndarray:
    """``s K [R | -R C]``: a calibration's projection matrix (its scale is arbitrary)."""
    return scale * K @ np.column_stack([rotation, -rotation @ C])


def _roll(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


# --------------------------------------------------------------------------- small fixtures


def test_doa_rows_by_hand(tmp_path):
    # the fixture's Z_doa: frame 1 none, 2 [10], 3 [20, -10], 4 none, 5 [40], 6 [50, -25]
    seq = load_av163(write_av163(tmp_path), 7, 2)
    t = av163_doa_table(seq)
    np.testing.assert_array_equal(t.frames, [1, 2, 2, 4, 5, 5])  # 0-based video frames
    np.testing.assert_allclose(t.time_s, [0.04, 0.08, 0.08, 0.16, 0.20, 0.20])  # k / 25 s
    np.testing.assert_array_equal(t.azimuth_deg, [10, 20, -10, 40, 50, -25])
    np.testing.assert_array_equal(t.elevation_deg, 0.0)  # not measured
    np.testing.assert_array_equal(t.ids, -1)
    np.testing.assert_array_equal(t.weight, 1.0)
    assert t.active.all()
    path = tmp_path / "doa.csv"
    doa_csv_from_av163(seq, path)
    lines = path.read_text().splitlines()
    assert lines[0] == "frame,time_s,id,azimuth_deg,elevation_deg,weight,active"
    assert lines[1:4] == ["1,0.0400,-1,10.000,0.000,1,1", "2,0.0800,-1,20.000,0.000,1,1",
                          "2,0.0800,-1,-10.000,0.000,1,1"]
    # read back by track-av's reader: cell k + 1 on video frame k
    peaks = azimuths_per_frame(read_doa_csv(path), 25.0, seq.n_frames)
    for k in range(seq.n_frames):
        np.testing.assert_array_equal(peaks[k], np.unique(seq.z_doa[k]))


def test_doa_azimuths_are_wrapped(tmp_path):
    folder = write_av163(tmp_path, n_frames=3)
    z = np.empty((3, 1), dtype=object)
    z[0, 0], z[1, 0], z[2, 0] = np.array([[200.0, -180.0]]), np.zeros((1, 0)), np.array([[90.0]])
    scipy.io.savemat(folder / "DOA_measurements_seq7_cam2.mat", {"Z_doa": z})
    t = av163_doa_table(load_av163(folder, 7, 2))
    np.testing.assert_array_equal(t.frames, [0, 0, 2])
    np.testing.assert_allclose(t.azimuth_deg, [-160.0, 180.0, 90.0])


def test_decompose_recovers_the_pose_through_align_mat():
    # align_mat maps calibration positions to the room: X_room = A X_cal
    a = _roll(30.0)  # a turn of 30 deg about z ...
    align = np.eye(4)
    align[:3, :3] = a
    align[:3, 3] = [0.3, -0.2, 0.1]  # ... and a shift
    cam = AV163Camera(_pmat(R) @ align, K, np.zeros(4), 0.0)  # Pmat @ inv(A) = K [R | -R C]
    k, rot, centre = cam.decompose(align)
    np.testing.assert_allclose(k, K, atol=1e-9)
    np.testing.assert_allclose(rot, R, atol=1e-12)
    np.testing.assert_allclose(centre, C, atol=1e-12)
    with pytest.raises(ValueError, match="align_mat must have shape"):
        cam.decompose(np.eye(3))


def test_camera_pose_by_hand(tmp_path):
    seq = load_av163(write_av163(tmp_path, Pmat=_pmat(R)), 7, 2)  # align_mat = identity
    cam = av163_camera(seq)
    assert (cam.fx, cam.fy, cam.cx, cam.cy) == pytest.approx((400, 420, 180, 150))
    assert (cam.width, cam.height) == (360, 288)
    # the optical centre in array 1's frame: C - (0, 0.4, 0)
    np.testing.assert_allclose(cam.position, [1.0, 2.0, 1.5], atol=1e-12)
    assert cam.yaw_deg == pytest.approx(90.0) and cam.pitch_deg == pytest.approx(-20.0)
    np.testing.assert_allclose(av163_roll(seq, cam), np.eye(2), atol=1e-12)
    # a point 3 m ahead of the camera, 0.5 m to its right: at (180 + 400 / 6, 150)
    point = C + 3.0 * R[2] + 0.5 * R[0] - np.asarray(AV163_ARRAY_CENTRE)
    np.testing.assert_allclose(cam.project(point)[0][0], [180 + 400 * 0.5 / 3, 150])


def test_roll_is_dropped_and_reported(tmp_path):
    seq = load_av163(write_av163(tmp_path, Pmat=_pmat(_roll(5.0) @ R)), 7, 2)
    cam = av163_pinhole(seq)
    assert cam.yaw_deg == pytest.approx(90.0) and cam.pitch_deg == pytest.approx(-20.0)
    r = av163_roll(seq, cam)
    assert math.degrees(math.atan2(r[1, 0], r[0, 0])) == pytest.approx(5.0)
    text = av163_camera_yaml(seq)
    assert "a roll of 5.0 deg" in text and "kc = (-0.3, 0, 0.005, -0.004)" in text


def test_camera_yaml_reads_back(tmp_path):
    seq = load_av163(write_av163(tmp_path / "av", Pmat=_pmat(R)), 7, 2)
    path = tmp_path / "camera.yaml"
    written = camera_yaml_from_av163(seq, path)
    text = path.read_text()
    assert text.startswith("# AV16.3 sequence 7, camera 2, in microphone array 1's frame")
    assert max(len(line) for line in text.splitlines()) <= 99
    assert read_camera_file(path) == written == av163_camera(seq)


@pytest.mark.parametrize("array", [2, 0, True, "1"])
def test_only_array_1(tmp_path, array):
    seq = load_av163(write_av163(tmp_path), 7, 2)
    with pytest.raises(ValueError, match=r"array must be one of \(1,\).*array 1's azimuths"):
        av163_doa_table(seq, array)
    with pytest.raises(ValueError, match=r"av163_camera: array must be one of"):
        av163_camera(seq, array)


def test_seq_must_be_a_sequence():
    with pytest.raises(TypeError, match="seq must be an AV163Sequence"):
        av163_doa_table("seq30")


# --------------------------------------------------------------------------- shared data


@pytest.fixture(scope="module")
def sequences(shared_data):
    folder = shared_data / "av16.3"
    return {(s, c): load_av163(folder, s, c) for s, c in ALL_SEQ_CAMS}


def _mouths_and_truth(seq):
    """3-D mouths (array 1's frame) of the present persons and their posGT pixels."""
    pts, gt = [], []
    for p in range(seq.n_persons):
        mouth = seq.mouth[p]
        idx = seq.frame_index(mouth.time_s)
        ok = seq.present[idx, p]
        pts.append(mouth.xyz[ok] - np.asarray(AV163_ARRAY_CENTRE))
        gt.append(seq.positions[p, idx[ok]])
    return np.vstack(pts), np.vstack(gt)


def test_camera_file_projects_a_mouth_onto_its_ground_truth(sequences, tmp_path):
    """Sequence 30, camera 1, frame 201: person 2's mouth (1.114, 0.858, 0.591) m in the
    MouthGT3D frame is at posGT (166.1, 132.4); near the image centre, where neither the
    dropped distortion nor the roll moves it, the camera file puts it within a pixel."""
    seq = sequences[30, 1]
    path = tmp_path / "camera.yaml"
    camera_yaml_from_av163(seq, path)
    cam = read_camera_file(path)
    k = 200
    np.testing.assert_allclose(seq.positions[1, k], [166.1048, 132.4338])
    mouth = seq.mouth[1]
    j = int(np.flatnonzero(seq.frame_index(mouth.time_s) == k)[0])
    np.testing.assert_allclose(mouth.xyz[j], [1.113949, 0.857736, 0.590656])
    uv, depth = cam.project(mouth.xyz[j] - np.asarray(AV163_ARRAY_CENTRE))
    assert depth[0] > 0
    assert np.linalg.norm(uv[0] - seq.positions[1, k]) < 1.0


@pytest.mark.parametrize(("seq", "cam"), ALL_SEQ_CAMS)
def test_camera_file_is_the_calibration_without_distortion_and_roll(sequences, seq, cam):
    """The camera file, with the roll and the lens distortion added back (AV163View), is the
    full calibration; alone it puts the mouths a few pixels from posGT."""
    from avtrack.av.av163 import AV163View

    s = sequences[seq, cam]
    camera = av163_camera(s)
    pts, gt = _mouths_and_truth(s)
    uv, _ = camera.project(pts)
    full = s.camera.project(pts + np.asarray(AV163_ARRAY_CENTRE), s.align_mat)
    ok = np.all(np.isfinite(uv), axis=1)
    np.testing.assert_allclose(AV163View(s).from_pinhole(uv[ok]), full[ok], atol=1e-4)
    err = np.linalg.norm(uv[ok] - gt[ok], axis=1)
    assert ok.mean() > 0.99
    assert np.median(err) < (8.0 if cam == 1 else 3.5)


@pytest.mark.parametrize(("seq", "cam"), ALL_SEQ_CAMS)
def test_doa_csv_round_trip_on_the_video_frames(sequences, seq, cam, tmp_path):
    s = sequences[seq, cam]
    path = tmp_path / "doa.csv"
    table = doa_csv_from_av163(s, path)
    assert len(table) == sum(np.size(z) for z in s.z_doa)
    peaks = azimuths_per_frame(read_doa_csv(path), 25.0, s.n_frames)
    for k in range(s.n_frames):
        np.testing.assert_allclose(peaks[k], np.unique(np.round(s.z_doa[k], 3)), atol=1e-9)


@pytest.mark.parametrize("seq", [24, 30, 45])
def test_doa_rows_meet_the_mouths_of_their_frame(sequences, seq):
    """Each measurement lies a median 1.8-2.2 degrees from the azimuth of the nearest mouth of
    its frame (seen from array 1's centre); no other pairing of cells and frames is better by
    more than 0.3 degrees, and five frames off is worse by more than a degree."""
    s = sequences[seq, 1]
    t = av163_doa_table(s)
    mouth_az = s.mouth_azimuths(np.asarray(AV163_ARRAY_CENTRE))

    def median_error(shift: int) -> float:
        k = t.frames - shift
        keep = (k >= 0) & (k < s.n_frames)
        diff = (t.azimuth_deg[keep][:, None] - mouth_az[:, k[keep]].T + 180) % 360 - 180
        return float(np.nanmedian(np.nanmin(np.abs(diff), axis=1)))

    errors = {shift: median_error(shift) for shift in range(-5, 6)}
    assert errors[0] < 2.3
    assert errors[0] < min(errors.values()) + 0.35  # no other pairing is clearly better
    assert min(errors[-5], errors[5]) > errors[0] + 0.9  # five frames off, clearly worse
