r"""Wind-tunnel calibration and verification of quadrotor wind measurement (seed 002).

Reads the run index, CTA signals and UAS attitude logs written by a tunnel campaign
(formats in :mod:`dronewind.simulate.tunnel`; measured campaigns write the same), and
computes the metrics of seed 002:

* calibration of the body-axis drag law per speed range (Sect. 3.1, Eq. 1, Table 2) on
  constant-speed steps, with the accelerometer offsets taken from a calm hover;
* RMSE of the speed per angle of sideslip and per UAS (portability) (Eq. 3; Figs. 4-5);
* IEC gusts: RMSE at the initial speed :math:`V_0` and the peak :math:`V_p` and the RMSE
  of the time between the two dips of each gust (Eqs. 4-5);
* velocity steps: start and 90 % times, step sizes and durations (Eqs. 6-13), their
  RMSEs (Eqs. 5, 14) and the RMSE of the stationary speeds :math:`V_l`, :math:`V_h`;
* statistical turbulence: PSD agreement and the highest resolvable frequency, variance
  bias with and without cutting the reference at the UAS's frequency, turbulence
  intensity RMSE (Eqs. 15-17).

References
----------
.. [1] Wind-tunnel calibration and verification of the SWUF-3D quadrotors, seed 002
   (``../shared/papers/002_*.txt``), Sects. 3-4, Eqs. 1-17, Table 2, Figs. 4-10.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
import scipy.signal

from dronewind.errors import InputError
from dronewind.quadrotor.calibration import (DragLaw, body_accelerations_ms2, calibrate_speed_ranges,
                                 wind_from_attitude)

__all__ = [
    "RUN_COLUMNS", "read_tunnel_index", "read_tunnel_run", "rmse", "uas_offsets",
    "step_means", "calibrate_tunnel", "stepped_accuracy", "gust_events", "step_events",
    "turbulence_metrics", "analyse_tunnel",
]

#: Columns of ``tunnel/runs.csv``.
RUN_COLUMNS: tuple[str, ...] = (
    "run_id", "kind", "uas", "aos_deg", "v0_ms", "vg_ms", "vdu_ms", "ti_percent", "duration_s",
    "fs_cta_hz", "fs_uas_hz", "steps_ms", "hold_s", "first_event_s", "period_s", "n_events",
    "cta_file", "uas_file",
)
_KINDS = {"calibration", "sideslip", "portability", "gust", "step", "turbulence"}


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    r"""Root-mean-square error (seed 002, Eqs. 3, 5, 14, 17).

    .. math:: \epsilon = \sqrt{\frac1n\sum_i (a_i - b_i)^2}

    Non-finite pairs are ignored; NaN if none is left.
    """
    d = np.asarray(a, float) - np.asarray(b, float)
    d = d[np.isfinite(d)]
    return float(np.sqrt(np.mean(d**2))) if d.size else float("nan")


def read_tunnel_index(path: str | Path) -> pd.DataFrame:
    """Read ``tunnel/runs.csv`` (format in :mod:`dronewind.simulate.tunnel`).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    pandas.DataFrame
        One row per run; attrs ``root`` (folder the file paths are relative to).

    Raises
    ------
    InputError
        Missing file or columns, unknown ``kind``.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(path, "tunnel run index not found")
    df = pd.read_csv(path, dtype={"run_id": str, "uas": str, "steps_ms": str})
    missing = [c for c in RUN_COLUMNS if c not in df.columns]
    if missing:
        raise InputError(path, f"missing column(s) {missing}")
    bad = sorted(set(df["kind"]) - _KINDS)
    if bad:
        line = int(np.flatnonzero(df["kind"].isin(bad))[0]) + 2
        raise InputError(f"{path}:{line}", f"unknown kind {bad[0]!r}; expected one of {sorted(_KINDS)}")
    df.attrs["root"] = str(path.parent.parent)
    return df


def read_tunnel_run(index: pd.DataFrame, run_id: str) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Read the CTA signal and UAS log of one run.

    Parameters
    ----------
    index : pandas.DataFrame
        From :func:`read_tunnel_index`.
    run_id : str

    Returns
    -------
    cta : pandas.DataFrame
        ``time_s``, ``wind_speed_ms``.
    uas : pandas.DataFrame
        ``time_s``, ``roll_deg``, ``pitch_deg``, ``yaw_deg``.

    Raises
    ------
    InputError
        Unknown run, missing files or columns, non-increasing time.
    """
    root = Path(index.attrs.get("root", "."))
    row = index.loc[index["run_id"] == run_id]
    if row.empty:
        raise InputError("tunnel/runs.csv", f"no run {run_id!r}")
    row = row.iloc[0]
    out = []
    for col, cols in (("cta_file", ("time_s", "wind_speed_ms")),
                      ("uas_file", ("time_s", "roll_deg", "pitch_deg", "yaw_deg"))):
        p = root / str(row[col])
        if not p.is_file():
            raise InputError(p, f"file of run {run_id!r} not found")
        df = pd.read_csv(p)
        missing = [c for c in cols if c not in df.columns]
        if missing:
            raise InputError(p, f"missing column(s) {missing}; expected {','.join(cols)}")
        if np.any(np.diff(df["time_s"].to_numpy()) <= 0):
            raise InputError(p, "time_s must increase strictly")
        out.append(df)
    return out[0], out[1]


def _block_mean_at(t_src: np.ndarray, x: np.ndarray, t_dst: np.ndarray) -> np.ndarray:
    """Mean of ``x`` over the interval each destination sample represents (down-sampling
    the CTA to the UAS rate, seed 002 Sect. 2.3)."""
    dt = np.median(np.diff(t_dst))
    edges = np.concatenate([t_dst - dt / 2, [t_dst[-1] + dt / 2]])
    k = np.searchsorted(edges, t_src, side="right") - 1
    ok = (k >= 0) & (k < t_dst.size)
    s = np.bincount(k[ok], weights=x[ok], minlength=t_dst.size)
    c = np.bincount(k[ok], minlength=t_dst.size)
    with np.errstate(invalid="ignore", divide="ignore"):
        return s / c


def step_means(time_s: np.ndarray, x: np.ndarray, n_steps: int, hold_s: float,
               settle_s: float = 10.0, guard_s: float = 2.0) -> np.ndarray:
    """Mean of ``x`` over each constant-speed step (step k spans [k hold, (k+1) hold)).

    Parameters
    ----------
    time_s, x : numpy.ndarray
    n_steps : int
    hold_s : float
        Step duration [s].
    settle_s, guard_s : float
        Time left out after the start and before the end of each step [s].

    Returns
    -------
    numpy.ndarray
        One mean per step.
    """
    out = np.full(n_steps, np.nan)
    for k in range(n_steps):
        sel = (time_s >= k * hold_s + settle_s) & (time_s < (k + 1) * hold_s - guard_s)
        if sel.any():
            out[k] = np.nanmean(x[sel])
    return out


def _step_index(time_s: np.ndarray, n_steps: int, hold_s: float, settle_s: float = 10.0,
                guard_s: float = 2.0) -> np.ndarray:
    """Step number of each sample inside the averaging part of a step, else -1 (as
    :func:`step_means`)."""
    k = np.floor(time_s / hold_s).astype(int)
    pos = time_s - k * hold_s
    ok = (k >= 0) & (k < n_steps) & (pos >= settle_s) & (pos < hold_s - guard_s)
    return np.where(ok, k, -1)


def _steps(row) -> list[float]:
    return [float(s) for s in str(row["steps_ms"]).split(";") if s not in ("", "nan")]


def uas_offsets(index: pd.DataFrame, calm_speed_ms: float = 0.5) -> pd.DataFrame:
    """Accelerometer (roll and pitch) offsets per UAS from calm hover (seed 002, Sect. 3.2.1).

    Parameters
    ----------
    index : pandas.DataFrame
        Run index; stepped runs (calibration, sideslip, portability) whose first preset
        speed is at most ``calm_speed_ms`` give the calm hover.
    calm_speed_ms : float
        Largest preset speed counted as calm [m s-1].

    Returns
    -------
    pandas.DataFrame
        ``uas``, ``pitch_offset_deg``, ``roll_offset_deg`` (logged minus true: the mean
        attitude in calm air), ``n_runs``.

    Raises
    ------
    InputError
        A UAS without any calm step.
    """
    rows = {}
    for _, r in index[index["kind"].isin(["calibration", "sideslip", "portability"])].iterrows():
        steps = _steps(r)
        if not steps or steps[0] > calm_speed_ms:
            continue
        _, uas = read_tunnel_run(index, r["run_id"])
        t = uas["time_s"].to_numpy()
        p = step_means(t, uas["pitch_deg"].to_numpy(), 1, float(r["hold_s"]))[0]
        q = step_means(t, uas["roll_deg"].to_numpy(), 1, float(r["hold_s"]))[0]
        rows.setdefault(r["uas"], []).append((p, q))
    for u in sorted(set(index["uas"])):
        if u not in rows:
            raise InputError("tunnel/runs.csv", f"UAS {u!r} has no calm (0 m/s) step to "
                                                "determine its accelerometer offset")
    return pd.DataFrame([{"uas": u, "pitch_offset_deg": float(np.mean([a for a, _ in v])),
                          "roll_offset_deg": float(np.mean([b for _, b in v])), "n_runs": len(v)}
                         for u, v in sorted(rows.items())])


def calibrate_tunnel(index: pd.DataFrame, offsets: pd.DataFrame, edges_ms: Sequence[float] = (4.0, 12.0),
                     mass_kg: float = 0.645, min_speed_ms: float = 1.0) -> tuple[DragLaw, pd.DataFrame]:
    r"""Body-axis calibration per speed range on the calibration runs (seed 002, Sect. 3.1, Table 2).

    Parameters
    ----------
    index : pandas.DataFrame
        Run index; ``kind == "calibration"`` runs at AoS 0 give :math:`(b_x, c_x)` per
        range, at AoS +-90 degree the lateral :math:`(b_y, c_y)`.
    offsets : pandas.DataFrame
        :func:`uas_offsets`.
    edges_ms : sequence of float
        Upper edges of the longitudinal speed ranges [m s-1].
    mass_kg : float
        UAS mass [kg] (0.645 kg, seed 002 Table 1).
    min_speed_ms : float
        Steps with a smaller reference speed are not used [m s-1].

    Returns
    -------
    law : DragLaw
        ``body_axis`` law with the fitted coefficients.
    table : pandas.DataFrame
        ``axis`` (x or y), ``lower_ms``, ``upper_ms``, ``b``, ``c``, ``n``, ``rmse_ms``,
        ``converged``.

    Raises
    ------
    InputError
        No calibration runs, or a range without enough steps.
    """
    off = offsets.set_index("uas")
    cal = index[index["kind"] == "calibration"]
    if cal.empty:
        raise InputError("tunnel/runs.csv", "no calibration runs")
    fx, vx, fy, vy, gx, gy, px, py = [], [], [], [], [], [], [], []
    for _, r in cal.iterrows():
        cta, uas = read_tunnel_run(index, r["run_id"])
        steps = _steps(r)
        hold = float(r["hold_s"])
        o = off.loc[r["uas"]]
        th = np.radians(uas["pitch_deg"].to_numpy() - o["pitch_offset_deg"])
        ph = np.radians(uas["roll_deg"].to_numpy() - o["roll_offset_deg"])
        f_x, f_y = body_accelerations_ms2(ph, th)
        v = step_means(cta["time_s"].to_numpy(), cta["wind_speed_ms"].to_numpy(), len(steps), hold)
        t = uas["time_s"].to_numpy()
        k = _step_index(t, len(steps), hold)
        use = k >= 0
        if abs(float(r["aos_deg"])) < 1e-6:
            # samples of each step; Eq. 1 speed projected on the horizontal by cos(pitch)
            fx.append(np.abs(f_x[use]))
            px.append(np.cos(th[use]))
            gx.append(k[use] + sum(len(x) for x in vx))
            vx.append(v)
        elif abs(abs(float(r["aos_deg"])) - 90.0) < 1e-6:
            fy.append(np.abs(f_y[use]))
            py.append(np.cos(ph[use]))
            gy.append(k[use] + sum(len(x) for x in vy))
            vy.append(v)
    if not fx:
        raise InputError("tunnel/runs.csv", "no calibration run at AoS 0")
    tables = []
    vxa = np.concatenate(vx)
    vxa = np.where(vxa >= min_speed_ms, vxa, np.nan)
    tx = calibrate_speed_ranges(np.concatenate(fx), vxa, edges_ms, group=np.concatenate(gx),
                                scale=np.concatenate(px)).assign(axis="x")
    if not tx["converged"].all():
        raise InputError("tunnel calibration", f"speed range(s) without a converged fit:\n{tx}")
    tables.append(tx)
    b_y, c_y = DragLaw().b_y, DragLaw().c_y
    if fy:
        vya = np.concatenate(vy)
        vya = np.where(vya >= min_speed_ms, vya, np.nan)
        ty = calibrate_speed_ranges(np.concatenate(fy), vya, [], group=np.concatenate(gy),
                                    scale=np.concatenate(py)).assign(axis="y")
        tables.append(ty)
        if ty["converged"].iloc[0]:
            b_y, c_y = float(ty["b"].iloc[0]), float(ty["c"].iloc[0])
    law = DragLaw(law="body_axis", edges_ms=tuple(edges_ms), b_x=tuple(tx["b"]), c_x=tuple(tx["c"]),
                  b_y=b_y, c_y=c_y, mass_kg=mass_kg)
    table = pd.concat(tables, ignore_index=True)
    return law, table[["axis", "lower_ms", "upper_ms", "b", "c", "n", "rmse_ms", "converged"]]


def _uas_speed(uas: pd.DataFrame, law: DragLaw, off: pd.Series) -> np.ndarray:
    w = wind_from_attitude(uas["roll_deg"].to_numpy(), uas["pitch_deg"].to_numpy(),
                           uas["yaw_deg"].to_numpy(), law=law, method="body_axis",
                           pitch_offset_deg=float(off["pitch_offset_deg"]),
                           roll_offset_deg=float(off["roll_offset_deg"]))
    return w["speed_ms"]


def stepped_accuracy(index: pd.DataFrame, law: DragLaw, offsets: pd.DataFrame,
                     kinds: Sequence[str] = ("sideslip", "portability"),
                     min_speed_ms: float = 1.0) -> pd.DataFrame:
    """UAS versus CTA speed per constant-speed step (seed 002, Figs. 4-5).

    Parameters
    ----------
    index : pandas.DataFrame
    law : DragLaw
        Calibration of the calibration UAS (:func:`calibrate_tunnel`), applied to every
        UAS (portability).
    offsets : pandas.DataFrame
        :func:`uas_offsets`.
    kinds : sequence of str
        Run kinds to evaluate.
    min_speed_ms : float
        Steps with a smaller reference speed are left out [m s-1].

    Returns
    -------
    pandas.DataFrame
        ``run_id``, ``kind``, ``uas``, ``aos_deg``, ``step``, ``preset_ms``, ``cta_ms``,
        ``uas_ms``, ``error_ms``.
    """
    off = offsets.set_index("uas")
    rows = []
    for _, r in index[index["kind"].isin(kinds)].iterrows():
        cta, uas = read_tunnel_run(index, r["run_id"])
        steps = _steps(r)
        hold = float(r["hold_s"])
        v_cta = step_means(cta["time_s"].to_numpy(), cta["wind_speed_ms"].to_numpy(), len(steps), hold)
        v_uas = step_means(uas["time_s"].to_numpy(), _uas_speed(uas, law, off.loc[r["uas"]]), len(steps), hold)
        for k, s in enumerate(steps):
            if np.isfinite(v_cta[k]) and v_cta[k] >= min_speed_ms:
                rows.append({"run_id": r["run_id"], "kind": r["kind"], "uas": r["uas"],
                             "aos_deg": float(r["aos_deg"]), "step": k, "preset_ms": s,
                             "cta_ms": v_cta[k], "uas_ms": v_uas[k], "error_ms": v_uas[k] - v_cta[k]})
    return pd.DataFrame(rows)


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
    r"""Speeds and timing of IEC gusts in a time series (seed 002, Sect. 3.2.3, Eqs. 4-5).

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
    r"""Velocity-step metrics per repetition (seed 002, Sect. 3.2.4, Eqs. 6-13).

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

    (Eq. 9 of seed 002 prints "1.1"; we read it as 90 % of the downward change.)
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
    r"""Turbulence resolved by the UAS compared with the CTA (seed 002, Sect. 3.2.5, Eqs. 15-17).

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
        Logarithmic frequency bins for the bin-averaged spectra (seed 002, Fig. 8).
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
    for a, b in zip(edges[:-1], edges[1:]):
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


def _events(row) -> list[float]:
    return [float(row["first_event_s"]) + k * float(row["period_s"]) for k in range(int(row["n_events"]))]


def analyse_tunnel(index_path: str | Path, edges_ms: Sequence[float] = (4.0, 12.0),
                   mass_kg: float = 0.645) -> dict[str, pd.DataFrame]:
    r"""All seed 002 tables of a tunnel campaign (analysis entry point).

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
        ``offsets`` (:func:`uas_offsets`); ``calibration`` (coefficients per range,
        Table 2 equivalent); ``steps_accuracy`` (per step, sideslip and portability runs);
        ``sideslip`` (RMSE per AoS: overall and in 2 m/s speed bins, Fig. 4);
        ``portability`` (RMSE per UAS, Fig. 5); ``gusts`` (per gust, UAS and CTA);
        ``gust_summary`` (per preset: RMSE at V0 and Vp, Eq. 3; RMSE of the dip-to-dip
        time, Eq. 5); ``steps`` (per repetition); ``step_summary`` (per preset: RMSE of
        V_l, V_h, Eq. 3; of dV_u, dV_d, Eq. 14; of dT_u and dT_d, Eq. 5); ``turbulence``
        (per run, :func:`turbulence_metrics`); ``turbulence_summary`` (variance bias with
        and without cutting the CTA at the UAS frequency, R^2 of the variances, TI RMSE
        per variance class <0.3, 0.3-0.5, >=0.5 m2 s-2, Eq. 17). Tables of run kinds
        absent from the index are empty.
    """
    index = read_tunnel_index(index_path)
    out: dict[str, pd.DataFrame] = {}
    offsets = uas_offsets(index)
    out["offsets"] = offsets
    law, cal = calibrate_tunnel(index, offsets, edges_ms, mass_kg)
    out["calibration"] = cal
    off = offsets.set_index("uas")
    acc = stepped_accuracy(index, law, offsets)
    out["steps_accuracy"] = acc
    if not acc.empty:
        ss = acc[acc["kind"] == "sideslip"].copy()
        ss["speed_bin_ms"] = np.round(ss["cta_ms"] / 2.0) * 2.0
        by_speed = ss.groupby(["aos_deg", "speed_bin_ms"]).apply(
            lambda g: rmse(g["uas_ms"], g["cta_ms"]), include_groups=False).rename("rmse_ms").reset_index()
        overall = ss.groupby("aos_deg").apply(lambda g: rmse(g["uas_ms"], g["cta_ms"]),
                                              include_groups=False).rename("rmse_ms").reset_index()
        out["sideslip"] = pd.concat([overall.assign(speed_bin_ms=np.nan), by_speed], ignore_index=True)
        po = acc[acc["kind"] == "portability"]
        out["portability"] = po.groupby("uas").apply(
            lambda g: pd.Series({"rmse_ms": rmse(g["uas_ms"], g["cta_ms"]), "bias_ms": float(g["error_ms"].mean()),
                                 "max_abs_error_ms": float(g["error_ms"].abs().max()), "n": len(g)}),
            include_groups=False).reset_index()
    gusts, steps, turb = [], [], []
    for _, r in index.iterrows():
        if r["kind"] not in ("gust", "step", "turbulence"):
            continue
        cta, uas = read_tunnel_run(index, r["run_id"])
        tu = uas["time_s"].to_numpy()
        vu = _uas_speed(uas, law, off.loc[r["uas"]])
        vc10 = _block_mean_at(cta["time_s"].to_numpy(), cta["wind_speed_ms"].to_numpy(), tu)
        meta = {"run_id": r["run_id"], "uas": r["uas"], "v0_set_ms": r["v0_ms"]}
        if r["kind"] == "gust":
            ev = _events(r)
            gu, gc = gust_events(tu, vu, ev), gust_events(tu, vc10, ev)
            m = gu.merge(gc, on="start_s", suffixes=("_uas", "_cta"))
            gusts.append(m.assign(**meta, vg_set_ms=r["vg_ms"]))
        elif r["kind"] == "step":
            ev = _events(r)
            su, sc = step_events(tu, vu, ev, float(r["period_s"])), step_events(tu, vc10, ev, float(r["period_s"]))
            if not su.empty and not sc.empty:
                m = su.merge(sc, on="start_s", suffixes=("_uas", "_cta"))
                steps.append(m.assign(**meta, vdu_set_ms=r["vdu_ms"]))
        else:
            met = turbulence_metrics(vu, float(r["fs_uas_hz"]), cta["wind_speed_ms"].to_numpy(),
                                     float(r["fs_cta_hz"]))
            turb.append({**meta, "ti_set_percent": r["ti_percent"], **met})
    g = pd.concat(gusts, ignore_index=True) if gusts else pd.DataFrame()
    out["gusts"] = g
    if not g.empty:
        out["gust_summary"] = g.groupby(["v0_set_ms", "vg_set_ms"]).apply(lambda x: pd.Series({
            "rmse_v0_ms": rmse(x["v0_ms_uas"], x["v0_ms_cta"]), "rmse_vp_ms": rmse(x["vp_ms_uas"], x["vp_ms_cta"]),
            "rmse_delta_t_s": rmse(x["delta_t_s_uas"], x["delta_t_s_cta"]), "n": len(x)}),
            include_groups=False).reset_index()
        out["gust_summary"].attrs["rmse_delta_t_all_s"] = rmse(g["delta_t_s_uas"], g["delta_t_s_cta"])
    else:
        out["gust_summary"] = pd.DataFrame()
    s = pd.concat(steps, ignore_index=True) if steps else pd.DataFrame()
    out["steps"] = s
    if not s.empty:
        out["step_summary"] = s.groupby(["v0_set_ms", "vdu_set_ms"]).apply(lambda x: pd.Series({
            "rmse_v_low_ms": rmse(x["v_low_ms_uas"], x["v_low_ms_cta"]),
            "rmse_v_high_ms": rmse(x["v_high_ms_uas"], x["v_high_ms_cta"]),
            "rmse_dv_up_ms": rmse(x["dv_u_ms_uas"], x["dv_u_ms_cta"]),
            "rmse_dv_down_ms": rmse(x["dv_d_ms_uas"], x["dv_d_ms_cta"]),
            "rmse_dt_ms": rmse(np.r_[x["dt_u_s_uas"], x["dt_d_s_uas"]], np.r_[x["dt_u_s_cta"], x["dt_d_s_cta"]]),
            "n": len(x)}), include_groups=False).reset_index().rename(columns={"rmse_dt_ms": "rmse_dt_s"})
    else:
        out["step_summary"] = pd.DataFrame()
    t = pd.DataFrame(turb)
    out["turbulence"] = t
    if not t.empty:
        cls = pd.cut(t["var_cta_full"], [0, 0.3, 0.5, np.inf], right=False, labels=["<0.3", "0.3-0.5", ">=0.5"])
        rows = [{"variance_class": "all", "n": len(t),
                 "bias_var_full_m2s2": float(np.mean(t["var_uas"] - t["var_cta_full"])),
                 "bias_var_cut_nyquist_m2s2": float(np.mean(t["var_uas"] - t["var_cta_cut_nyquist"])),
                 "bias_var_cut_fmax_m2s2": float(np.mean(t["var_uas"] - t["var_cta_cut_fmax"])),
                 "r2_var": float(np.corrcoef(t["var_uas"], t["var_cta_full"])[0, 1] ** 2) if len(t) > 2 else np.nan,
                 "rmse_ti": rmse(t["ti_uas"], t["ti_cta"]), "median_f_max_hz": float(t["f_max_hz"].median())}]
        for c in ["<0.3", "0.3-0.5", ">=0.5"]:
            x = t[cls == c]
            if len(x):
                rows.append({"variance_class": c, "n": len(x),
                             "bias_var_full_m2s2": float(np.mean(x["var_uas"] - x["var_cta_full"])),
                             "bias_var_cut_nyquist_m2s2": float(np.mean(x["var_uas"] - x["var_cta_cut_nyquist"])),
                             "bias_var_cut_fmax_m2s2": float(np.mean(x["var_uas"] - x["var_cta_cut_fmax"])),
                             "r2_var": np.nan, "rmse_ti": rmse(x["ti_uas"], x["ti_cta"]),
                             "median_f_max_hz": float(x["f_max_hz"].median())})
        out["turbulence_summary"] = pd.DataFrame(rows)
    else:
        out["turbulence_summary"] = pd.DataFrame()
    return out
