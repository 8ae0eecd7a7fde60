"""The sonic-INS lag search by short real FFTs against the full FFT convolution it replaces.

:func:`dronewind.payload.lag_search.lag_correlations` correlates only the lags searched, with FFTs
of a fast length just above the record (:func:`~dronewind.payload.lag_search.fast_fft_length`) and
the sum over the three components taken on the spectra. The reference below is the earlier
evaluation, :func:`scipy.signal.fftconvolve` of the twelve column pairs in ``valid`` mode:
both must give the same TKE curve (to float rounding) and the same lag, on synthetic signals
with a known lag and on a simulated payload flight with a hidden sonic-INS lag.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
import scipy.fft
import scipy.signal

from dronewind.manifest import default_config
from dronewind.payload import chain, lag_search
from dronewind.simulate.payload import payload_records
from tests.payload.test_sync import Flight, _arrays
from tests.simulate.test_simulate_payload import _campaign


def _tke_fftconvolve(rot: np.ndarray, v_sonic: np.ndarray, b: np.ndarray, n: int, n_half: int) -> np.ndarray:
    """The mean TKE per lag with one full FFT convolution per column pair (the earlier code)."""
    c_body = np.einsum("nji,nj->ni", rot, v_sonic)
    long_cols = np.concatenate([rot.reshape(-1, 9), c_body], axis=1)
    short_cols = np.concatenate([np.tile(b, (1, 3)), b], axis=1)
    corr = scipy.signal.fftconvolve(long_cols, short_cols[::-1], mode="valid", axes=0)
    sum_rb = corr[:, :9].reshape(-1, 3, 3).sum(axis=2)
    sum_cb = corr[:, 9:].sum(axis=1)
    cs_v = np.concatenate([np.zeros((1, 3)), np.cumsum(v_sonic, axis=0)])
    cs_v2 = np.concatenate([[0.0], np.cumsum(np.sum(v_sonic ** 2, axis=1))])
    j = np.arange(2 * n_half + 1)
    mean_w = (sum_rb + cs_v[j + n] - cs_v[j]) / n
    return 0.5 * ((float(np.sum(b * b)) + cs_v2[j + n] - cs_v2[j] + 2.0 * sum_cb) / n - np.sum(mean_w ** 2, axis=1))


@pytest.mark.parametrize("n", [1, 2, 7, 16, 97, 1000, 38401, 65537, 10 ** 6 + 1])
def test_fast_fft_length_is_scipys(n):
    assert lag_search.fast_fft_length(n) == scipy.fft.next_fast_len(n, real=True)


def test_lag_correlations_equal_direct_sums():
    rng = np.random.default_rng(4)
    n, n_lags = 300, 9
    x = rng.normal(size=(n + n_lags - 1, 4, 3))
    y = rng.normal(size=(n, 3))
    direct = np.array([[np.sum(x[j:j + n, g, :] * y) for g in range(4)] for j in range(n_lags)])
    np.testing.assert_allclose(lag_search.lag_correlations(x, y, n_lags), direct, rtol=1e-10, atol=1e-10)
    with pytest.raises(ValueError, match="expected long_series"):
        lag_search.lag_correlations(x[:-1], y, n_lags)


@pytest.mark.parametrize(("lag_true", "lever"), [(0.0, None), (0.3125, None), (-0.75, (0.3, 0.2, -0.8)),
                                                 (1.40625, (0.1, -0.1, 0.5))])
def test_same_curve_and_lag_as_fftconvolve_on_known_lags(lag_true, lever, monkeypatch):
    fl = Flight(seed=3, duration_s=300.0)
    sonic, ins = fl.l1(lag_true, "upside_down", lever)
    ts, s, ti, att, vel = _arrays(sonic, ins)
    sel = (ts > 40) & (ts < 260)
    lag_new, tke_new, _ = lag_search.tke_vs_lag(ts[sel], s[sel], ti, att, vel, "upside_down", lever)
    monkeypatch.setattr(lag_search, "_mean_tke_per_lag", _tke_fftconvolve)
    lag_old, tke_old, _ = lag_search.tke_vs_lag(ts[sel], s[sel], ti, att, vel, "upside_down", lever)
    np.testing.assert_array_equal(lag_new, lag_old)
    np.testing.assert_allclose(tke_new, tke_old, rtol=1e-10)
    found_new = lag_search.find_sonic_ins_lag(lag_new, tke_new)
    found_old = lag_search.find_sonic_ins_lag(lag_old, tke_old)
    assert found_new == found_old
    # the estimator's own sampling error on a 220 s segment: up to 3 steps (see test_sync)
    assert abs(found_new[0] - lag_true) <= 3.0 / 32 + 1e-12


def test_same_lag_and_wind_as_fftconvolve_on_a_simulated_flight(monkeypatch):
    """A simulated payload flight (400 s hover, sonic stamped 0.25 s early) through L1 and L2: the same lag,
    hence the same wind."""
    camp = _campaign([{"mechanism": "sonic_ins_lag", "parameters": {"lag_s": 0.25}}])
    camp["simulation"]["payload_flights"]["f1"]["sonic_ins_lag_s"] = 0.0  # the mechanism's lag alone
    records, _ = payload_records(camp, "f1")
    proc = copy.deepcopy(default_config()["processing"])
    table, ins_l1 = chain.compute_ins_l1(records[1])
    sonic_l1 = chain.compute_sonic_l1(records[0], records[1], table, proc["despike"])
    flight = {k: v for k, v in camp["payload_flights"][0].items() if k != "window"}  # hover found in the data

    hover = dict(proc["hover"], min_duration_s=300.0)

    def l2():
        return chain.compute_payload_l2(sonic_l1, ins_l1, flight, camp["site"]["altitude_m"],
                                        sonic_ins_lag=proc["sonic_ins_lag"], hover=hover,
                                        max_missing_fraction=proc["max_missing_fraction"])

    new = l2()
    monkeypatch.setattr(lag_search, "_mean_tke_per_lag", _tke_fftconvolve)
    old = l2()
    assert new.attrs["lag_sonic_ins_s"] == old.attrs["lag_sonic_ins_s"]
    assert new.attrs["lag_sonic_ins_s"] > 0.0  # the sonic's clock is behind: time is added to it
    np.testing.assert_allclose(new["tke_m2s2"].values, old["tke_m2s2"].values, rtol=1e-10)
    winds = [name for name in new.data_vars if name.startswith(("u_", "v_", "w_"))]
    assert winds
    for name in winds:
        np.testing.assert_array_equal(new[name].values, old[name].values)


def _halves(ppm):
    """Lags of the hover halves of the simulated flight with a sonic clock drift (same seed)."""
    mech = [] if ppm == 0 else [{"mechanism": "clock_drift", "parameters": {"ppm": ppm}}]
    camp = _campaign(mech)
    records, _ = payload_records(camp, "f1")
    proc = copy.deepcopy(default_config()["processing"])
    table, ins_l1 = chain.compute_ins_l1(records[1])
    sonic_l1 = chain.compute_sonic_l1(records[0], records[1], table, proc["despike"])
    flight = {k: v for k, v in camp["payload_flights"][0].items() if k != "window"}
    kw = dict(sonic_ins_lag=proc["sonic_ins_lag"], hover=dict(proc["hover"], min_duration_s=300.0),
              max_missing_fraction=proc["max_missing_fraction"])
    full = chain.compute_payload_l2(sonic_l1, ins_l1, flight, camp["site"]["altitude_m"], lag_halves=True, **kw)
    only = chain.compute_payload_l2(sonic_l1, ins_l1, flight, camp["site"]["altitude_m"], lag_halves=True,
                                    lag_only=True, **kw)
    halves = (full.attrs["lag_first_half_s"], full.attrs["lag_second_half_s"])
    assert halves == (only.attrs["lag_first_half_s"], only.attrs["lag_second_half_s"])
    assert "lag_first_half_s" not in chain.compute_payload_l2(sonic_l1, ins_l1, flight, camp["site"]["altitude_m"],
                                                              **kw).attrs
    return halves, float((full["time"].values[-1] - full["time"].values[0]) / np.timedelta64(1, "s"))


@pytest.mark.parametrize("ppm", [-1000.0, 500.0, 1000.0])
def test_lags_of_the_hover_halves_show_a_clock_drift(ppm):
    """A simulated flight whose sonic clock runs ``ppm`` fast (400 s hover) against the same
    flight without the drift (same seed): the lag difference between the two halves of the L2's
    hover window changes by the drift over the time between the halves' centres (ppm 1e-6 x
    200 s, 0.2 s at the catalog's largest 1000 ppm; a fast sonic clock needs less time added
    later), within two 1/32 s search steps, so a wrong sign (0.2-0.4 s off) fails. Without the
    drift the halves agree within three steps (the lag's sampling error on a 200 s segment, see
    test_sync). The halves are the same from the full L2 as from a lag-only pass, and absent
    unless asked for."""
    (a0, b0), _ = _halves(0.0)
    (a, b), hover_s = _halves(ppm)
    assert abs(b0 - a0) <= 3.0 / 32 + 1e-12
    expected = -ppm * 1e-6 * hover_s / 2.0
    assert abs((b - a) - (b0 - a0) - expected) <= 2.0 / 32 + 1e-12, (a, b, a0, b0, expected)


@pytest.mark.parametrize(("lag_true", "lever", "split_fraction"), [(0.0, None, 0.5), (0.3125, (0.3, 0.2, -0.8), 0.37)])
def test_whole_curve_from_the_halves_equals_its_own_correlation(lag_true, lever, split_fraction):
    """With a split, the whole grid's TKE curve is the halves' sums added: the same curve (to float
    rounding, 1e-12 of the curve's size) and the same lag as its own correlation; the halves are the
    curves of their own samples (the earlier evaluation, fftconvolve, on the halves' slices)."""
    fl = Flight(seed=5, duration_s=300.0)
    sonic, ins = fl.l1(lag_true, "upside_down", lever)
    ts, s, ti, att, vel = _arrays(sonic, ins)
    sel = (ts > 40) & (ts < 260)
    split = 40 + split_fraction * 220
    lags, whole, n, _ = lag_search._tke_curves(ts[sel], s[sel], ti, att, vel, "upside_down", lever, 2.0, 1 / 32, None)
    lags_s, whole_s, n_s, halves = lag_search._tke_curves(ts[sel], s[sel], ti, att, vel, "upside_down", lever, 2.0,
                                                    1 / 32, None, split)
    assert n_s == n and np.array_equal(lags_s, lags) and all(h is not None for h in halves)
    np.testing.assert_allclose(whole_s, whole, rtol=0, atol=1e-12 * np.max(np.abs(whole)))
    assert lag_search.find_sonic_ins_lag(lags_s, whole_s) == lag_search.find_sonic_ins_lag(lags, whole)
    assert abs(lag_search.find_sonic_ins_lag(lags, whole)[0] - lag_true) <= 3.0 / 32 + 1e-12
    # each half: its own samples' curve
    n_half = 64
    t_grid = ts[sel]
    t0 = t_grid[np.flatnonzero(t_grid >= ti[0] + 2.0 - 1e-9)[0]]
    k = int(np.ceil((split - t0) * 32 - 1e-9))
    b = lag_search._sonic_body_on_grid(ts[sel], s[sel], t0 + np.arange(n) / 32, "upside_down", None)
    rot, v = lag_search._ins_on_extended_grid(ti, att, vel, t0 + np.arange(-n_half, n + n_half) / 32, lever)
    for (lo, hi), half in zip(((0, k), (k, n)), halves, strict=True):
        ref = _tke_fftconvolve(rot[lo:hi + 2 * n_half], v[lo:hi + 2 * n_half], b[lo:hi], hi - lo, n_half)
        np.testing.assert_allclose(half, ref, rtol=1e-10)


@pytest.mark.parametrize("vertex_s", [0.0, 0.0117, -0.0151, 0.2031])
def test_subgrid_minimum_finds_a_parabolas_vertex_between_the_grid_lags(vertex_s):
    """A TKE curve that is a parabola in the lag (plus a constant) on a 1/32 s grid: the vertex
    comes back to rounding error, wherever it lies between two grid lags; the grid minimum is
    off by up to half a step (0.0156 s)."""
    lags = np.arange(-16, 17) / 32.0
    tke = 0.4 + 3.0 * (lags - vertex_s) ** 2
    assert lag_search.subgrid_minimum(lags, tke) == pytest.approx(vertex_s, abs=1e-12)
    assert abs(lag_search.find_sonic_ins_lag(lags, tke)[0] - vertex_s) <= 0.5 / 32 + 1e-12


def test_subgrid_minimum_stays_on_the_grid_at_an_end_or_beside_a_missing_value():
    """At an end of the grid, or beside a lag without a TKE (NaN), there is no parabola
    through the minimum: the grid minimum is returned. Two equal lowest values put the vertex
    half-way between them."""
    lags = np.arange(-4, 5) / 32.0
    assert lag_search.subgrid_minimum(lags, lags + 1.0) == lags[0]
    gap = np.array([3.0, 2.0, np.nan, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0])
    assert lag_search.subgrid_minimum(lags, gap) == lags[3]
    tie = np.array([3.0, 2.0, 1.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    assert lag_search.subgrid_minimum(lags, tie) == pytest.approx((lags[2] + lags[3]) / 2.0, abs=1e-15)
