"""The declared format of every file of a measured campaign, checked on its first lines before any job.

Each record of a manifest may declare its ``format`` (README "Input formats"; absent: the
contract format of its kind, :data:`dronewind.manifest.DEFAULT_FORMATS`). Before any job
runs (``dronewind validate-campaign`` and the workflow's start, ``workflow/rules/common.smk``)
each file is opened and its first lines (or a ULog's magic bytes) are compared with the
format: a file that is not what the manifest says fails there, naming ``<file>:<line>``,
what was found and what was expected (and, where the first bytes tell, the format the file
looks like), instead of failing in a job later.

What is checked, per format:

* ``toa5``: plain text; line 1 starts with the field ``TOA5``; line 2 names at least
  :data:`dronewind.mast.columns.REQUIRED_TOA5_COLUMNS`; lines 3 and 4 have as many fields; the
  first data row has as many fields, a TIMESTAMP that parses and an integer RECORD;
* ``gill_raw``: the file name ``G<DDD><HHMM>.RAW[.gz]``; gzip or plain as declared; the
  declared numeric columns hold numbers and the fields after them are empty;
* ``contract_csv``: the header line of the kind (payload sonic, INS, quadrotor) exactly,
  and a first data row with as many fields;
* ``ulog``: the ULog magic bytes ``ULog 01 12 35``;
* ``ardupilot_bin``: the first bytes of a DataFlash log's first message (``a3 95 80``, an FMT);
* ``delimited``: :func:`dronewind.core.delimited.check_delimited_head` (the mapped columns
  in the header, the field count, the time column parsing, numbers where mapped); the
  record of a rigid-mount flight (kind ``rigid_record``) is checked with the platform
  variables its mapping declares (:func:`dronewind.core.columns.rigid_layout`); its
  ``platform_log`` (kind ``platform_log``) as ``ardupilot_bin``.

What is echoed from a file is limited: the first field of a line, a time field, a header
line of a declared delimited file (shortened); binary content is described, never quoted.
"""

from __future__ import annotations

import glob
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from dronewind.core.columns import INS_COLUMNS, SONIC_COLUMNS, rigid_layout
from dronewind.core.delimited import (
    GZIP_MAGIC,
    check_delimited_head,
    compression_problem,
    delimited_layout,
    parse_times,
    read_text_lines,
    split_fields,
)
from dronewind.errors import InputError, ManifestError, describe_header
from dronewind.manifest import Campaign, is_rigid, record_format

# the column layouts, not the readers (which import xarray): this module runs at every Snakemake start
from dronewind.mast.columns import AMERIFLUX_GOLD_COLUMNS, REQUIRED_TOA5_COLUMNS
from dronewind.payload import delimited as payload_delimited
from dronewind.quadrotor.columns import DATAFLASH_MAGIC, QUADROTOR_COLUMNS, QUADROTOR_QUANTITIES

__all__ = ["ULOG_MAGIC", "CONTRACT_HEADERS", "describe_content", "check_file_format", "format_problems",
           "check_campaign_formats", "damaged_files"]

#: First bytes of a PX4 ULog file ("ULog" 01 12 35, then the version byte).
ULOG_MAGIC = b"ULog\x01\x12\x35"
#: The header line of each contract CSV, by record kind.
CONTRACT_HEADERS: dict[str, tuple[str, ...]] = {
    "payload_sonic": SONIC_COLUMNS, "payload_ins": INS_COLUMNS, "quadrotor_uav": QUADROTOR_COLUMNS}
_GILL_NAME = re.compile(r"^G(\d{3})(\d{2})(\d{2})\.RAW(\.gz)?$", re.IGNORECASE)
_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")
_HEAD_BYTES = 512
_N_ROWS = 5


def _head(path: Path) -> bytes:
    with open(path, "rb") as fh:
        return fh.read(_HEAD_BYTES)


def describe_content(head: bytes) -> str | None:
    """What the first bytes of a file look like, naming the format to declare.

    Parameters
    ----------
    head : bytes
        The first bytes of the file (a few hundred).

    Returns
    -------
    str or None
        E.g. ``"gzip-compressed data (bytes 1f 8b; the AmeriFlux/Gill RAW .gz files are gzip: format gill_raw)"``,
        or None when nothing is recognised.
    """
    if head.startswith(GZIP_MAGIC):
        return "gzip-compressed data (bytes 1f 8b; e.g. the AmeriFlux/Gill RAW .gz files: format gill_raw)"
    if head.startswith(ULOG_MAGIC):
        return "a PX4 ULog file (format ulog)"
    if head.startswith(DATAFLASH_MAGIC):
        return "an ArduPilot DataFlash log (format ardupilot_bin)"
    if head.startswith((b"\x89HDF", b"CDF\x01", b"CDF\x02")):
        return "a NetCDF/HDF5 file (a product, not raw data)"
    if b"\x00" in head:
        return "binary data"
    text = head.decode("utf-8", errors="replace").lstrip("\ufeff")
    first = text.splitlines()[0] if text else ""
    fields = [f.strip().strip('"') for f in first.split(",")]
    if fields and fields[0] == "TOA5":
        return "a Campbell TOA5 header (format toa5)"
    for kind, header in CONTRACT_HEADERS.items():
        if tuple(fields) == header:
            return f"the {kind.replace('_', ' ')} contract CSV header (format contract_csv)"
    numbers = [f for f in fields if f]
    if numbers and all(_NUMBER.fullmatch(f) for f in numbers):
        return "numbers without a header line (like the AmeriFlux/Gill RAW text: format gill_raw, or delimited)"
    return None


def _found(head: bytes, fallback: str) -> str:
    return describe_content(head) or fallback


def _check_toa5(p: Path) -> None:
    head = _head(p)
    expected = ("expected a Campbell TOA5 file: line 1 starting with the field \"TOA5\" (4 header lines: "
                "environment, field names, units, processing)")
    if head.startswith(GZIP_MAGIC) or head.startswith(ULOG_MAGIC) or b"\x00" in head:
        raise InputError(f"{p}:1", f"{_found(head, 'binary data')}, {expected}; declare the file's format")
    lines = read_text_lines(p, "none", n=4 + _N_ROWS)
    rows = split_fields(lines)
    first = rows[0][0] if rows and rows[0] else ""
    if first != "TOA5":
        raise InputError(f"{p}:1", f"{_found(head, f'first field {first[:20]!r}')}, {expected}")
    if len(rows) < 5:
        raise InputError(p, f"{len(rows)} lines, expected 4 header lines and data rows")
    names = rows[1]
    missing = [c for c in REQUIRED_TOA5_COLUMNS if c not in names]
    if missing:
        raise InputError(f"{p}:2", f"field-name line without {', '.join(missing)}, expected at least "
                         f"{', '.join(REQUIRED_TOA5_COLUMNS)}")
    for k in (2, 3):
        if len(rows[k]) != len(names):
            raise InputError(f"{p}:{k + 1}", f"{len(rows[k])} fields, expected {len(names)} (header line {k + 1} of "
                             "4, one field per name of line 2)")
    row = rows[4]
    if len(row) != len(names):
        raise InputError(f"{p}:5", f"{len(row)} fields, expected {len(names)} (one per field name of line 2)")
    stamp = row[names.index("TIMESTAMP")]
    if np.isnat(parse_times([stamp], "iso")[0]):
        raise InputError(f"{p}:5", f"TIMESTAMP {stamp[:30]!r}, expected YYYY-MM-DD HH:MM:SS[.f] (UTC)")
    record = row[names.index("RECORD")]
    if not re.fullmatch(r"[+-]?\d+", record):
        raise InputError(f"{p}:5", f"RECORD {record[:20]!r}, expected an integer")


def _check_gill(p: Path, fmt: Mapping[str, Any]) -> None:
    if not _GILL_NAME.match(p.name):
        raise InputError(p, f"file name {p.name!r}, expected G<DDD><HHMM>.RAW or G<DDD><HHMM>.RAW.gz (day of year "
                         "and start of the half hour: the times are dated from the name)")
    compression = str(fmt.get("compression", "auto"))
    problem = compression_problem(p, compression)
    if problem:
        raise InputError(f"{p}:1", problem)
    columns = list(fmt.get("columns", AMERIFLUX_GOLD_COLUMNS))
    lines = read_text_lines(p, compression, n=_N_ROWS)
    if not lines:
        raise InputError(p, "no lines, expected comma-separated numbers")
    expected = f"expected {len(columns)} numbers ({','.join(columns)}) followed by empty fields"
    for k, row in enumerate(split_fields(lines)):
        if row and row[0] == "TOA5":
            raise InputError(f"{p}:{k + 1}", f"a Campbell TOA5 header (format toa5), {expected}")
        extra = [j for j, f in enumerate(row) if j >= len(columns) and f]
        if extra:
            raise InputError(f"{p}:{k + 1}", f"{len([f for f in row if f])} non-empty fields (field {extra[0] + 1} "
                             f"beyond the declared columns), {expected}")
        for j, name in enumerate(columns):
            field = row[j] if j < len(row) else ""
            if name != "unused" and not _NUMBER.fullmatch(field):
                raise InputError(f"{p}:{k + 1}", f"field {j + 1} ({name}) is {field[:20]!r}, {expected}")


def _check_contract_csv(p: Path, kind: str) -> None:
    header = CONTRACT_HEADERS[kind]
    head = _head(p)
    expected = f"expected the contract CSV header {','.join(header)}"
    if head.startswith(GZIP_MAGIC) or head.startswith(ULOG_MAGIC) or b"\x00" in head:
        raise InputError(f"{p}:1", f"{_found(head, 'binary data')}, {expected}")
    if kind == "quadrotor_uav" and p.suffix.lower() != ".csv":
        raise InputError(p, f"file suffix {p.suffix!r} for format contract_csv, expected .csv (the quadrotor "
                         "reader picks CSV or ULog by the suffix)")
    lines = read_text_lines(p, "none", n=2)
    rows = split_fields(lines)
    found = rows[0] if rows else []
    if tuple(found) != header:
        hint = describe_content(head)
        raise InputError(f"{p}:1", f"{describe_header(found, header)}{f' (looks like {hint})' if hint else ''}")
    if len(rows) < 2:
        raise InputError(p, "no data rows after the header line")
    if len(rows[1]) != len(header):
        raise InputError(f"{p}:2", f"{len(rows[1])} fields, expected {len(header)} (one per header field)")


def _check_ulog(p: Path) -> None:
    head = _head(p)
    if not head.startswith(ULOG_MAGIC):
        found = _found(head, "first bytes " + (head[:7].hex(" ") or "none"))
        raise InputError(f"{p}:1", f"{found}, expected the PX4 ULog magic bytes 55 4c 6f 67 01 12 35 ('ULog')")
    if p.suffix.lower() != ".ulg":
        raise InputError(p, f"file suffix {p.suffix!r} for format ulog, expected .ulg (the quadrotor reader picks "
                         "CSV or ULog by the suffix)")


def _check_dataflash(p: Path) -> None:
    head = _head(p)
    if not head.startswith(DATAFLASH_MAGIC):
        found = _found(head, "first bytes " + (head[:3].hex(" ") or "none"))
        raise InputError(f"{p}:1", f"{found}, expected an ArduPilot DataFlash log (first bytes a3 95 80: an FMT "
                         "message)")


def check_file_format(path: str | Path, fmt: Mapping[str, Any], kind: str, where: str = "format") -> None:
    """Check the first lines of one file against its declared format.

    Parameters
    ----------
    path : str or Path
        The file.
    fmt : mapping
        The record's format (:func:`dronewind.manifest.record_format`): ``name`` and settings.
    kind : str
        ``mast_sonic``, ``payload_sonic``, ``payload_ins``, ``quadrotor_uav``,
        ``autopilot_log``, ``rigid_record`` or ``platform_log``.
    where : str
        Key path of the format in the manifest (messages about the mapping itself).

    Raises
    ------
    InputError
        ``<file>:<line>: <what was found>, expected <what>``; a format the kind does not take.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(p, "file not found")
    name = fmt["name"]
    allowed = {"mast_sonic": ("toa5", "gill_raw", "delimited"),
               "quadrotor_uav": ("contract_csv", "ulog", "ardupilot_bin", "delimited"),
               "autopilot_log": ("ardupilot_bin",), "rigid_record": ("delimited",), "platform_log": ("ardupilot_bin",),
               "payload_sonic": ("contract_csv", "delimited"), "payload_ins": ("contract_csv", "delimited")}.get(
        kind, ("contract_csv",))
    if name not in allowed:
        raise InputError(where, f"format {name!r} for a {kind.replace('_', ' ')}, expected one of {', '.join(allowed)}")
    if name == "toa5":
        _check_toa5(p)
    elif name == "gill_raw":
        _check_gill(p, fmt)
    elif name == "delimited" and kind == "rigid_record":
        # the mapping's columns against the head; which platform variables it must hold (a
        # platform_log gives the others) is the manifest's check (dronewind.manifest)
        check_delimited_head(p, rigid_layout(fmt, where, platform_log=None))
    elif name == "delimited" and kind == "payload_sonic":
        check_delimited_head(p, payload_delimited.sonic_layout(fmt, where))
    elif name == "delimited" and kind == "payload_ins":
        check_delimited_head(p, payload_delimited.ins_layouts(fmt, where)[0])
    elif name == "delimited" and kind == "quadrotor_uav":
        check_delimited_head(p, delimited_layout(fmt, where, QUADROTOR_QUANTITIES))
    elif name == "ardupilot_bin":
        _check_dataflash(p)
    elif name == "delimited":
        check_delimited_head(p, delimited_layout(fmt, where))
    elif name == "ulog":
        _check_ulog(p)
    else:
        _check_contract_csv(p, kind)


def _records(campaign: Campaign) -> list[tuple[str, str, dict[str, Any], list[Path]]]:
    """Every record with files: (key path, kind, format, files)."""
    root = campaign.data_root
    data = campaign.data
    out: list[tuple[str, str, dict[str, Any], list[Path]]] = []
    for i, mast in enumerate(data.get("masts") or []):
        for j, sonic in enumerate(mast["sonics"]):
            files = [Path(m) for pattern in sonic["files"] for m in sorted(glob.glob(str(root / pattern)))]
            out.append((f"masts[{i}].sonics[{j}]", "mast_sonic", record_format(sonic, "mast_sonic"),
                        list(dict.fromkeys(files))))
    for i, flight in enumerate(data.get("payload_flights") or []):
        if is_rigid(flight):
            out.append((f"payload_flights[{i}].record", "rigid_record", dict(flight["record"]["format"]),
                        [root / flight["record"]["file"]]))
            if flight.get("platform_log"):
                log = flight["platform_log"]
                out.append((f"payload_flights[{i}].platform_log", "platform_log", record_format(log, "platform_log"),
                            [root / log["file"]]))
            continue
        for part in ("sonic", "ins"):
            kind = f"payload_{part}"
            out.append((f"payload_flights[{i}].{part}", kind, record_format(flight[part], kind),
                        [root / flight[part]["file"]]))
    for i, flight in enumerate(data.get("quadrotor_flights") or []):
        for j, uav in enumerate(flight["uavs"]):
            out.append((f"quadrotor_flights[{i}].uavs[{j}]", "quadrotor_uav", record_format(uav, "quadrotor_uav"),
                        [root / uav["file"]]))
    for i, flight in enumerate(data.get("autopilot_flights") or []):
        out.append((f"autopilot_flights[{i}]", "autopilot_log", record_format(flight, "autopilot_log"),
                    [root / flight["file"]]))
    return out


def format_problems(campaign: Campaign) -> list[tuple[str, str]]:
    """Every record of a measured campaign whose files do not match its declared format.

    A record some of whose files match its format and some not is not a misdeclared format but
    a record with damaged files: the reader leaves those out, counted and named
    (:func:`damaged_files`); it is not a problem here.

    Parameters
    ----------
    campaign : Campaign
        A validated manifest (its files exist: :func:`dronewind.manifest.load_campaign`).

    Returns
    -------
    list of (str, str)
        ``(key path of the record's format, "<file>:<line>: <found>, expected <what>")``;
        one entry per record none of whose files matches (its first file's problem).
    """
    return [(key, failed[0]) for key, failed, n_files in _file_checks(campaign) if failed and len(failed) == n_files]


def damaged_files(campaign: Campaign) -> list[tuple[str, str]]:
    """Files that fail their declared format in a record whose other files match it.

    Returns
    -------
    list of (str, str)
        ``(key path of the record's format, "<file>:<line>: <found>, expected <what>")`` per
        damaged file: the run goes on without it (the record's reader leaves it out and says so).
    """
    return [(key, what) for key, failed, n_files in _file_checks(campaign) if len(failed) < n_files
            for what in failed]


def _file_checks(campaign: Campaign) -> list[tuple[str, list[str], int]]:
    """Per record: its format's key path, the problems of its failing files, its number of files."""
    out = []
    for key, kind, fmt, files in _records(campaign):
        failed = []
        for f in files:
            try:
                check_file_format(f, fmt, kind, f"{key}.format")
            except InputError as exc:
                failed.append(str(exc))
        out.append((f"{key}.format", failed, len(files)))
    return out


def check_campaign_formats(campaign: Campaign) -> list[str]:
    """Raise when a record of a measured campaign does not match its declared format.

    A virtual campaign (``simulation:``) is skipped: the simulator writes its files in the
    contract formats.

    Parameters
    ----------
    campaign : Campaign
        A validated manifest.

    Raises
    ------
    ManifestError
        Naming the manifest, the record's ``format`` key path and ``<file>:<line>: <found>,
        expected <what>``; every problem is listed.

    Returns
    -------
    list of str
        One warning per damaged file of a record whose other files match (:func:`damaged_files`).
    """
    if campaign.simulated:
        return []
    problems = format_problems(campaign)
    if problems:
        key, what = problems[0]
        if len(problems) > 1:
            what += "\n" + "\n".join(f"  also [{k}]: {w}" for k, w in problems[1:])
        raise ManifestError(campaign.path, key, what)
    return [f"[{key}] damaged file left out of its record: {what}" for key, what in damaged_files(campaign)]
