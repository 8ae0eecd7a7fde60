"""Autopilot flights: a multicopter's tilt-based wind against its autopilot's own EKF wind; files in, files out.

A measured campaign's ``autopilot_flights`` (docs/manifest.md) name autopilot logs
(``format: ardupilot_bin``, :mod:`dronewind.quadrotor.ardupilot`) with no anemometer to
compare with; the EKF wind the autopilot logs is the reference
(:mod:`dronewind.quadrotor.ekf_wind`). Steps (``R = results/<name>``):

* :func:`autopilot_wind` (one job per flight): ``R/netcdf/L3/autopilot/<flight>.nc`` (1-s
  tilt wind from the attitude and from the set points, EKF wind, air density, height) and
  ``R/netcdf/L4/autopilot/<flight>.nc`` (bias, RMSE, correlation of each tilt wind against
  the EKF's);
* :func:`autopilot_summary` (campaign): ``R/tables/autopilot_ekf_wind.csv`` (the L4 rows of
  every flight) and one figure per flight, ``R/figures/autopilot_ekf_wind_<flight>.png``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import pandas as pd
import xarray as xr

from dronewind.core.cf import atomic_write_text, data_source, write_netcdf
from dronewind.quadrotor.drag import DragLaw
from dronewind.quadrotor.ekf_wind import COMPARISON_COLUMNS, compare_with_ekf, tilt_and_ekf_wind
from dronewind.quadrotor.io import read_quadrotor
from dronewind.steps.common import LOG, open_product

__all__ = ["autopilot_wind", "autopilot_summary"]


def autopilot_wind(campaign: str, flight: Mapping[str, Any], raw_file: str | Path, site: Mapping[str, Any],
                   out_l3: str | Path, out_l4: str | Path, *, simulated: bool = False) -> list[Path]:
    """L3 and L4 of one autopilot flight: tilt wind and EKF wind side by side, and their statistics.

    Parameters
    ----------
    campaign : str
        Campaign name.
    flight : mapping
        The flight's manifest entry: ``id``, ``file``, ``format`` (a name or a mapping with
        ``name`` and ``ekf_core``), optional ``aero`` (:class:`dronewind.quadrotor.drag.DragLaw`
        fields), ``segment`` (:func:`dronewind.quadrotor.ekf_wind.airborne_segment` settings),
        ``density`` (``logged`` or ``law``), ``average_s``.
    raw_file : str or Path
        The log.
    site : mapping
        The manifest's ``site``.
    out_l3, out_l4 : str or Path
        NetCDF files to write.
    simulated : bool
        The campaign is virtual (stated in ``source``).

    Returns
    -------
    list of Path
        The written files.
    """
    flight_id = str(flight["id"])
    log = read_quadrotor(raw_file, flight.get("format"))
    law = DragLaw.from_dict(flight.get("aero"))
    l3 = tilt_and_ekf_wind(log, law=law, average_s=float(flight.get("average_s", 1.0)),
                           density=str(flight.get("density", "logged")), segment=flight.get("segment"),
                           where=f"autopilot flight {flight_id}")
    stats = compare_with_ekf(l3, flight_id)
    LOG.info("autopilot flight %s: %s; %s", flight_id, log.attrs.get("processing_log", "").replace("\n", "; "),
             l3.attrs["processing_log"].replace("\n", "; "))
    for _, row in stats.iterrows():
        LOG.info("autopilot flight %s, %s: speed bias %+.3f m/s, RMSE %.3f m/s, direction bias %+.1f deg (n = %d)",
                 flight_id, row["source"], row["speed_bias_ms"], row["speed_rmse_ms"], row["direction_bias_deg"],
                 row["n_blocks"])
    lat = float(log["lat_deg"].median()) if log["lat_deg"].notnull().any() else float(site["latitude"])
    lon = float(log["lon_deg"].median()) if log["lon_deg"].notnull().any() else float(site["longitude"])
    extra = {"campaign": campaign, "flight": flight_id, "source": data_source(simulated),
             "utc_valid": int(log.attrs.get("utc_valid", 0)), "ekf": str(log.attrs.get("ekf", "")),
             "reader_log": str(log.attrs.get("processing_log", ""))}
    common: dict[str, Any] = {"history": f"autopilot_wind {flight_id}", "inputs": [raw_file],
                              "config": {k: flight.get(k) for k in ("aero", "segment", "density", "average_s")},
                              "latitude": lat, "longitude": lon}
    p3 = write_netcdf(
        l3, out_l3, title=f"{campaign} flight {flight_id}: tilt-based wind and the autopilot's EKF wind, L3",
        summary="1-s block means over the slow airborne part of the flight: wind from the tilt of the airframe "
                "(attitude and the controller's set points) by the drag balance of Wetz et al. (2021), and the "
                "wind the autopilot's EKF estimates, with the air density from the logged pressure and temperature.",
        processing_level="L3: aligned 1-s blocks", station_id=flight_id, extra_attrs=extra, **common)
    l4 = xr.Dataset.from_dataframe(stats.drop(columns=["flight"]).set_index("source"))
    for name in l4.data_vars:
        l4[name].attrs["long_name"] = str(name).replace("_", " ")
        l4[name].attrs["units"] = ("m s-1" if str(name).endswith("_ms") else "degree" if str(name).endswith("_deg")
                                   else "kg m-3" if str(name).endswith("_kgm3") else "s" if str(name).endswith("_s")
                                   else "1")
    p4 = write_netcdf(
        l4, out_l4, title=f"{campaign} flight {flight_id}: tilt-based wind against the EKF wind, L4",
        summary="Bias (tilt minus EKF), RMSE and correlation of speed, components and direction of the tilt "
                "winds (attitude, set points) against the autopilot's EKF wind estimate.",
        processing_level="L4: statistics", feature_type=None, extra_attrs=extra, **common)
    return [p3, p4]


def autopilot_summary(l3_files: Sequence[str | Path], l4_files: Sequence[str | Path], out_table: str | Path,
                      out_figures: Sequence[str | Path]) -> list[Path]:
    """The comparison table of every autopilot flight and one figure per flight.

    Parameters
    ----------
    l3_files, l4_files : sequence of str or Path
        :func:`autopilot_wind` outputs, one of each per flight (same order).
    out_table : str or Path
        CSV of the L4 rows (:data:`dronewind.quadrotor.ekf_wind.COMPARISON_COLUMNS`).
    out_figures : sequence of str or Path
        One PNG per flight (same order).

    Returns
    -------
    list of Path
        The table and the figures.
    """
    from dronewind.figures.autopilot import ekf_wind_figure

    rows, written = [], []
    for l3_file, l4_file, fig in zip(l3_files, l4_files, out_figures, strict=True):
        l3 = open_product(l3_file)
        flight = str(l3.attrs.get("flight", Path(l3_file).stem))
        stats = open_product(l4_file).to_dataframe().reset_index()
        stats.insert(0, "flight", flight)
        stats = stats[list(COMPARISON_COLUMNS)]
        rows.append(stats)
        written.append(ekf_wind_figure(l3, stats, fig, flight))
    table = pd.concat(rows, ignore_index=True) if rows else pd.DataFrame(columns=list(COMPARISON_COLUMNS))
    atomic_write_text(out_table, table.to_csv(index=False))
    return [Path(out_table), *written]
