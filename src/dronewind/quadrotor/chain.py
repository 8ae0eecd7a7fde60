r"""The quadrotor processing chain, Dataset in, Dataset out (Wetz et al. (2021)).

The workflow steps (:mod:`dronewind.steps.quadrotor`) read the files, call these functions
and write what they return:

* :func:`compute_quadrotor_l1`: a UAV log (:func:`dronewind.quadrotor.io.read_quadrotor`)
  in CF form (GNSS track as CF H.5 ``precise_lat``/``precise_lon``/``altitude``, :func:`uav_track_to_cf`);
* :func:`compute_flight_windows`: the 10-min and 2-min averaging windows of every UAV of
  a flight (Wetz et al. (2021), Sect. 5 and App. C), UAV logs that cannot be used listed, never
  dropped silently;
* :func:`compute_quadrotor_tables`: the campaign tables (Tables 2, 3, C1, C2, the contract
  table and the data of Figs 3-9) and the calibration summary;
* :func:`compute_quadrotor_l2`: the calibrated 1 Hz wind of one UAV (Sect. 6) with a
  usable flag.

References
----------
.. [1] Wetz, T., Wildmann, N., Beyrich, F. (SWUF-3D), Wetz et al. (2021)
  , Sects. 4-6, Tables 2, 3, C1, C2, Figs 3-9.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence
from typing import Any, cast

import numpy as np
import pandas as pd
import xarray as xr

from dronewind.errors import InputError
from dronewind.quadrotor import QUAD_TABLES
from dronewind.quadrotor.drag import DragLaw, speed_from_tilt, tilt_from_attitude
from dronewind.quadrotor.wind import uav_wind_dataset, wind_from_attitude
from dronewind.quadrotor.windows import flight_windows_with_gaps

__all__ = [
    "QUAD_TABLES", "WINDOW_LENGTHS_S", "uav_track_to_cf", "nominal_position",
    "compute_quadrotor_l1", "compute_flight_windows", "unreadable_reference", "reference_variance",
    "compute_quadrotor_tables", "compute_quadrotor_l2",
]

LOG = logging.getLogger(__name__)

#: Averaging times of the windows [s]: 10 min (Wetz et al. (2021), Sect. 5) and 2 min (App. C).
WINDOW_LENGTHS_S: tuple[float, ...] = (600.0, 120.0)

_WINDOW_COLUMNS = ["window_key", "flight", "uav", "window", "start", "end", "height_m", "ref_height_m",
                   "ref_speed_ms", "ref_from_deg", "n_blocks", "n_blocks_nan", "n_ref", "sigma_h_m", "sigma_v_m",
                   "hover_s", "n_dropped_s", "window_s", "var_ref_1min_m2s2"]
_BLOCK_COLUMNS = ["window_key", "roll_deg", "pitch_deg", "yaw_deg", "vel_n_ms", "vel_e_ms", "rho_kgm3", "window_s"]
_PROBLEM_COLUMNS = ["flight", "uav", "file", "window_s", "error"]


# ----------------------------------------------------------------------------- L1


def uav_track_to_cf(ds: xr.Dataset) -> xr.Dataset:
    """GNSS track of a hovering UAV as CF H.5 ``precise_lat/precise_lon`` (time) and ``altitude``.

    Unlike :func:`dronewind.core.cf_names.track_to_cf`, the track variables get exactly the CF
    attributes (the reader's other attributes are dropped), as the quadrotor products always
    had; :func:`dronewind.core.cf_names.track_from_cf` reads them back.
    """
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


def nominal_position(ds: xr.Dataset, site: Mapping[str, Any]) -> tuple[float, float, float | None]:
    """Nominal position of a hovering UAV (CF form): median of its track, else the site.

    Parameters
    ----------
    ds : xarray.Dataset
        With ``precise_lat``, ``precise_lon``, ``altitude`` [m above MSL].
    site : mapping
        Manifest ``site`` (``latitude``, ``longitude``, ``altitude_m``).

    Returns
    -------
    latitude, longitude : float
        [degree].
    height_m : float or None
        Median altitude minus the site altitude [m]; None without a finite altitude.
    """
    lat = float(np.nanmedian(ds["precise_lat"])) if np.isfinite(ds["precise_lat"]).any() else site["latitude"]
    lon = float(np.nanmedian(ds["precise_lon"])) if np.isfinite(ds["precise_lon"]).any() else site["longitude"]
    finite = np.isfinite(ds["altitude"]).any()
    height = float(np.nanmedian(ds["altitude"])) - float(site["altitude_m"]) if finite else None
    return lat, lon, height


def compute_quadrotor_l1(log: xr.Dataset) -> xr.Dataset:
    """Quadrotor L1 dataset: a log read by :func:`dronewind.quadrotor.io.read_quadrotor` in CF form.

    Parameters
    ----------
    log : xarray.Dataset
        The reader's dataset (modified in place: velocity standard names removed).

    Returns
    -------
    xarray.Dataset
        Track renamed by :func:`uav_track_to_cf`.
    """
    for name in ("vel_n_ms", "vel_e_ms", "vel_d_ms"):
        if name in log:
            log[name].attrs.pop("standard_name", None)
    return uav_track_to_cf(log)


# ----------------------------------------------------------------------------- windows of a flight


def reference_variance(ref: xr.Dataset, windows: pd.DataFrame) -> np.ndarray:
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


def _window_tables(windows: list[pd.DataFrame], blocks: list[pd.DataFrame],
                   problems: list[dict[str, Any]]) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """Per-flight window, block and problem tables in their stored column order (ISO times)."""
    w = pd.concat(windows, ignore_index=True) if windows else pd.DataFrame(columns=_WINDOW_COLUMNS)
    b = pd.concat(blocks, ignore_index=True) if blocks else pd.DataFrame(columns=_BLOCK_COLUMNS)
    if "rho_kgm3" not in b:
        b["rho_kgm3"] = np.nan
    for col in ("start", "end"):
        if len(w):
            w[col] = pd.to_datetime(w[col]).dt.strftime("%Y-%m-%dT%H:%M:%S.%fZ")
    return w[_WINDOW_COLUMNS], b[_BLOCK_COLUMNS], pd.DataFrame(problems, columns=_PROBLEM_COLUMNS)


def compute_flight_windows(logs: Mapping[str, xr.Dataset], reference: xr.Dataset, flight_id: str,
                           site_altitude_m: float, files: Mapping[str, str] | None = None,
                           block_s: float = 1.0,
                           hover: Mapping[str, float] | None = None) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """Averaging windows of every UAV of a flight, 10-min and 2-min (Wetz et al. (2021), Sect. 5, App. C).

    Parameters
    ----------
    logs : mapping
        UAV id -> quadrotor log (library names, :func:`dronewind.quadrotor.io.read_quadrotor`).
    reference : xarray.Dataset
        Tower reference of the flight (:func:`dronewind.quadrotor.reference.read_tower_reference`).
    flight_id : str
        Flight id.
    site_altitude_m : float
        Ground altitude above MSL [m].
    files : mapping, optional
        UAV id -> file name for the problem table.
    block_s : float
        Block length of the attitude averages [s].
    hover : mapping, optional
        Hover selection settings (:func:`dronewind.quadrotor.hover.hover_segment`).

    Returns
    -------
    windows, blocks : pandas.DataFrame
        :func:`dronewind.quadrotor.windows.flight_windows` output for both window lengths,
        with a ``window_s`` column (window keys are unique per ``window_s``) and the tower
        variance ``var_ref_1min_m2s2`` (:func:`reference_variance`).
    problems : pandas.DataFrame
        ``flight, uav, file, window_s, error``: what could not be used (a UAV that never
        hovers, a reference that does not cover a window, ...).
    """
    files = dict(files or {})
    problems: list[dict[str, Any]] = []
    windows, blocks = [], []
    for uav, ds in logs.items():
        for window_s in WINDOW_LENGTHS_S:
            try:
                b, w, skipped = flight_windows_with_gaps(ds, reference, site_altitude_m, flight_id, uav,
                                                         window_s=window_s, block_s=block_s, hover_kwargs=hover)
            except InputError as exc:
                LOG.warning("flight %s uav %s (%g s windows): %s", flight_id, uav, window_s, exc)
                problems.append({"flight": flight_id, "uav": uav, "file": files.get(uav, ""),
                                 "window_s": window_s, "error": str(exc)})
                continue
            # a window a gap touches is skipped, the others kept: one problem row per skipped window
            for _, row in skipped.iterrows():
                problems.append({"flight": flight_id, "uav": uav, "file": files.get(uav, ""), "window_s": window_s,
                                 "error": f"window {row['window']} ({pd.Timestamp(row['start']):%Y-%m-%dT%H:%M:%SZ} to "
                                          f"{pd.Timestamp(row['end']):%Y-%m-%dT%H:%M:%SZ}) skipped: {row['reason']}"})
            if len(skipped):
                LOG.warning("flight %s uav %s (%g s windows): %d kept, %d skipped (gaps or coverage)", flight_id,
                            uav, window_s, len(w), len(skipped))
            if w.empty:
                continue
            windows.append(w.assign(window_s=window_s, var_ref_1min_m2s2=reference_variance(reference, w)))
            blocks.append(b.assign(window_s=window_s))
    return _window_tables(windows, blocks, problems)


def unreadable_reference(uavs: Sequence[str], reference_name: str, flight_id: str,
                         error: InputError) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """The tables of :func:`compute_flight_windows` for a flight whose tower reference cannot be read.

    Every UAV and window length is listed as a problem with the reader's error.
    """
    problems = [{"flight": flight_id, "uav": u, "file": reference_name, "window_s": w, "error": str(error)}
                for u in uavs for w in WINDOW_LENGTHS_S]
    return _window_tables([], [], problems)


# ----------------------------------------------------------------------------- campaign tables


def block_speeds(blocks: pd.DataFrame, windows: pd.DataFrame, params: pd.DataFrame, aero: Mapping) -> pd.DataFrame:
    """Wind speed and tilt of every block with a UAV's calibrated offsets (for variances and Fig. 4)."""
    p = params.set_index(params["uav"].astype(str))
    uav = blocks["window_key"].map(windows.set_index("window_key")["uav"].astype(str))
    off_p = uav.map(p["pitch_offset_deg"]).fillna(0.0).to_numpy(float)
    law = DragLaw(cd0a0_m2=float(aero["cd0a0_m2"]), cp_m2_per_rad=float(aero["cp_m2_per_rad"]))
    w = wind_from_attitude(blocks["roll_deg"].to_numpy(float), blocks["pitch_deg"].to_numpy(float),
                           blocks["yaw_deg"].to_numpy(float), blocks["vel_n_ms"].to_numpy(float),
                           blocks["vel_e_ms"].to_numpy(float), law=law, pitch_offset_deg=off_p)
    tilt, _ = tilt_from_attitude(np.radians(blocks["roll_deg"].to_numpy(float)),
                                 np.radians(blocks["pitch_deg"].to_numpy(float) - off_p))
    return pd.DataFrame({"window_key": blocks["window_key"].to_numpy(), "speed_ms": w["speed_ms"],
                         "tilt_deg": np.degrees(tilt)})


def window_predictions(main: Mapping[str, Any], blocks: pd.DataFrame, windows: pd.DataFrame) -> pd.DataFrame:
    """Per-window predictions (Figs 3, 5, 6, 9): individual, universal and scenario-d offsets.

    Parameters
    ----------
    main : mapping
        :func:`dronewind.quadrotor.validation.wetz2021_tables` result of the window length
        of the contract table.
    blocks, windows : pandas.DataFrame
        Its blocks and windows.

    Returns
    -------
    pandas.DataFrame
        ``quadrotor_windows.csv``: reference, calibrated UAV speed and direction,
        ``validation`` (0/1), speeds of the individual and universal calibrations, mean
        tilt, variance of 1-min means of the UAV (and the tower, if stored).
    """
    aero = main["aero"]
    table = main["calibration_table"]
    from dronewind.quadrotor.validation import predict_windows  # scipy.optimize/stats: only where used

    ind = predict_windows(blocks, windows, main["individual"], method="tilt")
    uni = predict_windows(blocks, windows, main["universal_offsets"], aero=aero)
    params = table[["uav", "pitch_offset_deg", "yaw_offset_deg"]]
    cal = predict_windows(blocks, windows, params, aero=aero)
    pw = cal[["window_key", "flight", "uav", "window", "start", "end", "height_m", "ref_height_m", "ref_speed_ms",
              "ref_from_deg", "uav_speed_ms", "uav_from_deg", "error_ms", "dir_error_deg"]].copy()
    pw["validation"] = pw["flight"].isin(main["validation"]).astype(int)
    pw["speed_individual_ms"] = pw["window_key"].map(ind.set_index("window_key")["uav_speed_ms"])
    pw["speed_universal_ms"] = pw["window_key"].map(uni.set_index("window_key")["uav_speed_ms"])
    bs = block_speeds(blocks, windows, params, aero)
    g = bs.groupby("window_key")
    pw["tilt_deg"] = pw["window_key"].map(g["tilt_deg"].mean())
    # variance of 1-min means (the tower reports 1-min means; Wetz et al. (2021), Fig. 9 analogue)
    bs["minute"] = bs.groupby("window_key").cumcount() // 60
    m = bs.groupby(["window_key", "minute"])["speed_ms"].mean().groupby("window_key")
    pw["var_uav_1min_m2s2"] = pw["window_key"].map(m.var(ddof=0))
    if "var_ref_1min_m2s2" in windows:
        pw["var_ref_1min_m2s2"] = pw["window_key"].map(windows.set_index("window_key")["var_ref_1min_m2s2"])
    return pw


def height_profiles(pw: pd.DataFrame, table: pd.DataFrame) -> pd.DataFrame:
    """Per flight and reference height: mean UAV and tower speed and the UAVs' RMSE (Fig. 8)."""
    prof = pw.groupby(["flight", "ref_height_m"]).agg(
        height_m=("height_m", "mean"), uav_speed_ms=("uav_speed_ms", "mean"), ref_speed_ms=("ref_speed_ms", "mean"),
        uav_from_deg=("uav_from_deg", "mean"), ref_from_deg=("ref_from_deg", "mean"),
        n_windows=("window_key", "size")).reset_index()
    rmse = table.set_index("uav")["rmse_ms"]
    prof["uav"] = prof.apply(lambda r: ",".join(sorted(set(pw.loc[(pw["flight"] == r["flight"])
                                                                  & (pw["ref_height_m"] == r["ref_height_m"]),
                                                                  "uav"]))), axis=1)
    prof["rmse_ms"] = prof["uav"].map(lambda u: float(np.nanmean([rmse.get(x, np.nan) for x in u.split(",")])))
    return prof


def _plain(value: Any) -> Any:
    """numpy scalars as Python values (JSON)."""
    if isinstance(value, bool | np.bool_):
        return bool(value)
    if isinstance(value, int | np.integer):
        return int(value)
    if isinstance(value, float | np.floating):
        return float(value)
    return value


def calibration_summary(main: Mapping[str, Any], window_s: float, n_windows: Mapping[str, int],
                        problems: pd.DataFrame) -> dict[str, Any]:
    """Content of ``quadrotor/calibration.json`` (without the campaign name).

    Parameters
    ----------
    main : mapping
        :func:`dronewind.quadrotor.validation.wetz2021_tables` result of the contract table.
    window_s : float
        Its window length [s].
    n_windows : mapping
        ``n_windows_600s`` and ``n_windows_120s``.
    problems : pandas.DataFrame
        UAV logs left out.

    Returns
    -------
    dict
        Aerodynamic parameters, convergence and status, scenarios, validation flights,
        hover accuracy, counts, the individual calibration and the universal law on a tilt
        grid (Wetz et al. (2021), Fig. 4 draws it from here).
    """
    aero = main["aero"]
    converged = bool(aero.get("converged", False))
    tilt_deg = np.arange(0.0, 20.01, 0.25)
    return {
        "calibration_window_s": window_s,
        "aero": {k: _plain(v) for k, v in aero.items()},
        "converged": converged,
        "status": "converged" if converged else "NOT CONVERGED: aerodynamic parameters unreliable",
        "independent_validation": bool(main["independent_validation"]),
        "scenarios": {k: list(v) for k, v in main["scenarios"].items()},
        "validation_flights": list(main["validation"]),
        "hover_accuracy": main["hover_accuracy"],
        **n_windows,
        "n_problem_logs": int(problems[["flight", "uav"]].drop_duplicates().shape[0]) if len(problems) else 0,
        "individual": main["individual"].to_dict(orient="records"),
        "regression_curve": {"tilt_deg": [float(x) for x in tilt_deg],
                             "speed_ms": [float(v) for v in speed_from_tilt(
                                 np.radians(tilt_deg), float(aero["cd0a0_m2"]), float(aero["cp_m2_per_rad"]))]},
    }


def compute_quadrotor_tables(blocks10: pd.DataFrame, windows10: pd.DataFrame, blocks2: pd.DataFrame,
                             windows2: pd.DataFrame, problems: pd.DataFrame,
                             calibration_window_s: float = 600.0,
                             roles: Mapping[str, str] | None = None) -> dict[str, Any]:
    """All campaign tables of the quadrotor chain (Wetz et al. (2021), Tables 2, 3, C1, C2, Figs 3-9 data).

    Parameters
    ----------
    blocks10, windows10 : pandas.DataFrame
        10-min windows (600 s).
    blocks2, windows2 : pandas.DataFrame
        2-min windows (120 s).
    problems : pandas.DataFrame
        UAV logs left out (concatenated per-flight problem tables).
    calibration_window_s : float
        Window length of the contract table (600 as Wetz et al. (2021), Sect. 5; 120 for short flights).
    roles : mapping, optional
        Flight id -> ``calibration`` or ``validation`` (the manifest's ``role``): the
        calibrations are fitted on the calibration flights and tested on the validation
        flights. Default (or no ``validation`` role): the chain's own split.

    Returns
    -------
    dict
        Tables keyed as :data:`QUAD_TABLES` and ``summary`` (dict for calibration.json).

    Raises
    ------
    InputError
        When a window length has fewer than 3 windows (nothing to calibrate).
    """
    from dronewind.quadrotor.validation import wetz2021_tables  # scipy.optimize/stats: only where used

    split: dict[str, Any] = {}
    if roles and "validation" in roles.values():
        split = {"calibration": [f for f, r in roles.items() if r != "validation"],
                 "validation": [f for f, r in roles.items() if r == "validation"]}
    res10 = wetz2021_tables(blocks10, windows10, **split) if len(windows10) >= 3 else None
    res2 = wetz2021_tables(blocks2, windows2, **split) if len(windows2) >= 3 else None
    if res10 is None and res2 is None:
        raise InputError("quadrotor windows", f"{len(windows10)} 10-min and {len(windows2)} 2-min windows; at least 3 "
                                              "are needed to calibrate (see quadrotor_problems.csv)")
    main = cast(dict[str, Any], res10 if (calibration_window_s >= 600.0 and res10 is not None) or res2 is None
                else res2)
    main_b, main_w = (blocks10, windows10) if main is res10 else (blocks2, windows2)
    out: dict[str, Any] = {}
    for name, res, key in (("quadrotor_table2", res10, "table2"), ("quadrotor_table3", res10, "table3"),
                           ("quadrotor_tableC1", res2, "table2"), ("quadrotor_tableC2", res2, "table3")):
        out[name] = res[key].reset_index() if res is not None else pd.DataFrame({"uav": []})
    out["quadrotor_direction"] = main["direction"].reset_index()
    out["quadrotor_calibration"] = main["calibration_table"]
    out["quadrotor_windows"] = window_predictions(main, main_b, main_w)
    out["quadrotor_profiles"] = height_profiles(out["quadrotor_windows"], main["calibration_table"])
    out["quadrotor_problems"] = problems.reset_index(drop=True)
    out["summary"] = calibration_summary(main, 600.0 if main is res10 else 120.0,
                                         {"n_windows_600s": len(windows10), "n_windows_120s": len(windows2)},
                                         problems)
    return out


# ----------------------------------------------------------------------------- L2


def compute_quadrotor_l2(log: xr.Dataset, calibration: pd.DataFrame, aero: Mapping[str, float], uav: str,
                         average_s: float = 1.0, hover: Mapping[str, float] | None = None) -> xr.Dataset:
    """Calibrated wind series of one UAV (Wetz et al. (2021), Sect. 6) with a hover flag.

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
        Output averaging [s] (1 Hz in Wetz et al. (2021)).
    hover : mapping, optional
        Hover selection settings (:func:`dronewind.quadrotor.hover.hover_segment`).

    Returns
    -------
    xarray.Dataset
        :func:`dronewind.quadrotor.wind.uav_wind_dataset` output with attrs ``usable`` (1/0),
        ``unusable_reason``; a UAV that never hovers gives the wind of its whole log with
        ``usable = 0`` (never a silent result). UAVs without a calibration use zero
        offsets and are marked ``calibrated = 0``.
    """
    row = calibration[calibration["uav"].astype(str) == str(uav)]
    p_off = float(row["pitch_offset_deg"].iloc[0]) if len(row) else math.nan
    y_off = float(row["yaw_offset_deg"].iloc[0]) if len(row) else math.nan
    calibrated = int(np.isfinite(p_off) and np.isfinite(y_off))
    p_off = p_off if np.isfinite(p_off) else 0.0
    y_off = y_off if np.isfinite(y_off) else 0.0
    law = DragLaw(cd0a0_m2=float(aero["cd0a0_m2"]), cp_m2_per_rad=float(aero["cp_m2_per_rad"]))
    try:
        ds = uav_wind_dataset(log, law=law, pitch_offset_deg=p_off, yaw_offset_deg=y_off, average_s=average_s,
                              hover_kwargs={**dict(hover or {}), "where": f"uav {uav}"})
        usable, reason = 1, ""
    except InputError as exc:
        LOG.warning("uav %s: %s; wind of the whole log written with usable = 0", uav, exc)
        ds = uav_wind_dataset(log, law=law, pitch_offset_deg=p_off, yaw_offset_deg=y_off, average_s=average_s,
                              hover_kwargs={"horiz_tol_m": 1e9, "alt_tol_m": 1e9, "max_speed_ms": 1e9,
                                            "min_duration_s": 0.0, "where": f"uav {uav}"})
        usable, reason = 0, str(exc)
    if not calibrated:
        reason = (reason + "; " if reason else "") + "no calibration for this UAV: zero offsets used"
    ds.attrs.update(usable=usable, unusable_reason=reason, calibrated=calibrated,
                    cd0a0_m2=float(aero["cd0a0_m2"]), cp_m2_per_rad=float(aero["cp_m2_per_rad"]))
    ds["yaw_from_deg"].attrs.pop("standard_name", None)
    return ds
