"""The NetCDF writer: CF-1.11/ACDD-1.3 compliance, provenance, atomic write, reproducibility."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from dronewind.core.cf import check_compliance, check_compliance_files, config_hash, write_netcdf
from dronewind.core.cf_names import strip_cf, track_from_cf, track_to_cf


def sample_dataset(n: int = 200) -> xr.Dataset:
    rng = np.random.default_rng(3)
    time = pd.date_range("2023-08-21T14:05:00", periods=n, freq="100ms").values
    return xr.Dataset(
        {
            "u_east_ms": ("time", rng.normal(2, 1, n), {"units": "m s-1", "standard_name": "eastward_wind"}),
            "w_up_ms": ("time", rng.normal(0, 0.3, n), {"units": "m s-1", "standard_name": "upward_air_velocity"}),
            "t_sonic_k": ("time", 290 + rng.normal(0, 0.2, n),
                          {"units": "K", "standard_name": "virtual_temperature", "comment": "sonic temperature"}),
            "qc_mast": ("time", np.zeros(n, np.int8),
                        {"standard_name": "status_flag", "flag_masks": np.array([1, 2, 4], np.int8),
                         "flag_meanings": "out_of_range spike missing"}),
        },
        coords={"time": time},
        attrs={"n_spikes": 0, "processing_log": "ingest: test"},
    )


def write(path, ds=None, **kw):
    args = dict(title="test", summary="test record", processing_level="L1 test", history="unit test",
                station_id="mast30", latitude=43.1247, longitude=0.3628, height_m=30.0)
    args.update(kw)
    return write_netcdf(sample_dataset() if ds is None else ds, path, **args)


def test_timeseries_file_passes_compliance_checker(tmp_path):
    path = write(tmp_path / "mast.nc")
    ok, report = check_compliance(path)
    assert ok, report


@pytest.mark.slow
def test_checking_files_together_gives_each_file_the_command_line_verdict(tmp_path):
    """One checker process for several files: each file's verdict is the exit status of
    ``compliance-checker`` run on it alone (a product that passes, one without CF and ACDD
    attributes that fails, in either order)."""
    import subprocess
    import sys

    good = write(tmp_path / "mast.nc")
    bad = tmp_path / "bare.nc"
    xr.Dataset({"x": ("t", np.arange(3.0))}).to_netcdf(bad)
    exe = Path(sys.executable).with_name("compliance-checker")
    for files in ([good, bad], [bad, good]):
        results = check_compliance_files(files)
        assert list(results) == files
        for path, (ok, report) in results.items():
            cli = subprocess.run([str(exe), "--test=cf:1.11", "--test=acdd:1.3", "--criteria=normal", "--format=text",
                                  str(path)], capture_output=True, text=True, check=False)
            assert ok == (cli.returncode == 0) == (path == good), (path, report)
            assert "cf:1.11" in report and "acdd:1.3" in report
    assert "title not present" in check_compliance_files([bad])[bad][1]
    assert check_compliance_files([]) == {}
    broken = tmp_path / "broken.nc"
    broken.write_bytes(b"CDF\x01 not a NetCDF file")
    results = check_compliance_files([broken, good])
    assert results[broken][0] is False and "compliance checker error" in results[broken][1]
    assert results[good][0] is True


def test_groups_for_quantities_without_standard_name(tmp_path):
    freq = np.linspace(0.01, 4, 50)
    spectra = xr.Dataset({"psd_u": ("frequency", freq ** (-5 / 3), {"units": "m2 s-1", "long_name": "PSD of u"})},
                         coords={"frequency": ("frequency", freq, {"units": "Hz", "long_name": "frequency"})})
    path = write(tmp_path / "spec.nc", groups={"spectra": spectra})
    ok, report = check_compliance(path)
    assert ok, report
    with xr.open_dataset(path, group="spectra") as back:
        np.testing.assert_allclose(back["psd_u"].values, freq ** (-5 / 3))
        assert back["psd_u"].attrs["long_name"] == "PSD of u"
    with xr.open_dataset(path) as root:
        assert root.attrs["groups"] == "spectra"


def test_time_encoding_and_provenance(tmp_path):
    inp = tmp_path / "raw.dat"
    inp.write_bytes(b"raw bytes")
    path = write(tmp_path / "x.nc", inputs=[inp], config={"a": 1})
    with xr.open_dataset(path, decode_times=False) as raw:
        t = raw["time"]
        assert "_FillValue" not in t.encoding and "_FillValue" not in t.attrs
        assert t.attrs["units_metadata"] == "leap_seconds: none"
        assert raw["t_sonic_k"].attrs["units_metadata"] == "temperature: on_scale"
        assert raw.attrs["Conventions"] == "CF-1.11, ACDD-1.3"
        assert raw.attrs["config_sha256"] == config_hash({"a": 1})
        assert hashlib.sha256(b"raw bytes").hexdigest() in raw.attrs["input_checksums"]
        assert raw.attrs["featureType"] == "timeSeries"
        assert raw["station"].attrs["cf_role"] == "timeseries_id"
    with xr.open_dataset(path) as ds:
        np.testing.assert_array_equal(ds["time"].values, sample_dataset()["time"].values)


def test_config_hash_ignores_key_order():
    assert config_hash({"a": 1, "b": {"c": 2, "d": 3}}) == config_hash({"b": {"d": 3, "c": 2}, "a": 1})
    assert config_hash({"a": 1}) != config_hash({"a": 2})


def test_same_inputs_give_bit_identical_files(tmp_path, monkeypatch):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000000")
    a = write(tmp_path / "x.nc").read_bytes()
    b = write(tmp_path / "x.nc").read_bytes()
    assert hashlib.sha256(a).hexdigest() == hashlib.sha256(b).hexdigest()


def test_interrupted_write_leaves_no_file(tmp_path, monkeypatch):
    target = tmp_path / "out.nc"

    def boom(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(xr.Dataset, "to_netcdf", boom)
    with pytest.raises(KeyboardInterrupt):
        write(target)
    assert not target.exists()
    assert list(tmp_path.iterdir()) == [], "no temporary file is left behind"


def test_track_names_round_trip():
    ds = sample_dataset(10)
    for name, value in (("lat_deg", 43.1), ("lon_deg", 0.36), ("alt_m", 633.0)):
        ds[name] = ("time", np.full(10, value), {"comment": "from the INS"})
    cf = track_to_cf(ds)
    assert {"precise_lat", "precise_lon", "altitude"} <= set(cf.variables) and "lat_deg" not in cf
    assert cf["precise_lat"].attrs["standard_name"] == "latitude" and cf["altitude"].attrs["positive"] == "up"
    assert cf["precise_lon"].attrs["comment"] == "from the INS"  # existing attributes are kept
    back = track_from_cf(cf)
    for name in ("lat_deg", "lon_deg", "alt_m"):
        np.testing.assert_array_equal(back[name].values, ds[name].values)


def test_strip_cf_drops_the_station_coordinates(tmp_path):
    from dronewind.core.products import open_product

    ds = strip_cf(open_product(write(tmp_path / "x.nc")))
    assert not {"station", "lat", "lon", "alt"} & set(ds.variables)
    assert all("coordinates" not in v.attrs and "coordinates" not in v.encoding for v in ds.variables.values())
    write(tmp_path / "again.nc", ds)  # can be written again


def test_source_states_measured_or_virtual_and_later_levels_inherit_it(tmp_path):
    import netCDF4

    from dronewind.core.cf import DATA_SOURCES, data_source

    measured = sample_dataset()
    measured.attrs["source"] = data_source(False)
    virtual = sample_dataset()
    virtual.attrs["source"] = data_source(True)
    l1_measured = write(tmp_path / "l1_measured.nc", measured)
    l1_virtual = write(tmp_path / "l1_virtual.nc", virtual)
    # a later level given no source inherits its input's
    l2 = write(tmp_path / "l2.nc", sample_dataset(), inputs=[l1_measured])
    unknown = write(tmp_path / "unknown.nc", sample_dataset())
    with netCDF4.Dataset(l1_measured) as a, netCDF4.Dataset(l1_virtual) as b, netCDF4.Dataset(l2) as c, \
            netCDF4.Dataset(unknown) as d:
        assert a.source.startswith("measured") and "virtual" not in a.source
        assert b.source.startswith("virtual campaign")
        assert c.source == a.source
        assert d.source == DATA_SOURCES["unknown"]


def test_open_product_names_a_file_hdf5_cannot_read(tmp_path):
    """Not NetCDF, a truncated HDF5 file, a missing file: each named, with what the file holds."""
    from dronewind.core.products import open_product
    from dronewind.errors import InputError

    text = tmp_path / "text.nc"
    text.write_bytes(b"previous version")
    with pytest.raises(InputError, match=r"text\.nc: not readable as a NetCDF-4 file .*16 bytes without the HDF5 sig"):
        open_product(text)
    whole = tmp_path / "whole.nc"
    xr.Dataset({"w": ("time", np.arange(1000.0))}).to_netcdf(whole, engine="netcdf4")
    cut = tmp_path / "cut.nc"
    cut.write_bytes(whole.read_bytes()[:2000])
    with pytest.raises(InputError, match=r"cut\.nc: .*an HDF5 file of 2000 bytes: truncated or damaged"):
        open_product(cut)
    with pytest.raises(FileNotFoundError):
        open_product(tmp_path / "missing.nc")


def test_open_product_reads_a_window_of_some_variables(tmp_path):
    """variables and time: the same values as the whole file read and then cut."""
    from dronewind.core.products import open_product

    n = 600
    time = np.datetime64("2023-08-21T14:00", "ns") + (np.arange(n) * 100_000_000).astype("timedelta64[ns]")
    rng = np.random.default_rng(3)
    attrs = {"u_east_ms": {"units": "m s-1", "standard_name": "eastward_wind"},
             "w_up_ms": {"units": "m s-1", "standard_name": "upward_air_velocity"}}
    ds = xr.Dataset({k: ("time", rng.normal(size=n), a) for k, a in attrs.items()}, coords={"time": time})
    path = write_netcdf(ds, tmp_path / "rec.nc", title="t", summary="s", processing_level="L1", history="h",
                        station_id="x")
    window = slice(time[100], time[199])
    whole = open_product(path)
    cut = open_product(path, ["w_up_ms", "absent_ms"], window)
    assert list(cut.data_vars) == ["w_up_ms"] and cut.sizes["time"] == 100
    assert cut["w_up_ms"].identical(whole["w_up_ms"].sel(time=window))
    assert cut.attrs == whole.attrs


def test_the_session_reads_a_file_another_process_holds_locked(tmp_path):
    """tests/conftest.py starts HDF5 with file locking off in this process only (a forked child's
    copy of a written file's lock made reads fail in CI); the processes it starts keep the default."""
    import os
    import subprocess
    import sys

    from dronewind.core.products import open_product

    path = write_netcdf(xr.Dataset({"w": ("time", np.arange(5.0), {"units": "m s-1"})}), tmp_path / "held.nc",
                        title="t", summary="s", processing_level="L1", history="h", station_id="x",
                        feature_type=None)
    holder = subprocess.Popen([sys.executable, "-c", "import fcntl, sys, time; f = open(sys.argv[1], 'rb'); "
                               "fcntl.flock(f, fcntl.LOCK_EX); print('held', flush=True); time.sleep(60)", str(path)],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
        assert open_product(path)["w"].values.tolist() == [0.0, 1.0, 2.0, 3.0, 4.0]
        # a child process starts HDF5 with the default (locking on) and cannot read it
        child = subprocess.run([sys.executable, "-c", "import netCDF4, sys; netCDF4.Dataset(sys.argv[1]).close()",
                                str(path)], capture_output=True, text=True, env=dict(os.environ), check=False)
        assert child.returncode != 0 and "HDF error" in child.stderr
    finally:
        holder.kill()
        holder.wait()
