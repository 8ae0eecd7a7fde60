r"""Calibration of the quadrotor fleet against the tower (Wetz et al. 2021, Sect. 5; Kistner et al. 2024, Sect. 3.1).

* :func:`calibrate_individual`: :math:`c_{d,0}A_0`, :math:`c_p` and a pitch offset per UAV
  (Wetz et al. (2021), Sect. 5.1);
* :func:`calibrate_universal`: common aerodynamic parameters with per-UAV pitch offsets
  (Sect. 5.2, Eq. 18);
* :func:`calibrate_pitch_offsets`: pitch offsets alone with fixed aerodynamic parameters,
  the calibration of scenarios a-d (Sect. 5.3);
* :func:`calibrate_yaw_offsets`: heading offsets under weather-vane mode (Sect. 5.4);
* :func:`calibrate_speed_ranges` and :func:`calibrate_fleet_speed_ranges`: power laws per
  speed range (Kistner et al. (2024), Eq. 1, Table 2), on tunnel steps or field windows.

All fits use the averaging windows of :mod:`dronewind.quadrotor.windows`; the validation
tables that use the results are in :mod:`dronewind.quadrotor.validation`.

References
----------
.. [1] Wetz, T., Wildmann, N., Beyrich, F. (SWUF-3D), Wetz et al. (2021)
  , Sect. 5, Eqs. 12-18.
.. [2] Wind-tunnel calibration and verification of the SWUF-3D quadrotors, Kistner et al. (2024)
  , Sect. 3.1, Eq. 1, Table 2.
.. [3] Branch, M. A., Coleman, T. F., Li, Y.: A subspace, interior, and conjugate
   gradient method for large-scale bound-constrained minimization problems, SIAM J.
   Sci. Comput. 21, 1-23, 1999 (scipy.optimize.least_squares, method 'trf').
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import cast

import numpy as np
import pandas as pd
import scipy.optimize

from dronewind.core.constants import AIR_DENSITY_KGM3, GRAVITY_MS2, WETZ2021_MASS_KG
from dronewind.errors import InputError
from dronewind.quadrotor.drag import DragLaw, tilt_from_attitude
from dronewind.quadrotor.windows import WindowArrays, circular_mean_deg, select_windows

__all__ = [
    "BOUNDS", "calibrate_individual", "calibrate_universal", "calibrate_pitch_offsets",
    "calibrate_yaw_offsets", "calibrate_speed_ranges", "calibrate_fleet_speed_ranges",
]

#: Physical bounds of the calibration parameters (Sect. 5.1: "bounds were chosen in order
#: to guideline the minimization in physical plausible values").
BOUNDS: dict[str, tuple[float, float]] = {
    "cd0a0_m2": (0.003, 0.2),
    "cp_m2_per_rad": (-0.2, 0.2),
    "pitch_offset_deg": (-10.0, 10.0),
}


def _param_se(res, n_obs: int) -> np.ndarray:
    """Standard errors from the Jacobian at the optimum (Gauss-Newton covariance)."""
    n_par = res.x.size
    dof = n_obs - n_par
    if dof <= 0:
        return np.full(n_par, np.nan)
    s2 = 2.0 * res.cost / dof
    jac = res.jac.toarray() if hasattr(res.jac, "toarray") else np.asarray(res.jac)  # sparse with jac_sparsity
    try:
        cov = np.linalg.pinv(jac.T @ jac) * s2
    except np.linalg.LinAlgError:
        return np.full(n_par, np.nan)
    return np.sqrt(np.clip(np.diag(cov), 0, None))


def _solve(fun, x0, lo, hi, where: str, jac_sparsity: np.ndarray | None = None):
    x0 = np.clip(np.asarray(x0, float), np.asarray(lo) + 1e-9, np.asarray(hi) - 1e-9)
    res = scipy.optimize.least_squares(fun, x0, bounds=(lo, hi), method="trf",
                                       x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12,
                                       max_nfev=2000, jac_sparsity=jac_sparsity)
    at_bound = np.isclose(res.x, lo, rtol=0, atol=1e-6) | np.isclose(res.x, hi, rtol=0, atol=1e-6)
    converged = bool(res.success and res.status > 0 and np.all(np.isfinite(res.fun)))
    return res, converged, at_bound


def calibrate_individual(blocks: pd.DataFrame, windows: pd.DataFrame,
                         flights: Iterable[str] | None = None, method: str = "tilt",
                         mass_kg: float = WETZ2021_MASS_KG, rho_kgm3: float = AIR_DENSITY_KGM3,
                         bounds: Mapping[str, tuple[float, float]] | None = None) -> pd.DataFrame:
    r"""Calibrate :math:`c_{d,0}A_0`, :math:`c_p` and :math:`\Delta\theta` per UAV (Wetz et al. (2021), Sect. 5.1).

    Parameters
    ----------
    blocks, windows : pandas.DataFrame
        Output of :func:`dronewind.quadrotor.windows.flight_windows`, concatenated over flights and UAVs.
    flights : iterable of str, optional
        Calibration flights (default all).
    method : {"tilt", "pitch"}
        See :func:`dronewind.quadrotor.wind.wind_from_attitude`.
    mass_kg, rho_kgm3 : float
        Vehicle mass [kg] and air density [kg m-3].
    bounds : mapping, optional
        Parameter bounds (default :data:`BOUNDS`).

    Returns
    -------
    pandas.DataFrame
        One row per UAV: ``uav``, ``cd0a0_m2``, ``cp_m2_per_rad``, ``pitch_offset_deg``,
        their standard errors ``*_se``, ``n_windows``, ``converged`` (bool), ``at_bound``
        (a parameter ended on a bound), ``cost``, ``status`` (text).

    Notes
    -----
    Minimises :math:`\sum_j (\bar V_j - \bar V_{ref,j})^2` over the UAV's windows
    :math:`j` with ``scipy.optimize.least_squares(method="trf")`` inside physical bounds
    (Wetz et al. (2021), Sect. 5.1: Trust Region Reflective, Branch et al. 1999). UAVs with fewer
    than 3 windows are not fitted (``status = "too few windows"``).
    """
    bd = {**BOUNDS, **dict(bounds or {})}
    b, w = select_windows(blocks, windows, flights)
    rows = []
    names = ("cd0a0_m2", "cp_m2_per_rad", "pitch_offset_deg")
    lo = [bd[k][0] for k in names]
    hi = [bd[k][1] for k in names]
    for uav in sorted(w["uav"].astype(str).unique()):
        bu, wu = select_windows(b, w, None, [uav])
        row = {"uav": uav, "n_windows": len(wu)}
        if len(wu) < 3:
            rows.append({**row, **{k: np.nan for k in names}, "converged": False,
                         "at_bound": False, "cost": np.nan, "status": "too few windows"})
            continue
        data = WindowArrays(bu, wu)

        def fun(x, data=data):
            law = DragLaw(cd0a0_m2=x[0], cp_m2_per_rad=x[1], mass_kg=mass_kg, rho_kgm3=rho_kgm3)
            return data.speed(law, x[2], method, signed=True) - data.ref

        # Multi-start over the pitch offset: the three-parameter problem has poor local
        # minima when the offset is far from the start (trade-off c_d0A0 <-> offset).
        fits = [_solve(fun, [0.03, -0.047, x0], lo, hi, f"uav {uav}") for x0 in (-5.0, 0.0, 5.0)]
        res, conv, atb = min(fits, key=lambda f: f[0].cost)
        se = _param_se(res, len(wu))
        rows.append({**row, **dict(zip(names, res.x, strict=True)),
                     **{f"{k}_se": s for k, s in zip(names, se, strict=True)},
                     "converged": conv, "at_bound": bool(atb.any()), "cost": float(res.cost),
                     "status": res.message})
    return pd.DataFrame(rows)


def calibrate_universal(blocks: pd.DataFrame, windows: pd.DataFrame,
                        flights: Iterable[str] | None = None, method: str = "tilt",
                        mass_kg: float = WETZ2021_MASS_KG, rho_kgm3: float = AIR_DENSITY_KGM3,
                        bounds: Mapping[str, tuple[float, float]] | None = None) -> tuple[dict, pd.DataFrame]:
    r"""Common aerodynamic parameters with per-UAV pitch offsets (Wetz et al. (2021), Sect. 5.2, Eq. 18).

    Parameters
    ----------
    blocks, windows, flights, method, mass_kg, rho_kgm3, bounds
        As in :func:`calibrate_individual`.

    Returns
    -------
    aero : dict
        ``cd0a0_m2``, ``cp_m2_per_rad`` (and ``*_se``), ``converged``, ``cost``.
    offsets : pandas.DataFrame
        ``uav``, ``pitch_offset_deg``, ``pitch_offset_deg_se``, ``n_windows``.

    Notes
    -----
    One joint least-squares fit (TRF, bounded) of :math:`c_{d,0}A_0`, :math:`c_p` and one
    :math:`\Delta\theta_i` per UAV to all windows, which "minimize[s] the overall error"
    (Wetz et al. (2021), Sect. 5.2). The common level of the offsets and :math:`c_{d,0}A_0` are
    only weakly separable; their standard errors say how well.
    """
    bd = {**BOUNDS, **dict(bounds or {})}
    b, w = select_windows(blocks, windows, flights)
    if len(w) < 3:
        raise InputError("calibration data", f"{len(w)} windows; at least 3 are needed")
    data = WindowArrays(b, w)
    uavs = sorted(set(data.uav))
    k_uav = np.searchsorted(uavs, data.block_uav)

    def fun(x):
        law = DragLaw(cd0a0_m2=x[0], cp_m2_per_rad=x[1], mass_kg=mass_kg, rho_kgm3=rho_kgm3)
        return data.speed(law, x[2:][k_uav], method, signed=True) - data.ref

    lo = [bd["cd0a0_m2"][0], bd["cp_m2_per_rad"][0]] + [bd["pitch_offset_deg"][0]] * len(uavs)
    hi = [bd["cd0a0_m2"][1], bd["cp_m2_per_rad"][1]] + [bd["pitch_offset_deg"][1]] * len(uavs)
    # Start values: offsets fitted per UAV with fixed aero parameters (1-D problems),
    # from two aero starts; the joint fit from the start with the lower cost wins. A
    # single start can end in a local minimum that trades c_d0A0 against the offsets.
    # A UAV's offset moves only that UAV's windows: with this pattern the finite-difference
    # Jacobian perturbs all offsets at once (3 evaluations per step instead of 2 + n_uav).
    window_uav = np.searchsorted(uavs, data.uav)
    sparsity = np.zeros((len(w), 2 + len(uavs)), dtype=int)
    sparsity[:, :2] = 1
    sparsity[np.arange(len(w)), 2 + window_uav] = 1
    fits = []
    for c0, cp in ((0.03, -0.047), (0.05, 0.0)):
        start = DragLaw(cd0a0_m2=c0, cp_m2_per_rad=cp, mass_kg=mass_kg, rho_kgm3=rho_kgm3)
        x0 = [c0, cp]
        for uav in uavs:
            sel = data.uav == uav
            sub = WindowArrays(b[b["window_key"].isin(w.loc[sel, "window_key"])], w[sel].reset_index(drop=True))
            r1, _, _ = _solve(lambda x, d=sub, law=start: d.speed(law, x[0], method, True) - d.ref, [0.0],
                              [bd["pitch_offset_deg"][0]], [bd["pitch_offset_deg"][1]], uav)
            x0.append(float(r1.x[0]))
        fits.append(_solve(fun, x0, lo, hi, "universal", jac_sparsity=sparsity))
    res, conv, atb = min(fits, key=lambda f: f[0].cost)
    se = _param_se(res, len(w))
    aero = {"cd0a0_m2": float(res.x[0]), "cp_m2_per_rad": float(res.x[1]),
            "cd0a0_m2_se": float(se[0]), "cp_m2_per_rad_se": float(se[1]),
            "converged": conv, "at_bound": bool(atb[:2].any()), "cost": float(res.cost),
            "n_windows": len(w)}
    counts = pd.Series(data.uav).value_counts()
    offsets = pd.DataFrame({"uav": uavs, "pitch_offset_deg": res.x[2:],
                            "pitch_offset_deg_se": se[2:],
                            "n_windows": [int(counts[u]) for u in uavs]})
    return aero, offsets


def calibrate_pitch_offsets(blocks: pd.DataFrame, windows: pd.DataFrame, aero: Mapping,
                            flights: Iterable[str] | None = None, method: str = "tilt",
                            mass_kg: float = WETZ2021_MASS_KG, rho_kgm3: float = AIR_DENSITY_KGM3,
                            bounds: tuple[float, float] = BOUNDS["pitch_offset_deg"]) -> pd.DataFrame:
    r"""Per-UAV pitch offset with fixed aerodynamic parameters (Wetz et al. (2021), Sect. 5.3).

    Parameters
    ----------
    blocks, windows : pandas.DataFrame
        From :func:`dronewind.quadrotor.windows.flight_windows`.
    aero : mapping
        ``cd0a0_m2`` and ``cp_m2_per_rad`` (e.g. from :func:`calibrate_universal`).
    flights : iterable of str, optional
        Calibration flights (scenarios a-d).
    method, mass_kg, rho_kgm3 : see :func:`calibrate_individual`.
    bounds : (float, float)
        Bounds on the offset [degree].

    Returns
    -------
    pandas.DataFrame
        ``uav``, ``pitch_offset_deg``, ``pitch_offset_deg_se``, ``n_windows``,
        ``converged``, ``at_bound``.
    """
    law = DragLaw(cd0a0_m2=float(aero["cd0a0_m2"]), cp_m2_per_rad=float(aero["cp_m2_per_rad"]),
                  mass_kg=mass_kg, rho_kgm3=rho_kgm3)
    b, w = select_windows(blocks, windows, flights)
    rows = []
    for uav in sorted(w["uav"].astype(str).unique()):
        bu, wu = select_windows(b, w, None, [uav])
        data = WindowArrays(bu, wu)
        res, conv, atb = _solve(lambda x, d=data: d.speed(law, x[0], method, True) - d.ref,
                                [0.0], [bounds[0]], [bounds[1]], f"uav {uav}")
        se = _param_se(res, len(wu))
        rows.append({"uav": uav, "pitch_offset_deg": float(res.x[0]),
                     "pitch_offset_deg_se": float(se[0]), "n_windows": len(wu),
                     "converged": conv, "at_bound": bool(atb.any())})
    return pd.DataFrame(rows, columns=["uav", "pitch_offset_deg", "pitch_offset_deg_se",
                                       "n_windows", "converged", "at_bound"])


def calibrate_yaw_offsets(blocks: pd.DataFrame, windows: pd.DataFrame,
                          flights: Iterable[str] | None = None,
                          min_speed_ms: float = 2.0) -> pd.DataFrame:
    r"""Per-UAV yaw (magnetometer) offset under weather-vane mode (Wetz et al. (2021), Sect. 5.4).

    Parameters
    ----------
    blocks, windows : pandas.DataFrame
        From :func:`dronewind.quadrotor.windows.flight_windows`.
    flights : iterable of str, optional
        Calibration flights (Wetz et al. (2021) uses #31 and #56).
    min_speed_ms : float
        Windows with a reference speed below this are not used: the weather-vane mode
        needs roll above 1 degree to turn the nose into the wind (Sect. 5.4) [m s-1].

    Returns
    -------
    pandas.DataFrame
        ``uav``, ``yaw_offset_deg`` (in (-180, 180]), ``yaw_offset_deg_se``,
        ``n_windows``, ``n_low_wind`` (windows left out).

    Notes
    -----
    The offset is the speed-weighted circular mean of logged yaw minus reference
    direction; it minimises :math:`\sum_j w_j\,[1-\cos(\psi_j-\Delta\psi-\psi_{ref,j})]`
    in closed form (no iterative solver needed).

    .. math:: \Delta\psi = \operatorname{atan2}\Big(\sum w_j\sin(\bar\psi_j-\psi_{ref,j}),
              \sum w_j\cos(\bar\psi_j-\psi_{ref,j})\Big)
    """
    b, w = select_windows(blocks, windows, flights)
    mean_yaw = b.assign(s=np.sin(np.radians(b["yaw_deg"])), c=np.cos(np.radians(b["yaw_deg"]))) \
        .groupby("window_key")[["s", "c"]].mean()
    yaw = cast(pd.Series, np.degrees(np.arctan2(mean_yaw["s"], mean_yaw["c"])))
    w = w.assign(yaw_deg=w["window_key"].map(yaw))
    rows = []
    for uav, wu in w.groupby(w["uav"].astype(str)):
        ok = wu["ref_speed_ms"] >= min_speed_ms
        d = (wu.loc[ok, "yaw_deg"] - wu.loc[ok, "ref_from_deg"]).to_numpy()
        wt = wu.loc[ok, "ref_speed_ms"].to_numpy()
        if d.size == 0:
            off, se = np.nan, np.nan
        else:
            off = circular_mean_deg(d, wt)
            off = (off + 180.0) % 360.0 - 180.0
            resid = (d - off + 180.0) % 360.0 - 180.0
            se = float(np.sqrt(np.sum(wt * resid**2) / np.sum(wt)) / np.sqrt(d.size)) if d.size > 1 else np.nan
        rows.append({"uav": uav, "yaw_offset_deg": off, "yaw_offset_deg_se": se,
                     "n_windows": int(ok.sum()), "n_low_wind": int((~ok).sum())})
    return pd.DataFrame(rows, columns=["uav", "yaw_offset_deg", "yaw_offset_deg_se",
                                       "n_windows", "n_low_wind"])


def calibrate_speed_ranges(force_n: np.ndarray, ref_speed_ms: np.ndarray,
                           edges_ms: Sequence[float] = (4.0, 12.0),
                           group: np.ndarray | None = None,
                           b_bounds: tuple[float, float] = (0.2, 2.0),
                           c_bounds: tuple[float, float] = (0.5, 50.0),
                           edge_tol_ms: float = 0.5, scale: np.ndarray | None = None) -> pd.DataFrame:
    r"""Power-law coefficients per speed range (Kistner et al. (2024), Sect. 3.1, Eq. 1, Table 2).

    Parameters
    ----------
    force_n : array_like
        Magnitude of the body-axis wind acceleration (force per unit mass) per sample
        [m s-2] (:func:`dronewind.quadrotor.drag.body_accelerations_ms2`), or a force [N].
    ref_speed_ms : array_like
        Reference (CTA or tower) speed per sample, or per group when ``group`` is given
        [m s-1].
    edges_ms : sequence of float
        Upper edges of the speed ranges [m s-1]; ranges (-inf, e1], (e1, e2), ...
    group : array_like of int, optional
        Index of the averaging interval of each sample; the model speed is averaged
        per group before it is compared with ``ref_speed_ms[group]`` (Kistner et al. (2024): averages
        over each constant-speed step).
    b_bounds, c_bounds : (float, float)
        Physical bounds of the exponent [-] and factor [m s-1 (m s-2)^-b].
    edge_tol_ms : float
        Intervals within this distance of a range's edges are used for that range too
        [m s-1]; a negative value keeps only intervals at least that far inside.
    scale : array_like, optional
        Factor per sample applied to the model speed, e.g. :math:`\cos\theta` to
        project the body-axis speed of Eq. 1 onto the horizontal, as
        :func:`dronewind.quadrotor.wind.wind_from_attitude` does with :math:`R` (default 1).

    Returns
    -------
    pandas.DataFrame
        One row per range: ``lower_ms``, ``upper_ms``, ``b``, ``c``, ``n``, ``rmse_ms``,
        ``converged``.

    Notes
    -----
    :math:`V = c\,F^{b}`; each range is fitted separately to the intervals whose
    reference speed lies in it, with ``scipy.optimize.least_squares(method="trf")``
    (the algorithm named by Kistner et al. (2024), Sect. 3.1).
    """
    f = np.abs(np.asarray(force_n, float))
    ref = np.asarray(ref_speed_ms, float)
    proj = np.ones_like(f) if scale is None else np.broadcast_to(np.asarray(scale, float), f.shape)
    group = np.arange(f.size) if group is None else np.asarray(group, int)
    ref_g = ref
    ng = ref_g.size
    cnt = np.bincount(group, minlength=ng).astype(float)
    edges = list(edges_ms)
    lo_e = [-np.inf] + edges
    hi_e = edges + [np.inf]
    rows = []
    for k in range(len(lo_e)):
        # intervals whose speed lies in the range, widened by edge_tol_ms so that the
        # steps at an edge (e.g. 4 m/s) constrain both neighbouring laws
        in_r = (ref_g >= lo_e[k] - edge_tol_ms) & (ref_g <= hi_e[k] + edge_tol_ms)
        gsel = np.flatnonzero(in_r & (cnt > 0))
        row = {"lower_ms": lo_e[k], "upper_ms": hi_e[k], "n": int(gsel.size)}
        if gsel.size < 3:
            rows.append({**row, "b": np.nan, "c": np.nan, "rmse_ms": np.nan, "converged": False})
            continue
        smask = np.isin(group, gsel)
        fs, gs, ps = f[smask], group[smask], proj[smask]

        def fun(x, fs=fs, gs=gs, ps=ps, gsel=gsel):
            s = np.bincount(gs, weights=ps * x[1] * fs ** x[0], minlength=ng)
            return s[gsel] / cnt[gsel] - ref_g[gsel]

        res, conv, _ = _solve(fun, [0.8, 7.0], [b_bounds[0], c_bounds[0]],
                              [b_bounds[1], c_bounds[1]], f"speed range {k}")
        rows.append({**row, "b": float(res.x[0]), "c": float(res.x[1]),
                     "rmse_ms": float(np.sqrt(np.mean(res.fun**2))), "converged": conv})
    return pd.DataFrame(rows)


def calibrate_fleet_speed_ranges(blocks: pd.DataFrame, windows: pd.DataFrame,
                                 pitch_offsets: pd.DataFrame | None = None,
                                 edges_ms: Sequence[float] = (4.0, 12.0),
                                 flights: Iterable[str] | None = None,
                                 edge_tol_ms: float = 0.5) -> pd.DataFrame:
    r"""Speed-range power laws (Kistner et al. (2024), Table 2 form) fitted to field "drone tower" windows.

    Parameters
    ----------
    blocks, windows : pandas.DataFrame
        From :func:`dronewind.quadrotor.windows.flight_windows`.
    pitch_offsets : pandas.DataFrame, optional
        ``uav``, ``pitch_offset_deg`` subtracted first (default none).
    edges_ms : sequence of float
        Upper edges of the speed ranges [m s-1].
    flights : iterable of str, optional
        Calibration flights (default all).
    edge_tol_ms : float
        See :func:`calibrate_speed_ranges`.

    Returns
    -------
    pandas.DataFrame
        As :func:`calibrate_speed_ranges`, on the wind acceleration
        :math:`a = g\sin\gamma` of each block (tilt :math:`\gamma` from roll and the
        corrected pitch) averaged per window against the window's reference speed.
    """
    b, w = select_windows(blocks, windows, flights)
    data = WindowArrays(b, w)
    off: float | np.ndarray = 0.0
    if pitch_offsets is not None:
        m = pitch_offsets.set_index(pitch_offsets["uav"].astype(str))["pitch_offset_deg"]
        off = pd.Series(data.block_uav).map(m).fillna(0.0).to_numpy()
    tilt, _ = tilt_from_attitude(np.radians(data.roll), np.radians(data.pitch - off))
    return calibrate_speed_ranges(GRAVITY_MS2 * np.sin(tilt), data.ref, edges_ms, group=data.win,
                                  edge_tol_ms=edge_tol_ms)

