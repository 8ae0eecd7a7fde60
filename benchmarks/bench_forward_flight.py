"""CPU seconds of one flight's forward-model runs and of the campaign fit, on a finished default run (any code version).

For each flight given, :func:`dronewind.steps.diagnosis.forward_probes` (the ``diagnose_forward``
job: 5 baseline seeds and every probe, measured atmosphere) runs ``--repeat`` times in this
process on the conditions of the run's ``diagnosis/measured/<flight>.json``; the least
``time.process_time`` of the repetitions is reported (the machine's other load only adds).
Then :func:`dronewind.steps.diagnosis.diagnose_campaign` (the ``diagnose`` job) runs on the
run's measured and forward files, and its named causes and misfit are recorded. With
``PYTHONPATH`` set to an older source tree it measures that version, so a before/after pair
runs the same script on the same results::

    git worktree add /tmp/base <commit>
    PYTHONPATH=/tmp/base/src .venv/bin/python benchmarks/bench_forward_flight.py results/mosai2023 s02 s05 \\
        --repeat 3 --out /tmp/before.json
    PYTHONPATH=src .venv/bin/python benchmarks/bench_forward_flight.py results/mosai2023 s02 s05 \\
        --repeat 3 --out /tmp/after.json
"""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path

from bench_common import DEFAULT_CAMPAIGN, default_forward_setup, finished_run_parser, git_commit, print_and_write
from dronewind.manifest import payload_flight_manifest
from dronewind.steps import diagnosis as steps


def main() -> None:
    parser = finished_run_parser(__doc__, "a finished default run's results/<campaign> folder")
    parser.add_argument("flights", nargs="+", help="payload flight ids")
    parser.add_argument("--repeat", type=int, default=3, help="repetitions per flight (least CPU reported)")
    args = parser.parse_args()
    data, config, processing = default_forward_setup()
    d = config["diagnosis"]
    diag = args.results / "diagnosis"
    forward_cpu: dict[str, list[float]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for flight in args.flights:
            reference = next(f["reference"] for f in data["payload_flights"] if f["id"] == flight)
            for _ in range(args.repeat):
                t0 = time.process_time()
                steps.forward_probes(diag / "measured" / f"{flight}.json", Path(tmp) / f"{flight}.json",
                                     campaign=payload_flight_manifest(data, flight), flight_id=flight,
                                     processing=processing, seeds=d["seeds"],
                                     mast_l1=args.results / "netcdf" / "L1" / f"mast_{reference}.nc",
                                     atmosphere=d["atmosphere"])
                forward_cpu.setdefault(flight, []).append(round(time.process_time() - t0, 3))
        t0 = time.process_time()
        out = Path(tmp) / "diagnosis.json"
        steps.diagnose_campaign(DEFAULT_CAMPAIGN, sorted((diag / "measured").glob("*.json")),
                                sorted((diag / "forward").glob("*.json")), out, Path(tmp) / "extended.yaml",
                                alpha=d["alpha"], max_causes=d["max_causes"], min_gain=d["min_gain"],
                                atmosphere=d["atmosphere"])
        diagnose_cpu = time.process_time() - t0
        result = json.loads(out.read_text())
    print_and_write({"commit": git_commit(Path(steps.__file__).parent), "results": str(args.results),
                     "repeat": args.repeat, "forward_cpu_s": forward_cpu,
                     "forward_cpu_s_least": {f: min(v) for f, v in forward_cpu.items()},
                     "diagnose_cpu_s": round(diagnose_cpu, 3), "named_causes": result.get("named_causes"),
                     "goodness_of_fit": result.get("goodness_of_fit")}, args.out)


if __name__ == "__main__":
    main()
