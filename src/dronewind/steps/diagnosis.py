"""Diagnosis steps, from files to files (see :mod:`dronewind.diagnose`).

Each step takes what it uses as arguments: the per-flight steps the one-flight view of the
manifest (:func:`dronewind.manifest.payload_flight_manifest`) and the ``processing`` and
``diagnosis`` settings of their rule, the campaign-level steps the manifest file.

1. :func:`measured_features` (per flight): residual features of the processed flight.
2. :func:`forward_probes` (per flight): the forward model of the flight, baseline and
   every candidate mechanism at its probe levels, processed like the measured flight.
3. :func:`diagnose_campaign`: fit, cross-validate, name causes, write ``diagnosis.json``
   and the extended campaign manifest.
4. :func:`extended_run` (per flight; :func:`extended_runs` runs every flight in one job): the
   extended model (named causes at their fitted values) rerun for the flight.
5. :func:`diagnosis_report`: before/after numbers, Markdown report and figures.
"""

from __future__ import annotations

import gc
import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from dronewind.core.cf import atomic_write_arrays, atomic_write_text
from dronewind.core.cf_names import strip_cf, track_from_cf
from dronewind.core.products import open_product
from dronewind.core.yamltext import load_yaml
from dronewind.diagnose import campaign as dc
from dronewind.diagnose.probes import MIN_FLIGHTS
from dronewind.diagnose.record import not_diagnosed_json
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
                      sonic_ins_lag: Mapping[str, Any], hover: Mapping[str, Any], max_missing_fraction: float,
                      forward_payload: Mapping[str, Any] | None = None) -> Path:
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
    forward_payload : mapping, optional
        ``diagnosis.forward_payload``: the forward model's payload settings, carried by the
        conditions (:func:`dronewind.diagnose.forward_conditions.forward_conditions`).

    Returns
    -------
    Path
        The written file.
    """
    from dronewind.diagnose import forward, forward_conditions
    from dronewind.diagnose.features import binned_spectra, features_to_dict

    sonic, ins, l2, l3 = _load_flight(sonic_l1, ins_l1, drone_l2, l3_file)
    if "mast" not in [str(s) for s in np.asarray(l3["sensor"].values).astype(str)]:
        # no usable reference over the flight (its mast record unreadable or not covering the
        # hover): no drone-mast feature to compare, so the flight is left out of the diagnosis
        reason = str(l3.attrs.get("reference_unusable_reason") or "no reference mast sonic in the L3")
        LOG.warning("flight %s: left out of the diagnosis: %s", flight_id, reason)
        return write_json(output, {"flight": flight_id, "features": None, "conditions": None, "usable": 0,
                                   "reason": reason})
    feats = forward.measured_features(campaign, flight_id, sonic, ins, l2, l3, sonic_ins_lag=sonic_ins_lag,
                                      hover=hover, max_missing_fraction=max_missing_fraction)
    conditions = forward_conditions.forward_conditions(campaign, flight_id, l3, l2, forward_payload, ins)
    LOG.info("flight %s: features %s", flight_id, feats.values)
    usable = int(l2.attrs.get("usable", 1))
    left_out = {} if usable else {"reason": str(l2.attrs.get("unusable_reason", ""))}
    return write_json(output, {"flight": flight_id, "features": features_to_dict(feats), "conditions": conditions,
                               "usable": usable, **left_out, "spectra": binned_spectra(l3)})


def forward_probes(measured_json: str | Path, output: str | Path, *, campaign: Mapping[str, Any], flight_id: str,
                   processing: Mapping[str, Any], seeds: Sequence[int], parts: Sequence[str] | None = None,
                   mast_l1: str | Path | None = None, atmosphere: str = "model",
                   joined_with: Sequence[str | Path] = ()) -> Path:
    """Forward-model runs (baseline seeds and every probe, or one part of them) of one flight, as JSON.

    A flight the campaign diagnosis leaves out (no reference mast sonic over it, or its payload
    L2 unusable) gets a placeholder without runs (``usable`` 0 and the reason).

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
        ``processing`` settings of the chain (:data:`dronewind.diagnose.probes.CHAIN_SETTINGS`).
    seeds : sequence of int
        ``diagnosis.seeds``.
    parts : sequence of str, optional
        Only these parts (``"baseline"``, a share of its seeds ``"baseline:k/n"`` or a
        mechanism, :func:`dronewind.diagnose.probes.probe_parts`); all by default.
    mast_l1 : str or Path, optional
        L1 of the flight's reference mast sonic (needed for ``atmosphere="measured"``).
    atmosphere : {"model", "measured"}
        ``diagnosis.atmosphere``: the forward runs' turbulence is the similarity model's, or
        the reference mast's measured record
        (:func:`dronewind.diagnose.forward_atmosphere.atmosphere_record`).
    joined_with : sequence of str or Path
        Outputs of this function for the flight's other parts: the file written is the
        flight's runs of all parts joined (:func:`dronewind.diagnose.probe_runs.merge_probe_runs`),
        the same as one job of the whole flight writes.

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    InputError
        An unknown ``atmosphere``, or ``measured`` without ``mast_l1``.
    """

    from dronewind.diagnose import probe_runs
    measured = json.loads(Path(measured_json).read_text())
    if measured.get("conditions") is None or not measured.get("usable", 1):
        # a flight the campaign diagnosis leaves out (no reference, or its L2 unusable: measured_features)
        # has no forward runs: nothing would read them
        return write_json(output, {"flight": flight_id, "usable": 0, "reason": measured.get("reason", ""),
                                   "atmosphere": atmosphere})
    record = _atmosphere(mast_l1, atmosphere, measured["conditions"])
    runs = probe_runs.probe_runs(campaign, flight_id, measured["conditions"], processing, seeds=tuple(seeds),
                              parts=None if parts is None else list(parts), atmosphere=record)
    if joined_with:
        runs = probe_runs.merge_probe_runs([*(json.loads(Path(f).read_text()) for f in joined_with), runs])
    return write_json(output, runs)


def _atmosphere(mast_l1: str | Path | None, atmosphere: str, conditions: Mapping[str, Any]) -> Any:
    """The forward runs' atmosphere record (``diagnosis.atmosphere``): None for ``model``,
    the reference mast's L1 around the flight for ``measured``
    (:func:`dronewind.diagnose.forward_atmosphere.atmosphere_record`).

    Raises
    ------
    InputError
        An unknown ``atmosphere``, or ``measured`` without ``mast_l1``.
    """
    from dronewind.diagnose import forward_atmosphere, probes
    from dronewind.errors import InputError

    if atmosphere not in probes.ATMOSPHERES:
        raise InputError("diagnosis.atmosphere", f"{atmosphere!r}; expected one of {probes.ATMOSPHERES}")
    if atmosphere == "model":
        return None
    if mast_l1 is None:
        raise InputError("diagnosis.atmosphere", "'measured' needs the reference mast's L1 (mast_l1)")
    # only the record's wind and temperature around the flight are read, not the whole L1
    record = open_product(mast_l1, forward_atmosphere.ATMOSPHERE_VARIABLES,
                          forward_atmosphere.atmosphere_window(conditions))
    return forward_atmosphere.atmosphere_record(strip_cf(record), conditions, str(mast_l1))


def merge_forward_parts(part_files: Sequence[str | Path], output: str | Path) -> Path:
    """Join the per-part forward runs of one flight into the flight's forward JSON.

    Parameters
    ----------
    part_files : sequence of str or Path
        Outputs of :func:`forward_probes` (or :func:`dronewind.steps.published.published_forward`)
        with ``parts``, together covering the flight's parts once.
    output : str or Path
        JSON file to write (the same content as one run of the whole flight writes).

    Returns
    -------
    Path
        The written file.
    """

    from dronewind.diagnose import probe_runs
    parts = [json.loads(Path(f).read_text()) for f in part_files]
    if any(p.get("usable", 1) == 0 and "baseline" not in p and "probes" not in p for p in parts):
        return write_json(output, parts[0])  # a flight left out of the diagnosis: its placeholder
    return write_json(output, probe_runs.merge_probe_runs(parts))


def _evidence(measured_files: Sequence[str | Path], forward_files: Sequence[str | Path]
              ) -> tuple[dc.CampaignEvidence, dict[str, str]]:
    """The campaign evidence of the usable flights' measured and forward-model feature files, and
    the flights left out (flight -> the reason its measured file gives, "" where none)."""

    measured, fwd, left_out = {}, {}, {}
    for path in measured_files:
        m = json.loads(Path(path).read_text())
        if m.get("usable", 1):
            measured[m["flight"]] = m["features"]
        else:
            left_out[m["flight"]] = str(m.get("reason") or "")
            LOG.warning("flight %s is unusable: left out of the diagnosis (%s)", m["flight"],
                        left_out[m["flight"]] or "no reason recorded")
    for path in forward_files:
        f = json.loads(Path(path).read_text())
        if f["flight"] in measured:
            fwd[f["flight"]] = f
    return dc.assemble(measured, fwd), left_out


def _rerun_conditions(ev: dc.CampaignEvidence, forward_files: Sequence[str | Path]) -> dict[str, dict[str, Any]]:
    """Each flight's conditions for the extended model's reruns.

    A measured sonic-INS lag is replaced by the lag the forward runs simulated to reproduce it
    (:func:`dronewind.diagnose.probe_runs.simulated_sonic_ins_lag_s`), so that the reruns' chain
    finds the measured lag as the forward runs' did.
    """
    simulated = {}
    for path in forward_files:
        f = json.loads(Path(path).read_text())
        if f.get("simulated_sonic_ins_lag_s") is not None:
            simulated[f["flight"]] = float(f["simulated_sonic_ins_lag_s"])
    out = {}
    for flight, cond in zip(ev.flights, ev.conditions, strict=True):
        out[flight] = dict(cond)
        if flight in simulated and "sonic_ins_lag_s" in cond:
            out[flight]["sonic_ins_lag_s"] = simulated[flight]
    return out


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
    from dronewind.diagnose.forward_conditions import split_payload
    from dronewind.errors import InputError

    split = {k: split_payload(v) for k, v in conditions.items()}
    payloads = [payload for _, payload in split.values()]
    if any(p != payloads[0] for p in payloads):
        raise InputError("diagnosis.forward_payload", "the flights' forward payload settings differ; expected one "
                         "setting for the campaign")
    data["simulation"] = {"seed": int(seed), "payload_flights": {k: flight for k, (flight, _) in split.items()},
                          "mechanisms": mechanisms}
    payload = payloads[0] if payloads else {}
    if payload:
        data["simulation"]["payload"] = payload
    return data


def diagnosis_reference(measured_files: Sequence[str | Path], forward_files: Sequence[str | Path],
                        output: str | Path, *, bootstrap: int, part: int, parts: int) -> Path:
    """One part of the campaign diagnosis' bootstrap reference, as a NumPy ``.npz`` file.

    The ``diagnose_reference`` jobs draw the ``bootstrap`` replicates in ``parts`` parts
    (:func:`dronewind.diagnose.naming.reference_part`); :func:`diagnose_campaign` joins them
    into the reference it would otherwise draw itself, number for number. A campaign for which
    the diagnosis draws no reference (fewer than two usable flights or seeds, no candidate)
    gets a file without replicates (``n_replicates`` 0).
    """
    from dronewind.diagnose.reference import reference_arrays, replicate_part

    ev, _ = _evidence(measured_files, forward_files)
    ref = None
    if len(ev.flights) >= MIN_FLIGHTS:
        replicates = len(replicate_part(int(bootstrap), int(part), int(parts)))
        ref = dc.reference_part(ev, int(bootstrap), int(part), int(parts),
                                progress=_replicate_counter(replicates, every=50))
    arrays = {"n_replicates": np.array(0)} if ref is None else reference_arrays(ref)
    LOG.info("bootstrap part %d of %d: %d replicates", int(part) + 1, int(parts), int(arrays["n_replicates"]))
    return atomic_write_arrays(output, arrays)


def _joined_reference(files: Sequence[str | Path], bootstrap: int) -> Any:
    """The bootstrap reference of the ``diagnose_reference`` parts (None when they hold none).

    Raises
    ------
    InputError
        The parts do not add up to ``bootstrap`` replicates (files of another setting).
    """
    from dronewind.diagnose.reference import joined_reference, reference_from_arrays
    from dronewind.errors import InputError

    parts = []
    for path in files:
        with np.load(path) as data:
            arrays = {k: data[k] for k in data.files}
        if int(arrays["n_replicates"]) == 0:
            return None
        parts.append(reference_from_arrays(arrays))
    ref = joined_reference(parts)
    if ref.n_replicates != int(bootstrap):
        raise InputError(str(files[0]), f"the reference parts hold {ref.n_replicates} replicates; diagnosis.bootstrap "
                         f"is {int(bootstrap)} (rerun diagnose_reference)")
    return ref


def diagnose_campaign(manifest: str | Path, measured_files: Sequence[str | Path],
                      forward_files: Sequence[str | Path], output_json: str | Path,
                      output_manifest: str | Path, *, alpha: float, max_causes: int, min_gain: float,
                      platform_files: Sequence[str | Path] = (), atmosphere: str = "model",
                      bootstrap: int = 600, reference_files: Sequence[str | Path] = ()) -> Path:
    """Fit and score every candidate, name causes; write diagnosis.json and the extended manifest.

    ``alpha``, ``max_causes``, ``min_gain`` and ``bootstrap`` (replicates of the reference
    distributions) are the ``diagnosis`` settings (see
    :func:`dronewind.diagnose.campaign.diagnose`); ``atmosphere`` (``diagnosis.atmosphere``)
    is recorded in diagnosis.json after checking that every forward file was run with it.
    ``platform_files``: the rigid-mount flights' platform-response results
    (:func:`platform_diagnosis`), added to the candidates, named causes and a ``rigid_mount``
    section (:func:`platform_entries`). ``reference_files``: the bootstrap reference in parts
    (:func:`diagnosis_reference`, in order), joined instead of drawn here.
    """

    campaign = load_campaign(manifest)
    _check_atmosphere(forward_files, atmosphere)
    ev, left_out = _evidence(measured_files, forward_files)
    if len(ev.flights) < MIN_FLIGHTS:
        result_json = {**not_diagnosed_json(campaign.name, len(ev.flights), left_out), "atmosphere": atmosphere}
        write_json(output_json, _with_platform(result_json, platform_files))
        conditions = _rerun_conditions(ev, forward_files)
        atomic_write_text(output_manifest, yaml.safe_dump(extended_manifest(campaign.data, conditions, []),
                                                          sort_keys=False))
        return Path(output_json)
    reference = _joined_reference(reference_files, int(bootstrap)) if reference_files else None
    result = dc.diagnose(ev, alpha=float(alpha), max_causes=int(max_causes), min_gain=float(min_gain),
                         n_replicates=int(bootstrap), progress=_replicate_counter(int(bootstrap)), reference=reference)
    out = dc.to_json(result, campaign.name)
    out["atmosphere"] = atmosphere
    out["baseline"]["wind_speed_slopes"] = dc.wind_speed_slopes(ev)
    out["extended"] = {"prediction_metrics": dc.baseline_metrics(ev, dc.combined_prediction(result)),
                       "mechanisms": dc.named_mechanisms(result)}
    LOG.info("named causes: %s", out["named_causes"] or "none")
    for cand in out["candidates"]:
        LOG.info("candidate %-20s gain %6.3f p %.2g significant %s estimate %s", cand["mechanism"], cand["gain"],
                 cand["p_value"], cand["significant"], cand["estimate"])
    conditions = _rerun_conditions(ev, forward_files)
    atomic_write_text(output_manifest, "# The campaign as a virtual campaign: conditions estimated from the processed\n"
                      "# data, plus the mechanisms the diagnosis named, at their fitted values.\n"
                      + yaml.safe_dump(extended_manifest(campaign.data, conditions, dc.named_mechanisms(result)),
                                       sort_keys=False))
    return write_json(output_json, _with_platform(out, platform_files))


def _replicate_counter(total: int, every: int = 100) -> Any:
    """A callback that logs the bootstrap's progress every ``every`` replicates."""
    done = [0]

    def tick() -> None:
        done[0] += 1
        if done[0] % every == 0 or done[0] == total:
            LOG.info("bootstrap replicate %d/%d", done[0], total)

    return tick


def _check_atmosphere(forward_files: Sequence[str | Path], atmosphere: str) -> None:
    """Every forward file was run with ``atmosphere`` (files without the key: the model atmosphere)."""
    from dronewind.errors import InputError

    for path in forward_files:
        used = json.loads(Path(path).read_text()).get("atmosphere", "model")
        if used != atmosphere:
            raise InputError(str(path), f"forward runs with the {used!r} atmosphere; diagnosis.atmosphere is "
                             f"{atmosphere!r} (rerun the forward rules)")


def _with_platform(out: dict[str, Any], platform_files: Sequence[str | Path]) -> dict[str, Any]:
    """diagnosis.json with the rigid-mount flights' entries appended (unchanged without any)."""
    if not platform_files:
        return out
    entries = platform_entries(platform_files)
    out["candidates"] = list(out.get("candidates") or []) + entries["candidates"]
    out["named_causes"] = list(out.get("named_causes") or []) + entries["named_causes"]
    if "named_estimates" in entries:
        out["named_estimates"] = {**(out.get("named_estimates") or {}), **entries["named_estimates"]}
    out["rigid_mount"] = entries["rigid_mount"]
    if entries.get("unexplained"):
        out["unexplained"] = list(out.get("unexplained") or []) + entries["unexplained"]
    return out


def extended_run(extended_manifest_file: str | Path, output: str | Path, *, flight_id: str,
                 processing: Mapping[str, Any], seeds: Sequence[int],
                 mast_l1: str | Path | None = None, atmosphere: str = "model") -> Path:
    """Rerun one flight of the extended campaign (fresh seeds) and store its features.

    ``processing`` holds the chain settings (:data:`dronewind.diagnose.probes.CHAIN_SETTINGS`);
    ``seeds`` are fresh seeds, none of ``diagnosis.seeds`` (:func:`dronewind.diagnose.probes.fresh_seeds`).
    ``mast_l1`` and ``atmosphere`` as for :func:`forward_probes`: with the measured
    atmosphere the rerun takes the same record as the baseline runs, read through the named
    mechanisms that act on it (:func:`dronewind.diagnose.forward_atmosphere.record_through`), so that
    the before/after comparison changes only the named causes.
    """
    from dronewind.diagnose import forward, forward_atmosphere, forward_conditions, probe_runs
    from dronewind.diagnose.features import features_to_dict

    data = load_yaml(Path(extended_manifest_file).read_text())
    conditions = data["simulation"]["payload_flights"].get(flight_id)
    out: dict[str, Any] = {"flight": flight_id, "runs": []}
    if conditions is None:
        out["note"] = "flight not in the extended campaign (unusable)"
        return write_json(output, out)
    from dronewind.diagnose.features import binned_spectra

    mechanisms = data["simulation"].get("mechanisms") or []
    base_record = _atmosphere(mast_l1, atmosphere, conditions)
    measured = base_record is not None
    record = None if base_record is None else forward_atmosphere.record_through(base_record, mechanisms)
    out["atmosphere"] = atmosphere
    # the seeds' runs share what their records share (with the measured atmosphere, the
    # forward mast's record is the measured one in every run): products and steps of the
    # first run are reused where a later run's inputs are bit-identical. The report reads
    # the runs' feature values only (diagnosis_report): their errors are not computed.
    cache = forward.ForwardCache()
    for k, seed in enumerate(seeds):
        feats, products = forward.run_forward(
            forward_conditions.forward_manifest(data, flight_id, conditions, mechanisms, seed, measured), flight_id,
            processing,
            atmosphere=record, cache=cache, errors=False)
        cache.freeze()
        out["runs"].append(features_to_dict(feats))
        if k == 0:
            # spectra before/after with common random numbers: the same seed without the mechanisms
            out["spectra"] = {"extended": binned_spectra(products["l3"])}
            if mechanisms:
                # the same true state where the mechanisms act on the measurement only
                truth = products["truth"] if probe_runs.shares_truth(mechanisms, measured) else None
                _, base = forward.run_forward(forward_conditions.forward_manifest(data, flight_id, conditions, [], seed,
                                                                       measured), flight_id, processing,
                                              truth=truth, atmosphere=base_record, cache=cache,
                                              features=(), errors=False)  # its spectra only
                out["spectra"]["baseline"] = binned_spectra(base["l3"])
                del base
            else:
                out["spectra"]["baseline"] = out["spectra"]["extended"]
        del products  # not read again: freed before the next seed's run (one run's datasets at a time)
    return write_json(output, out)


def extended_runs(extended_manifest_file: str | Path, outputs: Mapping[str, str | Path], *,
                  processing: Mapping[str, Any], seeds: Sequence[int],
                  mast_l1: Mapping[str, str | Path] | None = None, atmosphere: str = "model") -> list[Path]:
    """:func:`extended_run` for several flights in one job (the workflow's ``diagnose``, after the diagnosis).

    A flight's rerun is a few forward runs (about 0.3 CPU-s on the default campaign) where a job
    starts in about 1 CPU-s, and every flight's rerun reads the one extended manifest, so that a
    change of it reruns them all: the flights share one job.

    Parameters
    ----------
    extended_manifest_file : str or Path
        The extended campaign manifest (:func:`diagnose_campaign`).
    outputs : mapping
        Flight id -> the JSON file of its rerun, in the order they are run.
    processing, seeds, atmosphere
        As for :func:`extended_run`.
    mast_l1 : mapping, optional
        Flight id -> L1 of its reference mast sonic (needed for ``atmosphere="measured"``).

    Returns
    -------
    list of Path
        The written files, in the order of ``outputs``.
    """
    written = []
    for k, (flight_id, output) in enumerate(outputs.items(), start=1):
        written.append(extended_run(extended_manifest_file, output, flight_id=flight_id, processing=processing,
                                    seeds=seeds, mast_l1=(mast_l1 or {}).get(flight_id), atmosphere=atmosphere))
        # a run's datasets sit in reference cycles until the cyclic collector passes: collected
        # here, the job's peak memory is one flight's (the default campaign's ten flights: 588 MB
        # without, 446 MB with; published_reruns' seven samples: 1104 and 499 MB)
        gc.collect()
        LOG.info("extended rerun %d/%d: flight %s written", k, len(outputs), flight_id)
    return written


def diagnosis_report(diagnosis_json: str | Path, measured_files: Sequence[str | Path],
                     forward_files: Sequence[str | Path], extended_files: Sequence[str | Path],
                     output_md: str | Path, output_csv: str | Path, figures_dir: str | Path) -> list[Path]:
    """Before/after numbers (baseline vs rerun extended model), Markdown report, figures."""
    from dronewind.diagnose import report
    from dronewind.diagnose.features import FEATURES
    from dronewind.figures import diagnosis as diagnosis_figures

    diag = json.loads(Path(diagnosis_json).read_text())
    ev, _ = _evidence(measured_files, forward_files)
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

    atomic_write_text(output_csv, pd.DataFrame(rows).to_csv(index=False))  # full precision
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


# ----------------------------------------------------------------------------- rigid-mount flights


def _fmt(x: float | None, spec: str = ".2f") -> str:
    return "n/a" if x is None else format(x, spec)


def _platform_verdict(d: Mapping[str, Any]) -> str:
    """One flight's platform-response result in words (commanded motion; hover drift not used)."""
    c = d["commanded"]
    est, unc, test = d["estimate"], d["uncertainty"], d["test"]
    used = c["segments_used"]
    lag = c["lag"]
    fit = (f"gain_h = {_fmt(est['gain_h'])} ± {_fmt(unc['gain_h'])} from {used['horizontal']} legs, gain_v = "
           f"{_fmt(est['gain_v'])} ± {_fmt(unc['gain_v'])} from {used['vertical']} climbs and descents (p = "
           f"{_fmt(test['p_value'], '.2g')} against the present model g = 1, false-alarm rate {test['alpha']:g})")
    extra = (f"; sonic heading offset on the airframe {_fmt(c['heading_offset_deg'], '+.1f')} ± "
             f"{_fmt(c['heading_offset_sigma_deg'], '.1f')} degree; sonic-platform lag "
             + (f"{lag['lag_s']:+.2f} ± {lag['sigma_s']:.2f} s from {lag['n_turns']} turnarounds"
                if lag["identified"] else "not identified (0 s applied)")
             + f"; held-out gain of the extended correction (leave-one-segment-out) "
               f"{_fmt(c['held_out'].get('combined_gain'))}")
    if est["gain_h"] is None and est["gain_v"] is None:
        return (f"flight {d['flight']}: platform response not identified: no commanded motion (straight legs flown "
                "both ways, climbs and descents) in the record; hover drift follows the wind and is not used.")
    if d["significant"]:
        return (f"flight {d['flight']}: platform_velocity_response named from commanded motion: the motion correction "
                f"assumes the sonic sees the platform's whole velocity; it sees {fit}{extra}. Extended correction "
                "V_wind = R M V_sensor + G V_platform.")
    return f"flight {d['flight']}: no platform-motion response beyond sampling error (commanded motion): {fit}{extra}."


def platform_diagnosis(drone_l2: str | Path, output: str | Path, *, flight_id: str, alpha: float,
                       segment_s: float = 60.0, band_factor: float = 10.0, rigid_l1: str | Path | None = None,
                       flight: Mapping[str, Any] | None = None, max_lag_s: float = 2.0) -> Path:
    """``platform_velocity_response`` of one rigid-mount flight from its commanded motion, as JSON.

    The estimate is :func:`dronewind.diagnose.platform_commanded.diagnose_commanded_l1` on
    the whole record (legs flown both ways, climbs and descents; hover drift not used). The
    spectral estimate on the L2's steady segment (:func:`dronewind.diagnose.platform.diagnose_platform`)
    is kept under ``hover_spectral`` for reference: in a hover the vehicle's velocity follows
    the wind, which biases it.

    Parameters
    ----------
    drone_l2 : str or Path
        The flight's L2 (:func:`dronewind.payload.rigid.rigid_l2`).
    output : str or Path
        JSON file (``results/<name>/diagnosis/platform/<flight>.json``).
    flight_id : str
        Flight id.
    alpha : float
        False-alarm rate of the test against the present model (``diagnosis.alpha``) [1].
    segment_s, band_factor : float
        Spectral settings of the hover estimate [s], [1].
    rigid_l1 : str or Path, optional
        The flight's L1 (whole record); without it only the hover estimate is made and the
        response is reported as not identified.
    flight : mapping, optional
        The flight's manifest entry (``sonic`` mount).
    max_lag_s : float
        Half-width of the sonic-platform lag search [s] (``processing.rigid_mount.max_lag_s``).

    Returns
    -------
    Path
        The written file.
    """
    from dronewind.diagnose.platform import diagnose_platform
    from dronewind.diagnose.platform_commanded import diagnose_commanded_l1
    from dronewind.payload.rigid import rigid_mount

    l2 = strip_cf(open_product(drone_l2))
    if l2.attrs.get("platform") != "rigid_mount":
        raise ValueError(f"{drone_l2}: platform {l2.attrs.get('platform')!r}; expected a rigid_mount L2")
    wind = np.stack([l2[k].values for k in ("u_east_ms", "v_north_ms", "w_up_ms")], axis=-1)
    vel = np.stack([l2[k].values for k in ("platform_vel_e_ms", "platform_vel_n_ms", "platform_vel_u_ms")], axis=-1)
    hover = diagnose_platform(wind, vel, float(l2.attrs["sampling_rate_hz"]), segment_s=segment_s,
                              band_factor=band_factor, alpha=alpha)
    hover["not_used"] = ("hover drift of a position-holding vehicle follows the gusts: the wind is correlated with "
                         "the platform velocity, so this estimate is biased (reported for reference only)")
    if rigid_l1 is not None and flight is not None:
        mount = rigid_mount(flight["sonic"], f"payload flight {flight_id} sonic").matrix
        c = diagnose_commanded_l1(track_from_cf(strip_cf(open_product(rigid_l1))), mount, alpha=alpha,
                                  max_lag_s=max_lag_s)
    else:
        c = {"segments": [], "segments_used": {"horizontal": 0, "vertical": 0}, "estimate": {"gain_h": None,
             "gain_v": None}, "uncertainty": {"gain_h": None, "gain_v": None}, "significant": False,
             "test": {"p_value": float("nan"), "alpha": float(alpha)}, "lag": {"identified": False},
             "heading_offset_deg": None, "heading_offset_sigma_deg": None, "held_out": {}}
    d: dict[str, Any] = {
        "mechanism": "platform_velocity_response", "flight": flight_id, "usable": int(l2.attrs.get("usable", 1)),
        "method": "commanded motion (legs flown both ways, climbs and descents); hover drift not used",
        "estimate": c["estimate"], "uncertainty": c["uncertainty"], "test": c["test"],
        "significant": bool(c["significant"]), "adequate": True, "named": bool(c["significant"]),
        "commanded": c, "hover_spectral": hover,
        "assumption": ("over commanded segments the segment-mean platform velocity is set by the flight plan, "
                       "independent of the segment-mean wind; the turbulence's sampling error and the "
                       "segment-to-segment scatter make the uncertainty"),
    }
    d["verdict"] = _platform_verdict(d)
    LOG.info("%s", d["verdict"])
    return write_json(output, d)


def platform_entries(platform_files: Sequence[str | Path]) -> dict[str, Any]:
    """The rigid-mount flights' platform-response results as diagnosis.json entries.

    Parameters
    ----------
    platform_files : sequence of str or Path
        Outputs of :func:`platform_diagnosis`.

    Returns
    -------
    dict
        ``candidates`` (one ``platform_velocity_response`` entry: inverse-variance pooled
        estimate and uncertainty of the usable flights' commanded-motion estimates, the
        smallest p-value after a Bonferroni correction over flights, ``significant``,
        ``gain`` = held-out gain of the extended correction, leave-one-segment-out over the
        flights' commanded segments, and ``flights`` with each flight's estimate,
        uncertainty, p-value, segments, lag and heading offset), ``named_causes`` and
        ``rigid_mount`` (``flights``: every flight's full result, ``segments``: the segments
        used per flight, ``verdict``: sentences).
    """
    flights = [json.loads(Path(p).read_text()) for p in platform_files]
    usable = [f for f in flights if f.get("usable", 1)]
    out: dict[str, Any] = {"candidates": [], "named_causes": [],
                           "rigid_mount": {"flights": {f["flight"]: f for f in flights},
                                           "segments": {f["flight"]: [
                                               {"kind": s["kind"], "t_start_s": s["t_start_s"],
                                                "t_stop_s": s["t_stop_s"], "speed_ms": s["speed_ms"],
                                                "course_deg": s["course_deg"]}
                                               for s in f["commanded"]["segments"]] for f in flights},
                                           "verdict": [f["verdict"] for f in flights]}}
    identified = [f for f in usable if any(v is not None for v in f["estimate"].values())]
    if not identified:
        return out
    alpha = float(identified[0]["test"]["alpha"])
    p_min = min(1.0, min(f["test"]["p_value"] for f in identified) * len(identified))
    est: dict[str, float | None] = {}
    unc: dict[str, float | None] = {}
    for p in ("gain_h", "gain_v"):
        have = [f for f in identified if f["estimate"][p] is not None and f["uncertainty"][p]]
        if not have:
            est[p] = unc[p] = None
            continue
        w = np.array([1.0 / f["uncertainty"][p] ** 2 for f in have])
        est[p] = float(np.sum(w * np.array([f["estimate"][p] for f in have])) / np.sum(w))
        unc[p] = float(1.0 / np.sqrt(np.sum(w)))
    sse_p = sum(h["sse_present"] for f in identified for g, h in f["commanded"]["held_out"].items()
                if isinstance(h, dict))
    sse_e = sum(h["sse_extended"] for f in identified for g, h in f["commanded"]["held_out"].items()
                if isinstance(h, dict))
    significant = p_min < alpha
    out["candidates"].append({
        "mechanism": "platform_velocity_response", "platform": "rigid_mount", "estimate": est, "uncertainty": unc,
        "gain": 1.0 - sse_e / sse_p if sse_p > 0 else float("nan"),
        "gain_kind": "held out: each commanded segment predicted from a fit to the flight's other segments "
                     "(leave-one-segment-out)",
        "gain_measure": "relative reduction of the weighted squared error of held-out segment-mean corrected wind "
                        "(present model: no platform response, nuisance terms refitted), horizontal and vertical "
                        "summed",
        "p_value": p_min, "significant": bool(significant),
        "flights": [{"flight": f["flight"], "estimate": f["estimate"], "uncertainty": f["uncertainty"],
                     "p_value": f["test"]["p_value"], "significant": f["significant"], "adequate": True,
                     "segments_used": f["commanded"]["segments_used"],
                     "lag_s": f["commanded"]["lag"].get("lag_s"), "lag_sigma_s": f["commanded"]["lag"].get("sigma_s"),
                     "heading_offset_deg": f["commanded"]["heading_offset_deg"],
                     "heading_offset_sigma_deg": f["commanded"]["heading_offset_sigma_deg"],
                     "held_out_gain": f["commanded"]["held_out"].get("combined_gain")} for f in identified],
    })
    if significant:
        out["named_causes"].append("platform_velocity_response")
        out["named_estimates"] = {"platform_velocity_response": {
            "estimate": est, "uncertainty": unc, "gain": out["candidates"][0]["gain"]}}
    return out


def rigid_diagnosis(manifest: str | Path, platform_files: Sequence[str | Path], output_json: str | Path) -> Path:
    """diagnosis.json of a campaign with rigid-mount flights only (no sling-load flight to model).

    Parameters
    ----------
    manifest : str or Path
        The campaign manifest.
    platform_files : sequence of str or Path
        Outputs of :func:`platform_diagnosis`, one per rigid flight.
    output_json : str or Path
        ``results/<name>/diagnosis.json``.

    Returns
    -------
    Path
    """
    campaign = load_campaign(manifest)
    entries = platform_entries(platform_files)
    out = {"campaign": campaign.name, "baseline": {"metrics": {}}, "ambiguity_sets": [],
           "note": "rigid-mount flights only: no sling-load forward model; the platform-motion response is "
                   "identified from each flight's own record (no mast)", **entries}
    LOG.info("rigid-mount diagnosis: named causes %s", out["named_causes"] or "none")
    return write_json(output_json, out)
