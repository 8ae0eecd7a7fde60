"""Jobs, wall and CPU seconds of one stage in two finished runs, per rule and in total.

Reads each run's Snakemake benchmark files (:func:`bench_workflow_rules.collect`), e.g. the
quadrotor stage of the default campaign processed by two versions of the code:

    .venv/bin/python benchmarks/compare_stage_cpu.py results/before/mosai2023 results/mosai2023 \\
        --stage quadrotor --json benchmarks/results/quadrotor_jobs_cpu.json
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from bench_workflow_rules import collect


def stage_summary(results: Path, stage: str) -> dict[str, Any]:
    """Per-rule and total jobs, wall s and CPU s of one stage of a finished run."""
    jobs = collect(results)
    jobs = jobs[jobs["stage"] == stage]
    if jobs.empty:
        raise SystemExit(f"{results}: no benchmark files of stage {stage!r}")
    per_rule = jobs.groupby("rule").agg(jobs=("job", "count"), wall_s=("wall_s", "sum"), cpu_s=("cpu_s", "sum"))
    return {
        "results": str(results),
        "jobs": int(len(jobs)),
        "wall_s": round(float(jobs["wall_s"].sum()), 2),
        "cpu_s": round(float(jobs["cpu_s"].sum()), 2),
        "rules": {rule: {"jobs": int(row.jobs), "wall_s": round(float(row.wall_s), 2),
                         "cpu_s": round(float(row.cpu_s), 2)} for rule, row in per_rule.iterrows()},
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("before", type=Path, help="results/<campaign> folder of the first run")
    parser.add_argument("after", type=Path, help="results/<campaign> folder of the second run")
    parser.add_argument("--stage", required=True, help="stage (bench_workflow_rules.STAGES), e.g. quadrotor")
    parser.add_argument("--json", type=Path, help="write the comparison as JSON")
    args = parser.parse_args()
    out = {"stage": args.stage, "before": stage_summary(args.before, args.stage),
           "after": stage_summary(args.after, args.stage)}
    for key in ("before", "after"):
        s = out[key]
        print(f"{key}: {s['jobs']} jobs, {s['wall_s']:.0f} job-seconds, {s['cpu_s']:.0f} CPU-s ({s['results']})")
        for rule, r in s["rules"].items():
            print(f"  {rule:24s} {r['jobs']:4d} jobs {r['cpu_s']:8.1f} CPU-s")
    if args.json:
        args.json.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
