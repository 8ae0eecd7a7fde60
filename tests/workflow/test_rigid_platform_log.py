"""A rigid-mount flight whose platform state is the vehicle's own log, through the manifest and Snakemake.

The sonic record is the synthetic one of ``tests/payload/test_rigid_platform_log.py`` (a constant
wind read through the attitude and velocity of the real ArduCopter log ``ardupilot_dataflash``);
its mapping declares the sonic only, the manifest's ``platform_log`` gives the rest. Run:
the two jobs ``rigid_l1`` and ``rigid_l2`` only.
"""

from __future__ import annotations

import copy
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from dronewind.core.products import open_product
from dronewind.errors import ManifestError
from dronewind.manifest import load_campaign
from dronewind.payload.platform_log import read_platform_state
from tests.conftest import needs_record
from tests.payload.test_rigid_platform_log import FMT, LOG, WIND_ENU, sonic_on_log

ROOT = Path(__file__).resolve().parents[2]
pytestmark = needs_record("ardupilot_dataflash")

MANIFEST = {
    "name": "rigid_platform_log",
    "site": {"name": "Finse", "latitude": 60.5931, "longitude": 7.5241, "altitude_m": 1215.0},
    "masts": [],
    "payload_flights": [{
        "id": "finse", "platform": "rigid_mount", "target_height_m": 22.0,
        "record": {"file": "sonic.csv", "format": FMT},
        "platform_log": {"file": str(LOG), "format": "ardupilot_bin"},
        "sonic": {"model": "synthetic", "axes": {"u": "right", "v": "forward", "w": "up"}},
    }],
}


def _write(folder: Path, data: dict) -> Path:
    path = folder / "campaign.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    folder = tmp_path_factory.mktemp("rigid_platform_log")
    sonic_on_log(read_platform_state(LOG, "ardupilot_bin"), folder / "sonic.csv")
    return _write(folder, MANIFEST)


def test_manifest_names_a_missing_log_and_missing_platform_variables(campaign):
    assert load_campaign(campaign).payload_flights[0]["platform_log"]["file"] == str(LOG)
    folder = campaign.parent
    data = copy.deepcopy(MANIFEST)
    data["payload_flights"][0]["platform_log"]["file"] = "logs/absent.bin"
    with pytest.raises(ManifestError, match=r"payload_flights\[0\]\.platform_log\.file.*'logs/absent\.bin' does "
                                            "not exist"):
        load_campaign(_write(folder, data))
    del data["payload_flights"][0]["platform_log"]
    with pytest.raises(ManifestError, match=r"record\.format\.variables.*missing roll, pitch, yaw, lat, lon, alt"):
        load_campaign(_write(folder, data))
    _write(folder, MANIFEST)


def test_workflow_takes_the_platform_from_the_log(campaign, tmp_path):
    target = tmp_path / "rigid_platform_log" / "netcdf" / "L2" / "finse_drone.nc"
    run = subprocess.run([str(Path(sys.executable).with_name("snakemake")), "--cores", "1", "--config",
                          f"campaign={campaign}", f"results_dir={tmp_path}",
                          'processing={"rigid_mount": {"min_segment_s": 30.0}}', "--", str(target)],
                         cwd=ROOT, capture_output=True, text=True, timeout=300,
                         env={**os.environ, "PYTHONPATH": str(ROOT / "src")})
    assert run.returncode == 0, run.stderr[-3000:]
    # the log is an input of the L1 job (Snakemake tracks it: a changed log reruns the L1)
    assert f"input: {campaign.parent / 'sonic.csv'}, {LOG}" in run.stdout + run.stderr
    l1 = open_product(tmp_path / "rigid_platform_log" / "netcdf" / "L1" / "finse_rigid.nc")
    assert l1.attrs["platform_log_file"] == str(LOG)
    assert l1.attrs["platform_log_sha256"] == "8424b26fe3a2326dffeff817a544002877b65776e5429c91f98204e0e6535d46"
    assert l1.attrs["platform_log_format"] == "ardupilot_bin" and l1.attrs["n_platform_outside_log"] == 403
    l2 = open_product(target)
    for key, true in zip(("u_east_ms", "v_north_ms", "w_up_ms"), WIND_ENU, strict=True):
        assert float(l2[key].mean()) == pytest.approx(true, abs=0.05)
