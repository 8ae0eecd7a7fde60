"""Fault corpus: bad input, faults and hostile manifests, one at a time, on a small measured campaign.

A two-flight campaign (8-min hovers, one mast sonic with one TOA5 file per flight) is
simulated once into a folder and declared as measured data (no ``simulation:`` section).
Every case copies that folder, injects one fault into the files or the manifest of flight
``s01`` and runs the chain in-process, file to L4 (the same functions as the workflow
steps). Each case asserts its outcome, one of:

* ``error``: a named error (:class:`dronewind.errors.DronewindError`) whose message matches
  what the case expects (file, line or key, variable, numbers);
* ``unusable``: processed with ``usable = 0`` and the reason expected;
* ``ok``: read correctly: usable, the counts of what was removed or filled as expected and
  the numbers close to the fault-free flight;

and that the other flight (``s02``) gives exactly its fault-free numbers (its chain is
rerun whenever one of its input files changed, e.g. the shared mast record). Workflow-level
faults (a second run on a locked folder, a killed run, identical runs in two folders, paths
in a manifest that leave the results folder) are at the end; they reuse one small run.
"""

from __future__ import annotations

import csv
import hashlib
import io
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr
import yaml

from dronewind.compare.chain import compute_l3, compute_l4, reference_unusable_l3
from dronewind.core import spectra
from dronewind.errors import DronewindError, InputError, ManifestError
from dronewind.manifest import default_config, load_campaign
from dronewind.mast.chain import compute_mast_l1, flight_reference
from dronewind.payload.chain import compute_payload_l1, compute_payload_l2
from dronewind.steps.lock import LOCK_NAME, ResultsLockedError, acquire_results_lock, lock_owner, release_results_lock
from dronewind.steps.payload import simulate_payload, simulation_manifest
from tests.conftest import SOURCE_DATE_EPOCH, run_workflow, workflow_env
from tests.small_campaign import SHORT_HOVER, write_small_campaign

REPO = Path(__file__).resolve().parents[2]
BIN = Path(sys.executable).parent
PROCESSING = default_config()["processing"]
HOVER = {**PROCESSING["hover"], "min_duration_s": 300.0}
FLIGHTS = ("s01", "s02")
NUMBERS = ("lag_sonic_ins_s", "height_m", "U_ms", "sigma_u_ms", "sigma_w_ms", "uw_m2s2", "lag_drone_mast_s")


# ----------------------------------------------------------------------------- the campaign and the chain


@dataclass
class Outcome:
    """What the chain made of one flight."""

    status: str  # "ok", "unusable" or "error"
    message: str = ""
    reason: str = ""
    numbers: dict[str, float] = field(default_factory=dict)
    counts: dict[str, int] = field(default_factory=dict)
    log: str = ""


def _files_of(folder: Path, data: dict[str, Any], fid: str) -> list[Path]:
    flight = next(f for f in data["payload_flights"] if f["id"] == fid)
    mast = sorted(folder.glob(data["masts"][0]["sonics"][0]["files"][0]))
    return [folder / flight["sonic"]["file"], folder / flight["ins"]["file"], *mast]


def run_flight(folder: Path, data: dict[str, Any], fid: str) -> Outcome:
    """Files of one flight to L4 (drone), as the workflow steps do; named errors are outcomes."""
    flight = next(f for f in data["payload_flights"] if f["id"] == fid)
    sonic_entry = {**data["masts"][0]["sonics"][0], "mast_id": data["masts"][0]["id"],
                   "latitude": data["site"]["latitude"], "longitude": data["site"]["longitude"]}
    try:
        sonic, ins = compute_payload_l1(folder / flight["sonic"]["file"], folder / flight["ins"]["file"],
                                        PROCESSING["despike"])
        l2 = compute_payload_l2(sonic, ins, flight, float(data["site"]["altitude_m"]),
                                sonic_ins_lag=PROCESSING["sonic_ins_lag"], hover=HOVER,
                                max_missing_fraction=PROCESSING["max_missing_fraction"])
        try:  # a mast record that cannot be read or used: the flight goes on without its reference
            mast: Any = compute_mast_l1(_files_of(folder, data, fid)[2:], sonic_entry, PROCESSING["despike"])
        except InputError as exc:
            mast = exc
        mast_l2, reason = flight_reference(mast, l2, fid, PROCESSING["drone_mast"])
        if mast_l2 is None:
            l3 = reference_unusable_l3(l2, flight, PROCESSING["rotation"], reason)
        else:
            l3 = compute_l3(l2, mast_l2, flight, PROCESSING["drone_mast"], PROCESSING["rotation"])
        l4 = compute_l4(l3, "drone", PROCESSING["spectra"], PROCESSING["quadrant"], PROCESSING["detrending"])
    except DronewindError as exc:
        return Outcome("error", message=str(exc))
    if isinstance(mast, InputError):
        mast = xr.Dataset()
    usable = bool(l2.attrs["usable"]) and bool(l4.attrs.get("drone_usable", 1))
    reasons = str(l4.attrs.get("drone_unusable_reason", "")) or str(l2.attrs["unusable_reason"])
    numbers = {"lag_sonic_ins_s": float(l2.attrs["lag_sonic_ins_s"]), "height_m": float(l2.attrs["height_m"]),
               "lag_drone_mast_s": float(l3.attrs.get("lag_drone_mast_s", float("nan")))}
    numbers.update({k: float(l4[k]) for k in ("U_ms", "sigma_u_ms", "sigma_w_ms", "uw_m2s2")})
    counts = {k: int(v) for ds in (sonic, ins, l2, mast) for k, v in ds.attrs.items() if k.startswith("n_")}
    counts.update({f"sonic_{k}": int(v) for k, v in sonic.attrs.items() if k.startswith("n_")})
    counts.update({f"ins_{k}": int(v) for k, v in ins.attrs.items() if k.startswith("n_")})
    counts.update({f"mast_{k}": int(v) for k, v in mast.attrs.items() if k.startswith("n_")})
    return Outcome("ok" if usable else "unusable", reason=reasons, numbers=numbers, counts=counts,
                   log="\n".join(str(ds.attrs.get("processing_log", "")) for ds in (sonic, ins, l2, mast)))


@pytest.fixture(scope="module")
def base(tmp_path_factory) -> tuple[Path, dict[str, Any], dict[str, Outcome]]:
    """The measured two-flight campaign: folder, manifest content and the fault-free outcomes."""
    sim = tmp_path_factory.mktemp("faults_sim")
    virtual = load_campaign(write_small_campaign(sim, name="faultcamp", n_flights=2))
    folder = tmp_path_factory.mktemp("faults_base")
    for fid in FLIGHTS:
        simulate_payload(simulation_manifest(virtual.data), fid, sim, folder)
    data = {k: v for k, v in virtual.data.items() if k != "simulation"}
    (folder / "faultcamp.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    load_campaign(folder / "faultcamp.yaml")  # a valid measured campaign
    outcomes = {fid: run_flight(folder, data, fid) for fid in FLIGHTS}
    assert all(o.status == "ok" for o in outcomes.values()), outcomes
    return folder, data, outcomes


_OTHER_CACHE: dict[str, Outcome] = {}


def other_flight(folder: Path, data: dict[str, Any]) -> Outcome:
    """Outcome of s02, recomputed whenever one of its input files differs from a run already made."""
    digest = hashlib.sha256()
    for path in _files_of(folder, data, "s02"):
        digest.update(path.name.encode() + path.read_bytes())
    key = digest.hexdigest()
    if key not in _OTHER_CACHE:
        _OTHER_CACHE[key] = run_flight(folder, data, "s02")
    return _OTHER_CACHE[key]


# ----------------------------------------------------------------------------- file surgery


def lines_of(path: Path) -> list[str]:
    return path.read_text().splitlines()


def write_lines(path: Path, lines: list[str]) -> None:
    path.write_text("\n".join(lines) + "\n")


def sonic_path(folder: Path) -> Path:
    return folder / "flights" / "s01" / "sonic.csv"


def ins_path(folder: Path) -> Path:
    return folder / "flights" / "s01" / "ins.csv"


def mast_path(folder: Path, fid: str = "s01") -> Path:
    return folder / "mast" / f"mast30_{fid}.dat"


def rpi_at(folder: Path, utc: str) -> int:
    """Logger time [us] of a UTC instant, from the INS of s01 (shared clock of sonic and INS)."""
    rows = [r for r in csv.DictReader(io.StringIO(ins_path(folder).read_text())) if r["utc"]]
    target = np.datetime64(utc.rstrip("Z"), "us").astype(np.int64)
    utcs = np.array([np.datetime64(r["utc"].rstrip("Z"), "us").astype(np.int64) for r in rows])
    rpis = np.array([int(r["rpi_time_us"]) for r in rows])
    return int(np.interp(target, utcs, rpis))


HOVER_START, HOVER_END = "2023-08-21T14:05:00Z", "2023-08-21T14:13:00Z"
MID_HOVER = "2023-08-21T14:09:00Z"


def rows_between(path: Path, t0_us: int, t1_us: int) -> list[int]:
    """Indices (in lines_of) of the data rows whose rpi_time_us lies in [t0, t1]."""
    out = []
    for k, line in enumerate(lines_of(path)[1:], start=1):
        t = int(line.split(",", 1)[0])
        if t0_us <= t <= t1_us:
            out.append(k)
    return out


def edit_column(path: Path, column: str, func: Callable[[str], str], rows: list[int] | None = None) -> None:
    """Apply ``func`` to one column of a CSV (all data rows, or the given line indices)."""
    lines = lines_of(path)
    header = lines[0].split(",")
    j = header.index(column)
    targets = range(1, len(lines)) if rows is None else rows
    for k in targets:
        fields = lines[k].split(",")
        fields[j] = func(fields[j])
        lines[k] = ",".join(fields)
    write_lines(path, lines)


def scale(factor: float) -> Callable[[str], str]:
    return lambda s: s if s in ("", "nan") else f"{float(s) * factor:.6g}"


def every(path: Path, step: int, start: int = 1) -> list[int]:
    return list(range(start, len(lines_of(path)), step))


# ----------------------------------------------------------------------------- the faults (flight s01)


def f_sonic_cut_mid_hover(folder: Path, data: dict) -> None:
    """A sonic file cut in the middle of the hover (the INS goes on)."""
    cut = rpi_at(folder, MID_HOVER)
    lines = lines_of(sonic_path(folder))
    write_lines(sonic_path(folder), [ln for k, ln in enumerate(lines) if k == 0 or int(ln.split(",")[0]) < cut])


def f_sonic_cut_mid_line(folder: Path, data: dict) -> None:
    """The last line of the sonic file cut in the middle (a logger that stopped writing)."""
    text = sonic_path(folder).read_text()
    sonic_path(folder).write_text(text[: len(text) - 9])


def f_ins_hole_120s(folder: Path, data: dict) -> None:
    """A 120-s hole in the INS rows inside the hover."""
    t0 = rpi_at(folder, "2023-08-21T14:07:00Z")
    drop = set(rows_between(ins_path(folder), t0, t0 + 120_000_000))
    lines = lines_of(ins_path(folder))
    write_lines(ins_path(folder), [ln for k, ln in enumerate(lines) if k not in drop])


def f_ins_hole_half_second(folder: Path, data: dict) -> None:
    """A 0.5-s hole in the INS inside the hover: bridged (well under 2 %)."""
    t0 = rpi_at(folder, MID_HOVER)
    drop = set(rows_between(ins_path(folder), t0, t0 + 500_000))
    lines = lines_of(ins_path(folder))
    write_lines(ins_path(folder), [ln for k, ln in enumerate(lines) if k not in drop])


def f_altitude_in_feet(folder: Path, data: dict) -> None:
    edit_column(ins_path(folder), "alt_m", scale(3.28084))


def f_velocity_in_kmh(folder: Path, data: dict) -> None:
    for col in ("vel_n_ms", "vel_e_ms", "vel_d_ms"):
        edit_column(ins_path(folder), col, scale(3.6))


def f_vel_d_positive_up(folder: Path, data: dict) -> None:
    edit_column(ins_path(folder), "vel_d_ms", scale(-1.0))
    edit_column(ins_path(folder), "vel_n_ms", scale(-1.0))
    edit_column(ins_path(folder), "vel_e_ms", scale(-1.0))


def f_sonic_in_cm_per_s(folder: Path, data: dict) -> None:
    for col in ("u_ms", "v_ms", "w_ms"):
        edit_column(sonic_path(folder), col, scale(100.0))


def f_sonic_out_of_range_30s(folder: Path, data: dict) -> None:
    """30 s of the hover logged in cm/s (a sensor that switched units)."""
    t0 = rpi_at(folder, MID_HOVER)
    rows = rows_between(sonic_path(folder), t0, t0 + 30_000_000)
    for col in ("u_ms", "v_ms", "w_ms"):
        edit_column(sonic_path(folder), col, scale(100.0), rows=rows)


def f_toa5_header_line_missing(folder: Path, data: dict) -> None:
    lines = lines_of(mast_path(folder))
    write_lines(mast_path(folder), lines[:3] + lines[4:])  # the processing line dropped


def f_toa5_units_line_missing(folder: Path, data: dict) -> None:
    lines = lines_of(mast_path(folder))
    write_lines(mast_path(folder), lines[:2] + lines[3:])


def f_toa5_conflicting_duplicates_few(folder: Path, data: dict) -> None:
    """Five rows repeated with other values: both copies dropped and reported."""
    lines = lines_of(mast_path(folder))
    for k in (3000, 4000, 5000, 6000, 7000):
        fields = lines[k].split(",")
        fields[2] = str(float(fields[2]) + 5.0)
        lines.insert(k + 1, ",".join(fields))
    write_lines(mast_path(folder), lines)


def f_toa5_conflicting_duplicates_many(folder: Path, data: dict) -> None:
    lines = lines_of(mast_path(folder))
    out = lines[:4]
    for k, line in enumerate(lines[4:]):
        out.append(line)
        if k % 10 == 0:
            fields = line.split(",")
            fields[2] = str(float(fields[2]) + 5.0)
            out.append(",".join(fields))
    write_lines(mast_path(folder), out)


def f_toa5_nan_and_diag(folder: Path, data: dict) -> None:
    lines = lines_of(mast_path(folder))
    for k in range(2000, len(lines), 997):
        fields = lines[k].split(",")
        fields[2] = '"NAN"'
        lines[k] = ",".join(fields)
    for k in range(2500, len(lines), 1499):
        fields = lines[k].split(",")
        fields[6] = "4096"
        lines[k] = ",".join(fields)
    write_lines(mast_path(folder), lines)


def f_toa5_hole_over_hover(folder: Path, data: dict) -> None:
    """The mast logger stopped during the hover (no rows for 4 minutes)."""
    lines = lines_of(mast_path(folder))
    keep = [ln for k, ln in enumerate(lines) if k < 4 or not ("14:06:00" <= ln[12:20] <= "14:10:00")]
    write_lines(mast_path(folder), keep)


def f_toa5_off_grid_timestamp(folder: Path, data: dict) -> None:
    lines = lines_of(mast_path(folder))
    fields = lines[3000].split(",")
    fields[0] = fields[0][:-1] + '03"' if fields[0].endswith('"') else fields[0]
    stamp = fields[0].strip('"')
    fields[0] = f'"{stamp[:19]}.03"'
    lines[3000] = ",".join(fields)
    write_lines(mast_path(folder), lines)


def f_toa5_changed_header(folder: Path, data: dict) -> None:
    lines = lines_of(mast_path(folder))
    lines[1] = lines[1].replace('"Uz"', '"Uz_1"')
    write_lines(mast_path(folder), lines)


def _mast_mid(folder: Path) -> tuple[bytes, int]:
    """The mast file of s01 and the byte offset of the start of its middle data line."""
    raw = mast_path(folder).read_bytes()
    n = raw.count(b"\n")
    pos = 0
    for _ in range(n // 2):
        pos = raw.index(b"\n", pos) + 1
    return raw, pos


def f_toa5_row_cut_short(folder: Path, data: dict) -> None:
    """Power lost while the logger wrote a row: the row ends inside its quoted TIMESTAMP (an SD card's torn line)."""
    raw, pos = _mast_mid(folder)
    mast_path(folder).write_bytes(raw[:pos + 12] + raw[raw.index(b"\n", pos + 1):])


def f_toa5_nul_block(folder: Path, data: dict) -> None:
    """200 NUL bytes (a zeroed SD-card sector) in the middle of a row."""
    raw, pos = _mast_mid(folder)
    mast_path(folder).write_bytes(raw[:pos + 30] + b"\x00" * 200 + raw[pos + 30:])


def f_toa5_garbage_block(folder: Path, data: dict) -> None:
    """A block of binary garbage with line ends and quotes in it, over several rows."""
    raw, pos = _mast_mid(folder)
    junk = bytes(np.random.default_rng(3).integers(0, 256, 700, dtype=np.uint8)) + b'\n"\r\x00\n'
    mast_path(folder).write_bytes(raw[:pos + 5] + junk + raw[pos + 400:])


def f_toa5_mangled_time_and_number(folder: Path, data: dict) -> None:
    """A mangled TIMESTAMP and a field that is not a number."""
    lines = lines_of(mast_path(folder))
    lines[3001] = lines[3001].replace("-", "#", 1)
    fields = lines[5001].split(",")
    fields[3] = "1.2.3x"
    lines[5001] = ",".join(fields)
    write_lines(mast_path(folder), lines)


def f_sonic_row_cut_short_nul(folder: Path, data: dict) -> None:
    """The payload sonic: a row cut short and a block of 200 NUL bytes."""
    lines = lines_of(sonic_path(folder))
    k = len(lines) // 2
    lines[k] = lines[k][:9]
    lines[k + 500] = lines[k + 500][:5] + "\x00" * 200 + lines[k + 500][5:]
    write_lines(sonic_path(folder), lines)


def f_ins_row_cut_short_nul(folder: Path, data: dict) -> None:
    """The INS: a row cut short without its line end and a block of NUL bytes."""
    raw = ins_path(folder).read_bytes()
    mid = raw.index(b"\n", len(raw) // 2) + 1
    cut = raw[:mid + 20] + raw[raw.index(b"\n", mid) + 1:]
    mid2 = cut.index(b"\n", len(cut) * 3 // 4) + 1
    ins_path(folder).write_bytes(cut[:mid2 + 7] + b"\x00" * 200 + cut[mid2 + 7:])


def f_sonic_header_missing_column(folder: Path, data: dict) -> None:
    lines = lines_of(sonic_path(folder))
    write_lines(sonic_path(folder), [",".join(ln.split(",")[:4]) for ln in lines])


def f_sonic_header_renamed(folder: Path, data: dict) -> None:
    lines = lines_of(sonic_path(folder))
    lines[0] = lines[0].replace("u_ms", "U")
    write_lines(sonic_path(folder), lines)


def f_sonic_is_system_file(folder: Path, data: dict) -> None:
    """The manifest points the sonic at a file of another kind (here a passwd-like file)."""
    sonic_path(folder).write_text("root:x:0:0:root:/root:/bin/bash\ndaemon:x:1:1:daemon:/usr/sbin:/bin/sh\n")


def f_sonic_corrupt_few(folder: Path, data: dict) -> None:
    lines = lines_of(sonic_path(folder))
    for k in range(100, len(lines), 400):  # 0.25 % of the lines
        lines[k] = lines[k][:7] + "#!" + lines[k][9:]
    write_lines(sonic_path(folder), lines)


def f_sonic_corrupt_many(folder: Path, data: dict) -> None:
    lines = lines_of(sonic_path(folder))
    for k in range(5, len(lines), 10):  # 10 % of the lines
        lines[k] = "garbage"
    write_lines(sonic_path(folder), lines)


def f_sonic_binary_garbage(folder: Path, data: dict) -> None:
    raw = bytearray(sonic_path(folder).read_bytes())
    for pos in range(20_000, len(raw), 200_000):
        raw[pos:pos + 4] = b"\x00\xff\xfe\x80"
    sonic_path(folder).write_bytes(bytes(raw))


def f_sonic_exact_duplicates(folder: Path, data: dict) -> None:
    lines = lines_of(sonic_path(folder))
    for k in (900, 5000, 9000):
        lines.insert(k, lines[k])
    write_lines(sonic_path(folder), lines)


def f_sonic_conflicting_duplicates_few(folder: Path, data: dict) -> None:
    lines = lines_of(sonic_path(folder))
    for k in (6000, 9000, 12000):
        fields = lines[k].split(",")
        fields[1] = "9.99"
        lines.insert(k + 1, ",".join(fields))
    write_lines(sonic_path(folder), lines)


def f_sonic_conflicting_duplicates_many(folder: Path, data: dict) -> None:
    lines = lines_of(sonic_path(folder))
    out = lines[:1]
    for k, line in enumerate(lines[1:]):
        out.append(line)
        if k % 8 == 0:
            fields = line.split(",")
            fields[1] = "9.99"
            out.append(",".join(fields))
    write_lines(sonic_path(folder), out)


def f_sonic_rows_swapped(folder: Path, data: dict) -> None:
    lines = lines_of(sonic_path(folder))
    for k in (3000, 7000, 11000):
        lines[k], lines[k + 1] = lines[k + 1], lines[k]
    write_lines(sonic_path(folder), lines)


def f_sonic_clock_back(folder: Path, data: dict) -> None:
    """The logger clock set back by 30 s half-way (a clock jump)."""
    lines = lines_of(sonic_path(folder))
    half = len(lines) // 2
    for k in range(half, len(lines)):
        t, rest = lines[k].split(",", 1)
        lines[k] = f"{int(t) - 30_000_000},{rest}"
    write_lines(sonic_path(folder), lines)


def f_sonic_clock_forward_jump(folder: Path, data: dict) -> None:
    """The logger time steps forward by 2 h in the sonic (not in the INS)."""
    lines = lines_of(sonic_path(folder))
    for k in range(len(lines) // 2, len(lines)):
        t, rest = lines[k].split(",", 1)
        lines[k] = f"{int(t) + 7_200_000_000},{rest}"
    write_lines(sonic_path(folder), lines)


def f_sonic_gap_5s(folder: Path, data: dict) -> None:
    t0 = rpi_at(folder, MID_HOVER)
    drop = set(rows_between(sonic_path(folder), t0, t0 + 5_000_000))
    write_lines(sonic_path(folder), [ln for k, ln in enumerate(lines_of(sonic_path(folder))) if k not in drop])


def f_sonic_gap_30s(folder: Path, data: dict) -> None:
    t0 = rpi_at(folder, MID_HOVER)
    drop = set(rows_between(sonic_path(folder), t0, t0 + 30_000_000))
    write_lines(sonic_path(folder), [ln for k, ln in enumerate(lines_of(sonic_path(folder))) if k not in drop])


def f_sonic_spikes(folder: Path, data: dict) -> None:
    edit_column(sonic_path(folder), "w_ms", lambda s: "12.5", rows=every(sonic_path(folder), 1500, 4000))


def f_sonic_nan_values(folder: Path, data: dict) -> None:
    edit_column(sonic_path(folder), "t_sonic_c", lambda s: "nan", rows=every(sonic_path(folder), 2000, 4001))


def f_sonic_w_column_empty(folder: Path, data: dict) -> None:
    edit_column(sonic_path(folder), "w_ms", lambda s: "nan")


def f_sonic_header_only(folder: Path, data: dict) -> None:
    write_lines(sonic_path(folder), lines_of(sonic_path(folder))[:1])


def f_sonic_before_gnss_time(folder: Path, data: dict) -> None:
    """Only the sonic rows logged before the INS had a stable GNSS time."""
    t0 = rpi_at(folder, "2023-08-21T14:03:31Z")
    lines = lines_of(sonic_path(folder))
    write_lines(sonic_path(folder), [ln for k, ln in enumerate(lines) if k == 0 or int(ln.split(",")[0]) < t0])


def f_ins_yaw_empty(folder: Path, data: dict) -> None:
    edit_column(ins_path(folder), "yaw_deg", lambda s: "")


def f_ins_yaw_nan(folder: Path, data: dict) -> None:
    edit_column(ins_path(folder), "yaw_deg", lambda s: "nan")


def f_ins_no_gnss_time(folder: Path, data: dict) -> None:
    edit_column(ins_path(folder), "time_valid", lambda s: "0")
    edit_column(ins_path(folder), "utc", lambda s: "")


def f_ins_utc_jump(folder: Path, data: dict) -> None:
    """GNSS time steps by 1 s half-way (the logger clock does not)."""
    lines = lines_of(ins_path(folder))
    for k in range(len(lines) // 2, len(lines)):
        fields = lines[k].split(",")
        if fields[1]:
            t = np.datetime64(fields[1].rstrip("Z"), "us") + np.timedelta64(1, "s")
            fields[1] = str(np.datetime_as_string(t, unit="us")) + "Z"
        lines[k] = ",".join(fields)
    write_lines(ins_path(folder), lines)


def f_ins_ekf_invalid_5pct(folder: Path, data: dict) -> None:
    t0, t1 = rpi_at(folder, "2023-08-21T14:07:00Z"), rpi_at(folder, "2023-08-21T14:07:30Z")
    edit_column(ins_path(folder), "ekf_valid", lambda s: "0", rows=rows_between(ins_path(folder), t0, t1))


def f_ins_ekf_invalid_few(folder: Path, data: dict) -> None:
    t0, t1 = rpi_at(folder, "2023-08-21T14:07:00Z"), rpi_at(folder, "2023-08-21T14:07:01Z")
    edit_column(ins_path(folder), "ekf_valid", lambda s: "0", rows=rows_between(ins_path(folder), t0, t1))


def f_ins_header_extra_column(folder: Path, data: dict) -> None:
    lines = lines_of(ins_path(folder))
    write_lines(ins_path(folder), [ln + (",heading_acc" if k == 0 else ",0.1") for k, ln in enumerate(lines)])


def f_ins_yaw_0_360(folder: Path, data: dict) -> None:
    """Yaw logged in [0, 360) instead of (-180, 180]: the same flight."""
    edit_column(ins_path(folder), "yaw_deg", lambda s: s if s == "" else f"{float(s) % 360.0:.4f}")


def f_ins_utc_missing_rows(folder: Path, data: dict) -> None:
    """time_valid = 1 but no utc on a few rows (GNSS time missing there)."""
    edit_column(ins_path(folder), "utc", lambda s: "", rows=every(ins_path(folder), 3000, 2000))


def f_ins_conflicting_duplicates_few(folder: Path, data: dict) -> None:
    lines = lines_of(ins_path(folder))
    for k in (5000, 15000):
        fields = lines[k].split(",")
        fields[-1] = "12.3"
        lines.insert(k + 1, ",".join(fields))
    write_lines(ins_path(folder), lines)


def f_ins_from_other_flight(folder: Path, data: dict) -> None:
    """The INS file of another flight (logger times an hour away from the sonic's)."""
    shutil.copy(folder / "flights" / "s02" / "ins.csv", ins_path(folder))


def f_window_a_day_late(folder: Path, data: dict) -> None:
    data["payload_flights"][0]["window"] = {"start": "2023-08-22T14:05:00Z", "end": "2023-08-22T14:13:00Z"}


def f_window_too_short(folder: Path, data: dict) -> None:
    data["payload_flights"][0]["window"] = {"start": "2023-08-21T14:05:00Z", "end": "2023-08-21T14:07:00Z"}


def f_target_height_wrong(folder: Path, data: dict) -> None:
    data["payload_flights"][0]["target_height_m"] = 90


def f_wrong_mount(folder: Path, data: dict) -> None:
    """The manifest says upright for an upside-down sonic: the lag search finds no clear minimum."""
    data["payload_flights"][0]["sonic"]["mount"] = "upright"


#: (name, fault, expected status, pattern of the message or reason, counts expected > 0)
CASES: list[tuple[str, Callable[[Path, dict], None], str, str, tuple[str, ...]]] = [
    ("sonic_cut_mid_hover", f_sonic_cut_mid_hover, "unusable",
     r"sonic data used span 2\d\d\.\d s of the 480\.0 s hover window", ()),
    ("sonic_cut_mid_line", f_sonic_cut_mid_line, "ok", "", ("sonic_n_corrupt_lines",)),
    ("ins_hole_120s", f_ins_hole_120s, "unusable", r"2\d\.\d\d % of the INS samples in the hover window missing "
     r"\(\d+ NaN or ekf_valid=0, 6\d\d\d absent, longest gap 120\.\d s", ()),
    ("ins_hole_half_second", f_ins_hole_half_second, "ok", "", ("n_ins_absent_in_hover",)),
    ("altitude_in_feet", f_altitude_in_feet, "unusable", r"hover height 1\d\d\d\.\d m above ground .* target "
     r"height 30 m", ()),
    ("velocity_in_kmh", f_velocity_in_kmh, "unusable", r"INS horizontal velocity is 3\.\d\d times the GNSS position "
     r"derivative .*km/h", ()),
    ("vel_ned_signs_flipped", f_vel_d_positive_up, "unusable", r"anti-correlated with the GNSS position derivative",
     ()),
    ("sonic_in_cm_per_s", f_sonic_in_cm_per_s, "error", r"sonic\.csv \[u_ms, v_ms, w_ms, t_sonic_c\]: \d+ of \d+ "
     r"sonic samples \(\d+ %\) beyond the RM Young 81000 range .*median \|V\| 4\d\d", ()),
    ("sonic_out_of_range_30s", f_sonic_out_of_range_30s, "unusable", r"\d\.\d % of the sonic samples in the hover "
     r"window beyond the instrument range", ()),
    ("toa5_header_line_missing", f_toa5_header_line_missing, "unusable",
     r"reference mast record not usable over the flight's window \(.*mast sonic covers 0 % .*file\(s\) of the "
     r"record left out as unreadable: .*mast30_s01\.dat:4: line 4 is a data row .* only 3 header lines", ()),
    ("toa5_units_line_missing", f_toa5_units_line_missing, "unusable",
     r"left out as unreadable: .*mast30_s01\.dat:4: line 4 is a data row", ()),
    ("toa5_conflicting_duplicates_few", f_toa5_conflicting_duplicates_few, "ok", "", ("mast_n_time_conflicts",)),
    ("toa5_conflicting_duplicates_many", f_toa5_conflicting_duplicates_many, "unusable",
     r"reference mast record cannot be read \(.*mast30_s01\.dat:\d+: \d+ of \d+ rows repeat a TIMESTAMP with other "
     r"values", ()),
    ("toa5_nan_and_diag", f_toa5_nan_and_diag, "ok", "", ("mast_n_nan_values", "mast_n_diag_flagged")),
    ("toa5_hole_over_hover", f_toa5_hole_over_hover, "unusable",
     r"not usable over the flight's window \(.*mast sonic covers \d+ % of flight s01's hover window", ()),
    ("toa5_off_grid_timestamp", f_toa5_off_grid_timestamp, "unusable",
     r"cannot be read \(.*mast30_s01\.dat:\d+: TIMESTAMP .* is off the 10 Hz sampling grid", ()),
    ("toa5_changed_header", f_toa5_changed_header, "unusable",
     r"left out as unreadable: .*mast30_s01\.dat:2: required column\(s\) Uz missing", ()),
    ("toa5_row_cut_short", f_toa5_row_cut_short, "ok", "", ("mast_n_corrupt_lines",)),
    ("toa5_nul_block", f_toa5_nul_block, "ok", "", ("mast_n_corrupt_lines",)),
    ("toa5_garbage_block", f_toa5_garbage_block, "ok", "", ("mast_n_corrupt_lines",)),
    ("toa5_mangled_time_and_number", f_toa5_mangled_time_and_number, "ok", "", ("mast_n_corrupt_lines",
                                                                                 "mast_n_nonnumeric")),
    ("sonic_row_cut_short_nul", f_sonic_row_cut_short_nul, "ok", "", ("sonic_n_corrupt_lines",)),
    ("ins_row_cut_short_nul", f_ins_row_cut_short_nul, "ok", "", ("ins_n_corrupt_lines",)),
    ("sonic_header_missing_column", f_sonic_header_missing_column, "error",
     r"sonic\.csv:1: header has 4 fields, expected 5 .*missing: t_sonic_c", ()),
    ("sonic_header_renamed", f_sonic_header_renamed, "error", r"sonic\.csv:1: .*missing: u_ms; 1 unexpected field",
     ()),
    ("sonic_is_system_file", f_sonic_is_system_file, "error", r"sonic\.csv:1: header has 1 field, expected 5", ()),
    ("sonic_corrupt_few", f_sonic_corrupt_few, "ok", "", ("sonic_n_corrupt_lines",)),
    ("sonic_corrupt_many", f_sonic_corrupt_many, "error", r"sonic\.csv:6: \d+ of \d+ data lines corrupt", ()),
    ("sonic_binary_garbage", f_sonic_binary_garbage, "ok", "", ("sonic_n_corrupt_lines",)),
    ("sonic_exact_duplicates", f_sonic_exact_duplicates, "ok", "", ("sonic_n_duplicates",)),
    ("sonic_conflicting_duplicates_few", f_sonic_conflicting_duplicates_few, "ok", "", ("sonic_n_time_conflicts",)),
    ("sonic_conflicting_duplicates_many", f_sonic_conflicting_duplicates_many, "error",
     r"sonic\.csv:\d+: \d+ of \d+ rows repeat an rpi_time_us with other values", ()),
    ("sonic_rows_swapped", f_sonic_rows_swapped, "ok", "", ("sonic_n_out_of_order",)),
    ("sonic_clock_back", f_sonic_clock_back, "error", r"sonic\.csv:\d+: rpi_time_us steps back by 29\.9\d\d s "
     r".*logger clock jump", ()),
    ("sonic_clock_forward_jump", f_sonic_clock_forward_jump, "error",
     r"sonic\.csv: rpi_time_us steps forward by 7200\.\d s", ()),
    ("sonic_gap_5s", f_sonic_gap_5s, "ok", "", ("n_sonic_filled",)),
    ("sonic_gap_30s", f_sonic_gap_30s, "unusable", r"\d\.\d\d % of the sonic samples missing \(limit 2 %\)", ()),
    ("sonic_spikes", f_sonic_spikes, "ok", "", ("sonic_n_spikes",)),
    ("sonic_nan_values", f_sonic_nan_values, "ok", "", ("sonic_n_missing_values",)),
    ("sonic_w_column_empty", f_sonic_w_column_empty, "error", r"sonic\.csv \[w_ms\]: column\(s\) w_ms hold no valid "
     r"value", ()),
    ("sonic_header_only", f_sonic_header_only, "error", r"sonic\.csv: no data lines after the header", ()),
    ("sonic_before_gnss_time", f_sonic_before_gnss_time, "error",
     r"sonic\.csv: all \d+ sonic rows precede the INS's stable valid GNSS time: the sonic's logger time ends 20\.0 s "
     r"before it", ()),
    ("ins_yaw_empty", f_ins_yaw_empty, "error", r"ins\.csv:2: 33816 of 33816 data lines corrupt .*33816 bad yaw_deg "
     r"fields", ()),
    ("ins_yaw_nan", f_ins_yaw_nan, "error", r"ins\.csv \[yaw_deg\]: column yaw_deg holds no valid value", ()),
    ("ins_no_gnss_time", f_ins_no_gnss_time, "error", r"ins\.csv: no stable valid GNSS time", ()),
    ("ins_utc_jump", f_ins_utc_jump, "error", r"ins\.csv:\d+: the relation utc - rpi_time steps by 1\.000 s", ()),
    ("ins_ekf_invalid_30s", f_ins_ekf_invalid_5pct, "unusable",
     r"6\.\d\d % of the INS samples in the hover window missing \(1\d\d\d NaN or ekf_valid=0", ()),
    ("ins_ekf_invalid_1s", f_ins_ekf_invalid_few, "ok", "", ("n_ins_filled_in_hover",)),
    ("ins_header_extra_column", f_ins_header_extra_column, "error", r"ins\.csv:1: header has 14 fields, expected 13 "
     r".*1 unexpected field", ()),
    ("ins_yaw_0_360", f_ins_yaw_0_360, "ok", "", ()),
    ("ins_utc_missing_rows", f_ins_utc_missing_rows, "ok", "", ("ins_n_time_valid_without_utc",)),
    ("ins_conflicting_duplicates_few", f_ins_conflicting_duplicates_few, "ok", "", ("ins_n_time_conflicts",)),
    ("ins_from_other_flight", f_ins_from_other_flight, "error", r"sonic\.csv: all \d+ sonic rows precede the INS's "
     r"stable valid GNSS time: the sonic's logger time ends 2\d\d\d\.\d s before it", ()),
    ("window_a_day_late", f_window_a_day_late, "error",
     r"flight s01 \(sonic .*sonic\.csv, INS .*ins\.csv\) \[window\]: the manifest window 2023-08-22T14:05:00Z to "
     r"2023-08-22T14:13:00Z holds 0 sonic and 0 INS samples .*the window "
     r"starts 2\d\.\d h after the data end", ()),
    ("window_too_short", f_window_too_short, "unusable", r"hover window 120\.0 s shorter than 300 s", ()),
    ("target_height_wrong", f_target_height_wrong, "unusable", r"hover height 28\.0 m above ground .*differs from "
     r"the target height 90 m by -62\.0 m", ()),
]

#: Cases read correctly: numbers within these tolerances of the fault-free flight (absolute).
TOLERANCE = {"lag_sonic_ins_s": 1e-9, "height_m": 0.05, "U_ms": 0.02, "sigma_u_ms": 0.02, "sigma_w_ms": 0.01,
             "uw_m2s2": 0.01}

#: Faults in the mast record that make the whole record unreadable (it is read as one): every
#: flight referencing the sonic goes on without its reference, usable = 0 with the same
#: reason. A file that cannot be read on its own (a damaged header) is left out of the record
#: instead, and only the flight whose window it covers loses its reference.
SHARED = {"toa5_conflicting_duplicates_many", "toa5_off_grid_timestamp"}


@pytest.mark.parametrize("name, fault, status, pattern, counted", CASES, ids=[c[0] for c in CASES])
def test_fault(base, tmp_path, name, fault, status, pattern, counted):
    folder, data0, baseline = base
    case = tmp_path / "camp"
    shutil.copytree(folder, case)
    data = yaml.safe_load(yaml.safe_dump(data0))
    fault(case, data)
    outcome = run_flight(case, data, "s01")
    assert outcome.status == status, (outcome.status, outcome.message or outcome.reason)
    if status == "error":
        assert re.search(pattern, outcome.message), outcome.message
        assert "root:x" not in outcome.message and "/bin/bash" not in outcome.message
    elif status == "unusable":
        assert re.search(pattern, outcome.reason), outcome.reason
    else:
        assert outcome.reason == ""
        for key in counted:
            assert outcome.counts.get(key, 0) > 0, (key, outcome.counts)
        if "mast_n_corrupt_lines" in counted:  # the file and the lines, in the processing log
            assert re.search(r"read: mast30_s01\.dat: \d+ rows, [1-9]\d* corrupt removed.*\(corrupt lines \[\d+",
                             outcome.log), outcome.log
        for key, tol in TOLERANCE.items():
            assert abs(outcome.numbers[key] - baseline["s01"].numbers[key]) <= tol, (key, outcome.numbers[key],
                                                                                     baseline["s01"].numbers[key])
    other = other_flight(case, data)
    if name in SHARED:
        assert other.status == "unusable" and other.reason == outcome.reason
        assert other.numbers["lag_sonic_ins_s"] == baseline["s02"].numbers["lag_sonic_ins_s"]
    else:
        assert other.status == "ok" and other.numbers == baseline["s02"].numbers


def test_corpus_size():
    """At least 40 faults, each with its own expected outcome."""
    assert len(CASES) + len(MANIFEST_CASES) + 4 >= 40  # + the failing write, the killed write, the fit, the lock
    assert {c[2] for c in CASES} == {"ok", "unusable", "error"}


# ----------------------------------------------------------------------------- hostile manifests


def _virtual(data: dict) -> dict:
    return {**data, "simulation": {"seed": 1, "payload_flights": {}}}


MANIFEST_CASES: list[tuple[str, Callable[[dict], dict], str, str]] = [
    ("name_dotdot", lambda d: {**d, "name": ".."}, "name", r"'\.\.' is not valid: expected .*not starting with '\.'"),
    ("name_hidden", lambda d: {**d, "name": ".results"}, "name", r"is not valid"),
    ("name_with_slash", lambda d: {**d, "name": "a/b"}, "name", r"is not valid"),
    ("virtual_path_escapes", lambda d: _virtual(_set_sonic(d, "../../../../x/s01_sonic.csv")),
     "payload_flights[0].sonic.file", r"leaves results/<name>/L0/"),
    ("virtual_path_absolute", lambda d: _virtual(_set_sonic(d, "/tmp/x/s01_sonic.csv")),
     "payload_flights[0].sonic.file", r"absolute path '/tmp/x/s01_sonic\.csv' in a virtual campaign"),
    ("virtual_mast_glob_escapes", lambda d: _virtual(_set_mast(d, "../../mast30_*.dat")),
     "masts[0].sonics[0].files[0]", r"leaves results/<name>/L0/"),
    ("path_control_character", lambda d: _set_sonic(d, "flights/s01/so\x07nic.csv"), "payload_flights[0].sonic.file",
     r"control character"),
    ("flight_id_dotdot", lambda d: _set_flight_id(d, ".."), "payload_flights[0].id", r"is not valid"),
    ("measured_file_missing", lambda d: _set_sonic(d, "flights/s01/nothere.csv"), "payload_flights[0].sonic.file",
     r"file 'flights/s01/nothere\.csv' does not exist"),
    ("unknown_reference", lambda d: _set_reference(d, "mast99"), "payload_flights[0].reference",
     r"unknown mast sonic id 'mast99'"),
    ("window_end_before_start", lambda d: _set_window(d, "2023-08-21T14:13:00Z", "2023-08-21T14:05:00Z"),
     "payload_flights[0].window.end", r"is not after start"),
]


def _set_sonic(d: dict, path: str) -> dict:
    d["payload_flights"][0]["sonic"]["file"] = path
    return d


def _set_mast(d: dict, pattern: str) -> dict:
    d["masts"][0]["sonics"][0]["files"] = [pattern]
    return d


def _set_flight_id(d: dict, fid: str) -> dict:
    d["payload_flights"][0]["id"] = fid
    return d


def _set_reference(d: dict, ref: str) -> dict:
    d["payload_flights"][0]["reference"] = ref
    return d


def _set_window(d: dict, start: str, end: str) -> dict:
    d["payload_flights"][0]["window"] = {"start": start, "end": end}
    return d


@pytest.mark.parametrize("name, edit, key, pattern", MANIFEST_CASES, ids=[c[0] for c in MANIFEST_CASES])
def test_hostile_manifest(base, tmp_path, name, edit, key, pattern):
    """validate-campaign (the CLI) rejects the manifest naming the key path; nothing is written."""
    folder, data0, _ = base
    data = edit(yaml.safe_load(yaml.safe_dump(data0)))
    path = folder / f"hostile_{name}.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    before = sorted(p for p in folder.rglob("*"))
    try:
        with pytest.raises(ManifestError) as info:
            load_campaign(path)
        assert info.value.key_path == key, str(info.value)
        assert re.search(pattern, info.value.what), info.value.what
        proc = subprocess.run([str(BIN / "dronewind"), "validate-campaign", str(path)], capture_output=True,
                              text=True, check=False, env=os.environ)
        assert proc.returncode != 0 and f"[{key}]" in proc.stderr + proc.stdout
        assert sorted(p for p in folder.rglob("*")) == before
        assert not (folder.parent / "x").exists() and not Path("/tmp/x/s01_sonic.csv").exists()
    finally:
        path.unlink()


# ----------------------------------------------------------------------------- failing and killed writes


_FAILING_WRITE = """
import resource, signal, sys
from dronewind.steps.payload import payload_l1
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
resource.setrlimit(resource.RLIMIT_FSIZE, (200_000, 200_000))  # a disk that fills up after 200 kB
sonic, ins, out = sys.argv[1:4]
try:
    payload_l1(sonic, ins, out + "/s01_sonic.nc", out + "/s01_ins.nc", campaign="faultcamp", flight_id="s01",
               site={"latitude": 43.1, "longitude": 0.36}, target_height_m=30, despike={"window_s": 10, "n_mad": 7},
               simulated=True)
except OSError as exc:
    print("OSError:", exc)
    sys.exit(3)
"""


def test_full_disk_leaves_no_partial_file(base, tmp_path):
    """A write that fails (file-size limit: a full disk) raises, leaves the old file and no temporary file."""
    folder, _, _ = base
    out = tmp_path / "L1"
    out.mkdir()
    (out / "s01_sonic.nc").write_bytes(b"previous version")
    proc = subprocess.run([sys.executable, "-c", _FAILING_WRITE, str(sonic_path(folder)), str(ins_path(folder)),
                           str(out)], capture_output=True, text=True, check=False, env=os.environ, timeout=300)
    assert proc.returncode == 3, proc.stdout + proc.stderr
    assert re.search(r"OSError: .*s01_sonic\.nc: could not write the NetCDF file .*disk full", proc.stdout), proc.stdout
    assert (out / "s01_sonic.nc").read_bytes() == b"previous version"
    assert sorted(p.name for p in out.iterdir()) == ["s01_sonic.nc"]


_SLOW_WRITE = """
import sys, numpy as np, xarray as xr
from dronewind.core.cf import write_netcdf
n = 40_000_000
ds = xr.Dataset({"w": ("time", np.random.default_rng(1).normal(size=n), {"units": "m s-1",
                 "standard_name": "upward_air_velocity"})},
                coords={"time": ("time", np.datetime64("2023-08-21T14:00", "ns")
                                 + np.arange(n).astype("timedelta64[ms]"))})
print("writing", flush=True)
write_netcdf(ds, sys.argv[1], title="t", summary="s", processing_level="L1", history="h", station_id="x")
print("done", flush=True)
"""


def test_job_killed_mid_write_leaves_old_file(tmp_path):
    """kill -9 while a NetCDF is being written: the destination keeps its previous content."""
    out = tmp_path / "product.nc"
    out.write_bytes(b"previous version")
    proc = subprocess.Popen([sys.executable, "-c", _SLOW_WRITE, str(out)], stdout=subprocess.PIPE, text=True,
                            env=os.environ)
    assert proc.stdout is not None and proc.stdout.readline().strip() == "writing"
    deadline = time.time() + 120
    while time.time() < deadline and not list(tmp_path.glob(".product.nc.*.tmp")):
        time.sleep(0.05)
    assert list(tmp_path.glob(".product.nc.*.tmp")), "the temporary file never appeared"
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=60)
    assert out.read_bytes() == b"previous version"


def test_spectral_fit_that_does_not_converge_is_flagged():
    """A spectrum the model cannot fit returns NaN coefficients with a reason (never raises)."""
    f = np.logspace(-3, 0.6, 40)
    flat = np.full_like(f, 1e-9)  # no peak, no inertial subrange
    fit = spectra.fit_spectral_model(f, flat, 30.0, 4.0, 0.3, "blunt")
    nan_fit = spectra.fit_spectral_model(f, np.full_like(f, np.nan), 30.0, 4.0, 0.3, "blunt")
    assert not nan_fit.converged and nan_fit.reason and np.isnan(nan_fit.a)
    assert (not fit.converged and fit.reason) or (fit.converged and fit.b > 0)


# ----------------------------------------------------------------------------- the results lock (library)


def test_lock_taken_released_and_refused(tmp_path):
    folder = tmp_path / "results" / "camp"
    assert acquire_results_lock(folder, REPO) is None
    owner = lock_owner(folder)
    assert owner["pid"] == os.getpid() and owner["host"] == socket.gethostname()
    assert owner["checkout"] == str(REPO)
    # another live process (here: this test's parent) holds it -> refused, naming the owner
    assert release_results_lock(folder)
    assert acquire_results_lock(folder, "/other/checkout", pid=os.getppid()) is None
    with pytest.raises(ResultsLockedError, match=rf"another run is writing this results folder \(pid {os.getppid()} "
                                                 r"on host .*checkout /other/checkout"):
        acquire_results_lock(folder, REPO)
    assert not release_results_lock(folder)  # not ours: left alone
    assert lock_owner(folder)["pid"] == os.getppid()


def test_stale_lock_of_a_dead_run_is_taken_over(tmp_path):
    folder = tmp_path / "camp"
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    acquire_results_lock(folder, "/killed/checkout", pid=dead.pid)
    note = acquire_results_lock(folder, REPO)
    assert note and f"took over the lock of a run that no longer runs (pid {dead.pid}" in note
    assert lock_owner(folder)["pid"] == os.getpid()
    assert release_results_lock(folder) and lock_owner(folder) is None


def test_lock_of_another_host_is_refused(tmp_path):
    folder = tmp_path / "camp"
    folder.mkdir()
    (folder / LOCK_NAME).write_text('{"pid": 1, "host": "elsewhere", "checkout": "/x", "started": "2024"}\n')
    with pytest.raises(ResultsLockedError, match=r"another host .*elsewhere.*delete .*\.dronewind\.lock"):
        acquire_results_lock(folder, REPO)


# ----------------------------------------------------------------------------- workflow level


def snakemake(folder: Path, results: Path, *args: str, env: dict[str, str] | None = None,
              target: tuple[str, ...] | str = ("tables/flight_stats.csv",)) -> subprocess.CompletedProcess:
    """The workflow on ``folder``'s small campaign into ``results`` (dates fixed as the session's runs)."""
    targets = (target,) if isinstance(target, str) else target
    return run_workflow(folder / "smallcamp.yaml", results, folder / "short.yaml", *args, "--",
                        *(str(results / "smallcamp" / t) for t in targets),
                        env={"SOURCE_DATE_EPOCH": SOURCE_DATE_EPOCH, **(env or {})})


@pytest.fixture(scope="module")
def two_runs(small_campaign_run, small_campaign_rerun):
    """One virtual flight processed twice in two results folders of one folder (tests/conftest.py).

    ``results_b``: up to flight_stats.csv and campaign.json; ``results_a``: the whole
    workflow, a superset of those files. Both with the ``date_created`` of
    :data:`tests.conftest.SOURCE_DATE_EPOCH`, as :func:`snakemake` here.
    """
    folder, *_ = small_campaign_run
    assert (folder / "smallcamp.yaml").is_file() and (folder / "short.yaml").is_file()
    return folder


@pytest.mark.slow
def test_identical_runs_in_two_folders_give_identical_files(two_runs):
    """Every file of the second run (up to flight_stats and the campaign record) is byte for byte the first run's.
    """
    a, b = two_runs / "results_b" / "smallcamp", two_runs / "results_a" / "smallcamp"
    files = sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file() and p.parts[len(a.parts)] not in
                   ("logs", "benchmarks"))
    assert any(p.suffix == ".nc" for p in files) and Path("campaign.json") in files
    assert Path("tables/flight_stats.csv") in files and any(p.parts[0] == "L0" for p in files)
    differ = [str(p) for p in files if (a / p).read_bytes() != (b / p).read_bytes()]
    assert differ == []
    # the whole first run made no NetCDF file (L1-L4) that the second, up to flight_stats, did not
    netcdf = sorted(p for p in files if p.suffix == ".nc")
    assert sorted(p.relative_to(b) for p in b.rglob("*.nc")) == netcdf
    assert len(netcdf) >= 8, netcdf  # L1 (sonic, ins, mast), L2 (drone, mast), L3, L4 (drone, mast)
    assert not (a / LOCK_NAME).exists() and not (b / LOCK_NAME).exists()  # released at the end of each run


@pytest.mark.slow
def test_second_run_on_a_locked_folder_stops_and_dry_run_does_not(two_runs, tmp_path):
    results = two_runs / "results_b"
    (results / "smallcamp" / "campaign.json").unlink()
    holder = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)"])
    try:
        acquire_results_lock(results / "smallcamp", "/another/checkout", pid=holder.pid)
        dry = snakemake(two_runs, results, "--dry-run", target="campaign.json")
        assert dry.returncode == 0, dry.stderr[-3000:]
        proc = snakemake(two_runs, results, target="campaign.json")
        assert proc.returncode != 0
        assert f"another run is writing this results folder (pid {holder.pid}" in proc.stderr
        assert "/another/checkout" in proc.stderr
        assert not (results / "smallcamp" / "campaign.json").exists()
    finally:
        holder.kill()
        holder.wait()
    proc = snakemake(two_runs, results, target="campaign.json")  # the holder is gone: stale lock taken over
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert f"took over the lock of a run that no longer runs (pid {holder.pid}" in proc.stderr
    assert (results / "smallcamp" / "campaign.json").exists() and lock_owner(results / "smallcamp") is None


@pytest.mark.slow
def test_killed_run_resumes_with_the_same_command(two_runs):
    """kill -9 of Snakemake during a job; the same command again finishes (no --unlock) and plans nothing more."""
    results = two_runs / "resC"
    cmd = [str(BIN / "snakemake"), "--cores", "1", "--configfile", "config/config.yaml", str(two_runs / "short.yaml"),
           "--config", f"campaign={two_runs / 'smallcamp.yaml'}", f"results_dir={results}", "--",
           str(results / "smallcamp" / "tables" / "flight_stats.csv")]
    env = {**workflow_env(), "SOURCE_DATE_EPOCH": SOURCE_DATE_EPOCH}
    first = subprocess.Popen(cmd, cwd=REPO, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                             start_new_session=True)
    l1 = results / "smallcamp" / "netcdf" / "L1"
    deadline = time.time() + 300
    while time.time() < deadline and not (l1.exists() and any(l1.iterdir())):
        time.sleep(0.2)
    os.killpg(first.pid, signal.SIGKILL)  # the run and its job, as a kill -9 of the session
    first.wait(timeout=60)
    assert lock_owner(results / "smallcamp")["pid"] == first.pid  # left behind by the killed run
    proc = subprocess.run(cmd, cwd=REPO, env=env, capture_output=True, text=True, timeout=900, check=False)
    assert proc.returncode == 0, proc.stderr[-4000:]
    assert "took over the lock of a run that no longer runs" in proc.stderr
    for rel in ("netcdf/L4/s01_drone.nc", "tables/flight_stats.csv"):
        assert (results / "smallcamp" / rel).read_bytes() == (two_runs / "results_a" / "smallcamp" / rel).read_bytes()
    again = subprocess.run([*cmd[:-2], "--dry-run", "--", cmd[-1]], cwd=REPO, env=env, capture_output=True,
                           text=True, timeout=300, check=False)
    assert "Nothing to be done" in again.stdout + again.stderr


def test_workflow_rejects_a_manifest_writing_outside_results(tmp_path):
    """A virtual campaign whose data path leaves results/<name>/L0 stops before any job, writing nothing."""
    manifest = write_small_campaign(tmp_path, n_flights=1)
    data = yaml.safe_load(manifest.read_text())
    data["payload_flights"][0]["sonic"]["file"] = "../../../../x/s01_sonic.csv"
    manifest.write_text(yaml.safe_dump(data, sort_keys=False))
    (tmp_path / "short.yaml").write_text(SHORT_HOVER)
    proc = snakemake(tmp_path, tmp_path / "results")
    assert proc.returncode != 0
    assert "[payload_flights[0].sonic.file]" in proc.stderr and "leaves results/<name>/L0/" in proc.stderr
    assert not (tmp_path / "results").exists() and not (tmp_path.parent / "x").exists()
