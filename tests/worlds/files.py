"""The contract's L0 files (docs/data-contract.md, "Raw formats"), written by the world's own code."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import yaml

SONIC_COLUMNS = "rpi_time_us,u_ms,v_ms,w_ms,t_sonic_c"
INS_COLUMNS = ("rpi_time_us,utc,time_valid,ekf_valid,lat_deg,lon_deg,alt_m,vel_n_ms,vel_e_ms,vel_d_ms,"
               "roll_deg,pitch_deg,yaw_deg")

# WGS84 (NIMA TR8350.2): radii of curvature for the local east/north offsets
_A_M = 6378137.0
_E2 = 6.69437999014e-3


def enu_to_latlon(east_m: np.ndarray, north_m: np.ndarray, lat0_deg: float, lon0_deg: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Latitude and longitude of small east/north offsets from a point (meridian and prime-vertical radii)."""
    s2 = np.sin(np.radians(lat0_deg)) ** 2
    m = _A_M * (1 - _E2) / (1 - _E2 * s2) ** 1.5
    n = _A_M / np.sqrt(1 - _E2 * s2)
    return (lat0_deg + np.degrees(north_m / m),
            lon0_deg + np.degrees(east_m / (n * np.cos(np.radians(lat0_deg)))))


def iso_utc(times: np.ndarray) -> np.ndarray:
    """ISO 8601 with microseconds and a trailing Z."""
    return np.char.add(np.datetime_as_string(times.astype("datetime64[us]"), unit="us"), "Z")


def campbell_time(times: np.ndarray) -> np.ndarray:
    """``YYYY-MM-DD HH:MM:SS.ff`` with the fraction's trailing zeros dropped (Campbell style)."""
    text = pd.Series(pd.to_datetime(times)).dt.strftime("%Y-%m-%d %H:%M:%S.%f").str.rstrip("0").str.rstrip(".")
    return text.to_numpy(dtype=str)


def write_sonic_csv(path: Path, rpi_time_us: np.ndarray, uvw_ms: np.ndarray, t_sonic_c: np.ndarray) -> Path:
    """Payload sonic CSV (rows as given, in the given order)."""
    frame = pd.DataFrame({"t": rpi_time_us.astype(np.int64), "u": uvw_ms[:, 0], "v": uvw_ms[:, 1],
                          "w": uvw_ms[:, 2], "ts": t_sonic_c})
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(SONIC_COLUMNS + "\n" + frame.to_csv(index=False, header=False, float_format="%.2f",
                                                         lineterminator="\n"))
    return path


def write_ins_csv(path: Path, columns: dict[str, np.ndarray]) -> Path:
    """INS CSV; ``utc`` (datetime64) is left empty where ``time_valid`` is 0."""
    utc = iso_utc(columns["utc"]).astype(object)
    utc[columns["time_valid"] == 0] = ""
    frame = pd.DataFrame({
        "rpi_time_us": columns["rpi_time_us"].astype(np.int64), "utc": utc,
        "time_valid": columns["time_valid"].astype(int), "ekf_valid": columns["ekf_valid"].astype(int),
        "lat_deg": np.char.mod("%.9f", columns["lat_deg"]), "lon_deg": np.char.mod("%.9f", columns["lon_deg"]),
        **{k: np.char.mod("%.4f", columns[k]) for k in ("alt_m", "vel_n_ms", "vel_e_ms", "vel_d_ms", "roll_deg",
                                                        "pitch_deg", "yaw_deg")}})
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(INS_COLUMNS + "\n" + frame.to_csv(index=False, header=False, lineterminator="\n"))
    return path


def write_toa5(path: Path, times: np.ndarray, record: np.ndarray, ux: np.ndarray, uy: np.ndarray, uz: np.ndarray,
               ts_c: np.ndarray, diag: np.ndarray) -> Path:
    """Campbell TOA5 of a CSAT3: four header lines, quoted timestamps, ``"NAN"`` where a value is NaN."""
    head = ['"TOA5","world","CR3000","1234","CR3000.Std.32","CPU:world.CR3","4321","ts_data"',
            '"TIMESTAMP","RECORD","Ux","Uy","Uz","Ts","diag_csat"',
            '"TS","RN","m/s","m/s","m/s","C","unitless"',
            '"","","Smp","Smp","Smp","Smp","Smp"']

    def fmt(x: np.ndarray) -> np.ndarray:
        out = np.char.mod("%.4f", x).astype(object)
        out[~np.isfinite(x)] = '"NAN"'
        return out

    frame = pd.DataFrame({"ts": np.char.add(np.char.add('"', campbell_time(times)), '"'), "rec": record,
                          "ux": fmt(ux), "uy": fmt(uy), "uz": fmt(uz), "t": fmt(ts_c), "d": diag.astype(int)})
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(head) + "\n" + frame.to_csv(index=False, header=False, lineterminator="\n",
                                                          quoting=csv.QUOTE_NONE, quotechar="'"))
    return path


def write_manifest(path: Path, data: dict[str, Any]) -> Path:
    """Campaign manifest YAML (no ``simulation:`` section: measured data for the pipeline)."""
    if "simulation" in data:
        raise ValueError(f"{path}: a measured manifest has no simulation section")
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path
