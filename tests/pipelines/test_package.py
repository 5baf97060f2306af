"""The pipeline package: every public name resolves, and a path loads only its own module."""

from __future__ import annotations

import subprocess
import sys

import pytest

import avtrack.pipelines as pipelines


@pytest.mark.parametrize("name", pipelines.__all__)
def test_every_public_name_resolves_to_its_module(name):
    obj = getattr(pipelines, name)
    assert obj.__module__ == f"avtrack.pipelines.{pipelines._MODULE_OF[name]}"


def test_all_lists_every_name_the_package_resolves():
    assert sorted(pipelines.__all__) == sorted(pipelines._MODULE_OF)


def test_an_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'track_everything'"):
        _ = pipelines.track_everything


def test_the_visual_path_does_not_load_the_acoustic_one():
    code = ("import sys\nfrom avtrack.pipelines import track_mot_sequence\n"
            "print(sorted(m for m in sys.modules if m.startswith('avtrack.pipelines.')))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "['avtrack.pipelines.mot']"
