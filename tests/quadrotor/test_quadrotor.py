"""Known-answer tests of the quadrotor chain (dronewind.quadrotor: drag, wind, hover, windows, calibration,
validation; Wetz et al. (2021) Sects. 4-5, Kistner et al. (2024) Eq. 1), closed loops against the
simulator's independent forward physics (dronewind.simulate.airframe)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from dronewind.core import constants
from dronewind.core.constants import KISTNER2024_RANGES
from dronewind.errors import InputError
from dronewind.quadrotor import calibration as cal
from dronewind.quadrotor import drag, hover, validation, wind
from dronewind.quadrotor import windows as qw
from dronewind.simulate import airframe
from dronewind.simulate.quadrotor import simulate_uav_log

# ----------------------------------------------------------------------------- physics

def test_rotation_matrix_orthonormal_and_yaw():
    rng = np.random.default_rng(1)
    r = drag.rotation_body_to_ned(*np.radians(rng.uniform(-40, 40, (3, 50))))
    eye = np.einsum("nij,nkj->nik", r, r)
    assert np.allclose(eye, np.eye(3), atol=1e-12)
    r90 = drag.rotation_body_to_ned(0.0, 0.0, np.radians(90.0))
    # body x (nose) points east when yaw = 90 deg
    assert np.allclose(r90 @ [1, 0, 0], [0, 1, 0], atol=1e-12)


def test_speed_tilt_roundtrip_exact():
    v = np.linspace(-16, 16, 321)
    tilt = airframe.rayleigh_tilt_rad(v, 0.03, -0.047)
    assert np.max(np.abs(drag.speed_from_tilt(tilt, 0.03, -0.047) - v)) < 1e-9
    # Wetz et al. (2021), Eq. 18 as read here: about 11 degrees of tilt at 10 m/s
    assert 9.0 < np.degrees(airframe.rayleigh_tilt_rad(10.0, 0.03, -0.047)) < 13.0


def test_attitude_tilt_roundtrip():
    rng = np.random.default_rng(2)
    g = np.radians(rng.uniform(0, 30, 200))
    b = np.radians(rng.uniform(-180, 180, 200))
    phi, th = airframe.attitude_from_tilt(g, b)
    g2, b2 = drag.tilt_from_attitude(phi, th)
    assert np.max(np.abs(g2 - g)) < 1e-12
    assert np.max(np.abs(np.angle(np.exp(1j * (b2 - b))))) < 1e-9


@pytest.mark.parametrize("weathervane", [None, {"tau_s": 3.0, "min_roll_deg": 1.0}])
def test_wind_from_attitude_inverts_forward_model_exactly(weathervane):
    """Forward drag balance (simulator) then inverse (processing): exact to 1e-9 m/s."""
    rng = np.random.default_rng(3)
    n = 3000
    t = np.arange(n) / 10.0
    speed = 6 + 2 * np.sin(t / 17) + rng.normal(0, 0.5, n)
    frm = np.radians(240 + 30 * np.sin(t / 40))
    we, wn = -speed * np.sin(frm), -speed * np.cos(frm)
    vel = (rng.normal(0, 0.1, n), rng.normal(0, 0.1, n))
    sig = simulate_uav_log(we, wn, 10.0, rng, weathervane=weathervane, platform_velocity_ms=vel)
    w = wind.wind_from_attitude(sig["roll_deg"], sig["pitch_deg"], sig["yaw_deg"], vel[1], vel[0],
                             method="tilt")
    assert np.max(np.abs(w["u_east_ms"] - we)) < 1e-9
    assert np.max(np.abs(w["v_north_ms"] - wn)) < 1e-9
    if weathervane is None:  # heading into the relative wind: pitch-only (Eq. 13) is exact too
        rel = wind.wind_from_attitude(sig["roll_deg"], sig["pitch_deg"], sig["yaw_deg"], method="pitch")
        assert np.max(np.abs(rel["relative_speed_ms"] - np.hypot(we - vel[0], wn - vel[1]))) < 1e-9


def test_body_axis_inverse_exact_inside_ranges():
    """Kistner et al. (2024) Eq. 1 with Table 2: forward (tunnel simulator) then inverse, exact."""
    truth = airframe.AirframeDrag(law="body_axis")  # the simulator's Table 2
    law = drag.DragLaw(law="body_axis")  # the chain's Table 2
    rng = np.random.default_rng(4)
    u = np.r_[2.0, 3.0, 6.0, 8.0, 10.0, 13.0, 15.0, 17.0]
    beta = np.radians(rng.uniform(-30, 30, u.size))
    psi = rng.uniform(0, 360, u.size)
    af, ar = -u * np.cos(beta), -u * np.sin(beta)
    phi, th = airframe.attitude_from_relative_air(af, ar, truth)
    w = wind.wind_from_attitude(np.degrees(phi), np.degrees(th), psi, law=law, method="body_axis")
    p = np.radians(psi)
    assert np.allclose(w["v_north_ms"], af * np.cos(p) - ar * np.sin(p), atol=1e-9, rtol=0)
    assert np.allclose(w["u_east_ms"], af * np.sin(p) + ar * np.cos(p), atol=1e-9, rtol=0)


def test_offsets_are_subtracted():
    sig_pitch, sig_yaw = -8.0, 250.0
    w0 = wind.wind_from_attitude(0.0, sig_pitch, sig_yaw)
    w1 = wind.wind_from_attitude(0.0, sig_pitch + 2.0, sig_yaw + 5.0, pitch_offset_deg=2.0, yaw_offset_deg=5.0)
    assert abs(w0["speed_ms"] - w1["speed_ms"]) < 1e-12
    assert abs(w0["wind_from_deg"] - w1["wind_from_deg"]) < 1e-9
    assert abs(w0["wind_from_deg"] - 250.0) < 1e-9  # weather vane: the nose points into the wind


# ----------------------------------------------------------------------------- hover

def _hover_log(n_climb=300, n_hover=3000, sd_h=0.2, sd_v=0.8, moving=False, seed=5):
    rng = np.random.default_rng(seed)
    n = 2 * n_climb + n_hover
    t = np.datetime64("2020-07-24T10:00:00", "ns") + (np.arange(n) * 100_000_000).astype("timedelta64[ns]")
    alt = np.r_[np.linspace(73, 123, n_climb), 123 + rng.normal(0, sd_v, n_hover), np.linspace(123, 73, n_climb)]
    vd = np.r_[np.full(n_climb, -1.7), rng.normal(0, 0.1, n_hover), np.full(n_climb, 1.7)]
    lat = 52.1667 + rng.normal(0, sd_h, n) / 111_000
    lon = 14.1236 + rng.normal(0, sd_h, n) / 68_000
    vn = rng.normal(0, 0.1, n) + (3.0 if moving else 0.0)
    ds = xr.Dataset({k: ("time", v) for k, v in dict(
        roll_deg=np.zeros(n), pitch_deg=np.full(n, -5.0), yaw_deg=np.full(n, 200.0), vel_n_ms=vn,
        vel_e_ms=rng.normal(0, 0.1, n), vel_d_ms=vd, lat_deg=lat, lon_deg=lon, alt_m=alt).items()},
        coords={"time": t})
    ds.attrs["sampling_rate_hz"] = 10.0
    return ds


def test_hover_segment_and_accuracy():
    ds = _hover_log()
    mask, info = hover.hover_segment(ds)
    # the climb ends within 3 m (alt_tol) of the hover altitude: at most ~6 % of it is kept
    assert 2990 <= info["n_hover"] <= 3040
    assert abs(info["alt_m"] - 123) < 0.1
    # Sect. 4.3 accuracy: the set standard deviations come back (sampling error < 5 %)
    assert abs(info["sigma_h_m"] - 0.2) < 0.02
    assert abs(info["sigma_v_m"] - 0.8) < 0.05


def test_uav_that_never_hovers_is_named():
    with pytest.raises(InputError, match="never hovers"):
        hover.hover_segment(_hover_log(moving=True), where="uav q03")


def _reference(start, minutes, heights=(50.0,), speed=6.0):
    t = np.datetime64(start, "ns") + (np.arange(minutes) * 60_000_000_000).astype("timedelta64[ns]")
    ds = xr.Dataset({"wind_speed_ms": (("time", "height"), np.full((minutes, len(heights)), speed)),
                     "wind_from_deg": (("time", "height"), np.full((minutes, len(heights)), 200.0))},
                    coords={"time": t, "height_m": ("height", np.asarray(heights, float))})
    ds.attrs["sampling_interval_s"] = 60.0
    return ds


def test_flight_windows_and_reference_checks():
    ds = _hover_log()
    blocks, windows = qw.flight_windows(ds, _reference("2020-07-24T09:50", 30), 73.0, "f31", "q01", window_s=120)
    assert len(windows) == 2  # 300 s of hover -> two 2-min windows
    assert (windows["n_blocks"] == 120).all() and (windows["ref_speed_ms"] == 6.0).all()
    # a reference covering only the first window: that window is kept, the second listed as skipped
    b, w, skipped = qw.flight_windows_with_gaps(ds, _reference("2020-07-24T10:01", 2), 73.0, "f31", "q01",
                                                window_s=120)
    assert list(w["window"]) == [0] and list(skipped["window"]) == [1]
    assert skipped["reason"].str.contains("reference does not cover").all()
    with pytest.raises(InputError, match="does not cover"):
        qw.flight_windows(ds, _reference("2020-07-24T10:10", 2), 73.0, "f31", "q01", window_s=120)
    with pytest.raises(InputError, match="no reference height"):
        qw.flight_windows(ds, _reference("2020-07-24T09:50", 30, heights=(10.0,)), 73.0, "f31", "q01")


# ----------------------------------------------------------------------------- calibration

def _synthetic_fleet(seed, pitch_offsets, yaw_offsets, aero=(0.03, -0.047), n_windows=12,
                     n_blocks=60, turb_ms=0.3, regime=None):
    """Blocks/windows as flight_windows returns them, from the forward drag balance.

    Each window has a mean speed drawn in 2-10 m/s and 1-s blocks with turbulence
    ``turb_ms``; the reference is the window mean of the true block speeds.
    """
    rng = np.random.default_rng(seed)
    blocks, windows = [], []
    for u, (poff, yoff) in enumerate(zip(pitch_offsets, yaw_offsets, strict=True)):
        uav = f"q{u + 1:02d}"
        for j in range(n_windows):
            key = f"f{j:02d}/{uav}/0"
            mean = rng.uniform(2.0, 10.0)
            frm = rng.uniform(180, 330)
            sp = np.abs(mean + rng.normal(0, turb_ms, n_blocks))
            if regime is None:
                tilt = airframe.rayleigh_tilt_rad(sp, aero[0], aero[1])
            else:
                k = np.searchsorted(regime["edges"], sp)
                tilt = np.arcsin(((sp / regime["c"][k]) ** (1 / regime["b"][k])) / constants.GRAVITY_MS2)
            blocks.append(pd.DataFrame({"window_key": key, "roll_deg": 0.0,
                                        "pitch_deg": -np.degrees(tilt) + poff,
                                        "yaw_deg": (frm + yoff + rng.normal(0, 3.0, n_blocks)) % 360,
                                        "vel_n_ms": 0.0, "vel_e_ms": 0.0}))
            windows.append({"window_key": key, "flight": f"f{j:02d}", "uav": uav, "window": 0,
                            "ref_speed_ms": float(sp.mean()), "ref_from_deg": frm})
    return pd.concat(blocks, ignore_index=True), pd.DataFrame(windows)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_calibration_recovers_hidden_offsets(seed):
    rng = np.random.default_rng(100 + seed)
    n_uav = 5
    # seed 3 is the null case: all offsets zero
    pitch = np.zeros(n_uav) if seed == 3 else rng.uniform(-4.3, 4.3, n_uav)
    yaw = np.zeros(n_uav) if seed == 3 else rng.uniform(-2, 22, n_uav)
    blocks, windows = _synthetic_fleet(seed, pitch, yaw)
    aero, off = cal.calibrate_universal(blocks, windows)
    assert aero["converged"]
    # noise-free window means up to the non-linearity of the speed average: the aero
    # parameters come back within 1 % / 0.002 m2 rad-1, the offsets within 0.05 degree
    assert abs(aero["cd0a0_m2"] - 0.03) < 3e-4
    assert abs(aero["cp_m2_per_rad"] + 0.047) < 2e-3
    assert np.max(np.abs(off["pitch_offset_deg"].to_numpy() - pitch)) < 0.05
    if seed == 3:  # null case: consistent with zero (within 3 standard errors + 0.01 deg)
        assert np.all(np.abs(off["pitch_offset_deg"]) < 3 * off["pitch_offset_deg_se"] + 0.01)
    yo = cal.calibrate_yaw_offsets(blocks, windows)
    # 12 windows x 60 blocks with 3 degree heading noise: standard error ~0.1 degree
    assert np.max(np.abs(yo["yaw_offset_deg"].to_numpy() - yaw)) < 0.5
    ind = cal.calibrate_individual(blocks, windows)
    assert ind["converged"].all()
    assert np.max(np.abs(ind["pitch_offset_deg"].to_numpy() - pitch)) < 0.2
    po = cal.calibrate_pitch_offsets(blocks, windows, aero, flights=["f00", "f01"])
    assert np.max(np.abs(po["pitch_offset_deg"].to_numpy() - pitch)) < 0.1


def test_calibration_with_noise_null_case_and_table():
    """Reference noise (0.2 m/s per window): offsets consistent with zero, contract table."""
    rng = np.random.default_rng(7)
    blocks, windows = _synthetic_fleet(7, np.zeros(4), np.zeros(4), n_windows=20)
    windows["ref_speed_ms"] += rng.normal(0, 0.2, len(windows))
    aero, off = cal.calibrate_universal(blocks, windows)
    z = off["pitch_offset_deg"] / off["pitch_offset_deg_se"]
    assert np.all(np.abs(z) < 3.5), z
    pred = validation.predict_windows(blocks, windows, off, aero=aero)
    acc = validation.accuracy_table(pred)
    assert 0.1 < acc.loc["mean", "rmse_ms"] < 0.3  # the injected 0.2 m/s noise
    table = validation.calibration_table(off, cal.calibrate_yaw_offsets(blocks, windows), acc, aero)
    assert list(table.columns[:5]) == ["uav", "pitch_offset_deg", "yaw_offset_deg", "rmse_ms", "bias_ms"]
    assert len(table) == 4


@pytest.mark.parametrize("seed", [11, 12, 13])
def test_speed_range_calibration_recovers_random_drag_regime(seed):
    rng = np.random.default_rng(seed)
    b = np.array(KISTNER2024_RANGES["b_x"]) * rng.uniform(0.9, 1.1, 3)
    c = np.array(KISTNER2024_RANGES["c_x"]) * rng.uniform(0.9, 1.1, 3)
    edges = np.array(KISTNER2024_RANGES["edges_ms"])
    # calibration steps as in the tunnel: 2..18 m/s, 3 repetitions, 100 samples per step
    # (none on an edge, where the hidden law is discontinuous)
    ref = np.repeat(np.setdiff1d(np.arange(2.0, 18.1, 1.0), edges), 3)
    k = np.searchsorted(edges, ref)
    group = np.repeat(np.arange(ref.size), 100)
    speed = ref[group] + rng.normal(0, 0.2, group.size)
    kk = k[group]
    acc = (speed / c[kk]) ** (1 / b[kk])
    table = cal.calibrate_speed_ranges(acc, ref, edges, group=group, edge_tol_ms=0.0)
    assert table["converged"].all()
    for j, row in table.iterrows():
        lo = max(row["lower_ms"], 2.0)
        hi = min(row["upper_ms"], 18.0)
        a = np.linspace(((lo + 0.5) / c[j]) ** (1 / b[j]), ((hi - 0.5) / c[j]) ** (1 / b[j]), 20)
        # the fitted law reproduces the hidden one to 0.1 m/s inside its range (0.2 m/s
        # noise averaged over 100 samples, non-linear mean: ~0.02 m/s)
        assert np.max(np.abs(row["c"] * a ** row["b"] - c[j] * a ** b[j])) < 0.1


def test_too_few_windows_flagged_not_fitted():
    blocks, windows = _synthetic_fleet(8, [1.0], [0.0], n_windows=2)
    ind = cal.calibrate_individual(blocks, windows)
    assert not ind["converged"].iloc[0] and ind["status"].iloc[0] == "too few windows"
    with pytest.raises(InputError):
        cal.calibrate_universal(blocks.iloc[:0], windows.iloc[:0])


def test_accuracy_table_known_answer():
    pred = pd.DataFrame({"uav": ["a", "a", "b", "b"], "error_ms": [0.1, -0.3, 0.2, 0.2],
                         "dir_error_deg": [3.0, -4.0, 0.0, 0.0]})
    t = validation.accuracy_table(pred)
    assert t.loc["a", "bias_ms"] == pytest.approx(-0.1)
    assert t.loc["a", "rmse_ms"] == pytest.approx(np.sqrt(0.05))
    assert t.loc["b", "rmse_ms"] == pytest.approx(0.2)
    assert t.loc["mean", "rmse_ms"] == pytest.approx((np.sqrt(0.05) + 0.2) / 2)
    assert t.loc["a", "rmse_dir_deg"] == pytest.approx(np.sqrt(12.5))


def test_wetz2021_scenarios():
    ids = ["f01", "f18", "f31", "f37", "f38", "f56", "f73"]
    scen, val = validation.wetz2021_scenarios(ids)
    assert scen["b_first_week"] == ["f01", "f18", "f31", "f37"]
    assert scen["c_flight31"] == ["f31"] and scen["d_flights31_56"] == ["f31", "f56"]
    assert val == ["f38", "f56", "f73"]
    with pytest.raises(InputError):
        validation.flight_number("tower")


def test_fleet_speed_ranges_recover_regime():
    """Field windows from a hidden drag regime (Table 2 form): the fitted laws return it."""
    regime = {"edges": np.array([4.0, 12.0]), "b": np.array([0.75, 0.9, 0.65]), "c": np.array([6.0, 7.8, 8.9])}
    blocks, windows = _synthetic_fleet(21, [1.5, -2.0], [0.0, 0.0], n_windows=40, turb_ms=0.2, regime=regime)
    # windows span 2-10 m/s, so only the first two ranges are constrained; the hidden law
    # jumps at 4 m/s, so windows within 0.8 m/s (4 sigma of the 1-s turbulence) of an
    # edge are left out (edge_tol_ms < 0)
    offs = pd.DataFrame({"uav": ["q01", "q02"], "pitch_offset_deg": [1.5, -2.0]})
    t = cal.calibrate_fleet_speed_ranges(blocks, windows, offs, edge_tol_ms=-0.8)
    for j, (lo, hi) in enumerate([(2.5, 3.5), (5.0, 9.5)]):
        u = np.linspace(lo, hi, 10)
        a = (u / regime["c"][j]) ** (1 / regime["b"][j])
        assert np.max(np.abs(t.loc[j, "c"] * a ** t.loc[j, "b"] - u)) < 0.1
    assert not t.loc[2, "converged"]  # no window above 12 m/s: flagged, not fitted


def test_wetz2021_tables_generic_flight_ids():
    """Flight ids without numbers: one scenario, validation on the calibration flights."""
    blocks, windows = _synthetic_fleet(31, [1.0, -1.0], [5.0, -3.0], n_windows=6)
    windows["flight"] = ["run_" + "abcdef"[i % 6] for i in range(len(windows))]
    res = validation.wetz2021_tables(blocks, windows)
    assert not res["independent_validation"] and list(res["scenarios"]) == ["a_all"]
    t = res["calibration_table"]
    assert list(t.columns[:5]) == ["uav", "pitch_offset_deg", "yaw_offset_deg", "rmse_ms", "bias_ms"]
    assert np.allclose(t["pitch_offset_deg"], [1.0, -1.0], atol=0.05)
    assert np.allclose(t["yaw_offset_deg"], [5.0, -3.0], atol=1.0)


def test_lean_from_trig_equals_tilt_from_attitude_turned_by_the_heading():
    """The fits' tilt and lean from cosines and sines (angle-sum formulas for a pitch offset) equal
    tilt_from_attitude's at the offset pitch, turned by the heading, to rounding; upright included."""
    from dronewind.quadrotor.drag import lean_from_trig, tilt_from_attitude

    rng = np.random.default_rng(5)
    roll, pitch, yaw = (np.radians(rng.uniform(-lim, lim, 500)) for lim in (15.0, 15.0, 180.0))
    offset = np.radians(rng.choice([-2.5, 0.0, 1.75], 500))
    roll[:2], pitch[:2], offset[:2] = 0.0, [0.0, 0.03], [0.0, 0.03]  # upright, before and after the offset
    tilt, cos_lean, sin_lean = lean_from_trig(np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw),
                                              np.sin(yaw), pitch_offset=(np.cos(offset), np.sin(offset)))
    tilt_ref, lean_rel = tilt_from_attitude(roll, pitch - offset)
    # rounding of unit-size terms: a few ulp; the tilt within 1e-15 rad of tilts up to 0.37 rad
    np.testing.assert_allclose(tilt, tilt_ref, rtol=0, atol=1e-14)
    np.testing.assert_allclose(cos_lean, np.cos(yaw + lean_rel), rtol=0, atol=1e-12)
    np.testing.assert_allclose(sin_lean, np.sin(yaw + lean_rel), rtol=0, atol=1e-12)
    assert tilt[0] == 0.0 and abs(tilt[1]) < 1e-15
