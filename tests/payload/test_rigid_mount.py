"""Rigid-mount multicopter records: a simulated record with a known wind and lag, rejections with their numbers."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from dronewind.errors import InputError
from dronewind.payload import motion, rigid

FS = 10.0
WIND_ENU = np.array([3.0, -4.0, 0.2])  # east, north, up [m s-1]
AXES = {"u": "right", "v": "forward", "w": "up"}
FMT = {"name": "delimited", "time": {"column": "time", "kind": "iso"},
       "variables": {"u": {"column": "su", "unit": "m/s"}, "v": {"column": "sv", "unit": "m/s"},
                     "w": {"column": "sw", "unit": "m/s"}, "t": {"column": "tc", "unit": "degC"},
                     "vel_e": {"column": "ve", "unit": "m/s"}, "vel_n": {"column": "vn", "unit": "m/s"},
                     "vel_u": {"column": "vu", "unit": "m/s"}, "roll": {"column": "roll", "unit": "degree"},
                     "pitch": {"column": "pitch", "unit": "degree"}, "yaw": {"column": "yaw", "unit": "degree"},
                     "lat": {"column": "lat", "unit": "degree"}, "lon": {"column": "lon", "unit": "degree"},
                     "alt": {"column": "alt", "unit": "m"}}}


def _record(path, *, n=6000, lag_s=0.3, speed_ms=1.5, alt_jump_at=None, seed=1):
    """A rigid-mount record: the sonic reads (wind - platform velocity) rotated into the sensor frame.

    The platform flies slow legs with a swinging yaw and attitude; the sonic's clock is late by
    ``lag_s`` (its sample stamped t measured the air at t - lag_s), so the time to add to the
    sonic's clock (docs/data-contract.md ``lag_sonic_ins_s``) is -lag_s.
    """
    rng = np.random.default_rng(seed)
    t = np.arange(n) / FS
    yaw = 40.0 + 60.0 * np.sin(2 * np.pi * t / 90.0)
    roll = 3.0 * np.sin(2 * np.pi * t / 7.0)
    pitch = -4.0 + 2.0 * np.sin(2 * np.pi * t / 11.0)
    ve = speed_ms * np.sin(2 * np.pi * t / 60.0) + 0.3 * np.sin(2 * np.pi * t / 4.3)
    vn = speed_ms * np.cos(2 * np.pi * t / 45.0)
    vu = 0.2 * np.sin(2 * np.pi * t / 5.0)
    alt = 1200.0 + np.cumsum(vu) / FS
    if alt_jump_at is not None:
        alt[alt_jump_at:] += 20.0
    t_true = t - lag_s

    def at(x):
        return np.interp(t_true, t, x)

    rot = motion.rotation_matrix_body_to_ned(at(roll), at(pitch), at(yaw))
    wind_ned = np.array([WIND_ENU[1], WIND_ENU[0], -WIND_ENU[2]]) + 0.3 * rng.standard_normal((n, 3))
    rel_ned = wind_ned - np.stack([at(vn), at(ve), -at(vu)], axis=-1)
    body = np.einsum("nji,nj->ni", rot, rel_ned)
    m = rigid.mount_matrix_of(AXES)
    sensor = body @ m  # M is orthonormal: sensor = M^T body
    time = pd.Timestamp("2024-05-01T12:00:00Z") + pd.to_timedelta(t, unit="s")
    frame = pd.DataFrame({"time": time.strftime("%Y-%m-%dT%H:%M:%S.%f") + "Z", "su": sensor[:, 0],
                          "sv": sensor[:, 1], "sw": sensor[:, 2], "tc": 15.0 + 0.1 * rng.standard_normal(n),
                          "ve": ve, "vn": vn, "vu": vu, "roll": roll, "pitch": pitch,
                          "yaw": (yaw + 180.0) % 360.0 - 180.0, "lat": 45.0 + np.cumsum(vn) / FS / 111_195.0,
                          "lon": 7.0 + np.cumsum(ve) / FS / (111_195.0 * np.cos(np.deg2rad(45.0))), "alt": alt})
    frame.to_csv(path, index=False, float_format="%.9g")
    return path


def _l2(path, **kw):
    l1 = rigid.rigid_l1(path, FMT)
    settings = {"alt_band_m": 5.0, "max_horizontal_speed_ms": 3.0, "min_segment_s": 120.0, "max_lag_s": 2.0}
    settings.update(kw)
    return l1, rigid.rigid_l2(l1, rigid.rigid_mount({"axes": AXES}), site_altitude_m=1180.0, flight_id="sim",
                              **settings)


def test_simulated_record_recovers_wind_and_lag(tmp_path):
    _, ds = _l2(_record(tmp_path / "rec.csv"))
    assert ds.attrs["lag_sonic_ins_s"] == pytest.approx(-0.3, abs=0.5 / FS)
    assert ds.attrs["lag_search_step_s"] == pytest.approx(1.0 / FS)
    got = [float(ds[k].mean()) for k in ("u_east_ms", "v_north_ms", "w_up_ms")]
    np.testing.assert_allclose(got, WIND_ENU, atol=0.05)
    # the corrected wind no longer follows the platform; the sonic reading does
    ve = ds["platform_vel_e_ms"].values
    assert abs(np.corrcoef(ds["u_east_ms"].values, ve)[0, 1]) < 0.1
    assert np.corrcoef(ds["u_east_ms"].values - ve, ve)[0, 1] < -0.8
    assert ds.attrs["usable"] == 1, ds.attrs["unusable_reason"]
    assert ds.attrs["platform"] == "rigid_mount"


def test_wrong_axes_leave_more_tke(tmp_path):
    path = _record(tmp_path / "rec.csv")
    l1 = rigid.rigid_l1(path, FMT)
    kw = {"alt_band_m": 5.0, "max_horizontal_speed_ms": 3.0, "min_segment_s": 120.0, "max_lag_s": 2.0}
    right = rigid.rigid_l2(l1, rigid.rigid_mount({"axes": AXES}), **kw)
    wrong = rigid.rigid_l2(l1, rigid.rigid_mount({"axes": {"u": "forward", "v": "left", "w": "up"}}), **kw)
    assert float(wrong["tke_m2s2"].min()) > 2 * float(right["tke_m2s2"].min())


def test_too_fast_everywhere_names_the_speed_criterion(tmp_path):
    path = _record(tmp_path / "rec.csv", speed_ms=6.0)
    pattern = r"horizontal speed <= 3 m/s \(max_horizontal_speed_ms; record max 8\.70 m/s, \d+ samples faster"
    with pytest.raises(InputError, match=pattern):
        _l2(path)


def test_short_segment_names_min_segment_and_altitude_band(tmp_path):
    path = _record(tmp_path / "rec.csv", n=3000, alt_jump_at=1000)
    with pytest.raises(InputError) as err:
        _l2(path, min_segment_s=250.0)
    msg = str(err.value)
    assert "min_segment_s = 250 s" in msg and "alt_band_m" in msg and "samples outside" in msg


def test_lag_search_needs_samples_stated_in_samples_and_seconds(tmp_path):
    path = _record(tmp_path / "rec.csv", n=900)
    with pytest.raises(InputError, match=r"holds 900 samples \(90\.0 s at 10 Hz\).*needs at least 976 samples "
                                         r"\(97\.6 s\)"):
        _l2(path, min_segment_s=30.0, max_lag_s=12.0)


def test_lag_search_samples_scale_with_rate():
    assert rigid.lag_search_min_samples(2.0, 5.0) == (10, 96)
    assert rigid.lag_search_min_samples(2.0, 32.0) == (64, 528)


def test_mount_rejects_left_handed_axes():
    with pytest.raises(InputError, match="left-handed"):
        rigid.mount_matrix_of({"u": "forward", "v": "left", "w": "down"})
    with pytest.raises(InputError, match="not orthonormal"):
        rigid.mount_matrix_of({"u": "forward", "v": "forward", "w": "down"})
