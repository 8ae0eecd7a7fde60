"""Sling-load payload files in one's own layout: the same L1 as the contract files of the same samples.

``tests/data/payload_delimited`` holds one 30 s flight twice (``make_files.py`` writes both):
``contract/`` in the contract CSVs, ``own/`` in a logger's own layout (semicolons, a comment
and a units line, the clock in ms, cm/s with x and y swapped and z down, kelvin; a gzipped
tab-separated INS with epoch UTC, a fix status, radians and east/north/up velocity).
"""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
import yaml

from dronewind.errors import InputError, ManifestError
from dronewind.formats import check_file_format
from dronewind.manifest import load_campaign, record_format
from dronewind.payload.chain import compute_payload_l1
from dronewind.payload.delimited import ins_record, payload_source, sonic_record

DATA = Path(__file__).parents[1] / "data" / "payload_delimited"
DESPIKE = {"window_s": 10.0, "n_mad": 7.0}

#: The mappings of the own layout, as a manifest writes them (docs/manifest.md shows the same).
SONIC_FORMAT = {
    "name": "delimited", "delimiter": ";", "header_line": 2, "skip_lines": 1,
    "time": {"column": "clock", "kind": "clock_ms"},
    "variables": {"u": {"column": "X", "unit": "cm/s"}, "v": {"column": "Y", "unit": "cm/s"},
                  "w": {"column": "Z", "unit": "cm/s"}, "t": {"column": "Ts", "unit": "K"}},
    "axes": {"u": "v", "v": "u", "w": "-w"},
}
INS_FORMAT = {
    "name": "delimited", "delimiter": "\t",
    "time": {"column": "clock_ms", "kind": "clock_ms"},
    "utc": {"column": "gps_utc_s", "kind": "epoch_s"},
    "variables": {"time_valid": {"column": "fix", "unit": "1"}, "ekf_valid": {"column": "ekf_status", "unit": "1"},
                  "lat": {"column": "lat_rad", "unit": "rad"}, "lon": {"column": "lon_rad", "unit": "rad"},
                  "alt": {"column": "height_m", "unit": "m"}, "vel_e": {"column": "v_east", "unit": "m/s"},
                  "vel_n": {"column": "v_north", "unit": "m/s"}, "vel_u": {"column": "v_up", "unit": "m/s"},
                  "roll": {"column": "roll_rad", "unit": "rad"}, "pitch": {"column": "pitch_rad", "unit": "rad"},
                  "yaw": {"column": "heading_rad", "unit": "rad"}},
}
#: Unit conversions (cm/s x 0.01, K - 273.15, rad -> degree) round in the last bits: 1e-9 in
#: the variable's unit is a million times that and a thousand times below the files' last digit.
ATOL = 1e-9


@pytest.fixture(scope="module")
def both_l1():
    contract = compute_payload_l1(DATA / "contract" / "sonic.csv", DATA / "contract" / "ins.csv", DESPIKE)
    own = compute_payload_l1(payload_source(DATA / "own" / "sonic_log.txt", SONIC_FORMAT, "sonic"),
                             payload_source(DATA / "own" / "ins_log.tsv.gz", INS_FORMAT, "ins"), DESPIKE)
    return contract, own


@pytest.mark.parametrize("part", [0, 1], ids=["sonic", "ins"])
def test_own_layout_gives_the_contract_l1(both_l1, part):
    contract, own = both_l1[0][part], both_l1[1][part]
    assert list(own.data_vars) == list(contract.data_vars)
    np.testing.assert_array_equal(own["time"].values, contract["time"].values)
    for name, var in contract.data_vars.items():
        if var.dtype.kind == "f":
            np.testing.assert_allclose(own[name].values, var.values, rtol=0, atol=ATOL, err_msg=name)
        else:
            np.testing.assert_array_equal(own[name].values, var.values, err_msg=name)
    counts = {k: v for k, v in contract.attrs.items() if k.startswith("n_")}
    assert {k: own.attrs[k] for k in counts} == counts
    for key in ("clock_drift_ppm", "clock_offset_s", "sampling_rate_hz"):
        if key in contract.attrs:
            assert own.attrs[key] == pytest.approx(contract.attrs[key], abs=1e-9), key


def test_defects_are_counted_as_in_the_contract_files(both_l1):
    sonic = both_l1[1][0]
    assert sonic.attrs["n_corrupt_lines"] == 1, "the truncated line"
    assert sonic.attrs["n_duplicates"] == 1, "the row written twice"
    assert "sonic_log.txt (payload sonic by its manifest mapping)" in sonic.attrs["processing_log"]
    ins = both_l1[1][1]
    assert ins.attrs["n_before_stable_time"] == 50, "2 s without GNSS time at 25 Hz"


def test_mapped_record_has_the_contract_columns():
    rec = sonic_record(DATA / "own" / "sonic_log.txt", SONIC_FORMAT)
    assert list(rec.columns) == ["rpi_time_us", "u_ms", "v_ms", "w_ms", "t_sonic_c"]
    assert rec.columns["rpi_time_us"][0] == 7_312_094_113  # 7312094.113 ms, exactly
    assert rec.line_numbers()[0] == 4  # comment, header and units lines above
    ins = ins_record(DATA / "own" / "ins_log.tsv.gz", INS_FORMAT)
    assert np.isnat(ins.columns["utc"][:50]).all() and not np.isnat(ins.columns["utc"][50:]).any()
    assert set(np.unique(ins.columns["time_valid"])) == {0, 1}


def test_bad_mapping_names_the_key():
    bad = copy.deepcopy(SONIC_FORMAT)
    bad["axes"] = {"u": "v", "v": "v", "w": "w"}
    with pytest.raises(InputError, match=r"sonic.format.axes.*each logged component once"):
        sonic_record(DATA / "own" / "sonic_log.txt", bad)
    bad = copy.deepcopy(SONIC_FORMAT)
    bad["variables"]["u"]["column"] = "U"
    with pytest.raises(InputError, match=r"column 'U' of u not in the header line"):
        sonic_record(DATA / "own" / "sonic_log.txt", bad)


def _manifest(tmp_path: Path, sonic_format, ins_format) -> Path:
    data = {
        "name": "own_layout",
        "site": {"name": "P2OA", "latitude": 43.1247, "longitude": 0.3628, "altitude_m": 603},
        "data_root": str(DATA),
        "masts": [{"id": "p2oa", "sonics": [{"id": "mast30", "height_m": 30, "azimuth_deg": 218.0,
                                              "files": ["../io_excerpts/TOA5_*.dat"]}]}],
        "payload_flights": [{"id": "s01", "reference": "mast30", "target_height_m": 30,
                             "sonic": {"file": "own/sonic_log.txt", "mount": "upside_down", "format": sonic_format},
                             "ins": {"file": "own/ins_log.tsv.gz", "format": ins_format}}],
    }
    path = tmp_path / "campaign.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def test_manifest_takes_the_mapping_and_the_files_match_it(tmp_path):
    campaign = load_campaign(_manifest(tmp_path, SONIC_FORMAT, INS_FORMAT))
    flight = campaign.payload_flights[0]
    for part in ("sonic", "ins"):
        fmt = record_format(flight[part], f"payload_{part}")
        check_file_format(campaign.data_root / flight[part]["file"], fmt, f"payload_{part}")


def test_manifest_mapping_typo_is_named(tmp_path):
    bad = copy.deepcopy(INS_FORMAT)
    bad["utc"]["kind"] = "gps_week"
    with pytest.raises(ManifestError) as info:
        load_campaign(_manifest(tmp_path, SONIC_FORMAT, bad))
    assert info.value.key_path == "payload_flights[0].ins.format.utc.kind"
    bad = copy.deepcopy(SONIC_FORMAT)
    bad["axis"] = bad.pop("axes")
    with pytest.raises(ManifestError, match="did you mean 'axes'"):
        load_campaign(_manifest(tmp_path, bad, INS_FORMAT))


def test_workflow_step_writes_the_same_l1_files(tmp_path):
    """The L1 step (what the workflow rule runs) with the manifest's formats: same stored values."""
    import xarray as xr

    from dronewind.steps import payload_l1

    common = {"campaign": "own_layout", "flight_id": "s01", "site": {"latitude": 43.1247, "longitude": 0.3628},
              "target_height_m": 30.0, "despike": DESPIKE, "simulated": False, "data_root": DATA}
    a = payload_l1(DATA / "contract" / "sonic.csv", DATA / "contract" / "ins.csv", tmp_path / "a_sonic.nc",
                   tmp_path / "a_ins.nc", **common)
    b = payload_l1(DATA / "own" / "sonic_log.txt", DATA / "own" / "ins_log.tsv.gz", tmp_path / "b_sonic.nc",
                   tmp_path / "b_ins.nc", sonic_format=SONIC_FORMAT, ins_format=INS_FORMAT, **common)
    for fa, fb in zip(a, b, strict=True):
        for group in (None, "sensor_frame", "ins_raw"):
            try:
                da, db = xr.load_dataset(fa, group=group), xr.load_dataset(fb, group=group)
            except OSError:
                continue
            xr.testing.assert_allclose(da.drop_attrs(), db.drop_attrs(), rtol=0, atol=ATOL)


def test_the_manifest_page_shows_these_mappings():
    """docs/manifest.md's measured example with one's own layout is the mapping tested here."""
    from tests.workflow.test_readme import manifest_examples

    example = next(e for e in manifest_examples() if e["name"] == "own_logger")
    flight = example["payload_flights"][0]
    assert flight["sonic"]["format"] == SONIC_FORMAT
    assert flight["ins"]["format"] == INS_FORMAT
