"""Column layouts of the quadrotor's raw records (data contract), apart from their readers.

The raw-format checks that run at every Snakemake start (:mod:`dronewind.formats`) need the
column names, not the readers, which import xarray (a few tenths of a CPU-second at each
start, i.e. once per job on a cluster). :mod:`dronewind.quadrotor.io` re-exports these names.
"""

from __future__ import annotations

__all__ = ["QUADROTOR_COLUMNS", "REFERENCE_COLUMNS", "QUADROTOR_QUANTITIES", "DATAFLASH_MAGIC"]

#: Columns of the quadrotor CSV (data contract).
QUADROTOR_COLUMNS: tuple[str, ...] = (
    "time_utc", "roll_deg", "pitch_deg", "yaw_deg", "vel_n_ms", "vel_e_ms", "vel_d_ms",
    "lat_deg", "lon_deg", "alt_m",
)
#: Columns of the long-form tower reference CSV (data contract).
REFERENCE_COLUMNS: tuple[str, ...] = ("time_utc", "height_m", "wind_speed_ms", "wind_from_deg")
#: Variables of a delimited quadrotor record (:mod:`dronewind.quadrotor.delimited`) and the SI
#: unit their declared unit must convert to.
QUADROTOR_QUANTITIES: dict[str, str] = {
    "roll": "degree", "pitch": "degree", "yaw": "degree", "vel_n": "m s-1", "vel_e": "m s-1", "vel_d": "m s-1",
    "vel_u": "m s-1", "lat": "degree", "lon": "degree", "alt": "m", "ref_speed": "m s-1", "ref_from": "degree",
    "temperature": "K", "pressure": "Pa",
}
#: First bytes of every message of an ArduPilot DataFlash log (the first is an FMT, type 128).
DATAFLASH_MAGIC: bytes = b"\xa3\x95\x80"
