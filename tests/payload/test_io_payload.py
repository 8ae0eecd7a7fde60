"""Tests of the payload sonic / INS readers (dronewind.payload.reader, .clock, .ins, .sonic) on synthetic files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dronewind.errors import InputError
from dronewind.payload.clock import fit_logger_clock
from dronewind.payload.ins import ins_l1
from dronewind.payload.reader import ClockJumpError, read_ins_csv, read_sonic_csv
from dronewind.payload.sonic import payload_sonic_l1

RPI0_US = 1_234_567_890  # logger clock at the start of the synthetic flight [us]
UTC0 = np.datetime64("2023-08-21T14:05:00.000000", "ns")
DRIFT_PPM = 37.3  # UTC runs faster than the logger clock by 37.3 ppm
OFFSET_S = 0.3217  # UTC at RPI0_US minus UTC0


def true_utc(rpi_us: np.ndarray) -> np.ndarray:
    """Exact UTC (ns) of logger times, the mapping the clock fit must recover."""
    dt_s = (np.asarray(rpi_us, dtype=np.int64) - RPI0_US) / 1e6
    ns = np.rint((OFFSET_S + dt_s * (1 + DRIFT_PPM * 1e-6)) * 1e9).astype(np.int64)
    return UTC0 + ns.astype("timedelta64[ns]")


def to_us(t: np.ndarray) -> np.ndarray:
    """Round datetime64[ns] to microseconds (the resolution of the logged UTC strings)."""
    ns = t.astype("datetime64[ns]").astype(np.int64)
    return (np.rint(ns / 1000).astype(np.int64)).astype("datetime64[us]")


def utc_str(t: np.ndarray) -> list[str]:
    return [s + "Z" for s in np.datetime_as_string(to_us(t), unit="us")]


def make_ins_rows(duration_s: float = 60.0, fs_hz: float = 50.0, seed: int = 1,
                  invalid_s: float = 5.0, yaw_360: bool = False) -> list[list[str]]:  # fmt: skip
    """INS rows: GNSS time invalid for `invalid_s` (with a 2 s blink to valid), then valid."""
    rng = np.random.default_rng(seed)
    n = int(duration_s * fs_hz)
    t_s = np.arange(n) / fs_hz
    rpi = RPI0_US + np.rint(t_s * 1e6).astype(np.int64) + rng.integers(-200, 200, n)
    valid = (t_s >= invalid_s) | ((t_s >= 1.0) & (t_s < 3.0))
    utc = utc_str(true_utc(rpi))
    yaw = 175.0 + 10 * np.sin(2 * np.pi * t_s / 30.0)
    yaw = np.where(yaw > 180, yaw - 360, yaw)
    if yaw_360:
        yaw = np.mod(yaw, 360.0)
    rows = []
    for i in range(n):
        rows.append([
            str(rpi[i]), utc[i] if valid[i] else "", str(int(valid[i])), "1",
            f"{43.1247 + rng.normal(0, 1e-6):.8f}", f"{0.3628 + rng.normal(0, 1e-6):.8f}",
            f"{633 + rng.normal(0, 0.2):.3f}", f"{rng.normal(0, 0.3):.4f}",
            f"{rng.normal(0, 0.3):.4f}", f"{rng.normal(0, 0.1):.4f}",
            f"{rng.normal(0, 2):.3f}", f"{rng.normal(0, 2):.3f}", f"{yaw[i]:.3f}",
        ])  # fmt: skip
    return rows


def make_sonic_rows(duration_s: float = 60.0, fs_hz: float = 32.0, seed: int = 2
                    ) -> list[list[str]]:  # fmt: skip
    rng = np.random.default_rng(seed)
    n = int(duration_s * fs_hz)
    rpi = RPI0_US + np.rint(np.arange(n) / fs_hz * 1e6).astype(np.int64)
    rpi += rng.integers(-300, 300, n)  # logging jitter [us]
    u = 5 + rng.normal(0, 0.5, n)
    v = -1 + rng.normal(0, 0.5, n)
    w = rng.normal(0, 0.3, n)
    tc = 20 + rng.normal(0, 0.2, n)
    return [[str(rpi[i]), f"{u[i]:.3f}", f"{v[i]:.3f}", f"{w[i]:.3f}", f"{tc[i]:.3f}"]
            for i in range(n)]  # fmt: skip


SONIC_HEADER = "rpi_time_us,u_ms,v_ms,w_ms,t_sonic_c"
INS_HEADER = ("rpi_time_us,utc,time_valid,ekf_valid,lat_deg,lon_deg,alt_m,vel_n_ms,vel_e_ms,"
              "vel_d_ms,roll_deg,pitch_deg,yaw_deg")  # fmt: skip


def write_csv(path: Path, header: str, rows: list) -> Path:
    lines = [header] + [r if isinstance(r, str) else ",".join(r) for r in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture()
def flight(tmp_path: Path) -> tuple[Path, Path, list, list]:
    sonic_rows = make_sonic_rows()
    ins_rows = make_ins_rows()
    s = write_csv(tmp_path / "sonic.csv", SONIC_HEADER, sonic_rows)
    i = write_csv(tmp_path / "ins.csv", INS_HEADER, ins_rows)
    return s, i, sonic_rows, ins_rows


# ------------------------------------------------------------------------- clean files


def test_clean_flight_clock_and_counts(flight):
    sonic, ins, sonic_rows, _ = flight
    ds = payload_sonic_l1(sonic, ins)
    rpi = np.array([int(r[0]) for r in sonic_rows])
    # Sonic rows before the stable GNSS time (t < 5 s, 32 Hz) are discarded; the 2 s blink
    # to time_valid=1 (1-3 s) is not stable.
    stable_rpi = RPI0_US + 5_000_000
    assert ds.attrs["n_before_stable_time"] == int((rpi < stable_rpi).sum())
    assert ds.attrs["n_ins_before_stable_time"] == 250
    kept = rpi[rpi >= stable_rpi]
    np.testing.assert_array_equal(ds.rpi_time_us.values, kept)
    # UTC recovered from the fit: the UTC strings have 1 us resolution, 2750 points over
    # 55 s, so the fit error is far below 1 us; allow 1 us.
    err_ns = (ds.time.values - true_utc(kept)).astype(np.int64)
    assert np.abs(err_ns).max() <= 1000
    assert (ds.time.values.astype(np.int64) % 1000 == 0).all()  # rounded to whole us
    assert abs(ds.attrs["clock_drift_ppm"] - DRIFT_PPM) < 0.01
    # residuals = 1 us quantisation of the UTC strings: std 1/sqrt(12) us = 0.29 us
    assert 0.1e-6 < ds.attrs["clock_residual_std_s"] < 0.5e-6
    for key in ("n_corrupt_lines", "n_duplicates", "n_out_of_order", "n_missing",
                "n_out_of_range", "n_spikes", "n_time_conflicts"):  # fmt: skip
        assert ds.attrs[key] == 0, key
    assert ds.attrs["sampling_rate_hz"] == 32.0
    assert (ds.qc_sonic.values == 0).all()
    assert np.isfinite(ds.u_sensor_ms.values).all()
    np.testing.assert_allclose(ds.t_sonic_k.values.mean(), 293.15, atol=0.02)
    assert ds.t_sonic_k.attrs["standard_name"] == "virtual_temperature"
    assert ds.qc_sonic.attrs["standard_name"] == "status_flag"
    assert "gnss_time" in ds.attrs["processing_log"]
    assert ds.time.dtype == np.dtype("datetime64[ns]")
    assert (np.diff(ds.time.values).astype(np.int64) > 0).all()


def test_ins_l1_clean(flight):
    _, ins, _, ins_rows = flight
    ds = ins_l1(ins)
    assert ds.sizes["time"] == len(ins_rows) - 250
    assert ds.attrs["n_before_stable_time"] == 250
    assert ds.attrs["sampling_rate_hz"] == 50.0
    for v in ("roll_deg", "pitch_deg", "yaw_deg", "vel_n_ms", "vel_e_ms", "vel_d_ms",
              "lat_deg", "lon_deg", "alt_m", "ekf_valid", "rpi_time_us", "qc_ins"):  # fmt: skip
        assert v in ds, v
        assert "units" in ds[v].attrs
    # time is the logged utc column
    expect = to_us(true_utc(ds.rpi_time_us.values)).astype("datetime64[ns]")
    np.testing.assert_array_equal(ds.time.values, expect)
    assert ds.yaw_deg.attrs["standard_name"] == "platform_yaw"
    assert "(-180, 180]" in ds.yaw_deg.attrs["comment"]


def test_ins_yaw_0_360_accepted(tmp_path):
    ins = write_csv(tmp_path / "ins.csv", INS_HEADER, make_ins_rows(yaw_360=True))
    ds = ins_l1(ins)
    assert ds.attrs["n_out_of_range"] == 0
    assert float(ds.yaw_deg.max()) > 180.0
    assert "[0, 360)" in ds.yaw_deg.attrs["comment"]


# ----------------------------------------------------------------------- bad headers


def test_wrong_header_raises(tmp_path, flight):
    _, ins, sonic_rows, _ = flight
    bad = write_csv(tmp_path / "bad.csv", "rpi_time_us,u,v,w,t", sonic_rows)
    with pytest.raises(InputError, match=r"bad\.csv:1.*expected 5 \(rpi_time_us,u_ms.*missing: u_ms"):
        payload_sonic_l1(bad, ins)
    bad_ins = write_csv(tmp_path / "bad_ins.csv", INS_HEADER.replace("utc,", "gps_time,"),
                        make_ins_rows())  # fmt: skip
    with pytest.raises(InputError, match=r"bad_ins\.csv:1"):
        ins_l1(bad_ins)


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match="not found"):
        read_sonic_csv(tmp_path / "nope.csv")


# ----------------------------------------------------------------------- corrupt lines


def test_few_corrupt_lines_removed_and_counted(tmp_path, flight):
    _, ins, sonic_rows, _ = flight
    rows: list = list(sonic_rows)
    # rows i -> file line i + 2
    rows[300] = "1234,5.0,1.0"  # wrong column count
    rows[400] = rows[400][:1] + ["abc"] + rows[400][2:]  # non-numeric
    rows[500] = rows[500][:1] + ["1.0", "2.0", "3.0", "4.0", "5.0"]  # too many columns
    rows[600] = ["12.5"] + rows[600][1:]  # non-integer time stamp
    rows[700] = ",".join(rows[700])[:7]  # truncated line
    path = write_csv(tmp_path / "s.csv", SONIC_HEADER, rows)
    cols, counts, log = read_sonic_csv(path)
    assert counts["n_corrupt_lines"] == 5
    assert counts["n_lines"] == len(rows)
    assert cols["rpi_time_us"].size == len(rows) - 5
    assert "[302, 402, 502, 602, 702]" in log[0]
    ds = payload_sonic_l1(path, ins)
    assert ds.attrs["n_corrupt_lines"] == 5
    # the removed rows become missing samples on the 32 Hz sequence
    assert ds.attrs["n_missing"] == 5
    assert int(((ds.qc_sonic.values & 4) > 0).sum()) == 5


def test_too_many_corrupt_lines_raise(tmp_path):
    rows: list = make_sonic_rows(duration_s=10)  # 320 rows; 17 corrupt > 5 %
    for i in range(100, 117):
        rows[i] = "garbage"
    path = write_csv(tmp_path / "s.csv", SONIC_HEADER, rows)
    with pytest.raises(InputError, match=r"s\.csv:102: 17 of 320 data lines corrupt"):
        read_sonic_csv(path)
    # 16 corrupt lines (5.0 %) are still accepted
    rows[116] = make_sonic_rows(duration_s=10)[116]
    path = write_csv(tmp_path / "s2.csv", SONIC_HEADER, rows)
    assert read_sonic_csv(path)[1]["n_corrupt_lines"] == 16


def test_ins_time_valid_with_bad_utc_is_corrupt(tmp_path):
    rows = make_ins_rows()
    rows[1000][1] = "2023-13-45T99:00:00Z"
    path = write_csv(tmp_path / "ins.csv", INS_HEADER, rows)
    _, line_no, counts, log = read_ins_csv(path)
    assert counts["n_corrupt_lines"] == 1
    assert 1002 not in line_no
    assert "1002" in log[0]


# ------------------------------------------------------------ duplicates and ordering


def test_duplicates_and_out_of_order(tmp_path, flight):
    _, ins, sonic_rows, _ = flight
    rows = list(sonic_rows)
    dup_idx = [500, 800, 801, 1200]
    rows_dup = rows[:]
    for k, i in enumerate(dup_idx):
        rows_dup.insert(i + 1 + k, rows[i])  # exact duplicates right after the original
    rows_dup.append(rows[1000])  # a far-away exact duplicate at the end of the file
    # two adjacent swaps -> 2 late rows
    rows_dup[1500], rows_dup[1501] = rows_dup[1501], rows_dup[1500]
    rows_dup[1700], rows_dup[1701] = rows_dup[1701], rows_dup[1700]
    # a conflicting row: same time stamp, different values (neither trusted: both dropped)
    conflict = [rows[900][0], "9.9", "9.9", "9.9", "9.9"]
    rows_dup.insert(950, conflict)
    path = write_csv(tmp_path / "s.csv", SONIC_HEADER, rows_dup)
    cols, counts, log = read_sonic_csv(path)
    assert counts["n_duplicates"] == 5
    # two swaps -> 2 late rows; the conflicting rows are dropped before the order check
    assert counts["n_out_of_order"] == 2
    assert counts["n_time_conflicts"] == 2
    assert any("2 rows repeating an rpi_time_us with other values dropped" in line for line in log)
    np.testing.assert_array_equal(cols["rpi_time_us"], [int(r[0]) for r in rows if r is not rows[900]])
    ds = payload_sonic_l1(path, ins)
    assert ds.attrs["n_duplicates"] == 5
    assert ds.attrs["n_missing"] == 1  # the conflicting time stamp becomes a missing sample


def test_out_of_order_counts_late_rows(tmp_path):
    rows = make_sonic_rows(duration_s=10)
    late = rows.pop(100)
    rows.insert(110, late)  # one row arrives 10 samples late
    path = write_csv(tmp_path / "s.csv", SONIC_HEADER, rows)
    cols, counts, _ = read_sonic_csv(path)
    # rows 100..109 (original 101..110) now come before row 100 -> only the late row
    # itself is below the running maximum
    assert counts["n_out_of_order"] == 1
    assert (np.diff(cols["rpi_time_us"]) > 0).all()


# ------------------------------------------------------------------ clock jumps, gaps


def test_backward_clock_jump_raises(tmp_path, flight):
    _, ins, sonic_rows, _ = flight
    rows = [list(r) for r in sonic_rows]
    for r in rows[1000:]:
        r[0] = str(int(r[0]) - 5_000_000)  # logger clock set back by 5 s
    path = write_csv(tmp_path / "s.csv", SONIC_HEADER, rows)
    with pytest.raises(ClockJumpError, match=r"s\.csv:1002: rpi_time_us steps back by 4\.9"):
        payload_sonic_l1(path, ins)


def test_ins_relation_jump_raises(tmp_path, flight):
    sonic, _, _, ins_rows = flight
    rows = [list(r) for r in ins_rows]
    for r in rows[2000:]:
        r[0] = str(int(r[0]) + 2_000_000)  # logger clock jumps forward 2 s, UTC continuous
    path = write_csv(tmp_path / "ins.csv", INS_HEADER, rows)
    with pytest.raises(ClockJumpError, match=r"ins\.csv:2002: the relation utc - rpi_time"):
        ins_l1(path)
    with pytest.raises(ClockJumpError):
        payload_sonic_l1(sonic, path)


def test_forward_gap_is_missing_data(tmp_path, flight):
    _, ins, sonic_rows, _ = flight
    rows = sonic_rows[:1000] + sonic_rows[1064:]  # 2 s of sonic rows lost
    path = write_csv(tmp_path / "s.csv", SONIC_HEADER, rows)
    ds = payload_sonic_l1(path, ins)
    assert ds.attrs["n_missing"] == 64
    assert ds.attrs["n_gaps_over_1s"] == 1
    gap = (ds.qc_sonic.values & 4) > 0
    assert gap.sum() == 64
    assert np.isnan(ds.u_sensor_ms.values[gap]).all()
    # inserted samples are evenly spaced in the gap: steps ~ 1/32 s
    steps = np.diff(ds.rpi_time_us.values)
    assert steps.max() < 1.2e6 / 32


def test_sonic_beyond_ins_span_is_extrapolated_and_counted(tmp_path):
    sonic = write_csv(tmp_path / "s.csv", SONIC_HEADER, make_sonic_rows(duration_s=62.0))
    ins = write_csv(tmp_path / "i.csv", INS_HEADER, make_ins_rows(duration_s=60.0))
    ds = payload_sonic_l1(sonic, ins)
    # sonic rows after the last INS row (~2 s at 32 Hz) keep an extrapolated UTC
    assert 60 <= ds.attrs["n_time_extrapolated"] <= 66
    err = (ds.time.values - true_utc(ds.rpi_time_us.values)).astype(np.int64)
    assert np.abs(err).max() <= 1000


def test_isolated_bad_time_stamp_is_removed(tmp_path, flight):
    _, ins, sonic_rows, _ = flight
    rows = [list(r) for r in sonic_rows]
    rows[800][0] = str(int(rows[800][0]) + 3_600_000_000)  # bit error: +1 h on one row
    path = write_csv(tmp_path / "s.csv", SONIC_HEADER, rows)
    cols, counts, log = read_sonic_csv(path)
    assert counts["n_time_outliers"] == 1
    assert "lines [802]" in " ".join(log)
    ds = payload_sonic_l1(path, ins)
    assert ds.attrs["n_time_outliers"] == 1 and ds.attrs["n_missing"] == 1


def test_implausible_forward_step_raises(tmp_path, flight):
    _, ins, sonic_rows, _ = flight
    rows = [list(r) for r in sonic_rows]
    for r in rows[-3:]:  # the last rows jump 2 h ahead: not a data gap
        r[0] = str(int(r[0]) + 7_200_000_000)
    path = write_csv(tmp_path / "s.csv", SONIC_HEADER, rows)
    with pytest.raises(ClockJumpError, match="steps forward by 7200"):
        payload_sonic_l1(path, ins)


def test_ins_gap_counted(tmp_path):
    rows = make_ins_rows()
    del rows[2000:2100]  # 2 s without INS rows
    ds = ins_l1(write_csv(tmp_path / "ins.csv", INS_HEADER, rows))
    assert ds.attrs["n_gaps_over_1s"] == 1
    assert ds.sizes["time"] == len(rows) - 250


def test_no_stable_gnss_time_raises(tmp_path):
    rows = make_ins_rows(duration_s=30)
    for i, r in enumerate(rows):  # time_valid blinks: 1 s valid, 1 s invalid
        valid = (i // 50) % 2 == 1
        r[2] = str(int(valid))
        if not valid:
            r[1] = ""
    path = write_csv(tmp_path / "ins.csv", INS_HEADER, rows)
    with pytest.raises(InputError, match="no stable valid GNSS time"):
        ins_l1(path)


def test_time_valid_dropout_after_start_uses_fit(tmp_path):
    rows = make_ins_rows()
    for r in rows[1000:1010]:
        r[1], r[2] = "", "0"
    path = write_csv(tmp_path / "ins.csv", INS_HEADER, rows)
    ds = ins_l1(path)
    assert ds.attrs["n_time_from_clock_fit"] == 10
    assert ds.sizes["time"] == len(rows) - 250
    err = (ds.time.values - true_utc(ds.rpi_time_us.values)).astype(np.int64)
    assert np.abs(err).max() <= 1000


# ---------------------------------------------------------------- range and spikes


def test_out_of_range_and_spikes_flagged(tmp_path, flight):
    _, ins, sonic_rows, _ = flight
    rows = [list(r) for r in sonic_rows]
    rows[1000][1] = "45.0"  # speed > 40 m/s (RM Young 81000)
    rows[1100][4] = "60.0"  # sonic T > 50 degC
    rows[1200][3] = "nan"  # missing value
    rows[1300][1] = "11.0"  # spike: u = 5 +- 0.5 -> 12 sigma
    rows[1400][3] = "-4.0"  # spike in w (sigma 0.3)
    path = write_csv(tmp_path / "s.csv", SONIC_HEADER, rows)
    ds = payload_sonic_l1(path, ins)
    n_before = ds.attrs["n_before_stable_time"]
    qc = ds.qc_sonic.values
    idx = {k: k - n_before for k in (1000, 1100, 1200, 1300, 1400)}
    assert qc[idx[1000]] == 1 and qc[idx[1100]] == 1
    assert qc[idx[1200]] == 4
    assert qc[idx[1300]] == 2 and qc[idx[1400]] == 2
    assert ds.attrs["n_out_of_range"] == 2
    assert ds.attrs["n_spikes"] == 2
    assert ds.attrs["n_missing_values"] == 1
    assert ds.attrs["n_flagged"] == 5
    assert int((qc != 0).sum()) == 5
    for i in idx.values():
        assert np.isnan(ds.u_sensor_ms.values[i]) and np.isnan(ds.t_sonic_k.values[i])


# ------------------------------------------------------------------------ clock fit


def test_fit_logger_clock_known_answer_with_outliers():
    rng = np.random.default_rng(3)
    rpi = RPI0_US + np.sort(rng.integers(0, 1_200_000_000, 60_000))  # 20 min, irregular
    utc = to_us(true_utc(rpi))  # 1 us quantisation as in the files
    utc[[10, 2000, 30000, 45000, 59000]] += np.timedelta64(10, "ms")  # late GNSS stamps
    fit = fit_logger_clock(rpi, utc)
    assert fit.n_outliers == 5
    assert abs(fit.drift_ppm - DRIFT_PPM) < 1e-3
    err = (fit.to_utc(rpi) - true_utc(rpi)).astype(np.int64)
    assert np.abs(err).max() < 100  # ns: fit error of 60000 points, 1 us quantisation
    assert fit.residual_std_s < 0.5e-6
    attrs = fit.attrs()
    assert attrs["n_clock_fit_outliers"] == 5 and attrs["clock_utc0"].endswith("Z")


@pytest.mark.parametrize("dtype", [np.int64, np.float64])
def test_repeated_stamps_marked_as_pandas_marks_them(dtype):
    """Every row of a repeated stamp is marked, as ``Series.duplicated(keep=False)`` marks
    it, for sorted, swapped and shuffled stamps (integers through the sorted comparison,
    other dtypes through pandas)."""
    import pandas as pd

    from dronewind.payload.reader import _repeated

    rng = np.random.default_rng(11)
    for _ in range(400):
        n = int(rng.integers(0, 60))
        t = np.sort(rng.integers(0, int(rng.integers(1, 80)), n)).astype(dtype)
        if n > 1 and rng.random() < 0.5:
            i = rng.integers(0, n - 1, 3)
            t[i], t[i + 1] = t[i + 1].copy(), t[i].copy()
        if rng.random() < 0.3:
            rng.shuffle(t)
        np.testing.assert_array_equal(_repeated(t), pd.Series(t).duplicated(keep=False).to_numpy())
