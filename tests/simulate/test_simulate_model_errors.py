"""Physics the diagnosis' forward model does not have: turbulence model, mean-wind trends, mast flow distortion.

Each setting (``simulation.atmosphere``: spectrum, length-scale and sigma factors, speed and
direction trends; ``simulation.mast``: boom blockage, tower wake, streamline tilt) must
change what it says and nothing else. The comparisons run the same seed with and without
the setting: the latent phases, the motion and the noise draws are the same, so a
difference is the setting's own effect, exactly; where a value is compared with the
similarity model instead, the tolerance is stated with the sampling error it covers.
The flight is one 30-min hover of the hidden-effect campaign (experiments.campaign_manifest:
6 m/s from 200 deg at 30 m, z/L = -0.2, mast sonic azimuth 218 deg, payload at 28 m).
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
from scipy import signal

from dronewind.core import surface_layer
from dronewind.diagnose.experiments import Draw, campaign_manifest
from dronewind.errors import InputError
from dronewind.simulate import departures, spectral_model
from dronewind.simulate.defaults import MAST_DEFAULTS, SPECTRA, TURBULENCE_DEFAULTS
from dronewind.simulate.mast import DISTORTION_KEYS, flow_distortion
from dronewind.simulate.payload import payload_records, payload_truth
from dronewind.simulate.settings import validate_simulation

HOVER_S = 1800.0
SPEED_MS, FROM_DEG, Z_REF_M, Z_HOVER_M, ZETA = 6.0, 200.0, 30.0, 28.0, -0.2
AZIMUTH_DEG = 218.0


def _campaign(atmosphere=None, mast=None) -> dict:
    data = campaign_manifest(Draw("none", {}, 11), n_flights=1, hover_min=HOVER_S / 60, speeds_ms=(SPEED_MS,))
    if atmosphere is not None:
        data["simulation"]["atmosphere"] = atmosphere
    if mast is not None:
        data["simulation"]["mast"] = mast
    return data


def _truth(atmosphere=None, mast=None):
    return payload_truth(_campaign(atmosphere, mast), "h01")


@pytest.fixture(scope="module")
def base():
    return _truth()


def _hover(truth) -> np.ndarray:
    return (truth.air.t_s >= 0) & (truth.air.t_s < HOVER_S)


def _drone(truth) -> np.ndarray:
    """(3, n) east, north, up wind at the hover point during the hover window."""
    h = _hover(truth)
    return np.stack([truth.air.wind_e_ms[h], truth.air.wind_n_ms[h], truth.air.wind_up_ms[h]])


def _mast(truth) -> np.ndarray:
    """(3, n) east, north, up wind at the mast sonic during the hover window."""
    t = (truth.mast.times - truth.clock.start) / np.timedelta64(1, "s")
    h = (t >= 0) & (t < HOVER_S)
    return truth.mast.series[0, :3, h].T


OBUKHOV_M = Z_REF_M / ZETA
USTAR_MS = surface_layer.friction_velocity(SPEED_MS, Z_REF_M, 0.1, OBUKHOV_M)


def _similarity_sigmas() -> dict[str, float]:
    return surface_layer.turbulence_sigmas(USTAR_MS, Z_HOVER_M, OBUKHOV_M, 1000.0, 288.15)


def test_defaults_spelled_out_give_bit_identical_records():
    # every turbulence-model and flow-distortion setting, at its documented default
    defaults = {"spectrum": SPECTRA[0], **{k: v[0] for k, v in TURBULENCE_DEFAULTS.items()}}
    mast = {k: MAST_DEFAULTS[k][0] for k in (*DISTORTION_KEYS, "tower_wake_half_width_deg")}
    assert defaults["spectrum"] == "kaimal" and len(defaults) >= 7 and len(mast) >= 4  # the tables are read
    short = campaign_manifest(Draw("none", {}, 3), n_flights=1, hover_min=5.0)
    spelled = copy.deepcopy(short)
    spelled["simulation"].update(atmosphere=defaults, mast=mast)
    got, _ = payload_records(spelled, "h01")
    want, _ = payload_records(short, "h01")
    for a, b in zip(got, want, strict=True):
        assert a.columns.keys() == b.columns.keys()
        for key in a.columns:
            np.testing.assert_array_equal(a.columns[key], b.columns[key], err_msg=f"{a.source}:{key}")


def test_sigma_w_factor_scales_w_at_drone_and_mast_and_nothing_else(base):
    w15 = _truth({"sigma_w_factor": 1.5})
    for where, get in (("drone", _drone), ("mast", _mast)):
        new, old = get(w15), get(base)
        # same latents: the horizontal wind is untouched, w is exactly 1.5 times the baseline's
        np.testing.assert_array_equal(new[:2], old[:2], err_msg=where)
        np.testing.assert_allclose(new[2], 1.5 * old[2], rtol=1e-12, atol=1e-12, err_msg=where)
        # and 1.5 times the similarity sigma_w: over 30 min the sampling error of sigma_w is
        # about 3 % (integral time ~2 s), the band 1/period..fs/2 misses ~1 % of the variance;
        # 10 % is three sampling errors
        assert np.std(new[2]) / (1.5 * _similarity_sigmas()["sigma_w_ms"]) == pytest.approx(1.0, abs=0.10), where


def test_sigma_u_and_v_factors_scale_their_components_only(base):
    t = _truth({"sigma_u_factor": 0.7, "sigma_v_factor": 1.3})
    e_u, e_v = spectral_model.wind_frame_unit_vectors(FROM_DEG)
    for get in (_drone, _mast):
        new, old = get(t), get(base)
        np.testing.assert_array_equal(new[2], old[2])
        for unit, factor in ((e_u, 0.7), (e_v, 1.3)):
            fn, fo = unit @ new[:2], unit @ old[:2]
            np.testing.assert_allclose(fn - fn.mean(), factor * (fo - fo.mean()), atol=1e-9)


def test_von_karman_shape_has_the_variance_and_inertial_level_of_kaimal_and_another_peak():
    sig = _similarity_sigmas()
    ustar, zeta = USTAR_MS, Z_HOVER_M / OBUKHOV_M
    f = np.logspace(-6, 3, 200_000)
    params = spectral_model.spectral_parameters(sig, ustar, zeta)
    kaimal = spectral_model.component_spectra(f, Z_HOVER_M, SPEED_MS, sig, params)
    lengths_m = departures.von_karman_length_scales(sig, ustar, zeta, Z_HOVER_M)
    vk = departures.von_karman_spectra(f, SPEED_MS, sig, lengths_m)
    high = (f > 20) & (f < 200)
    peaks = {}
    for c in "uvw":
        # the integral over 1e-6..1e3 Hz misses < 0.5 % of either spectrum
        assert np.trapezoid(vk[f"S_{c}"], f) == pytest.approx(sig[f"sigma_{c}_ms"] ** 2, rel=0.005)
        np.testing.assert_allclose(vk[f"S_{c}"][high] / kaimal[f"S_{c}"][high], 1.0, rtol=0.01)
        peaks[c] = f[np.argmax(f * vk[f"S_{c}"])] / f[np.argmax(f * kaimal[f"S_{c}"])]
    # analytic: u peaks at x = sqrt(1.5/70.8) of f L_u/U; a grid step is 1e-4 in log10 f
    assert peaks["u"] == pytest.approx(1.36, abs=0.02)
    assert peaks["v"] == pytest.approx(1.28, abs=0.02)


def _slope(x: np.ndarray, fs_hz: float, f_lo: float, f_hi: float) -> float:
    f, p = signal.welch(x - x.mean(), fs=fs_hz, nperseg=4096)
    band = (f >= f_lo) & (f <= f_hi)
    return float(np.polyfit(np.log(f[band]), np.log(p[band]), 1)[0])


def _log_centroid_hz(x: np.ndarray, fs_hz: float) -> float:
    """exp of the power-weighted mean log frequency of a periodogram (where the variance sits)."""
    f, p = signal.periodogram(x - x.mean(), fs=fs_hz)
    f, p = f[1:], p[1:]
    return float(np.exp(np.sum(np.log(f) * p) / np.sum(p)))


def test_von_karman_field_keeps_the_inertial_slope_and_length_factor_moves_the_peak(base):
    vk = _truth({"spectrum": "von_karman"})
    fs = 32.0
    for get, rate in ((_drone, fs), (_mast, 10.0)):
        for comp in (0, 2):
            # -5/3 between 0.5 Hz and 0.4 fs; 0.1 covers the scatter of a Welch estimate of
            # ~14 segments over this decade and a half
            assert _slope(get(vk)[comp], rate, 0.5, 0.4 * rate) == pytest.approx(-5 / 3, abs=0.1)
    e_u, _ = spectral_model.wind_frame_unit_vectors(FROM_DEG)
    stretched = _truth({"length_scale_factor": 2.0})
    for get, rate in ((_drone, fs), (_mast, 10.0)):
        ratio = _log_centroid_hz(e_u @ get(stretched)[:2], rate) / _log_centroid_hz(e_u @ get(base)[:2], rate)
        # S -> 2 S(2f): the variance moves down by a factor 2 in frequency; the band edges
        # (1/period, fs/2) cut the shifted spectrum differently, hence 0.4-0.65, not 0.5
        assert 0.4 < ratio < 0.65
        assert np.std(e_u @ get(stretched)[:2]) == pytest.approx(np.std(e_u @ get(base)[:2]), rel=0.15)


@pytest.mark.parametrize(("speed_trend", "direction_trend"), [(2.0, 0.0), (0.0, 30.0), (-2.0, -20.0)])
def test_mean_wind_trend_shows_in_5_min_block_means_at_drone_and_mast(base, speed_trend, direction_trend):
    trend = _truth({"speed_trend_ms_per_h": speed_trend, "direction_trend_deg_per_h": direction_trend})
    for get in (_drone, _mast):
        new, old = get(trend), get(base)
        n = new.shape[1] // 6
        blocks_new = new[:2, : 6 * n].reshape(2, 6, n).mean(axis=2)
        blocks_old = old[:2, : 6 * n].reshape(2, 6, n).mean(axis=2)
        hours = ((np.arange(6) + 0.5) * HOVER_S / 6 - HOVER_S / 2) / 3600
        speed_new, speed_old = np.hypot(*blocks_new), np.hypot(*blocks_old)
        # the speed of each block rises by the trend times the time from the hover centre,
        # within 0.015 m/s: the hover point at 28 m has 0.99 of the 30 m reference speed
        # (0.004 m/s at most), and the trend is added along the mean wind while a block's
        # mean vector deviates from it by up to ~10 deg (1.5 % of 0.42 m/s); a veer turns
        # the block's mean vector and keeps its speed
        np.testing.assert_allclose(speed_new - speed_old, speed_trend * hours, atol=0.015)
        turn = np.degrees(np.arctan2(-blocks_new[0], -blocks_new[1]) - np.arctan2(-blocks_old[0], -blocks_old[1]))
        # the block's direction turns by the veer at the block centre; 0.4 deg covers the
        # speed change added along the mean wind to a block vector a few degrees off it
        # (0.42 m/s x sin 5 deg / 6 m/s = 0.35 deg) and the averaging over the block
        np.testing.assert_allclose((turn + 180) % 360 - 180, direction_trend * hours, atol=0.4)
        np.testing.assert_array_equal(new[2], old[2])


def test_flow_distortion_pattern_on_a_steady_wind():
    froms = np.array([AZIMUTH_DEG, AZIMUTH_DEG + 90, AZIMUTH_DEG + 180, AZIMUTH_DEG + 180 + 15, AZIMUTH_DEG + 230])
    a = np.deg2rad(froms)
    ue, vn, wu = -5 * np.sin(a), -5 * np.cos(a), np.zeros_like(a)
    settings = {"boom_blockage_deficit": 0.06, "tower_wake_deficit": 0.4, "tower_wake_half_width_deg": 30.0}
    e, n, w = flow_distortion(ue, vn, wu, AZIMUTH_DEG, settings)
    want = [0.94, 1.0, 0.6, 1 - 0.4 * np.cos(0.5 * np.pi * 15 / 30) ** 2, 1.0]
    np.testing.assert_allclose(np.hypot(e, n) / 5, want, atol=1e-12)
    np.testing.assert_allclose(np.degrees(np.arctan2(-e, -n)) % 360, froms % 360, atol=1e-9)  # direction kept
    np.testing.assert_array_equal(w, 0.0)  # no w gain: not the catalog's mast_w_attenuation
    e, n, w = flow_distortion(ue, vn, wu + 0.3, AZIMUTH_DEG, {"streamline_tilt_deg": 4.0})
    tau = np.deg2rad(4.0)
    np.testing.assert_allclose(w, 5 * np.sin(tau) + 0.3 * np.cos(tau), atol=1e-12)
    np.testing.assert_allclose(np.hypot(e, n), 5 * np.cos(tau) - 0.3 * np.sin(tau), atol=1e-12)


def test_mast_flow_distortion_shows_in_the_mast_record_only():
    short = campaign_manifest(Draw("none", {}, 3), n_flights=1, hover_min=10.0, speeds_ms=(SPEED_MS,))
    distorted = copy.deepcopy(short)
    distorted["simulation"]["mast"] = {"boom_blockage_deficit": 0.06}
    (son_d, ins_d, mast_d), _ = payload_records(distorted, "h01")
    (son, ins, mast), _ = payload_records(short, "h01")
    for a, b in ((son_d, son), (ins_d, ins)):  # the drone's records are untouched
        for key in a.columns:
            np.testing.assert_array_equal(a.columns[key], b.columns[key])

    def speed(rec):
        return np.nanmean(np.hypot(rec.columns["Ux"], rec.columns["Uy"]))

    # the flight's wind comes from 200 deg, 18 deg off the boom: deficit 0.06 cos 18 deg
    # on every sample's horizontal speed (the instantaneous direction varies by ~10 deg,
    # cos varies by < 0.1 around 0.95, hence 0.004)
    assert speed(mast_d) / speed(mast) == pytest.approx(1 - 0.06 * np.cos(np.deg2rad(18.0)), abs=0.004)
    np.testing.assert_allclose(mast_d.columns["Uz"], mast.columns["Uz"])


@pytest.mark.parametrize(("section", "key", "value", "expected"), [
    ("atmosphere", "spectrum", "mann", "['kaimal', 'von_karman']"),
    ("atmosphere", "sigma_w_factor", 3.0, "[0.5, 2.0]"),
    ("atmosphere", "length_scale_factor", 0.2, "[0.5, 2.0]"),
    ("atmosphere", "speed_trend_ms_per_h", 12.0, "[-10.0, 10.0]"),
    ("atmosphere", "direction_trend_deg_per_h", -200.0, "[-120.0, 120.0]"),
    ("mast", "tower_wake_deficit", 0.9, "[0.0, 0.6]"),
    ("mast", "boom_blockage_deficit", -0.01, "[0.0, 0.15]"),
    ("mast", "streamline_tilt_deg", 12.0, "[-10.0, 10.0]"),
])
def test_invalid_settings_name_the_key_and_the_range(section, key, value, expected):
    data = _campaign(**{section: {key: value}})
    with pytest.raises(InputError) as err:
        validate_simulation(data)
    assert err.value.where == f"simulation.{section}.{key}"
    assert expected in err.value.what


def test_unknown_atmosphere_key_lists_the_turbulence_settings():
    with pytest.raises(InputError) as err:
        validate_simulation(_campaign({"sigma_x_factor": 1.2}))
    assert err.value.where == "simulation.atmosphere.sigma_x_factor"
    assert "sigma_w_factor" in err.value.what and "roughness_length_m" in err.value.what


def test_a_trend_that_reverses_the_wind_is_refused():
    data = _campaign({"speed_trend_ms_per_h": -10.0})
    data["simulation"]["payload_flights"]["h01"]["mean_speed_ms"] = 1.0
    with pytest.raises(InputError) as err:
        payload_truth(data, "h01")
    assert err.value.where == "simulation.atmosphere.speed_trend_ms_per_h"


def test_a_truth_of_another_turbulence_model_is_refused():
    short = campaign_manifest(Draw("none", {}, 3), n_flights=1, hover_min=5.0)
    _, truth = payload_records(short, "h01")
    other = copy.deepcopy(short)
    other["simulation"]["atmosphere"] = {"sigma_w_factor": 1.2}
    with pytest.raises(ValueError, match="turbulence model"):
        payload_records(other, "h01", truth)
