"""Workflow settings: every option settable with --config, typed by the schema; typos caught.

Snakemake hands a ``--config KEY=VALUE`` value that is a YAML mapping over as text
(``{max_missing_fraction: '0.05'}``); the schema's types convert it. Ranges and allowed
values are reported as such, and a key the schema does not define is an error naming the
nearest valid key, before any job (a mistyped ``campaing=`` never runs the default campaign).
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml

from dronewind.config import check_config, config_problems, typed_config
from dronewind.errors import InputError
from dronewind.manifest import config_schema, default_config
from tests.small_campaign import write_small_campaign

REPO = Path(__file__).resolve().parents[2]
BIN = Path(sys.executable).parent
BASE = {"campaign": "c.yaml", "results_dir": "results"}


def as_text(value: Any) -> Any:
    """A value as Snakemake's --config parser hands nested values over: every scalar as text."""
    if isinstance(value, dict):
        return {k: as_text(v) for k, v in value.items()}
    if isinstance(value, list):
        return [as_text(v) for v in value]
    return "null" if value is None else str(value)


def leaves(schema: dict, path: tuple[str, ...] = ()) -> Iterator[tuple[tuple[str, ...], dict]]:
    """(key path, schema) of every setting that is not an object of further settings."""
    for key, sub in (schema.get("properties") or {}).items():
        if sub.get("type") == "object" and "properties" in sub:
            yield from leaves(sub, (*path, key))
        else:
            yield (*path, key), sub


def default_value(defaults: dict, path: tuple[str, ...]) -> Any:
    """A setting's default; for the optional ``diagnosis.forward_payload`` keys (none set by
    default) the simulator's own value."""
    from dronewind.simulate.defaults import PAYLOAD_DEFAULTS

    if path[:2] == ("diagnosis", "forward_payload"):
        return PAYLOAD_DEFAULTS[path[2]][0]
    value = defaults
    for key in path:
        value = value[key]
    return value


def nest(path: tuple[str, ...], value: Any) -> dict:
    out: Any = value
    for key in reversed(path):
        out = {key: out}
    return out


# ----------------------------------------------------------------------------- typing by the schema


def test_text_values_take_the_type_the_schema_declares():
    typed = typed_config({**BASE, "processing": {"max_missing_fraction": "0.05", "rotation": "triple",
                                                 "despike": {"n_mad": "5", "window_s": "2.5e1"},
                                                 "spectra": {"segments": "4"}},
                          "diagnosis": {"seeds": ["3", "4"], "published": "null", "alpha": "0.02"}})
    assert typed["processing"]["max_missing_fraction"] == 0.05
    assert typed["processing"]["despike"] == {"n_mad": 5, "window_s": 25.0}
    segments = typed["processing"]["spectra"]["segments"]
    assert segments == 4 and isinstance(segments, int)
    assert typed["diagnosis"]["seeds"] == [3, 4] and typed["diagnosis"]["published"] is None
    assert typed["processing"]["rotation"] == "triple"
    assert config_problems(typed) == []


def test_booleans_objects_and_lists_are_typed_too():
    schema = {"type": "object", "properties": {
        "flag": {"type": "boolean"},
        "opt": {"type": ["string", "null"]},
        "nested": {"type": "object", "properties": {"levels": {"type": "array", "items": {"type": "number"}}}},
        "name": {"type": "string"}}}
    typed = typed_config({"flag": "false", "opt": "~", "nested": {"levels": ["1", "2.5"]}, "name": "007"}, schema)
    assert typed == {"flag": False, "opt": None, "nested": {"levels": [1, 2.5]}, "name": "007"}
    assert typed_config({"flag": "True"}, schema)["flag"] is True
    assert typed_config({"flag": "maybe"}, schema)["flag"] == "maybe"  # kept: reported as a type error


def test_every_setting_round_trips_through_text():
    """Each setting's default, handed over as --config text, is typed back to the default."""
    defaults = default_config()
    for path, _ in leaves(config_schema()):
        if path[0] in BASE:
            continue
        value = default_value(defaults, path)
        typed = check_config({**BASE, **nest(path, as_text(value))})
        got = typed
        for key in path:
            got = got[key]
        assert got == value and type(got) is type(value), (path, got, value)


# ----------------------------------------------------------------------------- ranges, enums, types


@pytest.mark.parametrize(("setting", "message"), [
    ({"processing": {"despike": {"n_mad": "-3"}}}, "processing.despike.n_mad = -3 is out of range: must be > 0"),
    ({"processing": {"max_missing_fraction": "1.5"}},
     "processing.max_missing_fraction = 1.5 is out of range: must be <= 1"),
    ({"processing": {"rotation": "dubble"}},
     "processing.rotation = 'dubble' is not allowed: must be one of single, double, triple, planar_fit"),
    ({"processing": {"spectra": {"segments": "three"}}}, "processing.spectra.segments = 'three' is not an integer"),
    ({"diagnosis": {"seeds": [3]}}, "diagnosis.seeds = [3] has 1 item(s): must have at least 2"),
    ({"diagnosis": {"platform": {"segment_s": "5"}}},
     "diagnosis.platform.segment_s = 5 is out of range: must be >= 10"),
])
def test_bad_values_are_reported_with_key_path_and_bounds(setting, message):
    with pytest.raises(InputError) as err:
        check_config({**BASE, **setting})
    assert message in str(err.value)


# ----------------------------------------------------------------------------- unknown keys


@pytest.mark.parametrize(("setting", "message"), [
    ({"processing": {"rotatoin": "double"}}, "processing.rotatoin is not a setting: did you mean 'rotation'?"),
    ({"campaing": "x.yaml"}, "campaing is not a setting: did you mean 'campaign'?"),
    ({"processing": {"despike": {"nmad": 5}}}, "processing.despike.nmad is not a setting: did you mean 'n_mad'?"),
    ({"quadrotor": {"hover": {"max_sped_ms": 2}}},
     "quadrotor.hover.max_sped_ms is not a setting: did you mean 'max_speed_ms'?"),
    ({"diagnosis": {"zzz": 1}}, "diagnosis.zzz is not a setting (the settings of diagnosis are: alpha,"),
    ({"processing": {"quadrotor": {}}}, "processing.quadrotor is now quadrotor"),
    ({"diagnosis": {"quadrotor_min_gain": 0.1}}, "diagnosis.quadrotor_min_gain is now quadrotor.diagnosis.min_gain"),
])
def test_unknown_keys_are_rejected_naming_the_nearest_valid_one(setting, message):
    with pytest.raises(InputError) as err:
        check_config({**BASE, **setting})
    assert message in str(err.value)


def test_every_object_of_the_schema_is_closed():
    def objects(schema: dict, path: str = "(top)") -> Iterator[tuple[str, dict]]:
        if schema.get("type") == "object":
            yield path, schema
        for key, sub in (schema.get("properties") or {}).items():
            yield from objects(sub, key if path == "(top)" else f"{path}.{key}")

    for path, schema in objects(config_schema()):
        assert schema.get("additionalProperties") is False, f"{path} accepts unknown keys"


def test_the_shipped_config_is_valid():
    config = yaml.safe_load((REPO / "config" / "config.yaml").read_text())
    assert config_problems(typed_config(config)) == []


# ----------------------------------------------------------------------------- through Snakemake


@pytest.fixture(scope="module")
def small(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("config")
    return write_small_campaign(folder)


def dry_run(manifest: Path | None, *pairs: str) -> subprocess.CompletedProcess:
    campaign = [f"campaign={manifest}"] if manifest else []
    return subprocess.run(
        [str(BIN / "snakemake"), "-n", "--config", *campaign, f"results_dir={manifest.parent / 'results'}"
         if manifest else "results_dir=results", *pairs],
        cwd=REPO, capture_output=True, text=True, timeout=300, check=False,
        env={**os.environ, "PATH": f"{BIN}:{os.environ.get('PATH', '')}"},
    )


def test_every_setting_is_accepted_with_config_as_the_readme_says(small):
    """All settings at once, each as a --config pair of its own (Snakemake hands them as text)."""
    defaults = default_config()
    pairs = []
    for path, _ in leaves(config_schema()):
        if path[0] in BASE:
            continue
        value = default_value(defaults, path)
        inner = yaml.safe_dump(nest(path[1:], value), default_flow_style=True).strip()
        pairs.append(f"{path[0]}={inner}")
    pairs.append("processing={max_missing_fraction: 0.05, despike: {n_mad: 5}}")
    proc = dry_run(small, *pairs)
    assert proc.returncode == 0, (proc.stdout + proc.stderr)[-3000:]
    assert "Job stats" in proc.stdout


@pytest.mark.parametrize(("pair", "message"), [
    ("processing={despike: {n_mad: -3}}", "processing.despike.n_mad = -3 is out of range: must be > 0"),
    ("processing={rotatoin: double}", "processing.rotatoin is not a setting: did you mean 'rotation'?"),
    ("processing={max_missing_fraction: lots}", "processing.max_missing_fraction = 'lots' is not a number"),
])
def test_bad_config_stops_before_any_job(small, pair, message):
    proc = dry_run(small, pair)
    out = proc.stdout + proc.stderr
    assert proc.returncode != 0 and message in out, out[-3000:]
    assert "Job stats" not in out


def test_mistyped_campaign_key_never_falls_back_to_the_default_campaign(small):
    proc = dry_run(None, f"campaing={small}")
    out = proc.stdout + proc.stderr
    assert proc.returncode != 0, out[-2000:]
    assert "campaing is not a setting: did you mean 'campaign'?" in out
    assert "Job stats" not in out and "mosai2023" not in out


def test_no_shell_command_noise():
    """Every rule runs a script: the default profile does not print (absent) shell commands."""
    rules = "\n".join(p.read_text() for p in (REPO / "workflow" / "rules").glob("*.smk"))
    assert "shell:" not in rules
    profile = yaml.safe_load((REPO / "profiles" / "default" / "profile.yaml").read_text())
    assert not profile.get("printshellcmds")


def test_the_forward_payload_schema_is_the_simulators_payload_table():
    """diagnosis.forward_payload takes exactly the payload settings of the simulator, with their ranges."""
    from dronewind.simulate.defaults import PAYLOAD_DEFAULTS
    from dronewind.simulate.settings import PAYLOAD_EXCLUSIVE

    props = config_schema()["properties"]["diagnosis"]["properties"]["forward_payload"]["properties"]
    assert list(props) == list(PAYLOAD_DEFAULTS)
    for key, (_, lo, hi, _) in PAYLOAD_DEFAULTS.items():
        low = props[key].get("exclusiveMinimum") if key in PAYLOAD_EXCLUSIVE else props[key].get("minimum")
        assert (low, props[key]["maximum"]) == (lo, hi), key
