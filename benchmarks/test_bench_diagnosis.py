"""The forward model and the diagnosis of one flight."""

from __future__ import annotations

import json

from conftest import FLIGHT, cpu_round


def _chain_settings(setup):
    from dronewind.diagnose.probes import CHAIN_SETTINGS

    return {key: setup["processing"][key] for key in CHAIN_SETTINGS}


def test_forward_run(benchmark, measured_json, setup):
    """One forward run: the flight simulated at its measured conditions and processed to its features."""
    from dronewind.diagnose import forward, forward_conditions
    from dronewind.manifest import payload_flight_manifest

    conditions = json.loads(measured_json.read_text())["conditions"]
    flight = payload_flight_manifest(setup["data"], FLIGHT)
    manifest = forward_conditions.forward_manifest(flight, FLIGHT, conditions, None, 1)
    _, cpu = cpu_round(benchmark, forward.run_forward, manifest, FLIGHT, _chain_settings(setup), rounds=3)
    benchmark.extra_info.update(runs_per_cpu_min=round(60.0 / cpu, 1))


def test_diagnosis_of_one_flight(benchmark, flight, measured_json, setup, tmp_path):
    """A flight's forward runs for the diagnosis: the baseline seeds and every probe of the catalog (the
    workflow runs them in two jobs, diagnose_probes and diagnose_forward)."""
    from dronewind.diagnose.probes import resolved_seeds
    from dronewind.manifest import payload_flight_manifest
    from dronewind.steps import diagnosis

    d = setup["config"]["diagnosis"]
    seeds = resolved_seeds(d["seeds"], len(setup["data"]["payload_flights"]))  # as the workflow resolves them
    out = tmp_path / "forward.json"
    _, cpu = cpu_round(benchmark, diagnosis.forward_probes, measured_json, out,
                       campaign=payload_flight_manifest(setup["data"], FLIGHT), flight_id=FLIGHT,
                       processing=_chain_settings(setup), seeds=seeds, mast_l1=flight.products["mast_l1"],
                       atmosphere=d["atmosphere"], rounds=1)
    runs = json.loads(out.read_text())
    n_runs = len(runs.get("baseline", [])) + len(runs.get("probes", []))
    benchmark.extra_info.update(atmosphere=d["atmosphere"], seeds=len(seeds), forward_runs=n_runs,
                                cpu_s_per_forward_run=round(cpu / max(n_runs, 1), 3))
