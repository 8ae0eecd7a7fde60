"""Tests for dronewind.tables (Tables 4 and 5 of Ghirardelli et al. (2025) from stored L4 products)."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import pandas as pd
import pytest

from dronewind import tables
from dronewind.core.products import open_product
from dronewind.errors import InputError
from tests.products_fixture import FLIGHTS, set_nan, write_products


@pytest.fixture(scope="module")
def products(tmp_path_factory) -> Path:
    return write_products(tmp_path_factory.mktemp("products"))


def _l4_files(root: Path) -> list[Path]:
    return sorted((root / "netcdf" / "L4").glob("*.nc"))


def _l4(root: Path, flight: str, sensor: str):
    return open_product(root / "netcdf" / "L4" / f"{flight}_{sensor}.nc")


def test_stability_class_known_answers() -> None:
    # Ghirardelli et al. (2025) Table 4 values and how its text describes them (s1 unstable, s7 stable)
    assert tables.stability_class(-0.46) == "unstable"
    assert tables.stability_class(0.01) == "near-neutral"
    assert tables.stability_class(0.1) == "stable"
    assert tables.stability_class(1.25) == "very stable"
    assert tables.stability_class(float("nan")) == "undefined"


def test_derived_values_without_float_noise(products: Path, tmp_path: Path) -> None:
    assert tables._derived(1680.3 / 60.0) == 28.005  # not 28.004999999999995
    paths = tables.table_flights(_l4_files(products), tmp_path / "t4")
    duration = pd.read_csv(paths[0])["duration_min"]
    assert all(len(repr(float(v))) <= 15 for v in duration)


def test_default_detail_flights() -> None:
    ten = [f"s{i:02d}" for i in range(1, 11)]
    assert tables.default_detail_flights(ten) == ["s01", "s07"]
    assert tables.default_detail_flights(ten[:4]) == ["s01", "s04"]
    assert tables.default_detail_flights(["a"]) == ["a"]
    assert tables.default_detail_flights([]) == []


def test_table_flights_values_equal_stored(products: Path, tmp_path: Path) -> None:
    paths = tables.table_flights(_l4_files(products), tmp_path / "table4")
    assert [p.suffix for p in paths] == [".csv", ".md", ".tex"]
    assert all(p.stat().st_size > 0 for p in paths)
    t4 = pd.read_csv(paths[0], keep_default_na=True)
    assert list(t4["flight"]) == [s.flight for s in FLIGHTS]
    stats = pd.read_csv(products / "tables" / "flight_stats.csv")
    for spec in FLIGHTS:
        row = t4.set_index("flight").loc[spec.flight]
        mast, drone = _l4(products, spec.flight, "mast"), _l4(products, spec.flight, "drone")
        # full precision: the CSV holds the stored values exactly (shortest round-trip repr)
        assert row["U_ms"] == float(mast["U_ms"])
        assert row["zeta"] == float(mast["zeta"])
        assert row["wind_from_deg"] == float(mast["wind_from_deg"])
        assert row["reference_height_m"] == float(mast["height_m"])
        assert row["payload_height_m"] == float(drone["height_m"])
        assert row["duration_min"] == pytest.approx(float(mast["duration_s"]) / 60.0, rel=1e-12)
        assert row["start_utc"] == spec.start.replace("T", " ")
        assert row["reference"] == spec.reference
        assert row["stability_class"] == tables.stability_class(float(mast["zeta"]))
        # the lags agree with the pipeline's flight_stats.csv (written there with %.6g)
        st = stats[(stats.flight == spec.flight) & (stats.sensor == "drone")].iloc[0]
        assert row["lag_sonic_ins_s"] == pytest.approx(st["lag_sonic_ins_s"], rel=1e-5)
        assert row["lag_drone_mast_s"] == pytest.approx(st["lag_drone_mast_s"], rel=1e-5)
        assert bool(row["usable"]) is bool(spec.usable) and str(row["usable"]) in ("True", "False")
    md = paths[1].read_text()
    assert "| s04† |" in md and "unusable" in md  # the unusable flight is marked, with its reason
    tex = paths[2].read_text()
    assert tex.count(r"\begin{tabular}") == 1 and tex.count(r"\end{table}") == 1
    body = tex.split(r"\midrule")[1].split(r"\bottomrule")[0].strip().splitlines()
    assert len(body) == len(FLIGHTS) and all(line.count("&") == 11 for line in body)


def test_table_statistics_values_equal_stored(products: Path, tmp_path: Path) -> None:
    paths = tables.table_flight_statistics(_l4_files(products), tmp_path / "table5")
    t5 = pd.read_csv(paths[0]).set_index("statistic")
    assert list(t5.columns) == ["units", "s01_drone", "s01_mast", "s04_drone", "s04_mast"]  # default: first, last
    assert list(t5.index) == [r[0] for r in tables.TABLE5_ROWS]
    for col in t5.columns[1:]:
        flight, sensor = col.split("_")
        ds = _l4(products, flight, sensor)
        for name in t5.index:
            assert t5.loc[name, col] == float(ds[name]), (col, name)
    md = paths[1].read_text()
    assert "s04† drone" in md
    # rounded display agrees with the stored value to the shown decimals
    u = float(_l4(products, "s01", "drone")["U_ms"])
    assert f"| ū | m s⁻¹ | {u:.2f} |" in md


def test_table_statistics_chosen_flights_and_errors(products: Path, tmp_path: Path) -> None:
    paths = tables.table_flight_statistics(_l4_files(products), tmp_path / "t5b", flights=["s03", "s02"])
    t5 = pd.read_csv(paths[0])
    assert list(t5.columns[2:]) == ["s03_drone", "s03_mast", "s02_drone", "s02_mast"]
    with pytest.raises(InputError, match="s99"):
        tables.table_flight_statistics(_l4_files(products), tmp_path / "t5c", flights=["s99"])


def test_nan_and_missing_products(products: Path, tmp_path: Path) -> None:
    """A NaN stored value becomes an empty CSV field and "–" in the text; a missing mast file gives NaN."""
    l4_dir = tmp_path / "L4"
    shutil.copytree(products / "netcdf" / "L4", l4_dir)
    set_nan(l4_dir / "s01_drone.nc", "sigma_w_ms")
    (l4_dir / "s03_mast.nc").unlink()
    files = sorted(l4_dir.glob("*.nc"))
    p5 = tables.table_flight_statistics(files, tmp_path / "t5", flights=["s01"])
    t5 = pd.read_csv(p5[0]).set_index("statistic")
    assert math.isnan(t5.loc["sigma_w_ms", "s01_drone"])
    assert "| σ_w | m s⁻¹ | – |" in p5[1].read_text()
    assert "--" in p5[2].read_text()
    p4 = tables.table_flights(files, tmp_path / "t4")
    row = pd.read_csv(p4[0]).set_index("flight").loc["s03"]
    assert math.isnan(row["U_ms"]) and row["stability_class"] == "undefined"
    assert row["payload_height_m"] == float(_l4(products, "s03", "drone")["height_m"])


def test_not_an_l4_file_raises(products: Path, tmp_path: Path) -> None:
    with pytest.raises(InputError, match="flight"):
        tables.table_flights([products / "netcdf" / "L2" / "s01_mast.nc"], tmp_path / "x")
