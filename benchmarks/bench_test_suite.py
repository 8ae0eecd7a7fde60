"""Wall time and CPU of the test suite (``make test``), with where the time went.

Runs the suite as ``make test`` does (``-n 2 --dist loadgroup --no-loadscope-reorder``) or in
one process (``--workers 0``), and records:

* the wall time and pytest's summary line;
* the whole machine's CPU over the run (from ``/proc/stat``: the jobs SLURM starts and every
  other process included), so the fraction of the cores the suite kept busy, and the CPU of
  pytest and every process it waited for (``pytest_tree_cpu_s``: not SLURM's jobs);
* per worker, the time its tests spanned and their CPU (own and waited-for children,
  :mod:`pytest_timeline`), and the CPU per test module, largest first.

Examples::

    .venv/bin/python benchmarks/bench_test_suite.py --out benchmarks/results/test_suite.json
    .venv/bin/python benchmarks/bench_test_suite.py --workers 0 --out /tmp/test_suite_one_process.json
    .venv/bin/python benchmarks/bench_test_suite.py -- tests/payload/test_sync.py   # a part of the suite
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_common import git_commit, print_and_write  # noqa: E402

REPO = Path(__file__).resolve().parents[1]


def machine_cpu_s() -> tuple[float, float]:
    """(busy, idle) CPU seconds of the whole machine since boot, from ``/proc/stat``."""
    fields = [float(v) for v in Path("/proc/stat").read_text().splitlines()[0].split()[1:]]
    tick_s = 1.0 / os.sysconf("SC_CLK_TCK")
    idle = fields[3] + fields[4]  # idle + iowait
    return (sum(fields[:8]) - idle) * tick_s, idle * tick_s


def summarise(folder: Path) -> dict:
    """Per worker and per module figures from the timeline files in ``folder``."""
    rows = []
    for path in sorted(folder.glob("timeline-*.jsonl")):
        worker = path.stem.removeprefix("timeline-")
        rows += [{**json.loads(line), "worker": worker} for line in path.read_text().splitlines()]
    if not rows:
        return {}
    first = min(r["start_s"] for r in rows)
    workers = {}
    for worker in sorted({r["worker"] for r in rows}):
        mine = [r for r in rows if r["worker"] == worker]
        workers[worker] = {"tests": len(mine), "first_start_s": round(min(r["start_s"] for r in mine) - first, 1),
                           "last_end_s": round(max(r["end_s"] for r in mine) - first, 1),
                           "busy_s": round(sum(r["end_s"] - r["start_s"] for r in mine), 1),
                           "cpu_s": round(sum(r["cpu_s"] for r in mine), 1)}
    cpu, wall = collections.Counter(), collections.Counter()
    for r in rows:
        module = r["id"].split("::")[0]
        cpu[module] += r["cpu_s"]
        wall[module] += r["end_s"] - r["start_s"]
    modules = [{"module": m, "cpu_s": round(c, 1), "wall_s": round(wall[m], 1)} for m, c in cpu.most_common()]
    slowest = sorted(rows, key=lambda r: -r["cpu_s"])[:15]
    return {"workers": workers, "tests_cpu_s": round(sum(cpu.values()), 1), "modules": modules,
            "tests_by_cpu": [{"id": r["id"], "cpu_s": round(r["cpu_s"], 1),
                              "wall_s": round(r["end_s"] - r["start_s"], 1)} for r in slowest]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--workers", type=int, default=2, help="pytest-xdist workers; 0: one process (default 2)")
    parser.add_argument("--out", type=Path,
        default=Path(__file__).resolve().parent / "results" / "test_suite.json",
        help="JSON file to write")
    parser.add_argument("pytest_args", nargs="*", help="further pytest arguments (after --)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="bench_test_suite_") as folder:
        dist = ["-n", str(args.workers), "--dist", "loadgroup", "--no-loadscope-reorder"] if args.workers else []
        cmd = [sys.executable, "-m", "pytest", *dist, "-q", "-p", "pytest_timeline", *args.pytest_args]
        env = {**os.environ, "DRONEWIND_TIMELINE_DIR": folder,
               "PYTHONPATH": os.pathsep.join(filter(None, [str(REPO / "benchmarks"), os.environ.get("PYTHONPATH")]))}
        print("running:", " ".join(cmd[1:]), file=sys.stderr, flush=True)
        busy0, idle0 = machine_cpu_s()
        tree0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        proc = subprocess.run(cmd, cwd=REPO, env=env, capture_output=True, text=True, check=False)
        wall_s = time.perf_counter() - start
        busy1, idle1 = machine_cpu_s()
        tree1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        tree_cpu_s = (tree1.ru_utime + tree1.ru_stime) - (tree0.ru_utime + tree0.ru_stime)
        lines = proc.stdout.strip().splitlines()
        result = {
            "commit": git_commit(), "command": " ".join(cmd[1:]), "returncode": proc.returncode,
            "summary": lines[-1] if lines else proc.stderr[-500:],
            "failed": [line for line in lines if line.startswith(("FAILED ", "ERROR "))],
            "wall_s": round(wall_s, 1),
            "cores": os.cpu_count(), "machine_busy_cpu_s": round(busy1 - busy0, 1),
            "machine_idle_cpu_s": round(idle1 - idle0, 1),
            "pytest_tree_cpu_s": round(tree_cpu_s, 1),
            "cores_kept_busy": round((busy1 - busy0) / wall_s, 2),
            "load_average_at_end": list(os.getloadavg()),
            **summarise(Path(folder)),
        }
    print_and_write(result, args.out)
    return proc.returncode


if __name__ == "__main__":
    sys.exit(main())
