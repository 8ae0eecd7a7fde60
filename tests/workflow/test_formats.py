"""Formats declared per record: checked on the files' first lines before any job, and read by the mast L1 dispatch.

Real bytes: the TOA5 and AmeriFlux gold excerpts in tests/data/io_excerpts (CC0, MIT); the
full records, the PX4 logs and the drone-mounted sonic (GPL-3, read in place, never copied)
from the data folder of dronewind.datasets, skipped when absent.
"""

from __future__ import annotations

import gzip
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from dronewind.cli import main
from dronewind.core.delimited import delimited_layout, read_delimited
from dronewind.errors import InputError, ManifestError
from dronewind.formats import check_campaign_formats, check_file_format
from dronewind.manifest import load_campaign
from dronewind.mast import ameriflux, chain, level1, toa5
from dronewind.mast.delimited import sensor_to_enu
from tests.conftest import needs_record, record_path

HERE = Path(__file__).resolve().parents[1]
REPO = HERE.parent
EXCERPTS = HERE / "data" / "io_excerpts"
TOA5_EXCERPT = EXCERPTS / "TOA5_6843.ts_Above_2012_06_07_1245_excerpt.dat"
GOLD_EXCERPT = EXCERPTS / "G1040000.RAW.gz"
GOLD = record_path("ameriflux_gold_openpath")
FLUXPART = record_path("fluxpart_csat3_toa5")
ULOG = record_path("px4_ulog", "sample_log_small.ulg")
NMT = record_path("nmt_uas_sonic", "level0.csv")
DESPIKE = {"window_s": 10.0, "n_mad": 7.0}
CSAT = {"id": "m7", "height_m": 7.11, "azimuth_deg": 218.0, "model": "CSAT3"}
GILL = {"id": "g2", "height_m": 2.0, "azimuth_deg": 240.0, "model": "Gill WindMaster Pro"}
L1_VARIABLES = ("u_east_ms", "v_north_ms", "w_up_ms", "t_sonic_k", "qc_mast")

#: The CSAT3 TOA5 file described as generic delimited text.
TOA5_AS_DELIMITED = {
    "name": "delimited", "header_line": 2, "skip_lines": 2,
    "time": {"column": "TIMESTAMP", "kind": "iso"},
    "variables": {"u": {"column": "Ux", "unit": "m/s"}, "v": {"column": "Uy", "unit": "m/s"},
                  "w": {"column": "Uz", "unit": "m/s"}, "t": {"column": "Ts", "unit": "degC"},
                  "diag": {"column": "diag_csat", "unit": "1"}},
    "axes": {"convention": "csat3"},
}
SONIC_CSV = "rpi_time_us,u_ms,v_ms,w_ms,t_sonic_c\n1000000,1.0,0.5,0.1,20.0\n1031250,1.1,0.4,0.2,20.1\n"
INS_CSV = ("rpi_time_us,utc,time_valid,ekf_valid,lat_deg,lon_deg,alt_m,vel_n_ms,vel_e_ms,vel_d_ms,roll_deg,pitch_deg,"
           "yaw_deg\n1000000,2023-08-21T14:05:32.000000Z,1,1,43.1247,0.3628,650.0,0.1,0.2,0.0,1.0,2.0,3.0\n")
QUAD_CSV = ("time_utc,roll_deg,pitch_deg,yaw_deg,vel_n_ms,vel_e_ms,vel_d_ms,lat_deg,lon_deg,alt_m\n"
            "2020-06-30T18:00:00.0Z,1.0,-5.0,270.0,0.0,0.0,0.0,36.6,-97.5,320.0\n")
REFERENCE_CSV = "time_utc,height_m,wind_speed_ms,wind_from_deg\n2020-06-30T18:00:00Z,30,5.0,270\n"


def write_manifest(folder: Path, **sections) -> Path:
    data = {"name": "formats", "site": {"latitude": 38.4, "longitude": -120.9, "altitude_m": 130}, **sections}
    path = folder / "campaign.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def mast(*sonics: dict) -> list[dict]:
    return [{"id": "tower", "sonics": list(sonics)}]


def raises(path: Path, fmt: dict, kind: str = "mast_sonic") -> str:
    """The message of the format check of one file (it must fail)."""
    with pytest.raises(InputError) as info:
        check_file_format(path, fmt, kind)
    return str(info.value)


# ----------------------------------------------------------------------------- every format validates


def test_every_format_validates_on_real_or_tiny_files(tmp_path, capsys):
    (tmp_path / "flight").mkdir()
    (tmp_path / "flight" / "sonic.csv").write_text(SONIC_CSV)
    (tmp_path / "flight" / "ins.csv").write_text(INS_CSV)
    (tmp_path / "q01.csv").write_text(QUAD_CSV)
    (tmp_path / "ref.csv").write_text(REFERENCE_CSV)
    manifest = write_manifest(
        tmp_path,
        masts=mast({**CSAT, "id": "toa5", "files": [str(TOA5_EXCERPT)]},
                   {**CSAT, "id": "toa5_named", "format": {"name": "toa5"}, "files": [str(TOA5_EXCERPT)]},
                   {**GILL, "format": {"name": "gill_raw", "utc_offset_hours": -8, "year": 2004},
                    "files": [str(GOLD_EXCERPT)]},
                   {**CSAT, "id": "generic", "format": TOA5_AS_DELIMITED, "files": [str(TOA5_EXCERPT)]}),
        payload_flights=[{"id": "s01", "reference": "toa5",
                          "sonic": {"file": "flight/sonic.csv", "format": "contract_csv"},
                          "ins": {"file": "flight/ins.csv"}}],
        quadrotor_flights=[{"id": "f01", "reference": "ref.csv",
                            "uavs": [{"id": "q01", "file": "q01.csv", "format": "contract_csv"}]}],
    )
    assert main(["validate-campaign", str(manifest)]) == 0
    assert "valid measured campaign 'formats': 4 mast sonic(s), 1 payload flight(s)" in capsys.readouterr().out


@needs_record("px4_ulog")
def test_a_ulog_record_validates_and_a_csv_declared_ulog_does_not(tmp_path):
    (tmp_path / "ref.csv").write_text(REFERENCE_CSV)
    manifest = write_manifest(tmp_path, quadrotor_flights=[{"id": "f01", "reference": "ref.csv", "uavs": [
        {"id": "q01", "file": str(ULOG), "format": "ulog"}, {"id": "q02", "file": str(ULOG)}]}])
    check_campaign_formats(load_campaign(manifest))
    fake = tmp_path / "q03.ulg"
    fake.write_text(QUAD_CSV)
    message = raises(fake, {"name": "ulog"}, "quadrotor_uav")
    assert message.startswith(f"{fake}:1: ") and "expected the PX4 ULog magic bytes" in message
    message = raises(ULOG, {"name": "contract_csv"}, "quadrotor_uav")
    assert message.startswith(f"{ULOG}:1: a PX4 ULog file (format ulog), expected the contract CSV header")


# ----------------------------------------------------------------------------- each error named


def test_gzip_where_toa5_was_declared_names_the_likely_format(tmp_path):
    """The reported case: a Gill mast with the AmeriFlux .RAW.gz files and no format validated, then failed in L1."""
    manifest = write_manifest(tmp_path, masts=mast({**GILL, "files": [str(GOLD_EXCERPT)]}))
    with pytest.raises(ManifestError) as info:
        check_campaign_formats(load_campaign(manifest))
    assert info.value.key_path == "masts[0].sonics[0].format"
    assert (f"{GOLD_EXCERPT}:1: gzip-compressed data (bytes 1f 8b; e.g. the AmeriFlux/Gill RAW .gz files: format "
            "gill_raw), expected a Campbell TOA5 file") in str(info.value)
    assert main(["validate-campaign", str(manifest)]) == 1
    assert main(["validate-campaign", "--no-files", str(manifest)]) == 0


def test_toa5_without_a_required_column_names_line_2(tmp_path):
    bad = tmp_path / "bad.dat"
    lines = TOA5_EXCERPT.read_text().splitlines()
    bad.write_text("\n".join([lines[0], lines[1].replace('"diag_csat"', '"diag"')] + lines[2:8]) + "\n")
    assert raises(bad, {"name": "toa5"}) == (f"{bad}:2: field-name line without diag_csat, expected at least "
                                             "TIMESTAMP, RECORD, Ux, Uy, Uz, Ts, diag_csat")


def test_toa5_text_where_gill_raw_was_declared(tmp_path):
    plain = tmp_path / "G1040000.RAW"
    shutil.copy(TOA5_EXCERPT, plain)
    message = raises(plain, {"name": "gill_raw"})
    assert message.startswith(f"{plain}:1: a Campbell TOA5 header (format toa5), expected 6 numbers")


def test_gzip_declared_as_plain_text_and_plain_text_named_gz(tmp_path):
    message = raises(GOLD_EXCERPT, {"name": "gill_raw", "compression": "none"})
    assert message == (f"{GOLD_EXCERPT}:1: gzip-compressed data (bytes 1f 8b), expected plain text as compression: "
                       "none says; declare compression: gzip (or auto with a .gz file name)")
    plain = tmp_path / "G1040000.RAW.gz"
    with gzip.open(GOLD_EXCERPT, "rb") as fh:
        plain.write_bytes(fh.read())
    message = raises(plain, {"name": "gill_raw"})
    assert message.startswith(f"{plain}:1: plain data (first bytes 2b 30), expected gzip-compressed data (bytes 1f 8b)")
    # declared plain, read plain: valid, and the L1 is the same as from the gzip file
    check_file_format(plain, {"name": "gill_raw", "compression": "none"}, "mast_sonic")
    a = chain.compute_mast_l1([plain], {**GILL, "format": {"name": "gill_raw", "compression": "none"}}, DESPIKE)
    b = chain.compute_mast_l1([GOLD_EXCERPT], {**GILL, "format": "gill_raw"}, DESPIKE)
    assert np.array_equal(a["u_east_ms"].values, b["u_east_ms"].values, equal_nan=True)


def test_gill_raw_line_with_fields_beyond_the_declared_columns(tmp_path):
    path = tmp_path / "G1040000.RAW"
    path.write_text("+0.110,-0.930,+0.600,20.82,2.992,2.246,,,\n+0.020,-0.970,+0.630,20.87,2.993,2.251,7,,\n")
    assert raises(path, {"name": "gill_raw"}) == (
        f"{path}:2: 7 non-empty fields (field 7 beyond the declared columns), expected 6 numbers "
        "(w,u,v,t_sonic_c,h2o_v,co2_v) followed by empty fields")
    check_file_format(path, {"name": "gill_raw", "columns": ["w", "u", "v", "t_sonic_c", "h2o_v", "co2_v", "unused"]},
                      "mast_sonic")
    bad_name = tmp_path / "gold.raw"
    shutil.copy(path, bad_name)
    assert "expected G<DDD><HHMM>.RAW or G<DDD><HHMM>.RAW.gz" in raises(bad_name, {"name": "gill_raw"})


def test_delimited_column_absent_names_the_column_and_the_header_found():
    fmt = {**TOA5_AS_DELIMITED, "variables": {**TOA5_AS_DELIMITED["variables"], "u": {"column": "U_x", "unit": "m/s"}}}
    message = raises(TOA5_EXCERPT, fmt)
    assert message.startswith(f"{TOA5_EXCERPT}:2: column 'U_x' of u not in the header line, which has ['TIMESTAMP', "
                              "'RECORD', 'Ux', 'Uy', 'Uz', 'co2', 'h2o', 'Ts', 'press', 'diag_csat']; expected a field "
                              "named 'U_x'")


def test_delimited_time_that_does_not_parse():
    fmt = {**TOA5_AS_DELIMITED, "time": {"column": "TIMESTAMP", "kind": "epoch_s"}}
    assert raises(TOA5_EXCERPT, fmt) == (f"{TOA5_EXCERPT}:5: time column 'TIMESTAMP' holds '2012-06-07 12:45:00.05', "
                                         "expected seconds since 1970-01-01 UTC (a number)")
    fmt = {**TOA5_AS_DELIMITED, "time": {"column": "RECORD", "kind": "iso"}}
    assert raises(TOA5_EXCERPT, fmt).startswith(f"{TOA5_EXCERPT}:5: time column 'RECORD' holds '111850400', expected "
                                                "an ISO 8601 date and time")


def test_delimited_wrong_field_count_and_header_lines(tmp_path):
    lines = TOA5_EXCERPT.read_text().splitlines()
    short = tmp_path / "short.dat"
    short.write_text("\n".join(lines[:5] + [lines[5].rsplit(",", 1)[0]] + lines[6:9]) + "\n")
    assert raises(short, TOA5_AS_DELIMITED) == (f"{short}:6: 9 fields, expected 10 (as the header line 2; "
                                                "delimiter ',')")
    # one header line too few declared: the units line is read as data
    message = raises(TOA5_EXCERPT, {**TOA5_AS_DELIMITED, "skip_lines": 1})
    assert message.startswith(f"{TOA5_EXCERPT}:4: time column 'TIMESTAMP' holds '', expected an ISO 8601")
    with pytest.raises(InputError, match=r"\.variables\.u\.unit: unit 'degC' is not a unit of u; expected one of"):
        delimited_layout({**TOA5_AS_DELIMITED, "variables": {**TOA5_AS_DELIMITED["variables"],
                                                             "u": {"column": "Ux", "unit": "degC"}}}, "x")


def test_contract_csv_with_another_header_says_what_it_looks_like(tmp_path):
    path = tmp_path / "sonic.csv"
    path.write_text(INS_CSV)
    message = raises(path, {"name": "contract_csv"}, "payload_sonic")
    assert message.startswith(f"{path}:1: header has 13 fields, expected 5 (rpi_time_us,u_ms,v_ms,w_ms,t_sonic_c)")
    assert message.endswith("(looks like the payload ins contract CSV header (format contract_csv))")
    message = raises(GOLD_EXCERPT, {"name": "contract_csv"}, "payload_ins")
    assert message.startswith(f"{GOLD_EXCERPT}:1: gzip-compressed data")


def test_schema_rejects_a_bare_delimited_and_a_misspelt_setting(tmp_path):
    for fmt, key, what in (("delimited", "masts[0].sonics[0].format", "is not one of ['toa5', 'gill_raw']"),
                           ({"name": "gill_raw", "north_azimuth": 60}, "masts[0].sonics[0].format.north_azimuth",
                            "'north_azimuth' is not a manifest key: did you mean 'north_azimuth_deg'?"),
                           ({**TOA5_AS_DELIMITED, "time": {"column": "TIMESTAMP", "kind": "iso8601"}},
                            "masts[0].sonics[0].format.time.kind", "is not one of ['iso', 'epoch_s', 'epoch_ms']")):
        manifest = write_manifest(tmp_path, masts=mast({**CSAT, "format": fmt, "files": [str(TOA5_EXCERPT)]}))
        with pytest.raises(ManifestError) as info:
            load_campaign(manifest)
        assert info.value.key_path == key and what in info.value.what, str(info.value)


# ----------------------------------------------------------------------------- the mast L1 dispatch


def test_gill_record_through_compute_mast_l1_is_the_ameriflux_reader():
    ds = chain.compute_mast_l1([GOLD_EXCERPT], {**GILL, "format": {"name": "gill_raw", "utc_offset_hours": -8}},
                               DESPIKE)
    ref = ameriflux.read_ameriflux_gold(GOLD_EXCERPT, north_azimuth_deg=240.0, height_m=2.0)
    assert np.array_equal(ds["time"].values, ref["time"].values)
    for var in L1_VARIABLES:
        assert np.array_equal(ds[var].values, ref["qc_sonic" if var == "qc_mast" else var].values, equal_nan=True), var
    assert ds.attrs["input_format"] == "gill_raw" and ds.attrs["sampling_rate_hz"] == 10.0
    assert ds.attrs["sensor_id"] == "g2" and ds.attrs["height_m"] == 2.0


@needs_record("ameriflux_gold_openpath")
def test_gill_record_of_two_half_hours_on_one_grid():
    files = [GOLD / "G1040030.RAW.gz", GOLD / "G1040000.RAW.gz"]  # out of order on purpose
    fmt = {"name": "gill_raw", "north_azimuth_deg": 60.0, "year": 2004}
    ds = chain.compute_mast_l1(files, {**GILL, "format": fmt}, DESPIKE)
    # each file is one row short of 18000: the first one's gap is on the grid, the last one ends early
    assert ds.sizes["time"] == 35999 and ds.attrs["n_missing"] == 1
    assert np.all(np.diff(ds["time"].values).astype(np.int64) == 100_000_000)
    assert ds["time"].values[0] == np.datetime64("2004-04-13T00:00:00")
    for k, f in enumerate(sorted(files)):
        ref = ameriflux.read_ameriflux_gold(f, north_azimuth_deg=60.0, year=2004, utc_offset_hours=0.0)
        part = ds.isel(time=slice(18000 * k, 18000 * k + ref.sizes["time"]))
        assert np.array_equal(part["time"].values, ref["time"].values)
        assert np.array_equal(part["u_east_ms"].values, ref["u_east_ms"].values, equal_nan=True)
        assert np.array_equal(part["qc_mast"].values, ref["qc_sonic"].values)
    assert ds["qc_mast"].values[17999] == 4 and np.isnan(ds["u_east_ms"].values[17999])  # the absent sample


def test_toa5_as_delimited_text_is_the_toa5_reader():
    ref = chain.compute_mast_l1([TOA5_EXCERPT], CSAT, DESPIKE)
    ds = chain.compute_mast_l1([TOA5_EXCERPT], {**CSAT, "format": TOA5_AS_DELIMITED}, DESPIKE)
    assert ref.attrs["input_format"] == "toa5" and ds.attrs["input_format"] == "delimited"
    assert np.array_equal(ds["time"].values, ref["time"].values)
    for var in L1_VARIABLES:
        np.testing.assert_array_equal(ds[var].values, ref[var].values, err_msg=var)
    assert ds.attrs["sampling_rate_hz"] == ref.attrs["sampling_rate_hz"] == 20.0


@needs_record("fluxpart_csat3_toa5")
def test_full_fluxpart_record_as_delimited_text_is_the_toa5_reader():
    files = sorted(FLUXPART.glob("TOA5_*.dat"))
    ref = level1.mast_l1(files, azimuth_deg=218.0, height_m=7.11, sensor_id="m7")
    ds = chain.compute_mast_l1(files, {**CSAT, "format": TOA5_AS_DELIMITED}, DESPIKE)
    assert ds.sizes["time"] == ref.sizes["time"] > 30000
    assert np.array_equal(ds["time"].values, ref["time"].values)
    for var in L1_VARIABLES:
        np.testing.assert_allclose(ds[var].values, ref[var].values, rtol=1e-12, atol=0, err_msg=var)
    assert ds.attrs["n_spikes"] == ref.attrs["n_spikes"] and ds.attrs["n_missing"] == ref.attrs["n_missing"]


def test_scale_units_epoch_matrix_and_mount_of_the_generic_mapping(tmp_path):
    """The TOA5 excerpt rewritten: cm/s with a scale, kelvin, epoch milliseconds, tab-separated, no header,
    a head-down sensor; an explicit matrix of the CSAT3 rotation gives the TOA5 reader's L1."""
    frame, _ = toa5.read_toa5(TOA5_EXCERPT)
    t_ms = (frame["time"].to_numpy().astype("datetime64[ns]").astype(np.int64) // 1_000_000)
    rows = [f"{t}\t{2 * 100 * ux}\t{-100 * uy}\t{-100 * uz}\t{ts + 273.15}\t{int(d)}"
            for t, ux, uy, uz, ts, d in zip(t_ms, frame["Ux"], frame["Uy"], frame["Uz"], frame["Ts"],
                                            frame["diag_csat"], strict=True)]
    path = tmp_path / "sonic.tsv.gz"
    with gzip.open(path, "wt") as fh:
        fh.write("# logger dump\n" + "\n".join(rows) + "\n")
    a = np.deg2rad(218.0)
    matrix = [[-np.sin(a), np.cos(a), 0.0], [-np.cos(a), -np.sin(a), 0.0], [0.0, 0.0, 1.0]]
    fmt = {"name": "delimited", "delimiter": "\t", "header_line": 0, "skip_lines": 1,
           "time": {"column": 1, "kind": "epoch_ms"},
           "variables": {"u": {"column": 2, "scale": 0.5, "unit": "cm/s"}, "v": {"column": 3, "unit": "cm s-1"},
                         "w": {"column": 4, "unit": "cm/s"}, "t": {"column": 5, "unit": "K"},
                         "diag": {"column": 6, "unit": "1"}},
           "axes": {"convention": "matrix", "matrix": matrix}, "mount": "upside_down", "limits": "csat3"}
    check_file_format(path, fmt, "mast_sonic")
    ds = chain.compute_mast_l1([path], {**CSAT, "format": fmt}, DESPIKE)
    ref = chain.compute_mast_l1([TOA5_EXCERPT], CSAT, DESPIKE)
    assert np.array_equal(ds["time"].values, ref["time"].values)
    for var in ("u_east_ms", "v_north_ms", "w_up_ms", "t_sonic_k"):
        np.testing.assert_allclose(ds[var].values, ref[var].values, rtol=1e-12, atol=1e-12, err_msg=var)
    np.testing.assert_array_equal(ds["qc_mast"].values, ref["qc_mast"].values)


def test_axis_conventions_agree_on_one_wind():
    """Wind from the north-east at 5 m/s (towards the south-west), 0.3 m/s up, in each convention's sensor frame."""
    e, n, up = -5 / np.sqrt(2), -5 / np.sqrt(2), 0.3
    # csat3 with the head to 45 deg: Ux > 0 for wind from 45 deg into the head, Uy to the left
    got = sensor_to_enu(np.array([5.0]), np.array([0.0]), np.array([0.3]), {"convention": "csat3"}, azimuth_deg=45.0)
    np.testing.assert_allclose(np.ravel(got), [e, n, up], atol=1e-12)
    # gill with the N spar at 225 deg: U towards the spar, V towards its W
    got = sensor_to_enu(np.array([5.0]), np.array([0.0]), np.array([0.3]), {"convention": "gill",
                                                                            "north_azimuth_deg": 225.0})
    np.testing.assert_allclose(np.ravel(got), [e, n, up], atol=1e-12)
    got = sensor_to_enu(np.array([e]), np.array([-n]), np.array([-up]), {"convention": "enu"}, "upside_down")
    np.testing.assert_allclose(np.ravel(got), [e, n, up], atol=1e-12)


@needs_record("nmt_uas_sonic")
def test_iso_times_with_a_zone_against_the_utc_column_of_a_real_record():
    """nmt_uas_sonic/level0.csv (read in place): local times with -07:00 and a UTC column give the same instants."""
    variables = {k: {"column": c, "unit": "m/s"} for k, c in (("u", "Um"), ("v", "Vm"), ("w", "Wm"))}
    fmt = {"name": "delimited", "time": {"column": "Timestamp", "kind": "iso"},
           "variables": {**variables, "t": {"column": "T", "unit": "degC"}}, "axes": {"convention": "enu"}}
    check_file_format(NMT, fmt, "mast_sonic")
    local = read_delimited(NMT, delimited_layout(fmt, "x"))
    utc = read_delimited(NMT, delimited_layout({**fmt, "time": {"column": "Timestamp_UTC", "kind": "iso",
                                                                 "utc_offset_hours": 5.0}}, "x"))
    assert local.time.size > 5000 and np.array_equal(local.time, utc.time)
    naive = read_delimited(NMT, delimited_layout({**fmt, "time": {"column": "Seconds", "kind": "epoch_s"}}, "x"))
    assert naive.time[0] == np.datetime64("1970-01-01T00:00:00")


# ----------------------------------------------------------------------------- workflow and README


def test_workflow_stops_before_any_job_on_a_misdeclared_file(tmp_path):
    import subprocess

    from tests.conftest import BIN, workflow_env

    manifest = write_manifest(tmp_path, masts=mast({**GILL, "files": [str(GOLD_EXCERPT)]}))
    proc = subprocess.run([str(BIN / "snakemake"), "-n", "--cores", "1", "--config", f"campaign={manifest}",
                           f"results_dir={tmp_path / 'results'}"], cwd=REPO, capture_output=True, text=True,
                          timeout=600, check=False, env=workflow_env())
    assert proc.returncode != 0 and "Job stats" not in proc.stdout
    output = proc.stdout + proc.stderr
    assert f"{GOLD_EXCERPT}:1: gzip-compressed data" in output and "[masts[0].sonics[0].format]" in output


def test_gill_mast_l1_step_writes_the_product(tmp_path):
    import xarray as xr

    from dronewind.steps import mast_l1

    sonic = {**GILL, "mast_id": "tower", "latitude": 38.4, "longitude": -120.9,
             "format": {"name": "gill_raw", "utc_offset_hours": -8}}
    out = mast_l1([GOLD_EXCERPT], tmp_path / "mast_g2.nc", campaign="formats", sonic=sonic, despike=DESPIKE,
                  simulated=False)
    with xr.open_dataset(out) as ds:
        assert ds.attrs["input_format"] == "gill_raw" and ds.sizes["time"] == 300
        assert {"u_east_ms", "v_north_ms", "w_up_ms", "t_sonic_k", "qc_mast"} <= set(ds.data_vars)


def documented_format_examples() -> dict[str, dict]:
    """The manifest examples of docs/input-formats.md's first part (the readers), by format name."""
    text = (REPO / "docs" / "input-formats.md").read_text(encoding="utf-8")
    section = text.split("\n## ", 1)[0]
    blocks = [yaml.safe_load(b) for b in re.findall(r"^```yaml\n(.*?)^```", section, flags=re.S | re.M)]
    out = {}
    for block in blocks:
        for m in block.get("masts") or []:
            for s in m["sonics"]:
                fmt = s.get("format", "toa5")
                out[fmt if isinstance(fmt, str) else fmt["name"]] = block
        if block.get("payload_flights"):
            out["contract_csv"] = block
        for f in block.get("quadrotor_flights") or []:
            out.update({u.get("format", "contract_csv"): block for u in f["uavs"]})
    return out


def test_docs_have_a_valid_example_of_every_format(tmp_path):
    examples = documented_format_examples()
    assert {"toa5", "gill_raw", "contract_csv", "ulog", "delimited"} <= set(examples)
    for k, example in enumerate(examples.values()):
        path = tmp_path / f"example{k}.yaml"
        path.write_text(yaml.safe_dump(example, sort_keys=False))
        load_campaign(path, check_files=False)


def test_a_damaged_file_of_a_record_is_a_warning_a_record_of_damaged_files_an_error(tmp_path):
    """A mast record of two TOA5 files, one with its field-name line damaged (an SD card's torn
    header): the run goes on without that file (its reader leaves it out), with a warning naming
    it; with both files damaged the record's format cannot be right and the check stops the run."""
    good = tmp_path / "a.dat"
    bad = tmp_path / "b.dat"
    good.write_bytes(TOA5_EXCERPT.read_bytes())
    lines = TOA5_EXCERPT.read_text().splitlines(keepends=True)
    lines[1] = lines[1].replace('"Uz"', '"U?"')
    bad.write_text("".join(lines))
    manifest = write_manifest(tmp_path, masts=mast({**CSAT, "files": ["a.dat", "b.dat"]}))
    warnings = check_campaign_formats(load_campaign(manifest))
    assert len(warnings) == 1 and f"{bad}:2: field-name line without Uz" in warnings[0]
    manifest = write_manifest(tmp_path, masts=mast({**CSAT, "files": ["b.dat"]}))
    with pytest.raises(ManifestError) as info:
        check_campaign_formats(load_campaign(manifest))
    assert f"{bad}:2: field-name line without Uz" in str(info.value)
