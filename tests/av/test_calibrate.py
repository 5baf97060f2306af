"""Camera self-calibration from audio directions and head boxes (``avtrack.av.calibrate``)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from avtrack.av.calibrate import (
    camera_evidence,
    check_camera,
    fit_camera,
)
from avtrack.io.camera import PinholeCamera
from avtrack.io.mot import MOTData
from avtrack.localize.grid import heard_azimuth

FPS = 25.0


def _true_camera(yaw=20.0, pitch=0.0, hfov=60.0, position=(0.0, 0.0, 0.05)):
    return PinholeCamera.from_fov(hfov, 640, 480, np.asarray(position), yaw, pitch)


def _recording(camera, n_frames=400, outliers=0.0, seed=0, elevation=False, noise=1.0,
               sway_deg=6.0, turns=(0, 1, 2), line=None, height=(0.1, 0.45, -0.05),
               origin=(0.0, 0.0)):
    """Three people in front of the camera taking turns (one talker a frame, ``turns`` in
    order, 40 frames each), in the array's frame, swaying ``sway_deg``; a fraction
    ``outliers`` of the frames hears a random direction instead. ``line``: the axis of a
    line of microphones, which hears each talker at :func:`heard_azimuth`. The people stand
    around ``origin`` (x, y: the array's centre by default, the camera's place for a camera
    away from the array) and are heard from the array."""
    rng = np.random.default_rng(seed)
    yaw = camera.yaw_deg
    az = yaw + np.array([-24.0, -8.0, 19.0])
    dist = np.array([1.8, 2.4, 2.0])
    height = np.asarray(height)  # head heights relative to the array
    frames, ids, boxes, azs, els = [], [], [], [], []
    for t in range(n_frames):
        # people sway a little, the talker changes every 40 frames
        a = az + sway_deg * np.sin(0.02 * t + np.arange(3))
        pts = np.column_stack([origin[0] + dist * np.cos(np.deg2rad(a)),
                               origin[1] + dist * np.sin(np.deg2rad(a)), height])
        b = camera.head_box(pts)
        for i in range(3):
            if np.all(np.isfinite(b[i])):
                frames.append(t + 1)
                ids.append(i + 1)
                boxes.append(b[i])
        talker = turns[(t // 40) % len(turns)]
        p = pts[talker]
        if rng.random() < outliers:
            azs.append(np.array([rng.uniform(-180, 180)]))
            els.append(np.array([rng.uniform(-20, 40)]))
        else:
            heard = (np.degrees(np.arctan2(p[1], p[0])) if line is None
                     else heard_azimuth(p[None], line)[0])
            azs.append(np.array([heard + rng.normal(0, noise)]))
            els.append(np.array([np.degrees(np.arctan2(p[2], np.hypot(p[0], p[1])))
                                 + rng.normal(0, noise)]))
    dets = MOTData(np.array(frames), np.array(ids), np.array(boxes), np.ones(len(frames)))
    return camera_evidence(dets, azs, FPS, (640, 480), els if elevation else None,
                           line_axis=line)


@pytest.mark.parametrize("yaw", [0.0, 20.0, -135.0])
def test_fit_recovers_a_known_camera(yaw):
    cam = _true_camera(yaw=yaw, hfov=60.0)
    fit = fit_camera(_recording(cam), position=cam.position)
    assert abs(fit.camera.yaw_deg - yaw) < 1.0
    assert abs(fit.camera.fx / cam.fx - 1.0) < 0.05
    assert fit.camera.pitch_deg == 0.0 and not fit.pitch_fitted
    assert 0 < fit.yaw_std_deg < 1.0 and 0 < fit.focal_std_px < 0.05 * cam.fx
    assert "yaw" in fit.summary()


def test_fit_hears_the_talkers_as_a_line_of_microphones_does():
    """Two microphones on a line (axis y) hear talkers above them nearer the axis; the fit
    that knows it recovers the camera, the one that takes the sounds as horizontal does not."""
    cam = _true_camera(yaw=0.0, hfov=60.0, pitch=20.0)  # looking up at standing talkers
    axis = np.array([0.0, 1.0, 0.0])
    heights = (1.0, 1.3, 1.0)  # 25-33 degrees above the array
    ev = _recording(cam, line=axis, height=heights, noise=0.3)
    fit = fit_camera(ev, position=cam.position, pitch_deg=20.0)
    assert abs(fit.camera.fx / cam.fx - 1.0) < 0.03 and abs(fit.camera.yaw_deg) < 1.0
    flat = fit_camera(replace(ev, line_axis=None), position=cam.position, pitch_deg=20.0)
    assert flat.camera.fx / cam.fx - 1.0 > 0.1  # the sounds seem closer together (+14 %)


def test_fit_places_a_camera_away_from_the_array_at_the_position_given():
    """A camera 2.3 m from the array and 1.4 m above it, looking down at people 1.8-2.4 m in
    front of it (as AV16.3's camera 1): at its measured position the fit recovers its yaw
    and focal length; taken to stand at the array, it does not."""
    pos = (-1.6, 1.6, 1.4)
    cam = _true_camera(yaw=-25.0, pitch=-17.0, hfov=50.0, position=pos)
    ev = _recording(cam, origin=pos[:2], height=(0.45, 0.6, 0.4), noise=0.5)
    fit = fit_camera(ev, position=np.array(pos), pitch_deg=-17.0)
    assert abs(fit.camera.yaw_deg + 25.0) < 1.0
    assert abs(fit.camera.fx / cam.fx - 1.0) < 0.05
    assert np.allclose(fit.camera.position, pos)
    centre = fit_camera(ev, pitch_deg=-17.0)  # yaw 49 deg measured
    assert abs(centre.camera.yaw_deg + 25.0) > 10.0


def test_level_with_horizon_holds_the_pitch_of_the_heads_and_refits_the_rest():
    """The camera of the test above fitted level (the audio has no elevation), then with the
    pitch of the heads' horizon (the true camera's horizon row, 4 px uncertain): pitch,
    yaw and focal length are the camera's; a horizon too uncertain, or none, changes
    nothing, nor does it replace a pitch the audio measured."""
    import math

    from avtrack.av.calibrate import MAX_HORIZON_STD_DEG, level_with_horizon
    from avtrack.visual.horizon import Horizon

    pos = (-1.6, 1.6, 1.4)
    cam = _true_camera(yaw=-25.0, pitch=-17.0, hfov=50.0, position=pos)
    ev = _recording(cam, origin=pos[:2], height=(0.45, 0.6, 0.4), noise=0.5)
    level = fit_camera(ev, position=np.array(pos))
    assert level.pitch_source == "held" and level.camera.pitch_deg == 0.0
    row = cam.cy + cam.fy * math.tan(math.radians(-17.0))
    fit = level_with_horizon(level, ev, Horizon(row, 4.0, 3, 12))
    assert fit.pitch_source == "heads" and fit.pitch_fitted
    assert abs(fit.camera.pitch_deg + 17.0) < 1.0
    assert abs(fit.camera.yaw_deg + 25.0) < 1.0 and abs(fit.camera.fx / cam.fx - 1.0) < 0.05
    # 4 px at the focal length: degrees(4 / f) / (1 + tan(17 deg)^2), 0.31 deg
    t = math.tan(math.radians(fit.camera.pitch_deg))
    assert fit.pitch_std_deg == pytest.approx(math.degrees(4.0 / fit.camera.fx) / (1 + t * t),
                                              rel=1e-3)
    assert "from the horizon of the heads" in fit.summary()
    vague = Horizon(row, 1.1 * cam.fx * math.radians(MAX_HORIZON_STD_DEG), 1, 4)
    assert level_with_horizon(level, ev, vague) is level
    assert level_with_horizon(level, ev, None) is level
    heard = fit_camera(_recording(_true_camera(pitch=8.0), elevation=True))
    assert level_with_horizon(heard, ev, Horizon(row, 4.0, 3, 12)) is heard


def test_focal_bias_is_what_directions_heard_nearer_each_other_do_to_the_focal_length():
    """Audio directions heard AUDIO_BIAS_DEG nearer each other at their spread (as
    reverberation pulls them towards the array's axis) fit equally well with a longer focal
    length: longer by about ``focal_bias_px``, which the bootstrap does not show."""
    from avtrack.av.calibrate import AUDIO_BIAS_DEG

    cam = _true_camera(yaw=10.0, hfov=60.0)
    ev = _recording(cam, noise=0.3)
    fit = fit_camera(ev, position=cam.position)
    spread = AUDIO_BIAS_DEG * (1.0 + fit.camera.fx / fit.focal_bias_px)  # degrees, 17.6 here
    assert 10.0 < spread < 25.0
    squeezed = 10.0 + (ev.azimuth_deg - 10.0) * (1.0 - AUDIO_BIAS_DEG / spread)
    moved = fit_camera(replace(ev, azimuth_deg=squeezed), position=cam.position)
    assert 0.8 < (moved.camera.fx - fit.camera.fx) / fit.focal_bias_px < 1.2
    assert fit.focal_std_px < 0.2 * fit.focal_bias_px
    assert f"+{fit.focal_bias_px:.0f} if the audio directions are heard" in fit.summary()


def test_refine_yaw_takes_the_yaw_from_other_directions_and_keeps_the_focal_length():
    """Directions heard 2.5 deg off to one side (an azimuth map of talkers above a planar
    array) turn the fit by as much; refitted on directions without that offset, the yaw is
    the camera's again and the focal length is the first fit's, exactly."""
    from avtrack.av.calibrate import refine_yaw

    cam = _true_camera(yaw=15.0, hfov=60.0)
    ev = _recording(cam, noise=0.5, seed=4)
    off = replace(ev, azimuth_deg=ev.azimuth_deg + 2.5)
    fit = fit_camera(off, position=cam.position)
    assert abs(fit.camera.yaw_deg - 17.5) < 0.5
    turned = refine_yaw(fit, ev)
    assert abs(turned.camera.yaw_deg - 15.0) < 0.5
    assert turned.camera.fx == fit.camera.fx and turned.focal_std_px == fit.focal_std_px
    assert 0 < turned.yaw_std_deg < 1.0
    with pytest.raises(ValueError, match="hold_focal needs"):
        fit_camera(ev, hold_focal=True)


def test_fit_measures_the_pitch_from_audio_elevations():
    cam = _true_camera(yaw=10.0, pitch=8.0, hfov=70.0)
    fit = fit_camera(_recording(cam, elevation=True), position=cam.position)
    assert fit.pitch_fitted and fit.pitch_source == "audio"
    assert abs(fit.camera.pitch_deg - 8.0) < 1.5
    assert abs(fit.camera.yaw_deg - 10.0) < 1.0


def test_fit_is_robust_to_30_percent_outliers():
    cam = _true_camera(yaw=-40.0, hfov=75.0)
    fit = fit_camera(_recording(cam, outliers=0.3, seed=1), position=cam.position)
    assert abs(fit.camera.yaw_deg + 40.0) < 1.0
    assert abs(fit.camera.fx / cam.fx - 1.0) < 0.05
    assert fit.n_inliers < 0.8 * fit.n_directions


def test_fit_finds_the_camera_of_people_standing_still():
    """Still people are heard exactly where the true camera puts their boxes: a score that
    discounts matches by how often each direction is heard (chance) gave the true camera no
    more than any other, and picked a wrong one."""
    cam = _true_camera(yaw=15.0, hfov=60.0)
    fit = fit_camera(_recording(cam, sway_deg=0.0, outliers=0.2, seed=3), position=cam.position)
    assert abs(fit.camera.yaw_deg - 15.0) < 1.0
    assert abs(fit.camera.fx / cam.fx - 1.0) < 0.05


def test_fit_does_not_collapse_the_boxes_onto_the_talker_heard_most():
    """One person talks four times as long as the others: a camera of a tiny field of view
    putting every box on that person's direction would match most directions."""
    cam = _true_camera(yaw=-30.0, hfov=70.0)
    ev = _recording(cam, n_frames=480, seed=2, turns=(1, 1, 1, 1, 0, 2))
    fit = fit_camera(ev, position=cam.position)
    assert abs(fit.camera.yaw_deg + 30.0) < 1.0
    assert abs(fit.camera.fx / cam.fx - 1.0) < 0.05


def test_too_little_evidence_is_a_clear_error():
    cam = _true_camera()
    ev = _recording(cam, n_frames=15)
    with pytest.raises(ValueError, match=r"too little evidence.*talking while the camera"):
        fit_camera(ev)


def test_check_is_silent_for_the_right_camera():
    cam = _true_camera(yaw=15.0)
    chk = check_camera(cam, _recording(cam))
    assert chk.warnings == ()


def test_check_names_a_room_frame_camera():
    cam = _true_camera(yaw=15.0)
    room = PinholeCamera(cam.fx, cam.fy, cam.cx, cam.cy, 640, 480,
                         np.array([3.0, 0.8, 1.35]), 105.0, 0.0)
    chk = check_camera(room, _recording(cam))
    assert any("room's frame" in w for w in chk.warnings), chk.warnings


def test_check_names_mirrored_channels():
    cam = _true_camera(yaw=15.0)
    chk = check_camera(cam, _recording(cam).mirrored())
    assert any("mirrored" in w and "swapped" in w for w in chk.warnings), chk.warnings


def test_check_names_rotated_channels():
    cam = _true_camera(yaw=15.0)
    chk = check_camera(cam, _recording(cam).rotated(90.0))
    assert len(chk.warnings) == 1
    assert "90 deg" in chk.warnings[0] and "rotated" in chk.warnings[0]


def test_check_names_millimetres():
    cam = _true_camera(yaw=15.0, position=(0.0, 120.0, 50.0))
    ev = _recording(_true_camera(yaw=15.0, position=(0.0, 0.12, 0.05)))
    chk = check_camera(cam, ev)
    assert any("millimetres" in w for w in chk.warnings), chk.warnings
    assert len(chk.warnings) == 1


def test_check_names_a_pitch_of_the_wrong_sign_from_the_heads_horizon():
    """A camera 12 degrees down written with pitch +12: the audio (no elevations) cannot tell,
    the heads' horizon can; the right pitch, or no horizon, passes."""
    import math

    from avtrack.av.calibrate import MAX_HORIZON_STD_DEG
    from avtrack.visual.horizon import Horizon

    cam = _true_camera(yaw=10.0, pitch=-12.0)
    ev = _recording(cam)
    hz = Horizon(cam.cy + cam.fy * math.tan(math.radians(-12.0)), 6.0, 3, 20)
    chk = check_camera(replace(cam, pitch_deg=12.0), ev, horizon=hz)
    assert len(chk.warnings) == 1 and "pitch_deg's sign wrong" in chk.warnings[0], chk.warnings
    assert "pitch -12.0 deg" in chk.warnings[0]
    off = check_camera(replace(cam, pitch_deg=0.0), ev, horizon=hz)
    assert len(off.warnings) == 1 and "pitch_deg -12.0 would fit" in off.warnings[0]
    right = check_camera(cam, ev, horizon=hz)
    assert right.warnings == () and right.fit.pitch_source == "heads"
    assert abs(right.fit.camera.pitch_deg + 12.0) < 0.5
    assert check_camera(replace(cam, pitch_deg=12.0), ev).warnings == ()
    vague = Horizon(hz.row_px, 1.1 * cam.fy * math.radians(MAX_HORIZON_STD_DEG), 1, 4)
    unsure = check_camera(replace(cam, pitch_deg=12.0), ev, horizon=vague)
    assert unsure.warnings == () and unsure.fit.pitch_source == "held"


def _dense_search(ev, pitch_deg):
    """``_search`` written over whole (pairs x yaws) arrays."""
    import math

    from avtrack.av.calibrate import (
        MATCH_DEG,
        UNSEEN_TALKER_WEIGHT,
        _starts,
        predicted_directions,
    )
    from avtrack.io.doa import wrap_azimuth

    starts = _starts(ev.direction)
    yaws = np.arange(-180.0, 180.0, 1.0)
    best, best_score = (0.0, 1.0, -1), -np.inf
    for hfov in np.arange(20.0, 151.0, 5.0):
        f = 0.5 * ev.width / math.tan(math.radians(hfov) / 2.0)
        g, _ = predicted_directions(ev, 0.0, pitch_deg, f, np.zeros(3))
        off = wrap_azimuth(ev.azimuth_deg - g)
        hit = np.abs(wrap_azimuth(off[:, None] - yaws[None, :])) < MATCH_DEG
        k = np.add.reduceat(hit.astype(np.int64), starts, axis=0)  # boxes each direction hits
        score = np.where(k > 0, 1.0 / np.maximum(k, 1), 0.0).sum(axis=0)
        first = ev.azimuth_deg[starts]
        inside = np.abs(wrap_azimuth(first[:, None] - yaws[None, :])) < 0.5 * hfov - MATCH_DEG
        score -= UNSEEN_TALKER_WEIGHT * (inside & (k == 0)).sum(axis=0)
        mean = np.degrees(np.arctan2(np.sin(np.radians(first)).sum(),
                                     np.cos(np.radians(first)).sum()))
        heard = wrap_azimuth(first - mean)
        span = np.array([np.ptp(heard[k[:, y] > 0]) if np.any(k[:, y] > 0) else -np.inf
                         for y in range(yaws.size)])
        score = np.where(span >= 2.0 * MATCH_DEG, score, -np.inf)
        j = int(np.argmax(score))
        if np.isfinite(score[j]) and score[j] > best_score:
            best_score, best = float(score[j]), (float(yaws[j]), f, int((k > 0).sum(axis=0)[j]))
    return best


@pytest.mark.parametrize("chunk", [1, 7, 30, 360])
def test_search_a_few_yaws_at_a_time_is_the_dense_formula(chunk, monkeypatch):
    """The search holds (pairs x a few yaws) at a time; its choice is that of the formula over
    whole (pairs x yaws) arrays, exactly."""
    from avtrack.av import calibrate as C

    for seed, yaw in ((4, -40.0), (5, 120.0)):
        ev = _recording(_true_camera(yaw=yaw), n_frames=300, outliers=0.3, seed=seed)
        expected = _dense_search(ev, 0.0)
        monkeypatch.setattr(C, "_YAW_CHUNK", chunk)
        assert C._search(ev, 0.0) == expected


def test_check_is_silent_for_the_right_camera_metres_from_the_array():
    """A camera 2 m behind the array (as AV16.3's): the check fits the camera at the given
    place (and from the given camera) and finds nothing to say."""
    cam = _true_camera(yaw=0.0, position=(-2.0, 0.3, 0.4))
    chk = check_camera(cam, _recording(cam))
    assert chk.warnings == (), chk.warnings
    assert abs(chk.fit.camera.yaw_deg - cam.yaw_deg) < 2.0
    assert abs(chk.fit.camera.fx / cam.fx - 1.0) < 0.1


def test_face_boxes_give_the_evidence_of_head_boxes_at_the_same_depth():
    cam = _true_camera(yaw=10.0)
    head = _recording(cam)
    pts = np.array([[2.0, 0.3, 0.1]])
    hb = cam.head_box(pts)[0]
    face = hb.copy()
    face[3] *= 0.16 / 0.24  # a face box (0.16 m) of the same head, same centre row
    face[1] = hb[1] + 0.5 * (hb[3] - face[3])
    dets = MOTData(np.array([1, 1]), np.array([1, 2]), np.vstack([hb, face]), np.ones(2))
    ev = camera_evidence(dets, [np.array([5.0])], FPS, (640, 480))
    ev_face = camera_evidence(dets, [np.array([5.0])], FPS, (640, 480), box_height_m=0.16)
    np.testing.assert_allclose(ev_face.h[1], ev.h[0])  # the face box read as its head
    assert head.n_directions > 0
    with pytest.raises(ValueError, match="box_height_m"):
        camera_evidence(dets, [np.array([5.0])], FPS, (640, 480), box_height_m=0.0)
