"""Long mast records in bounded memory: N days of 20 Hz CSAT3 TOA5 through L1 to half-hour L4.

Run from the repository root::

    .venv/bin/python benchmarks/bench_long_record.py --days 3 10 30 --out benchmarks/results/long_record.json

For the largest N it writes N daily TOA5 files (Ux, Uy, Uz, Ts, diag_csat; 1 728 000 rows,
about 104 MB each) of synthetic AR(1) turbulence with
:func:`dronewind.simulate.writers.write_toa5` into a temporary folder; the generation is
not timed. Then for every N it runs :func:`dronewind.compare.long_record.process_long_record`
on the first N files in a fresh child process (L1 NetCDF per day, 30-min blocks,
``block_stats.csv``) and reports the child's wall and CPU seconds, its peak resident
memory (``ru_maxrss`` of the child alone, and ``VmHWM`` from /proc as a check) and the
throughput in samples per second. The parent imports nothing heavy and generates the files
in another child: Linux starts a child's ``ru_maxrss`` from the RSS of the process it was
forked from, so a parent holding generated data would inflate it. The temporary folder
(TOA5 and L1 files) is deleted at the end.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from bench_common import machine, print_and_write

FS_HZ = 20.0
SONIC = {"id": "csat3_30m", "height_m": 30.0, "azimuth_deg": 218.0}
T0_ISO = "2023-08-01T00:00:00"


def _ar1(rng: Any, n: int, mean: float, sigma: float, tau_s: float) -> Any:
    """AR(1) series of standard deviation ``sigma`` and integral time scale ``tau_s`` [s]."""
    import numpy as np
    import scipy.signal

    phi = float(np.exp(-1.0 / (tau_s * FS_HZ)))
    e = rng.normal(0.0, sigma * np.sqrt(1.0 - phi**2), n)
    return mean + scipy.signal.lfilter([1.0], [1.0, -phi], e)


def write_days(folder: Path, n_days: int, seed: int = 20260801) -> list[Path]:
    """One TOA5 file per UTC day: AR(1) Ux, Uy, Uz, Ts with a daily cycle of the mean wind."""
    import numpy as np

    from dronewind.simulate.writers import write_toa5

    t0 = np.datetime64(T0_ISO, "ns")
    rng = np.random.default_rng(seed)
    n = int(86400 * FS_HZ)
    files = []
    for d in range(n_days):
        k = d * n + np.arange(n)
        t = t0 + (k * int(1e9 / FS_HZ)).astype("timedelta64[ns]")
        hour = (np.arange(n) / FS_HZ / 3600.0) % 24.0
        cycle = np.sin(2 * np.pi * (hour - 9.0) / 24.0)
        ux = _ar1(rng, n, -4.0 - 1.5 * cycle, 0.9, 8.0)
        uy = _ar1(rng, n, 1.0 + 0.5 * d % 3, 0.7, 8.0)
        uz = _ar1(rng, n, 0.0, 0.35, 1.0)
        ts = _ar1(rng, n, 20.0 + 4.0 * cycle, 0.25, 10.0)
        files.append(write_toa5(folder / f"mast30_{str(t0 + np.timedelta64(d, 'D'))[:10]}.dat", t, k, ux, uy,
                                uz, ts, np.zeros(n, dtype=np.int64)))
    return files


def child(files: list[str], out_dir: str, n_workers: int) -> None:
    """Process the files (in this process) and print the measurements as JSON."""
    import logging

    from dronewind.compare.long_record import process_long_record

    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s", stream=sys.stderr)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    res = process_long_record(files, out_dir, SONIC, {}, record="bench", n_workers=n_workers)
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    print(json.dumps({"wall_s": wall, "cpu_s": cpu,
                      "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
                      "vm_hwm_mb": _vm_hwm_mb(),
                      "n_samples": res.n_samples, "n_blocks": res.n_blocks, "n_usable": res.n_usable}))


def _vm_hwm_mb() -> float:
    """Peak resident memory of this process image from /proc (VmHWM) [MB]; NaN where absent."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return float(line.split()[1]) / 1024.0
    except OSError:
        pass
    return float("nan")


def run(days: list[int], n_workers: int, keep: Path | None, toa5_dir: Path | None = None) -> dict:
    """Generate max(days) daily files once, process the first N in a child process for each N."""
    tmp = Path(tempfile.mkdtemp(prefix="bench_long_record_", dir=keep))
    results = []
    try:
        g0 = time.perf_counter()
        # generated in a child too: this parent stays small, so that the processing children's
        # ru_maxrss (which Linux starts from the RSS of the process they were forked from) is theirs
        if toa5_dir is not None:  # files of an earlier --generate: reused, not deleted
            files = sorted(toa5_dir.glob("mast30_*.dat"))[:max(days)]
        else:
            gen = subprocess.run([sys.executable, __file__, "--generate", str(max(days)), "--out-dir",
                                  str(tmp / "toa5")], check=True, stdout=subprocess.PIPE, text=True)
            files = [Path(f) for f in json.loads(gen.stdout.strip().splitlines()[-1])]
        gen_s = time.perf_counter() - g0
        size_gb = sum(f.stat().st_size for f in files) / 1e9
        print(f"generated {len(files)} daily TOA5 files ({size_gb:.2f} GB) in {gen_s:.0f} s", file=sys.stderr)
        for n in days:
            out = tmp / f"out_{n}"
            cmd = [sys.executable, __file__, "--child", "--workers", str(n_workers), "--out-dir", str(out),
                   *[str(f) for f in files[:n]]]
            proc = subprocess.run(cmd, check=True, stdout=subprocess.PIPE, text=True, env=os.environ.copy())
            r = json.loads(proc.stdout.strip().splitlines()[-1])
            r.update(days=n, n_files=n, samples_per_s=r["n_samples"] / r["wall_s"],
                     toa5_gb=sum(f.stat().st_size for f in files[:n]) / 1e9)
            results.append(r)
            print(f"{n:3d} days: {r['wall_s']:7.1f} s wall, {r['cpu_s']:7.1f} s CPU, peak RSS "
                  f"{r['peak_rss_mb']:6.0f} MB, {r['samples_per_s']:9.0f} samples/s, {r['n_blocks']} blocks",
                  file=sys.stderr)
            shutil.rmtree(out)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    first, last = results[0], results[-1]
    per_day = [r["wall_s"] / r["days"] for r in results]
    return {
        "what": "N days of 20 Hz CSAT3 TOA5 (one file per day) -> L1 NetCDF per day -> 30-min block L4 -> "
                "block_stats.csv, dronewind.compare.long_record.process_long_record in a child process",
        "command": "benchmarks/bench_long_record.py --days " + " ".join(map(str, days)) + f" --workers {n_workers}",
        "machine": machine(),
        "n_workers": n_workers, "generation_s": gen_s, "results": results,
        "wall_s_per_day": per_day,
        "linearity": {"wall_per_day_ratio_last_to_first": per_day[-1] / per_day[0],
                      "peak_rss_ratio_last_to_first": last["peak_rss_mb"] / first["peak_rss_mb"]},
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--days", type=int, nargs="+", default=[3, 10, 30], help="record lengths [days] (default 3 10 30)")
    ap.add_argument("--workers", type=int, default=1, help="dask tasks at once (default 1)")
    ap.add_argument("--out", type=Path,
        default=Path(__file__).resolve().parent / "results" / "long_record.json",
        help="write the results as JSON here")
    ap.add_argument("--tmp", type=Path, help="folder for the temporary files (default: the system's)")
    ap.add_argument("--toa5-dir", type=Path, help="reuse the daily files of an earlier run (python "
                    "benchmarks/bench_long_record.py --generate N --out-dir DIR) instead of generating them")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--generate", type=int, help="only write N daily files into --out-dir and exit")
    ap.add_argument("--out-dir", help="folder of --generate")
    ap.add_argument("files", nargs="*", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        child(args.files, args.out_dir, args.workers)
        return 0
    if args.generate:
        print(json.dumps([str(f) for f in write_days(Path(args.out_dir), args.generate)]))
        return 0
    report = run(sorted(args.days), args.workers, args.tmp, args.toa5_dir)
    print_and_write(report, args.out, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
