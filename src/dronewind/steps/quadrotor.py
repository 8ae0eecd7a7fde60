"""The quadrotor (SWUF-3D, seed 001) and wind-tunnel (seed 002) chains, step by step.

Each function reads its inputs, calls the library (:mod:`dronewind.quadrotor.calibration`,
:mod:`dronewind.tunnel.analysis`, :mod:`dronewind.quadrotor.io`) and writes its outputs: NetCDF
through :func:`dronewind.core.cf.write_netcdf`, tables atomically. Snakemake scripts in
``scripts/quadrotor_*.py`` and ``scripts/tunnel_*.py`` call them; they can be rerun by hand.

Steps and products (``R = results/<name>``):

* :func:`simulate_quadrotor` / :func:`simulate_tunnel` (virtual campaigns only): L0 files.
* :func:`quadrotor_flight` (one job per flight): ``R/netcdf/L1/quadrotor/<flight>_<uav>.nc``
  (attitude and GNSS log in CF form) and the flight's averaging windows
  ``R/quadrotor/windows/<flight>_{windows,blocks,problems}.csv`` (10-min and 2-min windows,
  seed 001 Sect. 5 and App. C; UAV logs that cannot be used are listed, never dropped
  silently).
* :func:`quadrotor_calibration` (campaign): ``R/tables/quadrotor_calibration.csv`` (the
  contract table), ``quadrotor_table2/3/C1/C2.csv``, ``quadrotor_direction.csv``,
  ``quadrotor_windows.csv`` (per-window predictions that the figures plot),
  ``quadrotor_profiles.csv``, ``quadrotor_problems.csv`` and ``R/quadrotor/calibration.json``.
* :func:`quadrotor_l2` (one job per flight): ``R/netcdf/L2/quadrotor/<flight>_<uav>.nc``, the
  calibrated 1 Hz wind of each UAV (seed 001 Sect. 6).
* :func:`tunnel_analysis`: ``R/tables/tunnel_<table>.csv`` (seed 002 Table 2 equivalent,
  Figs 4-5 RMSEs, gusts, steps, turbulence).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from dronewind.core.cf import atomic_write_text
from dronewind.errors import InputError, ProcessingError
from dronewind.manifest import load_campaign
from dronewind.steps.common import LOG, open_product

__all__ = [
    "QUAD_TABLES", "TUNNEL_TABLES", "simulate_quadrotor", "simulate_tunnel", "tunnel_root",
    "compute_quadrotor_l1", "compute_flight_windows", "quadrotor_flight", "read_windows",
    "compute_quadrotor_tables", "quadrotor_calibration", "compute_quadrotor_l2", "quadrotor_l2",
    "tunnel_analysis",
]

#: Campaign tables written by :func:`quadrotor_calibration` (file stem -> content).
QUAD_TABLES: dict[str, str] = {
    "quadrotor_calibration": "contract table: one row per UAV (uav, pitch_offset_deg, yaw_offset_deg, rmse_ms, "
                             "bias_ms, ...)",
    "quadrotor_table2": "seed 001 Table 2: individual vs universal calibration, 10-min windows",
    "quadrotor_table3": "seed 001 Table 3: calibration scenarios a-d, 10-min windows",
    "quadrotor_tableC1": "seed 001 Table C1: as Table 2 with 2-min windows",
    "quadrotor_tableC2": "seed 001 Table C2: as Table 3 with 2-min windows",
    "quadrotor_direction": "speed and direction accuracy with scenario-d pitch and yaw offsets (Sect. 5.4)",
    "quadrotor_windows": "per 10-min window: reference, UAV speed per calibration, direction, tilt, variance",
    "quadrotor_profiles": "per flight and height: mean UAV and tower speed (Fig. 8)",
    "quadrotor_problems": "UAV logs left out and why",
}

#: Tunnel tables written by :func:`tunnel_analysis` (keys of :func:`dronewind.tunnel.analysis.analyse_tunnel`).
TUNNEL_TABLES: tuple[str, ...] = (
    "offsets", "calibration", "steps_accuracy", "sideslip", "portability", "gusts", "gust_summary",
    "steps", "step_summary", "turbulence", "turbulence_summary",
)

_WINDOW_LENGTHS_S = (600.0, 120.0)


def _qcfg(config: Mapping[str, Any] | None) -> dict[str, Any]:
    """``processing.quadrotor`` options with defaults."""
    q = dict(((config or {}).get("processing") or {}).get("quadrotor") or {})
    return {"calibration_window_s": float(q.get("calibration_window_s", 600.0)),
            "average_s": float(q.get("average_s", 1.0)),
            "block_s": float(q.get("block_s", 1.0))}


def _csv(frame: pd.DataFrame, path: str | Path) -> Path:
    return atomic_write_text(path, frame.to_csv(index=False, float_format="%.8g", na_rep=""))


# ----------------------------------------------------------------------------- simulation


def simulate_quadrotor(manifest: str | Path, flight_id: str, out_dir: str | Path) -> list[Path]:
    """Write the L0 files of one simulated quadrotor flight (UAV CSVs and tower reference).

    Parameters
    ----------
    manifest : str or Path
        Manifest with ``simulation.quadrotor_flights.<flight_id>``.
    flight_id : str
        Quadrotor flight id.
    out_dir : str or Path
        L0 root (``results/<name>/L0``); files go to the manifest's relative paths.

    Returns
    -------
    list of Path
        The written files.
    """
    from dronewind.simulate.quadrotor import simulate_quadrotor_flight

    campaign = load_campaign(manifest)
    paths = simulate_quadrotor_flight(campaign.data, campaign.directory, flight_id, Path(out_dir))
    for path in paths:
        LOG.info("wrote %s", path)
    return paths


def tunnel_root(runs: str) -> Path:
    """Folder below which a simulated tunnel campaign writes ``tunnel/runs.csv``.

    The simulator always writes ``<root>/tunnel/runs.csv``; the manifest's ``tunnel.runs``
    must therefore end in ``tunnel/runs.csv``.

    Raises
    ------
    InputError
        Naming ``tunnel.runs`` when it does not.
    """
    rel = Path(runs)
    if rel.name != "runs.csv" or rel.parent.name != "tunnel":
        raise InputError("tunnel.runs", f"{runs!r}: a simulated tunnel campaign writes '<folder>/tunnel/runs.csv'")
    return rel.parent.parent


def simulate_tunnel(manifest: str | Path, out_dir: str | Path) -> list[Path]:
    """Write the L0 files of a simulated wind-tunnel campaign (``simulation.tunnel``).

    Parameters
    ----------
    manifest : str or Path
        Manifest with ``tunnel.runs`` and a ``simulation.tunnel`` section.
    out_dir : str or Path
        L0 root; the run index goes to ``out_dir / tunnel.runs``.

    Returns
    -------
    list of Path
        Files written (run index last).

    Notes
    -----
    The seed is SHA-256 of ``"<campaign seed>:tunnel"`` (like a flight's seed).
    """
    from dronewind.simulate.settings import flight_seed
    from dronewind.simulate.tunnel import simulate_tunnel as _simulate

    campaign = load_campaign(manifest)
    sim = campaign.data.get("simulation") or {}
    if "tunnel" not in sim:
        raise InputError("simulation.tunnel", "missing: a simulated tunnel campaign needs its settings")
    runs = (campaign.data.get("tunnel") or {}).get("runs")
    if not runs:
        raise InputError("tunnel.runs", "missing: path of the run index (e.g. tunnel/runs.csv)")
    root = Path(out_dir) / tunnel_root(runs)
    paths = _simulate(dict(sim.get("tunnel") or {}), root, flight_seed(int(sim.get("seed", 0)), "tunnel"))
    LOG.info("tunnel: wrote %d files under %s", len(paths), root / "tunnel")
    return paths


# ----------------------------------------------------------------------------- per flight


def _track_to_cf(ds: Any) -> Any:
    """GNSS track of a hovering platform as CF H.5 ``precise_lat/precise_lon`` (time)."""
    rename = {k: v for k, v in (("lat_deg", "precise_lat"), ("lon_deg", "precise_lon"), ("alt_m", "altitude"))
              if k in ds.variables}
    out = ds.rename(rename)
    for name, std, units, text in (("precise_lat", "latitude", "degrees_north", "GNSS latitude of the platform"),
                                   ("precise_lon", "longitude", "degrees_east", "GNSS longitude of the platform"),
                                   ("altitude", "altitude", "m", "GNSS altitude above mean sea level")):
        if name in out:
            out[name].attrs = {"standard_name": std, "units": units, "long_name": text}
            if name == "altitude":
                out[name].attrs["positive"] = "up"
    return out


def _from_cf(ds: Any) -> Any:
    """Back to the library's names: drop the writer's station coordinates, rename the track."""
    drop = [c for c in ("station", "lat", "lon", "alt") if c in ds.variables]
    out = ds.drop_vars(drop)
    for var in out.variables.values():
        var.attrs.pop("coordinates", None)
        var.encoding.pop("coordinates", None)
    pairs = (("precise_lat", "lat_deg"), ("precise_lon", "lon_deg"), ("altitude", "alt_m"))
    return out.rename({k: v for k, v in pairs if k in out.variables})


def compute_quadrotor_l1(path: str | Path) -> Any:
    """Quadrotor L1 dataset: the log read by :func:`dronewind.quadrotor.io.read_quadrotor` in CF form.

    Raises
    ------
    InputError
        From the reader (missing file, missing attitude columns, bad time stamps, ...).
    """
    from dronewind.quadrotor.io import read_quadrotor

    ds = read_quadrotor(path)
    for name in ("vel_n_ms", "vel_e_ms", "vel_d_ms"):
        if name in ds:
            ds[name].attrs.pop("standard_name", None)
    return _track_to_cf(ds)


def compute_flight_windows(logs: Mapping[str, Any], reference_file: str | Path, flight_id: str,
                           site_altitude_m: float, files: Mapping[str, str] | None = None,
                           block_s: float = 1.0) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """Averaging windows of every UAV of a flight, 10-min and 2-min (seed 001 Sect. 5, App. C).

    Parameters
    ----------
    logs : mapping
        UAV id -> quadrotor log (library names, :func:`dronewind.quadrotor.io.read_quadrotor`).
    reference_file : str or Path
        Tower reference CSV of the flight.
    flight_id : str
        Flight id.
    site_altitude_m : float
        Ground altitude above MSL [m].
    files : mapping, optional
        UAV id -> file name for the problem table.
    block_s : float
        Block length of the attitude averages [s].

    Returns
    -------
    windows, blocks : pandas.DataFrame
        :func:`dronewind.quadrotor.calibration.flight_windows` output for both window lengths, with a
        ``window_s`` column (window keys are unique per ``window_s``).
    problems : pandas.DataFrame
        ``flight, uav, file, window_s, error``: what could not be used (a UAV that never
        hovers, a reference that does not cover a window, ...).
    """
    from dronewind.quadrotor import calibration as q
    from dronewind.quadrotor.io import read_tower_reference

    files = dict(files or {})
    problems: list[dict[str, Any]] = []
    windows, blocks = [], []
    try:
        ref = read_tower_reference(reference_file)
    except InputError as exc:
        LOG.warning("flight %s: %s", flight_id, exc)
        problems = [{"flight": flight_id, "uav": u, "file": str(Path(reference_file).name), "window_s": w,
                     "error": str(exc)} for u in logs for w in _WINDOW_LENGTHS_S]
        ref = None
    if ref is not None:
        for uav, ds in logs.items():
            for window_s in _WINDOW_LENGTHS_S:
                try:
                    b, w = q.flight_windows(ds, ref, site_altitude_m, flight_id, uav, window_s=window_s,
                                            block_s=block_s)
                except InputError as exc:
                    LOG.warning("flight %s uav %s (%g s windows): %s", flight_id, uav, window_s, exc)
                    problems.append({"flight": flight_id, "uav": uav, "file": files.get(uav, ""),
                                     "window_s": window_s, "error": str(exc)})
                    continue
                windows.append(w.assign(window_s=window_s, var_ref_1min_m2s2=_ref_variance(ref, w)))
                blocks.append(b.assign(window_s=window_s))
    wcols = ["window_key", "flight", "uav", "window", "start", "end", "height_m", "ref_height_m", "ref_speed_ms",
             "ref_from_deg", "n_blocks", "n_blocks_nan", "n_ref", "sigma_h_m", "sigma_v_m", "hover_s",
             "n_dropped_s", "window_s", "var_ref_1min_m2s2"]
    bcols = ["window_key", "roll_deg", "pitch_deg", "yaw_deg", "vel_n_ms", "vel_e_ms", "window_s"]
    w = pd.concat(windows, ignore_index=True) if windows else pd.DataFrame(columns=wcols)
    b = pd.concat(blocks, ignore_index=True) if blocks else pd.DataFrame(columns=bcols)
    for col in ("start", "end"):
        if len(w):
            w[col] = pd.to_datetime(w[col]).dt.strftime("%Y-%m-%dT%H:%M:%S.%fZ")
    return (w[wcols], b[bcols],
            pd.DataFrame(problems, columns=["flight", "uav", "file", "window_s", "error"]))


def _ref_variance(ref: Any, windows: pd.DataFrame) -> np.ndarray:
    """Variance of the tower records (1-min means) inside each window at its reference height [m2 s-2]."""
    heights = ref["height_m"].to_numpy().astype(float)
    t = ref["time"].to_numpy()
    out = []
    for _, row in windows.iterrows():
        k = int(np.argmin(np.abs(heights - float(row["ref_height_m"]))))
        sp = ref["wind_speed_ms"].isel(height=k).to_numpy()
        sel = (t >= np.datetime64(row["start"])) & (t < np.datetime64(row["end"])) & np.isfinite(sp)
        out.append(float(np.var(sp[sel])) if sel.sum() > 1 else np.nan)
    return np.asarray(out)


def quadrotor_flight(manifest: str | Path, flight_id: str, uav_files: Mapping[str, str | Path],
                     reference_file: str | Path, out_l1: Mapping[str, str | Path], out_windows: str | Path,
                     out_blocks: str | Path, out_problems: str | Path, config: Mapping[str, Any]) -> list[Path]:
    """L0 -> L1 NetCDF of every UAV of a flight, and the flight's averaging windows.

    Parameters
    ----------
    manifest : str or Path
        Campaign manifest.
    flight_id : str
        Quadrotor flight id.
    uav_files : mapping
        UAV id -> raw log (CSV or ULog).
    reference_file : str or Path
        Tower reference CSV.
    out_l1 : mapping
        UAV id -> L1 NetCDF to write.
    out_windows, out_blocks, out_problems : str or Path
        CSV files (see :func:`compute_flight_windows`).
    config : mapping
        Workflow configuration (``processing.quadrotor.block_s``).

    Returns
    -------
    list of Path
        Written files.

    Raises
    ------
    InputError
        A log that cannot be read (e.g. without attitude columns): its L1 file cannot be
        written, so the job stops naming the file and what is missing.
    """
    from dronewind.core.cf import write_netcdf

    campaign = load_campaign(manifest)
    site = campaign.data["site"]
    site_alt = float(site["altitude_m"])
    logs, written = {}, []
    for uav, path in uav_files.items():
        ds = compute_quadrotor_l1(path)
        logs[uav] = _from_cf(ds)
        lat = float(np.nanmedian(ds["precise_lat"])) if np.isfinite(ds["precise_lat"]).any() else site["latitude"]
        lon = float(np.nanmedian(ds["precise_lon"])) if np.isfinite(ds["precise_lon"]).any() else site["longitude"]
        alt = float(np.nanmedian(ds["altitude"])) - site_alt if np.isfinite(ds["altitude"]).any() else None
        LOG.info("flight %s uav %s L1: %d samples; %s", flight_id, uav, ds.sizes["time"],
                 ds.attrs.get("processing_log", "").replace("\n", "; "))
        written.append(write_netcdf(
            ds, out_l1[uav], title=f"{campaign.name} flight {flight_id}: quadrotor {uav} attitude and GNSS, L1",
            summary="Attitude (roll, pitch, yaw) and GNSS/EKF velocity and position of a SWUF-3D quadrotor as "
                    "logged, time sorted and de-duplicated (seed 001 Sect. 2).",
            processing_level="L1: UTC time, sorted, duplicates removed", history=f"quadrotor_flight {flight_id} {uav}",
            inputs=[path], config=config, station_id=f"{flight_id}_{uav}", latitude=lat, longitude=lon,
            height_m=alt, extra_attrs={"campaign": campaign.name, "flight": flight_id, "uav": uav},
            nonstandard_group="platform_velocity"))
    files = {u: Path(p).name for u, p in uav_files.items()}
    w, b, problems = compute_flight_windows(logs, reference_file, flight_id, site_alt, files,
                                            block_s=_qcfg(config)["block_s"])
    LOG.info("flight %s: %d windows (600 s and 120 s), %d problem(s)", flight_id, len(w), len(problems))
    written += [_csv(w, out_windows), _csv(b, out_blocks), _csv(problems, out_problems)]
    return written


# ----------------------------------------------------------------------------- campaign


def read_windows(windows_files: Sequence[str | Path], blocks_files: Sequence[str | Path],
                 window_s: float) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Concatenate per-flight window and block tables of one window length.

    Returns
    -------
    blocks, windows : pandas.DataFrame
        As :func:`dronewind.quadrotor.calibration.flight_windows` (``start``/``end`` as datetime64).
    """
    ws = [pd.read_csv(f, dtype={"flight": str, "uav": str, "window_key": str}) for f in windows_files]
    bs = [pd.read_csv(f, dtype={"window_key": str}) for f in blocks_files]
    w = pd.concat([x for x in ws if len(x)], ignore_index=True) if any(len(x) for x in ws) else ws[0]
    b = pd.concat([x for x in bs if len(x)], ignore_index=True) if any(len(x) for x in bs) else bs[0]
    w = w[np.isclose(w["window_s"].astype(float), window_s)].reset_index(drop=True)
    b = b[np.isclose(b["window_s"].astype(float), window_s)].reset_index(drop=True)
    for col in ("start", "end"):
        w[col] = pd.to_datetime(w[col].astype(str).str.rstrip("Z")).astype("datetime64[ns]")
    return b.drop(columns="window_s"), w


def _block_speeds(blocks: pd.DataFrame, windows: pd.DataFrame, params: pd.DataFrame, aero: Mapping) -> pd.DataFrame:
    """Wind speed and tilt of every block with a UAV's calibrated offsets (for variances and Fig. 4)."""
    from dronewind.quadrotor import calibration as q

    p = params.set_index(params["uav"].astype(str))
    uav = blocks["window_key"].map(windows.set_index("window_key")["uav"].astype(str))
    off_p = uav.map(p["pitch_offset_deg"]).fillna(0.0).to_numpy(float)
    law = q.DragLaw(cd0a0_m2=float(aero["cd0a0_m2"]), cp_m2_per_rad=float(aero["cp_m2_per_rad"]))
    w = q.wind_from_attitude(blocks["roll_deg"].to_numpy(float), blocks["pitch_deg"].to_numpy(float),
                             blocks["yaw_deg"].to_numpy(float), blocks["vel_n_ms"].to_numpy(float),
                             blocks["vel_e_ms"].to_numpy(float), law=law, pitch_offset_deg=off_p)
    tilt, _ = q.tilt_from_attitude(np.radians(blocks["roll_deg"].to_numpy(float)),
                                   np.radians(blocks["pitch_deg"].to_numpy(float) - off_p))
    return pd.DataFrame({"window_key": blocks["window_key"].to_numpy(), "speed_ms": w["speed_ms"],
                         "tilt_deg": np.degrees(tilt)})


def compute_quadrotor_tables(blocks10: pd.DataFrame, windows10: pd.DataFrame, blocks2: pd.DataFrame,
                             windows2: pd.DataFrame, problems: pd.DataFrame,
                             calibration_window_s: float = 600.0) -> dict[str, Any]:
    """All campaign tables of the quadrotor chain (seed 001 Tables 2, 3, C1, C2, Figs 3-9 data).

    Parameters
    ----------
    blocks10, windows10 : pandas.DataFrame
        10-min windows (:func:`read_windows` with 600 s).
    blocks2, windows2 : pandas.DataFrame
        2-min windows (120 s).
    problems : pandas.DataFrame
        UAV logs left out (concatenated per-flight problem tables).
    calibration_window_s : float
        Window length of the contract table (600 as seed 001 Sect. 5; 120 for short flights).

    Returns
    -------
    dict
        Tables keyed as :data:`QUAD_TABLES` and ``summary`` (dict for calibration.json).

    Raises
    ------
    InputError
        When a window length has fewer than 3 windows (nothing to calibrate).
    """
    from dronewind.quadrotor import calibration as q

    out: dict[str, Any] = {}
    res10 = q.seed001_tables(blocks10, windows10) if len(windows10) >= 3 else None
    res2 = q.seed001_tables(blocks2, windows2) if len(windows2) >= 3 else None
    if res10 is None and res2 is None:
        raise InputError("quadrotor windows", f"{len(windows10)} 10-min and {len(windows2)} 2-min windows; at least 3 "
                                              "are needed to calibrate (see quadrotor_problems.csv)")
    main = res10 if (calibration_window_s >= 600.0 and res10 is not None) or res2 is None else res2
    main_b, main_w = (blocks10, windows10) if main is res10 else (blocks2, windows2)
    for name, res, key in (("quadrotor_table2", res10, "table2"), ("quadrotor_table3", res10, "table3"),
                           ("quadrotor_tableC1", res2, "table2"), ("quadrotor_tableC2", res2, "table3")):
        out[name] = res[key].reset_index() if res is not None else pd.DataFrame({"uav": []})
    out["quadrotor_direction"] = main["direction"].reset_index()
    table = main["calibration_table"]
    out["quadrotor_calibration"] = table
    # per-window predictions (Figs 3, 5, 6, 9): individual, universal and scenario-d offsets
    aero = main["aero"]
    ind = q.predict_windows(main_b, main_w, main["individual"], method="tilt")
    uni = q.predict_windows(main_b, main_w, main["universal_offsets"], aero=aero)
    params = table[["uav", "pitch_offset_deg", "yaw_offset_deg"]]
    cal = q.predict_windows(main_b, main_w, params, aero=aero)
    pw = cal[["window_key", "flight", "uav", "window", "start", "end", "height_m", "ref_height_m", "ref_speed_ms",
              "ref_from_deg", "uav_speed_ms", "uav_from_deg", "error_ms", "dir_error_deg"]].copy()
    pw["validation"] = pw["flight"].isin(main["validation"]).astype(int)
    pw["speed_individual_ms"] = pw["window_key"].map(ind.set_index("window_key")["uav_speed_ms"])
    pw["speed_universal_ms"] = pw["window_key"].map(uni.set_index("window_key")["uav_speed_ms"])
    bs = _block_speeds(main_b, main_w, params, aero)
    g = bs.groupby("window_key")
    pw["tilt_deg"] = pw["window_key"].map(g["tilt_deg"].mean())
    # variance of 1-min means (the tower reports 1-min means; seed 001 Fig. 9 analogue)
    bs["minute"] = bs.groupby("window_key").cumcount() // 60
    m = bs.groupby(["window_key", "minute"])["speed_ms"].mean().groupby("window_key")
    pw["var_uav_1min_m2s2"] = pw["window_key"].map(m.var(ddof=0))
    if "var_ref_1min_m2s2" in main_w:
        pw["var_ref_1min_m2s2"] = pw["window_key"].map(main_w.set_index("window_key")["var_ref_1min_m2s2"])
    out["quadrotor_windows"] = pw
    prof = pw.groupby(["flight", "ref_height_m"]).agg(
        height_m=("height_m", "mean"), uav_speed_ms=("uav_speed_ms", "mean"), ref_speed_ms=("ref_speed_ms", "mean"),
        uav_from_deg=("uav_from_deg", "mean"), ref_from_deg=("ref_from_deg", "mean"),
        n_windows=("window_key", "size")).reset_index()
    rmse = table.set_index("uav")["rmse_ms"]
    prof["uav"] = prof.apply(lambda r: ",".join(sorted(set(pw.loc[(pw["flight"] == r["flight"])
                                                                  & (pw["ref_height_m"] == r["ref_height_m"]),
                                                                  "uav"]))), axis=1)
    prof["rmse_ms"] = prof["uav"].map(lambda u: float(np.nanmean([rmse.get(x, np.nan) for x in u.split(",")])))
    out["quadrotor_profiles"] = prof
    out["quadrotor_problems"] = problems.reset_index(drop=True)
    converged = bool(aero.get("converged", False))
    summary = {
        "calibration_window_s": 600.0 if main is res10 else 120.0,
        "aero": {k: (bool(v) if isinstance(v, bool | np.bool_) else int(v) if isinstance(v, int | np.integer)
                     else float(v) if isinstance(v, float | np.floating) else v) for k, v in aero.items()},
        "converged": converged,
        "status": "converged" if converged else "NOT CONVERGED: aerodynamic parameters unreliable",
        "independent_validation": bool(main["independent_validation"]),
        "scenarios": {k: list(v) for k, v in main["scenarios"].items()},
        "validation_flights": list(main["validation"]),
        "hover_accuracy": main["hover_accuracy"],
        "n_windows_600s": len(windows10), "n_windows_120s": len(windows2),
        "n_problem_logs": int(problems[["flight", "uav"]].drop_duplicates().shape[0]) if len(problems) else 0,
        "individual": main["individual"].to_dict(orient="records"),
        # the universal law evaluated on a tilt grid (seed 001 Fig. 4 draws it from here)
        "regression_curve": {"tilt_deg": [float(x) for x in np.arange(0.0, 20.01, 0.25)],
                             "speed_ms": [float(v) for v in q.speed_from_tilt(
                                 np.radians(np.arange(0.0, 20.01, 0.25)), float(aero["cd0a0_m2"]),
                                 float(aero["cp_m2_per_rad"]))]},
    }
    out["summary"] = summary
    return out


def quadrotor_calibration(manifest: str | Path, windows_files: Sequence[str | Path],
                          blocks_files: Sequence[str | Path], problems_files: Sequence[str | Path],
                          tables_dir: str | Path, summary_file: str | Path, config: Mapping[str, Any]) -> list[Path]:
    """Campaign calibration and validation tables of the quadrotor fleet (seed 001 Sect. 5).

    Parameters
    ----------
    manifest : str or Path
        Campaign manifest.
    windows_files, blocks_files, problems_files : sequence of path
        Per-flight outputs of :func:`quadrotor_flight`.
    tables_dir : str or Path
        ``results/<name>/tables``; files ``<name>.csv`` for each of :data:`QUAD_TABLES`.
    summary_file : str or Path
        JSON with the aerodynamic parameters, convergence, scenarios and hover accuracy.
    config : mapping
        Workflow configuration (``processing.quadrotor.calibration_window_s``).

    Returns
    -------
    list of Path
        Written files.

    Notes
    -----
    A calibration that does not converge is not hidden: ``converged`` is 0 in the contract
    table and ``status`` in the JSON says so, and the log carries a warning.
    """
    campaign = load_campaign(manifest)
    b10, w10 = read_windows(windows_files, blocks_files, 600.0)
    b2, w2 = read_windows(windows_files, blocks_files, 120.0)
    probs = [pd.read_csv(f, dtype=str) for f in problems_files]
    problems = pd.concat(probs, ignore_index=True) if probs else pd.DataFrame()
    res = compute_quadrotor_tables(b10, w10, b2, w2, problems, _qcfg(config)["calibration_window_s"])
    summary = {"campaign": campaign.name, **res.pop("summary")}
    if not summary["converged"]:
        LOG.warning("quadrotor calibration did not converge: %s", summary["aero"])
    written = [_csv(res[name], Path(tables_dir) / f"{name}.csv") for name in QUAD_TABLES]
    written.append(atomic_write_text(summary_file, json.dumps(summary, indent=2, default=_json_default) + "\n"))
    LOG.info("quadrotor calibration: c_d0A0 = %.4f m2, c_p = %.4f m2/rad; mean RMSE %.3f m/s",
             summary["aero"]["cd0a0_m2"], summary["aero"]["cp_m2_per_rad"],
             float(np.nanmean(res["quadrotor_calibration"]["rmse_ms"])))
    return written


def _json_default(value: Any) -> Any:
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return None if not np.isfinite(value) else float(value)
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, pd.Timestamp | np.datetime64):
        return str(value)
    return str(value)


# ----------------------------------------------------------------------------- L2 per flight


def compute_quadrotor_l2(log: Any, calibration: pd.DataFrame, aero: Mapping[str, float], uav: str,
                         average_s: float = 1.0) -> Any:
    """Calibrated wind series of one UAV (seed 001 Sect. 6) with a hover flag.

    Parameters
    ----------
    log : xarray.Dataset
        Quadrotor log (library names).
    calibration : pandas.DataFrame
        Contract table (``uav``, ``pitch_offset_deg``, ``yaw_offset_deg``).
    aero : mapping
        ``cd0a0_m2``, ``cp_m2_per_rad`` (universal calibration).
    uav : str
        UAV id.
    average_s : float
        Output averaging [s] (1 Hz in seed 001).

    Returns
    -------
    xarray.Dataset
        :func:`dronewind.quadrotor.calibration.uav_wind_dataset` output with attrs ``usable`` (1/0),
        ``unusable_reason``; a UAV that never hovers gives the wind of its whole log with
        ``usable = 0`` (never a silent result). UAVs without a calibration use zero
        offsets and are marked ``calibrated = 0``.
    """
    from dronewind.quadrotor import calibration as q

    row = calibration[calibration["uav"].astype(str) == str(uav)]
    p_off = float(row["pitch_offset_deg"].iloc[0]) if len(row) else math.nan
    y_off = float(row["yaw_offset_deg"].iloc[0]) if len(row) else math.nan
    calibrated = int(np.isfinite(p_off) and np.isfinite(y_off))
    p_off = p_off if np.isfinite(p_off) else 0.0
    y_off = y_off if np.isfinite(y_off) else 0.0
    law = q.DragLaw(cd0a0_m2=float(aero["cd0a0_m2"]), cp_m2_per_rad=float(aero["cp_m2_per_rad"]))
    try:
        ds = q.uav_wind_dataset(log, law=law, pitch_offset_deg=p_off, yaw_offset_deg=y_off, average_s=average_s,
                                hover_kwargs={"where": f"uav {uav}"})
        usable, reason = 1, ""
    except InputError as exc:
        LOG.warning("uav %s: %s; wind of the whole log written with usable = 0", uav, exc)
        ds = q.uav_wind_dataset(log, law=law, pitch_offset_deg=p_off, yaw_offset_deg=y_off, average_s=average_s,
                                hover_kwargs={"horiz_tol_m": 1e9, "alt_tol_m": 1e9, "max_speed_ms": 1e9,
                                              "min_duration_s": 0.0, "where": f"uav {uav}"})
        usable, reason = 0, str(exc)
    if not calibrated:
        reason = (reason + "; " if reason else "") + "no calibration for this UAV: zero offsets used"
    ds.attrs.update(usable=usable, unusable_reason=reason, calibrated=calibrated,
                    cd0a0_m2=float(aero["cd0a0_m2"]), cp_m2_per_rad=float(aero["cp_m2_per_rad"]))
    ds["yaw_from_deg"].attrs.pop("standard_name", None)
    return ds


def quadrotor_l2(manifest: str | Path, flight_id: str, l1_files: Mapping[str, str | Path],
                 calibration_file: str | Path, summary_file: str | Path, out_l2: Mapping[str, str | Path],
                 config: Mapping[str, Any]) -> list[Path]:
    """L1 -> L2 NetCDF per UAV of a flight: calibrated 1 Hz wind (seed 001 Sect. 6, Fig. 7).

    Parameters
    ----------
    manifest : str or Path
        Campaign manifest.
    flight_id : str
        Quadrotor flight id.
    l1_files : mapping
        UAV id -> L1 file.
    calibration_file, summary_file : str or Path
        ``tables/quadrotor_calibration.csv`` and ``quadrotor/calibration.json``.
    out_l2 : mapping
        UAV id -> L2 file to write.
    config : mapping
        Workflow configuration (``processing.quadrotor.average_s``).

    Returns
    -------
    list of Path
        Written files.
    """
    from dronewind.core.cf import write_netcdf

    campaign = load_campaign(manifest)
    site = campaign.data["site"]
    table = pd.read_csv(calibration_file, dtype={"uav": str})
    aero = json.loads(Path(summary_file).read_text())["aero"]
    written = []
    for uav, path in l1_files.items():
        log = _from_cf(open_product(path))
        ds = compute_quadrotor_l2(log, table, aero, uav, _qcfg(config)["average_s"])
        LOG.info("flight %s uav %s L2: %d samples, usable %d %s", flight_id, uav, ds.sizes["time"],
                 ds.attrs["usable"], ds.attrs["unusable_reason"])
        ds = _track_to_cf(ds)
        lat = float(np.nanmedian(ds["precise_lat"])) if np.isfinite(ds["precise_lat"]).any() else site["latitude"]
        lon = float(np.nanmedian(ds["precise_lon"])) if np.isfinite(ds["precise_lon"]).any() else site["longitude"]
        height = float(np.nanmedian(ds["altitude"])) - float(site["altitude_m"])
        written.append(write_netcdf(
            ds, out_l2[uav], title=f"{campaign.name} flight {flight_id}: quadrotor {uav} wind, L2",
            summary="Horizontal wind from the attitude of a hovering SWUF-3D quadrotor: drag balance with the "
                    "universal aerodynamic parameters and the UAV's pitch and yaw offsets from the campaign "
                    "calibration, GNSS velocity added, 1 s averages over the hover (seed 001 Eqs 12-18, Sect. 6).",
            processing_level="L2: calibrated wind, earth frame", history=f"quadrotor_l2 {flight_id} {uav}",
            inputs=[path, calibration_file, summary_file], config=config, station_id=f"{flight_id}_{uav}",
            latitude=lat, longitude=lon, height_m=height if np.isfinite(height) else None,
            extra_attrs={"campaign": campaign.name, "flight": flight_id, "uav": uav},
            nonstandard_group="weather_vane"))
    return written


# ----------------------------------------------------------------------------- tunnel


def tunnel_analysis(manifest: str | Path, runs_file: str | Path, tables_dir: str | Path,
                    config: Mapping[str, Any] | None = None) -> list[Path]:
    """All seed 002 tables of the tunnel campaign (:func:`dronewind.tunnel.analysis.analyse_tunnel`).

    Parameters
    ----------
    manifest : str or Path
        Campaign manifest (for the log only).
    runs_file : str or Path
        ``tunnel/runs.csv``.
    tables_dir : str or Path
        Output folder; one ``tunnel_<table>.csv`` per :data:`TUNNEL_TABLES` (empty tables
        for run kinds absent from the programme).
    config : mapping, optional
        Workflow configuration (unused; kept for symmetry).

    Returns
    -------
    list of Path
        Written files.

    Raises
    ------
    InputError
        Bad index or runs (named by the library); ProcessingError when no speed range
        of the calibration converges.
    """
    from dronewind.tunnel.analysis import analyse_tunnel

    campaign = load_campaign(manifest)
    res = analyse_tunnel(runs_file)
    cal = res["calibration"]
    if len(cal) and not bool(cal["converged"].astype(bool).any()):
        raise ProcessingError(f"{runs_file}: tunnel calibration did not converge in any speed range")
    written = []
    for name in TUNNEL_TABLES:
        table = res.get(name, pd.DataFrame())
        written.append(_csv(table if isinstance(table, pd.DataFrame) else pd.DataFrame(table),
                            Path(tables_dir) / f"tunnel_{name}.csv"))
    LOG.info("%s tunnel: %d calibration ranges, %d sideslip rows, %d gusts, %d steps, %d turbulence runs",
             campaign.name, len(cal), len(res.get("sideslip", [])), len(res.get("gusts", [])),
             len(res.get("steps", [])), len(res.get("turbulence", [])))
    return written
