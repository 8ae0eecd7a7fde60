"""The planner's shared bootstrap reference against a reference of each draw's own, on paired draws.

The planner decides its Monte-Carlo campaigns against one bootstrap reference per error and
flight count (:func:`dronewind.plan.power.shared_reference`); a measured campaign's diagnosis
draws a reference of its own. This study draws the same campaigns
(:func:`dronewind.plan.power.drawn_campaigns`, one simulated plan without and with a hidden w
gain) and decides each both ways: the share of draws decided alike, the detection rates of
both with their 95 % Wilson intervals (Wilson 1927), the discordant pairs (McNemar's exact
two-sided p-value) and the CPU per draw of each. The simulated campaigns are kept in
``--evidence-dir`` with the decisions of each draw's own reference (deterministic: a rerun
reuses them).

Usage::

    PYTHONPATH=src nice -n 10 .venv/bin/python benchmarks/plan_reference_agreement.py --gain 1.05 1.08 \\
        --flights 3 --draws 30 --out benchmarks/results/plan_reference_agreement.json
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import scipy.stats

from bench_common import machine
from dronewind.diagnose.experiments import judge, wilson_interval
from dronewind.diagnose.in_process import diagnose_evidence
from dronewind.manifest import with_defaults
from dronewind.plan import power as pw
from dronewind.plan import simulation as sim
from dronewind.plan.manifest import flight_speeds
from dronewind.plan.planner import plan_campaign, power_campaigns
from dronewind.plan.spec import parse_plan
from plan_validation import SITE  # the validation plans' site

HERE = Path(__file__).resolve().parent


def _plan_body(gain: float, flights: int) -> dict[str, Any]:
    return {"name": "reference_agreement", "site": SITE, "platform": {"kind": "sling_load", "max_hover_min": 25},
            "conditions": {"wind_speed_ms": [3.0, 8.0], "wind_from_deg": 250, "stability": {"obukhov_length_m": -100},
                           "roughness_length_m": 0.1, "boundary_layer_height_m": 1000},
            "mast": {"heights_m": [30], "hover_height_m": 30},
            "targets": {"relative_uncertainty": {"sigma_w": 0.1, "u_star": 0.3},
                        "detect": [{"mechanism": "w_gain", "parameters": {"gain": gain}}], "power": 0.8,
                        "max_flights": flights},
            "monte_carlo": {"seed": 1}}


def _evidence(gain: float, flights: int, folder: Path) -> tuple[Any, dict[str, Any]]:
    """The plan's power model (simulated without and with the gain), kept in ``folder``."""
    spec = parse_plan(_plan_body(gain, flights), f"plan_reference_agreement:w_gain={gain:g}")
    plan = plan_campaign(spec, simulate_power=False)
    manifests = power_campaigns(plan)  # as plan_campaign simulates them for the power
    path = folder / f"evidences_gain{gain:g}_{flights}flights.json"
    if path.exists():
        evidences = json.loads(path.read_text())
    else:
        with tempfile.TemporaryDirectory() as tmp:
            evidences = sim.campaign_evidences(manifests, with_defaults({}), tmp)
        folder.mkdir(parents=True, exist_ok=True)
        tmp_path = path.with_suffix(".tmp")
        tmp_path.write_text(json.dumps(evidences))
        tmp_path.replace(path)
    speeds = flight_speeds(plan.speed_range_ms[0], plan.speed_range_ms[1], flights)
    return pw.campaign_power_model(manifests, evidences, spec.detect), {
        "error": spec.detect[0].label, "hover_duration_s": plan.duration_s, "speeds_ms": speeds}


def compare(model: Any, label: str | None, flights: int, draws: int, seed: int, cache: Path) -> dict[str, Any]:
    """Decide the same drawn campaigns with the shared reference and with each draw's own.

    The own-reference decisions are kept in ``cache`` (a JSON list; deterministic by draw).
    """
    config: dict[str, Any] = {}
    drawn = list(pw.drawn_campaigns(model, label, flights, draws, seed))
    t0 = time.process_time()
    shared = pw.shared_reference(drawn, config)
    cpu_reference = time.process_time() - t0
    kept = json.loads(cache.read_text()) if cache.exists() else []
    own, common, cpu_own, cpu_shared = [], [], [], 0.0
    for k, draw in enumerate(drawn):
        if k < len(kept):
            a, dt = kept[k]["detected"], kept[k]["cpu_s"]
        else:
            t0 = time.process_time()
            a = bool(judge(draw.truth, diagnose_evidence(draw.evidence, config), draw.campaign)["detected"])
            dt = time.process_time() - t0
            kept.append({"detected": a, "cpu_s": dt})
            cache.write_text(json.dumps(kept))
        t1 = time.process_time()
        b = judge(draw.truth, diagnose_evidence(draw.evidence, config, reference=shared), draw.campaign)["detected"]
        cpu_own.append(dt)
        cpu_shared += time.process_time() - t1
        own.append(bool(a))
        common.append(bool(b))
        print(f"{label or 'no error'} draw {k + 1}/{draws}: own reference {a}, shared {b}", file=sys.stderr, flush=True)
    only_own = sum(a and not b for a, b in zip(own, common, strict=True))
    only_shared = sum(b and not a for a, b in zip(own, common, strict=True))
    discordant = only_own + only_shared
    mcnemar = (float(scipy.stats.binomtest(only_own, discordant, 0.5).pvalue) if discordant else 1.0)
    k_own, k_shared = sum(own), sum(common)
    return {"case": label or "none", "rate_counts": "detected" if label else "named nothing", "draws": draws,
            "own_reference": {"k": k_own, "rate": k_own / draws, "wilson95": list(wilson_interval(k_own, draws))},
            "shared_reference": {"k": k_shared, "rate": k_shared / draws,
                                 "wilson95": list(wilson_interval(k_shared, draws))},
            "decided_alike": draws - discordant, "only_own": only_own, "only_shared": only_shared,
            "mcnemar_exact_p": mcnemar,
            "cpu_s": {"shared_reference": round(cpu_reference, 2), "per_draw_own": round(sum(cpu_own) / draws, 3),
                      "per_draw_shared": round(cpu_shared / draws, 3)}}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--gain", type=float, nargs="+", default=[1.05, 1.08],
                        help="hidden w gains (default 1.05 1.08)")
    parser.add_argument("--flights", type=int, default=3, help="flights of the plan (default 3)")
    parser.add_argument("--draws", type=int, default=30, help="paired draws per case (default 30)")
    parser.add_argument("--seed", type=int, default=7, help="seed of the draws (default 7)")
    parser.add_argument("--evidence-dir", type=Path, default=Path(tempfile.gettempdir()) / "plan_reference_agreement")
    parser.add_argument("--out", type=Path, default=HERE / "results" / "plan_reference_agreement.json")
    args = parser.parse_args(argv)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    plans = []
    for gain in args.gain:
        model, plan = _evidence(gain, args.flights, args.evidence_dir)
        stem = args.evidence_dir / f"own_gain{gain:g}_{args.flights}flights_seed{args.seed}"
        cases = [compare(model, plan["error"], args.flights, args.draws, args.seed, Path(f"{stem}_error.json")),
                 compare(model, None, args.flights, args.draws, args.seed, Path(f"{stem}_none.json"))]
        plans.append({**plan, "noise_factor": model.noise_factor, "cases": cases})
    argv_text = " ".join(sys.argv[1:] if argv is None else argv)
    out = {"command": f"PYTHONPATH=src .venv/bin/python benchmarks/plan_reference_agreement.py {argv_text}",
           "machine": machine(), "plans": plans,
           "wall_s": round(time.perf_counter() - wall0, 1), "cpu_s": round(time.process_time() - cpu0, 1)}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_suffix(".tmp")
    tmp.write_text(json.dumps(out, indent=2) + "\n")
    tmp.replace(args.out)
    for p in plans:
        for c in p["cases"]:
            print(f"{p['error']} {c['case']}: own {c['own_reference']['k']}/{c['draws']}, shared "
                  f"{c['shared_reference']['k']}/{c['draws']}, alike {c['decided_alike']}, McNemar p "
                  f"{c['mcnemar_exact_p']:.2f}")
    print(f"written {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
