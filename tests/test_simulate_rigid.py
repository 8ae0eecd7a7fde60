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
