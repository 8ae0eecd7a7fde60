"""Diagnosis steps, from files to files (see :mod:`dronewind.diagnose`).

Each step takes what it uses as arguments: the per-flight steps the one-flight view of the
manifest (:func:`dronewind.manifest.payload_flight_manifest`) and the ``processing`` and
``diagnosis`` settings of their rule, the campaign-level steps the manifest file.

1. :func:`measured_features` (per flight): residual features of the processed flight.
2. :func:`forward_probes` (per flight): the forward model of the flight, baseline and
   every candidate mechanism at its probe levels, processed like the measured flight.
3. :func:`diagnose_campaign`: fit, cross-validate, name causes, write ``diagnosis.json``
   and the extended campaign manifest.
4. :func:`extended_run` (per flight): the extended model (named causes at their fitted
   values) rerun for the flight.
5. :func:`diagnosis_report`: before/after numbers, Markdown report and figures.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from dronewind.core.cf import atomic_write_text, strip_cf, track_from_cf
from dronewind.core.products import open_product
from dronewind.diagnose import campaign as dc
from dronewind.manifest import load_campaign
from dronewind.steps.common import LOG


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {type(value)}")


def _clean(node: Any) -> Any:
    """NaN and inf become None (strict JSON)."""
    if isinstance(node, dict):
        return {k: _clean(v) for k, v in node.items()}
    if isinstance(node, list | tuple):
        return [_clean(v) for v in node]
    if isinstance(node, float | np.floating):
        return float(node) if math.isfinite(node) else None
    return node


def write_json(path: str | Path, data: Any) -> Path:
    """Write strict JSON atomically."""
    return atomic_write_text(path, json.dumps(_clean(data), indent=2, sort_keys=True, default=_json_default) + "\n")


def _load_flight(sonic_l1: str | Path, ins_l1: str | Path, drone_l2: str | Path, l3_file: str | Path
                 ) -> tuple[Any, Any, Any, Any]:
    sonic = strip_cf(open_product(sonic_l1))
    ins = track_from_cf(strip_cf(open_product(ins_l1)))
    l2 = track_from_cf(strip_cf(open_product(drone_l2)))
    l3 = strip_cf(open_product(l3_file))
    return sonic, ins, l2, l3


def measured_features(sonic_l1: str | Path, ins_l1: str | Path, drone_l2: str | Path, l3_file: str | Path,
                      output: str | Path, *, campaign: Mapping[str, Any], flight_id: str,
                      sonic_ins_lag: Mapping[str, Any], hover: Mapping[str, Any], max_missing_fraction: float) -> Path:
    """Residual features of one processed flight, and the forward model's conditions, as JSON.

    Parameters
    ----------
    sonic_l1, ins_l1, drone_l2, l3_file : str or Path
        The flight's products.
    output : str or Path
        JSON file to write.
    campaign : mapping
        One-flight view of the manifest (:func:`dronewind.manifest.payload_flight_manifest`).
    flight_id : str
        Payload flight id.
    sonic_ins_lag, hover, max_missing_fraction
        ``processing`` settings of the sonic-INS lag feature.

    Returns
    -------
    Path
        The written file.
    """
    from dronewind.diagnose import forward
    from dronewind.diagnose.features import binned_spectra, features_to_dict

    sonic, ins, l2, l3 = _load_flight(sonic_l1, ins_l1, drone_l2, l3_file)
    feats = forward.measured_features(campaign, flight_id, sonic, ins, l2, l3, sonic_ins_lag=sonic_ins_lag,
                                      hover=hover, max_missing_fraction=max_missing_fraction)
    conditions = forward.forward_conditions(campaign, flight_id, l3, l2)
    LOG.info("flight %s: features %s", flight_id, feats.values)
    return write_json(output, {"flight": flight_id, "features": features_to_dict(feats), "conditions": conditions,
                               "usable": int(l2.attrs.get("usable", 1)), "spectra": binned_spectra(l3)})


def forward_probes(measured_json: str | Path, output: str | Path, *, campaign: Mapping[str, Any], flight_id: str,
                   processing: Mapping[str, Any], seeds: Sequence[int], part: str | None = None) -> Path:
    """Forward-model runs (baseline seeds and every probe, or one part of them) of one flight, as JSON.

    Parameters
    ----------
    measured_json : str or Path
        Output of :func:`measured_features` (the forward conditions).
    output : str or Path
        JSON file to write.
    campaign : mapping
        One-flight view of the manifest.
    flight_id : str
        Payload flight id.
    processing : mapping
        ``processing`` settings of the chain (:data:`dronewind.diagnose.forward.CHAIN_SETTINGS`).
    seeds : sequence of int
        ``diagnosis.seeds``.
    part : str, optional
        Only this part (``"baseline"`` or a mechanism,
        :func:`dronewind.diagnose.forward.probe_parts`); all by default.

    Returns
    -------
    Path
        The written file.
    """
    from dronewind.diagnose import forward

    measured = json.loads(Path(measured_json).read_text())
    runs = forward.probe_runs(campaign, flight_id, measured["conditions"], processing, seeds=tuple(seeds),
                              parts=None if part is None else [part])
    return write_json(output, runs)


def merge_forward_parts(part_files: Sequence[str | Path], output: str | Path) -> Path:
    """Join the per-part forward runs of one flight into the flight's forward JSON.

    Parameters
    ----------
    part_files : sequence of str or Path
        Outputs of :func:`forward_probes` (or :func:`dronewind.steps.published.published_forward`)
        with ``part``, one per part.
    output : str or Path
        JSON file to write (the same content as one job per flight writes).

    Returns
    -------
    Path
        The written file.
    """
    from dronewind.diagnose import forward

    return write_json(output, forward.merge_probe_runs([json.loads(Path(f).read_text()) for f in part_files]))


def _evidence(measured_files: Sequence[str | Path], forward_files: Sequence[str | Path]) -> dc.CampaignEvidence:
    """The campaign evidence of the usable flights' measured and forward-model feature files."""

    measured, fwd = {}, {}
    for path in measured_files:
        m = json.loads(Path(path).read_text())
        if m.get("usable", 1):
            measured[m["flight"]] = m["features"]
        else:
            LOG.warning("flight %s is unusable: left out of the diagnosis", m["flight"])
    for path in forward_files:
        f = json.loads(Path(path).read_text())
        if f["flight"] in measured:
            fwd[f["flight"]] = f
    return dc.assemble(measured, fwd)


def extended_manifest(campaign_data: Mapping[str, Any], conditions: Mapping[str, Mapping[str, Any]],
                      mechanisms: list[dict[str, Any]], seed: int = 101) -> dict[str, Any]:
    """The campaign as a virtual campaign: measured conditions per flight plus the named mechanisms."""
    import copy

    data = {k: copy.deepcopy(v) for k, v in campaign_data.items() if k not in ("simulation",)}
    data["name"] = f"{campaign_data['name']}_extended"
    flights = []
    for f in data.get("payload_flights") or []:
        if f["id"] in conditions:
            f = dict(f)
            f.pop("window", None)
            flights.append(f)
    data["payload_flights"] = flights
    data["quadrotor_flights"] = []
    data.pop("tunnel", None)
    data["simulation"] = {"seed": int(seed), "payload_flights": {k: dict(v) for k, v in conditions.items()},
                          "mechanisms": mechanisms}
    return data


def diagnose_campaign(manifest: str | Path, measured_files: Sequence[str | Path],
                      forward_files: Sequence[str | Path], output_json: str | Path,
                      output_manifest: str | Path, *, alpha: float, max_causes: int, min_gain: float) -> Path:
    """Fit and score every candidate, name causes; write diagnosis.json and the extended manifest.

    ``alpha``, ``max_causes`` and ``min_gain`` are the ``diagnosis`` settings (see
    :func:`dronewind.diagnose.campaign.diagnose`).
    """

    campaign = load_campaign(manifest)
    ev = _evidence(measured_files, forward_files)
    if len(ev.flights) < 2:
        result_json = {"campaign": campaign.name, "baseline": {"metrics": {}}, "candidates": [],
                       "named_causes": [], "ambiguity_sets": [],
                       "note": f"{len(ev.flights)} usable flight(s): held-out scoring needs at least 2"}
        write_json(output_json, result_json)
        conditions = {f: c for f, c in zip(ev.flights, ev.conditions, strict=True)}
        atomic_write_text(output_manifest, yaml.safe_dump(extended_manifest(campaign.data, conditions, []),
                                                          sort_keys=False))
        return Path(output_json)
    result = dc.diagnose(ev, alpha=float(alpha), max_causes=int(max_causes), min_gain=float(min_gain))
    out = dc.to_json(result, campaign.name)
    out["baseline"]["residuals"] = dc.residual_table(ev)
    out["baseline"]["wind_speed_slopes"] = dc.wind_speed_slopes(ev)
    out["extended"] = {"prediction_metrics": dc.baseline_metrics(ev, dc.combined_prediction(result)),
                       "mechanisms": dc.named_mechanisms(result)}
    LOG.info("named causes: %s", out["named_causes"] or "none")
    for cand in out["candidates"]:
        LOG.info("candidate %-20s gain %6.3f p %.2g significant %s estimate %s", cand["mechanism"], cand["gain"],
                 cand["p_value"], cand["significant"], cand["estimate"])
    conditions = {f: c for f, c in zip(ev.flights, ev.conditions, strict=True)}
    atomic_write_text(output_manifest, "# The campaign as a virtual campaign: conditions estimated from the processed\n"
                      "# data, plus the mechanisms the diagnosis named, at their fitted values.\n"
                      + yaml.safe_dump(extended_manifest(campaign.data, conditions, dc.named_mechanisms(result)),
                                       sort_keys=False))
    return write_json(output_json, out)


def extended_run(extended_manifest_file: str | Path, output: str | Path, *, flight_id: str,
                 processing: Mapping[str, Any], seeds: Sequence[int] = (303, 404)) -> Path:
    """Rerun one flight of the extended campaign (fresh seeds) and store its features.

    ``processing`` holds the chain settings (:data:`dronewind.diagnose.forward.CHAIN_SETTINGS`).
    """
    from dronewind.diagnose import forward
    from dronewind.diagnose.features import features_to_dict

    data = yaml.safe_load(Path(extended_manifest_file).read_text())
    conditions = data["simulation"]["payload_flights"].get(flight_id)
    out: dict[str, Any] = {"flight": flight_id, "runs": []}
    if conditions is None:
        out["note"] = "flight not in the extended campaign (unusable)"
        return write_json(output, out)
    from dronewind.diagnose.features import binned_spectra

    mechanisms = data["simulation"].get("mechanisms") or []
    for k, seed in enumerate(seeds):
        feats, products = forward.run_forward(forward.forward_manifest(data, flight_id, conditions, mechanisms, seed),
                                              flight_id, processing)
        out["runs"].append(features_to_dict(feats))
        if k == 0:
            # spectra before/after with common random numbers: the same seed without the mechanisms
            out["spectra"] = {"extended": binned_spectra(products["l3"])}
            if mechanisms:
                _, base = forward.run_forward(forward.forward_manifest(data, flight_id, conditions, [], seed),
                                              flight_id, processing)
                out["spectra"]["baseline"] = binned_spectra(base["l3"])
            else:
                out["spectra"]["baseline"] = out["spectra"]["extended"]
    return write_json(output, out)


def diagnosis_report(diagnosis_json: str | Path, measured_files: Sequence[str | Path],
                     forward_files: Sequence[str | Path], extended_files: Sequence[str | Path],
                     output_md: str | Path, output_csv: str | Path, figures_dir: str | Path) -> list[Path]:
    """Before/after numbers (baseline vs rerun extended model), Markdown report, figures."""
    from dronewind.diagnose import report
    from dronewind.diagnose.features import FEATURES
    from dronewind.figures import diagnosis as diagnosis_figures

    diag = json.loads(Path(diagnosis_json).read_text())
    ev = _evidence(measured_files, forward_files)
    extended, model_spectra = {}, {}
    for path in extended_files:
        e = json.loads(Path(path).read_text())
        if e.get("spectra"):
            model_spectra[e["flight"]] = e["spectra"]
        if e.get("runs"):
            extended[e["flight"]] = np.nanmean(np.array([[np.nan if r["values"].get(f) is None else r["values"][f]
                                                          for f in FEATURES] for r in e["runs"]]), axis=0)
    after = np.array([extended.get(f, np.full(len(FEATURES), np.nan)) for f in ev.flights]) if ev.flights else None
    before_metrics = dc.baseline_metrics(ev) if ev.flights else {}
    after_metrics = dc.baseline_metrics(ev, after) if ev.flights else {}
    diag["extended"] = {**diag.get("extended", {}), "rerun_metrics": after_metrics}
    rows = dc.residual_table(ev) if ev.flights else []
    rows_after = dc.residual_table(ev, after) if ev.flights else []
    for row, row_after in zip(rows, rows_after, strict=True):
        row["predicted_extended"] = row_after["predicted"]
        row["z_extended"] = row_after["z"]
    import pandas as pd

    atomic_write_text(output_csv, pd.DataFrame(rows).to_csv(index=False, float_format="%.6g"))
    text = report.markdown(diag, before_metrics, after_metrics, rows)
    atomic_write_text(output_md, text)
    measured_spectra = {}
    for path in measured_files:
        m = json.loads(Path(path).read_text())
        if m.get("spectra"):
            measured_spectra[m["flight"]] = m["spectra"]
    figs = diagnosis_figures.residuals_figure(ev, after, diag, Path(figures_dir), features=FEATURES,
                                              labels=report.FEATURE_LABELS)
    figs += diagnosis_figures.spectra_figure(ev, measured_spectra, model_spectra, diag, Path(figures_dir))
    return [Path(output_md), Path(output_csv), *figs]
