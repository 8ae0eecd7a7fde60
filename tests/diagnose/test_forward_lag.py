"""The sonic-INS processing lag: a measured condition of the forward model.

Every flight has a processing lag of its own (Ghirardelli et al. 2025, Fig. 4; the
simulator's per-flight draw). The chain finds it by its lag search; the forward model takes
the lag found as a condition (``sonic_ins_lag_s`` of :func:`forward_conditions`) and
simulates the flight with the processing lag that makes its own chain find it again
(:func:`dronewind.diagnose.probe_runs.simulated_sonic_ins_lag_s`). Known answers: a flight
simulated with a set processing lag, processed like measured data.
"""

from __future__ import annotations

import pytest

from dronewind.diagnose import forward, forward_atmosphere, forward_conditions, probe_runs
from dronewind.diagnose.forward_conditions import forward_manifest
from dronewind.diagnose.probes import PROBES, probe_parts
from dronewind.simulate.payload import payload_records
from dronewind.simulate.settings import resolve_payload_flight
from tests.diagnose.test_forward_memory import _campaign, _processing

#: The flight's processing lag [s] (inside Fig. 4's range, off the 1/32 s search grid).
LAG_S = -0.15
#: One step of the lag search [s] (Ghirardelli et al. 2025, Sect. 3.3).
STEP_S = 1.0 / 32.0


def _measured(lag_s: float = LAG_S) -> tuple[dict, dict, object]:
    """The unit flight with processing lag ``lag_s``, processed as measured data: campaign,
    forward conditions and the reference mast's record."""
    camp = _campaign()
    camp["simulation"]["payload_flights"]["f1"]["sonic_ins_lag_s"] = lag_s
    records, _ = payload_records(camp, "f1")
    _, products = forward.process_forward_flight(camp, "f1", records, _processing())
    conditions = forward_conditions.forward_conditions(camp, "f1", products["l3"], products["l2"])
    return camp, conditions, forward_atmosphere.atmosphere_record(products["l1"]["mast"], conditions)


@pytest.fixture(scope="module")
def measured():
    return _measured()


def test_the_conditions_carry_the_lag_the_chain_found(measured):
    camp, conditions, _ = measured
    records, _ = payload_records(camp, "f1")
    _, products = forward.process_forward_flight(camp, "f1", records, _processing())
    assert conditions["sonic_ins_lag_s"] == products["l2"].attrs["lag_tke_min_s"]
    assert conditions["sonic_ins_lag_s"] == products["l2"].attrs["lag_sonic_ins_s"]
    # the chain's lag of minimum TKE lies below the processing lag: the attitude follows the
    # wind (simulated_sonic_ins_lag_s; 0.092 +- 0.033 s over 60 flights, here at most 5 steps)
    assert LAG_S - 5 * STEP_S <= conditions["sonic_ins_lag_s"] <= LAG_S + STEP_S


def test_forward_manifest_simulates_the_conditions_lag_or_none():
    camp = _campaign()
    conditions = dict(camp["simulation"]["payload_flights"]["f1"])
    assert resolve_payload_flight(forward_manifest(camp, "f1", conditions), "f1")["sonic_ins_lag_s"] == 0.0
    conditions["sonic_ins_lag_s"] = -0.125
    assert resolve_payload_flight(forward_manifest(camp, "f1", conditions), "f1")["sonic_ins_lag_s"] == -0.125


def test_forward_runs_find_the_measured_lag_and_probes_add_to_it(measured):
    """The first seed's forward run finds the measured lag (the calibration's seed: exactly,
    a whole number of steps moves stamps and TKE curve alike); the second seed within its
    sampling error (3 steps); the simulated processing lag estimates the true one within
    0.1 s (the chain's offset differs between realisations by about 0.033 s * sqrt(2)); a
    sonic_ins_lag probe of +0.3 s moves the lag found by 0.3 s (1.5 steps for two
    roundings); the lag drift of the halves is found."""
    camp, conditions, record = measured
    probes = tuple(p for p in PROBES if p.mechanism == "sonic_ins_lag")
    runs = probe_runs.probe_runs(camp, "f1", conditions, _processing(), seeds=(0, 1), probes=probes, atmosphere=record)
    lag_m = conditions["sonic_ins_lag_s"]
    found = [b["values"]["lag_sonic_ins_s"] for b in runs["baseline"]]
    assert found[0] == pytest.approx(lag_m, abs=1e-9)
    assert found[1] == pytest.approx(lag_m, abs=3 * STEP_S)
    assert runs["simulated_sonic_ins_lag_s"] == pytest.approx(LAG_S, abs=0.1)
    assert runs["conditions"]["sonic_ins_lag_s"] == lag_m  # the condition as measured
    plus = next(r for r in runs["probes"] if r["level"] == 0.3)
    assert plus["features"]["values"]["lag_sonic_ins_s"] - found[0] == pytest.approx(0.3, abs=1.5 * STEP_S)
    assert all(b["values"]["lag_drift_s"] is not None for b in runs["baseline"])


def test_the_lag_drift_does_not_see_a_constant_lag():
    """lag_drift_s (second half's lag minus the first's) of one true state with processing lags
    0 and -0.125 s (4 steps): the lag moved by the 4 steps, the same drift within a tenth of a
    step. The halves' lags lie between the grid's lags (lag_search.subgrid_minimum); the 50 Hz
    INS is interpolated at other phases when the sonic moves by 4 of its 32 Hz samples, which
    moves the parabola's vertex by about a millisecond (measured 1.1 ms)."""
    camp = _campaign()
    conditions = dict(camp["simulation"]["payload_flights"]["f1"])
    none, products = forward.run_forward(forward_manifest(camp, "f1", conditions), "f1", _processing())
    lagged, _ = forward.run_forward(forward_manifest(camp, "f1", {**conditions, "sonic_ins_lag_s": -0.125}),
                                    "f1", _processing(), truth=products["truth"])
    assert lagged.values["lag_sonic_ins_s"] - none.values["lag_sonic_ins_s"] == pytest.approx(-0.125, abs=1e-9)
    assert lagged.values["lag_drift_s"] == pytest.approx(none.values["lag_drift_s"], abs=0.1 * STEP_S)


@pytest.mark.slow
def test_parts_with_the_lag_condition_merge_into_the_whole_flight(measured):
    """Each part finds the same simulated lag on its own (the first seed's flight), so the
    per-mechanism jobs merge, bit for bit, into one job's runs."""
    camp, conditions, record = measured
    probes = tuple(p for p in PROBES if p.mechanism in ("w_gain", "height_offset", "attitude_lag"))
    proc = _processing()
    whole = probe_runs.probe_runs(camp, "f1", conditions, proc, seeds=(0, 1), probes=probes, atmosphere=record)
    parts = [probe_runs.probe_runs(camp, "f1", conditions, proc, seeds=(0, 1), probes=probes, parts=[name],
                                atmosphere=record)
             for name in reversed(probe_parts(probes))]
    merged = probe_runs.merge_probe_runs(parts, probes)
    for key in ("reused_products", "reused_steps"):
        whole.pop(key), merged.pop(key)
    assert merged == whole
    assert {p["simulated_sonic_ins_lag_s"] for p in parts} == {whole["simulated_sonic_ins_lag_s"]}


def test_the_declared_payload_travels_with_the_conditions_into_every_forward_manifest(measured):
    """diagnosis.forward_payload (the platform flown) is simulated by the forward runs and the extended model."""
    from dronewind.errors import InputError
    from dronewind.steps.diagnosis import extended_manifest

    camp, conditions, _ = measured
    records, _ = payload_records(camp, "f1")
    _, products = forward.process_forward_flight(camp, "f1", records, _processing())
    declared = {"rope_pitch_fraction": 1.0, "pendulum_length_m": 12.0}
    with_payload = forward_conditions.forward_conditions(camp, "f1", products["l3"], products["l2"], declared)
    assert with_payload == {**conditions, "payload": declared}
    flight, payload = forward_conditions.split_payload(with_payload)
    assert flight == conditions and payload == declared
    manifest = forward_manifest(camp, "f1", with_payload)
    assert manifest["simulation"]["payload"] == declared
    assert "payload" not in manifest["simulation"]["payload_flights"]["f1"]
    assert resolve_payload_flight(manifest, "f1")["payload"]["pendulum_length_m"] == 12.0
    assert "payload" not in forward_manifest(camp, "f1", conditions)["simulation"]
    extended = extended_manifest(camp, {"f1": with_payload}, [])
    assert extended["simulation"]["payload"] == declared
    assert extended["simulation"]["payload_flights"] == {"f1": conditions}
    with pytest.raises(InputError) as err:
        extended_manifest(camp, {"f1": with_payload, "f2": {**conditions, "payload": {"mass_kg": 6.0}}}, [])
    assert err.value.where == "diagnosis.forward_payload"
    for bad, where in (({"rope_length": 3.0}, "diagnosis.forward_payload.rope_length"),
                       ({"rope_pitch_fraction": 2.0}, "diagnosis.forward_payload.rope_pitch_fraction"),
                       ({"defects": {}}, "diagnosis.forward_payload.defects")):
        with pytest.raises(InputError) as err:
            forward_conditions.forward_conditions(camp, "f1", products["l3"], products["l2"], bad)
        assert err.value.where == where, str(err.value)
