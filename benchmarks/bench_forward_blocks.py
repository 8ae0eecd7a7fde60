"""Where the published numbers' forward runs spend their CPU: the chain's stages and the simulator's.

Runs the workflow's ``published_forward`` job of each sample given (default: the 7 stationary
samples) in this process, with the stages below wrapped to count their calls and CPU seconds
(``time.process_time``: the stages nest, so the shares of ``run_forward`` do not add up to
100 %; what the wrapped stages leave is the records' assembly and the runs' bookkeeping).
Unlike a profile (``profile_forward_flight.py``) it costs almost nothing, so the seconds are the
runs' own. Any code version: set ``PYTHONPATH`` to its source tree. Example::

    PYTHONPATH=src .venv/bin/python benchmarks/bench_forward_blocks.py \\
        --out benchmarks/results/forward_blocks_s32.json
"""

from __future__ import annotations

import argparse
import collections
import importlib
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from bench_common import (
    default_forward_setup,
    git_commit,
    machine,
    preload_as_server,
    print_and_write,
    published_forward_job,
)

#: The stages timed: (module, function); every module that imported the function gets the wrapper.
STAGES: tuple[tuple[str, str], ...] = (
    ("dronewind.diagnose.forward", "run_forward"),
    ("dronewind.simulate.payload", "_truth"),
    ("dronewind.simulate.payload", "_sonic_log"),
    ("dronewind.simulate.payload", "_ins_log"),
    ("dronewind.simulate.payload", "_mast_logs"),
    ("dronewind.payload.chain", "compute_sonic_l1"),
    ("dronewind.payload.chain", "compute_ins_l1"),
    ("dronewind.mast.chain", "compute_mast_l1"),
    ("dronewind.mast.chain", "compute_mast_l2"),
    ("dronewind.payload.chain", "compute_payload_l2"),
    ("dronewind.compare.chain", "compute_l3"),
    ("dronewind.diagnose.features", "flight_features"),
)
SAMPLES = ("s01", "s05", "s06", "s07", "s08", "s09", "s10")


def _timed(function: Callable[..., Any], name: str, seconds: collections.Counter[str],
           calls: collections.Counter[str]) -> Callable[..., Any]:
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        start = time.process_time()
        try:
            return function(*args, **kwargs)
        finally:
            seconds[name] += time.process_time() - start
            calls[name] += 1
    return wrapper


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("samples", nargs="*", default=list(SAMPLES), help="published samples (default: all 7)")
    parser.add_argument("--out", type=Path, help="write the result as JSON")
    args = parser.parse_args()
    preload_as_server()
    seconds: collections.Counter[str] = collections.Counter()
    calls: collections.Counter[str] = collections.Counter()
    for module_name, name in STAGES:
        module = importlib.import_module(module_name)
        original = getattr(module, name)
        wrapper = _timed(original, name, seconds, calls)
        for other in list(sys.modules.values()):
            if getattr(other, "__name__", "").startswith("dronewind") and getattr(other, name, None) is original:
                setattr(other, name, wrapper)
    setup = default_forward_setup()
    start = time.process_time()
    with tempfile.TemporaryDirectory() as tmp:
        for sample in args.samples:
            published_forward_job(setup, sample, Path(tmp) / f"{sample}.json")
    total = time.process_time() - start
    result = {
        "what": "CPU seconds of the published numbers' forward jobs by stage (nested: shares do not add up)",
        "samples": list(args.samples),
        "cpu_s": round(total, 2),
        "stages": {name: {"calls": calls[name], "cpu_s": round(seconds[name], 3),
                          "share": round(seconds[name] / total, 4)} for name, _ in seconds.most_common()},
        "commit": git_commit(),
        "machine": machine(),
    }
    print_and_write(result, args.out)


if __name__ == "__main__":
    main()
