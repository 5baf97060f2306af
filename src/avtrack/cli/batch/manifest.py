"""Manifests: recordings x commands x parameters, validated and expanded into work items.

A manifest is a YAML file::

    name: my-recordings
    items:
      - id: office-1                    # optional: names the item's output folder
        command: track-audio            # track-av, track-audio, localize, track-mot, track-phd
        audio: office-1/audio.wav       # path fields (see PATH_FIELDS), relative to this file
        array: respeaker4
        gt: office-1/doa.csv            # ground truth: the item is scored
        params:                         # every combination of the listed values
          tracker: [gauss, vonmises]
      - command: track-mot
        inputs: [../shared/data/mot15/TUD-Campus, "walkout:0:10"]
        params: {birth_frames: [2, 3]}

or a CSV file with one item per row: a header of ``id``, ``command``, ``input``, path fields
and ``param.NAME`` columns; empty cells are not given, and a parameter cell lists its values
separated by ``;`` (``gauss;vonmises``), each read as YAML (``3`` is a number).

An input (``input``, or each of ``inputs``) is a folder whose layout fills the path fields (a
scene directory written by ``avtrack simulate``, a MOTChallenge sequence with ``det/`` and
``gt/``, an AV16.3 folder) or ``NAME:SEED[:SECONDS]``, a named simulated scene drawn where the
item runs (``walkout:3:10`` = ``avtrack simulate walkout --seed 3 --duration 10``). Path fields
given in the item win over the input's.

Each work item is a plain dict (picklable, so it can travel to a process or a Dask worker)
with a stable ``id``: the name of its output folder, the same whenever the manifest gives the
same item.
"""

from __future__ import annotations

import csv
import hashlib
import itertools
import json
import re
from pathlib import Path
from typing import Any

from avtrack.cli.batch.commands import COMMANDS, PATH_FIELDS, RESERVED, options_of
from avtrack.errors import InputError
from avtrack.io.base import read_yaml_file

#: Manifests usable by name (``avtrack batch smoke``).
BUILTIN_MANIFESTS: dict[str, dict] = {
    "smoke": {
        "name": "smoke",
        "items": [
            {
                "command": "track-mot",
                "inputs": ["walkout:0:10", "walkout:1:10", "meeting:0:10"],
                "params": {"birth_frames": [2, 3]},
            },
            {
                "command": "localize",
                "inputs": ["locata-like:0:10"],
                "params": {"method": ["dprtf-eg", "srp-phat"]},
            },
        ],
    },
}

#: Fields of an item that are not path fields.
ITEM_FIELDS = ("id", "command", "input", "inputs", "params")


class _Where:
    """Where a problem is: the file, and the item (YAML) or row (CSV)."""

    def __init__(self, path: Path | None, item: str, row: int | None = None):
        self.path, self.item, self.row = path, item, row

    def error(self, field: str, message: str) -> InputError:
        name = f"{self.item}.{field}" if self.row is None else field
        return InputError(f"{name}: {message}", self.path, self.row)


def load_manifest(path: str | Path) -> tuple[str, list[dict]]:
    """A built-in manifest by name, or a manifest file (``.csv``, else YAML), expanded into
    work items."""
    if str(path) in BUILTIN_MANIFESTS:
        return expand_manifest(BUILTIN_MANIFESTS[str(path)])
    path = Path(path)
    if path.suffix.lower() == ".csv":
        return path.stem, _expand_csv(path)
    return expand_manifest(read_yaml_file(path, "manifest"), path)


def expand_manifest(raw: Any, path: str | Path | None = None) -> tuple[str, list[dict]]:
    """Validate a manifest mapping and expand it into work items, in a fixed order."""
    path = None if path is None else Path(path)
    if not isinstance(raw, dict):
        raise InputError(f"manifest: expected a mapping, got {type(raw).__name__}", path)
    unknown = sorted(set(raw) - {"name", "items"})
    if unknown:
        raise InputError(f"{unknown[0]}: unknown field (allowed: items, name)", path)
    name = raw.get("name", path.stem if path else "manifest")
    entries = raw.get("items")
    if not isinstance(entries, list) or not entries:
        raise InputError("items: expected a non-empty list", path)
    base = path.parent if path is not None else Path.cwd()
    items: list[dict] = []
    for i, entry in enumerate(entries):
        where = _Where(path, f"items[{i}]")
        if not isinstance(entry, dict):
            raise InputError(f"items[{i}]: expected a mapping", path)
        entry = dict(entry)
        if "task" in entry and "command" not in entry:  # the field's earlier name
            entry["command"] = entry.pop("task")
        params = entry.get("params") or {}
        if not isinstance(params, dict):
            raise where.error("params", "expected a mapping of values or lists of values")
        grid = {str(k): v if isinstance(v, list) else [v] for k, v in params.items()}
        items += _expand_entry(entry, grid, base, where)
    _check_unique(items, path)
    return str(name), items


def _expand_csv(path: Path) -> list[dict]:
    import yaml

    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputError("manifest file not found", path) from None
    except UnicodeDecodeError as exc:
        raise InputError(f"not a UTF-8 text file ({exc.reason})", path) from None
    reader = csv.DictReader(text.splitlines())
    header = reader.fieldnames or []
    for col in header:
        if col not in ITEM_FIELDS and col not in PATH_FIELDS and not col.startswith("param."):
            raise InputError(f"{col}: unknown column (allowed: {', '.join(ITEM_FIELDS)}, "
                             f"{', '.join(PATH_FIELDS)}, param.NAME)", path, 1)
    items: list[dict] = []
    for n, row in enumerate(reader, start=2):
        where = _Where(path, f"row {n}", n)
        if None in row:
            raise InputError(f"{len(header)} columns expected, got more", path, n)
        entry: dict[str, Any] = {}
        grid: dict[str, list] = {}
        for col, cell in row.items():
            cell = (cell or "").strip()
            if not cell:
                continue
            if col.startswith("param."):
                try:
                    grid[col[6:]] = [yaml.safe_load(v) for v in cell.split(";")]
                except yaml.YAMLError:
                    raise where.error(col, f"not a value: {cell!r}") from None
            elif col == "inputs":
                entry[col] = cell.split(";")
            else:
                entry[col] = cell
        if not entry and not grid:
            continue  # an empty line
        items += _expand_entry(entry, grid, path.parent, where)
    if not items:
        raise InputError("no items: expected a header and one row per item", path)
    _check_unique(items, path)
    return items


def _expand_entry(entry: dict, grid: dict[str, list], base: Path, where: _Where) -> list[dict]:
    extra = sorted(set(entry) - set(ITEM_FIELDS) - set(PATH_FIELDS))
    if extra:
        raise where.error(extra[0], "unknown field")
    name = entry.get("command")
    if not isinstance(name, str) or name not in COMMANDS:
        raise where.error("command", f"expected one of {', '.join(COMMANDS)}, got {name!r}")
    command = COMMANDS[name]
    for field in PATH_FIELDS:
        if field in entry and field not in command.fields:
            raise where.error(field, f"not an input of {name} (its fields: "
                                     f"{', '.join(command.fields)}; or input)")
    label = entry.get("id")
    if label is not None and (not isinstance(label, str) or not re.fullmatch(r"[\w.-]+", label)):
        raise where.error("id", f"expected a name of letters, digits, '.', '-', '_', got "
                                f"{label!r}")
    if "input" in entry and "inputs" in entry:
        raise where.error("inputs", "give input or inputs, not both")
    specs: list[Any] = [None]
    if "input" in entry:
        specs = [entry["input"]]
    elif "inputs" in entry:
        specs = entry["inputs"]
        if not isinstance(specs, list) or not specs:
            raise where.error("inputs", "expected a non-empty list")
    paths = {f: _resolve_path(entry[f], f, base, where) for f in PATH_FIELDS if f in entry}
    _check_params(name, grid, where)
    items = []
    for j, spec in enumerate(specs):
        field = "input" if "input" in entry else f"inputs[{j}]"
        resolved = None if spec is None else resolve_input(spec, base, where, field)
        # a folder input fills the fields (what it lacks, the command says when it runs)
        if resolved is None and not any(set(need) <= set(paths) for need in command.needs):
            alternatives = " or ".join(["+".join(n) for n in command.needs] + ["input"])
            raise where.error("command", f"{name} needs {alternatives}")
        for combo in itertools.product(*grid.values()):
            params = dict(zip(grid, combo, strict=True))
            items.append(_item(name, label, resolved, paths, params))
    return items


def _check_params(command: str, grid: dict[str, list], where: _Where) -> None:
    """Parameters are options of the command (values within its choices) or config fields
    (checked by the command when it reads the config)."""
    options = options_of(command)
    for key, values in grid.items():
        field = f"params.{key}" if where.row is None else f"param.{key}"
        if not re.fullmatch(r"[A-Za-z_][\w]*(\.[A-Za-z_][\w]*)*", key):
            raise where.error(field, "expected an option or config field name")
        if key in RESERVED or key in PATH_FIELDS:
            raise where.error(field, "set by the batch or a path field, not a parameter")
        if not values:
            raise where.error(field, "expected a value or a non-empty list")
        action = options.get(key)
        for v in values:
            if isinstance(v, dict | list) or v is None:
                raise where.error(field, f"expected a number, a string or true/false, got "
                                         f"{v!r}")
            if action is not None and action.choices is not None and v not in action.choices:
                raise where.error(field, f"expected one of {', '.join(map(str, action.choices))}"
                                         f", got {v!r}")


def _resolve_path(value: Any, field: str, base: Path, where: _Where) -> str:
    if not isinstance(value, str) or not value:
        raise where.error(field, f"expected a path, got {value!r}")
    if field == "array":
        from avtrack.audio.arrays import BUILTIN_ARRAYS

        if value in BUILTIN_ARRAYS:
            return value
    p = Path(value) if Path(value).is_absolute() else base / value
    if not p.exists():
        raise where.error(field, f"no such file: {value}")
    return str(p.resolve())


def resolve_input(spec: Any, base: Path, where: _Where, field: str) -> str:
    """A folder input's absolute path, or a named scene as ``NAME:SEED:SECONDS``."""
    from avtrack.simulate.library import SCENARIOS

    if not isinstance(spec, str) or not spec:
        raise where.error(field, f"expected a folder or NAME:SEED, got {spec!r}")
    head = spec.split(":")[0]
    if head in SCENARIOS:
        parts = spec.split(":")
        try:
            seed = int(parts[1]) if len(parts) > 1 else 0
            dur = float(parts[2]) if len(parts) > 2 else 20.0
        except ValueError:
            seed, dur = -1, -1.0
        if len(parts) > 3 or seed < 0 or not 0 < dur < float("inf"):
            raise where.error(field, f"expected NAME:SEED[:SECONDS], got {spec!r}")
        return f"{head}:{seed}:{dur:g}"
    folder = Path(spec) if Path(spec).is_absolute() else base / spec
    if not folder.is_dir():
        raise where.error(field, f"no such folder and not a named scene: {spec!r}")
    return str(folder.resolve())


def _item(command: str, label: str | None, spec: str | None, paths: dict[str, str],
          params: dict[str, Any]) -> dict:
    if label is None:
        if spec is not None:  # a named scene as it is, a folder by its name
            label = spec if ":" in spec else Path(spec).name
        else:  # the first path's file name without its extension
            label = Path(next(iter(paths.values()), command)).stem
    record = json.dumps([command, label, spec, sorted(paths.items()), sorted(params.items(),
                        key=str)], default=str)  # fmt: skip
    digest = hashlib.sha256(record.encode()).hexdigest()[:8]
    words = [command, label] + [f"{k}={v}" for k, v in params.items()]
    slug = re.sub(r"[^\w.=-]+", "_", "_".join(map(str, words)))[:80]
    return {"id": f"{slug}-{digest}", "label": label, "command": command, "input": spec,
            "paths": paths, "params": params}


def _check_unique(items: list[dict], path: Path | None) -> None:
    seen: set[str] = set()
    for item in items:
        if item["id"] in seen:
            raise InputError(f"the item {item['label']} ({item['command']}, "
                             f"{item['params']}) is given twice", path)
        seen.add(item["id"])
