r"""Calibration of the quadrotor drag law in the wind tunnel and its accuracy on constant-speed steps.

* :func:`uas_offsets`: accelerometer offsets from a calm hover (Kistner et al. (2024), Sect. 3.2.1);
* :func:`calibrate_tunnel`: body-axis power laws per speed range (Sect. 3.1, Eq. 1, Table 2);
* :func:`stepped_accuracy`: UAS versus CTA speed per step, for the sideslip and portability
  runs (Figs. 4-5).

References
----------
.. [1] Wind-tunnel calibration and verification of the SWUF-3D quadrotors, Kistner et al. (2024)
  , Sects. 3.1-3.2.2, Eq. 1, Table 2, Figs. 4-5.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from dronewind.errors import InputError
from dronewind.quadrotor.calibration import calibrate_speed_ranges
from dronewind.quadrotor.drag import DragLaw, body_accelerations_ms2
from dronewind.quadrotor.wind import wind_from_attitude
from dronewind.tunnel.io import preset_speeds, read_tunnel_run

__all__ = ["step_means", "step_index", "uas_offsets", "calibrate_tunnel", "uas_speed", "stepped_accuracy"]

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


def step_index(time_s: np.ndarray, n_steps: int, hold_s: float, settle_s: float = 10.0,
                guard_s: float = 2.0) -> np.ndarray:
    """Step number of each sample inside the averaging part of a step, else -1 (as
    :func:`step_means`)."""
    k = np.floor(time_s / hold_s).astype(int)
    pos = time_s - k * hold_s
    ok = (k >= 0) & (k < n_steps) & (pos >= settle_s) & (pos < hold_s - guard_s)
    return np.where(ok, k, -1)


def uas_offsets(index: pd.DataFrame, calm_speed_ms: float = 0.5) -> pd.DataFrame:
    """Accelerometer (roll and pitch) offsets per UAS from calm hover (Kistner et al. (2024), Sect. 3.2.1).

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
    rows: dict[str, list[tuple[float, float]]] = {}
    for _, r in index[index["kind"].isin(["calibration", "sideslip", "portability"])].iterrows():
        steps = preset_speeds(r)
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


def _calibration_samples(index: pd.DataFrame, offsets: pd.DataFrame) -> dict[str, tuple[list, list, list, list]]:
    """Wind accelerations, step speeds, step numbers and projections of the calibration runs.

    Returns
    -------
    dict
        ``x`` (runs at AoS 0) and ``y`` (AoS +-90 degree): lists per run of the absolute
        body-axis acceleration of every sample inside a step [m s-2], the CTA mean per step
        [m s-1], the step number of every sample (counted over the runs of the axis) and
        the factor that projects Eq. 1's body-axis speed on the horizontal (cos pitch or
        cos roll).
    """
    off = offsets.set_index("uas")
    cal = index[index["kind"] == "calibration"]
    if cal.empty:
        raise InputError("tunnel/runs.csv", "no calibration runs")
    fx: list[np.ndarray] = []
    vx: list[np.ndarray] = []
    fy: list[np.ndarray] = []
    vy: list[np.ndarray] = []
    gx: list[np.ndarray] = []
    gy: list[np.ndarray] = []
    px: list[np.ndarray] = []
    py: list[np.ndarray] = []
    for _, r in cal.iterrows():
        cta, uas = read_tunnel_run(index, r["run_id"])
        steps = preset_speeds(r)
        hold = float(r["hold_s"])
        o = off.loc[r["uas"]]
        th = np.radians(uas["pitch_deg"].to_numpy() - o["pitch_offset_deg"])
        ph = np.radians(uas["roll_deg"].to_numpy() - o["roll_offset_deg"])
        f_x, f_y = body_accelerations_ms2(ph, th)
        v = step_means(cta["time_s"].to_numpy(), cta["wind_speed_ms"].to_numpy(), len(steps), hold)
        t = uas["time_s"].to_numpy()
        k = step_index(t, len(steps), hold)
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
    return {"x": (fx, vx, gx, px), "y": (fy, vy, gy, py)}


def _fit_axis(samples: tuple[list, list, list, list], edges_ms: Sequence[float], min_speed_ms: float,
              axis: str) -> pd.DataFrame:
    """:func:`dronewind.quadrotor.calibration.calibrate_speed_ranges` on the steps of one axis."""
    f, v, g, p = samples
    va = np.concatenate(v)
    va = np.where(va >= min_speed_ms, va, np.nan)
    return calibrate_speed_ranges(np.concatenate(f), va, edges_ms, group=np.concatenate(g),
                                  scale=np.concatenate(p)).assign(axis=axis)


def calibrate_tunnel(index: pd.DataFrame, offsets: pd.DataFrame, edges_ms: Sequence[float] = (4.0, 12.0),
                     mass_kg: float = 0.645, min_speed_ms: float = 1.0) -> tuple[DragLaw, pd.DataFrame]:
    r"""Body-axis calibration per speed range on the calibration runs (Kistner et al. (2024), Sect. 3.1, Table 2).

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
        UAS mass [kg] (0.645 kg, Kistner et al. (2024), Table 1).
    min_speed_ms : float
        Steps with a smaller reference speed are not used [m s-1].

    Returns
    -------
    law : DragLaw
        ``body_axis`` law with the fitted coefficients; without a converged lateral fit the
        lateral coefficients of Kistner et al. (2024), Table 2.
    table : pandas.DataFrame
        ``axis`` (x or y), ``lower_ms``, ``upper_ms``, ``b``, ``c``, ``n``, ``rmse_ms``,
        ``converged``.

    Raises
    ------
    InputError
        No calibration runs, or a range without enough steps.
    """
    samples = _calibration_samples(index, offsets)
    if not samples["x"][0]:
        raise InputError("tunnel/runs.csv", "no calibration run at AoS 0")
    tx = _fit_axis(samples["x"], edges_ms, min_speed_ms, "x")
    if not tx["converged"].all():
        raise InputError("tunnel calibration", f"speed range(s) without a converged fit:\n{tx}")
    tables = [tx]
    b_y, c_y = DragLaw().b_y, DragLaw().c_y
    if samples["y"][0]:
        ty = _fit_axis(samples["y"], [], min_speed_ms, "y")
        tables.append(ty)
        if ty["converged"].iloc[0]:
            b_y, c_y = float(ty["b"].iloc[0]), float(ty["c"].iloc[0])
    law = DragLaw(law="body_axis", edges_ms=tuple(edges_ms), b_x=tuple(tx["b"]), c_x=tuple(tx["c"]),
                  b_y=b_y, c_y=c_y, mass_kg=mass_kg)
    table = pd.concat(tables, ignore_index=True)
    return law, table[["axis", "lower_ms", "upper_ms", "b", "c", "n", "rmse_ms", "converged"]]


def uas_speed(uas: pd.DataFrame, law: DragLaw, off: pd.Series) -> np.ndarray:
    """Wind speed of a UAS log by the body-axis law (Kistner et al. (2024), Eq. 1) after its accelerometer
    offsets ``off`` (``pitch_offset_deg``, ``roll_offset_deg``) [m s-1]; no GNSS in the tunnel."""
    w = wind_from_attitude(uas["roll_deg"].to_numpy(), uas["pitch_deg"].to_numpy(),
                           uas["yaw_deg"].to_numpy(), law=law, method="body_axis",
                           pitch_offset_deg=float(off["pitch_offset_deg"]),
                           roll_offset_deg=float(off["roll_offset_deg"]))
    return w["speed_ms"]


def stepped_accuracy(index: pd.DataFrame, law: DragLaw, offsets: pd.DataFrame,
                     kinds: Sequence[str] = ("sideslip", "portability"),
                     min_speed_ms: float = 1.0) -> pd.DataFrame:
    """UAS versus CTA speed per constant-speed step (Kistner et al. (2024), Figs. 4-5).

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
        steps = preset_speeds(r)
        hold = float(r["hold_s"])
        v_cta = step_means(cta["time_s"].to_numpy(), cta["wind_speed_ms"].to_numpy(), len(steps), hold)
        v_uas = step_means(uas["time_s"].to_numpy(), uas_speed(uas, law, off.loc[r["uas"]]), len(steps), hold)
        for k, s in enumerate(steps):
            if np.isfinite(v_cta[k]) and v_cta[k] >= min_speed_ms:
                rows.append({"run_id": r["run_id"], "kind": r["kind"], "uas": r["uas"],
                             "aos_deg": float(r["aos_deg"]), "step": k, "preset_ms": s,
                             "cta_ms": v_cta[k], "uas_ms": v_uas[k], "error_ms": v_uas[k] - v_cta[k]})
    return pd.DataFrame(rows)

