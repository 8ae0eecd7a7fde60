"""Rates of the diagnosis on campaigns written by an independent simulated world (tests/worlds).

Each draw writes a measured campaign (manifest without ``simulation:``, contract L0 files)
with the world's own physics: a Mann turbulence box (hipersim) holding the mast sonic and
the payload, a rope pendulum with drag under a jittering drone, an aided INS with its own
errors, a per-flight sonic-INS processing lag that is not a hidden effect. It hides
nothing (null), a model error of the world (tests.worlds.WORLD_MODEL_ERRORS: another Mann
Gamma, a mean-wind trend, mast flow distortion, another rope), or one catalog mechanism of
tests.worlds.HIDDEN_MECHANISMS with a size from experiments.HIDDEN_RANGES (both sides where
signed). The campaign is then processed and diagnosed in this process with the library
(in_process.measured_campaign_evidence, then in_process.diagnose_evidence; default
configuration) and judged by experiments.judge: nulls and model errors must name nothing,
a hidden mechanism must be the first named cause (or share an ambiguity set with it) with
its estimate within experiments.TOLERANCES. For ``sonic_ins_lag`` the truth is the hidden
lag alone (the per-flight base lag is part of every flight, null or not), judged by
experiments.judge_hidden_lag against the world's own base lags.

Examples::

    # pilot: 8 draws of 4 flights of 12-min hovers, two workers, niced
    PYTHONPATH=src nice -n 10 .venv/bin/python benchmarks/validate_independent_world.py \\
        --draws 8 --seed 1 --workers 2 --out benchmarks/results/diagnosis_independent_world.json
    # the full measurement
    PYTHONPATH=src nice -n 10 .venv/bin/python benchmarks/validate_independent_world.py \\
        --draws 60 --seed 1 --workers 2 --out benchmarks/results/diagnosis_independent_world.json
    # base lags of 50-150 ms of either sign instead of the paper's -0.185..0 s
    ... --base-lag symmetric
    # the forward model's payload attitude following the line (diagnosis.forward_payload)
    ... --forward-payload rope_pitch_fraction=1,rope_roll_fraction=1 --evidence-dir EVIDENCE_ROPE

The plan of draws is fixed by ``--draws`` and ``--seed`` (draw ``k`` is the same whatever
subset runs); ``--indices`` runs part of it, by default in an interleaved order (nulls, model
errors and mechanisms in proportion, so that a stopped run is a fair sample of the plan).
Every draw's evidence (the processed campaign: measured features and forward runs) and the
world's base lags are kept in ``--evidence-dir`` as ``draw{k:03d}.json``: a later run with the
same plan reuses them and only diagnoses again (``--evidence-only`` writes evidence without
diagnosing). The results file holds every draw of the plan whose evidence is kept.

The results also hold ``feature_offsets``: what the forward model gets wrong in this world,
feature by feature (each draw's mean standardised baseline residual, ``baseline_mean_z``,
pooled over the null and model-error draws and tested over them by
dronewind.diagnose.pooled.pooled_offsets, as ``dronewind model-error`` does for measured
campaigns; with the share of those draws whose own diagnosis lists the feature unexplained, and
the mean per label, so that a hidden mechanism's signal can be read against the nulls').
``wall_s`` is the time of this run: a run on kept evidence only diagnoses (about 8 min for 60
draws on two workers, against about 30 min with the processing).

A progress log (one JSON line per draw) goes to the output path with ``.log``; the results
file is rewritten after every draw (so a stopped run keeps what it measured).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import shlex
import sys
import tempfile
import time
from collections.abc import Mapping
from dataclasses import asdict, replace
from multiprocessing import Pool
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from tests.worlds import WorldSettings, stratified_world_draws, write_campaign  # noqa: E402

from bench_common import git_commit, machine  # noqa: E402
from dronewind.diagnose.evidence import finite_or_none  # noqa: E402
from dronewind.diagnose.experiments import Draw, judge, judge_hidden_lag, wilson_interval  # noqa: E402
from dronewind.diagnose.features import FEATURES  # noqa: E402
from dronewind.diagnose.in_process import diagnose_evidence, measured_campaign_evidence  # noqa: E402
from dronewind.diagnose.pooled import pooled_offsets, residual_mean_z  # noqa: E402
from dronewind.manifest import default_config  # noqa: E402

#: Targets the rates are read against (reported, never tuned to).
TARGETS = {"nothing_named_null_and_model_error": (">=", 0.90), "named_right_in_tolerance": (">=", 0.85),
           "wrong_cause": ("<=", 0.05)}


def _evidence_path(evidence_dir: str, index: int) -> Path:
    return Path(evidence_dir) / f"draw{index:03d}.json"


def draw_evidence(index: int, truth: Draw, config: Mapping[str, Any], settings: WorldSettings,
                  keep: str | None, evidence_dir: str) -> dict[str, Any]:
    """The processed campaign of draw ``index``: read from ``evidence_dir`` when kept for the same truth
    and world, else written, processed and kept (a failing chain is kept as the draw's error)."""
    path = _evidence_path(evidence_dir, index)
    key = {"truth": asdict(truth), "world": _world(settings)}
    forward_payload = dict(config["diagnosis"].get("forward_payload") or {})
    if forward_payload:  # the forward runs depend on it (evidence kept without it has none)
        key["forward_payload"] = forward_payload
    if path.exists():
        stored = json.loads(path.read_text())
        if stored.get("key") == json.loads(json.dumps(key, default=str)):
            return stored
    out: dict[str, Any] = {"key": key}
    with tempfile.TemporaryDirectory(prefix=f"world{index}_") as tmp:
        folder = Path(keep) / f"draw{index}" if keep else Path(tmp)
        c0 = c1 = time.process_time()
        try:
            manifest = write_campaign(truth, folder, settings, name=f"world{index}")
            c1 = time.process_time()
            out["evidence"] = measured_campaign_evidence(manifest, config)
            out["cpu_process_s"] = time.process_time() - c1
            truth_file = json.loads((folder / "truth.json").read_text())
            out["base_lags_s"] = {f: c["base_lag_s"] for f, c in truth_file["flights"].items()}
        except Exception as exc:  # a failing chain is a result of the draw, counted as such
            out["error"] = f"{type(exc).__name__}: {exc}"
        out["cpu_write_s"] = c1 - c0
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp_path = path.with_suffix(".tmp")
    tmp_path.write_text(json.dumps(out, default=str))
    tmp_path.replace(path)
    return json.loads(path.read_text())


def run_draw(job: tuple[int, Draw, Mapping[str, Any], WorldSettings, str | None, str, bool]) -> dict[str, Any]:
    """Evidence (kept or made), diagnosis and judgement of one draw; its record with CPU seconds per stage."""
    index, truth, config, settings, keep, evidence_dir, evidence_only = job
    out: dict[str, Any] = {"index": index, "label": truth.label, "case": truth.case, "seed": truth.seed}
    stored = draw_evidence(index, truth, config, settings, keep, evidence_dir)
    out["cpu_write_s"] = stored.get("cpu_write_s", 0.0)
    out["cpu_process_s"] = stored.get("cpu_process_s", 0.0)
    if "error" in stored:
        out["error"] = stored["error"]
        return out
    if evidence_only:
        out["evidence_only"] = True
        return out
    evidence = stored["evidence"]
    c2 = time.process_time()
    try:
        diagnosis = diagnose_evidence(evidence, config)
    except Exception as exc:  # a failing diagnosis is a result of the draw, counted as such; the study goes on
        out["error"] = f"diagnosis: {type(exc).__name__}: {exc}"
        return out
    out["cpu_diagnose_s"] = time.process_time() - c2
    base_lags = stored["base_lags_s"]
    out["judged"] = judge(truth, diagnosis) if truth.mechanism != "sonic_ins_lag" else judge_hidden_lag(
        truth, diagnosis, base_lags)
    out["named"] = diagnosis.get("named_causes", [])
    out["candidates"] = [{k: c.get(k) for k in ("mechanism", "estimate", "gain", "significant", "p_value")}
                         for c in diagnosis.get("candidates", [])[:4]]
    out["unexplained"] = diagnosis.get("unexplained", [])
    # the forward baseline's misfit by feature (what the model gets wrong in this world: feature_offsets)
    residuals = diagnosis["baseline"].get("residuals")
    out["baseline_mean_z"] = {f: finite_or_none(z) for f, z in residual_mean_z(residuals).items()} if residuals else {}
    out["unusable"] = evidence.get("unusable", [])
    if diagnosis.get("note"):  # too few usable flights: nothing diagnosed (record.not_diagnosed_json)
        out["not_diagnosed"] = diagnosis["note"]
    out["base_lags_s"] = base_lags
    return out


def _world(settings: WorldSettings) -> dict[str, Any]:
    out = {**asdict(replace(settings)), "line": asdict(settings.line), "ins_errors": asdict(settings.ins_errors)}
    if not out["inertial_topup"]:
        del out["inertial_topup"]  # the key of evidence kept before the setting existed
    return out


def interleaved(draws: list[Draw]) -> list[int]:
    """Indices of ``draws`` ordered so that every prefix holds each case (null, model error, mechanism)
    in proportion to the plan: by the position of a draw within its case, as a fraction of that case."""
    by_case: dict[str, list[int]] = {}
    for k, d in enumerate(draws):
        by_case.setdefault(d.case, []).append(k)
    key = {k: ((j + 0.5) / len(ks), k) for ks in by_case.values() for j, k in enumerate(ks)}
    return sorted(range(len(draws)), key=lambda k: key[k])


def _indices(text: str, n: int) -> set[int] | None:
    """``"a:b"`` (a range), ``"1,5,7"`` or empty (all)."""
    if not text:
        return None
    if ":" in text:
        a, b = text.split(":")
        return set(range(int(a or 0), min(int(b or n), n)))
    return {int(v) for v in text.split(",")}


def _rate(k: int, n: int) -> dict[str, Any]:
    lo, hi = wilson_interval(k, n)
    return {"k": k, "n": n, "rate": k / n if n else math.nan, "wilson95": [lo, hi]}


def rates(records: list[dict[str, Any]]) -> dict[str, Any]:
    """The target rates and per-label breakdowns, with 95 % Wilson intervals.

    * nothing_named_null_and_model_error: null and model-error draws naming nothing;
    * named_right_in_tolerance: mechanism draws whose hidden mechanism is detected
      (experiments.judge) AND the first named cause (or ambiguous with it) AND whose
      estimate is within tolerance;
    * wrong_cause: mechanism draws naming a cause neither the truth nor ambiguous with it;
    * errors: draws where writing, processing or the diagnosis failed (counted as failures of
      every rate they enter);
    * not_diagnosed: draws whose chain left fewer usable flights than the diagnosis needs (it
      names nothing and says so: a pass for a null or model error, a miss for a mechanism).
    """
    records = [r for r in records if not r.get("evidence_only")]
    ok = [r for r in records if "judged" in r]
    nulls = [r for r in records if r["case"] in ("null", "model_error")]
    mechs = [r for r in records if r["case"] == "mechanism"]
    quiet = sum(1 for r in nulls if "judged" in r and not r["judged"]["named"])
    right = sum(1 for r in mechs if "judged" in r and r["judged"]["detected"] and r["judged"]["estimate_ok"])
    wrong = sum(1 for r in mechs if "judged" in r and r["judged"]["wrong_cause"])
    out: dict[str, Any] = {
        "nothing_named_null_and_model_error": _rate(quiet, len(nulls)),
        "named_right_in_tolerance": _rate(right, len(mechs)),
        "detected": _rate(sum(1 for r in mechs if "judged" in r and r["judged"]["detected"]), len(mechs)),
        "wrong_cause": _rate(wrong, len(mechs)),
        "errors": len(records) - len(ok),
        "not_diagnosed": sum(1 for r in ok if r.get("not_diagnosed")),
        "by_label": {},
    }
    for r in records:
        cell = out["by_label"].setdefault(r["label"], {"n": 0, "pass": 0})
        cell["n"] += 1
        j = r.get("judged")
        passed = bool(j) and ((not j["named"]) if r["case"] != "mechanism" else (j["detected"] and j["estimate_ok"]
                                                                                 and not j["wrong_cause"]))
        cell["pass"] += int(passed)
    out["targets_met"] = {k: (out[k]["rate"] >= v if op == ">=" else out[k]["rate"] <= v)
                          for k, (op, v) in TARGETS.items() if out[k]["n"]}
    return out


def feature_offsets(records: list[dict[str, Any]]) -> dict[str, Any]:
    """What the forward model gets wrong in this world, feature by feature.

    * pooled: over the null and model-error draws (nothing hidden that the catalog names), each
      feature's mean standardised baseline residual, tested over the campaigns
      (:func:`dronewind.diagnose.pooled.pooled_offsets`, Bonferroni over the features);
    * unexplained_share: the share of those draws whose diagnosis lists the feature as
      ``unexplained`` (the per-campaign test);
    * by_label: the mean standardised baseline residual of every feature per label, so that a
      hidden mechanism's signal can be read against the nulls' offset.
    """
    quiet = [r for r in records if r["case"] in ("null", "model_error") and r.get("baseline_mean_z")]
    z = [{f: (v if v is not None else math.nan) for f, v in r["baseline_mean_z"].items()} for r in quiet]
    pooled = pooled_offsets(z)
    by_label: dict[str, dict[str, Any]] = {}
    for label in sorted({r["label"] for r in records}):
        rows = [r["baseline_mean_z"] for r in records if r["label"] == label and r.get("baseline_mean_z")]
        vals = {f: [v[f] for v in rows if v.get(f) is not None] for f in FEATURES}
        by_label[label] = {"n": len(rows), **{f: finite_or_none(sum(v) / len(v)) if v else None
                                              for f, v in vals.items()}}
    listed = [{u["feature"] for u in r.get("unexplained", [])} for r in quiet]
    return {"pooled": {f: {k: finite_or_none(v) if isinstance(v, float) else v for k, v in e.items()}
                       for f, e in pooled.items()},
            "n_campaigns": len(quiet),
            "unexplained_share": {f: (sum(f in s for s in listed) / len(listed)) if listed else None
                                  for f in FEATURES},
            "by_label": by_label}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--draws", type=int, default=8, help="number of draws (default 8)")
    parser.add_argument("--seed", type=int, default=1, help="seed of the stratified draws (default 1)")
    parser.add_argument("--workers", type=int, default=1, help="processes (default 1)")
    parser.add_argument("--flights", type=int, default=4, help="payload flights per campaign (default 4)")
    parser.add_argument("--hover-min", type=float, default=12.0, help="hover window per flight [min] (default 12)")
    parser.add_argument("--base-lag", choices=["paper", "symmetric"], default="paper",
                        help="per-flight sonic-INS processing lag: paper = uniform in [-0.185, 0] s "
                             "(Ghirardelli et al. 2025, Fig. 4), symmetric = 0.05-0.15 s of either sign")
    parser.add_argument("--null-share", type=float, default=0.2, help="share of null draws (default 0.2)")
    parser.add_argument("--model-error-share", type=float, default=0.2,
                        help="share of model-error draws (default 0.2)")
    parser.add_argument("--only", default="", help="comma-separated label prefixes to keep (after drawing)")
    parser.add_argument("--keep", default=None, help="folder to keep the written campaigns in (default: temp)")
    parser.add_argument("--out", type=Path, default=REPO / "benchmarks/results/diagnosis_independent_world.json")
    parser.add_argument("--evidence-dir", type=Path,
                        default=REPO / "benchmarks/results/diagnosis_independent_world_evidence",
                        help="folder of the kept evidence per draw (reused when present)")
    parser.add_argument("--indices", default="", help="draws of the plan to run: 'a:b' or '1,5,7' (default all)")
    parser.add_argument("--order", choices=["interleaved", "index"], default="interleaved",
                        help="order of the draws (default interleaved: every prefix a fair sample of the plan)")
    parser.add_argument("--evidence-only", action="store_true", help="make and keep the evidence, do not diagnose")
    parser.add_argument("--inertial-topup", action="store_true",
                        help="the world's sensors get the inertial subrange its Mann box lacks above about 1 Hz "
                             "(tests.worlds.turbulence.WindField.topup_enu); use another --evidence-dir")
    parser.add_argument("--forward-payload", default="", metavar="KEY=VALUE,...",
                        help="diagnosis.forward_payload: the forward model's payload settings, e.g. "
                             "rope_pitch_fraction=1,rope_roll_fraction=1 (default: none, the SAMURAI-S defaults); "
                             "use another --evidence-dir, the kept forward runs depend on it")
    args = parser.parse_args(argv)

    settings = WorldSettings(n_flights=args.flights, hover_s=60.0 * args.hover_min, base_lag=args.base_lag,
                             inertial_topup=args.inertial_topup)
    config = default_config()
    config["diagnosis"]["forward_payload"] = {key: float(value) for key, value in
                                              (item.split("=", 1) for item in args.forward_payload.split(",") if item)}
    draws = stratified_world_draws(args.draws, args.seed, args.null_share, args.model_error_share)
    chosen = _indices(args.indices, len(draws))
    order = interleaved(draws) if args.order == "interleaved" else list(range(len(draws)))
    jobs = [(k, draws[k], config, settings, args.keep, str(args.evidence_dir), args.evidence_only) for k in order
            if (chosen is None or k in chosen)
            and (not args.only or any(draws[k].label.startswith(p) for p in args.only.split(",")))]
    # draws of the plan already kept but not chosen this time are diagnosed too: the results hold the plan's kept draws
    kept = [(k, draws[k], config, settings, args.keep, str(args.evidence_dir), args.evidence_only) for k in order
            if _evidence_path(str(args.evidence_dir), k).exists() and all(j[0] != k for j in jobs)
            and (not args.only or any(draws[k].label.startswith(p) for p in args.only.split(",")))]
    jobs = kept + jobs
    command = "PYTHONPATH=src " + " ".join(shlex.quote(a) for a in [Path(sys.executable).name,
                                                                       *sys.argv])
    head = {"command": command, "commit": git_commit(), "machine": machine(), "processor": platform.processor()
            or platform.machine(), "cpu_count": os.cpu_count(), "world": _world(settings),
            "plan": {"draws": args.draws, "seed": args.seed, "null_share": args.null_share,
                     "model_error_share": args.model_error_share},
            "diagnosis_config": config["diagnosis"], "targets": TARGETS}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    log = args.out.with_suffix(".log")
    records: list[dict[str, Any]] = []
    wall0 = time.perf_counter()
    result: dict[str, Any] = {}
    with log.open("w") as fh:
        results = Pool(args.workers).imap_unordered(run_draw, jobs) if args.workers > 1 else map(run_draw, jobs)
        for rec in results:
            records.append(rec)
            fh.write(json.dumps(rec, default=str) + "\n")
            fh.flush()
            print(f"draw {rec['index']:3d} {rec['label']:34s} named={rec.get('named', rec.get('error'))} "
                  f"pass={rec.get('judged', {}).get('detected')} cpu="
                  f"{sum(rec.get(k, 0.0) for k in ('cpu_write_s', 'cpu_process_s', 'cpu_diagnose_s')):.0f}s",
                  flush=True)
            records.sort(key=lambda r: r["index"])
            cpu = [sum(r.get(k, 0.0) for k in ("cpu_write_s", "cpu_process_s", "cpu_diagnose_s")) for r in records]
            diag = [r["cpu_diagnose_s"] for r in records if "cpu_diagnose_s" in r]
            result = {**head, "n_draws": len(records), "wall_s": time.perf_counter() - wall0,
                      "cpu_s_per_draw": {"mean": sum(cpu) / len(cpu), "max": max(cpu),
                                         "diagnose_mean": sum(diag) / len(diag) if diag else None},
                      "rates": rates(records), "feature_offsets": feature_offsets(records), "draws": records}
            if args.evidence_only:
                continue
            tmp = args.out.with_suffix(".tmp")
            tmp.write_text(json.dumps(result, indent=1, default=str) + "\n")
            tmp.replace(args.out)
    print(json.dumps(result.get("rates"), indent=1, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
