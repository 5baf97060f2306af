"""Colour-template head detection: the maps on hand-made frames and on AV16.3's real video."""

from __future__ import annotations

import numpy as np
import pytest

from avtrack.metrics.points import point_matches
from avtrack.visual.colour import (
    ColourTemplateDetector,
    hue_saturation_bins,
    similarity_maps,
)


def patch_frame(x: int, y: int, colour=(30, 90, 200), size=(96, 64)) -> np.ndarray:
    """Grey frame with a 16 x 24 patch of one colour (BGR) at (x, y)."""
    w, h = size
    img = np.full((h, w, 3), 128, np.uint8)
    img[y : y + 24, x : x + 16] = colour
    return img


def template_of(img: np.ndarray) -> np.ndarray:
    b = hue_saturation_bins(img).ravel()
    return np.bincount(b, minlength=256).reshape(16, 16) / b.size


def test_similarity_map_is_the_bhattacharyya_coefficient_of_each_window():
    img = patch_frame(40, 20)
    q = template_of(img[20:44, 40:56])
    rho = similarity_maps(hue_saturation_bins(img), q.reshape(1, -1), (4, 6), 4)
    assert rho.shape == (64 // 4 - 6 + 1, 96 // 4 - 4 + 1, 1)
    # The window exactly on the patch matches it exactly; a window on grey not at all.
    assert rho[5, 10, 0] == pytest.approx(1.0)
    assert rho[0, 0, 0] == pytest.approx(0.0, abs=1e-12)
    # Half on the patch: the coefficient of (1/2 patch, 1/2 grey) with the patch is sqrt(1/2).
    assert rho[5, 8, 0] == pytest.approx(np.sqrt(0.5))
    assert np.all((rho >= 0) & (rho <= 1 + 1e-12))


def test_detector_finds_each_template_once_and_uses_the_background_model():
    q1 = template_of(patch_frame(0, 0)[0:24, 0:16])
    q2 = template_of(patch_frame(0, 0, colour=(200, 60, 30))[0:24, 0:16])
    det = ColourTemplateDetector(np.stack([q1, q2]), window=(16, 24), min_foreground=0.0,
                                 min_similarity=0.9)
    img = patch_frame(40, 20)
    img[8:32, 72:88] = (200, 60, 30)
    boxes, scores = det.detect(img)
    assert boxes.tolist() == [[40, 20, 16, 24], [72, 8, 16, 24]]
    assert np.allclose(scores, 1.0)
    # With the background model, a patch that never moves is background: nothing reported.
    det = ColourTemplateDetector(q1, window=(16, 24), min_foreground=0.5, min_similarity=0.9)
    for _ in range(30):
        boxes, _ = det.detect(patch_frame(40, 20))
    assert len(boxes) == 0
    boxes, _ = det.detect(patch_frame(8, 36))  # it moved: foreground now
    assert boxes.tolist() == [[8, 36, 16, 24]]


def test_detector_rejects_bad_templates_and_frames():
    with pytest.raises(ValueError, match="shape"):
        ColourTemplateDetector(np.ones((2, 8, 8)))
    with pytest.raises(ValueError, match="non-negative"):
        ColourTemplateDetector(-np.ones((16, 16)))
    with pytest.raises(ValueError, match="multiples"):
        ColourTemplateDetector(np.ones((16, 16)), window=(30, 48))
    det = ColourTemplateDetector(np.ones((16, 16)), window=(32, 48))
    with pytest.raises(ValueError, match="smaller than the window"):
        det.detect(np.zeros((20, 20, 3), np.uint8))
    with pytest.raises(ValueError, match="uint8"):
        det.detect(np.zeros((64, 64, 3)))


def test_templates_find_the_speakers_on_the_real_av163_video(shared_data):
    """AV16.3 sequence 30 camera 1, first 300 frames: the template points of the frames
    where a person is in view land within 20 px of a true mouth at least 40 % of the time,
    and most points lie near a person (measured: 55 % and 79 %)."""
    from avtrack.io.av163 import TEMPLATE_MOUTH_OFFSET, load_av163
    from avtrack.io.video import iter_frames

    folder = shared_data / "av16.3"
    video = folder / "seq30-2p-1101_cam1_divx_audio.avi"
    if not video.is_file():
        pytest.skip(f"{video} not in the shared data")
    seq = load_av163(folder, 30, 1)
    det = ColourTemplateDetector(seq.histograms[~seq.histogram_is_placeholder])
    points, truths = [], []
    for t, frame in enumerate(iter_frames(video)):
        if t >= 300:
            break
        boxes, _ = det.detect(frame)
        points.append(np.column_stack([boxes[:, 0] + boxes[:, 2] / 2,
                                       boxes[:, 1] + TEMPLATE_MOUTH_OFFSET * boxes[:, 3]]))
        truths.append(seq.positions[seq.present[t], t])
    m = point_matches(points, truths)
    assert m.n_true > 200 and m.n_points > 100
    assert m.recall >= 0.4
    assert m.precision >= 0.6
