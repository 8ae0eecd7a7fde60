"""Tests of the AmeriFlux open-path gold reader (dronewind.mast.ameriflux)."""

from __future__ import annotations

import gzip
import types
from pathlib import Path

import numpy as np
import pytest

from dronewind.errors import InputError
from dronewind.mast.ameriflux import gill_to_enu, read_ameriflux_gold, read_ameriflux_gold_blocks
from tests.conftest import needs_record, record_path

HERE = Path(__file__).resolve().parents[1]
SHARED = record_path("ameriflux_gold_openpath")
EXCERPT = HERE / "data" / "io_excerpts" / "G1040000.RAW.gz"


@pytest.mark.parametrize(
    ("beta", "u", "v", "east", "north"),
    [
        (0.0, 1.0, 0.0, 0.0, 1.0),  # sonic N on true north: U = northward flow
        (0.0, 0.0, 1.0, -1.0, 0.0),  # V = flow towards the sonic's W = westward
        (90.0, 1.0, 0.0, 1.0, 0.0),  # sonic N facing east: U = eastward flow
        (240.0, 1.0, 0.0, np.sin(np.radians(240)), np.cos(np.radians(240))),
        (240.0, 0.0, 1.0, np.sin(np.radians(150)), np.cos(np.radians(150))),
    ],
)  # fmt: skip
def test_gill_to_enu(beta, u, v, east, north):
    e, n = gill_to_enu(np.array([u]), np.array([v]), beta)
    np.testing.assert_allclose([e[0], n[0]], [east, north], atol=1e-12)


def test_gill_to_enu_preserves_speed():
    rng = np.random.default_rng(0)
    u, v = rng.normal(size=(2, 100))
    e, n = gill_to_enu(u, v, 240.0)
    np.testing.assert_allclose(np.hypot(e, n), np.hypot(u, v))


def test_excerpt_layout_and_values():
    ds = read_ameriflux_gold(EXCERPT)
    assert ds.sizes["time"] == 300
    # first line of the file: +0.110,-0.930,+0.600,20.82,2.992,2.246 (w, u, v, T, H2O, CO2)
    np.testing.assert_allclose(
        [ds.w_gill_ms[0], ds.u_gill_ms[0], ds.v_gill_ms[0], ds.t_sonic_c[0], ds.h2o_v[0],
         ds.co2_v[0]], [0.110, -0.930, 0.600, 20.82, 2.992, 2.246])  # fmt: skip
    np.testing.assert_allclose(ds.t_sonic_k[0], 293.97)
    np.testing.assert_allclose(ds.h2o_mmol_m3[0], 598.4)
    np.testing.assert_allclose(ds.co2_mmol_m3[0], 10 + 3 * 2.246)
    e, n = gill_to_enu(-0.93, 0.6, 240.0)
    np.testing.assert_allclose([ds.u_east_ms[0], ds.v_north_ms[0]], [e, n])
    # DOY 104 of the nominal year 2000 = 13 April; local 00:00 PST = 08:00 UTC
    assert str(ds.time.values[0]) == "2000-04-13T08:00:00.000000000"
    assert ds.time.values[1] - ds.time.values[0] == np.timedelta64(100, "ms")
    assert ds.attrs["n_missing_rows"] == 18000 - 300
    assert ds.attrs["sampling_rate_hz"] == 10.0
    ds2 = read_ameriflux_gold(EXCERPT, year=2004, utc_offset_hours=0.0)
    assert str(ds2.time.values[0]) == "2004-04-13T00:00:00.000000000"


def test_bad_files_raise(tmp_path):
    bad_name = tmp_path / "data.RAW.gz"
    bad_name.write_bytes(EXCERPT.read_bytes())
    with pytest.raises(InputError, match="G<DDD><HHMM>"):
        read_ameriflux_gold(bad_name)
    lines = gzip.decompress(EXCERPT.read_bytes()).decode().splitlines()
    lines[10] = lines[10].replace(",,,", ",7,,", 1)  # a number in an empty column: one corrupt line
    extra = tmp_path / "G1040030.RAW"
    extra.write_text("\r\n".join(lines) + "\r\n")
    ds = read_ameriflux_gold(extra)
    assert ds.attrs["n_corrupt_lines"] == 1 and "corrupt lines of G1040030.RAW: [11]" in ds.attrs["processing_log"]
    assert np.isnan(ds["w_gill_ms"].values[10]) and ds.sizes["time"] == 300
    for i in range(10, 30):  # in many lines: the columns declared are not the file's
        lines[i] = lines[i].replace(",,,", ",7,,", 1)
    extra.write_text("\r\n".join(lines) + "\r\n")
    with pytest.raises(InputError, match=r"G1040030\.RAW:11: non-empty field beyond column 6"):
        read_ameriflux_gold(extra)
    lines = gzip.decompress(EXCERPT.read_bytes()).decode().splitlines()
    for i in range(20):
        lines[i] = "x" + lines[i]
    corrupt = tmp_path / "G1040100.RAW"
    corrupt.write_text("\r\n".join(lines) + "\r\n")
    with pytest.raises(InputError, match=r"G1040100\.RAW:1: 20 of 300 lines"):
        read_ameriflux_gold(corrupt)


def test_blocks_are_lazy_and_ordered(tmp_path):
    raw = EXCERPT.read_bytes()
    for name in ("G1810030.RAW.gz", "G1040030.RAW.gz", "G1040000.RAW.gz"):
        (tmp_path / name).write_bytes(raw)
    gen = read_ameriflux_gold_blocks([tmp_path])
    assert isinstance(gen, types.GeneratorType)
    starts = [str(ds.time.values[0])[:16] for ds in gen]
    assert starts == ["2000-04-13T08:00", "2000-04-13T08:30", "2000-06-29T08:30"]


@needs_record("ameriflux_gold_openpath")
def test_all_96_real_files_parse():
    files = sorted(SHARED.glob("G*.RAW.gz"))
    assert len(files) == 96
    n_rows = {}
    for ds in read_ameriflux_gold_blocks(files, despike=False):
        name = Path(ds.attrs["source_file"]).name
        n_rows[name] = ds.sizes["time"]
        assert ds.attrs["n_corrupt_lines"] == 0
        assert ds.attrs["n_out_of_range"] == 0
        assert np.isfinite(ds.u_east_ms.values).all()
        assert 280 < float(ds.t_sonic_k.mean()) < 320
    # measured: 93 files hold 17999 rows, three hold 17998 (none holds 18000)
    short = sorted(k for k, v in n_rows.items() if v == 17998)
    assert short == ["G1040500.RAW.gz", "G1041330.RAW.gz", "G1810430.RAW.gz"]
    assert sum(v == 17999 for v in n_rows.values()) == 93
    days = sorted({k[1:4] for k in n_rows})
    assert days == ["104", "181"]
