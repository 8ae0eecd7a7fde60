"""Forked forward-model jobs of two source trees, alternating: user and system CPU, page faults, peak memory.

A local workflow run forks every job from one preloaded process (:mod:`dronewind.steps.preload`).
This script does the same for the forward-model jobs: a parent process per source tree
(``PYTHONPATH`` set to it) imports the libraries as the server does
(:func:`~dronewind.steps.preload.preload_libraries`, ``gc.freeze``,
:func:`~dronewind.steps.handoff.keep_freed_memory`), then forks one child per job, which runs
it once and exits, as a job does: ``--rule published_forward`` (default; one job per
published sample, :func:`dronewind.steps.published.published_forward`) or ``--rule
diagnose_forward`` (one job per payload flight of a finished default run, ``--results``:
:func:`dronewind.steps.diagnosis.forward_probes` on its measured conditions and mast L1). Each child's CPU,
minor page faults and peak resident memory are those ``wait4`` reports. The trees alternate
``--pairs`` times, so a slower hour of the machine weighs on both.

Example (the session's start against the working tree)::

    git worktree add /tmp/base <commit>
    PYTHONPATH=src .venv/bin/python benchmarks/bench_forked_jobs.py --tree start=/tmp/base/src --tree new=src \\
        --pairs 3 --out benchmarks/results/forked_jobs_s31.json
    PYTHONPATH=src .venv/bin/python benchmarks/bench_forked_jobs.py --tree start=/tmp/base/src --tree new=src \\
        --rule diagnose_forward --results <run>/results/mosai2023 --pairs 2 --out <file>
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from bench_common import (
    REPO,
    default_forward_setup,
    forked_job,
    git_commit,
    preload_as_server,
    print_and_write,
    published_forward_job,
)

PUBLISHED = REPO / "config" / "published" / "ghirardelli2025_samurai_s.yaml"


def parent(rule: str, jobs: list[str], results: Path | None) -> list[dict[str, Any]]:
    """In this process (the tree on ``PYTHONPATH``): preload as the server does, fork one child per job."""
    preload_as_server()
    from dronewind.manifest import payload_flight_manifest
    from dronewind.steps.diagnosis import forward_probes

    setup = default_forward_setup()
    data, config, processing = setup

    def job(name: str, out: Path) -> None:
        if rule == "published_forward":
            published_forward_job(setup, name, out)
            return
        assert results is not None
        reference = next(f["reference"] for f in data["payload_flights"] if f["id"] == name)
        forward_probes(results / "diagnosis" / "measured" / f"{name}.json", out,
                       campaign=payload_flight_manifest(data, name), flight_id=name, processing=processing,
                       seeds=config["diagnosis"]["seeds"], mast_l1=results / "netcdf" / "L1" / f"mast_{reference}.nc",
                       atmosphere=config["diagnosis"]["atmosphere"])

    with tempfile.TemporaryDirectory() as tmp:
        return [{"job": name, **forked_job(lambda name=name: job(name, Path(tmp) / f"{name}.json"))} for name in jobs]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tree", action="append", metavar="NAME=SRC",
                    help="a source tree to measure (its src folder), named; give two or more")
    ap.add_argument("--rule", choices=["published_forward", "diagnose_forward"], default="published_forward",
                    help="which jobs to fork")
    ap.add_argument("--results", type=Path, help="a finished default run's results/<campaign> (diagnose_forward)")
    ap.add_argument("--jobs", nargs="+", help="sample or flight ids (all of the rule's by default)")
    ap.add_argument("--pairs", type=int, default=2, help="alternating rounds over the trees")
    ap.add_argument("--out", type=Path, help="JSON file to write")
    ap.add_argument("--parent", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.parent:
        print(json.dumps(parent(args.rule, args.jobs, args.results)))
        return
    if not args.tree or len(args.tree) < 2:
        ap.error("give two or more --tree NAME=SRC")
    trees = dict(t.split("=", 1) for t in args.tree)
    if args.rule == "diagnose_forward" and args.results is None:
        ap.error("--rule diagnose_forward needs --results")
    jobs = args.jobs
    if not jobs and args.rule == "published_forward":
        from dronewind.diagnose.published import load_published

        jobs = list(load_published(PUBLISHED)["stationary_flights"])
    elif not jobs:
        jobs = sorted(p.stem for p in (args.results / "diagnosis" / "measured").glob("*.json"))
    rows = []
    for k in range(args.pairs):
        for name, src in trees.items():
            env = {**os.environ, "PYTHONPATH": str(Path(src).resolve())}
            extra = [] if args.results is None else ["--results", str(args.results.resolve())]
            out = subprocess.run([sys.executable, __file__, "--rule", args.rule, *extra,
                                  "--jobs", *jobs, "--parent"], check=True, stdout=subprocess.PIPE, text=True,
                                 env=env)
            done = json.loads(out.stdout.strip().splitlines()[-1])
            for row in done:
                rows.append({**row, "tree": name, "round": k})
            total = sum(r["user_s"] + r["sys_s"] for r in done)
            print(f"round {k} {name}: {total:.2f} CPU-s over {len(done)} jobs", file=sys.stderr)
    summary: dict[str, Any] = {}
    for name in trees:
        sel = [r for r in rows if r["tree"] == name]
        per_round = [[r for r in sel if r["round"] == k] for k in range(args.pairs)]
        summary[name] = {
            "cpu_s_per_round": [round(sum(r["user_s"] + r["sys_s"] for r in rr), 2) for rr in per_round],
            "sys_s_per_round": [round(sum(r["sys_s"] for r in rr), 2) for rr in per_round],
            "minor_faults_per_round": [sum(r["minor_faults"] for r in rr) for rr in per_round],
            "max_rss_mb_by_job": {j: max(r["max_rss_mb"] for r in sel if r["job"] == j) for j in jobs},
        }
    print_and_write({"what": f"{args.rule} jobs forked from a preloaded process, by source tree",
                     "trees": {name: str(src) for name, src in trees.items()}, "rule": args.rule, "jobs": jobs,
                     "pairs": args.pairs, "commit": git_commit(REPO / "src"), "rows": rows, "summary": summary},
                    args.out)


if __name__ == "__main__":
    main()
