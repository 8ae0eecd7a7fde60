"""The rigid-mount record simulator (dronewind.simulate.rigid) read back by the rigid-mount chain."""

from __future__ import annotations

import numpy as np
import pytest

from dronewind.errors import InputError
from dronewind.payload import rigid
from dronewind.simulate.rigid import RigidSettings, mount_matrix, platform_gains, simulate_rigid_record

MOUNT = {"u": "right", "v": "forward", "w": "up"}
PAIRS = (("u_east_ms", "vel_e_ms", "platform_vel_e_ms"), ("v_north_ms", "vel_n_ms", "platform_vel_n_ms"),
         ("w_up_ms", "vel_u_ms", "platform_vel_u_ms"))


def _chain(rec, settings):
    l1 = rigid.rigid_l1(rec.path, rec.format)
    return rigid.rigid_l2(l1, rigid.rigid_mount({"axes": dict(settings.mount_axes)}), alt_band_m=5.0,
                          max_horizontal_speed_ms=3.0, min_segment_s=120.0, max_lag_s=1.0,
                          site_altitude_m=settings.site_altitude_m, target_height_m=settings.height_m)


def _truth_on(l2, rec):
    """Indices of the L2 samples in the simulated series (the record starts at sample 0)."""
    t = (l2["time"].values - np.datetime64("2024-05-01T12:00:00", "ns")) / np.timedelta64(1, "s")
    return np.rint(t * 10.0).astype(int)


@pytest.mark.parametrize("gains", [(1.0, 1.0), (0.7, 0.4), (1.3, 1.1)])
def test_chain_keeps_one_minus_gain_of_the_platform_velocity(tmp_path, gains):
    """Corrected wind - true wind = (1 - g) V_platform per component; exactly the truth (to noise) when g = 1."""
    settings = RigidSettings(duration_s=600.0, mount_axes=MOUNT, heading_deg=140.0)
    mech = [{"mechanism": "platform_velocity_response", "parameters": {"gain_h": gains[0], "gain_v": gains[1]}}]
    rec = simulate_rigid_record(tmp_path / "r.csv", settings, mechanisms=mech, seed=11)
    assert rec.gains == gains
    l2 = _chain(rec, settings)
    assert l2.attrs["lag_sonic_ins_s"] == pytest.approx(0.0, abs=1e-9)
    assert l2.attrs["usable"] == 1, l2.attrs["unusable_reason"]
    idx = _truth_on(l2, rec)
    for (wind, vel, plat), g in zip(PAIRS, (gains[0], gains[0], gains[1]), strict=True):
        np.testing.assert_allclose(l2[plat].values, rec.truth[vel].values[idx], atol=1e-5)
        residual = l2[wind].values - rec.truth[wind].values[idx]
        slope = np.polyfit(l2[plat].values, residual, 1)[0]
        assert slope == pytest.approx(1.0 - g, abs=0.02), wind
        rest = residual - (1.0 - g) * l2[plat].values
        assert np.std(rest) < 0.06  # sonic noise 0.03 m/s per component, rotated, plus rounding


def test_legs_and_reproducibility(tmp_path):
    settings = RigidSettings(duration_s=300.0, leg_speed_ms=2.0, leg_s=30.0, position_sd_m=(0.3, 0.3, 0.1))
    a = simulate_rigid_record(tmp_path / "a.csv", settings, seed=5)
    b = simulate_rigid_record(tmp_path / "b.csv", settings, seed=5)
    assert a.path.read_bytes() == b.path.read_bytes()
    speed = np.hypot(a.truth["vel_e_ms"], a.truth["vel_n_ms"])
    assert 1.5 < float(np.median(speed)) < 2.5
    assert a.gains == (1.0, 1.0)


def test_errors_name_what_was_expected():
    with pytest.raises(InputError, match="platform_velocity_response"):
        platform_gains([{"mechanism": "w_gain", "parameters": {"gain": 0.9}}])
    with pytest.raises(InputError, match="gain_v"):
        platform_gains([{"mechanism": "platform_velocity_response", "parameters": {"gain_h": 1.0, "gain_v": 2.0}}])
    with pytest.raises(InputError, match="right-handed"):
        mount_matrix({"u": "forward", "v": "forward", "w": "up"})
    with pytest.raises(InputError, match="expected one of"):
        mount_matrix({"u": "sideways", "v": "forward", "w": "up"})
    np.testing.assert_array_equal(mount_matrix(MOUNT) @ [0.0, 0.0, 1.0], [0.0, 0.0, -1.0])


def test_position_hold_drifts_with_the_gusts_and_flies_the_plan(tmp_path):
    """The position hold: in the hover the velocity follows the gusts (coherent with the wind around the loop's
    natural frequency, 0.15 Hz: the loop is driven by the gusts alone), on the plan's legs and climbs it is the
    commanded velocity."""
    import scipy.signal

    s = RigidSettings(duration_s=900.0, fs_hz=5.0, platform_model="position_hold", leg_speed_ms=3.0, leg_s=40.0,
                      leg_heading_deg=90.0, climb_m=15.0, climb_speed_ms=2.0, hover_s=300.0, mean_speed_ms=8.0)
    rec = simulate_rigid_record(tmp_path / "p.csv", s, seed=21)
    tr = rec.truth
    hover = tr["time_s"].values < 290.0
    for wind, vel in (("u_east_ms", "vel_e_ms"), ("v_north_ms", "vel_n_ms"), ("w_up_ms", "vel_u_ms")):
        w, v = tr[wind].values[hover], tr[vel].values[hover]
        f, coh = scipy.signal.coherence(w, v, fs=5.0, nperseg=256)
        band = (f > 0.08) & (f < 0.3)
        assert coh[band].mean() > 0.8  # measured 0.96-0.98 on three seeds
        assert 0.02 < np.std(v) < 1.0
    fast = np.abs(tr["vel_e_ms"].values) > 2.5
    assert 0.3 < fast.mean() < 0.7  # legs east and west at 3 m/s
    assert np.max(tr["vel_u_ms"].values) == pytest.approx(2.0, abs=0.3)
    assert np.min(tr["vel_u_ms"].values) == pytest.approx(-2.0, abs=0.3)
    with pytest.raises(InputError, match="position_hold"):
        simulate_rigid_record(tmp_path / "x.csv", RigidSettings(duration_s=60.0, platform_model="pid"), seed=1)


def test_sonic_yaw_offset_and_clock_lag(tmp_path):
    """The sonic yawed by delta on the airframe and stamped early by L: the chain's earth-frame reading (declared
    mount) is the true air relative to the sonic rotated by delta, at platform time t + L."""
    base = dict(duration_s=200.0, fs_hz=10.0, platform_model="position_hold", leg_speed_ms=3.0, leg_s=30.0,
                sonic_noise_ms=0.0, attitude_sd_deg=0.0, tilt_deg_per_ms=0.0, heading_deg=90.0)
    rec = simulate_rigid_record(tmp_path / "o.csv", RigidSettings(**base, sonic_yaw_offset_deg=10.0,
                                                                 sonic_lag_s=0.5), seed=3)
    import pandas as pd

    table = pd.read_csv(rec.path)
    tr = rec.truth
    t = tr["time_s"].values
    body = table[["u_ms", "v_ms", "w_ms"]].values @ mount_matrix(MOUNT).T  # forward, right, down
    # heading 90 (east), no tilt: forward = east, right = south
    east, north = body[:, 0], -body[:, 1]
    air_e = np.interp(t + 0.5, t, tr["u_east_ms"].values - tr["vel_e_ms"].values)
    air_n = np.interp(t + 0.5, t, tr["v_north_ms"].values - tr["vel_n_ms"].values)
    d = np.radians(10.0)
    # rotated counterclockwise (east towards north) by the clockwise yaw of the sensor
    inner = slice(20, -20)
    np.testing.assert_allclose(east[inner], (np.cos(d) * air_e - np.sin(d) * air_n)[inner], atol=2e-3)
    np.testing.assert_allclose(north[inner], (np.sin(d) * air_e + np.cos(d) * air_n)[inner], atol=2e-3)
