"""Sonic-platform clock lag of a rigid-mount sonic from commanded motion.

Step 2 of the commanded-motion diagnosis (:mod:`dronewind.diagnose.platform_commanded`):
the reading carries :math:`-G V_{platform}(t + L)`, so in each turnaround it reverses with
the platform. The normalised reversals of reading and platform, averaged over the turns on
the platform's mid-turn time, are aligned by least squares; the error is the
delete-one-turn jackknife (:func:`turnaround_lag`). The cross-correlation of the reading's
and the platform's accelerations (:func:`sonic_platform_lag`) is reported beside it: over a
position hold it is biased, since the drift accelerations follow the gusts with the loop's
delay.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from dronewind.diagnose.commanded_segments import (
    CommandedSegment,
    _smooth,
)

__all__ = [
    "sonic_platform_lag",
    "turnaround_lag",
]


def _xcorr_lags(a: np.ndarray, b: np.ndarray, n_half: int) -> np.ndarray:
    """sum_t a(t) b(t + k) for k = -n_half..n_half (a, b (n, c); zero outside)."""
    n = a.shape[0]
    out = np.empty(2 * n_half + 1)
    for j, k in enumerate(range(-n_half, n_half + 1)):
        if k >= 0:
            out[j] = float(np.sum(a[: n - k] * b[k:]))
        else:
            out[j] = float(np.sum(a[-k:] * b[: n + k]))
    return out


def _peak(c: np.ndarray, n_half: int) -> tuple[float, bool]:
    """Parabolic refinement of the maximum of c (index offset from the centre) and whether it is at an edge."""
    j = int(np.argmax(c))
    if j == 0 or j == c.size - 1:
        return float(j - n_half), True
    den = c[j - 1] - 2 * c[j] + c[j + 1]
    off = 0.5 * (c[j - 1] - c[j + 1]) / den if den < 0 else 0.0
    return float(j - n_half + off), False


def sonic_platform_lag(t_s: np.ndarray, reading_enu: np.ndarray, vel_enu: np.ndarray, *, max_lag_s: float = 2.0,
                       smooth_s: float = 1.0, n_blocks: int = 10, valid: np.ndarray | None = None
                       ) -> dict[str, Any]:
    r"""Sonic-platform clock lag from the platform's acceleration signatures in the sonic reading.

    The earth-frame reading carries :math:`-G V_{platform}(t + L)` (the sonic sample stamped
    :math:`t` was taken when the platform clock read :math:`t + L`; the convention of
    :func:`dronewind.payload.rigid.rigid_l2`, ``lag_sonic_ins_s``). The lag :math:`L`
    maximises :math:`\sum_t (-\dot r(t)) \cdot \dot V_{platform}(t + L)` over the three
    components (derivatives by central differences of series smoothed over ``smooth_s``),
    refined by a parabola through the peak. The turnarounds, climbs and stops dominate the
    sum; the turbulence in :math:`\dot r` is the noise. The standard error is the
    delete-one-block jackknife over ``n_blocks`` contiguous blocks.

    Parameters
    ----------
    t_s : numpy.ndarray
        Regular sample times [s].
    reading_enu : numpy.ndarray
        (n, 3) earth-frame sonic reading (:func:`earth_reading`) [m s-1].
    vel_enu : numpy.ndarray
        (n, 3) platform velocity [m s-1].
    max_lag_s : float
        Half-width of the search [s].
    smooth_s : float
        Moving mean before differencing [s].
    n_blocks : int
        Jackknife blocks.
    valid : numpy.ndarray, optional
        Boolean mask of samples to use (default: all finite readings).

    Returns
    -------
    dict
        ``lag_s``, ``sigma_s``, ``at_edge``, ``peak_correlation`` (normalised cross-correlation
        at the peak), ``lags_s`` and ``correlation`` (the curve).
    """
    t = np.asarray(t_s, float)
    dt = float(np.median(np.diff(t)))
    n_half = int(round(max_lag_s / dt))
    r = np.asarray(reading_enu, float).copy()
    v = np.asarray(vel_enu, float)
    ok = np.all(np.isfinite(r), axis=1) if valid is None else np.asarray(valid, bool) & np.all(np.isfinite(r), axis=1)
    for j in range(3):
        r[:, j] = np.interp(t, t[ok], r[ok, j])
    m = max(1, int(round(smooth_s / dt)))
    a_s = -np.gradient(_smooth(r, m), dt, axis=0)
    a_p = np.gradient(_smooth(v, m), dt, axis=0)
    a_s[~ok] = 0.0
    a_s -= a_s.mean(axis=0)
    a_p -= a_p.mean(axis=0)
    c = _xcorr_lags(a_s, a_p, n_half)
    norm = float(np.sqrt(np.sum(a_s ** 2) * np.sum(a_p ** 2)))
    k, edge = _peak(c, n_half)
    blocks = np.array_split(np.arange(t.size), n_blocks)
    jk = []
    for blk in blocks:
        w = np.ones(t.size)
        w[blk] = 0.0
        jk.append(_peak(_xcorr_lags(a_s * w[:, None], a_p, n_half), n_half)[0])
    jk_arr = np.array(jk)
    sigma = float(np.sqrt((n_blocks - 1) / n_blocks * np.sum((jk_arr - jk_arr.mean()) ** 2))) * dt
    return {"lag_s": k * dt, "sigma_s": sigma, "at_edge": bool(edge),
            "peak_correlation": float(np.max(c) / norm) if norm > 0 else float("nan"),
            "lags_s": [float(x) for x in np.arange(-n_half, n_half + 1) * dt], "correlation": [float(x / norm)
                                                                                              for x in c]}


def _first_crossing(t: np.ndarray, x: np.ndarray, level: float, near: float) -> float:
    """Time where x crosses ``level`` (linear interpolation), the crossing nearest to ``near``; NaN if none."""
    d = x - level
    k = np.flatnonzero(np.sign(d[:-1]) * np.sign(d[1:]) < 0)
    if k.size == 0:
        return float("nan")
    tc = t[k] + (t[k + 1] - t[k]) * d[k] / (d[k] - d[k + 1])
    return float(tc[np.argmin(np.abs(tc - near))])


def turnaround_lag(t_s: np.ndarray, reading_enu: np.ndarray, vel_enu: np.ndarray,
                   segments: Sequence[CommandedSegment], *, level_s: float = 3.0, window_s: float = 8.0,
                   max_lag_s: float = 2.0, min_step_ms: float = 0.5) -> dict[str, Any]:
    r"""Sonic-platform clock lag from the turnarounds: the reading's reversal against the platform's.

    In a turnaround the commanded velocity reverses: along :math:`u = (v_B - v_A)/|v_B - v_A|`
    (leg A to leg B) the platform velocity crosses the mid-level of the two legs at platform
    time :math:`t_p` (drift of the position hold moves it by only its drift velocity over the
    turn's acceleration). The earth-frame sonic reading carries :math:`-G V_{platform}(t + L)`,
    so its projection, normalised per turn to run from 0 (leg A level) to 1 (leg B level), is
    a ramp centred at stamp :math:`t_p - L`. The normalised readings of all turns are averaged
    on a common axis :math:`	au = t - t_p` (a superposed-epoch average, weights the squared
    level steps): the turbulence, independent of when the turns were commanded, averages out,
    and the composite crosses 0.5 at :math:`	au^* = -L`. A cross-correlation of accelerations
    is not used: the position hold's drift accelerations follow the gusts with the loop's
    delay and pull its peak. The error is the delete-one-turn jackknife.

    Parameters
    ----------
    t_s : numpy.ndarray
        Regular sample times [s].
    reading_enu, vel_enu : numpy.ndarray
        (n, 3) earth-frame sonic reading (:func:`earth_reading`) and platform velocity [m s-1].
    segments : sequence of CommandedSegment
        :func:`commanded_segments` (legs joined by a turnaround are used).
    level_s : float
        Level windows at the ends of the legs [s].
    window_s : float
        Half-width of the composite [s].
    max_lag_s : float
        Largest lag accepted [s].
    min_step_ms : float
        Smallest change of the reading's level across a turn [m s-1].

    Returns
    -------
    dict
        ``lag_s``, ``sigma_s``, ``n_turns``, ``turn_times_s``, ``composite`` (``tau_s``,
        ``reading``), ``identified`` (at least three turns and the crossing inside the search).
    """
    t = np.asarray(t_s, float)
    dt = float(np.median(np.diff(t)))
    r = np.asarray(reading_enu, float)
    ok = np.all(np.isfinite(r), axis=1)
    v = np.asarray(vel_enu, float)
    legs = [sg for sg in segments if sg.kind == "leg"]
    m = max(2, int(round(level_s / dt)))
    tau = np.arange(-int(round(window_s / dt)), int(round(window_s / dt)) + 1) * dt
    n_lag = int(np.ceil(max_lag_s / dt))
    curves, plat, weights, times = [], [], [], []
    for a, b in zip(legs[:-1], legs[1:], strict=True):
        if not any(sg.kind == "turnaround" and a.stop - 1 <= sg.stop and sg.start <= b.start + 1 for sg in segments):
            continue
        # level windows kept a lag search away from the turn (the lagged reading's ramp must not reach them)
        ia = slice(max(a.stop - m - n_lag, a.start), a.stop - n_lag)
        ib = slice(b.start + n_lag, min(b.start + n_lag + m, b.stop))
        if ia.stop - ia.start < 2 or ib.stop - ib.start < 2:
            continue
        va, vb = v[ia, :2].mean(axis=0), v[ib, :2].mean(axis=0)
        u = (vb - va) / np.linalg.norm(vb - va)
        p = v[:, :2] @ u
        pa, pb = float(p[ia].mean()), float(p[ib].mean())
        tp = _first_crossing(t[ia.start:ib.stop], p[ia.start:ib.stop], 0.5 * (pa + pb),
                             0.5 * (t[a.stop] + t[b.start]))
        if not np.isfinite(tp) or not (ok[ia].any() and ok[ib].any()):
            continue
        q = r[:, :2] @ u
        qa, qb = float(np.nanmean(q[ia])), float(np.nanmean(q[ib]))
        if abs(qb - qa) < min_step_ms or tp + tau[0] - max_lag_s < t[0] or tp + tau[-1] + max_lag_s > t[-1]:
            continue
        good = ok & np.isfinite(q)
        curves.append((np.interp(tp + tau, t[good], q[good]) - qa) / (qb - qa))
        plat.append((np.interp(tp + tau, t, p) - pa) / (pb - pa))
        weights.append((qb - qa) ** 2)
        times.append(float(tp))
    n = len(curves)
    out: dict[str, Any] = {"n_turns": n, "turn_times_s": times, "method": "superposed-epoch averages of the "
                           "normalised sonic reading and platform velocity over the turnarounds (aligned on the "
                           "platform's mid-turn time), the reading's shifted by the lag of least squared difference"}
    if n < 3:
        return {**out, "lag_s": float("nan"), "sigma_s": float("nan"), "identified": False}
    c, cp, w = np.array(curves), np.array(plat), np.array(weights)
    grid = np.arange(-max_lag_s, max_lag_s + 1e-9, dt / 10.0)
    inner = np.abs(tau) <= window_s - max_lag_s

    def align(sel: np.ndarray) -> float:
        cq = np.average(c[sel], axis=0, weights=w[sel])
        cpl = np.average(cp[sel], axis=0, weights=w[sel])
        # the reading stamped t - L matches the platform at t: compare cq(tau - L) with cp(tau)
        sse = [float(np.sum((np.interp(tau[inner] - lag, tau, cq) - cpl[inner]) ** 2)) for lag in grid]
        return float(grid[int(np.argmin(sse))])

    lag = align(np.ones(n, dtype=bool))
    jk = np.array([align(np.arange(n) != k) for k in range(n)])
    sigma = float(np.sqrt((n - 1) / n * np.sum((jk - jk.mean()) ** 2)))
    return {**out, "lag_s": lag, "sigma_s": sigma,
            "identified": bool(abs(lag) < max_lag_s - dt),
            "composite": {"tau_s": [float(x) for x in tau],
                          "reading": [float(x) for x in np.average(c, axis=0, weights=w)],
                          "platform": [float(x) for x in np.average(cp, axis=0, weights=w)]}}
