"""Workflow settings: typed by the config schema, checked before any job runs.

Settings reach the workflow from ``config/config.yaml``, further ``--configfile`` files and
``--config KEY=VALUE`` pairs. Snakemake hands the value of a ``--config`` pair that is a YAML
mapping or list over as text (``--config "processing={max_missing_fraction: 0.05}"`` gives
``{"max_missing_fraction": "0.05"}``), so :func:`typed_config` first converts every text
value to the type the schema declares for its key (number, integer, boolean, null, array,
object), then :func:`check_config` validates the result and reports, one line per problem:

* a value out of range or not among the allowed ones, with the key path and the bounds
  (``processing.despike.n_mad = -3 is out of range: must be > 0``);
* a key the schema does not define, with the nearest valid name
  (``processing.rotatoin is not a setting: did you mean 'rotation'?``), so a typo never
  falls back silently to a default (a mistyped ``campaing=`` never runs the default campaign);
* a value of the wrong type, with the type expected.

The schema (``dronewind/schemas/config.schema.yaml``, symlinked from ``workflow/schemas/``)
is the one place where the settings, their types, bounds and defaults are kept.
"""

from __future__ import annotations

import copy
import difflib
from collections.abc import Mapping, Sequence
from typing import Any

import jsonschema

from dronewind.errors import InputError
from dronewind.manifest import config_schema, with_defaults

__all__ = ["typed_config", "check_config", "config_problems", "MOVED_SETTINGS"]

#: Settings that moved, as key path -> where they are now (reported instead of "not a setting").
MOVED_SETTINGS: dict[str, str] = {
    "processing.quadrotor": "quadrotor",
    "diagnosis.quadrotor_min_gain": "quadrotor.diagnosis.min_gain",
}

_TRUE = {"true", "yes", "on"}
_FALSE = {"false", "no", "off"}
_NULL = {"null", "~", "none"}
_RANGE_WORDS = {
    "minimum": ">=",
    "exclusiveMinimum": ">",
    "maximum": "<=",
    "exclusiveMaximum": "<",
}
_TYPE_WORDS = {
    "number": "a number",
    "integer": "an integer",
    "boolean": "true or false",
    "string": "a text",
    "null": "null",
    "array": "a list",
    "object": "a mapping",
}


def _types(schema: Mapping[str, Any]) -> list[str]:
    """The JSON types a schema allows (empty: any, e.g. an ``enum`` without ``type``)."""
    declared = schema.get("type")
    if declared is None:
        return []
    return [declared] if isinstance(declared, str) else list(declared)


def _from_text(text: str, types: Sequence[str]) -> Any:
    """A text value converted to the first declared type it reads as (the text if none).

    Parameters
    ----------
    text : str
        The value as Snakemake passes it (``"0.05"``, ``"true"``, ``"null"``).
    types : sequence of str
        JSON types allowed by the schema, in the order declared.
    """
    if "string" in types and "null" not in types:
        return text
    word = text.strip()
    for kind in types:
        if kind == "integer":
            try:
                return int(word)
            except ValueError:
                continue
        if kind == "number":
            for convert in (int, float):
                try:
                    return convert(word)
                except ValueError:
                    continue
        if kind == "boolean" and word.lower() in _TRUE | _FALSE:
            return word.lower() in _TRUE
        if kind == "null" and word.lower() in _NULL:
            return None
    return text


def _typed(value: Any, schema: Mapping[str, Any]) -> Any:
    """``value`` with every text leaf converted to the type ``schema`` declares for it."""
    types = _types(schema)
    if isinstance(value, str):
        return _from_text(value, types) if types else value
    if isinstance(value, dict):
        props = schema.get("properties") or {}
        return {key: _typed(item, props[key]) if key in props else item for key, item in value.items()}
    if isinstance(value, list) and isinstance(schema.get("items"), Mapping):
        return [_typed(item, schema["items"]) for item in value]
    return value


def typed_config(config: Mapping[str, Any], schema: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The configuration with text values converted to the types of the config schema.

    Parameters
    ----------
    config : mapping
        The merged configuration (config files and ``--config`` pairs).
    schema : mapping, optional
        Config schema; default: :func:`dronewind.manifest.config_schema`.

    Returns
    -------
    dict
        A copy; a text that does not read as the declared type is kept (and reported by
        :func:`check_config`).
    """
    return _typed(copy.deepcopy(dict(config)), config_schema() if schema is None else schema)


def _key(path: Sequence[Any]) -> str:
    """Dotted key path of a jsonschema error path (``diagnosis.seeds[0]``)."""
    out = ""
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "(top level)"


def _unknown_keys(error: jsonschema.ValidationError) -> list[str]:
    """The keys that an ``additionalProperties: false`` object does not define.

    A key close to a valid one gets its own line naming it (``did you mean 'rotation'?``);
    the others are listed together with the valid keys of that level.
    """
    known = sorted(error.schema.get("properties") or {})
    parent = _key(error.absolute_path)
    lines, unmatched = [], []
    for key in sorted(set(error.instance) - set(known)):
        where = f"{parent}.{key}" if error.absolute_path else str(key)
        close = difflib.get_close_matches(str(key), known, n=1, cutoff=0.6)
        if where in MOVED_SETTINGS:
            lines.append(f"{where} is now {MOVED_SETTINGS[where]}")
        elif close:
            lines.append(f"{where} is not a setting: did you mean {close[0]!r}?")
        else:
            unmatched.append(where)
    if unmatched:
        verb = "is not a setting" if len(unmatched) == 1 else "are not settings"
        level = f" of {parent}" if error.absolute_path else ""
        line = f"{', '.join(unmatched)} {verb} (the settings{level} are: {', '.join(known)})"
        if not error.absolute_path and {"payload_flights", "masts", "site"} & set(error.instance):
            line += "; a campaign manifest is given as --config campaign=<manifest>"
        lines.append(line)
    return lines


def _describe(error: jsonschema.ValidationError) -> list[str]:
    """The problem of one validation error, in the user's terms (key path, value, expected)."""
    where = _key(error.absolute_path)
    value = error.instance
    kind = error.validator
    if kind == "additionalProperties":
        return _unknown_keys(error)
    if kind in _RANGE_WORDS:
        return [f"{where} = {value!r} is out of range: must be {_RANGE_WORDS[str(kind)]} {error.validator_value}"]
    if kind == "enum":
        allowed = ", ".join(map(str, error.validator_value))
        return [f"{where} = {value!r} is not allowed: must be one of {allowed}"]
    if kind == "type":
        expected = " or ".join(_TYPE_WORDS.get(t, t) for t in _types(error.schema))
        return [f"{where} = {value!r} is not {expected}"]
    if kind == "required":
        return [f"{where}: {error.message}"]
    if kind in ("minItems", "maxItems"):
        bound = "at least" if kind == "minItems" else "at most"
        return [f"{where} = {value!r} has {len(value)} item(s): must have {bound} {error.validator_value}"]
    return [f"{where} = {value!r}: {error.message}"]


def config_problems(config: Mapping[str, Any], schema: Mapping[str, Any] | None = None) -> list[str]:
    """Every problem of a (typed) configuration against the config schema, one line each.

    Parameters
    ----------
    config : mapping
        The configuration, after :func:`typed_config`.
    schema : mapping, optional
        Config schema; default: :func:`dronewind.manifest.config_schema`.

    Returns
    -------
    list of str
        Empty when the configuration is valid.
    """
    validator = jsonschema.Draft202012Validator(config_schema() if schema is None else schema)
    errors = sorted(validator.iter_errors(dict(config)), key=lambda e: _key(e.absolute_path))
    return [line for error in errors for line in _describe(error)]


def check_config(config: Mapping[str, Any], *, defaults: bool = True) -> dict[str, Any]:
    """The configuration typed by the schema, validated, with the defaults filled in.

    Parameters
    ----------
    config : mapping
        The merged configuration (config files and ``--config`` pairs).
    defaults : bool
        Fill every missing setting from the schema's ``default:``.

    Returns
    -------
    dict
        The typed (and completed) configuration.

    Raises
    ------
    InputError
        Naming every bad setting: its key path, its value and what was expected.
    """
    schema = config_schema()
    typed = typed_config(config, schema)
    problems = config_problems(typed, schema)
    if problems:
        raise InputError("config (config files and --config)", "; ".join(problems))
    return with_defaults(typed) if defaults else typed
