"""Detection and false-alarm rates of the diagnosis over many hidden-effect draws.

Each draw hides one mechanism of dronewind.diagnose.experiments.HIDDEN_RANGES (random size,
random sign where it applies) or nothing, in a 4-flight virtual campaign of 12-minute hovers,
then simulates, processes and diagnoses it in-process (the same library functions as the
workflow's rules) and judges the result against the truth.

    .venv/bin/python benchmarks/bench_diagnosis_rates.py --draws 24 --workers 2 --seed 1 --out rates.json

Prints one line per draw and the rates per mechanism; about 3 CPU-minutes per draw.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from collections import defaultdict
from multiprocessing import Pool
from pathlib import Path

import numpy as np
import yaml

from dronewind.diagnose.experiments import draw, judge, run_in_process

REPO = Path(__file__).resolve().parents[1]


def one(args: tuple[int, int, float]) -> dict:
    seed, index, p_none = args
    rng = np.random.default_rng([seed, index])
    truth = draw(rng, p_none=p_none)
    config = yaml.safe_load((REPO / "config/config.yaml").read_text())
    start = time.perf_counter()
    try:
        with tempfile.TemporaryDirectory() as work:
            diagnosis = run_in_process(truth, config, work)
    except Exception as exc:  # a draw the chain cannot process is a failure, reported, not a crash
        verdict = {"mechanism": truth.mechanism, "truth": truth.parameters, "named": [], "detected": False,
                   "false_alarm": False, "estimate_ok": False, "error": f"{type(exc).__name__}: {exc}",
                   "seconds": time.perf_counter() - start, "top": []}
        print(json.dumps(verdict, default=str), flush=True)
        return verdict
    verdict = judge(truth, diagnosis)
    verdict["seconds"] = time.perf_counter() - start
    verdict["top"] = [(c["mechanism"], round(c["gain"], 3), c["significant"]) for c in diagnosis["candidates"][:3]]
    print(json.dumps(verdict, default=str), flush=True)
    return verdict


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--draws", type=int, default=12)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--p-none", type=float, default=0.25)
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    start = time.perf_counter()
    with Pool(args.workers) as pool:
        verdicts = pool.map(one, [(args.seed, i, args.p_none) for i in range(args.draws)])
    by = defaultdict(list)
    for v in verdicts:
        by[v["mechanism"]].append(v)
    print(f"\n{len(verdicts)} draws in {time.perf_counter() - start:.0f} s "
          f"({np.mean([v['seconds'] for v in verdicts]):.0f} s per draw per worker)")
    print(f"{'mechanism':22s} {'n':>3s} {'detected':>9s} {'estimate ok':>12s} {'false alarm':>12s}")
    for mech, vs in sorted(by.items()):
        print(f"{mech:22s} {len(vs):3d} {np.mean([v['detected'] for v in vs]):9.2f} "
              f"{np.mean([v['estimate_ok'] for v in vs]):12.2f} {np.mean([v['false_alarm'] for v in vs]):12.2f}")
    errors = [v for v in verdicts if v.get("error")]
    if errors:
        print(f"{len(errors)} draw(s) failed in processing: " + "; ".join(f"{v['mechanism']}: {v['error']}"
                                                                      for v in errors))
    hidden = [v for v in verdicts if v["mechanism"] != "none"]
    null = [v for v in verdicts if v["mechanism"] == "none"]
    if hidden:
        print(f"overall detection rate {np.mean([v['detected'] for v in hidden]):.2f} "
              f"(estimate within tolerance {np.mean([v['estimate_ok'] for v in hidden]):.2f}) over {len(hidden)}")
    if null:
        print(f"false-alarm rate {np.mean([v['false_alarm'] for v in null]):.2f} over {len(null)} null draws")
    if args.out:
        args.out.write_text(json.dumps(verdicts, indent=1, default=str))


if __name__ == "__main__":
    main()
