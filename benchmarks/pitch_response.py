"""Feature response of the forward model to a sonic mount pitch over -8 to 8 degree (linearity check).

Runs the forward model of default-campaign flights (one baseline seed, conditions of a finished
run's ``diagnosis/measured/<flight>.json``) with the mount pitched at -8, -6, ..., 8 degree and
writes, per flight and feature, the change from the baseline run (common random numbers)::

    PYTHONPATH=src .venv/bin/python benchmarks/pitch_response.py --results results/mosai2023 \\
        --out benchmarks/results/pitch_response.json s02 s05 s09
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from bench_common import REPO, default_forward_setup, git_commit, print_and_write
from dronewind.diagnose import forward, probe_runs, probes
from dronewind.diagnose.features import FEATURES
from dronewind.manifest import payload_flight_manifest

LEVELS_DEG = (-8.0, -6.0, -4.0, -2.0, 2.0, 4.0, 6.0, 8.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("flights", nargs="+", help="payload flight ids of the default campaign")
    parser.add_argument("--results", type=Path, default=REPO / "results" / "mosai2023",
                        help="results folder of a finished default run")
    parser.add_argument("--out", type=Path,
        default=Path(__file__).resolve().parent / "results" / "pitch_response.json",
        help="JSON file to write")
    args = parser.parse_args()
    data, config, processing = default_forward_setup()
    probe = probes.Probe("mount_misalignment", "mount_misalignment", "pitch_deg", LEVELS_DEG)
    out: dict = {"commit": git_commit(Path(forward.__file__).parent), "levels_deg": list(LEVELS_DEG), "flights": {}}
    for flight in args.flights:
        conditions = json.loads((args.results / "diagnosis" / "measured" / f"{flight}.json").read_text())["conditions"]
        runs = probe_runs.probe_runs(payload_flight_manifest(data, flight), flight, conditions, processing,
                                  seeds=(int(config["diagnosis"]["seeds"][0]),), probes=(probe,))
        base = runs["baseline"][0]["values"]
        change = {f: [None if r["features"]["values"][f] is None or base[f] is None
                      else r["features"]["values"][f] - base[f] for r in runs["probes"]] for f in FEATURES}
        tilt = np.array(change["tilt_diff_deg"], dtype=float)
        slope = float(np.polyfit(LEVELS_DEG, tilt, 1)[0])
        out["flights"][flight] = {"mean_speed_ms": conditions["mean_speed_ms"], "change": change,
                                  "tilt_diff_slope": slope,
                                  "tilt_diff_max_deviation_from_line_deg": float(np.max(np.abs(
                                      tilt - np.polyval(np.polyfit(LEVELS_DEG, tilt, 1), LEVELS_DEG))))}
    print_and_write(out, args.out)


if __name__ == "__main__":
    main()
