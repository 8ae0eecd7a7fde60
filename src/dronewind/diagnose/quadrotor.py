r"""Diagnosis of the quasi-steady single-law quadrotor model (SWUF-3D, Wetz et al. (2021) and Kistner et al. (2024)).

The baseline is the model the fleet is usually flown with: one drag law for every UAV
(Wetz et al. 2021, Eqs 12-18, :math:`c_{d,0}A_0` and :math:`c_p` fitted), no per-UAV
misalignment, a quasi-steady attitude (no response lag) and, in the tunnel, the
longitudinal drag law applied in every direction. Candidate extensions (field:
:mod:`dronewind.diagnose.quadrotor_field`; tunnel: :mod:`dronewind.diagnose.quadrotor_tunnel`),
each a mechanism of the catalog (:mod:`dronewind.mechanisms`) except ``sideslip``:

``pitch_offset`` (field)
    one pitch offset per UAV (logged minus true), Wetz et al. (2021) Sect. 5.2;
``yaw_offset`` (field)
    one heading offset per UAV, Wetz et al. (2021) Sect. 5.4 (scored on the direction);
``drag_regime`` (field and tunnel)
    power laws :math:`V = c_k a^{b_k}` per speed range instead of one law (Kistner et al. 2024, Eq. 1,
    Table 2), :math:`a = g\sin\gamma`;
``response_lag`` (tunnel)
    the attitude follows the air speed through a first-order lag :math:`\tau` (Kistner et al. 2024,
    Sect. 4: gusts and steps); invisible in 2-min and 10-min means, so it is tested on the
    tunnel's gust and step runs;
``sideslip`` (tunnel)
    separate lateral coefficients :math:`(b_y, c_y)` (Kistner et al. 2024, Eq. 1) instead of the
    longitudinal law at every angle of sideslip;
``flight_pitch_offset`` (field)
    one pitch offset per flight and UAV instead of per UAV: an IMU re-levelled between days
    of a multi-day campaign. A new flight's offset cannot be known in advance, so it is
    held out within flights (every ``k``-th window of each flight and UAV), the model it
    extends scored on the same folds; it replaces the per-UAV offsets;
``air_density`` (field)
    the air density of the drag balance (Wetz et al. 2021, Eq. 12) from the logged pressure
    and temperature of each block instead of one constant; a candidate only when the records
    hold them.

Scoring (the same for every candidate): the parameters are fitted on training data and
the misfit is measured on held-out data: field windows of flights left out (k-fold over
flights, leave-one-flight-out when there are at most ``k`` flights), tunnel runs left out
(leave-one-run-out) or, for ``sideslip``, the sideslip runs that the calibration never saw.
``gain`` is the relative reduction of the held-out RMSE,
:math:`1 - \mathrm{RMSE}_{cand}/\mathrm{RMSE}_{ref}`. Significance is a one-sided paired
Wilcoxon signed-rank test of the held-out squared errors per unit (field: one UAV log, i.e.
flight and UAV; tunnel: one gust/step repetition or one speed step) at :math:`\alpha`
Bonferroni-corrected over the candidates of the round, plus ``gain >= min_gain``. Because
the test is on held-out data, extra parameters that only fit noise lose rather than gain;
the in-sample F statistic
:math:`F = \frac{(RSS_0 - RSS_1)/\Delta p}{RSS_1/(n - p_1)}` is reported for reference.
Causes are named greedily: the best significant candidate joins the model, the others are
scored again against the extended model, until none is significant. The per-flight offsets
and the logged density are candidates of the same rounds as the per-UAV causes (same test,
Bonferroni family and gain rule), so a per-day offset competes with a per-UAV one.
Ambiguity: a significant candidate that the named one does not beat in a paired test of
their held-out errors (same metric, same folds, the round's level) explains the data as
well; it is listed in the named cause's ``ambiguous_with`` and the campaign's
``ambiguity_sets``. Per-flight offsets that cannot be told from per-UAV ones are not named:
the per-UAV offsets are (the simpler model).

References
----------
.. [1] Wetz et al. (SWUF-3D), Wetz et al. (2021), Sects. 4-5, Eqs. 12-18.
.. [2] Wind-tunnel calibration of the SWUF-3D quadrotors, Kistner et al. (2024), Eq. 1, Table 2, Sect. 4.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, cast

import numpy as np
import pandas as pd

from dronewind.diagnose.quadrotor_field import FieldData, _estimate, field_data, score_field_candidates
from dronewind.diagnose.quadrotor_tunnel import tunnel_candidates

__all__ = [
    "diagnose_quadrotor",
    "to_json_ready",
]


# ----------------------------------------------------------------------------- field data


# ----------------------------------------------------------------------------- tunnel


# ----------------------------------------------------------------------------- campaign


def _public(c: Mapping[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in c.items() if not k.startswith("_")}


def _field_part(data: FieldData, alpha: float, min_gain: float,
                k_folds: int) -> tuple[dict[str, Any], list[dict[str, Any]], list[dict[str, Any]], dict[str, Any]]:
    """Field candidates scored and named (:func:`score_field_candidates`).

    Returns
    -------
    metrics : dict
        Baseline held-out RMSEs, counts and the baseline law.
    candidates : list of dict
        Every candidate as scored in the last round it took part in (named ones: when
        named, with the estimates of the final extended model).
    named : list of dict
        Named candidates in order.
    extended : dict
        Held-out RMSE before and after with every named field cause.
    """
    res = score_field_candidates(data, alpha, min_gain, k_folds)
    bho = res["baseline"]["heldout"]
    eho = res["extended_baseline"]  # the baseline on the folds of the extended model
    bf = res["baseline"]["fit"]
    metrics = {"speed_rmse_ms": bho.rmse("speed"), "direction_rmse_deg": bho.rmse("direction"),
               "n_windows": data.n, "n_flights": int(len(set(data.flight))), "n_uavs": len(data.uavs),
               "cd0a0_m2": float(bf.x[0]), "cp_m2_per_rad": float(bf.x[1])}
    last: dict[str, dict] = {}
    for rnd in res["rounds"]:
        for s in rnd:
            last[s["mechanism"]] = s
    for n in res["named"]:
        # named causes: estimates from the final extended model (all named causes fitted jointly)
        est, unc = _estimate(res["final_fit"], n["mechanism"], data.uavs)
        last[n["mechanism"]] = {**n, "estimate": est, "uncertainty": unc}
    ext = res["extended"]
    extended = {
        "named": [n["mechanism"] for n in res["named"]],
        "speed_rmse_ms": {"before": eho.rmse("speed"), "after": ext.rmse("speed")},
        "direction_rmse_deg": {"before": eho.rmse("direction"), "after": ext.rmse("direction")},
        "speed_gain": 1.0 - ext.rmse("speed") / eho.rmse("speed") if eho.rmse("speed") > 0 else 0.0,
        "direction_gain": 1.0 - ext.rmse("direction") / eho.rmse("direction")
        if eho.rmse("direction") > 0 else 0.0,
        "heldout": res["extended_heldout"] if res["extended_heldout"].endswith("within flights")
        else f"{min(k_folds, len(set(data.flight)))}-fold over flights"}
    return metrics, [_public(s) for s in last.values()], list(res["named"]), extended


def _as_mechanisms(candidates: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Significant candidates as ``simulation.mechanisms`` entries (field causes, then a tunnel lag)."""
    mech: list[dict[str, Any]] = []
    for c in candidates:
        if not c["significant"] or c["source"] != "field":
            continue
        if c["mechanism"] in ("pitch_offset", "yaw_offset"):
            mech += [{"mechanism": c["mechanism"], "parameters": {"uav": u, "deg": round(v, 3)}}
                     for u, v in c["estimate"].items()]
        elif c["mechanism"] == "drag_regime":
            mech.append({"mechanism": "drag_regime", "parameters": c["estimate"]})
    for c in candidates:
        if c["significant"] and c["mechanism"] == "response_lag":
            mech.append({"mechanism": "response_lag", "parameters": {"tau_s": c["estimate"]["tau_s"]}})
    return mech


def diagnose_quadrotor(campaign: str, blocks: pd.DataFrame | None, windows: pd.DataFrame | None,
                       runs_file: str | Path | None = None, alpha: float = 0.01, min_gain: float = 0.05,
                       k_folds: int = 5, block_s: float = 10.0) -> dict[str, Any]:
    """The ``quadrotor_diagnosis.json`` structure (as ``diagnosis.json`` of ``docs/data-contract.md``).

    Parameters
    ----------
    campaign : str
        Campaign name.
    blocks, windows : pandas.DataFrame or None
        Field windows (:func:`dronewind.quadrotor.windows.flight_windows`); None or empty: no field part.
    runs_file : str or Path, optional
        Tunnel run index; None: no tunnel part.
    alpha, min_gain, k_folds, block_s
        See :func:`score_field_candidates` and :func:`field_data`.

    Returns
    -------
    dict
        ``campaign``, ``baseline.metrics`` (held-out RMSEs of the single-law model),
        ``candidates`` (ranked by gain, best first; each with ``mechanism``, ``source``,
        ``estimate``, ``uncertainty``, ``gain``, ``significant``, ``p_value``, ...),
        ``named_causes`` (empty when nothing is significant), ``ambiguity_sets`` (per named
        field cause: it and the significant candidates it does not beat), ``extended_model``
        (held-out RMSE before and after with every named field cause), ``as_mechanisms``
        (named causes as ``simulation.mechanisms`` entries), ``method``.
    """
    out: dict[str, Any] = {"campaign": campaign, "baseline": {"metrics": {}}, "candidates": [], "named_causes": [],
                           "ambiguity_sets": []}
    named_entries: list[dict[str, Any]] = []
    if windows is not None and len(windows) >= 3:
        metrics, cands, named_entries, out["extended_model"] = _field_part(
            field_data(cast(pd.DataFrame, blocks), windows, block_s), alpha, min_gain, k_folds)
        out["baseline"]["metrics"].update(metrics)
        out["candidates"] += cands
    if runs_file is not None:
        tun = tunnel_candidates(runs_file, alpha, min_gain)
        out["baseline"]["metrics"].update(tun["baseline"])
        out["candidates"] += tun["candidates"]
    out["candidates"].sort(key=lambda c: -(c["gain"] if np.isfinite(c["gain"]) else -np.inf))
    names = []
    for c in [*named_entries, *[c for c in out["candidates"] if c["source"] == "tunnel"]]:
        if c["significant"] and c["mechanism"] not in names:
            names.append(c["mechanism"])
    out["named_causes"] = names
    out["ambiguity_sets"] = [[c["mechanism"], *c.get("ambiguous_with", [])] for c in named_entries]
    out["as_mechanisms"] = _as_mechanisms(out["candidates"])
    out["method"] = ("single-law quasi-steady baseline (Wetz et al. 2021, Eq. 17; c_d0A0, c_p fitted) vs extensions; "
                     f"field: {k_folds}-fold over flights (within flights for per-flight offsets), held-out window "
                     "RMSE, one-sided paired test per UAV log (Wilcoxon signed-rank), per-flight offsets and the "
                     "logged air density in the same rounds as the per-UAV causes, ambiguity by a paired test of "
                     "the named cause against each other significant one; tunnel: leave-one-run-out "
                     "(response_lag) or runs not used in the calibration; "
                     f"alpha={alpha} Bonferroni per round, min gain {min_gain}; see dronewind.diagnose.quadrotor")
    return out


def to_json_ready(node: Any) -> Any:
    """A diagnosis structure with numpy scalars as Python values and non-finite floats as None (JSON)."""
    if isinstance(node, dict):
        return {str(k): to_json_ready(v) for k, v in node.items()}
    if isinstance(node, list | tuple):
        return [to_json_ready(v) for v in node]
    if isinstance(node, np.bool_ | bool):
        return bool(node)
    if isinstance(node, np.integer):
        return int(node)
    if isinstance(node, float | np.floating):
        return float(node) if np.isfinite(node) else None
    return node
