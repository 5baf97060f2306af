"""Foreground head tops: hand-built frames with a person-shaped blob and a known head."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.visual.colour import hue_saturation_bins
from avtrack.visual.heads import ForegroundHeadDetector

W, H = 160, 120


def background() -> np.ndarray:
    """A textured, static room: vertical grey stripes and a little fixed noise."""
    rng = np.random.default_rng(0)
    img = np.full((H, W, 3), 150, np.uint8)
    img[:, ::8] = 120
    return np.clip(img.astype(int) + rng.integers(-3, 4, img.shape), 0, 255).astype(np.uint8)


def person(img: np.ndarray, x: int, top: int, head: int, colour=(40, 60, 160)) -> None:
    """Draw a person: an elliptical head ``head`` pixels tall whose top is at ``(x, top)``
    and shoulders / body below it, in place."""
    import cv2

    hw = int(0.75 * head) // 2
    cv2.ellipse(img, (x, top + head // 2), (hw, head // 2), 0, 0, 360, colour, -1)
    cv2.rectangle(img, (x - 2 * hw, top + head), (x + 2 * hw, H - 1), (90, 90, 40), -1)


def learnt(det: ForegroundHeadDetector, n: int = 40) -> None:
    for _ in range(n):
        det.detect(background())


def test_head_top_and_mouth_of_one_person():
    det = ForegroundHeadDetector(20.0, gain=True)
    learnt(det)
    img = background()
    person(img, 70, 30, 20)
    boxes, scores = det.detect(img)
    assert len(boxes) == 1  # the shoulders are not heads
    left, top, w, h = boxes[0]
    assert left + w / 2 == pytest.approx(70, abs=2)
    assert top == pytest.approx(30, abs=3)
    assert h == 20 and w == 15
    assert det.mouth_offset == pytest.approx(0.69)
    assert scores.tolist() == [1.0]


def test_two_people_and_the_geometry_map_sets_each_head_size():
    # heads lower in the image are nearer, hence taller: a map growing downwards
    size = np.repeat(np.linspace(10, 40, H)[:, None], W, axis=1)
    det = ForegroundHeadDetector(size, head_aspect=0.0)  # the geometry alone
    learnt(det)
    img = background()
    person(img, 40, 20, 14)
    person(img, 115, 50, 30)
    boxes, _ = det.detect(img)
    assert len(boxes) == 2
    centres = boxes[:, 0] + boxes[:, 2] / 2
    assert centres == pytest.approx([40, 115], abs=3)
    assert boxes[:, 1] == pytest.approx([20, 50], abs=3)
    # the box height is the map's head size at the mouth (top + 0.69 height)
    for (x, top, w, h) in boxes:
        assert h == pytest.approx(size[int(top + 0.69 * h), int(x + w / 2)], abs=0.5)
    assert boxes[1, 3] > boxes[0, 3]


def test_exposure_change_is_compensated():
    det = ForegroundHeadDetector(20.0, gain=True)
    raw = ForegroundHeadDetector(20.0, gain=False)
    for _ in range(40):
        det.detect(background())
        raw.detect(background())
    img = background()
    person(img, 70, 40, 20)
    bright = np.clip(img.astype(float) * 1.25, 0, 255).astype(np.uint8)
    boxes, _ = det.detect(bright)
    assert len(boxes) == 1 and boxes[0, 0] + boxes[0, 2] / 2 == pytest.approx(70, abs=2)
    assert boxes[0, 1] == pytest.approx(40, abs=3)
    # without compensation the whole room turns foreground: no head at the person's top
    assert det._mask is not None
    mask_raw = raw.foreground(bright)
    assert mask_raw.mean() > 0.5
    assert (det._mask == 255).mean() < 0.3


def test_templates_score_and_filter_heads():
    img = background()
    person(img, 70, 30, 20, colour=(40, 60, 160))
    b = hue_saturation_bins(img[30:56, 60:80]).ravel()
    skin = np.bincount(b, minlength=256).reshape(16, 16).astype(float)
    blue = np.zeros((16, 16))
    blue[15, 15] = 1.0  # a colour nowhere in the frame
    det = ForegroundHeadDetector(20.0, templates=np.stack([blue, skin]), min_similarity=0.5)
    learnt(det)
    boxes, scores = det.detect(img)
    assert len(boxes) == 1 and scores[0] > 0.8
    det = ForegroundHeadDetector(20.0, templates=blue, min_similarity=0.5)
    learnt(det)
    boxes, scores = det.detect(img)
    assert len(boxes) == 0 and len(scores) == 0


def test_static_scene_gives_nothing_and_bad_input_is_rejected():
    det = ForegroundHeadDetector(20.0)
    for _ in range(40):
        boxes, scores = det.detect(background())
    assert boxes.shape == (0, 4) and scores.shape == (0,)
    with pytest.raises(ValueError):
        det.detect(np.zeros((H, W), np.uint8))
    with pytest.raises(ValueError):
        ForegroundHeadDetector(-1.0)
    with pytest.raises(ValueError):
        ForegroundHeadDetector(np.full((4, 4), np.nan))
    with pytest.raises(ValueError):
        ForegroundHeadDetector(20.0, mouth_fraction=1.5)
    det = ForegroundHeadDetector(np.full((10, 10), 20.0))
    with pytest.raises(ValueError, match="does not match"):
        det.detect(background())


def test_a_visible_face_places_the_mouth():
    """Skin on the right half of the head (a face in profile): the mouth moves to the skin's
    mean column and its lower rows; the back of a head keeps the geometric mouth."""
    det = ForegroundHeadDetector(20.0)
    learnt(det)
    img = background()
    person(img, 70, 30, 20)
    img[36:50, 71:77] = (120, 150, 200)  # skin (YCrCb Cr 155, Cb 105)
    boxes, _ = det.detect(img)
    assert len(boxes) == 1
    left, top, w, h = boxes[0]
    mouth = (left + w / 2, top + det.mouth_offset * h)
    assert mouth[0] == pytest.approx(73.5, abs=1.0)
    assert mouth[1] == pytest.approx(36 + 0.85 * 13, abs=1.0)
    det = ForegroundHeadDetector(20.0, min_skin=2.0)  # face refinement off
    learnt(det)
    boxes, _ = det.detect(img)
    left, top, w, h = boxes[0]
    assert left + w / 2 == pytest.approx(70, abs=2)
    assert top + det.mouth_offset * h == pytest.approx(30 + 0.69 * 20, abs=3)


def test_a_blob_cut_by_the_image_edge_is_not_a_head():
    det = ForegroundHeadDetector(20.0)
    learnt(det)
    img = background()
    img[40:, W - 6:] = (90, 90, 40)  # someone's shoulder entering at the right edge
    person(img, 70, 30, 20)
    boxes, _ = det.detect(img)
    assert len(boxes) == 1 and boxes[0, 0] + boxes[0, 2] / 2 == pytest.approx(70, abs=2)
    # a head near the edge is kept while its top does not reach within `border` of it
    img = background()
    person(img, W - 12, 30, 20)
    det = ForegroundHeadDetector(20.0, border=0.1)
    learnt(det)
    assert len(det.detect(img)[0]) == 1
    det = ForegroundHeadDetector(20.0, border=1.0)
    learnt(det)
    assert len(det.detect(img)[0]) == 0


def test_a_head_smaller_than_the_geometry_says_keeps_its_mouth_near_its_top():
    """The back of a head 12 px tall where the map expects 20 (a seated person below the
    mouth plane): the foreground's width bounds the head, so the mouth is 0.69 x ~12 below
    the top, not 0.69 x 20."""
    det = ForegroundHeadDetector(20.0)
    learnt(det)
    img = background()
    person(img, 70, 30, 12)
    boxes, _ = det.detect(img)
    assert len(boxes) == 1
    _, top, _, h = boxes[0]
    assert top + det.mouth_offset * h == pytest.approx(30 + 0.69 * 12, abs=2.5)
    det = ForegroundHeadDetector(20.0, head_aspect=0.0)
    learnt(det)
    _, top, _, h = det.detect(img)[0][0]
    assert top + det.mouth_offset * h == pytest.approx(30 + 0.69 * 20, abs=1.5)


def test_a_hole_under_the_head_top_still_bounds_the_head_by_its_width():
    """A person standing still fades into the background model from the inside: the head's
    column is not foreground a quarter head below the top. The foreground's extent around
    the column still bounds the head (mouth 0.69 x ~24 below the top, not 0.69 x 40)."""
    det = ForegroundHeadDetector(40.0)
    learnt(det)
    img = background()
    person(img, 70, 30, 24)
    img[35:47, 67:74] = background()[35:47, 67:74]  # a hole from 5 to 17 px below the top
    boxes, _ = det.detect(img)
    assert len(boxes) == 1
    mask_row = det._solid[int(30 + 0.25 * 40)]
    assert not mask_row[70]  # the hole is there at the row the width is measured on
    _, top, _, h = boxes[0]
    assert top + det.mouth_offset * h == pytest.approx(30 + 0.69 * 24, abs=4)  # 40: 57.6


SKIN = (120, 150, 200)  # BGR; YCrCb Cr 155, Cb 105: passes the skin rule


def test_the_neck_below_a_head_smaller_than_the_geometry_says_is_not_its_face():
    """The back of a head 28 px tall where the geometry expects 48, the neck's skin below
    it: a head box sized by the geometry holds the neck and puts the mouth on it, 20 px
    low; sized by the head's measured width it holds no face, and the mouth is 0.69 of the
    measured head below the top."""
    det = ForegroundHeadDetector(48.0)
    learnt(det)
    img = background()
    person(img, 70, 20, 28)
    img[49:67, 64:77] = SKIN  # the neck, under the head
    boxes, _ = det.detect(img)
    assert len(boxes) == 1
    _, top, _, h = boxes[0]
    assert top + det.mouth_offset * h == pytest.approx(20 + 0.69 * 28, abs=4)
    assert det.head_size(det.heads(det._solid))[0] < 36


def test_a_speck_of_foreground_with_nothing_below_it_is_not_a_head():
    det = ForegroundHeadDetector(20.0)
    learnt(det)
    img = background()
    person(img, 50, 40, 20)
    img[20:28, 120:128] = (40, 60, 160)  # a reflection on the wall: no body under it
    boxes, _ = det.detect(img)
    assert len(boxes) == 1 and boxes[0, 0] + boxes[0, 2] / 2 == pytest.approx(50, abs=2)
    det = ForegroundHeadDetector(20.0, min_fill=0.0)
    learnt(det)
    assert len(det.detect(img)[0]) == 2  # without the rule the speck is a head


def test_a_ghost_where_a_person_stood_is_not_a_head_but_a_moving_person_is():
    """A person stands until the background model has learnt them, then leaves: the place
    they stood stays foreground (a ghost) but does not move, while a person walking by
    does."""
    def run(det):
        for _ in range(40):
            img = background()
            person(img, 40, 30, 20)
            det.detect(img)
        for k in range(8):  # the first person has left; a second walks in at the right
            img = background()
            person(img, 110 + 2 * k, 35, 20, colour=(160, 60, 40))
            boxes, _ = det.detect(img)
        return boxes
    boxes = run(ForegroundHeadDetector(20.0))
    assert len(boxes) == 1 and boxes[0, 0] + boxes[0, 2] / 2 == pytest.approx(124, abs=3)
    boxes = run(ForegroundHeadDetector(20.0, min_motion=0.0))
    assert len(boxes) == 2  # without the rule the ghost is a head
