"""The forward model in memory: raw records instead of files, one true state per flight and seed.

The diagnosis simulates every flight some thirty times (dronewind.diagnose.forward). The
simulator hands the chain in-memory records (dronewind.core.raw) and reuses the flight's
true state (turbulence, motion, mast field) for every mechanism of the measurement stage;
the chain reuses the products of records that a probe leaves unchanged. These tests hold
the three shortcuts to the long way round: the files, a fresh simulation, no reuse.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest

from dronewind.core.raw import RawRecord
from dronewind.core.reuse import StepStore, reusing
from dronewind.diagnose import forward, forward_atmosphere, probe_runs
from dronewind.diagnose.probes import PROBES, probe_parts, seed_part
from dronewind.errors import InputError
from dronewind.manifest import default_config
from dronewind.mechanisms import get_mechanism
from dronewind.payload.reader import read_sonic_csv
from dronewind.simulate import atmosphere
from dronewind.simulate.payload import payload_records, payload_truth
from tests.simulate.test_simulate_payload import _campaign as _unit_campaign

#: Catalog mechanisms of the payload flight's measurement stage (all but height_offset).
MEASUREMENT_STAGE = ("sonic_ins_lag", "clock_drift", "mount_misalignment", "heading_bias", "attitude_lag",
                     "lever_arm", "w_gain", "sonic_noise", "downwash", "mast_w_attenuation")


def _campaign(mechanisms=None) -> dict:
    """The short unit flight (400 s hover) as a forward manifest: no window, the hover is found in the data."""
    camp = _unit_campaign(mechanisms)
    window = camp["payload_flights"][0].pop("window")
    camp["simulation"]["payload_flights"]["f1"]["start"] = window["start"]
    return camp


def _processing() -> dict:
    proc = copy.deepcopy(default_config()["processing"])
    proc["hover"]["min_duration_s"] = 300.0
    return proc


def _random_parameters(rng: np.random.Generator, name: str) -> dict[str, float]:
    """A draw inside the middle half of each catalog range (the simulator's settings must accept it)."""
    out = {}
    for p in get_mechanism(name).parameters:
        lo, hi = p.lower + 0.25 * (p.upper - p.lower), p.upper - 0.25 * (p.upper - p.lower)
        out[p.name] = float(rng.uniform(lo, hi))
    return out


def _same_records(a: list[RawRecord], b: list[RawRecord]) -> None:
    assert [r.source for r in a] == [r.source for r in b]
    for ra, rb in zip(a, b, strict=True):
        assert list(ra.columns) == list(rb.columns)
        for name in ra.columns:
            np.testing.assert_array_equal(ra.columns[name], rb.columns[name], err_msg=f"{ra.source} {name}")


def test_in_memory_records_give_the_l1_and_features_of_their_files():
    """One file round trip: the records, printed and parsed back, give identical L1 and features.

    With row defects (duplicates, swapped rows, out-of-range values, mast NaN and skipped
    records) and mechanisms in every instrument, so every reader path is exercised.
    """
    camp = _campaign([{"mechanism": "lever_arm", "parameters": {"x_m": 0.3, "y_m": -0.2, "z_m": 0.1}},
                      {"mechanism": "mast_w_attenuation", "parameters": {"gain": 0.9}},
                      {"mechanism": "downwash", "parameters": {"w0_ms": 0.8, "u_scale_ms": 4.0}}])
    check = forward.file_round_trip(camp, "f1", _processing())
    assert check == {"identical": True, "differences": []}


def test_the_round_trip_check_names_what_differs():
    """The comparison is not vacuous: one changed L1 value, attribute or feature is named."""
    run = forward.run_forward(_campaign(), "f1", _processing())
    assert forward.run_differences(run, run) == []
    sonic = run[1]["l1"]["sonic"].copy(deep=True)
    sonic["u_sensor_ms"].values[100] += 0.01
    ins = run[1]["l1"]["ins"].copy()
    ins.attrs["clock_drift_ppm"] = 1.0 + float(ins.attrs["clock_drift_ppm"])
    feats = copy.deepcopy(run[0])
    name = next(k for k, v in feats.values.items() if np.isfinite(v))
    feats.values[name] += 1e-9
    altered = (feats, {**run[1], "l1": {**run[1]["l1"], "sonic": sonic, "ins": ins}})
    assert forward.run_differences(run, altered) == ["L1 sonic u_sensor_ms", "L1 ins attribute clock_drift_ppm",
                                                     f"feature {name}"]


@pytest.mark.parametrize("seed", [11, 12, 13])
def test_reused_truth_gives_the_records_of_a_fresh_simulation(seed):
    """Every measurement-stage mechanism, drawn at random, applied to the baseline's true state
    gives bit for bit the records of simulating the flight with the mechanism from scratch."""
    rng = np.random.default_rng(seed)
    names = list(rng.choice(MEASUREMENT_STAGE, size=3, replace=False))
    mechanisms = [{"mechanism": name, "parameters": _random_parameters(rng, name)} for name in names]
    truth = payload_truth(_campaign(), "f1")
    baseline, _ = payload_records(_campaign(), "f1", truth)  # fills the truth's memo of unchanged records
    camp = _campaign(mechanisms)
    reused, _ = payload_records(camp, "f1", truth)
    again, _ = payload_records(_campaign(), "f1", truth)
    assert all(a is b for a, b in zip(baseline, again, strict=True))
    fresh, _ = payload_records(camp, "f1")
    _same_records(reused, fresh)


def test_a_truth_keeps_only_the_records_without_a_mechanism():
    """A probe's own record (a mechanism on its instrument) is measured for its run and not kept:
    asked again it is measured again, bit for bit the same; the records of the instruments it
    leaves alone are the baseline's objects, and the truth's memo does not grow with the probes."""
    truth = payload_truth(_campaign(), "f1")
    baseline, _ = payload_records(_campaign(), "f1", truth)
    kept = len(truth.memo)
    for mech in ({"mechanism": "w_gain", "parameters": {"gain": 1.1}},
                 {"mechanism": "lever_arm", "parameters": {"x_m": 0.3, "y_m": 0.0, "z_m": 0.0}},
                 {"mechanism": "mast_w_attenuation", "parameters": {"gain": 0.9}}):
        first, _ = payload_records(_campaign([mech]), "f1", truth)
        second, _ = payload_records(_campaign([mech]), "f1", truth)
        changed = {"w_gain": {0}, "lever_arm": {1}, "mast_w_attenuation": set(range(2, len(first)))}[mech["mechanism"]]
        for k, (a, b, base) in enumerate(zip(first, second, baseline, strict=True)):
            if k in changed:
                assert a is not b and a is not base, (mech["mechanism"], k)
                _same_records([a], [b])
            else:
                assert a is base and b is base, (mech["mechanism"], k)
    assert len(truth.memo) == kept


def test_a_truth_at_another_hover_height_reuses_the_seeds_draws():
    """A height offset's truth, made after the baseline's in one forward flight's step store, finds
    the seed's jitter, INS noise, latent draws and mast series made, and gives bit for bit the
    records of simulating it alone; its masts' records are the baseline's."""
    store = StepStore()
    raised = _campaign([{"mechanism": "height_offset", "parameters": {"dz_m": 5.0}}])
    with reusing(store):
        baseline, _ = payload_records(_campaign(), "f1")
        hits = store.hits
        records, _ = payload_records(raised, "f1")
    assert store.hits - hits >= 4  # payload jitter, INS noise, latent draws, mast series
    _same_records(records, payload_records(raised, "f1")[0])
    _same_records(records[2:], baseline[2:])
    assert not all(np.array_equal(records[0].columns[k], baseline[0].columns[k]) for k in records[0].columns)


def test_reused_latent_draws_leave_the_generator_as_drawing_them_would():
    """The draws found for a generator's state are those it would give, and it is advanced past them."""
    store = StepStore()
    drawn, found = np.random.default_rng(5), np.random.default_rng(5)
    with reusing(store):
        first = atmosphere._standard_latents(drawn, 40, 3)
        again = atmosphere._standard_latents(found, 40, 3)
        other = atmosphere._standard_latents(np.random.default_rng(6), 40, 3)
    assert store.hits == 1 and again is first and not np.array_equal(other, first)
    assert found.bit_generator.state == drawn.bit_generator.state
    np.testing.assert_array_equal(found.standard_normal(8), drawn.standard_normal(8))
    np.testing.assert_array_equal(atmosphere._standard_latents(np.random.default_rng(5), 40, 3), first)


def test_a_truth_of_another_hover_height_is_refused():
    truth = payload_truth(_campaign(), "f1")
    lowered = _campaign([{"mechanism": "height_offset", "parameters": {"dz_m": 5.0}}])
    with pytest.raises(ValueError, match="dz"):
        payload_records(lowered, "f1", truth)


def test_reused_products_give_the_features_of_a_full_run():
    """The cache of a baseline run, read by probe runs (sonic, INS and mast probes), changes nothing."""
    proc = _processing()
    base = _campaign()
    cache = forward.ForwardCache()
    _, products = forward.run_forward(base, "f1", proc, cache=cache)
    cache.freeze()
    for mech in ({"mechanism": "w_gain", "parameters": {"gain": 1.15}},
                 {"mechanism": "heading_bias", "parameters": {"deg": -7.0}},
                 {"mechanism": "mast_w_attenuation", "parameters": {"gain": 0.88}}):
        camp = _campaign([mech])
        hits = cache.hits
        with_cache, _ = forward.run_forward(camp, "f1", proc, truth=products["truth"], cache=cache)
        alone, _ = forward.run_forward(camp, "f1", proc)
        assert cache.hits > hits, mech["mechanism"]
        if mech["mechanism"] == "heading_bias":  # the sonic's channels are not despiked again
            assert cache.steps.hits > 0
        assert with_cache.values.keys() == alone.values.keys()
        for key, value in alone.values.items():
            assert with_cache.values[key] == pytest.approx(value, nan_ok=True, rel=0, abs=0), (mech, key)


def test_shares_truth_admits_measurement_mechanisms_only():
    """Reruns take the baseline's true state only where no mechanism moves the hover point or,
    with the measured atmosphere, is undone on the reference record."""
    def mech(*names):
        return [{"mechanism": n, "parameters": {}} for n in names]

    assert probe_runs.shares_truth([], measured=True)
    assert probe_runs.shares_truth(mech(*MEASUREMENT_STAGE), measured=False)
    assert not probe_runs.shares_truth(mech("w_gain", "height_offset"), measured=False)
    for name in forward_atmosphere.RECORD_INVERSES:
        assert probe_runs.shares_truth(mech(name), measured=False)  # the model field has no record
        assert not probe_runs.shares_truth(mech("w_gain", name), measured=True)


def test_a_record_with_other_columns_is_named():
    camp = _campaign()
    records, _ = payload_records(camp, "f1")
    sonic = records[0]
    bad = RawRecord(sonic.source, {k: v for k, v in sonic.columns.items() if k != "w_ms"})
    with pytest.raises(InputError, match=r"flights/f1/sonic\.csv.*expected \['rpi_time_us'"):
        read_sonic_csv(bad)


def _measured_mast(camp: dict, conditions: dict):
    """The flight's reference mast L1 from a run of the campaign itself (as the measured record)."""
    from dronewind.mast.chain import compute_mast_l1

    records, _ = payload_records(camp, "f1")
    sonic = next(s for m in camp["masts"] for s in m["sonics"] if s["id"] == camp["payload_flights"][0]["reference"])
    mast = [r for r in records[2:] if sonic["id"] in r.source]
    m1 = compute_mast_l1(mast, sonic, _processing()["despike"])
    return forward_atmosphere.atmosphere_record(m1, conditions)


@pytest.mark.parametrize("atmosphere", ["model", "measured"])
@pytest.mark.slow
def test_parts_run_apart_merge_into_the_whole_flight(atmosphere):
    """The workflow's per-mechanism probe jobs give, merged, the runs of one job per flight.

    With the measured atmosphere too, where the mast_w_attenuation probes simulate their own
    true state (the record with the attenuation undone).
    """
    camp = _campaign()
    conditions = camp["simulation"]["payload_flights"]["f1"]
    record = _measured_mast(camp, conditions) if atmosphere == "measured" else None
    probes = tuple(p for p in PROBES if p.mechanism in ("w_gain", "height_offset", "mast_w_attenuation"))
    proc = _processing()
    whole = probe_runs.probe_runs(camp, "f1", conditions, proc, seeds=(0, 1), probes=probes, atmosphere=record)
    assert whole["atmosphere"] == atmosphere
    parts = [probe_runs.probe_runs(camp, "f1", conditions, proc, seeds=(0, 1), probes=probes, parts=[name],
                                atmosphere=record)
             for name in reversed(probe_parts(probes))]
    merged = probe_runs.merge_probe_runs(parts, probes)
    for key in ("reused_products", "reused_steps"):
        whole.pop(key), merged.pop(key)
    assert merged == whole
    with pytest.raises(InputError, match="expected each of"):
        probe_runs.merge_probe_runs(parts[1:], probes)
    # the workflow's two jobs of a flight: every probe with the first third of the seeds, then
    # the other two thirds (which do not hold the first seed)
    seeds = (0, 1, 2)
    whole = probe_runs.probe_runs(camp, "f1", conditions, proc, seeds=seeds, probes=probes, atmosphere=record)
    jobs = [probe_runs.probe_runs(camp, "f1", conditions, proc, seeds=seeds, probes=probes,
                                  parts=[seed_part(1, 3), *probe_parts(probes)[1:]], atmosphere=record),
            probe_runs.probe_runs(camp, "f1", conditions, proc, seeds=seeds, probes=probes,
                                  parts=[seed_part(3, 3), seed_part(2, 3)], atmosphere=record)]
    assert [len(j["baseline"]) for j in jobs] == [1, 2]
    joined = probe_runs.merge_probe_runs(jobs[::-1], probes)
    assert joined.pop("reused_products") == whole.pop("reused_products")  # the probes share the first seed's
    joined.pop("reused_steps"), whole.pop("reused_steps")
    assert joined == whole
    with pytest.raises(InputError, match="seed part"):
        probe_runs.merge_probe_runs(jobs[1:], probes)
    # the diagnosis takes the errors from the baseline seeds: a probe carries values only
    assert all(v is not None for b in whole["baseline"] for k, v in b["sigma"].items() if b["values"][k] is not None)
    assert any(v is not None for r in whole["probes"] for v in r["features"]["values"].values())
    assert all(v is None for r in whole["probes"] for v in r["features"]["sigma"].values())


def test_runs_without_the_lag_drift_differ_only_in_that_feature():
    """``lag_drift=False`` (the published numbers, which hold no lag) leaves out the halves'
    lag searches: lag_drift_s is missing and every other feature is bit-identical; parts run
    with and without it are not merged."""
    proc = _processing()
    camp = _campaign([{"mechanism": "w_gain", "parameters": {"gain": 1.15}}])
    with_drift, _ = forward.run_forward(camp, "f1", proc)
    without, _ = forward.run_forward(camp, "f1", proc, lag_drift=False)
    assert np.isfinite(with_drift.values["lag_drift_s"]) and np.isnan(without.values["lag_drift_s"])
    assert without.reasons["lag_drift_s"]
    for key, value in with_drift.values.items():
        if key != "lag_drift_s":
            assert without.values[key] == pytest.approx(value, nan_ok=True, rel=0, abs=0), key
    conditions = camp["simulation"]["payload_flights"]["f1"]
    probes = tuple(p for p in PROBES if p.mechanism == "w_gain")
    parts = [probe_runs.probe_runs(_campaign(), "f1", conditions, proc, seeds=(0,), probes=probes, parts=[name],
                                lag_drift=name == "w_gain")
             for name in probe_parts(probes)]
    assert [p["lag_drift"] for p in parts] == [False, True]
    with pytest.raises(InputError, match="disagree on lag_drift"):
        probe_runs.merge_probe_runs(parts, probes)
    # nor parts of different feature sets (the published numbers' runs compute six)
    parts = [probe_runs.probe_runs(_campaign(), "f1", conditions, proc, seeds=(0,), probes=probes, parts=[name],
                                features=("sw_su_drone",) if name == "w_gain" else None)
             for name in probe_parts(probes)]
    assert parts[1]["features"] == ["sw_su_drone"]
    assert parts[1]["probes"][0]["features"]["reasons"]["ln_sigma_ratio_w"] == "not requested"
    with pytest.raises(InputError, match="disagree on features"):
        probe_runs.merge_probe_runs(parts, probes)


def test_ins_probes_share_the_baseline_ins_noise_and_give_fresh_records():
    """The INS errors are drawn once per truth (``ins noise`` in its memo) and every INS
    probe's record equals a fresh simulation's bit for bit."""
    truth = payload_truth(_campaign(), "f1")
    payload_records(_campaign(), "f1", truth)
    noise_keys = [key for key in truth.memo if key[0] == "ins noise"]
    assert len(noise_keys) == 1
    noise = truth.memo[noise_keys[0]]
    for mech in ({"mechanism": "heading_bias", "parameters": {"deg": 6.0}},
                 {"mechanism": "attitude_lag", "parameters": {"lag_s": 0.2}},
                 {"mechanism": "lever_arm", "parameters": {"x_m": -0.4, "y_m": 0.0, "z_m": 0.3}}):
        camp = _campaign([mech])
        reused, _ = payload_records(camp, "f1", truth)
        assert truth.memo[noise_keys[0]] is noise and len([k for k in truth.memo if k[0] == "ins noise"]) == 1
        fresh, _ = payload_records(camp, "f1")
        _same_records(reused, fresh)
        assert not forward.same_records([reused[1]], [payload_records(_campaign(), "f1", truth)[0][1]]), \
            mech["mechanism"]
