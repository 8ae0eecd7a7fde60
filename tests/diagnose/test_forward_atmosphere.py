"""The forward model's measured atmosphere: the reference mast's record constrains the field.

Known answers: a constraint record built here with another spectral shape (a -7/3 inertial
slope instead of -5/3), other isotropy (sigma_v/sigma_u = 1.2, sigma_w/sigma_u = 0.6) and a
trend in the mean wind; the field's other points must carry that shape, isotropy and
trend (``amplitudes="constraint"``), and a forward flight's simulated mast must reproduce the
measured mast record within the mast's instrument noise.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from scipy import signal

from dronewind.errors import InputError
from dronewind.simulate.atmosphere import simulate_wind

FS_HZ = 10.0
DURATION_S = 1800.0
SLOPE = -7.0 / 3.0  # the constraint's inertial slope (the model's is -5/3)
RATIO_V, RATIO_W = 1.2, 0.6  # the constraint's sigma_v/sigma_u, sigma_w/sigma_u (model: 0.80, 0.52)
TREND_MS = 1.5  # rise of the constraint's east wind over the record [m s-1]


@functools.cache
def _constraint(seed: int = 1) -> xr.Dataset:
    """A 10 m record (wind from the west) with spectra (1 + (f/0.02 Hz)^2)^(SLOPE/2), random phases.

    Made once per seed; the tests do not modify it."""
    n = int(FS_HZ * DURATION_S)
    f = np.fft.rfftfreq(n, 1 / FS_HZ)
    rng = np.random.default_rng(seed)
    out = {}
    for comp, sigma in (("u", 1.0), ("v", RATIO_V), ("w", RATIO_W), ("t", 0.1)):
        s = np.zeros_like(f)
        s[1:] = (1 + (f[1:] / 0.02) ** 2) ** (SLOPE / 2)
        c = np.sqrt(s) * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size))
        c[0] = 0
        x = np.fft.irfft(c, n)
        out[comp] = x * sigma / x.std()
    t = np.arange(n) / FS_HZ
    u = 5.0 + out["u"] + TREND_MS * (t / DURATION_S - 0.5)
    return xr.Dataset({"u_east_ms": ("time_s", u), "v_north_ms": ("time_s", out["v"]),
                       "w_up_ms": ("time_s", out["w"]), "t_sonic_k": ("time_s", 290.0 + out["t"])},
                      coords={"time_s": t}, attrs={"height_m": 10.0})


#: hover-like points: 20 m across the wind at the record's height, 5 m across at twice its
#: height, and 5 m across at its height (the trend point)
POINTS = np.array([[0.0, 20.0, 10.0], [0.0, 5.0, 20.0], [0.0, 5.0, 10.0]])


def _runs(amplitudes: str, seeds: range = range(4)) -> dict[str, list[float]]:
    con = _constraint()
    out: dict[str, list[float]] = {"slope": [], "v_u": [], "w_u": [], "trend": []}
    for seed in seeds:
        ds = simulate_wind(POINTS, DURATION_S, FS_HZ, 5.0, 270.0, 10.0, np.inf, 0.05, seed=seed, constraint=con,
                           amplitudes=amplitudes)
        for p in (0, 1):
            u, v, w = (ds[k].values[p] for k in ("u_east_ms", "v_north_ms", "w_up_ms"))
            f, su = signal.welch(u - u.mean(), FS_HZ, nperseg=2048)
            _, sv = signal.welch(v - v.mean(), FS_HZ, nperseg=2048)
            _, sw = signal.welch(w - w.mean(), FS_HZ, nperseg=2048)
            inertial = (f > 0.3) & (f < 4.0)
            out["slope"].append(float(np.polyfit(np.log(f[inertial]), np.log(su[inertial]), 1)[0]))
            band = (f > 0.05) & (f < 4.0)
            out["v_u"].append(float(np.sqrt(sv[band].sum() / su[band].sum())))
            out["w_u"].append(float(np.sqrt(sw[band].sum() / su[band].sum())))
        out["trend"].append(float(np.polyfit(ds["time_s"].values / DURATION_S, ds["u_east_ms"].values[2], 1)[0]))
    return out


@pytest.fixture(scope="module")
def measured_amplitudes() -> dict[str, list[float]]:
    return _runs("constraint")


@pytest.fixture(scope="module")
def model_amplitudes() -> dict[str, list[float]]:
    return _runs("model", range(2))


def test_spectral_shape_carries_to_other_points(measured_amplitudes, model_amplitudes):
    # Welch slopes over 0.3-4 Hz of 15-segment averages scatter by about 0.03 (measured:
    # -2.32..-2.37 over 4 seeds and 2 points); 0.15 is 5 times that and far from -5/3.
    assert np.all(np.abs(np.array(measured_amplitudes["slope"]) - SLOPE) < 0.15)
    assert np.all(np.abs(np.array(model_amplitudes["slope"]) + 5.0 / 3.0) < 0.15)  # the model's own shape otherwise


def test_isotropy_carries_to_other_points(measured_amplitudes, model_amplitudes):
    # at the record's height (the even entries: point 0 of each seed), band 0.05-4 Hz, mean of
    # 4 seeds: the low frequencies hold few independent estimates and single values scatter by
    # about 0.05-0.07 (measured means 1.13 and 0.63); 10 % holds them, and the model's ratios in
    # this band (w/u 0.82-0.90 at this point) fail it. (At twice the height w/u rises with the
    # model's height ratio of S_w, whose energy-containing range moves with z.)
    assert np.mean(measured_amplitudes["v_u"][::2]) == pytest.approx(RATIO_V, rel=0.10)
    assert np.mean(measured_amplitudes["w_u"][::2]) == pytest.approx(RATIO_W, rel=0.10)
    assert np.mean(model_amplitudes["w_u"][::2]) > 1.25 * RATIO_W


def test_trend_appears_at_the_hover_point(measured_amplitudes):
    con = _constraint()
    trend = np.polyfit(con["time_s"].values / DURATION_S, con["u_east_ms"].values, 1)[0]
    # 5 m across the wind the u coherence at the lowest frequencies is about 0.88
    # (IEC exponential model, L_c = 56.7 m): the trend arrives at 0.7-1.2 of the record's in the
    # mean of 4 seeds (measured 0.97)
    assert 0.7 * trend < np.mean(measured_amplitudes["trend"]) < 1.2 * trend


def test_record_reproduced_at_its_point_with_measured_amplitudes():
    con = _constraint()
    ds = simulate_wind(np.array([[0.0, 0.0, 10.0], [0.0, 20.0, 10.0]]), DURATION_S, FS_HZ, 5.0, 270.0, 10.0, np.inf,
                       0.05, seed=3, constraint=con, amplitudes="constraint")
    for var, out in (("u_east_ms", "u_east_ms"), ("v_north_ms", "v_north_ms"), ("w_up_ms", "w_up_ms"),
                     ("t_sonic_k", "theta_v_k")):
        x = con[var].values - con[var].values.mean()
        y = ds[out].values[0] - ds[out].values[0].mean()
        # all frequencies below Nyquist are constrained; the Nyquist bin (1 of 9000) is not
        assert np.std(y - x) < 1e-3 * np.std(x), var


def test_constraint_amplitudes_need_a_constraint():
    with pytest.raises(InputError, match="needs a constraint"):
        simulate_wind(np.array([[0.0, 0.0, 10.0]]), 60.0, FS_HZ, 5.0, 270.0, 10.0, np.inf, amplitudes="constraint")


@pytest.fixture(scope="module")
def forward_flight(tmp_path_factory):
    """One simulated flight processed to L3, its forward conditions and the mast L1."""
    from dronewind.diagnose import experiments as ex
    from dronewind.diagnose import forward_conditions, in_process
    from dronewind.manifest import with_defaults

    work = Path(tmp_path_factory.mktemp("atmosphere"))
    proc = with_defaults({})["processing"]
    data = ex.campaign_manifest(ex.Draw("none", {}, 7), n_flights=2, hover_min=6.0)
    flight = data["payload_flights"][1]
    v = in_process.process_virtual_flight(data, flight, work, proc)
    cond = forward_conditions.forward_conditions(data, flight["id"], v.l3, v.l2)
    return data, flight["id"], proc, cond, v.mast_l1, v.l2, v.l3


def _hover_differences(measured: xr.Dataset, simulated: xr.Dataset, l2: xr.Dataset) -> dict[str, np.ndarray]:
    t0, t1 = l2["time"].values[0], l2["time"].values[-1]
    a, b = measured.sel(time=slice(t0, t1)), simulated.sel(time=slice(t0, t1))
    common = np.intersect1d(a["time"].values, b["time"].values)
    assert common.size > 0.95 * a.sizes["time"]
    out = {}
    for var in ("u_east_ms", "v_north_ms", "w_up_ms", "t_sonic_k"):
        x, y = a[var].sel(time=common).values, b[var].sel(time=common).values
        ok = np.isfinite(x) & np.isfinite(y)
        out[var] = y[ok] - x[ok]
    return out


def test_forward_mast_reproduces_the_measured_record(forward_flight):
    from dronewind.diagnose import forward, forward_atmosphere, forward_conditions

    data, fid, proc, cond, m1, l2, _ = forward_flight
    record = forward_atmosphere.atmosphere_record(m1, cond)
    _, products = forward.run_forward(forward_conditions.forward_manifest(data, fid, cond, None, 101, True), fid, proc,
                                      atmosphere=record)
    diff = _hover_differences(m1, products["l1"]["mast"], l2)
    for var, d in diff.items():
        # the record already holds the mast's noise and the forward mast adds none (forward
        # manifest with measured_atmosphere): what is left is the TOA5 resolution of 0.001 m/s
        # (0.001 K) applied twice (sd 0.4 mm/s; measured 0.1-0.35 mm/s), within 1 mm/s
        assert np.std(d) < 0.001, var
        if var != "w_up_ms":  # the model's mean w is 0; the record's own mean w is not reproduced
            assert abs(np.mean(d)) < 0.005, var
    info = products["truth"].atmosphere_info
    # the record covers the forward flight but for a few seconds at its ends (mirrored)
    assert info["mirrored_s"] < 10.0 and info["record_covered_s"] > cond["duration_s"] + 300.0


def test_forward_mast_keeps_the_measured_samples_and_band_ratio(forward_flight):
    """The forward run is processed over the measured L2's samples, so its mast's <S_w/S_u> is the measured one.

    The conditions' window is the measured L2's span, which the chain had already cut by the
    sonic-INS lag: processed over that span again, a forward L2 lost the lag's samples (4-5
    at 32 Hz), its 8 Hz L3 one or two, and the mast's band ratio, a mean over log-frequency
    bins of 2-12 Welch ordinates each, moved with the Welch frequency grid by up to twice its
    sampling error at low wind speed (0.18 for 3.5 m/s). With the measured length the
    forward mast differs from the measured one only by the window the drone-mast lag shifts
    (a few seconds of 360 s), which moves the ratio by about 0.01 (0.009 sd over shifts of
    0-7 s of a 3.5 m/s flight): the tolerance is 0.03, a third of the ratio's sampling error.
    """
    from dronewind.diagnose import forward, forward_atmosphere, forward_conditions
    from dronewind.diagnose.features import flight_features

    data, fid, proc, cond, m1, l2, l3 = forward_flight
    record = forward_atmosphere.atmosphere_record(m1, cond)
    feats, products = forward.run_forward(forward_conditions.forward_manifest(data, fid, cond, None, 101, True), fid,
                                          proc, atmosphere=record, lag_drift=False, features=["sw_su_mast"])
    t_meas, t_fwd = l2["time"].values, products["l2"]["time"].values
    half = np.median(np.diff(t_meas)) / 2
    assert t_fwd.size == t_meas.size
    assert abs(t_fwd[0] - t_meas[0]) < half and abs(t_fwd[-1] - t_meas[-1]) < half
    measured = flight_features(l3, l2, features=["sw_su_mast"]).values["sw_su_mast"]
    assert products["l3"].sizes["time"] == l3.sizes["time"]
    assert feats.values["sw_su_mast"] == pytest.approx(measured, abs=0.03)


def test_mast_attenuation_probe_reads_the_record_through_the_mechanism(forward_flight):
    from dronewind.diagnose import forward, forward_atmosphere, forward_conditions

    data, fid, proc, cond, m1, l2, _ = forward_flight
    params = {"gain": 0.85}
    measured = forward_atmosphere.atmosphere_record(m1, cond)
    record = forward_atmosphere.RECORD_INVERSES["mast_w_attenuation"](measured, params)
    mech = [{"mechanism": "mast_w_attenuation", "parameters": params}]
    _, products = forward.run_forward(forward_conditions.forward_manifest(data, fid, cond, mech, 101, True), fid, proc,
                                      atmosphere=record)
    diff = _hover_differences(m1, products["l1"]["mast"], l2)
    # the true w at the mast is the record's w / 0.85; the attenuating mast measures the record
    # again (within the TOA5 resolution, as above)
    assert np.std(diff["w_up_ms"]) < 0.001


def test_atmosphere_record_needs_the_hover_window(forward_flight):
    from dronewind.diagnose import forward, forward_atmosphere, forward_conditions

    data, fid, proc, cond, m1, l2, _ = forward_flight
    short = m1.sel(time=slice(l2["time"].values[0] + np.timedelta64(60, "s"), None))
    with pytest.raises(InputError, match="hover window"):
        forward.run_forward(forward_conditions.forward_manifest(data, fid, cond, None, 101, True), fid, proc,
                            atmosphere=forward_atmosphere.atmosphere_record(short, cond))
    with pytest.raises(InputError, match="missing variable"):
        forward_atmosphere.atmosphere_record(m1.drop_vars("w_up_ms"), cond)


def test_forward_step_names_a_bad_setting(tmp_path):
    from dronewind.steps.diagnosis import _check_atmosphere, forward_probes

    measured = tmp_path / "measured.json"
    measured.write_text('{"conditions": {}}')
    with pytest.raises(InputError, match="expected one of"):
        forward_probes(measured, tmp_path / "out.json", campaign={}, flight_id="f", processing={}, seeds=[1],
                       atmosphere="textbook")
    with pytest.raises(InputError, match="needs the reference mast's L1"):
        forward_probes(measured, tmp_path / "out.json", campaign={}, flight_id="f", processing={}, seeds=[1],
                       atmosphere="measured")
    # forward files written with another atmosphere than the diagnosis is told are refused
    old = tmp_path / "old.json"
    old.write_text('{"flight": "f"}')  # written before the setting existed: the model atmosphere
    _check_atmosphere([old], "model")
    with pytest.raises(InputError, match="rerun the forward rules"):
        _check_atmosphere([old], "measured")


def test_forward_conditions_carry_the_measured_rates(forward_flight):
    """The forward runs record at the rates the flight was recorded at (the simulator's 32 Hz
    sonic, 50 Hz INS and 10 Hz mast here); rates outside the simulator's range are brought into
    it, whole numbers of Hz."""
    from dronewind.diagnose.forward_conditions import measured_rates_hz

    _, _, _, cond, _, l2, l3 = forward_flight
    assert (cond["sonic_rate_hz"], cond["mast_rate_hz"]) == (32.0, 10.0) and "ins_rate_hz" not in cond
    ins = xr.Dataset(attrs={"sampling_rate_hz": 50.0})
    assert measured_rates_hz(l3, l2, ins) == {"sonic_rate_hz": 32.0, "ins_rate_hz": 50.0, "mast_rate_hz": 10.0}
    odd = {"l3": l3.assign_attrs(mast_sampling_rate_hz=100.0), "l2": l2.assign_attrs(sampling_rate_hz=19.6)}
    assert measured_rates_hz(odd["l3"], odd["l2"], xr.Dataset(attrs={"sampling_rate_hz": 400.0})) == {
        "sonic_rate_hz": 20.0, "ins_rate_hz": 200.0, "mast_rate_hz": 60.0}
    assert measured_rates_hz(l3.drop_attrs(), l2.drop_attrs()) == {}


def _hf_power(truth) -> float:
    """1-4 Hz power of the true vertical wind at the payload while airborne [m2 s-2 Hz-1]."""
    a = truth.air
    x = a.wind_up_ms[a.airborne > 0.999]
    f, p = signal.welch(signal.detrend(x), 32.0, nperseg=32 * 60)
    return float(p[(f > 1.0) & (f < 4.0)].mean())


def test_a_gap_in_the_mast_record_does_not_lower_the_hover_points_spectrum(forward_flight):
    """A 100 s gap in the record shortly before the hover: bridged by a straight line it would
    take the share of the field period it fills (about 15 %) from the spectral level the
    record gives the hover point; the span ends at the gap and the record is mirrored there
    instead. The same seed with and without the gap: the 1-4 Hz level at the payload agrees
    within 6 % (ln 0.06, under half the bridged line's -0.136 measured here); what is left
    is the level of the mirrored stretch against that of the samples the gap removed
    (measured +0.028)."""
    from dronewind.diagnose import forward_atmosphere, forward_conditions
    from dronewind.simulate.payload import payload_truth

    data, fid, _, cond, m1, _, _ = forward_flight
    record = forward_atmosphere.atmosphere_record(m1, cond)
    start = np.datetime64(cond["start"].rstrip("Z"))
    t = record["time"].values
    gap = (t >= start - np.timedelta64(110, "s")) & (t < start - np.timedelta64(10, "s"))
    gappy = record.isel(time=np.flatnonzero(~gap))
    manifest = forward_conditions.forward_manifest(data, fid, cond, None, 101, True)
    full, cut = payload_truth(manifest, fid, record), payload_truth(manifest, fid, gappy)
    assert cut.atmosphere_info["gaps_cut"] == 1 and full.atmosphere_info["gaps_cut"] == 0
    assert abs(np.log(_hf_power(cut) / _hf_power(full))) < 0.06
