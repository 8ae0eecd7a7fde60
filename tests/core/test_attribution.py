"""Creator and licence of the products: defaults, set by the manifest, inherited by every later level."""

from __future__ import annotations

import numpy as np
import pandas as pd
import xarray as xr

from dronewind.core.attribution import attribution
from dronewind.core.cf import write_netcdf
from dronewind.manifest import campaign_schema


def _series(n: int = 5) -> xr.Dataset:
    time = pd.date_range("2023-08-21T14:00:00", periods=n, freq="1s").to_numpy()
    return xr.Dataset({"wind_speed": ("time", np.arange(n, dtype=float), {"units": "m s-1",
                                                                          "standard_name": "wind_speed"})},
                      coords={"time": time})


def _write(path, inputs=(), extra=None):
    return write_netcdf(_series(), path, title="t", summary="s", processing_level="L1", history="test",
                        inputs=inputs, station_id="x", latitude=43.1, longitude=0.36, extra_attrs=extra)


def test_defaults_state_the_outputs_licence(tmp_path):
    attrs = xr.open_dataset(_write(tmp_path / "a.nc")).attrs
    assert attrs["license"] == "CC-BY-4.0"
    assert attrs["creator_name"] == "dronewind workflow"


def test_manifest_creator_and_licence_reach_every_later_level(tmp_path):
    given = attribution({"name": "A. Smith", "email": "a.smith@example.org", "institution": "Univ. X"}, "CC0-1.0")
    assert given == {"creator_name": "A. Smith", "creator_email": "a.smith@example.org", "creator_type": "person",
                     "creator_institution": "Univ. X", "institution": "Univ. X", "license": "CC0-1.0"}
    l1 = _write(tmp_path / "l1.nc", extra=given)
    l2 = _write(tmp_path / "l2.nc", inputs=[l1])  # a later level states nothing: inherits
    for path in (l1, l2):
        attrs = xr.open_dataset(path).attrs
        assert {k: attrs[k] for k in given} == given, path.name


def test_manifest_schema_takes_creator_and_license():
    props = campaign_schema()["properties"]
    assert set(props["creator"]["properties"]) == {"name", "email", "institution", "url"}
    assert props["license"]["type"] == "string"


def test_code_licence_file_matches_pyproject():
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    assert (root / "LICENSE").read_text().startswith("MIT License")
    assert 'license = {text = "MIT"}' in (root / "pyproject.toml").read_text()
