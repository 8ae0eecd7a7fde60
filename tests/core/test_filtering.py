"""Known-answer tests of dronewind.core.filtering."""

from __future__ import annotations

import numpy as np
import pytest

from dronewind.core.filtering import (
    INSTRUMENT_LIMITS,
    despike_moving_mad,
    gap_fill_linear,
    hover_window_mask,
    range_mask,
)
from dronewind.core.geo import from_local_tangent_plane, local_tangent_plane_m


def test_range_mask():
    x = np.array([-50.0, -40.0, 0.0, 40.0, 40.01, np.nan])
    np.testing.assert_array_equal(range_mask(x, -40, 40), [True, False, False, False, True, False])
    with pytest.raises(ValueError):
        range_mask(x, 1, 0)


def test_instrument_limits_documented():
    assert INSTRUMENT_LIMITS["rmyoung_81000"]["speed_ms"] == (0.0, 40.0)  # Ghirardelli et al. (2025) Table 2
    assert INSTRUMENT_LIMITS["rmyoung_81000"]["t_sonic_c"] == (-50.0, 50.0)
    assert INSTRUMENT_LIMITS["csat3"]["uz_ms"] == (-8.0, 8.0)
    assert INSTRUMENT_LIMITS["csat3"]["ux_ms"] == (-65.0, 65.0)
    assert INSTRUMENT_LIMITS["csat3"]["t_sonic_c"] == (-30.0, 50.0)
    for entry in INSTRUMENT_LIMITS.values():
        assert entry["source"]


# ---------------------------------------------------------------------------- despiking


def test_despike_finds_injected_spikes():
    rng = np.random.default_rng(42)
    fs = 32.0
    n = int(20 * 60 * fs)  # a 20-min flight
    t = np.arange(n) / fs
    # turbulence-like noise (sigma 0.5) on a swinging signal (0.12 Hz pendulum, 0.5 m/s)
    x = 5 + 0.5 * np.sin(2 * np.pi * 0.12 * t) + rng.normal(0, 0.5, n)
    idx = np.sort(rng.choice(np.arange(10, n - 10), 40, replace=False))
    idx[0], idx[-1] = 0, n - 1  # spikes at the very ends (shrunken centred window)
    # The 10-s window spans more than one swing period, so the swing is part of the scatter:
    # scaled MAD <= 0.9 m/s (measured), threshold <= 6.3 m/s about the median; a spike of
    # 10-15 m/s stays above it even on the opposite swing extreme with -3 sigma noise.
    amp = rng.uniform(10, 15, idx.size) * rng.choice([-1, 1], idx.size)
    y = x.copy()
    y[idx] += amp
    y[[1000, 1001, 2000]] = np.nan  # missing samples are not spikes
    spikes = despike_moving_mad(y, fs)
    np.testing.assert_array_equal(np.flatnonzero(spikes), idx)


def test_despike_no_false_positives_on_gaussian_noise():
    # P(|z| > 7) = 2.6e-12 per sample; 10^6 samples -> expected 2.6e-6 false spikes. The
    # moving median/MAD estimates from 321 samples add scatter to the threshold (~5 %), which
    # cannot bring a 7-sigma threshold near a 1-in-10^6 event; so zero is required.
    rng = np.random.default_rng(7)
    x = rng.normal(0, 1, 1_000_000)
    assert despike_moving_mad(x, 32.0).sum() == 0


def test_despike_threshold_uses_scaled_mad():
    # A 6-sigma outlier is not a spike at 7 scaled MAD, but is one at n_mad=5; with the raw
    # (unscaled) MAD = 0.674 sigma, 7 MAD would be 4.7 sigma and would flag it.
    rng = np.random.default_rng(1)
    x = rng.normal(0, 1, 3200)
    x -= np.median(x)
    x[1600] = 6.0
    assert not despike_moving_mad(x, 32.0)[1600]
    assert despike_moving_mad(x, 32.0, n_mad=5.0)[1600]


def test_despike_window_is_centred_and_constant_signal():
    # a level step is not a spike (centred window, median follows the step)
    x = np.r_[np.zeros(500), np.ones(500) * 10.0] + np.random.default_rng(0).normal(0, .1, 1000)
    assert despike_moving_mad(x, 10.0).sum() == 0
    # a constant (stuck) signal has MAD 0: nothing can be separated, nothing flagged
    c = np.full(500, 3.0)
    c[200] = 4.0
    assert despike_moving_mad(c, 10.0).sum() == 0
    assert despike_moving_mad(np.array([]), 10.0).size == 0


# ---------------------------------------------------------------------------- gap fill


def test_gap_fill_exact_on_linear_signal():
    x = 0.37 * np.arange(1000) - 12.0
    y = x.copy()
    y[[3, 4, 5, 100, 500, 501, 998, 999]] = np.nan  # 0.8 %, includes the trailing edge
    y[0] = np.nan  # leading edge
    filled, n_filled, usable = gap_fill_linear(y)
    assert usable and n_filled == 9
    interior = np.ones(1000, dtype=bool)
    interior[[0, 998, 999]] = False
    np.testing.assert_allclose(filled[interior], x[interior], rtol=0, atol=1e-12)
    assert filled[0] == x[1] and filled[999] == x[997]  # edges: nearest valid value
    assert np.isnan(y[3])  # input untouched


def test_gap_fill_threshold_2_percent():
    x = np.sin(np.arange(1000) / 30.0)
    y = x.copy()
    y[100:120] = np.nan  # exactly 2 %
    filled, n_filled, usable = gap_fill_linear(y)
    assert usable and n_filled == 20 and np.isfinite(filled).all()
    y[500] = np.nan  # 2.1 %
    filled, n_filled, usable = gap_fill_linear(y)
    assert not usable and n_filled == 0 and np.isnan(filled[100])
    assert gap_fill_linear(np.full(10, np.nan)) [2] is False
    assert gap_fill_linear(y, max_missing_fraction=0.05)[2]


# --------------------------------------------------------------------------- hover window


def test_local_tangent_plane():
    # 0.001 deg of latitude at 45 deg N is 111.1318 m (WGS84 meridian arc), of longitude
    # 78.8463 m (N cos(phi) = 6388838 m * 0.7071 * pi/180 / 1000)
    e, n = local_tangent_plane_m(45.001, 0.0, 45.0, 0.0)
    np.testing.assert_allclose(n, 111.1318, rtol=2e-5)
    e, n = local_tangent_plane_m(45.0, 0.001, 45.0, 0.0)
    np.testing.assert_allclose(e, 78.8463, rtol=2e-5)
    e, _ = local_tangent_plane_m(0.0, -179.9995, 0.0, 179.9995)  # across the antimeridian
    np.testing.assert_allclose(e, 111.3195, rtol=1e-4)


def test_hover_window_mask():
    lat0, lon0, alt0 = 43.1247, 0.3628, 633.0
    m_per_deg_lat = 111_132.0
    m_per_deg_lon = 111_320.0 * np.cos(np.radians(lat0))
    rng = np.random.default_rng(3)
    n_climb, n_hover = 300, 2000
    alt = np.r_[np.linspace(603, alt0, n_climb), alt0 + rng.uniform(-2.5, 2.5, n_hover)]
    east = np.r_[np.zeros(n_climb), rng.uniform(-3.5, 3.5, n_hover)]
    north = np.r_[np.zeros(n_climb), rng.uniform(-3.5, 3.5, n_hover)]
    east[n_climb + 100 : n_climb + 150] = 6.0  # swing 6 m east: outside +-4 m
    north[n_climb + 500 : n_climb + 520] = -5.0  # 5 m south
    alt[n_climb + 900 : n_climb + 910] = alt0 + 3.6  # 3.6 m above the median
    lat = lat0 + north / m_per_deg_lat
    lon = lon0 + east / m_per_deg_lon
    lat[n_climb + 1500] = np.nan
    mask = hover_window_mask(alt, lat, lon)
    expect = np.r_[np.zeros(n_climb, bool), np.ones(n_hover, bool)]
    # the last ~9 m of the climb lie within 3 m of the hover altitude and at the hover spot
    expect[:n_climb] = np.abs(alt[:n_climb] - np.median(alt)) <= 3.0
    expect[n_climb + 100 : n_climb + 150] = False
    expect[n_climb + 500 : n_climb + 520] = False
    expect[n_climb + 900 : n_climb + 910] = False
    expect[n_climb + 1500] = False
    np.testing.assert_array_equal(mask, expect)
    # tolerances are parameters
    assert hover_window_mask(alt, lat, lon, horiz_tol_m=7.0)[n_climb + 120]
    with pytest.raises(ValueError):
        hover_window_mask(alt[:-1], lat, lon)


def test_local_tangent_plane_round_trip():
    """The inverse projection returns the positions to 1e-9 degrees (about 0.1 mm)."""
    lat = np.array([43.1247, 43.1250, 43.1200])
    lon = np.array([0.3628, 0.3700, 0.3500])
    e, n = local_tangent_plane_m(lat, lon, 43.1247, 0.3628)
    lat2, lon2 = from_local_tangent_plane(e, n, 43.1247, 0.3628)
    np.testing.assert_allclose(lat2, lat, atol=1e-9)
    np.testing.assert_allclose(lon2, lon, atol=1e-9)
