"""Where the published numbers' CPU goes: forward runs by kind and step, a forked job's first run, the fit's tries.

Three measurements, each printed and written to ``--out`` (JSON):

* ``kinds``: the forward runs of the seven published samples in this process (after one
  warm-up sample), by kind of run (baseline seed, height offset with its own true state,
  measurement probe): count, CPU seconds of ``run_forward`` and of the steps inside it
  (``time.process_time`` around each step; a step's seconds include what it reuses).
* ``fork``: ``--fork`` samples, each run twice in a child forked from a process with the
  libraries preloaded (as the workflow's jobs are, :mod:`dronewind.steps.preload`): the
  first run's CPU against the second's in the same child.
* ``fit``: with ``--forward`` (a finished run's ``published/forward`` folder), how many tries
  of the second naming round there were and how many were left out group by group
  (:func:`dronewind.diagnose.published.with_heldout`).
* ``rotation``: :func:`dronewind.payload.motion.rotation_matrix_body_to_ned` for 60,000
  attitudes, and the sines and cosines of its three angles alone (best of 5 x 20 calls).

Example::

    PYTHONPATH=src .venv/bin/python benchmarks/bench_published_runs.py \\
        --forward results/mosai2023/published/forward --out benchmarks/results/published_runs_s30.json
"""

from __future__ import annotations

import argparse
import collections
import os
import tempfile
import time
import timeit
from collections.abc import Callable
from pathlib import Path
from typing import Any

from bench_common import (
    default_forward_setup,
    git_commit,
    load_runs,
    preload_as_server,
    print_and_write,
    published_forward_job,
)

PUBLISHED = Path(__file__).resolve().parents[1] / "config" / "published" / "ghirardelli2025_samurai_s.yaml"
#: Steps timed inside a forward run (module, function).
STEPS = (("dronewind.simulate.payload", "_truth"), ("dronewind.simulate.payload", "payload_records"),
         ("dronewind.diagnose.forward", "compute_ins_l1"), ("dronewind.diagnose.forward", "compute_sonic_l1"),
         ("dronewind.diagnose.forward", "compute_payload_l2"), ("dronewind.diagnose.forward", "compute_mast_l1"),
         ("dronewind.diagnose.forward", "compute_mast_l2"), ("dronewind.diagnose.forward", "compute_l3"),
         ("dronewind.diagnose.forward", "flight_features"))


def _published_forward(setup: tuple[dict[str, Any], dict[str, Any], dict[str, Any]], flight: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        published_forward_job(setup, flight, Path(tmp) / "forward.json")


def by_kind(setup: tuple[dict[str, Any], dict[str, Any], dict[str, Any]], samples: list[str]) -> dict[str, Any]:
    """CPU seconds of the samples' forward runs by kind of run and step."""
    import importlib

    from dronewind.diagnose import forward, probe_runs

    cpu: dict[tuple[str, str], float] = collections.defaultdict(float)
    kind = {"now": ""}

    def timed(name: str, step: Callable[..., Any]) -> Callable[..., Any]:
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            t0 = time.process_time()
            try:
                return step(*args, **kwargs)
            finally:
                cpu[(kind["now"], name)] += time.process_time() - t0
        return wrapper

    def run_forward(manifest: dict[str, Any], *args: Any, **kwargs: Any) -> Any:
        mechanisms = manifest["simulation"].get("mechanisms") or []
        kind["now"] = ("baseline seeds" if not mechanisms else "height offsets"
                       if mechanisms[0]["mechanism"] == "height_offset" else "measurement probes")
        cpu[(kind["now"], "runs")] += 1
        return timed("run_forward", original)(manifest, *args, **kwargs)

    original = forward.run_forward
    saved = [(importlib.import_module(m), f) for m, f in STEPS]
    saved = [(module, f, getattr(module, f)) for module, f in saved]
    try:
        for module, f, step in saved:
            setattr(module, f, timed(f, step))
        forward.run_forward = probe_runs.run_forward = run_forward
        _published_forward(setup, samples[0])  # warm-up: lazily built designs, first-touch pages
        cpu.clear()
        for flight in samples:
            _published_forward(setup, flight)
    finally:
        forward.run_forward = probe_runs.run_forward = original
        for module, f, step in saved:
            setattr(module, f, step)
    kinds: dict[str, dict[str, float]] = collections.defaultdict(dict)
    for (k, name), value in sorted(cpu.items()):
        kinds[k][name] = round(value, 3)
    return dict(kinds)


def fork_first_runs(setup: tuple[dict[str, Any], dict[str, Any], dict[str, Any]], samples: list[str]
                    ) -> dict[str, list[float]]:
    """Per sample: CPU of the first and the second run in one child of a preloaded process."""
    import json
    import logging

    preload_as_server()
    out = {}
    for flight in samples:
        read, write = os.pipe()
        pid = os.fork()
        if pid == 0:  # the child: two runs, their CPU back through the pipe
            logging.disable(logging.INFO)
            runs = []
            for _ in range(2):
                t0 = time.process_time()
                _published_forward(setup, flight)
                runs.append(round(time.process_time() - t0, 3))
            os.write(write, json.dumps(runs).encode())
            os._exit(0)
        os.close(write)
        os.waitpid(pid, 0)
        with os.fdopen(read) as pipe:
            out[flight] = json.loads(pipe.read())
    return out


def fit_tries(forward_dir: Path) -> dict[str, int]:
    """Second-round tries of the published fit and how many were left out group by group."""
    from dronewind.diagnose import published as dp

    runs = load_runs(forward_dir)
    counts = {"second_round_tries": 0, "second_round_left_out": 0}
    score_combo, with_heldout = dp.score_combo, dp.with_heldout

    def counted_score(pe: Any, combo: Any, reference: Any = (), *args: Any, **kwargs: Any) -> Any:
        counts["second_round_tries"] += bool(reference)
        return score_combo(pe, combo, reference, *args, **kwargs)

    def counted_heldout(pe: Any, score: Any) -> Any:
        counts["second_round_left_out"] += bool(score.reference) and not score.heldout
        return with_heldout(pe, score)

    dp.score_combo, dp.with_heldout = counted_score, counted_heldout
    try:
        result = dp.analyse(dp.load_published(PUBLISHED), runs, alpha=default_forward_setup()[1]["diagnosis"]["alpha"])
    finally:
        dp.score_combo, dp.with_heldout = score_combo, with_heldout
    return {**counts, "named_causes": result["named_causes"]}


def rotation_timing(n: int = 60000) -> dict[str, float]:
    """Milliseconds per call: the body-to-NED matrices of n attitudes, and their sines and cosines alone."""
    import numpy as np

    from dronewind.payload.motion import rotation_matrix_body_to_ned

    rng = np.random.default_rng(0)
    roll, pitch, yaw = rng.normal(0, 3, n), rng.normal(0, 3, n), rng.uniform(0, 360, n)
    angles = [np.deg2rad(a) for a in (roll, pitch, yaw)]

    def best(call: Callable[[], Any]) -> float:
        return round(min(timeit.repeat(call, number=20, repeat=5)) / 20 * 1e3, 3)

    return {"n": n, "matrices_ms": best(lambda: rotation_matrix_body_to_ned(roll, pitch, yaw)),
            "sines_cosines_ms": best(lambda: [(np.sin(a), np.cos(a)) for a in angles])}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--forward", type=Path, help="a finished run's published/forward folder (the fit's tries)")
    parser.add_argument("--fork", nargs="*", default=["s05", "s07"], help="samples run twice in a forked child")
    parser.add_argument("--out", type=Path, help="JSON file for the results")
    args = parser.parse_args()
    for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(name, "1")  # as in the workflow's jobs (read when NumPy loads BLAS)
    from dronewind.diagnose.published import load_published

    setup = default_forward_setup()
    samples = list(load_published(PUBLISHED)["stationary_flights"])
    result: dict[str, Any] = {"commit": git_commit(), "samples": samples, "kinds": by_kind(setup, samples),
                              "rotation": rotation_timing()}
    if args.forward is not None:
        result["fit"] = fit_tries(args.forward)
    result["fork"] = fork_first_runs(setup, args.fork)  # last: it imports every library
    print_and_write(result, args.out)


if __name__ == "__main__":
    main()
