"""Rigid-mount flights whose platform state comes from the vehicle's own log (``platform_log``).

The vehicle is the real ArduCopter of record ``ardupilot_dataflash`` (Finse 2023: climbs to
about 24 m, holds its position while sinking slowly, lands; 163 s). The sonic record is
synthetic, written on that log's UTC span with 10 s more at each end: a 20-Hz sonic in a
constant wind (3, -4, 0.2) m/s east/north/up plus white noise of 0.3 m/s per component,
read through the log's own attitude and velocity (interpolated to the sonic's times), the sonic's
clock 0.25 s late. The rigid chain must take the attitude and velocity from the log and
recover the wind.

Tolerance of the mean wind: 0.05 m/s per component. The steady segment holds 967 samples
(48 s at 20 Hz, the hover around 22 m above the take-off point), so the noise alone leaves a
standard error of 0.3 / sqrt(967) = 0.010 m/s: 0.05 m/s is five standard errors, while a
chain that missed the log's yaw (30-41 degree) or velocity would be off by metres per second
(the yaw alone turns the 5-m/s wind by 2.6 m/s or more). Measured: within 0.012 m/s.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from dronewind.core.columns import log_platform_variables, rigid_layout
from dronewind.errors import InputError
from dronewind.payload import motion, rigid
from dronewind.payload.platform_log import merge_platform_state, read_platform_state
from tests.conftest import needs_record, record_path

LOG = record_path("ardupilot_dataflash", "finse_2023-03-28_0602.bin")
FS = 20.0
PAD_S = 10.0
LAG_S = 0.25
WIND_ENU = np.array([3.0, -4.0, 0.2])
AXES = {"u": "right", "v": "forward", "w": "up"}
SONIC_VARIABLES = {"u": {"column": "su", "unit": "m/s"}, "v": {"column": "sv", "unit": "m/s"},
                   "w": {"column": "sw", "unit": "m/s"}, "t": {"column": "tc", "unit": "degC"}}
FMT = {"name": "delimited", "time": {"column": "time", "kind": "iso"}, "variables": SONIC_VARIABLES}
L2_SETTINGS = {"alt_band_m": 5.0, "max_horizontal_speed_ms": 3.0, "min_segment_s": 30.0, "max_lag_s": 2.0}
SITE_ALTITUDE_M = 1215.0

pytestmark = needs_record("ardupilot_dataflash")


def sonic_on_log(state, path, *, seed: int = 3, with_position: bool = False):
    """Write the synthetic sonic record on the log's span (see the module doc); its times [ns] and truth."""
    t_log = state["time"].values.astype("datetime64[ns]").astype(np.int64)
    t0, t1 = t_log[0] - int(PAD_S * 1e9), t_log[-1] + int(PAD_S * 1e9)
    n = int((t1 - t0) / 1e9 * FS)
    t = t0 + np.rint(np.arange(n) / FS * 1e9).astype(np.int64)

    def at(x, lag_s=0.0):  # the log's value at the sonic's time minus its lag, held at the log's ends
        ok = np.isfinite(x)
        return np.interp(t - lag_s * 1e9, t_log[ok], x[ok])

    yaw = np.degrees(np.unwrap(np.radians(state["yaw_deg"].values)))
    rot = motion.rotation_matrix_body_to_ned(at(state["roll_deg"].values, LAG_S),
                                             at(state["pitch_deg"].values, LAG_S), at(yaw, LAG_S))
    rng = np.random.default_rng(seed)
    wind_ned = np.array([WIND_ENU[1], WIND_ENU[0], -WIND_ENU[2]]) + 0.3 * rng.standard_normal((n, 3))
    vel_ned = np.stack([at(state[k].values, LAG_S) for k in ("vel_n_ms", "vel_e_ms", "vel_d_ms")], axis=-1)
    body = np.einsum("nji,nj->ni", rot, wind_ned - vel_ned)
    sensor = body @ rigid.mount_matrix_of(AXES)  # M orthonormal: sensor = M^T body
    frame = pd.DataFrame({"time": pd.to_datetime(t).strftime("%Y-%m-%dT%H:%M:%S.%f") + "Z", "su": sensor[:, 0],
                          "sv": sensor[:, 1], "sw": sensor[:, 2], "tc": -5.0 + 0.1 * rng.standard_normal(n)})
    if with_position:  # a GNSS of the sonic's logger, 40 m above the vehicle's
        for col, key, shift in (("lat", "lat_deg", 0.0), ("lon", "lon_deg", 0.0), ("alt", "alt_m", 40.0)):
            frame[col] = at(state[key].values) + shift
    frame.to_csv(path, index=False, float_format="%.9g")
    return path, t


@pytest.fixture(scope="module")
def state():
    return read_platform_state(LOG, "ardupilot_bin")


@pytest.fixture(scope="module")
def chain(state, tmp_path_factory):
    path, t = sonic_on_log(state, tmp_path_factory.mktemp("rigid_log") / "sonic.csv")
    l1 = rigid.rigid_l1(path, FMT, platform_state=state)
    l2 = rigid.rigid_l2(l1, rigid.rigid_mount({"axes": AXES}), site_altitude_m=SITE_ALTITUDE_M,
                        target_height_m=22.0, flight_id="finse", **L2_SETTINGS)
    return l1, l2, t


def test_log_read_with_its_checksum_and_format(state):
    assert state.attrs["format"] == "ardupilot_bin"
    assert state.attrs["sha256"] == "8424b26fe3a2326dffeff817a544002877b65776e5429c91f98204e0e6535d46"
    t = state["time"].values
    assert np.all(t[1:] > t[:-1]) and t.size == 1632


def test_rigid_chain_recovers_the_wind_with_the_logs_attitude_and_velocity(chain):
    l1, l2, _ = chain
    got = np.array([float(l2[k].mean()) for k in ("u_east_ms", "v_north_ms", "w_up_ms")])
    np.testing.assert_allclose(got, WIND_ENU, atol=0.05)  # five standard errors (module doc)
    assert l2.attrs["lag_sonic_ins_s"] == pytest.approx(-LAG_S, abs=0.5 / FS)
    assert l2.attrs["usable"] == 1, l2.attrs["unusable_reason"]
    assert l2.attrs["n_samples"] == 967
    # the yaw of the log, 30-41 degree over the flight, is the one the correction used
    assert 29.0 < float(l2["yaw_deg"].min()) and float(l2["yaw_deg"].max()) < 42.0


def test_samples_outside_the_log_are_counted_not_used(chain):
    l1, l2, t = chain
    outside = l1["platform_outside_log"].values.astype(bool)
    # 10 s of 20-Hz sonic before the log's first and after its last sample (403 of 3661 samples)
    assert l1.attrs["n_platform_outside_log"] == int(outside.sum()) == 403
    assert np.isnan(l1["roll_deg"].values[outside]).all() and np.isfinite(l1["roll_deg"].values[~outside]).all()
    assert l2.attrs["n_platform_outside_log"] == 403
    assert "403 samples outside the log's coverage" in l2.attrs["processing_log"]
    assert l1.attrs["platform_log_sha256"].startswith("8424b26f") and l1.attrs["platform_log_format"] == "ardupilot_bin"
    assert l1.attrs["platform_log_start"] == "2023-03-28T06:02:40.447Z"


def test_yaw_is_unwrapped_through_north(state):
    # a log turning through north: 350 -> 10 degree in one step is +20 degree, not -340
    fake = state.isel(time=slice(0, 3)).copy()
    fake["yaw_deg"] = ("time", np.array([340.0, 350.0, 10.0]))
    t = fake["time"].values
    mid = t[1] + (t[2] - t[1]) / 2
    merged = merge_platform_state(np.array([mid]), fake, ["yaw_deg"])
    assert merged.values["yaw_deg"][0] == pytest.approx(0.0, abs=1e-6) or merged.values["yaw_deg"][0] == \
        pytest.approx(360.0, abs=1e-6)


def test_a_gap_of_the_log_is_outside_its_coverage(state):
    keep = np.r_[0:500, 540:state.sizes["time"]]  # 4 s of the log missing
    cut = state.isel(time=keep)
    t = state["time"].values
    merged = merge_platform_state(t, cut, ["roll_deg"], max_gap_s=1.0)
    assert merged.n_gaps == 1 and merged.n_outside == 40  # the log's times that were removed
    assert np.isnan(merged.values["roll_deg"][510])


def test_record_columns_win_over_the_log(state, tmp_path):
    path, _ = sonic_on_log(state, tmp_path / "sonic.csv", with_position=True)
    fmt = {**FMT, "variables": {**SONIC_VARIABLES, "lat": {"column": "lat", "unit": "degree"},
                                "lon": {"column": "lon", "unit": "degree"}, "alt": {"column": "alt", "unit": "m"}}}
    l1 = rigid.rigid_l1(path, fmt, platform_state=state)
    assert l1.attrs["platform_log_variables"] == "roll_deg, pitch_deg, yaw_deg, vel_n_ms, vel_e_ms, vel_d_ms"
    inside = l1["platform_outside_log"].values == 0
    # the record's altitude, 40 m above the log's, is the one kept
    assert float(np.nanmin(l1["alt_m"].values[inside])) > SITE_ALTITUDE_M + 40.0
    assert "from the record's columns (they win): lat_deg, lon_deg, alt_m" in l1.attrs["processing_log"]
    assert log_platform_variables(["u", "v", "w", "t", "vel_e", "vel_n", "vel_u", "yaw"]) == (
        "roll_deg", "pitch_deg", "lat_deg", "lon_deg", "alt_m")


def test_platform_sources_checked():
    with pytest.raises(InputError, match=r"missing roll, pitch, yaw, lat, lon, alt.*or a platform_log"):
        rigid_layout(FMT)
    rigid_layout(FMT, platform_log=True)  # every platform variable from the log
    full = {**FMT, "variables": {**SONIC_VARIABLES, **{k: {"column": k, "unit": "degree"} for k in
                                                        ("roll", "pitch", "yaw", "lat", "lon")},
                                 "alt": {"column": "alt", "unit": "m"},
                                 **{k: {"column": k, "unit": "m/s"} for k in ("vel_n", "vel_e", "vel_d")}}}
    with pytest.raises(InputError, match="platform_log would give nothing"):
        rigid_layout(full, platform_log=True)
    half = {**FMT, "variables": {**SONIC_VARIABLES, "vel_n": {"column": "vn", "unit": "m/s"}}}
    with pytest.raises(InputError, match="platform velocity incomplete.*or none of them"):
        rigid_layout(half, platform_log=True)


def test_unreadable_or_missing_log_names_the_file(tmp_path, state):
    bad = tmp_path / "broken.bin"
    bad.write_bytes(b"\xa3\x95\x80" + b"\x00" * 64)
    with pytest.raises(InputError) as err:
        read_platform_state(bad, "ardupilot_bin")
    assert str(bad) in str(err.value)
    with pytest.raises(InputError, match="platform log not found"):
        read_platform_state(tmp_path / "absent.bin", {"name": "ardupilot_bin"})
    with pytest.raises(InputError, match="do not overlap"):
        merge_platform_state(np.array(["2020-01-01T00:00:00"], dtype="datetime64[ns]"), state, ["roll_deg"])
