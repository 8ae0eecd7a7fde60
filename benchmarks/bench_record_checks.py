"""Seconds per digest of a forward run's raw records: SHA-256 in place against BLAKE2b of a copy.

A forward run keys the products it may reuse (:class:`dronewind.diagnose.forward.ForwardCache`)
by the digest of each record the simulator makes (:attr:`dronewind.core.raw.RawRecord.digest`),
so every run digests its records. This measures both hashes on the default campaign's first
flight's in-memory records (sonic, INS, mast TOA5)::

    PYTHONPATH=src .venv/bin/python benchmarks/bench_digest.py --out benchmarks/results/digest_s26.json
"""

from __future__ import annotations

import argparse
import hashlib
import time
from pathlib import Path

import numpy as np

from bench_common import DEFAULT_CAMPAIGN, git_commit, print_and_write
from dronewind.manifest import load_campaign
from dronewind.simulate.payload import payload_records


def blake2b_copy(columns: dict[str, np.ndarray]) -> str:
    """The earlier digest: BLAKE2b of each column's bytes, copied out first."""
    h = hashlib.blake2b(digest_size=16)
    for name, col in columns.items():
        arr = np.ascontiguousarray(col)
        h.update(f"{name}:{arr.dtype.str}:{arr.shape}".encode())
        h.update(arr.view(np.uint8).tobytes() if arr.dtype.kind != "O" else repr(arr.tolist()).encode())
    return h.hexdigest()


def best_s(fn, repeat: int) -> float:
    """Least wall seconds of ``repeat`` calls."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=20, help="calls per record and hash (least reported)")
    parser.add_argument("--out", type=Path, help="JSON file to write")
    args = parser.parse_args()
    data = load_campaign(DEFAULT_CAMPAIGN).data
    flight = data["payload_flights"][0]["id"]
    records, _ = payload_records(data, flight)
    rows = {}
    for rec in records:
        n_bytes = sum(np.asarray(c).nbytes for c in rec.columns.values())
        sha = best_s(lambda rec=rec: rec.__class__.digest.func(rec), args.repeat)
        blake = best_s(lambda rec=rec: blake2b_copy(dict(rec.columns)), args.repeat)
        rows[rec.name] = {"mbytes": round(n_bytes / 1e6, 2), "sha256_in_place_ms": round(1e3 * sha, 2),
                          "blake2b_copy_ms": round(1e3 * blake, 2), "speed_up": round(blake / sha, 2)}
    total_sha = sum(r["sha256_in_place_ms"] for r in rows.values())
    total_blake = sum(r["blake2b_copy_ms"] for r in rows.values())
    print_and_write({"commit": git_commit(), "flight": flight, "repeat": args.repeat, "records": rows,
                     "total_ms": {"sha256_in_place": round(total_sha, 2), "blake2b_copy": round(total_blake, 2)}},
                    args.out)


if __name__ == "__main__":
    main()
