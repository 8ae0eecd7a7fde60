"""Throughput of the raw-text parsers: payload sonic CSV, INS CSV, Campbell TOA5, the quadrotor CSV, AmeriFlux gold.

Plain script; run from the repository root, for example::

    PYTHONPATH=src .venv/bin/python benchmarks/bench_parsing.py --out benchmarks/results/parsing_after.json

Inputs:

* payload: a synthetic 30-min flight written by :mod:`dronewind.simulate.writers`
  (sonic 32 Hz, INS 50 Hz with the first 20 s before GNSS time, i.e. empty ``utc``);
* TOA5: the real fluxpart CSAT3 files (``../shared/data/fluxpart_csat3_toa5``), or a
  synthetic 30-min 20 Hz file written by :func:`dronewind.simulate.writers.write_toa5` when
  they are absent;
* quadrotor: a 30-min 10 Hz UAV log in the quadrotor simulator's format (values rounded as
  a logger writes them, printed by ``pandas.DataFrame.to_csv``);
* AmeriFlux gold: the 96 real half-hour files (``../shared/data/ameriflux_gold_openpath``,
  gzip, 10 Hz), when present.

Measured (best of ``--repeat`` runs, seconds and rows per second):

* ``parse``: text to column arrays with the corrupt lines separated
  (``dronewind.payload.reader._parse_csv``; for TOA5 ``read_toa5``, which is only that);
* ``read``: the public readers ``read_sonic_csv`` / ``read_ins_csv`` (parse plus duplicate
  removal and sorting by logger time) and ``read_quadrotor_csv`` (parse, sorting and
  duplicate removal by time, the Dataset); for the gold files ``parse`` is the reader's
  decompression and text-to-numbers step (``_read_gold_values``) of all 96 files, ``read``
  is ``read_ameriflux_gold`` of all of them (plus the QC, despiking and the Dataset).
"""

from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SHARED_TOA5 = ROOT.parent / "shared" / "data" / "fluxpart_csat3_toa5"
SHARED_GOLD = ROOT.parent / "shared" / "data" / "ameriflux_gold_openpath"


def write_flight(folder: Path, duration_s: float = 1800.0) -> tuple[Path, Path]:
    """Write the sonic and INS CSV of a synthetic flight of `duration_s` [s]; return their paths."""
    from dronewind.simulate.writers import write_ins_csv, write_payload_sonic_csv

    rng = np.random.default_rng(20240521)
    rpi0 = 5_000_000_000
    n_s = int(duration_s * 32)
    rpi_s = rpi0 + np.rint(np.arange(n_s) / 32 * 1e6).astype(np.int64) + rng.integers(-300, 300, n_s)
    sonic = write_payload_sonic_csv(folder / "sonic.csv", rpi_s, rng.normal(5, .5, n_s), rng.normal(0, .5, n_s),
                                    rng.normal(0, .3, n_s), rng.normal(20, .2, n_s))
    n_i = int(duration_s * 50)
    rpi_i = rpi0 + np.rint(np.arange(n_i) / 50 * 1e6).astype(np.int64) + rng.integers(-200, 200, n_i)
    utc = np.datetime64("2023-08-21T14:00:00", "us") + np.rint((rpi_i - rpi0) * (1 + 30e-6)).astype(
        np.int64).astype("timedelta64[us]")
    valid = (np.arange(n_i) >= 20 * 50).astype(np.int64)  # 20 s before GNSS time: empty utc
    ins = write_ins_csv(folder / "ins.csv", rpi_i, utc, valid, np.ones(n_i, np.int64),
                        43.1247 + rng.normal(0, 1e-5, n_i), 0.3628 + rng.normal(0, 1e-5, n_i),
                        633.0 + rng.normal(0, .2, n_i), rng.normal(0, .3, n_i), rng.normal(0, .3, n_i),
                        rng.normal(0, .1, n_i), rng.normal(0, 2, n_i), rng.normal(0, 2, n_i),
                        170 + rng.normal(0, 3, n_i))
    return sonic, ins


def write_toa5_file(folder: Path, duration_s: float = 1800.0) -> Path:
    """A synthetic 20 Hz CSAT3 TOA5 file of `duration_s` [s]."""
    from dronewind.simulate.writers import write_toa5

    rng = np.random.default_rng(7)
    n = int(duration_s * 20)
    t = np.datetime64("2023-08-21T14:00:00", "ns") + (np.arange(n) * 50_000_000).astype("timedelta64[ns]")
    return write_toa5(folder / "TOA5_sim.dat", t, np.arange(n), rng.normal(2, 1, n), rng.normal(0, 1, n),
                      rng.normal(0, .3, n), rng.normal(20, .3, n), np.zeros(n, np.int64))


def best_time(fn: Callable[[], Any], repeat: int) -> float:
    """Shortest wall time of `repeat` calls of `fn` [s]."""
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def n_data_lines(path: Path, n_header: int) -> int:
    """Non-blank lines after the `n_header` header lines."""
    lines = path.read_bytes().splitlines()[n_header:]
    return sum(1 for ln in lines if ln.strip())


def entry(rows: int, seconds: float, files: list[Path]) -> dict[str, Any]:
    """One result: rows, seconds, rows/s and input bytes."""
    return {"rows": rows, "seconds": round(seconds, 5), "rows_per_s": round(rows / seconds, 1),
            "bytes": int(sum(f.stat().st_size for f in files))}


def write_quadrotor_log(folder: Path, duration_s: float = 1800.0) -> Path:
    """A 10 Hz UAV log in the quadrotor simulator's format (:mod:`dronewind.simulate.quadrotor`)."""
    import pandas as pd

    rng = np.random.default_rng(3)
    n = int(duration_s * 10)
    t = np.datetime64("2020-07-24T10:00:00", "ms") + (np.arange(n) * 100).astype("timedelta64[ms]")
    frame = pd.DataFrame({
        "time_utc": np.char.add(np.datetime_as_string(t, unit="ms").astype(str), "Z"),
        "roll_deg": np.round(rng.normal(0, 3, n), 4), "pitch_deg": np.round(rng.normal(-5, 2, n), 4),
        "yaw_deg": np.round(rng.uniform(0, 360, n), 4), "vel_n_ms": np.round(rng.normal(0, .2, n), 4),
        "vel_e_ms": np.round(rng.normal(0, .2, n), 4), "vel_d_ms": np.round(rng.normal(0, .1, n), 4),
        "lat_deg": np.round(52.1 + rng.normal(0, 1e-5, n), 8), "lon_deg": np.round(14.1 + rng.normal(0, 1e-5, n), 8),
        "alt_m": np.round(150 + rng.normal(0, .5, n), 3),
    })
    path = folder / "q01.csv"
    path.write_text(frame.to_csv(index=False))
    return path


def run(repeat: int, toa5_files: list[Path] | None, tmp: Path) -> dict[str, Any]:
    """Time every parser; return the results dict."""
    from dronewind.mast.toa5 import read_toa5
    from dronewind.payload import columns, reader

    sonic, ins = write_flight(tmp)
    kinds_s = {"rpi_time_us": "int", "u_ms": "float", "v_ms": "float", "w_ms": "float", "t_sonic_c": "float"}
    kinds_i = {c: "float" for c in columns.INS_COLUMNS}
    kinds_i.update(rpi_time_us="int", utc="utc", time_valid="flag", ekf_valid="int")
    n_s, n_i = n_data_lines(sonic, 1), n_data_lines(ins, 1)
    out: dict[str, Any] = {}
    out["sonic_csv"] = {
        "parse": entry(n_s, best_time(lambda: reader._parse_csv(sonic, columns.SONIC_COLUMNS, kinds_s, 0.05), repeat),
                       [sonic]),
        "read": entry(n_s, best_time(lambda: reader.read_sonic_csv(sonic), repeat), [sonic]),
    }
    out["ins_csv"] = {
        "parse": entry(n_i, best_time(lambda: reader._parse_csv(ins, columns.INS_COLUMNS, kinds_i, 0.05), repeat),
                       [ins]),
        "read": entry(n_i, best_time(lambda: reader.read_ins_csv(ins), repeat), [ins]),
    }
    if not toa5_files:
        toa5_files = [write_toa5_file(tmp)]
    n_t = sum(n_data_lines(f, 4) for f in toa5_files)
    out["toa5"] = {
        "parse": entry(n_t, best_time(lambda: [read_toa5(f) for f in toa5_files], repeat), toa5_files),
        "files": [f.name for f in toa5_files],
    }
    from dronewind.quadrotor.io import read_quadrotor_csv

    quad = write_quadrotor_log(tmp)
    out["quadrotor_csv"] = {"read": entry(n_data_lines(quad, 1), best_time(lambda: read_quadrotor_csv(quad), repeat),
                                          [quad])}
    gold = sorted(SHARED_GOLD.glob("G*.RAW.gz"))
    if gold:
        from dronewind.mast import ameriflux

        n_g = sum(ameriflux._read_gold_values(f, 0.05)[0].shape[0] for f in gold)
        out["ameriflux_gold"] = {
            "parse": entry(n_g, best_time(lambda: [ameriflux._read_gold_values(f, 0.05) for f in gold], repeat), gold),
            "read": entry(n_g, best_time(lambda: [ameriflux.read_ameriflux_gold(f) for f in gold], repeat), gold),
            "files": len(gold),
        }
    return out


def git_commit() -> str:
    """The checked-out commit of the tree the parsers are imported from (or "unknown")."""
    import dronewind

    src = Path(dronewind.__file__).resolve().parents[2]
    try:
        return subprocess.run(["git", "-C", str(src), "rev-parse", "--short", "HEAD"], check=True,
                              capture_output=True, text=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def main(argv: list[str] | None = None) -> int:
    """Command line entry point."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=3, help="runs per measurement; the best is kept (default 3)")
    ap.add_argument("--toa5", type=Path, nargs="*", default=None,
                    help="TOA5 files to read (default: the fluxpart files in ../shared/data, or a synthetic one)")
    ap.add_argument("--out", type=Path, default=None, help="write the results as JSON to this file")
    args = ap.parse_args(argv)
    toa5 = args.toa5 if args.toa5 is not None else sorted(SHARED_TOA5.glob("*.dat"))
    import numpy
    import pandas

    import dronewind

    with tempfile.TemporaryDirectory() as tmp:
        res = run(args.repeat, toa5, Path(tmp))
    doc = {"commit": git_commit(), "dronewind_src": str(Path(dronewind.__file__).resolve().parent),
           "python": platform.python_version(), "numpy": numpy.__version__, "pandas": pandas.__version__,
           "repeat": args.repeat, "results": res}
    for fmt in ("sonic_csv", "ins_csv", "toa5", "quadrotor_csv", "ameriflux_gold"):
        for stage in ("parse", "read"):
            if stage in res.get(fmt, {}):
                e = res[fmt][stage]
                print(f"{fmt:14s} {stage:5s} {e['rows']:7d} rows {e['seconds']:8.4f} s {e['rows_per_s']:12.0f} rows/s")
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(doc, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
