"""Cost and block statistics of the tower records: the dronewind workflow, then EC-PeT.

A benchmark, not a timed test. For each record (``gold``: the AmeriFlux open-path gold files,
96 half-hours of a Gill WindMaster Pro at 10 Hz; ``fluxpart``: 2 x 15 min of a CSAT3 at 20 Hz):

1. the dronewind workflow on the shipped campaign (``config/campaigns/real_ameriflux_gold.yaml``
   with 30-min blocks, ``config/campaigns/real_fluxpart.yaml`` with ``config/blocks_15min.yaml``)
   into a fresh temporary results folder, ``snakemake --cores N`` (``--cores``, default 1);
2. then the same record through EC-PeT's Python API (``ecpet.ecengine.process``, all stages,
   one process: ``nproc = 1``) in a child process, with the settings of dronewind's
   configuration where EC-PeT has them: the block length, double rotation (yaw and pitch, no
   roll, no planar fit), linear detrending, MAD despiking at 7 MADs; EC-PeT's own corrections
   (frequency response, sonic temperature, Webb, ...) are left at its defaults;
3. per block, U, sigma_w, u* and w'T' of the two tools: the median (and maximum) relative
   difference |EC-PeT - dronewind| / |dronewind| over the blocks both report.

Both tools run with one BLAS/OpenMP thread (``--blas-threads``, default 1): on a loaded
machine idle BLAS threads spin and count as CPU time. Each run is measured as wall seconds,
CPU seconds (user + system of the child and all its descendants, from ``os.wait4``) and
peak RSS (``ru_maxrss`` from the same call: the largest single process among them, not a
sum). The two tools run one after the other on the same
machine; the load average before and after each run is recorded.

EC-PeT reads Campbell TOA5 only. The fluxpart files are TOA5 and go in as they are
(linked into the run folder). The gold files (``G<DDD><HHMM>.RAW.gz``) are converted to TOA5
first, into the temporary folder (not timed with EC-PeT; its cost is reported apart): w, u,
v and sonic temperature as logged (Gill axes, right-handed; double rotation removes the
sonic's azimuth), the half hour's start converted from local standard time (UTC-8) to UTC,
year 2000, as dronewind's reader does; sample i of a file is stamped start + (i + 1) / 10 s
(TOA5's end-of-scan stamp), because EC-PeT's blocks hold (begin, end] while dronewind puts
sample i at start + i / 10 s in [begin, end): both tools then see the same samples in each
block. The gold record has no pressure: a constant 997.9 hPa (standard atmosphere at the
nominal 129 m) is given as EC-PeT's slow reference pressure; for fluxpart the slow pressure
is the fast ``press`` column's per-minute mean (EC-PeT uses the fast column). The gold record's
two days (April and June) are two EC-PeT runs (one per day, inside the one timed child),
because EC-PeT processes one contiguous period.

Install EC-PeT without its GUI dependencies (pinned in workflow/envs/requirements.txt)::

    .venv/bin/pip install --no-deps ecpet==2.1.0b1

Examples (from the repository root)::

    PYTHONPATH=src nice -n 10 .venv/bin/python benchmarks/bench_ecpet.py \\
        --out benchmarks/results/ecpet_compare.json
    PYTHONPATH=src nice -n 10 .venv/bin/python benchmarks/bench_ecpet.py --records fluxpart --cores 2
    PYTHONPATH=src .venv/bin/python benchmarks/bench_ecpet.py --records gold --keep /tmp/ecpet_gold
"""

from __future__ import annotations

import argparse
import gzip
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from bench_common import print_and_write
from dronewind import datasets

ROOT = Path(__file__).resolve().parents[1]
GOLD_DIR = datasets.data_dir() / "ameriflux_gold_openpath"  # the real records (dronewind.datasets)
FLUXPART_DIR = datasets.data_dir() / "fluxpart_csat3_toa5"

#: The two records: shipped campaign, extra config files, block length and sampling rate.
RECORDS: dict[str, dict[str, Any]] = {
    "gold": {
        "lat_lon": "38.4067 -120.9507",
        "campaign": "config/campaigns/real_ameriflux_gold.yaml",
        "configfiles": [],
        "block_s": 1800,
        "fs_hz": 10.0,
        "sonic": "GillSolent",
    },
    "fluxpart": {
        "lat_lon": "50.0 0.0",  # not documented (the campaign's 0/0 are placeholders): EC-PeT's own fallback
        "campaign": "config/campaigns/real_fluxpart.yaml",
        "configfiles": ["config/config.yaml", "config/blocks_15min.yaml"],
        "block_s": 900,
        "fs_hz": 20.0,
        "sonic": "CSATSonic",
    },
}

#: EC-PeT device codes of ``SonCal.QQType`` (``ecpet.ecutils.APPARATUS_TYPES``).
SONIC_CODE = {"CSATSonic": 1, "GillSolent": 11}

#: Quantities compared: dronewind's block_stats.csv column -> EC-PeT interval column.
QUANTITIES = {"U_ms": "vectwind", "sigma_w_ms": "std_uz", "ustar_ms": "ustar", "wT_Kms": "cov_uz_ts"}

#: Thread-count variables set for both tools (``--blas-threads``).
BLAS_THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")

GOLD_NAME = re.compile(r"G(\d{3})(\d{2})(\d{2})\.RAW\.gz$")
GOLD_YEAR = 2000
GOLD_UTC_OFFSET_H = -8
GOLD_PRESSURE_HPA = 997.9


# ---------------------------------------------------------------- measuring


def _load() -> list[float]:
    return [round(x, 2) for x in os.getloadavg()]


def measure(cmd: list[str], log: Path, cwd: Path | None = None, env: dict[str, str] | None = None) -> dict[str, Any]:
    """Run ``cmd``; wall s, CPU s (user + sys of it and its reaped descendants) and peak RSS [MB]."""
    load_before = _load()
    with open(log, "w") as out:
        t0 = time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT, cwd=cwd, env=env)
        _, status, ru = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    return {
        "command": " ".join(cmd),
        "returncode": proc.returncode,
        "wall_s": round(wall, 2),
        "cpu_s": round(ru.ru_utime + ru.ru_stime, 2),
        "user_s": round(ru.ru_utime, 2),
        "sys_s": round(ru.ru_stime, 2),
        "peak_rss_mb": round(ru.ru_maxrss / 1024.0, 1),  # Linux: kB
        "load_before": load_before,
        "load_after": _load(),
        "log": str(log),
    }


# ---------------------------------------------------------------- dronewind


def run_dronewind(name: str, work: Path, cores: int) -> tuple[dict[str, Any], pd.DataFrame | None]:
    rec = RECORDS[name]
    results = work / "dronewind_results"
    snakemake = str(Path(sys.executable).with_name("snakemake"))
    cmd = [snakemake, "--cores", str(cores)]
    if rec["configfiles"]:
        cmd += ["--configfile", *rec["configfiles"]]
    cmd += ["--config", f"campaign={ROOT / rec['campaign']}", f"results_dir={results}"]
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    m = measure(cmd, work / "dronewind.log", cwd=ROOT, env=env)
    m["cores"] = cores
    stats = sorted(results.glob("*/tables/block_stats.csv"))
    return m, (pd.read_csv(stats[0]) if m["returncode"] == 0 and stats else None)


# ---------------------------------------------------------------- EC-PeT input


def _toa5_header(names: list[str], units: list[str], station: str, table: str) -> str:
    q = lambda xs: ",".join(f'"{x}"' for x in xs)  # noqa: E731
    return (
        "\n".join(
            [
                q(["TOA5", station, "converted", "0", "none", "bench_ecpet.py", "0", table]),
                q(["TIMESTAMP", "RECORD", *names]),
                q(["TS", "RN", *units]),
                q(["", "", *["Smp"] * len(names)]),
            ]
        )
        + "\n"
    )


def _write_toa5(
    path: Path, times: pd.DatetimeIndex, cols: dict[str, np.ndarray], units: list[str], table: str, fmt: str
) -> None:
    stamps = times.strftime("%Y-%m-%d %H:%M:%S.%f").str.slice(0, 23)
    body = pd.DataFrame({"TIMESTAMP": stamps, "RECORD": np.arange(len(times)), **cols})
    with open(path, "w") as f:
        f.write(_toa5_header(list(cols), units, "dronewind_bench", table))
        body.to_csv(f, header=False, index=False, quoting=0, float_format=fmt)
    # quote the time stamps as a logger does
    text = path.read_text().splitlines(keepends=True)
    path.write_text("".join(text[:4]) + "".join(f'"{ln[:23]}"{ln[23:]}' for ln in text[4:]))


def _write_slow(path: Path, first: pd.Timestamp, last: pd.Timestamp, pressure_hpa: np.ndarray | float) -> None:
    """One-minute slow records (reference pressure [hPa]) covering first..last."""
    times = pd.date_range(first.floor("min"), last.ceil("min"), freq="1min")
    p = (
        np.broadcast_to(np.asarray(pressure_hpa, dtype=float), times.shape)
        if np.ndim(pressure_hpa) == 0
        else np.asarray(pressure_hpa, dtype=float)
    )
    _write_toa5(path, times, {"Pref": np.asarray(p)}, ["hPa"], "rpv", "%.2f")


def prepare_gold(run_dir: Path) -> list[dict[str, Any]]:
    """Gold .RAW.gz -> TOA5 (one file per half hour), one segment (raw folder) per file day."""
    files = sorted(p for p in GOLD_DIR.glob("G*.RAW.gz") if GOLD_NAME.search(p.name))
    segments: dict[str, list[pd.Timestamp]] = {}
    for p in files:
        doy, hh, mm = (int(x) for x in GOLD_NAME.search(p.name).groups())  # type: ignore[union-attr]
        start = (
            datetime(GOLD_YEAR, 1, 1, tzinfo=UTC)
            + timedelta(days=doy - 1, hours=hh, minutes=mm)
            - timedelta(hours=GOLD_UTC_OFFSET_H)
        )
        with gzip.open(p, "rt") as f:
            a = pd.read_csv(f, header=None, usecols=[0, 1, 2, 3], dtype=float).to_numpy()
        n = len(a)
        times = pd.DatetimeIndex(
            pd.Timestamp(start).tz_localize(None)
            + pd.to_timedelta((np.arange(n) + 1) / RECORDS["gold"]["fs_hz"], unit="s")
        )
        seg = f"day{doy:03d}"
        d = run_dir / seg / "raw"
        d.mkdir(parents=True, exist_ok=True)
        _write_toa5(
            d / f"TOA5_gold.ts_{p.name[:-7]}.dat",
            times,
            {"Ux": a[:, 1], "Uy": a[:, 2], "Uz": a[:, 0], "Ts": a[:, 3]},
            ["m/s", "m/s", "m/s", "C"],
            "ts",
            "%.3f",
        )
        segments.setdefault(seg, []).extend([times[0], times[-1]])
    out = []
    for seg, ts in segments.items():
        _write_slow(run_dir / seg / "raw" / "TOA5_gold.rpv.dat", min(ts), max(ts), GOLD_PRESSURE_HPA)
        out.append(
            {
                "name": seg,
                "first": str(min(ts)),
                "last": str(max(ts)),
                "raw_dir": str(run_dir / seg / "raw"),
                "columns": {"U": "Ux:m/s", "V": "Uy:m/s", "W": "Uz:m/s", "Tsonic": "Ts:C"},
            }
        )
    return out


def prepare_fluxpart(run_dir: Path) -> list[dict[str, Any]]:
    """Link the TOA5 files; a slow file with the per-minute mean of the fast pressure."""
    d = run_dir / "all" / "raw"
    d.mkdir(parents=True, exist_ok=True)
    frames = []
    for p in sorted(FLUXPART_DIR.glob("TOA5_*.dat")):
        (d / p.name).symlink_to(p)
        frames.append(pd.read_csv(p, skiprows=[0, 2, 3], usecols=["TIMESTAMP", "press"]))
    fast = pd.concat(frames)
    fast = fast.set_index(pd.to_datetime(fast["TIMESTAMP"], format="ISO8601"))["press"]
    per_min = fast.resample("1min", closed="right", label="right").mean()
    times = pd.date_range(fast.index[0].floor("min"), fast.index[-1].ceil("min"), freq="1min")
    p_hpa = per_min.reindex(times).ffill().bfill().to_numpy() * 10.0  # kPa -> hPa
    _write_slow(d / "TOA5_fluxpart.rpv.dat", times[0], times[-1], p_hpa)
    # CSAT3 TOA5 layout: Ux Uy Uz co2 h2o Ts press diag_csat (EC-PeT's default columns)
    return [
        {
            "name": "all",
            "first": str(fast.index[0]),
            "last": str(fast.index[-1]),
            "raw_dir": str(d),
            "columns": {
                "U": "Ux:m/s",
                "V": "Uy:m/s",
                "W": "Uz:m/s",
                "CO2": "co2:mg/m^3",
                "Humidity": "h2o:g/m^3",
                "Tsonic": "Ts:C",
                "Press": "press:kPa",
                "diag": "diag_csat:m/s",
            },
        }
    ]


def ecpet_config(name: str, seg: dict[str, Any], seg_dir: Path) -> dict[str, str]:
    """EC-PeT configuration tokens (strings, as in its configuration files)."""
    rec = RECORDS[name]
    conf = {
        "RawDir": seg["raw_dir"],
        # whole blocks from the first to the last sample (EC-PeT's own choice, the minutes of
        # the first and last stamps, would drop a last block that ends short of its end)
        # (quoted: EC-PeT splits an unquoted value at blanks)
        "DateBegin": pd.Timestamp(seg["first"]).floor(f"{rec['block_s']}s").strftime('"%Y-%m-%d %H:%M"'),
        "DateEnd": pd.Timestamp(seg["last"]).ceil(f"{rec['block_s']}s").strftime('"%Y-%m-%d %H:%M"'),
        "RawFormat": "toa5",
        "RawFastData": "*.ts*",
        "RawSlowData": "*.rpv*",
        "AvgInterval": str(rec["block_s"]),
        "DatDir": str(seg_dir / "work"),
        "OutDir": str(seg_dir / "out"),
        "nproc": "1",
        "Par.FREQ": f"{rec['fs_hz']:g}",
        "InstLatLon": rec["lat_lon"],  # EC-PeT's post-processing QC needs it (Coriolis parameter)
        # double rotation, no planar fit; linear detrending (dronewind's defaults)
        "Par.DoYaw": "T",
        "Par.DoPitch": "T",
        "Par.DoRoll": "F",
        "Par.DoPF": "F",
        "Par.DoTilt": "F",
        "Par.DoDetrend": "T",
        # despiking on: median absolute deviation, dronewind's threshold
        "Despiking": "mad",
        "qcconf.madth": "7.0",
        "SonCal.QQType": str(SONIC_CODE[rec["sonic"]]),
        # slow reference: pressure only
        "slowfmt.Tref_col": "0",
        "slowfmt.RelHum_col": "0",
        "slowfmt.Pref_col": "0",
        "slowfmt.Pref_nam": "Pref:hPa:Smp",
    }
    # columns by name ("<name>:<unit>:<sampling>", EC-PeT's database column names): given by
    # number, EC-PeT 2.1.0b1 stores the resolved names quoted twice and then cannot find them
    # (ecengine.check_raw_columns), and reads a single slow file name as a list of characters
    for var in ("U", "V", "W", "Tsonic", "Tcouple", "Humidity", "CO2", "Press", "diag", "agc"):
        conf[f"fastfmt.{var}_col"] = "0"
        if var in seg["columns"]:
            conf[f"fastfmt.{var}_nam"] = seg["columns"][var] + ":Smp"
    if "Humidity" not in seg["columns"]:
        conf["HygCal.QQType"] = "0"
    if "CO2" not in seg["columns"]:
        conf["Co2Cal.QQType"] = "0"
    return conf


# ---------------------------------------------------------------- EC-PeT child


def _ecpet_setup() -> None:
    import logging

    from ecpet import eclogger

    eclogger.setup_custom_logging()
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")


#: Run-time fixes of EC-PeT 2.1.0b1 (function, wrong text, right text), applied in the child.
ECPET_FIXES = [
    # the pitch rotation of the double rotation reads the mean of a column that does not
    # exist ("KeyError: 'uw'"); the vertical wind is 'uz' everywhere else in ecpack
    ("process_flux_interval", "means['ux'], means['uw']", "means['ux'], means['uz']"),
    # its pitch angle calls numpy.arcin ("AttributeError: module 'numpy' has no attribute 'arcin'")
    ("tilt_mean_vert", "np.arcin(", "np.arcsin("),
]


def _apply_fixes() -> None:
    """Recompile the named EC-PeT functions with the one-token fixes of ECPET_FIXES."""
    import inspect
    import textwrap

    from ecpet import ecpack

    for func, wrong, right in ECPET_FIXES:
        src = textwrap.dedent(inspect.getsource(getattr(ecpack, func)))
        if wrong not in src:
            raise RuntimeError(f"EC-PeT fix not applicable: {wrong!r} not in ecpack.{func}")
        code = compile(src.replace(wrong, right), inspect.getsourcefile(ecpack) or "ecpack", "exec")
        exec(code, ecpack.__dict__)  # noqa: S102 - redefines the function in its own module


def ecpet_child(spec_path: str) -> int:
    """Run EC-PeT on every segment of a spec file (the timed child)."""
    _ecpet_setup()
    from ecpet import ecconfig, ecdb, ecengine

    _apply_fixes()

    for seg in json.loads(Path(spec_path).read_text()):
        for k in ("DatDir", "OutDir"):
            Path(seg["conf"][k]).mkdir(parents=True, exist_ok=True)
        conf = ecconfig.complete(seg["conf"])
        ecdb.dbfile = os.path.join(conf.pull("DatDir"), "database.sqlite")
        ecengine.process(conf, 0)
    return 0


def ecpet_dump(spec_path: str, out_csv: str) -> int:
    """Write the flux-stage intervals of every segment to one CSV (not timed)."""
    _ecpet_setup()
    from ecpet import ecdb

    frames = []
    for seg in json.loads(Path(spec_path).read_text()):
        ecdb.dbfile = os.path.join(seg["conf"]["DatDir"], "database.sqlite")
        df = ecdb.retrieve_df(station_name="post", table_name="intervals")
        df["segment"] = seg["name"]
        frames.append(df)
    pd.concat(frames).to_csv(out_csv, index=False)
    return 0


def run_ecpet(name: str, work: Path, python: str) -> tuple[dict[str, Any], pd.DataFrame | None]:
    run_dir = work / "ecpet"
    run_dir.mkdir()
    t0 = time.perf_counter()
    c0 = time.process_time()
    segments = prepare_gold(run_dir) if name == "gold" else prepare_fluxpart(run_dir)
    prep = {
        "wall_s": round(time.perf_counter() - t0, 2),
        "cpu_s": round(time.process_time() - c0, 2),
        "what": "TOA5 conversion of the .RAW.gz files"
        if name == "gold"
        else "links to the TOA5 files and the slow (pressure) file",
    }
    spec = [{"name": s["name"], "conf": ecpet_config(name, s, run_dir / s["name"])} for s in segments]
    spec_path = run_dir / "spec.json"
    spec_path.write_text(json.dumps(spec, indent=1))
    m = measure([python, __file__, "--ecpet-child", str(spec_path)], work / "ecpet.log", cwd=run_dir)
    m["preparation"] = prep
    m["runtime_fixes"] = [{"function": f"ecpet.ecpack.{f}", "replaced": w, "by": r} for f, w, r in ECPET_FIXES]
    m["segments"] = [s["name"] for s in spec]
    m["config"] = spec[0]["conf"]
    if m["returncode"] != 0:
        m["error"] = (work / "ecpet.log").read_text().strip().splitlines()[-5:]
        return m, None
    out_csv = run_dir / "intervals.csv"
    subprocess.run(
        [python, __file__, "--ecpet-dump", str(spec_path), str(out_csv)], check=True, capture_output=True, cwd=run_dir
    )
    return m, pd.read_csv(out_csv)


# ---------------------------------------------------------------- comparison


def compare(dw: pd.DataFrame, ep: pd.DataFrame) -> dict[str, Any]:
    """Per-block relative differences |EC-PeT - dronewind| / |dronewind| on the usable blocks."""
    d = dw[dw["usable"].astype(str) == "True"].copy()
    d["begin"] = pd.to_datetime(d["start_utc"], utc=True)
    e = ep.copy()
    e["begin"] = pd.to_datetime(e["begin"], utc=True)
    m = d.merge(e, on="begin", how="inner")
    out: dict[str, Any] = {"blocks_dronewind_usable": len(d), "blocks_ecpet": len(e), "blocks_matched": len(m)}
    per_block: dict[str, list[Any]] = {"begin": [t.isoformat() for t in m["begin"]]}
    for q, col in QUANTITIES.items():
        if col not in m:
            out[q] = {"error": f"EC-PeT column {col} missing"}
            continue
        a = m[q].to_numpy(float)
        b = m[col].to_numpy(float)
        ok = np.isfinite(a) & np.isfinite(b) & (a != 0)
        rel = np.abs(b[ok] - a[ok]) / np.abs(a[ok])
        sign = np.sign(b[ok]) == np.sign(a[ok])
        out[q] = {
            "ecpet_column": col,
            "blocks_compared": int(ok.sum()),
            "median_rel_diff": float(np.median(rel)) if ok.any() else None,
            "max_rel_diff": float(np.max(rel)) if ok.any() else None,
            "median_ratio_ecpet_over_dronewind": float(np.median(b[ok] / a[ok])) if ok.any() else None,
            "same_sign_fraction": float(np.mean(sign)) if ok.any() else None,
        }
        per_block[q] = [None if not np.isfinite(x) else float(x) for x in a]
        per_block[col] = [None if not np.isfinite(x) else float(x) for x in b]
    out["per_block"] = per_block
    return out


# ---------------------------------------------------------------- main


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--records", nargs="+", choices=sorted(RECORDS), default=["gold", "fluxpart"])
    ap.add_argument("--cores", type=int, default=1, help="snakemake --cores (default 1)")
    ap.add_argument("--out", type=Path,
        default=Path(__file__).resolve().parent / "results" / "ecpet_compare.json",
        help="write the results as JSON here")
    ap.add_argument(
        "--ecpet-python",
        default=sys.executable,
        help="Python with EC-PeT installed (default: this one; see workflow/envs/ecpet-requirements.txt)",
    )
    ap.add_argument(
        "--blas-threads", type=int, default=1, help="BLAS/OpenMP threads of both tools (default 1; 0: leave as is)"
    )
    ap.add_argument("--keep", type=Path, help="work in this (new) folder and keep it (default: a temporary one)")
    ap.add_argument("--ecpet-child", metavar="SPEC", help=argparse.SUPPRESS)
    ap.add_argument("--ecpet-dump", nargs=2, metavar=("SPEC", "CSV"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.ecpet_child:
        return ecpet_child(args.ecpet_child)
    if args.ecpet_dump:
        return ecpet_dump(*args.ecpet_dump)

    probe = subprocess.run(
        [
            args.ecpet_python,
            "-c",
            "import importlib.metadata as m; "
            "print(*(f'{p}=={m.version(p)}' for p in ('ecpet', 'pandas', 'numpy', 'scipy')))",
        ],
        capture_output=True,
        text=True,
    )
    ecpet_env = probe.stdout.split() if probe.returncode == 0 else [probe.stderr.strip().splitlines()[-1]]
    if args.blas_threads > 0:
        # inherited by both tools' processes: on a loaded machine idle BLAS threads spin and
        # count as CPU time (EC-PeT on fluxpart: 21 s CPU with one thread, 41-290 s with two)
        for var in BLAS_THREAD_VARS:
            os.environ[var] = str(args.blas_threads)
    base = args.keep if args.keep else Path(tempfile.mkdtemp(prefix="bench_ecpet_"))
    base.mkdir(parents=True, exist_ok=True)
    result: dict[str, Any] = {
        "machine": {
            "platform": platform.platform(),
            "python": platform.python_version(),
            "cpus": os.cpu_count(),
            "nice": os.nice(0),
        },
        "blas_threads": {v: os.environ.get(v) for v in BLAS_THREAD_VARS},
        "ecpet_python": args.ecpet_python,
        "ecpet_environment": ecpet_env,
        "snakemake": str(Path(sys.executable).with_name("snakemake")),
        "records": {},
    }
    try:
        for name in args.records:
            work = base / name
            work.mkdir()
            print(f"[{name}] dronewind workflow ...", flush=True)
            dw_m, dw = run_dronewind(name, work, args.cores)
            print(f"[{name}]   {dw_m['wall_s']} s wall, {dw_m['cpu_s']} s CPU, {dw_m['peak_rss_mb']} MB", flush=True)
            print(f"[{name}] EC-PeT ...", flush=True)
            ep_m, ep = run_ecpet(name, work, args.ecpet_python)
            print(
                f"[{name}]   {ep_m['wall_s']} s wall, {ep_m['cpu_s']} s CPU, {ep_m['peak_rss_mb']} MB"
                f" (rc {ep_m['returncode']})",
                flush=True,
            )
            rec: dict[str, Any] = {"dronewind": dw_m, "ecpet": ep_m}
            if dw is not None and ep is not None:
                rec["comparison"] = compare(dw, ep)
                for q in QUANTITIES:
                    c = rec["comparison"][q]
                    print(
                        f"[{name}]   {q}: {c.get('blocks_compared')} blocks, median rel. diff "
                        f"{c.get('median_rel_diff')}",
                        flush=True,
                    )
            result["records"][name] = rec
    finally:
        if not args.keep:
            shutil.rmtree(base, ignore_errors=True)
    print_and_write(result, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
