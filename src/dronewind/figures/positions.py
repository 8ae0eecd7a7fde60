r"""Payload positions: height above ground over time and track around the mast (Ghirardelli et al. (2025), Fig. 7).

Drawn from the stored L2 drone files (GNSS ``altitude``, ``precise_lat``/``precise_lon``
on ``time``; nominal ``lat``/``lon``), the mast L4 files (``U_ms``, ``wind_from_deg`` for
the wind arrows) and ``campaign.json`` (site altitude, mast positions, sonic heights and
azimuths). Presentation-only arithmetic: height = GNSS altitude - site altitude,
latitude/longitude to metres east/north of the mast with the one local tangent-plane
projection (:func:`dronewind.core.geo.local_tangent_plane_m`), and the stored wind
direction turned into an arrow.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from dronewind.core.geo import local_tangent_plane_m
from dronewind.core.products import L4Products, load_l4_products, open_by_flight, stored_scalar
from dronewind.figures.style import (
    UNIT_MS,
    UNUSABLE_COLOUR,
    PathLike,
    add_notes,
    flight_colours,
    minutes,
    new_figure,
    no_data,
    save_figure,
)

__all__ = ["fig07_positions"]


class _Arrow(NamedTuple):
    """A wind arrow: start east/north of the mast [m], wind vector [m s-1], colour, speed [m s-1], from [deg]."""

    east_m: float
    north_m: float
    u_ms: float
    v_ms: float
    colour: Any
    speed_ms: float
    from_deg: float
    flight: str


class _LineStyle(NamedTuple):
    colour: Any
    ls: str
    label: str


# ----------------------------------------------------------------------------- campaign record


def _campaign_content(campaign_json: PathLike) -> dict[str, Any]:
    """The manifest content recorded in ``campaign.json`` (the record itself if it holds none)."""
    record = json.loads(Path(campaign_json).read_text("utf-8"))
    return record.get("manifest_content", record)


def _sonics(content: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    """Mast sonics by id, each with its mast id and the mast's (else the site's) latitude/longitude."""
    out = {}
    for mast in content.get("masts") or []:
        for sonic in mast.get("sonics") or []:
            out[sonic["id"]] = {**sonic, "mast_id": mast["id"],
                                "latitude": mast.get("latitude", content["site"]["latitude"]),
                                "longitude": mast.get("longitude", content["site"]["longitude"])}
    return out


def _mast_origin(content: Mapping[str, Any], sonics: Mapping[str, Mapping[str, Any]],
                 notes: list[str]) -> tuple[float, float]:
    """Latitude and longitude of the origin: the first mast (the site without masts) [degrees]."""
    refs = {f["id"]: f.get("reference") for f in content.get("payload_flights") or []}
    mast_ids = {sonics[r]["mast_id"] for r in refs.values() if r in sonics}
    first = next(iter(sonics.values()), None)
    lat0 = float(first["latitude"]) if first else float(content["site"]["latitude"])
    lon0 = float(first["longitude"]) if first else float(content["site"]["longitude"])
    if len(mast_ids) > 1 and first is not None:
        notes.append(f"several masts ({', '.join(sorted(mast_ids))}); positions relative to {first['mast_id']}.")
    return lat0, lon0


# ----------------------------------------------------------------------------- one flight


def _line_style(flight: str, ds: xr.Dataset, colour: Any, notes: list[str]) -> _LineStyle:
    """Flight colour, solid, for a usable record; grey, dashed and noted otherwise."""
    if bool(int(ds.attrs.get("usable", 1))):
        return _LineStyle(colour, "-", flight)
    notes.append(f"{flight}: drone record unusable ({ds.attrs.get('unusable_reason', '') or 'no reason'}); "
                 "drawn grey, dashed.")
    return _LineStyle(UNUSABLE_COLOUR, "--", f"{flight} (unusable)")


def _height_series(ax: Axes, flight: str, ds: xr.Dataset, site_altitude_m: float, style: _LineStyle,
                   notes: list[str]) -> None:
    """Height above ground (GNSS altitude - site altitude) against minutes since the start."""
    if "altitude" not in ds.variables:
        notes.append(f"{flight}: no GNSS altitude stored.")
        return
    ax.plot(minutes(ds["time"].values), np.asarray(ds["altitude"].values) - site_altitude_m, color=style.colour,
            ls=style.ls, lw=1.0, label=style.label, rasterized=True)


def _track(ax: Axes, flight: str, ds: xr.Dataset, origin: tuple[float, float], style: _LineStyle,
           notes: list[str]) -> float | None:
    """The GNSS track east/north of the mast; return its largest offset [m] (None without a track)."""
    if "precise_lat" not in ds.variables or "precise_lon" not in ds.variables:
        notes.append(f"{flight}: no GNSS track stored.")
        return None
    e, n = local_tangent_plane_m(ds["precise_lat"].values, ds["precise_lon"].values, *origin)
    ax.plot(e, n, color=style.colour, ls=style.ls, lw=0.6, alpha=0.8, rasterized=True)
    return float(np.nanmax(np.abs(np.concatenate([e, n]))))


def _wind_arrow(ax: Axes, flight: str, ds: xr.Dataset, origin: tuple[float, float], mast: xr.Dataset | None,
                colour: Any, notes: list[str]) -> _Arrow | None:
    """Mark the nominal position; the arrow of the mast's stored wind from there (None if not stored)."""
    if "lat" not in ds.variables or "lon" not in ds.variables:
        return None
    e0, n0 = local_tangent_plane_m(np.array(float(ds["lat"])), np.array(float(ds["lon"])), *origin)
    speed, wfrom = stored_scalar(mast, "U_ms"), stored_scalar(mast, "wind_from_deg")
    ax.plot(e0, n0, marker="o", ms=4, color=colour)
    if np.isfinite(speed) and np.isfinite(wfrom) and speed > 0:
        return _Arrow(float(e0), float(n0), -speed * math.sin(math.radians(wfrom)),
                      -speed * math.cos(math.radians(wfrom)), colour, speed, wfrom, flight)
    notes.append(f"{flight}: no wind arrow (mast U_ms or wind_from_deg missing or NaN).")
    return None


def _draw_flights(ax_h: Axes, ax_p: Axes, drones: Mapping[str, xr.Dataset], l4: L4Products, site_altitude_m: float,
                  origin: tuple[float, float], notes: list[str]
                  ) -> tuple[list[float], list[_Arrow], dict[str, _LineStyle]]:
    """Height series and track of every flight; return the track extents [m], the wind arrows, the line styles."""
    colours = flight_colours(list(drones))
    span = [1.0]
    arrows = []
    styles = {}
    for flight, ds in drones.items():
        style = styles[flight] = _line_style(flight, ds, colours[flight], notes)
        _height_series(ax_h, flight, ds, site_altitude_m, style, notes)
        extent = _track(ax_p, flight, ds, origin, style, notes)
        if extent is None:
            continue
        span.append(extent)
        arrow = _wind_arrow(ax_p, flight, ds, origin, l4.get(flight, {}).get("mast"), style.colour, notes)
        if arrow is not None:
            arrows.append(arrow)
    return span, arrows, styles


# ----------------------------------------------------------------------------- panels


def _finish_height_panel(ax: Axes, sonics: Mapping[str, Mapping[str, Any]], have_drones: bool) -> None:
    """Dotted lines at the mast sonic heights with their labels, axis labels (or a no-data note)."""
    heights = sorted({float(s["height_m"]) for s in sonics.values()})
    for h in heights:
        ax.axhline(h, color="k", lw=0.8, ls=":")
        ax.annotate(f"mast sonic {h:g} m", (0.0, h), xytext=(2, 2), textcoords="offset points", fontsize=7)
    ax.set_xlabel("time since start of the hover window (min)")
    ax.set_ylabel("payload height above ground (m)")
    ax.grid(alpha=0.3)
    if not have_drones:
        no_data(ax, "no L2 drone files")


def _mast_and_sonic_heads(ax: Axes, sonics: Mapping[str, Mapping[str, Any]], lim_m: float) -> None:
    """The mast at the origin and a line towards each sonic head's azimuth (listed in the legend)."""
    ax.plot(0, 0, marker="s", color="k", ms=7, ls="none")
    for sonic in sonics.values():
        az_deg = float(sonic.get("azimuth_deg", math.nan))
        if np.isfinite(az_deg):
            az = math.radians(az_deg)
            ax.plot([0, 0.2 * lim_m * math.sin(az)], [0, 0.2 * lim_m * math.cos(az)], color="k", lw=1.0)


def _draw_wind_arrows(ax: Axes, arrows: Iterable[_Arrow], lim_m: float) -> None:
    """Direction-only arrows of fixed length (the stored speeds are in the figure legend)."""
    length = 0.25 * lim_m
    for e0, n0, u, v, colour, speed, *_ in arrows:
        ax.annotate("", xy=(e0 + length * u / speed, n0 + length * v / speed), xytext=(e0, n0),
                    arrowprops={"arrowstyle": "-|>", "color": colour, "lw": 1.6})


def _flight_legend(fig: Figure, drones: Mapping[str, xr.Dataset], arrows: Sequence[_Arrow],
                   styles: Mapping[str, _LineStyle], site_altitude_m: float,
                   sonics: Mapping[str, Mapping[str, Any]]) -> None:
    """One legend outside the panels: per flight its colour, median height and the mast wind; the sonic heads."""
    wind = {a.flight: a for a in arrows}
    handles: list[Any] = []
    for flight, style in styles.items():
        ds = drones[flight]
        text = style.label
        if "altitude" in ds.variables:
            text += f", {float(np.nanmedian(ds['altitude'].values)) - site_altitude_m:.0f} m"
        if flight in wind:
            a = wind[flight]
            text += f": {a.speed_ms:.1f} {UNIT_MS} from {a.from_deg:.0f}°"
        handles.append(Line2D([], [], color=style.colour, ls=style.ls, lw=1.4, label=text))
    handles.append(Line2D([], [], color="k", marker="s", ms=6, ls="none", label="mast"))
    for sid, sonic in sonics.items():
        az_deg = float(sonic.get("azimuth_deg", math.nan))
        if np.isfinite(az_deg):
            handles.append(Line2D([], [], color="k", lw=1.0,
                                  label=f"{sid} ({float(sonic['height_m']):g} m) head towards {az_deg:g}°"))
    if handles:
        fig.legend(handles=handles, loc="outside right upper", fontsize=7, frameon=False,
                   title="flight, median height: mast wind", title_fontsize=7)


def _finish_position_panel(ax: Axes, lim_m: float) -> None:
    """Square axes of half-width ``lim_m`` [m] around the mast, labelled."""
    ax.set_xlim(-lim_m, lim_m)
    ax.set_ylim(-lim_m, lim_m)
    ax.set_aspect("equal")
    ax.set_xlabel("distance east of the mast (m)")
    ax.set_ylabel("distance north of the mast (m)")
    ax.grid(alpha=0.3)


# ----------------------------------------------------------------------------- Fig. 7


def fig07_positions(l2_drone_files: Iterable[PathLike], l4_files: Iterable[PathLike], campaign_json: PathLike,
                    out_stem: PathLike) -> list[Path]:
    r"""Fig. 7: payload height above ground vs time, and position relative to the mast with wind arrows.

    Parameters
    ----------
    l2_drone_files : iterable of path
        L2 drone files (``altitude``, ``precise_lat``, ``precise_lon`` on ``time``; nominal
        ``lat``/``lon``).
    l4_files : iterable of path
        L4 files (mast ``U_ms`` and ``wind_from_deg`` give the arrows).
    campaign_json : str or Path
        ``campaign.json`` (site altitude, mast positions, sonic heights and azimuths, flight
        references).
    out_stem : str or Path
        Output path without suffix.

    Returns
    -------
    list of Path
        PNG and PDF.

    Notes
    -----
    Height = GNSS ``altitude`` - site ``altitude_m``. Arrows start at the stored nominal
    position of the drone file (median of the track) and point where the wind blows to
    (reference mast's stored ``wind_from_deg``); they have a fixed length (Ghirardelli et al. (2025)
    scale them to a 2 m s-1 reference vector, which makes 10 m s-1 arrows leave the panel). No text is drawn on
    the data: one legend outside the panels gives each flight's colour, median height and
    the mast's stored ``U_ms`` and ``wind_from_deg``, and the sonic heads' azimuths.
    """
    content = _campaign_content(campaign_json)
    sonics = _sonics(content)
    drones = open_by_flight(l2_drone_files)
    fig = new_figure(11.0, 4.8)
    ax_h, ax_p = fig.subplots(1, 2, width_ratios=[1.2, 1.0])
    notes: list[str] = []
    origin = _mast_origin(content, sonics, notes)
    site_altitude_m = float(content["site"]["altitude_m"])
    span, arrows, styles = _draw_flights(ax_h, ax_p, drones, load_l4_products(l4_files), site_altitude_m, origin,
                                         notes)
    _finish_height_panel(ax_h, sonics, bool(drones))
    lim = 1.15 * max(span)
    _mast_and_sonic_heads(ax_p, sonics, lim)
    _draw_wind_arrows(ax_p, arrows, lim)
    _finish_position_panel(ax_p, lim)
    _flight_legend(fig, drones, arrows, styles, site_altitude_m, sonics)
    return save_figure(fig, out_stem, add_notes(fig, notes))
