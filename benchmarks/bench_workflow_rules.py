"""Wall and CPU time per rule of a finished workflow run, from Snakemake's benchmark files.

Every rule writes ``results/<campaign>/benchmarks/<rule>/<wildcards>.tsv`` (Snakemake's
``benchmark:`` directive: wall seconds ``s``, ``cpu_time``, peak ``max_rss`` MB). This
script sums them per rule and per stage, e.g. the time of the diagnosis for the default campaign:

    .venv/bin/python benchmarks/bench_workflow_rules.py results/mosai2023
    .venv/bin/python benchmarks/bench_workflow_rules.py results/mosai2023 --stage diagnosis --json out.json
"""

from __future__ import annotations

import argparse
import json
import re
from pathlib import Path

import pandas as pd

#: Rule name prefix -> stage.
STAGES = {
    "simulate": "simulate", "payload_chain": "payload chain", "mast_l1": "payload chain", "l3": "payload chain",
    "l4": "analysis", "flight_stats": "analysis",
    "tables": "analysis", "figures": "analysis", "campaign_record": "analysis",
    "diagnose": "diagnosis", "diagnosis_report": "diagnosis", "published": "published numbers",
    "quadrotor": "quadrotor", "tunnel": "tunnel",
}


def stage_of(rule: str) -> str:
    """Stage of a rule by the longest matching prefix."""
    best = max((p for p in STAGES if rule.startswith(p)), key=len, default=None)
    return STAGES[best] if best else "other"


#: The last line of a job's log: its process' own CPU time when it ended (dronewind.steps.logged).
LOG_CPU = re.compile(r"done in [0-9.]+ s; process: ([0-9.]+) CPU-s")


def log_cpu_s(log: Path) -> float:
    """The CPU seconds a job's log gives for its process (NaN without the closing line)."""
    found = LOG_CPU.findall(log.read_text()) if log.exists() else []
    return float(found[-1]) if found else float("nan")


def collect(results: Path) -> pd.DataFrame:
    """One row per job: rule, job, wall s, CPU s, max RSS MB (the job's last benchmark line) and the
    CPU s its log gives (``log_cpu_s``)."""
    rows = []
    for tsv in sorted((results / "benchmarks").glob("*/*.tsv")):
        df = pd.read_csv(tsv, sep="\t")
        rows.append({"rule": tsv.parent.name, "job": tsv.stem, "wall_s": float(df["s"].iloc[-1]),
                     "cpu_s": float(df["cpu_time"].iloc[-1]), "max_rss_mb": float(df["max_rss"].iloc[-1]),
                     "log_cpu_s": log_cpu_s(results / "logs" / tsv.parent.name / f"{tsv.stem}.log")})
    if not rows:
        raise SystemExit(f"{results}: no benchmark files under benchmarks/ (run the workflow first)")
    out = pd.DataFrame(rows)
    out["stage"] = out["rule"].map(stage_of)
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
