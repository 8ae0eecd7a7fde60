r"""Wind-tunnel calibration and verification of quadrotor wind measurement (Kistner et al. (2024)): all tables.

:func:`analyse_tunnel` reads a tunnel campaign (:mod:`dronewind.tunnel.io`) and computes
the tables of Kistner et al. (2024):

* calibration of the body-axis drag law per speed range (Sect. 3.1, Eq. 1, Table 2) on
  constant-speed steps, with the accelerometer offsets taken from a calm hover
  (:mod:`dronewind.tunnel.calibration`);
* RMSE of the speed per angle of sideslip and per UAS (portability) (Eq. 3; Figs. 4-5);
* IEC gusts: RMSE at the initial speed :math:`V_0` and the peak :math:`V_p` and the RMSE
  of the time between the two dips of each gust (Eqs. 4-5);
* velocity steps: start and 90 % times, step sizes and durations (Eqs. 6-13), their
  RMSEs (Eqs. 5, 14) and the RMSE of the stationary speeds :math:`V_l`, :math:`V_h`;
* statistical turbulence: PSD agreement and the highest resolvable frequency, variance
  bias with and without cutting the reference at the UAS's frequency, turbulence
  intensity RMSE (Eqs. 15-17); the per-series metrics are in :mod:`dronewind.tunnel.metrics`.

References
----------
.. [1] Wind-tunnel calibration and verification of the SWUF-3D quadrotors, Kistner et al. (2024)
  , Sects. 3-4, Eqs. 1-17, Table 2, Figs. 4-10.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from dronewind.quadrotor.drag import DragLaw
from dronewind.tunnel import TUNNEL_TABLES
from dronewind.tunnel.calibration import calibrate_tunnel, stepped_accuracy, uas_offsets, uas_speed
from dronewind.tunnel.io import event_starts, read_tunnel_index, read_tunnel_run
from dronewind.tunnel.metrics import gust_events, rmse, step_events, turbulence_metrics

__all__ = ["TUNNEL_TABLES", "analyse_tunnel", "sideslip_table", "portability_table", "dynamic_runs",
           "gust_summary", "step_summary", "turbulence_summary"]

def _block_mean_at(t_src: np.ndarray, x: np.ndarray, t_dst: np.ndarray) -> np.ndarray:
    """Mean of ``x`` over the interval each destination sample represents (down-sampling
    the CTA to the UAS rate, Kistner et al. (2024), Sect. 2.3)."""
    dt = np.median(np.diff(t_dst))
    edges = np.concatenate([t_dst - dt / 2, [t_dst[-1] + dt / 2]])
    k = np.searchsorted(edges, t_src, side="right") - 1
    ok = (k >= 0) & (k < t_dst.size)
    s = np.bincount(k[ok], weights=x[ok], minlength=t_dst.size)
    c = np.bincount(k[ok], minlength=t_dst.size)
    with np.errstate(invalid="ignore", divide="ignore"):
        return s / c


def sideslip_table(acc: pd.DataFrame) -> pd.DataFrame:
    """RMSE of the UAS speed per angle of sideslip, overall and in 2 m/s speed bins (Fig. 4)."""
    ss = acc[acc["kind"] == "sideslip"].copy()
    ss["speed_bin_ms"] = np.round(ss["cta_ms"] / 2.0) * 2.0
    by_speed = ss.groupby(["aos_deg", "speed_bin_ms"]).apply(  # type: ignore[call-overload]
        lambda g: rmse(g["uas_ms"], g["cta_ms"]), include_groups=False).rename("rmse_ms").reset_index()
    overall = ss.groupby("aos_deg").apply(  # type: ignore[call-overload]
        lambda g: rmse(g["uas_ms"], g["cta_ms"]), include_groups=False).rename("rmse_ms").reset_index()
    return pd.concat([overall.assign(speed_bin_ms=np.nan), by_speed], ignore_index=True)


def portability_table(acc: pd.DataFrame) -> pd.DataFrame:
    """RMSE, bias and largest error per UAS with the calibration UAS's law (Fig. 5)."""
    po = acc[acc["kind"] == "portability"]
    return po.groupby("uas").apply(  # type: ignore[call-overload]
        lambda g: pd.Series({"rmse_ms": rmse(g["uas_ms"], g["cta_ms"]), "bias_ms": float(g["error_ms"].mean()),
                             "max_abs_error_ms": float(g["error_ms"].abs().max()), "n": len(g)}),
        include_groups=False).reset_index()


def dynamic_runs(index: pd.DataFrame, law: DragLaw, offsets: pd.DataFrame) -> tuple[list, list, list[dict]]:
    """Gust, velocity-step and turbulence metrics of every dynamic run, UAS against CTA.

    The CTA is block-averaged to the UAS times for gusts and steps; turbulence compares the
    full-rate CTA.

    Returns
    -------
    gusts, steps : list of pandas.DataFrame
        Per run: :func:`dronewind.tunnel.metrics.gust_events` /
        :func:`~dronewind.tunnel.metrics.step_events` of UAS and CTA merged on the event
        start (suffixes ``_uas``, ``_cta``) with the run's presets.
    turbulence : list of dict
        Per run: presets and :func:`~dronewind.tunnel.metrics.turbulence_metrics`.
    """
    off = offsets.set_index("uas")
    gusts, steps, turb = [], [], []
    for _, r in index.iterrows():
        if r["kind"] not in ("gust", "step", "turbulence"):
            continue
        cta, uas = read_tunnel_run(index, r["run_id"])
        tu = uas["time_s"].to_numpy()
        vu = uas_speed(uas, law, off.loc[r["uas"]])
        vc10 = _block_mean_at(cta["time_s"].to_numpy(), cta["wind_speed_ms"].to_numpy(), tu)
        meta = {"run_id": r["run_id"], "uas": r["uas"], "v0_set_ms": r["v0_ms"]}
        if r["kind"] == "gust":
            ev = event_starts(r)
            gu, gc = gust_events(tu, vu, ev), gust_events(tu, vc10, ev)
            m = gu.merge(gc, on="start_s", suffixes=("_uas", "_cta"))
            gusts.append(m.assign(**meta, vg_set_ms=r["vg_ms"]))
        elif r["kind"] == "step":
            ev = event_starts(r)
            su, sc = step_events(tu, vu, ev, float(r["period_s"])), step_events(tu, vc10, ev, float(r["period_s"]))
            if not su.empty and not sc.empty:
                m = su.merge(sc, on="start_s", suffixes=("_uas", "_cta"))
                steps.append(m.assign(**meta, vdu_set_ms=r["vdu_ms"]))
        else:
            met = turbulence_metrics(vu, float(r["fs_uas_hz"]), cta["wind_speed_ms"].to_numpy(),
                                     float(r["fs_cta_hz"]))
            turb.append({**meta, "ti_set_percent": r["ti_percent"], **met})
    return gusts, steps, turb


def gust_summary(g: pd.DataFrame) -> pd.DataFrame:
    """Per gust preset: RMSE at V0 and Vp (Eq. 3) and of the dip-to-dip time (Eq. 5).

    attrs ``rmse_delta_t_all_s``: the dip-to-dip RMSE over every gust.
    """
    if g.empty:
        return pd.DataFrame()
    out = g.groupby(["v0_set_ms", "vg_set_ms"]).apply(lambda x: pd.Series({  # type: ignore[call-overload]
        "rmse_v0_ms": rmse(x["v0_ms_uas"], x["v0_ms_cta"]), "rmse_vp_ms": rmse(x["vp_ms_uas"], x["vp_ms_cta"]),
        "rmse_delta_t_s": rmse(x["delta_t_s_uas"], x["delta_t_s_cta"]), "n": len(x)}),
        include_groups=False).reset_index()
    out.attrs["rmse_delta_t_all_s"] = rmse(g["delta_t_s_uas"], g["delta_t_s_cta"])
    return out


def step_summary(s: pd.DataFrame) -> pd.DataFrame:
    """Per step preset: RMSE of V_l, V_h (Eq. 3), of dV_u, dV_d (Eq. 14) and of dT_u, dT_d (Eq. 5)."""
    if s.empty:
        return pd.DataFrame()
    return s.groupby(["v0_set_ms", "vdu_set_ms"]).apply(lambda x: pd.Series({  # type: ignore[call-overload]
        "rmse_v_low_ms": rmse(x["v_low_ms_uas"], x["v_low_ms_cta"]),
        "rmse_v_high_ms": rmse(x["v_high_ms_uas"], x["v_high_ms_cta"]),
        "rmse_dv_up_ms": rmse(x["dv_u_ms_uas"], x["dv_u_ms_cta"]),
        "rmse_dv_down_ms": rmse(x["dv_d_ms_uas"], x["dv_d_ms_cta"]),
        "rmse_dt_ms": rmse(np.r_[x["dt_u_s_uas"], x["dt_d_s_uas"]], np.r_[x["dt_u_s_cta"], x["dt_d_s_cta"]]),
        "n": len(x)}), include_groups=False).reset_index().rename(columns={"rmse_dt_ms": "rmse_dt_s"})


def _variance_row(x: pd.DataFrame, variance_class: str, r2_var: float) -> dict[str, Any]:
    return {"variance_class": variance_class, "n": len(x),
            "bias_var_full_m2s2": float(np.mean(x["var_uas"] - x["var_cta_full"])),
            "bias_var_cut_nyquist_m2s2": float(np.mean(x["var_uas"] - x["var_cta_cut_nyquist"])),
            "bias_var_cut_fmax_m2s2": float(np.mean(x["var_uas"] - x["var_cta_cut_fmax"])),
            "r2_var": r2_var, "rmse_ti": rmse(x["ti_uas"], x["ti_cta"]),
            "median_f_max_hz": float(x["f_max_hz"].median())}


def turbulence_summary(t: pd.DataFrame) -> pd.DataFrame:
    """Variance bias with and without cutting the CTA at the UAS frequency, R^2 of the
    variances, TI RMSE (Eq. 17): over all runs and per variance class <0.3, 0.3-0.5, >=0.5 m2 s-2."""
    if t.empty:
        return pd.DataFrame()
    cls = pd.cut(t["var_cta_full"], [0, 0.3, 0.5, np.inf], right=False, labels=["<0.3", "0.3-0.5", ">=0.5"])
    r2 = float(np.corrcoef(t["var_uas"], t["var_cta_full"])[0, 1] ** 2) if len(t) > 2 else np.nan
    rows = [_variance_row(t, "all", r2)]
    for c in ["<0.3", "0.3-0.5", ">=0.5"]:
        x = t[cls == c]
        if len(x):
            rows.append(_variance_row(x, c, np.nan))
    return pd.DataFrame(rows)


def analyse_tunnel(index_path: str | Path, edges_ms: Sequence[float] = (4.0, 12.0),
                   mass_kg: float = 0.645) -> dict[str, pd.DataFrame]:
    r"""All Kistner et al. (2024) tables of a tunnel campaign (analysis entry point).

    Parameters
    ----------
    index_path : str or Path
        ``tunnel/runs.csv``.
    edges_ms : sequence of float
        Longitudinal speed-range edges [m s-1] (Table 2: 4 and 12).
    mass_kg : float
        UAS mass [kg].

    Returns
    -------
    dict of pandas.DataFrame
        ``offsets`` (:func:`~dronewind.tunnel.calibration.uas_offsets`); ``calibration``
        (coefficients per range, Table 2 equivalent); ``steps_accuracy`` (per step,
        sideslip and portability runs); ``sideslip`` (:func:`sideslip_table`, Fig. 4);
        ``portability`` (:func:`portability_table`, Fig. 5); ``gusts`` (per gust, UAS and
        CTA); ``gust_summary`` (:func:`gust_summary`); ``steps`` (per repetition);
        ``step_summary`` (:func:`step_summary`); ``turbulence`` (per run,
        :func:`~dronewind.tunnel.metrics.turbulence_metrics`); ``turbulence_summary``
        (:func:`turbulence_summary`). Tables of run kinds absent from the index are empty.
    """
    index = read_tunnel_index(index_path)
    out: dict[str, pd.DataFrame] = {}
    offsets = uas_offsets(index)
    out["offsets"] = offsets
    law, cal = calibrate_tunnel(index, offsets, edges_ms, mass_kg)
    out["calibration"] = cal
    acc = stepped_accuracy(index, law, offsets)
    out["steps_accuracy"] = acc
    if not acc.empty:
        out["sideslip"] = sideslip_table(acc)
        out["portability"] = portability_table(acc)
    gusts, steps, turb = dynamic_runs(index, law, offsets)
    out["gusts"] = pd.concat(gusts, ignore_index=True) if gusts else pd.DataFrame()
    out["gust_summary"] = gust_summary(out["gusts"])
    out["steps"] = pd.concat(steps, ignore_index=True) if steps else pd.DataFrame()
    out["step_summary"] = step_summary(out["steps"])
    out["turbulence"] = pd.DataFrame(turb)
    out["turbulence_summary"] = turbulence_summary(out["turbulence"])
    return out
