"""The diagnosis report as Markdown, from the stored diagnosis results.

The report's figures are drawn by :mod:`dronewind.figures.diagnosis` (called by the
workflow step :func:`dronewind.steps.diagnosis.diagnosis_report`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from dronewind.diagnose.features import FEATURES

__all__ = ["markdown", "FEATURE_LABELS"]

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


def _fit_lines(diag: Mapping[str, Any]) -> list[str]:
    """Goodness of fit of the model with the named causes, and what it still misses."""
    gof = diag.get("goodness_of_fit") or {}
    out = []
    if gof:
        out.append(f"**Goodness of fit** (model with the named causes): χ² = {_fmt(gof.get('chi2'))} for "
                   f"{gof.get('dof', '–')} degrees of freedom, p = {_fmt(gof.get('p_value'), 2)}.")
    missed = diag.get("unexplained")
    if missed:
        out += ["", "**Unexplained residual:** the model with the named causes still misses these features "
                "(model error that no catalog mechanism describes; not named as a cause):", "",
                "| feature | mean z | slope vs U [per m/s] | p (mean) | p (slope) | flights |",
                "|---|---|---|---|---|---|"]
        out += [f"| {FEATURE_LABELS.get(m['feature'], m['feature'])} | {_fmt(m['mean_z'], 2)} | "
                f"{_fmt(m['slope_per_ms'])} | {_fmt(m['p_mean'], 2)} | {_fmt(m['p_slope'], 2)} | {m['n_flights']} |"
                for m in missed]
    elif missed is not None:
        out.append("Nothing is left unexplained: no feature's mean residual or trend with wind speed is "
                   "significant (Bonferroni over features).")
    return out


def _candidate_lines(diag: Mapping[str, Any]) -> list[str]:
    """The candidate table and the ambiguity sets of the report."""
    lines: list[str] = []
    lines += ["", "## Candidates (fitted on all flights, scored leaving one flight out)", "",
              "| mechanism | estimate | uncertainty | held-out gain | LR p-value | significant |",
              "|---|---|---|---|---|---|"]
    for c in diag.get("candidates") or []:
        est = ", ".join(f"{k} = {_fmt(v)}" for k, v in c["estimate"].items())
        unc = ", ".join(f"{k} ± {_fmt(v, 2)}" for k, v in c["uncertainty"].items())
        lines.append(f"| `{c['mechanism']}` | {est} | {unc} | {_fmt(c['gain'], 3)} | {_fmt(c['p_value'], 2)} "
                     f"| {'yes' if c['significant'] else 'no'} |")
    amb = diag.get("ambiguity_sets") or []
    lines += ["", "## Ambiguity", ""]
    for c in diag.get("caveats") or []:
        lines += [f"**Caveat on `{c['mechanism']}`:** {c['alias']} (an effect outside the catalog; the data "
                  "alone cannot tell them apart).", ""]
    for w in diag.get("withheld") or []:
        est = ", ".join(f"{k} = {_fmt(v)}" for k, v in w["estimate"].items())
        lines += [f"**Not named: `{w['mechanism']}`** ({est}, LR p-value {_fmt(w['p_value'], 2)}): "
                  f"{100 * w['share']:.0f} % of the misfit it would remove is in `{w['feature']}`, and {w['alias']} "
                  "(an effect outside the catalog); that misfit is left unexplained.", ""]
    lines.append("Mechanisms the data cannot tell apart (their fitted predictions differ by less than 2σ): "
                 + "; ".join("{" + ", ".join(f"`{m}`" for m in g) + "}" for g in amb) if amb else
                 "No two significant candidates predict the same features within their errors.")
    return lines


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
        lines.append("**No mechanism is significant:** no catalog mechanism explains the measured drone–mast "
                     "differences better than the forward model without one.")
    lines += ["", *_fit_lines(diag)]
    lines += ["", "## What the baseline simulation gets wrong", "",
              "The forward model without any mechanism was run for every flight with the conditions measured "
              "by the reference mast (mean wind, direction, temperature, u*, Obukhov length) and the drone's hover "
              "height, position and window, and processed exactly like the data. Residual = measured − "
              "predicted; z = residual / sampling error (Ghirardelli et al. 2025, Eqs 10-13, scaled by the "
              "spread of the forward model's seeds).", ""]
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
        mean_meas = np.nanmean(meas) if np.isfinite(meas).any() else np.nan
        mean_pred = np.nanmean(pred) if np.isfinite(pred).any() else np.nan
        mean_z = np.nanmean(z) if np.isfinite(z).any() else np.nan
        max_abs_z = np.nanmax(np.abs(z)) if np.isfinite(z).any() else np.nan
        lines.append(f"| {FEATURE_LABELS.get(feat, feat)} | {_fmt(mean_meas)} | {_fmt(mean_pred)} "
                     f"| {_fmt(mean_z, 2)} | {_fmt(max_abs_z, 2)} | {_fmt(slopes.get(feat))} |")
    lines += _candidate_lines(diag)
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
