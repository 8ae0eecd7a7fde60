"""Tests of the campaign planner (dronewind.plan): plan file, uncertainties, separation, manifest, CLI.

Truths: independent realisations of the forward simulation's turbulence (the scatter of a
hover's statistics over seeds), the printed statements of Ghirardelli et al. (2025) on their
uncertainty metrics (Sect. 5.3, Fig. 16), and exact identities (tau^-1/2 scaling, the
coherence at zero separation).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from dronewind.cli import main
from dronewind.errors import InputError
from dronewind.plan.manifest import flight_speeds, hover_offset_enu_m, plan_manifest
from dronewind.plan.separation import along_wind_limit_m, separation_limit_m, series_correlation
from dronewind.plan.spec import STABILITY_CLASSES, load_plan, parse_plan
from dronewind.plan.uncertainty import point_uncertainty

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "config" / "plans" / "example_plan.yaml"


def _plan(**over):
    body = {"name": "t", "site": {"latitude": 43.1, "longitude": 0.36, "altitude_m": 603},
            "conditions": {"wind_speed_ms": [4, 8], "wind_from_deg": 290, "stability": {"obukhov_length_m": -200}},
            "mast": {"heights_m": [30, 60]},
            "targets": {"relative_uncertainty": {"sigma_w": 0.1}}}
    for key, value in over.items():
        body[key] = value
    return body


# ---------------------------------------------------------------- plan file
def test_example_plan_loads_with_defaults():
    spec = load_plan(EXAMPLE)
    assert spec.platform == "sling_load" and spec.max_hover_s == 1500.0
    assert spec.obukhov_length_m == STABILITY_CLASSES["near_neutral_unstable"]
    assert spec.reference_height_m == 30.0 and spec.hover_height_m == 30.0
    assert [d.mechanism for d in spec.detect] == ["w_gain", "heading_bias", "sonic_ins_lag"]


def test_schema_copies_are_identical():
    a = (ROOT / "workflow" / "schemas" / "plan.schema.json").read_text()
    b = (ROOT / "src" / "dronewind" / "schemas" / "plan.schema.json").read_text()
    assert json.loads(a) == json.loads(b)


@pytest.mark.parametrize("over, where, what", [
    ({"conditions": {"wind_speed_ms": [4, 8], "wind_from_deg": 290}}, "[conditions]", "stability"),
    ({"conditions": {"wind_speed_ms": 0.5, "wind_from_deg": 290, "stability": {"class": "neutral"}}},
     "[conditions.wind_speed_ms]", "at least 1 m/s"),
    ({"conditions": {"wind_speed_ms": 5, "wind_from_deg": 290, "stability": {"class": "windy"}}},
     "[conditions.stability.class]", "windy"),
    ({"conditions": {"wind_speed_ms": [8, 4], "wind_from_deg": 290, "stability": {"class": "neutral"}}},
     "[conditions.wind_speed_ms]", "lowest, highest"),
    ({"conditions": {"wind_speed_ms": 5, "wind_from_deg": 290, "stability": {"obukhov_length_m": 5}}},
     "[conditions.stability]", "z/L"),
    ({"platform": {"kind": "quadrotor_fleet"}}, "[targets.relative_uncertainty.sigma_w]", "horizontal wind"),
    ({"targets": {"detect": [{"mechanism": "w_gian", "parameters": {"gain": 1.1}}]}}, "targets.detect[0]", "w_gian"),
    ({"targets": {"detect": [{"mechanism": "w_gain", "parameters": {"gain": 1.1}}]},
      "platform": {"kind": "rigid_mount"}}, "targets.detect[0]", "sling-load"),
    ({"mast": {"heights_m": []}}, "[mast.heights_m]", "non-empty"),
    ({"colour": "red"}, "(top level)", "colour"),
])
def test_bad_plans_name_the_key(over, where, what):
    with pytest.raises(InputError) as info:
        parse_plan(_plan(**over), "p.yaml")
    text = str(info.value)
    assert text.startswith("p.yaml") and where in text and what in text, text


def test_missing_plan_file(tmp_path):
    with pytest.raises(InputError, match="cannot read the plan file"):
        load_plan(tmp_path / "none.yaml")


# ---------------------------------------------------------------- uncertainty
def test_predicted_uncertainty_matches_the_scatter_of_independent_hovers():
    """The prediction against the truth: sigma_w, u* and w'T' of 48 independent 10-min hovers.

    Tolerance 35 %: the standard error of a relative scatter from 48 values is 1/sqrt(94) =
    10 %, so 35 % is 3.4 standard errors; the exponential fit of the time scale is a few % short
    of the autocorrelation's integral (measured 4-8 %)."""
    from dronewind.core.uncertainty import product_series
    from dronewind.simulate.atmosphere import simulate_wind
    from dronewind.simulate.spectral_model import wind_frame_unit_vectors

    z, speed, ell, z0, tau = 30.0, 4.0, -100.0, 0.1, 600.0
    pred = point_uncertainty(z, speed, 250.0, ell, z0, seed=3).relative(tau)
    e_u, e_v = wind_frame_unit_vectors(250.0)
    stats = {"sigma_w": [], "u_star": [], "w_theta": []}
    for s in range(48):
        ds = simulate_wind(np.array([[0.0, 0.0, z]]), tau, 8.0, speed, 250.0, z, ell, z0, seed=7919 * (s + 1))
        east, north = ds["u_east_ms"].values[0], ds["v_north_ms"].values[0]
        u, v = east * e_u[0] + north * e_u[1], east * e_v[0] + north * e_v[1]
        w, t = ds["w_up_ms"].values[0], ds["theta_v_k"].values[0]
        stats["sigma_w"].append(math.sqrt(np.mean(product_series(w))))
        stats["u_star"].append(math.hypot(np.mean(product_series(u, w)), np.mean(product_series(v, w))) ** 0.5)
        stats["w_theta"].append(np.mean(product_series(w, t)))
    for q, values in stats.items():
        achieved = np.std(values, ddof=1) / abs(np.mean(values))
        assert achieved == pytest.approx(pred[q], rel=0.35), (q, achieved, pred[q])


def test_uncertainty_scales_with_hover_duration_and_wind():
    pu = point_uncertainty(30.0, 5.0, 250.0, -300.0, 0.3, seed=1)
    a, b = pu.relative(600.0), pu.relative(2400.0)
    for q in a:
        assert b[q] == pytest.approx(a[q] / 2.0, rel=1e-12)
    need = pu.duration_for({"sigma_w": 0.04, "u_star": 0.12})
    assert need % 30.0 == 0
    got = pu.relative(need)
    assert got["sigma_w"] <= 0.04 and got["u_star"] <= 0.12
    shorter = pu.relative(need - 30.0)
    assert shorter["sigma_w"] > 0.04 or shorter["u_star"] > 0.12
    # a weaker wind needs a longer hover (Ghirardelli et al. 2025, Sect. 4.2: inversely proportional to U)
    weak = point_uncertainty(30.0, 2.0, 250.0, -300.0, 0.3, seed=1)
    assert weak.relative(600.0)["sigma_w"] > a["sigma_w"]


def test_paper_metric_against_ghirardelli_table4():
    """Ghirardelli et al. (2025), Sect. 5.3 and Fig. 16 at the Table 4 conditions and durations.

    Published (printed statements; the figure is not digitised): most samples below 0.5;
    s2, s3 and s4 "systematically fall outside" (above 0.5) for their weak wind; among the
    stationary samples, s5 has a high a_theta_w for its short record. Tolerance: the
    classification against 0.5 (each s2-s4 sample has at least half of its six metrics above
    0.5, every metric of the seven stationary samples below it), and s5's a_theta_w the largest
    of the stationary ones. Not reproduced (and not tested): s9's high a_theta_w, which the
    paper calls unclear and sees in the drone's data only."""
    from dronewind.diagnose.published_file import load_published

    pub = load_published(ROOT / "config" / "published" / "ghirardelli2025_samurai_s.yaml")
    metrics = {}
    for flight, row in pub["table4"].items():
        z, zeta = float(row["payload_height_m"]), float(row["zeta"])
        pu = point_uncertainty(z, float(row["wind_speed_ms"]), float(row["wind_from_deg"]), z / zeta, 0.3,
                               1500.0 if zeta < 0 else 1000.0, 285.0, seed=1)
        metrics[flight] = pu.paper(60.0 * float(row["duration_min"]))
    for flight in ("s02", "s03", "s04"):
        above = sum(v > 0.5 for v in metrics[flight].values())
        assert above >= 3, (flight, metrics[flight])
    stationary = pub["stationary_flights"]
    for flight in stationary:
        assert all(v < 0.5 for v in metrics[flight].values()), (flight, metrics[flight])
    assert max(stationary, key=lambda f: metrics[f]["wtheta"]) == "s05"


# ---------------------------------------------------------------- separation
def test_separation_limit_from_the_coherence_model():
    assert series_correlation(0.0, 30.0, 5.0, -200.0, 0.3) == pytest.approx(1.0, abs=1e-9)
    rho = [series_correlation(d, 30.0, 5.0, -200.0, 0.3) for d in (10.0, 36.0, 100.0)]
    assert rho[0] > rho[1] > rho[2] > 0
    limit = separation_limit_m(30.0, 5.0, -200.0, 0.3, 0.3)
    assert series_correlation(limit, 30.0, 5.0, -200.0, 0.3) == pytest.approx(0.3, abs=0.005)
    # a vertical offset uses up part of the effective separation
    offset = separation_limit_m(30.0, 5.0, -200.0, 0.3, 0.3, vertical_offset_m=20.0)
    assert offset == pytest.approx(math.sqrt(limit**2 - 20.0**2), abs=0.2)
    assert separation_limit_m(30.0, 5.0, -200.0, 0.3, 0.3, vertical_offset_m=500.0) == 0.0
    assert along_wind_limit_m(50.0, 3.0, 6.0) == 18.0 and along_wind_limit_m(5.0, 3.0, 6.0) == 10.0


# ---------------------------------------------------------------- manifest
def test_flight_speeds_span_the_range_in_every_prefix():
    speeds = flight_speeds(3.0, 9.0, 5)
    assert speeds[:2] == [3.0, 9.0] and sorted(speeds) == [3.0, 4.5, 6.0, 7.5, 9.0]
    assert flight_speeds(5.0, 5.0, 3) == [5.0, 5.0, 5.0]


def test_plan_manifest_is_a_valid_virtual_campaign(tmp_path):
    import yaml

    from dronewind.manifest import load_campaign
    from dronewind.simulate.settings import resolve_payload_flight

    spec = parse_plan(_plan(mast={"heights_m": [30, 60], "hover_height_m": 55}), "p.yaml")
    data = plan_manifest(spec, 3, 720.0, flight_speeds(4, 8, 3), 40.0, seed=5)
    path = tmp_path / "campaign.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    campaign = load_campaign(path)
    assert campaign.simulated and len(campaign.payload_flights) == 3
    cond = resolve_payload_flight(data, "p02")
    assert cond["reference"] == "mast60" and cond["duration_s"] == 720.0
    assert cond["mean_speed_ms"] == 8.0 and cond["z_ref_m"] == 55.0 and cond["hover_height_m"] == 55.0
    assert math.hypot(*cond["hover_offset_enu_m"]) == pytest.approx(40.0, abs=0.01)
    # to the right of the mast looking downwind: wind from 290 blows towards 110 degree
    east, north = hover_offset_enu_m(40.0, 290.0)
    assert east * math.sin(math.radians(200)) + north * math.cos(math.radians(200)) == pytest.approx(40.0, abs=0.01)


# ---------------------------------------------------------------- CLI
def test_cli_help_has_examples(capsys):
    with pytest.raises(SystemExit):
        main(["plan", "--help"])
    out = capsys.readouterr().out
    assert "examples:" in out and "dronewind plan config/plans/example_plan.yaml" in out


def test_cli_plan_without_power(tmp_path, capsys):
    assert main(["plan", str(EXAMPLE), "--no-power", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "hover duration" in out and "largest separation" in out
    doc = json.loads((tmp_path / "plan.json").read_text())
    assert doc["hover_duration_s"] >= 630.0 and doc["targets_met"]["sigma_w"]
    assert (tmp_path / "uncertainty_vs_hover.png").stat().st_size > 1000
    assert "# Campaign plan example_plan" in (tmp_path / "plan.md").read_text()


def test_cli_plan_bad_file(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text(EXAMPLE.read_text().replace("max_flights: 6", "max_flights: 0"))
    assert main(["plan", str(bad), "--out", str(tmp_path / "o")]) == 1
    err = capsys.readouterr().err
    assert "bad.yaml [targets.max_flights]" in err


def test_power_stages_add_two_flights_at_a_time():
    """The power's flights are simulated two at a time, the first stage at the fewest flights a
    campaign diagnosis takes, the last at the plan's most."""
    from dronewind.plan.planner import power_stages

    assert power_stages(6) == [2, 4, 6]
    assert power_stages(7) == [2, 4, 6, 7]
    assert power_stages(2) == [2] and power_stages(1) == [1]
    assert power_stages(5, step=3) == [3, 5]


def test_count_search_draws_each_error_until_it_reaches_the_target():
    """Known powers per error and flight count: each error is drawn up to its first count at or above
    the target, a count below the fewest flights a diagnosis takes alone, the rest in batches that
    fill the workers; what is kept does not depend on the workers, and an error that never reaches
    the target is drawn at every count."""
    from dronewind.plan.planner import search_counts
    from dronewind.plan.power import PowerResult

    detected = {"a": [0, 18, 20, 20, 20, 20], "b": [0, 0, 8, 20, 20, 20], "c": [20, 20, 20, 20, 20, 20],
                "d": [0, 2, 3, 4, 5, 6]}
    for labels, expect in ((["a", "b", "c"], {"a": 2, "b": 4, "c": 1}), (["a", "d"], {"a": 2, "d": None})):
        kept = []
        for workers in (1, 2, 3):
            calls: list[list[tuple[str, int]]] = []

            def draw(batch, calls=calls):
                calls.append(batch)
                return [PowerResult(label, k, detected[label][k - 1], 20) for label, k in batch]

            reach = dict.fromkeys(labels)
            curve = {label: [] for label in labels}
            search_counts(labels, [1, 2, 3], reach, curve, 0.8, workers, draw)
            search_counts(labels, [4, 5, 6], reach, curve, 0.8, workers, draw)
            assert reach == expect
            assert calls[0] == [(label, 1) for label in labels]  # the free count first, alone
            for label in labels:
                last = reach[label] or 6
                assert [r.n_flights for r in curve[label]] == list(range(1, last + 1))
            kept.append((reach, curve))
        assert kept[0] == kept[1] == kept[2]
    # three errors on two workers: two counts per batch; one left: two counts
    calls = []
    search_counts(["a", "b", "c"], [1, 2, 3, 4, 5, 6], dict.fromkeys("abc"), {k: [] for k in "abc"}, 0.8, 2,
                  lambda batch: calls.append(batch) or [PowerResult(lab, k, detected[lab][k - 1], 20)
                                                         for lab, k in batch])
    # only the errors still below the target are drawn: c reached it at one flight, a at two
    assert calls == [[("a", 1), ("b", 1), ("c", 1)], [("a", 2), ("b", 2)], [("b", 3), ("b", 4)]]


# ---------------------------------------------------------------- power (slow)
@pytest.mark.slow
def test_power_of_a_two_flight_plan(tmp_path):
    """A plan of at most four flights (its flights and draws in two worker processes) that reaches its
    target at two, simulating only those (the first stage): a large w gain is detected
    in nearly every draw, the false-alarm rate is small (the diagnosis' calibration: 0 of 12 null
    draws named a cause). Ten draws per rate,
    30 baseline seeds per flight (the least the error model takes; the default for two flights
    is 90) and a bootstrap of 100 replicates (the least that alpha = 0.01 allows), drawn once per
    error and flight count for all draws (test_shared_reference_decides_as_each_draws_own)."""
    from dronewind.plan import plan_campaign

    body = _plan(targets={"relative_uncertainty": {"sigma_w": 0.1},
                          "detect": [{"mechanism": "w_gain", "parameters": {"gain": 1.25}}], "max_flights": 4},
                 monte_carlo={"draws": 10, "curve_draws": 10, "seed": 3})
    config = {"diagnosis": {"bootstrap": 100, "seeds": list(range(1, 31))}}
    plan = plan_campaign(parse_plan(body, "p.yaml"), config=config, work_dir=tmp_path, workers=2)
    # the four flights (two without the error, two with it) and the draws ran in worker processes
    assert plan.seconds["total_cpu"] > plan.seconds["simulation"] / 2
    r = plan.power["w_gain gain=1.25"]
    # the Wilson bound of 10/10 is 1 to rounding
    assert r.power >= 0.8 and r.interval[0] - 1e-12 <= r.power <= r.interval[1] + 1e-12
    assert plan.false_alarm is not None and plan.false_alarm.power >= 0.7
    assert len(plan.manifest["payload_flights"]) == plan.n_flights
    # the power curve stops at the first flight count that meets the target: the plan's
    curve = plan.power_curve["w_gain gain=1.25"]
    assert [x.n_flights for x in curve] == list(range(1, plan.n_flights + 1))
    assert curve[-1].power >= 0.8 and all(x.power < 0.8 for x in curve[:-1])
    # reached at two of four flights: the flights above the first stage were not simulated
    assert plan.n_flights == 2 and plan.simulated_flights == 2
    assert any("(w_gain gain=1.25: 2), then at the plan's 2 flights" in note and "(2 of 4 flights simulated)" in note
               for note in plan.notes)
    assert plan.to_json()["simulated_flights"] == 2 and "about the 2-flight campaign" in plan.power_note


@pytest.mark.slow
def test_flights_simulated_in_stages_have_the_evidence_of_one_call(tmp_path):
    """A campaign's flights simulated one call at a time (the power's stages) get the measured
    features, runs and statistics they get when simulated together: the campaign stays whole
    (two flights, two seeds)."""
    from dronewind.manifest import with_defaults
    from dronewind.plan import plan_campaign
    from dronewind.plan import power as pw
    from dronewind.plan import simulation as sim
    from dronewind.plan.planner import power_campaigns

    spec = parse_plan(_plan(targets={"relative_uncertainty": {"sigma_w": 0.1}, "max_flights": 2}), "p.yaml")
    config = with_defaults({"diagnosis": {"seeds": [1, 2]}})
    manifests = {pw.NO_ERROR: power_campaigns(plan_campaign(spec, config=config, simulate_power=False))[pw.NO_ERROR]}
    whole = sim.campaign_evidences(manifests, config, tmp_path / "whole")[pw.NO_ERROR]
    fids = list(whole["forward"])
    assert len(fids) == 2
    parts = [sim.campaign_evidences(manifests, config, tmp_path / "staged", flights=[fid])[pw.NO_ERROR]
             for fid in fids]
    for fid, part in zip(fids, parts, strict=True):
        assert list(part["forward"]) == [fid]
        for key in ("measured", "forward", "statistics"):
            assert json.dumps(part[key][fid], sort_keys=True) == json.dumps(whole[key][fid], sort_keys=True)


@pytest.fixture(scope="module")
def two_flight_model(tmp_path_factory):
    """The power model of a 2-flight plan with a w gain of 1.25 hidden (30 seeds per flight)."""
    from dronewind.manifest import with_defaults
    from dronewind.plan import plan_campaign
    from dronewind.plan import power as pw
    from dronewind.plan import simulation as sim
    from dronewind.plan.planner import power_campaigns

    spec = parse_plan(_plan(targets={"relative_uncertainty": {"sigma_w": 0.1},
                                     "detect": [{"mechanism": "w_gain", "parameters": {"gain": 1.25}}],
                                     "max_flights": 2}), "p.yaml")
    config = with_defaults({"diagnosis": {"bootstrap": 100, "seeds": list(range(1, 31))}})
    plan = plan_campaign(spec, config=config, simulate_power=False)
    manifests = power_campaigns(plan)  # as plan_campaign simulates them for the power
    model = pw.campaign_power_model(manifests, sim.campaign_evidences(manifests, config,
                                                                     tmp_path_factory.mktemp("power")), spec.detect)
    return model, spec.detect[0].label, config


@pytest.mark.slow
def test_flights_an_error_leaves_unseen_share_the_forward_runs_they_would_have(tmp_path):
    """A w gain of the payload sonic moves neither the conditions the chain measures from the mast
    nor the mast record: the flight of the campaign with the error gets the forward runs of the
    flight without it, and they are those it would get on its own (two seeds, one flight)."""
    from dronewind.manifest import with_defaults
    from dronewind.plan import plan_campaign
    from dronewind.plan import power as pw
    from dronewind.plan import simulation as sim
    from dronewind.plan.planner import power_campaigns

    spec = parse_plan(_plan(targets={"relative_uncertainty": {"sigma_w": 0.1},
                                     "detect": [{"mechanism": "w_gain", "parameters": {"gain": 1.25}}],
                                     "max_flights": 1}), "p.yaml")
    config = with_defaults({"diagnosis": {"seeds": [1, 2]}})
    manifests = power_campaigns(plan_campaign(spec, config=config, simulate_power=False))
    label = spec.detect[0].label
    cpu: list[float] = []
    evidences = sim.campaign_evidences(manifests, config, tmp_path / "shared", cpu_seconds=cpu)
    fid = next(iter(evidences[pw.NO_ERROR]["forward"]))
    assert len(cpu) == 3  # two flights processed, one set of forward runs
    assert evidences[label]["forward"][fid] is evidences[pw.NO_ERROR]["forward"][fid]
    assert evidences[label]["measured"][fid] != evidences[pw.NO_ERROR]["measured"][fid]
    own = sim.flight_evidence(sim._simulated_view(manifests[label]), fid, config, tmp_path / "own")
    assert json.dumps(own["forward"], sort_keys=True) == json.dumps(evidences[label]["forward"][fid], sort_keys=True)
    assert own["measured"] == evidences[label]["measured"][fid]


@pytest.mark.slow
def test_shared_reference_decides_as_each_draws_own(two_flight_model):
    """The draws of one case share one bootstrap reference (made once per error and flight count,
    reused on the next call); their decisions are those of a reference of each draw's own: the
    two differ only where a p-value sits near alpha, so at least 5 of 6 paired draws agree, and
    the draws are the same campaigns both ways (same seed, same features)."""
    from dronewind.diagnose.experiments import judge
    from dronewind.diagnose.in_process import diagnose_evidence
    from dronewind.plan import power as pw

    model, label, config = two_flight_model
    first = pw.draw_power(model, label, 2, 6, 11, config)
    assert set(model.references) == {(label, 2)}
    ref = model.references[(label, 2)]
    assert ref is not None and ref.n_replicates == 100
    again = pw.draw_power(model, label, 2, 6, 11, config)
    assert model.references[(label, 2)] is ref and again == first
    draws = list(pw.drawn_campaigns(model, label, 2, 6, 11))
    same = list(pw.drawn_campaigns(model, label, 2, 6, 11))
    assert [d.evidence["measured"] for d in draws] == [d.evidence["measured"] for d in same]
    own = [judge(d.truth, diagnose_evidence(d.evidence, config), d.campaign)["detected"] for d in draws]
    shared = [judge(d.truth, diagnose_evidence(d.evidence, config, reference=ref), d.campaign)["detected"]
              for d in draws]
    assert sum(shared) == first.detected
    assert sum(a == b for a, b in zip(own, shared, strict=True)) >= 5
    with pytest.raises(ValueError, match="per_draw"):
        pw.draw_power(model, label, 2, 1, 11, config, reference="bootstrap")


@pytest.mark.slow
def test_draws_of_one_flight_are_not_diagnosed_and_draw_no_reference(two_flight_model):
    """A campaign of fewer flights than the diagnosis needs is not diagnosed (nothing named), as a
    measured one is; its draws get no bootstrap reference, which would be drawn for nothing."""
    from dronewind.diagnose.in_process import decide_evidence
    from dronewind.diagnose.probes import MIN_FLIGHTS
    from dronewind.plan import power as pw

    model, label, config = two_flight_model
    assert MIN_FLIGHTS == 2
    draws = list(pw.drawn_campaigns(model, label, 1, 3, 5))
    assert pw.shared_reference(draws, config) is None
    assert all(decide_evidence(d.evidence, config)["named_causes"] == [] for d in draws)
    result = pw.draw_power(model, label, 1, 3, 5, config)
    assert model.references[(label, 1)] is None and result.detected == 0 and result.draws == 3


@pytest.mark.slow
def test_draw_powers_in_worker_processes_are_the_calls_in_this_process(two_flight_model):
    """The Monte-Carlo calls spread over two worker processes give the same detections and the
    same shared references as the same calls one after the other here (the draws are seeded by
    their arguments, the references by their draws; a one-flight campaign has none); a call whose
    reference exists reuses it."""
    import copy

    from dronewind.plan import power as pw

    model, label, config = two_flight_model
    calls = [(label, 1, 3, 4), (label, 2, 6, 4), (None, 2, 6, 5)]
    here, there = copy.deepcopy(model), copy.deepcopy(model)
    here.references.clear()
    there.references.clear()
    cpu: list[float] = []
    sequential = pw.draw_powers(here, calls, config)
    parallel = pw.draw_powers(there, calls, config, workers=2, cpu_seconds=cpu)
    assert parallel == sequential
    assert set(there.references) == set(here.references) == {(label, 1), (label, 2), (None, 2)}
    assert here.references[(label, 1)] is None and there.references[(label, 1)] is None
    for key, ref in here.references.items():
        if ref is not None:
            assert np.array_equal(there.references[key].lr[next(iter(ref.lr))], ref.lr[next(iter(ref.lr))])
    assert len(cpu) == 3 and all(c > 0 for c in cpu)
    kept = there.references[(label, 2)]
    assert pw.draw_powers(there, [(label, 2, 6, 4)], config, workers=2) == sequential[1:2]
    assert there.references[(label, 2)] is kept
    # one pool for several calls (the planner's flight counts in turn): the same results
    pooled = copy.deepcopy(model)
    pooled.references.clear()
    with pw.power_pool(pooled, 2) as pool:
        assert [pw.draw_powers(pooled, [call], config, workers=2, pool=pool)[0] for call in calls] == sequential


def test_first_flights_of_a_plan_manifest_stay_a_valid_virtual_campaign():
    """The power curve's campaigns of fewer flights keep only those flights' simulated conditions,
    so the judge can read their processing lags (a hidden sonic-INS lag's verdict needs them)."""
    from dronewind.plan.power import _first_flights
    from dronewind.simulate.settings import validate_simulation

    spec = parse_plan(_plan(targets={"relative_uncertainty": {"sigma_w": 0.1}, "max_flights": 3}), "p.yaml")
    full = plan_manifest(spec, 3, 630.0, [4.0, 6.0, 8.0], 36.0)
    one = _first_flights(full, ["p01"])
    assert [f["id"] for f in one["payload_flights"]] == ["p01"]
    assert sorted(one["simulation"]["payload_flights"]) == ["p01"]
    validate_simulation(one)
    assert sorted(full["simulation"]["payload_flights"]) == ["p01", "p02", "p03"]  # the original is untouched
