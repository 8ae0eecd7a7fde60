"""Is a catalog mechanism identifiable at a physical size? One hidden draw each, diagnosed in-process.

For mechanisms that are not (or not yet) in ``experiments.HIDDEN_RANGES``, each case hides one
mechanism at a stated size in the 4-flight hidden-effect campaign
(:func:`dronewind.diagnose.experiments.campaign_manifest`), runs the in-process diagnosis with
the default configuration (:func:`~dronewind.diagnose.in_process.run_in_process`) and records
the verdict (:func:`~dronewind.diagnose.experiments.judge`), the named causes, ambiguity sets,
goodness of fit and the first candidates. One draw per case: evidence for what enters the
hidden draws, not a rate (bench_diagnosis_rates.py measures rates).

    PYTHONPATH=src nice -n 5 .venv/bin/python benchmarks/bench_identifiability.py \\
        --out benchmarks/results/hidden_identifiability.json
    PYTHONPATH=src .venv/bin/python benchmarks/bench_identifiability.py --case lever_x1 --out /tmp/one.json
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

from bench_common import git_commit
from dronewind.diagnose.experiments import Draw, judge
from dronewind.diagnose.in_process import run_in_process

#: name -> hidden truth (mechanism, every parameter, campaign seed)
CASES: dict[str, Draw] = {
    "lever_x1": Draw("lever_arm", {"x_m": 1.0, "y_m": 0.0, "z_m": 0.0}, 11),
    "lever_z-1.5": Draw("lever_arm", {"x_m": 0.0, "y_m": 0.0, "z_m": -1.5}, 12),
    "downwash_1_5": Draw("downwash", {"w0_ms": 1.0, "u_scale_ms": 5.0}, 13),
    "mount_pitch4": Draw("mount_misalignment", {"roll_deg": 0.0, "pitch_deg": 4.0, "yaw_deg": 0.0}, 14),
    "mount_roll-4": Draw("mount_misalignment", {"roll_deg": -4.0, "pitch_deg": 0.0, "yaw_deg": 0.0}, 15),
}


def run_case(name: str) -> dict:
    """Diagnose one case; the verdict and what the diagnosis said."""
    truth = CASES[name]
    t0 = time.process_time()
    with tempfile.TemporaryDirectory() as work:
        diag = run_in_process(truth, {}, work)
    keep = {k: diag.get(k) for k in ("named_causes", "ambiguity_sets", "named_estimates", "goodness_of_fit",
                                     "unexplained", "atmosphere")}
    keep["candidates"] = [{k: c.get(k) for k in ("mechanism", "variant", "estimate", "uncertainty", "p_value", "gain",
                                                 "significant")} for c in diag.get("candidates", [])][:6]
    return {"case": name, "judge": judge(truth, diag), "cpu_s": time.process_time() - t0, **keep}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--case", action="append", choices=sorted(CASES), help="run only these cases (repeatable)")
    parser.add_argument("--out", type=Path,
        default=Path(__file__).resolve().parent / "results" / "hidden_identifiability.json",
        help="JSON file to write")
    args = parser.parse_args()
    commit = git_commit()
    results = []
    for name in args.case or sorted(CASES):
        print(f"case {name} ...", flush=True)
        results.append(run_case(name))
        print(f"  named {results[-1]['named_causes']}, detected {results[-1]['judge']['detected']}", flush=True)
    args.out.write_text(json.dumps({"command": "benchmarks/bench_identifiability.py", "commit": commit,
                                    "cases": results}, indent=1, default=str))


if __name__ == "__main__":
    main()
