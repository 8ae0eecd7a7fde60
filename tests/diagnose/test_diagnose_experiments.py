"""Hidden-effect draws: commit-derived seed, stratified cells, model-error truths, judging, intervals."""

from __future__ import annotations

import subprocess
from collections import Counter

import numpy as np
import pytest

from dronewind.diagnose import experiments as ex
from dronewind.mechanisms import get_mechanism
from dronewind.simulate.defaults import MAST_DEFAULTS, PAYLOAD_DEFAULTS, SPECTRA, TURBULENCE_DEFAULTS
from dronewind.simulate.settings import validate_simulation


def test_hidden_ranges_are_inside_the_catalog_ranges_and_signed_ones_cover_both_sides():
    rng = np.random.default_rng(0)
    for mech, params in ex.HIDDEN_RANGES.items():
        for name, (lo, hi, signed) in params.items():
            spec = next(p for p in get_mechanism(mech).parameters if p.name == name)
            centre = ex.HIDDEN_CENTRES.get((mech, name), 0.0)
            ends = [centre + lo, centre + hi] + ([centre - lo, centre - hi] if signed else [])
            assert spec.lower <= min(ends) and max(ends) <= spec.upper, (mech, name)
            if signed:
                values = [ex._hidden_value(rng, mech, name, side) for side in (1, -1)]
                assert values[0] > centre > values[1]


def test_stratified_draws_have_the_stated_shares_and_every_cell():
    draws = ex.stratified_draws(60, seed=1)
    cases = Counter(d.case for d in draws)
    assert cases == {"null": 12, "model_error": 9, "mechanism": 39}
    labels = {d.label for d in draws}
    for mech, params in ex.HIDDEN_RANGES.items():
        if any(s for _, _, s in params.values()):
            assert {mech + "+", mech + "-"} <= labels
        else:
            assert mech in labels
    assert {f"model_error:{m}" for m in ex.MODEL_ERRORS} <= labels
    assert ex.stratified_draws(60, seed=1) == draws  # reproducible
    assert ex.stratified_draws(60, seed=2) != draws


@pytest.mark.parametrize("name", sorted(ex.MODEL_ERRORS))
def test_model_error_truth_reaches_the_simulation_but_not_the_catalog(name):
    d = ex.model_error_draw(np.random.default_rng(3), name)
    manifest = ex.campaign_manifest(d)
    assert manifest["simulation"]["mechanisms"] == []
    for section, settings in ex.MODEL_ERRORS[name].items():
        assert set(manifest["simulation"][section]) == set(settings)
        assert manifest["simulation"][section] == d.model_error[section]
    validate_simulation(manifest)  # every drawn size inside the simulator's physical ranges
    verdict = ex.judge(d, {"named_causes": ["attitude_lag"]})
    assert verdict["false_alarm"] and not verdict["detected"] and verdict["case"] == "model_error"
    assert ex.judge(d, {"named_causes": []})["detected"]


def test_model_error_ranges_lie_inside_the_settings_ranges():
    tables = {"payload": PAYLOAD_DEFAULTS, "mast": MAST_DEFAULTS, "atmosphere": TURBULENCE_DEFAULTS}
    for name, sections in ex.MODEL_ERRORS.items():
        for section, keys in sections.items():
            for key, choices in keys.items():
                if key == "spectrum":
                    assert set(choices) <= set(SPECTRA) - {SPECTRA[0]}, name
                    continue
                default, lo, hi, _ = tables[section][key]
                for low, high in choices:
                    assert lo <= low < high <= hi, (name, key)
                    assert not low <= default <= high, (name, key)  # the forward model's value is excluded


def test_judge_flags_a_wrong_cause_and_measures_the_estimate_error():
    truth = ex.Draw("w_gain", {"gain": 0.8}, 1)
    diag = {"named_causes": ["w_gain", "sonic_noise"], "ambiguity_sets": [],
            "named_estimates": {"w_gain": {"estimate": {"gain": 0.83}}}}
    v = ex.judge(truth, diag)
    assert v["detected"] and v["wrong_cause"] and v["estimate_ok"]
    assert v["estimate_error"] == pytest.approx(0.03 / 0.05)
    assert not ex.judge(truth, {**diag, "named_causes": ["w_gain"]})["wrong_cause"]


def test_judge_mast_attenuation_named_as_drone_w_gain_only_with_the_measured_atmosphere():
    # the measured atmosphere is the mast's record: a mast w attenuation g and a drone w gain
    # 1/g predict the same sensor differences; the model atmosphere separates them
    truth = ex.Draw("mast_w_attenuation", {"gain": 0.83}, 1)
    diag = {"named_causes": ["w_gain"], "ambiguity_sets": [], "candidates": []}
    measured = ex.judge(truth, {**diag, "atmosphere": "measured"})
    assert measured["detected"] and not measured["wrong_cause"]
    model = ex.judge(truth, {**diag, "atmosphere": "model"})
    assert not model["detected"] and model["wrong_cause"]


def test_judge_takes_the_estimate_of_a_named_exact_equivalent_translated():
    # a hidden drone w gain of 1.30 named as a mast attenuation of 0.78 (= a w gain of 1.282):
    # judged on that estimate, not on the unnamed w_gain candidate's 1.249 (0.051 off, beyond
    # the 0.05 tolerance); with the model atmosphere the two are not equivalent
    truth = ex.Draw("w_gain", {"gain": 1.30}, 1)
    diag = {"named_causes": ["mast_w_attenuation"], "ambiguity_sets": [],
            "named_estimates": {"mast_w_attenuation": {"estimate": {"gain": 0.78}}},
            "candidates": [{"mechanism": "w_gain", "estimate": {"gain": 1.249}}]}
    measured = ex.judge(truth, {**diag, "atmosphere": "measured"})
    assert measured["detected"] and measured["estimate_ok"]
    assert measured["estimate"]["gain"] == pytest.approx(1.0 / 0.78)
    assert measured["estimate_error"] == pytest.approx(abs(1.0 / 0.78 - 1.30) / 0.05)
    model = ex.judge(truth, {**diag, "atmosphere": "model"})
    assert model["estimate"]["gain"] == 1.249 and not model["estimate_ok"]


def test_draw_seed_from_the_environment_the_commit_or_fixed(tmp_path, monkeypatch):
    monkeypatch.setenv(ex.DRAW_SEED_ENV, "123")
    assert ex.draw_seed(tmp_path) == (123, f"${ex.DRAW_SEED_ENV}")
    monkeypatch.delenv(ex.DRAW_SEED_ENV)
    seed, source = ex.draw_seed(tmp_path)
    assert seed == ex.FALLBACK_DRAW_SEED and "not a git checkout" in source
    env = {"GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@t", "GIT_COMMITTER_NAME": "t", "GIT_COMMITTER_EMAIL": "t@t"}
    subprocess.run(["git", "init", "-q"], cwd=tmp_path, check=True)
    subprocess.run(["git", "commit", "-q", "--allow-empty", "-m", "x"], cwd=tmp_path, check=True, env=env)
    sha = subprocess.run(["git", "rev-parse", "HEAD"], cwd=tmp_path, capture_output=True, text=True,
                         check=True).stdout.strip()
    assert ex.draw_seed(tmp_path) == (int(sha[:8], 16), f"commit {sha[:12]}")


@pytest.mark.parametrize(("k", "n", "lo", "hi"), [
    (0, 10, 0.0, 0.2775),  # closed form of Wilson (1927) evaluated by hand
    (5, 10, 0.2366, 0.7634),
    (10, 10, 0.7225, 1.0),
    (1, 60, 0.00295, 0.0886),
])
def test_wilson_interval_known_values(k, n, lo, hi):
    got = ex.wilson_interval(k, n)
    assert got == pytest.approx((lo, hi), abs=5e-4)


def test_hidden_mount_and_downwash_draws_carry_every_parameter_and_validate():
    draws = [d for d in ex.stratified_draws(60, seed=5) if d.mechanism in ("mount_misalignment", "downwash")]
    assert {d.label for d in draws} >= {"mount_misalignment+", "mount_misalignment-", "downwash"}
    for d in draws:
        validate_simulation(ex.campaign_manifest(d))  # all parameters present and inside the catalog
        if d.mechanism == "mount_misalignment":
            assert d.parameters["roll_deg"] == d.parameters["yaw_deg"] == 0.0
            assert 3.0 <= abs(d.parameters["pitch_deg"]) <= 8.0


def test_downwash_is_judged_on_its_downdraft_at_the_reference_speed():
    truth = ex.Draw("downwash", {"w0_ms": 1.0, "u_scale_ms": 5.0}, 1)
    # another (w0, u_scale) pair with nearly the same downdraft at 6.5 m/s: 0.320 vs 0.273 m/s
    close = {"named_causes": ["downwash"], "named_estimates": {"downwash": {"estimate": {"w0_ms": 0.72,
                                                                                        "u_scale_ms": 8.0}}}}
    far = {"named_causes": ["downwash"], "named_estimates": {"downwash": {"estimate": {"w0_ms": 0.3,
                                                                                      "u_scale_ms": 3.0}}}}
    assert ex.judge(truth, close)["estimate_ok"]
    verdict = ex.judge(truth, far)  # 0.034 m/s: 88 % low
    assert verdict["detected"] and not verdict["estimate_ok"]
    assert verdict["estimate_error"] == pytest.approx(abs(0.3 * np.exp(-6.5 / 3) - np.exp(-1.3)) / (0.4 * np.exp(-1.3)))


def test_named_causes_with_known_uncatalogued_aliases_carry_a_caveat():
    from dronewind.diagnose.campaign import caveats

    out = caveats(["w_gain", "mount_misalignment", "height_offset"])
    assert [c["mechanism"] for c in out] == ["mount_misalignment", "height_offset"]
    assert all("mast" in c["alias"] for c in out)
    assert caveats([]) == []


def test_a_model_error_named_as_its_caveated_alias_is_flagged_not_excused():
    d = ex.model_error_draw(np.random.default_rng(0), "mast_flow_distortion")
    flagged = {"named_causes": ["mount_misalignment"],
               "caveats": [{"mechanism": "mount_misalignment", "alias": "mast tilt"}]}
    verdict = ex.judge(d, flagged)
    assert verdict["false_alarm"] and verdict["caveated"]
    # without the diagnosis' caveat, or with another cause, it is a plain false attribution
    assert not ex.judge(d, {"named_causes": ["mount_misalignment"]})["caveated"]
    assert not ex.judge(d, {**flagged, "named_causes": ["mount_misalignment", "w_gain"]})["caveated"]
    other = ex.model_error_draw(np.random.default_rng(0), "turbulence_isotropy")
    assert not ex.judge(other, flagged)["caveated"]
    clean = ex.judge(other, {"named_causes": []})
    assert clean["detected"] and not clean["false_alarm"] and not clean["caveated"]


def test_extended_reruns_get_seeds_the_baseline_never_ran():
    from dronewind.diagnose.probes import fresh_seeds, resolved_seeds
    from dronewind.manifest import default_config

    baseline = resolved_seeds(default_config()["diagnosis"]["seeds"], 4)
    rerun = fresh_seeds(baseline)
    assert len(set(rerun)) == 2 and not set(rerun) & set(baseline)
    assert fresh_seeds([101, 202]) == (303, 404)  # the historical rerun seeds where free
    assert not set(fresh_seeds([404, 7, 1000], n=3)) & {404, 7, 1000}


def test_a_hidden_lag_is_judged_on_the_estimated_processing_lags_with_nothing_named():
    """A hidden sonic_ins_lag adds to every flight's processing lag (a measured condition of
    the forward model): right when nothing is named and the median over the flights of the
    estimated processing lag minus the flight's own equals the hidden lag within 0.1 s."""
    from dronewind.simulate.settings import resolve_payload_flight

    truth = ex.Draw("sonic_ins_lag", {"lag_s": 0.4}, 5)
    camp = ex.campaign_manifest(truth)
    base = {f["id"]: resolve_payload_flight(camp, f["id"])["sonic_ins_lag_s"] for f in camp["payload_flights"]}
    assert all(-0.185 <= b <= 0.0 for b in base.values()) and len(set(base.values())) == len(base)
    errors = dict(zip(base, (0.03, -0.05, 0.07, 0.09), strict=True))
    # the chain's own lag (sonic_ins_lag_s, below the processing lag) is not the estimate
    found = {f: {"sonic_ins_lag_s": b + 0.4 - 0.1, "processing_lag_s": b + 0.4 + errors[f]} for f, b in base.items()}
    v = ex.judge(truth, {"named_causes": [], "measured_conditions": found})
    assert v["detected"] and not v["wrong_cause"] and v["estimate_ok"]
    assert v["estimate"]["lag_s"] == pytest.approx(0.45)  # median of 0.43, 0.35, 0.47, 0.49
    assert v["estimate_error"] == pytest.approx(0.05 / 0.1)
    assert v["measured_lags"]["h02"] == pytest.approx({"estimated": base["h02"] + 0.35, "base": base["h02"]})
    named = ex.judge(truth, {"named_causes": ["lever_arm"], "measured_conditions": found})
    assert not named["detected"] and named["wrong_cause"] and not named["estimate_ok"]
    # the hidden lag missed on two flights (only their processing lag found there): the median
    # of 0.43, 0.35, 0 and 0 is off
    missed = {**found, **{f: {"processing_lag_s": base[f]} for f in ("h03", "h04")}}
    v = ex.judge(truth, {"named_causes": [], "measured_conditions": missed})
    assert not v["estimate_ok"] and v["estimate_error"] == pytest.approx((0.4 - 0.175) / 0.1)
    # a diagnosis without measured lags cannot show it
    v = ex.judge(truth, {"named_causes": []})
    assert v["detected"] and not v["estimate_ok"] and np.isnan(v["estimate_error"])
