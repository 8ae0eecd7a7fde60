"""CPU seconds of workflow jobs, each in a fresh interpreter, for one or more source trees.

Snakemake's benchmark files sample a job's CPU time every 0.5 s, so jobs of one or two
seconds are measured coarsely. This script measures them exactly (``getrusage`` of the child
process: interpreter start, imports and work):

* ``imports``: the imports of every ``scripts/*.py`` with the two modules Snakemake's script
  preamble imports (minus that preamble alone, measured on its own);
* ``jobs``: the quadrotor jobs of three flights of the default campaign (simulate, L1,
  windows, L2) and the payload L2 of three flights, run by calling the step functions with
  the inputs of a finished run (outputs go to a temporary folder).

Each number is the minimum over ``--repeat`` runs (the least disturbed by other work on the
machine). Example (``/tmp/base`` an export of an older commit)::

    PYTHONPATH=src .venv/bin/python benchmarks/bench_job_cpu.py --trees before=/tmp/base after=. \\
        --results results/mosai2023 --out benchmarks/results/job_cpu.json
"""

from __future__ import annotations

import argparse
import ast
import json
import os
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

from bench_common import print_and_write

REPO = Path(__file__).resolve().parents[1]
PREAMBLE = "import pickle\nfrom snakemake.logging import logger\nfrom snakemake.iocontainers import Snakemake\n"

#: One job of a step, run in a fresh interpreter: argv = results folder, output folder, flight id.
JOB = r'''
import sys
from pathlib import Path
from dronewind.manifest import default_config, load_campaign
base, out, fid, kind = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3], sys.argv[4]
campaign = load_campaign(sys.argv[5])
site, cfg = campaign.data["site"], default_config()
if kind == "payload_l2":
    from dronewind.steps.payload import payload_l2
    p = cfg["processing"]
    flight = next(f for f in campaign.data["payload_flights"] if f["id"] == fid)
    payload_l2(base / f"netcdf/L1/{fid}_sonic.nc", base / f"netcdf/L1/{fid}_ins.nc", out / "l2.nc",
               campaign=campaign.name, flight_id=fid, flight=flight, site=site, sonic_ins_lag=p["sonic_ins_lag"],
               hover=p["hover"], max_missing_fraction=p["max_missing_fraction"])
    raise SystemExit
from dronewind.steps import quadrotor as q
flight = campaign.quadrotor_flight(fid)
uavs = [u["id"] for u in flight["uavs"]]
l1 = [str(base / "netcdf/L1/quadrotor" / f"{fid}_{u}.nc") for u in uavs]
qc = cfg["quadrotor"]
if kind == "simulate":
    sim = campaign.data["simulation"]
    simulation = {"quadrotor": sim.get("quadrotor") or {}, "quadrotor_flights": {fid: sim["quadrotor_flights"][fid]},
                  "mechanisms": [m for m in sim.get("mechanisms") or []
                                 if m.get("flights") is None or fid in m["flights"]], "seed": sim["seed"]}
    q.simulate_quadrotor(flight, simulation, site, out / "L0")
elif kind == "l1":
    q.quadrotor_l1_flight(campaign.name, fid, uavs, [str(base / "L0" / u["file"]) for u in flight["uavs"]], site,
                          [str(out / f"{u}_l1.nc") for u in uavs], simulated=True)
elif kind == "windows":
    q.quadrotor_windows(flight, dict(zip(uavs, l1, strict=True)), base / "L0" / flight["reference"],
                        site["altitude_m"], qc["block_s"], qc["hover"], out / "w.csv", out / "b.csv", out / "p.csv")
elif kind == "l2":
    q.quadrotor_l2_flight(campaign.name, fid, uavs, l1, base / "tables/quadrotor_calibration.csv",
                          base / "quadrotor/calibration.json", site, [str(out / f"{u}_l2.nc") for u in uavs],
                          qc["average_s"], qc["hover"])
'''


def child_cpu_s(argv: list[str], src: Path, repeat: int) -> float:
    """Least CPU time [s] (user + system) of ``python argv`` with ``PYTHONPATH=src`` over ``repeat`` runs."""
    best = float("inf")
    for _ in range(repeat):
        r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run([sys.executable, *argv], env=dict(os.environ, PYTHONPATH=str(src)), check=True,
                       capture_output=True, cwd=REPO)
        r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        best = min(best, r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime)
    return best


def script_imports(tree: Path, repeat: int) -> dict[str, float]:
    """Import CPU [s] of every ``scripts/*.py`` of a tree, beyond Snakemake's preamble."""
    src = tree / "src"
    base = child_cpu_s(["-c", PREAMBLE], src, repeat)
    out = {"_preamble": round(base, 3)}
    for script in sorted((tree / "scripts").glob("*.py")):
        body = ast.parse(script.read_text()).body
        imports = "\n".join(ast.unparse(n) for n in body if isinstance(n, ast.Import | ast.ImportFrom))
        out[script.stem] = round(child_cpu_s(["-c", PREAMBLE + imports], src, repeat) - base, 3)
    return out


def job_cpu(tree: Path, results: Path, repeat: int) -> dict[str, float]:
    """Mean over three flights of the CPU [s] of each kind of job."""
    manifest = tree / "config" / "campaigns" / "mosai2023.yaml"
    out = {}
    with tempfile.TemporaryDirectory(prefix="dronewind_jobcpu_") as tmp:
        for kind in ("simulate", "l1", "windows", "l2", "payload_l2"):
            flights = ("s01", "s02", "s03") if kind == "payload_l2" else ("f01", "f02", "f03")
            values = [child_cpu_s(["-c", JOB, str(results), tmp, fid, kind, str(manifest)], tree / "src", repeat)
                      for fid in flights]
            out[kind] = round(sum(values) / len(values), 3)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--trees", nargs="+", required=True, help="NAME=PATH of source trees (repository roots)")
    parser.add_argument("--results", type=Path, required=True,
                        help="results/<campaign> folder of a finished default run (the jobs' inputs)")
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    result: dict[str, dict] = {"imports": {}, "jobs": {}}
    for spec in args.trees:
        name, path = spec.split("=", 1)
        tree = Path(path).resolve()
        result["jobs"][name] = job_cpu(tree, args.results.resolve(), args.repeat)
        result["imports"][name] = script_imports(tree, args.repeat)
        print(name, json.dumps(result["jobs"][name]), flush=True)
    print_and_write(result, args.out)


if __name__ == "__main__":
    main()
