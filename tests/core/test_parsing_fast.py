"""One parser per raw text format: the scanned regular lines and the fault handling of the others agree.

Each format has one parser that scans the regular lines in bulk and hands every other line
(with its line number) to its line-by-line fault handling. The references here are the
fault handling applied to every line of the file (what the parser would give if no line
were regular) and, for files with scattered bad rows, the rows of the clean file: columns
equal bit for bit, counts, line numbers, logs and errors identical.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from dronewind.core import columns, textscan
from dronewind.core.rowfaults import text_lines
from dronewind.errors import InputError
from dronewind.mast import ameriflux, level1, toa5
from dronewind.payload import reader
from dronewind.simulate.writers import write_ins_csv, write_payload_sonic_csv, write_toa5
from tests.conftest import needs_record, record_path

SHARED = record_path("fluxpart_csat3_toa5")
SONIC_KINDS = {"rpi_time_us": "int", "u_ms": "float", "v_ms": "float", "w_ms": "float", "t_sonic_c": "float"}
INS_KINDS = {**{c: "float" for c in columns.INS_COLUMNS}, "rpi_time_us": "int", "utc": "utc", "time_valid": "flag",
             "ekf_valid": "int"}  # fmt: skip


# ----------------------------------------------------------------------------- helpers


def outcome(fn: Callable[[], Any]) -> tuple[str, Any]:
    """("ok", result) or ("error", (class name, message))."""
    try:
        return "ok", fn()
    except Exception as exc:  # noqa: BLE001 - the class and message are compared
        return "error", (type(exc).__name__, str(exc))


def assert_same_arrays(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> None:
    assert list(a) == list(b)
    for k in b:
        assert a[k].dtype == b[k].dtype, k
        assert a[k].tobytes() == b[k].tobytes(), k


def edit_lines(path: Path, edits: dict[int, bytes | None], insert: dict[int, bytes] | None = None) -> Path:
    """Replace (or delete, None) 0-based lines of a file and insert a line before others."""
    lines = path.read_bytes().split(b"\n")
    if lines[-1] == b"":
        lines = lines[:-1]
    out: list[bytes] = []
    for i, ln in enumerate(lines):
        if insert and i in insert:
            out.append(insert[i])
        new = edits.get(i, ln)
        if new is not None:
            out.append(new)
    path.write_bytes(b"\n".join(out) + b"\n")
    return path


def scatter(path: Path, header_lines: int, bad: dict[int, bytes]) -> Path:
    """Replace the 0-based data lines `bad` of a file (line ends kept)."""
    return edit_lines(path, {header_lines + i: text for i, text in bad.items()})


# ----------------------------------------------------------------------- payload CSVs


def payload_by_lines(path: Path, expected: tuple[str, ...], kinds: dict[str, str]) -> Any:
    """The rows of a payload CSV with every data line through the fault handling (the reference)."""
    body = text_lines(path.read_bytes())[1:]
    blank = np.array([not ln.strip() for ln in body], dtype=bool)
    good_count, cols, bad, per_column = reader._irregular_rows([ln for ln, b in zip(body, blank, strict=True)
                                                                if not b], expected, kinds)  # fmt: skip
    return reader._Rows(np.arange(2, len(body) + 2)[~blank], int(blank.sum()), good_count, cols, bad, per_column)


def assert_payload_rows(path: Path, ins: bool) -> Any:
    """The parser's rows equal the line-by-line reference's; return them."""
    expected, kinds = (columns.INS_COLUMNS, INS_KINDS) if ins else (columns.SONIC_COLUMNS, SONIC_KINDS)
    got, ref = reader._rows(path, expected, kinds), payload_by_lines(path, expected, kinds)
    assert got.line_numbers.tolist() == ref.line_numbers.tolist() and got.n_blank == ref.n_blank
    assert got.good_count.tolist() == ref.good_count.tolist() and got.bad.tolist() == ref.bad.tolist()
    assert got.per_column == ref.per_column
    assert_same_arrays(got.cols, ref.cols)
    return got


def sonic_file(folder: Path, n: int = 400, seed: int = 0) -> Path:
    rng = np.random.default_rng(seed)
    rpi = 5_000_000_000 + np.rint(np.arange(n) / 32 * 1e6).astype(np.int64) + rng.integers(-300, 300, n)
    return write_payload_sonic_csv(folder / "sonic.csv", rpi, rng.normal(5, 1, n), rng.normal(0, 1, n),
                                   rng.normal(0, .3, n), rng.normal(20, .3, n))


def ins_file(folder: Path, n: int = 600, seed: int = 1) -> Path:
    rng = np.random.default_rng(seed)
    rpi = 5_000_000_000 + np.rint(np.arange(n) / 50 * 1e6).astype(np.int64) + rng.integers(-200, 200, n)
    utc = np.datetime64("2023-08-21T14:00:00", "us") + (rpi - rpi[0]).astype("timedelta64[us]")
    valid = (np.arange(n) >= 50).astype(np.int64)
    return write_ins_csv(folder / "ins.csv", rpi, utc, valid, np.ones(n, np.int64), 43.1 + rng.normal(0, 1e-5, n),
                         0.36 + rng.normal(0, 1e-5, n), 600 + rng.normal(0, 1, n), rng.normal(0, .3, n),
                         rng.normal(0, .3, n), rng.normal(0, .1, n), rng.normal(0, 2, n), rng.normal(0, 2, n),
                         170 + rng.normal(0, 3, n))


def test_regular_payload_files_are_read_whole_by_the_scan(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    sonic, ins = sonic_file(tmp_path, n=3000), ins_file(tmp_path)
    handed: list[int] = []
    real = reader._irregular_rows
    monkeypatch.setattr(reader, "_irregular_rows", lambda lines, *a: handed.append(len(lines)) or real(lines, *a))
    rows = assert_payload_rows(sonic, ins=False)
    assert handed == [0, 3000]  # none by the parser; every line by the reference
    assert rows.line_numbers.tolist() == list(range(2, 3002)) and not rows.bad.any()
    assert not assert_payload_rows(ins, ins=True).bad.any() and handed[2] == 0


def test_scattered_bad_payload_rows_cost_their_lines_only(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A long file with a few bad rows: those lines go to the fault handling, the rest equal the clean file."""
    clean = sonic_file(tmp_path, n=20_000)
    clean_table = reader._parse_csv(clean, columns.SONIC_COLUMNS, SONIC_KINDS, 0.05)
    bad = {137: b"5004281250,abc,0.1,0.2,20.1", 4_000: b"x,y", 9_999: b"\xde\xad,\xbe\xef", 15_000: b"",
           19_998: b"5624937500,1.0,0.1"}
    path = scatter(clean, 1, bad)
    handed: list[int] = []
    real = reader._irregular_rows
    monkeypatch.setattr(reader, "_irregular_rows", lambda lines, *a: handed.append(len(lines)) or real(lines, *a))
    table = reader._parse_csv(path, columns.SONIC_COLUMNS, SONIC_KINDS, 0.05)
    assert handed == [4]  # the blank line is counted as blank, the four others are handled line by line
    assert table.corrupt_lines == [139, 4002, 10001, 20000]
    assert table.counts == {"n_lines": 19_999, "n_corrupt_lines": 4, "n_blank_lines": 1}
    keep = ~np.isin(np.arange(20_000), list(bad))
    assert table.line_no.tolist() == np.arange(2, 20_002)[keep].tolist()
    for name in columns.SONIC_COLUMNS:
        assert table.columns[name].tobytes() == clean_table.columns[name][keep].tobytes(), name
    monkeypatch.undo()
    assert_payload_rows(path, ins=False)


SONIC_DEFECTS: dict[str, tuple[dict[int, bytes | None], dict[int, bytes]]] = {
    "corrupt_value": ({5: b"5000156250,abc,0.1,0.2,20.1", 9: b"5000281250,1.0,,0.2,20.1"}, {}),
    "wrong_field_count": ({6: b"5000187500,1.0,0.1", 12: b"5000375000,1,2,3,4,5"}, {}),
    "blank_lines": ({}, {3: b"", 8: b"   ", 20: b"\t"}),
    "nan_literals": ({4: b"5000125000,nan,NaN,-nan,+NAN", 7: b"5000218750,1.5,NAN,0.1,20"}, {}),
    "binary_garbage": ({10: b"\x00\xff\xfe\x80garbage\x9c", 11: b"\xde\xad,\xbe\xef"}, {}),
    "garbage_right_count": ({10: b"5000312500,1.\xff5,0.1,0.2,20.1"}, {}),
    "spaces": ({3: b"5000093750, 1.25 ,0.1,0.2,20.1"}, {}),
    "quotes": ({3: b'5000093750,"1.25",0.1,0.2,20.1'}, {}),
    "long_and_exponent_floats": ({3: b"5000093750,1.2345678901234567,1e-23,2.5E+2,-0.00000000000000123"}, {}),
    "inf_and_ints": ({3: b"5000093750,inf,-Infinity,3,+4", 4: b"+5000125000,1,2,3,4"}, {}),
    "int_time_as_float": ({3: b"5000093750.0,1,2,3,4"}, {}),
    "many_corrupt": ({i: b"x,y" for i in range(2, 60)}, {}),
    "duplicates_and_conflicts": ({5: b"5000156250,1,2,3,4", 6: b"5000156250,1,2,3,4", 7: b"5000156250,9,9,9,9"},
                                 {}),  # fmt: skip
    "int_forms": ({3: b"-5000093750,1,2,3,4", 4: b"00005000125000,1,2,3,4", 5: b"5000156250+,1,2,3,4",
                   6: b"+,1,2,3,4"}, {}),  # fmt: skip
}


@pytest.mark.parametrize("name", sorted(SONIC_DEFECTS))
def test_sonic_defects_same_rows(name: str, tmp_path: Path) -> None:
    edits, insert = SONIC_DEFECTS[name]
    path = edit_lines(sonic_file(tmp_path), {k + 1: v for k, v in edits.items()},
                      {k + 1: v for k, v in insert.items()})  # fmt: skip
    assert_payload_rows(path, ins=False)


@pytest.mark.parametrize("variant", ["bom", "two_boms", "crlf", "lone_cr", "form_feed", "nel", "no_final_newline",
                                     "header_spaces", "header_wrong", "header_only", "empty"])  # fmt: skip
def test_sonic_text_variants(variant: str, tmp_path: Path) -> None:
    path = sonic_file(tmp_path, n=120)
    text = path.read_bytes()
    text = {"bom": lambda t: b"\xef\xbb\xbf" + t, "two_boms": lambda t: b"\xef\xbb\xbf\xef\xbb\xbf" + t,
            "crlf": lambda t: t.replace(b"\n", b"\r\n"), "lone_cr": lambda t: t.replace(b"\n", b"\r", 3),
            "form_feed": lambda t: t.replace(b",", b",\x0c", 1), "nel": lambda t: t.replace(b"\n", b"\n\xc2\x85", 2),
            "no_final_newline": lambda t: t.rstrip(b"\n"),
            "header_spaces": lambda t: t.replace(b"u_ms,", b" u_ms ,", 1),
            "header_wrong": lambda t: t.replace(b"u_ms,", b"u_cm,", 1),
            "header_only": lambda t: t.split(b"\n")[0] + b"\n\n", "empty": lambda t: b""}[variant](text)
    path.write_bytes(text)
    if variant in ("header_wrong", "header_only", "empty"):
        message = {"header_wrong": r"sonic\.csv:1", "header_only": "no data lines after the header",
                   "empty": "empty file"}[variant]  # fmt: skip
        with pytest.raises(InputError, match=message):
            reader._rows(path, columns.SONIC_COLUMNS, SONIC_KINDS)
        return
    rows = assert_payload_rows(path, ins=False)
    assert int(rows.good_count.sum()) == 120


INS_DEFECTS: dict[str, dict[int, bytes | None]] = {
    "valid_without_utc": {70: b"5001400000,,1,1,43.1,0.36,600.0,0.1,0.1,0.0,1.0,1.0,170.0"},
    "bad_utc": {70: b"5001400000,2023-13-21T14:00:01.400000Z,1,1,43.1,0.36,600.0,0.1,0.1,0.0,1.0,1.0,170.0",
                71: b"5001420000,2023-02-30T14:00:01.420000Z,1,1,43.1,0.36,600.0,0.1,0.1,0.0,1.0,1.0,170.0"},
    "utc_other_forms": {70: b"5001400000,2023-08-21T14:00:01.4Z,1,1,43.1,0.36,600.0,0.1,0.1,0.0,1.0,1.0,170.0",
                        71: b"5001420000,2023-08-21T14:00:01.420000,1,1,43.1,0.36,600.0,0.1,0.1,0.0,1.0,1.0,170.0",
                        72: b"5001440000,2023-08-21 14:00:01.440000Z,1,1,43.1,0.36,600.0,0.1,0.1,0.0,1,1,170"},
    "utc_garbage": {70: b"5001400000,garbage,1,1,43.1,0.36,600.0,0.1,0.1,0.0,1.0,1.0,170.0"},
    "flag_out_of_range": {70: b"5001400000,2023-08-21T14:00:01.400000Z,2,1,43.1,0.36,600,0.1,0.1,0,1,1,170",
                          71: b"5001420000,2023-08-21T14:00:01.420000Z,1.0,1,43.1,0.36,600,0.1,0.1,0,1,1,170"},
    "corrupt_and_short": {80: b"5001600000,2023-08-21T14:00:01.6", 81: b"\xff\xfe"},
    "nan_in_ins": {90: b"5001800000,2023-08-21T14:00:01.800000Z,1,1,nan,0.36,600,0.1,0.1,0,1,1,170"},
    "clock_jump": {300: b"4000000000,2023-08-21T14:00:06.000000Z,1,1,43.1,0.36,600,0.1,0.1,0,1,1,170"},
}


@pytest.mark.parametrize("name", sorted(INS_DEFECTS))
def test_ins_defects_same_rows(name: str, tmp_path: Path) -> None:
    assert_payload_rows(edit_lines(ins_file(tmp_path), INS_DEFECTS[name]), ins=True)


def test_ins_leap_day_and_year_edges(tmp_path: Path) -> None:
    """Fixed-width UTC parse on calendar edges: leap days, ends of months and years, all fraction digits."""
    stamps = ["2024-02-29T23:59:59.999999Z", "2023-12-31T23:59:59.000001Z", "2000-02-29T00:00:00.000000Z",
              "1900-03-01T12:00:00.500000Z", "2100-02-28T01:02:03.040506Z", "2199-12-31T23:59:59.999999Z",
              "2023-04-30T10:00:00.000000Z", "2023-04-31T10:00:00.000000Z", "1900-02-29T00:00:00.000000Z"]
    head = ",".join(columns.INS_COLUMNS)
    lines = [f"{5_000_000_000 + 20_000 * i},{s},1,1,43.1,0.36,600,0.1,0.1,0,1,1,170" for i, s in enumerate(stamps)]
    lines += [f"{5_000_000_000 + 20_000 * i},,0,1,43.1,0.36,600,0.1,0.1,0,1,1,170" for i in range(9, 300)]
    path = tmp_path / "ins.csv"
    path.write_text(head + "\n" + "\n".join(lines) + "\n")
    rows = assert_payload_rows(path, ins=True)
    assert rows.cols["utc"][0] == np.datetime64("2024-02-29T23:59:59.999999", "ns")
    assert rows.bad[[7, 8]].all() and not rows.bad[:7].any()


def test_short_decimals_rounded_like_the_fault_handling(tmp_path: Path) -> None:
    """Random decimal literals of up to 20 characters (the scan converts those of <= 15)."""
    rng = np.random.default_rng(3)
    n = 3000
    digits = rng.integers(0, 10, (n, 18)).astype(str)
    length = rng.integers(1, 18, n)
    point = rng.integers(-1, 18, n)
    vals = []
    for d, k, p in zip(digits, length, point, strict=True):
        s = "".join(d[:k])
        s = s if p < 0 or p > k else s[:p] + "." + s[p:]
        vals.append(rng.choice(["", "-", "+"]) + (s if s.strip(".") else "0"))
    rpi = 5_000_000_000 + 31_250 * np.arange(n)
    path = tmp_path / "sonic.csv"
    path.write_text("rpi_time_us,u_ms,v_ms,w_ms,t_sonic_c\n"
                    + "".join(f"{r},{v},0.5,{v},20\n" for r, v in zip(rpi, vals, strict=True)))
    assert_payload_rows(path, ins=False)


# ------------------------------------------------------------------------------ TOA5


def toa5_by_lines(monkeypatch: pytest.MonkeyPatch, path: Path) -> tuple[str, Any]:
    """Outcome of the TOA5 parser with every data line through the fault handling (the reference)."""
    with monkeypatch.context() as m:
        m.setattr(toa5, "_regular_rows", lambda body, starts, ends, names: (np.zeros(starts.size, dtype=bool), {}))
        return outcome(lambda: toa5.read_toa5(path))


def assert_toa5_same(monkeypatch: pytest.MonkeyPatch, path: Path) -> tuple[str, Any]:
    """The parser's outcome equals the line-by-line reference's; return it."""
    (kf, f), (kc, c) = outcome(lambda: toa5.read_toa5(path)), toa5_by_lines(monkeypatch, path)
    assert kf == kc, (f, c)
    if kf == "error":
        assert f == c
        return kf, f
    pd.testing.assert_frame_equal(f[0], c[0], check_exact=True)
    for col in c[0]:
        assert f[0][col].to_numpy().tobytes() == c[0][col].to_numpy().tobytes(), col
    assert f[1] == c[1]
    return kf, f


def handed_toa5(monkeypatch: pytest.MonkeyPatch, path: Path) -> list[int]:
    """Numbers of lines the TOA5 parser hands to its fault handling, per block."""
    handed: list[int] = []
    real = toa5._irregular_rows
    with monkeypatch.context() as m:
        m.setattr(toa5, "_irregular_rows", lambda lines, *a: handed.append(len(lines)) or real(lines, *a))
        outcome(lambda: toa5.read_toa5(path))
    return handed


def toa5_file(folder: Path, n: int = 600, kelvin: bool = False, nan_every: int = 0) -> Path:
    rng = np.random.default_rng(4)
    t = np.datetime64("2023-08-21T14:00:00", "ns") + (np.arange(n) * 50_000_000).astype("timedelta64[ns]")
    ts = rng.normal(20, .3, n) + (273.15 if kelvin else 0.0)
    ux = rng.normal(2, 1, n)
    if nan_every:
        ux[::nan_every] = np.nan
    path = write_toa5(folder / "TOA5_t.dat", t, np.arange(n) + 10, ux, rng.normal(0, 1, n), rng.normal(0, .3, n), ts,
                      np.zeros(n, np.int64))
    if kelvin:
        path.write_bytes(path.read_bytes().replace(b'"m/s","C","unitless"', b'"m/s","K","unitless"', 1))
    return path


@needs_record("fluxpart_csat3_toa5")
def test_real_toa5_files_are_read_whole_by_the_scan(monkeypatch: pytest.MonkeyPatch) -> None:
    for f in sorted(SHARED.glob("*.dat")):
        assert handed_toa5(monkeypatch, f) == []
        assert assert_toa5_same(monkeypatch, f)[0] == "ok"


def test_scattered_bad_toa5_rows_cost_their_lines_only(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A long file with a few bad rows: those lines go to the fault handling, the rest equal the clean file."""
    clean = toa5_file(tmp_path, n=20_000)
    ref, _ = toa5.read_toa5(clean)
    bad = {137: b'"2023-08-21 25:00:00.3",16,1,1,0.1,20,0', 4_000: b'"2023-08-21 14:00:00.3",x7,1,1,0.1,20,0',
           9_999: b"\xff\xfe\x9c\x80junk", 15_000: b"", 19_998: b'"2023-08-21 14:00:00.3",16,1.0'}
    path = scatter(clean, 4, bad)
    assert handed_toa5(monkeypatch, path) == [5]
    frame, info = toa5.read_toa5(path)
    assert info["n_corrupt_lines"] == 5 and info["corrupt_lines"] == [142, 4005, 10004, 15005, 20003]
    assert info["n_lines"] == 20_000 and info["n_nonnumeric"] == 0
    keep = ~np.isin(np.arange(20_000), list(bad))
    for col in ref:
        assert frame[col].to_numpy().tobytes() == ref[col].to_numpy()[keep].tobytes(), col
    assert_toa5_same(monkeypatch, path)


TOA5_DEFECTS: dict[str, dict[int, bytes | None]] = {
    "quoted_nan": {10: b'"2023-08-21 14:00:00.3",16,"NAN",0.5,0.1,20.1,0', 11: b'"2023-08-21 14:00:00.35",17,'
                   b'1.0,"nan",0.1,"",0'},  # fmt: skip
    "unquoted_nan_and_empty": {10: b'"2023-08-21 14:00:00.3",16,NAN,,0.1,20.1,0'},
    "wrong_field_count": {10: b'"2023-08-21 14:00:00.3",16,1.0', 12: b""},
    "bad_timestamp_and_record": {10: b'"2023-08-21 25:00:00.3",16,1,1,0.1,20,0', 11: b'"2023-08-21 14:00:00.35",'
                                 b'x7,1,1,0.1,20,0'},  # fmt: skip
    "nonnumeric_value": {10: b'"2023-08-21 14:00:00.3",16,abc,1,0.1,20,0'},
    "binary_garbage": {10: b"\xff\xfe\x9c\x80junk", 11: b"\xde\xad,\xbe\xef"},
    "garbage_right_count": {10: b'"2023-08-21 14:00:00.3",16,1.\xff0,1,0.1,20,0'},
    "comma_in_quotes": {10: b'"2023-08-21 14:00:00.3",16,"1,0",1,0.1,20,0'},
    "space_outside_quotes": {10: b'"2023-08-21 14:00:00.3",16, 1.0,1,0.1,20,0'},
    "unbalanced_quote": {10: b'"2023-08-21 14:00:00.3,16,1.0,1,0.1,20,0'},
    "quote_inside_field": {10: b'"2023-08-21 14:00:00.3",16,1"0",1,0.1,20,0'},
    "comma_inside_timestamp_quotes": {10: b'"2023-08-21 14:00:00X,16",1.0,1,0.1,20,0',
                                      11: b'"2023-08-21 14:00:00X,16",1.0,1,0.1,20,0,"x"'},
    "timestamp_iso_t": {10: b'"2023-08-21T14:00:00.3",16,1.0,1,0.1,20,0'},
    "unquoted_timestamp": {10: b"2023-08-21 14:00:00.3,16,1.0,1,0.1,20,0"},
    "long_exponent_floats": {10: b'"2023-08-21 14:00:00.3",16,1.2345678901234567,1e-23,2.5E+2,20,0'},
    "quoted_record": {10: b'"2023-08-21 14:00:00.3","16",1.0,1,0.1,20,0'},
    "record_forms": {10: b'"2023-08-21 14:00:00.3",+16,1.0,1,0.1,20,0', 11: b'"2023-08-21 14:00:00.35",16.0,1,1,0,2,0'},
    "nul": {10: b'"2023-08-21 14:00:00.3",16,1.0,1,0.1,20\x00,0'},
    "many_corrupt": {i: b'"x",1' for i in range(5, 80)},
}


@pytest.mark.parametrize("name", sorted(TOA5_DEFECTS))
def test_toa5_defects_same_result(name: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = edit_lines(toa5_file(tmp_path), TOA5_DEFECTS[name])
    handed = handed_toa5(monkeypatch, path)
    regular_edits = {"quoted_nan": 2, "unquoted_nan_and_empty": 1, "quoted_record": 1, "record_forms": 1}
    if name != "many_corrupt":  # only the edited lines go to the fault handling, except those still regular
        n_irregular = len(TOA5_DEFECTS[name]) - regular_edits.get(name, 0)
        assert handed == ([n_irregular] if n_irregular else [])
    assert_toa5_same(monkeypatch, path)


@pytest.mark.parametrize("variant", ["crlf", "bom", "kelvin", "nan_values", "header_broken", "header_only",
                                     "lone_cr"])  # fmt: skip
def test_toa5_variants_same_result(variant: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = toa5_file(tmp_path, kelvin=variant == "kelvin", nan_every=7 if variant == "nan_values" else 0)
    text = path.read_bytes()
    if variant == "crlf":
        text = text.replace(b"\n", b"\r\n")
    elif variant == "bom":
        text = b"\xef\xbb\xbf" + text
    elif variant == "header_broken":
        text = text.replace(b'"Uz",', b"", 1)
    elif variant == "header_only":
        text = b"\n".join(text.split(b"\n")[:4]) + b"\n"
    elif variant == "lone_cr":
        text = text.replace(b"\n", b"\r", 7)
    path.write_bytes(text)
    assert assert_toa5_same(monkeypatch, path)[0] == ("error" if variant.startswith("header") else "ok")
    if not variant.startswith("header"):
        assert handed_toa5(monkeypatch, path) == []
    if variant == "kelvin":  # the whole mast chain (units from the header) reads the header's unit
        ds = level1.mast_l1(path, 218.0, 30.0, "m30")
        assert float(np.nanmedian(ds["t_sonic_k"])) == pytest.approx(293.15, abs=0.2)


# ------------------------------------------------------------------------- textscan


@pytest.mark.parametrize("seed", range(20))
def test_text_body_splits_lines_as_the_fault_handling(seed: int) -> None:
    """Lines as byte offsets decode to the lines of text_lines: BOMs, CR, CRLF, invalid UTF-8, other breaks."""
    rng = np.random.default_rng(seed)
    pieces = [b"ab,1", b"\n", b"\r", b"\r\n", b"\xef\xbb\xbf", b"\xe2\x80", b"\xff", b"\x0b", b"\xc2\x85", b"",
              b"\xe2\x80\xa8", b"x"]
    raw = b"".join(pieces[k] for k in rng.integers(0, len(pieces), 60))
    raw = (b"\xef\xbb\xbf" * int(rng.integers(0, 3))) + raw
    for n_header in (0, 1, 4):
        head, body, _, starts, ends, _ = textscan.text_body(raw, n_header)
        lines = head + textscan.line_text(body, starts, ends, np.arange(starts.size))
        assert lines == text_lines(raw)
    assert textscan.first_line(raw) == (text_lines(raw) or [None])[0]


def test_nan_literals_cover_every_spelling() -> None:
    spellings = {s + "".join(c) for s in ("", "+", "-") for c in itertools.product("nN", "aA", "nN")}
    assert set(textscan.NAN_LITERALS) == spellings


def test_fixed_width_times_rejects_what_it_cannot_vouch_for() -> None:
    stamps = [b"2023-08-21T14:00:01.400000Z", b"2023-08-21T24:00:01.400000Z", b"2023-08-21T14:60:01.400000Z",
              b"2023-08-21T14:00:60.400000Z", b"2023-00-21T14:00:01.400000Z", b"2023-08-00T14:00:01.400000Z",
              b"1899-12-31T14:00:01.400000Z", b"2023-08-21T14:00:01.4a0000Z", b"2023-08-21X14:00:01.400000Z",
              b"2023-08-21T14:00:01.400000", b"2023-08-21T14:00:01Z", b"2023-08-21T14:00:01.123456789Z"]
    buf = np.frombuffer(b"".join(stamps), dtype=np.uint8)
    length = np.array([len(s) for s in stamps])
    start = np.concatenate([[0], np.cumsum(length)[:-1]])
    times, ok = textscan.fixed_width_times(buf, start, length, sep=b"T", suffix=b"Z")
    assert ok.tolist() == [True] + [False] * 8 + [False, True, True]
    assert times[0] == np.datetime64("2023-08-21T14:00:01.4", "ns")
    assert times[-1] == np.datetime64("2023-08-21T14:00:01.123456789", "ns")
    assert np.isnat(times[1:9]).all()


# ----------------------------------------------------------------------------- AmeriFlux gold

GOLD = record_path("ameriflux_gold_openpath")


def gold_by_lines(monkeypatch: pytest.MonkeyPatch, path: Path, **kw: Any) -> tuple[str, Any]:
    """Outcome of the gold parser with every line through the fault handling (the reference)."""
    with monkeypatch.context() as m:
        m.setattr(ameriflux, "_regular_gold_rows", lambda body, buf, starts, ends, unusual, columns:
                  (np.zeros(starts.size, dtype=bool), np.zeros((0, 6))))
        return outcome(lambda: ameriflux._gold_values(path, 0.05, **kw))


def handed_gold(monkeypatch: pytest.MonkeyPatch, path: Path, **kw: Any) -> list[int]:
    """Numbers of lines the gold parser hands to its fault handling."""
    handed: list[int] = []
    real = ameriflux._irregular_gold_rows
    with monkeypatch.context() as m:
        m.setattr(ameriflux, "_irregular_gold_rows", lambda lines, *a: handed.append(len(lines)) or real(lines, *a))
        outcome(lambda: ameriflux._gold_values(path, 0.05, **kw))
    return handed


def assert_gold_same(monkeypatch: pytest.MonkeyPatch, path: Path, **kw: Any) -> str:
    (kind_a, a), (kind_b, b) = outcome(lambda: ameriflux._gold_values(path, 0.05, **kw)), \
        gold_by_lines(monkeypatch, path, **kw)  # fmt: skip
    assert kind_a == kind_b, (a, b)
    if kind_a == "ok":
        assert a.values.dtype == b.values.dtype and a.values.tobytes() == b.values.tobytes()
        assert a.corrupt.tobytes() == b.corrupt.tobytes() and a.line_no.tolist() == b.line_no.tolist()
        assert (a.n_joined, a.problem) == (b.n_joined, b.problem)
    else:
        assert a == b
    return kind_a


def gold_file(tmp_path: Path, seed: int = 0, n: int = 600, crlf: bool = True) -> Path:
    """A gold-format file: six signed decimals per line as the logger writes them, 15 empty fields."""
    rng = np.random.default_rng(seed)
    w, u, v = (rng.normal(0, 1.5, n) for _ in range(3))
    t, h, c = rng.normal(20, 2, n), rng.uniform(2.9, 3.1, n), rng.uniform(2.2, 2.3, n)
    end = "\r\n" if crlf else "\n"
    lines = [f"{a:+.3f},{b:+.3f},{d:+.3f},{e:.2f},{f:.3f},{g:.3f}" + "," * 15 for a, b, d, e, f, g in
             zip(w, u, v, t, h, c, strict=True)]
    path = tmp_path / "G1040000.RAW"
    path.write_bytes((end.join(lines) + end).encode())
    return path


@needs_record("ameriflux_gold_openpath")
def test_real_gold_files_are_read_whole_by_the_scan(monkeypatch: pytest.MonkeyPatch) -> None:
    for f in sorted(GOLD.glob("G*.RAW.gz"))[::8]:
        assert handed_gold(monkeypatch, f) == [0]
        assert assert_gold_same(monkeypatch, f) == "ok"


@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize("crlf", [True, False])
def test_regular_gold_files_are_read_whole_by_the_scan(seed: int, crlf: bool, tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    path = gold_file(tmp_path, seed, crlf=crlf)
    assert handed_gold(monkeypatch, path) == [0]
    assert assert_gold_same(monkeypatch, path) == "ok"


def test_scattered_bad_gold_rows_cost_their_lines_only(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Bad lines among 18,000, a joined line among them: each costs its samples, the others are the clean ones."""
    clean = gold_file(tmp_path, 4, n=18_000, crlf=False)
    ref = ameriflux._gold_values(clean, 0.05)
    joined = b"+0.110,-0.930,+0.600,20.82,2.992,2.246" + b"," * 36 + b"+0.1,2,3,4,5,6"  # 43 fields: 3 samples
    bad = {10: b"+0.1x0,-0.930,+0.600,20.82,2.992,2.246" + b"," * 15, 5_000: joined, 9_000: b"",
           17_999: b"+0.110,-0.930"}
    path = scatter(clean, 0, bad)
    assert handed_gold(monkeypatch, path) == [4]
    got = ameriflux._gold_values(path, 0.05)
    assert got.n_joined == 3 and got.values.shape == (18_000 + 2 - 1, 6)
    assert got.line_no[got.corrupt].tolist() == [11, 5001, 5001, 5001, 18_000]  # a short line: four numbers lack
    keep = ~np.isin(np.arange(18_000), list(bad))
    assert got.values[~got.corrupt].tobytes() == ref.values[keep].tobytes()
    assert got.line_no[~got.corrupt].tolist() == (np.arange(1, 18_001)[keep]).tolist()
    assert assert_gold_same(monkeypatch, path) == "ok"


GOLD_DEFECTS: dict[str, dict[int, bytes]] = {
    "letters": {5: b"+0.1x0,-0.930,+0.600,20.82,2.992,2.246" + b"," * 15},
    "empty_number": {5: b",-0.930,+0.600,20.82,2.992,2.246" + b"," * 15},
    "nan_literal": {5: b"nan,-0.930,+0.600,20.82,2.992,2.246" + b"," * 15},
    "space_padded": {5: b" +0.110,-0.930,+0.600,20.82,2.992,2.246" + b"," * 15},
    "exponent": {5: b"1e-1,-0.930,+0.600,20.82,2.992,2.246" + b"," * 15},
    "sixteen_chars": {5: b"+0.1100000000000,-0.930,+0.600,20.82,2.992,2.246" + b"," * 15},
    "seventh_field": {5: b"+0.110,-0.930,+0.600,20.82,2.992,2.246,7" + b"," * 14},
    "short_line": {5: b"+0.110,-0.930,+0.600"},
    "six_fields": {5: b"+0.110,-0.930,+0.600,20.82,2.992,2.246"},
    "long_line": {5: b"+0.110,-0.930,+0.600,20.82,2.992,2.246" + b"," * 16},
    "joined_lines": {5: b"+0.110,-0.930,+0.600,20.82,2.992,2.246" + b"," * 36 + b"+0.1,2,3,4,5,6"},
    "blank_line": {5: b""},
    "double_sign": {5: b"+-0.110,-0.930,+0.600,20.82,2.992,2.246" + b"," * 15},
    "two_points": {5: b"+0.1.10,-0.930,+0.600,20.82,2.992,2.246" + b"," * 15},
    "lone_sign": {5: b"+,-0.930,+0.600,20.82,2.992,2.246" + b"," * 15},
    "binary": {5: b"\xff\xfe,-0.930,+0.600,20.82,2.992,2.246" + b"," * 15},
    "many_corrupt": {i: b"x,y" + b"," * 19 for i in range(0, 100)},
}


@pytest.mark.parametrize("name", sorted(GOLD_DEFECTS))
def test_gold_defects_same_result(name: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = gold_file(tmp_path, 7)
    lines = path.read_bytes().split(b"\r\n")
    for i, text in GOLD_DEFECTS[name].items():
        lines[i] = text
    path.write_bytes(b"\r\n".join(lines))
    if name != "many_corrupt":
        assert handed_gold(monkeypatch, path) == [1]  # the edited line only
    assert_gold_same(monkeypatch, path)


def test_gold_lone_cr_and_other_columns(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = gold_file(tmp_path, 8)
    columns = ("w", "u", "v", "t_sonic_c", "unused", "unused")
    assert handed_gold(monkeypatch, path, columns=columns) == [0]
    assert assert_gold_same(monkeypatch, path, columns=columns) == "ok"
    path.write_bytes(path.read_bytes().replace(b"\r\n", b"\r", 3))
    assert handed_gold(monkeypatch, path) == [0]
    assert_gold_same(monkeypatch, path)


def test_damaged_gzip_stream_is_read_as_far_as_it_goes(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import gzip

    path = gold_file(tmp_path, 9)
    data = gzip.compress(path.read_bytes(), mtime=0)
    gz = tmp_path / "G1040000.RAW.gz"
    gz.write_bytes(data[: len(data) * 2 // 3])
    got = ameriflux._gold_values(gz, 0.05)
    assert got.problem and "truncated" in got.problem and 0 < got.values.shape[0] < 600
    assert assert_gold_same(monkeypatch, gz) == "ok"
