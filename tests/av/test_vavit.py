"""VAVIT (thesis ch. 4): a talker who walks out of view keeps their identity on audio alone."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from avtrack.av.features import AudioFeatureConfig, AudioFeatures, extract_audio_features
from avtrack.av.vavit import (
    VAVITConfig,
    VAVITracker,
    fov_strip,
    restrict_fov,
    track_scene,
    with_visual,
)
from avtrack.config import build_config
from avtrack.io.mot import read_mot
from avtrack.io.scene import load_scene
from avtrack.visual.ovbt import OVBTConfig
from tests.av.scenes import FOV_FRACTION, walkout


@pytest.fixture(scope="module")
def scene():
    scene_dir, mapping, _ = walkout()
    sc = load_scene(scene_dir)
    feats = extract_audio_features(sc.audio, sc.fs, sc.n_frames, AudioFeatureConfig())
    gt = read_mot(scene_dir / "gt" / "gt.txt", kind="gt")
    return scene_dir, mapping, sc, feats, gt


def _centres(data) -> dict[int, float]:
    return {int(f): float(b[0] + b[2] / 2) for f, b in zip(data.frames, data.boxes, strict=True)}


def test_walking_out_of_view_keeps_identity_on_audio(scene):
    scene_dir, mapping, sc, feats, gt = scene
    lo, _ = fov_strip(sc.image_size[0], FOV_FRACTION)
    gx = _centres(gt)
    out = [f for f, x in gx.items() if x < lo - 20]  # frames the camera cannot see them
    assert len(out) > 100
    res = track_scene(scene_dir, mapping, fov_fraction=FOV_FRACTION, features=feats, scene=sc)
    assert np.unique(res.tracks.ids).tolist() == [1]  # one identity from start to end
    tx = _centres(res.tracks)
    assert sum(f in tx for f in out) >= 0.95 * len(out)  # reported while out of view
    err = np.array([abs(tx[f] - gx[f]) for f in out if f in tx])
    # the same tracker without audio observations only coasts: audio halves the error
    mute = dataclasses.replace(
        feats, active=np.zeros_like(feats.active), vad=np.zeros_like(feats.vad)
    )
    coast = track_scene(scene_dir, mapping, fov_fraction=FOV_FRACTION, features=mute, scene=sc)
    cx = _centres(coast.tracks)
    coast_err = np.array([abs(cx[f] - gx[f]) for f in out if f in cx])
    assert np.median(err) < 0.7 * np.median(coast_err)
    assert np.median(err) < 45.0  # pixels, a head is ~60 px wide here
    # the visual-only tracker loses them and gives them a new identity when they come back
    vis = track_scene(scene_dir, fov_fraction=FOV_FRACTION, use_audio=False, scene=sc)
    vx = _centres(vis.tracks)
    assert sum(f in vx for f in out) < 0.1 * len(out)
    assert len(np.unique(vis.tracks.ids)) == 2


def test_full_view_tracks_and_diarizes(scene):
    scene_dir, mapping, sc, feats, _gt = scene
    res = track_scene(scene_dir, mapping, features=feats, scene=sc, record_precisions=True)
    assert np.unique(res.tracks.ids).tolist() == [1]
    assert res.precisions.shape == (len(res.tracks), 3, 2, 2)
    # visual, audio and dynamics precisions are symmetric positive semi-definite
    eig = np.linalg.eigvalsh(res.precisions)
    assert np.all(eig > -1e-12)
    assert res.speech and {s.speaker for s in res.speech} == {"P1"}
    spoken = sum(s.duration for s in res.speech)
    assert 0.3 * res.timing["duration"] < spoken < res.timing["duration"]


def test_online_step_api(scene):
    _scene_dir, mapping, sc, feats, _ = scene
    fov = fov_strip(sc.image_size[0], 1.0)
    dets, app = restrict_fov(sc.detections, sc.appearance, fov)
    tracker = VAVITracker(mapping, image_size=sc.image_size)
    ids = set()
    for t, sl in enumerate(dets.frame_slices(60)):
        bands, g = feats.frame(t)
        out = tracker.step(dets.boxes[sl], dets.scores[sl], app[sl], bands, g)
        assert out.boxes.shape == (len(out.ids), 4)
        assert out.speaking.dtype == bool and out.audio_share.shape == out.ids.shape
        ids |= set(out.ids.tolist())
    assert ids == {1}
    # a frame without audio observations
    out = tracker.step(dets.boxes[:0], appearance=app[:0])
    assert not out.speaking.any()


def test_config_validation():
    with pytest.raises(ValueError, match="sigma_scale"):
        VAVITConfig(sigma_scale=0.0)
    with pytest.raises(ValueError, match="diarization_threshold"):
        VAVITConfig(diarization_threshold=1.5)
    with pytest.raises(ValueError, match="unknown field"):
        build_config(VAVITConfig, {"sigma": 2})
    cfg = build_config(VAVITConfig, {"visual": {"death_frames": 5}, "sigma_scale": 2.0})
    assert cfg.visual.death_frames == 5 and cfg.visual.appearance == "cosine"
    assert with_visual(VAVITConfig(), death_frames=7).visual.death_frames == 7
    assert VAVITConfig().visual == OVBTConfig(appearance="cosine", weak_evidence=1.0,
                                              birth_sequence=False)


def test_bad_inputs_are_named(scene, tmp_path):
    scene_dir, mapping, sc, feats, _ = scene
    with pytest.raises(ValueError, match="fov"):
        VAVITracker(mapping, image_size=(640, 480), fov=(500, 100))
    with pytest.raises(ValueError, match="fov fraction"):
        track_scene(scene_dir, mapping, fov_fraction=0.0, scene=sc)
    with pytest.raises(ValueError, match="mapping"):
        track_scene(scene_dir, None, scene=sc)
    short = AudioFeatures(
        *(
            getattr(feats, n)[:10]
            for n in ("features", "active", "vad", "speech_fraction", "band_power")
        )
    )
    with pytest.raises(ValueError, match="features cover 10 frames"):
        track_scene(scene_dir, mapping, features=short, scene=sc)
    with pytest.raises(ValueError, match="scene directory not found"):
        load_scene(tmp_path / "nowhere")
