"""The diagnosis report: Markdown text and figures, from the stored diagnosis results."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dronewind.diagnose.features import FEATURES

__all__ = ["markdown", "figures", "FEATURE_LABELS"]

#: Human-readable feature names (units in brackets).
FEATURE_LABELS: dict[str, str] = {
    "ln_sigma_ratio_u": "ln(σu drone / σu mast) [-]",
    "ln_sigma_ratio_v": "ln(σv drone / σv mast) [-]",
    "ln_sigma_ratio_w": "ln(σw drone / σw mast) [-]",
    "ln_speed_ratio": "ln(U drone / U mast) [-]",
    "dir_diff_deg": "direction drone − mast [°]",
    "tilt_diff_deg": "streamline tilt drone − mast [°]",
    "sw_su_drone": "<Sw/Su> drone, 2<fr<10 [-]",
    "sw_su_mast": "<Sw/Su> mast, 2<fr<10 [-]",
    "ln_pendulum_w": "ln(w power drone/mast, 0.08–0.17 Hz) [-]",
    "ln_hf_u": "ln(u power drone/mast, 1.5–3 Hz) [-]",
    "ln_hf_w": "ln(w power drone/mast, 1.5–3 Hz) [-]",
    "lag_sonic_ins_s": "sonic–INS lag [s]",
    "lag_drift_s": "lag 2nd − 1st half [s]",
    "corr_wres_pitch_rate": "corr(w drone − w mast, pitch rate) [-]",
    "corr_wres_roll_rate": "corr(w drone − w mast, roll rate) [-]",
}


def _fmt(value: Any, digits: int = 3) -> str:
    if value is None:
        return "–"
    try:
        v = float(value)
    except (TypeError, ValueError):
        return str(value)
    return "–" if not np.isfinite(v) else f"{v:.{digits}g}"


def _named_summary(mechanism: str, entry: Mapping[str, Any]) -> str:
    """One named cause as "`name` (p = est ± unc; held-out gain g)"."""
    uncertainty = entry.get("uncertainty") or {}
    parts = [f"{key} = {_fmt(value)} ± {_fmt(uncertainty.get(key, float('nan')), 2)}"
             for key, value in entry["estimate"].items()]
    return f"`{mechanism}` ({', '.join(parts)}; held-out gain {_fmt(entry['gain'], 2)})"


def markdown(diag: Mapping[str, Any], before: Mapping[str, float], after: Mapping[str, float],
             rows: Sequence[Mapping[str, Any]]) -> str:
    """The report as Markdown.

    Parameters
    ----------
    diag : mapping
        ``diagnosis.json`` content.
    before, after : mapping
        Misfit metrics of the baseline and of the rerun extended model.
    rows : sequence of mapping
        Per-flight residual rows (:func:`dronewind.diagnose.campaign.residual_table`).

    Returns
    -------
    str
        Markdown text.
    """
    lines = [f"# Diagnosis of campaign {diag.get('campaign')}", ""]
    named = diag.get("named_causes") or []
    if diag.get("note"):
        lines += [f"**No diagnosis:** {diag['note']}", ""]
    if named:
        lines.append("**Named cause(s):** " + ", ".join(_named_summary(m, diag["named_estimates"][m]) for m in named))
    else:
        lines.append("**No mechanism is significant:** the forward model without any mechanism explains the "
                     "measured drone–mast differences within their sampling errors.")
    lines += ["", "## What the baseline simulation gets wrong", "",
              "The forward model without any mechanism was run for every flight with the conditions measured "
              "by the reference mast (mean wind, direction, temperature, u*, Obukhov length) and the drone's hover "
              "height, position and window, and processed exactly like the data. Residual = measured − "
              "predicted; z = residual / sampling error (seed 000, Eqs 10-13, scaled by the spread of the "
              "forward model's seeds).", ""]
    metrics = (diag.get("baseline") or {}).get("metrics") or {}
    lines += [f"- misfit χ² = {_fmt(metrics.get('chi2'))} over {metrics.get('n_features_used', '–')} features "
              f"(χ²/feature = {_fmt(metrics.get('chi2_per_feature'))}; ≈ 1 when the model is right)",
              f"- RMSE of σw drone/mast ratio, measured vs predicted: {_fmt(metrics.get('sigma_w_ratio_rmse'))}", ""]
    slopes = (diag.get("baseline") or {}).get("wind_speed_slopes") or {}
    lines += ["| feature | mean measured | mean predicted | mean z | max abs z | slope of residual vs U [per m/s] |",
              "|---|---|---|---|---|---|"]
    for feat in FEATURES:
        sel = [r for r in rows if r["feature"] == feat]
        meas = np.array([r["measured"] for r in sel], dtype=float)
        pred = np.array([r["predicted"] for r in sel], dtype=float)
        z = np.array([r["z"] for r in sel], dtype=float)
        lines.append(f"| {FEATURE_LABELS.get(feat, feat)} | {_fmt(np.nanmean(meas) if np.isfinite(meas).any() else np.nan)} "
                     f"| {_fmt(np.nanmean(pred) if np.isfinite(pred).any() else np.nan)} "
                     f"| {_fmt(np.nanmean(z) if np.isfinite(z).any() else np.nan, 2)} "
                     f"| {_fmt(np.nanmax(np.abs(z)) if np.isfinite(z).any() else np.nan, 2)} | {_fmt(slopes.get(feat))} |")
    lines += ["", "## Candidates (fitted on all flights, scored leaving one flight out)", "",
              "| mechanism | estimate | uncertainty | held-out gain | LR p-value | significant |", "|---|---|---|---|---|---|"]
    for c in diag.get("candidates") or []:
        est = ", ".join(f"{k} = {_fmt(v)}" for k, v in c["estimate"].items())
        unc = ", ".join(f"{k} ± {_fmt(v, 2)}" for k, v in c["uncertainty"].items())
        lines.append(f"| `{c['mechanism']}` | {est} | {unc} | {_fmt(c['gain'], 3)} | {_fmt(c['p_value'], 2)} "
                     f"| {'yes' if c['significant'] else 'no'} |")
    amb = diag.get("ambiguity_sets") or []
    lines += ["", "## Ambiguity", ""]
    lines.append("Mechanisms the data cannot tell apart (their fitted predictions differ by less than 2σ): "
                 + "; ".join("{" + ", ".join(f"`{m}`" for m in g) + "}" for g in amb) if amb else
                 "No two significant candidates predict the same features within their errors.")
    lines += ["", "## The extended model", ""]
    mechs = ((diag.get("extended") or {}).get("mechanisms")) or []
    if mechs:
        lines.append("Named mechanisms added to the campaign's simulation (`diagnosis/extended_campaign.yaml`): "
                     + "; ".join(f"`{m['mechanism']}` {m['parameters']}" for m in mechs) + ". Every flight was "
                     "rerun with them (new seeds) and processed again:")
    else:
        lines.append("Nothing was added; the rerun below repeats the baseline with new seeds (a check of the "
                     "sampling errors):")
    lines += ["", "| metric | baseline | extended model (rerun) |", "|---|---|---|"]
    for key in ("chi2", "chi2_per_feature", "sigma_w_ratio_rmse", "sigma_u_ratio_rmse", "sigma_v_ratio_rmse"):
        lines.append(f"| {key} | {_fmt(before.get(key))} | {_fmt(after.get(key))} |")
    lines += ["", "## Method", "", str(diag.get("method", "")),
              "Significance: a candidate must lower the misfit of the fitted flights by more than the 1 − 0.01/M "
              "quantile of χ² with k degrees of freedom (k parameters, M mechanisms tried) and lower the misfit of "
              "flights left out of the fit. A second cause is named only if it is significant on what the first "
              "leaves unexplained.", ""]
    return "\n".join(lines) + "\n"


def figures(ev: Any, after: np.ndarray | None, diag: Mapping[str, Any], out_dir: Path) -> list[Path]:
    """Residuals against wind speed, before (baseline) and after (extended model).

    Parameters
    ----------
    ev : CampaignEvidence
        Evidence arrays.
    after : numpy.ndarray or None
        Rerun extended-model features (flights x features).
    diag : mapping
        ``diagnosis.json`` content.
    out_dir : Path
        Folder for ``diagnosis_residuals.png``/``.pdf``.

    Returns
    -------
    list of Path
        Written files.
    """
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    from dronewind.figures.payload import save_figure

    speed = np.array([c.get("mean_speed_ms", np.nan) for c in ev.conditions], dtype=float)
    feats = ["ln_sigma_ratio_w", "ln_sigma_ratio_u", "sw_su_drone", "sw_su_mast", "dir_diff_deg",
             "tilt_diff_deg", "lag_sonic_ins_s", "ln_pendulum_w", "ln_hf_w"]
    fig = Figure(figsize=(12, 10), dpi=100)
    axes = fig.subplots(3, 3)
    for ax, feat in zip(axes.ravel(), feats, strict=True):
        j = FEATURES.index(feat)
        if ev.flights:
            r0 = ev.y[:, j] - ev.baseline[:, j]
            ax.errorbar(speed, r0, yerr=ev.sigma[:, j], fmt="o", color="tab:red", label="baseline", capsize=2)
        if ev.flights and after is not None and np.isfinite(after[:, j]).any():
            r1 = ev.y[:, j] - after[:, j]
            ax.errorbar(speed + 0.1, r1, yerr=ev.sigma[:, j], fmt="s", color="tab:blue", label="extended model",
                        capsize=2)
        ax.axhline(0, color="k", lw=0.8)
        ax.set_xlabel("mast mean wind speed [m s$^{-1}$]")
        ax.set_ylabel("measured − predicted")
        ax.set_title(FEATURE_LABELS[feat], fontsize=9)
        ax.grid(alpha=0.3)
    if ev.flights:
        axes[0, 0].legend(fontsize=8)
    named = ", ".join(diag.get("named_causes") or []) or "none"
    note = "" if ev.flights else " (no usable flight)"
    fig.suptitle(f"Diagnosis of {diag.get('campaign')}: residuals before and after (named: {named}){note}")
    fig.tight_layout()
    return save_figure(fig, out_dir / "diagnosis_residuals", [note.strip(" ()")] if note else ())


def spectra_figure(ev: Any, measured: Mapping[str, Mapping[str, Any]], model: Mapping[str, Mapping[str, Any]],
                   diag: Mapping[str, Any], out_dir: Path, n_flights: int = 3) -> list[Path]:
    """Drone and mast spectra of u and w, measured against the model before and after.

    For up to ``n_flights`` flights spread over the wind-speed range (lowest, middle,
    highest mast wind speed): premultiplied spectra :math:`f S(f)` of the measured drone
    and mast and of the forward model without (baseline) and with the named mechanisms
    (extended; the same seed, so the difference is the mechanisms' effect).

    Parameters
    ----------
    ev : CampaignEvidence
    measured : mapping
        Flight -> ``binned_spectra`` of the measured flight.
    model : mapping
        Flight -> ``{"baseline": spectra, "extended": spectra}``.
    diag : mapping
        ``diagnosis.json`` content.
    out_dir : Path
        Folder for ``diagnosis_spectra.png``/``.pdf``.

    Returns
    -------
    list of Path
    """
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    from dronewind.figures.payload import save_figure

    flights = [f for f in ev.flights if f in measured and f in model]
    speed = {f: c.get("mean_speed_ms", np.nan) for f, c in zip(ev.flights, ev.conditions, strict=True)}
    flights.sort(key=lambda f: speed[f])
    if len(flights) > n_flights:
        pick = np.unique(np.linspace(0, len(flights) - 1, n_flights).round().astype(int))
        flights = [flights[i] for i in pick]
    fig = Figure(figsize=(11, 3.4 * max(len(flights), 1)), dpi=100)
    axes = np.atleast_2d(fig.subplots(max(len(flights), 1), 2))
    notes = [] if flights else ["no flight with stored spectra"]
    for row, flight in zip(axes, flights, strict=False):
        for ax, comp in zip(row, ("u", "w"), strict=True):
            m = measured[flight]
            f = np.asarray(m["f_hz"])
            ax.loglog(f, f * np.asarray(m[f"drone_{comp}"]), color="k", lw=1.4, label="measured drone")
            ax.loglog(f, f * np.asarray(m[f"mast_{comp}"]), color="0.6", lw=1.0, label="measured mast")
            for key, colour in (("baseline", "tab:red"), ("extended", "tab:blue")):
                s = model[flight].get(key)
                if s:
                    fm = np.asarray(s["f_hz"])
                    ax.loglog(fm, fm * np.asarray(s[f"drone_{comp}"]), color=colour, lw=1.0,
                              ls="--" if key == "baseline" else "-", label=f"{key} model drone")
            ax.set_title(f"{flight}, U = {speed[flight]:.1f} m/s: $fS_{comp}$", fontsize=9)
            ax.set_xlabel("f [Hz]")
            ax.set_ylabel(f"$fS_{comp}$ [m$^2$ s$^{{-2}}$]")
            ax.grid(alpha=0.3, which="both")
    if flights:
        axes[0, 0].legend(fontsize=7)
    named = ", ".join(diag.get("named_causes") or []) or "none"
    fig.suptitle(f"Diagnosis of {diag.get('campaign')}: spectra, measured vs model before/after (named: {named})")
    fig.tight_layout()
    return save_figure(fig, out_dir / "diagnosis_spectra", notes)
