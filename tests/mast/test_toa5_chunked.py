"""The TOA5 parser reads long files block by block: the same rows, counts and line numbers as in one block."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from dronewind.mast import toa5
from tests.conftest import needs_record
from tests.mast.test_io_toa5 import EXCERPT, SHARED, synthetic_rows, write_toa5


def _row_by_row(path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[pd.DataFrame, dict]:
    """The parser's result with every line through the fault handling (the reference)."""
    with monkeypatch.context() as m:
        m.setattr(toa5, "_regular_rows", lambda body, starts, ends, names: (np.zeros(starts.size, dtype=bool), {}))
        return toa5.read_toa5(path)


def _assert_same(path: Path, monkeypatch: pytest.MonkeyPatch, blocks: tuple[int, ...] = (7, 64, 400_000)) -> None:
    slow = _row_by_row(Path(path), monkeypatch)
    for block in blocks:
        with monkeypatch.context() as m:
            m.setattr(toa5, "_BLOCK_LINES", block)
            fast = toa5.read_toa5(path)
        pd.testing.assert_frame_equal(fast[0], slow[0], check_exact=True)
        for col in slow[0]:
            assert fast[0][col].to_numpy().tobytes() == slow[0][col].to_numpy().tobytes(), (block, col)
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
    _assert_same(sorted(SHARED.glob("*.dat"))[0], monkeypatch, blocks=(5000, 400_000))


@pytest.mark.parametrize("damage", ["short_row", "long_row", "text_value", "bad_timestamp", "blank_line",
                                    "bad_record"])
@pytest.mark.parametrize("at", [5, 63, 64])  # inside a block, at the last and the first line of one
def test_damaged_rows_cost_their_lines_in_every_block(tmp_path, monkeypatch, damage, at):
    rows = synthetic_rows(400)
    if damage == "short_row":
        rows[at] = rows[at].rsplit(",", 1)[0]
    elif damage == "long_row":
        rows[at] += ",9"
    elif damage == "text_value":
        rows[at] = rows[at].replace(rows[at].split(",")[2], "abc", 1)
    elif damage == "bad_timestamp":
        rows[at] = '"2023-08-21 xx:00:00"' + rows[at][rows[at].index(","):]
    elif damage == "blank_line":
        rows.insert(at, "")
    else:
        rows[at] = rows[at].replace(rows[at].split(",")[1], "12a", 1)
    p = write_toa5(tmp_path / "d.dat", rows)
    _assert_same(p, monkeypatch)
    frame, info = toa5.read_toa5(p)
    assert info["n_corrupt_lines"] + info["n_nonnumeric"] == 1
    if damage != "text_value":
        assert info["corrupt_lines"] == [at + 5] and at + 5 not in frame["_line"].tolist()


@pytest.mark.parametrize("text", ["1.5e-3", "0.12345678901234567"])
def test_number_text_that_may_round_differently_goes_to_the_fault_handling(tmp_path, monkeypatch, text):
    """An exponent or 16+ digits: read_csv and pandas' to_numeric may differ in the last bit."""
    rows = synthetic_rows(400)
    rows[7] = rows[7].replace(rows[7].split(",")[2], text, 1)
    p = write_toa5(tmp_path / "e.dat", rows)
    handed = []
    real = toa5._irregular_rows
    monkeypatch.setattr(toa5, "_irregular_rows", lambda lines, *a: handed.append(len(lines)) or real(lines, *a))
    frame, info = toa5.read_toa5(p)
    assert handed == [1] and info["n_nonnumeric"] == 0
    monkeypatch.undo()
    _assert_same(p, monkeypatch)
