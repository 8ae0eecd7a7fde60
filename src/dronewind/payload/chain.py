"""The payload chain, datasets in and datasets out: raw sonic and INS files to L1, L1 to L2.

The workflow steps (:mod:`dronewind.steps.payload`) wrap these functions in file input and
output; the diagnosis runs them in-process on forward-model flights
(:mod:`dronewind.diagnose.forward`), so a measured and a simulated flight go through
identical code. Settings come in explicitly, as the sub-mappings of the workflow
configuration (``processing.despike``, ``processing.hover``, ...); their defaults live once,
in the configuration schema (:func:`dronewind.manifest.default_config`).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from dronewind.core.raw import RawRecord
from dronewind.manifest import parse_utc
from dronewind.payload import l2
from dronewind.payload.ins import InsTable, ins_l1, load_ins_table
from dronewind.payload.sonic import payload_sonic_l1

__all__ = ["flight_window", "compute_ins_l1", "compute_sonic_l1", "compute_payload_l1", "compute_payload_l2"]


def flight_window(flight: Mapping[str, Any]) -> tuple[np.datetime64, np.datetime64] | None:
    """The hover window a manifest flight declares, or ``None`` (the chain then finds it).

    Parameters
    ----------
    flight : mapping
        Payload flight entry of the manifest (optional ``window: {start, end}``, UTC).

    Returns
    -------
    tuple of numpy.datetime64 or None
        Start and end.
    """
    window = flight.get("window")
    if not window:
        return None
    return parse_utc(window["start"]), parse_utc(window["end"])


def compute_ins_l1(ins_file: str | Path | RawRecord) -> tuple[InsTable, xr.Dataset]:
    """The parsed INS (with the logger-clock fit) and the INS L1 of one flight.

    Parameters
    ----------
    ins_file : str, Path or RawRecord
        Raw INS CSV file, or its in-memory record (:mod:`dronewind.core.raw`).

    Returns
    -------
    table : dronewind.payload.ins.InsTable
        Parsed rows and the clock fit (for :func:`compute_sonic_l1`).
    ins : xarray.Dataset
        L1 INS.
    """
    table = load_ins_table(ins_file)
    return table, ins_l1(ins_file, ins_table=table)


def compute_sonic_l1(sonic_file: str | Path | RawRecord, ins_file: str | Path | RawRecord,
                     ins_table: InsTable, despike: Mapping[str, Any]) -> xr.Dataset:
    """Payload sonic L1: the logger clock to UTC through the INS's clock fit, QC and despiking.

    Parameters
    ----------
    sonic_file, ins_file : str, Path or RawRecord
        Raw payload sonic and INS CSV files of one flight, or their in-memory records.
    ins_table : dronewind.payload.ins.InsTable
        The parsed INS of :func:`compute_ins_l1`.
    despike : mapping
        ``processing.despike``: ``window_s`` [s] and ``n_mad`` of the moving-MAD despiking.

    Returns
    -------
    xarray.Dataset
        L1 payload sonic (sensor frame, UTC).
    """
    return payload_sonic_l1(
        sonic_file, ins_file, despike_window_s=float(despike["window_s"]),
        despike_n_mad=float(despike["n_mad"]), ins_table=ins_table,
    )


def compute_payload_l1(
    sonic_file: str | Path | RawRecord, ins_file: str | Path | RawRecord, despike: Mapping[str, Any]
) -> tuple[xr.Dataset, xr.Dataset]:
    """Payload sonic and INS L1 datasets (library names; :mod:`dronewind.payload.ins`, :mod:`dronewind.payload.sonic`).

    The INS file is parsed once, for the logger-clock fit and for the INS L1 (Ghirardelli et al. (2025),
    Sect. 3.2): :func:`compute_ins_l1`, then :func:`compute_sonic_l1`.

    Parameters
    ----------
    sonic_file, ins_file : str, Path or RawRecord
        Raw payload sonic and INS CSV files of one flight, or their in-memory records
        (:mod:`dronewind.core.raw`).
    despike : mapping
        ``processing.despike``: ``window_s`` [s] and ``n_mad`` of the moving-MAD despiking.

    Returns
    -------
    sonic, ins : xarray.Dataset
        L1 payload sonic (sensor frame, UTC) and L1 INS.
    """
    table, ins = compute_ins_l1(ins_file)
    return compute_sonic_l1(sonic_file, ins_file, table, despike), ins


def _target_height(flight: Mapping[str, Any]) -> float | None:
    """The flight's target height above ground [m], or None when the manifest gives none."""
    value = flight.get("target_height_m")
    return None if value is None else float(value)


def compute_payload_l2(
    sonic: xr.Dataset,
    ins: xr.Dataset,
    flight: Mapping[str, Any],
    site_altitude_m: float,
    *,
    sonic_ins_lag: Mapping[str, Any],
    hover: Mapping[str, Any],
    max_missing_fraction: float,
    lag_only: bool = False,
    lag_halves: bool = False,
) -> xr.Dataset:
    """Payload L2: hover window, sonic-INS lag, motion correction (see :func:`dronewind.payload.l2.payload_l2`).

    Parameters
    ----------
    sonic, ins : xarray.Dataset
        L1 payload sonic and INS (library names).
    flight : mapping
        Payload flight entry of the manifest (``sonic.mount``, optional ``window`` and
        ``target_height_m``).
    site_altitude_m : float
        Ground altitude of the site above mean sea level [m].
    sonic_ins_lag : mapping
        ``processing.sonic_ins_lag``: ``max_lag_s`` and ``step_s`` of the lag search [s]
        (Ghirardelli et al. (2025), Sect. 3.3).
    hover : mapping
        ``processing.hover``: ``alt_tol_m``, ``horiz_tol_m`` [m] and ``min_duration_s`` [s]
        of the hover window (Ghirardelli et al. (2025), Sect. 3.2).
    max_missing_fraction : float
        ``processing.max_missing_fraction``: most missing data that are gap-filled [1].
    lag_only : bool
        Stop after the sonic-INS lag search: a dataset without variables whose attributes
        hold the lag (``lag_sonic_ins_s``, ``lag_tke_min_s``) and the reasons found so far
        (for the lags of the hover's halves, :func:`dronewind.diagnose.forward.lag_halves`).
    lag_halves : bool
        Also find the lag on each half of the hover window (attrs ``lag_first_half_s``,
        ``lag_second_half_s``; :func:`dronewind.payload.l2.payload_l2`).

    Returns
    -------
    xarray.Dataset
        L2 drone wind in east/north/up with the flight's ``target_height_m`` attribute. The
        hover height is checked against ``target_height_m``, the INS velocity against the
        GNSS position and the sonic against its range (:mod:`dronewind.payload.checks`); a
        failed check sets ``usable = 0`` with the reason.
    """
    ds = l2.payload_l2(
        sonic, ins, mount=flight["sonic"].get("mount", "upside_down"),
        max_lag_s=float(sonic_ins_lag["max_lag_s"]), lag_step_s=float(sonic_ins_lag["step_s"]),
        window=flight_window(flight), max_missing_fraction=float(max_missing_fraction),
        min_hover_s=float(hover["min_duration_s"]),
        hover_alt_tol_m=float(hover["alt_tol_m"]), hover_horiz_tol_m=float(hover["horiz_tol_m"]),
        site_altitude_m=float(site_altitude_m), target_height_m=_target_height(flight), flight_id=str(flight["id"]),
        lag_only=lag_only, lag_halves=lag_halves,
    )
    ds.attrs["target_height_m"] = float(flight.get("target_height_m", float("nan")))
    return ds
