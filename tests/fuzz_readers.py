"""Byte-level logger faults and the readers they are fed to (shared by the fuzz tests and the benchmark).

Each :class:`Reader` knows a few clean sample files of its format (short excerpts of real
records, files written by :mod:`dronewind.simulate`), how to read a file row by row (rows
keyed by their file line, before rows are sorted or merged) and how to call the public
reader (the checks of exceptions only). :func:`damage` applies one fault to a sample's
bytes and returns the damaged bytes with the span of clean lines it touched, so that the
property "the good rows outside the damaged span equal the clean file's rows" can be
checked line by line.

To fuzz another reader, append a :class:`Reader` to :data:`READERS` (``samples`` writes its
clean files, ``rows`` reads one row by row, ``full`` calls the public reader).
"""

from __future__ import annotations

import gzip
import math
import re
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from dronewind import datasets

REPO = Path(__file__).resolve().parents[1]
EXCERPTS = REPO / "tests" / "data" / "io_excerpts"
SHARED = datasets.data_dir()  # the real records (dronewind.datasets; read-only; excerpts only)

# ----------------------------------------------------------------------------- faults

#: Fault classes (``op`` of :func:`damage`).
OPS = ("cut_row", "cut_row_joined", "nul_block", "garbage_block", "mangle_field", "duplicate_block",
       "reverse_block", "header", "empty", "truncate", "gzip_truncate", "gzip_damage")
#: Fault classes of binary formats (no lines, no header line).
BINARY_OPS = ("nul_block", "garbage_block", "duplicate_block", "empty", "truncate")


@dataclass(frozen=True)
class Damage:
    """A damaged file: its bytes as written and the clean lines the fault touched.

    Attributes
    ----------
    data : bytes
        The file as written (gzip-compressed for a gzip sample).
    first, last : int
        0-based clean lines touched (inclusive); lines before ``first`` keep their number,
        lines after ``last`` move by ``shift``.
    shift : int
        Lines added (negative: removed) by the fault.
    """

    data: bytes
    first: int
    last: int
    shift: int


_BREAK = re.compile(rb"\r\n|\r|\n")  # the line ends of the readers (\n, \r\n and \r)


def _line_starts(content: bytes) -> np.ndarray:
    return np.array([0] + [m.end() for m in _BREAK.finditer(content)], dtype=np.int64)


def _n_lines(content: bytes) -> int:
    n = len(_BREAK.findall(content))
    return n + (1 if content and not content.endswith((b"\n", b"\r")) else 0)


def _line_of(starts: np.ndarray, pos: int) -> int:
    return int(np.searchsorted(starts, pos, side="right") - 1)


def _replace(content: bytes, a: int, b: int, new: bytes) -> tuple[bytes, int, int, int]:
    """``content[a:b]`` replaced by ``new``; the touched lines (the line holding ``b`` included) and the shift."""
    starts = _line_starts(content)
    first = _line_of(starts, a)
    last = _line_of(starts, b) + 1  # one more: a \r\n split by the fault ends two lines
    out = content[:a] + new + content[b:]
    return out, first, last, _n_lines(out) - _n_lines(content)


def damage(clean: bytes, op: str, u: tuple[float, float, float], junk: bytes, header_lines: int,
           gzipped: bool = False) -> Damage:
    """Apply one fault to a clean file's content.

    Parameters
    ----------
    clean : bytes
        Uncompressed content.
    op : str
        One of :data:`OPS`.
    u : tuple of float
        Three numbers in [0, 1) placing and sizing the fault (where, how long, what).
    junk : bytes
        Bytes of a garbage block or a mangled field.
    header_lines : int
        Lines before the first data row (the faults other than ``header`` stay below them).
    gzipped : bool
        Write the result gzip-compressed (and allow the gzip faults).

    Returns
    -------
    Damage
    """
    starts = _line_starts(clean)
    n_lines = _n_lines(clean)
    body_first = min(header_lines, max(n_lines - 1, 0))
    n_body = max(n_lines - body_first, 1)
    line = body_first + min(int(u[0] * n_body), n_body - 1)
    a_line = int(starts[line])
    end_line = int(starts[line + 1]) - 1 if line + 1 < starts.size else len(clean)  # the \n (or the end)
    width = end_line - a_line
    pos = a_line + int(u[1] * max(width, 1))
    block = 1 + int(u[1] * min(40, n_body - 1 - (line - body_first)))  # lines of a block
    if op == "cut_row":  # the rest of the row lost, its line end kept
        new, f, la, sh = _replace(clean, pos, end_line, b"")
    elif op == "cut_row_joined":  # the rest of the row and its line end lost
        new, f, la, sh = _replace(clean, pos, min(end_line + 1, len(clean)), b"")
    elif op == "nul_block":
        n = 1 + int(u[2] * 511)
        if u[2] < 0.5:
            new, f, la, sh = _replace(clean, pos, pos, b"\x00" * n)
        else:
            new, f, la, sh = _replace(clean, pos, min(pos + n, len(clean)), b"\x00" * n)
    elif op == "garbage_block":
        new, f, la, sh = _replace(clean, pos, min(pos + int(u[2] * len(junk)), len(clean)), junk)
    elif op == "mangle_field":
        k = max(1, min(len(junk), 1 + int(u[2] * 6)))
        new, f, la, sh = _replace(clean, pos, min(pos + k, end_line), junk[:k].replace(b"\n", b" "))
    elif op == "duplicate_block":
        stop = int(starts[min(line + block, starts.size - 1)]) if line + block < starts.size else len(clean)
        copy = clean[a_line:stop]
        if not copy.endswith(b"\n"):
            copy += b"\n"
        new, f, la, sh = _replace(clean, stop, stop, copy)
    elif op == "reverse_block":
        stop = int(starts[line + block]) if line + block < starts.size else len(clean)
        rows = clean[a_line:stop].split(b"\n")
        tail = rows.pop() if not clean[a_line:stop].endswith(b"\n") else None
        if tail is not None:
            rows.append(tail)
        else:
            rows = rows[:-1]
        text = b"\n".join(reversed(rows)) + (b"\n" if clean[a_line:stop].endswith(b"\n") else b"")
        new, f, la, sh = _replace(clean, a_line, stop, text)
    elif op == "header":
        h_end = int(starts[min(header_lines, starts.size - 1)]) if header_lines else 0
        hp = int(u[0] * max(h_end, 1))
        k = max(1, min(len(junk), 1 + int(u[2] * 8)))
        new, f, la, sh = _replace(clean, hp, min(hp + k, len(clean)), junk[:k])
    elif op == "empty":
        new, f, la, sh = b"", 0, n_lines, -n_lines
    elif op in ("truncate", "gzip_truncate", "gzip_damage"):
        if op == "truncate" or not gzipped:
            cut = a_line + int(u[1] * max(width, 1)) if u[2] < 0.7 else int(u[0] * len(clean))
            new, f, la, sh = _replace(clean, cut, len(clean), b"")
        else:
            packed = gzip.compress(clean, mtime=0)
            cut = 10 + int(u[0] * (len(packed) - 10))
            if op == "gzip_truncate":
                packed = packed[:cut]
            else:
                packed = packed[:cut] + junk[:1 + int(u[2] * 63)] + packed[cut:]
            d = zlib.decompressobj(wbits=31)
            try:
                got = d.decompress(packed)
            except zlib.error:
                got = b""  # where the damage stops the stream is not known here: every line is in the span
                return Damage(packed, 0, n_lines, 0)
            if d.eof and got == clean:
                return Damage(packed, n_lines, n_lines, 0)  # the damage hit the trailer's padding only
            k = len(got)
            f = _line_of(starts, k)
            return Damage(packed, min(f, n_lines), n_lines, 0)
    else:
        raise ValueError(op)
    return Damage(gzip.compress(new, mtime=0) if gzipped else new, f, la, sh)


# ----------------------------------------------------------------------------- readers


@dataclass(frozen=True)
class Reader:
    """A reader under fuzzing.

    Attributes
    ----------
    name : str
        Short name.
    file_name : str
        Name the damaged file is written under (some readers need it, e.g. a Gill block).
    header_lines : int
        Lines before the first data row.
    gzipped : bool
        The samples are written gzip-compressed.
    samples : callable
        ``samples(folder)`` -> {sample name: clean uncompressed content}.
    rows : callable or None
        ``rows(path)`` -> ({0-based line: tuple of values}, counts); None for a binary format.
    full : callable
        ``full(path)``: the public reader on one file.
    ops : tuple of str
        Fault classes that apply.
    records : tuple of str
        The real records (:mod:`dronewind.datasets`) the samples are cut from, where they have no
        synthetic sample: without them the reader has no sample.
    """

    name: str
    file_name: str
    header_lines: int
    gzipped: bool
    samples: Callable[[Path], dict[str, bytes]]
    rows: Callable[[Path], tuple[dict[int, tuple], dict[str, int]]] | None
    full: Callable[[Path], Any]
    ops: tuple[str, ...]
    records: tuple[str, ...] = ()


def _head(path: Path, n_lines: int, gz: bool = False) -> bytes:
    opener = gzip.open if gz else open
    out = []
    with opener(path, "rb") as fh:
        for _ in range(n_lines):
            ln = fh.readline()
            if not ln:
                break
            out.append(ln)
    return b"".join(out)


def _key(values: Any) -> tuple:
    """Row values as a comparable tuple (NaN equal to NaN)."""
    out = []
    for v in values:
        if isinstance(v, (float, np.floating)) and math.isnan(v):
            out.append("nan")
        elif isinstance(v, np.datetime64):
            out.append("NaT" if np.isnat(v) else int(v.astype("datetime64[ns]").astype(np.int64)))
        else:
            out.append(v.item() if hasattr(v, "item") else v)
    return tuple(out)


def _sim_series(n: int, seed: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.datetime64("2024-05-03T10:00:00", "ns") + (np.arange(n) * 50_000_000).astype("timedelta64[ns]")
    return {"time": t, "u": 3 + rng.normal(0, 0.8, n), "v": -1 + rng.normal(0, 0.8, n), "w": rng.normal(0, 0.3, n),
            "t": 18 + rng.normal(0, 0.2, n)}


# TOA5 -------------------------------------------------------------------------


def _toa5_samples(folder: Path) -> dict[str, bytes]:
    from dronewind.simulate.writers import write_toa5

    s = _sim_series(240, 1)
    sim = write_toa5(folder / "toa5_sim.dat", s["time"], np.arange(1000, 1240), s["u"], s["v"], s["w"], s["t"],
                     np.zeros(240, dtype=np.int64))
    out = {"excerpt": (EXCERPTS / "TOA5_6843.ts_Above_2012_06_07_1245_excerpt.dat").read_bytes(),
           "simulated": sim.read_bytes()}
    real = SHARED / "fluxpart_csat3_toa5" / "TOA5_6843.ts_Above_2012_06_07_1300.dat"
    if real.is_file():
        out["real_1300"] = _head(real, 244)
    return out


def _toa5_rows(path: Path) -> tuple[dict[int, tuple], dict[str, int]]:
    from dronewind.mast.toa5 import read_toa5

    frame, info = read_toa5(path)
    cols = [c for c in frame.columns if c not in ("_line",)]
    rows = {int(ln) - 1: _key(r) for ln, r in zip(frame["_line"].to_numpy(), frame[cols].itertuples(index=False),
                                                  strict=True)}
    return rows, {"n_corrupt": int(info["n_corrupt_lines"]), "n_nonnumeric": int(info["n_nonnumeric"])}


def _toa5_full(path: Path) -> Any:
    from dronewind.mast.level1 import mast_l1

    return mast_l1(path, azimuth_deg=200.0, height_m=3.0, sensor_id="csat")


# Gill RAW ---------------------------------------------------------------------


def _gill_samples(folder: Path) -> dict[str, bytes]:
    out = {"excerpt": gzip.decompress((EXCERPTS / "G1040000.RAW.gz").read_bytes())}
    real = SHARED / "ameriflux_gold_openpath" / "G1040030.RAW.gz"
    if real.is_file():
        out["real_0030"] = _head(real, 300, gz=True)
    return out


def _gill_rows(path: Path) -> tuple[dict[int, tuple], dict[str, int]]:
    from dronewind.mast.ameriflux import _read_gold_values

    vals, corrupt, line_no = _read_gold_values(path, 0.05, with_lines=True)
    rows = {int(ln) - 1: _key(v) for v, c, ln in zip(vals, corrupt, line_no, strict=True) if not c}
    return rows, {"n_corrupt": int(corrupt.sum())}


def _gill_full(path: Path) -> Any:
    from dronewind.mast.ameriflux import read_ameriflux_gold

    return read_ameriflux_gold(path)


# generic delimited -------------------------------------------------------------------

_DELIMITED_SPEC = {"delimiter": ";", "header_line": 2, "skip_lines": 1,
                   "time": {"column": "stamp", "kind": "iso", "utc_offset_hours": 1.0},
                   "variables": {"u": {"column": "U", "unit": "cm/s"}, "v": {"column": "V", "unit": "m/s"},
                                 "w": {"column": "W", "unit": "m/s"}, "t": {"column": "T", "unit": "degC"}}}


def _delimited_samples(folder: Path) -> dict[str, bytes]:
    s = _sim_series(240, 2)
    stamps = pd.Series(s["time"]).dt.strftime("%Y-%m-%d %H:%M:%S.%f").str.slice(0, 23)
    frame = pd.DataFrame({"stamp": stamps, "U": np.round(100 * s["u"], 1), "V": np.round(s["v"], 3),
                          "W": np.round(s["w"], 3), "T": np.round(s["t"], 2)})
    text = "logger 7 export\n" + frame.to_csv(sep=";", index=False, lineterminator="\n").replace(
        "\n", "\nunits;cm/s;m/s;m/s;degC\n", 1)
    return {"simulated": text.encode()}


def _delimited_layout(gz: bool) -> Any:
    from dronewind.core.delimited import delimited_layout

    return delimited_layout({**_DELIMITED_SPEC, "compression": "gzip" if gz else "none"}, "fuzz")


def _delimited_rows(path: Path) -> tuple[dict[int, tuple], dict[str, int]]:
    from dronewind.core.delimited import read_delimited

    tab = read_delimited(path, _delimited_layout(path.name.endswith(".gz")))
    names = list(tab.values)
    rows = {int(ln) - 1: _key([t, *(tab.values[k][i] for k in names)])
            for i, (ln, t) in enumerate(zip(tab.line_no, tab.time, strict=True))}
    return rows, {"n_corrupt": tab.n_corrupt, "n_nonnumeric": tab.n_nonnumeric}


def _delimited_full(path: Path) -> Any:
    from dronewind.mast.delimited import mast_l1_delimited

    spec = {**_DELIMITED_SPEC, "compression": "gzip" if path.name.endswith(".gz") else "none",
            "axes": {"convention": "enu"}}
    return mast_l1_delimited([path], spec, {"id": "sonic", "height_m": 3.0, "azimuth_deg": 0.0})


# payload CSVs ----------------------------------------------------------------------


def _payload_sim(n: int, seed: int) -> dict[str, np.ndarray]:
    s = _sim_series(n, seed)
    rng = np.random.default_rng(seed + 10)
    rpi = 5_000_000 + np.arange(n, dtype=np.int64) * 50_000 + rng.integers(-300, 300, n)
    return {**s, "rpi": rpi}


def _sonic_samples(folder: Path) -> dict[str, bytes]:
    from dronewind.simulate.writers import write_payload_sonic_csv

    s = _payload_sim(300, 3)
    p = write_payload_sonic_csv(folder / "sonic_sim.csv", s["rpi"], s["u"], s["v"], s["w"], s["t"])
    return {"simulated": p.read_bytes()}


def _ins_samples(folder: Path) -> dict[str, bytes]:
    from dronewind.simulate.writers import write_ins_csv

    n = 300
    s = _payload_sim(n, 4)
    valid = np.ones(n, dtype=np.int64)
    valid[:20] = 0
    rng = np.random.default_rng(9)
    p = write_ins_csv(folder / "ins_sim.csv", s["rpi"], s["time"], valid, np.ones(n, dtype=np.int64),
                      48.1 + rng.normal(0, 1e-6, n), 11.5 + rng.normal(0, 1e-6, n), 520 + rng.normal(0, 0.1, n),
                      rng.normal(0, 0.1, n), rng.normal(0, 0.1, n), rng.normal(0, 0.05, n), rng.normal(0, 2, n),
                      rng.normal(0, 2, n), 90 + rng.normal(0, 3, n))
    return {"simulated": p.read_bytes()}


def _payload_rows(expected: tuple[str, ...], kinds: dict[str, str]) -> Callable[[Path], Any]:
    def rows(path: Path) -> tuple[dict[int, tuple], dict[str, int]]:
        from dronewind.payload.reader import _parse_csv

        table = _parse_csv(path, expected, kinds, 0.05)
        out = {int(ln) - 1: _key([table.columns[c][i] for c in expected]) for i, ln in enumerate(table.line_no)}
        return out, {"n_corrupt": int(table.counts["n_corrupt_lines"])}

    return rows


def _sonic_full(path: Path) -> Any:
    from dronewind.payload.reader import read_sonic_csv

    return read_sonic_csv(path)


def _ins_full(path: Path) -> Any:
    from dronewind.payload.reader import read_ins_csv

    return read_ins_csv(path)


# quadrotor CSV and tower reference -------------------------------------------------


def _quad_samples(folder: Path) -> dict[str, bytes]:
    from dronewind.quadrotor.columns import QUADROTOR_COLUMNS

    n = 200
    rng = np.random.default_rng(5)
    t = np.datetime64("2020-07-24T10:19:30", "ns") + (np.arange(n) * 100_000_000).astype("timedelta64[ns]")
    stamps = pd.Series(t).dt.strftime("%Y-%m-%dT%H:%M:%S.%f").str.slice(0, 21) + "Z"
    cols = {"time_utc": stamps}
    for c in QUADROTOR_COLUMNS[1:]:
        cols[c] = np.round(rng.normal(0, 3, n), 4)
    return {"simulated": pd.DataFrame(cols).to_csv(index=False, lineterminator="\n").encode()}


def _quad_rows(path: Path) -> tuple[dict[int, tuple], dict[str, int]]:
    from dronewind.quadrotor.io import _quadrotor_rows

    time, cols, line_no, counts = _quadrotor_rows(path, 0.05)
    names = list(cols)
    return ({int(ln) - 1: _key([time[i], *(cols[k][i] for k in names)]) for i, ln in enumerate(line_no)},
            {"n_corrupt": counts["n_corrupt_lines"]})


def _quad_full(path: Path) -> Any:
    from dronewind.quadrotor.io import read_quadrotor_csv

    return read_quadrotor_csv(path)


def _tower_samples(folder: Path) -> dict[str, bytes]:
    rng = np.random.default_rng(6)
    lines = ["time_utc,height_m,wind_speed_ms,wind_from_deg"]
    for k in range(120):
        for h in (10, 40, 98):
            lines.append(f"2020-07-24T10:{19 + k // 60:02d}:{k % 60:02d}Z,{h},{abs(rng.normal(5, 1)):.2f},"
                         f"{rng.uniform(180, 240):.1f}")
    return {"simulated": ("\n".join(lines) + "\n").encode()}


def _tower_rows(path: Path) -> tuple[dict[int, tuple], dict[str, int]]:
    from dronewind.quadrotor.reference import _reference_rows

    long, counts = _reference_rows(path, 0.05)
    rows = {int(r.line) - 1: _key([r.time, r.height_m, r.wind_speed_ms, r.wind_from_deg])
            for r in long.itertuples(index=False)}
    return rows, {"n_corrupt": counts["n_corrupt_lines"]}


def _tower_full(path: Path) -> Any:
    from dronewind.quadrotor.reference import read_tower_reference

    return read_tower_reference(path)


# PX4 ULog ----------------------------------------------------------------------------


def _ulog_samples(folder: Path) -> dict[str, bytes]:
    real = SHARED / "px4_ulog" / "sample_log_small.ulg"
    if not real.is_file():
        return {}
    with open(real, "rb") as fh:
        return {"real_head": fh.read(200_000)}


def _ulog_full(path: Path) -> Any:
    from dronewind.quadrotor.ulog import read_quadrotor_ulog

    return read_quadrotor_ulog(path)


# ArduPilot DataFlash -----------------------------------------------------------------


def _dataflash_samples(folder: Path) -> dict[str, bytes]:
    real = next(iter(sorted((SHARED / "ardupilot_dataflash").glob("*.bin"))), None)
    if real is None:
        return {}
    with open(real, "rb") as fh:
        return {"real_head": fh.read(400_000)}


def _dataflash_full(path: Path) -> Any:
    from dronewind.quadrotor.ardupilot import read_quadrotor_ardupilot

    return read_quadrotor_ardupilot(path)


_TEXT_OPS = tuple(o for o in OPS if not o.startswith("gzip"))
_SONIC_KINDS = {"rpi_time_us": "int", "u_ms": "float", "v_ms": "float", "w_ms": "float", "t_sonic_c": "float"}


def _ins_kinds() -> tuple[tuple[str, ...], dict[str, str]]:
    from dronewind.core.columns import INS_COLUMNS

    kinds = {c: "float" for c in INS_COLUMNS}
    kinds.update(rpi_time_us="int", utc="utc", time_valid="flag", ekf_valid="int")
    return INS_COLUMNS, kinds


def _sonic_columns() -> tuple[str, ...]:
    from dronewind.core.columns import SONIC_COLUMNS

    return SONIC_COLUMNS


#: The readers under fuzzing; another reader (e.g. of ArduPilot DataFlash logs) is added here.
READERS: list[Reader] = [
    Reader("toa5", "TOA5_fuzz.dat", 4, False, _toa5_samples, _toa5_rows, _toa5_full, _TEXT_OPS),
    Reader("gill_raw", "G1040000.RAW.gz", 0, True, _gill_samples, _gill_rows, _gill_full, OPS),
    Reader("delimited", "mast.txt", 3, False, _delimited_samples, _delimited_rows, _delimited_full, _TEXT_OPS),
    Reader("delimited_gz", "mast.txt.gz", 3, True, _delimited_samples, _delimited_rows, _delimited_full, OPS),
    Reader("payload_sonic", "sonic.csv", 1, False, _sonic_samples, _payload_rows(_sonic_columns(), _SONIC_KINDS),
           _sonic_full, _TEXT_OPS),
    Reader("payload_ins", "ins.csv", 1, False, _ins_samples, _payload_rows(*_ins_kinds()), _ins_full, _TEXT_OPS),
    Reader("quadrotor_csv", "q01.csv", 1, False, _quad_samples, _quad_rows, _quad_full, _TEXT_OPS),
    Reader("tower_reference", "reference.csv", 1, False, _tower_samples, _tower_rows, _tower_full, _TEXT_OPS),
    Reader("px4_ulog", "log.ulg", 0, False, _ulog_samples, None, _ulog_full, BINARY_OPS, ("px4_ulog",)),
    Reader("ardupilot_bin", "log.bin", 0, False, _dataflash_samples, None, _dataflash_full, BINARY_OPS,
           ("ardupilot_dataflash",)),
]


# ----------------------------------------------------------------------------- the property


@dataclass
class Prepared:
    """A reader's clean samples, written once, with their rows."""

    reader: Reader
    folder: Path
    clean: dict[str, bytes]
    rows: dict[str, dict[int, tuple]]


def prepare(reader: Reader, folder: Path) -> Prepared:
    """Write a reader's samples and read their clean rows (the reference of :func:`check`)."""
    folder.mkdir(parents=True, exist_ok=True)
    clean = reader.samples(folder)
    rows: dict[str, dict[int, tuple]] = {}
    for name, content in clean.items():
        path = folder / reader.file_name
        path.write_bytes(gzip.compress(content, mtime=0) if reader.gzipped else content)
        if reader.rows is not None:
            rows[name] = reader.rows(path)[0]
            assert rows[name], f"{reader.name} {name}: no rows in the clean sample"
        reader.full(path)  # the clean sample reads without error
    return Prepared(reader, folder, clean, rows)


def check(prep: Prepared, sample: str, op: str, u: tuple[float, float, float], junk: bytes) -> str:
    """Damage one sample, read it, and check the property; return the outcome.

    The only exception that may leave the reader is :class:`dronewind.errors.InputError`;
    when it reads the file, every row of a clean line outside the damaged span is read, at
    its (shifted) line, with the clean values, and no row appears at a line outside the
    span that the clean file did not have.

    Returns
    -------
    str
        ``"read"`` (the public reader returned), ``"input_error"`` (it raised the named error).
    """
    from dronewind.errors import InputError

    r = prep.reader
    d = damage(prep.clean[sample], op, u, junk, r.header_lines, r.gzipped)
    path = prep.folder / r.file_name
    path.write_bytes(d.data)
    try:
        r.full(path)
        outcome = "read"
    except InputError:
        outcome = "input_error"
    if r.rows is None:
        return outcome
    try:
        rows, _ = r.rows(path)
    except InputError:
        return outcome
    clean = prep.rows[sample]
    for ln, row in clean.items():
        if d.first <= ln <= d.last:
            continue
        at = ln if ln < d.first else ln + d.shift
        assert rows.get(at) == row, (f"{r.name}/{sample} {op} {u}: clean line {ln + 1} (now {at + 1}) read as "
                                     f"{rows.get(at)}, expected {row}")
    for ln in rows:
        if ln < d.first:
            assert ln in clean, f"{r.name}/{sample} {op} {u}: a row at line {ln + 1} before the damage"
        elif ln > d.last + d.shift:
            assert ln - d.shift in clean, f"{r.name}/{sample} {op} {u}: a row at line {ln + 1} after the damage"
    return outcome


def reader_by_name(name: str) -> Reader:
    """The entry of :data:`READERS` called ``name``."""
    return next(r for r in READERS if r.name == name)
