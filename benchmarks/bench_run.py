"""Wall time of whole workflow runs and their CPU time per stage.

Two runs, each into a fresh results folder, on the cores given (default 2):

* ``default``: ``snakemake --cores 2`` on the embedded default campaign, as ``make run``
  does (everything: simulation, chains, quadrotor fleet, tunnel, diagnosis, published
  numbers, figures, report);
* ``measured6``: a 6-flight campaign of 20-minute hovers, simulated first (not timed) and
  then declared as measured data (no ``simulation:`` section), run to everything the
  workflow makes for a measured campaign (chain, tables, figures, diagnosis, report).

The CPU seconds per stage and rule come from the rules' benchmark files (:mod:`bench_workflow_rules`),
beside those of the jobs' logs (each job's process, read when it ends) and of all processes. Examples::

    .venv/bin/python benchmarks/bench_run.py default --out benchmarks/results/run_default.json
    .venv/bin/python benchmarks/bench_run.py measured6 --out benchmarks/results/run_measured6.json
    .venv/bin/python benchmarks/bench_run.py default --config diagnosis="{probe_jobs: mechanism}"
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_common import git_commit, print_and_write, reference_workload_s  # noqa: E402
from bench_workflow_rules import collect  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
FLIGHTS = ("m01", "m02", "m03", "m04", "m05", "m06")


def measured_campaign(folder: Path) -> Path:
    """Simulate a 6-flight campaign into ``folder`` and write it as a measured manifest."""
    from dronewind.steps.payload import simulate_payload, simulation_manifest

    speeds = (4.0, 6.0, 5.0, 7.0, 3.5, 5.5)
    flights, conditions = [], {}
    for k, fid in enumerate(FLIGHTS):
        start = np.datetime64("2023-08-21T09:05:00") + np.timedelta64(k, "h")
        end = start + np.timedelta64(20, "m")
        flights.append({"id": fid, "reference": "mast30", "target_height_m": 30,
                        "sonic": {"file": f"flights/{fid}/sonic.csv", "mount": "upside_down"},
                        "ins": {"file": f"flights/{fid}/ins.csv"},
                        "window": {"start": str(start) + "Z", "end": str(end) + "Z"}})
        conditions[fid] = {"mean_speed_ms": speeds[k], "wind_from_deg": 200.0 + 10 * k,
                           "z_over_L": -0.1 - 0.05 * k, "hover_height_m": 28.0}
    data = {"name": "measured6", "site": {"name": "P2OA", "latitude": 43.1247, "longitude": 0.3628,
                                          "altitude_m": 603},
            "masts": [{"id": "p2oa", "latitude": 43.1247, "longitude": 0.3628,
                       "sonics": [{"id": "mast30", "height_m": 30, "model": "CSAT3", "azimuth_deg": 218.0,
                                   "files": ["mast/mast30_*.dat"]}]}],
            "payload_flights": flights, "simulation": {"seed": 17, "payload_flights": conditions}}
    sim = simulation_manifest(data)
    for fid in FLIGHTS:
        simulate_payload(sim, fid, folder, folder)
    measured = {k: v for k, v in data.items() if k != "simulation"}
    path = folder / "measured6.yaml"
    path.write_text(yaml.safe_dump(measured, sort_keys=False))
    return path


def run(kind: str, cores: int, extra_config: list[str], keep: Path | None = None) -> dict:
    """Run the workflow once into a fresh results folder; wall time and per-stage CPU.

    The folder is temporary unless ``keep`` names one (it must not exist yet).
    """
    if keep is not None:
        keep.mkdir(parents=True, exist_ok=False)
    with tempfile.TemporaryDirectory(prefix=f"dronewind_bench_{kind}_") as tmp:
        tmp_path = Path(tmp) if keep is None else keep
        config = [f"results_dir={tmp_path / 'results'}", *extra_config]
        if kind == "measured6":
            config.append(f"campaign={measured_campaign(tmp_path)}")
        cmd = [str(BIN / "snakemake"), "--cores", str(cores), "--config", *config]
        print("running:", " ".join(cmd), flush=True)
        start = time.perf_counter()
        children = resource.getrusage(resource.RUSAGE_CHILDREN)
        proc = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, check=False,
                              env={**os.environ, "PATH": f"{BIN}:{os.environ.get('PATH', '')}"})
        wall = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        # every process of the run: Snakemake itself, its scheduler and each job's start-up,
        # which the rules' benchmark files (sampled while a job runs) do not count
        process_cpu_s = (after.ru_utime - children.ru_utime) + (after.ru_stime - children.ru_stime)
        if proc.returncode != 0:
            raise SystemExit(f"snakemake failed ({proc.returncode}):\n{proc.stderr[-3000:]}")
        name = "measured6" if kind == "measured6" else "mosai2023"
        jobs = collect(tmp_path / "results" / name)
    stages = jobs.groupby("stage").agg(jobs=("job", "count"), wall_s=("wall_s", "sum"), cpu_s=("cpu_s", "sum"))
    rules = jobs.groupby("rule").agg(jobs=("job", "count"), cpu_s=("cpu_s", "sum"), log_cpu_s=("log_cpu_s", "sum"))
    return {"run": kind, "cores": cores, "config": extra_config, "wall_s": round(wall, 1),
            "n_jobs": int(len(jobs)), "cpu_s_total": round(float(jobs["cpu_s"].sum()), 1),
            "cpu_s_all_processes": round(process_cpu_s, 1),
            "cpu_s_job_logs": round(float(jobs["log_cpu_s"].sum()), 1),
            "stages": {k: {"jobs": int(v["jobs"]), "cpu_s": round(float(v["cpu_s"]), 1)} for k, v in
                       stages.iterrows()},
            "rules": {k: {"jobs": int(v["jobs"]), "cpu_s": round(float(v["cpu_s"]), 1),
                          "log_cpu_s": round(float(v["log_cpu_s"]), 1)} for k, v in rules.iterrows()},
            "load_average_at_end": os.getloadavg()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("kind", choices=["default", "measured6"], help="which run")
    parser.add_argument("--cores", type=int, default=2)
    parser.add_argument("--config", nargs="*", default=[], help="extra --config KEY=VALUE pairs")
    parser.add_argument("--out", type=Path, help="JSON file to write (default: benchmarks/results/run_<kind>.json)")
    parser.add_argument("--keep", type=Path, help="run into this new folder and keep it (default: a temporary one)")
    args = parser.parse_args()
    args.out = args.out or Path(__file__).resolve().parent / "results" / f"run_{args.kind}.json"
    before = reference_workload_s()
    result = {**run(args.kind, args.cores, args.config, args.keep), "commit": git_commit(),
              "reference_workload_s": {"before": before, "after": reference_workload_s()}}
    print_and_write(result, args.out)


if __name__ == "__main__":
    main()
