"""CPU seconds of the quadrotor campaign steps on a finished default run (any code version).

Runs :func:`dronewind.steps.quadrotor.quadrotor_calibration` and
:func:`dronewind.steps.quadrotor.quadrotor_diagnosis` in this process on the window files of a
finished run (``results/<campaign>/quadrotor/windows``, the tunnel's ``L0/tunnel/runs.csv``),
``--repeat`` times each, with scipy.signal imported first as in a workflow job (the preloaded
process holds it). Reports the least ``time.process_time`` and the SHA-256 of every output
file, so that a before/after pair shows the same outputs::

    git worktree add /work/base <commit>
    PYTHONPATH=/work/base/src .venv/bin/python benchmarks/bench_quadrotor_steps.py results/mosai2023 \\
        --work /tmp/q_before --out /tmp/q_before.json
    PYTHONPATH=src .venv/bin/python benchmarks/bench_quadrotor_steps.py results/mosai2023 \\
        --work /tmp/q_after --out /tmp/q_after.json
"""

from __future__ import annotations

import hashlib
import time
from pathlib import Path

import scipy.signal  # noqa: F401 (imported as in a workflow job's preloaded process)

import dronewind
from bench_common import finished_run_parser, git_commit, print_and_write
from dronewind.manifest import default_config
from dronewind.steps.quadrotor import quadrotor_calibration, quadrotor_diagnosis


def main() -> None:
    parser = finished_run_parser(__doc__, "a finished default run's results/<campaign> folder")
    parser.add_argument("--work", type=Path, required=True, help="folder for the outputs")
    parser.add_argument("--repeat", type=int, default=2, help="runs of each step (least CPU reported)")
    args = parser.parse_args()
    config = default_config()
    quad, diag = config["quadrotor"], config["diagnosis"]
    folder = args.results / "quadrotor" / "windows"
    windows, blocks, problems = (sorted(folder.glob(f"*_{kind}.csv")) for kind in ("windows", "blocks", "problems"))
    runs = args.results / "L0" / "tunnel" / "runs.csv"
    args.work.mkdir(parents=True, exist_ok=True)
    steps = {
        "quadrotor_calibration": lambda: quadrotor_calibration(
            args.results.name, windows, blocks, problems, str(args.work), str(args.work / "calibration.json"),
            quad["calibration_window_s"]),
        "quadrotor_diagnosis": lambda: quadrotor_diagnosis(
            args.results.name, windows, blocks, runs if runs.is_file() else None,
            str(args.work / "quadrotor_diagnosis.json"), alpha=diag["alpha"], min_gain=quad["diagnosis"]["min_gain"],
            window_s=quad["diagnosis"]["window_s"]),
    }
    cpu: dict[str, list[float]] = {}
    for name, step in steps.items():
        for _ in range(args.repeat):
            t0 = time.process_time()
            step()
            cpu.setdefault(name, []).append(round(time.process_time() - t0, 3))
    digests = {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(args.work.iterdir()) if p.is_file()}
    print_and_write({"commit": git_commit(Path(dronewind.__file__).parent), "results": str(args.results),
                     "windows_files": len(windows), "cpu_s": cpu, "cpu_s_least": {k: min(v) for k, v in cpu.items()},
                     "output_sha256": digests}, args.out)


if __name__ == "__main__":
    main()
