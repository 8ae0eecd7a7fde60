"""CPU seconds of one Snakemake start on the default campaign: a dry run, and the Snakefile's imports alone.

Snakemake runs the Snakefile each time it starts: ``make run`` once, every test that runs the
workflow once, and on a cluster every job once more (the job's own Snakemake). Two numbers,
each the least of ``--repeat`` runs in fresh processes (the machine's other load only adds):

* ``dry_run_cpu_s``: ``snakemake -n --quiet all`` on the embedded default campaign, the CPU of
  the Snakemake process (user + sys, ``resource.getrusage`` of the children);
* ``imports_cpu_s``: a fresh interpreter that runs only the ``from dronewind ... import``
  lines of ``workflow/rules/*.smk``, and the heavy libraries they load.

The wall time of a start also holds what the installed executor plugins do when Snakemake
imports them: the SLURM plugin asks ``scontrol show config`` at import, which waits about 9 s
on a machine with SLURM's client but no reachable controller. It is reported, not counted in
the CPU. Example (before/after: run it in two worktrees)::

    .venv/bin/python benchmarks/bench_snakemake_start.py --repeat 5 --out /tmp/start.json
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_common import REPO, git_commit, print_and_write

BIN = Path(sys.executable).parent
HEAVY = ("scipy", "scipy.signal", "scipy.stats", "xarray", "matplotlib", "pandas", "netCDF4", "dask")


def snakefile_imports() -> str:
    """The ``from dronewind ... import`` statements of the workflow's rule files, as one script."""
    lines, block = [], ""
    for path in sorted((REPO / "workflow" / "rules").glob("*.smk")):
        for line in path.read_text().splitlines():
            if block or line.lstrip().startswith(("from dronewind", "import dronewind")):
                block += line.strip() + " "
                if "(" not in block or ")" in block:
                    lines.append(block.strip())
                    block = ""
    return "\n".join(lines)


def child_cpu(cmd: list[str], env: dict[str, str]) -> tuple[float, float, str]:
    """CPU seconds (user + sys) and wall seconds of one child process, and its stdout."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=REPO, env=env, capture_output=True, text=True, check=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, wall, proc.stdout


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=5, help="runs of each measurement (least CPU reported)")
    parser.add_argument("--out", type=Path,
        default=Path(__file__).resolve().parent / "results" / "snakemake_start.json",
        help="JSON file to write")
    args = parser.parse_args()
    env = dict(os.environ, PYTHONPATH=str(REPO / "src"))
    script = snakefile_imports() + f"\nimport json, sys\nprint(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))"
    dry, dry_wall, imp, loaded = [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(args.repeat):
            cpu, wall, _ = child_cpu([str(BIN / "snakemake"), "-n", "--quiet", "all", "--config",
                                      f"results_dir={tmp}/results"], env)
            dry.append(round(cpu, 3))
            dry_wall.append(round(wall, 3))
            cpu, _, out = child_cpu([sys.executable, "-c", script], env)
            imp.append(round(cpu, 3))
            loaded = json.loads(out.strip().splitlines()[-1])
    print_and_write({"commit": git_commit(), "repeat": args.repeat, "dry_run_cpu_s": dry,
                     "dry_run_cpu_s_least": min(dry), "dry_run_wall_s": dry_wall, "imports_cpu_s": imp,
                     "imports_cpu_s_least": min(imp), "heavy_modules_loaded_by_imports": loaded}, args.out)


if __name__ == "__main__":
    main()
