"""Long steps say what they have done: one log line per item, with its count and elapsed time."""

from __future__ import annotations

import logging
import re

import pytest

from dronewind.core.progress import Progress


def test_one_line_per_item_with_count_and_time(caplog):
    caplog.set_level(logging.INFO, logger="dronewind")
    progress = Progress("figure", 3, "drawn")
    for name in ("fig04_tke_lag", "fig07_positions"):
        with progress.item(name):
            pass
    progress.skipped("fig08_timeseries", "no usable flight")
    progress.finished()
    lines = [r.getMessage() for r in caplog.records]
    assert re.fullmatch(r"figure 1/3 fig04_tke_lag drawn in \d+\.\d s", lines[0])
    assert re.fullmatch(r"figure 2/3 fig07_positions drawn in \d+\.\d s", lines[1])
    assert lines[2] == "figure 3/3 fig08_timeseries skipped: no usable flight"
    assert re.fullmatch(r"figure: 3/3 drawn in \d+\.\d s", lines[3])


def test_an_item_that_fails_is_not_counted(caplog):
    caplog.set_level(logging.INFO, logger="dronewind")
    progress = Progress("probe", 2, "run")
    with pytest.raises(ValueError), progress.item("bad"):
        raise ValueError("boom")
    assert progress.done == 0 and not caplog.records
