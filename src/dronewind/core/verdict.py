"""The verdict of a diagnosis in words, from ``diagnosis.json`` alone.

One implementation for every place that states it: the campaign's front page
(:mod:`dronewind.steps.report`), the diagnosis report ``diagnosis/report.md``
(:mod:`dronewind.diagnose.report`) and the figure captions (:mod:`dronewind.figures.captions`).
Each of them states the numbers of the same stored object, so no two can differ; the wording
is built so that it cannot contradict itself: the goodness of fit is stated for the model that
was actually fitted (with the named causes, or the forward model when none is named) and its
p-value is said in words, including a p-value near 1 (a misfit smaller than the sampling
errors make likely).

Text only; nothing here computes a statistic.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

__all__ = ["MISFIT_METRICS", "Verdict", "fit_meaning", "misfit_rows", "number", "verdict", "verdict_sentence"]

#: p-values of a goodness-of-fit test below this: the model misses something.
P_LOW = 0.01
#: p-values above this: the misfit is smaller than the sampling errors make likely.
P_HIGH = 0.99

#: Misfit metrics shown before/after: key -> label.
MISFIT_METRICS: dict[str, str] = {
    "chi2": "misfit χ²",
    "chi2_per_feature": "χ² per feature (≈ 1 for a correct model)",
    "sigma_w_ratio_rmse": "RMSE of the σ_w drone/mast ratio, measured against predicted",
}


def number(value: Any, digits: int = 3) -> str:
    """``value`` to ``digits`` significant digits; "–" for None, NaN or text that is no number."""
    if isinstance(value, bool) or value is None:
        return "–" if value is None else ("yes" if value else "no")
    try:
        v = float(value)
    except (TypeError, ValueError):
        return str(value)
    if not math.isfinite(v):
        return "–"
    text = f"{v:.{digits}g}"
    return "0" if text in ("-0", "-0.0") else text


def _list(items: Sequence[str]) -> str:
    items = list(items)
    if not items:
        return "none"
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def _estimates(estimate: Mapping[str, Any], uncertainty: Mapping[str, Any] | None = None) -> str:
    parts = []
    for key, value in estimate.items():
        if isinstance(value, int | float) and not isinstance(value, bool):
            err = (uncertainty or {}).get(key)
            parts.append(f"{key} = {number(value)}"
                         + (f" ± {number(err, 2)}" if isinstance(err, int | float) and math.isfinite(err) else ""))
    return ", ".join(parts)


def fit_meaning(p_value: float) -> str:
    """What a goodness-of-fit p-value says about the model, in words."""
    if p_value < P_LOW:
        return "the misfit is larger than sampling error explains: the model still misses something"
    if p_value > P_HIGH:
        return ("the misfit is smaller than sampling error alone would make it: the sampling errors (from the "
                "spread of the forward model's seeds) are overestimated, so the tests here are conservative")
    return "the misfit is what sampling error explains"


@dataclass
class Verdict:
    """The verdict of one diagnosis, sentence by sentence.

    Attributes
    ----------
    named : list of str
        Named causes (empty: none).
    headline : str
        The named causes with estimates and held-out gains, or that none is named.
    fit : str
        The goodness of fit of the model that was fitted, with what its p-value means ("" if not stored).
    unexplained : str
        What remains unexplained, or that nothing does ("" if not stored).
    caveats : list of str
        Each caveat once: effects outside the catalog the data cannot tell from a named cause,
        mechanisms that fit as well.
    numbers : dict
        The numbers the sentences state (``chi2``, ``dof``, ``p_value``), for comparison with their source.
    """

    named: list[str]
    headline: str
    fit: str = ""
    unexplained: str = ""
    caveats: list[str] = field(default_factory=list)
    numbers: dict[str, Any] = field(default_factory=dict)

    def sentences(self, caveats: bool = False) -> list[str]:
        """The sentences in reading order (the caveats last, if asked for)."""
        out = [s for s in (self.headline, self.fit, self.unexplained) if s]
        return out + (self.caveats if caveats else [])

    def text(self, caveats: bool = False) -> str:
        """The verdict as one paragraph."""
        return " ".join(self.sentences(caveats))


def verdict(diag: Mapping[str, Any]) -> Verdict:
    """The verdict of a diagnosis JSON (the campaign's or the published numbers').

    Parameters
    ----------
    diag : mapping
        ``diagnosis.json``: ``named_causes``, ``named_estimates`` (``estimate``,
        ``uncertainty``, ``gain`` per cause), ``candidates`` and, when present,
        ``goodness_of_fit``, ``unexplained``, ``caveats``, ``ambiguity`` and ``note``.

    Returns
    -------
    Verdict
    """
    named = list(diag.get("named_causes") or [])
    cands = {c.get("mechanism"): c for c in reversed(diag.get("candidates") or [])}
    if not named and not cands and diag.get("note"):
        return Verdict(named, f"Not diagnosed: {diag['note']}.")
    if not named:
        headline = "No cause named: no catalog mechanism explains the measured drone-mast differences significantly."
    else:
        parts = []
        for name in named:
            entry = (diag.get("named_estimates") or {}).get(name) or {}
            cand = cands.get(name, {})
            est = entry.get("estimate", cand.get("estimate") or {})
            gain = entry.get("gain", cand.get("gain"))
            details = [d for d in (_estimates(est, entry.get("uncertainty", cand.get("uncertainty"))),
                                   f"held-out gain {gain:.2f}" if isinstance(gain, int | float) else "") if d]
            parts.append(f"{name} ({'; '.join(details)})" if details else name)
        headline = f"Named cause{'s' if len(parts) > 1 else ''}: {'; '.join(parts)}."
    out = Verdict(named, headline)
    gof = diag.get("goodness_of_fit") or {}
    if isinstance(gof.get("p_value"), int | float):
        p, chi2, dof = float(gof["p_value"]), gof.get("chi2"), gof.get("dof")
        model = (f"the model with the named cause{'s' if len(named) > 1 else ''}" if named
                 else "the forward model (no cause named)")
        ref = gof.get("reference_mean")
        expected = (f"; a correct model gives {number(ref)} on average" if isinstance(ref, int | float)
                    else f"; a correct model gives about {dof} on average" if isinstance(dof, int) else "")
        out.fit = (f"Goodness of fit of {model}: χ² = {number(chi2)} for {dof if dof is not None else '?'} "
                   f"residuals{expected}, p = {number(p, 2)}: {fit_meaning(p)}.")
        out.numbers.update(chi2=chi2, dof=dof, p_value=p)
    left = diag.get("unexplained")
    if isinstance(left, list):
        if left:
            items = []
            for u in left:
                z = u.get("mean_z")
                items.append(f"{u.get('feature')} (offset z {float(z):+.1f})" if isinstance(z, int | float)
                             else str(u.get("feature")))
            out.unexplained = "Still unexplained (model error no catalog mechanism describes): " + _list(items) + "."
        else:
            out.unexplained = "Nothing remains unexplained."
    seen: set[str] = set()
    for c in diag.get("caveats") or []:
        text = (f"Caveat on {c.get('mechanism')}: {c.get('alias')} (an effect outside the catalog) would look "
                "the same; the data alone cannot tell them apart.")
        if text not in seen:
            seen.add(text)
            out.caveats.append(text)
    amb = [a for a in diag.get("ambiguity") or [] if a.get("named") in named]
    if amb:
        out.caveats.append("Equally possible explanations of the same effect: " + _list(
            [f"{a['mechanism']} for {a['named']}" for a in amb]) + "; the named one fits best.")
    return out


def verdict_sentence(diag: Mapping[str, Any]) -> str:
    """The verdict of a diagnosis JSON as one paragraph (:func:`verdict`, without the caveats)."""
    return verdict(diag).text()


def misfit_rows(diag: Mapping[str, Any]) -> list[tuple[str, str, Any, Any]]:
    """The misfit before (baseline) and after (extended model, as fitted) stored in ``diagnosis.json``.

    Returns
    -------
    list of (key, label, baseline, extended)
        One row per :data:`MISFIT_METRICS` key the baseline has; ``extended`` is None when
        the diagnosis stores no prediction of the extended model.
    """
    before = (diag.get("baseline") or {}).get("metrics") or {}
    after = (diag.get("extended") or {}).get("prediction_metrics") or {}
    return [(k, label, before[k], after.get(k)) for k, label in MISFIT_METRICS.items() if k in before]
