"""Readers of quadrotor logs (CSV, PX4 ULog) and the tower reference (data contract)."""

from __future__ import annotations

import struct

import numpy as np
import pandas as pd
import pytest

from dronewind.errors import InputError
from dronewind.quadrotor.columns import QUADROTOR_COLUMNS
from dronewind.quadrotor.io import read_quadrotor, read_quadrotor_csv
from dronewind.quadrotor.reference import read_tower_reference
from dronewind.quadrotor.ulog import quaternion_to_euler_deg
from tests.conftest import needs_record, record_path

ULOG_DIR = record_path("px4_ulog")
HEADER = ",".join(QUADROTOR_COLUMNS)


def _row(t: str, pitch: str = "-5.0") -> str:
    return f"{t},0.5,{pitch},210.0,0.01,-0.02,0.0,52.1667,14.1236,123.0"


def test_csv_times_with_and_without_fractions(tmp_path):
    p = tmp_path / "q01.csv"
    rows = [_row("2020-07-24T10:19:30Z"), _row("2020-07-24T10:19:30.1Z"), _row("2020-07-24T10:19:30.25Z"),
            _row("2020-07-24T10:19:30.25Z"),            # duplicate
            _row("2020-07-24T10:19:30.2Z", "abc")]      # out of order, bad number
    p.write_text(HEADER + "\n" + "\n".join(rows) + "\n")
    ds = read_quadrotor(p)
    t = ds["time"].to_numpy()
    assert t[0] == np.datetime64("2020-07-24T10:19:30.000", "ns")
    assert t[-1] == np.datetime64("2020-07-24T10:19:30.250", "ns")
    assert ds.sizes["time"] == 4 and np.all(np.diff(t.astype("int64")) > 0)
    assert ds.attrs["n_duplicates"] == 1 and ds.attrs["n_out_of_order"] == 1
    assert ds.attrs["n_nonfinite"] == 1 and np.isnan(ds["pitch_deg"].values[2])
    assert ds["pitch_deg"].attrs["standard_name"] == "platform_pitch"
    assert "dedupe" in ds.attrs["processing_log"]


def test_csv_bad_input_is_named(tmp_path):
    p = tmp_path / "bad.csv"
    p.write_text("time_utc,roll_deg,pitch_deg\n2020-07-24T10:19:30Z,0,0\n")
    with pytest.raises(InputError, match="missing column"):
        read_quadrotor_csv(p)
    p.write_text(HEADER + "\n" + _row("2020-07-24T10:19:30Z") + "\n" + _row("2020-07-24 10:19:31") + "\n")
    with pytest.raises(InputError, match=r"bad\.csv:3.*trailing 'Z'"):
        read_quadrotor_csv(p)
    p.write_text(HEADER + "\n")
    with pytest.raises(InputError, match="no data rows"):
        read_quadrotor_csv(p)
    with pytest.raises(InputError, match="not found"):
        read_quadrotor_csv(tmp_path / "missing.csv")
    with pytest.raises(InputError, match="unknown quadrotor log type"):
        read_quadrotor(tmp_path / "log.txt")


def test_quaternion_to_euler_known_answers():
    r, p, y = quaternion_to_euler_deg(np.array([[1.0, 0, 0, 0]]))
    assert np.allclose([r[0], p[0], y[0]], 0.0)
    h = np.radians(90.0) / 2
    r, p, y = quaternion_to_euler_deg(np.array([[np.cos(h), 0, 0, np.sin(h)]]))   # yaw 90
    assert np.allclose([r[0], p[0], y[0]], [0, 0, 90], atol=1e-9)
    h = np.radians(-10.0) / 2
    r, p, y = quaternion_to_euler_deg(np.array([[np.cos(h), 0, np.sin(h), 0]]))   # pitch -10
    assert np.allclose([r[0], p[0], y[0]], [0, -10, 0], atol=1e-9)


@needs_record("px4_ulog")
def test_ulog_samples():
    small = read_quadrotor(ULOG_DIR / "sample_log_small.ulg")
    assert small.attrs["utc_valid"] == 1
    # the small log is from 2021-04-21 (GNSS UTC); attitude at ~200 Hz
    assert str(small["time"].values[0])[:10] == "2021-04-21"
    assert 150 < small.attrs["sampling_rate_hz"] < 260
    assert np.all(np.isfinite(small["roll_deg"])) and np.abs(small["roll_deg"]).max() < 30
    assert np.isfinite(small["lat_deg"]).mean() > 0.9
    bench = read_quadrotor(ULOG_DIR / "sample.ulg")   # no GNSS: boot time, flagged
    assert bench.attrs["utc_valid"] == 0
    assert bench.sizes["time"] == 6461
    assert bench.attrs["n_position_missing"] < 20
    assert set(QUADROTOR_COLUMNS[1:]) <= set(bench.data_vars)


def test_ulog_without_attitude_is_an_input_error(tmp_path):
    # minimal valid ULog: header, flag bits, one info message, no data topics
    hdr = b"ULog\x01\x12\x35" + bytes([1]) + struct.pack("<Q", 1000)
    flags = bytes(40)
    key, val = b"char[3] sys_name", b"PX4"
    info = bytes([len(key)]) + key + val
    body = struct.pack("<HB", len(flags), ord("B")) + flags + struct.pack("<HB", len(info), ord("I")) + info
    p = tmp_path / "noatt.ulg"
    p.write_bytes(hdr + body)
    with pytest.raises(InputError, match="vehicle_attitude"):
        read_quadrotor(p)


def test_reference_long_form_and_wide_form(tmp_path):
    long = tmp_path / "ref_long.csv"
    long.write_text("time_utc,height_m,wind_speed_ms,wind_from_deg\n"
                    "2020-07-24T10:19:00Z,10,4.1,200\n2020-07-24T10:19:00Z,98,6.5,210\n"
                    "2020-07-24T10:20:00Z,10,4.3,202\n2020-07-24T10:20:00Z,98,6.7,211\n"
                    "2020-07-24T10:21:00Z,98,NAN,212\n")
    ds = read_tower_reference(long)
    assert ds.sizes == {"time": 3, "height": 2}
    assert list(ds["height_m"].values) == [10.0, 98.0]
    assert ds.attrs["sampling_interval_s"] == 60.0
    assert ds["wind_speed_ms"].sel(height=1).values[1] == 6.7
    assert np.isnan(ds["wind_speed_ms"].values[2, 0])  # 10 m missing at 10:21 -> NaN
    assert ds.attrs["n_nonfinite"] == 1
    wide = tmp_path / "ref_wide.csv"
    wide.write_text("time_utc,wind_speed_ms_10m,wind_from_deg_10m,wind_speed_ms_98m,wind_from_deg_98m\n"
                    "2020-07-24T10:19:00Z,4.1,200,6.5,210\n2020-07-24T10:19:01Z,4.3,202,6.7,211\n")
    dw = read_tower_reference(wide)
    assert dw.attrs["form"] == "wide" and dw.attrs["sampling_interval_s"] == 1.0
    assert np.allclose(dw["wind_speed_ms"].values, [[4.1, 6.5], [4.3, 6.7]])


def test_reference_bad_values_named(tmp_path):
    p = tmp_path / "ref.csv"
    p.write_text("time_utc,height_m,wind_speed_ms,wind_from_deg\n2020-07-24T10:19:00Z,10,4.1,400\n")
    with pytest.raises(InputError, match=r"ref\.csv:2.*wind_from_deg"):
        read_tower_reference(p)
    p.write_text("time_utc,height_m,wind_speed_ms,wind_from_deg\n2020-07-24T10:19:00Z,10,-1,100\n")
    with pytest.raises(InputError, match="wind_speed_ms must be >= 0"):
        read_tower_reference(p)
    p.write_text("time_utc,speed\n2020-07-24T10:19:00Z,1\n")
    with pytest.raises(InputError, match="neither long form"):
        read_tower_reference(p)


# ----------------------------------------------------------------------------- the scan of the CSV reader


def _plain_log(rng: np.random.Generator, n: int = 400) -> str:
    """A log as the simulator writes it: shortest float reprs of rounded values, fractional stamps."""
    t0 = np.datetime64("2020-07-24T10:19:30", "ns")
    stamps = np.datetime_as_string(t0 + (np.arange(n) * 1e8).astype("timedelta64[ns]"), unit="ms")
    cols = [np.round(rng.normal(0, 5, n), 4), np.round(rng.normal(-4, 2, n), 4), np.round(rng.uniform(0, 360, n), 4),
            np.round(rng.normal(0, 0.3, n), 4), np.round(rng.normal(0, 0.3, n), 4), np.round(rng.normal(0, .1, n), 4),
            np.round(52.1 + rng.normal(0, 1e-5, n), 8), np.round(14.1 + rng.normal(0, 1e-5, n), 8),
            np.round(120 + rng.normal(0, 1, n), 3)]
    cols[1][:5] = [0.0, -0.0, 12.0, 1e-4, -300.0]  # integers, signed zero, small and large values
    lines = [",".join([f"{s}Z", *(repr(float(c[i])) for c in cols)]) for i, s in enumerate(stamps)]
    return HEADER + "\n" + "\n".join(lines) + "\n"


def _same(a, b) -> None:
    ta, ca, na = a
    tb, cb, nb = b
    assert np.array_equal(ta, tb) and na == nb and list(ca) == list(cb)
    for col in ca:  # bit for bit, NaN included
        assert np.array_equal(ca[col].view(np.int64), cb[col].view(np.int64)), col


def _parsed(p):
    """Time, columns and non-finite count of the parser (:func:`_quadrotor_rows`)."""
    from dronewind.quadrotor.io import _quadrotor_rows

    time, cols, _, counts = _quadrotor_rows(p)
    return time, cols, counts["n_nonfinite"]


def _by_lines(p):
    """The same with every line through the fault handling (the reference)."""
    from dronewind.quadrotor.columns import QUADROTOR_COLUMNS
    from dronewind.quadrotor.io import _csv_rows

    _, frame, time, _, _, _ = _csv_rows(p, "not found", QUADROTOR_COLUMNS, exact=False)
    cols = {c: pd.to_numeric(frame[c].astype(str).str.strip(), errors="coerce").to_numpy(dtype=float)
            for c in QUADROTOR_COLUMNS[1:]}
    return time, cols, sum(int((~np.isfinite(v)).sum()) for v in cols.values())


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_csv_scan_equals_the_line_by_line_parse_bit_for_bit(tmp_path, monkeypatch, seed):
    from dronewind.quadrotor import io

    p = tmp_path / "q.csv"
    p.write_text(_plain_log(np.random.default_rng(seed)))
    handed = []
    real = io._irregular_csv_rows
    monkeypatch.setattr(io, "_irregular_csv_rows", lambda lines, *a, **k: handed.append(len(lines))
                        or real(lines, *a, **k))
    fast = _parsed(p)
    assert handed == [0]  # a regular file: every line read by the scan
    monkeypatch.undo()
    _same(fast, _by_lines(p))
    p.write_bytes(p.read_bytes().replace(b"\n", b"\r\n"))  # CRLF: the same lines
    _same(_parsed(p), _by_lines(p))


@pytest.mark.parametrize("edit", [
    lambda t: t.replace(",0.0,", ", 0.0,", 1),               # a space: the fault handling strips it
    lambda t: t.replace(",12.0,", ",nan,", 1),               # a NaN literal: counted as non-finite
    lambda t: t.replace(",12.0,", ",1.2e1,", 1),             # an exponent
    lambda t: t.replace(",12.0,", ",12.000000000000001,", 1),  # a long literal
    lambda t: t.replace(",12.0,", ",abc,", 1),               # a corrupt field
    lambda t: t.replace(",12.0,", ",,", 1),                  # an empty field
    lambda t: t.replace(",12.0,", ',"12.0",', 1),            # quoted
    lambda t: t.replace("\n", "\n\n", 3),                    # blank lines
    lambda t: t.replace(HEADER, HEADER + ",extra", 1).replace("\n2020", ",1\n2020"),  # an extra column
    lambda t: t.replace(HEADER, "extra," + HEADER, 1).replace("\n2020", "\nx,2020"),  # another column order
    lambda t: t.replace("T10:19:30.000Z", "T10:19:30Z", 1),  # a stamp without fraction
])
def test_csv_irregular_lines_agree_with_the_line_by_line_parse(tmp_path, edit):
    p = tmp_path / "q.csv"
    p.write_text(edit(_plain_log(np.random.default_rng(5))))
    parsed = _parsed(p)
    _same(parsed, _by_lines(p))
    assert read_quadrotor_csv(p).attrs["n_nonfinite"] == parsed[2]


def test_csv_bad_stamps_are_counted_by_the_fault_handling(tmp_path):
    p = tmp_path / "q.csv"
    text = _plain_log(np.random.default_rng(7))
    p.write_text(text.replace("T10:19:30.100Z", "T10:19:30.100", 1))
    ds = read_quadrotor_csv(p)  # one bad stamp: its line counted and named, the others read
    assert ds.attrs["n_corrupt_lines"] == 1 and ds.sizes["time"] == 399 and "(lines [3])" in ds.attrs["processing_log"]
    lines = text.split("\n")
    p.write_text("\n".join([lines[0], *(ln.replace("Z,", ",", 1) for ln in lines[1:40]), *lines[40:]]))
    with pytest.raises(InputError, match=r"q\.csv:2.*trailing 'Z'"):  # many: the named error
        read_quadrotor_csv(p)
    p.write_text(text.replace("2020-07-24T10:19:30.100Z", "2020-02-30T10:19:30.100Z", 1))
    assert read_quadrotor_csv(p).attrs["n_corrupt_lines"] == 1
    p.write_text(text.replace("2020-07-24T10:19:3", "2020-02-30T10:19:3", 40))
    with pytest.raises(InputError, match=r"q\.csv:2.*not a valid date"):
        read_quadrotor_csv(p)
