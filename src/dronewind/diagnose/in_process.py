"""Campaigns through the chain and the forward model in this process, without Snakemake.

The workflow runs every flight's steps as jobs; the rate benchmarks, the planner and the tests
run hundreds of small campaigns, where that many jobs would cost more than the science. The
functions here call the same library functions as the rules, in the rules' order: a virtual
flight simulated and processed to L3 (:func:`process_virtual_flight`); a hidden-effect
campaign of :mod:`dronewind.diagnose.experiments` simulated, processed and forward-run
(:func:`campaign_evidence`); a measured campaign's files processed and forward-run
(:func:`measured_campaign_evidence`); and the campaign diagnosis of either
(:func:`diagnose_evidence`, :func:`run_in_process`), or only what it decides
(:func:`decide_evidence`).
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, NamedTuple

import xarray as xr

from dronewind.compare.chain import compute_l3
from dronewind.diagnose.experiments import Draw, campaign_manifest
from dronewind.diagnose.probes import resolved_seeds
from dronewind.manifest import with_defaults
from dronewind.mast.chain import compute_mast_l1, compute_mast_l2
from dronewind.payload.chain import compute_payload_l1, compute_payload_l2

__all__ = ["VirtualFlight", "process_virtual_flight", "forward_inputs", "run_in_process", "campaign_evidence",
           "diagnose_evidence", "decide_evidence", "measured_campaign_evidence"]


class VirtualFlight(NamedTuple):
    """A flight processed to L3 with its reference mast sonic's L1: a simulated one processed as
    measured data (:func:`process_virtual_flight`), or a measured one (:func:`measured_campaign_evidence`)."""

    sonic_l1: xr.Dataset
    ins_l1: xr.Dataset
    l2: xr.Dataset
    mast_l1: xr.Dataset
    l3: xr.Dataset


def process_virtual_flight(data: Mapping[str, Any], flight: Mapping[str, Any], work: Path,
                           processing: Mapping[str, Any]) -> VirtualFlight:
    """Simulate one flight of a virtual campaign into ``work`` and process it to L3, in this process.

    The workflow's chain in the rules' order (payload L1, L2, mast L1, L2, L3) on the files the
    simulator writes; the campaign's first mast sonic is the reference.

    Parameters
    ----------
    data : mapping
        Manifest content with a ``simulation:`` section (e.g.
        :func:`~dronewind.diagnose.experiments.campaign_manifest`).
    flight : mapping
        The payload flight's manifest entry.
    work : Path
        Folder for the raw files.
    processing : mapping
        ``processing`` settings (at least :data:`dronewind.diagnose.probes.CHAIN_SETTINGS`).

    Returns
    -------
    VirtualFlight
    """
    from dronewind.diagnose import probes
    from dronewind.simulate.payload import simulate_payload_flight

    fid = flight["id"]
    lag = {key: processing[key] for key in probes.LAG_SETTINGS}
    paths = simulate_payload_flight(copy.deepcopy(dict(data)), work, fid, work)
    s1, i1 = compute_payload_l1(work / flight["sonic"]["file"], work / flight["ins"]["file"], processing["despike"])
    l2 = compute_payload_l2(s1, i1, flight, float(data["site"]["altitude_m"]), **lag)
    m1 = compute_mast_l1([p for p in paths if p.suffix == ".dat"], data["masts"][0]["sonics"][0],
                         processing["despike"])
    m2 = compute_mast_l2(m1, l2, fid, processing["drone_mast"])
    l3 = compute_l3(l2, m2, flight, processing["drone_mast"], processing["rotation"])
    return VirtualFlight(s1, i1, l2, m1, l3)


def forward_inputs(data: Mapping[str, Any], flight_id: str, flight: VirtualFlight, processing: Mapping[str, Any],
                   atmosphere: str = "measured", forward_payload: Mapping[str, Any] | None = None
                   ) -> tuple[dict[str, Any], dict[str, Any], xr.Dataset | None]:
    """What a processed flight's forward runs read, as the workflow's forward job makes it.

    Parameters
    ----------
    data : mapping
        The campaign's manifest (or its one-flight view).
    flight_id : str
        Payload flight id.
    flight : VirtualFlight
        The flight's products.
    processing : mapping
        ``processing`` settings (at least :data:`dronewind.diagnose.probes.LAG_SETTINGS`).
    atmosphere : {"measured", "model"}
        ``diagnosis.atmosphere``.
    forward_payload : mapping, optional
        ``diagnosis.forward_payload`` (the conditions' ``payload``).

    Returns
    -------
    measured : dict
        Residual features (:func:`~dronewind.diagnose.features.features_to_dict`).
    conditions : dict
        :func:`dronewind.diagnose.forward_conditions.forward_conditions`.
    record : xarray.Dataset or None
        The reference mast's record as the forward runs' atmosphere
        (:func:`dronewind.diagnose.forward_atmosphere.atmosphere_record`); None for ``model``.
    """
    from dronewind.diagnose import forward, forward_atmosphere, forward_conditions, probes
    from dronewind.diagnose.features import features_to_dict

    lag = {key: processing[key] for key in probes.LAG_SETTINGS}
    measured = features_to_dict(forward.measured_features(data, flight_id, flight.sonic_l1, flight.ins_l1, flight.l2,
                                                          flight.l3, **lag))
    conditions = forward_conditions.forward_conditions(data, flight_id, flight.l3, flight.l2, forward_payload,
                                                       flight.ins_l1)
    record = forward_atmosphere.atmosphere_record(flight.mast_l1, conditions) if atmosphere == "measured" else None
    return measured, conditions, record


def _process_flight(data: Mapping[str, Any], flight: Mapping[str, Any], work: Path,
                    processing: Mapping[str, Any], seeds: tuple[int, ...],
                    atmosphere: str = "measured", forward_payload: Mapping[str, Any] | None = None
                    ) -> tuple[dict[str, Any], dict[str, Any]]:
    """Simulate one flight of a hidden-effect campaign, process it, run its forward probes.

    ``atmosphere`` is ``diagnosis.atmosphere``: with ``measured`` the forward runs take the
    reference mast's L1 as their atmosphere, as the workflow's forward rules do;
    ``forward_payload`` is ``diagnosis.forward_payload``.

    Returns
    -------
    measured : dict
        Residual features of the flight (:func:`~dronewind.diagnose.features.features_to_dict`).
    forward_runs : dict
        :func:`dronewind.diagnose.probe_runs.probe_runs` of the flight.
    """
    from dronewind.diagnose import probe_runs

    fid = flight["id"]
    v = process_virtual_flight(data, flight, work, processing)
    measured, conditions, record = forward_inputs(data, fid, v, processing, atmosphere, forward_payload)
    return measured, probe_runs.probe_runs(data, fid, conditions, processing, seeds=seeds, atmosphere=record)


def run_in_process(truth: Draw, config: Mapping[str, Any], work_dir: str | Path, **manifest_kw: Any
                   ) -> dict[str, Any]:
    """Simulate, process and diagnose a hidden-effect campaign in this process (no Snakemake).

    Uses the same library functions as the workflow's rules, in the same order; meant for
    the rate benchmark, where hundreds of Snakemake jobs per draw would cost more than the
    science. :func:`campaign_evidence` then :func:`diagnose_evidence`.

    Parameters
    ----------
    truth : Draw
        The hidden effect.
    config : mapping
        Workflow configuration, possibly partial: missing settings take their defaults
        (:func:`dronewind.manifest.with_defaults`).
    work_dir : str or Path
        Folder for the raw files.
    **manifest_kw
        Passed to :func:`~dronewind.diagnose.experiments.campaign_manifest`.

    Returns
    -------
    dict
        The diagnosis, as ``diagnosis.json``.
    """
    return diagnose_evidence(campaign_evidence(truth, config, work_dir, **manifest_kw), config)


def campaign_evidence(truth: Draw, config: Mapping[str, Any], work_dir: str | Path, **manifest_kw: Any
                      ) -> dict[str, Any]:
    """The diagnosis' input for a hidden-effect campaign: every flight simulated, processed and forward-run.

    Parameters
    ----------
    truth, config, work_dir, **manifest_kw
        As :func:`run_in_process`.

    Returns
    -------
    dict
        ``name`` (the campaign's), ``measured`` (flight -> measured features, as
        ``diagnosis/measured/<flight>.json`` holds them) and ``forward`` (flight -> forward
        runs, as ``diagnosis/forward/<flight>.json``): JSON-serialisable, so that a
        benchmark can keep it and diagnose it again with other settings
        (:func:`diagnose_evidence`).
    """
    settings = with_defaults(config)
    processing, diagnosis = settings["processing"], settings["diagnosis"]
    data = campaign_manifest(truth, **manifest_kw)
    measured, fwd = {}, {}
    seeds = tuple(resolved_seeds(diagnosis["seeds"], len(data["payload_flights"])))
    for flight in data["payload_flights"]:
        measured[flight["id"]], fwd[flight["id"]] = _process_flight(data, flight, Path(work_dir), processing, seeds,
                                                                    str(diagnosis["atmosphere"]),
                                                                    diagnosis["forward_payload"])
    return {"name": data["name"], "measured": measured, "forward": fwd}


def diagnose_evidence(evidence: Mapping[str, Any], config: Mapping[str, Any], reference: Any = None) -> dict[str, Any]:
    """The campaign diagnosis of :func:`campaign_evidence`'s output, as ``diagnosis.json``.

    Parameters
    ----------
    evidence : mapping
        Output of :func:`campaign_evidence` (or the same read back from JSON).
    config : mapping
        Workflow configuration (its ``diagnosis`` settings; defaults where missing).
    reference : NullReference, optional
        A bootstrap reference for evidence with the same forward runs
        (:func:`dronewind.diagnose.naming.diagnose`); by default the diagnosis draws its own.

    Returns
    -------
    dict
        The diagnosis, as ``diagnosis.json``.
    """
    from dronewind.diagnose.record import to_json

    return _recorded(evidence, config, reference, to_json)


def decide_evidence(evidence: Mapping[str, Any], config: Mapping[str, Any], reference: Any = None) -> dict[str, Any]:
    """What the campaign diagnosis of ``evidence`` decides: :func:`diagnose_evidence` without the fit's quality.

    The same diagnosis (the same causes named with the same estimates, the same ambiguity sets
    and measured conditions), recorded by :func:`dronewind.diagnose.record.decision_json`: no
    goodness of fit, whose p-value refits the named causes on every bootstrap replicate. For the
    Monte-Carlo campaigns that are judged only by what is named (the planner's power draws).

    Parameters
    ----------
    evidence, config, reference
        As :func:`diagnose_evidence`.

    Returns
    -------
    dict
        The decision entries of ``diagnosis.json`` and ``atmosphere``.
    """
    from dronewind.diagnose.record import decision_json

    return _recorded(evidence, config, reference, decision_json)


def _recorded(evidence: Mapping[str, Any], config: Mapping[str, Any], reference: Any,
              record: Callable[[Any, str], dict[str, Any]]) -> dict[str, Any]:
    """The campaign diagnosis of ``evidence`` with the configured settings, written by ``record``."""
    from dronewind.diagnose import campaign as dc
    from dronewind.diagnose.probes import MIN_FLIGHTS
    from dronewind.diagnose.record import not_diagnosed_json

    diagnosis = with_defaults(config)["diagnosis"]
    ev = dc.assemble(evidence["measured"], evidence["forward"])
    if len(ev.flights) < MIN_FLIGHTS:  # as the workflow's diagnose step (steps.diagnosis.diagnose_campaign)
        reasons = evidence.get("unusable_reasons") or {}
        out = not_diagnosed_json(evidence["name"], len(ev.flights),
                                 {f: reasons.get(f, "") for f in evidence.get("unusable", ())})
    else:
        result = dc.diagnose(ev, alpha=float(diagnosis["alpha"]), max_causes=int(diagnosis["max_causes"]),
                             min_gain=float(diagnosis["min_gain"]), n_replicates=int(diagnosis["bootstrap"]),
                             reference=reference)
        out = record(result, evidence["name"])
    out["atmosphere"] = str(diagnosis["atmosphere"])
    return out


def measured_campaign_evidence(manifest_path: str | Path, config: Mapping[str, Any]) -> dict[str, Any]:
    """The diagnosis' input for a measured campaign (a manifest without ``simulation:``), in this process.

    Each payload flight goes through the workflow's chain in the rules' order, as
    :func:`process_virtual_flight` does for a simulated one but from the campaign's files:
    payload L1 and L2, the reference mast sonic's L1 (once per sonic, from all its files)
    and L2, L3; then its residual features, forward conditions, atmosphere record
    (``diagnosis.atmosphere: measured``) and forward probes, each on the one-flight view of
    the manifest (:func:`dronewind.manifest.payload_flight_manifest`), as the per-flight
    diagnosis rules read it. Flights whose L2 is marked unusable are left out, as the
    campaign diagnosis leaves them out (their ids in ``unusable``, their L2's reasons in
    ``unusable_reasons``).

    Parameters
    ----------
    manifest_path : str or Path
        Campaign manifest of measured data (its files must exist).
    config : mapping
        Workflow configuration, possibly partial (:func:`dronewind.manifest.with_defaults`).

    Returns
    -------
    dict
        ``name``, ``measured`` (flight -> features), ``forward`` (flight -> forward runs),
        ``unusable`` (flight ids left out) and ``unusable_reasons`` (flight -> why): the input
        of :func:`diagnose_evidence`.

    Raises
    ------
    ManifestError
        The manifest is invalid or declares a ``simulation:`` section.
    """
    from dronewind.diagnose import probe_runs, probes
    from dronewind.errors import ManifestError
    from dronewind.manifest import load_campaign, payload_flight_manifest

    campaign = load_campaign(manifest_path)
    if campaign.simulated:
        raise ManifestError(campaign.path, "simulation", "a measured campaign is expected (no simulation: section)")
    settings = with_defaults(config)
    processing, diagnosis = settings["processing"], settings["diagnosis"]
    lag = {key: processing[key] for key in probes.LAG_SETTINGS}
    root, sonics = campaign.data_root, campaign.mast_sonics()
    altitude_m = float(campaign.data["site"]["altitude_m"])
    mast_l1: dict[str, xr.Dataset] = {}
    measured: dict[str, Any] = {}
    fwd: dict[str, Any] = {}
    unusable: list[str] = []
    reasons: dict[str, str] = {}
    seeds = tuple(resolved_seeds(diagnosis["seeds"], len(campaign.payload_flights)))
    for flight in campaign.payload_flights:
        fid, ref = flight["id"], flight["reference"]
        view = payload_flight_manifest(campaign.data, fid)
        s1, i1 = compute_payload_l1(root / flight["sonic"]["file"], root / flight["ins"]["file"],
                                    processing["despike"])
        l2 = compute_payload_l2(s1, i1, flight, altitude_m, **lag)
        if not int(l2.attrs.get("usable", 1)):
            unusable.append(fid)
            reasons[fid] = str(l2.attrs.get("unusable_reason", ""))
            continue
        if ref not in mast_l1:
            mast_l1[ref] = compute_mast_l1(campaign.mast_files(ref), sonics[ref], processing["despike"])
        m2 = compute_mast_l2(mast_l1[ref], l2, fid, processing["drone_mast"])
        l3 = compute_l3(l2, m2, flight, processing["drone_mast"], processing["rotation"])
        measured[fid], conditions, record = forward_inputs(view, fid, VirtualFlight(s1, i1, l2, mast_l1[ref], l3),
                                                           processing, str(diagnosis["atmosphere"]),
                                                           diagnosis["forward_payload"])
        fwd[fid] = probe_runs.probe_runs(view, fid, conditions, processing, seeds=seeds, atmosphere=record)
    return {"name": campaign.name, "measured": measured, "forward": fwd, "unusable": unusable,
            "unusable_reasons": reasons}
