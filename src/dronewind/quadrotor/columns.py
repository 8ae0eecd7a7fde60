"""Column layouts of the quadrotor's raw records (data contract), apart from their readers.

The raw-format checks that run at every Snakemake start (:mod:`dronewind.formats`) need the
column names, not the readers, which import xarray (a few tenths of a CPU-second at each
start, i.e. once per job on a cluster). :mod:`dronewind.quadrotor.io` re-exports these names.
"""

from __future__ import annotations

__all__ = ["QUADROTOR_COLUMNS", "REFERENCE_COLUMNS"]

#: Columns of the quadrotor CSV (data contract).
QUADROTOR_COLUMNS: tuple[str, ...] = (
    "time_utc", "roll_deg", "pitch_deg", "yaw_deg", "vel_n_ms", "vel_e_ms", "vel_d_ms",
    "lat_deg", "lon_deg", "alt_m",
)
#: Columns of the long-form tower reference CSV (data contract).
REFERENCE_COLUMNS: tuple[str, ...] = ("time_utc", "height_m", "wind_speed_ms", "wind_from_deg")
