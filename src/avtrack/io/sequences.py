"""MOTChallenge sequence folders and benchmark trees.

Published layout (MOT15/16/17/20)::

    <benchmark>/<split>/<sequence>/        e.g. MOT17/train/MOT17-02-FRCNN/
        seqinfo.ini                        [Sequence] name, imDir, frameRate, seqLength,
                                           imWidth, imHeight, imExt (absent in MOT15)
        det/det.txt                        detections
        gt/gt.txt                          ground truth (training sequences only)
        img1/000001.jpg ...                frames (optional here)

MOT15 sequences have no ``seqinfo.ini``. Their image size then comes from the ``image_size``
argument; without one it is unknown (``width`` and ``height`` are None and
:attr:`MOTSequence.note` says so) — no size is guessed. The sequence length is
``seqLength``, else the number of images in ``img1/``, else the last frame of the detections
and ground truth.
"""

from __future__ import annotations

import configparser
from dataclasses import dataclass
from pathlib import Path

from avtrack.errors import InputError
from avtrack.io.datasets import read_seqinfo
from avtrack.io.mot import MOTData, read_mot

IMAGE_EXTENSIONS = (".jpg", ".jpeg", ".png")


@dataclass(frozen=True)
class MOTSequence:
    """One MOTChallenge sequence.

    Attributes
    ----------
    name : str
        ``name`` of ``seqinfo.ini``, else the folder name.
    folder : Path
    detections : MOTData
        ``det/det.txt``.
    ground_truth : MOTData or None
        ``gt/gt.txt`` when present.
    length : int
        Number of frames (see the module docstring for its source).
    width, height : int or None
        Image size in pixels; None when unknown.
    frame_rate : float or None
    image_dir : Path or None
        The image folder when it exists.
    note : str
        Where the image size and length came from.
    """

    name: str
    folder: Path
    detections: MOTData
    ground_truth: MOTData | None
    length: int
    width: int | None
    height: int | None
    frame_rate: float | None
    image_dir: Path | None
    note: str = ""

    def __post_init__(self) -> None:
        if self.length < 0:
            raise ValueError(f"MOTSequence: length must be >= 0, got {self.length}")
        if (self.width is None) != (self.height is None):
            raise ValueError("MOTSequence: give both width and height, or neither")
        if self.width is not None and self.height is not None and (
            self.width <= 0 or self.height <= 0
        ):
            raise ValueError(
                f"MOTSequence: image size must be > 0, got {self.width} x {self.height}"
            )

    @property
    def image_size(self) -> tuple[int, int] | None:
        """``(width, height)``, or None when unknown."""
        return None if self.width is None or self.height is None else (self.width, self.height)


def _image_dir_name(seqinfo: Path) -> str:
    parser = configparser.ConfigParser()
    parser.read_string(seqinfo.read_text())
    return parser["Sequence"].get("imDir", "img1")


def _check_size_arguments(
    image_size: tuple[int, int] | None, frame_rate: float | None
) -> tuple[int, int] | None:
    """Check :func:`load_mot_sequence`'s ``image_size`` and ``frame_rate``; the size as ints."""
    if image_size is not None:
        if len(image_size) != 2 or any(
            isinstance(v, bool) or int(v) != v or v <= 0 for v in image_size
        ):
            raise ValueError(
                f"image_size must be (width, height) positive integers, got {image_size!r}"
            )
        image_size = (int(image_size[0]), int(image_size[1]))
    if frame_rate is not None and not frame_rate > 0:
        raise ValueError(f"frame_rate must be > 0, got {frame_rate!r}")
    return image_size


def _image_size(
    info: dict, image_size: tuple[int, int] | None, seqinfo_path: Path, notes: list[str]
) -> tuple[int | None, int | None]:
    """``(width, height)`` from ``seqinfo.ini`` or ``image_size`` (None if neither gives it),
    noting where it came from in ``notes``."""
    width = height = None
    if "width" in info and "height" in info:
        width, height = int(info["width"]), int(info["height"])
        if image_size is not None and image_size != (width, height):
            raise InputError(
                f"imWidth x imHeight is {width} x {height} but image_size "
                f"{image_size[0]} x {image_size[1]} was given",
                seqinfo_path,
            )
        notes.append("image size from seqinfo.ini")
    elif image_size is not None:
        width, height = image_size
        notes.append("image size from the image_size argument")
    else:
        where = "no seqinfo.ini" if not info else "seqinfo.ini has no imWidth/imHeight"
        notes.append(f"image size unknown ({where}; pass image_size=(width, height))")
    return width, height


def _sequence_length(info: dict, image_dir: Path | None, last: int, notes: list[str]) -> int:
    """The number of frames: from ``seqinfo.ini``, else the images, else the last annotated
    frame, noting which in ``notes``."""
    if "length" in info:
        length = int(info["length"])
        notes.append("length from seqinfo.ini")
    elif image_dir is not None:
        length = sum(1 for p in image_dir.iterdir() if p.suffix.lower() in IMAGE_EXTENSIONS)
        notes.append(f"length from the images in {image_dir.name}/")
    else:
        length = last
        notes.append("length from the last annotated frame")
    return length


def load_mot_sequence(
    folder: str | Path,
    *,
    image_size: tuple[int, int] | None = None,
    frame_rate: float | None = None,
) -> MOTSequence:
    """Read a MOTChallenge sequence folder.

    Parameters
    ----------
    folder : str or Path
        The sequence folder (holding ``det/det.txt``).
    image_size : (width, height), optional
        Image size for sequences without ``seqinfo.ini``; when the sequence has one, a
        different size is an error.
    frame_rate : float, optional
        Same, for the frame rate.

    Returns
    -------
    MOTSequence

    Raises
    ------
    InputError
        Missing folder or ``det/det.txt``; a malformed ``seqinfo.ini``, detection or
        ground-truth file; an ``image_size`` / ``frame_rate`` contradicting ``seqinfo.ini``;
        a detection or ground-truth frame beyond the sequence length.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(
            "sequence folder not found" if not folder.exists() else "not a folder", folder
        )
    image_size = _check_size_arguments(image_size, frame_rate)

    seqinfo_path = folder / "seqinfo.ini"
    info = read_seqinfo(seqinfo_path) if seqinfo_path.is_file() else {}
    notes: list[str] = []
    width, height = _image_size(info, image_size, seqinfo_path, notes)
    if "frame_rate" in info:
        if frame_rate is not None and float(frame_rate) != float(info["frame_rate"]):
            raise InputError(
                f"frameRate is {info['frame_rate']} but frame_rate {frame_rate} was given",
                seqinfo_path,
            )
        frame_rate = float(info["frame_rate"])

    detections = read_mot(folder / "det" / "det.txt", kind="det")
    gt_path = folder / "gt" / "gt.txt"
    ground_truth = read_mot(gt_path, kind="gt") if gt_path.is_file() else None

    images = folder / (_image_dir_name(seqinfo_path) if info else "img1")
    image_dir = images if images.is_dir() else None
    last = max(detections.n_frames, ground_truth.n_frames if ground_truth is not None else 0)
    length = _sequence_length(info, image_dir, last, notes)
    for data, path in ((detections, folder / "det" / "det.txt"), (ground_truth, gt_path)):
        if data is not None and data.n_frames > length:
            raise InputError(
                f"frame {data.n_frames} is beyond the sequence length {length} ({notes[-1]})", path
            )

    return MOTSequence(
        name=str(info.get("name", folder.name)),
        folder=folder,
        detections=detections,
        ground_truth=ground_truth,
        length=length,
        width=width,
        height=height,
        frame_rate=frame_rate,
        image_dir=image_dir,
        note="; ".join(notes),
    )


def _is_sequence(path: Path) -> bool:
    return (path / "det" / "det.txt").is_file() or (path / "seqinfo.ini").is_file()


def list_mot_sequences(root: str | Path) -> list[Path]:
    """Sequence folders of a MOTChallenge tree, sorted by path.

    ``root`` may be a benchmark folder (``MOT17/`` with ``train/`` and ``test/``), a split
    folder (``MOT17/train``) or a single sequence. A sequence is a folder holding
    ``det/det.txt`` or ``seqinfo.ini``.

    Raises
    ------
    InputError
        ``root`` is not a folder, or holds no sequence within two levels.
    """
    root = Path(root)
    if not root.is_dir():
        raise InputError("folder not found" if not root.exists() else "not a folder", root)
    if _is_sequence(root):
        return [root]
    found = [p for p in sorted(root.iterdir()) if p.is_dir() and _is_sequence(p)]
    for split in sorted(root.iterdir()):
        if split.is_dir() and not _is_sequence(split):
            found += [p for p in sorted(split.iterdir()) if p.is_dir() and _is_sequence(p)]
    if not found:
        raise InputError(
            "no MOTChallenge sequence (a folder with det/det.txt or seqinfo.ini) "
            "here or two levels below",
            root,
        )
    return sorted(found)
