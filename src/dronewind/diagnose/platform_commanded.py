r"""Platform-motion response of a rigid-mount sonic from commanded motion (``platform_velocity_response``).

The sonic on the airframe measures the air relative to itself. With the catalog mechanism
``platform_velocity_response`` (``docs/data-contract.md``) it sees :math:`G V_{platform}` instead of the
platform's whole velocity, :math:`G = \mathrm{diag}(g_h, g_h, g_v)` (east, north, up), and
with its heading on the airframe off the declared mount by :math:`\delta` (compass sense,
clockwise seen from above) the earth-frame reading of the chain
(:mod:`dronewind.payload.rigid`, :math:`R M V_{sensor}`) is, for small tilts,

.. math:: r = e^{i\delta} (V_{wind} - g_h V_{platform}) \quad\text{(horizontal, as complex } e + i n),
          \qquad r_u = w - g_v V_{platform,u},

so the corrected wind :math:`y = r + V_{platform}` (the present model, :math:`g = 1`,
:math:`\delta = 0`) is

.. math:: y = e^{i\delta} V_{wind} + H V_{platform}, \qquad H = 1 - g_h e^{i\delta}, \qquad
          y_u = w + h_v V_{platform,u}, \qquad h_v = 1 - g_v .

Why commanded motion
--------------------
A position-holding multicopter is carried by the gusts and pulled back by its controller, so
in a hover its velocity follows the wind: a regression (or cross-spectrum) of the corrected
wind on the hover drift is biased by about :math:`\rho\,\sigma_w/\sigma_x` (:mod:`.platform`,
*Assumption*). Velocities the vehicle is commanded to fly (straight survey legs, flown both
ways; climbs and descents) are set by its flight plan, not by the wind. Over such segments the
segment-mean platform velocity is large and independent of the segment-mean wind, so a
regression of segment means of the corrected wind on segment means of the platform velocity
identifies :math:`H` and :math:`h_v` without a mast (the classical "legs flown both ways"
calibration of airborne wind measurements: Lenschow and Spyers-Duran 1989, *Measurement
techniques: air motion sensing*, NCAR Bulletin 23; Williams and Marcotte 2000, J. Atmos.
Oceanic Technol. 17, 795-810). Hover drift is never used.

Steps (all pure functions of arrays)
------------------------------------
1. Segments (:func:`commanded_segments`): from the set points where logged, else from the
   track: straight legs (horizontal speed at least ``min_leg_speed_ms``, course within
   ``max_course_change_deg`` of the leg's, at least ``min_leg_s``), climbs and descents
   (vertical speed at least ``min_climb_speed_ms`` and horizontal speed below the leg limit,
   at least ``min_climb_s``), and turnarounds (the stretch between two legs of opposite
   course). ``trim_s`` is cut from both ends of every leg (the transients of the controller
   and the sonic-platform lag); climbs and descents, a few seconds long on a multicopter, are
   padded by ``climb_pad_s`` instead (three standard errors of the lag of step 2), so that
   their windows hold the whole vertical excursion in the reading and in the platform velocity
   whatever the lag's error.
2. Sonic-platform clock lag (:func:`turnaround_lag`): the reading carries
   :math:`-G V_{platform}(t + L)`, so in each turnaround it reverses with the platform. The
   normalised reversals of reading and platform, averaged over the turns on the platform's
   mid-turn time, are aligned by least squares; the error is the delete-one-turn jackknife.
   The cross-correlation of the reading's and the platform's accelerations
   (:func:`sonic_platform_lag`) is reported beside it: over a position hold it is biased,
   since the drift accelerations follow the gusts with the loop's delay.
3. Segment means and their sampling error (:func:`segment_means`): the random error of a
   mean of a turbulent series over :math:`T` is :math:`\sigma^2\, 2\tau/T` with :math:`\tau` the
   integral time scale (Lenschow, Mann and Kristensen 1994, J. Atmos. Oceanic Technol. 11,
   661-673, the random error of a mean), :math:`\tau` of each component from the
   autocorrelation of its anomalies within the legs (the longest segments; also used for the
   climbs and descents).
4. Regression (:func:`response_fit`): weighted least squares of the segment means on the
   segment-mean platform velocity with a mean-wind intercept, a linear trend in time and (for
   legs at several altitudes) a linear altitude term as nuisance covariates. Horizontal: legs,
   :math:`(y_e, y_n) = a + b\,t + c\,z + H v` with :math:`H` a rotation-scaling (two unknowns,
   :math:`\mathrm{Re}\,H, \mathrm{Im}\,H`). Vertical: climbs and descents,
   :math:`y_u = a + b\,t + h_v v_u`. The weights are :math:`1/(s_k^2 + \tau_b^2)` with
   :math:`s_k^2` the sampling variance and :math:`\tau_b^2` the segment-to-segment scatter
   beyond it, chosen so that the weighted residual chi-square equals its degrees of freedom
   (Paule and Mandel 1982, J. Res. Natl. Bur. Stand. 87, 377-385); the parameter covariance is
   :math:`(X^T W X)^{-1}`. Then :math:`g_h = |1 - H|`, :math:`\delta = \arg(1 - H)`,
   :math:`g_v = 1 - h_v`, errors by the delta method.
5. Test of the present model :math:`g_h = g_v = 1`: :math:`t_j = (\hat g_j - 1)/\sigma_j` is
   Student t with the group's residual degrees of freedom :math:`\nu_j`; each is mapped to the
   normal deviate :math:`z_j` of the same tail probability, :math:`T^2 = \sum z_j^2` is
   chi-square with one degree of freedom per identified group, and the mechanism is named when
   :math:`p < \alpha`.
6. Held-out gain (:func:`leave_one_segment_out`): each segment's mean predicted from fits to
   the others, with the extended model (:math:`H, h_v` fitted) and with the present model
   (:math:`H = h_v = 0`, nuisance refitted); gain = 1 - (weighted squared error of the
   extended model) / (that of the present model).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict
from typing import Any

import numpy as np
import scipy.optimize
import scipy.stats

from dronewind.diagnose.commanded_segments import (
    _KINDS_H,
    _KINDS_V,
    CommandedSegment,
    commanded_segments,
    earth_reading,
)
from dronewind.diagnose.platform_lag import sonic_platform_lag, turnaround_lag
from dronewind.errors import InputError

__all__ = [
    "segment_means",
    "response_fit",
    "leave_one_segment_out",
    "diagnose_commanded",
    "diagnose_commanded_l1",
]


def _integral_time_scale(y: np.ndarray, segments: Sequence[CommandedSegment], dt: float) -> float:
    """Integral time scale [s] of a series from the autocorrelation of its within-segment anomalies."""
    acs, weights = [], []
    for s in segments:
        x = y[s.start:s.stop]
        x = x[np.isfinite(x)]
        if x.size < 8:
            continue
        x = x - x.mean()
        full = np.correlate(x, x, mode="full")[x.size - 1:]
        acs.append(full / np.arange(x.size, 0, -1))
        weights.append(x.size)
    if not acs:
        return dt
    n = min(len(a) for a in acs)
    n = max(n // 2, 2)
    ac = np.average(np.stack([a[:n] for a in acs]), axis=0, weights=weights)
    rho = ac / ac[0] if ac[0] > 0 else np.zeros(n)
    zero = np.flatnonzero(rho <= 0)
    stop = int(zero[0]) if zero.size else n
    return float(max(dt, np.trapezoid(rho[:stop], dx=dt)))


def segment_means(y: np.ndarray, v: np.ndarray, t_s: np.ndarray, alt_m: np.ndarray,
                  segments: Sequence[CommandedSegment], tau_s: float) -> dict[str, np.ndarray]:
    r"""Means of the corrected wind and platform velocity over each segment, with the sampling variance.

    The sampling variance of the mean of a turbulent series of variance :math:`\sigma^2` over
    :math:`T` is :math:`\sigma^2\, 2\tau/T` (Lenschow, Mann and Kristensen 1994, the random
    error of a mean), capped at :math:`\sigma^2`.

    Parameters
    ----------
    y, v : numpy.ndarray
        (n, k) corrected wind and platform velocity [m s-1] (NaN in ``y`` skipped).
    t_s, alt_m : numpy.ndarray
        Times [s] and altitude [m].
    segments : sequence of CommandedSegment
    tau_s : float
        Integral time scale [s].

    Returns
    -------
    dict
        ``y``, ``v`` (m, k) means; ``var`` (m,) sampling variance per component (the
        components' mean); ``t`` and ``z`` (m,) mean time and altitude; ``n`` samples used.
    """
    dt = float(np.median(np.diff(t_s)))
    ys, vs, var, ts, zs, ns = [], [], [], [], [], []
    for s in segments:
        sl = slice(s.start, s.stop)
        ok = np.all(np.isfinite(y[sl]), axis=1)
        yy = y[sl][ok]
        n = int(ok.sum())
        ys.append(yy.mean(axis=0))
        vs.append(v[sl][ok].mean(axis=0))
        sig2 = float(np.mean(yy.var(axis=0, ddof=1))) if n > 1 else float("nan")
        var.append(sig2 * min(1.0, 2.0 * tau_s / (n * dt)))
        ts.append(float(np.mean(t_s[sl][ok])))
        zs.append(float(np.mean(alt_m[sl][ok])))
        ns.append(n)
    return {"y": np.array(ys), "v": np.array(vs), "var": np.array(var), "t": np.array(ts), "z": np.array(zs),
            "n": np.array(ns)}


def _design(group: str, m: dict[str, np.ndarray], covariates: Sequence[str], with_response: bool = True
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stacked design matrix, observations and sampling variances of one group."""
    cov = []
    if "time" in covariates:
        cov.append((m["t"] - m["t"].mean()) / 600.0)
    if "altitude" in covariates:
        cov.append(m["z"] - m["z"].mean())
    k = len(m["t"])
    if group == "horizontal":
        ve, vn = m["v"][:, 0], m["v"][:, 1]
        one, zero = np.ones(k), np.zeros(k)
        east = [one, zero, *[c for c in cov], *[zero for _ in cov]]
        north = [zero, one, *[zero for _ in cov], *[c for c in cov]]
        if with_response:
            east += [ve, -vn]
            north += [vn, ve]
        x = np.vstack([np.stack(east, axis=1), np.stack(north, axis=1)])
        y = np.concatenate([m["y"][:, 0], m["y"][:, 1]])
        s2 = np.concatenate([m["var"], m["var"]])
    else:
        cols = [np.ones(k), *cov] + ([m["v"][:, 2]] if with_response else [])
        x = np.stack(cols, axis=1)
        y = m["y"][:, 2]
        s2 = m["var"]
    return x, y, s2


def _wls(x: np.ndarray, y: np.ndarray, s2: np.ndarray, n_units: int) -> dict[str, Any]:
    """Weighted least squares with the Paule-Mandel between-segment variance (shared by a segment's rows)."""
    p = x.shape[1]
    dof = x.shape[0] - p

    def fit(tau2: float) -> tuple[np.ndarray, np.ndarray, float]:
        w = 1.0 / (s2 + tau2)
        xtw = x.T * w
        cov = np.linalg.pinv(xtw @ x)
        beta = cov @ (xtw @ y)
        chi2 = float(np.sum(w * (y - x @ beta) ** 2))
        return beta, cov, chi2

    beta, cov, chi2 = fit(0.0)
    tau2 = 0.0
    if dof > 0 and chi2 > dof:
        hi = max(float(np.var(y)), 1e-6)
        while fit(hi)[2] > dof:
            hi *= 4.0
        tau2 = float(scipy.optimize.brentq(lambda t2: fit(t2)[2] - dof, 0.0, hi, xtol=1e-10))
        beta, cov, chi2 = fit(tau2)
    return {"beta": beta, "cov": cov, "chi2": chi2, "dof": dof, "tau2": tau2, "n_segments": n_units}


def _covariates(group: str, m: dict[str, np.ndarray], requested: Sequence[str]) -> list[str]:
    """The nuisance covariates the group's segments can carry (at least three segments per parameter)."""
    k = len(m["t"])
    rows = 2 * k if group == "horizontal" else k
    base = 4 if group == "horizontal" else 2
    per = 2 if group == "horizontal" else 1
    out: list[str] = []
    for c in requested:
        if c == "altitude" and float(np.ptp(m["z"])) < 1.0:
            continue
        if rows >= 3 * (base + per * (len(out) + 1)):
            out.append(c)
    return out


def response_fit(group: str, m: dict[str, np.ndarray], covariates: Sequence[str] = ("time", "altitude")
                 ) -> dict[str, Any]:
    r"""Fit the platform response of one group to its segment means (weighted, with segment scatter).

    Parameters
    ----------
    group : {"horizontal", "vertical"}
        Legs (complex :math:`H`) or climbs and descents (:math:`h_v`).
    m : dict
        :func:`segment_means` of the group's segments.
    covariates : sequence of str
        Nuisance terms requested (``time``, ``altitude``); each is used only when there are at
        least three segment rows per parameter, altitude only when the segments span 1 m.

    Returns
    -------
    dict
        ``gain`` and ``sigma`` (:math:`g_h` or :math:`g_v`), for the horizontal also
        ``heading_offset_deg`` and its ``sigma``, ``transfer`` (:math:`H` as ``[re, im]`` or
        :math:`h_v`), ``tau_between_ms`` (segment scatter beyond sampling), ``dof``,
        ``covariates``, ``n_segments``.
    """
    k = len(m["t"])
    need = 3
    if k < need:
        raise InputError(f"platform response ({group})", f"{k} commanded segments; expected at least {need} "
                         "(legs flown both ways for the horizontal, climbs and descents for the vertical)")
    cov_used = _covariates(group, m, covariates)
    x, y, s2 = _design(group, m, cov_used)
    r = _wls(x, y, s2, k)
    beta, cov = r["beta"], r["cov"]
    out: dict[str, Any] = {"n_segments": k, "dof": int(r["dof"]), "covariates": cov_used,
                           "tau_between_ms": float(np.sqrt(r["tau2"])), "chi2": r["chi2"]}
    if group == "horizontal":
        hr, hi = float(beta[-2]), float(beta[-1])
        c2 = cov[-2:, -2:]
        a, b = 1.0 - hr, -hi                       # 1 - H = a + i b
        g = float(np.hypot(a, b))
        jac_g = np.array([-a / g, -b / g]) if g > 0 else np.zeros(2)       # d g / d (hr, hi)
        jac_d = np.array([b / g ** 2, -a / g ** 2]) if g > 0 else np.zeros(2)  # d atan2(b, a) / d (hr, hi)
        out.update({"transfer": [hr, hi], "gain": g, "sigma": float(np.sqrt(jac_g @ c2 @ jac_g)),
                    "heading_offset_deg": float(np.degrees(np.arctan2(b, a))),
                    "heading_offset_sigma_deg": float(np.degrees(np.sqrt(jac_d @ c2 @ jac_d)))})
    else:
        h = float(beta[-1])
        out.update({"transfer": h, "gain": 1.0 - h, "sigma": float(np.sqrt(cov[-1, -1]))})
    return out


def leave_one_segment_out(group: str, m: dict[str, np.ndarray], covariates: Sequence[str]) -> dict[str, Any]:
    """Held-out gain of the extended model: each segment predicted from fits to the others.

    Parameters
    ----------
    group : {"horizontal", "vertical"}
    m : dict
        :func:`segment_means` of the group's segments.
    covariates : sequence of str
        The nuisance covariates of the fit (:func:`response_fit` ``covariates``).

    Returns
    -------
    dict
        ``gain`` = 1 - SSE(extended) / SSE(present) over the held-out segments (weights
        1/sampling variance) [1], ``sse_present``, ``sse_extended``, ``gains_each`` (the
        extended gain fitted without each segment), ``n_segments``.
    """
    k = len(m["t"])
    sse_p = sse_e = 0.0
    each = []
    for j in range(k):
        keep = np.arange(k) != j
        sub = {key: val[keep] for key, val in m.items()}
        one = {key: val[j:j + 1] for key, val in m.items()}
        # centre the held-out covariates on the fitting segments' means
        one = {**one, "t": one["t"] - sub["t"].mean() + 0.0, "z": one["z"] - sub["z"].mean() + 0.0}
        sub_c = {**sub, "t": sub["t"] - sub["t"].mean(), "z": sub["z"] - sub["z"].mean()}
        for with_response in (False, True):
            x, y, s2 = _design(group, sub_c, covariates, with_response)
            r = _wls(x, y, s2, k - 1)
            x1, y1, s21 = _design_at(group, one, covariates, with_response)
            e = float(np.sum((y1 - x1 @ r["beta"]) ** 2 / s21))
            if with_response:
                sse_e += e
                if group == "horizontal":
                    each.append(float(np.hypot(1.0 - r["beta"][-2], r["beta"][-1])))
                else:
                    each.append(float(1.0 - r["beta"][-1]))
            else:
                sse_p += e
    return {"gain": 1.0 - sse_e / sse_p if sse_p > 0 else float("nan"), "sse_present": sse_p,
            "sse_extended": sse_e, "gains_each": each, "n_segments": k,
            "measure": "weighted squared error of held-out segment-mean corrected wind (weights 1/sampling "
                       "variance); present model H = 0 with the nuisance terms refitted"}


def _design_at(group: str, one: dict[str, np.ndarray], covariates: Sequence[str], with_response: bool
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Design rows of one held-out segment, its covariates already centred on the fitting segments."""
    cov = []
    if "time" in covariates:
        cov.append(one["t"] / 600.0)
    if "altitude" in covariates:
        cov.append(one["z"])
    ve, vn, vu = one["v"][0]
    if group == "horizontal":
        e = [1.0, 0.0, *[float(c[0]) for c in cov], *[0.0 for _ in cov]] + ([ve, -vn] if with_response else [])
        n = [0.0, 1.0, *[0.0 for _ in cov], *[float(c[0]) for c in cov]] + ([vn, ve] if with_response else [])
        return np.array([e, n]), np.array([one["y"][0, 0], one["y"][0, 1]]), np.array([one["var"][0]] * 2)
    row = [1.0, *[float(c[0]) for c in cov]] + ([vu] if with_response else [])
    return np.array([row]), np.array([one["y"][0, 2]]), np.array([one["var"][0]])


def diagnose_commanded(t_s: np.ndarray, sensor_xyz: np.ndarray, attitude_deg: np.ndarray, vel_enu: np.ndarray,
                       alt_m: np.ndarray, mount: np.ndarray, *, setpoint_vel_enu: np.ndarray | None = None,
                       alpha: float = 0.01, max_lag_s: float = 2.0,
                       covariates: Sequence[str] = ("time", "altitude"), **segment_kw: float) -> dict[str, Any]:
    """``platform_velocity_response`` of one rigid-mount flight from its commanded motion only.

    Parameters
    ----------
    t_s : numpy.ndarray
        Regular sample times [s].
    sensor_xyz : numpy.ndarray
        (n, 3) sonic u, v, w, sensor frame [m s-1] (NaN where flagged).
    attitude_deg : numpy.ndarray
        (n, 3) roll, pitch, yaw [degree] on the platform clock (gap-filled).
    vel_enu : numpy.ndarray
        (n, 3) platform velocity east, north, up [m s-1] (gap-filled).
    alt_m : numpy.ndarray
        Altitude [m].
    mount : numpy.ndarray
        Declared sensor-to-body matrix M.
    setpoint_vel_enu : numpy.ndarray, optional
        Commanded velocity where logged (segments from it, else from the track).
    alpha : float
        False-alarm rate of the test against :math:`g_h = g_v = 1` [1].
    max_lag_s : float
        Half-width of the lag search [s].
    covariates : sequence of str
        :func:`response_fit`.
    **segment_kw
        :func:`commanded_segments` settings.

    Returns
    -------
    dict
        ``segments`` (kind, times, speed, course), ``lag`` (:func:`turnaround_lag`, the lag
        applied and the acceleration cross-correlation of :func:`sonic_platform_lag` for comparison),
        ``heading_offset_deg`` (and sigma), ``estimate`` / ``uncertainty`` (``gain_h``,
        ``gain_v``; None where not identified), ``fits`` per group, ``test``, ``significant``,
        ``named``, ``held_out`` (:func:`leave_one_segment_out` per group), settings.
    """
    t = np.asarray(t_s, float)
    s = np.asarray(sensor_xyz, float)
    att = np.asarray(attitude_deg, float)
    v = np.asarray(vel_enu, float)
    alt = np.asarray(alt_m, float)
    if not (s.shape == att.shape == v.shape == (t.size, 3)) or alt.shape != t.shape:
        raise InputError("commanded-motion diagnosis", f"sonic {s.shape}, attitude {att.shape}, velocity {v.shape}, "
                         f"altitude {alt.shape} for {t.size} times; expected (n, 3) arrays and (n,) on one axis")
    if not (np.all(np.isfinite(att)) and np.all(np.isfinite(v)) and np.all(np.isfinite(alt))):
        raise InputError("commanded-motion diagnosis", "non-finite platform samples; expected the gap-filled "
                         "platform record")
    if not 0.0 < alpha < 1.0:
        raise InputError("alpha", f"{alpha!r}; expected a false-alarm rate in (0, 1)")
    segs = commanded_segments(t, v, setpoint_vel_enu=setpoint_vel_enu, **segment_kw)

    def at_lag(lag: float) -> tuple[np.ndarray, np.ndarray]:
        """Platform attitude and velocity at the sonic's times (platform clock = sonic stamp + lag)."""
        tq = np.clip(t + lag, t[0], t[-1])
        yaw = np.degrees(np.unwrap(np.radians(att[:, 2])))
        a = np.stack([np.interp(tq, t, att[:, 0]), np.interp(tq, t, att[:, 1]), np.interp(tq, t, yaw)], axis=-1)
        vv = np.stack([np.interp(tq, t, v[:, j]) for j in range(3)], axis=-1)
        return a, vv

    # the lag from the turnarounds (commanded reversals); the cross-correlation of accelerations
    # around the commanded segments' ends is reported beside it (the position hold's drift
    # accelerations follow the gusts with the loop's delay and pull its peak)
    dt = float(np.median(np.diff(t)))
    half = float(segment_kw.get("trim_s", 1.0)) + max_lag_s + 2.0
    windows = np.zeros(t.size, dtype=bool)
    for sg in segs:
        if sg.kind != "turnaround":
            for edge in (sg.t_start_s, sg.t_stop_s):
                windows |= np.abs(t - edge) <= half
    r0 = earth_reading(s, att[:, 0], att[:, 1], att[:, 2], mount)
    lag = turnaround_lag(t, r0, v, segs, max_lag_s=max_lag_s)
    lag_used = float(lag["lag_s"]) if lag["identified"] else 0.0
    a_l, v_l = at_lag(lag_used)
    reading = earth_reading(s, a_l[:, 0], a_l[:, 1], a_l[:, 2], mount)
    y = reading + v_l
    if windows.sum() > 4 * (2 * int(round(max_lag_s / dt)) + 1):
        xc = sonic_platform_lag(t, r0, v, max_lag_s=max_lag_s, valid=windows)
        lag["cross_correlation"] = {k: xc[k] for k in ("lag_s", "sigma_s", "at_edge", "peak_correlation")}
    else:
        lag["cross_correlation"] = {"lag_s": float("nan"), "sigma_s": float("nan"), "at_edge": False,
                                    "peak_correlation": float("nan")}
    lag["cross_correlation"]["samples_used"] = int(windows.sum())
    lag["lag_used_s"] = lag_used
    if "climb_pad_s" not in segment_kw:
        # climbs and descents padded by three standard errors of the lag (at least two samples,
        # at most the lag search): their windows then hold the whole excursion in the reading
        pad = float(np.clip(3.0 * lag["sigma_s"], 2 * dt, max_lag_s)) if lag["identified"] else float(max_lag_s)
        segs = commanded_segments(t, v, setpoint_vel_enu=setpoint_vel_enu, climb_pad_s=pad, **segment_kw)
        lag["climb_pad_s"] = pad
    groups = {"horizontal": [sg for sg in segs if sg.kind in _KINDS_H],
              "vertical": [sg for sg in segs if sg.kind in _KINDS_V]}
    fits: dict[str, dict[str, Any]] = {}
    held: dict[str, dict[str, Any]] = {}
    means: dict[str, dict[str, Any]] = {}
    # integral time scales from the legs (long segments; a climb of a few seconds cuts the
    # autocorrelation short and would understate the sampling error of its mean)
    tau_from = groups["horizontal"] if len(groups["horizontal"]) >= 3 else [sg for g in groups.values() for sg in g]
    for group, gs in groups.items():
        comps = (0, 1) if group == "horizontal" else (2,)
        tau = float(np.mean([_integral_time_scale(y[:, c], tau_from, dt) for c in comps])) if tau_from else dt
        if len(gs) < 3:
            kinds = list(_KINDS_H if group == "horizontal" else _KINDS_V)
            fits[group] = {"identified": False, "n_segments": len(gs),
                           "why": f"{len(gs)} segments of the kinds {kinds}; at least 3 needed"}
            continue
        m = segment_means(y, v_l, t, alt, gs, tau)
        fit = response_fit(group, m, covariates)
        fit.update({"identified": True, "integral_time_scale_s": tau})
        fits[group] = fit
        held[group] = leave_one_segment_out(group, m, fit["covariates"])
        means[group] = {"corrected_wind_ms": m["y"].tolist(), "platform_velocity_ms": m["v"].tolist(),
                        "sampling_sd_ms": np.sqrt(m["var"]).tolist(), "time_s": m["t"].tolist(),
                        "alt_m": m["z"].tolist()}
    ok = {g: f for g, f in fits.items() if f.get("identified")}
    z = {g: (f["gain"] - 1.0) / f["sigma"] for g, f in ok.items() if f["sigma"] > 0}
    param = {"horizontal": "gain_h", "vertical": "gain_v"}
    if z:
        # each t to the normal deviate of the same tail probability (a group with few segments
        # has a noisy error), then chi-square with one degree of freedom per group
        zn = {g: float(scipy.stats.norm.isf(scipy.stats.t.sf(abs(val), max(ok[g]["dof"], 1)) )) for g, val in z.items()}
        t2 = float(sum(val * val for val in zn.values()))
        p = float(scipy.stats.chi2.sf(t2, len(z)))
    else:
        t2, p = float("nan"), float("nan")
    sse_p = sum(h["sse_present"] for h in held.values())
    sse_e = sum(h["sse_extended"] for h in held.values())
    out: dict[str, Any] = {
        "mechanism": "platform_velocity_response",
        "method": "commanded motion: segment means of the corrected wind regressed on the segment-mean platform "
                  "velocity over straight legs (horizontal, complex gain: g_h and the sonic heading offset) and "
                  "climbs and descents (vertical); hover drift not used",
        "segments": [asdict(sg) for sg in segs],
        "segments_used": {g: len(gs) for g, gs in groups.items()},
        "lag": lag,
        "heading_offset_deg": ok["horizontal"]["heading_offset_deg"] if "horizontal" in ok else None,
        "heading_offset_sigma_deg": ok["horizontal"]["heading_offset_sigma_deg"] if "horizontal" in ok else None,
        "estimate": {param[g]: (fits[g]["gain"] if g in ok else None) for g in param},
        "uncertainty": {param[g]: (fits[g]["sigma"] if g in ok else None) for g in param},
        "fits": fits, "segment_means": means,
        "test": {"null": "gain_h = gain_v = 1 (the present model)",
                 "statistic": "T2 = sum of z^2, each t = (g - 1)/sigma mapped to the normal deviate of its tail "
                              "probability (Student t, the group's residual dof); chi-square, one dof per group",
                 "t2": t2, "dof": len(z), "p_value": p, "alpha": float(alpha),
                 "t": {param[g]: val for g, val in z.items()},
                 "dof_each": {param[g]: int(ok[g]["dof"]) for g in z},
                 "p_value_each": {param[g]: float(2 * scipy.stats.t.sf(abs(val), max(ok[g]["dof"], 1)))
                                  for g, val in z.items()}},
        "significant": bool(np.isfinite(p) and p < alpha),
        "held_out": {**held, "combined_gain": 1.0 - sse_e / sse_p if sse_p > 0 else float("nan")},
        "settings": {"max_lag_s": float(max_lag_s),
                     "covariates": list(covariates), **{k: float(val) for k, val in segment_kw.items()}},
    }
    out["named"] = out["significant"]
    return out


def diagnose_commanded_l1(l1: Any, mount: np.ndarray, **kw: Any) -> dict[str, Any]:
    """:func:`diagnose_commanded` on a rigid-mount L1 (:func:`dronewind.payload.rigid.rigid_l1`), whole record.

    The platform series are gap-filled linearly in time (yaw unwrapped first) and the filled
    samples counted; the sonic keeps its NaNs (flagged samples are left out of the segment
    means and the lag search).

    Parameters
    ----------
    l1 : xarray.Dataset
        The L1.
    mount : numpy.ndarray
        Declared sensor-to-body matrix M.
    **kw
        :func:`diagnose_commanded` settings.

    Returns
    -------
    dict
        :func:`diagnose_commanded` output plus ``n_platform_filled`` and ``n_sonic_missing``.
    """
    from dronewind.core.timeseries import fill_nan_by_time

    t = (l1["time"].values - l1["time"].values[0]) / np.timedelta64(1, "s")
    filled: dict[str, np.ndarray] = {}
    missing = np.zeros(t.size, dtype=bool)
    for k in ("roll_deg", "pitch_deg", "yaw_deg", "vel_e_ms", "vel_n_ms", "vel_d_ms", "alt_m"):
        x = np.asarray(l1[k].values, dtype=float).copy()
        ok = np.isfinite(x)
        if ok.sum() < 2:
            raise InputError(f"rigid-mount L1 [{k}]", f"{int(ok.sum())} finite samples of {t.size}; expected a "
                             "platform record")
        missing |= ~ok
        if k == "yaw_deg":
            x[ok] = np.degrees(np.unwrap(np.radians(x[ok])))
        filled[k], _ = fill_nan_by_time(t, x)
    sensor = np.stack([np.asarray(l1[k].values, float) for k in ("u_sensor_ms", "v_sensor_ms", "w_sensor_ms")],
                      axis=-1)
    att = np.stack([filled["roll_deg"], filled["pitch_deg"], filled["yaw_deg"]], axis=-1)
    vel = np.stack([filled["vel_e_ms"], filled["vel_n_ms"], -filled["vel_d_ms"]], axis=-1)
    out = diagnose_commanded(t, sensor, att, vel, filled["alt_m"], mount, **kw)
    out["n_platform_filled"] = int(missing.sum())
    out["n_sonic_missing"] = int((~np.all(np.isfinite(sensor), axis=1)).sum())
    return out
