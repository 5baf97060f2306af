"""Tests of avtrack.io.av163: the AV16.3 reader on small MAT fixtures laid out as the shared
files are, and on every shared file (values against raw ``loadmat``, the timecode decoding, the
projection recipe and the face-box convention stated in the module docstring)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import scipy.io

from avtrack.errors import InputError
from avtrack.io.av163 import (
    AV163Camera,
    decode_timecode,
    load_av163,
    load_av163_doa,
    load_av163_faces,
    load_av163_histograms,
)

SEQ_CAMS = [(seq, cam) for seq in (24, 45) for cam in (1, 2, 3)]


def _load(path: Path):
    return scipy.io.loadmat(path, squeeze_me=True, struct_as_record=False)


# --------------------------------------------------------------------------- fixtures


def write_av163(folder: Path, seq: int = 7, cam: int = 2, n_frames: int = 6, **over) -> Path:
    """A small AV16.3 folder: ``data_av``, ``DOA_measurements`` and ``hist_temp`` files with
    the fields, shapes and MATLAB types of the shared files. ``over`` replaces posGT/other
    entries by name (``Pmat``, ``person1``, ``Timingcam``, ``Z_doa`` ...)."""
    folder.mkdir(parents=True, exist_ok=True)
    cams = np.empty(3, dtype=object)
    pmat = np.array([[400.0, 0, 180, 0], [0, 400, 144, 0], [0, 0, 1, 2]])
    for k in range(3):
        cams[k] = {
            "Pmat": over.get("Pmat", pmat),
            "K": np.array([[400.0, 0, 180], [0, 400, 144], [0, 0, 1]]),
            "kc": np.array([-0.3, 0, 0.005, -0.004]),
            "alpha_c": 0,
        }
    frames = np.arange(1, n_frames + 1, dtype=float)
    # timecode 9.23, 9.24, 10.00, 10.01 ... (seconds.ff)
    ff = (23 + np.arange(n_frames)) % 25
    sec = 9 + (23 + np.arange(n_frames)) // 25
    timing = np.column_stack([sec + ff / 100, frames])
    p1 = np.column_stack([frames, 100 + frames, 50 + frames])
    p2 = np.column_stack([frames, 200 + frames, 80 + frames])
    x_true = np.zeros((5, n_frames, 2), dtype=np.uint16)
    x_true[0, :, 0], x_true[2, :, 0] = np.rint(p1[:, 1]), np.rint(p1[:, 2])
    x_true[0, 2:, 1], x_true[2, 2:, 1] = np.rint(p2[2:, 1]), np.rint(p2[2:, 2])  # p2 from f3
    p2[:2, 1:] = [-40.5, 120.0]  # stale off-image position while absent
    mouth = np.column_stack(
        [decode_timecode(timing[:, 0]), np.ones(n_frames), np.tile([0.1, 0.2, 0.7], (n_frames, 1))]
    )
    data = {
        "experiment": {
            "ExGT1": np.array([[9.92, 10.0], [9.96, 11.0]]),
            "ExGT2": np.array([[10.0, -20.0]]),
            "ExData1": np.array([[9.93, 9.5], [9.94, 10.5], [9.95, 12.0]]),
            "ExData2": np.array([[10.01, -19.0], [10.02, -21.0]]),
        },
        "cam": cams,
        "align_mat": np.eye(4),
        "MouthGT3D": {"person1": mouth, "person2": mouth + np.array([0, 0, 0, 0, 0.1])},
        "Timingcam": over.get("Timingcam", timing),
        "posGT": {
            "N_speaker": np.array([1, 1] + [2] * (n_frames - 2), dtype=np.uint8),
            "person1": over.get("person1", p1),
            "X_true": x_true,
            "person2": p2,
        },
    }
    for name in over.get("drop", ()):
        data.pop(name)
    scipy.io.savemat(folder / f"data_av_seq{seq}_cam{cam}.mat", {"Data": data})
    z = np.empty((over.get("n_doa", n_frames), 1), dtype=object)
    for i in range(z.shape[0]):
        z[i, 0] = np.zeros((1, 0)) if i % 3 == 0 else np.array([[10.0 * i, -5.0 * i][: i % 3]])
    scipy.io.savemat(folder / f"DOA_measurements_seq{seq}_cam{cam}.mat", {"Z_doa": z})
    hist = np.empty((3, 1), dtype=object)
    hist[0, 0] = np.full((16, 16), 1 / 256)
    hist[1, 0] = np.full((16, 16), 1 / 256)
    hist[2, 0] = np.zeros((16, 16), dtype=np.uint8)
    hist[2, 0][0, 5] = 1
    scipy.io.savemat(folder / f"hist_temp_16bins_seq{seq}_cam{cam}.mat", {"hist_temp": hist})
    return folder


@pytest.fixture(scope="module")
def av_folder(shared_data) -> Path:
    return shared_data / "av16.3"


@pytest.fixture(scope="module")
def sequences(av_folder):
    """Every shared sequence/camera, read once for the module."""
    return {(seq, cam): load_av163(av_folder, seq, cam) for seq, cam in SEQ_CAMS}


@pytest.fixture(scope="module")
def raw(av_folder):
    """Raw ``loadmat`` of every shared data_av / DOA file."""
    out = {}
    for seq, cam in SEQ_CAMS:
        out[seq, cam] = (
            _load(av_folder / f"data_av_seq{seq}_cam{cam}.mat")["Data"],
            _load(av_folder / f"DOA_measurements_seq{seq}_cam{cam}.mat")["Z_doa"],
        )
    return out


@pytest.fixture(scope="module")
def faces(av_folder):
    return load_av163_faces(av_folder, 45, 1)


# --------------------------------------------------------------------------- small fixtures


def test_fixture_round_trip(tmp_path):
    s = load_av163(write_av163(tmp_path), 7, 2)
    assert (s.n_frames, s.n_persons) == (6, 2)
    np.testing.assert_array_equal(s.frames, np.arange(1, 7))
    # 9.23, 9.24, 10.00 ... decode to 9.92, 9.96, 10.00 ...: 0.04 s steps across the second
    np.testing.assert_allclose(s.time_s, 9.92 + 0.04 * np.arange(6), atol=1e-12)
    np.testing.assert_array_equal(s.present[:, 0], True)
    np.testing.assert_array_equal(s.present[:, 1], [False, False, True, True, True, True])
    assert np.all(np.isnan(s.positions[1, :2]))  # stale -40.5 replaced by NaN
    np.testing.assert_array_equal(s.positions[1, 2], [203, 83])
    np.testing.assert_array_equal(s.n_speakers, [1, 1, 2, 2, 2, 2])
    assert s.camera is s.cameras[1]
    np.testing.assert_array_equal(s.camera.kc, [-0.3, 0, 0.005, -0.004])
    assert [len(z) for z in s.z_doa] == [0, 1, 2, 0, 1, 2]
    np.testing.assert_array_equal(s.z_doa[2], [20.0, -10.0])
    assert s.doa_gt[1].shape == (1, 2) and s.doa_measured[0].shape == (3, 2)
    assert s.histograms.shape == (3, 16, 16)
    np.testing.assert_array_equal(s.histogram_is_placeholder, [False, False, True])
    np.testing.assert_array_equal(s.frame_index([9.92, 10.0, 9.89, 99.0]), [0, 2, -1, -1])
    np.testing.assert_allclose(s.mouth[1].xyz[0], [0.1, 0.2, 0.8])


def test_project_pinhole_without_distortion_by_hand():
    cam = AV163Camera(
        pmat=np.array([[400.0, 0, 180, 0], [0, 400, 144, 0], [0, 0, 1, 0]]),
        K=np.array([[400.0, 0, 180], [0, 400, 144], [0, 0, 1]]),
        kc=np.zeros(4),
        alpha_c=0,
    )
    pts = np.array([[0.5, -0.25, 2.0], [0.0, 0.0, -1.0]])
    uv = cam.project(pts)
    np.testing.assert_allclose(uv[0], [180 + 400 * 0.25, 144 - 400 * 0.125])
    assert np.all(np.isnan(uv[1]))  # behind the camera
    # align_mat translating the calibration frame by +1 m in x: X_cal = X - (1, 0, 0)
    align = np.eye(4)
    align[0, 3] = 1.0
    np.testing.assert_allclose(cam.project(pts[:1], align)[0], [180 - 400 * 0.25, 94])


def test_distortion_matches_bouguet_formula():
    k = np.array([[400.0, 0, 180], [0, 420, 140], [0, 0, 1]])
    cam = AV163Camera(np.hstack([k, np.zeros((3, 1))]), k, [-0.3, 0.1, 0.01, -0.02], 0)
    x, y = 0.2, -0.1
    r2 = x * x + y * y
    radial = 1 - 0.3 * r2 + 0.1 * r2 * r2
    xd = x * radial + 2 * 0.01 * x * y - 0.02 * (r2 + 2 * x * x)
    yd = y * radial + 0.01 * (r2 + 2 * y * y) + 2 * -0.02 * x * y
    got = cam.distort(np.array([[180 + 400 * x, 140 + 420 * y]]))
    np.testing.assert_allclose(got[0], [180 + 400 * xd, 140 + 420 * yd], rtol=0, atol=1e-9)


def test_decode_timecode():
    np.testing.assert_allclose(
        decode_timecode([12.0, 12.12, 12.24, 13.0]), [12.0, 12.48, 12.96, 13.0]
    )
    with pytest.raises(ValueError, match=r"row 2: 12\.25 is not a seconds\.ff timecode"):
        decode_timecode([12.24, 12.25])


def where(path: Path) -> str:
    return re.escape(f"{path}: ")


def test_missing_files_are_named(tmp_path):
    folder = write_av163(tmp_path)
    with pytest.raises(InputError, match=where(folder / "data_av_seq7_cam1.mat") + "file not"):
        load_av163(folder, 7, 1)
    (folder / "DOA_measurements_seq7_cam2.mat").unlink()
    with pytest.raises(InputError, match=where(folder / "DOA_measurements_seq7_cam2.mat")):
        load_av163(folder, 7, 2)
    with pytest.raises(InputError, match=where(folder / "face_seq7_cam2.mat") + "file not"):
        load_av163_faces(folder, 7, 2)


def test_not_a_mat_file(tmp_path):
    folder = write_av163(tmp_path)
    (folder / "data_av_seq7_cam2.mat").write_text("hello")
    with pytest.raises(InputError, match="cannot read as a MATLAB file"):
        load_av163(folder, 7, 2)


@pytest.mark.parametrize(
    ("over", "message"),
    [
        ({"Pmat": np.ones((3, 3))}, r"Data\.cam\[0\]\.Pmat must be 3×4, got shape \(3, 3\)"),
        ({"person1": np.ones((6, 2))}, r"Data\.posGT\.person1 must be 6×3"),
        ({"drop": ["MouthGT3D"]}, r"missing field Data\.MouthGT3D"),
        (
            {"Timingcam": np.array([[9.23, 1], [9.26, 2]])},
            r"Data\.Timingcam row 2: 9\.26 is not a seconds\.ff timecode",
        ),
        ({"n_doa": 5}, r"Z_doa has 5 cells, expected one per frame \(6"),
    ],
)
def test_malformed_fields_are_named(tmp_path, over, message):
    folder = write_av163(tmp_path, **over)
    with pytest.raises(InputError, match=message):
        load_av163(folder, 7, 2)


def test_nan_is_named_with_its_row(tmp_path):
    p1 = np.column_stack([np.arange(1.0, 7), np.full(6, 100.0), np.full(6, 50.0)])
    p1[3, 2] = np.nan
    folder = write_av163(tmp_path, person1=p1)
    with pytest.raises(InputError, match=r"Data\.posGT\.person1 row 4 holds a NaN"):
        load_av163(folder, 7, 2)


def test_frame_numbers_must_agree(tmp_path):
    p1 = np.column_stack([np.arange(1.0, 7), np.full(6, 100.0), np.full(6, 50.0)])
    p1[4, 0] = 9
    with pytest.raises(InputError, match=r"person1 row 5: frame 9 differs from Data\.Timingcam"):
        load_av163(write_av163(tmp_path, person1=p1), 7, 2)


@pytest.mark.parametrize(("seq", "cam"), [(0, 1), (24, 4), (24, True), ("24", 1)])
def test_bad_seq_cam_arguments(tmp_path, seq, cam):
    with pytest.raises(ValueError, match=r"seq must be|cam must be"):
        load_av163(tmp_path, seq, cam)


def test_face_boxes_fixture_and_inverted_box(tmp_path):
    cells = np.empty((3, 1), dtype=object)
    cells[0, 0] = np.zeros((0, 5), dtype=np.float32)
    cells[1, 0] = np.array([[10, 20, 30, 50, 7.5]], dtype=np.float32)
    cells[2, 0] = np.array([[1, 2, 5, 8, 0.5], [100, 100, 110, 130, 2.0]], dtype=np.float32)
    scipy.io.savemat(tmp_path / "face_seq45_cam1.mat", {"face": cells})
    det = load_av163_faces(tmp_path)
    np.testing.assert_array_equal(det.frames, [2, 3, 3])
    np.testing.assert_array_equal(det.boxes, [[10, 20, 20, 30], [1, 2, 4, 6], [100, 100, 10, 30]])
    np.testing.assert_array_equal(det.scores, [7.5, 0.5, 2.0])
    np.testing.assert_array_equal(det.ids, -1)
    cells[2, 0] = np.array([[5, 2, 1, 8, 0.5]], dtype=np.float32)
    scipy.io.savemat(tmp_path / "face_seq45_cam1.mat", {"face": cells})
    with pytest.raises(InputError, match=r"face cell 3: box .* is not x1, y1, x2, y2"):
        load_av163_faces(tmp_path)


# --------------------------------------------------------------------------- shared data


@pytest.mark.parametrize(("seq", "cam"), SEQ_CAMS)
def test_every_shared_file_matches_raw_loadmat(sequences, raw, seq, cam):
    s = sequences[seq, cam]
    data, z_raw = raw[seq, cam]
    assert s.n_frames == data.Timingcam.shape[0] == len(z_raw)
    assert s.n_persons == (3 if seq == 45 else 2)
    np.testing.assert_array_equal(s.frames, data.Timingcam[:, 1])
    np.testing.assert_array_equal(s.n_speakers, data.posGT.N_speaker)
    for k in range(s.n_persons):
        gt = getattr(data.posGT, f"person{k + 1}")
        present = np.any(data.posGT.X_true[:, :, k] != 0, axis=0)
        np.testing.assert_array_equal(s.present[:, k], present)
        np.testing.assert_array_equal(s.positions[k][present], gt[present, 1:3])
        assert np.all(np.isnan(s.positions[k][~present]))
        mouth = getattr(data.MouthGT3D, f"person{k + 1}")
        np.testing.assert_array_equal(s.mouth[k].xyz, mouth[:, 2:5])
        np.testing.assert_array_equal(s.doa_gt[k], getattr(data.experiment, f"ExGT{k + 1}"))
        np.testing.assert_array_equal(
            s.doa_measured[k], getattr(data.experiment, f"ExData{k + 1}")
        )
    for c in range(3):
        np.testing.assert_array_equal(s.cameras[c].pmat, data.cam[c].Pmat)
        np.testing.assert_array_equal(s.cameras[c].K, data.cam[c].K)
    np.testing.assert_array_equal(s.align_mat, data.align_mat)
    assert [len(z) for z in s.z_doa] == [np.size(z) for z in z_raw]
    np.testing.assert_array_equal(
        np.concatenate(s.z_doa), np.concatenate([np.atleast_1d(z) for z in z_raw])
    )
    # the person count agrees with N_speaker except at a few border frames (seq45 cam2)
    agree = np.mean(s.present.sum(axis=1) == s.n_speakers)
    assert agree == 1.0 or ((seq, cam) == (45, 2) and agree > 0.98)
    # histograms: one real template per person, the rest placeholders
    assert s.histograms.shape == (10, 16, 16)
    np.testing.assert_array_equal(
        np.flatnonzero(~s.histogram_is_placeholder), np.arange(s.n_persons)
    )
    np.testing.assert_allclose(s.histograms.sum(axis=(1, 2)), 1.0)


def test_specific_shared_values(sequences):
    s = sequences[45, 1]
    # frame 101 (index 100): only person 2 in view, at (284.0486, 97.6139)
    assert s.n_speakers[100] == 1
    np.testing.assert_array_equal(s.present[100], [False, True, False])
    np.testing.assert_allclose(s.positions[1, 100], [284.0486, 97.6139])
    # person 1 is out of view at the start: the file holds x = -48.214 there
    assert np.isnan(s.positions[0, 0, 0])
    np.testing.assert_allclose(s.cameras[0].pmat[0, 3], 886.67421)
    np.testing.assert_allclose(s.cameras[0].K[0, 0], 387.02534112)
    np.testing.assert_allclose(s.align_mat[0, 0], 0.999259521)
    assert [sum(len(z) == n for z in s.z_doa) for n in range(4)] == [188, 251, 167, 495]
    assert [len(d) for d in s.doa_gt] == [648, 864, 612]
    np.testing.assert_allclose(s.doa_gt[0][0], [14.56, 53.71336193])
    s24 = sequences[24, 1]
    assert [sum(len(z) == n for z in s24.z_doa) for n in range(3)] == [543, 115, 541]
    np.testing.assert_allclose(s24.z_doa[254], [-45.64616626858042])


@pytest.mark.parametrize(("seq", "cam"), SEQ_CAMS)
def test_timecode_decodes_to_25_fps(sequences, raw, seq, cam):
    s = sequences[seq, cam]
    steps = np.diff(raw[seq, cam][0].Timingcam[:, 0])
    # raw steps: 0.01 within a second, 0.76 from .24 to the next .00
    np.testing.assert_allclose(np.unique(steps.round(6)), [0.01, 0.76])
    np.testing.assert_allclose(np.diff(s.time_s), 0.04, atol=1e-9)
    # the mouth ground truth is sampled on the decoded frame clock
    for mouth in s.mouth:
        assert np.all(s.frame_index(mouth.time_s) >= 0)


@pytest.mark.parametrize(("seq", "cam"), SEQ_CAMS)
def test_projected_mouth_lands_on_image_ground_truth(sequences, seq, cam):
    """Pmat @ inv(align_mat) plus lens distortion, at the frame of the same time, hits posGT
    within a fraction of a pixel (median); dropping either step costs more than a pixel."""
    s = sequences[seq, cam]

    def errors(**kw):
        err = []
        for k in range(s.n_persons):
            mouth = s.mouth[k]
            idx = s.frame_index(mouth.time_s)
            uv = s.camera.project(mouth.xyz, **kw)
            ok = s.present[idx, k]
            err.append(np.linalg.norm(uv[ok] - s.positions[k, idx[ok]], axis=1))
        return np.concatenate(err)

    full = errors(align_mat=s.align_mat)
    assert np.median(full) < 0.35
    assert np.percentile(full, 90) < 6.0
    assert np.median(errors(align_mat=None)) > 1.0
    assert np.median(errors(align_mat=s.align_mat, distort=False)) > 1.5
    # project_mouth puts the same values on the frame grid
    k = 0
    uv = s.project_mouth(k)
    ok = s.present[:, k] & np.isfinite(uv[:, 0])
    assert np.median(np.linalg.norm(uv[ok] - s.positions[k, ok], axis=1)) < 0.35


def _match(faces, s, centre):
    """Offset (GT - centre) to the nearest present person, per detection."""
    c = centre(faces.boxes)
    gt = np.transpose(s.positions, (1, 0, 2))[faces.frames - 1]  # (K, P, 2)
    d = gt - c[:, None, :]
    dist = np.where(np.isnan(d[..., 0]), np.inf, np.hypot(d[..., 0], d[..., 1]))
    j = np.argmin(dist, axis=1)
    return d[np.arange(len(j)), j], dist[np.arange(len(j)), j]


def test_face_box_convention_is_corners(faces, sequences, av_folder):
    """Rows are x1, y1, x2, y2, score: evidence against the mouth ground truth of seq45 cam1."""
    raw_cells = [np.atleast_2d(c) for c in _load(av_folder / "face_seq45_cam1.mat")["face"]]
    rows = np.vstack([c for c in raw_cells if c.size])
    assert len(faces) == len(rows) == 1875
    assert np.all(rows[:, 2] > rows[:, 0]) and np.all(rows[:, 3] > rows[:, 1])
    s = sequences[45, 1]
    w, h = faces.boxes[:, 2], faces.boxes[:, 3]
    assert 12 < np.median(w) < 25 and 18 < np.median(h) < 32  # face sized
    offset, dist = _match(faces, s, lambda b: b[:, :2] + b[:, 2:] / 2)
    assert np.median(dist) < 10 and np.mean(dist < 15) > 0.95
    near = dist < 30
    assert abs(np.median(offset[near, 0])) < 2  # mouth horizontally centred
    assert 0.2 < np.median(offset[near, 1] / h[near]) < 0.4  # and below the centre
    inside = (np.abs(offset[:, 0]) <= w / 2) & (np.abs(offset[:, 1]) <= h / 2)
    assert inside.mean() > 0.99
    # read as left, top, width, height the centres would be far from every person
    _, dist_xywh = _match(faces, s, lambda b: rows[:, :2] + rows[:, 2:4] / 2)
    assert np.median(dist_xywh) > 50
    np.testing.assert_allclose(faces.boxes[:, :2], rows[:, :2], rtol=1e-6)
    np.testing.assert_allclose(faces.scores, rows[:, 4], rtol=1e-6)


def test_doa_and_histogram_readers_alone(av_folder, raw):
    z = load_av163_doa(av_folder, 24, 2)
    assert len(z) == len(raw[24, 2][1]) == 1214
    hists, placeholder = load_av163_histograms(av_folder, 24, 2)
    assert hists.shape == (10, 16, 16) and placeholder.sum() == 8
