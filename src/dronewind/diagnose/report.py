"""The diagnosis report as Markdown, from the stored diagnosis results.

The report's figures are drawn by :mod:`dronewind.figures.diagnosis` (called by the
workflow step :func:`dronewind.steps.diagnosis.diagnosis_report`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from dronewind.core.verdict import misfit_rows, verdict
from dronewind.diagnose.evidence import PROCESSING_LAG_KEY
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
    """Goodness of fit of the fitted model (:func:`dronewind.core.verdict.verdict`), and what it still misses."""
    v = verdict(diag)
    head, _, rest = v.fit.partition(":")
    out = [f"**{head}:**{rest}"] if v.fit else []
    missed = diag.get("unexplained")
    if missed:
        out += ["", "**Unexplained residual:** the model still misses these features (model error that no catalog "
                "mechanism describes; not named as a cause). Offset and trend are family-wise bootstrap p-values; "
                "the discrepancy is the scatter across flights beyond sampling error (95 % interval):", "",
                "| feature | offset z | slope vs U [per m/s] | p (offset) | p (trend) | discrepancy sd (95 %) "
                "| p (discrepancy) | flights |",
                "|---|---|---|---|---|---|---|---|"]
        for m in missed:
            ci = m.get("discrepancy_ci95") or [None, None]
            out.append(f"| {FEATURE_LABELS.get(m['feature'], m['feature'])} | {_fmt(m['mean_z'], 2)} | "
                       f"{_fmt(m['slope_per_ms'])} | {_fmt(m.get('p_mean'), 2)} | {_fmt(m.get('p_slope'), 2)} | "
                       f"{_fmt(m.get('discrepancy_sd'), 2)} ({_fmt(ci[0], 2)}–{_fmt(ci[1], 2)}) | "
                       f"{_fmt(m.get('p_discrepancy'), 2)} | {m.get('n_flights', '–')} |")
    elif missed is not None:
        out += ["", "**Nothing remains unexplained:** no feature's offset, trend with wind speed or scatter across "
                "flights exceeds sampling error (family-wise over the features)."]
    return out


def _error_model_lines(diag: Mapping[str, Any]) -> list[str]:
    """The error model: seeds, shrinkage, discrepancy, reference distributions, measured conditions."""
    em = diag.get("error_model") or {}
    if not em:
        return []
    out = ["", "## Error model", "",
           f"- baseline seeds per flight: {em.get('n_seeds', '–')} (pooled degrees of freedom {em.get('dof', '–')}); "
           f"feature correlation shrunk toward the identity with intensity {_fmt(em.get('shrinkage_intensity'), 2)}",
           f"- reference distributions: {(em.get('reference') or {}).get('method', '–')}"
           + (f", {em['reference']['replicates']} replicates" if (em.get("reference") or {}).get("replicates")
              else "")]
    payload = em.get("forward_payload") or {}
    out.append("- payload of the forward runs: " + (", ".join(f"{k} = {_fmt(v)}" for k, v in sorted(payload.items()))
                                                    + " (diagnosis.forward_payload), SAMURAI-S defaults otherwise"
                                                    if payload else "the simulator's SAMURAI-S defaults"))
    disc = (em.get("discrepancy") or {}).get("per_feature") or {}
    nonzero = {f: d for f, d in disc.items() if d.get("tau")}
    out.append("- model discrepancy (scatter across flights beyond sampling error, in every candidate test): "
               + ("; ".join(f"{f} {_fmt(d['tau'], 2)} ({_fmt(d['ci95'][0], 2)}–{_fmt(d['ci95'][1], 2)})"
                            for f, d in nonzero.items()) if nonzero else "none estimated above zero"))
    cond = diag.get("measured_conditions") or {}
    keys = sorted({k for values in cond.values() for k in values})
    for key in keys:
        what = ("the sonic-INS processing lag the forward runs estimated from the measured lag, the chain's "
                "bias removed" if key == PROCESSING_LAG_KEY else
                "taken by the forward runs as measured, not evidence")
        out.append(f"- measured condition `{key}` ({what}): "
                   + ", ".join(f"{f} {_fmt(values.get(key))}" for f, values in cond.items()))
    return out


def _candidate_lines(diag: Mapping[str, Any]) -> list[str]:
    """The candidate table, the candidates not identified and the ambiguity sets of the report."""
    lines: list[str] = []
    lines += ["", "## Candidates (fitted on all flights, scored leaving one flight out)", "",
              "| mechanism | estimate | uncertainty | held-out gain | family-wise p | significant |",
              "|---|---|---|---|---|---|"]
    for c in diag.get("candidates") or []:
        est = ", ".join(f"{k} = {_fmt(v)}" for k, v in c["estimate"].items())
        unc = ", ".join(f"{k} ± {_fmt(v, 2)}" for k, v in c["uncertainty"].items())
        sig = "at bound: not identified" if c.get("at_bound") else ("yes" if c["significant"] else "no")
        lines.append(f"| `{c['mechanism']}` | {est} | {unc} | {_fmt(c['gain'], 3)} | {_fmt(c['p_value'], 2)} "
                     f"| {sig} |")
    nid = diag.get("not_identified") or []
    if nid:
        lines += ["", "**Significant but not named:** "
                  + "; ".join(f"`{n['mechanism']}` ({', '.join(f'{k} = {_fmt(v)}' for k, v in n['estimate'].items())}):"
                              f" {n['reason']}" for n in nid)]
    lines += ["", "## Ambiguity", ""]
    for c in verdict(diag).caveats:
        lines += [c, ""]
    for w in diag.get("withheld") or []:
        est = ", ".join(f"{k} = {_fmt(v)}" for k, v in w["estimate"].items())
        lines += [f"**Not named: `{w['mechanism']}`** ({est}, family-wise p {_fmt(w['p_value'], 2)}): "
                  f"{100 * w['share']:.0f} % of the misfit it would remove is in `{w['feature']}`, and {w['alias']} "
                  "(an effect outside the catalog); that misfit is left unexplained.", ""]
    if diag.get("named_causes") and not diag.get("ambiguity"):
        lines.append("No other mechanism's responses reproduce the named causes' effects (cosine below 0.9).")
    elif diag.get("ambiguity"):
        lines.append("Cosine of the whitened probe responses of each equally possible explanation and the named "
                     "cause: " + "; ".join(f"`{a['named']}` and `{a['mechanism']}` ({_fmt(a['cosine'], 3)})"
                                           for a in diag["ambiguity"]) + ".")
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
    head = verdict(diag).headline
    if diag.get("note") and not head.startswith("Not diagnosed"):
        lines += [f"**Note:** {diag['note']}", ""]
    label, _, rest = head.partition(":")
    lines.append(f"**{label}:**{rest}")
    if diag.get("unusable"):
        reasons = diag.get("unusable_reasons") or {}
        lines += ["", "**Flights left out (unusable):** " + "; ".join(
            f"{f} ({reasons[f]})" if reasons.get(f) else f for f in diag["unusable"]) + "."]
    lines += ["", *_fit_lines(diag), *_error_model_lines(diag)]
    lines += ["", "## What the baseline simulation gets wrong", "",
              "The forward model without any mechanism was run for every flight with the conditions measured "
              "by the reference mast (mean wind, direction, temperature, u*, Obukhov length) and the drone's hover "
              "height, position and window, and processed exactly like the data. Residual = measured − "
              "predicted; z = residual / sampling error (Ghirardelli et al. 2025, Eqs 10-13, scaled by the "
              "spread of the forward model's seeds).", ""]
    metrics = (diag.get("baseline") or {}).get("metrics") or {}  # the numbers of diagnosis.json, never recomputed
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
    lines += ["", "| metric | baseline | extended model (as fitted) | extended model rerun with new seeds (a check) |",
              "|---|---|---|---|"]
    for key, label, base, fitted in misfit_rows(diag):
        lines.append(f"| {label} | {_fmt(base)} | {_fmt(fitted)} | {_fmt(after.get(key))} |")
    lines += ["", "## Method", "", str(diag.get("method", "")),
              "Significance: a candidate's likelihood-ratio statistic (misfit drop on the fitted flights, with the "
              "sampling covariance and the model discrepancy) is compared with its distribution under the model "
              "without a cause, from a parametric bootstrap over seeds that repeats every estimate; the family-wise "
              "p-value over the round's candidates (Westfall-Young min-p) must be below the false-alarm rate and "
              "the held-out gain must reach diagnosis.min_gain. A further cause is named only if it raises the "
              "held-out gain by more than that rise's uncertainty on what the causes before it leave.", ""]
    return "\n".join(lines) + "\n"
