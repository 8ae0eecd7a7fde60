"""Compare forward-model runs (diagnosis/forward/<flight>.json) of two code versions, number by number.

Every baseline and probe feature value and error, every condition, probe level and skipped
probe must be equal (NaN equal to NaN); the bookkeeping keys that only the newer runner
writes (``parts``, ``reused_products``, ``reused_steps``) are ignored. Where numbers differ,
the largest absolute and relative difference is reported too (a change of the arithmetic's
rounding shows as relative differences of order 1e-12). Example::

    PYTHONPATH=/tmp/old/src .venv/bin/python benchmarks/forward_runs.py s01 \\
        results/mosai2023/diagnosis/measured/s01.json /tmp/old_s01.json
    .venv/bin/python benchmarks/compare_forward_runs.py /tmp/old_s01.json \\
        results/mosai2023/diagnosis/forward/s01.json --json out.json
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

#: Keys written only by the runner that splits a flight into parts and reuses products.
BOOKKEEPING = ("parts", "reused_products", "reused_steps")


def differences(a: Any, b: Any, path: str = "", numeric: list[tuple[float, float, str]] | None = None) -> list[str]:
    """Paths at which two parsed JSON documents differ (NaN equals NaN).

    Each pair of differing numbers also goes to ``numeric`` as (absolute difference,
    difference relative to the larger magnitude, path).
    """
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for key in sorted(set(a) | set(b)):
            if key in BOOKKEEPING:
                continue
            if key not in a or key not in b:
                out.append(f"{path}/{key}: only in {'b' if key not in a else 'a'}")
                continue
            out += differences(a[key], b[key], f"{path}/{key}", numeric)
        return out
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{path}: {len(a)} != {len(b)} items"]
        return [d for k, (x, y) in enumerate(zip(a, b, strict=True))
                for d in differences(x, y, f"{path}[{k}]", numeric)]
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return []
    if a == b:
        return []
    if numeric is not None and all(isinstance(x, float | int) and not isinstance(x, bool) for x in (a, b)):
        d = abs(float(a) - float(b))
        numeric.append((d, d / max(abs(float(a)), abs(float(b))), path))
    return [f"{path}: {a!r} != {b!r}"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("pairs", nargs="+", type=Path, help="A1 B1 [A2 B2 ...]: forward JSON files to compare")
    parser.add_argument("--json", type=Path, help="write the result as JSON")
    args = parser.parse_args()
    if len(args.pairs) % 2:
        raise SystemExit("give the files in pairs: A1 B1 [A2 B2 ...]")
    result = []
    for a, b in zip(args.pairs[::2], args.pairs[1::2], strict=True):
        da, db = json.loads(a.read_text()), json.loads(b.read_text())
        numeric: list[tuple[float, float, str]] = []
        diffs = differences(da, db, numeric=numeric)
        n_values = sum(len(r["features"]["values"]) for r in da["probes"]) + sum(len(r["values"]) for r in
                                                                                   da["baseline"])
        abs_diff = max((d for d, _, _ in numeric), default=0.0)
        _, rel_diff, where = max(numeric, key=lambda x: x[1], default=(0.0, 0.0, ""))
        result.append({"a": str(a), "b": str(b), "flight": da["flight"], "baseline_runs": len(da["baseline"]),
                       "probe_runs": len(da["probes"]), "feature_values": n_values, "n_differences": len(diffs),
                       "max_abs_difference": abs_diff, "max_rel_difference": rel_diff, "max_rel_at": where,
                       "differences": diffs[:50]})
        print(f"{da['flight']}: {len(da['baseline'])} baseline + {len(da['probes'])} probe runs, {n_values} "
              f"feature values, {len(diffs)} differences (largest {abs_diff:.3g} absolute, {rel_diff:.3g} "
              f"relative at {where or '-'})")
    if args.json:
        args.json.write_text(json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    main()
