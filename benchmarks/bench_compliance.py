"""CPU seconds of the CF/ACDD compliance check of a finished run's NetCDF files (any code version).

Checks every ``--every``-th NetCDF file (sorted paths) of a finished run's ``netcdf/`` folder
with the library's checker: :func:`dronewind.core.cf.check_compliance_files` (one checker
process for all files) where the checked-out version has it, else
:func:`dronewind.core.cf.check_compliance` file by file (one ``compliance-checker`` process per
file, the version before). CPU time is that of this process and its children (user + sys);
every file's verdict is recorded. A before/after pair runs the same script on the same files::

    git worktree add /tmp/base <commit>
    PYTHONPATH=/tmp/base/src .venv/bin/python benchmarks/bench_compliance.py results/mosai2023 --out /tmp/before.json
    PYTHONPATH=src .venv/bin/python benchmarks/bench_compliance.py results/mosai2023 --out /tmp/after.json
"""

from __future__ import annotations

import time
from pathlib import Path

from bench_common import cpu_s_with_children, finished_run_parser, git_commit, print_and_write
from dronewind.core import cf


def main() -> None:
    parser = finished_run_parser(__doc__)
    parser.add_argument("--every", type=int, default=20, help="check every n-th NetCDF file (default 20)")
    args = parser.parse_args()
    files = sorted((args.results / "netcdf").rglob("*.nc"))[:: args.every]
    batched = hasattr(cf, "check_compliance_files")
    t0, w0 = cpu_s_with_children(), time.perf_counter()
    if batched:
        verdicts = {str(p): ok for p, (ok, _) in cf.check_compliance_files(files).items()}
    else:
        verdicts = {str(p): cf.check_compliance(p)[0] for p in files}
    cpu_s, wall_s = cpu_s_with_children() - t0, time.perf_counter() - w0
    print_and_write({"commit": git_commit(Path(cf.__file__).parent), "results": str(args.results),
                     "mode": "one checker process" if batched else "one checker process per file",
                     "files": len(files), "cpu_s": round(cpu_s, 2), "wall_s": round(wall_s, 2),
                     "cpu_s_per_file": round(cpu_s / max(len(files), 1), 3), "passed": verdicts}, args.out)


if __name__ == "__main__":
    main()
