r"""An AV16.3 camera as the direction-space person tracker sees it.

The person tracker (:mod:`avtrack.av.persons`) keeps persons as directions from the
microphone array and meets the camera through :class:`~avtrack.av.geometry.CameraGeometry`: an
ideal pinhole camera (yaw and pitch, no roll, no lens distortion) in the array's frame. An
AV16.3 camera is a calibrated projection ``Pmat`` (Bouguet's toolbox, from the calibration
frame; ``align_mat`` maps that frame to the ``MouthGT3D`` room frame) with radial distortion
and a few degrees of roll. :class:`AV163View` splits it exactly into

1. the lens distortion (undone on the way in, redone on the way out),
2. an in-plane rotation of the normalised image coordinates by the roll angle (a rotation
   about the optical axis: :math:`R = R_{\mathrm{roll}} R_{\mathrm{yaw,pitch}}`), and
3. a :class:`~avtrack.io.camera.PinholeCamera` with the calibration's focal lengths and
   principal point, its optical centre and yaw / pitch in the array frame.

The array frame is the room frame moved to array 1's centre
(:data:`~avtrack.io.av163.AV163_ARRAY_CENTRE`, the frame of the ``Z_doa`` azimuths).

Depth. A head's distance cannot be read from the size of a fixed-size template window, but
AV16.3's mouths are all at about the same height (:data:`~avtrack.io.av163.
AV163_MOUTH_HEIGHT` above the array plane): a mouth pixel's ray meets that plane at the mouth.
:meth:`AV163View.mouth_boxes` turns detections into head boxes centred on their mouth points
and sized for that depth, which is what the geometry's box back-projection expects.
"""

from __future__ import annotations

import numpy as np

from avtrack.av.geometry import HEAD_HEIGHT_M, CameraGeometry
from avtrack.io.av163 import (
    AV163_ARRAY_CENTRE,
    AV163_MOUTH_HEIGHT,
    AV163Sequence,
    av163_pinhole,
    av163_roll,
)


class AV163View:
    """One AV16.3 camera of a sequence, mapped to a pinhole camera in the array frame.

    Parameters
    ----------
    seq : AV163Sequence
    array_centre : (float, float, float)
        Array centre in the ``MouthGT3D`` frame (metres).
    mouth_height : float
        Height of the mouths above the array plane (metres).
    """

    def __init__(self, seq: AV163Sequence, array_centre=AV163_ARRAY_CENTRE,
                 mouth_height: float = AV163_MOUTH_HEIGHT) -> None:
        self.source = seq.camera
        self.centre = np.asarray(array_centre, dtype=float)
        self.mouth_height = float(mouth_height)
        self.camera = av163_pinhole(seq, self.centre)
        # R = R_roll R_pinhole: the roll as a rotation of normalised coordinates
        self.roll = av163_roll(seq, self.camera)
        self.roll_deg = float(np.degrees(np.arctan2(self.roll[1, 0], self.roll[0, 0])))
        self.geometry = CameraGeometry(self.camera, np.zeros(3), 0.0)

    # ------------------------------------------------------------------ pixels
    def _K(self) -> np.ndarray:
        return self.camera.K

    def to_pinhole(self, pixels: np.ndarray) -> np.ndarray:
        """Image pixels ``(N, 2)`` (distorted, rolled) -> the pinhole camera's pixels."""
        import cv2

        pix = np.asarray(pixels, dtype=float).reshape(-1, 1, 2)
        if pix.shape[0] == 0:
            return np.zeros((0, 2))
        kc = self.source.kc
        norm = cv2.undistortPoints(pix, self.source.K, kc).reshape(-1, 2)  # normalised, true
        norm = norm @ self.roll  # R_roll^T n (rows): undo the roll
        K = self._K()
        return np.column_stack([K[0, 0] * norm[:, 0] + K[0, 2], K[1, 1] * norm[:, 1] + K[1, 2]])

    def from_pinhole(self, pixels: np.ndarray) -> np.ndarray:
        """The pinhole camera's pixels ``(N, 2)`` -> image pixels (rolled, distorted)."""
        pix = np.asarray(pixels, dtype=float).reshape(-1, 2)
        K = self._K()
        norm = np.column_stack([(pix[:, 0] - K[0, 2]) / K[0, 0], (pix[:, 1] - K[1, 2]) / K[1, 1]])
        norm = norm @ self.roll.T  # R_roll n
        undist = np.column_stack([norm, np.ones(len(norm))]) @ self.source.K.T
        return self.source.distort(undist[:, :2] / undist[:, 2:3])

    # ------------------------------------------------------------------ boxes
    def mouth_depth(self, pinhole_pixels: np.ndarray) -> np.ndarray:
        """Depth along the optical axis (metres) where each pinhole pixel's ray meets the
        mouth plane; NaN where it does not (ray parallel to or away from the plane)."""
        cam = self.camera
        p = np.asarray(pinhole_pixels, dtype=float).reshape(-1, 2)
        ray_c = np.column_stack([(p[:, 0] - cam.cx) / cam.fx, (p[:, 1] - cam.cy) / cam.fy,
                                 np.ones(len(p))])
        ray = ray_c @ cam.R  # room direction per unit depth
        with np.errstate(divide="ignore", invalid="ignore"):
            z = (self.mouth_height - cam.position[2]) / ray[:, 2]
        return np.where(np.isfinite(z) & (z > 0), z, np.nan)

    def head_height_map(self, max_depth: float = 15.0) -> np.ndarray:
        """Height (pixels) of a head of :data:`~avtrack.av.geometry.HEAD_HEIGHT_M` whose
        mouth is at each image pixel, at the depth where the pixel's ray meets the mouth
        plane: ``(height, width)`` (rays above the plane's horizon get ``max_depth``). The
        ``head_height`` of :class:`~avtrack.visual.heads.ForegroundHeadDetector`."""
        width, height = self.camera.width, self.camera.height
        yy, xx = np.mgrid[0:height, 0:width]
        p = self.to_pinhole(np.column_stack([xx.ravel(), yy.ravel()]).astype(float))
        z = np.clip(np.nan_to_num(self.mouth_depth(p), nan=max_depth), 0.3, max_depth)
        return (self.camera.fy * HEAD_HEIGHT_M / z).reshape(height, width)

    def mouth_boxes(self, points: np.ndarray, doa_deg: np.ndarray | None = None,
                    max_depth: float = 15.0, heights: tuple[float, float] = (0.5, 1.0),
                    gate_deg: float = 5.0) -> np.ndarray:
        """Head boxes ``(N, 4)`` (left, top, width, height) in pinhole pixels, centred on the
        mouth points ``(N, 2)`` (image pixels) and as tall as a head at the mouth's depth.

        The depth is where the mouth's ray meets the mouth plane; a seated talker's mouth lies
        lower than a standing one's, which moves that point along the ray and, seen from
        the array metres away, turns its azimuth by up to 20 degrees. When the frame has DOAs,
        the mouth height in ``heights`` (metres above the array plane) whose point on the ray
        lies closest in azimuth to a DOA (within ``gate_deg``) is used instead: the
        intersection of the camera ray and the DOA's vertical half-plane (the DOA lines of
        Kilic et al., IEEE TMM 2016). Rays that miss the plane get ``max_depth``.
        """
        p = self.to_pinhole(points)
        z = self.mouth_depth(p)
        if doa_deg is not None and len(doa_deg) and len(p):
            cam = self.camera
            ray = np.column_stack([(p[:, 0] - cam.cx) / cam.fx, (p[:, 1] - cam.cy) / cam.fy,
                                   np.ones(len(p))]) @ cam.R  # room direction per unit depth
            hs = np.linspace(heights[0], heights[1], 26)
            with np.errstate(divide="ignore", invalid="ignore"):
                depth = (hs[None, :] - cam.position[2]) / ray[:, 2:3]  # (N, H)
            pts = cam.position[None, None, :] + depth[..., None] * ray[:, None, :]
            az = np.degrees(np.arctan2(pts[..., 1], pts[..., 0]))
            diff = np.abs((az[..., None] - np.asarray(doa_deg)[None, None, :] + 180) % 360 - 180)
            best = np.where(depth > 0, diff.min(axis=2), np.inf)  # (N, H)
            j = np.argmin(best, axis=1)
            hit = best[np.arange(len(p)), j] <= gate_deg
            z = np.where(hit, depth[np.arange(len(p)), j], z)
        z = np.clip(np.nan_to_num(z, nan=max_depth), 0.3, max_depth)
        h = self.camera.fy * HEAD_HEIGHT_M / z
        w = 0.75 * h
        return np.column_stack([p[:, 0] - w / 2, p[:, 1] - h / 2, w, h])

#: Detectors :func:`av163_detector` builds for an AV16.3 video.
AV163_DETECTORS = ("heads", "templates")


def av163_detector(seq: AV163Sequence, kind: str = "heads"):
    """The visual detector of an AV16.3 sequence's video.

    ``heads`` (the default): :class:`~avtrack.visual.heads.ForegroundHeadDetector`, the tops
    of the exposure-compensated foreground with this camera's head sizes
    (:meth:`AV163View.head_height_map`), the face placing the mouth where visible and the
    sequence's ``hist_temp_16bins`` templates as scores; ``templates``: the colour-template
    windows of Kilic et al. (:class:`~avtrack.visual.colour.ColourTemplateDetector`).
    """
    from avtrack.io.av163 import av163_templates

    if kind == "templates":
        from avtrack.visual.colour import ColourTemplateDetector

        return ColourTemplateDetector(av163_templates(seq))
    if kind != "heads":
        raise ValueError(f"unknown AV16.3 detector {kind!r}; one of {AV163_DETECTORS}")
    from avtrack.visual.heads import ForegroundHeadDetector

    return ForegroundHeadDetector(AV163View(seq).head_height_map(), av163_templates(seq))


def track_av163(
    seq: AV163Sequence,
    video,
    detector=None,
    *,
    config=None,
    mouth_offset: float | None = None,
):
    """The direction-space person tracker on an AV16.3 sequence from its real video.

    Visual: a detector on every frame (default: :func:`av163_detector`, the foreground head
    tops of :class:`~avtrack.visual.heads.ForegroundHeadDetector`), each box's
    mouth point turned into a head box at the mouth plane's depth (:meth:`AV163View.
    mouth_boxes`), with the hue-saturation histogram of the detected window as appearance.
    Audio: the sequence's DOA measurements (``Z_doa``, array 1) as the peaks of each frame.

    Parameters
    ----------
    seq : AV163Sequence
    video : str or Path
        The sequence's video (360 x 288, one frame per ``Timingcam`` row).
    detector : object with ``detect(frame) -> (boxes, scores)``, optional
    config : PersonConfig, optional
    mouth_offset : float, optional
        Mouth point as a fraction of a box's height from its top (default: the detector's
        ``mouth_offset`` if it has one, the template offset for the template detector, the
        face-box offset for any other).

    Returns
    -------
    result : PersonsResult
        With ``tracks`` boxes and ``persons`` pixels in the video's own (distorted) pixels.
    view : AV163View
    """
    from dataclasses import replace

    from avtrack.av.persons import PersonConfig
    from avtrack.av.persons_scene import track_persons
    from avtrack.io.av163 import (
        FACE_MOUTH_OFFSET,
        TEMPLATE_MOUTH_OFFSET,
        probe_av163_video,
    )
    from avtrack.io.mot import MOTData
    from avtrack.io.video import iter_frames
    from avtrack.visual.colour import ColourTemplateDetector
    from avtrack.visual.histograms import box_histograms

    info = probe_av163_video(video, seq)
    if detector is None:
        detector = av163_detector(seq)
    if mouth_offset is None:
        mouth_offset = getattr(detector, "mouth_offset", None)
    if mouth_offset is None:
        mouth_offset = (TEMPLATE_MOUTH_OFFSET if isinstance(detector, ColourTemplateDetector)
                        else FACE_MOUTH_OFFSET)
    view = AV163View(seq)
    frames, boxes, scores, hists = [], [], [], []
    for k, frame in enumerate(iter_frames(video, info), start=1):
        b, s = detector.detect(frame)
        b = np.asarray(b, dtype=float).reshape(-1, 4)
        s = np.asarray(s, dtype=float).reshape(-1)
        if len(b) == 0:
            continue
        mouth = np.column_stack([b[:, 0] + b[:, 2] / 2, b[:, 1] + mouth_offset * b[:, 3]])
        frames.append(np.full(len(b), k))
        boxes.append(view.mouth_boxes(mouth, seq.z_doa[k - 1]))
        scores.append(s)
        hists.append(box_histograms(frame, b))
    if frames:
        dets = MOTData(np.concatenate(frames), -np.ones(sum(map(len, frames))),
                       np.vstack(boxes), np.concatenate(scores))
        appearance = np.vstack(hists)
    else:
        dets = MOTData(np.zeros(0, int), np.zeros(0), np.zeros((0, 4)), np.zeros(0))
        appearance = None
    config = config or PersonConfig()
    vcfg = config.visual
    if appearance is not None and vcfg.appearance != "bhattacharyya":
        vcfg = replace(vcfg, appearance="bhattacharyya", appearance_lambda=2.0)
    peaks = [np.asarray(z, dtype=float) for z in seq.z_doa]
    res = track_persons(dets, appearance, peaks, view.geometry, info.fps, seq.n_frames,
                        visual_config=vcfg, config=config, azimuth_span_deg=360.0)
    # back to the video's own pixels
    px = res.persons.pixels.copy()
    ok = np.all(np.isfinite(px), axis=1)
    px[ok] = view.from_pinhole(px[ok])
    persons = replace(res.persons, pixels=px)
    tb = res.tracks.boxes.copy()
    if len(tb):
        centre = view.from_pinhole(tb[:, :2] + tb[:, 2:] / 2)
        tb[:, :2] = centre - tb[:, 2:] / 2
    tracks = replace(res.tracks, boxes=tb)
    return replace(res, tracks=tracks, persons=persons), view
