"""The virtual quadrotor fleet: files per the contract, determinism, mechanisms, recovery."""

from __future__ import annotations

import importlib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from dronewind.core import constants
from dronewind.errors import InputError
from dronewind.quadrotor import calibration as cal
from dronewind.quadrotor import hover, validation, wind
from dronewind.quadrotor import windows as qw
from dronewind.quadrotor.columns import QUADROTOR_COLUMNS
from dronewind.quadrotor.io import read_quadrotor
from dronewind.quadrotor.reference import read_tower_reference
from dronewind.simulate.quadrotor import (
    log_profile_wind,
    quadrotor_mechanisms,
    simulate_quadrotor_flight,
    simulate_uav_log,
)

SITE_ALT = 73.0


def _campaign(n_flights=1, uavs=("q01", "q02"), offsets=None, mechanisms=None, minutes=6, speed0=3.0):
    offsets = offsets or {}
    flights, conds = [], {}
    for k in range(n_flights):
        fid = f"f{31 + k}"
        flights.append({"id": fid, "reference": f"tower/{fid}_reference.csv",
                        "uavs": [{"id": u, "file": f"quad/{fid}/{u}.csv"} for u in uavs]})
        start = np.datetime64("2020-07-24T10:00:00") + np.timedelta64(20 * k, "m")
        conds[fid] = {"start": f"{start}Z", "end": f"{start + np.timedelta64(minutes, 'm')}Z",
                      "wind_speed_ms": speed0 + k, "wind_from_deg": 200.0 + 15 * k,
                      "heights_m": {u: h for u, h in zip(uavs, (20, 60, 90, 40), strict=False)}}
    return {"name": "t", "site": {"latitude": 52.1667, "longitude": 14.1236, "altitude_m": SITE_ALT},
            "quadrotor_flights": flights,
            "simulation": {"seed": 5, "quadrotor": {"uavs": {u: {"pitch_offset_deg": o[0], "yaw_offset_deg": o[1]}
                                                              for u, o in offsets.items()}},
                           "quadrotor_flights": conds, "mechanisms": mechanisms or []}}


def test_files_follow_the_contract_and_are_deterministic(tmp_path):
    camp = _campaign()
    paths = simulate_quadrotor_flight(camp, tmp_path, "f31", tmp_path / "a", wind_fn=log_profile_wind)
    again = simulate_quadrotor_flight(camp, tmp_path, "f31", tmp_path / "b", wind_fn=log_profile_wind)
    assert [p.relative_to(tmp_path / "a") for p in paths] == [Path("quad/f31/q01.csv"), Path("quad/f31/q02.csv"),
                                                              Path("tower/f31_reference.csv")]
    for p, r in zip(paths, again, strict=True):
        assert p.read_bytes() == r.read_bytes()
    assert pd.read_csv(paths[0], nrows=1).columns.tolist() == list(QUADROTOR_COLUMNS)
    assert pd.read_csv(paths[-1], nrows=1).columns.tolist() == ["time_utc", "height_m", "wind_speed_ms",
                                                                 "wind_from_deg"]
    ds = read_quadrotor(paths[0])
    assert abs(ds.attrs["sampling_rate_hz"] - 10.0) < 1e-6
    ref = read_tower_reference(paths[-1])
    assert ref.attrs["sampling_interval_s"] == 60.0 and ref.sizes["height"] == 10
    mask, info = hover.hover_segment(ds)
    assert abs(info["alt_m"] - SITE_ALT - 20.0) < 0.5
    # hover accuracy of Wetz et al. (2021) Sect. 4.3 is what the simulator was set to
    assert 0.12 < info["sigma_h_m"] < 0.26 and 0.5 < info["sigma_v_m"] < 1.2


def test_unknown_flight_and_missing_conditions(tmp_path):
    camp = _campaign()
    with pytest.raises(InputError, match="no quadrotor flight"):
        simulate_quadrotor_flight(camp, tmp_path, "f99", tmp_path, wind_fn=log_profile_wind)
    del camp["simulation"]["quadrotor_flights"]["f31"]
    with pytest.raises(InputError, match="missing flight conditions"):
        simulate_quadrotor_flight(camp, tmp_path, "f31", tmp_path, wind_fn=log_profile_wind)


def test_mechanisms_parsed_and_validated():
    sim = {"mechanisms": [{"mechanism": "pitch_offset", "parameters": {"uav": "q02", "deg": 2.0}},
                          {"mechanism": "response_lag", "parameters": {"tau_s": 0.8}, "flights": ["f40"]},
                          {"mechanism": "heading_bias", "parameters": {"deg": 3.0}}]}
    m = quadrotor_mechanisms(sim, "f31")
    assert m["pitch_offset"] == {"q02": 2.0} and m["response_lag_s"] == 0.0
    assert quadrotor_mechanisms(sim, "f40")["response_lag_s"] == 0.8
    with pytest.raises(InputError, match="outside the physical range"):
        quadrotor_mechanisms({"mechanisms": [{"mechanism": "pitch_offset",
                                              "parameters": {"uav": "q01", "deg": 45.0}}]})


def test_response_lag_is_a_first_order_lag():
    """A wind step: the attitude-derived speed reaches 63 % of the step after tau."""
    n, fs, tau = 600, 10.0, 2.0
    speed = np.where(np.arange(n) < 100, 4.0, 8.0)
    we, wn = np.zeros(n), -speed
    sig = simulate_uav_log(we, wn, fs, np.random.default_rng(0), response_lag_s=tau, weathervane=None)
    w = wind.wind_from_attitude(sig["roll_deg"], sig["pitch_deg"], sig["yaw_deg"])
    k63 = np.argmax(w["speed_ms"] >= 4.0 + 0.632 * 4.0)
    assert abs((k63 - 100) / fs - tau) <= 0.1 + 1e-9  # one sample


def test_end_to_end_recovers_hidden_offsets(tmp_path):
    """Simulated files -> readers -> windows -> calibration: offsets come back."""
    offsets = {"q01": (2.0, 10.0), "q02": (-1.5, -2.0), "q03": (0.0, 0.0)}
    camp = _campaign(n_flights=4, uavs=tuple(offsets), offsets=offsets, minutes=8, speed0=6.0)
    blocks, windows = [], []
    for f in camp["quadrotor_flights"]:
        paths = simulate_quadrotor_flight(camp, tmp_path, f["id"], tmp_path, wind_fn=log_profile_wind)
        ref = read_tower_reference(paths[-1])
        for p in paths[:-1]:
            b, w = qw.flight_windows(read_quadrotor(p), ref, SITE_ALT, f["id"], p.stem, window_s=120)
            blocks.append(b)
            windows.append(w)
    blocks, windows = pd.concat(blocks), pd.concat(windows, ignore_index=True)
    po = cal.calibrate_pitch_offsets(blocks, windows, constants.WETZ2021_AERO)
    yo = cal.calibrate_yaw_offsets(blocks, windows)
    true_p = np.array([v[0] for v in offsets.values()])
    true_y = np.array([v[1] for v in offsets.values()])
    # 12 two-minute windows per UAV in 6-9 m/s (at 98 m) with turbulence (TI 12 %, 20 s
    # time scale), a tower 20 m away and the weather vane's 1 degree roll dead band (heading
    # errors up to ~10 degree at 2 degree tilt): the offsets come back within 0.4 degree
    # (pitch) and 3 degree (yaw)
    assert np.max(np.abs(po["pitch_offset_deg"].to_numpy() - true_p)) < 0.4
    assert np.max(np.abs(yo["yaw_offset_deg"].to_numpy() - true_y)) < 3.0


def test_with_atmosphere_simulate_wind(tmp_path):
    """The default wind source (dronewind.simulate.atmosphere.simulate_wind)."""
    importlib.import_module("dronewind.simulate.atmosphere")
    camp = _campaign(uavs=("q01",), minutes=4)
    paths = simulate_quadrotor_flight(camp, tmp_path, "f31", tmp_path)
    ds = read_quadrotor(paths[0])
    ref = read_tower_reference(paths[-1])
    b, w = qw.flight_windows(ds, ref, SITE_ALT, "f31", "q01", window_s=120)
    pred = validation.predict_windows(b, w, pd.DataFrame({"uav": ["q01"], "pitch_offset_deg": [0.0]}),
                             aero=constants.WETZ2021_AERO)
    # no offsets, true drag law: the UAV agrees with the tower within turbulence sampling
    assert np.all(np.abs(pred["error_ms"]) < 1.0)


def test_drag_regime_tilt_inverts_power_law():
    """drag_regime truth (Kistner et al. 2024 Table 2 form): c * (g sin(tilt))^b returns the speed."""
    from dronewind.simulate.airframe import regime_tilt

    regime = [{"min_speed_ms": 0.0, "max_speed_ms": 4.0, "b": 0.784, "c": 6.338},
              {"min_speed_ms": 4.0, "max_speed_ms": 12.0, "b": 0.882, "c": 7.604},
              {"min_speed_ms": 12.0, "max_speed_ms": 18.0, "b": 0.635, "c": 8.600}]
    u = np.array([1.0, 3.9, 4.0, 8.0, 11.9, 12.0, 17.0])
    k = np.array([0, 0, 1, 1, 1, 2, 2])
    acc = constants.GRAVITY_MS2 * np.sin(regime_tilt(u, regime))
    b = np.array([r["b"] for r in regime])[k]
    c = np.array([r["c"] for r in regime])[k]
    assert np.max(np.abs(c * acc ** b - u)) < 1e-9


def test_campaign_windows_records_problems_and_wind_dataset(tmp_path):
    camp = _campaign(uavs=("q01", "q02"), minutes=5, speed0=6.0)
    simulate_quadrotor_flight(camp, tmp_path, "f31", tmp_path, wind_fn=log_profile_wind)
    bad = tmp_path / "quad/f31/q02.csv"
    frame = pd.read_csv(bad)
    frame["vel_n_ms"] = 3.0  # never still: never hovers
    frame.to_csv(bad, index=False)
    blocks, windows, problems = qw.campaign_windows(camp, tmp_path, window_s=120)
    assert set(windows["uav"]) == {"q01"}
    assert problems["uav"].tolist() == ["q02"] and "never hovers" in problems["error"].iloc[0]
    with pytest.raises(InputError, match="never hovers"):
        qw.campaign_windows(camp, tmp_path, window_s=120, strict=True)
    ds = wind.uav_wind_dataset(read_quadrotor(tmp_path / "quad/f31/q01.csv"))
    assert ds["u_east_ms"].attrs["standard_name"] == "eastward_wind"
    assert abs(np.median(np.diff(ds["time"].values).astype("int64")) / 1e9 - 1.0) < 1e-9
    assert ds.attrs["n_excluded"] > 0 and 2.0 < float(ds["wind_speed_ms"].mean()) < 9.0


def test_unknown_settings_named(tmp_path):
    camp = _campaign()
    camp["simulation"]["quadrotor"]["mass"] = 1.0
    with pytest.raises(InputError, match=r"simulation\.quadrotor\.mass"):
        simulate_quadrotor_flight(camp, tmp_path, "f31", tmp_path, wind_fn=log_profile_wind)
    camp = _campaign()
    camp["simulation"]["quadrotor_flights"]["f31"]["heights_m"]["q09"] = 30
    with pytest.raises(InputError, match=r"heights_m\.q09"):
        simulate_quadrotor_flight(camp, tmp_path, "f31", tmp_path, wind_fn=log_profile_wind)
