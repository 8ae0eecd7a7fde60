r"""Goodness of fit and ``unexplained``: what the model, with the named causes, still misses.

The goodness of fit compares a prediction with the flights against the sampling error alone;
``unexplained`` tests every feature's residuals for a common offset and a trend with wind
speed (family-wise over all features and both tests, Westfall and Young 1993) and reports its
model discrepancy (DerSimonian and Laird 1986; Kennedy and O'Hagan 2001). Both are referred to
the parametric bootstrap over seeds of :func:`dronewind.diagnose.reference.null_reference`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.stats

from dronewind.diagnose.calibration import UNEXPLAINED_ALPHA, discrepancy
from dronewind.diagnose.evidence import CampaignEvidence, finite_or_none
from dronewind.diagnose.features import FEATURES
from dronewind.diagnose.fitting import (
    chi2,
)
from dronewind.diagnose.reference import empirical_p, familywise_p, mc_standard_error, offset_trend_z

if TYPE_CHECKING:
    from dronewind.diagnose.naming import DiagnosisResult

__all__ = ["baseline_metrics", "goodness_of_fit", "unexplained_features", "residual_table", "wind_speed_slopes",
           "summarise"]

def _ratio_rmse(ev: CampaignEvidence, prediction: np.ndarray, feature: str) -> float:
    j = FEATURES.index(feature)
    a = np.exp(ev.y[:, j])
    b = np.exp(prediction[:, j])
    ok = np.isfinite(a) & np.isfinite(b)
    return float(np.sqrt(np.mean((a[ok] - b[ok]) ** 2))) if ok.any() else float("nan")


def baseline_metrics(ev: CampaignEvidence, prediction: np.ndarray | None = None) -> dict[str, float]:
    """Misfit summaries of a prediction (the baseline when ``prediction`` is None)."""
    pred = ev.baseline if prediction is None else prediction
    per_flight = chi2(ev.y, pred, ev.sigma, ev.whitener())
    n_feat = int(np.sum(np.isfinite(ev.y) & np.isfinite(ev.sigma) & np.isfinite(pred)))
    return {
        "chi2": float(per_flight.sum()),
        "chi2_per_feature": float(per_flight.sum() / max(n_feat, 1)),
        "n_features_used": n_feat,
        "sigma_w_ratio_rmse": _ratio_rmse(ev, pred, "ln_sigma_ratio_w"),
        "sigma_u_ratio_rmse": _ratio_rmse(ev, pred, "ln_sigma_ratio_u"),
        "sigma_v_ratio_rmse": _ratio_rmse(ev, pred, "ln_sigma_ratio_v"),
    }


def goodness_of_fit(ev: CampaignEvidence, prediction: np.ndarray, n_parameters: int,
                    result: DiagnosisResult | None = None, baseline: bool = False) -> dict[str, Any]:
    """Goodness of fit of a prediction (the baseline or the extended model) against the sampling error.

    Parameters
    ----------
    ev : CampaignEvidence
        Measured features and their residual errors.
    prediction : numpy.ndarray
        Predicted features, (n_flights, n_features).
    n_parameters : int
        Parameters fitted to obtain the prediction (0 for the baseline).
    result : DiagnosisResult, optional
        The diagnosis: with its bootstrap reference the p-value is the share of replicates
        (the named causes refitted on each) whose misfit is at least this one.
    baseline : bool
        The prediction is the baseline (its reference is the replicates' baseline misfit).

    Returns
    -------
    dict
        ``chi2``, ``dof`` (finite residuals minus fitted parameters), ``chi2_per_dof``,
        ``p_value`` (bootstrap, or the chi-square upper tail without a reference) with
        ``p_mc_se`` (its Monte-Carlo standard error, bootstrap only),
        ``reference`` and ``reference_mean`` (the mean misfit a correct model gives).

    Notes
    -----
    .. math:: \\chi^2 = \\sum_i z_i^\\top R^{*-1} z_i, \\qquad
              z_{i,f} = \\frac{y_{i,f} - \\hat y_{i,f}}{\\sigma_{i,f}}

    against the sampling error alone (no discrepancy): it answers whether the model, with the
    named causes, reproduces the flights to within their sampling error. A small p-value says
    it does not (model error: see ``unexplained``); a p-value near 1 says the misfit is smaller
    than sampling error alone makes likely.
    """
    per = chi2(ev.y, prediction, ev.sigma, ev.sampling_whitener())
    n = int(np.sum(np.isfinite(ev.y) & np.isfinite(ev.sigma) & (ev.sigma > 0) & np.isfinite(prediction)))
    dof = max(n - int(n_parameters), 1)
    value = float(per.sum())
    out: dict[str, Any] = {"chi2": value, "dof": dof, "chi2_per_dof": value / dof}
    ref = None if result is None else result.reference
    if ref is None:
        out.update({"p_value": float(scipy.stats.chi2.sf(value, dof)), "reference": "chi-square"})
        return out
    if baseline or not result.named:  # type: ignore[union-attr]
        reps = ref.gof
    else:
        idx = np.arange(len(ev.flights))
        reps = ref.extended_gof([(ev.models[c], idx) for c, _ in result.named])  # type: ignore[union-attr]
    p_value = empirical_p(value, reps)
    out.update({"p_value": p_value, "p_mc_se": mc_standard_error(p_value, int(reps.size)),
                "reference": "parametric bootstrap over seeds",
                "reference_mean": float(np.mean(reps)), "replicates": int(reps.size)})
    return out


def unexplained_features(ev: CampaignEvidence, prediction: np.ndarray, alpha: float = UNEXPLAINED_ALPHA,
                         result: DiagnosisResult | None = None) -> list[dict[str, Any]]:
    """Features the prediction still misses: an offset, a trend with wind speed, or a discrepancy.

    Parameters
    ----------
    ev : CampaignEvidence
        Measured features, errors and flight conditions.
    prediction : numpy.ndarray
        Predicted features (the model with the named causes), (n_flights, n_features).
    alpha : float
        Family-wise false-alarm rate over the features' offset and trend tests, and (Bonferroni)
        over their discrepancy tests (:data:`~dronewind.diagnose.calibration.UNEXPLAINED_ALPHA`,
        where its power is stated).
    result : DiagnosisResult, optional
        The diagnosis: with its bootstrap reference the offset and trend tests are referred to
        it (Westfall and Young 1993 single-step min-p over all features and both tests, each
        statistic through its two-sided normal tail, so that the smallest attainable p-value
        is :math:`1/(B+1)`); without, to the normal distribution with a Bonferroni correction.

    Returns
    -------
    list of dict
        One entry per missed feature: ``feature``, ``mean_z`` (weighted mean residual over its
        standard error), ``slope_per_ms`` (residual against mean wind speed [feature unit per
        m s-1]), ``slope_z``, ``p_mean``, ``p_slope`` (family-wise), ``discrepancy_sd`` (the
        model discrepancy [feature unit]) with ``discrepancy_ci95``, ``p_discrepancy`` and
        ``n_flights`` and ``p_mc_se`` (the Monte-Carlo standard error of the smaller of
        ``p_mean`` and ``p_slope``). Empty when the prediction fits.

    Notes
    -----
    The residuals' errors are the sampling error plus the discrepancy of the extended model
    (:func:`dronewind.diagnose.calibration.discrepancy`, estimated about an offset and trend,
    so neither is absorbed); the offset and trend statistics use these known variances
    (:func:`dronewind.diagnose.reference.offset_trend_z`). Each entry carries the feature's
    discrepancy with its interval and its Q test (:math:`Q_f \\sim \\chi^2_{n-q}` without
    discrepancy, Bonferroni over the features), which alone does not make an entry: the
    sampling error of a mast-only feature is near zero where the measured atmosphere reproduces
    the mast, so the Q test rejects on campaigns with nothing wrong; every feature's discrepancy
    is in ``error_model``. The offset and trend replicates of the bootstrap estimate the
    discrepancy again on every replicate, as here; the family-wise p-value counts the observed
    campaign among the :math:`B + 1` draws (ranks among the replicates alone would make any
    statistic beyond all replicates of its test significant at :math:`1/(B+1)`, whatever the
    number of tests). Rates on null campaigns:
    ``benchmarks/results/null_calibration.json``. These are per-feature (marginal) tests, so
    each can be named; this is where model error that no catalog mechanism describes is
    reported.
    """
    resid = ev.y - prediction
    disc = discrepancy(resid, ev.sigma, ev.speed_ms)
    total = np.sqrt(ev.sigma**2 + disc.tau_or_zero()[None, :] ** 2)
    mean_z, slope_z = offset_trend_z(resid, total, ev.speed_ms)
    slopes = wind_speed_slopes(ev, prediction)
    ref = None if result is None else result.reference
    names = [f"{kind}:{f}" for kind in ("mean", "slope") for f in FEATURES]
    observed = dict(zip(names, np.abs(np.concatenate([mean_z, slope_z])), strict=True))
    if ref is not None:
        reps = dict(zip(names, np.concatenate([ref.mean_z, ref.slope_z], axis=1).T, strict=True))
        family = [t for t in names if np.isfinite(observed[t])]
        normal = {t: (lambda x: 2.0 * scipy.stats.norm.sf(x)) for t in family}
        p = familywise_p(observed, reps, family, marginal=normal)
    else:
        k = sum(np.isfinite(v) for v in observed.values())
        p = {t: min(1.0, float(2.0 * scipy.stats.norm.sf(v)) * k) for t, v in observed.items() if np.isfinite(v)}
    n_disc = max(int(np.sum(disc.dof > 0)), 1)
    out = []
    for j, feat in enumerate(FEATURES):
        n = int(np.sum(np.isfinite(resid[:, j]) & np.isfinite(ev.sigma[:, j])))
        if n < 2:
            continue
        p_mean, p_slope = p.get(f"mean:{feat}", 1.0), p.get(f"slope:{feat}", 1.0)
        p_disc = (min(1.0, float(scipy.stats.chi2.sf(disc.q_statistic[j], disc.dof[j])) * n_disc)
                  if disc.dof[j] > 0 else 1.0)
        if min(p_mean, p_slope) < alpha:
            out.append({"feature": feat, "mean_z": finite_or_none(mean_z[j]),
                        "slope_per_ms": slopes.get(feat, float("nan")),
                        "slope_z": finite_or_none(slope_z[j]), "p_mean": p_mean, "p_slope": p_slope,
                        "discrepancy_sd": finite_or_none(disc.tau[j]),
                        "discrepancy_ci95": [finite_or_none(disc.low[j]), finite_or_none(disc.high[j])],
                        "p_discrepancy": p_disc, "n_flights": n,
                        "p_mc_se": mc_standard_error(min(p_mean, p_slope), ref.n_replicates)
                        if ref is not None else None})
    return out


def residual_table(ev: CampaignEvidence, prediction: np.ndarray | None = None) -> list[dict[str, Any]]:
    """Per-flight measured, predicted and normalised residuals of every feature."""
    pred = ev.baseline if prediction is None else prediction
    rows = []
    for i, flight in enumerate(ev.flights):
        for j, feat in enumerate(FEATURES):
            rows.append({
                "flight": flight, "feature": feat, "U_ms": ev.conditions[i].get("mean_speed_ms"),
                "measured": ev.y[i, j], "predicted": pred[i, j], "sigma": ev.sigma[i, j],
                "z": (ev.y[i, j] - pred[i, j]) / ev.sigma[i, j] if ev.sigma[i, j] > 0 else np.nan,
            })
    return rows


def wind_speed_slopes(ev: CampaignEvidence, prediction: np.ndarray | None = None) -> dict[str, float]:
    """Slope of each residual against the mean wind speed (weighted least squares) [unit per m/s]."""
    pred = ev.baseline if prediction is None else prediction
    speed = np.array([c.get("mean_speed_ms", np.nan) for c in ev.conditions], dtype=float)
    out = {}
    for j, feat in enumerate(FEATURES):
        r = ev.y[:, j] - pred[:, j]
        w = 1.0 / ev.sigma[:, j] ** 2
        ok = np.isfinite(r) & np.isfinite(w) & np.isfinite(speed)
        if ok.sum() < 3 or np.ptp(speed[ok]) == 0:
            out[feat] = float("nan")
            continue
        coef = np.polyfit(speed[ok], r[ok], 1, w=np.sqrt(w[ok]))
        out[feat] = float(coef[0])
    return out


def summarise(values: Sequence[float]) -> str:
    """Short text for a list of numbers."""
    arr = np.asarray(values, dtype=float)
    return f"mean {np.nanmean(arr):.3g}, range {np.nanmin(arr):.3g} to {np.nanmax(arr):.3g}"
