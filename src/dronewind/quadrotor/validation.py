r"""Validation of the calibrated fleet: the tables of Wetz et al. (2021) and the contract table.

* :func:`predict_windows`: calibrated UAV wind speed and direction per window;
* :func:`accuracy_table`: bias and RMS deviation per UAV (Tables 2, 3, C1, C2);
* :func:`wetz2021_scenarios` and :func:`calibration_scenarios`: calibration scenarios a-d
  validated on the second week (Sect. 5.3, Tables E1-E2);
* :func:`wetz2021_tables`: every table of Sect. 5 from one set of windows;
* :func:`calibration_table`: ``tables/quadrotor_calibration.csv`` of the data contract.

References
----------
.. [1] Wetz, T., Wildmann, N., Beyrich, F. (SWUF-3D), Wetz et al. (2021)
  , Sect. 5, Tables 2, 3, C1, C2, E1, E2.
.. [2] Wind-tunnel calibration and verification of the SWUF-3D quadrotors, Kistner et al. (2024)
  , Eq. 3.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping, Sequence
from typing import Any, cast

import numpy as np
import pandas as pd

from dronewind.core.constants import AIR_DENSITY_KGM3, WETZ2021_MASS_KG
from dronewind.errors import InputError
from dronewind.quadrotor.calibration import (
    calibrate_individual,
    calibrate_pitch_offsets,
    calibrate_universal,
    calibrate_yaw_offsets,
)
from dronewind.quadrotor.drag import DragLaw
from dronewind.quadrotor.windows import WindowArrays, select_windows

__all__ = [
    "predict_windows", "accuracy_table", "flight_number", "wetz2021_scenarios", "calibration_scenarios",
    "wetz2021_tables", "calibration_table",
]

def predict_windows(blocks: pd.DataFrame, windows: pd.DataFrame, params: pd.DataFrame,
                    aero: Mapping | None = None, flights: Iterable[str] | None = None,
                    method: str = "tilt", mass_kg: float = WETZ2021_MASS_KG,
                    rho_kgm3: float = AIR_DENSITY_KGM3) -> pd.DataFrame:
    r"""Calibrated UAV wind speed and direction per window.

    Parameters
    ----------
    blocks, windows : pandas.DataFrame
        From :func:`dronewind.quadrotor.windows.flight_windows`.
    params : pandas.DataFrame
        Per-UAV ``uav``, ``pitch_offset_deg`` and, unless ``aero`` is given, ``cd0a0_m2``
        and ``cp_m2_per_rad``; optional ``yaw_offset_deg`` (default 0).
    aero : mapping, optional
        Common ``cd0a0_m2``, ``cp_m2_per_rad``.
    flights : iterable of str, optional
        Validation flights (default all).
    method, mass_kg, rho_kgm3 : see :func:`dronewind.quadrotor.calibration.calibrate_individual`.

    Returns
    -------
    pandas.DataFrame
        ``windows`` columns plus ``uav_speed_ms``, ``uav_from_deg`` (circular mean of
        corrected yaw), ``error_ms`` (UAV minus reference), ``dir_error_deg``. UAVs
        without parameters are left out (counted in ``attrs['n_uncalibrated']``).
    """
    b, w = select_windows(blocks, windows, flights)
    p = params.set_index(params["uav"].astype(str))
    have = w["uav"].astype(str).isin(p.index[np.isfinite(p["pitch_offset_deg"].to_numpy(float))])
    n_uncal = int((~have).sum())
    b, w = select_windows(b, w[have], None)
    out = []
    for uav, wu in w.groupby(w["uav"].astype(str)):
        bu = b[b["window_key"].isin(wu["window_key"])]
        pu = cast(pd.Series, p.loc[uav])
        a: Any = aero if aero is not None else pu
        law = DragLaw(cd0a0_m2=float(a["cd0a0_m2"]), cp_m2_per_rad=float(a["cp_m2_per_rad"]),
                      mass_kg=mass_kg, rho_kgm3=rho_kgm3)
        wu = wu.reset_index(drop=True)
        data = WindowArrays(bu, wu)
        yaw_off = float(pu["yaw_offset_deg"]) if "yaw_offset_deg" in pu and np.isfinite(pu["yaw_offset_deg"]) else 0.0
        sp = data.speed(law, float(pu["pitch_offset_deg"]), method)
        ys = np.bincount(data.win, weights=np.sin(np.radians(data.yaw - yaw_off)), minlength=data.nwin)
        yc = np.bincount(data.win, weights=np.cos(np.radians(data.yaw - yaw_off)), minlength=data.nwin)
        wu = wu.assign(uav_speed_ms=sp, uav_from_deg=np.degrees(np.arctan2(ys, yc)) % 360.0)
        out.append(wu)
    res = pd.concat(out, ignore_index=True) if out else w.assign(uav_speed_ms=[], uav_from_deg=[])
    res["error_ms"] = res["uav_speed_ms"] - res["ref_speed_ms"]
    res["dir_error_deg"] = (res["uav_from_deg"] - res["ref_from_deg"] + 180.0) % 360.0 - 180.0
    res.attrs["n_uncalibrated"] = n_uncal
    return res


def accuracy_table(predicted: pd.DataFrame, label: str = "") -> pd.DataFrame:
    r"""Bias and RMS deviation per UAV, and their mean (Wetz et al. 2021, Tables 2, 3, C1, C2; Kistner et al. 2024,
    Eq. 3).

    Parameters
    ----------
    predicted : pandas.DataFrame
        Output of :func:`predict_windows`.
    label : str
        Suffix for the column names (e.g. ``"_individual"``).

    Returns
    -------
    pandas.DataFrame
        Index ``uav`` plus a last row ``mean``; columns ``bias_ms``, ``rmse_ms``,
        ``rmse_dir_deg``, ``n`` (each with ``label`` appended).

    Notes
    -----
    .. math:: \Delta V_w = \frac1n\sum(\bar V_{UAV}-\bar V_{ref}),\qquad
              \sigma_{rms} = \sqrt{\frac1n\sum(\bar V_{UAV}-\bar V_{ref})^2}

    The ``mean`` row averages the per-UAV values (as in the tables of Wetz et al. (2021)).
    """
    g = predicted.groupby(predicted["uav"].astype(str))
    t = pd.DataFrame({
        "bias_ms": g["error_ms"].mean(),
        "rmse_ms": g["error_ms"].apply(lambda e: float(np.sqrt(np.mean(e**2)))),
        "rmse_dir_deg": g["dir_error_deg"].apply(lambda e: float(np.sqrt(np.mean(e**2)))),
        "n": g.size(),
    })
    t.index.name = "uav"
    mean = t.mean(numeric_only=True)
    mean["n"] = t["n"].sum()
    t.loc["mean"] = mean
    t["n"] = t["n"].astype(int)
    return t.add_suffix(label)


def flight_number(flight_id: str) -> int:
    """Number in a flight id (``"f31"`` -> 31); raises InputError if there is none."""
    m = re.search(r"(\d+)", str(flight_id))
    if not m:
        raise InputError("flight id", f"{flight_id!r} holds no flight number")
    return int(m.group(1))


def wetz2021_scenarios(flight_ids: Iterable[str]) -> tuple[dict[str, list[str]], list[str]]:
    r"""Calibration scenarios a-d and validation flights of Wetz et al. (2021), Sect. 5.3.

    Parameters
    ----------
    flight_ids : iterable of str
        "Drone tower" flight ids whose number is the FESST@MOL flight number.

    Returns
    -------
    scenarios : dict
        ``a_all``: all flights; ``b_first_week``: flights 1-37 (Table E1);
        ``c_flight31``: flight 31; ``d_flights31_56``: flights 31 and 56.
    validation : list of str
        Second-week flights (number >= 38, Table E2).
    """
    ids = [str(f) for f in flight_ids]
    num = {f: flight_number(f) for f in ids}
    scen = {
        "a_all": ids,
        "b_first_week": [f for f in ids if num[f] <= 37],
        "c_flight31": [f for f in ids if num[f] == 31],
        "d_flights31_56": [f for f in ids if num[f] in (31, 56)],
    }
    return scen, [f for f in ids if num[f] >= 38]


def calibration_scenarios(blocks: pd.DataFrame, windows: pd.DataFrame, aero: Mapping,
                          scenarios: Mapping[str, Sequence[str]], validation: Sequence[str],
                          method: str = "tilt") -> pd.DataFrame:
    r"""Table 3 / C2 of Wetz et al. (2021): pitch-offset-only calibration on several flight subsets.

    Parameters
    ----------
    blocks, windows : pandas.DataFrame
        From :func:`dronewind.quadrotor.windows.flight_windows` (10-min or 2-min windows).
    aero : mapping
        Common aerodynamic parameters (Eq. 18 or :func:`~dronewind.quadrotor.calibration.calibrate_universal`).
    scenarios : mapping
        Scenario name to calibration flight ids (:func:`wetz2021_scenarios`).
    validation : sequence of str
        Validation flight ids.
    method : str
        See :func:`dronewind.quadrotor.wind.wind_from_attitude`.

    Returns
    -------
    pandas.DataFrame
        Index ``uav`` (+ ``mean``); columns ``bias_ms_<scenario>``, ``rmse_ms_<scenario>``,
        ``pitch_offset_deg_<scenario>``. A UAV absent from a scenario's calibration flights
        has NaN (the "-" of Table 3).
    """
    parts = []
    for name, flights in scenarios.items():
        off = calibrate_pitch_offsets(blocks, windows, aero, flights=flights, method=method)
        pred = predict_windows(blocks, windows, off, aero=aero, flights=validation, method=method)
        acc = accuracy_table(pred)[["bias_ms", "rmse_ms"]].add_suffix(f"_{name}")
        acc[f"pitch_offset_deg_{name}"] = off.set_index("uav")["pitch_offset_deg"]
        parts.append(acc)
    return pd.concat(parts, axis=1)


def wetz2021_tables(blocks: pd.DataFrame, windows: pd.DataFrame, method: str = "tilt",
                   scenarios: Mapping[str, Sequence[str]] | None = None,
                   validation: Sequence[str] | None = None,
                   calibration: Sequence[str] | None = None) -> dict[str, Any]:
    r"""Wetz et al. (2021), Tables 2 and 3 (10-min windows) or C1 and C2 (2-min windows), and the
    contract table ``quadrotor_calibration.csv``.

    Parameters
    ----------
    blocks, windows : pandas.DataFrame
        From :func:`~dronewind.quadrotor.windows.flight_windows` /
        :func:`~dronewind.quadrotor.windows.campaign_windows` for all "drone tower" flights.
    method : str
        See :func:`dronewind.quadrotor.wind.wind_from_attitude`.
    scenarios, validation : optional
        Default :func:`wetz2021_scenarios` of the flights present. Flight ids without a
        number, or no second-week flight, give one scenario ``a_all`` validated on the
        calibration flights themselves (flag ``independent_validation`` False).
    calibration : sequence of str, optional
        Flights the calibrations are fitted on (the manifest's ``role: calibration``; a
        multi-day campaign calibrated on some days and validated on others). Default: all.
        With it, the default scenario is ``a_calibration`` (these flights) and the default
        validation flights are the others.

    Returns
    -------
    dict
        ``individual`` (per-UAV parameters, Sect. 5.1), ``aero`` and
        ``universal_offsets`` (:func:`~dronewind.quadrotor.calibration.calibrate_universal`, Sect. 5.2), ``table2``
        (columns ``*_individual`` and ``*_universal``), ``table3``
        (:func:`calibration_scenarios`, Sect. 5.3), ``yaw_offsets`` (on the scenario-d
        flights 31 and 56 if present, else all flights, Sect. 5.4), ``direction``
        (validation accuracy of speed and direction with scenario-d offsets),
        ``calibration_table`` (:func:`calibration_table`: universal aero parameters and
        pitch offsets from all flights, yaw offsets as above, accuracy on the validation
        flights), ``independent_validation`` (bool), ``scenarios``, ``validation``,
        ``hover_accuracy`` (mean horizontal and vertical position standard deviation over
        all UAV logs, Sect. 4.3).
    """
    flights = sorted(windows["flight"].astype(str).unique())
    try:
        flights = sorted(flights, key=flight_number)
        s, v = wetz2021_scenarios(flights)
    except InputError:
        s, v = {"a_all": flights}, []
    fit_b, fit_w = blocks, windows
    if calibration is not None:
        cal = [f for f in flights if f in {str(c) for c in calibration}]
        if not cal:
            raise InputError("quadrotor_flights.role", "no window of a calibration flight; the calibration needs "
                             "at least one")
        s, v = {"a_calibration": cal}, [f for f in flights if f not in cal]
        fit_b, fit_w = select_windows(blocks, windows, cal)
    scenarios = dict(scenarios or s)
    validation = list(validation if validation is not None else v)
    independent = bool(validation)
    if not validation:
        validation = flights
    ind = calibrate_individual(fit_b, fit_w, method=method)
    aero, uoff = calibrate_universal(fit_b, fit_w, method=method)
    t_ind = accuracy_table(predict_windows(blocks, windows, ind, method=method), "_individual")
    t_uni = accuracy_table(predict_windows(blocks, windows, uoff, aero=aero, method=method), "_universal")
    table2 = pd.concat([t_ind, t_uni], axis=1)
    scen = {k: f for k, f in scenarios.items() if len(f)}
    table3 = calibration_scenarios(blocks, windows, aero, scen, validation, method=method)
    yaw_flights = scenarios.get("d_flights31_56") or sorted(fit_w["flight"].astype(str).unique())
    yaw = calibrate_yaw_offsets(blocks, windows, flights=yaw_flights)
    p = calibrate_pitch_offsets(blocks, windows, aero, flights=yaw_flights, method=method) \
        .merge(yaw[["uav", "yaw_offset_deg"]], on="uav", how="left")
    direction = accuracy_table(predict_windows(blocks, windows, p, aero=aero, flights=validation, method=method))
    contract_params = uoff.merge(yaw[["uav", "yaw_offset_deg"]], on="uav", how="left")
    acc = accuracy_table(predict_windows(blocks, windows, contract_params, aero=aero, flights=validation,
                                         method=method))
    table = calibration_table(uoff.assign(converged=aero["converged"]), yaw, acc, aero)
    per_log = windows.drop_duplicates(["flight", "uav"])
    hover = {"sigma_h_m": float(per_log["sigma_h_m"].mean()), "sigma_v_m": float(per_log["sigma_v_m"].mean()),
             "n_logs": len(per_log)} if "sigma_h_m" in windows else {}
    return {"individual": ind, "aero": aero, "universal_offsets": uoff, "table2": table2,
            "table3": table3, "yaw_offsets": yaw, "direction": direction, "calibration_table": table,
            "independent_validation": independent, "scenarios": scenarios, "validation": validation,
            "hover_accuracy": hover}


def calibration_table(pitch_offsets: pd.DataFrame, yaw_offsets: pd.DataFrame,
                      accuracy: pd.DataFrame, aero: Mapping | None = None) -> pd.DataFrame:
    """The contract table ``tables/quadrotor_calibration.csv`` (one row per UAV).

    Parameters
    ----------
    pitch_offsets : pandas.DataFrame
        ``uav``, ``pitch_offset_deg`` (and optionally ``cd0a0_m2``, ``cp_m2_per_rad``,
        ``pitch_offset_deg_se``, ``converged``).
    yaw_offsets : pandas.DataFrame
        :func:`dronewind.quadrotor.calibration.calibrate_yaw_offsets`.
    accuracy : pandas.DataFrame
        :func:`accuracy_table` without label (index ``uav``; the ``mean`` row is dropped).
    aero : mapping, optional
        Common ``cd0a0_m2`` and ``cp_m2_per_rad`` written to every row.

    Returns
    -------
    pandas.DataFrame
        Columns ``uav, pitch_offset_deg, yaw_offset_deg, rmse_ms, bias_ms`` first, then
        ``rmse_dir_deg, n_windows, cd0a0_m2, cp_m2_per_rad, pitch_offset_deg_se,
        yaw_offset_deg_se, converged`` where available.
    """
    t = pitch_offsets.copy()
    t["uav"] = t["uav"].astype(str)
    t = t.merge(yaw_offsets[["uav", "yaw_offset_deg", "yaw_offset_deg_se"]].astype({"uav": str}),
                on="uav", how="outer")
    acc = accuracy.drop(index="mean", errors="ignore").reset_index()
    acc["uav"] = acc["uav"].astype(str)
    t = t.merge(acc[["uav", "rmse_ms", "bias_ms", "rmse_dir_deg", "n"]].rename(columns={"n": "n_windows_validation"}),
                on="uav", how="left")
    if aero is not None:
        t["cd0a0_m2"] = float(aero["cd0a0_m2"])
        t["cp_m2_per_rad"] = float(aero["cp_m2_per_rad"])
    first = ["uav", "pitch_offset_deg", "yaw_offset_deg", "rmse_ms", "bias_ms"]
    extra = [c for c in ("rmse_dir_deg", "n_windows", "n_windows_validation", "cd0a0_m2", "cp_m2_per_rad",
                         "pitch_offset_deg_se", "yaw_offset_deg_se", "converged") if c in t.columns]
    return t[first + extra].sort_values("uav").reset_index(drop=True)

