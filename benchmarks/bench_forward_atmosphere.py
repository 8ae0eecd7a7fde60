"""The forward model's atmosphere, measured against the model's: hidden-effect draws run in-process.

Each case is a 4-flight virtual campaign of 12-minute hovers (dronewind.diagnose.experiments),
simulated, processed and diagnosed in-process (in_process.run_in_process, the workflow's
library functions) with ``diagnosis.atmosphere: measured`` (the reference mast's L1 constrains
the forward runs' field and gives its spectra) and, for some cases, ``model`` (similarity
turbulence at the measured mean conditions):

* null draws: nothing hidden; the right verdict names nothing;
* one draw of each of w_gain, sonic_ins_lag, heading_bias, clock_drift, mast_w_attenuation;
* a turbulence model error: nothing hidden, but the true atmosphere is more convective than the
  forward model's (convective boundary layer 5000 m instead of the model's 1000 m, z/L from
  -0.6 to -0.15: sigma_u, sigma_v 25-60 % above the model's at both sensors); the right verdict
  names nothing; a stronger one with z/L from -2 to -0.5.

    PYTHONPATH=src nice -n 5 .venv/bin/python benchmarks/bench_forward_atmosphere.py \\
        --out benchmarks/results/forward_atmosphere.json

Per run: named causes, ambiguity sets, estimates, the judgement (experiments.judge), the
whitened baseline misfit chi2/dof, the unexplained features and the CPU seconds.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from dronewind.diagnose.experiments import Draw, judge
from dronewind.diagnose.in_process import run_in_process

REPO = Path(__file__).resolve().parents[1]

#: the true atmosphere of the turbulence model error (simulation.atmosphere and z/L per flight)
TURBULENCE_ERROR: dict[str, Any] = {"atmosphere": {"boundary_layer_height_m": 5000.0},
                                    "z_over_l": (-0.6, -0.4, -0.25, -0.15)}
#: a stronger one: z/L from -2 to -0.5 (sigma_u, sigma_v about twice the model's)
STRONG_TURBULENCE_ERROR: dict[str, Any] = {"atmosphere": {"boundary_layer_height_m": 5000.0},
                                           "z_over_l": (-2.0, -1.5, -1.0, -0.5)}

#: (label, truth, campaign keywords, atmospheres to run)
CASES: list[tuple[str, Draw, dict[str, Any], tuple[str, ...]]] = [
    ("null", Draw("none", {}, 11), {}, ("measured", "model")),
    ("null", Draw("none", {}, 12), {}, ("measured",)),
    ("w_gain", Draw("w_gain", {"gain": 1.2}, 13), {}, ("measured",)),
    ("sonic_ins_lag", Draw("sonic_ins_lag", {"lag_s": 0.4}, 14), {}, ("measured",)),
    ("heading_bias", Draw("heading_bias", {"deg": -9.0}, 15), {}, ("measured",)),
    ("clock_drift", Draw("clock_drift", {"ppm": 350.0}, 16), {}, ("measured",)),
    ("mast_w_attenuation", Draw("mast_w_attenuation", {"gain": 0.83}, 17), {}, ("measured", "model")),
    ("turbulence_model_error", Draw("none", {}, 18), TURBULENCE_ERROR, ("measured", "model")),
    ("strong_turbulence_model_error", Draw("none", {}, 19), STRONG_TURBULENCE_ERROR, ("measured", "model")),
]


def run_case(label: str, truth: Draw, manifest_kw: dict[str, Any], atmosphere: str) -> dict[str, Any]:
    """One diagnosis of one case with one atmosphere."""
    t0 = time.process_time()
    with tempfile.TemporaryDirectory(prefix="dronewind_atm_") as work:
        diag = run_in_process(truth, {"diagnosis": {"atmosphere": atmosphere}}, work, **manifest_kw)
    cpu = time.process_time() - t0
    verdict = judge(truth, diag)
    gof = diag.get("goodness_of_fit") or {}
    return {"label": label, "atmosphere": atmosphere, "truth": {"mechanism": truth.mechanism,
                                                                "parameters": truth.parameters, "seed": truth.seed},
            "campaign": {k: (list(v) if isinstance(v, tuple) else v) for k, v in manifest_kw.items()},
            "named": diag.get("named_causes"), "ambiguity_sets": diag.get("ambiguity_sets"),
            "named_estimates": diag.get("named_estimates"),
            "judge": {k: verdict[k] for k in ("detected", "false_alarm", "wrong_cause", "estimate_ok",
                                              "estimate_error") if k in verdict},
            "chi2": gof.get("chi2"), "dof": gof.get("dof"),
            "unexplained": [u.get("feature") for u in diag.get("unexplained") or []],
            "candidates": [{"mechanism": c["mechanism"], "p_value": c["p_value"], "gain": c["gain"],
                            "estimate": c.get("estimate")} for c in diag.get("candidates") or []],
            "cpu_s": cpu}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=REPO / "benchmarks/results/forward_atmosphere.json")
    parser.add_argument("--only", nargs="*", default=None, help="labels to run (default: all)")
    args = parser.parse_args(argv)
    log = args.out.with_suffix(".log")
    runs = []
    for label, truth, kw, atmospheres in CASES:
        if args.only and label not in args.only:
            continue
        for atmosphere in atmospheres:
            run = run_case(label, truth, kw, atmosphere)
            runs.append(run)
            with log.open("a") as fh:
                fh.write(json.dumps(run, default=float) + "\n")
            print(f"{label:24s} {atmosphere:9s} named {run['named']} ambiguity {run['ambiguity_sets']} "
                  f"chi2/dof {run['chi2']:.1f}/{run['dof']} judge {run['judge']} cpu {run['cpu_s']:.0f} s",
                  file=sys.stderr)
    args.out.write_text(json.dumps({"command": " ".join(["benchmarks/bench_forward_atmosphere.py", *(argv or
                                                                                                      sys.argv[1:])]),
                                    "runs": runs}, indent=2, default=float) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
