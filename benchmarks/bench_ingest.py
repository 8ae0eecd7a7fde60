"""Throughput of the L0 -> L1 readers (plain script, prints numbers).

Run: ``.venv/bin/python benchmarks/bench_ingest.py`` from the repository root.

* payload: a synthetic 20-min flight, 32 Hz sonic + 50 Hz INS CSV written to a temp dir;
  rows/s of ``read_sonic_csv``, ``ins_l1`` and the full ``payload_sonic_l1``;
* TOA5: rows/s of ``mast_l1`` on the real fluxpart files (../shared/data), or on a
  synthetic 30-min 20 Hz file if they are absent;
* AmeriFlux: seconds and peak RSS for the 96 gold files read block by block with
  ``read_ameriflux_gold_blocks``; each part runs in its own process so that the peak RSS
  (resource.getrusage ru_maxrss) belongs to that part alone.
"""

from __future__ import annotations

import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def write_flight(folder: Path, duration_s: float = 1200.0) -> tuple[Path, Path, int, int]:
    rng = np.random.default_rng(0)
    rpi0 = 5_000_000_000
    utc0 = np.datetime64("2023-08-21T14:00:00", "us")
    n_s = int(duration_s * 32)
    rpi_s = rpi0 + np.rint(np.arange(n_s) / 32 * 1e6).astype(np.int64)
    rpi_s += rng.integers(-300, 300, n_s)  # logging jitter [us]
    son = np.column_stack([rng.normal(5, .5, n_s), rng.normal(0, .5, n_s),
                           rng.normal(0, .3, n_s), rng.normal(20, .2, n_s)])  # fmt: skip
    sonic = folder / "sonic.csv"
    with sonic.open("w") as fh:
        fh.write("rpi_time_us,u_ms,v_ms,w_ms,t_sonic_c\n")
        for r, v in zip(rpi_s, son, strict=True):
            fh.write(f"{r},{v[0]:.3f},{v[1]:.3f},{v[2]:.3f},{v[3]:.3f}\n")
    n_i = int(duration_s * 50)
    rpi_i = rpi0 + np.rint(np.arange(n_i) / 50 * 1e6).astype(np.int64)
    rpi_i += rng.integers(-200, 200, n_i)
    utc = utc0 + np.rint((rpi_i - rpi0) * (1 + 30e-6)).astype(np.int64).astype("timedelta64[us]")
    utc_s = np.datetime_as_string(utc, unit="us")
    ins = folder / "ins.csv"
    with ins.open("w") as fh:
        fh.write("rpi_time_us,utc,time_valid,ekf_valid,lat_deg,lon_deg,alt_m,vel_n_ms,"
                 "vel_e_ms,vel_d_ms,roll_deg,pitch_deg,yaw_deg\n")  # fmt: skip
        for i in range(n_i):
            fh.write(f"{rpi_i[i]},{utc_s[i]}Z,1,1,43.1247,0.3628,633.0,{rng.normal(0, .3):.4f},"
                     f"{rng.normal(0, .3):.4f},{rng.normal(0, .1):.4f},{rng.normal(0, 2):.3f},"
                     f"{rng.normal(0, 2):.3f},{170 + rng.normal(0, 3):.3f}\n")  # fmt: skip
    return sonic, ins, n_s, n_i


def bench_payload() -> None:
    from dronewind.payload.ins import ins_l1
    from dronewind.payload.reader import read_sonic_csv
    from dronewind.payload.sonic import payload_sonic_l1

    with tempfile.TemporaryDirectory() as tmp:
        sonic, ins, n_s, n_i = write_flight(Path(tmp))
        t = time.perf_counter()
        read_sonic_csv(sonic)
        dt_read = time.perf_counter() - t
        t = time.perf_counter()
        ins_l1(ins)
        dt_ins = time.perf_counter() - t
        t = time.perf_counter()
        payload_sonic_l1(sonic, ins)
        dt_all = time.perf_counter() - t
    print(f"payload  20-min flight: sonic {n_s} rows, INS {n_i} rows")
    print(f"  read_sonic_csv   {dt_read:6.3f} s  {n_s / dt_read:10.0f} rows/s")
    print(f"  ins_l1           {dt_ins:6.3f} s  {n_i / dt_ins:10.0f} rows/s")
    print(f"  payload_sonic_l1 {dt_all:6.3f} s  {(n_s + n_i) / dt_all:10.0f} rows/s "
          "(sonic + INS rows, incl. QC and clock fit)")  # fmt: skip
    print(f"  peak RSS {peak_rss_mb():.0f} MB")


def bench_toa5() -> None:
    from dronewind.mast.level1 import mast_l1

    files = sorted((SHARED / "fluxpart_csat3_toa5").glob("TOA5_*.dat"))
    with tempfile.TemporaryDirectory() as tmp:
        if not files:  # synthetic 30-min, 20 Hz file
            rng = np.random.default_rng(1)
            p = Path(tmp) / "m.dat"
            t0 = np.datetime64("2023-08-21T14:00:00.000", "ms")
            with p.open("w") as fh:
                fh.write('"TOA5","x"\n"TIMESTAMP","RECORD","Ux","Uy","Uz","Ts","diag_csat"\n'
                         '"TS","RN","m/s","m/s","m/s","C",""\n"","","Smp","Smp","Smp","Smp",'
                         '"Smp"\n')  # fmt: skip
                for i in range(36000):
                    ts = str(t0 + np.timedelta64(50 * i, "ms")).replace("T", " ")
                    fh.write(f'"{ts}",{i},{rng.normal(3, .5):.4f},{rng.normal(0, .5):.4f},'
                             f'{rng.normal(0, .2):.4f},{rng.normal(20, .1):.4f},0\n')  # fmt: skip
            files = [p]
            label = "synthetic 30-min 20 Hz file"
        else:
            label = "real fluxpart files (2 x 15 min, 20 Hz)"
        t = time.perf_counter()
        ds = mast_l1(files, 0.0, 7.11, "bench")
        dt = time.perf_counter() - t
    n = ds.sizes["time"]
    print(f"TOA5     {label}: {n} rows in {dt:.3f} s = {n / dt:.0f} rows/s; "
          f"peak RSS {peak_rss_mb():.0f} MB")


def bench_ameriflux() -> None:
    from dronewind.mast.ameriflux import read_ameriflux_gold_blocks

    folder = SHARED / "ameriflux_gold_openpath"
    files = sorted(folder.glob("G*.RAW.gz"))
    if not files:
        print(f"AmeriFlux: files not found in {folder}; skipped")
        return
    rss0 = peak_rss_mb()
    t = time.perf_counter()
    n = 0
    for ds in read_ameriflux_gold_blocks(files):
        n += ds.sizes["time"]
    dt = time.perf_counter() - t
    print(f"AmeriFlux {len(files)} files, {n} rows: {dt:.2f} s ({n / dt:.0f} rows/s); peak RSS "
          f"{peak_rss_mb():.0f} MB (after imports {rss0:.0f} MB)")  # fmt: skip


PARTS = {"payload": bench_payload, "toa5": bench_toa5, "ameriflux": bench_ameriflux}

if __name__ == "__main__":
    if len(sys.argv) > 1:
        import xarray as xr

        import dronewind.mast.toa5  # noqa: F401  (imports before measuring)
        import dronewind.payload.ins  # noqa: F401
        import dronewind.payload.sonic  # noqa: F401

        xr.Dataset({"x": ("t", np.zeros(2))})  # xarray's lazy one-time setup, not measured

        PARTS[sys.argv[1]]()
    else:
        for part in PARTS:
            subprocess.run([sys.executable, __file__, part], check=True)
