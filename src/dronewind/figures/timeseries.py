r"""Time series of the detailed flights, drone against mast (Ghirardelli et al. (2025), Figs 8 and 10).

Drawn from the stored L3 files (streamline velocities and sonic temperature of both
sensors on one time base) with heights, mean speeds and mean temperatures from L4. The
only arithmetic: the stored L4 mean temperature is subtracted from the stored L3 series.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

import numpy as np
import xarray as xr
from matplotlib.axes import Axes

from dronewind.core.products import drone_usable, load_l4_products, open_by_flight, stored_scalar
from dronewind.figures.style import (
    SENSOR_COLOURS,
    UNIT_MS,
    PathLike,
    add_notes,
    chosen_flights,
    legend,
    minutes,
    new_figure,
    no_data,
    save_figure,
    start_label,
    status_text,
)

__all__ = ["fig08_timeseries", "fig10_temperature_series"]


# ----------------------------------------------------------------------------- Fig. 8


def _velocity_title(flight: str, ds: xr.Dataset, prod: Mapping[str, xr.Dataset]) -> str:
    """Heights and mean speeds (L4) of both sensors, and the rotation method (L3)."""
    mast = prod.get("mast")
    z_mast, u_mast = stored_scalar(mast, "height_m"), stored_scalar(mast, "U_ms")
    z_drone, u_drone = stored_scalar(prod.get("drone"), "height_m"), stored_scalar(prod.get("drone"), "U_ms")
    return (f"{flight}: mast z = {z_mast:.0f} m, $\\bar u$ = {u_mast:.1f} {UNIT_MS}; "
            f"drone z = {z_drone:.1f} m, $\\bar u$ = {u_drone:.1f} {UNIT_MS}; rotation: "
            f"{ds.attrs.get('rotation_method', '?')}")


def _velocity_rows(axes: Sequence[Axes], flight: str, ds: xr.Dataset | None, prod: Mapping[str, xr.Dataset],
                   notes: list[str]) -> None:
    """Three panels (u, v, w) of one flight, drone and mast; the drone left out when unusable."""
    usable, reason = drone_usable(prod) if prod else (True, "")
    if ds is None:
        no_data(axes[1], f"{flight}: no L3 file")
        notes.append(f"{flight}: no L3 file.")
        for ax in (axes[0], axes[2]):
            ax.set_axis_off()
        return
    t = minutes(ds["time"].values)
    sensors = [str(s) for s in ds["sensor"].values]
    for ax, comp, name in zip(axes, ("u", "v", "w"), ("u_ms", "v_ms", "w_ms"), strict=True):
        for sensor, colour in SENSOR_COLOURS:
            if sensor not in sensors:
                continue
            if sensor == "drone" and not usable:
                continue
            ax.plot(t, ds[name].sel(sensor=sensor).values, color=colour, lw=0.6, label=sensor, rasterized=True)
        ax.set_ylabel(f"{comp} ({UNIT_MS})")
        ax.grid(alpha=0.3)
    title = _velocity_title(flight, ds, prod)
    if not usable:
        title += " — drone unusable, not drawn"
        notes.append(f"{flight}: drone record unusable ({reason or 'no reason'}); only the mast is drawn.")
    axes[0].set_title(title, fontsize=9, loc="left")
    legend(axes[0], fontsize=7, loc="upper right", ncol=2)
    axes[2].set_xlabel(f"time since {start_label(ds['time'].values)} UTC (min)")


def fig08_timeseries(l3_files: Iterable[PathLike], l4_files: Iterable[PathLike], out_stem: PathLike,
                     flights: Sequence[str] | None = None) -> list[Path]:
    r"""Fig. 8: streamwise, cross-wind and vertical velocity, drone vs mast, for chosen flights.

    Parameters
    ----------
    l3_files : iterable of path
        L3 files (``u_ms``, ``v_ms``, ``w_ms`` over ``sensor`` and ``time``).
    l4_files : iterable of path
        L4 files (``U_ms`` and ``height_m`` for the panel titles).
    out_stem : str or Path
        Output path without suffix.
    flights : sequence of str, optional
        Flights to draw (default: first and seventh, see
        :func:`dronewind.tables.default_detail_flights`).

    Returns
    -------
    list of Path
        PNG and PDF.
    """
    l3 = open_by_flight(l3_files)
    l4 = load_l4_products(l4_files)
    chosen = chosen_flights(flights, list(l3))
    nrow = 3 * max(1, len(chosen))
    fig = new_figure(10.0, 1.55 * nrow + 0.6)
    axes = np.atleast_1d(fig.subplots(nrow, 1, sharex=False))
    notes: list[str] = []
    if not chosen:
        no_data(axes[0], "no L3 files")
    for k, flight in enumerate(chosen):
        _velocity_rows(list(axes[3 * k: 3 * k + 3]), flight, l3.get(flight), l4.get(flight, {}), notes)
    return save_figure(fig, out_stem, add_notes(fig, notes))


# ----------------------------------------------------------------------------- Fig. 10


def _temperature_panel(ax: Axes, flight: str, ds: xr.Dataset | None, prod: Mapping[str, xr.Dataset],
                       notes: list[str]) -> None:
    r"""One flight: :math:`\theta_v - \bar\theta_v` of drone and mast with the stored means."""
    if ds is None:
        no_data(ax, f"{flight}: no L3 file")
        notes.append(f"{flight}: no L3 file.")
        return
    usable, reason = drone_usable(prod) if prod else (True, "")
    t = minutes(ds["time"].values)
    for sensor, colour in SENSOR_COLOURS:
        if sensor == "drone" and not usable:
            notes.append(f"{flight}: drone record unusable ({reason or 'no reason'}); only the mast is drawn.")
            continue
        mean = stored_scalar(prod.get(sensor), "theta_v_mean_k")
        if not np.isfinite(mean):
            notes.append(f"{flight} {sensor}: mean sonic temperature NaN "
                         f"({status_text(prod.get(sensor), 'temperature')}); not drawn.")
            continue
        ax.plot(t, ds["theta_v_k"].sel(sensor=sensor).values - mean, color=colour, lw=0.6, rasterized=True,
                label=f"{sensor} ($\\bar\\theta_v$ = {mean:.2f} K, "
                      f"z = {stored_scalar(prod.get(sensor), 'height_m'):.0f} m)")
    ax.set_title(flight, fontsize=9, loc="left")
    ax.set_xlabel(f"time since {start_label(ds['time'].values)} UTC (min)")
    ax.set_ylabel("$\\theta_v'$ (K)")
    ax.grid(alpha=0.3)
    legend(ax, fontsize=7, loc="upper right")


def fig10_temperature_series(l3_files: Iterable[PathLike], l4_files: Iterable[PathLike], out_stem: PathLike,
                             flights: Sequence[str] | None = None) -> list[Path]:
    r"""Fig. 10: sonic temperature fluctuations :math:`\theta_v'`, drone vs mast, for chosen flights.

    Parameters
    ----------
    l3_files : iterable of path
        L3 files (``theta_v_k`` over ``sensor`` and ``time``).
    l4_files : iterable of path
        L4 files (``theta_v_mean_k`` and ``height_m``).
    out_stem : str or Path
        Output path without suffix.
    flights : sequence of str, optional
        Flights to draw (default: first and seventh).

    Returns
    -------
    list of Path
        PNG and PDF.

    Notes
    -----
    :math:`\theta_v' = \theta_v - \bar\theta_v` with the stored L4 mean of each sensor
    (the L4 statistics themselves use linearly detrended series).
    """
    l3 = open_by_flight(l3_files)
    l4 = load_l4_products(l4_files)
    chosen = chosen_flights(flights, list(l3))
    ncol = max(1, len(chosen))
    fig = new_figure(5.2 * ncol, 3.6)
    axes = np.atleast_1d(fig.subplots(1, ncol))
    notes: list[str] = []
    if not chosen:
        no_data(axes[0], "no L3 files")
    for ax, flight in zip(axes, chosen, strict=False):
        _temperature_panel(ax, flight, l3.get(flight), l4.get(flight, {}), notes)
    return save_figure(fig, out_stem, add_notes(fig, notes))
