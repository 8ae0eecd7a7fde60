"""Tests of the TOA5 / CSAT3 mast reader (dronewind.mast.toa5)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dronewind.errors import InputError
from dronewind.mast.level1 import csat3_to_enu, mast_l1
from dronewind.mast.toa5 import read_toa5
from tests.conftest import needs_record, record_path

HERE = Path(__file__).resolve().parents[1]
SHARED = record_path("fluxpart_csat3_toa5")
EXCERPT = HERE / "data" / "io_excerpts" / "TOA5_6843.ts_Above_2012_06_07_1245_excerpt.dat"

HEADER = [
    '"TOA5","1","CR3000","1","CR3000.Std.22","CPU:x.CR3","1","ts"',
    '"TIMESTAMP","RECORD","Ux","Uy","Uz","Ts","diag_csat"',
    '"TS","RN","m/s","m/s","m/s","C","unitless"',
    '"","","Smp","Smp","Smp","Smp","Smp"',
]


def write_toa5(path: Path, rows: list[str], header: list[str] | None = None) -> Path:
    path.write_text("\r\n".join((header or HEADER) + rows) + "\r\n")
    return path


def synthetic_rows(n: int = 600, fs_hz: float = 10.0, start_record: int = 100,
                   t0: str = "2023-08-21 14:00:00", seed: int = 0) -> list[str]:  # fmt: skip
    """Rows with Campbell's timestamp style: trailing zeros of the fraction dropped."""
    rng = np.random.default_rng(seed)
    base = np.datetime64(t0.replace(" ", "T"), "ms")
    rows = []
    for i in range(n):
        t = base + np.timedelta64(int(round(i * 1000 / fs_hz)), "ms")
        s = str(t).replace("T", " ")
        if "." in s:
            s = s.rstrip("0").rstrip(".")
        rows.append(f'"{s}",{start_record + i},{3 + rng.normal(0, .4):.4f},'
                    f'{1 + rng.normal(0, .4):.4f},{rng.normal(0, .2):.4f},'
                    f'{22 + rng.normal(0, .1):.4f},0')  # fmt: skip
    return rows


# ------------------------------------------------------------------------- known answers


@pytest.mark.parametrize(
    ("alpha", "ux", "uy", "east", "north"),
    [
        (0.0, 1.0, 0.0, 0.0, -1.0),  # head points north, wind from north -> blows south
        (90.0, 1.0, 0.0, -1.0, 0.0),  # head points east, wind from east -> blows west
        (0.0, 0.0, 1.0, 1.0, 0.0),  # Uy > 0 at alpha 0: wind from the west
        (218.0, 2.0, -1.0, -2 * np.sin(np.radians(218)) - np.cos(np.radians(218)),
         -2 * np.cos(np.radians(218)) + np.sin(np.radians(218))),
    ],
)  # fmt: skip
def test_csat3_to_enu(alpha, ux, uy, east, north):
    e, n = csat3_to_enu(np.array([ux]), np.array([uy]), alpha)
    np.testing.assert_allclose([e[0], n[0]], [east, north], atol=1e-12)
    # wind-from direction (docs/data-contract.md): alpha - atan2(Uy, Ux)
    if ux or uy:
        wd = (alpha - np.degrees(np.arctan2(uy, ux))) % 360
        np.testing.assert_allclose(np.degrees(np.arctan2(-e[0], -n[0])) % 360, wd, atol=1e-9)


# ------------------------------------------------------------------------ synthetic files


def test_synthetic_toa5_all_details(tmp_path):
    rows = synthetic_rows(600)
    assert '"2023-08-21 14:00:00.1"' in rows[1] and '"2023-08-21 14:00:01"' in rows[10]
    rows[50] = rows[50].rsplit(",", 5)[0] + ',"NAN","NAN","NAN","NAN",0'
    rows[60] = rows[60][: rows[60].rfind(",")] + ",61440"  # diag: bad, e.g. lost trigger
    del rows[100]  # RECORD skip and a missing time stamp; later list indices shift by 1
    rows[200] = rows[200].replace(rows[200].split(",")[2], "70.0", 1)  # Ux out of range (t 201)
    rows[300] = rows[300].split(",")[0] + ",bad,1,2"  # corrupt line (time stamp 301)
    p = write_toa5(tmp_path / "m.dat", rows)
    ds = mast_l1(p, azimuth_deg=218.0, height_m=30.0, sensor_id="mast30")
    assert ds.attrs["sampling_rate_hz"] == 10.0
    assert ds.sizes["time"] == 600
    assert ds.attrs["n_record_skips"] == 2  # row 100 deleted + corrupt row 300 removed
    assert ds.attrs["n_corrupt_lines"] == 1
    assert ds.attrs["n_missing"] == 2
    assert ds.attrs["n_nan_values"] == 1
    assert ds.attrs["n_diag_flagged"] == 1
    assert ds.attrs["n_out_of_range"] == 1
    qc = ds.qc_mast.values
    assert qc[50] & 4 and qc[60] & 16 and qc[100] & 4 and qc[201] & 1 and qc[301] & 4
    assert ds.diag_csat.values[60] == 61440 and ds.diag_csat.values[100] == -1
    flagged = qc != 0
    assert np.isnan(ds.u_east_ms.values[flagged]).all()
    assert np.isfinite(ds.u_east_ms.values[~flagged]).all()
    assert ds.ux_ms.values[201] == 70.0  # raw kept as logged
    e, n = csat3_to_enu(ds.ux_ms.values, ds.uy_ms.values, 218.0)
    np.testing.assert_allclose(ds.u_east_ms.values[~flagged], e[~flagged])
    np.testing.assert_allclose(ds.t_sonic_k.values[0], float(rows[0].split(",")[5]) + 273.15)
    assert ds.time.values[1] - ds.time.values[0] == np.timedelta64(100, "ms")
    assert ds.attrs["azimuth_deg"] == 218.0 and ds.attrs["sensor_id"] == "mast30"
    assert ds.u_east_ms.attrs["standard_name"] == "eastward_wind"
    assert ds.qc_mast.attrs["standard_name"] == "status_flag"
    assert "RECORD" in ds.attrs["processing_log"]


def test_files_concatenated_in_time_order(tmp_path):
    rows = synthetic_rows(400, fs_hz=20.0)
    a = write_toa5(tmp_path / "b_first.dat", rows[:200])
    b = write_toa5(tmp_path / "a_second.dat", rows[200:])
    c = write_toa5(tmp_path / "c_overlap.dat", rows[190:210])  # exact duplicates
    ds = mast_l1([b, c, a], 0.0, 10.0, "s")
    assert ds.sizes["time"] == 400
    assert ds.attrs["n_duplicates"] == 20
    assert ds.attrs["sampling_rate_hz"] == 20.0
    assert (np.diff(ds.time.values) == np.timedelta64(50, "ms")).all()
    ds_glob = mast_l1(str(tmp_path / "*.dat"), 0.0, 10.0, "s")
    np.testing.assert_array_equal(ds_glob.ux_ms.values, ds.ux_ms.values)


def test_records_days_apart_stay_separate_segments(tmp_path):
    """One file per flight on different days: the gap is a break, not a day of NaN samples."""
    a = write_toa5(tmp_path / "day1.dat", synthetic_rows(300, t0="2023-08-21 14:00:00"))
    # day 1 ends at 14:00:29.9; this file starts 10 s later: a short gap, filled with missing samples
    b = write_toa5(tmp_path / "day1b.dat", synthetic_rows(100, t0="2023-08-21 14:00:40", start_record=1000, seed=2))
    c = write_toa5(tmp_path / "day2.dat", synthetic_rows(300, t0="2023-12-13 07:00:00.05", seed=3))  # other phase
    ds = mast_l1([a, b, c], 0.0, 10.0, "s")
    assert ds.attrs["n_record_breaks"] == 1
    assert ds.attrs["n_missing"] == 100  # the 10 s gap on day 1 is filled with missing samples
    assert ds.sizes["time"] == 300 + 100 + 100 + 300
    t = ds.time.values
    assert (np.diff(t) > np.timedelta64(0)).all()
    assert t[-300] == np.datetime64("2023-12-13T07:00:00.050")  # grid phase restarts after the break
    assert "1 record breaks" in ds.attrs["processing_log"]


def test_missing_column_raises(tmp_path):
    header = [HEADER[0], HEADER[1].replace(',"Uz"', ""), HEADER[2], HEADER[3]]
    rows = [",".join(r.split(",")[:4] + r.split(",")[5:]) for r in synthetic_rows(20)]
    p = write_toa5(tmp_path / "changed.dat", rows, header)
    with pytest.raises(InputError, match=r"changed\.dat:2: required column\(s\) Uz missing"):
        mast_l1(p, 0.0, 1.0, "s")


def test_not_toa5_raises(tmp_path):
    p = write_toa5(tmp_path / "x.dat", synthetic_rows(5), ['"TOB1","1"', *HEADER[1:]])
    with pytest.raises(InputError, match=r"x\.dat:1.*TOA5"):
        read_toa5(p)


def test_too_many_corrupt_rows_raise(tmp_path):
    rows = synthetic_rows(100)
    for i in range(10, 16):  # 6 % of the rows
        rows[i] = '"not a time",1,2,3,4,5,0'
    p = write_toa5(tmp_path / "c.dat", rows)
    with pytest.raises(InputError, match=r"c\.dat:15: 6 of 100 data rows corrupt"):
        read_toa5(p)


def test_spike_flagged(tmp_path):
    rows = synthetic_rows(1200)
    parts = rows[700].split(",")
    parts[4] = "3.5"  # Uz spike: 17 sigma, inside the CSAT3 range
    rows[700] = ",".join(parts)
    ds = mast_l1(write_toa5(tmp_path / "s.dat", rows), 0.0, 1.0, "s")
    assert ds.attrs["n_spikes"] == 1
    assert ds.qc_mast.values[700] == 2


# ----------------------------------------------------------------------------- real files


def test_excerpt_of_real_toa5():
    frame, info = read_toa5(EXCERPT)
    assert len(frame) == 200 and info["n_corrupt_lines"] == 0
    assert info["units"]["Ts"] == "C"
    ds = mast_l1(EXCERPT, 0.0, 7.11, "fluxpart")
    assert ds.attrs["sampling_rate_hz"] == 20.0
    assert str(ds.time.values[0]) == "2012-06-07T12:45:00.050000000"
    np.testing.assert_allclose(ds.ux_ms.values[:2], [2.00875, 2.0785])
    np.testing.assert_allclose(ds.t_sonic_k.values[0], 27.65771 + 273.15)


@needs_record("fluxpart_csat3_toa5")
def test_real_fluxpart_files():
    files = sorted(SHARED.glob("TOA5_*.dat"))
    assert len(files) == 2
    ds = mast_l1(files[::-1], azimuth_deg=0.0, height_m=7.11, sensor_id="fluxpart")
    # 2 files x 18000 rows at 20 Hz, 12:45:00.05 .. 13:15:00.00, no gaps, no NAN, diag 0
    assert ds.sizes["time"] == 36000
    assert ds.attrs["sampling_rate_hz"] == 20.0
    assert str(ds.time.values[0]) == "2012-06-07T12:45:00.050000000"
    assert str(ds.time.values[-1]) == "2012-06-07T13:15:00.000000000"
    for key in ("n_corrupt_lines", "n_record_skips", "n_record_restarts", "n_missing",
                "n_nan_values", "n_diag_flagged", "n_out_of_range", "n_duplicates"):  # fmt: skip
        assert ds.attrs[key] == 0, key
    for v in ("ux_ms", "uy_ms", "uz_ms"):
        assert np.isfinite(ds[v].values).all()
    # only moving-MAD spikes are NaN in the derived variables (measured: 46, mostly sharp
    # sonic-temperature ramps); they must stay a small fraction
    assert ds.attrs["n_flagged"] == ds.attrs["n_spikes"]
    assert ds.attrs["n_spikes"] < 0.005 * 36000
    assert int(np.isnan(ds.u_east_ms.values).sum()) == ds.attrs["n_flagged"]
    # azimuth 0: u_east = Uy, v_north = -Ux
    ok = ds.qc_mast.values == 0
    np.testing.assert_allclose(ds.u_east_ms.values[ok], ds.uy_ms.values[ok])
    np.testing.assert_allclose(ds.v_north_ms.values[ok], -ds.ux_ms.values[ok])
