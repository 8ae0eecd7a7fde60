"""Two signal steps every forward run repeats: linear detrending and the L3's anti-alias FIR.

* detrending: :func:`dronewind.core.stats.detrend` (closed-form line) against
  ``scipy.signal.detrend(type="linear")`` (singular-value decomposition) on random walks of
  the lengths a forward run meets (an 8 Hz L3 series of 28 min, a 32 Hz one), with their
  largest difference relative to the series' magnitude;
* the anti-alias FIR with decimation by 4 (:func:`dronewind.compare.align.fir_decimate`,
  ``fftconvolve`` of the whole record, then every fourth output) against two ways that
  compute only the kept outputs: a direct polyphase sum over the taps and overlap-add
  (``scipy.signal.oaconvolve``), on 53,760 x 8 samples (28 min at 32 Hz, drone and mast).

Microseconds per call, best of ``--repeat`` timings of ``--number`` calls (one thread for the
linear-algebra libraries, as the workflow's jobs). Example::

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=src .venv/bin/python benchmarks/bench_detrend_fir.py \\
        --out benchmarks/results/detrend_fir_s29.json
"""

from __future__ import annotations

import argparse
import timeit
from pathlib import Path

import numpy as np
import scipy.signal

from bench_common import git_commit, print_and_write
from dronewind.compare.align import design_antialias_fir, fir_decimate
from dronewind.core import stats


def _best_us(fn, number: int, repeat: int) -> float:
    return round(min(timeit.repeat(fn, number=number, repeat=repeat)) / number * 1e6, 1)


def _polyphase(x: np.ndarray, taps: np.ndarray, factor: int) -> np.ndarray:
    """Only the kept outputs, as a sum over the taps (the same outputs as fir_decimate, phase 0)."""
    half = taps.size // 2
    index = np.arange(half + ((-half) % factor), x.shape[0] - half, factor)
    out = np.zeros((index.size, x.shape[1]))
    for k in range(taps.size):
        out += taps[k] * x[index - half + k]
    return out


def _overlap_add(x: np.ndarray, taps: np.ndarray, factor: int) -> np.ndarray:
    half = taps.size // 2
    index = np.arange(half + ((-half) % factor), x.shape[0] - half, factor)
    return scipy.signal.oaconvolve(x, taps[:, None], mode="valid", axes=0)[index - half]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--number", type=int, default=20)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    detrend = {}
    for n in (13_440, 53_760):
        x = 5.0 + np.cumsum(rng.standard_normal(n))
        diff = float(np.max(np.abs(stats.detrend(x) - scipy.signal.detrend(x, type="linear"))) / np.max(np.abs(x)))
        detrend[str(n)] = {"closed_form_us": _best_us(lambda x=x: stats.detrend(x), args.number, args.repeat),
                           "scipy_svd_us": _best_us(lambda x=x: scipy.signal.detrend(x, type="linear"), args.number,
                                                    args.repeat),
                           "max_difference_relative": diff}
    taps = design_antialias_fir(32.0, 4)
    x = rng.standard_normal((53_760, 8))
    ref = fir_decimate(x, taps, 4)[0]
    fir = {"n_taps": int(taps.size), "samples": list(x.shape)}
    for name, fn in (("fftconvolve_whole_us", lambda: fir_decimate(x, taps, 4)),
                     ("polyphase_us", lambda: _polyphase(x, taps, 4)),
                     ("overlap_add_us", lambda: _overlap_add(x, taps, 4))):
        fir[name] = _best_us(fn, max(args.number // 4, 1), args.repeat)
    fir["polyphase_max_difference"] = float(np.max(np.abs(_polyphase(x, taps, 4) - ref)))
    fir["overlap_add_max_difference"] = float(np.max(np.abs(_overlap_add(x, taps, 4) - ref)))
    print_and_write({"commit": git_commit(), "detrend": detrend, "fir_decimate": fir}, args.out)


if __name__ == "__main__":
    main()
