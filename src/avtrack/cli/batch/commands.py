"""The commands a batch item can run, each through the command line's own parser.

An item is one command line: its input paths become the command's arguments, its parameters
become options (``tracker: vonmises`` is ``--tracker vonmises``) or, when the command has no
such option, fields of the ``--config`` file written into the item's folder
(``birth_frames: 3``, ``visual.birth_frames: 3``). Running it through the parser means a batch
item accepts and refuses exactly what the command line does. When the item gives ground truth,
its outputs are scored by the scoring ``avtrack eval`` does (the eval commands themselves, whose
``--json`` records become the row's columns), or, for the trackers ``eval`` has no task for,
by the same metric functions the tracking command prints.

Each command is a :class:`BatchCommand` in :data:`COMMANDS`: the path fields it takes, how a
folder input (a scene directory from ``avtrack simulate``, a MOTChallenge sequence, an AV16.3
folder) fills them, the arguments they make, and how the outputs are scored.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from avtrack.errors import InputError
from avtrack.registry import Registry

#: Every path field an item may give, in table order, and what it is.
PATH_FIELDS: dict[str, str] = {
    "video": "the camera's video",
    "audio": "the microphone array's WAV",
    "detections": "MOTChallenge detections (det.txt)",
    "appearance": "appearance descriptors (.npy), one row per detection",
    "array": "a built-in array name or an array JSON file",
    "camera": "a camera file (CAMERA.yaml)",
    "doa": "a DOA CSV (peaks of a localizer)",
    "config": "a --config YAML file the parameters are added to",
    "gt": "ground truth: MOTChallenge gt.txt (track-mot, track-av) or a DOA CSV (localize, "
          "track-audio)",
    "gt_speech": "ground truth speaker turns (RTTM; track-av)",
}  # fmt: skip

#: Options a parameter may not set: the batch sets them (outputs, verbosity) or they are the
#: item's path fields.
RESERVED = ("output", "force", "quiet", "verbose", "help", "plot", "report", "truth", "roc",
            "json")  # fmt: skip

Paths = Mapping[str, str]


@dataclass(frozen=True)
class BatchCommand:
    """One command a batch item can run.

    Attributes
    ----------
    name : str
        The sub-command (``avtrack NAME``).
    fields : tuple of str
        The path fields (:data:`PATH_FIELDS`) it takes.
    needs : tuple of tuple of str
        Alternatives of the fields it needs without a folder input (one of them complete).
    output : str
        The file ``-o`` names in the item's folder (``""``: the folder itself).
    arguments : callable ``(paths) -> list of str``
        Positional arguments and path options.
    from_folder : callable ``(folder) -> (paths, default parameters)``
        The fields a folder input fills, and parameters it implies (the item's own win).
    score : callable ``(paths, folder, parameters) -> dict``
        Scores of the outputs in ``folder`` (``{}`` without ground truth).
    """

    name: str
    fields: tuple[str, ...]
    needs: tuple[tuple[str, ...], ...]
    output: str
    arguments: Callable[[Paths], list[str]]
    from_folder: Callable[[Path], tuple[dict[str, str], dict[str, Any]]]
    score: Callable[[Paths, Path, Mapping[str, Any]], dict[str, Any]]


#: command name -> :class:`BatchCommand`.
COMMANDS: Registry[BatchCommand] = Registry("batch command")


def _add(command: BatchCommand) -> None:
    COMMANDS.register(command.name)(command)


# ------------------------------------------------------------------------ running a command
def _raise_instead_of_exit(parser: argparse.ArgumentParser) -> None:
    """Make ``parser`` and its sub-parsers raise :class:`InputError` instead of exiting."""

    def error(message: str):
        raise InputError(f"{parser.prog}: {message}")

    parser.error = error  # type: ignore[method-assign]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                _raise_instead_of_exit(sub)


def command_parser(name: str) -> argparse.ArgumentParser:
    """The parser of sub-command ``name`` (``"eval"``, ``"track-av"`` ...), raising
    :class:`InputError` on bad arguments."""
    from avtrack.cli.main import build_parser, command_name, module_of

    parser = build_parser((module_of(name),))
    _raise_instead_of_exit(parser)
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return action.choices[command_name(module_of(name))]
    raise RuntimeError(f"no sub-command {name!r}")  # (never: build_parser adds them all)


def run_cli(argv: list[str]) -> None:
    """Run ``avtrack ARGV`` in this process, as ``avtrack.cli.main.main`` does; a refusal is
    raised (:class:`InputError`), a non-zero exit status too."""
    from avtrack.cli.main import build_parser, module_of

    parser = build_parser((module_of(argv[0]),))
    _raise_instead_of_exit(parser)
    args = parser.parse_args(argv)
    from avtrack.cli.base import check_outputs

    check_outputs(args)
    status = int(args.func(args) or 0)
    if status:
        raise RuntimeError(f"avtrack {argv[0]} exited with status {status}")


def options_of(name: str) -> dict[str, argparse.Action]:
    """The options of command ``name`` a parameter may set, by parameter name
    (``--grid-step`` is ``grid_step``)."""
    out = {}
    for action in command_parser(name)._actions:
        for opt in action.option_strings:
            if opt.startswith("--"):
                key = opt[2:].replace("-", "_")
                if key not in RESERVED and key not in PATH_FIELDS:
                    out[key] = action
    return out


def command_line(command: BatchCommand, paths: Paths, params: Mapping[str, Any],
                 folder: Path) -> list[str]:
    """The arguments of one item (the options of ``params``, the others written to
    ``folder/config.yaml``)."""
    import yaml

    options = options_of(command.name)
    argv = [command.name, *command.arguments(paths)]
    fields: dict[str, Any] = {}
    for key, value in params.items():
        action = options.get(key)
        if action is None:
            node = fields
            *parents, leaf = key.split(".")
            for p in parents:
                node = node.setdefault(p, {})
            node[leaf] = value
        elif isinstance(action, argparse._StoreTrueAction | argparse._StoreFalseAction):
            if value:
                argv.append(action.option_strings[-1])
        else:
            argv.append(f"{action.option_strings[-1]}={value}")
    if fields:
        base: dict[str, Any] = {}
        if "config" in paths:
            from avtrack.config import read_config_mapping

            base = read_config_mapping(Path(paths["config"]), "parameters")
        _merge(base, fields)
        (folder / "config.yaml").write_text(yaml.safe_dump(base, sort_keys=False))
        argv += ["--config", str(folder / "config.yaml")]
    elif "config" in paths:
        argv += ["--config", paths["config"]]
    argv += ["-o", str(folder / command.output) if command.output else str(folder),
             "--force", "--quiet"]
    return argv


def _merge(base: dict, extra: Mapping) -> None:
    for k, v in extra.items():
        if isinstance(v, Mapping) and isinstance(base.get(k), dict):
            _merge(base[k], v)
        else:
            base[k] = v


def eval_scores(task: str, argv: list[str], folder: Path, keep: tuple[str, ...]) -> dict:
    """The scores ``avtrack eval TASK ARGV --json`` writes, those named in ``keep``."""
    out = folder / f"scores-{task}.json"
    run_cli(["eval", task, *argv, "--json", str(out), "--quiet"])
    scores = json.loads(out.read_text())["scores"]
    return {k: scores[k] for k in keep}


def _option(flag: str, paths: Paths, field: str) -> list[str]:
    return [flag, paths[field]] if field in paths else []


def _scene_camera(folder: Path) -> dict[str, Any]:
    cam = json.loads((folder / "camera.json").read_text())
    out: dict[str, Any] = {"image_size": f"{int(cam['width'])}x{int(cam['height'])}"}
    if cam.get("fps"):
        out["fps"] = float(cam["fps"])
    return out


def _is_scene(folder: Path) -> bool:
    return (folder / "scene.yaml").is_file()


# ------------------------------------------------------------------------------- track-mot
MOT_COLUMNS = ("MOTA", "MOTP", "IDF1", "HOTA", "FP", "FN", "IDSW")


def _mot_folder(folder: Path) -> tuple[dict[str, str], dict[str, Any]]:
    if _is_scene(folder):  # a simulated scene: detections with appearance embeddings
        paths = {"detections": "detections.txt", "appearance": "appearance.npy",
                 "gt": "gt/gt.txt"}  # fmt: skip
        defaults = {**_scene_camera(folder), "appearance": "cosine"}
        return {k: str(folder / v) for k, v in paths.items()}, defaults
    files = {"detections": folder / "det" / "det.txt", "gt": folder / "gt" / "gt.txt"}
    return {k: str(v) for k, v in files.items() if v.is_file()}, {}


def _mot_benchmark(paths: Paths) -> str:
    """MOT17 preprocessing for a simulated scene's ground truth (it has classes), else
    MOT15."""
    return "MOT17" if _is_scene(Path(paths["gt"]).parent.parent) else "MOT15"


def _score_mot(paths: Paths, folder: Path, params: Mapping[str, Any]) -> dict[str, Any]:
    if "gt" not in paths:
        return {}
    return eval_scores("mot", [paths["gt"], str(folder / "tracks.txt"), "--benchmark",
                               _mot_benchmark(paths)], folder, MOT_COLUMNS)


_add(BatchCommand(
    name="track-mot",
    fields=("detections", "video", "appearance", "config", "gt"),
    needs=(("detections",), ("video",)),
    output="tracks.txt",
    arguments=lambda p: ([p["detections"]] if "detections" in p else [])
    + _option("--video", p, "video") + _option("--appearance", p, "appearance"),
    from_folder=_mot_folder,
    score=_score_mot,
))  # fmt: skip


# -------------------------------------------------------------------- localize, track-audio
DOA_COLUMNS = ("MD%", "FA%", "MAE")


def _audio_folder(folder: Path) -> tuple[dict[str, str], dict[str, Any]]:
    paths = {"audio": "audio.wav", "array": "array.json", "gt": "gt/doa.csv"}
    return {k: str(folder / v) for k, v in paths.items() if (folder / v).is_file()}, {}


def _score_localize(paths: Paths, folder: Path, params: Mapping[str, Any]) -> dict[str, Any]:
    if "gt" not in paths:
        return {}
    return eval_scores("doa", [paths["gt"], str(folder / "doa.csv")], folder, DOA_COLUMNS)


_add(BatchCommand(
    name="localize",
    fields=("audio", "array", "config", "gt"),
    needs=(("audio", "array"),),
    output="doa.csv",
    arguments=lambda p: [p["audio"], "--array", p["array"]],
    from_folder=_audio_folder,
    score=_score_localize,
))  # fmt: skip


def tracker_frame_times(tracks, truth, step: int, hop_s: float, duration_s: float | None):
    """The tracker's frames (one per ``step`` localizer frames of ``hop_s``, at the end of each
    block, as :func:`avtrack.doa.base.heatmap_sequence` takes them) up to the recording's end
    (else the last row of either table), frames where no track was alive included."""
    import numpy as np

    period = step * hop_s
    end = duration_s if duration_s is not None else float(
        max(truth.time_s.max(initial=0.0), tracks.time_s.max(initial=0.0)))
    offset = float(tracks.time_s.min()) % period if len(tracks) else 0.0
    if offset > period - 1e-6:
        offset = 0.0
    times = np.arange(offset, end + 1e-6, period)
    return times[times > 1e-9]


def _score_track_audio(paths: Paths, folder: Path, params: Mapping[str, Any]) -> dict:
    if "gt" not in paths:
        return {}
    from avtrack.audio.stft import FRAME_HOP_S as HOP_S
    from avtrack.io.doa import read_doa_csv
    from avtrack.metrics.doa_tracking import evaluate_tracks

    tracks = read_doa_csv(folder / "tracks.csv")
    truth = read_doa_csv(paths["gt"])
    duration = None
    if "audio" in paths:
        import soundfile as sf

        duration = float(sf.info(paths["audio"]).duration)
    times = tracker_frame_times(tracks, truth, int(params.get("step", 4)), HOP_S, duration)
    d = evaluate_tracks(tracks, truth, frame_times=times).as_dict()
    return {k: d[k] for k in ("MD%", "FA%", "MAE", "IDs", "OSPA")}


_add(BatchCommand(
    name="track-audio",
    fields=("audio", "array", "doa", "config", "gt"),
    needs=(("audio", "array"), ("doa",)),
    output="tracks.csv",
    arguments=lambda p: ([p["audio"]] if "audio" in p else []) + _option("--array", p, "array")
    + _option("--doa", p, "doa"),
    from_folder=_audio_folder,
    score=_score_track_audio,
))  # fmt: skip


# -------------------------------------------------------------------------------- track-av
def _av_folder(folder: Path) -> tuple[dict[str, str], dict[str, Any]]:
    paths = {"input": str(folder)}
    if _is_scene(folder):
        paths |= {"gt": str(folder / "gt" / "gt.txt")}
        if (folder / "gt" / "speech.rttm").is_file():
            paths |= {"gt_speech": str(folder / "gt" / "speech.rttm")}
    return paths, {}


def _score_track_av(paths: Paths, folder: Path, params: Mapping[str, Any]) -> dict[str, Any]:
    scores: dict[str, Any] = {}
    if "gt" in paths:
        scores |= eval_scores("mot", [paths["gt"], str(folder / "tracks.txt"), "--benchmark",
                                      _mot_benchmark(paths)], folder, MOT_COLUMNS)
    if "gt_speech" in paths and (folder / "speech.rttm").is_file():
        scores |= eval_scores("der", [paths["gt_speech"], str(folder / "speech.rttm")], folder,
                              ("DER",))
    return scores


_RECORDING = ("video", "audio", "array", "camera", "detections", "appearance", "doa")
_add(BatchCommand(
    name="track-av",
    fields=(*_RECORDING, "config", "gt", "gt_speech"),
    needs=(("camera",),),
    output="",
    arguments=lambda p: ([p["input"]] if "input" in p else [])
    + [a for f in _RECORDING for a in _option(f"--{f}", p, f)],
    from_folder=_av_folder,
    score=_score_track_av,
))  # fmt: skip


# ------------------------------------------------------------------------------- track-phd
def _score_track_phd(paths: Paths, folder: Path, params: Mapping[str, Any]) -> dict[str, Any]:
    """OSPA and OSPA-T of the written tracks against the sequence's ground truth, as
    ``avtrack track-phd`` prints them."""
    import numpy as np

    from avtrack.io.av163 import load_av163
    from avtrack.metrics.ospa import ospa_sequence
    from avtrack.phd.likelihood import av163_truth
    from avtrack.phd.scoring import OSPA_CUTOFF, OSPA_ORDER, ospa_t_of_rows

    seq = load_av163(Path(paths["input"]), int(params["seq"]), int(params["cam"]))
    rows = np.loadtxt(folder / "tracks.csv", delimiter=",", skiprows=1, ndmin=2)
    positions = [rows[rows[:, 0] == f, 2:4] for f in seq.frames]
    ospa = ospa_sequence(positions, av163_truth(seq), OSPA_CUTOFF, OSPA_ORDER)
    return {"OSPA": float(ospa[:, 0].mean()), "OSPA-T": ospa_t_of_rows(rows, seq)}


_add(BatchCommand(
    name="track-phd",
    fields=("video", "config"),
    needs=(),
    output="tracks.csv",
    arguments=lambda p: [p["input"], *_option("--video", p, "video")],
    from_folder=lambda folder: ({"input": str(folder)}, {}),
    score=_score_track_phd,
))  # fmt: skip
