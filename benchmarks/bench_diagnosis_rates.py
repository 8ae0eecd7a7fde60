"""Detection, false-alarm and estimate-error rates of the diagnosis over stratified hidden-effect draws.

Each draw hides, in a 4-flight virtual campaign of 12-minute hovers, either nothing (null),
a model error (dronewind.diagnose.experiments.MODEL_ERRORS: another pendulum length or
damping than the forward model's, another turbulence spectrum or isotropy, a trending mean
wind, a mast flow distortion), or one mechanism of experiments.HIDDEN_RANGES on each
side of its "off" value (random size); it is then simulated, processed and diagnosed
in-process (the same library functions as the workflow's rules, default configuration) and
judged against the truth (experiments.judge). Shares: 20 % null, 15 % model error, the rest
cycling through the (mechanism, side) cells.

    PYTHONPATH=src nice -n 10 .venv/bin/python benchmarks/bench_diagnosis_rates.py \\
        --draws 60 --seed 1 --workers 1 --out benchmarks/results/diagnosis_rates.json

Rates (per label, mechanism, case and overall), each with a 95 % Wilson score interval:

* detection: mechanism draws where the hidden mechanism is named (or in an ambiguity set
  with a named one);
* false alarm: null draws with any named cause; false attribution: model-error draws with
  a named catalog cause (the right verdict is none, the misfit belongs in ``unexplained``),
  and those of them whose named causes the diagnosis does not flag with a caveat of the
  model error's kind (experiments.CAVEATED_MODEL_ERRORS);
* withheld: draws where a significant candidate was not named because its evidence rests on
  one feature that an effect outside the catalog moves alike
  (dronewind.diagnose.campaign.FEATURE_ALIASES);
* wrong cause: mechanism draws with a named cause that is neither the truth nor ambiguous
  with it;
* estimate within tolerance, and the median of |estimate - truth| / tolerance over detected
  draws with its distribution-free 95 % interval (binomial order statistics);
* null calibration of the likelihood-ratio test: over the candidates of the null draws, the
  share of p-values below 0.01 and 0.05 (nominal 0.01 and 0.05 if the whitened misfit is
  chi-square), the mean likelihood-ratio statistic the candidates are tested by (the profile
  one) per fitted parameter (nominal 1) and the share of null
  draws where some candidate passes the Bonferroni-corrected test before the gain filter.

``--only`` keeps the draws whose label starts with one of the given prefixes (e.g.
``--only model_error:mean_wind_trend,model_error:mast_flow_distortion``), after drawing,
so the kept draws are those of the full stratified set:

    PYTHONPATH=src nice -n 5 .venv/bin/python benchmarks/bench_diagnosis_rates.py \\
        --draws 12 --seed 1 --null-share 0 --model-error-share 1 \\
        --only model_error:turbulence,model_error:mean_wind,model_error:mast \\
        --out benchmarks/results/diagnosis_model_errors.json

Draws run in a fixed random order (so that a partial progress log mixes the cases). A
progress log (one JSON line per draw) goes to the output path with ``.log``; the results
file is written atomically at the end.

``--evidence DIR`` keeps each draw's diagnosis input (measured features and forward runs,
:func:`dronewind.diagnose.in_process.campaign_evidence`) as ``DIR/draw<index>.json.gz``,
and a draw whose file is already there is only diagnosed again: a change to the diagnosis
itself (not to the simulator or the chain) is then measured on the very same draws in
about a second per draw, before against after (another source tree on ``PYTHONPATH``, with
``dronewind.diagnose.in_process.diagnose_evidence``, rescores kept evidence with its own diagnosis)::

    PYTHONPATH=src .venv/bin/python benchmarks/bench_diagnosis_rates.py --draws 60 --seed 1 \\
        --workers 2 --evidence /tmp/rates_evidence --out /tmp/rates_after.json
    PYTHONPATH=/tmp/base/src .venv/bin/python benchmarks/bench_diagnosis_rates.py --draws 60 --seed 1 \\
        --evidence /tmp/rates_evidence --out /tmp/rates_before.json
"""

from __future__ import annotations

import argparse
import gzip
import json
import os
import sys
import tempfile
import time
from collections import defaultdict
from multiprocessing import Pool
from pathlib import Path
from typing import Any

import numpy as np
import scipy.stats
import yaml

from bench_common import git_commit
from dronewind.diagnose import experiments as experiments_module
from dronewind.diagnose.experiments import Draw, judge, stratified_draws, wilson_interval
from dronewind.diagnose.in_process import diagnose_evidence
from dronewind.manifest import with_defaults

REPO = Path(__file__).resolve().parents[1]


def rate(flags: list[bool]) -> dict[str, Any]:
    """Proportion with its 95 % Wilson interval."""
    k, n = int(sum(bool(f) for f in flags)), len(flags)
    lo, hi = wilson_interval(k, n)
    return {"k": k, "n": n, "rate": k / n if n else float("nan"), "ci95": [lo, hi]}


def median_ci(values: list[float]) -> dict[str, Any]:
    """Median with a distribution-free 95 % interval from binomial order statistics."""
    x = np.sort(np.asarray([v for v in values if np.isfinite(v)], dtype=float))
    n = x.size
    if n == 0:
        return {"n": 0, "median": float("nan"), "ci95": [float("nan"), float("nan")]}
    lo_k = int(scipy.stats.binom.ppf(0.025, n, 0.5))
    hi_k = int(scipy.stats.binom.ppf(0.975, n, 0.5))
    lo = float(x[lo_k - 1]) if lo_k >= 1 else float("nan")
    hi = float(x[hi_k]) if hi_k < n else float("nan")
    return {"n": int(n), "median": float(np.median(x)), "ci95": [lo, hi]}


def _evidence(truth: Draw, config: dict[str, Any], path: Path | None) -> dict[str, Any]:
    """The draw's diagnosis input: read from ``path`` if there (checked against the draw), else made (and kept)."""
    key = {"label": truth.label, "seed": truth.seed, "mechanism": truth.mechanism, "parameters": truth.parameters,
           "model_error": truth.model_error}
    if path is not None and path.is_file():
        with gzip.open(path, "rt") as fh:
            kept = json.load(fh)
        if kept["draw"] != json.loads(json.dumps(key)):
            raise ValueError(f"{path}: kept evidence of draw {kept['draw']}, not of {key}")
        return kept["evidence"]
    from dronewind.diagnose.in_process import campaign_evidence

    with tempfile.TemporaryDirectory() as work:
        evidence = campaign_evidence(truth, config, work)
    if path is not None:
        tmp = path.with_suffix(".tmp")
        with gzip.open(tmp, "wt") as fh:
            json.dump({"draw": key, "evidence": evidence}, fh)
        os.replace(tmp, path)
    return evidence


def one(args: tuple[int, Draw, Path | None]) -> dict[str, Any]:
    """Simulate, process, diagnose and judge one draw (the simulation read back from ``--evidence`` if kept)."""
    index, truth, evidence_dir = args
    config = yaml.safe_load((REPO / "config/config.yaml").read_text())
    start = time.perf_counter()
    try:
        path = None if evidence_dir is None else evidence_dir / f"draw{index}.json.gz"
        reused = path is not None and path.is_file()
        diagnosis = diagnose_evidence(_evidence(truth, config, path), config)
    except Exception as exc:  # a draw the chain cannot process is a failure, reported, not a crash
        verdict = judge(truth, {"named_causes": []})
        verdict.update(index=index, seed=truth.seed, detected=False, estimate_ok=False,
                       error=f"{type(exc).__name__}: {exc}", seconds=time.perf_counter() - start)
        return verdict
    verdict = judge(truth, diagnosis)
    em = diagnosis.get("error_model", {})
    verdict.update(
        index=index, seed=truth.seed, seconds=time.perf_counter() - start, evidence_reused=reused,
        # "lr": the statistic the candidate was tested by (the profile likelihood ratio where recorded)
        candidates=[{"mechanism": c["mechanism"], "gain": c["gain"],
                     "lr": c["lr_profile"] if c.get("lr_profile") is not None else c["lr_statistic"],
                     "lr_conditional": c["lr_statistic"], "p": c["p_value"],
                     "k": c["n_parameters"], "significant": c["significant"]} for c in diagnosis["candidates"]],
        error_model={k: em.get(k) for k in ("n_seeds", "dof", "shrinkage_intensity")},
        goodness_of_fit=diagnosis.get("goodness_of_fit"),
        unexplained=[u["feature"] for u in diagnosis.get("unexplained", [])],
        caveats=[c["mechanism"] for c in diagnosis.get("caveats", [])],
        withheld=[{k: w[k] for k in ("mechanism", "feature", "share", "p_value")}
                  for w in diagnosis.get("withheld", [])],
    )
    return verdict


def summarise(verdicts: list[dict[str, Any]], alpha: float) -> dict[str, Any]:
    """Rates per label, mechanism and case, overall, and the null calibration of the LR test."""
    def block(vs: list[dict[str, Any]]) -> dict[str, Any]:
        out: dict[str, Any] = {"n": len(vs)}
        mech = [v for v in vs if v["case"] == "mechanism"]
        null = [v for v in vs if v["case"] == "null"]
        model = [v for v in vs if v["case"] == "model_error"]
        if mech:
            out["detection"] = rate([v["detected"] for v in mech])
            out["wrong_cause"] = rate([v["wrong_cause"] for v in mech])
            out["estimate_within_tolerance"] = rate([v["estimate_ok"] for v in mech])
            out["estimate_error_over_tolerance"] = median_ci([v["estimate_error"] for v in mech if v["detected"]])
            # a significant candidate not named: it rests on one feature an effect outside the
            # catalog moves alike
            out["withheld"] = rate([bool(v.get("withheld")) for v in mech])
        if null:
            out["false_alarm"] = rate([v["false_alarm"] for v in null])
        if model:
            out["false_attribution"] = rate([v["false_alarm"] for v in model])
            out["false_attribution_not_caveated"] = rate([v["false_alarm"] and not v.get("caveated") for v in model])
            out["withheld"] = rate([bool(v.get("withheld")) for v in model])
        if null or model:
            out["any_named_without_catalog_truth"] = rate([v["false_alarm"] for v in null + model])
        return out

    groups: dict[str, dict[str, list[dict[str, Any]]]] = {"label": defaultdict(list), "mechanism": defaultdict(list),
                                                          "case": defaultdict(list)}
    for v in verdicts:
        groups["label"][v["label"]].append(v)
        groups["mechanism"][v["mechanism"] if v["case"] != "model_error" else v["label"]].append(v)
        groups["case"][v["case"]].append(v)
    null_cands = [c for v in verdicts if v["case"] == "null" for c in v.get("candidates", [])]
    null_draws = [v for v in verdicts if v["case"] == "null" and v.get("candidates")]
    n_tests = {v["index"]: len({c["mechanism"] for c in v["candidates"]}) for v in null_draws}
    calibration = {
        "n_candidate_tests": len(null_cands),
        "p_below_0.01": rate([c["p"] < 0.01 for c in null_cands]),
        "p_below_0.05": rate([c["p"] < 0.05 for c in null_cands]),
        "mean_lr_per_parameter": float(np.mean([c["lr"] / c["k"] for c in null_cands if c["k"]]))
        if null_cands else float("nan"),
        "familywise_lr_pass": rate([any(c["p"] < alpha / n_tests[v["index"]] for c in v["candidates"])
                                    for v in null_draws]),
        "nominal_familywise_alpha": alpha,
    }
    intensities = [v["error_model"].get("shrinkage_intensity") for v in verdicts
                   if v.get("error_model", {}).get("shrinkage_intensity") is not None]
    return {
        "overall": block(verdicts),
        "by_case": {k: block(vs) for k, vs in sorted(groups["case"].items())},
        "by_mechanism": {k: block(vs) for k, vs in sorted(groups["mechanism"].items())},
        "by_label": {k: block(vs) for k, vs in sorted(groups["label"].items())},
        "null_lr_calibration": calibration,
        "shrinkage_intensity": median_ci(intensities) if intensities else None,
        "failed_draws": [{"index": v["index"], "label": v["label"], "error": v["error"]}
                         for v in verdicts if v.get("error")],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--draws", type=int, default=60)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--null-share", type=float, default=0.2)
    parser.add_argument("--model-error-share", type=float, default=0.15)
    parser.add_argument("--only", default="",
                        help="comma-separated label prefixes: keep only these draws (e.g. model_error:mast)")
    parser.add_argument("--out", type=Path, default=REPO / "benchmarks/results/diagnosis_rates.json")
    parser.add_argument("--evidence", type=Path,
                        help="folder that keeps each draw's diagnosis input; kept draws are only diagnosed again")
    args = parser.parse_args()
    if args.evidence is not None:
        args.evidence.mkdir(parents=True, exist_ok=True)
    config = yaml.safe_load((REPO / "config/config.yaml").read_text())
    diag = with_defaults(config)["diagnosis"]
    draws = stratified_draws(args.draws, args.seed, args.null_share, args.model_error_share)
    prefixes = [p for p in args.only.split(",") if p]
    if prefixes:
        draws = [d for d in draws if any(d.label.startswith(p) for p in prefixes)]
    log_path = args.out.with_suffix(".log")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    # the source tree that runs (an older worktree on PYTHONPATH when rescoring kept evidence)
    commit = git_commit(Path(experiments_module.__file__).parent)
    verdicts = []
    with log_path.open("w") as log:
        log.write(json.dumps({"command": " ".join(sys.argv), "commit": commit, "draws": len(draws),
                              "seed": args.seed}) + "\n")
        log.flush()
        # a fixed permutation, so that a partial log mixes the cases
        jobs = [(int(k), draws[k], args.evidence) for k in np.random.default_rng(args.seed).permutation(len(draws))]
        results = Pool(args.workers).imap_unordered(one, jobs) if args.workers > 1 else map(one, jobs)
        for verdict in results:
            verdicts.append(verdict)
            line = json.dumps(verdict, default=str)
            log.write(line + "\n")
            log.flush()
            print(f"[{len(verdicts)}/{len(draws)}] {verdict['label']}: named {verdict['named']} "
                  f"detected={verdict['detected']} ({verdict['seconds']:.0f} s)", flush=True)
    verdicts.sort(key=lambda v: v["index"])
    summary = summarise(verdicts, float(diag["alpha"]))
    result = {
        "command": "PYTHONPATH=src nice -n 10 .venv/bin/python benchmarks/bench_diagnosis_rates.py "
                   f"--draws {args.draws} --seed {args.seed} --workers {args.workers} "
                   f"--null-share {args.null_share} --model-error-share {args.model_error_share}"
                   + (f" --only {args.only}" if prefixes else "")
                   + (f" --evidence {args.evidence}" if args.evidence is not None else ""),
        "commit": commit,
        "settings": {"draws": args.draws, "kept_draws": len(draws), "only": prefixes, "seed": args.seed,
                     "null_share": args.null_share,
                     "model_error_share": args.model_error_share, "diagnosis": diag,
                     "campaign": "4 flights, 12-min hovers, 3.5-9.5 m/s (experiments.campaign_manifest)"},
        "wall_seconds": time.perf_counter() - start,
        "cpu_seconds_per_draw": float(np.mean([v["seconds"] for v in verdicts])),
        "summary": summary,
        "draws": verdicts,
    }
    tmp = args.out.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(result, indent=1, default=str))
    os.replace(tmp, args.out)
    print(json.dumps(summary["overall"], indent=1))
    print(json.dumps(summary["null_lr_calibration"], indent=1))


if __name__ == "__main__":
    main()
