"""``avtrack.config``: config dataclasses from mappings and YAML files, checked field by field."""

from __future__ import annotations

from pathlib import Path

import pytest

from avtrack.av.vavit import VAVITConfig
from avtrack.config import build_config, load_config
from avtrack.errors import InputError
from avtrack.localize import LOCALIZERS
from avtrack.phd import PHDConfig
from avtrack.simulate.robot import RobotSimConfig
from avtrack.visual.ovbt import OVBTConfig


def test_nested_mapping_overrides_only_the_fields_it_names():
    cfg = build_config(VAVITConfig, {"visual": {"birth_frames": 3}, "sigma_scale": 2})
    assert cfg.visual.birth_frames == 3
    assert cfg.visual.appearance == VAVITConfig().visual.appearance == "cosine"
    assert cfg.sigma_scale == 2 and cfg.diarization_threshold == 0.4
    prp = build_config(LOCALIZERS["prp-rem"].Config, {"dprtf": {"rho": 2.0}})
    assert (prp.dprtf.ctf_length, prp.dprtf.phase_only, prp.dprtf.rho) == (1, True, 2.0)


def test_lists_become_tuples_and_null_is_kept_for_optional_fields():
    assert build_config(PHDConfig, {"image_size": [640, 480]}).image_size == (640, 480)
    eg = LOCALIZERS["dprtf-eg"].Config
    assert build_config(eg, {"dprtf": {"noise": None}}).dprtf.noise is None
    off = build_config(eg, {"dprtf": {"noise": None}})
    assert build_config(off, {"dprtf": {"noise": {"speech_ratio": 4.0}}}).dprtf.noise.bias is None


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ({"n_iter": 2.0}, "c.yaml: n_iter: expected an integer, got 2.0"),
        ({"n_iter": True}, "c.yaml: n_iter: expected an integer, got True"),
        ({"exclusive": 1}, "c.yaml: exclusive: expected true or false, got 1"),
        ({"appearance": 3}, "c.yaml: appearance: expected a string, got 3"),
        ({"obs_std_pos": "1e-3"}, "got '1e-3' (YAML reads 1e-3 as text: write 1.0e-3)"),
        ({"n_iters": 2}, "c.yaml: n_iters: unknown field (allowed: appearance, "),
        ({"n_iter": 0}, "c.yaml: OVBTConfig.n_iter must be an integer >= 1, got 0"),
    ],
)
def test_errors_name_the_file_and_the_field(values, message):
    with pytest.raises(InputError) as exc:
        build_config(OVBTConfig, values, Path("c.yaml"))
    assert message in str(exc.value) and "\n" not in str(exc.value)


def test_nested_errors_carry_the_field_path():
    with pytest.raises(InputError, match=r"^r.yaml: tracker.death_frame: unknown field"):
        build_config(RobotSimConfig, {"tracker": {"death_frame": 3}}, Path("r.yaml"))
    with pytest.raises(InputError, match=r"^r.yaml: stereo.depth_range: expected a list of 2"):
        build_config(RobotSimConfig, {"stereo": {"depth_range": [1.0]}}, Path("r.yaml"))
    with pytest.raises(InputError, match=r"^r.yaml: tracker: RobotTrackerConfig.control must"):
        build_config(RobotSimConfig, {"tracker": {"control": "bad"}}, Path("r.yaml"))
    with pytest.raises(InputError, match=r"^r.yaml: detector: expected a mapping of Detector"):
        build_config(RobotSimConfig, {"detector": 0.1}, Path("r.yaml"))


def test_load_config_file_then_command_line(tmp_path):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("min_score: 0.2\nbirth_frames: 4\n")
    assert load_config(None, OVBTConfig) == OVBTConfig()
    got = load_config(cfg, OVBTConfig, overrides={"min_score": 0.5, "death_frames": None})
    assert (got.min_score, got.birth_frames, got.death_frames) == (0.5, 4, 10)
    robot = load_config(None, RobotSimConfig, overrides={"tracker.control": "exact"})
    assert robot.tracker.control == "exact" and robot.gain == RobotSimConfig().gain
    cfg.write_text("- 1\n")
    with pytest.raises(InputError, match="expected a mapping of OVBTConfig fields"):
        load_config(cfg, OVBTConfig)
