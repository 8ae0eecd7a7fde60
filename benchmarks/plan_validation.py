"""Validate ``dronewind plan``: the planned virtual campaign flown over many seeds against the plan.

For each validation plan (short and long hovers, low and high wind, two hover heights) the
planner gives the hover duration, the number of flights, the predicted relative
uncertainties of sigma_w, u* and w'T' per flight and the predicted detection power of one
instrument error (:mod:`dronewind.plan.power`: campaigns drawn about the planned campaign
simulated with and without the error, each decided by the campaign diagnosis and judged as a
measured campaign is). The planned manifest is then simulated, processed, forward-run and
diagnosed in full for ``--seeds`` campaign seeds with the error hidden
(:func:`dronewind.plan.power.simulated_detection`, seeds disjoint from the planner's): the
achieved relative uncertainty of each statistic is its scatter over the seeds (per flight,
relative to its mean over the seeds), the detection rate is the share of seeds in which the
judge finds the error detected (the same judge as the planner's draws). Criteria (of the
planner): achieved uncertainties within 20 % of the predicted ones (root mean square over the
flights), detection rate within 10 points of the predicted power. Both rates carry their 95 %
Wilson intervals (Wilson 1927); the record states the point difference, its standard error
and whether its 95 % interval reaches within 10 points (``compatible_with_10_points``).

The rigid-mount plan is judged on its uncertainties only (the campaign diagnosis models the
sling-load payload). The planner's Ghirardelli et al. (2025) metric at the conditions and
durations of their Table 4 is recorded beside the paper's printed statements on it
(Sect. 5.3, Fig. 16: the figure is not digitised).

Usage (the CPU per seed and plan is in the record, ``cpu_seconds_per_campaign``)::

    PYTHONPATH=src nice -n 10 .venv/bin/python benchmarks/plan_validation.py --seeds 20 --workers 1 \\
        --out benchmarks/results/plan_validation.json
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from dronewind.diagnose.experiments import wilson_interval
from dronewind.plan.planner import plan_campaign, plan_uncertainty
from dronewind.plan.power import simulated_detection
from dronewind.plan.spec import parse_plan

SITE = {"name": "virtual", "latitude": 43.1247, "longitude": 0.3628, "altitude_m": 603}

#: The validation plans: name -> plan content. The errors are sized so that the predicted
#: power lies between the extremes (a rate near 0 or 1 agrees with any prediction).
PLANS: dict[str, dict[str, Any]] = {
    "short_hover_low_wind": {
        "conditions": {"wind_speed_ms": [3.0, 5.0], "wind_from_deg": 250, "stability": {"obukhov_length_m": -100},
                       "roughness_length_m": 0.1, "boundary_layer_height_m": 1000},
        "mast": {"heights_m": [30], "hover_height_m": 30},
        "targets": {"relative_uncertainty": {"sigma_w": 0.1, "u_star": 0.3},
                    "detect": [{"mechanism": "w_gain", "parameters": {"gain": 1.03}}]},
    },
    "long_hover_high_wind": {
        "conditions": {"wind_speed_ms": [7.0, 10.0], "wind_from_deg": 300, "stability": {"obukhov_length_m": 300},
                       "roughness_length_m": 0.3},
        "mast": {"heights_m": [30, 60], "hover_height_m": 30},
        "targets": {"relative_uncertainty": {"sigma_w": 0.02, "u_star": 0.06},
                    "detect": [{"mechanism": "heading_bias", "parameters": {"deg": 4.0}}]},
    },
    "mid_hover_60m": {
        "conditions": {"wind_speed_ms": [5.0, 8.0], "wind_from_deg": 280, "stability": {"obukhov_length_m": -300},
                       "roughness_length_m": 0.3, "boundary_layer_height_m": 1200},
        "mast": {"heights_m": [30, 60], "hover_height_m": 60},
        "targets": {"relative_uncertainty": {"sigma_w": 0.04, "u_star": 0.1, "w_theta": 0.25},
                    "detect": [{"mechanism": "sonic_ins_lag", "parameters": {"lag_s": 0.05}}]},
    },
}

QUANTITIES = ("sigma_w", "u_star", "w_theta")

#: The rigid-mount plan: uncertainties only (the campaign diagnosis, hence the power, is the
#: sling-load payload's). Its flights are simulated as rigid-mount records
#: (:func:`dronewind.simulate.rigid.simulate_rigid_record`) and processed by the rigid-mount chain.
RIGID_PLAN: dict[str, Any] = {
    "conditions": {"wind_speed_ms": [4.0, 8.0], "wind_from_deg": 200, "stability": {"obukhov_length_m": -200},
                   "roughness_length_m": 0.05},
    "platform": {"kind": "rigid_mount", "max_hover_min": 20},
    "mast": {"heights_m": [40], "hover_height_m": 40},
    "targets": {"relative_uncertainty": {"sigma_w": 0.05, "u_star": 0.15, "w_theta": 0.3}, "max_flights": 3},
}


def _rigid_statistics(task: tuple[float, float, int, float]) -> dict[str, float]:
    """One rigid-mount hover simulated, processed (L1, L2), rotated (double) and reduced to statistics."""
    import tempfile

    from dronewind.core.rotation import rotate
    from dronewind.core.uncertainty import product_series
    from dronewind.payload.rigid import rigid_l1, rigid_l2, rigid_mount
    from dronewind.simulate.rigid import RigidSettings, simulate_rigid_record

    speed, duration, seed, ell = task
    settings = RigidSettings(duration_s=duration + 60.0, mean_speed_ms=speed, wind_from_deg=200.0, height_m=40.0,
                             obukhov_length_m=ell, roughness_length_m=0.05)
    with tempfile.TemporaryDirectory() as tmp:
        rec = simulate_rigid_record(Path(tmp) / "rigid.csv", settings, seed=seed)
        l1 = rigid_l1(rec.path, rec.format)
        l2 = rigid_l2(l1, rigid_mount({"axes": dict(settings.mount_axes)}), alt_band_m=5.0, max_horizontal_speed_ms=3.0,
                      min_segment_s=120.0, max_lag_s=1.0, site_altitude_m=settings.site_altitude_m,
                      target_height_m=settings.height_m)
    e, n, w, t = (np.asarray(l2[k].values, dtype=float) for k in ("u_east_ms", "v_north_ms", "w_up_ms", "t_sonic_k"))
    ok = np.isfinite(e) & np.isfinite(n) & np.isfinite(w) & np.isfinite(t)
    u, v, w, _ = rotate(e[ok], n[ok], w[ok], "double")
    t = t[ok]
    uw, vw = float(np.mean(product_series(u, w))), float(np.mean(product_series(v, w)))
    times = l2["time"].values
    return {"sigma_w": float(np.sqrt(np.mean(product_series(w)))), "u_star": float((uw**2 + vw**2) ** 0.25),
            "w_theta": float(np.mean(product_series(w, t))),
            "duration_s": float((times[-1] - times[0]) / np.timedelta64(1, "ns") * 1e-9)}


def rigid_validation(seeds: int, workers: int) -> dict[str, Any]:
    """The rigid-mount plan's predicted uncertainties against its simulated, processed hovers."""
    body = {"name": "rigid_mount_plan", "site": SITE, **RIGID_PLAN, "monte_carlo": {"seed": 1}}
    spec = parse_plan(body, "plan_validation:rigid_mount_plan")
    plan = plan_campaign(spec, simulate_power=False)
    print(plan.table(), flush=True)
    tasks = [(u, plan.duration_s, 20_000 + s, spec.obukhov_length_m) for u in plan.speeds_ms
             for s in range(1, seeds + 1)]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        stats = list(pool.map(_rigid_statistics, tasks))
    per_q: dict[str, Any] = {}
    for q in QUANTITIES:
        ach, pred = [], []
        for j, u in enumerate(plan.speeds_ms):
            rows = stats[j * seeds:(j + 1) * seeds]
            vals = np.array([r[q] for r in rows])
            dur = float(np.mean([r["duration_s"] for r in rows]))
            ach.append(float(np.std(vals, ddof=1) / abs(np.mean(vals))))
            pred.append(plan_uncertainty(spec, u).relative(dur)[q])
        ratio = math.sqrt(np.mean(np.square(ach)) / np.mean(np.square(pred)))
        per_q[q] = {"achieved_per_flight": ach, "predicted_per_flight": pred, "ratio_rms": ratio,
                    "ratio_standard_error": ratio / math.sqrt(2 * len(plan.speeds_ms) * (seeds - 1)),
                    "within_20_percent": abs(ratio - 1) <= 0.2}
    print("rigid_mount_plan: uncertainty ratios " + ", ".join(f"{q} {v['ratio_rms']:.2f}" for q, v in per_q.items()),
          flush=True)
    return {"plan": {"hover_duration_s": plan.duration_s, "speeds_ms": plan.speeds_ms, "hover_height_m": 40.0,
                     "obukhov_length_m": spec.obukhov_length_m, "platform": "rigid_mount"},
            "power": "not simulated: the campaign diagnosis is the sling-load payload's",
            "uncertainty": per_q, "uncertainty_within_20_percent": all(v["within_20_percent"] for v in per_q.values())}


def compare_rates(k_pred: int, n_pred: int, k_sim: int, n_sim: int, points: float = 0.10) -> dict[str, Any]:
    """Predicted against simulated detection rate, with their Monte-Carlo uncertainty.

    The point difference, its standard error (two independent binomial shares; each share
    taken as (k + 1/2)/(n + 1) in the variance so that 0/n and n/n do not give zero), its 95 %
    interval, whether the point difference is within ``points`` and whether that interval
    reaches within ``points`` (the data do not exclude agreement within ``points``), and
    whether the two 95 % Wilson intervals (Wilson 1927) overlap.
    """
    p_pred, p_sim = k_pred / n_pred, k_sim / n_sim
    a, b = (k_pred + 0.5) / (n_pred + 1), (k_sim + 0.5) / (n_sim + 1)
    se = math.sqrt(a * (1 - a) / n_pred + b * (1 - b) / n_sim)
    diff = p_sim - p_pred
    lo, hi = diff - 1.959963984540054 * se, diff + 1.959963984540054 * se
    wp, ws = wilson_interval(k_pred, n_pred), wilson_interval(k_sim, n_sim)
    return {"difference": diff, "difference_se": se, "difference_ci95": [lo, hi],
            "within_10_points": abs(diff) <= points, "compatible_with_10_points": lo <= points and hi >= -points,
            "wilson_intervals_overlap": wp[0] <= ws[1] and ws[0] <= wp[1]}


def table4_comparison() -> dict[str, Any]:
    """The planner's Ghirardelli et al. (2025) metric at their Table 4 conditions and durations.

    The published values are in their Fig. 16, which is not digitised; the comparison is with
    their printed statements (Sect. 5.3): most samples below 0.5, s2-s4 above it for their weak
    wind, s5 a high a_theta_w for its short record among the stationary samples. Roughness
    length 0.3 m and boundary-layer depth 1500 m (unstable) or 1000 m (stable) are assumed
    (not in Table 4).
    """
    from dronewind.diagnose.published_file import load_published
    from dronewind.plan.uncertainty import point_uncertainty

    root = Path(__file__).resolve().parents[1]
    pub = load_published(root / "config" / "published" / "ghirardelli2025_samurai_s.yaml")
    rows: dict[str, Any] = {}
    for flight, row in pub["table4"].items():
        z, zeta = float(row["payload_height_m"]), float(row["zeta"])
        pu = point_uncertainty(z, float(row["wind_speed_ms"]), float(row["wind_from_deg"]), z / zeta, 0.3,
                               1500.0 if zeta < 0 else 1000.0, 285.0, seed=1)
        duration = 60.0 * float(row["duration_min"])
        rows[flight] = {"duration_s": duration, "wind_speed_ms": float(row["wind_speed_ms"]), "zeta": zeta,
                        "paper_metric": pu.paper(duration), "relative_uncertainty": pu.relative(duration)}
    stationary = list(pub["stationary_flights"])
    weak = ["s02", "s03", "s04"]
    checks = {
        "weak_wind_samples_mostly_above_0.5": {f: sum(v > 0.5 for v in rows[f]["paper_metric"].values()) >= 3
                                               for f in weak},
        "stationary_samples_all_below_0.5": {f: all(v < 0.5 for v in rows[f]["paper_metric"].values())
                                             for f in stationary},
        "s05_highest_a_theta_w_of_stationary":
            max(stationary, key=lambda f: rows[f]["paper_metric"]["wtheta"]) == "s05",
    }
    agree = (all(checks["weak_wind_samples_mostly_above_0.5"].values())
             and all(checks["stationary_samples_all_below_0.5"].values())
             and checks["s05_highest_a_theta_w_of_stationary"])
    return {"source": "Ghirardelli et al. (2025), Table 4 (conditions, durations); Sect. 5.3 and Fig. 16 (statements)",
            "published": {"most_below_0.5": True, "above_0.5": weak, "high_a_theta_w_stationary": "s05",
                          "not_reproduced_by_design": "s09 high a_theta_w (called unclear in the paper, drone only)"},
            "samples": rows, "checks": checks, "agrees_with_statements": bool(agree)}


def _spec(name: str, flights: int, draws: int, curve_draws: int = 20) -> Any:
    body = {"name": name, "site": SITE, "platform": {"kind": "sling_load", "max_hover_min": 25},
            **PLANS[name], "monte_carlo": {"draws": draws, "curve_draws": min(curve_draws, draws), "seed": 1}}
    body["targets"] = {**body["targets"], "power": 0.8, "max_flights": flights}
    return parse_plan(body, f"plan_validation:{name}")


def _run(task: tuple[dict[str, Any], Any, int]) -> dict[str, Any]:
    manifest, error, seed = task
    return simulated_detection(manifest, error, [seed])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--flights", type=int, default=3, help="max_flights of every plan")
    parser.add_argument("--draws", type=int, default=60, help="Monte-Carlo draws of the predicted power")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--plans", nargs="*", default=list(PLANS))
    parser.add_argument("--out", type=Path,
                        default=Path(__file__).resolve().parent / "results" / "plan_validation.json")
    parser.add_argument("--curve-draws", type=int, default=20, help="Monte-Carlo draws per point of the power curve")
    parser.add_argument("--rigid-only", action="store_true", help="only the rigid-mount plan (uncertainties)")
    parser.add_argument("--no-rigid", action="store_true", help="without the rigid-mount plan")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    results: dict[str, Any] = {} if args.no_rigid else {"rigid_mount_plan": rigid_validation(args.seeds, args.workers)}
    table4 = table4_comparison()
    print(f"Ghirardelli et al. (2025) Table 4: statements reproduced {table4['agrees_with_statements']}", flush=True)
    if args.rigid_only:
        args.plans = []
    tasks, owners = [], []
    plans = {}
    for name in args.plans:
        spec = _spec(name, args.flights, args.draws, args.curve_draws)
        t = time.process_time()
        logging.getLogger("dronewind").setLevel(logging.INFO)  # the planner's progress
        plan = plan_campaign(spec)
        logging.getLogger("dronewind").setLevel(logging.WARNING)
        plans[name] = (spec, plan)
        print(f"{name}: planned in {time.process_time() - t:.1f} CPU-s\n{plan.table()}", flush=True)
        error = spec.detect[0]
        for s in range(1, args.seeds + 1):
            tasks.append((plan.manifest, error, 10_000 + s))
            owners.append(name)
    outs: dict[str, list[dict[str, Any]]] = {name: [] for name in plans}
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        for i, (name, out) in enumerate(zip(owners, pool.map(_run, tasks), strict=True)):
            outs[name].append(out)
            print(f"campaign {i + 1}/{len(tasks)} {name} seed done ({out['evidence_seconds'][0]:.0f} CPU-s, "
                  f"named {out['named'][0]}, detected {out['detected']})", flush=True)
    ok_all = all(bool(r["uncertainty_within_20_percent"]) for r in results.values())
    for name, (spec, plan) in plans.items():
        runs = outs[name]
        label = spec.detect[0].label
        k = sum(r["detected"] for r in runs)
        n = sum(r["n"] for r in runs)
        rate = k / n
        predicted = plan.power[label]
        comparison = compare_rates(predicted.detected, predicted.draws, k, n)
        power_ok = comparison["within_10_points"]
        flights = sorted(runs[0]["statistics"][0])
        per_q: dict[str, Any] = {}
        for q in QUANTITIES:
            ach, pred = [], []
            for j, fid in enumerate(flights):
                vals = np.array([r["statistics"][0][fid][q] for r in runs])
                dur = float(np.mean([r["statistics"][0][fid]["duration_s"] for r in runs]))
                ach.append(float(np.std(vals, ddof=1) / abs(np.mean(vals))))
                pred.append(plan_uncertainty(spec, plan.speeds_ms[j]).relative(dur)[q])
            ratio = math.sqrt(np.mean(np.square(ach)) / np.mean(np.square(pred)))
            # sampling error of the ratio: each flight's scatter from `seeds` values
            ratio_se = ratio / math.sqrt(2 * len(flights) * (len(runs) - 1))
            per_q[q] = {"achieved_per_flight": ach, "predicted_per_flight": pred, "ratio_rms": ratio,
                        "ratio_standard_error": ratio_se, "within_20_percent": abs(ratio - 1) <= 0.2}
        unc_ok = all(v["within_20_percent"] for v in per_q.values())
        ok_all &= power_ok and unc_ok
        results[name] = {
            "plan": {"hover_duration_s": plan.duration_s, "n_flights": plan.n_flights, "speeds_ms": plan.speeds_ms,
                     "hover_height_m": spec.hover_height_m, "separation_limit_m": plan.separation_limit_m,
                     "obukhov_length_m": spec.obukhov_length_m, "error": label},
            "predicted_power": predicted.power, "predicted_power_ci95": list(predicted.interval),
            "predicted_draws": predicted.draws,
            "simulated_detection": rate, "simulated_detected": k, "simulated_n": n,
            "simulated_ci95": list(wilson_interval(k, n)), "power_within_10_points": power_ok,
            "power_comparison": comparison,
            "predicted_false_alarm": None if plan.false_alarm is None else 1.0 - plan.false_alarm.power,
            "planner_cpu_seconds": plan.seconds.get("total_cpu"),
            "uncertainty": per_q, "uncertainty_within_20_percent": unc_ok,
            "named_per_seed": [r["named"][0] for r in runs],
            "cpu_seconds_per_campaign": float(np.mean([r["evidence_seconds"][0] for r in runs])),
        }
        print(f"{name}: power predicted {predicted.power:.2f} ({predicted.detected}/{predicted.draws}) simulated "
              f"{rate:.2f} ({k}/{n}), difference {comparison['difference']:+.2f} +- "
              f"{comparison['difference_se']:.2f}; uncertainty ratios "
              + ", ".join(f"{q} {v['ratio_rms']:.2f}" for q, v in per_q.items()), flush=True)
    doc = {"command": "PYTHONPATH=src nice -n 10 .venv/bin/python benchmarks/plan_validation.py "
                      + " ".join(sys.argv[1:] if argv is None else argv),
           "seeds": args.seeds, "criteria": {"uncertainty": "|achieved/predicted - 1| <= 0.2 (rms over flights)",
                                            "power": "|simulated rate - predicted power| <= 0.10 (point); "
                                                     "compatible: the difference's 95 % interval reaches within 0.10"},
           "all_met": bool(ok_all), "plans": results, "ghirardelli2025_table4": table4,
           "wall_seconds": time.perf_counter() - wall0, "parent_cpu_seconds": time.process_time() - cpu0}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    print(f"written {args.out}; all criteria met: {ok_all}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
