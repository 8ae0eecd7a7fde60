"""Tests for dronewind.compare.l4 (L4 orchestrator): layout, known values and bad input."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from dronewind.compare import l4
from dronewind.errors import InputError

FS_HZ = 8.0


def synthesise(psd, n: int, rng: np.random.Generator) -> np.ndarray:
    f = np.fft.rfftfreq(n, 1.0 / FS_HZ)
    s = np.zeros_like(f)
    s[1:] = psd(f[1:])
    x = np.sqrt(s * FS_HZ * n / 4.0) * (rng.normal(size=f.size) + 1j * rng.normal(size=f.size))
    x[0] = x[-1] = 0.0
    return np.fft.irfft(x, n=n)


def von_karman(length_m: float, speed_ms: float):
    """Longitudinal von Karman spectrum and the isotropic transverse one (analytic)."""

    def s_u(f):
        x2 = (2 * np.pi * f * length_m / speed_ms) ** 2
        return (1 + x2) ** (-5 / 6)

    def s_w(f):
        x2 = (2 * np.pi * f * length_m / speed_ms) ** 2
        return 0.5 * (1 + 8 / 3 * x2) / (1 + x2) ** (11 / 6)

    return s_u, s_w


def make_l3(speed_ms: float = 6.0, minutes: float = 28.0, seed: int = 0, drone_w_gain: float = 1.3) -> xr.Dataset:
    """Synthetic L3 flight: isotropic-spectra turbulence, u'w' < 0, w'T' > 0 (unstable)."""
    n = int(minutes * 60 * FS_HZ)
    rng = np.random.default_rng(seed)
    z = 30.0
    s_u, s_w = von_karman(2 * z, speed_ms)
    data = {k: np.empty((2, n)) for k in ("u_ms", "v_ms", "w_ms", "theta_v_k")}
    for i, gain in enumerate((drone_w_gain, 1.0)):
        u = synthesise(s_u, n, rng)
        v = synthesise(s_w, n, rng)
        w = synthesise(s_w, n, rng)
        w_corr = w - 0.3 * u  # downward momentum flux
        t = 0.3 * synthesise(s_u, n, rng) + 0.4 * w  # upward buoyancy flux
        data["u_ms"][i] = speed_ms + 0.8 * u + 0.002 * np.arange(n) / FS_HZ / 60  # slow trend
        data["v_ms"][i] = 0.8 * v
        data["w_ms"][i] = 0.8 * gain * w_corr
        data["theta_v_k"][i] = 290.0 + t
    time = pd.date_range("2023-08-21T14:05:32", periods=n, freq="125ms").values
    ds = xr.Dataset(
        {k: (("sensor", "time"), v, {"units": "m s-1"}) for k, v in data.items()},
        coords={"sensor": ["drone", "mast"], "time": time},
    )
    ds["theta_v_k"].attrs["units"] = "K"
    ds["height_m"] = ("sensor", [28.0, 30.0])
    ds["wind_from_deg"] = ("sensor", [97.0, 95.0])
    ds.attrs.update(sampling_rate_hz=FS_HZ, lag_drone_mast_s=1.25, rotation_method="double")
    return ds


@pytest.fixture(scope="module")
def l3() -> xr.Dataset:
    return make_l3()


def test_layout_units_and_names(l3: xr.Dataset, tmp_path) -> None:
    ds = l4.flight_l4(l3, "mast")
    assert ds.attrs["sensor"] == "mast" and ds.attrs["lag_drone_mast_s"] == 1.25
    for name, var in ds.variables.items():
        assert "long_name" in var.attrs or "standard_name" in var.attrs, name
        assert ("units" in var.attrs) != name.startswith("status_"), name  # flags carry no units
        if name.startswith("status_"):
            assert var.dtype == np.int8 and var.attrs["standard_name"] == "status_flag"
            assert len(var.attrs["flag_values"]) == len(var.attrs["flag_meanings"].split())
    assert ds["L_m"].attrs["standard_name"] == "atmosphere_obukhov_length"
    assert ds["tke_m2s2"].attrs["standard_name"] == "specific_turbulent_kinetic_energy_of_air"
    for name in ("U_ms", "sigma_w_ms", "uw_m2s2", "wT_Kms", "L_m", "zeta", "Sw_Su", "Sv_Su",
                 "fit_a_u", "fit_b_w", "T_u_s", "L_w_m", "a_uw", "eps_sigma_w2"):
        assert ds[name].ndim == 0, name
    assert ds["S_u"].dims == ("frequency",) and np.all(np.diff(ds["frequency"].values) > 0)
    assert ds.sizes["frequency"] + ds.attrs["n_empty_frequency_bins"] == 100
    path = tmp_path / "l4.nc"
    ds.to_netcdf(path)
    back = xr.load_dataset(path)
    assert float(back["L_m"]) == pytest.approx(float(ds["L_m"]))


def test_known_values_on_synthetic_flight(l3: xr.Dataset) -> None:
    ds = l4.flight_l4(l3, "mast")
    mast = l3.sel(sensor="mast")
    t = np.arange(mast.sizes["time"])
    u_lin = mast["u_ms"].values - np.polyval(np.polyfit(t, mast["u_ms"].values, 1), t)
    assert float(ds["sigma_u_ms"]) == pytest.approx(u_lin.std(), rel=1e-10)
    assert float(ds["U_ms"]) == pytest.approx(6.0, abs=0.05)
    assert float(ds["uw_m2s2"]) < 0 and float(ds["wT_Kms"]) > 0
    assert float(ds["L_m"]) < 0 and float(ds["zeta"]) == pytest.approx(30.0 / float(ds["L_m"]))
    assert int(ds["status_obukhov"]) == 0
    # isotropic spectra in the band; w = w_iso - 0.3 u (independent parts) adds 0.3^2 = 0.09:
    # S_w/S_u = 4/3 + 0.09 = 1.423 expected; S_v/S_u = 4/3. Tolerance 5 % (spectral scatter ~1 %)
    assert int(ds["status_Sw_Su"]) == 0 and int(ds["status_Sv_Su"]) == 0
    assert float(ds["Sv_Su"]) == pytest.approx(4 / 3, rel=0.05)
    assert float(ds["Sw_Su"]) == pytest.approx(4 / 3 + 0.09, rel=0.05)
    for comp in ("u", "v", "w", "uw"):
        assert int(ds[f"status_fit_{comp}"]) == 0, ds[f"status_fit_{comp}"].attrs["reason"]
    assert float(ds["fit_a_uw"]) < 0
    # Taylor: I_u ~ 0.13 < 0.5, U > 1 -> L = U T
    assert float(ds["L_u_m"]) == pytest.approx(float(ds["U_ms"]) * float(ds["T_u_s"]))
    assert int(ds["status_a_sigma_u2"]) == 0 and float(ds["a_sigma_u2"]) < 0.5
    drone = l4.flight_l4(l3, "drone")
    # w gain 1.3 on the drone: S_w/S_u up by ~1.69
    assert float(drone["Sw_Su"]) / float(ds["Sw_Su"]) == pytest.approx(1.69, rel=0.08)
    assert float(drone["sigma_w_ms"]) / float(ds["sigma_w_ms"]) == pytest.approx(1.3, rel=0.08)


def _quiet(func, *args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # bad input must not even warn
        return func(*args, **kw)


def test_low_wind_no_quadrant_ratio() -> None:
    ds = _quiet(l4.flight_l4, make_l3(speed_ms=1.5, minutes=10), "mast")
    assert np.isnan(float(ds["Sw_Su"])) and np.isnan(float(ds["Sv_Su"]))
    assert int(ds["status_Sw_Su"]) == l4.STATUS_FLAG_MEANINGS.index("low_wind_speed")
    assert "not above 2" in ds["status_Sw_Su"].attrs["reason"]
    assert "status_Sw_Su: low_wind_speed" in ds.attrs["processing_log"]
    assert np.isfinite(float(ds["sigma_w_ms"]))  # statistics still computed


def test_taylor_invalid_gives_nan_length_scale() -> None:
    ds = _quiet(l4.flight_l4, make_l3(speed_ms=0.9, minutes=10), "mast")
    assert np.isnan(float(ds["L_u_m"])) and np.isfinite(float(ds["T_u_s"]))
    assert int(ds["status_L_u"]) == l4.STATUS_FLAG_MEANINGS.index("taylor_hypothesis_invalid")


def test_record_too_short_for_spectra() -> None:
    l3 = make_l3(minutes=0.25)  # 120 samples: Welch segments of 60 < 64
    ds = _quiet(l4.flight_l4, l3, "drone")
    assert ds.sizes["frequency"] == 0
    assert int(ds["status_spectra"]) == l4.STATUS_FLAG_MEANINGS.index("record_too_short")
    for name in ("fit_a_u", "fit_b_uw", "Sw_Su"):
        assert np.isnan(float(ds[name])), name
    assert int(ds["status_fit_w"]) == l4.STATUS_FLAG_MEANINGS.index("record_too_short")
    assert "segments of 60 < 64" in ds["status_spectra"].attrs["reason"]
    assert np.isfinite(float(ds["sigma_u_ms"]))
    tiny = _quiet(l4.flight_l4, make_l3(minutes=1 / 60), "drone")  # 8 samples
    assert int(tiny["status_statistics"]) == l4.STATUS_FLAG_MEANINGS.index("record_too_short")
    assert np.isnan(float(tiny["sigma_u_ms"])) and np.isnan(float(tiny["L_m"]))


def test_nan_input_and_constant_input_are_flagged() -> None:
    l3 = make_l3(minutes=5)
    l3["w_ms"][0, 100:105] = np.nan
    ds = _quiet(l4.flight_l4, l3, "drone")
    assert int(ds["status_statistics"]) == l4.STATUS_FLAG_MEANINGS.index("invalid_input")
    assert ds.attrs["n_nonfinite_w"] == 5
    assert np.isnan(float(ds["sigma_u_ms"])) and np.isnan(float(ds["a_uw"]))
    mast = _quiet(l4.flight_l4, l3, "mast")  # the other sensor is unaffected
    assert int(mast["status_statistics"]) == 0
    flat = make_l3(minutes=5)
    for k in ("u_ms", "v_ms", "w_ms"):
        flat[k][:] = 3.0 if k == "u_ms" else 0.0
    ds = _quiet(l4.flight_l4, flat, "mast")
    assert float(ds["sigma_u_ms"]) == pytest.approx(0.0, abs=1e-12)
    assert int(ds["status_fit_u"]) == l4.STATUS_FLAG_MEANINGS.index("fit_not_converged")
    assert np.isnan(float(ds["L_m"])) and int(ds["status_obukhov"]) != 0
    assert np.isnan(float(ds["T_u_s"])) and "zero variance" in ds["status_T_u"].attrs["reason"]


def test_white_noise_fit_does_not_converge() -> None:
    rng = np.random.default_rng(4)
    n = 4000
    ds = _quiet(l4.record_l4, 5 + rng.normal(size=n), rng.normal(size=n), rng.normal(size=n) - 0.0,
                290 + rng.normal(size=n), FS_HZ, 30.0)
    assert int(ds["status_fit_u"]) == l4.STATUS_FLAG_MEANINGS.index("fit_not_converged")
    assert np.isnan(float(ds["fit_a_u"])) and np.all(np.isnan(ds["S_u_model"].values))
    assert ds.attrs["n_status_not_ok"] >= 1


def test_contract_violations_raise() -> None:
    l3 = make_l3(minutes=1)
    with pytest.raises(InputError, match="theta_v_k"):
        l4.flight_l4(l3.drop_vars("theta_v_k"), "mast")
    with pytest.raises(InputError, match="tower"):
        l4.flight_l4(l3, "tower")
    bad = l3.copy()
    bad.attrs = {}
    with pytest.raises(InputError, match="sampling_rate_hz"):
        l4.flight_l4(bad, "mast")


def test_fits_use_the_l3_filter_passband(l3: xr.Dataset) -> None:
    """flight_l4 fits the spectral models only up to the L3 anti-alias passband edge."""
    unfiltered = l4.flight_l4(l3, "mast")
    assert unfiltered.attrs["spectral_fit_f_max_hz"] == pytest.approx(FS_HZ / 2)
    filtered = l4.flight_l4(l3.assign_attrs(fir_passband_edge_hz=3.0), "mast")
    assert filtered.attrs["spectral_fit_f_max_hz"] == 3.0
    assert float(filtered["fit_b_w"]) != float(unfiltered["fit_b_w"])  # fewer bins, another fit


def test_block_mean_detrending_is_recorded_and_differs_on_a_trend(l3: xr.Dataset) -> None:
    """detrending = block_mean removes only the mean: the slow trend of make_l3's u (0.002 m/s per
    minute over 28 min) then adds to sigma_u; linear removes it. Recorded in attrs["detrending"]."""
    lin = l4.flight_l4(l3, "drone")
    blk = l4.flight_l4(l3, "drone", detrending="block_mean")
    assert lin.attrs["detrending"].startswith("linear") and blk.attrs["detrending"].startswith("block mean")
    assert "block mean removed" in blk["sigma_u_ms"].attrs["long_name"]
    u = l3.sel(sensor="drone")["u_ms"].values
    expected = float(np.std(u))  # population standard deviation about the block mean
    assert float(blk["sigma_u_ms"]) == pytest.approx(expected, rel=1e-12)
    assert float(blk["sigma_u_ms"]) > float(lin["sigma_u_ms"])
    with pytest.raises(InputError, match="block_mean"):
        l4.flight_l4(l3, "drone", detrending="quadratic")
