"""Platform-motion response of a rigid-mount sonic (dronewind.diagnose.platform) on simulated records."""

from __future__ import annotations

import numpy as np
import pytest

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
