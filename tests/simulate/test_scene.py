"""Whole scenes: files, ground-truth consistency, determinism, the ``simulate`` CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest
import soundfile as sf
import yaml

from avtrack.cli.main import main
from avtrack.errors import InputError
from avtrack.io.camera import PinholeCamera
from avtrack.io.doa import read_doa_csv
from avtrack.io.mot import read_mot
from avtrack.io.rttm import read_rttm
from avtrack.io.scenario import load_scenario, validate_scenario
from avtrack.simulate.library import named_scenario
from avtrack.simulate.scene import simulate_scene, write_scene


def _walkout(seed=0, duration=4.0, **over):
    raw = named_scenario("walkout", seed, duration)
    raw["speech"] = {**raw["speech"], "utterances": "synthetic"}
    raw.update(over)
    return validate_scenario(raw)


@pytest.fixture(scope="module")
def scene_dir(tmp_path_factory):
    sc = _walkout(seed=2, duration=6.0)
    scene = simulate_scene(sc)
    out = tmp_path_factory.mktemp("scenes") / "walkout"
    write_scene(scene, out)
    return scene, out


def test_scene_directory_contract(scene_dir):
    scene, out = scene_dir
    names = {p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()}
    assert names == {
        "scene.yaml",
        "audio.wav",
        "array.json",
        "camera.json",
        "detections.txt",
        "appearance.npy",
        "gt/gt.txt",
        "gt/doa.csv",
        "gt/speech.rttm",
        "gt/positions.csv",
        *(f"gt/voices/{pid}.wav" for pid in scene.ids),
    }
    audio, fs = sf.read(out / "audio.wav", always_2d=True)
    assert fs == 16000 and audio.shape == (6 * 16000, 4)
    # the references at microphone 0 add up to its speech: what is left is the noise
    refs = np.stack([sf.read(out / "gt" / "voices" / f"{pid}.wav")[0] for pid in scene.ids])
    assert refs.shape == (scene.ids.size, 6 * 16000)
    residual = audio[:, 0] - refs.sum(axis=0)
    assert np.sum(residual**2) < 0.1 * np.sum(audio[:, 0] ** 2)
    assert np.all(np.isfinite(audio)) and 0 < np.abs(audio).max() <= 0.9 + 1e-6
    assert json.loads((out / "array.json").read_text())["positions"]
    dets = read_mot(out / "detections.txt", kind="det")
    app = np.load(out / "appearance.npy")
    assert app.shape[0] == dets.frames.size
    # scene.yaml re-simulates the same scene
    assert load_scenario(out / "scene.yaml") == scene.scenario


def test_gt_boxes_are_the_projected_positions(scene_dir):
    _scene, out = scene_dir
    cam = PinholeCamera.from_json(json.loads((out / "camera.json").read_text()))
    gt = read_mot(out / "gt" / "gt.txt", kind="gt")
    pos = np.loadtxt(out / "gt" / "positions.csv", delimiter=",", skiprows=1, ndmin=2)
    lookup = {(int(r[0]), int(r[2])): r[3:6] for r in pos}
    assert gt.frames.size > 0
    for f, pid, box in zip(gt.frames, gt.ids, gt.boxes, strict=True):
        want = cam.head_box(lookup[(f, pid)][None, :])[0]
        np.testing.assert_allclose(box, want, atol=0.02)  # file precision: 2 decimals
    # some frames have people out of view (walkout), so gt has fewer rows than positions
    assert gt.frames.size < pos.shape[0]


def test_gt_doa_matches_positions(scene_dir):
    scene, out = scene_dir
    doa = read_doa_csv(out / "gt" / "doa.csv")
    sc = scene.scenario
    centre = np.asarray(sc["array"]["position"])
    yaw = sc["array"]["yaw_deg"]
    for traj, pid in zip(scene.trajectories, scene.ids, strict=True):
        rows = doa.ids == pid
        p = traj.position(doa.time_s[rows]) - centre
        az = np.rad2deg(np.arctan2(p[:, 1], p[:, 0])) - yaw
        diff = np.angle(np.exp(1j * np.deg2rad(doa.azimuth_deg[rows] - az)))
        assert np.abs(np.rad2deg(diff)).max() < 0.01
        el = np.rad2deg(np.arctan2(p[:, 2], np.hypot(p[:, 0], p[:, 1])))
        np.testing.assert_allclose(doa.elevation_deg[rows], el, atol=0.01)


def test_rttm_matches_where_sources_are_active(scene_dir):
    scene, out = scene_dir
    segs = read_rttm(out / "gt" / "speech.rttm")
    assert segs, "a 6 s conversation has speech"
    fs = scene.fs
    t = np.arange(scene.dry.shape[1]) / fs
    for k, pid in enumerate(scene.ids):
        inside = np.zeros(t.size, dtype=bool)
        mine = [s for s in segs if s.speaker == f"P{pid}"]
        for s in mine:
            a, b = round(s.start * fs), round((s.start + s.duration) * fs)
            inside[a:b] = True
            assert np.any(scene.dry[k, a:b] != 0), "every RTTM segment has signal"
        assert not np.any(scene.dry[k, ~inside]), "no signal outside the RTTM segments"
    # doa.csv's active flag agrees with the RTTM
    doa = read_doa_csv(out / "gt" / "doa.csv")
    for pid in scene.ids:
        rows = doa.ids == pid
        speaking = np.zeros(rows.sum(), dtype=bool)
        for s in segs:
            if s.speaker == f"P{pid}":
                tt = doa.time_s[rows]
                speaking |= (tt >= s.start - 1e-3) & (tt < s.start + s.duration - 1e-3)
        np.testing.assert_array_equal(doa.active[rows], speaking)


def test_same_seed_same_scene_other_seed_other_scene():
    a = simulate_scene(_walkout(seed=5, duration=2.0))
    b = simulate_scene(_walkout(seed=5, duration=2.0))
    c = simulate_scene(_walkout(seed=6, duration=2.0))
    np.testing.assert_array_equal(a.audio, b.audio)
    np.testing.assert_array_equal(a.detections.detections.boxes, b.detections.detections.boxes)
    assert a.audio.shape != c.audio.shape or not np.array_equal(a.audio, c.audio)


def test_detector_settings_do_not_change_the_audio():
    sc = _walkout(seed=1, duration=2.0)
    other = validate_scenario({**sc, "detector": {**sc["detector"], "miss_rate": 0.5}})
    a, b = simulate_scene(sc), simulate_scene(other)
    np.testing.assert_array_equal(a.audio, b.audio)


def test_write_scene_refuses_a_foreign_directory(tmp_path, scene_dir):
    scene, _ = scene_dir
    (tmp_path / "precious.txt").write_text("keep me")
    with pytest.raises(InputError, match="not a scene directory"):
        write_scene(scene, tmp_path)
    assert (tmp_path / "precious.txt").read_text() == "keep me"


def test_cli_simulate_named_and_file(tmp_path, capsys):
    out = tmp_path / "w"
    rc = main(
        [
            "simulate",
            "walkout",
            "-o",
            str(out),
            "--duration",
            "2",
            "--seed",
            "3",
            "--utterances",
            "synthetic",
        ]
    )
    assert rc == 0 and (out / "audio.wav").is_file()
    assert "walkout (seed 3)" in capsys.readouterr().out
    # re-simulate from the written scene.yaml into the same directory (--force: it is not
    # empty): identical audio
    before = sf.read(out / "audio.wav")[0]
    rc = main(["simulate", str(out / "scene.yaml"), "-o", str(out), "-q", "--force"])
    assert rc == 0
    np.testing.assert_array_equal(sf.read(out / "audio.wav")[0], before)


def test_cli_simulate_errors(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump({"people": [{"motion": {"type": "seated"}}]}))
    assert main(["simulate", str(bad), "-o", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert "bad.yaml" in err and "people[0].motion.position: required" in err
    assert not (tmp_path / "x").exists()
    assert main(["simulate", "nonesuch", "-o", str(tmp_path / "y")]) == 2
    assert "not a named scenario" in capsys.readouterr().err
    assert main(["simulate", "walkout"]) == 2
    assert "-o SCENE_DIR is required" in capsys.readouterr().err


def test_cli_print_and_reference(capsys):
    assert main(["simulate", "meeting", "--print", "--seed", "1"]) == 0
    printed = yaml.safe_load(capsys.readouterr().out)
    assert printed["name"] == "meeting" and printed["seed"] == 1
    assert main(["simulate", "--help-scenario"]) == 0
    assert "azimuth-track" in capsys.readouterr().out


@pytest.mark.parametrize("name", ["locata-like", "kinovis-like", "meeting"])
def test_named_scenes_with_real_material(name, shared_data, tmp_path):
    sc = validate_scenario(named_scenario(name, seed=0, duration=3.0))
    scene = simulate_scene(sc, data_dir=shared_data)
    assert scene.scenario["speech"]["utterances"] == "shared"
    assert scene.audio.shape == (scene.array.n_mics, 3 * 16000)
    assert np.all(np.isfinite(scene.audio))
    write_scene(scene, tmp_path / name)
    assert (tmp_path / name / "gt" / "doa.csv").is_file()
