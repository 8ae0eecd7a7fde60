"""Compare two results of bench_diagnosis_rates.py draw by draw (the same draws: same --draws and --seed).

For every draw (matched by index, which must hold the same seed and label) it reports whether the
verdict is the same (named causes, detected, false alarm, wrong cause, estimate within
tolerance, caveat) and the largest difference of the candidates' likelihood-ratio statistics,
p-values and held-out gains and of the estimate error; then the summary rates of both. Example::

    .venv/bin/python benchmarks/compare_rates.py benchmarks/results/diagnosis_rates.json \\
        benchmarks/results/diagnosis_rates_s28.json --json benchmarks/results/diagnosis_rates_s28_compare.json
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

#: Per-draw fields that make the verdict.
VERDICT = ("named", "detected", "false_alarm", "wrong_cause", "estimate_ok", "caveated")
#: Candidate numbers compared.
NUMBERS = ("lr", "p", "gain")


def _diff(a: Any, b: Any) -> float:
    """|a - b| of two numbers; 0 for two NaN or two None, inf when only one is missing."""
    if a is None and b is None:
        return 0.0
    if a is None or b is None:
        return math.inf
    a, b = float(a), float(b)
    if math.isnan(a) and math.isnan(b):
        return 0.0
    return abs(a - b)


def compare_draw(a: dict[str, Any], b: dict[str, Any]) -> dict[str, Any]:
    """The verdict fields that differ and the largest numeric differences of one draw."""
    if (a["seed"], a["label"]) != (b["seed"], b["label"]):
        raise SystemExit(f"draw {a['index']}: seed/label {a['seed']}/{a['label']} vs {b['seed']}/{b['label']}: "
                         "not the same draws (use the same --draws and --seed)")
    cand_a = {c["mechanism"]: c for c in a.get("candidates", [])}
    cand_b = {c["mechanism"]: c for c in b.get("candidates", [])}
    largest = {name: max((_diff(cand_a[m].get(name), cand_b[m].get(name)) for m in cand_a.keys() & cand_b.keys()),
                         default=0.0) for name in NUMBERS}
    return {"index": a["index"], "label": a["label"],
            "verdict_differs": [k for k in VERDICT if a.get(k) != b.get(k)],
            "candidates_only_in_one": sorted(cand_a.keys() ^ cand_b.keys()),
            "max_abs_diff": {**largest, "estimate_error": _diff(a.get("estimate_error"), b.get("estimate_error"))}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("before", type=Path, help="a bench_diagnosis_rates.py result")
    parser.add_argument("after", type=Path, help="another one, of the same draws")
    parser.add_argument("--json", type=Path, help="write the comparison as JSON")
    args = parser.parse_args()
    a, b = (json.loads(p.read_text()) for p in (args.before, args.after))
    if len(a["draws"]) != len(b["draws"]):
        raise SystemExit(f"{len(a['draws'])} draws against {len(b['draws'])}")
    rows = [compare_draw(x, y) for x, y in zip(sorted(a["draws"], key=lambda d: d["index"]),
                                               sorted(b["draws"], key=lambda d: d["index"]), strict=True)]
    worst = {k: max(r["max_abs_diff"][k] for r in rows) for k in (*NUMBERS, "estimate_error")}
    result = {"before": {"file": str(args.before), "commit": a.get("commit")},
              "after": {"file": str(args.after), "commit": b.get("commit")},
              "draws": len(rows), "verdicts_differ": sum(bool(r["verdict_differs"]) for r in rows),
              "max_abs_diff": worst, "summary_before": a.get("summary"), "summary_after": b.get("summary"),
              "differing_draws": [r for r in rows if r["verdict_differs"] or r["candidates_only_in_one"]
                                  or any(v > 0 for v in r["max_abs_diff"].values())]}
    print(f"{result['draws']} draws, {result['verdicts_differ']} with another verdict; largest differences {worst}; "
          f"{len(result['differing_draws'])} draws differ in any number")
    if args.json:
        args.json.write_text(json.dumps(result, indent=1, default=str) + "\n")


if __name__ == "__main__":
    main()
