"""Throughput of the payload chain's numeric stages on a 20-min, 32 Hz flight.

Run: .venv/bin/python benchmarks/bench_payload_chain.py
Prints samples per second and CPU seconds per flight-hour of 32 Hz data for: the sonic-INS
lag search (129 lags), the motion correction, the drone-mast alignment + FIR decimation
(+ double rotation, i.e. the whole L3 builder), a double rotation alone, and the whole L2
builder. Target: >= 1 flight-hour of 32 Hz data per CPU-second for the numeric stages.
"""

from __future__ import annotations

import time

import numpy as np
import xarray as xr

from dronewind.compare import align
from dronewind.core import rotation
from dronewind.payload import l2, lag_search, motion

FS = 32.0
DURATION_S = 20 * 60.0
T0 = np.datetime64("2023-08-21T14:00:00", "ns")


def _best(fn, repeat=5):
    best = np.inf
    for _ in range(repeat):
        c0 = time.process_time()
        fn()
        best = min(best, time.process_time() - c0)
    return best


def _report(name, seconds, n_samples):
    per_hour = seconds * 3600.0 / DURATION_S
    print(f"{name:<34s} {seconds * 1e3:9.2f} ms  {n_samples / seconds:12.3e} samples/s  "
          f"{per_hour:8.4f} CPU-s per flight-hour  ({1 / per_hour:8.1f} flight-h per CPU-s)")


def main() -> None:
    rng = np.random.default_rng(0)
    w = 2 * np.pi * 0.1175
    ts = np.arange(0.0, DURATION_S, 1 / FS)
    ti = np.arange(-10.0, DURATION_S + 10.0, 0.02)  # INS covers the sonic +/- 10 s
    n = ts.size
    sonic = np.stack([6 + rng.standard_normal(n), rng.standard_normal(n), 0.4 * rng.standard_normal(n)], axis=-1)
    att = np.stack([4 * np.sin(w * ti), 1.5 + 3 * np.sin(w * ti + 1), (178 + 15 * np.sin(0.2 * ti) + 180) % 360 - 180],
                   axis=-1)
    vel = np.stack([np.sin(w * ti), np.cos(w * ti), 0.05 * np.sin(2 * w * ti)], axis=-1)
    print(f"flight: {DURATION_S / 60:.0f} min at {FS:g} Hz = {n} sonic samples; INS {ti.size} samples at 50 Hz")

    t = _best(lambda: lag_search.tke_vs_lag(ts, sonic, ti, att, vel, "upside_down"))
    _report("lag search (129 lags)", t, n)
    t = _best(lambda: lag_search.tke_vs_lag(ts, sonic, ti, att, vel, "upside_down", lever_arm_m=(0.1, 0.2, 0.5)))
    _report("lag search + lever arm", t, n)

    def direct():  # reference: interpolate, correct and take variances lag by lag
        for lag in np.arange(-64, 65) / 32.0:
            attitude = {"r": att[:, 0], "p": att[:, 1], "yaw_deg": att[:, 2], "v": vel}
            q = lag_search.interpolate_ins(ti, attitude, ts + lag)
            u = motion.motion_correct(sonic[:, 0], sonic[:, 1], sonic[:, 2], q["r"], q["p"], q["yaw_deg"],
                                      q["v"][:, 0], q["v"][:, 1], q["v"][:, 2], "upside_down")
            0.5 * sum(np.var(c) for c in u)

    t = _best(direct, repeat=1)
    _report("lag search, direct loop (reference)", t, n)

    ins_s = lag_search.interpolate_ins(ti, {"r": att[:, 0], "p": att[:, 1], "yaw_deg": att[:, 2], "v": vel}, ts)
    t = _best(lambda: motion.motion_correct(sonic[:, 0], sonic[:, 1], sonic[:, 2], ins_s["r"], ins_s["p"],
                                            ins_s["yaw_deg"], ins_s["v"][:, 0], ins_s["v"][:, 1], ins_s["v"][:, 2],
                                            "upright"))
    _report("motion correction", t, n)
    t = _best(lambda: motion.motion_correct(sonic[:, 0], sonic[:, 1], sonic[:, 2], ins_s["r"], ins_s["p"],
                                            ins_s["yaw_deg"], ins_s["v"][:, 0], ins_s["v"][:, 1], ins_s["v"][:, 2],
                                            "upright", lever_arm_m=(0.1, 0.2, 0.5), time_s=ts))
    _report("motion correction + lever arm", t, n)

    def ds(t_s, fs, height):
        m = t_s.size
        return xr.Dataset({k: ("time", v) for k, v in (
            ("u_east_ms", 5 + rng.standard_normal(m)), ("v_north_ms", 2 + rng.standard_normal(m)),
            ("w_up_ms", 0.4 * rng.standard_normal(m)), ("t_sonic_k", 290 + 0.2 * rng.standard_normal(m)))},
            coords={"time": T0 + np.round(t_s * 1e9).astype("timedelta64[ns]")}, attrs={"height_m": height})

    drone = ds(ts, FS, 30.0)
    mast = ds(np.arange(-30.0, DURATION_S + 30.0, 1 / 20), 20.0, 30.0)
    t = _best(lambda: align.align_drone_mast(drone, mast))
    _report("L3: align + FIR/decimate + rotate", t, n)
    x = np.stack([drone[k].values for k in ("u_east_ms", "v_north_ms", "w_up_ms")])
    t = _best(lambda: rotation.double_rotation(*x))
    _report("double rotation (32 Hz input)", t, n)
    t = _best(lambda: rotation.triple_rotation(*x))
    _report("triple rotation (32 Hz input)", t, n)

    # whole L2 builder (hover search, gap filling, lag search, correction, dataset)
    sonic_l1 = xr.Dataset({"u_sensor_ms": ("time", sonic[:, 0]), "v_sensor_ms": ("time", sonic[:, 1]),
                           "w_sensor_ms": ("time", sonic[:, 2]), "t_sonic_k": ("time", np.full(n, 293.0))},
                          coords={"time": T0 + np.round(ts * 1e9).astype("timedelta64[ns]")})
    ins_l1 = xr.Dataset({"roll_deg": ("time", att[:, 0]), "pitch_deg": ("time", att[:, 1]),
                         "yaw_deg": ("time", att[:, 2]), "vel_n_ms": ("time", vel[:, 0]),
                         "vel_e_ms": ("time", vel[:, 1]), "vel_d_ms": ("time", vel[:, 2]),
                         "lat_deg": ("time", np.full(ti.size, 43.1)), "lon_deg": ("time", np.full(ti.size, 0.36)),
                         "alt_m": ("time", np.full(ti.size, 633.0))},
                        coords={"time": T0 + np.round(ti * 1e9).astype("timedelta64[ns]")})
    t = _best(lambda: l2.payload_l2(sonic_l1, ins_l1, "upside_down"), repeat=3)
    _report("L2 builder (payload_l2, whole)", t, n)


if __name__ == "__main__":
    main()
