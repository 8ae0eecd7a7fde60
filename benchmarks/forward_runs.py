"""Forward-model runs of one default-campaign flight at the conditions of a finished run (any code version).

Runs :func:`dronewind.diagnose.probe_runs.probe_runs` with the default settings on the one-flight
view of the default manifest, at the conditions stored in the flight's
``diagnosis/measured/<flight>.json``, and writes the runs as JSON; with ``PYTHONPATH`` set to an
older source tree it runs that version's forward model (see compare_forward_runs.py). Example::

    PYTHONPATH=src .venv/bin/python benchmarks/forward_runs.py s01 \\
        results/mosai2023/diagnosis/measured/s01.json /tmp/s01_forward.json
"""

import argparse
import json
from pathlib import Path

from bench_common import default_forward_setup
from dronewind.diagnose import probe_runs
from dronewind.manifest import payload_flight_manifest


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("flight", help="payload flight id of the default campaign")
    parser.add_argument("measured", type=Path, help="diagnosis/measured/<flight>.json of a finished run")
    parser.add_argument("out", type=Path, help="JSON file to write")
    args = parser.parse_args()
    data, config, processing = default_forward_setup()
    conditions = json.loads(args.measured.read_text())["conditions"]
    runs = probe_runs.probe_runs(payload_flight_manifest(data, args.flight), args.flight, conditions, processing,
                              seeds=tuple(config["diagnosis"]["seeds"]))
    args.out.write_text(json.dumps(runs, default=str))


if __name__ == "__main__":
    main()
