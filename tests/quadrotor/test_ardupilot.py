"""ArduPilot DataFlash logs: a synthetic log with known answers, and the real Finse log.

The synthetic log is written message by message in the DataFlash layout (FMT messages
describing each type, then ``a3 95 <type>`` and the packed fields), because pymavlink reads
DataFlash logs but has no writer for them; it is read back through pymavlink like any log.
Its answers are known by construction: the UTC of the GPS week and milliseconds minus 18
leap seconds, the attitude, the EKF core chosen, the rows whose EKF wind is still unset,
the air density of the logged pressure and temperature, and an EKF wind equal to the drag
balance of the logged tilt (Wetz et al. 2021, Eqs. 12-18) so that tilt minus EKF is zero.

The real log (record ``ardupilot_dataflash`` of :mod:`dronewind.datasets`, GPL-3.0, read where it lies) is
checked for what it holds: 1632 attitude rows at 10 Hz from 06:02:40 UTC on 2023-03-28 (the
time in its original file name), the EKF wind set after take-off, and the numbers of the
comparison reported in README.
"""

from __future__ import annotations

import os
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from dronewind.errors import InputError
from dronewind.formats import check_file_format
from dronewind.quadrotor import ardupilot as ap
from dronewind.quadrotor.drag import DragLaw, speed_from_tilt
from dronewind.quadrotor.ekf_wind import air_density_kgm3, compare_with_ekf, tilt_and_ekf_wind
from dronewind.quadrotor.io import read_quadrotor
from tests.conftest import needs_record, record_path

ROOT = Path(__file__).resolve().parents[2]
REAL = record_path("ardupilot_dataflash", "finse_2023-03-28_0602.bin")
needs_real = needs_record("ardupilot_dataflash")

# ----------------------------------------------------------------------------- a DataFlash writer

#: (type id, name, format, columns) of the messages written; format letters as ArduPilot's
#: (Q uint64, f float, B uint8, H uint16, I uint32, d double, N char[16]).
_TYPES = {
    "ATT": (130, "QffffffB", "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,AEKF"),
    "XKF1": (131, "QBffffff", "TimeUS,C,VN,VE,VD,PN,PE,PD"),
    "XKF2": (132, "QBff", "TimeUS,C,VWN,VWE"),
    "GPS": (133, "QBIH", "TimeUS,Status,GMS,GWk"),
    "POS": (134, "Qddf", "TimeUS,Lat,Lng,Alt"),
    "BARO": (135, "QBfff", "TimeUS,I,Alt,Press,Temp"),
    "PARM": (136, "QNf", "TimeUS,Name,Value"),
}
_STRUCT = {"Q": "Q", "f": "f", "B": "B", "H": "H", "I": "I", "d": "d", "n": "4s", "N": "16s", "Z": "64s"}


def _fmt_message(type_id: int, name: str, fmt: str, columns: str) -> bytes:
    size = 3 + struct.calcsize("<" + "".join(_STRUCT[c] for c in fmt))
    return b"\xa3\x95\x80" + struct.pack("<BB4s16s64s", type_id, size, name.encode(), fmt.encode(), columns.encode())


def write_dataflash(path: Path, rows: list[tuple[str, tuple]]) -> Path:
    """A DataFlash log of the FMT of every type in :data:`_TYPES` (FMT itself first), then ``rows``."""
    out = bytearray(_fmt_message(128, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns"))
    for name, (type_id, fmt, columns) in _TYPES.items():
        out += _fmt_message(type_id, name, fmt, columns)
    for name, values in rows:
        type_id, fmt, _ = _TYPES[name]
        out += b"\xa3\x95" + bytes([type_id]) + struct.pack("<" + "".join(_STRUCT[c] for c in fmt), *values)
    path.write_bytes(bytes(out))
    return path


# a hover of 60 s at 20 m above a take-off point, nose east, pitched 5 degrees nose down
BOOT_TO_UTC_US = 1_622_541_600_000_000  # UTC 2021-06-01T10:00:00 at boot time 0
WEEK = 2160  # GPS week of 2021-06-01
PITCH_DEG, YAW_DEG, PRESS_PA, TEMP_C = -5.0, 90.0, 90_000.0, 0.0


def _gps_ms_of_week(utc_us: int) -> float:
    gps_us = utc_us + 18_000_000 - (np.datetime64("1980-01-06", "us").astype(np.int64))
    return (gps_us - WEEK * 7 * 86400 * 10**6) / 1000.0


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory):
    law = DragLaw(rho_kgm3=float(air_density_kgm3(PRESS_PA, TEMP_C)))
    # the EKF wind equal to the drag balance of the tilt: from the east (the nose), blowing west
    speed = float(speed_from_tilt(np.radians(5.0), law.cd0a0_m2, law.cp_m2_per_rad, law.mass_kg, law.rho_kgm3))
    rows: list[tuple[str, tuple]] = [("PARM", (0, b"AHRS_TRIM_X", 0.01)), ("PARM", (0, b"EK3_DRAG_BCOEF_X", 100.0))]
    for i in range(1200):  # 120 s at 10 Hz
        t_us = 1_000_000 + i * 100_000
        climbing = i < 200
        alt = 1000.0 + (20.0 * i / 200 if climbing else 20.0)
        rows.append(("ATT", (t_us, 0.0, 0.0, PITCH_DEG, PITCH_DEG, YAW_DEG, YAW_DEG, 3)))
        for core in (0, 1):
            vd = -1.0 if climbing else 0.0
            rows.append(("XKF1", (t_us - 500, core, 0.0 + core, 0.0, vd, 0.0, 0.0, 1000.0 - alt)))
            unset = i < 300
            rows.append(("XKF2", (t_us - 500, core, 0.0, 0.0 if unset else -speed + core)))
        rows.append(("POS", (t_us + 100, 60.0, 7.0, alt)))
        rows.append(("BARO", (t_us + 200, 0, alt - 1000.0, PRESS_PA, TEMP_C)))
        if i % 2 == 0:  # GPS at 5 Hz, with 80 ms between the fix and its log row
            rows.append(("GPS", (t_us + 80_000, 6, round(_gps_ms_of_week(BOOT_TO_UTC_US + t_us)), WEEK)))
    path = write_dataflash(tmp_path_factory.mktemp("dataflash") / "hover.bin", rows)
    return path, law, speed


def test_leap_seconds_of_the_table():
    # GPS - UTC: 0 at the GPS epoch, 17 s in 2016, 18 s from 2017-01-01 (IERS Bulletin C)
    offs = ap.gps_utc_offset_s(np.array(["1980-01-06", "2016-12-31T23:59:59", "2017-01-01", "2023-03-28"],
                                        dtype="datetime64[ns]"))
    assert list(offs) == [0, 17, 18, 18]
    # GPS week 2255, 194578.6 s (the Finse log's first fix) -> 2023-03-28 06:02:40.6 UTC
    assert ap.gps_to_utc_ns(np.array([2255]), np.array([194_578_600]))[0] == np.datetime64(
        "2023-03-28T06:02:40.600", "ns")


def test_synthetic_log_known_answers(synthetic):
    path, _, speed = synthetic
    ds = read_quadrotor(path)  # by the .bin suffix
    assert ds.sizes["time"] == 1200 and ds.attrs["utc_valid"] == 1
    # UTC: boot time 1 s is 10:00:01 (the GPS rows' 80 ms after the fix are the median offset)
    first = ds["time"].to_numpy()[0]
    expected = np.datetime64(BOOT_TO_UTC_US + 1_000_000, "us").astype("datetime64[ns]") - np.timedelta64(80, "ms")
    assert abs((first - expected).astype("int64")) <= 1000  # 1 us: the ms of week are rounded
    assert np.allclose(ds["pitch_deg"], PITCH_DEG) and np.allclose(ds["yaw_deg"], YAW_DEG)
    assert np.allclose(ds["des_pitch_deg"], PITCH_DEG)
    # core 0 is read (core 1 has VN = 1); interpolation to the ATT times is exact for constants
    assert np.nanmax(np.abs(ds["vel_n_ms"].to_numpy())) == 0.0
    # 300 rows per core with the EKF wind unset: NaN and counted
    assert ds.attrs["n_ekf_wind_unset"] == 300
    wind_e = ds["ekf_wind_e_ms"].to_numpy()
    # the last ATT row is 0.5 ms after the last XKF2 row: outside its span, NaN
    assert np.isnan(wind_e[:299]).all() and np.allclose(wind_e[301:-1], -speed) and np.isnan(wind_e[-1])
    assert np.allclose(ds["pressure_pa"][1:], PRESS_PA) and ds.attrs["param_AHRS_TRIM_X"] == pytest.approx(0.01)
    core1 = read_quadrotor(path, {"name": "ardupilot_bin", "ekf_core": 1})
    assert np.nanmin(core1["vel_n_ms"].to_numpy()) == 1.0


def test_tilt_wind_equals_an_ekf_wind_of_the_same_drag_balance(synthetic):
    path, law, speed = synthetic
    ds = read_quadrotor(path, "ardupilot_bin")
    l3 = tilt_and_ekf_wind(ds, law=DragLaw(), density="logged")
    # density of the logged 90 kPa and 0 degC: p / (R_d T) = 1.1478 kg m-3
    assert np.allclose(l3["rho_kgm3"], 90_000.0 / (287.05 * 273.15))
    stats = compare_with_ekf(l3, "synthetic").set_index("source")
    # the segment: airborne above 3 m, EKF wind set (after row 300), i.e. 90 s
    assert stats.loc["attitude", "n_blocks"] == 90
    # tilt minus EKF: zero to float32 rounding of the logged values (1e-5 relative)
    assert abs(stats.loc["attitude", "speed_bias_ms"]) < 1e-4 * speed
    assert abs(stats.loc["attitude", "direction_bias_deg"]) < 1e-3
    assert np.allclose(l3["wind_from_deg"], 90.0, atol=1e-3)  # from the east, the nose's direction
    assert stats.loc["attitude", "scale_to_ekf"] == pytest.approx(1.0, abs=1e-4)
    # with the law's own density (1.2 kg m-3) the tilt speed is lower by sqrt(1.1478 / 1.2)
    l3_law = tilt_and_ekf_wind(ds, law=DragLaw(), density="law")
    ratio = float(l3_law["wind_speed_ms"].mean() / l3["wind_speed_ms"].mean())
    assert ratio == pytest.approx(np.sqrt(90_000.0 / (287.05 * 273.15) / 1.2), rel=1e-6)


def test_format_check_and_bad_files(synthetic, tmp_path):
    path, _, _ = synthetic
    check_file_format(path, {"name": "ardupilot_bin"}, "quadrotor_uav")
    not_bin = tmp_path / "log.bin"
    not_bin.write_text("time_utc,roll_deg\n")
    with pytest.raises(InputError, match="expected an ArduPilot DataFlash log"):
        check_file_format(not_bin, {"name": "ardupilot_bin"}, "quadrotor_uav")
    no_att = write_dataflash(tmp_path / "no_att.bin", [("BARO", (1, 0, 0.0, PRESS_PA, TEMP_C))])
    with pytest.raises(InputError, match=r"no_att.bin \[ATT\].*no ATT message"):
        read_quadrotor(no_att)
    with pytest.raises(InputError, match="not found"):
        read_quadrotor(tmp_path / "absent.bin")


@needs_real
def test_real_finse_log():
    ds = read_quadrotor(REAL, {"name": "ardupilot_bin"})
    assert ds.sizes["time"] == 1632 and ds.attrs["sampling_rate_hz"] == pytest.approx(10.0, rel=1e-3)
    t0 = pd.Timestamp(ds["time"].to_numpy()[0])
    assert t0.floor("s") == pd.Timestamp("2023-03-28T06:02:40")  # the original file name's time
    assert ds.attrs["ekf"] == "EKF3" and ds.attrs["n_ekf_wind_unset"] == 259
    assert ds.attrs["param_EK3_DRAG_BCOEF_X"] == 100.0
    l3 = tilt_and_ekf_wind(ds, law=DragLaw(), density="logged")
    stats = compare_with_ekf(l3, "finse20230328").set_index("source")
    att = stats.loc["attitude"]
    # what the log gives (README): 104 s compared, speeds alike on average, directions not
    assert att["n_blocks"] == 104
    assert att["mean_ekf_speed_ms"] == pytest.approx(1.94, abs=0.01)
    assert att["speed_bias_ms"] == pytest.approx(0.02, abs=0.01)
    assert att["speed_rmse_ms"] == pytest.approx(0.59, abs=0.01)
    assert att["direction_bias_deg"] == pytest.approx(-66.0, abs=1.0)
    assert l3.attrs["segment_n_no_ekf_wind"] == 260


@needs_real
@pytest.mark.slow
def test_real_campaign_workflow(tmp_path):
    """The shipped campaign through Snakemake: L3, L4, the table and the figure."""
    campaign = ROOT / "config" / "campaigns" / "real_ardupilot_finse.yaml"
    out = tmp_path / "real_ardupilot_finse"
    targets = [str(out / "tables" / "autopilot_ekf_wind.csv"),
               str(out / "figures" / "autopilot_ekf_wind_finse20230328.png")]
    run = subprocess.run([str(Path(sys.executable).with_name("snakemake")), "--cores", "1", "--config",
                          f"campaign={campaign}", f"results_dir={tmp_path}", "--", *targets],
                         cwd=ROOT, capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(ROOT / "src")})
    assert run.returncode == 0, run.stderr[-3000:]
    table = pd.read_csv(targets[0])
    assert list(table["source"]) == ["attitude", "set_point"]
    assert table.loc[0, "speed_bias_ms"] == pytest.approx(0.02, abs=0.01)
    assert (out / "netcdf" / "L3" / "autopilot" / "finse20230328.nc").is_file()
    assert (out / "netcdf" / "L4" / "autopilot" / "finse20230328.nc").is_file()


def test_platform_state_for_a_rigid_mount(synthetic):
    from dronewind.payload.rigid import read_platform_state

    path, _, _ = synthetic
    ds = read_platform_state(path, {"name": "ardupilot_bin", "ekf_core": 1})
    assert list(ds.data_vars) == ["roll_deg", "pitch_deg", "yaw_deg", "vel_n_ms", "vel_e_ms", "vel_d_ms", "lat_deg",
                                  "lon_deg", "alt_m"]
    assert np.nanmin(ds["vel_n_ms"].to_numpy()) == 1.0 and np.allclose(ds["yaw_deg"], YAW_DEG)
    with pytest.raises(InputError, match="no platform-state reader"):
        read_platform_state(path, "ulog")
