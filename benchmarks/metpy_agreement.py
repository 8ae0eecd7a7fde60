"""Block statistics of the workflow against an independent implementation (MetPy) on the same despiked blocks.

Run from the repository root after the workflow has processed the tower campaigns, e.g.::

    PYTHONPATH=src .venv/bin/python benchmarks/metpy_agreement.py \\
        --results results/real_ameriflux_gold results/real_fluxpart \\
        --out benchmarks/results/metpy_agreement.json

For every usable block of ``tables/block_stats.csv`` it reads the block's samples from the
sonic's L1 file the workflow wrote (``netcdf/L1/mast_<sonic>.nc``: east/north/up and sonic
temperature, flagged (range, spike, diagnostic) samples NaN): the despiking is the one
thing shared with the workflow. Everything else is done here, without dronewind's
processing code: the flagged samples are bridged by linear interpolation (``numpy.interp``),
the block is double-rotated with numpy (yaw to the mean wind, then pitch to zero mean w),
detrended as the block L4 file says (``linear``: minus the least-squares line of
``numpy.polyfit``; block mean: :func:`metpy.calc.get_perturbation`), and MetPy gives the
statistics: U = :func:`metpy.calc.wind_speed` of the mean streamwise and cross-stream
components, sigma_w = sqrt(:func:`metpy.calc.kinematic_flux` (w', w')), u* =
:func:`metpy.calc.friction_velocity` (u', w', v') = ((u'w')^2 + (v'w')^2)^(1/4) and w'T' =
:func:`metpy.calc.kinematic_flux` (w', T').

Output: per results folder and quantity, the number of blocks and the median and maximum
of the relative difference |workflow - MetPy| / |MetPy|, and whether the median is within
the limits (0.5 % for U, sigma_w, u*; 2 % for w'T'). Exit status 1 when a
limit is exceeded.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

#: Limits of the median relative difference per quantity.
LIMITS = {"U_ms": 0.005, "sigma_w_ms": 0.005, "ustar_ms": 0.005, "wT_Kms": 0.02}


def _groups(path: Path) -> list[str]:
    with xr.open_dataset(path) as root:
        return [g.strip() for g in str(root.attrs.get("groups", "")).split(",") if g.strip()]


def _read_l1(path: Path) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Time [ns since 1970] and u_east, v_north, w_up [m s-1], t_sonic [K] of an L1 file (root group)."""
    with xr.open_dataset(path) as ds:
        t = np.asarray(ds["time"].values).astype("datetime64[ns]").astype(np.int64)
        return t, {k: np.asarray(ds[k].values, dtype=float) for k in ("u_east_ms", "v_north_ms", "w_up_ms",
                                                                      "t_sonic_k")}


def _detrending(path: Path) -> str:
    """``linear`` or ``block_mean`` from the block L4 file's ``detrending`` attribute."""
    with xr.open_dataset(path) as ds:
        text = str(ds.attrs["detrending"])
    if text.startswith("linear"):
        return "linear"
    if text.startswith("block mean"):
        return "block_mean"
    raise ValueError(f"{path}: attribute detrending {text!r}; expected 'linear ...' or 'block mean ...'")


def _fill(x: np.ndarray) -> np.ndarray:
    ok = np.isfinite(x)
    i = np.arange(x.size)
    return np.interp(i, i[ok], x[ok])


def _double_rotation(u: np.ndarray, v: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    yaw = np.arctan2(v.mean(), u.mean())
    u1 = u * np.cos(yaw) + v * np.sin(yaw)
    v1 = -u * np.sin(yaw) + v * np.cos(yaw)
    pitch = np.arctan2(w.mean(), u1.mean())
    u2 = u1 * np.cos(pitch) + w * np.sin(pitch)
    w2 = -u1 * np.sin(pitch) + w * np.cos(pitch)
    return u2, v1, w2


def _perturbation(x: np.ndarray, method: str) -> np.ndarray:
    from metpy.calc import get_perturbation

    if method == "linear":
        i = np.arange(x.size, dtype=float)
        return x - np.polyval(np.polyfit(i, x, 1), i)
    return np.asarray(get_perturbation(x))


def metpy_block(values: dict[str, np.ndarray], method: str) -> dict[str, float]:
    """U [m s-1], sigma_w [m s-1], u* [m s-1] and w'T' [K m s-1] of one block with MetPy.

    Parameters
    ----------
    values : dict
        ``u_east_ms``, ``v_north_ms``, ``w_up_ms`` [m s-1], ``t_sonic_k`` [K] of the block,
        flagged samples NaN.
    method : {"linear", "block_mean"}
        Detrending.

    Returns
    -------
    dict
        ``U_ms``, ``sigma_w_ms``, ``ustar_ms``, ``wT_Kms``.
    """
    from metpy.calc import friction_velocity, kinematic_flux, wind_speed
    from metpy.units import units

    ue, vn, wu, tk = (_fill(values[k]) for k in ("u_east_ms", "v_north_ms", "w_up_ms", "t_sonic_k"))
    u, v, w = _double_rotation(ue, vn, wu)
    up, vp, wp, tp = (_perturbation(x, method) for x in (u, v, w, tk))
    ms = units("m/s")
    speed = wind_speed(u.mean() * ms, v.mean() * ms)
    sigma_w = np.sqrt(kinematic_flux(wp * ms, wp * ms, perturbation=True))
    ustar = friction_velocity(up * ms, wp * ms, v=vp * ms, perturbation=True)
    wt = kinematic_flux(wp * ms, tp * units.kelvin, perturbation=True)
    # MetPy returns the means of the 1-D series as one-element arrays
    return {"U_ms": _scalar(speed.m_as("m/s")), "sigma_w_ms": _scalar(sigma_w.m_as("m/s")),
            "ustar_ms": _scalar(ustar.m_as("m/s")), "wT_Kms": _scalar(wt.m_as("K * m / s"))}


def _scalar(x: Any) -> float:
    arr = np.asarray(x, dtype=float).ravel()
    if arr.size != 1:
        raise ValueError(f"expected one value, got {arr.size}")
    return float(arr[0])


def agreement(results: Path) -> dict[str, Any]:
    """Per-quantity agreement of one results folder's ``block_stats.csv`` with MetPy."""
    table = pd.read_csv(results / "tables" / "block_stats.csv")
    table = table[table["usable"].astype(str).str.lower().isin(("true", "1"))]
    diffs: dict[str, list[float]] = {k: [] for k in LIMITS}
    blocks = []
    for sensor, rows in table.groupby("sensor"):
        l1 = results / "netcdf" / "L1" / f"mast_{sensor}.nc"
        method = _detrending(results / "netcdf" / "L4" / "blocks" / f"{sensor}.nc")
        t, cols = _read_l1(l1)
        for _, row in rows.iterrows():
            t0 = pd.Timestamp(row["start_utc"]).tz_localize(None).value
            t1 = pd.Timestamp(row["end_utc"]).tz_localize(None).value
            sel = (t >= t0) & (t < t1)
            ours = metpy_block({k: x[sel] for k, x in cols.items()}, method)
            entry = {"sensor": sensor, "start_utc": row["start_utc"], "n_samples": int(sel.sum())}
            for k in LIMITS:
                ref, got = ours[k], float(row[k])
                rel = abs(got - ref) / abs(ref) if ref != 0 else float("inf")
                diffs[k].append(rel)
                entry[k] = {"workflow": got, "metpy": ref, "relative_difference": rel}
            blocks.append(entry)
    summary = {}
    for k, d in diffs.items():
        arr = np.asarray(d)
        med = float(np.median(arr)) if arr.size else float("nan")
        summary[k] = {"n_blocks": int(arr.size), "median_relative_difference": med,
                      "max_relative_difference": float(arr.max()) if arr.size else float("nan"),
                      "limit_median": LIMITS[k], "within_limit": bool(arr.size and med <= LIMITS[k])}
    return {"results": str(results), "detrending": sorted({_detrending(p) for p in
                                                           (results / "netcdf" / "L4" / "blocks").glob("*.nc")}),
            "summary": summary, "blocks": blocks}


def main(argv: list[str] | None = None) -> int:
    """Command line: see the module docstring."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--results", nargs="+", type=Path, required=True,
                        help="results/<campaign> folders written by the workflow (tower or mast campaigns)")
    parser.add_argument("--out", type=Path,
        default=Path(__file__).resolve().parent / "results" / "metpy_agreement.json",
        help="JSON file to write")
    args = parser.parse_args(argv)
    import metpy

    out = {"command": "python benchmarks/metpy_agreement.py " + " ".join(sys.argv[1:] if argv is None else argv),
           "metpy_version": metpy.__version__, "python": platform.python_version(), "limits_median": LIMITS,
           "records": [agreement(r) for r in args.results]}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(out, indent=1) + "\n")
    ok = True
    for rec in out["records"]:
        for k, s in rec["summary"].items():
            print(f"{Path(rec['results']).name:24s} {k:11s} n={s['n_blocks']:3d} "
                  f"median {s['median_relative_difference']:.2e} max {s['max_relative_difference']:.2e} "
                  f"limit {s['limit_median']:g} "
                  f"{'ok' if s['within_limit'] else 'EXCEEDED'}")
            ok &= s["within_limit"]
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
