"""User and system CPU of forked forward-model jobs, with and without reusing freed memory.

A local workflow run forks every job from one preloaded process (:mod:`dronewind.steps.preload`),
which calls :func:`dronewind.steps.handoff.keep_freed_memory` before it serves. This script
does the same: it imports the libraries as the server does (:func:`preload_libraries`, then
``gc.freeze``), and forks one child per published-numbers job
(:func:`dronewind.steps.published.published_forward`: baseline seeds and every probe of one
sample), alternating a parent that kept its freed memory and one that did not (each
setting in its own parent process, so the children inherit exactly one of them). It reports
each child's user and system CPU seconds and its minor page faults (``wait4``). Example::

    PYTHONPATH=src .venv/bin/python benchmarks/bench_freed_memory.py s05 s01 --pairs 2 \\
        --out benchmarks/results/freed_memory_s29.json
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

from bench_common import (
    REPO,
    default_forward_setup,
    forked_job,
    git_commit,
    preload_as_server,
    print_and_write,
    published_forward_job,
)


def parent(samples: list[str], keep: bool) -> list[dict]:
    """In this process: preload as the server does, optionally keep freed memory, fork one child per sample."""
    kept = preload_as_server(keep_freed=keep)
    setup = default_forward_setup()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for sample in samples:
            usage = forked_job(lambda sample=sample: published_forward_job(setup, sample, Path(tmp) / f"{sample}.json"))
            rows.append({"sample": sample, "keep_freed_memory": keep, "setting_taken": kept,
                         **{k: usage[k] for k in ("user_s", "sys_s", "minor_faults")}})
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("samples", nargs="+", help="published sample ids (e.g. s05 s01)")
    ap.add_argument("--pairs", type=int, default=2, help="alternating pairs of parents (kept, default)")
    ap.add_argument("--out", type=Path, help="JSON file to write")
    ap.add_argument("--parent", choices=["keep", "default"], help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.parent:
        print(json.dumps(parent(args.samples, args.parent == "keep")))
        return
    rows = []
    for k in range(args.pairs):
        for mode in ("keep", "default"):
            out = subprocess.run([sys.executable, __file__, *args.samples, "--parent", mode], check=True,
                                 stdout=subprocess.PIPE, text=True)
            for row in json.loads(out.stdout.strip().splitlines()[-1]):
                rows.append({**row, "pair": k})
                print(row, file=sys.stderr)
    summary = {}
    for sample in args.samples:
        for mode in (True, False):
            sel = [r for r in rows if r["sample"] == sample and r["keep_freed_memory"] == mode]
            summary[f"{sample} {'kept' if mode else 'default'}"] = {
                key: [r[key] for r in sel] for key in ("user_s", "sys_s", "minor_faults")}
    print_and_write({"what": "published_forward jobs forked from a preloaded process, keep_freed_memory or not",
                     "command": "benchmarks/bench_freed_memory.py " + " ".join(args.samples)
                                + f" --pairs {args.pairs}",
                     "commit": git_commit(REPO / "src"), "rows": rows, "summary": summary}, args.out)


if __name__ == "__main__":
    main()
