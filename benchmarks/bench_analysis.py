"""Throughput of the L4 analysis (statistics + spectra + fits + scales + uncertainties).

Run: ``.venv/bin/python benchmarks/bench_analysis.py``. Prints seconds for
(1) one synthetic 28-min 8 Hz flight (two sensors, :func:`dronewind.compare.l4.flight_l4`) and
(2) the 96 AmeriFlux gold half-hours at 10 Hz (:func:`dronewind.compare.l4.record_l4`), with the
reading + gap filling + double rotation timed separately.
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from dronewind.compare import l4

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "ameriflux_gold_openpath"


def synthetic_l3(minutes: float = 28.0, fs_hz: float = 8.0, seed: int = 0) -> xr.Dataset:
    """Two-sensor L3 dataset with Kaimal-like red noise (AR(1) filtered white noise)."""
    n = int(minutes * 60 * fs_hz)
    rng = np.random.default_rng(seed)

    def red(scale_s: float) -> np.ndarray:
        phi = np.exp(-1 / (fs_hz * scale_s))
        e = rng.normal(size=n) * np.sqrt(1 - phi**2)
        from scipy.signal import lfilter

        return lfilter([1.0], [1.0, -phi], e)

    arr = {k: np.empty((2, n)) for k in ("u_ms", "v_ms", "w_ms", "theta_v_k")}
    for i in range(2):
        u, v, w = red(10.0), red(5.0), red(1.0)
        arr["u_ms"][i] = 6 + u
        arr["v_ms"][i] = 0.8 * v
        arr["w_ms"][i] = 0.5 * w - 0.2 * u
        arr["theta_v_k"][i] = 290 + 0.3 * red(5.0) + 0.2 * w
    time_ = pd.date_range("2023-08-21T14:05:32", periods=n, freq=f"{int(1000 / fs_hz)}ms").values
    ds = xr.Dataset({k: (("sensor", "time"), v) for k, v in arr.items()},
                    coords={"sensor": ["drone", "mast"], "time": time_})
    ds["height_m"] = ("sensor", [28.0, 30.0])
    ds["wind_from_deg"] = ("sensor", [97.0, 95.0])
    ds.attrs["sampling_rate_hz"] = fs_hz
    return ds


def bench_flight(repeats: int = 5) -> float:
    l3 = synthetic_l3()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for sensor in ("drone", "mast"):
            l4.flight_l4(l3, sensor)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def bench_gold() -> tuple[float, float, int] | None:
    if not DATA.is_dir():
        return None
    from dronewind.core.filtering import gap_fill_linear
    from dronewind.core.rotation import double_rotation
    from dronewind.mast.ameriflux import read_ameriflux_gold_blocks

    t0 = time.perf_counter()
    blocks = []
    for ds in read_ameriflux_gold_blocks([DATA]):
        filled = [gap_fill_linear(ds[k].values)[0] for k in ("u_east_ms", "v_north_ms", "w_up_ms", "t_sonic_k")]
        u, v, w, _ = double_rotation(*filled[:3])
        blocks.append((u, v, w, filled[3], ds.attrs["sampling_rate_hz"], ds.attrs["height_m"]))
    t_read = time.perf_counter() - t0
    t0 = time.perf_counter()
    for u, v, w, t, fs, z in blocks:
        l4.record_l4(u, v, w, t, fs, z)
    return t_read, time.perf_counter() - t0, len(blocks)


def main() -> None:
    t_flight = bench_flight()
    print(f"one 28-min 8 Hz flight, 2 sensors (13440 samples each): {t_flight:.3f} s (median of 5)")
    gold = bench_gold()
    if gold is None:
        print("gold half-hours: data missing, skipped")
    else:
        t_read, t_l4, n = gold
        print(f"{n} gold half-hours at 10 Hz: read+gap-fill+rotate {t_read:.2f} s, L4 analysis {t_l4:.2f} s "
              f"({t_l4 / n * 1000:.0f} ms per half-hour)")


if __name__ == "__main__":
    main()
