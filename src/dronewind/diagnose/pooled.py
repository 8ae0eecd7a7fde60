r"""Model error common to several campaigns: what the forward model gets wrong on every one of them.

One campaign's ``unexplained`` test (:func:`dronewind.diagnose.fit_quality.unexplained_features`)
sees a feature's offset only where it stands above that campaign's few flights. Physics the
forward model lacks moves a feature the same way on every campaign, so it shows in the mean
standardised residual over campaigns: :func:`residual_mean_z` of each campaign's
``baseline.residuals`` (:func:`dronewind.diagnose.fit_quality.residual_table`, in every
diagnosis record), pooled and tested by :func:`pooled_offsets`; :func:`read_campaign` and
:func:`pool_diagnoses` do it for ``diagnosis.json`` files (``dronewind model-error``).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import scipy.stats

from dronewind.diagnose.calibration import UNEXPLAINED_ALPHA
from dronewind.diagnose.features import FEATURES
from dronewind.errors import InputError

__all__ = ["residual_mean_z", "pooled_offsets", "CampaignResiduals", "read_campaign", "pool_diagnoses",
           "offsets_table"]


def pooled_offsets(campaigns: Sequence[dict[str, float]], alpha: float = UNEXPLAINED_ALPHA,
                   features: Sequence[str] = FEATURES) -> dict[str, dict[str, Any]]:
    r"""Model error common to several campaigns: each feature's mean standardised residual over them, tested.

    One campaign's ``unexplained`` test
    (:func:`dronewind.diagnose.fit_quality.unexplained_features`) sees an offset of a feature
    only where it stands above that campaign's few flights; an offset the forward model carries
    on every campaign (physics it lacks) shows in the mean over campaigns.

    Parameters
    ----------
    campaigns : sequence of dict
        Per campaign, feature -> mean standardised residual over its flights
        (:func:`residual_mean_z`) [-].
    alpha : float
        Family-wise false-alarm rate over the features (Bonferroni).
    features : sequence of str
        Features to pool (default all).

    Returns
    -------
    dict
        Feature -> ``mean_z`` (mean over the campaigns), ``se`` (its standard error from their
        spread), ``n`` (campaigns with the feature), ``p_value`` (two-sided one-sample t-test,
        :math:`n - 1` degrees of freedom) and ``significant`` (:math:`p < \alpha / k`, :math:`k`
        the features tested).

    Notes
    -----
    With :math:`\bar z_c` the mean standardised residual of campaign :math:`c`,

    .. math::

        m = \frac{1}{n}\sum_c \bar z_c, \qquad
        s_m = \sqrt{\frac{\sum_c (\bar z_c - m)^2}{n (n - 1)}}, \qquad
        t = m / s_m \sim t_{n-1}.

    The spread over campaigns, not the nominal :math:`1/\sqrt{n_{flights}}`, sets the error: it
    holds the flights' correlation within a campaign and each campaign's own discrepancy, so the
    test stays calibrated when the per-flight errors are not exactly 1
    (``tests/diagnose/test_diagnose_pooled_offsets.py`` measures its false-alarm rate).
    """
    values = {f: np.array([c.get(f, np.nan) for c in campaigns], dtype=float) for f in features}
    tested = [f for f, v in values.items() if np.isfinite(v).sum() >= 2]
    out: dict[str, dict[str, Any]] = {}
    for f, v in values.items():
        v = v[np.isfinite(v)]
        entry: dict[str, Any] = {"mean_z": float(v.mean()) if v.size else float("nan"), "se": float("nan"),
                                 "n": int(v.size), "p_value": float("nan"), "significant": False}
        if f in tested:
            se = float(v.std(ddof=1) / np.sqrt(v.size))
            entry["se"] = se
            if se > 0:
                entry["p_value"] = float(2.0 * scipy.stats.t.sf(abs(entry["mean_z"]) / se, v.size - 1))
            else:
                entry["p_value"] = 0.0 if entry["mean_z"] != 0 else 1.0
            entry["significant"] = bool(entry["p_value"] < alpha / len(tested))
        out[f] = entry
    return out


def residual_mean_z(rows: Sequence[Mapping[str, Any]]) -> dict[str, float]:
    """Mean standardised residual of every feature over a campaign's flights, from residual rows.

    Parameters
    ----------
    rows : sequence of mapping
        ``baseline.residuals`` of a ``diagnosis.json``
        (:func:`dronewind.diagnose.fit_quality.residual_table`): ``feature`` and ``z`` per flight.

    Returns
    -------
    dict
        Feature -> mean of its finite ``z`` [-] (NaN where no flight has one).
    """
    values: dict[str, list[float]] = {f: [] for f in FEATURES}
    for row in rows:
        z = row.get("z")
        if row.get("feature") in values and z is not None and math.isfinite(float(z)):
            values[row["feature"]].append(float(z))
    return {f: float(np.mean(v)) if v else float("nan") for f, v in values.items()}


@dataclass
class CampaignResiduals:
    """One campaign's diagnosis, as the pooling reads it."""

    path: str
    campaign: str
    mean_z: dict[str, float] = field(default_factory=dict)
    n_flights: int = 0
    unexplained: list[str] = field(default_factory=list)
    #: why the campaign has no residuals (not diagnosed: too few usable flights), else empty
    left_out: str = ""


def read_campaign(path: str | Path) -> CampaignResiduals:
    """The baseline residuals of a ``diagnosis.json`` (the workflow's ``results/<campaign>/diagnosis.json``).

    Parameters
    ----------
    path : str or Path
        A ``diagnosis.json``.

    Returns
    -------
    CampaignResiduals
        Its mean standardised residual per feature, flights and ``unexplained`` features; a
        campaign that was not diagnosed (too few usable flights) has ``left_out`` set to its note.

    Raises
    ------
    InputError
        The file is not JSON, or not a diagnosis (no ``campaign`` or ``baseline.residuals``).
    """
    p = Path(path)
    try:
        doc = json.loads(p.read_text())
    except json.JSONDecodeError as exc:
        raise InputError(f"{p}:{exc.lineno}", f"not JSON ({exc.msg})") from exc
    if not isinstance(doc, dict) or "campaign" not in doc:
        raise InputError(p, "not a diagnosis.json (expected an object with 'campaign' and 'baseline')")
    name = str(doc["campaign"])
    if doc.get("note") and not (doc.get("baseline") or {}).get("residuals"):
        return CampaignResiduals(str(p), name, left_out=str(doc["note"]))
    rows = (doc.get("baseline") or {}).get("residuals")
    if not isinstance(rows, list):
        raise InputError(f"{p} [baseline.residuals]", "expected the list of per-flight residual rows of a "
                         "diagnosis.json")
    flights = {str(r.get("flight")) for r in rows if isinstance(r, Mapping)}
    bad = [k for k, r in enumerate(rows) if not isinstance(r, Mapping) or "feature" not in r or "z" not in r
           or not (r["z"] is None or (isinstance(r["z"], (int, float)) and not isinstance(r["z"], bool)))]
    if bad:
        raise InputError(f"{p} [baseline.residuals][{bad[0]}]", "expected a row with 'feature' and a number or "
                         "null 'z'")
    return CampaignResiduals(str(p), name, residual_mean_z(rows), len(flights),
                             sorted({str(u.get("feature")) for u in doc.get("unexplained") or []}))


def pool_diagnoses(campaigns: Sequence[CampaignResiduals], alpha: float = UNEXPLAINED_ALPHA) -> dict[str, Any]:
    """Model error common to campaigns: :func:`pooled_offsets` over their diagnoses.

    Parameters
    ----------
    campaigns : sequence of CampaignResiduals
        From :func:`read_campaign`.
    alpha : float
        Family-wise false-alarm rate over the features.

    Returns
    -------
    dict
        ``features`` (:func:`pooled_offsets` with ``unexplained_in``: the campaigns whose own
        diagnosis lists the feature), ``campaigns`` (name, path, flights), ``left_out``
        (campaigns not diagnosed, with their notes) and ``alpha``.

    Raises
    ------
    InputError
        A campaign given twice (same name, identical residuals: a copy of its results, or the
        same inputs run again, which the workflow reproduces bit for bit): the test treats
        campaigns as independent, so a copy would count its residuals twice.
    """
    seen: dict[tuple[str, tuple[float, ...]], str] = {}
    for c in campaigns:
        if c.left_out:
            continue
        key = (c.campaign, tuple(np.nan_to_num(np.array([c.mean_z.get(f, np.nan) for f in FEATURES]), nan=1e300)))
        if key in seen:
            raise InputError(c.path, f"campaign {c.campaign!r} with the residuals of {seen[key]}: the same campaign "
                                     "given twice (each campaign counts once)")
        seen[key] = c.path
    used = [c for c in campaigns if not c.left_out]
    pooled = pooled_offsets([c.mean_z for c in used], alpha)
    for f, entry in pooled.items():
        entry["unexplained_in"] = [c.campaign for c in used if f in c.unexplained]
    return {"alpha": alpha, "features": pooled,
            "campaigns": [{"campaign": c.campaign, "path": c.path, "n_flights": c.n_flights} for c in used],
            "left_out": [{"campaign": c.campaign, "path": c.path, "note": c.left_out} for c in campaigns
                         if c.left_out]}


def offsets_table(result: Mapping[str, Any]) -> str:
    """:func:`pool_diagnoses` as a text table, significant features marked, left-out campaigns listed."""
    n = len(result["campaigns"])
    lines = [f"model error common to {n} campaign{'s' if n != 1 else ''} (mean standardised baseline residual; "
             f"t-test over campaigns, family-wise alpha {result['alpha']:g})",
             f"  {'feature':24s} {'mean z':>7s} {'s.e.':>6s} {'p':>8s}  common  unexplained in"]
    for f, e in result["features"].items():
        se = "" if not math.isfinite(e["se"]) else f"{e['se']:.2f}"
        p = "" if not math.isfinite(e["p_value"]) else f"{e['p_value']:.2g}"
        mean = "" if not math.isfinite(e["mean_z"]) else f"{e['mean_z']:+.2f}"
        lines.append(f"  {f:24s} {mean:>7s} {se:>6s} {p:>8s}  {'yes' if e['significant'] else '':6s}  "
                     f"{len(e['unexplained_in'])}/{n}")
    if n < 2:
        lines.append("  (one campaign: no spread over campaigns to test against; its own diagnosis' unexplained "
                     "test applies)")
    for c in result["left_out"]:
        lines.append(f"  left out: {c['campaign']} ({c['path']}): {c['note']}")
    return "\n".join(lines)

