"""``avtrack simulate``: draw a simulated audio-visual scene and write its directory."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from avtrack.cli import progress
from avtrack.cli.base import add_command, add_common, add_options_option
from avtrack.errors import InputError
from avtrack.io.scenario import (
    SCENARIO_REFERENCE,
    dump_scenario,
    load_scenario,
    validate_scenario,
)
from avtrack.simulate.library import SCENARIOS, named_scenario

EXAMPLES = f"""\
named scenarios: {", ".join(SCENARIOS)}
  meeting       2-4 people around a table, binaural dummy head + camera (AVDIAR-like)
  locata-like   two talkers walking around a NAO head (measured HRIRs, recorded LOCATA tracks)
  kinovis-like  noisy room, three talkers coming and going around the NAO head
  walkout       people walk out of the camera's view while talking, then come back

examples:
  avtrack simulate meeting -o scenes/meeting-0
  avtrack simulate walkout -o scenes/walkout-3 --seed 3 --duration 30
  avtrack simulate meeting --print            # show the scenario YAML, simulate nothing
  avtrack simulate my-scene.yaml -o scenes/mine
  avtrack simulate --help-scenario            # every scenario field, with its default
  avtrack simulate --options sim.yaml --seed 4 # the file's options, another seed

The --options YAML holds option values by name (SCENARIO included), e.g.:
  scenario: walkout
  output: scenes/walkout
  duration: 30
  utterances: synthetic
Scenario fields themselves (room, people, noise ...) go in a scenario YAML file.

The scene directory holds scene.yaml, audio.wav, array.json, camera.json, detections.txt,
appearance.npy and gt/ (gt.txt, doa.csv, speech.rttm, positions.csv); see the README.
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    p = add_command(
        subparsers,
        "simulate",
        help="simulate an audio-visual scene (room acoustics, camera, detections, ground truth)",
        description="""\
Simulate people who move and talk in a reverberant room, recorded by a microphone
array and a camera: microphone signals, head detections with appearance, and exact
ground truth (boxes, directions of arrival, who speaks when).""",
        epilog=EXAMPLES,
    )
    p.add_argument(
        "scenario",
        nargs="?",
        metavar="SCENARIO",
        help=f"a scenario YAML file, or a named scenario ({', '.join(SCENARIOS)})",
    )
    p.add_argument("-o", "--output", type=Path, metavar="SCENE_DIR", help="scene directory")
    p.add_argument("--seed", type=int, metavar="S", help="random seed (overrides the file's)")
    p.add_argument(
        "--duration", type=float, metavar="SECONDS", help="scene length (overrides the file's)"
    )
    p.add_argument(
        "--array", metavar="ARRAY", help="microphone array: built-in name or JSON file (override)"
    )
    p.add_argument(
        "--utterances",
        metavar="SRC",
        help="speech material: auto, shared, synthetic, or a folder of wav files (override)",
    )
    p.add_argument(
        "--print",
        dest="print_only",
        action="store_true",
        help="print the validated scenario as YAML and exit",
    )
    p.add_argument(
        "--help-scenario", action="store_true", help="print every scenario field and exit"
    )
    add_common(p, run)
    add_options_option(p, exclude=("print_only", "help_scenario"))


def resolve_scenario(args: argparse.Namespace) -> tuple[dict, Path | None]:
    """The validated scenario the arguments describe, and the file it came from."""
    name = args.scenario
    path = None
    if args.seed is not None and args.seed < 0:
        raise InputError(f"--seed must be >= 0, got {args.seed}")
    if name in SCENARIOS:
        if args.duration is not None and args.duration <= 0:
            raise InputError(f"--duration must be > 0 seconds, got {args.duration}")
        raw = named_scenario(name, args.seed or 0, args.duration or 20.0)
    else:
        path = Path(name)
        if not path.is_file():
            raise InputError(
                f"no such scenario file, and not a named scenario ({', '.join(SCENARIOS)})", path
            )
        raw = dump_and_load(path)
        if args.seed is not None:
            raw["seed"] = args.seed
        if args.duration is not None:
            raw["duration"] = args.duration
    if args.array is not None:
        raw.setdefault("array", {})
        raw["array"] = {**raw["array"], "name": args.array, "hrir": False}
    if args.utterances is not None:
        raw["speech"] = {**raw.get("speech", {}), "utterances": args.utterances}
    return validate_scenario(raw, path), path


def dump_and_load(path: Path) -> dict:
    """The raw mapping of a scenario file (validated once, so its errors name the file)."""
    load_scenario(path)  # raises with the file's name on a bad field
    import yaml

    return yaml.safe_load(path.read_text())


def run(args: argparse.Namespace) -> int:
    if args.help_scenario:
        print(SCENARIO_REFERENCE, end="")
        return 0
    if args.scenario is None:
        raise InputError("give a scenario file or name (see 'avtrack simulate --help')")
    scenario, path = resolve_scenario(args)
    if args.print_only:
        print(dump_scenario(scenario), end="")
        return 0
    if args.output is None:
        raise InputError("-o SCENE_DIR is required (or use --print)")
    from avtrack.simulate.scene import simulate_scene, write_scene

    t0 = time.perf_counter()
    desc = f"simulating {scenario['duration']:g} s of {scenario['name']}"
    with progress.activity(desc, args.quiet):
        scene = simulate_scene(scenario, scenario_path=path)
    write_scene(scene, args.output)
    if not args.quiet:
        dur = scenario["duration"]
        talk = sum(s.end - s.start for s in scene.segments)
        n_det = scene.detections.detections.frames.size
        print(
            f"{scenario['name']} (seed {scenario['seed']}): {dur:g} s, {len(scene.ids)} people, "
            f"{scene.array.n_mics} mics ({scene.array.name}), {talk:.1f} s of speech, "
            f"{n_det} detections in {scene.video_times.size} frames"
            f" -> {args.output}  [{time.perf_counter() - t0:.1f} s]",
            file=sys.stdout,
        )
    return 0
