"""L0 writers: payload sonic CSV, INS CSV and Campbell TOA5 (``docs/data-contract.md``, "Data contract").

The simulator reaches the processing chain only through these files, so they follow
the contract byte for byte: exact header lines, integer ``rpi_time_us``, ISO 8601 UTC
with microseconds and a trailing ``Z`` (empty while ``time_valid`` is 0), and TOA5 with
four header lines, Campbell-style timestamps (trailing zeros of the fraction dropped)
and quoted ``"NAN"`` for bad samples. Every file is written atomically (temporary file in
the destination folder, then renamed), so a killed job never leaves a half-written L0 file.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pandas as pd

from dronewind.core.cf import atomic_write_text
from dronewind.core.raw import RawRecord

__all__ = [
    "SONIC_HEADER",
    "INS_HEADER",
    "TOA5_FIELDS",
    "payload_sonic_record",
    "ins_record",
    "toa5_record",
    "write_record",
    "write_payload_sonic_csv",
    "write_ins_csv",
    "write_toa5",
    "utc_strings",
    "campbell_timestamps",
]

SONIC_HEADER = "rpi_time_us,u_ms,v_ms,w_ms,t_sonic_c"
INS_HEADER = ("rpi_time_us,utc,time_valid,ekf_valid,lat_deg,lon_deg,alt_m,vel_n_ms,vel_e_ms,"
              "vel_d_ms,roll_deg,pitch_deg,yaw_deg")
TOA5_FIELDS = ("TIMESTAMP", "RECORD", "Ux", "Uy", "Uz", "Ts", "diag_csat")
TOA5_UNITS = ("TS", "RN", "m/s", "m/s", "m/s", "C", "unitless")
TOA5_PROCESSING = ("", "", "Smp", "Smp", "Smp", "Smp", "Smp")


def _write_frame(path: Path, header: str, frame: pd.DataFrame) -> Path:
    body = frame.to_csv(index=False, header=False, lineterminator="\n", na_rep="")
    return atomic_write_text(Path(path), header + "\n" + body)


def utc_strings(times: np.ndarray) -> np.ndarray:
    """ISO 8601 UTC strings with microseconds and a trailing Z.

    Parameters
    ----------
    times : numpy.ndarray
        datetime64 (any unit; naive meaning UTC).

    Returns
    -------
    numpy.ndarray
        Strings like ``2023-08-21T14:05:32.031250Z``.
    """
    return np.char.add(np.datetime_as_string(np.asarray(times).astype("datetime64[us]"), unit="us"), "Z")


def campbell_timestamps(times: np.ndarray) -> np.ndarray:
    """Campbell TOA5 timestamps: ``YYYY-MM-DD HH:MM:SS.ff`` with trailing zeros dropped.

    Parameters
    ----------
    times : numpy.ndarray
        datetime64 (naive, UTC).

    Returns
    -------
    numpy.ndarray
        Strings such as ``2023-08-21 14:05:32.1`` and ``2023-08-21 14:05:33``.
    """
    text = np.datetime_as_string(np.asarray(times).astype("datetime64[ms]"), unit="ms")
    s = pd.Series(text).str.replace("T", " ", regex=False)
    s = s.str.rstrip("0").str.rstrip(".")
    return s.to_numpy(dtype=object)


def payload_sonic_record(source: str | Path, rpi_time_us: np.ndarray, u_ms: np.ndarray, v_ms: np.ndarray,
                         w_ms: np.ndarray, t_sonic_c: np.ndarray, decimals: int = 2) -> RawRecord:
    """The payload sonic file ``rpi_time_us,u_ms,v_ms,w_ms,t_sonic_c`` as an in-memory record.

    Parameters
    ----------
    source : str or Path
        Path of the file the record stands for.
    rpi_time_us : numpy.ndarray
        Logger clock stamps [us] (int64), in row order as logged.
    u_ms, v_ms, w_ms : numpy.ndarray
        Air velocity relative to the sensor in the sensor frame [m s-1].
    t_sonic_c : numpy.ndarray
        Sonic temperature [degree C].
    decimals : int
        Decimals written (the RM Young 81000 resolution is 0.01, Ghirardelli et al. (2025) Table 2).

    Returns
    -------
    RawRecord
        The values rounded as :func:`write_payload_sonic_csv` prints them.
    """
    return RawRecord(str(source), {
        "rpi_time_us": np.asarray(rpi_time_us, dtype=np.int64),
        "u_ms": np.round(np.asarray(u_ms, float), decimals),
        "v_ms": np.round(np.asarray(v_ms, float), decimals),
        "w_ms": np.round(np.asarray(w_ms, float), decimals),
        "t_sonic_c": np.round(np.asarray(t_sonic_c, float), decimals),
    })


def write_payload_sonic_csv(path: Path, rpi_time_us: np.ndarray, u_ms: np.ndarray, v_ms: np.ndarray,
                            w_ms: np.ndarray, t_sonic_c: np.ndarray, decimals: int = 2) -> Path:
    """Write the payload sonic file ``rpi_time_us,u_ms,v_ms,w_ms,t_sonic_c``.

    Parameters are those of :func:`payload_sonic_record` (``path``: the output file;
    folders are created).

    Returns
    -------
    Path
    """
    return write_record(path, payload_sonic_record(path, rpi_time_us, u_ms, v_ms, w_ms, t_sonic_c, decimals))


def ins_record(source: str | Path, rpi_time_us: np.ndarray, utc: np.ndarray, time_valid: np.ndarray,
               ekf_valid: np.ndarray, lat_deg: np.ndarray, lon_deg: np.ndarray, alt_m: np.ndarray,
               vel_n_ms: np.ndarray, vel_e_ms: np.ndarray, vel_d_ms: np.ndarray,
               roll_deg: np.ndarray, pitch_deg: np.ndarray, yaw_deg: np.ndarray) -> RawRecord:
    """The INS (EKF) file with the contract header as an in-memory record.

    Parameters
    ----------
    source : str or Path
        Path of the file the record stands for.
    rpi_time_us : numpy.ndarray
        Logger clock [us] (int64).
    utc : numpy.ndarray
        datetime64 UTC of each row; kept (to the microsecond) only where ``time_valid``
        is 1, NaT elsewhere (the file's field is empty there).
    time_valid, ekf_valid : numpy.ndarray
        0/1 flags.
    lat_deg, lon_deg : numpy.ndarray
        Position [degree_north, degree_east] (9 decimals, about 0.1 mm).
    alt_m : numpy.ndarray
        Altitude above mean sea level [m] (3 decimals).
    vel_n_ms, vel_e_ms, vel_d_ms : numpy.ndarray
        Velocity of the sonic's measurement volume, NED [m s-1] (4 decimals).
    roll_deg, pitch_deg, yaw_deg : numpy.ndarray
        Euler angles [degree] (Ghirardelli et al. 2025, Appendix A; 4 decimals).

    Returns
    -------
    RawRecord
    """
    tv = np.asarray(time_valid, dtype=np.int64)
    utc_us = np.asarray(utc).astype("datetime64[us]")
    return RawRecord(str(source), {
        "rpi_time_us": np.asarray(rpi_time_us, dtype=np.int64),
        "utc": np.where(tv == 1, utc_us, np.datetime64("NaT", "us")).astype("datetime64[ns]"),
        "time_valid": tv,
        "ekf_valid": np.asarray(ekf_valid, dtype=np.int64),
        "lat_deg": np.round(np.asarray(lat_deg, float), 9),
        "lon_deg": np.round(np.asarray(lon_deg, float), 9),
        "alt_m": np.round(np.asarray(alt_m, float), 3),
        "vel_n_ms": np.round(np.asarray(vel_n_ms, float), 4),
        "vel_e_ms": np.round(np.asarray(vel_e_ms, float), 4),
        "vel_d_ms": np.round(np.asarray(vel_d_ms, float), 4),
        "roll_deg": np.round(np.asarray(roll_deg, float), 4),
        "pitch_deg": np.round(np.asarray(pitch_deg, float), 4),
        "yaw_deg": np.round(np.asarray(yaw_deg, float), 4),
    })


def write_ins_csv(path: Path, rpi_time_us: np.ndarray, utc: np.ndarray, time_valid: np.ndarray,
                  ekf_valid: np.ndarray, lat_deg: np.ndarray, lon_deg: np.ndarray, alt_m: np.ndarray,
                  vel_n_ms: np.ndarray, vel_e_ms: np.ndarray, vel_d_ms: np.ndarray,
                  roll_deg: np.ndarray, pitch_deg: np.ndarray, yaw_deg: np.ndarray) -> Path:
    """Write the INS (EKF) file with the contract header.

    Parameters are those of :func:`ins_record` (``path``: the output file).

    Returns
    -------
    Path
    """
    return write_record(path, ins_record(path, rpi_time_us, utc, time_valid, ekf_valid, lat_deg, lon_deg, alt_m,
                                         vel_n_ms, vel_e_ms, vel_d_ms, roll_deg, pitch_deg, yaw_deg))


def toa5_record(source: str | Path, times: np.ndarray, record: np.ndarray, ux_ms: np.ndarray, uy_ms: np.ndarray,
                uz_ms: np.ndarray, ts_c: np.ndarray, diag_csat: np.ndarray, decimals: int = 4,
                table: str = "ts_data") -> RawRecord:
    """A Campbell TOA5 file of a CSAT3 as an in-memory record.

    Parameters
    ----------
    source : str or Path
        Path of the file the record stands for.
    times : numpy.ndarray
        datetime64 UTC time stamps (kept to the millisecond, as printed).
    record : numpy.ndarray
        RECORD numbers (int; may skip).
    ux_ms, uy_ms, uz_ms : numpy.ndarray
        CSAT3 components [m s-1] (sign convention of ``docs/data-contract.md``; NaN where bad).
    ts_c : numpy.ndarray
        Sonic temperature [degree C].
    diag_csat : numpy.ndarray
        CSAT3 diagnostic word (0 = good).
    decimals : int
        Decimals of the values.
    table : str
        Table name of the TOA5 header (``meta["table"]``).

    Returns
    -------
    RawRecord
        Columns ``TIMESTAMP`` (datetime64[ns]), ``RECORD``, ``Ux``, ``Uy``, ``Uz``, ``Ts``,
        ``diag_csat``; units of the TOA5 units line; first data row on line 5.
    """
    return RawRecord(str(source), {
        "TIMESTAMP": np.asarray(times).astype("datetime64[ms]").astype("datetime64[ns]"),
        "RECORD": np.asarray(record, dtype=np.int64),
        "Ux": np.round(np.asarray(ux_ms, float), decimals),
        "Uy": np.round(np.asarray(uy_ms, float), decimals),
        "Uz": np.round(np.asarray(uz_ms, float), decimals),
        "Ts": np.round(np.asarray(ts_c, float), decimals),
        "diag_csat": np.asarray(diag_csat, dtype=np.int64),
    }, units=dict(zip(TOA5_FIELDS, TOA5_UNITS, strict=True)), first_line=5, meta={"table": table})


def write_toa5(path: Path, times: np.ndarray, record: np.ndarray, ux_ms: np.ndarray, uy_ms: np.ndarray,
               uz_ms: np.ndarray, ts_c: np.ndarray, diag_csat: np.ndarray, station: str = "P2OA",
               logger: str = "CR3000", serial: str = "6843", table: str = "ts_data",
               program: str = "CPU:dronewind_sim.CR3", decimals: int = 4) -> Path:
    """Write a Campbell TOA5 file of a CSAT3 (NaN values are written as ``"NAN"``).

    Parameters
    ----------
    path : Path
        Output file.
    times, record, ux_ms, uy_ms, uz_ms, ts_c, diag_csat, decimals
        As :func:`toa5_record`.
    station, logger, serial, table, program : str
        Header line 1 fields.

    Returns
    -------
    Path
    """
    rec = toa5_record(path, times, record, ux_ms, uy_ms, uz_ms, ts_c, diag_csat, decimals, table=table)
    return write_record(path, rec, station=station, logger=logger, serial=serial, program=program)


def _toa5_text(rec: RawRecord, station: str, logger: str, serial: str, program: str) -> str:
    env = ["TOA5", station, logger, serial, f"{logger}.Std.32", program, "24006", rec.meta.get("table", "ts_data")]
    lines = [",".join(f'"{x}"' for x in env), ",".join(f'"{x}"' for x in TOA5_FIELDS),
             ",".join(f'"{x}"' for x in TOA5_UNITS), ",".join(f'"{x}"' for x in TOA5_PROCESSING)]
    cols = dict(rec.columns)
    cols["TIMESTAMP"] = np.char.add(np.char.add('"', campbell_timestamps(cols["TIMESTAMP"]).astype(str)), '"')
    body = pd.DataFrame(cols).to_csv(index=False, header=False, lineterminator="\n", na_rep="NAN",
                                     quoting=csv.QUOTE_NONE, quotechar="'")
    return "\n".join(lines) + "\n" + body.replace(",NAN", ',"NAN"')


def write_record(path: str | Path, rec: RawRecord, *, station: str = "P2OA", logger: str = "CR3000",
                 serial: str = "6843", program: str = "CPU:dronewind_sim.CR3") -> Path:
    """Print an in-memory record as its raw file (atomically; folders are created).

    Parameters
    ----------
    path : str or Path
        Output file.
    rec : RawRecord
        A record of :func:`payload_sonic_record`, :func:`ins_record` or :func:`toa5_record`
        (recognised by its columns).
    station, logger, serial, program : str
        TOA5 header line 1 fields (TOA5 records only; the table name is the record's
        ``meta["table"]``).

    Returns
    -------
    Path
    """
    path = Path(path)
    names = tuple(rec.columns)
    if names == TOA5_FIELDS:
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(path, _toa5_text(rec, station, logger, serial, program))
        return path
    if ",".join(names) == SONIC_HEADER:
        return _write_frame(path, SONIC_HEADER, pd.DataFrame(dict(rec.columns)))
    if ",".join(names) == INS_HEADER:
        cols = dict(rec.columns)
        cols["utc"] = np.where(cols["time_valid"] == 1, utc_strings(cols["utc"]), "")
        return _write_frame(path, INS_HEADER, pd.DataFrame(cols))
    raise ValueError(f"{rec.source}: columns {list(names)} are none of the simulator's raw formats")
