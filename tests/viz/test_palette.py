"""One colour per person id: the palette, its BGR form and speaker labels."""

from __future__ import annotations

import pytest

from avtrack.viz.palette import (
    TAB10_HEX,
    person_bgr,
    person_colour,
    speaker_colour,
    speaker_person,
)


def test_a_person_colour_depends_on_the_id_alone():
    assert [person_colour(p) for p in range(1, 11)] == list(TAB10_HEX)  # ten distinct
    assert person_colour(11) == person_colour(1) and person_colour(0) == TAB10_HEX[-1]
    assert person_bgr(1) == (180, 119, 31)  # tab10 blue #1f77b4 as (b, g, r)
    with pytest.raises(TypeError, match="person must be an integer id, got float"):
        person_colour(1.0)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="got bool"):
        person_colour(True)


def test_a_speaker_label_names_its_person():
    assert speaker_person("P3") == 3 and speaker_person("spk_12") == 12
    assert speaker_person("alice") is None
    assert speaker_colour("P3") == person_colour(3)
    assert speaker_colour("alice") == speaker_colour("alice") in TAB10_HEX  # fixed per label
