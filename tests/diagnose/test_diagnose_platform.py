"""Platform-motion response of a rigid-mount sonic (dronewind.diagnose.platform) on simulated records."""

from __future__ import annotations

import numpy as np
import pytest

from dronewind.diagnose import commanded_segments, platform_lag
from dronewind.diagnose import platform_commanded as pc
from dronewind.diagnose.platform import band_power_after, diagnose_platform, pooled_estimate
from dronewind.errors import InputError
from dronewind.payload import rigid
from dronewind.simulate.rigid import RigidSettings, simulate_rigid_record

WIND = ("u_east_ms", "v_north_ms", "w_up_ms")
PLAT = ("platform_vel_e_ms", "platform_vel_n_ms", "platform_vel_u_ms")


def _l2_arrays(tmp_path, gains, seed, fs=5.0, duration_s=700.0):
    """Simulate a rigid flight with these gains, run the rigid-mount chain, return wind and platform velocity."""
    s = RigidSettings(duration_s=duration_s, fs_hz=fs)
    mech = [{"mechanism": "platform_velocity_response", "parameters": {"gain_h": gains[0], "gain_v": gains[1]}}]
    rec = simulate_rigid_record(tmp_path / f"r{seed}.csv", s, mechanisms=mech, seed=seed)
    l2 = rigid.rigid_l2(rigid.rigid_l1(rec.path, rec.format), rigid.rigid_mount({"axes": dict(s.mount_axes)}),
                        alt_band_m=5.0, max_horizontal_speed_ms=3.0, min_segment_s=120.0, max_lag_s=1.0,
                        site_altitude_m=s.site_altitude_m, target_height_m=s.height_m)
    return (np.stack([l2[k].values for k in WIND], axis=-1), np.stack([l2[k].values for k in PLAT], axis=-1),
            float(l2.attrs["sampling_rate_hz"]))


@pytest.mark.parametrize("seed", [201, 202, 203])
def test_random_gains_recovered_and_named(tmp_path, seed):
    rng = np.random.default_rng(seed)
    gains = tuple(float(g) for g in rng.uniform(0.3, 1.4, 2))
    y, x, fs = _l2_arrays(tmp_path, gains, seed)
    d = diagnose_platform(y, x, fs)
    for p, g in zip(("gain_h", "gain_v"), gains, strict=True):
        assert abs(d["estimate"][p] - g) < 4 * d["uncertainty"][p] + 0.02, (p, g, d["estimate"], d["uncertainty"])
        assert 0 < d["uncertainty"][p] < 0.2
    far = max(abs(g - 1) / d["uncertainty"][p] for p, g in zip(("gain_h", "gain_v"), gains, strict=True))
    assert d["significant"] == (d["test"]["p_value"] < 0.01)
    if far > 6:
        assert d["significant"]
    # the extended correction removes the platform's imprint: coherence in the band falls
    for group in ("horizontal", "vertical"):
        before, after = d["gain"][group]["before"], d["gain"][group]["after"]
        assert after["coherence"] <= before["coherence"] + 1e-12
        assert after["coherent_power_m2s2"] <= before["coherent_power_m2s2"] + 1e-12
    # applied in the time domain and diagnosed again, the gains are 1 (nothing left)
    g = np.array([d["estimate"]["gain_h"], d["estimate"]["gain_h"], d["estimate"]["gain_v"]])
    again = diagnose_platform(y - (1.0 - g) * x, x, fs)
    for p in ("gain_h", "gain_v"):
        assert again["estimate"][p] == pytest.approx(1.0, abs=1e-9)
    assert not again["significant"]


def test_present_model_true_names_nothing(tmp_path):
    """g = 1 (no mechanism): gains near 1, no cause named; band power after equals before at g = 1."""
    y, x, fs = _l2_arrays(tmp_path, (1.0, 1.0), 301)
    d = diagnose_platform(y, x, fs, alpha=0.01)
    assert not d["significant"]
    for p in ("gain_h", "gain_v"):
        assert abs(d["estimate"][p] - 1.0) < 4 * d["uncertainty"][p]
    for group in ("horizontal", "vertical"):
        assert d["gain"][group]["before"]["coherence"] < 0.1
        assert d["present_model"][group]["band_hz"][0] > 0.0


@pytest.mark.slow
def test_null_false_alarm_rate(tmp_path):
    """20 records under the present model: at alpha = 0.05 at most 3 false alarms (P(X > 3) = 0.016 if calibrated)."""
    alarms = 0
    for seed in range(400, 420):
        y, x, fs = _l2_arrays(tmp_path, (1.0, 1.0), seed, duration_s=650.0)
        alarms += diagnose_platform(y, x, fs, alpha=0.05)["significant"]
    assert alarms <= 3


def test_band_power_after_and_pooling():
    rng = np.random.default_rng(0)
    n, fs = 6000, 10.0
    x = np.cumsum(rng.standard_normal((n, 3)), axis=0)
    x = x - np.convolve(x[:, 0], np.ones(51) / 51, "same")[:, None]  # band-limited platform motion
    wind = rng.standard_normal((n, 3)) * 0.3
    y = wind + np.array([0.4, 0.4, -0.2]) * x  # g_h = 0.6, g_v = 1.2
    d = diagnose_platform(y, x, fs, segment_s=60.0)
    assert d["estimate"]["gain_h"] == pytest.approx(0.6, abs=0.05)
    assert d["estimate"]["gain_v"] == pytest.approx(1.2, abs=0.05)
    from dronewind.diagnose.platform import BandSums

    s = BandSums(**d["band_sums"]["horizontal"])
    assert band_power_after(s, 1.0)["power_m2s2"] == pytest.approx(d["gain"]["horizontal"]["before"]["power_m2s2"])
    pooled = pooled_estimate([{**d, "flight": "a"}, {**d, "flight": "b"}])
    assert pooled["estimate"]["gain_h"] == pytest.approx(d["estimate"]["gain_h"])
    assert pooled["uncertainty"]["gain_h"] == pytest.approx(d["uncertainty"]["gain_h"] / np.sqrt(2))
    assert pooled_estimate([{**d, "flight": "a"}, {**d, "flight": "b"}], leave_out="a")["flights"] == ["b"]


def test_errors_name_what_was_expected():
    x = np.ones((100, 3))
    with pytest.raises(InputError, match=r"\(n, 3\)"):
        diagnose_platform(x[:, :2], x[:, :2], 5.0)
    with pytest.raises(InputError, match="at least 4 segments"):
        diagnose_platform(x, x, 5.0, segment_s=60.0)
    bad = x.copy()
    bad[3, 1] = np.nan
    with pytest.raises(InputError, match="non-finite"):
        diagnose_platform(bad, x, 5.0, segment_s=4.0)


def test_band_constancy_flags_a_frequency_dependent_response():
    """A response that changes across the band (here: 1 - g rising with frequency) is model error:
    the present model is rejected, but the constant-gain mechanism is not named."""
    rng = np.random.default_rng(7)
    fs, n = 5.0, 5 * 1200
    t = np.arange(n) / fs
    x = np.zeros((n, 3))
    for k in range(3):  # platform velocity with power over 0.02-0.2 Hz
        for f0 in (0.03, 0.05, 0.08, 0.12, 0.17):
            x[:, k] += np.sin(2 * np.pi * f0 * t + rng.uniform(0, 2 * np.pi)) * rng.uniform(0.5, 1.0)
    # the corrected wind responds with H(f) = 0 at low and 1 at high frequencies: a first-order high-pass
    from scipy.signal import butter, sosfiltfilt

    y = 0.3 * rng.standard_normal((n, 3)) + sosfiltfilt(butter(2, 0.07, "highpass", fs=fs, output="sos"), x, axis=0)
    d = diagnose_platform(y, x, fs, segment_s=100.0, band_factor=100.0)
    assert d["significant"]
    assert not d["adequate"] and not d["named"]
    assert min(c["p_value"] for c in d["band_constancy"].values()) < 0.01


def test_constant_gain_passes_band_constancy(tmp_path):
    y, x, fs = _l2_arrays(tmp_path, (0.5, 0.6), 404)
    d = diagnose_platform(y, x, fs)
    assert d["significant"] and d["adequate"] and d["named"]


# ----------------------------------------------------------------------------- commanded motion



def _survey(tmp_path, gains, seed, **kw):
    """A 30-min position-hold survey flight (legs both ways at 3 m/s, climbs and descents of 15 m), read to L1."""
    s = RigidSettings(duration_s=1800.0, fs_hz=5.0, platform_model="position_hold", leg_speed_ms=3.0, leg_s=40.0,
                      climb_m=15.0, climb_speed_ms=2.0, heading_deg=90.0, leg_heading_deg=90.0, **kw)
    mech = [{"mechanism": "platform_velocity_response", "parameters": {"gain_h": gains[0], "gain_v": gains[1]}}]
    rec = simulate_rigid_record(tmp_path / f"s{seed}.csv", s, mechanisms=mech, seed=seed)
    return s, rec, rigid.rigid_l1(rec.path, rec.format)


def test_commanded_null_names_nothing(tmp_path):
    """G = I on a position-hold survey: gains within 3 sigma of 1, nothing named (alpha 0.01)."""
    s, _, l1 = _survey(tmp_path, (1.0, 1.0), 1001)
    d = pc.diagnose_commanded_l1(l1, rigid.rigid_mount({"axes": dict(s.mount_axes)}).matrix, alpha=0.01)
    assert d["segments_used"]["horizontal"] >= 30 and d["segments_used"]["vertical"] >= 14
    for p in ("gain_h", "gain_v"):
        assert abs(d["estimate"][p] - 1.0) < 3 * d["uncertainty"][p], (p, d["estimate"], d["uncertainty"])
        assert 0 < d["uncertainty"][p] < 0.08  # 30-odd legs at 3 m/s, 16 climbs at 2 m/s (bench: 0.03, 0.04)
    assert not d["named"]


@pytest.mark.parametrize("seed, gains, offset_deg, lag_s", [(1002, (0.6, 1.3), 6.0, 0.6), (1003, (1.25, 0.4), -8.0,
                                                                                             -0.4)])
def test_commanded_recovers_gains_heading_offset_and_lag(tmp_path, seed, gains, offset_deg, lag_s):
    """Gains within 0.1 (the benchmark's criterion), the sonic's heading offset and clock lag within 3 sigma."""
    s, _, l1 = _survey(tmp_path, gains, seed, sonic_yaw_offset_deg=offset_deg, sonic_lag_s=lag_s)
    d = pc.diagnose_commanded_l1(l1, rigid.rigid_mount({"axes": dict(s.mount_axes)}).matrix, alpha=0.01)
    for p, g in zip(("gain_h", "gain_v"), gains, strict=True):
        assert abs(d["estimate"][p] - g) < 0.1, (p, g, d["estimate"])
    assert d["named"]
    assert abs(d["heading_offset_deg"] - offset_deg) < 3 * d["heading_offset_sigma_deg"] + 0.5
    assert d["lag"]["identified"] and abs(d["lag"]["lag_s"] - lag_s) < 3 * d["lag"]["sigma_s"] + 0.1
    # the extended model predicts the segments left out better than the present one
    assert d["held_out"]["combined_gain"] > 0.3
    kinds = {sg["kind"] for sg in d["segments"]}
    assert kinds == {"leg", "turnaround", "climb", "descent"}


def test_hover_drift_biases_the_spectral_estimate_and_is_not_used(tmp_path):
    """A position-holding hover (no commanded motion): the hover estimate is pulled far from the true g = 1, the
    commanded-motion diagnosis identifies nothing instead of naming anything."""
    s = RigidSettings(duration_s=900.0, fs_hz=5.0, platform_model="position_hold", mean_speed_ms=8.0)
    rec = simulate_rigid_record(tmp_path / "h.csv", s, seed=1010)
    tr = rec.truth
    wind, vel = tr[list(WIND)].values, tr[["vel_e_ms", "vel_n_ms", "vel_u_ms"]].values
    # with a correct sensor (G = I) the corrected wind is the true wind
    hover = diagnose_platform(wind, vel, s.fs_hz, segment_s=60.0)
    assert hover["estimate"]["gain_h"] < 0.5  # biased by rho sigma_w / sigma_x (true 1)
    d = pc.diagnose_commanded_l1(rigid.rigid_l1(rec.path, rec.format),
                                 rigid.rigid_mount({"axes": dict(s.mount_axes)}).matrix)
    assert d["segments_used"] == {"horizontal": 0, "vertical": 0}
    assert d["estimate"] == {"gain_h": None, "gain_v": None} and not d["named"]


def test_response_fit_exact_on_noiseless_segments():
    """Segment means built from the model: H = 1 - g e^{i delta} and h_v recovered exactly; LOSO gain 1."""
    rng = np.random.default_rng(3)
    k = 12
    g, delta, gv = 0.8, np.radians(5.0), 1.2
    v = np.zeros((k, 3))
    v[:, 0] = np.where(np.arange(k) % 2 == 0, 3.0, -3.0)
    v[:, 1] = rng.normal(0, 0.2, k)
    v[:, 2] = np.where(np.arange(k) % 3 == 0, 1.5, -1.5)
    wind = np.array([4.0, -2.0])
    z = wind[0] + 1j * wind[1] + (1 - g * np.exp(1j * delta)) * (v[:, 0] + 1j * v[:, 1])
    y = np.stack([z.real, z.imag, 0.1 + (1 - gv) * v[:, 2]], axis=-1)
    m = {"y": y, "v": v, "var": np.full(k, 0.01), "t": np.arange(k) * 60.0, "z": np.zeros(k)}
    h = pc.response_fit("horizontal", m)
    assert h["gain"] == pytest.approx(g, abs=1e-9)
    assert h["heading_offset_deg"] == pytest.approx(5.0, abs=1e-7)
    vv = pc.response_fit("vertical", m)
    assert vv["gain"] == pytest.approx(gv, abs=1e-9)
    held = pc.leave_one_segment_out("horizontal", m, h["covariates"])
    assert held["gain"] == pytest.approx(1.0, abs=1e-9)
    with pytest.raises(InputError, match="at least 3"):
        pc.response_fit("vertical", {key: val[:2] for key, val in m.items()})


def test_segments_and_turnaround_lag_on_a_noiseless_track():
    """Legs back and forth with ramps: legs and turnarounds found; a reading lagged by L gives L (to 1/10 step)."""
    t = np.arange(0.0, 600.0, 0.2)
    v = np.zeros((t.size, 3))
    v[:, 0] = np.convolve(np.where((t // 50) % 2 == 0, 3.0, -3.0), np.ones(20) / 20, mode="same")
    v[:, 1] = 0.01 * np.sin(t)
    segs = commanded_segments.commanded_segments(t, v)
    legs = [sg for sg in segs if sg.kind == "leg"]
    assert len(legs) == 12 and len([sg for sg in segs if sg.kind == "turnaround"]) == 11
    assert {round(sg.course_deg) % 360 for sg in legs} == {90, 270}
    # set points, where logged, are used instead of the track (here the same motion: the same segments)
    from_setpoints = commanded_segments.commanded_segments(t, v + 0.3, setpoint_vel_enu=v)
    assert [(sg.kind, sg.start, sg.stop) for sg in from_setpoints] == [(sg.kind, sg.start, sg.stop) for sg in segs]
    assert {sg.source for sg in from_setpoints} == {"setpoint"}
    for lag in (0.0, 0.6, -0.6):
        reading = -np.stack([np.interp(t + lag, t, v[:, j]) for j in range(3)], axis=-1)
        res = platform_lag.turnaround_lag(t, reading, v, segs)
        assert res["lag_s"] == pytest.approx(lag, abs=0.021)
    with pytest.raises(InputError, match="finite"):
        commanded_segments.commanded_segments(t, np.full_like(v, np.nan))
