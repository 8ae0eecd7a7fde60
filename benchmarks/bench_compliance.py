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

With ``--compare`` (a version with :mod:`dronewind.core.compliance`) the same files are also
checked with the checker as installed (``remember=False``) and every report is compared
with the remembered scans' one: the verdicts, and the text of each suite's report (the
checker prints its suites in an order that varies between processes and stamps each
report with the time, so the sections are compared as a set, the time stamp left out)::

    PYTHONPATH=src .venv/bin/python benchmarks/bench_compliance.py results/mosai2023 --every 1 --compare \\
        --out /tmp/compliance.json
"""

from __future__ import annotations

import time
from pathlib import Path

from bench_common import RESULTS, cpu_s_with_children, finished_run_parser, git_commit, print_and_write
from dronewind.core import cf


def timed_check(files: list[Path], **kwargs: bool) -> tuple[dict[Path, tuple[bool, str]], float, float]:
    """The checker's results on ``files``, its CPU seconds (with children) and wall seconds."""
    t0, w0 = cpu_s_with_children(), time.perf_counter()
    results = cf.check_compliance_files(files, **kwargs)
    return results, cpu_s_with_children() - t0, time.perf_counter() - w0


def main() -> None:
    parser = finished_run_parser(__doc__, default_out=RESULTS / "compliance.json")
    parser.add_argument("--every", type=int, default=20, help="check every n-th NetCDF file (default 20)")
    parser.add_argument("--compare", action="store_true",
                        help="also check without the remembered scans and compare every report")
    args = parser.parse_args()
    files = sorted((args.results / "netcdf").rglob("*.nc"))[:: args.every]
    batched = hasattr(cf, "check_compliance_files")
    out: dict = {"commit": git_commit(Path(cf.__file__).parent), "results": str(args.results),
                 "mode": "one checker process" if batched else "one checker process per file", "files": len(files)}
    if batched:
        results, cpu_s, wall_s = timed_check(files)
        verdicts = {str(p): ok for p, (ok, _) in results.items()}
    else:
        t0, w0 = cpu_s_with_children(), time.perf_counter()
        verdicts = {str(p): cf.check_compliance(p)[0] for p in files}
        cpu_s, wall_s = cpu_s_with_children() - t0, time.perf_counter() - w0
    out.update({"cpu_s": round(cpu_s, 2), "wall_s": round(wall_s, 2),
                "cpu_s_per_file": round(cpu_s / max(len(files), 1), 3)})
    if args.compare:
        from dronewind.core.compliance import report_sections

        plain, plain_cpu_s, plain_wall_s = timed_check(files, remember=False)
        differ = [str(p) for p in files if plain[p][0] != results[p][0]
                  or report_sections(plain[p][1]) != report_sections(results[p][1])]
        out.update({"plain_cpu_s": round(plain_cpu_s, 2), "plain_wall_s": round(plain_wall_s, 2),
                    "plain_cpu_s_per_file": round(plain_cpu_s / max(len(files), 1), 3),
                    "reports_differing": differ, "failed": sorted(str(p) for p in files if not results[p][0])})
    out["passed"] = verdicts
    print_and_write(out, args.out)


if __name__ == "__main__":
    main()
