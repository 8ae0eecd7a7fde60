"""Soak: 20 seeded random faults injected into a 6-flight measured campaign, processed in one run.

A 6-flight campaign (8-min hovers an hour apart, one mast sonic with one TOA5 file per
flight) is simulated and declared as measured data. The workflow processes it twice, each
time to the L4 files of every flight (``--keep-going``, so a flight that stops with a named
error does not stop the others):

1. clean;
2. with 20 faults drawn with a fixed seed from the catalogue below and injected into the
   files of flights s01-s04 (s05 and s06 are controls that receive none).

Every flight must then be one of: processed correctly (usable, numbers within tolerance of
the clean run), unusable with its reason (``usable = 0`` in the L2 file), or stopped with a
named error (its job log names file and problem); the control flights' numbers must equal
the clean run's exactly. Writes ``benchmarks/results/soak_faults.json``.

Run from the repository root: ``PYTHONPATH=src .venv/bin/python benchmarks/soak_faults.py``.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from dronewind.core.products import open_product
from dronewind.manifest import load_campaign
from dronewind.steps.payload import simulate_payload, simulation_manifest

REPO = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
SEED = 20240521
N_FAULTS = 20
FLIGHTS = ("s01", "s02", "s03", "s04", "s05", "s06")
FAULTED = FLIGHTS[:4]
NUMBERS = ("U_ms", "sigma_u_ms", "sigma_v_ms", "sigma_w_ms", "uw_m2s2", "wT_Kms")
TOLERANCE = {"U_ms": 0.03, "sigma_u_ms": 0.03, "sigma_v_ms": 0.03, "sigma_w_ms": 0.015, "uw_m2s2": 0.015,
             "wT_Kms": 0.01}
SHORT_HOVER = {"processing": {"hover": {"alt_tol_m": 3.0, "horiz_tol_m": 4.0, "min_duration_s": 300}}}


def campaign(folder: Path) -> Path:
    """The virtual 6-flight campaign (the simulator's settings) in ``folder``."""
    speeds = (4.0, 6.0, 5.0, 7.0, 3.5, 5.5)
    flights, conditions = [], {}
    for k, fid in enumerate(FLIGHTS):
        start = np.datetime64("2023-08-21T09:05:00") + np.timedelta64(k, "h")
        stamp = str(start) + "Z"
        end = str(start + np.timedelta64(8, "m")) + "Z"
        flights.append({"id": fid, "reference": "mast30", "target_height_m": 30,
                        "sonic": {"file": f"flights/{fid}/sonic.csv", "mount": "upside_down"},
                        "ins": {"file": f"flights/{fid}/ins.csv"}, "window": {"start": stamp, "end": end}})
        conditions[fid] = {"mean_speed_ms": speeds[k], "wind_from_deg": 200.0 + 10 * k, "z_over_L": -0.1 - 0.05 * k,
                           "hover_height_m": 28.0}
    data = {"name": "soakcamp", "site": {"name": "P2OA", "latitude": 43.1247, "longitude": 0.3628, "altitude_m": 603},
            "masts": [{"id": "p2oa", "latitude": 43.1247, "longitude": 0.3628,
                       "sonics": [{"id": "mast30", "height_m": 30, "model": "CSAT3", "azimuth_deg": 218.0,
                                   "files": ["mast/mast30_*.dat"]}]}],
            "payload_flights": flights, "simulation": {"seed": 11, "payload_flights": conditions}}
    path = folder / "soakcamp_virtual.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


# ----------------------------------------------------------------------------- faults


def _lines(path: Path) -> list[str]:
    return path.read_text().splitlines()


def _write(path: Path, lines: list[str]) -> None:
    path.write_text("\n".join(lines) + "\n")


def _time(line: str) -> int | None:
    """The rpi_time_us of a payload line, or None for a line an earlier fault corrupted."""
    try:
        return int(line.split(",", 1)[0])
    except ValueError:
        return None


def _rpi_range(path: Path, frac0: float, frac1: float) -> tuple[int, int]:
    """Logger times at two fractions of a payload file's span."""
    times = [t for t in map(_time, _lines(path)[1:]) if t is not None]
    t0, t1 = min(times), max(times)
    return int(t0 + frac0 * (t1 - t0)), int(t0 + frac1 * (t1 - t0))


def _drop_span(path: Path, start_frac: float, seconds: float) -> None:
    a, _ = _rpi_range(path, start_frac, start_frac)
    b = a + int(seconds * 1e6)
    _write(path, [ln for k, ln in enumerate(_lines(path)) if k == 0 or not a <= (_time(ln) or 0) < b])


def _edit(path: Path, column: str, func: Callable[[str], str], every: int = 1, offset: int = 1) -> None:
    lines = _lines(path)
    header = lines[0].split(",")
    if column not in header:
        return  # an earlier fault renamed it
    j = header.index(column)
    for k in range(offset, len(lines), every):
        fields = lines[k].split(",")
        if len(fields) == len(header):
            fields[j] = func(fields[j])
            lines[k] = ",".join(fields)
    _write(path, lines)


def _scale(factor: float) -> Callable[[str], str]:
    def scaled(s: str) -> str:
        try:
            return f"{float(s) * factor:.6g}"
        except ValueError:
            return s
    return scaled


def f_corrupt_lines(d: Path, fid: str, rng: np.random.Generator) -> None:
    p = d / "flights" / fid / "sonic.csv"
    lines = _lines(p)
    for k in rng.choice(np.arange(1, len(lines)), 40, replace=False):
        lines[k] = lines[k][:5] + "?#" + lines[k][7:]
    _write(p, lines)


def f_exact_duplicates(d: Path, fid: str, rng: np.random.Generator) -> None:
    p = d / "flights" / fid / "sonic.csv"
    lines = _lines(p)
    for k in sorted(rng.choice(np.arange(1, len(lines)), 30, replace=False), reverse=True):
        lines.insert(int(k), lines[int(k)])
    _write(p, lines)


def f_conflicting_duplicates(d: Path, fid: str, rng: np.random.Generator) -> None:
    p = d / "flights" / fid / "ins.csv"
    lines = _lines(p)
    for k in sorted(rng.choice(np.arange(2000, len(lines)), 5, replace=False), reverse=True):
        fields = lines[int(k)].split(",")
        fields[-1] = "99.9"
        lines.insert(int(k) + 1, ",".join(fields))
    _write(p, lines)


def f_swapped_rows(d: Path, fid: str, rng: np.random.Generator) -> None:
    p = d / "flights" / fid / "sonic.csv"
    lines = _lines(p)
    for k in rng.choice(np.arange(1, len(lines) - 1), 20, replace=False):
        lines[k], lines[k + 1] = lines[k + 1], lines[k]
    _write(p, lines)


def f_spikes(d: Path, fid: str, rng: np.random.Generator) -> None:
    _edit(d / "flights" / fid / "sonic.csv", "w_ms", lambda s: "14.0", every=2000, offset=int(rng.integers(1, 2000)))


def f_sonic_gap_5s(d: Path, fid: str, rng: np.random.Generator) -> None:
    _drop_span(d / "flights" / fid / "sonic.csv", float(rng.uniform(0.3, 0.6)), 5.0)


def f_yaw_0_360(d: Path, fid: str, rng: np.random.Generator) -> None:
    def wrapped(s: str) -> str:
        try:
            return f"{float(s) % 360:.4f}"
        except ValueError:
            return s
    _edit(d / "flights" / fid / "ins.csv", "yaw_deg", wrapped)


def f_mast_nan_diag(d: Path, fid: str, rng: np.random.Generator) -> None:
    p = d / "mast" / f"mast30_{fid}.dat"
    lines = _lines(p)
    for k in rng.choice(np.arange(4, len(lines)), 15, replace=False):
        fields = lines[k].split(",")
        fields[int(rng.choice([2, 6]))] = '"NAN"' if rng.random() < 0.5 else "4096"
        lines[k] = ",".join(fields)
    _write(p, lines)


def f_sonic_cut(d: Path, fid: str, rng: np.random.Generator) -> None:
    p = d / "flights" / fid / "sonic.csv"
    lines = _lines(p)
    _write(p, lines[: int(len(lines) * rng.uniform(0.45, 0.6))])


def f_sonic_gap_40s(d: Path, fid: str, rng: np.random.Generator) -> None:
    _drop_span(d / "flights" / fid / "sonic.csv", float(rng.uniform(0.35, 0.55)), 40.0)


def f_ins_hole_120s(d: Path, fid: str, rng: np.random.Generator) -> None:
    _drop_span(d / "flights" / fid / "ins.csv", float(rng.uniform(0.35, 0.5)), 120.0)


def f_altitude_feet(d: Path, fid: str, rng: np.random.Generator) -> None:
    _edit(d / "flights" / fid / "ins.csv", "alt_m", _scale(3.28084))


def f_velocity_kmh(d: Path, fid: str, rng: np.random.Generator) -> None:
    for col in ("vel_n_ms", "vel_e_ms", "vel_d_ms"):
        _edit(d / "flights" / fid / "ins.csv", col, _scale(3.6))


def f_clock_back(d: Path, fid: str, rng: np.random.Generator) -> None:
    p = d / "flights" / fid / "sonic.csv"
    lines = _lines(p)
    for k in range(len(lines) // 2, len(lines)):
        t = _time(lines[k])
        if t is not None:
            lines[k] = f"{t - 20_000_000},{lines[k].split(',', 1)[1]}"
    _write(p, lines)


def f_header_changed(d: Path, fid: str, rng: np.random.Generator) -> None:
    p = d / "flights" / fid / "sonic.csv"
    lines = _lines(p)
    lines[0] = lines[0].replace("t_sonic_c", "t_sonic_k")
    _write(p, lines)


def f_no_gnss_time(d: Path, fid: str, rng: np.random.Generator) -> None:
    _edit(d / "flights" / fid / "ins.csv", "time_valid", lambda s: "0")
    _edit(d / "flights" / fid / "ins.csv", "utc", lambda s: "")


#: name -> (fault, kind): "benign" faults must be read correctly, the others must end in an
#: unusable flight or a named error.
CATALOGUE: dict[str, tuple[Callable[[Path, str, np.random.Generator], None], str]] = {
    "corrupt_lines": (f_corrupt_lines, "benign"), "exact_duplicates": (f_exact_duplicates, "benign"),
    "conflicting_duplicates": (f_conflicting_duplicates, "benign"), "swapped_rows": (f_swapped_rows, "benign"),
    "spikes": (f_spikes, "benign"), "sonic_gap_5s": (f_sonic_gap_5s, "benign"), "yaw_0_360": (f_yaw_0_360, "benign"),
    "mast_nan_diag": (f_mast_nan_diag, "benign"), "sonic_cut": (f_sonic_cut, "harmful"),
    "sonic_gap_40s": (f_sonic_gap_40s, "harmful"), "ins_hole_120s": (f_ins_hole_120s, "harmful"),
    "altitude_feet": (f_altitude_feet, "harmful"), "velocity_kmh": (f_velocity_kmh, "harmful"),
    "clock_back": (f_clock_back, "harmful"), "header_changed": (f_header_changed, "harmful"),
    "no_gnss_time": (f_no_gnss_time, "harmful"),
}


# ----------------------------------------------------------------------------- runs and outcomes


def run(manifest: Path, results: Path, config: Path) -> float:
    targets = [str(results / "soakcamp" / "netcdf" / "L4" / f"{fid}_{s}.nc") for fid in FLIGHTS
               for s in ("drone", "mast")]
    t0 = time.perf_counter()
    subprocess.run([str(BIN / "snakemake"), "--cores", "2", "--keep-going", "--configfile", "config/config.yaml",
                    str(config), "--config", f"campaign={manifest}", f"results_dir={results}", "--", *targets],
                   cwd=REPO, capture_output=True, text=True, check=False,
                   env={**os.environ, "PATH": f"{BIN}:{os.environ.get('PATH', '')}", "SOURCE_DATE_EPOCH": "1700000000"})
    return time.perf_counter() - t0


def _named_error(logs: Path, fid: str) -> str:
    """The error a flight's jobs stopped with (last error line of its logs), or ''."""
    for rule in ("payload_chain", "mast_l1", "l3", "l4"):  # l4: one job for every flight (all.log)
        for log in [*sorted((logs / rule).glob(f"{fid}*.log")), *sorted((logs / rule).glob("mast30*.log")),
                    *sorted((logs / rule).glob("all.log"))]:
            hits = [ln for ln in log.read_text(errors="replace").splitlines()
                    if re.search(r"(InputError|ClockJumpError|ManifestError|ProcessingError|Error):", ln)]
            if hits:
                return hits[-1].strip()
    return ""


def outcome(results: Path, fid: str) -> dict[str, Any]:
    base = results / "soakcamp"
    l4 = base / "netcdf" / "L4" / f"{fid}_drone.nc"
    if not l4.exists():
        return {"status": "error", "error": _named_error(base / "logs", fid)}
    l2 = open_product(base / "netcdf" / "L2" / f"{fid}_drone.nc")
    ds = open_product(l4)
    usable = int(l2.attrs["usable"])
    return {"status": "ok" if usable else "unusable", "reason": str(l2.attrs.get("unusable_reason", "")),
            "numbers": {k: float(ds[k]) for k in NUMBERS}, "lag_sonic_ins_s": float(l2.attrs["lag_sonic_ins_s"])}


def main() -> int:
    work = Path(tempfile.mkdtemp(prefix="soak_faults_"))
    sim = load_campaign(campaign(work))
    data_dir = work / "data"
    t0 = time.perf_counter()
    for fid in FLIGHTS:
        simulate_payload(simulation_manifest(sim.data), fid, work, data_dir)
    measured = {k: v for k, v in sim.data.items() if k != "simulation"}
    (data_dir / "soakcamp.yaml").write_text(yaml.safe_dump(measured, sort_keys=False))
    config = work / "short.yaml"
    config.write_text(yaml.safe_dump(SHORT_HOVER))
    simulate_s = time.perf_counter() - t0

    faulted_dir = work / "faulted"
    shutil.copytree(data_dir, faulted_dir)
    rng = np.random.default_rng(SEED)
    names = sorted(CATALOGUE)
    injected: dict[str, list[str]] = {fid: [] for fid in FLIGHTS}
    for _ in range(N_FAULTS):
        name = str(rng.choice(names))
        fid = str(rng.choice(FAULTED))
        CATALOGUE[name][0](faulted_dir, fid, rng)
        injected[fid].append(name)

    clean_s = run(data_dir / "soakcamp.yaml", work / "results_clean", config)
    fault_s = run(faulted_dir / "soakcamp.yaml", work / "results_faulted", config)

    flights = {}
    failures = []
    for fid in FLIGHTS:
        clean = outcome(work / "results_clean", fid)
        got = outcome(work / "results_faulted", fid)
        kinds = {CATALOGUE[n][1] for n in injected[fid]}
        entry = {"faults": injected[fid], "outcome": got["status"], "reason": got.get("reason") or got.get("error", "")}
        if clean["status"] != "ok":
            failures.append(f"{fid}: the clean run is not ok ({clean})")
        if not injected[fid]:
            entry["verdict"] = "control, numbers identical" if got.get("numbers") == clean.get("numbers") else \
                "CONTROL CHANGED"
        elif got["status"] == "ok":
            diffs = {k: abs(got["numbers"][k] - clean["numbers"][k]) for k in NUMBERS}
            entry["max_abs_diff"] = {k: round(v, 6) for k, v in diffs.items()}
            close = all(diffs[k] <= TOLERANCE[k] for k in NUMBERS)
            entry["verdict"] = ("processed correctly" if close and kinds == {"benign"} else
                                "ACCEPTED A HARMFUL FAULT" if "harmful" in kinds else "NUMBERS CHANGED")
        elif got["status"] == "unusable":
            entry["verdict"] = "unusable with its reason" if got["reason"] else "UNUSABLE WITHOUT REASON"
        else:
            entry["verdict"] = "named error" if got["error"] else "FAILED WITHOUT A NAMED ERROR"
        if entry["verdict"].isupper() or entry["verdict"].startswith(("CONTROL", "ACCEPTED", "NUMBERS", "UNUSABLE",
                                                                      "FAILED")):
            failures.append(f"{fid}: {entry['verdict']}")
        flights[fid] = entry

    summary = {
        "seed": SEED, "n_faults": N_FAULTS, "flights": list(FLIGHTS), "faulted_flights": list(FAULTED),
        "per_flight": flights,
        "counts": {v: sum(1 for e in flights.values() if e["verdict"] == v)
                   for v in sorted({e["verdict"] for e in flights.values()})},
        "all_pass": not failures, "failures": failures,
        "seconds": {"simulate": round(simulate_s, 1), "clean_run": round(clean_s, 1), "faulted_run": round(fault_s, 1)},
        "tolerance": TOLERANCE,
    }
    out = REPO / "benchmarks" / "results" / "soak_faults.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(summary, indent=2) + "\n")
    print(json.dumps(summary, indent=2))
    shutil.rmtree(work, ignore_errors=True)
    return 0 if not failures else 1


if __name__ == "__main__":
    import argparse

    argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="example: .venv/bin/python benchmarks/soak_faults.py   (about 2-3 min on 2 cores)",
    ).parse_args()
    sys.exit(main())
