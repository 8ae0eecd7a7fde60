"""CPU seconds of the campaign figures step (``figures`` rule) on a finished run (any code version).

Draws every campaign figure (:func:`dronewind.figures.campaign.draw_all`, PNG and PDF) from
the stored products of a finished run into a temporary folder, ``--repeat`` times in this
process, and reports the least ``time.process_time`` (the machine's other load only adds)
and the figures written. A before/after pair runs the same script on the same run::

    git worktree add /tmp/base <commit>
    PYTHONPATH=/tmp/base/src .venv/bin/python benchmarks/bench_figures.py results/mosai2023 --out /tmp/before.json
    PYTHONPATH=src .venv/bin/python benchmarks/bench_figures.py results/mosai2023 --out /tmp/after.json
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from bench_common import finished_run_parser, git_commit, print_and_write
from dronewind.figures.campaign import draw_all


def main() -> None:
    parser = finished_run_parser(__doc__)
    parser.add_argument("--repeat", type=int, default=2, help="runs (least CPU reported)")
    args = parser.parse_args()
    cpu: list[float] = []
    names: list[str] = []
    for _ in range(args.repeat):
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.process_time()
            draw_all(args.results, Path(tmp))
            cpu.append(round(time.process_time() - t0, 3))
            names = sorted(p.name for p in Path(tmp).iterdir())
    print_and_write({"commit": git_commit(Path(draw_all.__code__.co_filename).parent), "results": str(args.results),
                     "cpu_s": cpu, "cpu_s_least": min(cpu), "files": names}, args.out)


if __name__ == "__main__":
    main()
