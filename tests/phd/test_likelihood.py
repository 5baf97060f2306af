"""Audio-visual measurements and kernels: AVFrame contract, DOA-line projection, fusion,
the synthetic face detector, and the facts about the shared AV16.3 files the module states."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.errors import InputError
from avtrack.io.av163 import AV163Camera, load_av163
from avtrack.io.mot import MOTData
from avtrack.phd.likelihood import (
    AV163_ARRAY_CENTRE,
    AV163_MOUTH_HEIGHT,
    AVFrame,
    SyntheticFaceDetector,
    audio_kernel,
    av163_frames,
    av163_truth,
    av163_visual,
    doa_lines,
    face_measurements,
    line_distance,
    make_frame,
    pair_measurements,
    visual_kernel,
)


def test_kernels():
    p = np.array([[0.0, 0.0], [3.0, 4.0]])
    np.testing.assert_allclose(visual_kernel(p, np.array([[0.0, 0.0]]), 5.0)[:, 0],
                               [1.0, np.exp(-0.5)])  # fmt: skip
    line = np.array([[0.0, 1.0, 4.0]])  # y = 4
    np.testing.assert_allclose(line_distance(p, line)[:, 0], [-4.0, 0.0])
    np.testing.assert_allclose(audio_kernel(p, line, 2.0)[:, 0], [np.exp(-2.0), 1.0])


def test_pair_measurements():
    vis = np.array([[10.0, 10.0], [100.0, 10.0], [200.0, 50.0]])
    lines = np.array([[1.0, 0.0, 101.0], [1.0, 0.0, 12.0], [0.0, 1.0, 280.0]])
    pairs = pair_measurements(vis, lines, sigma_audio=5.0, gate=3.0)
    # x=101 pairs with the point at x=100, x=12 with x=10; y=280 is 230 px from every point
    assert pairs.tolist() == [[2, 1], [1, 2], [0, 3], [3, 0]]
    assert pair_measurements(np.zeros((0, 2)), lines[:1], 5.0).tolist() == [[1, 0]]
    assert pair_measurements(vis[:1], np.zeros((0, 3)), 5.0).tolist() == [[0, 1]]
    assert pair_measurements(np.zeros((0, 2)), np.zeros((0, 3)), 5.0).shape == (0, 2)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"visual": [[np.nan, 1.0]]}, "visual must be finite"),
        ({"lines": np.zeros((0, 3))}, "one row per DOA"),
        ({"lines": [[2.0, 0.0, 1.0]]}, "unit norm"),
        ({"pairs": [[0, 0]]}, "not both 0"),
        ({"pairs": [[2, 1]]}, "0 <= o <= 1"),
        ({"pairs": [[0.5, 1]]}, "must be integer"),
    ],
)
def test_avframe_validation(kwargs, message):
    args = {"visual": [[1.0, 2.0]], "doa_deg": [10.0], "lines": [[1.0, 0.0, 5.0]],
            "pairs": [[1, 1]]} | kwargs  # fmt: skip
    with pytest.raises(ValueError, match=message):
        AVFrame(**args)


def test_make_frame_drops_lines_outside_the_image():
    lines = np.array([[1.0, 0.0, 5.0], [np.nan, np.nan, np.nan]])
    f = make_frame(np.array([[6.0, 0.0]]), np.array([10.0, 20.0]), lines, 5.0)
    assert f.doa_deg.tolist() == [10.0] and f.pairs.tolist() == [[1, 1]]


def test_doa_lines_are_the_projected_rays():
    cam = AV163Camera(
        np.array([[400.0, 0, 180, 0], [0, 400, 144, 0], [0, 0, 1, 4]]),
        np.array([[400.0, 0, 180], [0, 400, 144], [0, 0, 1]]), np.zeros(4), 0.0,
    )  # fmt: skip
    az = np.array([30.0, 100.0])
    lines = doa_lines(cam, np.eye(4), az, centre=(0, 0, 0), height=0.5)
    assert lines.shape == (2, 3)
    np.testing.assert_allclose(np.hypot(lines[:, 0], lines[:, 1]), 1.0)
    for k, a in enumerate(np.deg2rad(az)):
        r = np.array([0.5, 1.0, 2.0])[:, None]
        pts = np.column_stack([r * np.cos(a), r * np.sin(a), np.full((3, 1), 0.5)])
        pix = cam.project(pts)
        np.testing.assert_allclose(line_distance(pix, lines[k : k + 1]), 0, atol=1e-6)
    assert doa_lines(cam, np.eye(4), np.zeros(0)).shape == (0, 3)
    with pytest.raises(ValueError, match="centre must be 3 numbers"):
        doa_lines(cam, np.eye(4), az, centre=(0, 0))


def test_face_measurements():
    faces = MOTData(np.array([1, 1, 3]), -np.ones(3),
                    np.array([[10.0, 20, 18, 25], [50, 60, 10, 10], [0, 0, 20, 30]]),
                    np.ones(3))  # fmt: skip
    out = face_measurements(faces, 4)
    assert [len(z) for z in out] == [2, 0, 1, 0]
    np.testing.assert_allclose(out[0], [[19.0, 40.0], [55.0, 68.0]])  # centre x, top + 0.8 h


def test_synthetic_detector_statistics():
    det = SyntheticFaceDetector()
    t, p = 15000, 2
    pos = np.broadcast_to(np.array([[100.0, 100.0], [250.0, 150.0]])[:, None], (p, t, 2))
    present = np.ones((t, p), bool)
    present[:, 1] = np.arange(t) % 2 == 0
    out = det.detect(pos, present, np.random.default_rng(0))
    assert len(out) == t
    near0 = np.array([np.any(np.linalg.norm(z - [100, 100], axis=1) < 20) for z in out])
    near1 = np.array([np.any(np.linalg.norm(z - [250, 150], axis=1) < 20) for z in out])
    assert near0.mean() == pytest.approx(det.detection_probability, abs=0.03)
    assert not np.any(near1[1::2])  # never detected while absent
    runs = np.diff(np.flatnonzero(np.diff(np.r_[1, near0.astype(int), 1]) != 0))[::2]
    assert runs.mean() == pytest.approx(det.mean_miss_run, rel=0.2)  # misses come in bursts
    err = np.vstack([z[np.linalg.norm(z - [100, 100], axis=1) < 20] - [100, 100] for z in out])
    np.testing.assert_allclose(err.std(0), det.noise_std, rtol=0.05)
    n_total = sum(len(z) for z in out)
    assert n_total - near0.sum() - near1.sum() == pytest.approx(det.clutter_rate * t, abs=20)
    again = det.detect(pos, present, np.random.default_rng(0))
    assert all(np.array_equal(a, b) for a, b in zip(out, again, strict=True))
    with pytest.raises(ValueError, match="present must have shape"):
        det.detect(pos, present.T, np.random.default_rng(0))
    with pytest.raises(ValueError, match="must be >= 1 frame"):
        SyntheticFaceDetector(mean_miss_run=0.5)


def test_av163_visual_sources(tmp_path, shared_data):
    seq = load_av163(shared_data / "av16.3", 24, 1)
    with pytest.raises(InputError, match=r"face_seq24_cam1\.mat"):
        av163_visual(shared_data / "av16.3", seq, "faces")
    with pytest.raises(ValueError, match="rng is required"):
        av163_visual(shared_data / "av16.3", seq, "synthetic")
    with pytest.raises(ValueError, match="source must be one of"):
        av163_visual(shared_data / "av16.3", seq, "histograms")
    vis, used = av163_visual(shared_data / "av16.3", seq, rng=np.random.default_rng(0))
    assert used == "synthetic" and len(vis) == seq.n_frames


# --------------------------------------------------------------------------- shared data facts


@pytest.fixture(scope="module")
def av_folder(shared_data):
    return shared_data / "av16.3"


@pytest.mark.parametrize("seq_no", [24, 45])
def test_doa_azimuths_are_seen_from_the_array_centre(av_folder, seq_no):
    seq = load_av163(av_folder, seq_no, 1)
    c = np.asarray(AV163_ARRAY_CENTRE)
    errs = []
    for t in range(seq.n_frames):
        if not len(seq.z_doa[t]):
            continue
        az = []
        for m in seq.mouth:
            j = np.searchsorted(m.time_s, seq.time_s[t])
            if j < len(m.time_s) and abs(m.time_s[j] - seq.time_s[t]) < 0.02:
                d = m.xyz[j, :2] - c[:2]
                az.append(np.degrees(np.arctan2(d[1], d[0])))
        if az:
            diff = (seq.z_doa[t][:, None] - np.array(az)[None] + 180) % 360 - 180
            errs.extend(np.abs(diff).min(axis=1))
    assert np.median(errs) < 2.5  # degrees (1.8 on seq 24, 2.2 on seq 45)
    heights = np.concatenate([m.xyz[:, 2] for m in seq.mouth]) - c[2]
    assert np.median(heights) == pytest.approx(AV163_MOUTH_HEIGHT, abs=0.05)


def test_ground_truth_lies_on_the_doa_lines(av_folder):
    seq = load_av163(av_folder, 45, 2)
    frames = av163_frames(seq, [np.zeros((0, 2))] * seq.n_frames, sigma_audio=10.0)
    truth = av163_truth(seq)
    d = [np.abs(line_distance(truth[t], f.lines)).min(axis=0)
         for t, f in enumerate(frames) if len(f.lines) and len(truth[t])]  # fmt: skip
    assert np.median(np.concatenate(d)) < 4.0  # pixels (2.1 measured)
