"""Calibration of the campaign diagnosis on the project's own simulator: nulls, offsets and trends.

Simulates null virtual campaigns (nothing hidden) and diagnoses each with the workflow's
library functions in this process, then measures what a calibrated diagnosis must show:

* the goodness-of-fit p-values of the nulls are uniform (Kolmogorov-Smirnov test against
  U(0, 1); histogram in the results) and the misfit per degree of freedom is near 1;
* no cause is named on a null (false-alarm rate, Wilson interval);
* a common offset of 2 residual errors in one feature, and a trend of 1.5 residual errors
  per standard deviation of the flights' wind speeds in another, added to a null's measured
  features, are each reported in ``unexplained`` (detection rates, Wilson intervals).

Besides, per feature, the 5 %, 50 % and 95 % quantiles over all flights of each flight's own
seed scatter relative to the pooled scale (``flight_seed_scale``: the ratio the bootstrap's
replicates are drawn with, :func:`dronewind.diagnose.reference.flight_seed_scale`); with
``n`` seeds per flight chance alone spreads it by about 1/sqrt(2(n - 1)).

The forward runs of every draw are kept (``--evidence-dir``, ``draw{k:03d}.json``, deterministic by
draw index ``k``: seed ``--seed + k``), so the statistics can be recomputed without simulating
again (``--reuse``: the kept draws among the first ``--draws``), and a stopped run resumes where
it stopped (draws already kept are not simulated again). The results file is rewritten after
every analysed draw.

Examples
--------
Sixty null campaigns of ten 6-min hovers on two processes::

    nice .venv/bin/python benchmarks/validate_null_calibration.py --draws 60 --workers 2

Recompute the statistics from the kept forward runs::

    .venv/bin/python benchmarks/validate_null_calibration.py --draws 60 --reuse
"""

from __future__ import annotations

import argparse
import functools
import json
import multiprocessing
import platform
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
import scipy.stats

REPO = Path(__file__).resolve().parents[1]
DEFAULT_OUT = REPO / "benchmarks" / "results" / "null_calibration.json"
DEFAULT_EVIDENCE = REPO / "benchmarks" / "results" / "null_calibration_evidence"
#: the processing of the study's short hovers (the chain's hover minimum is 10 min by default)
CONFIG: dict[str, Any] = {"processing": {"hover": {"min_duration_s": 300.0}}}


def _evidence(args: tuple[int, int, float, int, str]) -> str:
    """Simulate, process and forward-run one null campaign; write its evidence JSON; return the path."""
    from dronewind.diagnose import experiments as ex
    from dronewind.diagnose import in_process

    draw_index, n_flights, hover_min, seed, out_dir = args
    path = Path(out_dir) / f"draw{draw_index:03d}.json"
    if path.exists():
        return str(path)
    truth = ex.Draw("none", {}, int(seed) + draw_index)
    speeds = tuple(float(v) for v in np.linspace(3.0, 11.0, n_flights))
    z_over_l = tuple(float(v) for v in np.linspace(-0.3, 0.1, n_flights))
    with tempfile.TemporaryDirectory() as work:
        ev = in_process.campaign_evidence(truth, CONFIG, work, n_flights=n_flights, hover_min=hover_min,
                                          speeds_ms=speeds, z_over_l=z_over_l, name=f"null{draw_index:03d}")
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(ev))
    tmp.replace(path)
    return str(path)


def _inject(ev: Any, kind: str, feature: int) -> None:
    """Add a common offset (2 errors) or a trend (1.5 errors per SD of wind speed) to one feature."""
    sigma = ev.total_sigma[:, feature]
    if kind == "offset":
        ev.y[:, feature] = ev.y[:, feature] + 2.0 * sigma
    else:
        u = ev.speed_ms
        ev.y[:, feature] = ev.y[:, feature] + 1.5 * sigma * (u - u.mean()) / u.std(ddof=1)


def _analyse(path: str, replicates: int, feature_offset: str, feature_trend: str) -> dict[str, Any]:
    """Diagnose one kept evidence file as it is, with an offset and with a trend."""
    from dronewind.diagnose import campaign as dc
    from dronewind.diagnose.features import FEATURES

    cpu0 = time.process_time()
    evidence = json.loads(Path(path).read_text())
    out: dict[str, Any] = {"draw": Path(path).stem}
    ev = dc.assemble(evidence["measured"], evidence["forward"])
    res = dc.diagnose(ev, n_replicates=replicates)
    js = dc.to_json(res, evidence["name"])
    gof = js["baseline"]["goodness_of_fit"]
    out.update({"gof_p": gof["p_value"], "chi2": gof["chi2"], "dof": gof["dof"],
                "reference_mean": gof.get("reference_mean"), "named": js["named_causes"],
                "unexplained": [u["feature"] for u in js["unexplained"]],
                "shrinkage_intensity": js["error_model"].get("shrinkage_intensity"),
                "n_seeds": js["error_model"]["n_seeds"], "n_flights": len(ev.flights),
                "flight_seed_scale": (np.asarray(ev.flight_scale, dtype=float)
                                      / np.asarray(ev.scale, dtype=float)[None, :]).tolist()})
    for kind, feat in (("offset", feature_offset), ("trend", feature_trend)):
        ev_k = dc.assemble(evidence["measured"], evidence["forward"])
        res0 = dc.diagnose(ev_k, n_replicates=0)  # the discrepancy and total errors of the null
        _inject(ev_k, kind, FEATURES.index(feat))
        del res0
        res_k = dc.diagnose(ev_k, n_replicates=replicates)
        found = {u["feature"] for u in dc.to_json(res_k, evidence["name"])["unexplained"]}
        out[f"{kind}_found"] = feat in found
    out["cpu_s"] = time.process_time() - cpu0
    return out


def _wilson(k: int, n: int) -> list[float]:
    from dronewind.diagnose.experiments import wilson_interval

    return [round(v, 3) for v in wilson_interval(k, n)]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog=__doc__.split("Examples\n--------\n")[1])
    parser.add_argument("--draws", type=int, default=60, help="null campaigns (default 60)")
    parser.add_argument("--flights", type=int, default=10, help="payload flights per campaign (default 10)")
    parser.add_argument("--hover-min", type=float, default=6.0, help="hover length [min] (default 6)")
    parser.add_argument("--seed", type=int, default=7000, help="seed of the first draw (default 7000)")
    parser.add_argument("--replicates", type=int, default=300, help="bootstrap replicates (default 300)")
    parser.add_argument("--workers", type=int, default=2, help="processes (default 2)")
    parser.add_argument("--offset-feature", default="ln_sigma_ratio_w")
    parser.add_argument("--trend-feature", default="dir_diff_deg")
    parser.add_argument("--evidence-dir", type=Path, default=DEFAULT_EVIDENCE)
    parser.add_argument("--reuse", action="store_true", help="only analyse the kept evidence")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    args = parser.parse_args(argv)
    args.evidence_dir.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    jobs = [(i, args.flights, args.hover_min, args.seed, str(args.evidence_dir)) for i in range(args.draws)]
    if args.reuse:  # the kept draws among the first --draws (evidence is deterministic by draw index)
        paths = [str(args.evidence_dir / f"draw{i:03d}.json") for i in range(args.draws)
                 if (args.evidence_dir / f"draw{i:03d}.json").exists()]
    else:
        with multiprocessing.get_context("fork").Pool(args.workers) as pool:
            paths = []
            for k, path in enumerate(pool.imap(_evidence, jobs)):
                paths.append(path)
                print(f"evidence {k + 1}/{args.draws} {path}", file=sys.stderr, flush=True)
    t_evidence = time.perf_counter() - start
    rows: list[dict[str, Any]] = []
    work = functools.partial(_analyse, replicates=args.replicates, feature_offset=args.offset_feature,
                             feature_trend=args.trend_feature)
    pool = multiprocessing.get_context("fork").Pool(args.workers) if args.workers > 1 else None
    try:
        for k, row in enumerate(pool.imap(work, paths) if pool is not None else map(work, paths)):
            rows.append(row)
            print(f"analysed {k + 1}/{len(paths)}", file=sys.stderr, flush=True)
            summary = _summary(rows, args, argv, t_evidence, time.perf_counter() - start)
            tmp = args.out.with_suffix(".tmp")
            tmp.write_text(json.dumps(summary, indent=1) + "\n")
            tmp.replace(args.out)  # rewritten after every draw: a stopped run keeps what it measured
    finally:
        if pool is not None:
            pool.close()
    print(json.dumps({k: v for k, v in summary.items() if k != "draws"}, indent=1))
    return 0


def _scale_quantiles(rows: list[dict[str, Any]]) -> dict[str, list[float]]:
    """Feature -> 5, 50 and 95 % quantiles over all flights of the flight's seed scale relative to the pooled one."""
    from dronewind.diagnose.features import FEATURES

    ratios = np.concatenate([np.asarray(r["flight_seed_scale"], dtype=float) for r in rows])
    out = {}
    for k, name in enumerate(FEATURES):
        v = ratios[:, k][np.isfinite(ratios[:, k])]
        if v.size:
            out[name] = [round(float(q), 3) for q in np.quantile(v, [0.05, 0.5, 0.95])]
    return out


def _summary(rows: list[dict[str, Any]], args: argparse.Namespace, argv: list[str] | None, t_evidence: float,
             seconds: float) -> dict[str, Any]:
    """Rates with Wilson intervals, the goodness of fit's uniformity and the rows."""
    p = np.array([r["gof_p"] for r in rows])
    per_dof = np.array([r["chi2"] / r["dof"] for r in rows])
    ks = scipy.stats.kstest(p, "uniform")
    n = len(rows)
    false = sum(bool(r["named"]) for r in rows)
    unexpl = sum(bool(r["unexplained"]) for r in rows)
    off = sum(r["offset_found"] for r in rows)
    tr = sum(r["trend_found"] for r in rows)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=REPO, capture_output=True,
                            text=True).stdout.strip()
    return {
        "command": "benchmarks/validate_null_calibration.py " + " ".join(argv if argv is not None else sys.argv[1:]),
        "commit_of_code": commit,
        "processor": platform.processor() or platform.machine(),
        "campaigns": {"draws": n, "flights": args.flights, "hover_min": args.hover_min,
                      "seeds_per_flight": rows[0]["n_seeds"] if rows else None, "replicates": args.replicates},
        "goodness_of_fit": {
            "ks_uniform_p": float(ks.pvalue), "ks_statistic": float(ks.statistic),
            "histogram_p_deciles": np.histogram(p, bins=10, range=(0, 1))[0].tolist(),
            "chi2_per_dof_median": float(np.median(per_dof)), "chi2_per_dof_mean": float(np.mean(per_dof)),
            "reference_mean_per_dof_median": float(np.median([r["reference_mean"] / r["dof"] for r in rows
                                                              if r["reference_mean"] is not None])),
        },
        "null_named_anything": {"k": false, "n": n, "ci95": _wilson(false, n)},
        "null_unexplained_anything": {"k": unexpl, "n": n, "ci95": _wilson(unexpl, n),
                                      "features": dict(Counter(f for r in rows for f in r["unexplained"]))},
        "offset_2sigma_found": {"feature": args.offset_feature, "k": off, "n": n, "ci95": _wilson(off, n)},
        "trend_1p5sigma_per_sd_found": {"feature": args.trend_feature, "k": tr, "n": n, "ci95": _wilson(tr, n)},
        "shrinkage_intensity_median": float(np.median([r["shrinkage_intensity"] for r in rows])),
        "flight_seed_scale_quantiles": _scale_quantiles(rows),
        "seconds": {"evidence": round(t_evidence, 1), "total": round(seconds, 1),
                    "cpu_per_draw_mean": round(float(np.mean([r["cpu_s"] for r in rows])), 1)},
        "draws": rows,
    }


if __name__ == "__main__":
    raise SystemExit(main())
