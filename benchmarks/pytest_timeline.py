"""pytest plugin of benchmarks/bench_test_suite.py: each test's wall span and CPU, one JSON line per test.

Loaded with ``-p pytest_timeline`` (``benchmarks`` on ``PYTHONPATH``); writes to
``$DRONEWIND_TIMELINE_DIR/timeline-<worker>.jsonl`` (``main`` without pytest-xdist). The CPU
is the process's own and that of the children it waited for (workflow runs, the compliance
checker), from ``getrusage``; a test's module- or suite-wide fixture is counted in the
first test that uses it.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import pytest

from bench_common import cpu_s_with_children


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: pytest.Item | None):
    start_s, cpu0_s = time.time(), cpu_s_with_children()
    yield
    folder = os.environ.get("DRONEWIND_TIMELINE_DIR")
    if folder:
        worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
        line = {"id": item.nodeid, "start_s": start_s, "end_s": time.time(), "cpu_s": cpu_s_with_children() - cpu0_s}
        with (Path(folder) / f"timeline-{worker}.jsonl").open("a") as out:
            out.write(json.dumps(line) + "\n")
