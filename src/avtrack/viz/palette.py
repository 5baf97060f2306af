"""One colour per person, the same on every figure and in the video overlay.

A person's colour depends on their id alone -- never on which other ids a panel happens to
show -- so person 3 is drawn in one colour on the image trajectories, the persons' directions,
the heat map's overlay, the diarization rows and the boxes of the video. The colours are
matplotlib's ``tab10``: person ``p`` gets ``TAB10_HEX[(p - 1) % 10]`` (ids count from 1, so
persons 1 to 10 get ten different colours).

A speaker label of a diarization (``"P3"``, ``"spk_12"``) names the person of its trailing
number (:func:`speaker_person`).
"""

from __future__ import annotations

import re
import zlib

#: matplotlib's ``tab10`` colours, ``#rrggbb``.
TAB10_HEX: tuple[str, ...] = (
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#d62728",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#7f7f7f",
    "#bcbd22",
    "#17becf",
)


def _person_id(person: int) -> int:
    if isinstance(person, bool) or not hasattr(person, "__index__"):
        raise TypeError(f"person must be an integer id, got {type(person).__name__}")
    return int(person)


def person_colour(person: int) -> str:
    """The colour of person ``person`` on every figure, ``#rrggbb``.

    Parameters
    ----------
    person : int
        The person's (or track's) id.

    Raises
    ------
    TypeError
        If ``person`` is not an integer.
    """
    return TAB10_HEX[(_person_id(person) - 1) % len(TAB10_HEX)]


def person_bgr(person: int) -> tuple[int, int, int]:
    """:func:`person_colour` as an OpenCV ``(blue, green, red)`` triple of 0..255."""
    code = person_colour(person)
    r, g, b = (int(code[k : k + 2], 16) for k in (1, 3, 5))
    return b, g, r


def speaker_person(label: str) -> int | None:
    """The person id a speaker label names: its trailing number (``"P3"`` -> 3), or None for
    a label without one."""
    m = re.search(r"(\d+)$", str(label))
    return int(m[1]) if m else None


def speaker_colour(label: str) -> str:
    """The colour of a diarization's speaker: its person's (:func:`speaker_person`), or, for a
    label without a number, a ``tab10`` colour fixed by the label's CRC-32."""
    person = speaker_person(label)
    if person is not None:
        return person_colour(person)
    return TAB10_HEX[zlib.crc32(str(label).encode()) % len(TAB10_HEX)]
