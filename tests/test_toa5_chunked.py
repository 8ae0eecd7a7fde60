"""The chunked C-parser path of the TOA5 reader (large files) gives exactly the careful result, or declines."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from dronewind.mast import columns, toa5
from tests.conftest import needs_record
from tests.test_io_toa5 import EXCERPT, SHARED, synthetic_rows, write_toa5


def _row_by_row(path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[pd.DataFrame, dict]:
    with monkeypatch.context() as m:
        m.setattr(toa5, "_CHUNKED_MIN_BYTES", 1 << 62)  # never chunked
        m.setattr(toa5, "_toa5_fast", lambda p, required: None)  # the careful csv.reader path
        return toa5.read_toa5(path)


def _assert_same(path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    fast = toa5._read_toa5_chunked(Path(path), columns.REQUIRED_TOA5_COLUMNS)
    assert fast is not None, f"{path}: clean file, the C-parser path should take it"
    slow = _row_by_row(Path(path), monkeypatch)
    pd.testing.assert_frame_equal(fast[0], slow[0], check_exact=True)
    assert fast[1] == slow[1]


def test_clean_file_with_nan_literals_identical(tmp_path, monkeypatch):
    rows = synthetic_rows(300)
    rows[10] = rows[10].replace(rows[10].split(",")[2], '"NAN"', 1)  # a quoted NAN as Campbell writes it
    rows[11] = rows[11].replace(rows[11].split(",")[3], "NAN", 1)
    rows[12] = rows[12].replace(rows[12].split(",")[4], "nan", 1)
    p = write_toa5(tmp_path / "a.dat", rows)  # CRLF line ends, as loggers write
    _assert_same(p, monkeypatch)
    frame, _ = toa5.read_toa5(p)
    assert frame[["Ux", "Uy", "Uz"]].isna().sum().sum() == 3


def test_real_excerpt_identical(monkeypatch):
    _assert_same(EXCERPT, monkeypatch)


@needs_record("fluxpart_csat3_toa5")
def test_real_fluxpart_file_identical(monkeypatch):
    _assert_same(sorted(SHARED.glob("*.dat"))[0], monkeypatch)


@pytest.mark.parametrize("damage", ["short_row", "long_row", "text_value", "bad_timestamp", "blank_line",
                                    "bad_record"])
def test_damaged_file_declined_and_read_row_by_row(tmp_path, monkeypatch, damage):
    rows = synthetic_rows(400)
    if damage == "short_row":
        rows[5] = rows[5].rsplit(",", 1)[0]
    elif damage == "long_row":
        rows[5] += ",9"
    elif damage == "text_value":
        rows[5] = rows[5].replace(rows[5].split(",")[2], "abc", 1)
    elif damage == "bad_timestamp":
        rows[5] = '"2023-08-21 xx:00:00"' + rows[5][rows[5].index(","):]
    elif damage == "blank_line":
        rows.insert(5, "")
    else:
        rows[5] = rows[5].replace(rows[5].split(",")[1], "12a", 1)
    p = write_toa5(tmp_path / "d.dat", rows)
    assert toa5._read_toa5_chunked(p, columns.REQUIRED_TOA5_COLUMNS) is None
    frame, info = toa5.read_toa5(p)
    assert frame.equals(_row_by_row(p, monkeypatch)[0])
    assert info["n_corrupt_lines"] + info["n_nonnumeric"] == 1


@pytest.mark.parametrize("text", ["1.5e-3", "0.12345678901234567"])
def test_number_text_that_may_round_differently_is_declined(tmp_path, monkeypatch, text):
    """An exponent or 16+ digits: read_csv and the careful path's pd.to_numeric may differ in the last bit."""
    rows = synthetic_rows(400)
    rows[7] = rows[7].replace(rows[7].split(",")[2], text, 1)
    p = write_toa5(tmp_path / "e.dat", rows)
    assert toa5._read_toa5_chunked(p, columns.REQUIRED_TOA5_COLUMNS) is None
    frame, info = toa5.read_toa5(p)
    assert frame.equals(_row_by_row(p, monkeypatch)[0]) and info["n_nonnumeric"] == 0


def test_large_files_take_the_chunked_path(tmp_path, monkeypatch):
    """Above the size threshold read_toa5 returns the chunked path's frame, equal to the careful one."""
    p = write_toa5(tmp_path / "big.dat", synthetic_rows(2000))
    monkeypatch.setattr(toa5, "_CHUNKED_MIN_BYTES", 1)
    calls = []
    real = toa5._read_toa5_chunked
    monkeypatch.setattr(toa5, "_read_toa5_chunked", lambda *a: calls.append(a) or real(*a))
    frame, _ = toa5.read_toa5(p)
    assert calls and frame.equals(_row_by_row(p, monkeypatch)[0])
