"""AV16.3 as a recording of one's own: the DOA CSV and the CAMERA.yaml of ``track-av``.

``avtrack track-av --video FILE --doa DOA.csv --camera CAMERA.yaml`` tracks any recording whose
directions were computed elsewhere and whose camera is known in the microphone array's frame.
This module writes those two files from an AV16.3 sequence (:func:`~avtrack.io.av163.
load_av163`), so that the sequence's video can be tracked as a user's own recording and scored
against its ``posGT`` beside the dataset path (``track-av AV16.3_DIR --seq N --cam C``), which
reads the same measurements and calibration directly.

**DOA CSV** (:func:`doa_csv_from_av163`, the format of :mod:`avtrack.io.doa`), one row per
azimuth of ``DOA_measurements_seqNN_camC.mat`` (``Z_doa``, microphone array 1):

=============== ======================================================================
column          value
=============== ======================================================================
``frame``       0-based video frame ``k``: ``Z_doa`` cell ``k + 1`` (one cell per video frame,
                the pairing the dataset path uses)
``time_s``      ``k / 25``: seconds from the video's first frame (``track-av`` puts a row on
                the frame nearest ``time_s * fps``), not the ``Timingcam`` clock
``id``          -1 (frame-wise measurements, no track)
``azimuth_deg`` the measurement as stored: degrees, counter-clockwise from the room's x axis
                seen from array 1's centre (:data:`~avtrack.io.av163.AV163_ARRAY_CENTRE`),
                i.e. already the azimuth of the array frame below
``elevation_deg`` 0: ``Z_doa`` holds azimuths only (``track-av`` counts a zero elevation as
                not measured)
``weight``      1 (the file holds no power or confidence)
``active``      1
=============== ======================================================================

Frames without a measurement have no row. Checked on the shared files of camera 1
(sequences 24, 30 and 45): a measurement lies a median 1.8-2.2 degrees from the azimuth of the
nearest ground-truth mouth of its frame (``MouthGT3D`` seen from array 1's centre); with the
cells moved one frame earlier or later 1.7-2.7 degrees, two frames 1.9-3.6 degrees: no other
pairing is better on every sequence (one frame earlier gains 0.3 degrees on sequence 30 and
loses 0.1 on sequence 45).

**CAMERA.yaml** (:func:`camera_yaml_from_av163`, the fields :func:`~avtrack.io.camera.
read_camera_file` reads): the sequence's camera in array 1's frame, metres (the ``MouthGT3D``
room frame moved to the array's centre: x is azimuth 0 of the measurements, z up), as
:func:`~avtrack.io.av163.av163_pinhole` gives it: the pinhole part of the calibration
``Pmat @ inv(align_mat)`` (its focal lengths, principal point, optical centre and axis). A
``PinholeCamera`` has no lens distortion and no roll, so both are dropped (a comment in the
file gives them): the ``MouthGT3D`` mouths it projects lie a median 5.4-7.6 px (90th
percentile 14.4-20.2 px) from ``posGT`` with camera 1 (roll 3.6 degrees; sequences 24, 30 and
45), 2.2-3.2 px (12.5-16.6 px) with cameras 2 and 3 (roll under 1 degree), against 0.25-0.30 px
with the full calibration.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from avtrack.io.av163 import (
    AV163_ARRAY_CENTRE,
    FRAME_RATE,
    AV163Sequence,
    av163_pinhole,
    av163_roll,
)
from avtrack.io.base import atomic_write
from avtrack.io.camera import PinholeCamera
from avtrack.io.doa import DOATable, write_doa_csv

#: The microphone arrays whose frame the files can be written in: ``Z_doa`` holds array 1's
#: azimuths (see :mod:`avtrack.phd.likelihood` for the fit of its centre).
AV163_EXPORT_ARRAYS = (1,)


def _check(seq: AV163Sequence, array: int, name: str) -> None:
    if not isinstance(seq, AV163Sequence):
        raise TypeError(f"{name}: seq must be an AV163Sequence (load_av163), got "
                        f"{type(seq).__name__}")
    if isinstance(array, bool) or array not in AV163_EXPORT_ARRAYS:
        raise ValueError(f"{name}: array must be one of {AV163_EXPORT_ARRAYS} (the "
                         f"DOA_measurements files hold microphone array 1's azimuths), got "
                         f"{array!r}")


def av163_doa_table(seq: AV163Sequence, array: int = 1) -> DOATable:
    """The sequence's DOA measurements ``Z_doa`` as DOA CSV rows (see the module docstring).

    Parameters
    ----------
    seq : AV163Sequence
    array : int
        Microphone array whose frame the azimuths are in (1, the array of ``Z_doa``).

    Returns
    -------
    DOATable
        ``K`` rows, one per measurement, in frame order.
    """
    _check(seq, array, "av163_doa_table")
    counts = np.array([np.size(z) for z in seq.z_doa], dtype=np.int64)
    frames = np.repeat(np.arange(seq.n_frames, dtype=np.int64), counts)  # cell k + 1 -> k
    azimuth = np.concatenate([np.zeros(0), *[np.ravel(z) for z in seq.z_doa]])
    n = frames.shape[0]
    return DOATable(frames, frames / FRAME_RATE,  # time_s = k / 25 from the first frame
                    -np.ones(n, dtype=np.int64), azimuth, np.zeros(n), np.ones(n),
                    np.ones(n, dtype=bool))


def doa_csv_from_av163(seq: AV163Sequence, path: str | Path, array: int = 1) -> DOATable:
    """Write the sequence's DOA measurements as a DOA CSV at ``path`` (atomically; the
    columns are in the module docstring) and return its rows."""
    table = av163_doa_table(seq, array)
    write_doa_csv(path, table)
    return table


def av163_camera(seq: AV163Sequence, array: int = 1) -> PinholeCamera:
    """The sequence's camera in array ``array``'s frame (see the module docstring)."""
    _check(seq, array, "av163_camera")
    return av163_pinhole(seq, AV163_ARRAY_CENTRE)


def av163_camera_yaml(seq: AV163Sequence, array: int = 1) -> str:
    """CAMERA.yaml text of :func:`av163_camera`, what it is and what it lacks in comments."""
    import yaml

    camera = av163_camera(seq, array)
    roll = av163_roll(seq, camera)
    roll_deg = float(np.degrees(np.arctan2(roll[1, 0], roll[0, 0])))
    kc = ", ".join(f"{v:.4g}" for v in seq.camera.kc)
    head = (
        f"# AV16.3 sequence {seq.seq}, camera {seq.cam}, in microphone array {array}'s frame\n"
        f"# (metres; x axis = azimuth 0 of its DOA measurements, z up, the array's centre at\n"
        f"# the origin): the pinhole part of the calibration Pmat @ inv(align_mat).\n"
        f"# Not in this file (a PinholeCamera has neither): a roll of {roll_deg:.1f} deg about\n"
        f"# the optical axis and the lens distortion kc = ({kc}).\n"
    )
    return head + yaml.safe_dump(camera.to_json(), sort_keys=False)


def camera_yaml_from_av163(seq: AV163Sequence, path: str | Path, array: int = 1) -> PinholeCamera:
    """Write the sequence's camera as CAMERA.yaml at ``path`` (atomically) and return it."""
    text = av163_camera_yaml(seq, array)
    with atomic_write(path) as fh:
        fh.write(text)
    return av163_camera(seq, array)
