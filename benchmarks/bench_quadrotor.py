"""Throughput of the quadrotor chain: simulate the default fleet campaign, read, window,
calibrate and validate (Wetz et al. 2021 Tables 2, 3, C1, C2), and the wind-tunnel campaign
(Kistner et al. 2024).

Run from the repository root::

    .venv/bin/python benchmarks/bench_quadrotor.py [campaign.yaml] [--flights N] [--stand-in]

The campaign defaults to the first manifest in config/campaigns/ with quadrotor flights
(the embedded default), else ../briefs/D_default_campaign_snippet.yaml. ``--stand-in``
uses the simple log-profile wind instead of dronewind.simulate.atmosphere.simulate_wind.
Prints wall-clock seconds per stage and the headline accuracy numbers.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd
import yaml

from dronewind.quadrotor import validation
from dronewind.quadrotor import windows as qw
from dronewind.quadrotor.io import read_quadrotor
from dronewind.quadrotor.reference import read_tower_reference
from dronewind.simulate.quadrotor import log_profile_wind, simulate_quadrotor_flight
from dronewind.simulate.tunnel import simulate_tunnel
from dronewind.tunnel.analysis import analyse_tunnel

ROOT = Path(__file__).resolve().parents[1]
FALLBACK_SITE = {"name": "GM Falkenberg", "latitude": 52.1667, "longitude": 14.1236, "altitude_m": 73.0}


def _campaign(path: str | None) -> dict:
    candidates = [Path(path)] if path else sorted((ROOT / "config" / "campaigns").glob("*.yaml")) + [
        ROOT.parent / "briefs" / "D_default_campaign_snippet.yaml"]
    for c in candidates:
        if c.is_file():
            data = yaml.safe_load(c.read_text())
            if data.get("quadrotor_flights"):
                data.setdefault("site", FALLBACK_SITE)
                data.setdefault("simulation", {}).setdefault("seed", 1)
                print(f"campaign: {c}")
                return data
    sys.exit("no campaign with quadrotor_flights found")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("campaign", nargs="?")
    ap.add_argument("--flights", type=int, default=0, help="only the first N flights")
    ap.add_argument("--stand-in", action="store_true", help="log-profile stand-in wind")
    args = ap.parse_args()
    camp = _campaign(args.campaign)
    flights = camp["quadrotor_flights"][: args.flights or None]
    wind_fn = log_profile_wind if args.stand_in else None
    site_alt = float(camp["site"]["altitude_m"])
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        t0 = time.perf_counter()
        paths = {f["id"]: simulate_quadrotor_flight(camp, out, f["id"], out, wind_fn=wind_fn) for f in flights}
        t_sim = time.perf_counter() - t0
        n_uav = sum(len(f["uavs"]) for f in flights)
        print(f"simulate: {len(flights)} flights, {n_uav} UAV logs: {t_sim:.1f} s")
        for window_s, label in ((600.0, "10-min (Tables 2, 3)"), (120.0, "2-min (Tables C1, C2)")):
            t0 = time.perf_counter()
            blocks, windows = [], []
            for fid, ps in paths.items():
                ref = read_tower_reference(ps[-1])
                for p in ps[:-1]:
                    b, w = qw.flight_windows(read_quadrotor(p), ref, site_alt, fid, p.stem, window_s=window_s)
                    blocks.append(b)
                    windows.append(w)
            blocks, windows = pd.concat(blocks, ignore_index=True), pd.concat(windows, ignore_index=True)
            t_read = time.perf_counter() - t0
            t0 = time.perf_counter()
            res = validation.wetz2021_tables(blocks, windows)
            t_cal = time.perf_counter() - t0
            print(f"{label}: read + windows {t_read:.1f} s ({len(windows)} windows), "
                  f"calibration + validation {t_cal:.1f} s")
            t2, t3 = res["table2"], res["table3"]
            print(f"  Table 2 mean RMSE: individual {t2.loc['mean', 'rmse_ms_individual']:.3f} m/s, "
                  f"universal {t2.loc['mean', 'rmse_ms_universal']:.3f} m/s; aero c_d0A0 = "
                  f"{res['aero']['cd0a0_m2']:.4f} m2, c_p = {res['aero']['cp_m2_per_rad']:.4f} m2/rad")
            if not t3.empty:
                cols = [c for c in t3.columns if c.startswith("rmse_ms_")]
                print("  Table 3 mean RMSE: " + ", ".join(
                    f"{c.replace('rmse_ms_', '')} {t3.loc['mean', c]:.3f}" for c in cols))
            if res["hover_accuracy"]:
                h = res["hover_accuracy"]
                print(f"  hover accuracy (Sect. 4.3): sigma_h {h['sigma_h_m']:.2f} m, sigma_v {h['sigma_v_m']:.2f} m")
            if not res["direction"].empty:
                print(f"  direction RMSE (validation, scenario d offsets): "
                      f"{res['direction'].loc['mean', 'rmse_dir_deg']:.1f} deg")
            truth = camp["simulation"].get("quadrotor", {}).get("uavs", {})
            if truth and window_s == 600.0:
                off = res["universal_offsets"].set_index("uav")["pitch_offset_deg"]
                err = [abs(off[u] - v["pitch_offset_deg"]) for u, v in truth.items() if u in off]
                yo = res["yaw_offsets"].set_index("uav")["yaw_offset_deg"]
                erry = [abs(yo[u] - v["yaw_offset_deg"]) for u, v in truth.items() if u in yo]
                print(f"  recovered offsets: max |pitch error| {max(err):.2f} deg, max |yaw error| {max(erry):.2f} deg")
        t0 = time.perf_counter()
        tpaths = simulate_tunnel({}, out / "tunnel_campaign", seed=1)
        t_ts = time.perf_counter() - t0
        t0 = time.perf_counter()
        tres = analyse_tunnel(tpaths[-1])
        t_ta = time.perf_counter() - t0
        print(f"tunnel: simulate {t_ts:.1f} s ({len(tpaths) - 1} files), analyse {t_ta:.1f} s")
        side = tres["sideslip"]
        print("  sideslip RMSE [m/s] per AoS: " + ", ".join(
            f"{a:g}: {r:.2f}" for a, r in side[side["speed_bin_ms"].isna()][["aos_deg", "rmse_ms"]].to_numpy()))
        print(f"  gust dip-to-dip RMSE {tres['gust_summary'].attrs['rmse_delta_t_all_s']:.2f} s; "
              f"turbulence median f_max {tres['turbulence_summary'].loc[0, 'median_f_max_hz']:.2f} Hz")


if __name__ == "__main__":
    main()
