r"""Figures of the quadrotor fleet (Wetz et al. 2021, Figs 3-9) and the wind tunnel (Kistner et al. 2024, Figs 4-7, 9).

Drawn only from stored products: the campaign tables written by
:func:`dronewind.steps.quadrotor.quadrotor_calibration` and
:func:`dronewind.steps.quadrotor.tunnel_analysis`, ``quadrotor/calibration.json`` (the
universal law evaluated on a tilt grid), the L2 NetCDF files of one flight and its tower
reference CSV. Presentation-only arithmetic: absolute values of stored per-step errors
(Fig. 5 of Kistner et al. (2024), one step's RMSE) and the 1:1 lines.

Output: one PNG per figure and its vector copy (PDF) beside it, drawn and saved like the
payload figures (:mod:`dronewind.figures.style`: fixed size and resolution, no time stamp in
the metadata, written atomically; Agg canvas, no pyplot state). Legends stand outside the
axes, each label once; figures of several panels carry panel letters; the scatter figures
state n, bias, RMSE and R² of the points drawn, at the precision that is real.
Windows and UAVs that could not be used are named in a note on the figure, never dropped
silently.

References
----------
.. [1] Wetz et al. (2021), Figs 3-9 with their captions.
.. [2] Kistner et al. (2024), Figs 4-7 and 9 with their captions.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from dronewind.errors import InputError
from dronewind.figures.labels import QUAD_FIGURES, TUNNEL_FIGURES
from dronewind.figures.style import add_notes, new_figure, panel_letters, save_figure

__all__ = ["QUAD_FIGURES", "TUNNEL_FIGURES", "quadrotor_figures", "tunnel_figures"]

#: Width of the figures [inch] (the legend, outside the axes on the right, included).
WIDTH_IN = 6.4


def _figure(width_in: float = WIDTH_IN, height_in: float = 4.5) -> tuple[Any, Any]:
    fig = new_figure(width_in, height_in)
    return fig, fig.add_subplot()


def _save(fig: Any, path: str | Path, note: str = "") -> Path:
    """Write the PNG and its vector copy (PDF) atomically without time stamps (:func:`save_figure`).

    ``note`` (what was left out and why) goes below the axes and into the metadata; a
    figure of several panels gets its panel letters first.
    """
    panel_letters(fig)
    notes = add_notes(fig, [note] if note else [])
    target = Path(path)
    return save_figure(fig, target.with_suffix(""), notes)[0]


def _legend(ax: Any, **kwargs: Any) -> None:
    """The legend outside the axes on the right (never over data), each label once."""
    seen: dict[str, Any] = {}
    for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
        if label and not label.startswith("_"):
            seen.setdefault(label, handle)
    if seen:
        ax.legend(list(seen.values()), list(seen), loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0,
                  frameon=False, fontsize=kwargs.get("fontsize", 7), ncol=1 if len(seen) <= 14 else 2)


def _decimals_of(value: float, significant: int = 2) -> int:
    """Decimals that show ``value`` to ``significant`` digits (at least 2: never a bare 0.0 for a small value)."""
    if not np.isfinite(value) or value == 0:
        return 2
    return max(2, significant - 1 - int(np.floor(np.log10(abs(value)))))


def agreement(x: np.ndarray | pd.Series, y: np.ndarray | pd.Series, unit: str = "m s$^{-1}$",
              circular: bool = False) -> str:
    """"n = .., bias = .., RMSE = .. <unit>, R² = .." of y against x, at the precision that is real.

    Presentation of the plotted points only (no stored statistic is replaced). A value is
    written to two significant digits, so a small RMSE reads "0.0031", never "0.000"; R² shows
    enough decimals to tell it from 1. ``circular``: differences wrapped to ±180 (directions),
    no R².
    """
    xs, ys = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    ok = np.isfinite(xs) & np.isfinite(ys)
    n = int(ok.sum())
    if n == 0:
        return "no points"
    d = ys[ok] - xs[ok]
    if circular:
        d = (d + 180.0) % 360.0 - 180.0
    bias, rmse = float(d.mean()), float(np.sqrt(np.mean(d**2)))
    text = (f"n = {n}, bias = {bias:.{_decimals_of(bias)}f}, RMSE = {rmse:.{_decimals_of(rmse)}f} {unit}")
    if not circular and n >= 3:
        ss = float(((ys[ok] - ys[ok].mean()) ** 2).sum())
        r = float(np.corrcoef(xs[ok], ys[ok])[0, 1]) if ss > 0 and np.ptp(xs[ok]) > 0 else float("nan")
        if np.isfinite(r):
            r2 = r * r
            dec = max(2, _decimals_of(1.0 - r2, 1) if r2 < 1 else 4)
            text += f", R² = {r2:.{dec}f}"
    return text


def _one_to_one(ax: Any, x: np.ndarray | pd.Series, y: np.ndarray | pd.Series) -> None:
    v = np.concatenate([np.asarray(x, float), np.asarray(y, float)])
    v = v[np.isfinite(v)]
    hi = float(v.max()) * 1.05 if v.size else 1.0
    lo = min(0.0, float(v.min())) if v.size else 0.0
    ax.plot([lo, hi], [lo, hi], color="0.5", lw=0.8, ls="--", label="1:1")
    ax.set_xlim(lo, hi)
    ax.set_ylim(lo, hi)
    ax.set_aspect("equal")


def _scatter_by_uav(ax: Any, table: pd.DataFrame, x: str, y: str) -> None:
    for uav, g in table.groupby("uav"):
        ax.plot(g[x], g[y], "o", ms=4, label=str(uav))


def _by_path(outputs: Sequence[str | Path]) -> dict[str, Path]:
    """The PNG outputs by stem (the vector copy of each is written beside its PNG)."""
    return {Path(p).stem: Path(p) for p in outputs if Path(p).suffix == ".png"}


def _fig3_individual(win: pd.DataFrame, label: str, path: Path, note: str) -> Path:
    """Wetz et al. (2021), Fig. 3: window speeds of the individual calibration against the tower."""
    fig, ax = _figure()
    _scatter_by_uav(ax, win, "ref_speed_ms", "speed_individual_ms")
    _one_to_one(ax, win["ref_speed_ms"], win["speed_individual_ms"])
    ax.set(xlabel="tower wind speed (m s$^{-1}$)", ylabel="UAV wind speed (m s$^{-1}$)",
           title=f"individual calibration, {win['flight'].nunique()} flights, {label}\n"
                 f"{agreement(win['ref_speed_ms'], win['speed_individual_ms'])}")
    _legend(ax)
    return _save(fig, path, note)


def _fig4_regression(win: pd.DataFrame, summary: dict[str, Any], path: Path, skipped: str) -> Path:
    """Wetz et al. (2021), Fig. 4: tilt against tower speed with the stored universal law."""
    fig, ax = _figure()
    _scatter_by_uav(ax, win, "tilt_deg", "ref_speed_ms")
    curve = summary.get("regression_curve", {})
    aero = summary.get("aero", {})
    if curve:
        ax.plot(curve["tilt_deg"], curve["speed_ms"], "k-",
                label=f"c_d0A0 = {aero.get('cd0a0_m2', np.nan):.4f} m2, c_p = {aero.get('cp_m2_per_rad', np.nan):.4f}")
    ax.set(xlabel="tilt, offset-corrected (°)", ylabel="tower wind speed (m s$^{-1}$)",
           title="universal regression (Wetz et al. (2021), Eq. 18 form)")
    _legend(ax)
    note = skipped if summary.get("converged", True) else "calibration NOT converged; " + skipped
    return _save(fig, path, note)


def _fig5_validation(val: pd.DataFrame, path: Path, note: str) -> Path:
    """Wetz et al. (2021), Fig. 5: validation windows, universal law with calibrated offsets, against the tower."""
    fig, ax = _figure()
    _scatter_by_uav(ax, val, "ref_speed_ms", "uav_speed_ms")
    _one_to_one(ax, val["ref_speed_ms"], val["uav_speed_ms"])
    ax.set(xlabel="tower wind speed (m s$^{-1}$)", ylabel="UAV wind speed (m s$^{-1}$)",
           title=f"validation flights ({val['flight'].nunique()}), universal law + pitch offsets\n"
                 f"{agreement(val['ref_speed_ms'], val['uav_speed_ms'])}")
    _legend(ax)
    return _save(fig, path, note)


def _fig6_direction(val: pd.DataFrame, path: Path, note: str) -> Path:
    """Wetz et al. (2021), Fig. 6: wind direction from the corrected heading against the tower."""
    fig, ax = _figure()
    _scatter_by_uav(ax, val, "ref_from_deg", "uav_from_deg")
    ax.plot([0, 360], [0, 360], color="0.5", lw=0.8, ls="--", label="1:1")
    ticks = np.arange(0, 361, 90)
    ax.set_xticks(ticks)
    ax.set_yticks(ticks)
    ax.set(xlim=(-12, 372), ylim=(-12, 372), xlabel="tower wind direction (°)",
           ylabel="UAV wind direction (corrected yaw) (°)",
           title="wind direction with yaw offsets\n"
                 f"{agreement(val['ref_from_deg'], val['uav_from_deg'], unit='°', circular=True)}")
    _legend(ax)
    return _save(fig, path, note)


def _fig7_timeseries(l2_files: Sequence[str | Path], reference_file: str | Path, path: Path) -> Path:
    """Wetz et al. (2021), Fig. 7: 1 Hz wind of the UAVs of one flight (L2 files) and the tower's 1-min means."""
    from matplotlib.dates import DateFormatter

    from dronewind.core.products import open_product
    from dronewind.quadrotor.reference import read_tower_reference

    fig = new_figure(7.5, 6.0)
    ax_one, ax = fig.subplots(2, 1, sharex=True)
    flight, notes = "", []
    try:
        ref = read_tower_reference(reference_file)
    except InputError as exc:  # a reference held in the UAV records' own columns is no tower file
        ref = None
        notes.append(f"tower reference not drawn ({exc})")
    series = []
    for l2 in l2_files:
        ds = open_product(l2)
        flight = str(ds.attrs.get("flight", ""))
        series.append((float(ds["alt"]) if "alt" in ds else float("nan"), ds))
    series.sort(key=lambda x: x[0])
    for h, ds in series:
        usable = int(ds.attrs.get("usable", 1))
        style = {"lw": 0.7} if usable else {"lw": 0.7, "ls": ":", "color": "0.5"}
        ax.plot(ds["time"].values, ds["wind_speed_ms"].values, label=f"{ds.attrs.get('uav', '')} {h:.0f} m", **style)
        if not usable:
            notes.append(f"{ds.attrs.get('uav', '')}: {ds.attrs.get('unusable_reason', '')}")
    if series:
        h, ds = series[-1]
        k = int(np.argmin(np.abs(ref["height_m"].values - h))) if ref is not None else 0
        ax_one.plot(ds["time"].values, ds["wind_speed_ms"].values, lw=0.8, color="tab:red",
                    label=f"UAV {ds.attrs.get('uav', '')} at {h:.0f} m (1 Hz)")
        if ref is not None:
            ax_one.step(ref["time"].values, ref["wind_speed_ms"].isel(height=k).values, where="post", color="k",
                        lw=1.2, label=f"tower {float(ref['height_m'].values[k]):g} m (1-min means)")
        t = np.concatenate([d["time"].values for _, d in series])
        ax.set_xlim(t.min(), t.max())
        _legend(ax_one)
    ax_one.set(ylabel="wind speed (m s$^{-1}$)", title=f"flight {flight}: the highest UAV and the tower")
    ax.set_title("all UAVs of the flight")
    ax.set(xlabel="time (UTC)", ylabel="wind speed (m s$^{-1}$)")
    ax.xaxis.set_major_formatter(DateFormatter("%H:%M"))
    _legend(ax)
    return _save(fig, path, "; ".join(notes))


def _fig8_profiles(prof: pd.DataFrame, path: Path, note: str) -> Path:
    """Wetz et al. (2021), Fig. 8: profiles of the UAVs (error bars: their RMSE) and the tower, two flights."""
    fig, ax = _figure(5.0, 5.0)
    counts = prof.groupby("flight")["ref_height_m"].nunique().sort_values(ascending=False, kind="stable")
    for flight, style in zip(counts.index[:2], ("-", "--"), strict=False):
        g = prof[prof["flight"] == flight].sort_values("height_m")
        ax.errorbar(g["uav_speed_ms"], g["height_m"], xerr=g["rmse_ms"], fmt="o" + style, ms=4,
                    label=f"UAVs, flight {flight}")
        ax.plot(g["ref_speed_ms"], g["ref_height_m"], "k" + style, marker="s", ms=4, label=f"tower, flight {flight}")
    ax.set(xlabel="wind speed (m s$^{-1}$)", ylabel="height (m)", title="profiles (error bars: UAV RMSE, Sect. 5.3)")
    _legend(ax)
    return _save(fig, path, note)


def _fig9_variance(win: pd.DataFrame, path: Path) -> Path:
    """Wetz et al. (2021), Fig. 9 analogue: variance of 1-min mean speeds per window, UAV against tower."""
    fig, ax = _figure()
    if "var_ref_1min_m2s2" in win:
        ok = np.isfinite(win["var_ref_1min_m2s2"]) & np.isfinite(win["var_uav_1min_m2s2"])
        _scatter_by_uav(ax, win[ok], "var_ref_1min_m2s2", "var_uav_1min_m2s2")
        _one_to_one(ax, win.loc[ok, "var_ref_1min_m2s2"], win.loc[ok, "var_uav_1min_m2s2"])
        note = f"{int((~ok).sum())} window(s) without a variance" if (~ok).any() else ""
        stats = "\n" + agreement(win.loc[ok, "var_ref_1min_m2s2"], win.loc[ok, "var_uav_1min_m2s2"], "m$^2$ s$^{-2}$")
    else:
        note, stats = "no tower variance stored", ""
    ax.set(xlabel="tower variance of 1-min means (m$^2$ s$^{-2}$)",
           ylabel="UAV variance of 1-min means (m$^2$ s$^{-2}$)",
           title="wind-speed variance per window" + stats)
    _legend(ax)
    return _save(fig, path, note)


def quadrotor_figures(tables_dir: str | Path, summary_file: str | Path, l2_files: Sequence[str | Path],
                      reference_file: str | Path, outputs: Sequence[str | Path]) -> list[Path]:
    """Draw Wetz et al. (2021), Figs 3-9 from the stored quadrotor tables.

    Parameters
    ----------
    tables_dir : str or Path
        Folder with ``quadrotor_*.csv``.
    summary_file : str or Path
        ``quadrotor/calibration.json``.
    l2_files : sequence of path
        L2 files of the flight shown as time series (Fig. 7).
    reference_file : str or Path
        That flight's tower reference CSV.
    outputs : sequence of path
        PNG files, stems as in :data:`QUAD_FIGURES`.

    Returns
    -------
    list of Path
        Written files.
    """
    tdir = Path(tables_dir)
    out = _by_path(outputs)
    win = pd.read_csv(tdir / "quadrotor_windows.csv", dtype={"uav": str, "flight": str})
    prof = pd.read_csv(tdir / "quadrotor_profiles.csv", dtype={"flight": str})
    probs = pd.read_csv(tdir / "quadrotor_problems.csv", dtype=str)
    summary = json.loads(Path(summary_file).read_text())
    skipped = (f"left out: {probs[['flight', 'uav']].drop_duplicates().shape[0]} UAV log(s), see "
               "quadrotor_problems.csv") if len(probs) else ""
    label = f"{summary.get('calibration_window_s', 600):g}-s windows"
    val = win[win["validation"] == 1] if (win["validation"] == 1).any() else win
    indep = "" if summary.get("independent_validation", True) else \
        "no second-week flights: validated on the calibration flights. "
    return [_fig3_individual(win, label, out["quadrotor_fig3_individual"], skipped),
            _fig4_regression(win, summary, out["quadrotor_fig4_regression"], skipped),
            _fig5_validation(val, out["quadrotor_fig5_validation"], indep + skipped),
            _fig6_direction(val, out["quadrotor_fig6_direction"], indep + skipped),
            _fig7_timeseries(l2_files, reference_file, out["quadrotor_fig7_timeseries"]),
            _fig8_profiles(prof, out["quadrotor_fig8_profiles"], skipped),
            _fig9_variance(win, out["quadrotor_fig9_variance"])]


def _read_tunnel_table(tables_dir: Path, name: str) -> pd.DataFrame:
    """``tunnel_<name>.csv``; an empty table (run kind absent) as an empty frame."""
    path = tables_dir / f"tunnel_{name}.csv"
    try:
        return pd.read_csv(path, dtype={"uas": str})
    except pd.errors.EmptyDataError:
        return pd.DataFrame()


def _tunnel_fig4_sideslip(side: pd.DataFrame, path: Path) -> Path:
    """Kistner et al. (2024), Fig. 4: RMSE of the UAS speed over the CTA speed per angle of sideslip."""
    fig, ax = _figure()
    note = ""
    if len(side) and "speed_bin_ms" in side:
        s = side[side["speed_bin_ms"].notna()]
        for aos, g in s.groupby("aos_deg"):
            ax.plot(g["speed_bin_ms"], g["rmse_ms"], "o-", ms=3, label=f"AoS {aos:g}°")
        _legend(ax)
    else:
        note = "no sideslip runs"
    ax.set(xlabel="CTA wind speed (m s$^{-1}$)", ylabel="RMSE of the UAS speed (m s$^{-1}$)", title="angle of sideslip")
    return _save(fig, path, note)


def _tunnel_fig5_portability(acc: pd.DataFrame, path: Path) -> Path:
    """Kistner et al. (2024), Fig. 5: speed error of each UAS per step (absolute value of the stored error)."""
    fig, ax = _figure()
    po = acc[acc["kind"] == "portability"] if len(acc) else acc
    note = "" if len(po) else "no portability runs"
    for uas, g in (po.groupby("uas") if len(po) else []):
        g = g.sort_values("cta_ms")
        ax.plot(g["cta_ms"], np.abs(g["error_ms"]), "o-", ms=3, label=str(uas))
    if len(po):
        _legend(ax)
    ax.set(xlabel="CTA wind speed (m s$^{-1}$)", ylabel="|UAS - CTA| per step (m s$^{-1}$)",
           title="portability of the calibration")
    return _save(fig, path, note)


def _tunnel_fig6_gusts(gs: pd.DataFrame, path: Path) -> Path:
    """Kistner et al. (2024), Fig. 6: gust RMSE at V0 and at the peak Vp per preset."""
    fig, ax = _figure()
    note = "" if len(gs) else "no gust runs"
    if len(gs):
        lab = [f"{a:g}/{b:g}" for a, b in zip(gs["v0_set_ms"], gs["vg_set_ms"], strict=True)]
        x = np.arange(len(gs))
        ax.plot(x, gs["rmse_v0_ms"], "o-", label="V0")
        ax.plot(x, gs["rmse_vp_ms"], "s-", label="Vp")
        ax.set_xticks(x, lab, rotation=45, fontsize=7)
        _legend(ax)
    ax.set(xlabel="preset V0 / Vg (m s$^{-1}$)", ylabel="RMSE (m s$^{-1}$)", title="IEC gusts")
    return _save(fig, path, note)


def _tunnel_fig7_steps(ss: pd.DataFrame, path: Path) -> Path:
    """Kistner et al. (2024), Fig. 7: velocity-step RMSEs per preset."""
    fig, ax = _figure()
    note = "" if len(ss) else "no velocity-step runs"
    if len(ss):
        lab = [f"{a:g}+{b:g}" for a, b in zip(ss["v0_set_ms"], ss["vdu_set_ms"], strict=True)]
        x = np.arange(len(ss))
        for col, mk, name in (("rmse_v_high_ms", "o-", "V_h"), ("rmse_v_low_ms", "s-", "V_l"),
                              ("rmse_dv_up_ms", "^-", "dV_u"), ("rmse_dv_down_ms", "v-", "dV_d")):
            ax.plot(x, ss[col], mk, label=name)
        ax.set_xticks(x, lab, fontsize=7)
        _legend(ax)
    ax.set(xlabel="preset V_l + dV (m s$^{-1}$)", ylabel="RMSE (m s$^{-1}$)", title="velocity steps")
    return _save(fig, path, note)


def _tunnel_fig9_variance(tb: pd.DataFrame, path: Path) -> Path:
    """Kistner et al. (2024), Fig. 9: UAS variance against the CTA's, at full and cut bandwidth."""
    fig, ax = _figure()
    note = "" if len(tb) else "no turbulence runs"
    if len(tb):
        ax.plot(tb["var_cta_full"], tb["var_uas"], "ko", ms=4, label="CTA at its own rate")
        ax.plot(tb["var_cta_cut_fmax"], tb["var_uas"], "ro", ms=4, label="CTA cut at the UAS's f_max")
        _one_to_one(ax, np.r_[tb["var_cta_full"], tb["var_cta_cut_fmax"]], tb["var_uas"])
        _legend(ax)
        stats = "\ncut bandwidth: " + agreement(tb["var_cta_cut_fmax"], tb["var_uas"], "m$^2$ s$^{-2}$")
    else:
        stats = ""
    ax.set(xlabel="CTA variance (m$^2$ s$^{-2}$)", ylabel="UAS variance (m$^2$ s$^{-2}$)",
           title="turbulence variance" + stats)
    return _save(fig, path, note)


def tunnel_figures(tables_dir: str | Path, outputs: Sequence[str | Path]) -> list[Path]:
    """Draw Kistner et al. (2024), Figs 4-7 and 9 from the stored tunnel tables.

    Parameters
    ----------
    tables_dir : str or Path
        Folder with ``tunnel_*.csv``.
    outputs : sequence of path
        PNG files, stems as in :data:`TUNNEL_FIGURES`.

    Returns
    -------
    list of Path
        Written files; a table that is empty (run kind absent) gives a figure that says so.
    """
    tdir = Path(tables_dir)
    out = _by_path(outputs)
    return [_tunnel_fig4_sideslip(_read_tunnel_table(tdir, "sideslip"), out["tunnel_fig4_sideslip"]),
            _tunnel_fig5_portability(_read_tunnel_table(tdir, "steps_accuracy"), out["tunnel_fig5_portability"]),
            _tunnel_fig6_gusts(_read_tunnel_table(tdir, "gust_summary"), out["tunnel_fig6_gusts"]),
            _tunnel_fig7_steps(_read_tunnel_table(tdir, "step_summary"), out["tunnel_fig7_steps"]),
            _tunnel_fig9_variance(_read_tunnel_table(tdir, "turbulence"), out["tunnel_fig9_variance"])]
