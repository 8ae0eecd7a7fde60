"""Tunnel candidates of the quadrotor diagnosis: response lag, speed-range drag law and sideslip.

Scored on the wind-tunnel runs of Kistner et al. (2024) (:mod:`dronewind.tunnel`):
``response_lag`` (the attitude follows the air speed through a first-order lag, Sect. 4:
gusts and steps) left out run by run; ``drag_regime`` (power laws per speed range, Eq. 1 and
Table 2) on the speed steps; ``sideslip`` (separate lateral coefficients, Eq. 1) on the
sideslip runs that the calibration never saw (:func:`tunnel_candidates`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import scipy.optimize
import scipy.sparse
import scipy.stats

from dronewind.diagnose.quadrotor_field import _paired
from dronewind.quadrotor.drag import DragLaw
from dronewind.quadrotor.wind import wind_from_attitude
from dronewind.simulate.common import first_order_lag
from dronewind.tunnel.calibration import calibrate_tunnel, stepped_accuracy, uas_offsets
from dronewind.tunnel.io import read_tunnel_index, read_tunnel_run

__all__ = [
    "tunnel_candidates",
]


def _lag_runs(index: pd.DataFrame, law: DragLaw, offsets: pd.DataFrame) -> list[dict[str, Any]]:
    off = offsets.set_index("uas")
    runs = []
    for _, r in index[index["kind"].isin(["gust", "step"])].iterrows():
        cta, uas = read_tunnel_run(index, r["run_id"])
        o = off.loc[r["uas"]]
        v = wind_from_attitude(uas["roll_deg"].to_numpy(), uas["pitch_deg"].to_numpy(), uas["yaw_deg"].to_numpy(),
                                 law=law, method="body_axis", pitch_offset_deg=float(o["pitch_offset_deg"]),
                                 roll_offset_deg=float(o["roll_offset_deg"]))["speed_ms"]
        tc = cta["time_s"].to_numpy(float)
        runs.append({"run_id": r["run_id"], "t_uas": uas["time_s"].to_numpy(float), "v_uas": v, "t_cta": tc,
                     "v_cta": cta["wind_speed_ms"].to_numpy(float), "fs_cta": 1.0 / float(np.median(np.diff(tc)))})
    return runs


def _lag_pred(run: Mapping[str, Any], distance_m: float, tau_s: float) -> np.ndarray:
    """UAS speed predicted from the CTA: advected over ``distance_m`` (delay d/V), then lagged."""
    v = run["v_cta"]
    y = first_order_lag(v, tau_s, run["fs_cta"])
    # the UAS sees the flow distance/V earlier than the CTA (Kistner et al. 2024 Fig. 1 geometry)
    t_adv = run["t_cta"] - distance_m / np.maximum(v, 0.5)
    order = np.argsort(t_adv, kind="stable")
    return np.interp(run["t_uas"], t_adv[order], y[order])


def _fit_lag(runs: Sequence[Mapping[str, Any]], with_tau: bool,
             distance_m: float | None = None) -> np.ndarray:
    """Least-squares advection distance (unless given) and lag; returns ``[distance_m, tau_s]``."""
    def unpack(x):
        d = distance_m if distance_m is not None else x[0]
        tau = (x[-1] if with_tau else 0.0)
        return d, tau

    def fun(x):
        d, tau = unpack(x)
        return np.concatenate([_lag_pred(r, d, tau) - r["v_uas"] for r in runs])

    x0, lo, hi = [], [], []
    if distance_m is None:
        x0, lo, hi = [2.0], [-10.0], [10.0]
    if with_tau:
        x0, lo, hi = x0 + [0.1], lo + [0.0], hi + [5.0]
    if not x0 and distance_m is not None:
        return np.array([float(distance_m), 0.0])
    res = scipy.optimize.least_squares(fun, x0, bounds=(lo, hi), method="trf")
    d, tau = unpack(res.x)
    return np.array([float(d), float(tau)])


def _event_units(run: Mapping[str, Any], row: pd.Series) -> np.ndarray:
    """Index of the gust or step repetition of every UAS sample (-1 outside)."""
    t = run["t_uas"]
    k = np.floor((t - float(row["first_event_s"])) / float(row["period_s"])).astype(int)
    return np.where((k >= 0) & (k < int(row["n_events"])), k, -1)


def _response_lag_candidate(index: pd.DataFrame, runs: list[dict[str, Any]],
                            advection_distance_m: float | None) -> tuple[dict[str, Any], float]:
    """``response_lag`` scored leave-one-run-out on the gust and step runs; returns the
    candidate and the baseline held-out RMSE [m s-1]."""
    rows = index.set_index("run_id")
    e0, e1, taus, units = [], [], [], []
    for k in range(len(runs)):
        train = [r for j, r in enumerate(runs) if j != k]
        x0 = _fit_lag(train, False, advection_distance_m)
        x1 = _fit_lag(train, True, advection_distance_m)
        taus.append(x1[1])
        e0.append(_lag_pred(runs[k], x0[0], 0.0) - runs[k]["v_uas"])
        e1.append(_lag_pred(runs[k], x1[0], x1[1]) - runs[k]["v_uas"])
        ev = _event_units(runs[k], rows.loc[runs[k]["run_id"]])
        units.append(np.where(ev >= 0, np.char.add(f"{runs[k]['run_id']}/", ev.astype(str)), ""))
    full = _fit_lag(runs, True, advection_distance_m)
    a0, a1, u = np.concatenate(e0), np.concatenate(e1), np.concatenate(units)
    r0 = float(np.sqrt(np.mean(a0**2)))
    r1 = float(np.sqrt(np.mean(a1**2)))
    ok = u != ""
    p, n_units = _paired(a0[ok], a1[ok], u[ok])
    return {"mechanism": "response_lag", "source": "tunnel", "metric": "uas_speed_series_rmse",
            "heldout_rmse_before": r0, "heldout_rmse_after": r1, "gain": 1.0 - r1 / r0,
            "p_value": p, "n_units": n_units, "n_parameters": 1,
            "estimate": {"tau_s": float(full[1])},
            "uncertainty": {"tau_s": float(np.std(taus, ddof=1)) if len(taus) > 1 else float("nan")},
            "advection_distance_m": float(full[0]), "converged": True}, r0


def _drag_regime_candidate(acc_one: pd.DataFrame, acc_reg: pd.DataFrame,
                           law: DragLaw) -> tuple[dict[str, Any], float]:
    """``drag_regime``: one power law against the speed ranges, on the AoS-0 steps not used in the
    calibration; returns the candidate and the baseline RMSE [m s-1]."""
    sel = acc_one["aos_deg"].abs() < 1e-6
    a0, a1 = acc_one[sel], acc_reg[sel]
    r0 = float(np.sqrt(np.mean(a0["error_ms"] ** 2)))
    r1 = float(np.sqrt(np.mean(a1["error_ms"] ** 2)))
    p, n_units = _paired(a0["error_ms"].to_numpy(), a1["error_ms"].to_numpy(), np.arange(len(a0)).astype(str))
    return {"mechanism": "drag_regime", "source": "tunnel", "metric": "step_speed_rmse",
            "heldout_rmse_before": r0, "heldout_rmse_after": r1, "gain": 1.0 - r1 / r0,
            "p_value": p, "n_units": n_units, "n_parameters": 2 * (len(law.b_x) - 1),
            "estimate": {"coefficients": [{"min_speed_ms": lo, "max_speed_ms": hi, "b": b, "c": c}
                                          for lo, hi, b, c in zip((0.0,) + law.edges_ms,
                                                                  law.edges_ms + (None,),
                                                                  law.b_x, law.c_x, strict=True)]},
            "uncertainty": {}, "converged": True}, r0


def _sideslip_candidate(index: pd.DataFrame, law: DragLaw,
                        offsets: pd.DataFrame) -> tuple[dict[str, Any], float] | None:
    """``sideslip``: the middle range's longitudinal law applied laterally against the fitted lateral
    coefficients, on the sideslip runs at AoS != 0 (None without such runs); with the baseline RMSE."""
    iso = DragLaw(law="body_axis", edges_ms=law.edges_ms, b_x=law.b_x, c_x=law.c_x,
                  b_y=law.b_x[min(1, len(law.b_x) - 1)], c_y=law.c_x[min(1, len(law.c_x) - 1)],
                  mass_kg=law.mass_kg)
    acc_iso = stepped_accuracy(index, iso, offsets, kinds=("sideslip",))
    side = acc_iso["aos_deg"].abs() > 1e-6
    if not side.any():
        return None
    acc_lat = stepped_accuracy(index, law, offsets, kinds=("sideslip",))
    e0 = acc_iso.loc[side, "error_ms"].to_numpy()
    e1 = acc_lat.loc[side.to_numpy(), "error_ms"].to_numpy()
    r0 = float(np.sqrt(np.mean(e0**2)))
    r1 = float(np.sqrt(np.mean(e1**2)))
    p, n_units = _paired(e0, e1, np.arange(e0.size).astype(str))
    return {"mechanism": "sideslip", "source": "tunnel", "metric": "sideslip_step_speed_rmse",
            "heldout_rmse_before": r0, "heldout_rmse_after": r1, "gain": 1.0 - r1 / r0,
            "p_value": p, "n_units": n_units, "n_parameters": 2,
            "estimate": {"b_y": float(law.b_y), "c_y": float(law.c_y)}, "uncertainty": {},
            "converged": True}, r0


def tunnel_candidates(runs_file: str | Path, alpha: float = 0.01, min_gain: float = 0.05,
                      advection_distance_m: float | None = 2.5) -> dict[str, Any]:
    r"""Tunnel candidates ``response_lag``, ``drag_regime`` and ``sideslip`` (Kistner et al. 2024) with held-out gains.

    Parameters
    ----------
    runs_file : str or Path
        ``tunnel/runs.csv``.
    alpha, min_gain : float
        As in :func:`score_field_candidates` (Bonferroni over the three candidates).
    advection_distance_m : float or None
        Distance from the UAS to the CTA along the flow [m] (Kistner et al. 2024 Fig. 1: UAS 2.5 m
        and CTA 5 m downstream of the grid); ``None`` fits it too, which lets a pure delay
        absorb about half of a lag (the two are nearly collinear in gusts at one speed).

    Returns
    -------
    dict
        ``baseline`` metrics and ``candidates`` (same fields as the field candidates).

    Notes
    -----
    * ``response_lag``: baseline UAS speed = CTA speed advected over the distance
      (delay :math:`d/V`, the UAS hovers upstream of the CTA); the candidate adds a
      first-order lag :math:`\tau`; leave-one-run-out over the gust and step runs, RMSE of
      the UAS time series; the paired test is over gust/step repetitions.
    * ``drag_regime``: one power law (no speed ranges) against Kistner et al. (2024)'s three ranges
      (edges 4 and 12 m/s), both calibrated on the calibration runs; held out: the
      AoS-0 sideslip and the portability runs (per-step RMSE).
    * ``sideslip``: the longitudinal law of the middle range applied laterally against the
      fitted lateral coefficients; held out: the sideslip runs at AoS != 0.
    """
    index = read_tunnel_index(runs_file)
    offsets = uas_offsets(index)
    law, _ = calibrate_tunnel(index, offsets)
    cands, base = [], {}
    runs = _lag_runs(index, law, offsets)
    if len(runs) >= 2:
        cand, base["tunnel_gust_step_rmse_ms"] = _response_lag_candidate(index, runs, advection_distance_m)
        cands.append(cand)
    one, _ = calibrate_tunnel(index, offsets, edges_ms=())
    acc_one = stepped_accuracy(index, one, offsets, kinds=("sideslip", "portability"))
    acc_reg = stepped_accuracy(index, law, offsets, kinds=("sideslip", "portability"))
    if len(acc_one):
        cand, base["tunnel_step_rmse_aos0_ms"] = _drag_regime_candidate(acc_one, acc_reg, law)
        cands.append(cand)
        side = _sideslip_candidate(index, law, offsets)
        if side is not None:
            cand, base["tunnel_sideslip_rmse_ms"] = side
            cands.append(cand)
    level = alpha / max(len(cands), 1)
    for c in cands:
        c["alpha_bonferroni"] = level
        c["significant"] = bool(c["p_value"] < level and c["gain"] >= min_gain)
    return {"baseline": base, "candidates": cands}
