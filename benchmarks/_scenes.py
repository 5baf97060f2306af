"""The simulated scenes of the persons and voice-activity benchmarks, cached in a work folder
under the same names (``<kind>-<seed>``), so that the two benchmarks can share one."""

from __future__ import annotations

from pathlib import Path

from avtrack.io.scenario import validate_scenario
from avtrack.simulate.library import named_scenario
from avtrack.simulate.scene import simulate_scene, write_scene


def scene_dir(work: Path, kind: str, seed: int, duration: float) -> Path:
    """``work/<kind>-<seed>``: the named scenario ``kind`` (:func:`named_scenario`) simulated
    and written there the first time."""
    d = work / f"{kind}-{seed}"
    if not (d / "scene.yaml").is_file():
        write_scene(simulate_scene(validate_scenario(named_scenario(kind, seed, duration))), d)
    return d
