r"""The ``diagnosis.json`` record of a campaign diagnosis (docs/data-contract.md) and the evidence a report needs."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from dronewind.diagnose.calibration import ProfiledFit
from dronewind.diagnose.evidence import error_model, measured_conditions
from dronewind.diagnose.features import FEATURES
from dronewind.diagnose.fit_quality import baseline_metrics, goodness_of_fit, residual_table, unexplained_features
from dronewind.diagnose.naming import (
    FEATURE_ALIASES,
    DiagnosisResult,
    _at_bound,
    best_variants,
    caveats,
    combined_prediction,
)
from dronewind.diagnose.probes import MIN_FLIGHTS
from dronewind.diagnose.reference import mc_standard_error

__all__ = ["to_json", "decision_json", "withheld_json", "not_diagnosed_json"]

def not_diagnosed_json(campaign: str, n_usable: int, left_out: Mapping[str, str]) -> dict[str, Any]:
    """The ``diagnosis.json`` record of a campaign with fewer than :data:`~dronewind.diagnose.probes.MIN_FLIGHTS`
    usable payload flights.

    Nothing is fitted or named; ``note`` says why, ``unusable`` lists the flights the chain left
    out and ``unusable_reasons`` why, where known (a flight's L2 ``unusable_reason``). Nothing
    was tested either, so the record has no ``unexplained`` entry (an empty one would read as
    "nothing remains unexplained"). A campaign whose every flight is unusable is reported so, as
    one with a single usable flight is, and the run goes on.

    Parameters
    ----------
    campaign : str
        Campaign name.
    n_usable : int
        Usable payload flights.
    left_out : mapping
        Id of every flight left out -> why ("" where no reason was recorded).

    Returns
    -------
    dict
        ``campaign``, empty ``baseline.metrics``, ``candidates``, ``named_causes`` and
        ``ambiguity_sets``, ``unusable``, ``unusable_reasons`` (the known ones) and ``note``.

    Examples
    --------
    >>> not_diagnosed_json("demo", 0, {"s02": "", "s01": "hover window 85 s shorter than 600 s"})
    ... # doctest: +NORMALIZE_WHITESPACE
    {'campaign': 'demo', 'baseline': {'metrics': {}}, 'candidates': [], 'named_causes': [], 'ambiguity_sets': [],
     'unusable': ['s01', 's02'], 'note': '0 usable flight(s): held-out scoring needs at least 2',
     'unusable_reasons': {'s01': 'hover window 85 s shorter than 600 s'}}
    """
    out: dict[str, Any] = {"campaign": campaign, "baseline": {"metrics": {}}, "candidates": [], "named_causes": [],
                           "ambiguity_sets": [], "unusable": sorted(left_out),
                           "note": f"{int(n_usable)} usable flight(s): held-out scoring needs at least {MIN_FLIGHTS}"}
    reasons = {f: str(left_out[f]) for f in sorted(left_out) if left_out[f]}
    if reasons:
        out["unusable_reasons"] = reasons
    return out


def withheld_json(result: DiagnosisResult) -> list[dict[str, Any]]:
    """``diagnosis.json`` entries of the withheld candidates (:class:`Withheld`)."""
    ev = result.evidence
    return [{"mechanism": ev.mechanism_of[w.candidate], "variant": w.candidate if w.candidate != ev.mechanism_of[
                w.candidate] else None,
             "estimate": result.estimate(w.candidate, w.score), "p_value": w.score.p_value,
             "gain": w.score.gain, "feature": w.feature, "share": w.shares[w.feature],
             "alias": FEATURE_ALIASES[w.feature]} for w in result.withheld]


def _profiled_tau(profile: ProfiledFit | None) -> dict[str, float]:
    """The features' model discrepancy under a candidate's fit (those above zero) [feature units]."""
    if profile is None:
        return {}
    tau = profile.discrepancy.tau_or_zero()
    return {f: float(t) for f, t in zip(FEATURES, tau, strict=True) if t > 0}


def _profiles_or_none(profiles: Sequence[ProfiledFit] | None, n: int) -> list[ProfiledFit | None]:
    """The named causes' profiled fits, or ``None`` for each where none were kept."""
    return list(profiles) if profiles else [None] * n


def to_json(result: DiagnosisResult, campaign: str) -> dict[str, Any]:
    """The ``diagnosis.json`` structure of the data contract (plus evidence fields).

    The :func:`decision_json` entries, with the fit's quality beside them: the goodness of fit
    of the named model and of the baseline (the named model's p-value refits the named causes on
    every bootstrap replicate), the baseline's per-flight residuals
    (:func:`~dronewind.diagnose.fit_quality.residual_table`, what ``dronewind model-error`` pools
    over campaigns), the ``unexplained`` features, the error model and the method.
    """
    ev = result.evidence
    decision = decision_json(result, campaign)
    extended = combined_prediction(result)
    n_fitted = sum(len(s.parameter_names) for _, s in result.named)
    return {
        "campaign": campaign,
        "goodness_of_fit": goodness_of_fit(ev, extended, n_fitted, result),
        "unexplained": unexplained_features(ev, extended, result=result),
        "baseline": {"metrics": {**baseline_metrics(ev), "heldout_chi2": float(
            next(iter(result.scores.values())).heldout_chi2_baseline.sum()) if result.scores else float("nan")},
            "goodness_of_fit": goodness_of_fit(ev, ev.baseline, 0, result, baseline=True),
            "residuals": residual_table(ev)},
        **{key: value for key, value in decision.items() if key != "campaign"},
        "sigma_scale": {f: float(k) for f, k in zip(FEATURES, ev.scale, strict=True)},
        "error_model": error_model(ev, result),
        "method": "forward-model responses (simulated probes, common random numbers), bounded least squares "
                  "whitened by the shrunk feature correlation of the baseline seeds plus the model discrepancy "
                  "profiled under each candidate, "
                  "leave-one-flight-out gain, likelihood-ratio test referred to a parametric bootstrap over seeds "
                  "(Westfall-Young min-p over each naming round's candidates at alpha), greedy naming while the "
                  "held-out gain rises by more than its uncertainty; see dronewind.diagnose",
    }


def decision_json(result: DiagnosisResult, campaign: str) -> dict[str, Any]:
    """What a campaign diagnosis decided, as :func:`to_json` writes it, without the fit's quality.

    The candidates and the named causes with their estimates, the ambiguity sets, what was not
    identified or withheld, the caveats and the measured conditions: every entry that says which
    cause is named and how large it is (what :func:`dronewind.diagnose.experiments.judge`
    reads), the same as in :func:`to_json`. Left out are the goodness of fit, ``unexplained``
    and the error model, which describe how well the named model fits and do not change what is
    named; the goodness of fit of a named model refits its causes on every bootstrap replicate,
    most of the cost of a diagnosis against a given reference (the planner's Monte-Carlo draws,
    :mod:`dronewind.plan.power`, decide hundreds of campaigns and judge only the decision).

    Parameters
    ----------
    result : DiagnosisResult
        The diagnosis (:func:`dronewind.diagnose.naming.diagnose`).
    campaign : str
        The campaign's name.

    Returns
    -------
    dict
        ``campaign``, ``candidates``, ``named_causes``, ``named_estimates``, ``ambiguity_sets``,
        ``ambiguity``, ``not_identified``, ``caveats``, ``withheld``, ``measured_conditions``,
        ``features`` and ``flights``.
    """
    ev = result.evidence
    b = result.reference.n_replicates if result.reference is not None else 0
    candidates = []
    for cand in best_variants(result):
        s = result.scores[cand]
        mech = ev.mechanism_of[cand]
        unc = s.uncertainty()
        est = result.estimate(cand)
        bound = _at_bound(ev.models[cand], s.fit.theta)
        candidates.append({
            "mechanism": mech,
            "variant": cand if cand != mech else None,
            "estimate": est,
            "uncertainty": {k: unc.get(k, 0.0) for k in est},
            "gain": s.gain,
            "significant": bool(s.significant and not bound),
            "at_bound": bound,
            "p_value": s.p_value,
            "p_mc_se": mc_standard_error(s.p_value, b) if b else None,
            "lr_statistic": s.lr_statistic,
            "lr_profile": s.lr_profile if math.isfinite(s.lr_profile) else None,
            "discrepancy_sd": _profiled_tau(result.profiles.get(cand)),
            "n_parameters": len(s.parameter_names),
            "heldout_chi2": float(s.heldout_chi2.sum()),
        })
    named = []
    for cand, _ in result.named:
        mech = ev.mechanism_of[cand]
        if mech not in named:
            named.append(mech)
    return {
        "campaign": campaign,
        "candidates": candidates,
        "named_causes": named,
        "named_estimates": {ev.mechanism_of[c]: {"estimate": result.estimate(c, s), "uncertainty": s.uncertainty(),
                                                 "gain": s.gain, "gain_rise": rise, "gain_rise_se": rise_se,
                                                 "p_value": s.p_value,
                                                 "p_mc_se": mc_standard_error(s.p_value, b) if b else None,
                                                 "discrepancy_sd": _profiled_tau(prof),
                                                 "evidence_share": {f: v for f, v in share.items() if v >= 0.05}}
                            for (c, s), share, (rise, rise_se), prof in zip(
                                result.named, result.shares, result.gain_rises,
                                _profiles_or_none(result.named_profiles, len(result.named)), strict=True)},
        "ambiguity_sets": [list(g) for g in result.ambiguity],
        "ambiguity": [{"named": ev.mechanism_of[c], "mechanism": m, "cosine": cos}
                      for (c, _), cosines in zip(result.named, result.ambiguity_cosines, strict=True)
                      for m, cos in cosines.items()],
        "not_identified": [{"mechanism": ev.mechanism_of[c], "variant": c if c != ev.mechanism_of[c] else None,
                            "estimate": result.estimate(c, s), "p_value": s.p_value, "gain": s.gain, "reason": why}
                           for c, s, why in result.not_identified],
        "caveats": caveats(named),
        "withheld": withheld_json(result),
        "measured_conditions": measured_conditions(ev),
        "features": list(FEATURES),
        "flights": ev.flights,
    }
