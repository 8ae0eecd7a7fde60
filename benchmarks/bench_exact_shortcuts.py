"""Milliseconds of the exact shortcuts of session 32 against the computations they replace.

Runs the workflow's ``published_forward`` job of one sample (default ``s01``: 36 forward runs)
and keeps the inputs each shortcut gets there; then times, over all those inputs, the shortcut
and the computation it replaces (the least of ``--repeat`` passes), and checks that both give
the same bits:

- :func:`dronewind.core.timeseries.median_of_steps` (a record's median step, which the payload
  readers take three times per record) against ``np.median``;
- :func:`dronewind.core.timeseries.unwrap_rad` (the INS yaw, the L2's attitude, the simulated
  payload's heading) against ``np.unwrap``; a logged yaw that wraps at +/-180 degree takes
  numpy's path after the shortcut's check;
- ``dronewind.simulate.payload._slope_at_knots`` (the payload's velocity on its own time axis)
  against evaluating the motion's spline there.

Per kind: calls, total and largest milliseconds of each. Example::

    PYTHONPATH=src .venv/bin/python benchmarks/bench_exact_shortcuts.py \\
        --out benchmarks/results/exact_shortcuts_s32.json
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from bench_common import (
    default_forward_setup,
    git_commit,
    machine,
    preload_as_server,
    print_and_write,
    published_forward_job,
)


def _same_bits(a: Any, b: Any) -> bool:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and bool(np.array_equal(a.view(np.uint64), b.view(np.uint64)))


def _least_ms(fn: Callable[[], Any], repeat: int) -> float:
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return 1e3 * best


def _compare(inputs: list[Any], new: Callable[[Any], Any], old: Callable[[Any], Any], repeat: int) -> dict[str, Any]:
    new_ms = [_least_ms(lambda x=x: new(x), repeat) for x in inputs]
    old_ms = [_least_ms(lambda x=x: old(x), repeat) for x in inputs]
    return {"calls": len(inputs), "new_total_ms": round(sum(new_ms), 2), "old_total_ms": round(sum(old_ms), 2),
            "new_largest_ms": round(max(new_ms), 3), "old_largest_ms": round(max(old_ms), 3),
            "same_bits": all(_same_bits(new(x), old(x)) for x in inputs)}


def _collect(module_names: tuple[str, ...], name: str, inputs: list[Any], copy: Callable[[Any], Any]) -> None:
    """Wrap ``name`` where these modules look it up, keeping a copy of each first argument."""
    import importlib

    original = getattr(importlib.import_module(module_names[0]), name)

    def wrapper(first: Any, *args: Any, **kwargs: Any) -> Any:
        inputs.append(copy(first))
        return original(first, *args, **kwargs)

    for module_name in module_names:
        module = importlib.import_module(module_name)
        if getattr(module, name, None) is original:
            setattr(module, name, wrapper)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("sample", nargs="?", default="s01", help="published sample (default s01)")
    parser.add_argument("--repeat", type=int, default=3, help="passes per input (least reported)")
    parser.add_argument("--out", type=Path, help="JSON file to write")
    args = parser.parse_args()
    preload_as_server()
    from dronewind.core.timeseries import median_of_steps, unwrap_rad
    from dronewind.simulate.payload import _slope_at_knots

    steps: list[np.ndarray] = []
    angles: list[np.ndarray] = []
    splines: list[Any] = []
    _collect(("dronewind.core.timeseries", "dronewind.payload.io"), "median_of_steps", steps, np.array)
    _collect(("dronewind.core.timeseries", "dronewind.payload.io", "dronewind.payload.sync", "dronewind.payload.motion",
              "dronewind.diagnose.features", "dronewind.simulate.payload"), "unwrap_rad", angles, np.array)
    _collect(("dronewind.simulate.payload",), "_slope_at_knots", splines, lambda s: s)
    with tempfile.TemporaryDirectory() as tmp:
        published_forward_job(default_forward_setup(), args.sample, Path(tmp) / "forward.json")
    result = {
        "sample": args.sample,
        "median_of_steps": _compare(steps, median_of_steps, lambda x: float(np.median(x)), args.repeat),
        "unwrap_rad": _compare(angles, unwrap_rad, np.unwrap, args.repeat),
        "slope_at_knots": _compare(splines, _slope_at_knots, lambda s: s(s.x, 1), args.repeat),
        "commit": git_commit(),
        "machine": machine(),
    }
    print_and_write(result, args.out)


if __name__ == "__main__":
    sys.exit(main())
