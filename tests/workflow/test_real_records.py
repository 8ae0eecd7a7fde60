"""Real records: dronewind statistics vs MetPy (independent implementation) and L4 on real data.

Data (the records of :mod:`dronewind.datasets`, through the ``real_record`` fixture; skipped if absent):
* ``ameriflux_gold_openpath``: 96 half-hours, Gill WindMaster Pro at 2 m, 10 Hz
  (read by :func:`dronewind.io.read_ameriflux_gold`);
* ``fluxpart_csat3_toa5``: CSAT3, 20 Hz, 2 x 15 min on 7 June 2012, tower 7.11 m
  (heights.csv, value valid from 2012-05-07), read by :func:`dronewind.io.mast_l1`.

Every block is gap-filled (:func:`dronewind.core.filtering.gap_fill_linear`, the L1 spikes
are NaN) and double-rotated (:func:`dronewind.core.rotation.double_rotation`) once; the same
arrays go to dronewind and to MetPy (``friction_velocity``, ``kinematic_flux``, ``tke``),
so the comparison isolates the statistics.

Measured (2026-11-22, 96 gold blocks): with block-mean fluctuations dronewind = MetPy to
1.4e-12 relative (w'T', L; MetPy's one-pass mean(wT) - mean(w) mean(T) loses digits at
T = 294 K) and 2e-16 for u*, sigma_w, TKE. With the linear detrending of the L4 chain
(Ghirardelli et al. 2025 Sect. 4.4) the median |relative difference| vs MetPy's block mean is u* 1.0 %,
sigma_w 0.05 % (max 1.9 %), w'T' 3 %, L 4.5 %, TKE 6 %: the trend removed is real
sub-record low-frequency variance, mostly in u.
"""

from __future__ import annotations

import numpy as np
import pytest

FLUXPART_HEIGHT_M = 7.11  # heights.csv, tower height valid 2012-05-07 .. 2012-06-13

mpcalc = pytest.importorskip("metpy.calc", reason="MetPy is the independent implementation")
from dronewind.compare import l4  # noqa: E402
from dronewind.core import filtering, rotation, stats  # noqa: E402
from dronewind.mast import ameriflux, level1  # noqa: E402


def _prepare(u_e, v_n, w_up, t_k):
    """Gap-fill (<= 2 % NaN) and double-rotate one block; None if not usable."""
    filled = []
    n_filled = 0
    for x in (u_e, v_n, w_up, t_k):
        y, n, usable = filtering.gap_fill_linear(np.asarray(x, dtype=float))
        if not usable:
            return None
        filled.append(y)
        n_filled += n
    u, v, w, _ = rotation.double_rotation(*filled[:3])
    return u, v, w, filled[3], n_filled


def _metpy(u, v, w, t):
    us = float(np.squeeze(mpcalc.friction_velocity(u, w, v=v)))
    wt = float(np.squeeze(mpcalc.kinematic_flux(w, t)))
    sw = float(np.sqrt(np.squeeze(mpcalc.kinematic_flux(w, w))))
    tke = float(np.squeeze(mpcalc.tke(u, v, w)))
    ell = -(us**3) * float(np.mean(t)) / (9.81 * 0.40 * wt)  # Eq. 9 written out independently
    return np.array([us, sw, wt, ell, tke])


def _dronewind(u, v, w, t, method):
    uw, vw = stats.covariance(u, w, method), stats.covariance(v, w, method)
    us = stats.friction_velocity(uw, vw)
    wt = stats.covariance(w, t, method)
    sw = stats.standard_deviation(w, method)
    tke = stats.turbulent_kinetic_energy(stats.standard_deviation(u, method), stats.standard_deviation(v, method), sw)
    return np.array([us, sw, wt, stats.obukhov_length(us, wt, np.mean(t)), tke], dtype=float)


@pytest.fixture(scope="module")
def gold_blocks(real_record):
    gold = real_record("ameriflux_gold_openpath")
    blocks, unusable = [], []
    for ds in ameriflux.read_ameriflux_gold_blocks([gold]):
        prepared = _prepare(ds["u_east_ms"].values, ds["v_north_ms"].values, ds["w_up_ms"].values,
                            ds["t_sonic_k"].values)
        if prepared is None:
            unusable.append(ds.attrs.get("source_file"))
        else:
            blocks.append((ds.attrs.get("source_file"), ds.attrs["sampling_rate_hz"], ds.attrs["height_m"], prepared))
    return blocks, unusable


@pytest.fixture(scope="module")
def gold_table(gold_blocks):
    blocks, _ = gold_blocks
    mp = np.array([_metpy(*b[3][:4]) for b in blocks])
    const = np.array([_dronewind(*b[3][:4], "constant") for b in blocks])
    lin = np.array([_dronewind(*b[3][:4], "linear") for b in blocks])
    return mp, const, lin


def test_gold_all_blocks_read(gold_blocks) -> None:
    blocks, unusable = gold_blocks
    assert len(blocks) + len(unusable) == 96
    assert len(unusable) == 0, unusable  # every gold half-hour has < 2 % flagged samples


def test_gold_block_mean_statistics_equal_metpy(gold_table) -> None:
    mp, const, _ = gold_table
    # u*, sigma_w, TKE: same arithmetic -> 1e-14; w'T' and L: MetPy's one-pass covariance
    # cancels digits at T ~ 294 K (measured max 1.4e-12) -> 1e-10
    np.testing.assert_allclose(const[:, [0, 1, 4]], mp[:, [0, 1, 4]], rtol=1e-12)
    np.testing.assert_allclose(const[:, [2, 3]], mp[:, [2, 3]], rtol=1e-10)


def test_gold_linear_detrend_close_to_metpy(gold_table) -> None:
    """L4 statistics (linear detrend) vs MetPy (block mean): measured medians u* 1.0 %,
    sigma_w 0.05 % (max 1.9 %), w'T' 3.0 %, L 4.5 %; bounds set ~2x above."""
    mp, _, lin = gold_table
    rel = np.abs(lin / mp - 1)
    assert np.median(rel[:, 0]) < 0.02
    assert np.max(rel[:, 1]) < 0.04
    assert np.median(rel[:, 2]) < 0.06
    assert np.median(rel[:, 3]) < 0.10
    assert np.all(np.sign(lin[:, 3]) == np.sign(mp[:, 3]))  # stability class never flips


def test_gold_surface_layer_similarity(gold_table) -> None:
    """Near-neutral blocks (|z/L| < 0.1, z = 2 m): sigma_w/u* = 1.25 +- 0.2 expected
    (Panofsky and Dutton 1984; Kaimal and Finnigan 1994); checks the sign and scale of
    the whole chain (reader frame, rotation, statistics) on real data."""
    mp, _, lin = gold_table
    zeta = 2.0 / lin[:, 3]
    neutral = np.abs(zeta) < 0.1
    assert neutral.sum() >= 5
    ratio = np.median(lin[neutral, 1] / lin[neutral, 0])
    assert 1.0 < ratio < 1.6
    # daytime convective blocks: w'T' > 0 <=> L < 0
    assert np.all((lin[:, 2] > 0) == (lin[:, 3] < 0))


def test_gold_l4_subset_no_silent_numbers(gold_blocks) -> None:
    """Full L4 (spectra, fits, scales, uncertainties) on every 4th gold block (24).

    Invariant: each quantity with a status is finite iff its status is 0 ("ok"), apart
    from ratios with a truncated band (ok + reason). Quadrant ratios exist only for U > 2.
    """
    blocks, _ = gold_blocks
    pairs = {"Sw_Su": "status_Sw_Su", "L_u_m": "status_L_u", "T_w_s": "status_T_w", "fit_a_w": "status_fit_w",
             "a_wT": "status_a_wT", "L_m": "status_obukhov"}
    n_ratio = 0
    for _, fs_hz, z_m, (u, v, w, t, _) in blocks[::4]:
        ds = l4.record_l4(u, v, w, t, fs_hz, z_m)
        for value, status in pairs.items():
            val, flag = float(ds[value]), int(ds[status])
            if flag == 0:
                assert np.isfinite(val), (value, ds[status].attrs["reason"])
            elif flag != l4.STATUS_FLAG_MEANINGS.index("above_uncertainty_threshold"):
                assert np.isnan(val), (value, flag)
                assert ds[status].attrs["reason"], value
        if float(ds["U_ms"]) > 2.0:
            n_ratio += 1
            assert np.isfinite(float(ds["Sw_Su"]))
            # 2 m height: the band 2 < f_r < 10 reaches past the 5 Hz Nyquist frequency
            assert "truncated" in ds["Sw_Su"].attrs["reason"]
        else:
            assert np.isnan(float(ds["Sw_Su"]))
        assert float(ds["u_star_ms"]) == pytest.approx(float(stats.friction_velocity(
            stats.covariance(u, w), stats.covariance(v, w))))
    assert n_ratio >= 5


@pytest.fixture(scope="module")
def fluxpart(real_record):
    files = sorted(real_record("fluxpart_csat3_toa5").glob("TOA5_*.dat"))
    # the CSAT3 azimuth is not documented; 0 is used: after double rotation the
    # streamline components do not depend on it
    ds = level1.mast_l1(files, azimuth_deg=0.0, height_m=FLUXPART_HEIGHT_M, sensor_id="fluxpart")
    return ds


def test_fluxpart_blocks_equal_metpy_and_l4_runs(fluxpart) -> None:
    ds = fluxpart
    fs_hz = ds.attrs["sampling_rate_hz"]
    assert fs_hz == pytest.approx(20.0)
    n = ds.sizes["time"]
    assert n == 36000
    half = n // 2
    results = []
    for sl in (slice(0, half), slice(half, n), slice(0, n)):  # 2 x 15 min and the 30 min
        prepared = _prepare(*(ds[k].values[sl] for k in ("u_east_ms", "v_north_ms", "w_up_ms", "t_sonic_k")))
        assert prepared is not None
        u, v, w, t, n_filled = prepared
        assert n_filled <= ds.attrs["n_flagged"] * 4
        mp = _metpy(u, v, w, t)
        np.testing.assert_allclose(_dronewind(u, v, w, t, "constant"), mp, rtol=1e-10)
        lin = _dronewind(u, v, w, t, "linear")
        assert lin[0] == pytest.approx(mp[0], rel=0.05)
        assert lin[1] == pytest.approx(mp[1], rel=0.02)
        out = l4.record_l4(u, v, w, t, fs_hz, FLUXPART_HEIGHT_M)
        results.append(out)
        assert int(out["status_statistics"]) == 0 and int(out["status_spectra"]) == 0
        # midday over a crop: upward buoyancy flux, unstable
        assert float(out["wT_Kms"]) > 0 and float(out["L_m"]) < 0
    for name in ("sigma_w_ms", "u_star_ms"):
        v15 = [float(r[name]) for r in results[:2]]
        assert min(v15) * 0.7 < float(results[2][name]) < max(v15) * 1.3
