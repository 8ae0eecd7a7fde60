"""Property-based fuzzing of every reader with byte-level logger faults (hypothesis).

Each reader of :data:`tests.fuzz_readers.READERS` is fed its clean sample files (excerpts
of real records, files of :mod:`dronewind.simulate`) with one random fault: a row cut
short (line end kept or lost), a block of NUL bytes or of binary garbage, a mangled field,
a duplicated or reversed block of lines, a damaged header, an empty file, a truncated file
or gzip member, damaged gzip data. The property (:func:`tests.fuzz_readers.check`): only
:class:`dronewind.errors.InputError` may leave the reader, and the rows it reads from the
lines outside the damaged span equal the clean file's rows. The budget is fixed and the
examples derandomized, so the run is the same in CI; a longer run is
``benchmarks/bench_reader_fuzzing.py`` (``benchmarks/results/reader_fuzzing.json``).
"""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.conftest import record_skip_reason
from tests.fuzz_readers import OPS, READERS, Prepared, Reader, check, damage, prepare

#: Examples per reader in the test suite (the whole file runs in well under a minute).
MAX_EXAMPLES = 30

def _no_sample(reader: Reader) -> str:
    """Why a reader has no sample: its real records' skip reasons (data folder and fetch command)."""
    return "; ".join(filter(None, map(record_skip_reason, reader.records))) or f"no sample of {reader.name}"


_unit = st.floats(min_value=0.0, max_value=1.0, exclude_max=True, allow_nan=False)


@pytest.fixture(scope="module")
def prepared(tmp_path_factory) -> dict[str, Prepared]:
    base = tmp_path_factory.mktemp("fuzz")
    return {r.name: prepare(r, base / r.name) for r in READERS}


@pytest.mark.parametrize("name", [r.name for r in READERS])
def test_reader_takes_random_faults(prepared, name):
    prep = prepared[name]
    if not prep.clean:
        pytest.skip(_no_sample(prep.reader))
    outcomes: list[str] = []

    @settings(max_examples=MAX_EXAMPLES, deadline=None, derandomize=True, database=None,
              suppress_health_check=list(HealthCheck))
    @given(sample=st.sampled_from(sorted(prep.clean)), op=st.sampled_from(prep.reader.ops),
           u=st.tuples(_unit, _unit, _unit), junk=st.binary(min_size=1, max_size=400))
    def run(sample, op, u, junk):
        outcomes.append(check(prep, sample, op, u, junk))

    run()
    assert len(outcomes) >= MAX_EXAMPLES // 2
    if prep.reader.rows is not None:
        assert "read" in outcomes  # most faults are rows, read around


@pytest.mark.parametrize("name, op", [(r.name, op) for r in READERS for op in r.ops])
def test_every_fault_class_once(prepared, name, op):
    """Each fault class at a fixed place: the property, and what a row fault costs."""
    prep = prepared[name]
    if not prep.clean:
        pytest.skip(_no_sample(prep.reader))
    sample = sorted(prep.clean)[0]
    outcome = check(prep, sample, op, (0.5, 0.5, 0.3), bytes(range(7, 250, 3)))
    row_faults = ("cut_row_joined", "nul_block", "garbage_block", "duplicate_block", "reverse_block")
    if op == "empty":
        assert outcome == "input_error"
    elif op in row_faults and prep.reader.rows is not None:
        assert outcome == "read", f"{name}: one {op} in the middle stopped the reader"


def test_damage_spans_are_right():
    """The harness itself: lines outside the span are unchanged and moved by the shift."""
    clean = b"h1\nh2\n" + b"".join(b"row %d,1,2\n" % i for i in range(50))
    for op in OPS:
        for u in ((0.1, 0.2, 0.3), (0.9, 0.9, 0.9), (0.5, 0.0, 0.6)):
            d = damage(clean, op, u, b"\x00\nxy\n", 2)
            a, b = clean.split(b"\n")[:-1], d.data.split(b"\n")
            for i, line in enumerate(a):
                if i < d.first:
                    assert b[i] == line
                elif i > d.last and op not in ("empty", "truncate"):
                    assert b[i + d.shift] == line, (op, u, i)
