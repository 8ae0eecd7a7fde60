"""What a published-numbers forward job holds in memory, and what prefaulting its heap would do.

Two measurements of one sample's ``published_forward`` job (any code version: set
``PYTHONPATH`` to its source tree):

* ``traced`` (in this process, :mod:`tracemalloc`): after each forward run, the memory the
  job holds and the peak of that run [MB], by kind of run (baseline seed, height offset,
  measurement probe); what it holds once every run is made (before the JSON is written) and
  the largest holders then, by the three innermost frames of ``dronewind`` that allocated
  them.
* ``prefault`` (with ``--prefault MB``): the job forked from a preloaded process as the
  workflow runs it, alternately as it is and after growing the heap by ``MB`` and asking
  the kernel to fault it in at once (``madvise(MADV_POPULATE_WRITE)``), ``--pairs`` times:
  user and system CPU and page faults of each child (prefaulting included).

Example::

    PYTHONPATH=src .venv/bin/python benchmarks/bench_job_memory.py s05 --prefault 300 --pairs 2 \\
        --out benchmarks/results/job_memory_s31.json
"""

from __future__ import annotations

import argparse
import collections
import ctypes
import tempfile
import tracemalloc
from pathlib import Path
from typing import Any

from bench_common import (
    default_forward_setup,
    forked_job,
    git_commit,
    preload_as_server,
    print_and_write,
    published_forward_job,
)

_MB = 2.0**20
#: glibc's M_TOP_PAD and Linux's MADV_POPULATE_WRITE
_M_TOP_PAD, _MADV_POPULATE_WRITE = -2, 23


def traced(setup: tuple[dict[str, Any], dict[str, Any], dict[str, Any]], sample: str) -> dict[str, Any]:
    """Memory held after each run and the runs' peaks, by kind; what is held once all runs are made."""
    from dronewind.diagnose import forward, probe_runs

    runs: list[tuple[str, float, float]] = []
    at_end: dict[str, Any] = {}
    run_forward, progress = forward.run_forward, probe_runs.Progress

    def counted(manifest: dict[str, Any], *args: Any, **kwargs: Any) -> Any:
        tracemalloc.reset_peak()
        out = run_forward(manifest, *args, **kwargs)
        current, peak = tracemalloc.get_traced_memory()
        mechanisms = manifest["simulation"].get("mechanisms") or []
        kind = ("baseline seeds" if not mechanisms else "height offsets"
                if mechanisms[0]["mechanism"] == "height_offset" else "measurement probes")
        runs.append((kind, current / _MB, peak / _MB))
        return out

    class Finished(progress):  # type: ignore[misc, valid-type]
        def finished(self) -> None:  # every run made, the JSON not yet written
            at_end["snapshot"] = tracemalloc.take_snapshot()
            super().finished()

    forward.run_forward = probe_runs.run_forward = counted
    probe_runs.Progress = Finished
    tracemalloc.start(25)
    try:
        with tempfile.TemporaryDirectory() as tmp:
            published_forward_job(setup, sample, Path(tmp) / "forward.json")
    finally:
        tracemalloc.stop()
        forward.run_forward = probe_runs.run_forward = run_forward
        probe_runs.Progress = progress
    holders: collections.Counter[str] = collections.Counter()
    for stat in at_end["snapshot"].statistics("traceback"):
        frames = [f for f in stat.traceback if "src/dronewind" in f.filename][::-1][:3]
        holders[" <- ".join(f"{f.filename.split('dronewind/')[-1]}:{f.lineno}" for f in frames)] += stat.size
    by_kind: dict[str, dict[str, float]] = {}
    for kind, current, peak in runs:
        row = by_kind.setdefault(kind, {"runs": 0, "held_max_mb": 0.0, "peak_max_mb": 0.0})
        row["runs"] += 1
        row["held_max_mb"] = round(max(row["held_max_mb"], current), 1)
        row["peak_max_mb"] = round(max(row["peak_max_mb"], peak), 1)
    return {"held_after_first_run_mb": round(runs[0][1], 1), "by_kind": by_kind,
            "held_at_end_mb": round(sum(holders.values()) / _MB, 1),
            "largest_holders_at_end_mb": {k: round(v / _MB, 1) for k, v in holders.most_common(12)}}


def _prefault(mb: int) -> int:
    """Grow the heap by ``mb`` MB and fault it in at once; returns how much it grew [MB].

    Raises
    ------
    RuntimeError
        The heap did not grow (free memory at its top already held the block).
    """
    libc = ctypes.CDLL(None, use_errno=True)
    libc.sbrk.restype, libc.sbrk.argtypes = ctypes.c_void_p, [ctypes.c_ssize_t]
    libc.malloc.restype, libc.malloc.argtypes = ctypes.c_void_p, [ctypes.c_size_t]
    libc.free.argtypes = [ctypes.c_void_p]
    libc.madvise.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int]
    libc.mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    before = libc.sbrk(0)
    libc.mallopt(_M_TOP_PAD, mb << 20)  # the next growth of the heap adds this much
    block = libc.malloc(3 << 20)  # below the mmap threshold: from the heap
    after = libc.sbrk(0)
    libc.free(block)
    libc.mallopt(_M_TOP_PAD, 128 << 10)  # glibc's default again
    if after <= before:
        raise RuntimeError("prefault: the heap did not grow")
    start = (before + 4095) & ~4095
    if libc.madvise(start, after - start, _MADV_POPULATE_WRITE) != 0:
        raise OSError(ctypes.get_errno(), "madvise(MADV_POPULATE_WRITE) failed")
    return (after - before) >> 20


def prefault(setup: tuple[dict[str, Any], dict[str, Any], dict[str, Any]], sample: str, mb: int,
             pairs: int) -> list[dict[str, Any]]:
    """The job forked as it is and after prefaulting ``mb`` MB of heap, alternately."""
    preload_as_server()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(pairs):
            for heap_mb in (0, mb):
                def job(heap_mb: int = heap_mb) -> None:
                    if heap_mb:
                        _prefault(heap_mb)
                    published_forward_job(setup, sample, Path(tmp) / "forward.json")

                rows.append({"pair": k, "prefault_mb": heap_mb, **forked_job(job)})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("sample", help="published sample id (e.g. s05)")
    parser.add_argument("--prefault", type=int, default=0, help="also fork the job with this many MB prefaulted")
    parser.add_argument("--pairs", type=int, default=2, help="alternating pairs for --prefault")
    parser.add_argument("--out", type=Path, help="JSON file for the results")
    args = parser.parse_args()
    import dronewind

    setup = default_forward_setup()
    result: dict[str, Any] = {"commit": git_commit(Path(dronewind.__file__).parent), "sample": args.sample}
    if args.prefault:
        # first: the children must start from the preloaded heap, not from one the traced job grew
        result["prefault"] = prefault(setup, args.sample, args.prefault, args.pairs)
    result["traced"] = traced(setup, args.sample)
    print_and_write(result, args.out)


if __name__ == "__main__":
    main()
