"""Seed-to-seed scatter of the forward model's features with a mechanism on, against the baseline's.

The diagnosis' errors are the baseline seeds' scatter (``dronewind.diagnose.campaign``); a
mechanism that widens a feature's scatter makes that feature's residuals look more
significant than they are. This runs one default-campaign flight (conditions of a finished
run's ``diagnosis/measured/<flight>.json``, the similarity model's atmosphere) with seeds
1..N for the baseline and for each ``mechanism:parameter=value`` given, and writes the mean
and standard deviation of every feature::

    PYTHONPATH=src .venv/bin/python benchmarks/mechanism_scatter.py s05 attitude_lag:lag_s=0.3 \\
        sonic_ins_lag:lag_s=0.27 --seeds 10 --out benchmarks/results/mechanism_scatter.json
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from bench_common import REPO, default_forward_setup, git_commit, print_and_write
from dronewind.diagnose import forward, forward_conditions
from dronewind.diagnose.features import FEATURES, features_to_dict
from dronewind.manifest import payload_flight_manifest


def _mechanism(text: str) -> list[dict]:
    name, _, assignment = text.partition(":")
    parameter, _, value = assignment.partition("=")
    return [{"mechanism": name, "parameters": {parameter: float(value)}}]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("flight", help="payload flight id of the default campaign")
    parser.add_argument("mechanisms", nargs="+", help="mechanism:parameter=value, e.g. attitude_lag:lag_s=0.3")
    parser.add_argument("--seeds", type=int, default=10, help="seeds 1..N per configuration (default 10)")
    parser.add_argument("--results", type=Path, default=REPO / "results" / "mosai2023",
                        help="results folder of a finished default run")
    parser.add_argument("--out", type=Path,
        default=Path(__file__).resolve().parent / "results" / "mechanism_scatter.json",
        help="JSON file to write")
    args = parser.parse_args()
    data, _, processing = default_forward_setup()
    measured = json.loads((args.results / "diagnosis" / "measured" / f"{args.flight}.json").read_text())
    view = payload_flight_manifest(data, args.flight)
    out: dict = {"commit": git_commit(Path(forward.__file__).parent), "flight": args.flight,
                 "seeds": list(range(1, args.seeds + 1)), "configurations": {}}
    for label in ["baseline", *args.mechanisms]:
        mech = None if label == "baseline" else _mechanism(label)
        rows = []
        for seed in out["seeds"]:
            manifest = forward_conditions.forward_manifest(view, args.flight, measured["conditions"], mech, seed, False)
            feats, _ = forward.run_forward(manifest, args.flight, processing)
            rows.append(features_to_dict(feats)["values"])
        values = {f: np.array([np.nan if r[f] is None else r[f] for r in rows], dtype=float) for f in FEATURES}
        out["configurations"][label] = {f: {"mean": float(np.nanmean(v)), "sd": float(np.nanstd(v, ddof=1))}
                                        for f, v in values.items()}
    base = out["configurations"]["baseline"]
    out["sd_ratio_to_baseline"] = {label: {f: c[f]["sd"] / base[f]["sd"] if base[f]["sd"] > 0 else None
                                           for f in FEATURES}
                                   for label, c in out["configurations"].items() if label != "baseline"}
    print_and_write(out, args.out)


if __name__ == "__main__":
    main()
