"""Tower and mast records in blocks (dronewind.compare.blocks): known answers per block.

The synthetic records are built so that every block's statistics are known exactly: the
fluctuations of each block are made orthogonal to a constant and a line in time and then
coloured to a prescribed sample covariance (divisor n, as the L4), so neither detrending
changes them and the double rotation recovers the streamline frame to rounding. The
tolerances are therefore rounding-level (1e-9 relative), except the spectral ratio, which
is a Welch estimate (see its test).
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from dronewind.compare import blocks as blk
from dronewind.core import rotation as rot
from dronewind.core.constants import GRAVITY_MS2, KARMAN

FS_HZ = 10.0
HEIGHT_M = 10.0
T0_K = 293.15


def _exact_fluctuations(rng: np.random.Generator, n: int, cov: np.ndarray) -> np.ndarray:
    """(n, 4) zero-mean series, orthogonal to a line in time, with sample covariance exactly ``cov``."""
    z = rng.normal(size=(n, cov.shape[0]))
    basis = np.column_stack([np.ones(n), np.linspace(-1.0, 1.0, n)])
    z -= basis @ np.linalg.lstsq(basis, z, rcond=None)[0]
    s = z.T @ z / n
    z = z @ np.linalg.inv(np.linalg.cholesky(s)).T  # sample covariance = identity
    return z @ np.linalg.cholesky(cov).T


def _cov(su: float, sv: float, sw: float, st: float, uw: float, vw: float, wt: float) -> np.ndarray:
    return np.array([[su**2, 0.0, uw, 0.0], [0.0, sv**2, vw, 0.0], [uw, vw, sw**2, wt], [0.0, 0.0, wt, st**2]])


def _to_enu(u: np.ndarray, v: np.ndarray, wind_from_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Streamline (u along the mean wind, v to its left) to east/north for a wind from ``wind_from_deg``."""
    beta = np.deg2rad(wind_from_deg + 180.0)  # direction the wind blows to
    return u * np.sin(beta) - v * np.cos(beta), u * np.cos(beta) + v * np.sin(beta)


def make_l1(blocks: list[dict], start: str = "2023-08-21T10:00:00", block_s: float = 600.0,
            seed: int = 0) -> xr.Dataset:
    """A mast L1 of consecutive blocks with known mean speed, direction and covariance each."""
    rng = np.random.default_rng(seed)
    n = int(block_s * FS_HZ)
    cols = []
    for b in blocks:
        x = _exact_fluctuations(rng, n, b["cov"])
        u = b["U"] + x[:, 0] + b.get("trend_u", 0.0) * (np.arange(n) - (n - 1) / 2) / FS_HZ
        ue, vn = _to_enu(u, x[:, 1], b["wind_from"])
        cols.append(np.column_stack([ue, vn, x[:, 2], T0_K + x[:, 3]]))
    data = np.vstack(cols)
    t = np.datetime64(start, "ns") + (np.arange(data.shape[0]) * int(1e9 / FS_HZ)).astype("timedelta64[ns]")
    return xr.Dataset({k: ("time", data[:, j]) for j, k in enumerate(("u_east_ms", "v_north_ms", "w_up_ms",
                                                                        "t_sonic_k"))},
                      coords={"time": t}, attrs={"sampling_rate_hz": FS_HZ, "height_m": HEIGHT_M, "sensor_id": "m10"})


BLOCKS = [
    {"U": 5.0, "wind_from": 230.0, "cov": _cov(0.9, 0.7, 0.45, 0.2, -0.12, 0.02, 0.03)},
    {"U": 3.0, "wind_from": 40.0, "cov": _cov(0.6, 0.6, 0.30, 0.1, -0.05, -0.01, -0.006)},
]


def _settings(**kw) -> blk.BlockSettings:
    return blk.BlockSettings.from_processing({"block_s": 600.0, **kw})


@pytest.mark.parametrize("detrending", ["linear", "block_mean"])
def test_block_statistics_recover_known_moments(detrending):
    l1 = make_l1(BLOCKS)
    l4s = blk.record_blocks(l1, _settings(detrending=detrending))
    assert len(l4s) == 2
    for l4, b in zip(l4s, BLOCKS, strict=True):
        row = blk.block_stats_row(l4, "tower", "m10")
        c = b["cov"]
        ustar = (c[0, 2] ** 2 + c[1, 2] ** 2) ** 0.25
        ell = -(ustar**3) * T0_K / (KARMAN * GRAVITY_MS2 * c[2, 3])  # Ghirardelli et al. (2025) Eq. 9
        expected = {"U_ms": b["U"], "wind_from_deg": b["wind_from"], "sigma_u_ms": np.sqrt(c[0, 0]),
                    "sigma_v_ms": np.sqrt(c[1, 1]), "sigma_w_ms": np.sqrt(c[2, 2]), "ustar_ms": ustar,
                    "uw_m2s2": c[0, 2], "wT_Kms": c[2, 3], "L_m": ell, "zeta": HEIGHT_M / ell, "height_m": HEIGHT_M}
        for key, value in expected.items():
            assert row[key] == pytest.approx(value, rel=1e-9), key
        assert row["usable"] is True and row["reason"] == ""
        assert row["missing_fraction"] == 0.0
        assert list(row) == list(blk.BLOCK_STATS_COLUMNS)


def test_spectral_ratio_of_white_noise_is_the_variance_ratio():
    """White fluctuations have flat spectra, so <S_w/S_u> = sigma_w^2 / sigma_u^2. Tolerance 10 %: the
    band f_r 2-10 (1-5 Hz at U = 5 m/s, z = 10 m) holds about 1200 raw Welch estimates of 3 segments each,
    log-binned; measured over seeds 0-5: -1.1 % to +4.5 % (the ratio of noisy estimates has a small positive bias)."""
    l4 = blk.record_blocks(make_l1(BLOCKS[:1]), _settings())[0]
    c = BLOCKS[0]["cov"]
    assert float(l4["Sw_Su"]) == pytest.approx(c[2, 2] / c[0, 0], rel=0.10)
    assert int(l4["status_Sw_Su"]) == 0


def test_blocks_align_to_utc_multiples():
    """A record from 10:13:20 for 70 min in 30-min blocks: 10:00, 10:30, 11:00; the partial ones unusable."""
    l1 = make_l1([BLOCKS[0]] * 7, start="2023-08-21T10:13:20", block_s=600.0)
    table = blk.block_stats_table([blk.block_stats_row(x, "tower", "m10")
                               for x in blk.record_blocks(l1, blk.BlockSettings.from_processing({}))])
    assert table["start_utc"].tolist() == ["2023-08-21T10:00:00Z", "2023-08-21T10:30:00Z", "2023-08-21T11:00:00Z"]
    assert table["end_utc"].tolist() == ["2023-08-21T10:30:00Z", "2023-08-21T11:00:00Z", "2023-08-21T11:30:00Z"]
    assert table["usable"].tolist() == [False, True, False]
    assert table["missing_fraction"].tolist() == pytest.approx([800 / 1800, 0.0, 400 / 1800])
    assert "missing fraction 0.4444 > processing.max_missing_fraction 0.02" in table["reason"][0]
    assert np.isnan(table["sigma_w_ms"][0]) and np.isfinite(table["sigma_w_ms"][1])
    # 10-min blocks start at 10:10
    starts = [b.start for b in blk.iter_blocks(l1["time"].values, 600.0)]
    assert str(starts[0]).startswith("2023-08-21T10:10:00")


def test_gap_above_limit_unusable_with_reason_below_limit_filled():
    l1 = make_l1(BLOCKS)
    l1["u_east_ms"].values[1000:1180] = np.nan  # 180 of 6000 = 3 % of block 1
    l1["t_sonic_k"].values[7000:7060] = np.nan  # 60 of 6000 = 1 % of block 2
    first, second = blk.record_blocks(l1, _settings())
    assert first.attrs["usable"] == 0
    assert first.attrs["unusable_reason"] == ("missing fraction 0.0300 > processing.max_missing_fraction 0.02 "
                                              "(180 of 6000 samples of the 600 s block absent or flagged)")
    assert np.isnan(float(first["sigma_u_ms"]))
    assert second.attrs["usable"] == 1 and second.attrs["n_gap_filled"] == 60
    assert float(second["sigma_w_ms"]) == pytest.approx(np.sqrt(BLOCKS[1]["cov"][2, 2]), rel=1e-9)  # w untouched
    # a looser limit fills the first block
    first_loose = blk.record_blocks(l1, _settings(max_missing_fraction=0.05))[0]
    assert first_loose.attrs["usable"] == 1 and first_loose.attrs["n_gap_filled"] == 180


@pytest.mark.slow
def test_too_few_samples_unusable_with_reason():
    l1 = make_l1(BLOCKS[:1])
    l4 = blk.record_blocks(l1, blk.BlockSettings.from_processing({"block_s": 1.0}))[0]  # 10 samples a block
    assert l4.attrs["usable"] == 0
    assert l4.attrs["unusable_reason"].startswith("velocity statistics: record_too_short: 10 samples < 16")


def test_block_mean_and_linear_detrending_differ_by_the_trend():
    """A trend a t in u adds a^2 var(t) to the block-mean variance and nothing to the linear one."""
    a = 0.002  # m s-2: 1.2 m/s over the 10-min block
    l1 = make_l1([{**BLOCKS[0], "trend_u": a}])
    lin = blk.record_blocks(l1, _settings(detrending="linear"))[0]
    bmean = blk.record_blocks(l1, _settings(detrending="block_mean"))[0]
    n = 6000
    var_t = np.var((np.arange(n) - (n - 1) / 2) / FS_HZ)
    c = BLOCKS[0]["cov"]
    assert float(lin["sigma_u_ms"]) == pytest.approx(np.sqrt(c[0, 0]), rel=1e-9)
    assert float(bmean["sigma_u_ms"]) == pytest.approx(np.sqrt(c[0, 0] + a**2 * var_t), rel=1e-9)
    assert float(bmean["uw_m2s2"]) == pytest.approx(c[0, 2], rel=1e-9)  # w' is orthogonal to t
    assert lin.attrs["detrending"].startswith("linear") and bmean.attrs["detrending"].startswith("block mean")


def test_planar_fit_rotation_uses_the_given_fit():
    """With rotation planar_fit, a known tilt (from the fit) is removed and the block keeps its w offset plane."""
    l1 = make_l1(BLOCKS)
    fit = rot.planar_fit_tilt(np.array([5.0, -3.0, 0.0, 2.0]), np.array([0.0, 1.0, -4.0, 3.0]),
                              np.array([0.0, 0.0, 0.0, 0.0]))  # a level plane: no tilt
    pf = blk.record_blocks(l1, _settings(rotation="planar_fit"), fit)
    dbl = blk.record_blocks(l1, _settings())
    for a, b in zip(pf, dbl, strict=True):  # level sonic, zero mean w: planar fit = double rotation
        for key in ("sigma_u_ms", "sigma_w_ms", "uw_m2s2", "wT_Kms", "U_ms"):
            assert float(a[key]) == pytest.approx(float(b[key]), rel=1e-9, abs=1e-12), key
    with pytest.raises(Exception, match="planar_fit"):
        blk.record_blocks(l1, _settings(rotation="planar_fit"))


def test_block_sums_merge_equals_whole_record_block_means():
    rng = np.random.default_rng(3)
    n = 30000
    t = np.datetime64("2023-08-21T10:07:00", "ns") + (np.arange(n) * 100_000_000).astype("timedelta64[ns]")
    u, v, w = rng.normal(5, 1, n), rng.normal(1, 1, n), rng.normal(0.1, 0.3, n)
    u[5000:9000] = np.nan
    whole = rot.block_means(t, u, v, w, fs_hz=FS_HZ)
    cuts = [0, 7777, 18000, 23456, n]
    parts = [rot.block_sums(t[a:b], u[a:b], v[a:b], w[a:b]) for a, b in zip(cuts[:-1], cuts[1:], strict=True)]
    merged = rot.means_of_block_sums(rot.merge_block_sums(parts), FS_HZ)
    for x, y in zip(whole, merged, strict=True):
        np.testing.assert_allclose(x, y, rtol=1e-12)
    assert whole[0].size == 2  # 10:00 and 10:30 blocks, each more than half valid


def test_stacked_blocks_give_the_rows_of_each_block_and_pass_cf(tmp_path):
    """One L4 file per sonic with the blocks along time: its rows are exactly the per-block rows."""
    from dronewind.core.cf import check_compliance
    from dronewind.core.products import open_product
    from dronewind.steps.blocks import block_stats, mast_blocks
    from dronewind.steps.payload import Position, write_product

    l1 = make_l1(BLOCKS)
    l1["u_east_ms"].values[1000:1180] = np.nan  # block 1 unusable (3 % missing): no spectra, padded
    settings = _settings(detrending="block_mean")
    direct = [blk.block_stats_row(b, "p2oa", "m10") for b in blk.record_blocks(l1, settings)]
    for v in ("u_east_ms", "v_north_ms", "w_up_ms"):
        l1[v].attrs = {"units": "m s-1", "standard_name": {"u_east_ms": "eastward_wind", "v_north_ms": "northward_wind",
                                                          "w_up_ms": "upward_air_velocity"}[v]}
    l1["t_sonic_k"].attrs = {"units": "K", "standard_name": "virtual_temperature"}
    sonic = {"id": "m10", "mast_id": "p2oa", "height_m": HEIGHT_M, "latitude": 43.1, "longitude": 0.36}
    l1_file = write_product(l1, tmp_path / "mast_m10.nc", "mast_l1",
                            {"campaign": "t", "sonic": "m10", "mast": "p2oa", "model": "CSAT3", "height_m": HEIGHT_M},
                            Position(43.1, 0.36, HEIGHT_M), [], {})
    out = mast_blocks(l1_file, tmp_path / "L4" / "m10.nc", campaign="t", sonic=sonic,
                      processing={"block_s": 600.0, "detrending": "block_mean"})
    table = tmp_path / "block_stats.csv"
    block_stats([out], table)
    import pandas as pd

    got = pd.read_csv(table, keep_default_na=False)
    assert list(got.columns) == list(blk.BLOCK_STATS_COLUMNS)
    assert list(got["usable"]) == [False, True]
    assert got["reason"][0] == direct[0]["reason"] and got["reason"][1] == ""
    for col in ("U_ms", "sigma_w_ms", "ustar_ms", "wT_Kms", "L_m", "Sw_Su"):
        # the CSV holds 6 significant digits: relative rounding <= 5e-6
        assert float(got[col][1]) == pytest.approx(direct[1][col], rel=6e-6), col
    stored = open_product(out)
    assert stored.attrs["detrending"].startswith("block mean")
    assert stored["frequency"].dims == ("time", "frequency_bin")
    assert np.isnan(stored["S_w"].values[0]).all() and np.isfinite(stored["S_w"].values[1]).any()
    passed, report = check_compliance(out)
    assert passed, report[-2000:]
