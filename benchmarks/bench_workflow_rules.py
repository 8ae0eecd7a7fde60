"""Wall and CPU time per rule of a finished workflow run, from Snakemake's benchmark files.

Every rule writes ``results/<campaign>/benchmarks/<rule>/<wildcards>.tsv`` (Snakemake's
``benchmark:`` directive: wall seconds ``s``, ``cpu_time``, peak ``max_rss`` MB), plus, for
jobs run in the preloaded process, the CPU time of their child (``preloaded_jobs.tsv``). This
script sums them per rule and per stage, e.g. the time of the diagnosis for the default campaign:

    .venv/bin/python benchmarks/bench_workflow_rules.py results/mosai2023
    .venv/bin/python benchmarks/bench_workflow_rules.py results/mosai2023 --stage diagnosis --json out.json
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import pandas as pd

#: Rule name prefix -> stage.
STAGES = {
    "simulate": "simulate", "payload_l1": "payload chain", "mast_l1": "payload chain", "payload_l2": "payload chain",
    "mast_l2": "payload chain", "l3": "payload chain", "l4": "analysis", "flight_stats": "analysis",
    "tables": "analysis", "figures": "analysis", "campaign_record": "analysis",
    "diagnose": "diagnosis", "diagnosis_report": "diagnosis", "published": "published numbers",
    "quadrotor": "quadrotor", "tunnel": "tunnel",
}


def stage_of(rule: str) -> str:
    """Stage of a rule by the longest matching prefix."""
    best = max((p for p in STAGES if rule.startswith(p)), key=len, default=None)
    return STAGES[best] if best else "other"


def collect(results: Path) -> pd.DataFrame:
    """One row per job: rule, job, wall s, CPU s, max RSS MB.

    A job that ran in the preloaded process (``dronewind.steps.preload``) did its work in a
    child of that process, which its benchmark file does not see: its CPU time is the
    benchmark file's (the job's own process) plus the child's, from
    ``benchmarks/preloaded_jobs.tsv`` (``cpu_s_preloaded``).
    """
    rows = []
    for tsv in sorted((results / "benchmarks").glob("*/*.tsv")):
        df = pd.read_csv(tsv, sep="\t")
        rows.append({"rule": tsv.parent.name, "job": tsv.stem, "wall_s": float(df["s"].iloc[-1]),
                     "cpu_s_benchmark": float(df["cpu_time"].iloc[-1]), "max_rss_mb": float(df["max_rss"].iloc[-1])})
    if not rows:
        raise SystemExit(f"{results}: no benchmark files under benchmarks/ (run the workflow first)")
    out = pd.DataFrame(rows)
    preloaded = preloaded_cpu(results / "benchmarks" / "preloaded_jobs.tsv", set(out["rule"]))
    key = list(zip(out["rule"], out["job"], strict=True))
    unmatched = set(preloaded) - set(key)
    if unmatched:
        raise SystemExit(f"{results}: preloaded jobs without a benchmark file: {sorted(unmatched)[:5]}")
    out["cpu_s_preloaded"] = [preloaded.get(k, (0.0, 0.0))[0] for k in key]
    out["cpu_s"] = out["cpu_s_benchmark"] + out["cpu_s_preloaded"]
    out["max_rss_mb"] = [max(rss, preloaded.get(k, (0.0, 0.0))[1]) for k, rss in zip(key, out["max_rss_mb"],
                                                                                       strict=True)]
    out["stage"] = out["rule"].map(stage_of)
    return out


def preloaded_cpu(table: Path, folders: set[str]) -> dict[tuple[str, str], tuple[float, float]]:
    """CPU seconds and peak memory [MB] of the jobs run in the preloaded process, keyed as the
    benchmark files (rule folder, job).

    A rule made per flight (``quadrotor_l1_f01``) has its benchmark files in the folder of its
    stem (``quadrotor_l1/f01.tsv``); a rule with wildcards names its file by their values
    joined with ``_`` (``all`` without wildcards). The table keeps the jobs of every run into
    the folder; a job's last successful line is its last run, which its benchmark file holds.
    """
    if not table.is_file():
        return {}
    df = pd.read_csv(table, sep="\t", dtype={"rule": str, "wildcards": str}, keep_default_na=False)
    df = df[df["exit_status"] == 0]  # a failed attempt (its rule may be unknown) has no benchmark file of its own
    out: dict[tuple[str, str], tuple[float, float]] = {}
    for rule, wildcards, cpu, rss in zip(df["rule"], df["wildcards"], df["cpu_s"], df["max_rss_mb"], strict=True):
        values = list(json.loads(wildcards).values())
        if rule in folders:
            folder, job = rule, "_".join(map(str, values)) or "all"
        else:
            folder = max((f for f in folders if rule.startswith(f + "_")), key=len, default=rule)
            job = rule[len(folder) + 1:]
        out[(folder, job)] = (float(cpu), float(rss))  # a job run again (a later run): its last run, as its file
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("results", type=Path, help="results/<campaign> folder of a finished run")
    parser.add_argument("--stage", help="only this stage (e.g. diagnosis)")
    parser.add_argument("--json", type=Path, help="write the per-stage sums as JSON")
    args = parser.parse_args()
    jobs = collect(args.results)
    if args.stage:
        jobs = jobs[jobs["stage"] == args.stage]
    per_rule = jobs.groupby("rule").agg(jobs=("job", "count"), wall_s=("wall_s", "sum"), cpu_s=("cpu_s", "sum"),
                                        max_rss_mb=("max_rss_mb", "max"))
    per_stage = jobs.groupby("stage").agg(jobs=("job", "count"), wall_s=("wall_s", "sum"), cpu_s=("cpu_s", "sum"),
                                          max_rss_mb=("max_rss_mb", "max"))
    print(per_rule.to_string(float_format=lambda x: f"{x:.1f}"))
    print()
    print(per_stage.to_string(float_format=lambda x: f"{x:.1f}"))
    print(f"\ntotal: {len(jobs)} jobs, {jobs['wall_s'].sum():.0f} job-seconds, {jobs['cpu_s'].sum():.0f} CPU-s")
    if args.json:
        args.json.write_text(json.dumps(per_stage.reset_index().to_dict(orient="records"), indent=1))


if __name__ == "__main__":
    main()
