"""The Markdown report of the published-results diagnosis (Ghirardelli et al. 2025, Tables 4 and 5).

:func:`markdown` writes the result of :func:`dronewind.diagnose.published.analyse` (and of a
rerun, :func:`dronewind.diagnose.published.rerun_summary`) as a short report: the
observations and the baseline's misfit in standard errors, the candidates' scores, the named
causes with their parameters, the mechanisms the numbers cannot tell apart, and the paper's
quantitative claims against the prediction.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

__all__ = [
    "markdown",
]


def _f(x: object, digits: int = 3) -> str:
    """A number for the report: ``digits`` significant digits, "–" for None or non-finite."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    return f"{x:.{digits}g}" if isinstance(x, float) else str(x)


def _md_introduction(result: Mapping[str, Any], published: Mapping[str, Any]) -> list[str]:
    """Title and what was compared."""
    src = published["source"]
    return ["# The paper's numbers: what the baseline simulation gets wrong, and which mechanism fixes it", "",
            f"Source: {src['citation'].strip()}: Table 4 (conditions), Table 5 "
            "(s1, s7), Sect. 5.2 and 6 (claims). The forward model was run at the Table 4 conditions of the "
            f"stationary samples {', '.join(result['flights'])} and processed like measured data; every catalog "
            "mechanism was fitted to the published numbers and scored by leaving one group of numbers out "
            f"(groups: {', '.join(result['groups'])}).", ""]


def _md_baseline(result: Mapping[str, Any]) -> list[str]:
    """Published against baseline-predicted quantities, with the baseline misfit."""
    lines = ["## What the baseline gets wrong", "",
             "| group | quantity | published | baseline | σ | z |", "|---|---|---|---|---|---|"]
    for q in result["baseline"]["quantities"]:
        lines.append(f"| {q['group']} | {q['quantity']} | {_f(q['published'])} | {_f(q['predicted'])} | "
                     f"{_f(q['sigma'], 2)} | {_f(q['z'], 2)} |")
    return lines + ["", f"Baseline χ² = {_f(result['baseline']['chi2'])} for {result['baseline']['n_observations']} "
                    "published numbers (ln ratios of Table 5; S_w/S_u extremes as expected extremes over the samples).",
                    ""]


def _md_candidates(result: Mapping[str, Any]) -> list[str]:
    """The single candidates ranked by held-out gain."""
    lines = ["## Candidates (ranked by held-out gain)", "",
             "| candidate | estimate | χ² | held-out gain | p | significant |", "|---|---|---|---|---|---|"]
    for c in result["candidates"]:
        est = ", ".join(f"{k} = {_f(v)}" for k, v in c["estimate"].items())
        lines.append(f"| `{c['candidate']}` | {est} | {_f(c['chi2'])} | {_f(c['gain'], 2)} | {_f(c['p_value'], 2)} | "
                     f"{'yes' if c['significant'] else 'no'} |")
    return lines + [""]


def _md_named(result: Mapping[str, Any]) -> list[str]:
    """The named causes with their estimates (or that none is significant) and the ambiguity."""
    if not result["named_causes"]:
        return ["**No mechanism is significant** for the published numbers."]
    parts = []
    for mech in result["named_causes"]:
        e = result["named_estimates"][mech]
        parts.append(f"`{mech}` (" + ", ".join(f"{k} = {_f(v)} ± {_f(e['uncertainty'].get(k), 2)}"
                                              for k, v in e["estimate"].items() if k in e["uncertainty"]) + ")")
    lines = [f"**Named:** {' + '.join(parts)}; combined χ² {_f(result['named_fit']['chi2'])}, held-out gain "
             f"{_f(result['named_fit']['gain'], 2)} (α = {result['alpha']}, Bonferroni over "
             f"{result['n_tests']} mechanisms)."]
    if len(result["ambiguity_set"]) > 1:
        lines.append(f"\n**Ambiguity:** the published numbers cannot tell apart {', '.join(result['ambiguity_set'])}"
                     " (fits within the χ²₁ quantile of the named first cause).")
    return lines


def _md_not_named(result: Mapping[str, Any]) -> list[str]:
    """What was tried next and not named."""
    if not result.get("not_named"):
        return []
    lines = ["", "Tried next and not named (likelihood-ratio test against the named model, threshold "
             f"p < {_f(result['not_named'][0]['threshold'], 2)} after the Bonferroni correction; held-out gain "
             "against the named model):", "", "| added | estimates | χ² | p | held-out gain |", "|---|---|---|---|---|"]
    for t in result["not_named"]:
        est = "; ".join(f"{c}: " + ", ".join(f"{k} = {_f(v)}" for k, v in p.items()) for c, p in t["estimate"].items())
        lines.append(f"| `{t['added']}` | {est} | {_f(t['chi2'])} (from {_f(t['chi2_reference'])}) | "
                     f"{_f(t['p_value'], 2)} | {_f(t['gain'], 2)} |")
    return lines


def _md_rerun(rerun: Mapping[str, Any]) -> list[str]:
    """Table 5 statistics: published, baseline and extended reruns; the mast-side levels."""
    lines = ["", "## Before and after: the forward model rerun at Table 4 conditions", "",
             "Fresh seeds; baseline = no mechanism, extended = the named mechanism(s) at their fitted values.", "",
             "| flight | statistic | published drone/mast | baseline drone/mast | extended drone/mast |",
             "|---|---|---|---|---|"]
    for r in rerun["table5"]:
        lines.append(f"| {r['flight']} | {r['statistic']} | "
                     f"{_f(r['published_drone'], 2)} / {_f(r['published_mast'], 2)}"
                     f" | {_f(r['baseline_drone'], 2)} / {_f(r['baseline_mast'], 2)} | {_f(r['extended_drone'], 2)} / "
                     f"{_f(r['extended_mast'], 2)} |")
    levels = [r for r in rerun["table5"] if r["statistic"].startswith("sigma_")]
    if levels:
        ratios = ", ".join(f"{r['flight']} {r['statistic'].split('_')[1]} "
                           f"{r['published_mast'] / r['baseline_mast']:.2f}"
                           for r in levels if r["baseline_mast"] > 0)
        lines += ["", "Mast-side levels (the model atmosphere, not a payload mechanism): published mast σ over the "
                  f"baseline model's mast σ = {ratios}. The candidates act on drone/mast ratios; an error of the "
                  "atmosphere's absolute σ levels (roughness length, σ/u* similarity constants) scales the absolute "
                  "σ_w excess, not the ratios."]
    return lines


def _md_claims(rerun: Mapping[str, Any], published: Mapping[str, Any]) -> list[str]:
    """The paper's claims (S_w/S_u extremes, sigma_w excess against U): published, baseline, extended."""
    cb, ce = rerun["claims"]["baseline"], rerun["claims"]["extended"]
    claims = published["claims"]
    lines = ["", "| claim | published | baseline | extended |", "|---|---|---|---|",
             f"| drone max ⟨S_w/S_u⟩ | {_f(claims['sw_su_drone_max']['value'])} | {_f(cb['sw_su_drone_max'])} | "
             f"{_f(ce['sw_su_drone_max'])} |",
             f"| mast min ⟨S_w/S_u⟩ | {_f(claims['sw_su_mast_min']['value'])} | {_f(cb['sw_su_mast_min'])} | "
             f"{_f(ce['sw_su_mast_min'])} |"]
    if "sw_su_mast_range" in claims:
        lo, hi = claims["sw_su_mast_range"]["value"]
        lines.append(f"| mast ⟨S_w/S_u⟩ range | {lo}–{hi} | {_f(cb['sw_su_mast_min'])}–{_f(cb['sw_su_mast_max'])} | "
                     f"{_f(ce['sw_su_mast_min'])}–{_f(ce['sw_su_mast_max'])} |")
    lines.append(f"| drone ⟨S_w/S_u⟩ > 4/3 for U > 6 m/s (smallest) | > 1.33 | {_f(cb['sw_su_drone_min_above_6ms'])} | "
                 f"{_f(ce['sw_su_drone_min_above_6ms'])} |")
    ds = rerun["dsigma_w"]
    pub = ds.get("published_table5", {})
    lines.append(f"| σ_w,drone − σ_w,mast vs U: slope [s] (r) | {_f(pub.get('slope_per_ms'))} (Table 5, 2 points) | "
                 f"{_f(ds['baseline']['slope_per_ms'])} ({_f(ds['baseline']['r'], 2)}) | "
                 f"{_f(ds['extended']['slope_per_ms'])} ({_f(ds['extended']['r'], 2)}) |")
    return lines


_MD_LIMITS = ["", "Limits: two flights of Table 5 and two extremes are few numbers; the paper's per-flight "
              "values of Figs 12 and 15 are not printed and are not used. Roughness length, temperature and the "
              "hover position are not in the paper and come from the reconstruction manifest.", ""]


def markdown(result: Mapping[str, Any], rerun: Mapping[str, Any], published: Mapping[str, Any]) -> str:
    """The published-numbers diagnosis as a Markdown report.

    Parameters
    ----------
    result : mapping
        Output of :func:`analyse`.
    rerun : mapping
        Output of :func:`rerun_summary`.
    published : mapping
        Output of :func:`load_published`.

    Returns
    -------
    str
        The report: baseline misfit, candidates, named causes, before/after reruns, claims, limits.
    """
    return "\n".join(_md_introduction(result, published) + _md_baseline(result) + _md_candidates(result)
                     + _md_named(result) + _md_not_named(result) + _md_rerun(rerun) + _md_claims(rerun, published)
                     + _MD_LIMITS)
