"""Configuration dataclasses from mappings and YAML files, checked field by field.

Every algorithm's parameters are a frozen dataclass (``OVBTConfig``, ``PHDConfig``,
``GaussConfig`` ...) that validates itself in ``__post_init__``. :func:`build_config` builds
one from a mapping (a YAML file's, or a suite's parameters), checking each value against the
field's annotation first so that an error names the file and the field
(``cfg.yaml: visual.birth_frames: expected an integer, got '3'``); unknown fields are
refused by name. :func:`load_config` reads a ``--config`` file and applies command-line
overrides on top.
"""

from __future__ import annotations

import dataclasses
import types
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Any, TypeVar

from avtrack.errors import InputError

C = TypeVar("C")


def read_config_mapping(path, what: str, kind: str = "config") -> dict:
    """The mapping in a ``--config`` (or ``--options``) YAML file (``{}`` for an empty file),
    with clear errors.

    Parameters
    ----------
    path : Path
        The file.
    what : str
        What the mapping holds, for the error message (e.g. ``"OVBTConfig fields"``).
    kind : str
        The file's kind in the message for a missing file (``"config"``, ``"options"``).
    """
    import yaml

    if not path.is_file():
        raise InputError(f"{kind} file not found", path)
    try:
        loaded = yaml.safe_load(path.read_bytes())
    except yaml.YAMLError as exc:
        raise InputError(f"invalid YAML: {str(exc).splitlines()[0]}", path) from None
    if loaded is None:
        return {}
    if not isinstance(loaded, dict):
        raise InputError(f"expected a mapping of {what}", path)
    return loaded


# -- config dataclasses -------------------------------------------------------------------
def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _unknown(allowed) -> str:
    return f"unknown field (allowed: {', '.join(sorted(allowed))})"


def _number_problem(value: Any) -> str:
    hint = ""
    if isinstance(value, str):
        try:
            float(value)
            hint = " (YAML reads 1e-3 as text: write 1.0e-3)"
        except ValueError:
            pass
    return f"expected a number, got {_show(value)}{hint}"


def _check_value(annotation: Any, value: Any, base: Any, field: str, path) -> Any:
    """``value`` checked against a field's type annotation; returns what the dataclass gets.

    Lists become tuples for tuple fields; a mapping for a dataclass field overrides the
    fields of ``base`` (the current value of that field). Annotations not handled here are
    passed through unchecked: the dataclass's own validation sees them.
    """
    origin = typing.get_origin(annotation)
    args = typing.get_args(annotation)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        options = [a for a in args if a is not type(None)]
        if len(options) == 1:
            return _check_value(options[0], value, base, field, path)
        return value
    if isinstance(annotation, type) and dataclasses.is_dataclass(annotation):
        if not isinstance(value, dict):
            what = f"a mapping of {annotation.__name__} fields"
            raise InputError(f"{field}: expected {what}, got {_show(value)}", path)
        start = base if isinstance(base, annotation) else annotation
        return build_config(start, value, path, field)
    if annotation is bool:
        if not isinstance(value, bool):
            raise InputError(f"{field}: expected true or false, got {_show(value)}", path)
        return value
    if annotation is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise InputError(f"{field}: expected an integer, got {_show(value)}", path)
        return value
    if annotation is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise InputError(f"{field}: {_number_problem(value)}", path)
        return value
    if annotation is str:
        if not isinstance(value, str):
            raise InputError(f"{field}: expected a string, got {_show(value)}", path)
        return value
    if origin is tuple and args:
        items = list(args[:1]) if len(args) == 2 and args[1] is Ellipsis else list(args)
        if not isinstance(value, list | tuple) or (
            args[-1] is not Ellipsis and len(value) != len(items)
        ):
            size = "a list" if args[-1] is Ellipsis else f"a list of {len(items)} values"
            raise InputError(f"{field}: expected {size}, got {_show(value)}", path)
        kinds = items * len(value) if args[-1] is Ellipsis else items
        return tuple(
            _check_value(kind, v, None, f"{field}[{i}]", path)
            for i, (kind, v) in enumerate(zip(kinds, value, strict=True))
        )
    return value


def _defaults(cls: type) -> Any:
    """``cls()``, or None for a dataclass with required fields."""
    try:
        return cls()
    except TypeError:
        return None


def build_config(base: Any, values: Mapping, path: str | Path | None = None, prefix: str = ""):
    """A config dataclass from ``base`` with the fields in ``values`` replaced, checked one by one.

    Parameters
    ----------
    base : dataclass instance or dataclass type
        What the unlisted fields keep (a type: its defaults).
    values : mapping
        Field name -> value, as read from YAML. A nested dataclass field takes a mapping that
        overrides the fields of ``base``'s value (``visual: {birth_frames: 3}`` keeps the
        other fields of ``base.visual``). Types follow the annotations: ``bool`` true/false,
        ``int`` an integer, ``float`` a number, ``str`` a string, ``X | None`` also null,
        ``tuple[...]`` a list of that length.
    path : str or Path, optional
        The file ``values`` came from, named in errors.
    prefix : str
        Field path of ``base`` inside the file (for nested dataclasses).

    Raises
    ------
    InputError
        ``FILE: a.b: what is wrong`` for an unknown field or a value of the wrong type;
        ``FILE: [a: ]message`` for a value the dataclass's own validation rejects (its message
        names the class and field).
    """
    cls = base if isinstance(base, type) else type(base)
    where = f"{prefix}." if prefix else ""
    if not isinstance(values, Mapping):
        what = f"a mapping of {cls.__name__} fields"
        raise InputError(f"{prefix or 'config'}: expected {what}, got {_show(values)}", path)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    unknown = sorted(str(k) for k in values if k not in fields)
    if unknown:
        raise InputError(f"{where}{unknown[0]}: {_unknown(fields)}", path)
    hints = typing.get_type_hints(cls)
    current = _defaults(cls) if isinstance(base, type) else base
    changes = {
        name: _check_value(
            hints.get(name),
            value,
            None if current is None else getattr(current, name),
            f"{where}{name}",
            path,
        )
        for name, value in values.items()
    }
    try:
        return cls(**changes) if current is None else dataclasses.replace(current, **changes)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{where[:-1]}: {exc}" if prefix else str(exc), path) from None


def _nested(flat: Mapping[str, Any]) -> dict:
    """``{"a.b": 1}`` -> ``{"a": {"b": 1}}``."""
    out: dict = {}
    for key, value in flat.items():
        *parents, name = key.split(".")
        node = out
        for p in parents:
            node = node.setdefault(p, {})
        node[name] = value
    return out


def load_config(
    path: Path | None,
    base: Any,
    what: str | None = None,
    overrides: Mapping[str, Any] | None = None,
):
    """The config dataclass of a ``--config`` file, with command-line overrides on top.

    Parameters
    ----------
    path : Path or None
        The YAML file (None: ``base`` as it is).
    base : dataclass instance or dataclass type
        Defaults (see :func:`build_config`).
    what : str, optional
        What the file holds, for the "expected a mapping of ..." error (default
        ``"<Class> fields"``).
    overrides : mapping, optional
        Values of command-line options by dotted field path (``{"tracker.control":
        "exact"}``); None values (option not given) are skipped. They win over the file.
    """
    cls = base if isinstance(base, type) else type(base)
    config = base() if isinstance(base, type) else base
    if path is not None:
        values = read_config_mapping(path, what or f"{cls.__name__} fields")
        config = build_config(config, values, path)
    given = {k: v for k, v in (overrides or {}).items() if v is not None}
    if given:
        config = build_config(config, _nested(given))
    return config
