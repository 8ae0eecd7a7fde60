"""Campaign manifests and workflow settings: loading, validation and defaults before any job runs.

A manifest (YAML, format in ``docs/data-contract.md`` "Campaign manifest") is validated in three
passes and every problem is reported with the manifest file, the key path and what was
expected:

1. structure, against the JSON schema ``dronewind/schemas/campaign.schema.json``
   (missing keys, wrong types, bad identifiers and times, and keys the schema does not
   define: a typo such as ``mounting:`` for ``mount:`` is reported with its key path and the
   nearest valid name, as :mod:`dronewind.config` reports the settings, instead of being
   ignored while the default applies). Keys of one's own are kept under an ``x-`` prefix
   (``x-operator: ...``) or in an ``extra:`` mapping, at any level;
2. paths: a virtual campaign's data paths are where the simulator writes
   (``results/<name>/L0/<path>``), so they must be relative and stay below that folder
   (absolute paths and ``..`` above it are rejected); a measured campaign's files are only
   read and may lie anywhere (absolute, or relative to the manifest). The campaign name
   cannot start with ``.`` (``..`` would put the results in the parent of ``results_dir``);
3. meaning: duplicate flight, mast or sensor ids; a payload flight whose ``reference`` is
   not a mast sonic id; a window whose end is not after its start; a rigid-mount flight
   whose platform variables come from neither its record's columns nor its ``platform_log``
   (or a ``platform_log`` that would give none); and, for measured
   campaigns (no ``simulation:`` section), files that do not exist and globs that match
   nothing.

A manifest with a ``simulation:`` section describes a virtual campaign: its L0 files are
written by the simulator (under ``results/<name>/L0/``), so they need not exist yet.

The workflow configuration's defaults live once, as ``default:`` values of its schema
(``workflow/schemas/config.schema.yaml``, shipped as ``dronewind/schemas/config.schema.yaml``).
Snakemake fills them in when it validates the config; :func:`default_config` and
:func:`with_defaults` give library callers outside Snakemake (the diagnosis experiments,
tests, the command line) the same values.
"""

from __future__ import annotations

import copy
import datetime as _dt
import difflib
import functools
import glob
import json
import ntpath
import posixpath
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from dronewind.errors import InputError, ManifestError

__all__ = ["Campaign", "load_campaign", "campaign_schema", "parse_utc", "config_schema", "default_config",
           "with_defaults", "payload_flight_manifest", "data_paths", "path_problem", "confined_path",
           "record_format", "DEFAULT_FORMATS", "is_rigid"]


def campaign_schema() -> dict[str, Any]:
    """The JSON schema of campaign manifests (draft 2020-12)."""
    text = resources.files("dronewind").joinpath("schemas/campaign.schema.json").read_text("utf-8")
    return json.loads(text)


def config_schema() -> dict[str, Any]:
    """The JSON schema of the workflow configuration, with the default of every setting.

    Returns
    -------
    dict
        ``workflow/schemas/config.schema.yaml`` (draft 2020-12), parsed.
    """
    return copy.deepcopy(_parsed_config_schema())


@functools.lru_cache(maxsize=1)
def _parsed_config_schema() -> dict[str, Any]:
    """The configuration schema parsed once per process (a YAML parse costs 7 ms; the planner fills
    the defaults of every drawn campaign's configuration). Read only: callers get copies."""
    from dronewind.core.yamltext import load_yaml  # here, not at the top: a job that only resolves paths

    text = resources.files("dronewind").joinpath("schemas/config.schema.yaml").read_text("utf-8")
    return load_yaml(text)


def _fill_defaults(instance: dict[str, Any], schema: Mapping[str, Any]) -> None:
    """Set every missing property that has a ``default`` and recurse into objects (in place).

    The same rule as Snakemake's ``validate(config, schema)``: a property absent from the
    instance takes a copy of its schema default; an object property is then filled in turn.
    """
    for key, sub in (schema.get("properties") or {}).items():
        if "default" in sub and key not in instance:
            instance[key] = copy.deepcopy(sub["default"])
        if isinstance(instance.get(key), dict):
            _fill_defaults(instance[key], sub)


def with_defaults(config: Mapping[str, Any]) -> dict[str, Any]:
    """A configuration with the schema's defaults filled in (the input is not changed).

    Parameters
    ----------
    config : mapping
        Workflow configuration, possibly partial (e.g. ``{"processing": {"rotation": "planar_fit"}}``).

    Returns
    -------
    dict
        A deep copy with every missing setting at its default.
    """
    out = copy.deepcopy(dict(config))
    _fill_defaults(out, _parsed_config_schema())  # read only: the defaults are copied in
    return out


def default_config() -> dict[str, Any]:
    """The default settings of the workflow, from the config schema.

    Returns
    -------
    dict
        Every section with defaults (``processing``, ``diagnosis``, ...), each key at its
        default (``campaign`` and ``results_dir`` have none: they name the run).
    """
    return with_defaults({})


def parse_utc(value: str, where: str = "time") -> np.datetime64:
    """Parse an ISO 8601 UTC time (trailing ``Z`` optional) to ``datetime64[us]``.

    Parameters
    ----------
    value : str
        Time such as ``2023-08-21T14:05:32Z`` or ``2023-08-21T14:05:32.25Z``.
    where : str
        Name used in the error message.

    Returns
    -------
    numpy.datetime64
        Naive time meaning UTC, microsecond resolution.
    """
    text = str(value).strip()
    if text.endswith("Z"):
        text = text[:-1]
    for suffix in ("+00:00", "+0000", "-00:00"):
        if text.endswith(suffix):
            text = text[: -len(suffix)]
    try:
        return np.datetime64(text.replace(" ", "T"), "us")
    except ValueError as exc:
        raise ValueError(f"{where}: {value!r} is not an ISO 8601 UTC time") from exc


def _normalise(node: Any) -> Any:
    """YAML turns ISO times into datetime objects: turn them back into ISO strings."""
    if isinstance(node, dict):
        return {str(k): _normalise(v) for k, v in node.items()}
    if isinstance(node, list):
        return [_normalise(v) for v in node]
    if isinstance(node, _dt.datetime):
        if node.tzinfo is not None:
            node = node.astimezone(_dt.UTC).replace(tzinfo=None)
        return node.isoformat() + "Z"
    if isinstance(node, _dt.date):
        return node.isoformat()
    return node


def _key_path(parts: Any) -> str:
    out = ""
    for part in parts:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "(top level)"


def _unknown_keys(error: Any) -> list[tuple[str, str]]:
    """The keys an ``additionalProperties: false`` object of the manifest does not define.

    Each unknown key is reported at its own key path; one close to a valid name (difflib
    ratio 0.6, as :func:`dronewind.config._unknown_keys`) with that name, the others with
    the valid keys of their level.
    """
    import re

    known = sorted(error.schema.get("properties") or {})
    patterns = list(error.schema.get("patternProperties") or {})
    parent = _key_path(error.absolute_path)
    out = []
    for key in sorted(map(str, error.instance)):
        if key in known or any(re.search(p, key) for p in patterns):
            continue
        where = f"{parent}.{key}" if error.absolute_path else key
        close = difflib.get_close_matches(key, known, n=1, cutoff=0.6)
        hint = f"did you mean {close[0]!r}?" if close else f"the keys here are: {', '.join(known)}"
        own = f" (a key of one's own: x-{key} or under extra:)" if patterns else ""
        out.append((where, f"{key!r} is not a manifest key: {hint}{own}"))
    return out


@dataclass
class Campaign:
    """A validated campaign manifest.

    Attributes
    ----------
    path : Path
        The manifest file (absolute).
    data : dict
        The manifest content (times as ISO strings; absent sections as empty lists).
    """

    path: Path
    data: dict[str, Any] = field(repr=False)

    @property
    def name(self) -> str:
        """Campaign name (results go to ``results/<name>/``)."""
        return str(self.data["name"])

    @property
    def directory(self) -> Path:
        """Folder that manifest-relative paths refer to."""
        return self.path.parent

    @property
    def data_root(self) -> Path:
        """Folder the data paths of a measured campaign refer to: ``data_root`` (absolute or
        relative to the manifest; ``registry``: the data folder of :mod:`dronewind.datasets`,
        ``$DRONEWIND_DATA``), else the manifest's folder."""
        return _data_root(self.path, self.data)

    @property
    def simulated(self) -> bool:
        """True when the manifest has a ``simulation:`` section (a virtual campaign)."""
        return bool(self.data.get("simulation"))

    @property
    def payload_flights(self) -> list[dict[str, Any]]:
        """Payload (SAMURAI-S) flights."""
        return list(self.data.get("payload_flights") or [])

    @property
    def quadrotor_flights(self) -> list[dict[str, Any]]:
        """Quadrotor (SWUF-3D) flights."""
        return list(self.data.get("quadrotor_flights") or [])

    @property
    def autopilot_flights(self) -> list[dict[str, Any]]:
        """Autopilot logs compared with the autopilot's own EKF wind."""
        return list(self.data.get("autopilot_flights") or [])

    def autopilot_flight(self, flight_id: str) -> dict[str, Any]:
        """The autopilot flight with this id."""
        for flight in self.autopilot_flights:
            if flight["id"] == flight_id:
                return flight
        raise KeyError(f"{self.path}: no autopilot flight {flight_id!r}")

    def mast_sonics(self) -> dict[str, dict[str, Any]]:
        """Mast sonics by id, each with its mast's id and position merged in."""
        out: dict[str, dict[str, Any]] = {}
        for mast in self.data.get("masts") or []:
            for sonic in mast["sonics"]:
                entry = dict(sonic)
                entry["mast_id"] = mast["id"]
                entry["latitude"] = mast.get("latitude", self.data["site"]["latitude"])
                entry["longitude"] = mast.get("longitude", self.data["site"]["longitude"])
                out[str(sonic["id"])] = entry
        return out

    def payload_flight(self, flight_id: str) -> dict[str, Any]:
        """The payload flight with this id."""
        for flight in self.payload_flights:
            if flight["id"] == flight_id:
                return flight
        raise KeyError(f"{self.path}: no payload flight {flight_id!r}")

    def quadrotor_flight(self, flight_id: str) -> dict[str, Any]:
        """The quadrotor flight with this id."""
        for flight in self.quadrotor_flights:
            if flight["id"] == flight_id:
                return flight
        raise KeyError(f"{self.path}: no quadrotor flight {flight_id!r}")

    def mast_files(self, sonic_id: str, root: Path | None = None) -> list[Path]:
        """Files of a mast sonic, in time order (globs expanded, sorted by name).

        For a simulated campaign, each ``*`` of a glob stands for a payload-flight id whose
        reference is this sonic (the simulator writes one file per flight and sonic).
        """
        root = Path(root) if root is not None else self.data_root
        sonic = self.mast_sonics()[sonic_id]
        files: list[Path] = []
        for pattern in sonic["files"]:
            if self.simulated:
                if "*" in pattern:
                    files += [root / pattern.replace("*", f["id"]) for f in self.payload_flights]
                else:
                    files.append(root / pattern)
            else:
                matches = sorted(glob.glob(str(root / pattern)))
                files += [Path(m) for m in matches]
        return list(dict.fromkeys(files))


#: ``data_root`` value naming the data folder of the record registry (:func:`dronewind.datasets.data_dir`).
REGISTRY_DATA_ROOT = "registry"


def _data_root(path: Path, data: Mapping[str, Any]) -> Path:
    """The folder data paths are relative to (see :attr:`Campaign.data_root`)."""
    root = data.get("data_root")
    if root == REGISTRY_DATA_ROOT:
        from dronewind.datasets import data_dir

        return data_dir()
    return path.parent if not root else (path.parent / str(root)).resolve()


def is_rigid(flight: Mapping[str, Any]) -> bool:
    """Whether a payload flight is a rigid-mount multicopter (``platform: rigid_mount``)."""
    return flight.get("platform", "sling_load") == "rigid_mount"


def payload_flight_manifest(data: Mapping[str, Any], flight_id: str, *, atmosphere: bool = False
                            ) -> dict[str, Any]:
    """The manifest reduced to one payload flight and its reference sonic.

    What a per-flight job of the diagnosis reads of a campaign: every top-level key except
    the other payload flights, the other mast sonics (a mast without the reference sonic is
    dropped) and the ``simulation``, ``quadrotor_flights`` and ``tunnel`` sections. Keys keep
    their order; values are copies.

    Parameters
    ----------
    data : mapping
        Manifest content (:attr:`Campaign.data`).
    flight_id : str
        Payload flight id.
    atmosphere : bool
        Keep the simulated atmosphere: ``simulation.atmosphere`` and the flight's
        ``simulation.payload_flights`` conditions (empty for a measured campaign), which the
        published-numbers diagnosis reads for what the paper does not print.

    Returns
    -------
    dict
        The one-flight manifest.
    """
    flight = next(f for f in data["payload_flights"] if f["id"] == flight_id)
    masts = []
    for mast in data.get("masts") or []:
        sonics = [copy.deepcopy(s) for s in mast["sonics"] if s["id"] == flight["reference"]]
        if sonics:
            masts.append({**copy.deepcopy(mast), "sonics": sonics})
    out: dict[str, Any] = {}
    for key, value in data.items():
        if key in ("simulation", "quadrotor_flights", "tunnel", "autopilot_flights"):
            continue
        out[key] = [copy.deepcopy(flight)] if key == "payload_flights" else masts if key == "masts" \
            else copy.deepcopy(value)
    if atmosphere:
        sim = data.get("simulation") or {}
        out["simulation"] = copy.deepcopy({"atmosphere": sim.get("atmosphere") or {}, "payload_flights": {
            flight_id: (sim.get("payload_flights") or {}).get(flight_id) or {}}})
    return out


def data_paths(data: Mapping[str, Any]) -> list[tuple[str, str]]:
    """Every data path a manifest names, with its key path.

    Parameters
    ----------
    data : mapping
        Manifest content (after the structural validation).

    Returns
    -------
    list of (str, str)
        ``(key path, path as written)``: mast sonic files (globs), payload sonic and INS
        files, quadrotor references and UAV logs, the tunnel run index.
    """
    out: list[tuple[str, str]] = []
    for i, mast in enumerate(data.get("masts") or []):
        for j, sonic in enumerate(mast.get("sonics") or []):
            out += [(f"masts[{i}].sonics[{j}].files[{k}]", str(p)) for k, p in enumerate(sonic.get("files") or [])]
    for i, flight in enumerate(data.get("payload_flights") or []):
        if is_rigid(flight):
            out.append((f"payload_flights[{i}].record.file", str(flight["record"]["file"])))
            if flight.get("platform_log"):
                out.append((f"payload_flights[{i}].platform_log.file", str(flight["platform_log"]["file"])))
            continue
        out += [(f"payload_flights[{i}].{part}.file", str(flight[part]["file"])) for part in ("sonic", "ins")]
    for i, flight in enumerate(data.get("quadrotor_flights") or []):
        if isinstance(flight["reference"], str):  # else the UAV records' own columns
            out.append((f"quadrotor_flights[{i}].reference", str(flight["reference"])))
        out += [(f"quadrotor_flights[{i}].uavs[{j}].file", str(u["file"])) for j, u in enumerate(flight["uavs"])]
    out += [(f"autopilot_flights[{i}].file", str(f["file"])) for i, f in enumerate(data.get("autopilot_flights") or [])]
    if (data.get("tunnel") or {}).get("runs"):
        out.append(("tunnel.runs", str(data["tunnel"]["runs"])))
    return out


#: The format of a record that declares none: the contract format of its kind (``docs/data-contract.md``).
DEFAULT_FORMATS: dict[str, str] = {"mast_sonic": "toa5", "payload_sonic": "contract_csv",
                                   "payload_ins": "contract_csv", "quadrotor_uav": "contract_csv",
                                   "autopilot_log": "ardupilot_bin", "platform_log": "ardupilot_bin"}


def record_format(record: Mapping[str, Any], kind: str, file: str | None = None) -> dict[str, Any]:
    """The declared ``format`` of a manifest record as a mapping with ``name``.

    Parameters
    ----------
    record : mapping
        A mast sonic, a payload flight's ``sonic`` or ``ins`` entry, or a quadrotor UAV.
    kind : str
        ``mast_sonic``, ``payload_sonic``, ``payload_ins`` or ``quadrotor_uav``.
    file : str, optional
        The record's file (a quadrotor UAV without ``format`` is a PX4 ULog when it ends in
        ``.ulg``, as the reader decides).

    Returns
    -------
    dict
        ``{"name": ...}`` and the format's settings (a copy): absent ``format`` is the
        contract format of the kind (:data:`DEFAULT_FORMATS`); a bare name becomes
        ``{"name": name}``.
    """
    declared = record.get("format")
    if declared is None:
        name = DEFAULT_FORMATS[kind]
        suffix = str(file or record.get("file", "")).lower()
        if kind == "quadrotor_uav" and suffix.endswith(".ulg"):
            name = "ulog"
        elif kind == "quadrotor_uav" and suffix.endswith(".bin"):
            name = "ardupilot_bin"
        return {"name": name}
    if isinstance(declared, str):
        return {"name": declared}
    return copy.deepcopy(dict(declared))


def path_problem(rel: str, *, confined: bool) -> str | None:
    """What is wrong with a data path of a manifest, or ``None``.

    Parameters
    ----------
    rel : str
        The path as written in the manifest.
    confined : bool
        The path is written to (a virtual campaign's L0 file under ``results/<name>/L0/``):
        it must be relative and stay below that folder. Measured data are only read and
        may lie anywhere (absolute, or ``..`` above the manifest).

    Returns
    -------
    str or None
        The problem and what was expected.
    """
    if any(ord(c) < 32 for c in rel):
        return f"path {rel!r} holds a control character; expected a plain file path"
    if not confined:
        return None
    if posixpath.isabs(rel) or ntpath.isabs(rel) or rel.startswith("~"):
        return (f"absolute path {rel!r} in a virtual campaign: the simulator writes its raw files under "
                "results/<name>/L0/, so give a path relative to the manifest (e.g. flights/s01/sonic.csv)")
    norm = posixpath.normpath(rel.replace("\\", "/"))
    if norm == ".." or norm.startswith("../"):
        return (f"path {rel!r} leaves results/<name>/L0/ ('..' above its top): a virtual campaign's raw "
                "files are written there, so give a path inside it (e.g. flights/s01/sonic.csv)")
    if norm in (".", ""):
        return f"path {rel!r} names the L0 folder itself; expected a file below it"
    return None


def _path_checks(data: dict[str, Any]) -> list[tuple[str, str]]:
    """Paths that a virtual campaign would write outside ``results/<name>/L0/``, control characters."""
    confined = bool(data.get("simulation"))
    problems = []
    for key, rel in data_paths(data):
        what = path_problem(rel, confined=confined)
        if what:
            problems.append((key, what))
    return problems


def _rigid_platform_checks(key: str, flight: Mapping[str, Any], root: Path, check_files: bool
                            ) -> list[tuple[str, str]]:
    """Where a rigid-mount flight's platform state comes from: the record's columns, its ``platform_log``, or both.

    Each platform variable comes from the record's mapping when it declares it (the record's
    columns win), else from the platform log (:func:`dronewind.core.columns.rigid_layout`);
    the log file must exist.
    """
    from dronewind.core.columns import rigid_layout

    problems: list[tuple[str, str]] = []
    log = flight.get("platform_log")
    try:
        rigid_layout(flight["record"]["format"], f"{key}.record.format", platform_log=bool(log))
    except InputError as exc:
        problems.append((exc.where, exc.what))
    if log and check_files and not (root / log["file"]).is_file():
        problems.append((f"{key}.platform_log.file", f"platform log {log['file']!r} does not exist under {root}; "
                         "expected the vehicle's own log (format ardupilot_bin)"))
    return problems


def _semantic_checks(path: Path, data: dict[str, Any], check_files: bool) -> list[tuple[str, str]]:
    problems: list[tuple[str, str]] = _path_checks(data)
    if data.get("data_root") and data.get("simulation"):
        problems.append(("data_root", "data_root in a virtual campaign: its raw files are written under "
                         "results/<name>/L0/; remove data_root (it is for measured records read where they lie)"))
    if problems:
        return problems
    root = _data_root(path, data)
    if check_files and not root.is_dir():
        if data.get("data_root") == REGISTRY_DATA_ROOT:
            return [("data_root", f"data folder of the record registry {root} does not exist; set DRONEWIND_DATA "
                     "to the folder holding the records, or fetch them (python -m dronewind.datasets fetch)")]
        return [("data_root", f"folder {data.get('data_root')!r} ({root}) does not exist; expected the folder the "
                 "data paths are relative to")]
    sonic_ids: dict[str, str] = {}
    for i, mast in enumerate(data.get("masts") or []):
        for j, sonic in enumerate(mast["sonics"]):
            key = f"masts[{i}].sonics[{j}]"
            if sonic["id"] in sonic_ids:
                problems.append((f"{key}.id", f"duplicate sensor id {sonic['id']!r} (also {sonic_ids[sonic['id']]})"))
            sonic_ids.setdefault(sonic["id"], key)
            if check_files:
                for k, pattern in enumerate(sonic["files"]):
                    if not glob.glob(str(root / pattern)):
                        kind = "glob" if any(c in pattern for c in "*?[") else "file"
                        problems.append((f"{key}.files[{k}]", f"{kind} {pattern!r} matches no file under {root}"))
    mast_ids = [m["id"] for m in data.get("masts") or []]
    for dup in sorted({m for m in mast_ids if mast_ids.count(m) > 1}):
        problems.append(("masts", f"duplicate mast id {dup!r}"))

    seen_flights: dict[str, str] = {}
    for section in ("payload_flights", "quadrotor_flights"):
        for i, flight in enumerate(data.get(section) or []):
            key = f"{section}[{i}]"
            fid = flight["id"]
            if fid in seen_flights:
                problems.append((f"{key}.id", f"duplicate flight id {fid!r} (also {seen_flights[fid]})"))
            seen_flights.setdefault(fid, key)
            if section == "payload_flights" and is_rigid(flight):
                ref = flight.get("reference")
                if ref is not None and ref not in sonic_ids:
                    known = ", ".join(sorted(sonic_ids)) or "none defined"
                    problems.append((f"{key}.reference", f"unknown mast sonic id {ref!r}; expected one of: {known} "
                                     "(or no reference: drone-only statistics)"))
                if check_files and not (root / flight["record"]["file"]).is_file():
                    problems.append((f"{key}.record.file",
                                     f"file {flight['record']['file']!r} does not exist under {root}"))
                problems += _rigid_platform_checks(key, flight, root, check_files)
            elif section == "payload_flights":
                if flight.get("platform_log"):
                    problems.append((f"{key}.platform_log", "a platform_log is for a rigid-mount flight (platform: "
                                     "rigid_mount); a sling-load flight's platform state is its INS file (ins:)"))
                if flight["reference"] not in sonic_ids:
                    known = ", ".join(sorted(sonic_ids)) or "none defined"
                    problems.append((f"{key}.reference",
                                     f"unknown mast sonic id {flight['reference']!r}; expected one of: {known}"))
                window = flight.get("window")
                if window:
                    start = parse_utc(window["start"], f"{key}.window.start")
                    end = parse_utc(window["end"], f"{key}.window.end")
                    if end <= start:
                        problems.append((f"{key}.window.end",
                                         f"end {window['end']} is not after start {window['start']}"))
                if check_files:
                    for part in ("sonic", "ins"):
                        if not (root / flight[part]["file"]).is_file():
                            problems.append((f"{key}.{part}.file",
                                             f"file {flight[part]['file']!r} does not exist under {root}"))
            else:
                uav_ids = [u["id"] for u in flight["uavs"]]
                for dup in sorted({u for u in uav_ids if uav_ids.count(u) > 1}):
                    problems.append((f"{key}.uavs", f"duplicate UAV id {dup!r}"))
                if isinstance(flight["reference"], dict):
                    for j, uav in enumerate(flight["uavs"]):
                        fmt = uav.get("format")
                        if not (isinstance(fmt, dict) and "ref_speed" in (fmt.get("variables") or {})):
                            problems.append((f"{key}.uavs[{j}].format", "the reference is from_record, so each UAV "
                                             "record must be delimited with a ref_speed variable"))
                if check_files:
                    if isinstance(flight["reference"], str) and not (root / flight["reference"]).is_file():
                        problems.append((f"{key}.reference",
                                         f"file {flight['reference']!r} does not exist under {root}"))
                    for j, uav in enumerate(flight["uavs"]):
                        if not (root / uav["file"]).is_file():
                            problems.append((f"{key}.uavs[{j}].file",
                                             f"file {uav['file']!r} does not exist under {root}"))
    for i, flight in enumerate(data.get("autopilot_flights") or []):
        key = f"autopilot_flights[{i}]"
        if flight["id"] in seen_flights:
            problems.append((f"{key}.id", f"duplicate flight id {flight['id']!r} (also {seen_flights[flight['id']]})"))
        seen_flights.setdefault(flight["id"], key)
        if check_files and not (root / flight["file"]).is_file():
            problems.append((f"{key}.file", f"file {flight['file']!r} does not exist under {root}"))
    return problems


def load_campaign(path: str | Path, *, check_files: bool | None = None) -> Campaign:
    """Load and validate a campaign manifest.

    Parameters
    ----------
    path : str or Path
        The manifest (YAML).
    check_files : bool, optional
        Check that data files exist and globs match. Default: only for measured campaigns
        (no ``simulation:`` section).

    Returns
    -------
    Campaign
        The validated campaign.

    Raises
    ------
    ManifestError
        Naming the manifest, the key path of the first problem and what was expected;
        the message lists every problem found.
    """
    # here, not at the top (0.1 CPU-s): most workflow jobs import this module for its paths only
    import jsonschema
    import yaml

    from dronewind.core.yamltext import load_yaml

    path = Path(path).resolve()
    if not path.is_file():
        raise ManifestError(path, "(file)", "manifest file does not exist")
    try:
        raw = load_yaml(path.read_text(encoding="utf-8"))
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}" if mark is not None else "(file)"
        raise ManifestError(path, where, f"not valid YAML: {exc}") from exc
    if not isinstance(raw, dict):
        raise ManifestError(path, "(top level)", "expected a mapping (name:, site:, masts:, ...)")
    data = _normalise(raw)

    validator = jsonschema.Draft202012Validator(campaign_schema())
    errors = sorted(validator.iter_errors(data), key=lambda e: [str(p) for p in e.absolute_path])
    problems: list[tuple[str, str]] = []
    for error in errors:
        key = _key_path(error.absolute_path)
        if error.validator == "required":
            missing = error.message.split("'")[1] if "'" in error.message else error.message
            problems.append((f"{key}.{missing}" if error.absolute_path else missing,
                             f"missing required key: {error.message}"))
        elif error.validator == "additionalProperties":
            problems += _unknown_keys(error)
        elif error.validator == "type":
            got = f"{type(error.instance).__name__} ({error.instance!r})"
            problems.append((key, f"wrong type: expected {error.validator_value}, got {got}"))
        elif error.validator == "pattern":
            hint = error.schema.get("description", f"pattern {error.validator_value}")
            problems.append((key, f"{error.instance!r} is not valid: expected {hint}"))
        else:
            problems.append((key, error.message))
    if not problems:
        if check_files is None:
            check_files = not bool(data.get("simulation"))
        problems = _semantic_checks(path, data, check_files)
    if problems:
        key, what = problems[0]
        if len(problems) > 1:
            what += "\n" + "\n".join(f"  also [{k}]: {w}" for k, w in problems[1:])
        raise ManifestError(path, key, what)
    return Campaign(path=path, data=data)


def confined_path(root: str | Path, rel: str, where: str = "path") -> Path:
    """``root / rel`` when it stays below ``root`` (both resolved), else an error.

    The last line of defence of every writer that takes a path from a manifest: the
    manifest validation already rejects such paths (:func:`path_problem`).

    Parameters
    ----------
    root : str or Path
        Folder the path must stay in (e.g. ``results/<name>/L0``).
    rel : str
        Path relative to ``root``.
    where : str
        Key path or name for the message.

    Returns
    -------
    Path
        The joined path (not resolved: symbolic links inside ``root`` are kept).

    Raises
    ------
    ManifestError
        The path is absolute or leaves ``root``.
    """
    what = path_problem(str(rel), confined=True)
    base = Path(root)
    out = base / str(rel)
    if what is None and not out.resolve().is_relative_to(base.resolve()):
        what = f"path {rel!r} resolves to {out.resolve()}, outside {base.resolve()}"
    if what:
        raise ManifestError(str(base), where, what)
    return out
