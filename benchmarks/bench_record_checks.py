"""Milliseconds of the per-record bookkeeping of a forward run, before and after session 26.

A forward run keys the products it may reuse (:class:`dronewind.diagnose.forward.ForwardCache`)
by the digest of each record the simulator makes (:func:`dronewind.core.raw.content_digest`),
and its readers look for repeated time stamps in every INS and sonic record
(``dronewind.payload.reader._repeated``). On the default campaign's first flight's in-memory
records this measures, per record:

- the digest: SHA-256 of the arrays in place against BLAKE2b of a copy (the earlier one);
- the repeated-stamp check of the INS and sonic stamps: the sorted comparison against
  pandas' ``Series.duplicated(keep=False)`` (the earlier one), and that both mark the same rows.

::

    PYTHONPATH=src .venv/bin/python benchmarks/bench_record_checks.py --out benchmarks/results/record_checks_s26.json
"""

from __future__ import annotations

import argparse
import hashlib
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from bench_common import DEFAULT_CAMPAIGN, git_commit, print_and_write
from dronewind.core.raw import content_digest
from dronewind.manifest import load_campaign
from dronewind.payload.reader import _repeated
from dronewind.simulate.payload import payload_records


def blake2b_copy(columns: dict[str, np.ndarray]) -> str:
    """The earlier digest: BLAKE2b of each column's bytes, copied out first."""
    h = hashlib.blake2b(digest_size=16)
    for name, col in columns.items():
        arr = np.ascontiguousarray(col)
        h.update(f"{name}:{arr.dtype.str}:{arr.shape}".encode())
        h.update(arr.view(np.uint8).tobytes() if arr.dtype.kind != "O" else repr(arr.tolist()).encode())
    return h.hexdigest()


def best_ms(fn: Callable[[], object], repeat: int) -> float:
    """Least wall milliseconds of ``repeat`` calls."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return round(1e3 * min(times), 2)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=20, help="calls per record and method (least reported)")
    parser.add_argument("--out", type=Path, help="JSON file to write")
    args = parser.parse_args()
    data = load_campaign(DEFAULT_CAMPAIGN).data
    flight = data["payload_flights"][0]["id"]
    records, _ = payload_records(data, flight)
    rows = {}
    for rec in records:
        columns = dict(rec.columns)
        row = {"rows": rec.n_rows, "mbytes": round(sum(np.asarray(c).nbytes for c in columns.values()) / 1e6, 2),
               "digest_sha256_in_place_ms": best_ms(lambda c=columns: content_digest(c), args.repeat),
               "digest_blake2b_copy_ms": best_ms(lambda c=columns: blake2b_copy(c), args.repeat)}
        if "rpi_time_us" in columns:
            t = np.asarray(columns["rpi_time_us"])
            same = bool(np.array_equal(_repeated(t), pd.Series(t).duplicated(keep=False).to_numpy()))
            row.update({"repeated_stamps": int(_repeated(t).sum()), "same_rows_as_pandas": same,
                        "repeat_check_sorted_ms": best_ms(lambda t=t: _repeated(t), args.repeat),
                        "repeat_check_pandas_ms": best_ms(lambda t=t: pd.Series(t).duplicated(keep=False).to_numpy(),
                                                          args.repeat)})
        rows[rec.name] = row
    print_and_write({"commit": git_commit(), "flight": flight, "repeat": args.repeat, "records": rows}, args.out)


if __name__ == "__main__":
    main()
