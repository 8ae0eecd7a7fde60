"""Column layouts of the payload's raw records (data contract), apart from their readers.

The raw-format checks that run at every Snakemake start (:mod:`dronewind.formats`) need the
column names and the rigid-mount layout check, not the readers, which import xarray and the
chain (a few tenths of a CPU-second at each start, i.e. once per job on a cluster). The
readers (:mod:`dronewind.payload.reader`, :mod:`dronewind.payload.rigid`) use these names.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from dronewind.core.delimited import DelimitedLayout, delimited_layout
from dronewind.errors import InputError

__all__ = ["SONIC_COLUMNS", "INS_COLUMNS", "RIGID_QUANTITIES", "rigid_layout"]

#: Columns of the payload sonic CSV (data contract).
SONIC_COLUMNS: tuple[str, ...] = ("rpi_time_us", "u_ms", "v_ms", "w_ms", "t_sonic_c")
#: Columns of the payload INS CSV (data contract).
INS_COLUMNS: tuple[str, ...] = (
    "rpi_time_us", "utc", "time_valid", "ekf_valid", "lat_deg", "lon_deg", "alt_m",
    "vel_n_ms", "vel_e_ms", "vel_d_ms", "roll_deg", "pitch_deg", "yaw_deg",
)  # fmt: skip

#: Variables of a rigid-mount record and the SI unit their declared unit must convert to.
RIGID_QUANTITIES: dict[str, str] = {
    "u": "m s-1", "v": "m s-1", "w": "m s-1", "t": "K", "diag": "1",
    "vel_e": "m s-1", "vel_n": "m s-1", "vel_u": "m s-1", "vel_d": "m s-1",
    "roll": "degree", "pitch": "degree", "yaw": "degree", "lat": "degree", "lon": "degree", "alt": "m",
}
_REQUIRED = ("u", "v", "w", "t", "roll", "pitch", "yaw", "lat", "lon", "alt")
_VELOCITY_SETS = (("vel_e", "vel_n", "vel_u"), ("vel_n", "vel_e", "vel_d"))


def rigid_layout(fmt: Mapping[str, Any], where: str = "record.format") -> DelimitedLayout:
    """The delimited layout of a rigid-mount record, its variables checked.

    Parameters
    ----------
    fmt : mapping
        The record's ``format`` (``name: delimited``; ``variables`` with u, v, w, t, roll,
        pitch, yaw, lat, lon, alt and either vel_e, vel_n, vel_u or vel_n, vel_e, vel_d).
    where : str
        Key path for messages.

    Returns
    -------
    DelimitedLayout

    Raises
    ------
    InputError
        Another format name, a variable missing, an incomplete velocity set, or a unit of
        the wrong quantity.
    """
    if fmt.get("name") != "delimited":
        raise InputError(f"{where}.name", f"{fmt.get('name')!r}; a rigid-mount record is read by a delimited mapping")
    layout = delimited_layout(fmt, where, RIGID_QUANTITIES)
    have = set(layout.variables)
    missing = [k for k in _REQUIRED if k not in have]
    if missing:
        raise InputError(f"{where}.variables", f"missing {', '.join(missing)}; a rigid-mount record needs "
                         f"{', '.join(_REQUIRED)} and a platform velocity")
    if not any(set(s) <= have for s in _VELOCITY_SETS):
        found = sorted(have & {k for s in _VELOCITY_SETS for k in s})
        raise InputError(f"{where}.variables", f"platform velocity incomplete (found {found}); "
                         "expected vel_e, vel_n, vel_u (east, north, up) or vel_n, vel_e, vel_d (north, east, down)")
    return layout
