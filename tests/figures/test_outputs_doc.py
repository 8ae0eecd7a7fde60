"""docs/outputs.md: every Python example runs as written in a run's results folder (a small product set)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from dronewind.steps import payload_l1
from tests.products_fixture import write_products

REPO = Path(__file__).resolve().parents[2]
DATA = Path(__file__).parents[1] / "data" / "payload_delimited" / "contract"


def python_blocks() -> list[str]:
    text = (REPO / "docs" / "outputs.md").read_text(encoding="utf-8")
    return re.findall(r"```python\n(.*?)```", text, flags=re.S)


@pytest.fixture(scope="module")
def results(tmp_path_factory) -> Path:
    folder = write_products(tmp_path_factory.mktemp("outputs"))
    payload_l1(DATA / "sonic.csv", DATA / "ins.csv", folder / "netcdf" / "L1" / "s01_sonic.nc",
               folder / "netcdf" / "L1" / "s01_ins.nc", campaign="fixcamp", flight_id="s01",
               site={"latitude": 43.1247, "longitude": 0.3628}, target_height_m=30.0,
               despike={"window_s": 10.0, "n_mad": 7.0}, simulated=False)
    return folder


def test_outputs_page_has_an_example_of_every_level():
    text = "\n".join(python_blocks())
    for level in ("L1", "L2", "L3", "L4", "flight_stats.csv", "diagnosis.json"):
        assert level in text, level


def test_outputs_page_examples_run(results, monkeypatch):
    monkeypatch.chdir(results)
    namespace: dict = {}
    for block in python_blocks():
        exec(compile(block, "docs/outputs.md", "exec"), namespace)  # noqa: S102 (the page's own examples)
    assert namespace["w_drone"].dims == ("time",)
    np.testing.assert_array_equal(namespace["w_first"].values, namespace["w_drone"].values)
    assert "S_w" in namespace["stats"] and float(namespace["l4"]["sigma_w_ms"]) > 0


def test_every_product_opens_with_xarray_alone(results):
    """featureType everywhere, sensor selectable by name, the comment says where the groups are."""
    import xarray as xr

    files = sorted((results / "netcdf").glob("L*/*.nc"))
    assert {f.parent.name for f in files} == {"L1", "L2", "L3", "L4"}
    for path in files:
        ds = xr.open_dataset(path)
        assert ds.attrs["featureType"] == "timeSeries", path.name
        assert "seed 00" not in str(ds.attrs)
        for group in ds.attrs.get("groups", "").split(", "):
            if group:
                assert f"group={group!r}" in ds.attrs["comment"], path.name
                sub = xr.open_dataset(path, group=group)
                assert not any("seed 00" in str(v.attrs) for v in sub.variables.values()), (path.name, group)
    l3 = xr.open_dataset(results / "netcdf" / "L3" / "s01.nc")
    assert list(l3.indexes["sensor"]) == ["drone", "mast"]
    assert l3["u_ms"].sel(sensor="mast").dims == ("time",)
