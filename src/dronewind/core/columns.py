"""Column layouts of the payload's raw records (data contract), apart from their readers.

The raw-format checks that run at every Snakemake start (:mod:`dronewind.formats`) need the
column names and the rigid-mount layout check, not the readers, which import xarray and the
chain (a few tenths of a CPU-second at each start, i.e. once per job on a cluster). The
readers (:mod:`dronewind.payload.reader`, :mod:`dronewind.payload.rigid`) use these names.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from typing import Any

from dronewind.core.delimited import DelimitedLayout, delimited_layout
from dronewind.errors import InputError

__all__ = ["SONIC_COLUMNS", "INS_COLUMNS", "RIGID_QUANTITIES", "PLATFORM_FROM_LOG", "log_platform_variables",
           "rigid_layout"]

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
_SONIC_REQUIRED = ("u", "v", "w", "t")
_ATTITUDE_POSITION = ("roll", "pitch", "yaw", "lat", "lon", "alt")
_REQUIRED = _SONIC_REQUIRED + _ATTITUDE_POSITION
_VELOCITY_SETS = (("vel_e", "vel_n", "vel_u"), ("vel_n", "vel_e", "vel_d"))
_VELOCITY = ("vel_e", "vel_n", "vel_u", "vel_d")

#: Platform variables of the project (the L1 names) that a vehicle's log can give, by the
#: record variables that would give them instead.
PLATFORM_FROM_LOG: dict[str, tuple[str, ...]] = {
    "roll_deg": ("roll",), "pitch_deg": ("pitch",), "yaw_deg": ("yaw",), "lat_deg": ("lat",), "lon_deg": ("lon",),
    "alt_m": ("alt",), "vel_n_ms": _VELOCITY, "vel_e_ms": _VELOCITY, "vel_d_ms": _VELOCITY}


def log_platform_variables(declared: Collection[str]) -> tuple[str, ...]:
    """Platform variables a rigid-mount flight takes from its ``platform_log``: those its record lacks.

    The record's columns win: a platform variable declared in the record's mapping is read
    from the record; the velocity is taken whole (all three components) from one source.

    Parameters
    ----------
    declared : collection of str
        Variables of the record's ``delimited`` mapping (``u``, ..., ``roll``, ``vel_e``, ...).

    Returns
    -------
    tuple of str
        L1 names (``roll_deg``, ..., ``vel_d_ms``) read from the log, in the order of
        :data:`PLATFORM_FROM_LOG`.
    """
    have = set(declared)
    return tuple(name for name, keys in PLATFORM_FROM_LOG.items() if not have & set(keys))


def rigid_layout(fmt: Mapping[str, Any], where: str = "record.format", *,
                 platform_log: bool | None = False) -> DelimitedLayout:
    """The delimited layout of a rigid-mount record, its variables checked.

    Parameters
    ----------
    fmt : mapping
        The record's ``format`` (``name: delimited``; ``variables`` with u, v, w, t and,
        unless a platform log gives them, roll, pitch, yaw, lat, lon, alt and either vel_e,
        vel_n, vel_u or vel_n, vel_e, vel_d).
    where : str
        Key path for messages.
    platform_log : bool or None
        The flight declares a ``platform_log``: the platform variables are optional (those
        absent come from the log, :func:`log_platform_variables`), a velocity must still be
        complete or absent, and a mapping declaring every platform variable is an error (the
        log would give nothing). None: the platform variables are not checked (a check of
        the file's head against the mapping only).

    Returns
    -------
    DelimitedLayout

    Raises
    ------
    InputError
        Another format name, a variable missing, an incomplete velocity set, a unit of the
        wrong quantity, or a platform log that would give nothing.
    """
    if fmt.get("name") != "delimited":
        raise InputError(f"{where}.name", f"{fmt.get('name')!r}; a rigid-mount record is read by a delimited mapping")
    layout = delimited_layout(fmt, where, RIGID_QUANTITIES)
    have = set(layout.variables)
    required = _REQUIRED if platform_log is False else _SONIC_REQUIRED
    missing = [k for k in required if k not in have]
    if missing:
        raise InputError(f"{where}.variables", f"missing {', '.join(missing)}; a rigid-mount record needs "
                         f"{', '.join(required)}" + (" and a platform velocity, or a platform_log (the vehicle's own "
                                                     "log) that gives the platform variables the record lacks"
                                                     if platform_log is False else ""))
    velocity = have & set(_VELOCITY)
    complete = any(set(s) <= have for s in _VELOCITY_SETS)
    if not complete and (platform_log is False or velocity):
        raise InputError(f"{where}.variables", f"platform velocity incomplete (found {sorted(velocity)}); "
                         "expected vel_e, vel_n, vel_u (east, north, up) or vel_n, vel_e, vel_d (north, east, down)"
                         + (", or none of them (the velocity from the platform_log)" if platform_log else ""))
    if platform_log and not log_platform_variables(have):
        raise InputError(f"{where}.variables", "every platform variable (roll, pitch, yaw, lat, lon, alt, velocity) "
                         "is a column of the record, so the platform_log would give nothing (the record's columns "
                         "win); remove the platform_log or the platform columns the log should give")
    return layout
