"""Diagnosis steps, from files to files (see :mod:`dronewind.diagnose`).

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

from dronewind.core.cf import atomic_write_text
from dronewind.manifest import load_campaign
from dronewind.steps.common import LOG, open_product
from dronewind.steps.payload import _strip_cf, _track_from_cf


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
    sonic = _strip_cf(open_product(sonic_l1))
    ins = _track_from_cf(_strip_cf(open_product(ins_l1)))
    l2 = _track_from_cf(_strip_cf(open_product(drone_l2)))
    l3 = _strip_cf(open_product(l3_file))
    return sonic, ins, l2, l3


def measured_features(manifest: str | Path, flight_id: str, sonic_l1: str | Path, ins_l1: str | Path,
                      drone_l2: str | Path, l3_file: str | Path, output: str | Path,
                      config: Mapping[str, Any]) -> Path:
    """Residual features of one processed flight, and the forward model's conditions, as JSON."""
    from dronewind.diagnose import forward
    from dronewind.diagnose.features import features_to_dict

    campaign = load_campaign(manifest)
    sonic, ins, l2, l3 = _load_flight(sonic_l1, ins_l1, drone_l2, l3_file)
    feats = forward.measured_features(campaign.data, flight_id, sonic, ins, l2, l3, config)
    conditions = forward.forward_conditions(campaign.data, flight_id, l3, l2)
    LOG.info("flight %s: features %s", flight_id, feats.values)
    from dronewind.diagnose.features import binned_spectra

    return write_json(output, {"flight": flight_id, "features": features_to_dict(feats), "conditions": conditions,
                               "usable": int(l2.attrs.get("usable", 1)), "spectra": binned_spectra(l3)})


def forward_probes(manifest: str | Path, flight_id: str, measured_json: str | Path, output: str | Path,
                   config: Mapping[str, Any]) -> Path:
    """Forward-model runs (baseline seeds and every probe) of one flight, as JSON."""
    from dronewind.diagnose import forward

    campaign = load_campaign(manifest)
    measured = json.loads(Path(measured_json).read_text())
    runs = forward.probe_runs(campaign.data, flight_id, measured["conditions"], config,
                              seeds=tuple(config.get("diagnosis", {}).get("seeds", (101, 202))))
    return write_json(output, runs)


def _evidence(measured_files: Sequence[str | Path], forward_files: Sequence[str | Path]) -> Any:
    from dronewind.diagnose import campaign as dc

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
                      output_manifest: str | Path, config: Mapping[str, Any]) -> Path:
    """Fit and score every candidate, name causes; write diagnosis.json and the extended manifest."""
    from dronewind.diagnose import campaign as dc

    campaign = load_campaign(manifest)
    diag_cfg = config.get("diagnosis", {})
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
    result = dc.diagnose(ev, alpha=float(diag_cfg.get("alpha", 0.01)),
                         max_causes=int(diag_cfg.get("max_causes", 3)),
                         min_gain=float(diag_cfg.get("min_gain", dc.MIN_GAIN)))
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


def extended_run(extended_manifest_file: str | Path, flight_id: str, output: str | Path,
                 config: Mapping[str, Any], seeds: Sequence[int] = (303, 404)) -> Path:
    """Rerun one flight of the extended campaign (fresh seeds) and store its features."""
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
                                              flight_id, config)
        out["runs"].append(features_to_dict(feats))
        if k == 0:
            # spectra before/after with common random numbers: the same seed without the mechanisms
            out["spectra"] = {"extended": binned_spectra(products["l3"])}
            if mechanisms:
                _, base = forward.run_forward(forward.forward_manifest(data, flight_id, conditions, [], seed),
                                              flight_id, config)
                out["spectra"]["baseline"] = binned_spectra(base["l3"])
            else:
                out["spectra"]["baseline"] = out["spectra"]["extended"]
    return write_json(output, out)


def diagnosis_report(diagnosis_json: str | Path, measured_files: Sequence[str | Path],
                     forward_files: Sequence[str | Path], extended_files: Sequence[str | Path],
                     output_md: str | Path, output_csv: str | Path, figures_dir: str | Path) -> list[Path]:
    """Before/after numbers (baseline vs rerun extended model), Markdown report, figures."""
    from dronewind.diagnose import campaign as dc
    from dronewind.diagnose import report
    from dronewind.diagnose.features import FEATURES

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
    figs = report.figures(ev, after, diag, Path(figures_dir))
    figs += report.spectra_figure(ev, measured_spectra, model_spectra, diag, Path(figures_dir))
    return [Path(output_md), Path(output_csv), *figs]
