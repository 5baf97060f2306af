"""Direction-space persons: camera geometry, the person tracker, persons.csv."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avtrack.av.geometry import CameraGeometry
from avtrack.av.persons import PersonConfig, PersonTracker
from avtrack.av.persons_scene import (
    AUDIO_PEAK_FLOOR,
    AUDIO_PEAK_FLOORS,
    PERSONS_LOCALIZER,
    audio_peak_floor,
    audio_peaks,
    track_persons,
)
from avtrack.config import build_config
from avtrack.io.camera import PinholeCamera
from avtrack.io.mot import MOTData
from avtrack.io.persons import PERSONS_HEADER
from avtrack.localize.grid import DirectionGrid


def geometry(hfov: float = 60.0, offset=(0.0, 0.0, 0.0)) -> CameraGeometry:
    """Array at the origin of the room, x axis along room +y (yaw 90); the camera on it
    (plus ``offset``), looking along the array's x axis."""
    cam = PinholeCamera.from_fov(hfov, 640, 480, np.array(offset, float), 90.0, 0.0)
    return CameraGeometry(cam, np.zeros(3), 90.0)


def head_box(geo: CameraGeometry, az: float, el: float = 0.0, dist: float = 2.0) -> np.ndarray:
    pts = geo.direction_to_room(np.array([az]), np.array([el]), np.array([dist]))
    return geo.camera.head_box(pts)


# ------------------------------------------------------------------ geometry


def test_image_centre_is_the_array_axis():
    geo = geometry()
    az, el, dist = geo.boxes_to_directions(np.array([[320 - 20, 240 - 27, 40, 54]]))
    # a 54-pixel head of 0.24 m at f = 554.26: depth 2.463 m straight ahead
    assert az[0] == pytest.approx(0.0, abs=1e-9) and el[0] == pytest.approx(0.0, abs=1e-9)
    assert dist[0] == pytest.approx(554.2562584220408 * 0.24 / 54, rel=1e-9)
    px, inside = geo.directions_to_pixels(np.array([0.0, 90.0, 180.0]), np.zeros(3), 2.0)
    assert px[0] == pytest.approx([320, 240]) and inside.tolist() == [True, False, False]


def test_edge_of_a_60_degree_camera_is_30_degrees_off_axis():
    geo = geometry(60.0)
    px, inside = geo.directions_to_pixels(np.array([29.0, 31.0, -29.0]), np.zeros(3), 2.0)
    # azimuth counter-clockwise = to the camera's left = small u
    assert px[0, 0] < 20 and inside.tolist() == [True, False, True] and px[2, 0] > 620


@settings(max_examples=50, deadline=None)
@given(
    st.floats(-28.0, 28.0), st.floats(-20.0, 20.0), st.floats(1.0, 5.0),
    st.floats(-0.5, 0.5), st.floats(-0.5, 0.5),
)
def test_direction_pixel_direction_round_trip(az, el, dist, dx, dz):
    """A head placed in a direction projects to a box whose direction is that direction,
    also when the camera sits away from the array (the distance from the box height)."""
    geo = geometry(90.0, offset=(dx, 0.0, dz))
    box = head_box(geo, az, el, dist)
    b = box[0]
    if not np.all(np.isfinite(b)) or min(b[0], b[1]) <= 0 or b[0] + b[2] >= 640 or (
        b[1] + b[3] >= 480
    ):
        return  # clipped at the image border: its centre and height are not the head's
    a, e, r = geo.boxes_to_directions(box)
    assert a[0] == pytest.approx(az, abs=1e-6)
    assert e[0] == pytest.approx(el, abs=1e-6)
    assert r[0] == pytest.approx(dist, rel=1e-6)


# ------------------------------------------------------------------ the tracker


def run_frames(tracker, frames):
    return [tracker.step(*f) for f in frames]


def walk_out_and_back(geo, talk_away: bool, n_away: int = 150, appearance=True):
    """Frames of one person: 50 frames seen at 0 deg (visual track 7), walks out to 70 deg
    (seen while in the image), ``n_away`` frames away (peaks when ``talk_away``), back in
    as visual track 8."""
    app = np.array([[1.0, 0.0, 0.0]]) if appearance else None
    frames = []
    path = np.r_[np.zeros(50), np.linspace(0, 70, 50), np.full(n_away, 70.0),
                 np.linspace(70, 0, 50), np.zeros(50)]
    rng = np.random.default_rng(0)
    back = False
    for t, az in enumerate(path):
        if t > 100 + n_away:
            back = True
        box = head_box(geo, az)
        seen = np.all(np.isfinite(box)) and abs(az) < 28
        peaks = np.array([az + rng.normal(0, 2.0)]) if (talk_away or abs(az) < 28) else np.zeros(0)
        if seen:
            frames.append((np.array([8 if back else 7]), box, app, peaks))
        else:
            frames.append((np.zeros(0, int), np.zeros((0, 4)), None, peaks))
    return frames


def test_person_walking_out_of_the_image_while_talking_keeps_one_identity():
    geo = geometry(60.0)
    tracker = PersonTracker(geo, fps=25.0)
    outs = run_frames(tracker, walk_out_and_back(geo, talk_away=True))
    assert {int(i) for o in outs for i in o.ids} == {1}
    away = outs[120:240]
    assert all(not o.in_view[0] and np.isnan(o.pixels[0]).all() for o in away)
    assert np.mean([abs(o.azimuth_deg[0] - 70.0) for o in away]) < 5.0
    assert all(o.person_of_visual.tolist() == [1] for o in outs[-40:])  # back: track 8 -> 1


def test_silent_return_is_recognised_by_appearance():
    geo = geometry(60.0)
    tracker = PersonTracker(geo, PersonConfig(death_s=30.0), fps=25.0)
    outs = run_frames(tracker, walk_out_and_back(geo, talk_away=False))
    assert all(o.person_of_visual.tolist() == [1] for o in outs[-40:])


def test_silent_person_out_of_view_is_ended():
    geo = geometry(60.0)
    cfg = PersonConfig(death_s=4.0)
    tracker = PersonTracker(geo, cfg, fps=25.0)
    frames = walk_out_and_back(geo, talk_away=False, n_away=200)[:300]
    outs = run_frames(tracker, frames)
    quiet_from = next(t for t, f in enumerate(frames) if f[0].size == 0)
    ends = next(t for t, o in enumerate(outs) if o.ids.size == 0)
    assert ends - quiet_from == pytest.approx(4.0 * 25, abs=2)


def test_person_ended_away_is_revived_on_return_by_appearance():
    """Silent and away longer than death_s: the person ends; back in view, the new visual
    track looks like them and gets their identity back."""
    geo = geometry(60.0)
    tracker = PersonTracker(geo, PersonConfig(death_s=2.0), fps=25.0)
    outs = run_frames(tracker, walk_out_and_back(geo, talk_away=False, n_away=200))
    assert any(o.ids.size == 0 for o in outs)  # it did end while away
    assert all(o.person_of_visual.tolist() == [1] for o in outs[-40:])
    no_revival = PersonTracker(geo, PersonConfig(death_s=2.0, revive_s=1.0), fps=25.0)
    outs = run_frames(no_revival, walk_out_and_back(geo, talk_away=False, n_away=200))
    assert outs[-1].person_of_visual.tolist() == [2]


def test_talker_never_seen_is_born_from_audio_and_speaks():
    geo = geometry(60.0)
    tracker = PersonTracker(geo, fps=25.0)
    rng = np.random.default_rng(1)
    none = (np.zeros(0, int), np.zeros((0, 4)), None)
    outs = [tracker.step(*none, np.array([-80.0 + rng.normal(0, 2)])) for _ in range(30)]
    assert outs[3].ids.size == 0  # not before birth_min_frames frames of evidence
    last = outs[-1]
    assert last.ids.tolist() == [1] and not last.in_view[0]
    assert last.azimuth_deg[0] == pytest.approx(-80.0, abs=3.0) and last.speaking[0] > 0.9


def test_isolated_peaks_are_clutter():
    geo = geometry(60.0)
    tracker = PersonTracker(geo, fps=25.0)
    none = (np.zeros(0, int), np.zeros((0, 4)), None)
    rng = np.random.default_rng(2)
    for _ in range(200):
        out = tracker.step(*none, rng.uniform(-180, 180, size=1))
    assert out.ids.size == 0


def test_covariances_stay_symmetric_positive_definite():
    geo = geometry(60.0)
    tracker = PersonTracker(geo, fps=25.0)
    for f in walk_out_and_back(geo, talk_away=True):
        tracker.step(*f)
        g = tracker.gamma
        assert np.allclose(g, np.transpose(g, (0, 2, 1)))
        assert np.all(np.linalg.eigvalsh(g) > 0)


def test_bad_input_is_named():
    geo = geometry()
    with pytest.raises(ValueError, match="sigma_audio_deg"):
        PersonConfig(sigma_audio_deg=0)
    with pytest.raises(ValueError, match="birth_min_frames"):
        PersonConfig(birth_min_frames=20, birth_window=10)
    with pytest.raises(ValueError, match="unknown field"):
        build_config(PersonConfig, {"sigma": 1})
    tracker = PersonTracker(geo)
    with pytest.raises(ValueError, match="one row per visual id"):
        tracker.step(np.array([1, 2]), np.zeros((1, 4)), None, np.zeros(0))
    with pytest.raises(ValueError, match="finite"):
        tracker.step(np.zeros(0, int), np.zeros((0, 4)), None, np.array([np.nan]))
    with pytest.raises(ValueError, match="fov"):
        PersonTracker(geo, fov=(0, 700))


# ------------------------------------------------------------------ pipeline


def test_audio_peaks_average_each_video_frame():
    grid = DirectionGrid.azimuths(90.0)  # -90, 0, 90, 180
    w = np.zeros((10, 4))
    w[:5, 1] = 1.0  # frame 0 (times 0..0.016): peak at 0 deg
    w[5:, 3] = 0.5  # frame 1: at 180 deg
    t = np.r_[np.linspace(0, 0.016, 5), np.linspace(0.03, 0.05, 5)]
    peaks = audio_peaks(w, t, grid, 25.0, 3, floor=0.1)
    assert [p.tolist() for p in peaks] == [[0.0], [180.0], []]


def test_audio_peak_floor_per_localizer():
    from avtrack.localize import LOCALIZERS

    assert PERSONS_LOCALIZER in LOCALIZERS
    assert set(AUDIO_PEAK_FLOORS) <= set(LOCALIZERS)
    assert audio_peak_floor(None) == audio_peak_floor("dprtf-eg") == AUDIO_PEAK_FLOOR
    for name, floor in AUDIO_PEAK_FLOORS.items():
        assert audio_peak_floor(name) == floor > 0


@pytest.mark.slow
@pytest.mark.parametrize("localizer", ["dprtf-eg", "dprtf-eg-fast"])
def test_track_scene_persons_on_either_localizers_maps(localizer):
    """The person walking out of the image keeps one identity and is tracked out of view on
    the heat maps of either DPRTF-EG localizer; the talker never seen is found."""
    from avtrack.av.persons_scene import track_scene_persons
    from avtrack.io.doa import read_doa_csv
    from avtrack.io.scene import load_scene
    from tests.av.scenes import out_of_image

    scene_dir = out_of_image()
    res = track_scene_persons(load_scene(scene_dir), localizer=localizer)
    assert len(np.unique(res.tracks.ids)) == 1
    p = res.persons
    mine = p.ids == res.tracks.ids[0]
    away = mine & ((p.frames - 1) / p.fps >= 6.0) & ((p.frames - 1) / p.fps <= 10.0)
    assert away.sum() > 90 and not p.in_view[away].any()
    truth = read_doa_csv(scene_dir / "gt" / "doa.csv")
    sel = (truth.ids == 1) & (truth.time_s > 6) & (truth.time_s < 10)
    assert abs(np.median(p.azimuth_deg[away]) - np.median(truth.azimuth_deg[sel])) < 10.0
    hidden = {int(i) for i in np.unique(p.ids[~mine & (np.abs(p.azimuth_deg + 75.0) < 12.0)])}
    assert len(hidden) >= 1
    assert {s.speaker for s in res.speech} >= {f"P{int(res.tracks.ids[0])}"}
    assert any(s.speaker in {f"P{i}" for i in hidden} for s in res.speech)


def test_track_persons_labels_boxes_with_person_ids_and_writes_csv():
    geo = geometry(60.0)
    frames = walk_out_and_back(geo, talk_away=True, appearance=False)
    rows = [(t + 1, f[0], f[1]) for t, f in enumerate(frames) if f[0].size]
    dets = MOTData(
        np.array([r[0] for r in rows]), -np.ones(len(rows)), np.vstack([r[2] for r in rows]),
        np.ones(len(rows)),
    )
    res = track_persons(dets, None, [f[3] for f in frames], geo, 25.0, len(frames))
    assert len(np.unique(res.tracks.ids)) == 1
    text = res.persons.to_csv().splitlines()
    assert text[0] == PERSONS_HEADER
    assert len(text) - 1 == len(frames) and text[1].startswith("1,0.0000,1,")
    assert {s.speaker for s in res.speech} == {f"P{int(res.tracks.ids[0])}"}


def test_track_persons_never_repeats_an_id_in_a_frame():
    """Every head detected twice (a second box a few pixels off, as two detectors or two
    colour templates on one person give): the tracks stay a valid MOT result, one box per
    person and frame."""
    geo = geometry(60.0)
    frames = walk_out_and_back(geo, talk_away=True, appearance=False)
    rows = [(t + 1, b) for t, f in enumerate(frames) for b in f[1]]
    rows += [(t + 1, b + np.array([6.0, 3.0, 0.0, 0.0])) for t, f in enumerate(frames)
             for b in f[1]]
    rows.sort(key=lambda r: r[0])
    dets = MOTData(np.array([r[0] for r in rows]), -np.ones(len(rows)),
                   np.vstack([r[1] for r in rows]), np.ones(len(rows)))
    res = track_persons(dets, None, [f[3] for f in frames], geo, 25.0, len(frames))
    pairs = list(zip(res.tracks.frames.tolist(), res.tracks.ids.tolist(), strict=True))
    assert len(pairs) == len(set(pairs))
    assert len(pairs) >= 0.9 * len({r[0] for r in rows})  # about one box per frame seen


def test_elevation_stays_a_latitude():
    """A person whose elevation moves up at 3 degrees per frame from 89 degrees (a camera far
    from the array sees them almost over it) is reported at most at 90, and is at most 90."""
    tracker = PersonTracker(geometry(60.0), PersonConfig(), 25.0)
    tracker.step(np.array([1]), np.array([[300.0, 200.0, 40.0, 54.0]]), None, np.zeros(0))
    assert tracker.n_persons == 1
    tracker.mu[:, 1], tracker.mu[:, 3] = 89.0, 3.0
    out = tracker.step(np.zeros(0, int), np.zeros((0, 4)), None, np.zeros(0))
    assert out.elevation_deg[0] == 90.0 and tracker.mu[0, 1] == 90.0


def test_image_shows_a_person_only_while_the_camera_confirms_them():
    """A person seen at 0 deg for 50 frames, then missed by the detector for 20 frames while
    still talking in view: the image position is held for image_hold_s, then withdrawn (the
    person keeps its identity and direction); seen again, it is back at once."""
    geo = geometry(60.0)
    box = head_box(geo, 0.0)
    seen = (np.array([7]), box, None, np.array([0.0]))
    missed = (np.zeros(0, int), np.zeros((0, 4)), None, np.array([0.0]))
    frames = [seen] * 50 + [missed] * 20 + [seen] * 5
    for hold_s, held in ((0.1, 2), (0.0, 0), (0.4, 10)):
        tracker = PersonTracker(geo, PersonConfig(image_hold_s=hold_s), fps=25.0)
        outs = run_frames(tracker, frames)
        assert {int(i) for o in outs for i in o.ids} == {1}
        shown = [bool(o.in_view[0]) and bool(np.isfinite(o.pixels[0]).all()) for o in outs]
        assert all(shown[:50]) and all(shown[70:])
        assert shown[50:70] == [True] * held + [False] * (20 - held), hold_s
        assert all(abs(o.azimuth_deg[0]) < 3.0 for o in outs[50:70])  # still tracked
        centre = box[0, :2] + box[0, 2:] / 2  # seen: the visual box's centre, exactly
        assert all(np.allclose(o.pixels[0], centre) for o in outs[:50] + outs[70:])


def test_image_hold_must_not_be_negative():
    with pytest.raises(ValueError, match="image_hold_s"):
        PersonConfig(image_hold_s=-0.1)


def test_geometry_reads_a_box_at_the_depth_of_what_it_outlines():
    """A face box (0.16 m) and the head box (0.24 m) of the same person give one distance."""
    import numpy as np

    from avtrack.av.geometry import HEAD_HEIGHT_M, CameraGeometry
    from avtrack.io.camera import PinholeCamera

    cam = PinholeCamera.from_fov(60.0, 640, 480, np.zeros(3), 0.0, 0.0)
    head = CameraGeometry(cam, np.zeros(3), 0.0)
    face = CameraGeometry(cam, np.zeros(3), 0.0, box_height_m=0.16)
    z = 2.5
    hb = np.array([[300.0, 200.0, 40.0, cam.fy * HEAD_HEIGHT_M / z]])
    fb = np.array([[300.0, 200.0, 40.0, cam.fy * 0.16 / z]])
    fb[0, 1] += 0.5 * (hb[0, 3] - fb[0, 3])  # same centre
    np.testing.assert_allclose(head.boxes_to_directions(hb)[2], face.boxes_to_directions(fb)[2])
    try:
        CameraGeometry(cam, np.zeros(3), 0.0, box_height_m=-1.0)
    except ValueError as exc:
        assert "box_height_m" in str(exc)
    else:
        raise AssertionError("a negative box height was accepted")
