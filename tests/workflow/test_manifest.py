"""Campaign manifests: a valid one loads; each kind of mistake is named (file, key path, expectation)."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest
import yaml

from dronewind.cli import main as cli_main
from dronewind.errors import ManifestError
from dronewind.manifest import config_schema, default_config, load_campaign, payload_flight_manifest, with_defaults

VALID = {
    "name": "testcamp",
    "site": {"name": "P2OA", "latitude": 43.1247, "longitude": 0.3628, "altitude_m": 603},
    "masts": [
        {
            "id": "p2oa",
            "latitude": 43.1247,
            "longitude": 0.3628,
            "sonics": [
                {"id": "mast30", "height_m": 30, "model": "CSAT3", "azimuth_deg": 218.0,
                 "files": ["mast/mast30_*.dat"]},
                {"id": "mast60", "height_m": 60, "model": "CSAT3", "azimuth_deg": 230.5,
                 "files": ["mast/mast60_*.dat"]},
            ],
        }
    ],
    "payload_flights": [
        {
            "id": "s01",
            "reference": "mast30",
            "target_height_m": 30,
            "sonic": {"file": "flights/s01/sonic.csv", "mount": "upside_down"},
            "ins": {"file": "flights/s01/ins.csv"},
            "window": {"start": "2023-08-21T14:05:32Z", "end": "2023-08-21T14:33:32Z"},
        }
    ],
    "quadrotor_flights": [
        {"id": "f31", "reference": "tower/f31_reference.csv", "uavs": [{"id": "q01", "file": "quad/f31/q01.csv"}]}
    ],
}


#: File heads in the contract formats (validate-campaign reads the first lines of every file).
_TOA5_HEAD = (Path(__file__).parents[1] / "data" / "io_excerpts" / "TOA5_6843.ts_Above_2012_06_07_1245_excerpt.dat"
              ).read_text().splitlines()[:6]
FILE_HEADS = {
    "mast/mast30_a.dat": "\n".join(_TOA5_HEAD) + "\n",
    "mast/mast60_a.dat": "\n".join(_TOA5_HEAD) + "\n",
    "flights/s01/sonic.csv": "rpi_time_us,u_ms,v_ms,w_ms,t_sonic_c\n1000000,1.0,0.5,0.1,20.0\n",
    "flights/s01/ins.csv": "rpi_time_us,utc,time_valid,ekf_valid,lat_deg,lon_deg,alt_m,vel_n_ms,vel_e_ms,vel_d_ms,"
                           "roll_deg,pitch_deg,yaw_deg\n1000000,,0,1,43.1,0.36,650.0,0,0,0,1,2,3\n",
    "tower/f31_reference.csv": "time_utc,height_m,wind_speed_ms,wind_from_deg\n2020-06-30T18:00:00Z,30,5.0,270\n",
    "quad/f31/q01.csv": "time_utc,roll_deg,pitch_deg,yaw_deg,vel_n_ms,vel_e_ms,vel_d_ms,lat_deg,lon_deg,alt_m\n"
                        "2020-06-30T18:00:00Z,1,-5,270,0,0,0,36.6,-97.5,320\n",
}


def write_campaign(tmp_path: Path, data: dict, make_files: bool = True) -> Path:
    if make_files:
        for rel, head in FILE_HEADS.items():
            (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
            (tmp_path / rel).write_text(head)
    path = tmp_path / "campaign.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def expect_error(tmp_path: Path, data: dict, key: str, fragment: str, make_files: bool = True) -> ManifestError:
    path = write_campaign(tmp_path, data, make_files)
    with pytest.raises(ManifestError) as info:
        load_campaign(path)
    err = info.value
    assert str(path) in str(err), "the message names the manifest file"
    assert err.key_path == key, f"key path: got {err.key_path!r}, expected {key!r}\n{err}"
    assert fragment in str(err), f"expected {fragment!r} in: {err}"
    return err


def test_valid_manifest_loads(tmp_path):
    campaign = load_campaign(write_campaign(tmp_path, VALID))
    assert campaign.name == "testcamp"
    assert not campaign.simulated
    assert set(campaign.mast_sonics()) == {"mast30", "mast60"}
    assert campaign.mast_files("mast30") == [tmp_path / "mast/mast30_a.dat"]
    assert campaign.payload_flight("s01")["sonic"]["mount"] == "upside_down"


def test_yaml_timestamps_are_normalised(tmp_path):
    path = write_campaign(tmp_path, VALID)
    # unquoted ISO times are parsed by YAML into datetimes; they must come back as UTC strings
    text = path.read_text().replace("'2023-08-21T14:05:32Z'", "2023-08-21T14:05:32Z")
    path.write_text(text)
    window = load_campaign(path).payload_flight("s01")["window"]
    assert window["start"] == "2023-08-21T14:05:32Z"


def test_missing_key(tmp_path):
    data = copy.deepcopy(VALID)
    del data["payload_flights"][0]["ins"]
    expect_error(tmp_path, data, "payload_flights[0].ins", "missing required key")


def test_missing_top_level_key(tmp_path):
    data = copy.deepcopy(VALID)
    del data["site"]
    expect_error(tmp_path, data, "site", "missing required key")


def test_wrong_type(tmp_path):
    data = copy.deepcopy(VALID)
    data["masts"][0]["sonics"][0]["height_m"] = "thirty"
    expect_error(tmp_path, data, "masts[0].sonics[0].height_m", "expected number")


def test_unknown_sensor_id(tmp_path):
    data = copy.deepcopy(VALID)
    data["payload_flights"][0]["reference"] = "mast45"
    err = expect_error(tmp_path, data, "payload_flights[0].reference", "unknown mast sonic id 'mast45'")
    assert "mast30" in str(err) and "mast60" in str(err), "the known ids are listed"


def test_file_does_not_exist(tmp_path):
    data = copy.deepcopy(VALID)
    data["payload_flights"][0]["sonic"]["file"] = "flights/s01/missing.csv"
    expect_error(tmp_path, data, "payload_flights[0].sonic.file", "does not exist")


def test_glob_matches_nothing(tmp_path):
    data = copy.deepcopy(VALID)
    data["masts"][0]["sonics"][1]["files"] = ["mast/other_*.dat"]
    expect_error(tmp_path, data, "masts[0].sonics[1].files[0]", "glob 'mast/other_*.dat' matches no file")


def test_duplicate_flight_ids(tmp_path):
    data = copy.deepcopy(VALID)
    data["payload_flights"].append(copy.deepcopy(data["payload_flights"][0]))
    expect_error(tmp_path, data, "payload_flights[1].id", "duplicate flight id 's01'")


def test_duplicate_ids_across_sections(tmp_path):
    data = copy.deepcopy(VALID)
    data["quadrotor_flights"][0]["id"] = "s01"
    expect_error(tmp_path, data, "quadrotor_flights[0].id", "duplicate flight id 's01'")


def test_window_end_before_start(tmp_path):
    data = copy.deepcopy(VALID)
    data["payload_flights"][0]["window"]["end"] = "2023-08-21T14:00:00Z"
    expect_error(tmp_path, data, "payload_flights[0].window.end", "is not after start")


def test_bad_time_string(tmp_path):
    data = copy.deepcopy(VALID)
    data["payload_flights"][0]["window"]["start"] = "21/08/2023 14:05"
    expect_error(tmp_path, data, "payload_flights[0].window.start", "ISO 8601")


def test_bad_mount(tmp_path):
    data = copy.deepcopy(VALID)
    data["payload_flights"][0]["sonic"]["mount"] = "sideways"
    expect_error(tmp_path, data, "payload_flights[0].sonic.mount", "sideways")



def test_mistyped_key_is_named_with_the_nearest_valid_one(tmp_path):
    """``mounting: upright`` would leave the mount at its default (v and w flipped): an error, not a pass."""
    data = copy.deepcopy(VALID)
    data["payload_flights"][0]["sonic"] = {"file": "flights/s01/sonic.csv", "mounting": "upright"}
    expect_error(tmp_path, data, "payload_flights[0].sonic.mounting", "did you mean 'mount'?")


def test_mistyped_key_beside_the_real_one_is_an_error(tmp_path):
    data = copy.deepcopy(VALID)
    data["payload_flights"][0]["target_hieght_m"] = 28
    expect_error(tmp_path, data, "payload_flights[0].target_hieght_m", "did you mean 'target_height_m'?")


def test_unknown_key_far_from_any_lists_the_valid_keys(tmp_path):
    data = copy.deepcopy(VALID)
    data["site"]["weather"] = "sunny"
    err = expect_error(tmp_path, data, "site.weather", "the keys here are: altitude_m, extra, latitude")
    assert "x-weather" in str(err)


def test_every_unknown_key_is_reported(tmp_path):
    data = copy.deepcopy(VALID)
    data["masts"][0]["sonics"][1]["hieght_m"] = 60
    data["quadrotor_flights"][0]["uavs"][0]["fromat"] = "ulog"
    err = expect_error(tmp_path, data, "masts[0].sonics[1].hieght_m", "did you mean 'height_m'?")
    assert "[quadrotor_flights[0].uavs[0].fromat]" in str(err) and "did you mean 'format'?" in str(err)


def test_own_keys_under_x_prefix_or_extra_are_kept(tmp_path):
    data = copy.deepcopy(VALID)
    data["x-operator"] = "A. Smith"
    data["payload_flights"][0]["x-battery"] = 3
    data["payload_flights"][0]["sonic"]["extra"] = {"serial": "81000-123"}
    data["masts"][0]["extra"] = {"painted": True}
    campaign = load_campaign(write_campaign(tmp_path, data))
    assert campaign.data["x-operator"] == "A. Smith"
    assert campaign.payload_flights[0]["sonic"]["extra"] == {"serial": "81000-123"}

def test_simulated_campaign_needs_no_files(tmp_path):
    data = copy.deepcopy(VALID)
    data["simulation"] = {"seed": 1}
    campaign = load_campaign(write_campaign(tmp_path, data, make_files=False))
    assert campaign.simulated
    # one generated mast file per payload flight, '*' standing for the flight id
    assert campaign.mast_files("mast30", tmp_path / "L0") == [tmp_path / "L0/mast/mast30_s01.dat"]


def test_only_quadrotor_section(tmp_path):
    data = {k: v for k, v in copy.deepcopy(VALID).items() if k not in ("masts", "payload_flights")}
    campaign = load_campaign(write_campaign(tmp_path, data))
    assert campaign.payload_flights == [] and len(campaign.quadrotor_flights) == 1


def test_cli_validate_campaign(tmp_path, capsys):
    assert cli_main(["validate-campaign", str(write_campaign(tmp_path, VALID))]) == 0
    assert "valid measured campaign 'testcamp'" in capsys.readouterr().out
    data = copy.deepcopy(VALID)
    data["payload_flights"][0]["reference"] = "nope"
    assert cli_main(["validate-campaign", str(write_campaign(tmp_path, data))]) == 1
    assert "payload_flights[0].reference" in capsys.readouterr().err


# ----------------------------------------------------------------------------- workflow settings


def _schema_defaults(node: dict) -> dict:
    """Every ``default`` of the config schema, as a nested dict (independent of with_defaults)."""
    out = {}
    for key, sub in (node.get("properties") or {}).items():
        if sub.get("type") == "object":
            out[key] = _schema_defaults(sub)
        elif "default" in sub:
            out[key] = sub["default"]
    return out


def test_every_processing_and_diagnosis_setting_has_one_default():
    schema = config_schema()
    for section in ("processing", "diagnosis"):
        for key, sub in schema["properties"][section]["properties"].items():
            assert "default" in sub, f"{section}.{key} has no default"
            if (section, key) == ("diagnosis", "forward_payload"):
                # the simulator's payload settings, each optional (the simulator's own value where unset)
                assert sub["default"] == {}
                continue
            for name, leaf in (sub.get("properties") or {}).items():
                assert "default" in leaf, f"{section}.{key}.{name} has no default"
    defaults = default_config()
    assert defaults == _schema_defaults(schema)
    assert defaults["processing"]["spectra"] == {"segments": 3, "overlap": 0.5, "bins": 100}
    assert defaults["diagnosis"]["seeds"] is None  # enough for the campaign's flights (probes.baseline_seeds)


def test_with_defaults_fills_only_what_is_missing():
    given = {"campaign": "c.yaml", "processing": {"spectra": {"segments": 5}, "rotation": "planar_fit"}}
    config = with_defaults(given)
    assert config["processing"]["spectra"] == {"segments": 5, "overlap": 0.5, "bins": 100}
    assert config["processing"]["rotation"] == "planar_fit"
    assert config["processing"]["hover"] == default_config()["processing"]["hover"]
    assert given == {"campaign": "c.yaml", "processing": {"spectra": {"segments": 5}, "rotation": "planar_fit"}}


def test_shipped_config_is_valid_against_its_schema():
    import jsonschema

    config = with_defaults(yaml.safe_load((Path(__file__).resolve().parents[2] / "config/config.yaml").read_text()))
    jsonschema.Draft202012Validator(config_schema()).validate(config)


def test_payload_flight_manifest_keeps_one_flight_and_its_reference_sonic():
    data = copy.deepcopy(VALID)
    data["payload_flights"].append({**copy.deepcopy(data["payload_flights"][0]), "id": "s02", "reference": "mast60"})
    data["simulation"] = {"seed": 1, "atmosphere": {"roughness_length_m": 0.2},
                          "payload_flights": {"s02": {"mean_speed_ms": 5.0}}}
    view = payload_flight_manifest(data, "s02")
    assert [f["id"] for f in view["payload_flights"]] == ["s02"]
    assert [s["id"] for m in view["masts"] for s in m["sonics"]] == ["mast60"]
    assert "simulation" not in view and "quadrotor_flights" not in view
    assert list(view) == [k for k in data if k not in ("simulation", "quadrotor_flights", "tunnel")]
    with_atmosphere = payload_flight_manifest(data, "s02", atmosphere=True)
    assert with_atmosphere["simulation"] == {"atmosphere": {"roughness_length_m": 0.2},
                                             "payload_flights": {"s02": {"mean_speed_ms": 5.0}}}
