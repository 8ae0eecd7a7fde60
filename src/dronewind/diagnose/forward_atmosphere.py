"""The measured atmosphere of the forward runs: the reference mast's record over a flight.

With ``diagnosis.atmosphere: measured`` the forward runs take the turbulence both sensors
share from the reference mast as measured: its L1 record over the flight and a margin
(:func:`atmosphere_record`, :func:`atmosphere_window`) constrains the simulated field at the
mast sonic (:func:`dronewind.simulate.payload_wind.measured_constraint`). A mechanism acting
on the mast's record (:data:`RECORD_INVERSES`) is probed by undoing it on the record
(:func:`record_through`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from dronewind.manifest import parse_utc

__all__ = [
    "RECORD_INVERSES",
    "atmosphere_record",
    "record_through",
    "hover_span",
    "atmosphere_window",
    "ATMOSPHERE_VARIABLES",
]


def _undo_mast_w_attenuation(record: xr.Dataset, parameters: Mapping[str, float]) -> xr.Dataset:
    """The measured mast record with ``mast_w_attenuation`` undone: w divided by the gain."""
    out = record.copy()
    out["w_up_ms"] = record["w_up_ms"] / float(parameters["gain"])
    return out


#: Mechanisms acting on the reference mast's record, and how each is undone on a measured
#: record to give the true wind at the mast (:func:`probe_runs` with a measured atmosphere).
RECORD_INVERSES: dict[str, Callable[[xr.Dataset, Mapping[str, float]], xr.Dataset]] = {
    "mast_w_attenuation": _undo_mast_w_attenuation,
}


def record_through(record: xr.Dataset, mechanisms: Sequence[Mapping[str, Any]]) -> xr.Dataset:
    """The measured atmosphere record read through the mechanisms that act on it.

    Parameters
    ----------
    record : xarray.Dataset
        :func:`atmosphere_record` output.
    mechanisms : sequence of mapping
        ``[{"mechanism": name, "parameters": {...}}]`` (e.g. the named causes of an extended
        model).

    Returns
    -------
    xarray.Dataset
        The record with each mechanism of :data:`RECORD_INVERSES` undone (the true wind the
        mast would have measured without it); the record itself when none acts on it.
    """
    for m in mechanisms:
        if m["mechanism"] in RECORD_INVERSES:
            record = RECORD_INVERSES[m["mechanism"]](record, m["parameters"])
    return record


#: Variables of the reference mast's record that the forward runs' atmosphere takes (the
#: temperature optional).
ATMOSPHERE_VARIABLES: tuple[str, ...] = ("u_east_ms", "v_north_ms", "w_up_ms", "t_sonic_k")


#: Margin kept around the hover window when the measured record is cut (:func:`atmosphere_record`) [s].
ATMOSPHERE_MARGIN_S = 3600.0


def hover_span(conditions: Mapping[str, Any]) -> tuple[np.datetime64, np.datetime64]:
    """Start and end of a flight's measured hover window (``start``, ``duration_s`` of :func:`forward_conditions`).

    Returns
    -------
    tuple of numpy.datetime64
        UTC, microsecond resolution.
    """
    start = parse_utc(str(conditions["start"]), "conditions.start")
    return start, start + np.timedelta64(int(round(float(conditions["duration_s"]) * 1e6)), "us")


def atmosphere_window(conditions: Mapping[str, Any]) -> slice:
    """The times of the reference mast's record that :func:`atmosphere_record` keeps: the hover
    window and :data:`ATMOSPHERE_MARGIN_S` on either side (a ``slice`` of datetime64)."""
    start, end = hover_span(conditions)
    margin = np.timedelta64(int(ATMOSPHERE_MARGIN_S * 1e6), "us")
    return slice(start - margin, end + margin)


def atmosphere_record(mast: xr.Dataset, conditions: Mapping[str, Any], where: str = "mast record") -> xr.Dataset:
    """The reference mast's measured record of one flight, as the forward runs' atmosphere.

    Parameters
    ----------
    mast : xarray.Dataset
        The reference sonic's L1 (or L2): ``u_east_ms``, ``v_north_ms``, ``w_up_ms`` and
        optionally ``t_sonic_k`` on a datetime64 ``time`` axis.
    conditions : mapping
        The flight's forward conditions (:func:`forward_conditions`: ``start``,
        ``duration_s``).
    where : str
        Name of the record in errors (its file).

    Returns
    -------
    xarray.Dataset
        Those variables within :data:`ATMOSPHERE_MARGIN_S` of the hover window (a shorter
        record is cut again by the simulator, which mirrors it where the forward flight's
        span reaches beyond it, :func:`dronewind.simulate.payload_wind.measured_constraint`),
        with attributes ``noise_ms`` and ``temperature_noise_k``: the white noise of the
        forward model's CSAT3 (``simulation.mast`` defaults), which the record holds and
        the forward mast does not add again (:func:`forward_manifest`).

    Raises
    ------
    InputError
        Variables or the time axis missing.
    """
    from dronewind.simulate.defaults import MAST_DEFAULTS
    from dronewind.simulate.payload_wind import check_atmosphere_record

    check_atmosphere_record(mast, where)
    names = [v for v in ATMOSPHERE_VARIABLES if v in mast]

    cut = mast[names].sel(time=atmosphere_window(conditions))
    cut = cut.drop_vars([c for c in cut.coords if c != "time"])
    cut.attrs = {"noise_ms": MAST_DEFAULTS["noise_ms"][0],
                 "temperature_noise_k": MAST_DEFAULTS["temperature_noise_k"][0]}
    return cut
