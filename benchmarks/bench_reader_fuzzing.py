"""Long fuzzing run of every reader with byte-level logger faults (the validation of tests/core/test_fuzz_readers.py).

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/bench_reader_fuzzing.py [examples per reader]``
(default 600). The same property as the tests (:func:`tests.fuzz_readers.check`: only the
named :class:`dronewind.errors.InputError` may leave a reader; the rows outside the damaged
span equal the clean file's rows), with hypothesis derandomized so the run repeats, and
``max_examples`` per reader instead of the tests' small budget. Writes
``benchmarks/results/reader_fuzzing.json``: per reader and fault class the cases run and
their outcomes, the failures (none expected), the command and the time taken.
"""

from __future__ import annotations

import argparse
import collections
import json
import sys
import tempfile
import time
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.fuzz_readers import READERS, check, prepare  # noqa: E402

OUT = ROOT / "benchmarks" / "results" / "reader_fuzzing.json"


def fuzz_reader(name: str, folder: Path, max_examples: int) -> dict:
    """Run one reader's fuzzing; outcome counts per fault class and the failures."""
    prep = prepare(next(r for r in READERS if r.name == name), folder)
    counts: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
    failures: list[str] = []
    unit = st.floats(min_value=0.0, max_value=1.0, exclude_max=True, allow_nan=False)

    @settings(max_examples=max_examples, deadline=None, derandomize=True, database=None,
              suppress_health_check=list(HealthCheck))
    @given(sample=st.sampled_from(sorted(prep.clean)), op=st.sampled_from(prep.reader.ops),
           u=st.tuples(unit, unit, unit), junk=st.binary(min_size=1, max_size=400))
    def run(sample, op, u, junk):
        try:
            counts[op][check(prep, sample, op, u, junk)] += 1
        except Exception as exc:  # noqa: BLE001 - every escape is a finding, recorded
            counts[op]["failed"] += 1
            failures.append(f"{sample} {op} {u}: {type(exc).__name__}: {str(exc)[:300]}")
            raise

    t0 = time.perf_counter()
    try:
        run()
    except Exception:  # noqa: BLE001 - hypothesis re-raises the (shrunk) failure; it is in `failures`
        pass
    return {"samples": sorted(prep.clean), "cases": int(sum(sum(c.values()) for c in counts.values())),
            "by_fault": {op: dict(c) for op, c in sorted(counts.items())}, "failures": failures[:20],
            "seconds": round(time.perf_counter() - t0, 1)}


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        epilog="example: PYTHONPATH=src .venv/bin/python benchmarks/bench_reader_fuzzing.py 600")
    parser.add_argument("examples", nargs="?", type=int, default=600, help="examples per reader (default 600)")
    n = parser.parse_args().examples
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        readers = {r.name: fuzz_reader(r.name, Path(tmp) / r.name, n) for r in READERS}
    result = {
        "command": f"PYTHONPATH=src .venv/bin/python benchmarks/bench_reader_fuzzing.py {n}",
        "max_examples_per_reader": n,
        "property": "only dronewind.errors.InputError leaves a reader; rows of lines outside the damaged span "
                    "equal the clean file's rows (tests/fuzz_readers.py:check)",
        "total_cases": sum(r["cases"] for r in readers.values()),
        "total_failures": sum(len(r["failures"]) for r in readers.values()),
        "seconds": round(time.perf_counter() - t0, 1),
        "readers": readers,
    }
    OUT.write_text(json.dumps(result, indent=1) + "\n")
    print(f"{result['total_cases']} cases, {result['total_failures']} failures, {result['seconds']} s -> {OUT}")


if __name__ == "__main__":
    main()
