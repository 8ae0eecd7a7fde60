r"""Metrics of Kistner et al. (2024) on a pair of speed series (UAS and CTA): RMSE, gusts, steps, turbulence.

* :func:`rmse` (Eqs. 3, 5, 14, 17);
* :func:`gust_events`: IEC gusts, initial speed, peak and the two dips (Sect. 3.2.3, Eqs. 4-5);
* :func:`step_events`: velocity steps, start and 90 % times, step sizes and durations
  (Sect. 3.2.4, Eqs. 6-13);
* :func:`turbulence_metrics`: PSD agreement, highest resolvable frequency, variances with
  and without cutting the reference, turbulence intensities (Sect. 3.2.5, Eqs. 15-17).

References
----------
.. [1] Wind-tunnel calibration and verification of the SWUF-3D quadrotors, Kistner et al. (2024)
  , Sects. 3.2-4, Eqs. 3-17, Figs. 6-10.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
import pandas as pd
import scipy.signal

__all__ = ["rmse", "gust_events", "step_events", "turbulence_metrics"]

def rmse(a: npt.ArrayLike, b: npt.ArrayLike) -> float:
    r"""Root-mean-square error (Kistner et al. (2024), Eqs. 3, 5, 14, 17).

    .. math:: \epsilon = \sqrt{\frac1n\sum_i (a_i - b_i)^2}

    Non-finite pairs are ignored; NaN if none is left.
    """
    d = np.asarray(a, float) - np.asarray(b, float)
    d = d[np.isfinite(d)]
    return float(np.sqrt(np.mean(d**2))) if d.size else float("nan")


def _parabolic_min(t: np.ndarray, x: np.ndarray, i: int) -> tuple[float, float]:
    """Time and value of the minimum near sample i by a parabola through 3 samples."""
    if 0 < i < x.size - 1:
        a, b, c = x[i - 1], x[i], x[i + 1]
        den = a - 2 * b + c
        if den > 0:
            d = 0.5 * (a - c) / den
            dt = t[i + 1] - t[i]
            return float(t[i] + d * dt), float(b - 0.25 * (a - c) * d)
    return float(t[i]), float(x[i])


def gust_events(time_s: np.ndarray, v_ms: np.ndarray, starts_s: Sequence[float],
                duration_s: float = 10.5, pre_s: float = 5.0) -> pd.DataFrame:
    r"""Speeds and timing of IEC gusts in a time series (Kistner et al. (2024), Sect. 3.2.3, Eqs. 4-5).

    Parameters
    ----------
    time_s, v_ms : numpy.ndarray
        Series [s], [m s-1].
    starts_s : sequence of float
        Nominal gust start times [s].
    duration_s : float
        Gust duration [s].
    pre_s : float
        Length of the stationary interval before each gust used for :math:`V_0` [s].

    Returns
    -------
    pandas.DataFrame
        Per gust: ``start_s``, ``v0_ms`` (mean before the gust), ``vp_ms`` (maximum in the
        gust), ``t_dip1_s``, ``t_dip2_s`` (the two downward peaks, refined by a parabola
        through three samples), ``delta_t_s`` = ``t_dip2_s - t_dip1_s``.

    Notes
    -----
    The first dip is searched in the first half of the gust, the second in the second half
    (the IEC profile of Eq. 4 is symmetric about :math:`T_{peak}`).
    """
    t = np.asarray(time_s, float)
    v = np.asarray(v_ms, float)
    rows = []
    for s in starts_s:
        pre = (t >= s - pre_s) & (t < s)
        first = np.flatnonzero((t >= s) & (t < s + duration_s / 2))
        second = np.flatnonzero((t >= s + duration_s / 2) & (t <= s + duration_s))
        if not pre.any() or first.size < 3 or second.size < 3:
            continue
        i1 = first[np.argmin(v[first])]
        i2 = second[np.argmin(v[second])]
        t1, _ = _parabolic_min(t, v, i1)
        t2, _ = _parabolic_min(t, v, i2)
        rows.append({"start_s": s, "v0_ms": float(np.mean(v[pre])),
                     "vp_ms": float(np.max(v[first[0]:second[-1] + 1])),
                     "t_dip1_s": t1, "t_dip2_s": t2, "delta_t_s": t2 - t1})
    return pd.DataFrame(rows, columns=["start_s", "v0_ms", "vp_ms", "t_dip1_s", "t_dip2_s", "delta_t_s"])


def _crossing(t: np.ndarray, v: np.ndarray, i0: int, level: float, upward: bool) -> float:
    """First time after sample i0 where v crosses ``level`` (linear interpolation)."""
    seg = v[i0:]
    hit = np.flatnonzero(seg >= level) if upward else np.flatnonzero(seg <= level)
    if hit.size == 0:
        return float("nan")
    j = i0 + int(hit[0])
    if j == i0:  # already past the level at the start sample
        return float(t[j])
    a, b = v[j - 1], v[j]
    if b == a:
        return float(t[j])
    return float(t[j - 1] + (level - a) / (b - a) * (t[j] - t[j - 1]))


def step_events(time_s: np.ndarray, v_ms: np.ndarray, rep_starts_s: Sequence[float], period_s: float,
                smooth_s: float = 0.3, guard_s: float = 1.0) -> pd.DataFrame:
    r"""Velocity-step metrics per repetition (Kistner et al. (2024), Sect. 3.2.4, Eqs. 6-13).

    Parameters
    ----------
    time_s, v_ms : numpy.ndarray
        Series [s], [m s-1].
    rep_starts_s : sequence of float
        Start of each repetition (one up and one down step) [s].
    period_s : float
        Repetition length [s].
    smooth_s : float
        Width of the centred moving average applied before differentiating [s] (the
        gradient of a noisy 10 Hz signal otherwise picks noise).
    guard_s : float
        Time left out next to the steps when averaging the plateaus [s].

    Returns
    -------
    pandas.DataFrame
        Per repetition: ``v_low_ms``, ``v_high_ms`` (plateau means), ``t_u0_s``,
        ``t_u1_s``, ``t_d0_s``, ``t_d1_s``, ``dv_u_ms``, ``dv_d_ms``, ``dt_u_s``,
        ``dt_d_s``.

    Notes
    -----
    .. math::
        T_{u,0} = t(\max\dot V),\quad T_{d,0} = t(\min\dot V),\quad
        V(T_{u,1}) = V_l + 0.9(V_h - V_l),\quad V(T_{d,1}) = V_h - 0.9(V_h - V_l),

        \Delta V_u = V(T_{u,1}) - V(T_{u,0}),\quad \Delta V_d = V(T_{d,1}) - V(T_{d,0}),\quad
        \Delta T_u = T_{u,1}-T_{u,0},\quad \Delta T_d = T_{d,1}-T_{d,0}

    (Eq. 9 of Kistner et al. (2024) prints "1.1"; we read it as 90 % of the downward change.)
    :math:`V_l` is the mean before the up step, :math:`V_h` the mean over the second half
    of the high plateau. Crossing times are linearly interpolated.
    """
    t = np.asarray(time_s, float)
    v = np.asarray(v_ms, float)
    dt = float(np.median(np.diff(t)))
    w = max(1, int(round(smooth_s / dt)))
    vs = np.convolve(np.pad(v, (w // 2, w - 1 - w // 2), mode="edge"), np.ones(w) / w, mode="valid")
    dv = np.gradient(vs, t)
    rows = []
    for s in rep_starts_s:
        idx = np.flatnonzero((t >= s) & (t < s + period_s))
        if idx.size < 10:
            continue
        iu = idx[np.argmax(dv[idx])]
        idn = idx[np.argmin(dv[idx])]
        if idn <= iu:
            continue
        low = idx[t[idx] < t[iu] - guard_s]
        high = np.flatnonzero((t >= 0.5 * (t[iu] + t[idn])) & (t < t[idn] - guard_s))
        if low.size == 0 or high.size == 0:
            continue
        vl, vh = float(np.mean(v[low])), float(np.mean(v[high]))
        tu1 = _crossing(t, v, iu, vl + 0.9 * (vh - vl), True)
        td1 = _crossing(t, v, idn, vh - 0.9 * (vh - vl), False)
        tu0, td0 = float(t[iu]), float(t[idn])
        vi = lambda x: float(np.interp(x, t, v))  # noqa: E731
        rows.append({"start_s": s, "v_low_ms": vl, "v_high_ms": vh, "t_u0_s": tu0, "t_u1_s": tu1,
                     "t_d0_s": td0, "t_d1_s": td1,
                     "dv_u_ms": vi(tu1) - vi(tu0), "dv_d_ms": vi(td1) - vi(td0),
                     "dt_u_s": tu1 - tu0, "dt_d_s": td1 - td0})
    return pd.DataFrame(rows)


def _lowpass_var(x: np.ndarray, fs_hz: float, fc_hz: float) -> float:
    if not np.isfinite(fc_hz) or fc_hz <= 0:
        return float("nan")
    if fc_hz >= 0.5 * fs_hz:
        return float(np.var(x))
    sos = scipy.signal.butter(8, fc_hz, fs=fs_hz, output="sos")
    return float(np.var(scipy.signal.sosfiltfilt(sos, x - np.mean(x))))


def turbulence_metrics(v_uas_ms: np.ndarray, fs_uas_hz: float, v_cta_ms: np.ndarray, fs_cta_hz: float,
                       ratio_tol: float = 2.0, segment_s: float = 30.0,
                       bins_per_decade: int = 10, f_min_hz: float = 0.1) -> dict[str, float]:
    r"""Turbulence resolved by the UAS compared with the CTA (Kistner et al. (2024), Sect. 3.2.5, Eqs. 15-17).

    Parameters
    ----------
    v_uas_ms, v_cta_ms : numpy.ndarray
        Speed series of the UAS and the CTA over the same interval [m s-1].
    fs_uas_hz, fs_cta_hz : float
        Their sampling rates [Hz].
    ratio_tol : float
        The spectra agree in a frequency bin when
        :math:`1/r \le S_{UAS}/S_{CTA} \le r`.
    segment_s : float
        Welch segment length [s].
    bins_per_decade : int
        Logarithmic frequency bins for the bin-averaged spectra (Kistner et al. (2024), Fig. 8).
    f_min_hz : float
        Lowest frequency compared [Hz]: below it few Welch segments make the ratio noisy
        (and grid or fan excitation, not the UAS, dominates the difference).

    Returns
    -------
    dict
        ``f_max_hz`` (upper edge of the last bin of the agreeing run that starts at
        ``f_min_hz``: the highest resolvable frequency; 0 if the first bin disagrees), ``f_nyquist_uas_hz``,
        ``var_uas``, ``var_cta_full``, ``var_cta_cut_nyquist`` (CTA low-passed at the UAS
        Nyquist frequency), ``var_cta_cut_fmax`` (at ``f_max_hz``) [m2 s-2], ``mean_uas_ms``,
        ``mean_cta_ms``, ``ti_uas``, ``ti_cta`` (Eq. 16 with Eq. 15).

    Notes
    -----
    .. math:: \sigma = \sqrt{\frac1n\sum(V_i-\bar V)^2},\qquad I = \sigma/\bar V

    PSDs by Welch's method (``scipy.signal.welch``, Hann window); the low-pass is an
    8th-order Butterworth applied forwards and backwards.
    """
    vu = np.asarray(v_uas_ms, float)
    vc = np.asarray(v_cta_ms, float)
    nu = int(min(vu.size, segment_s * fs_uas_hz))
    nc = int(min(vc.size, segment_s * fs_cta_hz))
    fu, su = scipy.signal.welch(vu, fs=fs_uas_hz, nperseg=nu)
    fc, sc = scipy.signal.welch(vc, fs=fs_cta_hz, nperseg=nc)
    f_lo = max(fu[1], fc[1], f_min_hz)
    f_hi = 0.5 * fs_uas_hz
    edges = np.logspace(np.log10(f_lo), np.log10(f_hi), int(np.ceil(np.log10(f_hi / f_lo) * bins_per_decade)) + 1)
    f_max = 0.0
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        mu = (fu >= a) & (fu < b)
        mc = (fc >= a) & (fc < b)
        if not mu.any() or not mc.any():
            continue
        r = np.mean(su[mu]) / np.mean(sc[mc])
        if 1.0 / ratio_tol <= r <= ratio_tol:
            f_max = float(b)
        else:
            break
    mean_u, mean_c = float(np.mean(vu)), float(np.mean(vc))
    var_u, var_c = float(np.var(vu)), float(np.var(vc))
    return {"f_max_hz": f_max, "f_nyquist_uas_hz": f_hi, "var_uas": var_u, "var_cta_full": var_c,
            "var_cta_cut_nyquist": _lowpass_var(vc, fs_cta_hz, f_hi),
            "var_cta_cut_fmax": _lowpass_var(vc, fs_cta_hz, f_max),
            "mean_uas_ms": mean_u, "mean_cta_ms": mean_c,
            "ti_uas": np.sqrt(var_u) / mean_u, "ti_cta": np.sqrt(var_c) / mean_c}

