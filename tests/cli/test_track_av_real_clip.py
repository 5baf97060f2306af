"""A recording of one's own, end to end, on a real clip: frames of AV16.3 sequence 30 (camera
1), a 4-microphone WAV rendered for the talker's true path, the camera file in the array's
frame from the AV16.3 calibration."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

import avtrack.cli.main as cli_main
from tests.conftest import shared_data_dir
from tests.io.test_video import read_video

FIRST, N_FRAMES, FPS = 150, 100, 25.0  # frames 151-250: both people in view, person 1 talks


class HeadsFromTemplates:
    """A head detector for the clip: the colour templates of sequence 30 find the heads, and
    each window becomes a head box around its mouth point, as tall as a head at the depth
    where the mouth's ray meets the mouths' plane (a user's own head detector gives such boxes
    directly)."""

    def __init__(self):
        from avtrack.av.av163 import AV163View
        from avtrack.io.av163 import load_av163
        from avtrack.visual.colour import ColourTemplateDetector

        seq = load_av163(shared_data_dir() / "av16.3", 30, 1)
        self.templates = ColourTemplateDetector(seq.histograms[~seq.histogram_is_placeholder])
        self.view = AV163View(seq)

    def detect(self, frame):
        from avtrack.io.av163 import TEMPLATE_MOUTH_OFFSET

        b, s = self.templates.detect(frame)
        mouth = np.column_stack([b[:, 0] + b[:, 2] / 2, b[:, 1] + TEMPLATE_MOUTH_OFFSET * b[:, 3]])
        return self.view.mouth_boxes(mouth), s


@pytest.mark.slow
def test_own_recording_on_a_real_clip(shared_data, tmp_path, capsys):
    import cv2
    import soundfile

    from avtrack.audio.arrays import load_array
    from avtrack.av.av163 import AV163View
    from avtrack.io.av163 import load_av163
    from avtrack.io.persons import read_persons_csv
    from avtrack.io.video import iter_frames
    from avtrack.simulate.acoustics import ArrayPose, MovingSource, Room, render

    folder = shared_data / "av16.3"
    video = folder / "seq30-2p-1101_cam1_divx_audio.avi"
    if not video.is_file():
        pytest.skip(f"{video} not in the shared data")
    seq = load_av163(folder, 30, 1)
    view = AV163View(seq)
    # the clip
    clip = tmp_path / "clip.avi"
    writer = cv2.VideoWriter(str(clip), cv2.VideoWriter_fourcc(*"MJPG"), FPS, (360, 288))
    for k, frame in enumerate(iter_frames(video)):
        if FIRST <= k < FIRST + N_FRAMES:
            writer.write(frame)
    writer.release()
    # the camera file: the calibration's pinhole part, in the array's frame
    cam = view.camera
    camera = tmp_path / "camera.yaml"
    camera.write_text(yaml.safe_dump({
        "fx": cam.fx, "fy": cam.fy, "cx": cam.cx, "cy": cam.cy, "width": cam.width,
        "height": cam.height, "position": [float(v) for v in cam.position],
        "yaw_deg": cam.yaw_deg, "pitch_deg": cam.pitch_deg}))
    # the WAV: person 1's mouth path (array frame) talking, rendered for a 4-mic array
    mouth = seq.mouth[0]
    t_clip = seq.time_s[FIRST : FIRST + N_FRAMES]
    idx = np.clip(np.searchsorted(mouth.time_s, t_clip), 0, len(mouth.time_s) - 1)
    path = mouth.xyz[idx] - view.centre  # (N_FRAMES, 3), array frame
    array = load_array("nao4")
    room = Room(np.array([10.0, 10.0, 3.0]), t60=0.2, fs=16000)
    pose = ArrayPose(np.array([5.0, 5.0, 0.8]))
    rng = np.random.default_rng(0)
    n = int(N_FRAMES / FPS * 16000)
    t = np.arange(n) / 16000
    speech = rng.standard_normal(n) * (0.6 + 0.4 * np.sin(2 * np.pi * 3.0 * t)) ** 2
    src = MovingSource(speech, np.arange(N_FRAMES) / FPS, path + pose.position)
    mix = render(room, array, pose, src, rng=1)
    wav = tmp_path / "clip.wav"
    soundfile.write(wav, (0.3 * mix / np.abs(mix).max()).T, 16000, subtype="FLOAT")
    out = tmp_path / "out"
    rc = cli_main.main(["track-av", "--video", str(clip), "--audio", str(wav), "--array",
                        "nao4", "--camera", str(camera), "--detector",
                        "tests.cli.test_track_av_real_clip:HeadsFromTemplates", "-o",
                        str(out), "-q"])
    assert rc == 0
    persons = read_persons_csv(out / "persons.csv", fps=FPS)
    true_az = np.degrees(np.arctan2(path[:, 1], path[:, 0]))
    # the talker is heard: the persons speaking lie near the true mouth azimuth (measured:
    # median 8.8 degrees, on 82 of 100 frames; a mapping or linking fault gives tens)
    talking = persons.speaking >= 0.5
    assert talking.sum() > 0.3 * N_FRAMES
    err = np.abs((persons.azimuth_deg[talking] - true_az[persons.frames[talking] - 1] + 180)
                 % 360 - 180)
    assert np.median(err) < 12.0
    assert (out / "speech.rttm").read_text().strip()
    # the report: the tracks drawn over the clip's own frames
    import cv2

    page = (out / "index.html").read_text()
    assert "tracks.webm" in page or "data:video/webm" in page
    frames = read_video(out / "tracks.webm")
    assert len(frames) == N_FRAMES
    original = cv2.VideoCapture(str(clip))
    ok, first = original.read()
    original.release()
    assert ok
    # below the header band the report's frame is the clip's frame (up to coding loss and
    # the drawn boxes): the mean absolute difference is small against a rendered room's
    h = first.shape[0]
    diff = np.abs(frames[0][h // 3:, :first.shape[1]].astype(float) - first[h // 3:].astype(float))
    assert np.median(diff) < 12.0
    # --no-report writes none of it
    out2 = tmp_path / "out2"
    assert cli_main.main(["track-av", "--video", str(clip), "--audio", str(wav), "--array",
                          "nao4", "--camera", str(camera), "--detector",
                          "tests.cli.test_track_av_real_clip:HeadsFromTemplates", "-o",
                          str(out2), "-q", "--no-report"]) == 0
    assert not (out2 / "index.html").exists() and not (out2 / "tracks.webm").exists()
