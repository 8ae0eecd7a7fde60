"""Run the throughput benchmarks one after another (``make bench``).

Each benchmark is its own script (see its ``--help``); this runner calls the quick ones with
their defaults and prints their output. The long ones are run by hand:

* ``bench_diagnosis_rates.py --draws 24 --workers 2`` (about 3 CPU-minutes per draw);
* ``bench_workflow_rules.py results/<campaign>`` after a workflow run (per-rule times).
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
QUICK = ["bench_simulate.py", "bench_ingest.py", "bench_parsing.py", "bench_payload_chain.py", "bench_analysis.py",
         "bench_quadrotor.py"]


def main() -> int:
    failed = []
    for name in QUICK:
        print(f"=== {name}", flush=True)
        t0 = time.perf_counter()
        rc = subprocess.call([sys.executable, str(HERE / name)])
        print(f"=== {name}: exit {rc}, {time.perf_counter() - t0:.1f} s", flush=True)
        if rc:
            failed.append(name)
    if failed:
        print(f"failed: {failed}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
