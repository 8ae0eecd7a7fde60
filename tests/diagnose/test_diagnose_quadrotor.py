"""Diagnosis of the single-law quadrotor model: hidden pitch/yaw offsets and a drag regime
drawn at random (seeded) must be named and recovered; the null case must name nothing.

Each draw simulates 8 flights x 3 UAVs x 10 min (UAVs at 20, 50 and 90 m, rotated between
flights so that a UAV's offset and the speed dependence of the drag law are separable; 98-m wind speed
2.5 to 11 m/s, log-profile wind with 12 % turbulence intensity, the simulator's default
attitude noise, hover wander and weather-vane dead band), cuts 2-min windows (96 in all)
and runs the diagnosis with 5-fold cross-validation over flights.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dronewind.diagnose import quadrotor as dq
from dronewind.diagnose import quadrotor_field, quadrotor_tunnel
from dronewind.errors import InputError
from dronewind.quadrotor import windows as qw
from dronewind.simulate.quadrotor import log_profile_wind, simulate_quadrotor_flight

pytestmark = pytest.mark.slow  # workflow runs or repeated diagnoses: not in the fast tier

UAVS = ("q01", "q02", "q03")


def _campaign(seed: int, offsets: dict, regime: list | None, n_flights: int = 8, minutes: int = 10) -> dict:
    rng = np.random.default_rng(seed)
    flights, conds = [], {}
    speeds = np.linspace(2.5, 11.0, n_flights)
    for k in range(n_flights):
        fid = f"f{31 + k}"
        flights.append({"id": fid, "reference": f"tower/{fid}_reference.csv",
                        "uavs": [{"id": u, "file": f"quad/{fid}/{u}.csv"} for u in UAVS]})
        start = np.datetime64("2020-07-24T08:00:00") + np.timedelta64(30 * k, "m")
        conds[fid] = {"start": f"{start}Z", "end": f"{start + np.timedelta64(minutes, 'm')}Z",
                      "wind_speed_ms": float(speeds[k]), "wind_from_deg": float(rng.uniform(180, 330)),
                      "heights_m": dict(zip(UAVS, np.roll((20, 50, 90), k).tolist(), strict=True))}
    mech = [{"mechanism": "drag_regime", "parameters": {"coefficients": regime}}] if regime else []
    return {"name": "t", "site": {"latitude": 52.1667, "longitude": 14.1236, "altitude_m": 73.0},
            "quadrotor_flights": flights,
            "simulation": {"seed": seed, "quadrotor": {"uavs": {u: {"pitch_offset_deg": o[0], "yaw_offset_deg": o[1]}
                                                                for u, o in offsets.items()}},
                           "quadrotor_flights": conds, "mechanisms": mech}}


def _draw(seed: int, kind: str) -> tuple[dict, list | None]:
    """Hidden truth of one draw: per-UAV offsets and/or a two-range drag regime."""
    rng = np.random.default_rng(1000 + seed)
    offsets = {u: (0.0, 0.0) for u in UAVS}
    regime = None
    if kind in ("offsets", "both"):
        # Wetz et al. (2021) reports pitch offsets within +-4.3 degree and yaw offsets of -2..22 degree;
        # at least 1 degree / 5 degree away from zero so that every UAV has something to find
        offsets = {u: (float(rng.choice([-1, 1]) * rng.uniform(1.0, 4.0)),
                       float(rng.choice([-1, 1]) * rng.uniform(5.0, 20.0))) for u in UAVS}
    if kind in ("regime", "both"):
        # continuous two-range power law (Kistner et al. 2024 Table 2 form) with a kink at a random edge:
        # steeper below the edge (b1 0.8-0.95) than above (b2 0.4-0.5)
        edge = float(rng.uniform(4.5, 6.5))
        b1, c1, b2 = float(rng.uniform(0.8, 0.95)), float(rng.uniform(6.5, 7.5)), float(rng.uniform(0.4, 0.5))
        c2 = edge / ((edge / c1) ** (1 / b1)) ** b2
        regime = [{"min_speed_ms": 0.0, "max_speed_ms": edge, "b": b1, "c": c1},
                  {"min_speed_ms": edge, "max_speed_ms": 40.0, "b": b2, "c": c2}]
    return offsets, regime


def _diagnose(tmp_path: Path, seed: int, kind: str):
    offsets, regime = _draw(seed, kind)
    camp = _campaign(seed, offsets, regime)
    for f in camp["quadrotor_flights"]:
        simulate_quadrotor_flight(camp, tmp_path, f["id"], tmp_path, wind_fn=log_profile_wind)
    blocks, windows, problems = qw.campaign_windows(camp, tmp_path, window_s=120)
    assert problems.empty
    return offsets, regime, dq.diagnose_quadrotor("t", blocks, windows)


def _cand(res: dict, name: str) -> dict:
    return next(c for c in res["candidates"] if c["mechanism"] == name and c["source"] == "field")


#: Speeds at which a fitted drag law is compared with the hidden one [m s-1].
CHECK_SPEEDS_MS = np.linspace(2.5, 10.0, 16)


def _regime_error(est: dict, regime: list, speeds_ms: np.ndarray = CHECK_SPEEDS_MS) -> float:
    """Largest speed error of the fitted law on the true law's accelerations over 2.5-10 m/s."""
    err = []
    coef = est["coefficients"]
    edges = [c["max_speed_ms"] for c in coef[:-1]]
    for u in speeds_ms:
        r = next(r for r in regime if r["min_speed_ms"] <= u < r["max_speed_ms"])
        a = (u / r["c"]) ** (1 / r["b"])
        v = quadrotor_field.regime_speed(a, edges, [c["b"] for c in coef], [c["c"] for c in coef])
        err.append(abs(float(v) - u))
    return max(err)


@pytest.mark.parametrize("seed,kind", [(1, "offsets"), (3, "regime"), (10, "regime"),
                                       (2, "both")])
def test_hidden_causes_are_named_and_recovered(tmp_path, seed, kind):
    """Measured over more draws (same settings): offsets named in 2/2 (seeds 1, 17), regime-only
    named in 6/6 (seeds 3, 8-12; held-out gain 0.20-0.38), both: offsets named in 2/2 (seeds 2,
    13) but the regime in 0/2 (see test_regime_and_common_pitch_offset_are_confounded); the null
    case named nothing in 3/3 (seeds 5, 15, 16)."""
    offsets, regime, res = _diagnose(tmp_path, seed, kind)
    expected = {"offsets": {"pitch_offset", "yaw_offset"}, "both": {"pitch_offset", "yaw_offset"},
                "regime": {"drag_regime"}}[kind]
    assert expected <= set(res["named_causes"]), res["named_causes"]
    if kind != "both":
        assert set(res["named_causes"]) == expected
    ranked = [c["gain"] for c in res["candidates"]]
    assert ranked == sorted(ranked, reverse=True)
    if "pitch_offset" in expected:
        est = _cand(res, "pitch_offset")["estimate"]
        err = np.array([est[u] - offsets[u][0] for u in UAVS])
        if kind == "both":
            # a common pitch offset and the drag-law shape are confounded in field data: only
            # the UAV-to-UAV differences are identified (measured < 0.2 degree)
            err = err - err.mean()
        # 12 two-minute windows per UAV; measured |error| < 0.1 degree (pitch) and 0.6 degree
        # (yaw) over these draws; tolerances 0.5 and 3 degree (Wetz et al. 2021: offsets up to 4.3 deg)
        assert np.max(np.abs(err)) < 0.5
        est = _cand(res, "yaw_offset")["estimate"]
        assert max(abs((est[u] - offsets[u][1] + 180) % 360 - 180) for u in UAVS) < 3.0
    if "drag_regime" in expected:
        # the fitted speed-range law reproduces the hidden one within 0.5 m/s over 2.5-10 m/s
        # (measured 0.10-0.27 m/s over the named draws)
        assert _regime_error(_cand(res, "drag_regime")["estimate"], regime) < 0.5
    ext = res["extended_model"]
    # the extended model beats the single-law baseline on held-out flights by > 25 %
    # (measured 0.36-0.84)
    assert ext["speed_gain"] > 0.25
    assert ext["speed_rmse_ms"]["after"] < ext["speed_rmse_ms"]["before"]
    for c in res["candidates"]:
        if c["significant"]:
            assert c["p_value"] < c["alpha_bonferroni"] and c["gain"] >= 0.05


def test_regime_and_common_pitch_offset_are_confounded(tmp_path):
    """With per-UAV offsets present, a drag regime is largely absorbed by the common part of the
    offsets plus the refitted single law (Wetz et al. 2021 Sect. 5.2 notes c_d0A0 and the offsets trade
    off): the diagnosis must not claim it, and the offsets absorb a common shift."""
    offsets, regime, res = _diagnose(tmp_path, 13, "both")
    assert "drag_regime" not in res["named_causes"]
    est = _cand(res, "pitch_offset")["estimate"]
    err = np.array([est[u] - offsets[u][0] for u in UAVS])
    assert np.ptp(err) < 0.5 < np.abs(err.mean())


def test_null_case_names_nothing(tmp_path):
    _, _, res = _diagnose(tmp_path, 5, "null")
    assert res["named_causes"] == []
    assert res["as_mechanisms"] == []
    # extra parameters that only fit noise do not gain on held-out flights
    assert all(c["gain"] < 0.05 for c in res["candidates"])
    assert res["baseline"]["metrics"]["speed_rmse_ms"] < 0.4


def test_regime_speed_known_answer():
    # one range: V = c a^b; two ranges switch where range 0 reaches its edge (5 m/s)
    assert quadrotor_field.regime_speed(4.0, [], [0.5], [6.0]) == pytest.approx(12.0)
    a_edge = (5.0 / 7.0) ** (1 / 0.8)
    v = quadrotor_field.regime_speed(np.array([0.5 * a_edge, 2 * a_edge]), [5.0], [0.8, 0.5], [7.0, 6.0])
    assert v[0] == pytest.approx(7.0 * (0.5 * a_edge) ** 0.8)
    assert v[1] == pytest.approx(6.0 * (2 * a_edge) ** 0.5)


def test_too_few_windows_is_a_named_error():
    import pandas as pd

    w = pd.DataFrame({"window_key": ["a"], "uav": ["q01"], "flight": ["f1"], "ref_speed_ms": [3.0],
                      "ref_from_deg": [200.0]})
    with pytest.raises(InputError, match="at least 3"):
        quadrotor_field.field_data(pd.DataFrame(columns=["window_key"]), w)


def _tunnel(tmp_path: Path, lag_s: float, seed: int) -> Path:
    from dronewind.simulate.tunnel import simulate_tunnel

    settings = {"uas": ["uas06"], "response_lag_s": lag_s,
                "kinds": ["calibration", "sideslip", "gust", "step"],
                "calibration": {"hold_s": 20.0, "aos_deg": [0.0, 0.0, 90.0], "v_max_ms": [16.0]},
                "sideslip": {"aos_deg": [0.0, 45.0], "hold_s": 15.0},
                "gusts": {"presets": [[6.0, 3.5], [10.0, 4.5]], "repetitions": 4},
                "steps": {"presets": [[5.0, 7.0]], "repetitions": [4]}}
    return simulate_tunnel(settings, tmp_path, seed)[-1]


@pytest.mark.parametrize("lag_s,seed", [(0.4, 21), (0.15, 22), (0.0, 23)])
def test_tunnel_response_lag_recovered_or_not_named(tmp_path, lag_s, seed):
    """Hidden first-order attitude lag in the tunnel's gusts and steps (Kistner et al. 2024 Sect. 4):
    recovered within 0.05 s and named when it matters; not named when absent (measured over
    seeds 21-25: 0.4 s -> 0.395 s, gain 0.29; 0.15 s -> 0.128-0.138 s, gain 0.048-0.054,
    named in 1 of 2; 0.0 s -> 0.022 s, gain 0.00). The attitude noise (0.25 degree) dominates
    the series RMSE, so a 0.15-s lag gains only ~5 % and sits at the naming threshold."""
    res = quadrotor_tunnel.tunnel_candidates(_tunnel(tmp_path, lag_s, seed))
    lag = next(c for c in res["candidates"] if c["mechanism"] == "response_lag")
    assert lag["estimate"]["tau_s"] == pytest.approx(lag_s, abs=0.05)
    if lag_s >= 0.4:
        assert lag["significant"] and lag["gain"] > 0.2
    if lag_s == 0.0:
        assert not lag["significant"] and lag["gain"] < 0.05
    side = next(c for c in res["candidates"] if c["mechanism"] == "sideslip")
    assert side["gain"] > 0.3  # lateral law (b_y, c_y) = (0.86, 5.6) vs longitudinal (0.88, 7.6)


def test_offset_attitude_terms_equal_the_direct_evaluation():
    """The fits' tilt and lean with pitch offsets (angle-sum formulas on cached cosines and sines)
    equal tilt_from_attitude at the offset pitch to rounding, upright blocks included."""
    from dronewind.quadrotor.drag import tilt_from_attitude

    rng = np.random.default_rng(3)
    n = 400
    roll = rng.uniform(-12.0, 12.0, n)
    pitch = rng.uniform(-15.0, 15.0, n)
    roll[:3], pitch[:3] = 0.0, [0.0, 1.5, -2.0]  # upright at 0 offset, and upright after the offsets below
    uav = np.array(["q1", "q2"])[rng.integers(0, 2, n)]
    uav[:3] = ["q1", "q1", "q2"]
    data = quadrotor_field.FieldData(win=np.arange(n), roll=roll, pitch=pitch, yaw=rng.uniform(0.0, 360.0, n),
                                     vn=np.zeros(n), ve=np.zeros(n), ref_speed=np.ones(n), ref_from=np.zeros(n),
                                     flight=np.array(["f1"] * n), uav=uav, uavs=["q1", "q2"])
    offsets = np.array([1.5, -2.0])  # [degree]
    index = data.uav_index[data.win]
    tilt, cos_lean, sin_lean, cos_psi, sin_psi = quadrotor_field._attitude_terms(data, (offsets, index), 0.0)
    tilt_ref, lean_rel = tilt_from_attitude(np.radians(roll), np.radians(pitch - offsets[index]))
    lean = np.radians(data.yaw) + lean_rel
    # rounding: a few ulp of the unit-size terms, the tilt within 1e-15 rad of about 0.3 rad
    np.testing.assert_allclose(tilt, tilt_ref, rtol=0, atol=1e-14)
    np.testing.assert_allclose(cos_lean, np.cos(lean), rtol=0, atol=1e-12)
    np.testing.assert_allclose(sin_lean, np.sin(lean), rtol=0, atol=1e-12)
    assert tilt[1] == tilt[2] == 0.0
