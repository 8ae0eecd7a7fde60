"""Known-answer tests of the turbulence generator (dronewind.simulate.atmosphere).

Tolerances: variances and covariances are compared with their own sampling error,
computed from the discrete spectra the generator uses (a complex-Gaussian Fourier
coefficient c_k with E|c_k|^2 = S_k df / 2 gives Var(sum 2|c_k|^2) = sum (S_k df)^2 and,
for a covariance, Var <= sum (S_x df)(S_y df)); 4 standard errors are allowed, so a
correct generator fails with probability < 1e-4 while a 10 % bias in sigma^2 is caught.
"""

from __future__ import annotations

import importlib

import numpy as np
import pytest
import xarray as xr
from scipy import signal

from dronewind.core import surface_layer
from dronewind.errors import InputError
from dronewind.simulate import atmosphere as atm
from dronewind.simulate import spectral_model
from dronewind.simulate.atmosphere import simulate_wind


def _wind_frame(ds: xr.Dataset, wind_from_deg: float, p: int = 0):
    e_u, e_v = spectral_model.wind_frame_unit_vectors(wind_from_deg)
    ue, vn = ds.u_east_ms[p].values, ds.v_north_ms[p].values
    return ue * e_u[0] + vn * e_u[1], ue * e_v[0] + vn * e_v[1], ds.w_up_ms[p].values, ds.theta_v_k[p].values


def _discrete_power(z, speed, ustar, L, T, fs, theta=293.15):
    """S_k df per component, exactly as the generator scales them."""
    sig = surface_layer.turbulence_sigmas(ustar, z, L, 1000.0, theta)
    par = spectral_model.spectral_parameters(sig, ustar, z / L)
    f = np.arange(1, int(np.ceil(T * fs / 2))) / T
    spec = spectral_model.component_spectra(f, z, speed, sig, par)
    out = {}
    for c in ("u", "v", "w", "theta"):
        out[c] = spec[f"S_{c}"] / T
    return sig, out


@pytest.mark.parametrize("L", [-40.0, 200.0])
def test_variances_and_fluxes_within_sampling_error(L):
    z, U, T, fs, z0 = 20.0, 6.0, 3600.0, 4.0, 0.1
    ds = simulate_wind(np.array([[0.0, 0.0, z]]), T, fs, U, 250.0, z, L, z0, seed=11)
    u, v, w, th = _wind_frame(ds, 250.0)
    ustar = ds.attrs["friction_velocity_ms"]
    sig, power = _discrete_power(z, U, ustar, L, T, fs)
    for x, c, key in ((u, "u", "sigma_u_ms"), (v, "v", "sigma_v_ms"), (w, "w", "sigma_w_ms"),
                      (th, "theta", "sigma_theta_k")):
        se = np.sqrt(np.sum(power[c] ** 2))
        expected = np.sum(power[c])  # similarity sigma^2 minus the part below 1/T and above fs/2
        assert 0.8 * sig[key] ** 2 < expected <= sig[key] ** 2
        assert abs(np.var(x) - expected) < 4 * se, (c, np.var(x), expected, se)
        assert se < 0.2 * sig[key] ** 2  # the test can see an 80 % bias at least
    uw = np.mean((u - u.mean()) * (w - w.mean()))
    se_uw = np.sqrt(np.sum(power["u"] * power["w"]))
    assert abs(uw + ustar**2) < 4 * se_uw, (uw, -ustar**2, se_uw)
    wt = np.mean((w - w.mean()) * (th - th.mean()))
    se_wt = np.sqrt(np.sum(power["w"] * power["theta"]))
    assert abs(wt - sig["wtheta_kms"]) < 4 * se_wt
    # sign of the buoyancy flux from stability: upward (positive) when L < 0
    assert np.sign(sig["wtheta_kms"]) == -np.sign(L)
    assert np.sign(wt) == -np.sign(L)


def test_inertial_subrange_slope_and_isotropy():
    """S_u ~ f^(-5/3) and S_w/S_u -> 4/3 for reduced frequency n = f z/U in [2.5, 8.8]."""
    z, U, fs = 10.0, 8.0, 16.0
    ds = simulate_wind(np.array([[0.0, 0.0, z]]), 1200.0, fs, U, 180.0, z, 1e5, 0.05, seed=5)
    u, v, w, _ = _wind_frame(ds, 180.0)
    f, su = signal.welch(u, fs, nperseg=1024)
    _, sv = signal.welch(v, fs, nperseg=1024)
    _, sw = signal.welch(w, fs, nperseg=1024)
    band = (f >= 2.0) & (f <= 7.0)
    slope = np.polyfit(np.log(f[band]), np.log(su[band]), 1)[0]
    # model slope in the band is -5/3 (1 - 1/(1 + b n)) ~ -1.66; 37 segments -> +-0.05
    assert abs(slope + 5 / 3) < 0.1, slope
    ratio_w = np.mean(sw[band] / su[band])
    ratio_v = np.mean(sv[band] / su[band])
    # model ratio 1.30-1.33 in the band, sampling error of the band mean ~0.03
    assert abs(ratio_w - 4 / 3) < 0.1, ratio_w
    assert abs(ratio_v - 4 / 3) < 0.1, ratio_v


def test_coherence_decays_with_separation_and_frequency():
    """Lateral coherence of v follows exp(-12 sqrt((f d/U)^2 + (0.12 d/Lc)^2)) (IEC)."""
    z, U, fs = 20.0, 8.0, 4.0
    pts = np.array([[0.0, 0.0, z], [0.0, 5.0, z], [0.0, 20.0, z]])  # wind from west: y is lateral
    ds = simulate_wind(pts, 3600.0, fs, U, 270.0, z, 1e5, 0.05, seed=2)
    v = ds.v_north_ms.values
    f, c5 = signal.coherence(v[0], v[1], fs, nperseg=512)
    _, c20 = signal.coherence(v[0], v[2], fs, nperseg=512)
    band = (f > 0.03) & (f < 0.15)
    model5 = spectral_model.coherence(f[band], np.array(5.0), U, z, "v") ** 2
    # 56 segments: coherence estimates scatter ~0.05 per bin, the band mean much less
    assert abs(np.mean(c5[band]) - np.mean(model5)) < 0.08, (np.mean(c5[band]), np.mean(model5))
    assert np.mean(c20[band]) < np.mean(c5[band]) - 0.2
    hi = (f > 0.4) & (f < 0.8)
    assert np.mean(c5[hi]) < np.mean(c5[band]) - 0.2
    # coherence of u and w decays too
    for var in ("u_east_ms", "w_up_ms"):
        x = ds[var].values
        _, a = signal.coherence(x[0], x[1], fs, nperseg=512)
        _, b = signal.coherence(x[0], x[2], fs, nperseg=512)
        assert np.mean(b[band]) < np.mean(a[band])


@pytest.mark.parametrize("wind_from,ue,vn", [(270.0, 1, 0), (90.0, -1, 0), (0.0, 0, -1), (180.0, 0, 1),
                                             (225.0, 1, 1)])
def test_enu_signs_of_mean_wind(wind_from, ue, vn):
    ds = simulate_wind(np.array([[0.0, 0.0, 30.0]]), 600.0, 2.0, 5.0, wind_from, 30.0, -100.0, 0.1, seed=1)
    mean_e, mean_n = ds.u_east_ms.mean().item(), ds.v_north_ms.mean().item()
    speed = np.hypot(mean_e, mean_n)
    assert speed == pytest.approx(5.0, rel=1e-6)  # mean at z_ref is exactly the input
    assert mean_e == pytest.approx(5.0 * ue / np.hypot(ue, vn), abs=1e-6)
    assert mean_n == pytest.approx(5.0 * vn / np.hypot(ue, vn), abs=1e-6)
    direction_deg = np.degrees(np.arctan2(-mean_e, -mean_n))
    # circular difference: 359.9999999 and 0 are the same direction
    assert abs((direction_deg - wind_from + 180.0) % 360.0 - 180.0) < 1e-6
    assert abs(ds.w_up_ms.mean().item()) < 1e-9


def test_taylor_advection_delay():
    """A point 40 m downwind sees the upwind point's structures 40/U = 5 s later.

    The expected cross-spectrum E[c_2 c_1*] has phase -2 pi f tau; it is estimated from
    300 realisations of u and v and fitted by weighted least squares at f <= 0.06 Hz.
    """
    pts = np.array([[0.0, 0.0, 30.0], [40.0, 0.0, 30.0]])  # wind from west -> point 2 downwind
    acc = 0
    for seed in range(300):
        c = atm.field_coefficients(pts, 200.0, 1.0, 8.0, 270.0, 30.0, 1e5, 0.1, np.random.default_rng(seed)).coeffs
        acc = acc + c[1, 0] * np.conj(c[0, 0]) + c[1, 1] * np.conj(c[0, 1])  # u and v cross-spectra
    f = np.arange(acc.size) / 200.0
    band = (f >= 0.01) & (f <= 0.06)
    omega, phase, weight = 2 * np.pi * f[band], np.angle(acc[band]), np.abs(acc[band])
    tau = -np.sum(weight * phase * omega) / np.sum(weight * omega**2)  # weighted LS through 0
    # 8 batches of 300 realisations gave 4.87-5.12 s
    assert tau == pytest.approx(5.0, abs=0.5)


def test_profiles_and_similarity():
    ustar = surface_layer.friction_velocity(8.0, 60.0, 0.3, np.inf)
    assert surface_layer.mean_speed_profile(60.0, ustar, 0.3, np.inf) == pytest.approx(8.0)
    assert ustar == pytest.approx(0.4 * 8.0 / np.log(60 / 0.3))
    # unstable air mixes more: larger u* for the same speed; stable less
    u_unstable = surface_layer.friction_velocity(8.0, 60.0, 0.3, -50.0)
    assert u_unstable > ustar > surface_layer.friction_velocity(8.0, 60.0, 0.3, 50.0)
    s = surface_layer.turbulence_sigmas(0.5, 30.0, np.inf)
    assert s["sigma_u_ms"] / 0.5 == pytest.approx(2.39) and s["sigma_w_ms"] / 0.5 == pytest.approx(1.25)
    par = spectral_model.spectral_parameters(s, 0.5, 0.0)
    assert par["b_w"] == pytest.approx(5.45, abs=0.1)  # Kaimal et al. (1972): 5.3
    # stable peak at higher reduced frequency (smaller b) than neutral
    st = surface_layer.turbulence_sigmas(0.5, 30.0, 30.0)
    assert spectral_model.spectral_parameters(st, 0.5, 1.0)["b_u"] < par["b_u"]


def test_same_seed_same_field_and_prefix_independence():
    pts = np.array([[0.0, 0.0, 30.0], [20.0, 10.0, 50.0]])
    a = simulate_wind(pts, 300.0, 10.0, 6.0, 300.0, 30.0, 500.0, seed=9)
    b = simulate_wind(pts, 300.0, 10.0, 6.0, 300.0, 30.0, 500.0, seed=9)
    c = simulate_wind(pts, 300.0, 10.0, 6.0, 300.0, 30.0, 500.0, seed=10)
    assert a.identical(b)
    assert not np.allclose(a.w_up_ms.values, c.w_up_ms.values)
    assert a.sizes == {"point": 2, "time": 3000}
    assert a.time_s.values[1] == pytest.approx(0.1)


def _fourier_lowpass(x: np.ndarray, n_keep: int) -> np.ndarray:
    c = np.fft.rfft(x - x.mean())
    c[n_keep:] = 0
    c[0] = 0
    return np.fft.irfft(c, n=x.size)


def test_constraint_reproduced_at_its_point():
    """Constrained generation (pyconturb method): the field equals the record at its point."""
    truth = simulate_wind(np.array([[0.0, 0.0, 10.0]]), 600.0, 20.0, 5.0, 200.0, 10.0, -30.0, seed=3)
    con = xr.Dataset({k: ("time", truth[v][0].values) for k, v in
                      (("u_east_ms", "u_east_ms"), ("v_north_ms", "v_north_ms"), ("w_up_ms", "w_up_ms"),
                       ("t_sonic_k", "theta_v_k"))},
                     coords={"time_s": ("time", truth.time_s.values)}, attrs={"height_m": 10.0})
    pts = np.array([[0.0, 0.0, 10.0], [0.0, 2.0, 10.0]])
    ds = simulate_wind(pts, 600.0, 10.0, 5.0, 200.0, 10.0, -30.0, seed=8, constraint=con)
    assert ds.attrs["constrained"] == 1
    n_keep = 3000  # below the 5 Hz Nyquist of the 10 Hz output
    for var, src in (("u_east_ms", "u_east_ms"), ("w_up_ms", "w_up_ms"), ("theta_v_k", "t_sonic_k")):
        ref = _fourier_lowpass(con[src].values, n_keep)[::2]
        got = ds[var][0].values - ds[var][0].values.mean()
        assert np.max(np.abs(got - ref)) < 1e-4  # 1e-12 Cholesky jitter of co-located points
        # the neighbour 2 m away is coherent with the record but not equal to it
        r = np.corrcoef(ds[var][1].values, ref)[0, 1]
        assert 0.3 < r < 0.999, (var, r)
    free = simulate_wind(pts, 600.0, 10.0, 5.0, 200.0, 10.0, -30.0, seed=8)
    assert abs(np.corrcoef(free.w_up_ms[1].values, _fourier_lowpass(con.w_up_ms.values, n_keep)[::2])[0, 1]) < 0.1


def test_constraint_from_real_csat3_record(real_record):
    """A measured CSAT3 record (fluxpart, 20 Hz) read by dronewind.mast.toa5 constrains the field."""
    folder = real_record("fluxpart_csat3_toa5")
    level1 = importlib.import_module("dronewind.mast.level1")
    l1 = level1.mast_l1(sorted(folder.glob("TOA5_*1245.dat")), azimuth_deg=0.0, height_m=7.11, sensor_id="fluxpart")
    l1.attrs["height_m"] = 7.11
    ds = simulate_wind(np.array([[0.0, 0.0, 7.11], [0.0, 1.0, 7.11]]), 600.0, 10.0, 3.0, 200.0, 7.11, -20.0,
                       seed=1, constraint=l1)
    ref = l1.w_up_ms.values[:12000].copy()
    ok = np.isfinite(ref)
    ref = np.interp(np.arange(ref.size), np.flatnonzero(ok), ref[ok])
    ref = _fourier_lowpass(ref, 3000)[::2]
    got = ds.w_up_ms[0].values - ds.w_up_ms[0].values.mean()
    assert np.corrcoef(got, ref)[0, 1] > 0.999
    assert ds.attrs["n_constraint_missing"] >= 0


@pytest.mark.parametrize("kwargs,where", [
    ({"points_enu_m": np.zeros((2, 2))}, "points_enu_m"),
    ({"points_enu_m": np.array([[0.0, 0.0, 0.01]])}, "points_enu_m"),
    ({"mean_speed_ms": -2.0}, "mean_speed_ms"),
    ({"fs_hz": 0.0}, "fs_hz"),
    ({"obukhov_length_m": 0.0}, "obukhov_length_m"),
    ({"roughness_length_m": -0.1}, "roughness_length_m"),
])
def test_bad_inputs_named(kwargs, where):
    args = dict(points_enu_m=np.array([[0.0, 0.0, 20.0]]), duration_s=60.0, fs_hz=10.0, mean_speed_ms=5.0,
                wind_from_deg=0.0, z_ref_m=20.0, obukhov_length_m=100.0)
    args.update(kwargs)
    with pytest.raises(InputError) as err:
        simulate_wind(**args)
    assert where in err.value.where


def test_coherence_factor_remembered_by_content():
    """Equal points and wind in new arrays find the remembered Cholesky factor, which
    equals a fresh factorisation; other points get their own."""
    from dronewind.simulate.spectral_model import _coherence_factor, _CoherenceKey, coherence

    f = np.linspace(0.001, 10.0, 500)
    pts = np.array([[0.0, 0.0, 30.0], [5.0, 0.0, 30.0], [0.0, 3.0, 60.0]])
    d = np.linalg.norm(pts[:, None] - pts[None], axis=-1)
    z = 0.5 * (pts[:, 2][:, None] + pts[:, 2][None])
    first = _coherence_factor(_CoherenceKey(f, d, 5.0, z, "u"))
    again = _coherence_factor(_CoherenceKey(f.copy(), d.copy(), 5.0, z.copy(), "u"))
    assert again is first and not first.flags.writeable
    fresh = np.linalg.cholesky(coherence(f, d, 5.0, z, "u") + 1e-12 * np.eye(3)[None])
    np.testing.assert_array_equal(first, fresh)
    assert _coherence_factor(_CoherenceKey(f, 2 * d, 5.0, z, "u")) is not first
    assert _coherence_factor(_CoherenceKey(f, d, 5.0, z, "w")) is not first
