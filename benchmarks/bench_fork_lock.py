"""HDF5 file locking and a process that forks while it writes NetCDF files (why tests/conftest.py turns locking off).

One process writes a small NetCDF file atomically (:func:`dronewind.core.cf.write_netcdf`'s
temporary file and rename) and reads it back (:func:`dronewind.core.products.open_product`),
over and over, while a second thread of the same process starts short subprocesses, as the
test run's background threads start Snakemake runs and poll SLURM. A child holds a copy
of every open descriptor, and so HDF5's lock on the file being written, until it closes them
before exec; on a busy machine that takes long enough for the read to find the file locked
("NetCDF: HDF error"). Each mode runs in a fresh interpreter (HDF5 reads
``HDF5_USE_FILE_LOCKING`` when it starts), with ``--busy`` CPU-bound processes beside it.
Example::

    .venv/bin/python benchmarks/bench_fork_lock.py --n 3000 --busy 3 --out benchmarks/results/fork_lock.json
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

from bench_common import print_and_write

REPO = Path(__file__).resolve().parents[1]

_CHILD = """
import sys, tempfile, threading, subprocess
from pathlib import Path
import numpy as np, xarray as xr
from dronewind.core.cf import write_netcdf
from dronewind.core.products import open_product
stop = False
def forker():
    while not stop:
        subprocess.run(["true"], check=False)
threading.Thread(target=forker, daemon=True).start()
folder = Path(tempfile.mkdtemp(prefix="dronewind_forklock_"))
ds = xr.Dataset({"w": ("time", np.random.default_rng(0).normal(size=20000), {"units": "m s-1"})})
failures = 0
n = int(sys.argv[1])
for i in range(n):
    path = folder / f"f{i}.nc"
    write_netcdf(ds, path, title="t", summary="s", processing_level="L1", history="h", station_id="x",
                 feature_type=None)
    try:
        open_product(path)
    except Exception:
        failures += 1
    path.unlink()
stop = True
print(failures)
"""


def run_mode(locking: bool, n: int, busy: int) -> dict:
    """Failures of ``n`` write-then-read cycles with HDF5 file locking on or off."""
    env = {**os.environ, "PYTHONPATH": str(REPO / "src")}
    env.pop("HDF5_USE_FILE_LOCKING", None)
    if not locking:
        env["HDF5_USE_FILE_LOCKING"] = "FALSE"
    load = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(busy)]
    try:
        proc = subprocess.run([sys.executable, "-c", _CHILD, str(n)], capture_output=True, text=True, env=env,
                              check=True, timeout=3600)
    finally:
        for p in load:
            p.kill()
            p.wait()
    failures = int(proc.stdout.strip().splitlines()[-1])
    return {"hdf5_file_locking": locking, "cycles": n, "busy_processes": busy, "failed_reads": failures}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--n", type=int, default=3000, help="write-then-read cycles per mode")
    parser.add_argument("--busy", type=int, default=3, help="CPU-bound processes running beside it")
    parser.add_argument("--out", type=Path,
        default=Path(__file__).resolve().parent / "results" / "fork_lock.json",
        help="JSON file to write")
    args = parser.parse_args()
    result = {"runs": [run_mode(locking, args.n, args.busy) for locking in (True, False)]}
    print_and_write(result, args.out)


if __name__ == "__main__":
    main()
