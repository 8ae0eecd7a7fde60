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
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from bench_common import DEFAULT_CAMPAIGN, REPO, git_commit, print_and_write

PUBLISHED = REPO / "config" / "published" / "seed000_samurai_s.yaml"


def parent(samples: list[str], keep: bool) -> list[dict]:
    """In this process: preload as the server does, optionally keep freed memory, fork one child per sample."""
    import gc

    from dronewind.steps.preload import ONE_THREAD_ENV, preload_libraries

    os.environ.update(ONE_THREAD_ENV)
    preload_libraries()
    gc.collect()
    gc.freeze()
    from dronewind.diagnose import forward
    from dronewind.manifest import default_config, load_campaign, payload_flight_manifest
    from dronewind.steps.handoff import keep_freed_memory
    from dronewind.steps.published import published_forward

    kept = keep_freed_memory() if keep else False
    config = default_config()
    data = load_campaign(DEFAULT_CAMPAIGN).data
    processing = {k: config["processing"][k] for k in forward.CHAIN_SETTINGS}
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for sample in samples:
            pid = os.fork()
            if pid == 0:  # the child: one job, then exit without cleanup (as the server's children)
                published_forward(PUBLISHED, Path(tmp) / f"{sample}.json",
                                  campaign=payload_flight_manifest(data, sample, atmosphere=True), flight_id=sample,
                                  processing=processing, seeds=config["diagnosis"]["seeds"])
                os._exit(0)
            _, status, usage = os.wait4(pid, 0)
            if status != 0:
                raise RuntimeError(f"job {sample} failed (status {status})")
            rows.append({"sample": sample, "keep_freed_memory": keep, "setting_taken": kept,
                         "user_s": round(usage.ru_utime, 3), "sys_s": round(usage.ru_stime, 3),
                         "minor_faults": usage.ru_minflt})
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
