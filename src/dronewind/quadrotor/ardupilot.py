"""ArduPilot DataFlash logs (``format: ardupilot_bin``) as quadrotor records and as platform state.

The log is read by :func:`dronewind.core.dataflash.read_dataflash` (pymavlink's DataFlash
parser; attitude and set points, EKF velocity, position and wind, GPS time to UTC with the
leap seconds, barometer, parameters); here it gets the layout every quadrotor reader gives
(:func:`dronewind.quadrotor.io.read_quadrotor_csv`: sorted, de-duplicated, counted).

References
----------
.. [1] Wetz, T., Wildmann, N., Beyrich, F. (2021): Distributed wind measurements with
   multiple quadrotor unmanned aerial vehicles in the atmospheric boundary layer
   (SWUF-3D), Sect. 2 (the attitude, velocity and position a tilt-based wind needs).
"""

from __future__ import annotations

from pathlib import Path

import xarray as xr

from dronewind.core.dataflash import (
    GPS_UTC_LEAP_SECONDS,
    KEPT_PARAMETERS,
    LEAP_TABLE_VALID_UNTIL,
    gps_to_utc_ns,
    gps_utc_offset_s,
    read_dataflash,
    read_dataflash_messages,
)

__all__ = ["GPS_UTC_LEAP_SECONDS", "KEPT_PARAMETERS", "LEAP_TABLE_VALID_UNTIL", "gps_to_utc_ns", "gps_utc_offset_s",
           "read_dataflash_messages", "read_quadrotor_ardupilot"]


def read_quadrotor_ardupilot(path: str | Path, ekf_core: int = 0) -> xr.Dataset:
    """Read an ArduPilot DataFlash log into the quadrotor dataset.

    Parameters
    ----------
    path : str or Path
        DataFlash ``.bin`` file.
    ekf_core : int
        EKF core (``C``) whose velocity, position and wind are read (0: the first).

    Returns
    -------
    xarray.Dataset
        :func:`dronewind.core.dataflash.read_dataflash` sorted by time, duplicated stamps
        removed and counted, with ``sampling_rate_hz`` (as
        :func:`dronewind.quadrotor.io.read_quadrotor_csv`).

    Raises
    ------
    InputError
        Unreadable file, or no ``ATT`` message.
    """
    from dronewind.quadrotor.io import _finish, _sort_dedupe  # the layout every quadrotor reader shares

    ds = read_dataflash(path, ekf_core=ekf_core)
    log = str(ds.attrs["processing_log"]).split("\n")
    ds = _sort_dedupe(ds, log)
    return _finish(ds, Path(path), log)
