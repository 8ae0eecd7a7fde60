"""What fewer forward runs would do to the published-numbers diagnosis: answers against CPU.

The published numbers' CPU (issue 14, item 6: <= 30 CPU-s) is set by how many forward runs
the science design asks for: per stationary sample the baseline seeds (``diagnosis.seeds``),
one run per measurement-probe level, one run with its own true state per height-offset
level, and per sample two fresh-seed reruns of the baseline and the extended model. This
script does not change that design. It takes a finished run's forward and rerun files and
refits the published numbers on subsets of them (:func:`dronewind.diagnose.published.analyse`
and :func:`~dronewind.diagnose.published.rerun_summary`), so that whoever owns the design can
see what each cut would cost in answers and save in CPU:

* ``seeds``: only the first k baseline seeds (the probes always use the first one);
* ``height``: one height-offset level left out;
* ``reruns``: only the first fresh seed of the reruns.

For every variant it reports the named causes, their estimates and uncertainties, the
baseline and named misfit, the second round's tries, the error model's seed-to-seed degrees
of freedom, and the CPU the left-out runs took, from the per-run costs of
``--runs`` (:mod:`bench_published_runs`'s JSON; the reruns' from the run's job table,
``--run-json``, :mod:`bench_run`'s output). A subset of one run's files is not an
independent rerun of the design with fewer runs (the seeds kept are the same), so a changed
answer here is a lower bound on how often it would change.

Example::

    PYTHONPATH=src .venv/bin/python benchmarks/published_run_count.py /tmp/run/results/mosai2023/published \\
        --runs benchmarks/results/published_runs_s30.json --run-json /tmp/run.json \\
        --out benchmarks/results/published_run_count_s31.json
"""

from __future__ import annotations

import argparse
import copy
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from bench_common import git_commit, load_runs, print_and_write
from dronewind.diagnose import published as dp

PUBLISHED = Path(__file__).resolve().parents[1] / "config" / "published" / "ghirardelli2025_samurai_s.yaml"


def first_seeds(k: int) -> Callable[[dict[str, Any]], int]:
    """A variant keeping the first ``k`` baseline seeds; returns the number of runs left out."""
    def cut(run: dict[str, Any]) -> int:
        dropped = len(run["baseline"]) - k
        if dropped < 0:
            raise SystemExit(f"sample {run['flight']}: {len(run['baseline'])} seeds, fewer than {k}")
        run["baseline"], run["seeds"] = run["baseline"][:k], run["seeds"][:k]
        return dropped
    return cut


def without_level(candidate: str, level: float) -> Callable[[dict[str, Any]], int]:
    """A variant leaving out one probe level of a candidate; returns the number of runs left out."""
    def cut(run: dict[str, Any]) -> int:
        keep = [p for p in run["probes"] if not (p["candidate"] == candidate and p["level"] == level)]
        dropped = len(run["probes"]) - len(keep)
        run["probes"] = keep
        return dropped
    return cut


def answers(result: dict[str, Any]) -> dict[str, Any]:
    """The parts of :func:`~dronewind.diagnose.published.analyse`'s result that a reader acts on."""
    named_fit = result.get("named_fit") or {}
    return {
        "named_causes": result["named_causes"],
        "estimates": {c: {"estimate": v["estimate"], "uncertainty": v["uncertainty"]}
                      for c, v in result["named_estimates"].items()},
        "ambiguity_set": result["ambiguity_set"],
        "baseline_chi2": round(result["baseline"]["chi2"], 3),
        "named_chi2": None if not named_fit else round(named_fit["chi2"], 3),
        "second_round": [{"added": t["added"], "p_value": t["p_value"], "gain": round(t["gain"], 4)}
                         for t in result.get("not_named", [])],
    }


def rerun_numbers(summary: dict[str, Any]) -> dict[str, float]:
    """The before/after numbers of :func:`~dronewind.diagnose.published.rerun_summary`, flattened."""
    out: dict[str, float] = {}
    for row in summary["table5"]:
        for key, value in row.items():
            if key.startswith(("baseline_", "extended_")) and isinstance(value, float):
                out[f"{row['flight']} {row['statistic']} {key}"] = value
    for model, claims in summary["claims"].items():
        if isinstance(claims, dict):
            for key, value in claims.items():
                if isinstance(value, float):
                    out[f"claims {model} {key}"] = value
    for model, fit in summary["dsigma_w"].items():
        if model != "published_table5":
            for key, value in fit.items():
                if isinstance(value, float):
                    out[f"dsigma_w {model} {key}"] = value
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("published", type=Path, help="a finished run's results/<campaign>/published folder")
    parser.add_argument("--runs", type=Path, required=True,
                        help="bench_published_runs.py JSON (CPU per baseline and height-offset run)")
    parser.add_argument("--run-json", type=Path, help="bench_run.py JSON of the same run (the reruns' CPU)")
    parser.add_argument("--out", type=Path, help="JSON file for the results")
    args = parser.parse_args()
    pub = dp.load_published(PUBLISHED)
    forward = load_runs(args.published / "forward")
    config_alpha = json.loads((args.published / "diagnosis.json").read_text())["alpha"]
    kinds = json.loads(args.runs.read_text())["kinds"]
    per_run = {"baseline": kinds["baseline seeds"]["run_forward"] / kinds["baseline seeds"]["runs"],
               "height": kinds["height offsets"]["run_forward"] / kinds["height offsets"]["runs"]}
    variants: dict[str, tuple[Callable[[dict[str, Any]], int], str]] = {
        "all runs (the design)": (lambda run: 0, "baseline"),
        "4 baseline seeds": (first_seeds(4), "baseline"),
        "3 baseline seeds": (first_seeds(3), "baseline"),
        "height offset without -6 m": (without_level("height_offset", -6.0), "height"),
        "height offset without +6 m": (without_level("height_offset", 6.0), "height"),
        "height offset without +15 m": (without_level("height_offset", 15.0), "height"),
    }
    reference = None
    out: dict[str, Any] = {"commit": git_commit(), "published": str(args.published), "alpha": config_alpha,
                           "cpu_per_run_s": {k: round(v, 4) for k, v in per_run.items()}, "variants": {}}
    for name, (cut, kind) in variants.items():
        runs = copy.deepcopy(forward)
        n_left_out = sum(cut(run) for run in runs.values())
        result = answers(dp.analyse(pub, runs, alpha=config_alpha))
        reference = reference or result
        same = {key: result[key] == reference[key] for key in ("named_causes", "ambiguity_set")}
        out["variants"][name] = {"runs_left_out": n_left_out,
                                 "cpu_s_saved": round(n_left_out * per_run[kind], 2),
                                 "same_as_design": same, **result}
    reruns = load_runs(args.published / "rerun")
    full = rerun_numbers(dp.rerun_summary(reruns, pub))
    one = copy.deepcopy(reruns)
    for run in one.values():
        run["baseline"], run["extended"], run["seeds"] = run["baseline"][:1], run["extended"][:1], run["seeds"][:1]
    single = rerun_numbers(dp.rerun_summary(one, pub))
    shift = {k: round(single[k] - full[k], 4) for k in full if k in single}
    rerun_cpu = None
    if args.run_json is not None:
        rules = json.loads(args.run_json.read_text())["rules"]
        rerun_cpu = rules.get("published_rerun", {}).get("cpu_s")
    out["reruns_one_seed"] = {
        "cpu_s_saved_estimate": None if rerun_cpu is None else round(rerun_cpu / 2, 2),
        "largest_shifts": dict(sorted(shift.items(), key=lambda kv: -abs(kv[1]))[:8]),
        "n_numbers": len(shift),
    }
    print_and_write(out, args.out)


if __name__ == "__main__":
    main()
