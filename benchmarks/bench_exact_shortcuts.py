"""Milliseconds of the exact shortcuts of sessions 32 and 33 against the computations they replace.

Runs the workflow's ``published_forward`` job of one sample (default ``s01``: 36 forward runs)
and keeps the inputs each shortcut gets there; then times, over all those inputs, the shortcut
and the computation it replaces (the least of ``--repeat`` passes), and checks that both give
the same bits:

- :func:`dronewind.core.timeseries.median_of_steps` (a record's median step, which the payload
  readers take three times per record) against ``np.median``;
- :func:`dronewind.core.timeseries.unwrap_rad` (the INS yaw, the L2's attitude, the simulated
  payload's heading) against ``np.unwrap``; a logged yaw that wraps at +/-180 degree takes
  numpy's path after the shortcut's check;
- ``dronewind.simulate.payload_motion._slope_at_knots`` (the payload's velocity on its own time axis)
  against evaluating the motion's spline there;

and of session 33:

- :func:`dronewind.core.spectra.welch_psd` (the transform's design remembered) against
  ``scipy.signal.welch`` of the same detrended series;
- :func:`dronewind.core.angles.deg2rad`, ``rad2deg``, ``wrap_180`` and ``wrap_360`` against
  ``np.deg2rad``, ``np.rad2deg`` and numpy's remainder;
- :func:`dronewind.core.stats.detrend` (a finite series not filled) against its general path
  (``stats._detrend_filled``), which every series took before;
- :func:`dronewind.core.reuse.same_bits` (leading rows first) against comparing whole arrays.

Per kind: calls, total and largest milliseconds of each (the inputs kept up to 200 MB per kind;
``calls_in_the_job`` counts them all). Example::

    PYTHONPATH=src .venv/bin/python benchmarks/bench_exact_shortcuts.py \\
        --out benchmarks/results/exact_shortcuts_s33.json
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
    if isinstance(a, tuple):
        return all(_same_bits(x, y) for x, y in zip(a, b, strict=True))
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def _same_bits_before(a: np.ndarray, b: np.ndarray) -> bool:
    """:func:`dronewind.core.reuse.same_bits` as it was before session 33 (whole arrays at once)."""
    from dronewind.core.reuse import _UINTS

    if a.dtype != b.dtype or a.shape != b.shape:
        return False
    uint = _UINTS.get(a.dtype.itemsize)
    if uint is None or a.ndim == 0:
        a, b, uint = np.ascontiguousarray(a).reshape(-1), np.ascontiguousarray(b).reshape(-1), np.uint8
    return bool(np.array_equal(a.view(uint), b.view(uint)))


def _welch_before(x: np.ndarray, fs_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`dronewind.core.spectra.welch_psd`'s defaults as it computed them before session 33."""
    import scipy.signal

    from dronewind.core import spectra
    from dronewind.core.stats import detrend

    nperseg, noverlap = spectra._welch_setup(x.size, 3, 0.5, 16, "welch_psd(x)")
    f, p = scipy.signal.welch(detrend(x), fs=fs_hz, window="hamming", nperseg=nperseg, noverlap=noverlap,
                              detrend=False, scaling="density", return_onesided=True)
    return f[1:], p[1:]


def _is_float_array(x: Any) -> bool:
    return isinstance(x, np.ndarray) and x.dtype == np.float64 and x.size > 1


def _least_ms(fn: Callable[[], Any], repeat: int) -> float:
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return 1e3 * best


def _compare(inputs: list[Any], new: Callable[[Any], Any], old: Callable[[Any], Any], repeat: int) -> dict[str, Any]:
    new_ms, old_ms = [], []
    for x in inputs:  # each input both ways in turn, so both find it equally warm in the caches
        old(x)
        new_ms.append(_least_ms(lambda x=x: new(x), repeat))
        old_ms.append(_least_ms(lambda x=x: old(x), repeat))
    return {"calls": len(inputs), "new_total_ms": round(sum(new_ms), 2), "old_total_ms": round(sum(old_ms), 2),
            "new_largest_ms": round(max(new_ms), 3), "old_largest_ms": round(max(old_ms), 3),
            "same_bits": all(_same_bits(new(x), old(x)) for x in inputs)}


#: Largest size of the copies kept per kind [bytes]: the calls after it are counted, not timed
#: (the reuse checks alone get several GB of arrays in one job).
MAX_KEPT_BYTES = 200_000_000


def _collect(module_names: tuple[str, ...], name: str, inputs: list[Any], copy: Callable[[Any], Any],
             all_arguments: bool = False, seen: dict[str, int] | None = None) -> Callable[[], None]:
    """Wrap ``name`` where these modules look it up, keeping a copy of each first argument (or,
    ``all_arguments``, a tuple of copies of the positional arguments) up to :data:`MAX_KEPT_BYTES`;
    ``seen[name]`` counts every call. Returns what puts the original back (before anything is
    timed: the functions timed call each other)."""
    import importlib

    original = getattr(importlib.import_module(module_names[0]), name)
    kept = [0]

    def wrapper(first: Any, *args: Any, **kwargs: Any) -> Any:
        if seen is not None:
            seen[name] = seen.get(name, 0) + 1
        if kept[0] < MAX_KEPT_BYTES:
            item = tuple(copy(a) for a in (first, *args)) if all_arguments else copy(first)
            kept[0] += sum(getattr(a, "nbytes", 0) for a in (item if all_arguments else (item,)))
            inputs.append(item)
        return original(first, *args, **kwargs)

    wrapped = [importlib.import_module(m) for m in module_names]
    wrapped = [module for module in dict.fromkeys(wrapped) if getattr(module, name, None) is original]
    for module in wrapped:
        setattr(module, name, wrapper)

    def restore() -> None:
        for module in wrapped:
            setattr(module, name, original)

    return restore


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("sample", nargs="?", default="s01", help="published sample (default s01)")
    parser.add_argument("--repeat", type=int, default=3, help="passes per input (least reported)")
    parser.add_argument("--out", type=Path, help="JSON file to write")
    args = parser.parse_args()
    preload_as_server()
    from dronewind.core import angles, reuse, spectra, stats
    from dronewind.core.timeseries import median_of_steps, unwrap_rad
    from dronewind.simulate.payload_motion import _slope_at_knots

    steps: list[np.ndarray] = []
    unwrapped: list[np.ndarray] = []
    splines: list[Any] = []
    restores = [
        _collect(("dronewind.core.timeseries", "dronewind.payload.sonic"), "median_of_steps", steps, np.array),
        _collect(("dronewind.core.timeseries", "dronewind.payload.ins", "dronewind.payload.lag_search",
                  "dronewind.payload.l2", "dronewind.payload.motion", "dronewind.diagnose.features",
                  "dronewind.simulate.payload_motion"),
                 "unwrap_rad", unwrapped, np.array),
        _collect(("dronewind.simulate.payload_motion",), "_slope_at_knots", splines, lambda s: s),
    ]
    users = tuple(name for name in sorted(sys.modules) if name.startswith("dronewind."))
    collected: dict[str, list[Any]] = {}
    seen: dict[str, int] = {}
    shortcuts = (("dronewind.core.angles", "deg2rad", False), ("dronewind.core.angles", "rad2deg", False),
                 ("dronewind.core.angles", "wrap_180", False), ("dronewind.core.angles", "wrap_360", False),
                 ("dronewind.core.stats", "detrend", False), ("dronewind.core.spectra", "welch_psd", True),
                 ("dronewind.core.reuse", "same_bits", True))
    for module, name, every in shortcuts:
        collected[name] = []
        restores.append(_collect((module, *users), name, collected[name],
                                 lambda a: np.array(a) if isinstance(a, np.ndarray) else a, all_arguments=every,
                                 seen=seen))
    with tempfile.TemporaryDirectory() as tmp:
        published_forward_job(default_forward_setup(), args.sample, Path(tmp) / "forward.json")
    for restore in restores:
        restore()
    floats = {name: [x for x in collected[name] if _is_float_array(x)] for name in ("deg2rad", "rad2deg", "wrap_180",
                                                                                   "wrap_360", "detrend")}
    welch = [a for a in collected["welch_psd"] if len(a) == 2]  # the default settings (all the forward runs use)
    result = {
        "sample": args.sample,
        "median_of_steps": _compare(steps, median_of_steps, lambda x: float(np.median(x)), args.repeat),
        "unwrap_rad": _compare(unwrapped, unwrap_rad, np.unwrap, args.repeat),
        "slope_at_knots": _compare(splines, _slope_at_knots, lambda s: s(s.x, 1), args.repeat),
        "welch_psd": _compare(welch, lambda a: spectra.welch_psd(*a), lambda a: _welch_before(*a), args.repeat),
        "deg2rad": _compare(floats["deg2rad"], angles.deg2rad, np.deg2rad, args.repeat),
        "rad2deg": _compare(floats["rad2deg"], angles.rad2deg, np.rad2deg, args.repeat),
        "wrap_180": _compare(floats["wrap_180"], angles.wrap_180, lambda x: (x + 180.0) % 360.0 - 180.0, args.repeat),
        "wrap_360": _compare(floats["wrap_360"], angles.wrap_360, lambda x: np.mod(x, 360.0), args.repeat),
        "detrend": _compare(floats["detrend"], stats.detrend,
                            lambda x: stats._detrend_filled(x, np.isfinite(x), -1), args.repeat),
        "same_bits": _compare(collected["same_bits"], lambda a: reuse.same_bits(*a), lambda a: _same_bits_before(*a),
                              args.repeat),
        "calls_in_the_job": seen,
        "commit": git_commit(),
        "machine": machine(),
    }
    print_and_write(result, args.out)


if __name__ == "__main__":
    sys.exit(main())
