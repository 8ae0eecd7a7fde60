r"""Campaign figures drawn from stored products (seed 000, Figs 4, 7-16, B1-B2).

Every function reads stored NetCDF files (L2, L3, L4; opened with
:func:`dronewind.steps.open_product`) and the campaign record ``campaign.json``, and
draws; none recomputes a statistic, spectrum, fit or scale. Presentation-only arithmetic
is limited to: normalising a stored curve by a stored number (TKE by its minimum,
spectra by the stored variance or covariance), multiplying a stored spectrum by its
frequency, subtracting the stored mean temperature from the stored L3 series,
converting the stored GNSS latitude/longitude to metres east/north of the mast (local
equirectangular projection) and the stored GNSS altitude to height above the site.

Each figure is written as ``<out_stem>.png`` and ``<out_stem>.pdf`` (atomic rename)
and the two paths are returned. Output is deterministic: fixed size and resolution
(:data:`DPI`), no time stamps in the metadata (PNG ``Software`` and PDF
``CreationDate`` removed), no pyplot global state (figures are built with
:class:`matplotlib.figure.Figure` and the Agg canvas).

A flight whose drone record is flagged unusable, or a quantity that is NaN in the
product, is never drawn silently: it is left out of the comparison panels and listed in
a note at the bottom of the figure with the stored reason (the ``status_*`` flag of the
quantity, or ``drone_unusable_reason``). Time series and tracks of unusable flights
(Figs 4, 7) are drawn in grey, dashed.

References
----------
.. [1] Seed 000 (``../shared/papers/000_*.txt``), Figs 4, 7-16 and B1-B2 with their
   captions; Sects. 3.3, 4 and 5, Appendix B.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
import textwrap
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.layout_engine import ConstrainedLayoutEngine
from matplotlib.lines import Line2D

from dronewind.core.qc import STATUS_FLAG_MEANINGS
from dronewind.tables import default_detail_flights, load_l4_products

__all__ = [
    "DPI",
    "FIGURE_FUNCTIONS",
    "draw_all",
    "save_figure",
    "fig04_tke_lag",
    "fig07_positions",
    "fig08_timeseries",
    "fig09_velocity_spectra",
    "fig10_temperature_series",
    "fig11_temperature_spectra",
    "fig12_mean_and_sigma",
    "fig13_fluxes_obukhov",
    "fig14_length_scales",
    "fig15_quadrant",
    "fig16_uncertainty",
    "figB1_normalised_velocity_spectra",
    "figB2_normalised_temperature_spectra",
    "figure_captions",
]

PathLike = str | Path

#: Resolution of the PNG files [dots per inch]; the pixel size is figsize x DPI.
DPI = 120
DRONE_COLOUR = "tab:blue"
MAST_COLOUR = "tab:orange"
UNUSABLE_COLOUR = "0.6"
#: Markers of the reference heights, lowest first (seed 000: circles 30 m, triangles 60 m).
HEIGHT_MARKERS = ("o", "^", "s", "D", "v", "P")
_EARTH_RADIUS_M = 6_371_008.8  # IUGG mean Earth radius, for the local projection only


# ----------------------------------------------------------------------------- infrastructure


def _figure(width_in: float, height_in: float) -> Figure:
    fig = Figure(figsize=(width_in, height_in), dpi=DPI)
    FigureCanvasAgg(fig)
    fig.set_layout_engine(ConstrainedLayoutEngine(h_pad=0.04, w_pad=0.04))
    return fig


def _add_notes(fig: Figure, notes: Sequence[str]) -> list[str]:
    """List what was skipped (and why) below the axes; reserve room in the layout.

    Returns the de-duplicated notes (also stored in the file metadata by :func:`_save`).
    """
    notes = list(dict.fromkeys(n for n in notes if n))
    if not notes:
        return notes
    width_in, height_in = fig.get_size_inches()
    chars = max(40, int(width_in * 14))
    lines: list[str] = []
    for note in notes:
        lines += textwrap.wrap(note, chars) or [""]
    line_in = 0.16
    frac = min(0.45, (len(lines) * line_in + 0.1) / height_in)
    fig.get_layout_engine().set(rect=(0.0, frac, 1.0, 1.0 - frac))
    fig.text(0.01, frac - 0.02 / height_in, "\n".join(lines), ha="left", va="top", fontsize=7.5, color="0.25",
             family="DejaVu Sans")
    return notes


def save_figure(fig: Figure, out_stem: PathLike, notes: Sequence[str] = ()) -> list[Path]:
    """Write PNG and PDF atomically, without time stamps.

    The notes (what was skipped and why) also go into the metadata: PNG text chunk
    ``Description``, PDF ``Subject``; "none" when nothing was skipped.
    """
    stem = Path(out_stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    text = " | ".join(notes) if notes else "none"
    paths = []
    for ext, meta in ((".png", {"Software": None, "Title": stem.name, "Description": f"skipped: {text}"}),
                      (".pdf", {"CreationDate": None, "Creator": "dronewind", "Title": stem.name,
                                "Subject": f"skipped: {text}"})):
        target = stem.with_name(stem.name + ext)
        handle, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
        os.close(handle)
        try:
            fig.savefig(tmp, format=ext[1:], dpi=DPI, metadata=meta)
            os.chmod(tmp, 0o644)  # mkstemp creates 0600; figures are ordinary readable files
            os.replace(tmp, target)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
        paths.append(target)
    return paths


def _legend(ax: Any, **kwargs: Any) -> None:
    """Legend only when something labelled was drawn (an empty legend warns)."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(**kwargs)


def _no_data(ax: Any, text: str) -> None:
    ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes, fontsize=9, color="0.3", wrap=True)
    ax.set_xticks([])
    ax.set_yticks([])


def _scalar(ds: Any | None, name: str) -> float:
    if ds is None or name not in ds.variables:
        return math.nan
    return float(np.asarray(ds[name].values).reshape(-1)[0])


def _status_text(ds: Any | None, status: str) -> str:
    """Why a stored quantity is NaN: the meaning and reason of its ``status_<status>`` flag."""
    if ds is None:
        return "no product"
    var = f"status_{status}"
    if var in ds.variables:
        flag = int(np.asarray(ds[var].values).reshape(-1)[0])
        meaning = STATUS_FLAG_MEANINGS[flag] if 0 <= flag < len(STATUS_FLAG_MEANINGS) else str(flag)
        reason = str(ds[var].attrs.get("reason", "")).strip()
        if flag == 0:
            return f"NaN while {var} = ok"
        return f"{meaning}{': ' + reason if reason else ''}"
    return f"NaN or missing, no {var} stored"


def _drone_usable(prod: dict[str, Any]) -> tuple[bool, str]:
    drone = prod.get("drone")
    if drone is None:
        return False, "no drone L4 product"
    return bool(int(drone.attrs.get("drone_usable", 1))), str(drone.attrs.get("drone_unusable_reason", ""))


def _flight_colours(flights: Sequence[str]) -> dict[str, Any]:
    from matplotlib import colormaps

    cmap = colormaps["tab10"] if len(flights) <= 10 else colormaps["tab20"]
    return {f: cmap(i % cmap.N) for i, f in enumerate(sorted(flights))}


def _open_by_flight(files: Iterable[PathLike]) -> dict[str, Any]:
    from dronewind.steps import open_product

    out = {}
    for path in files:
        ds = open_product(path)
        flight = str(ds.attrs.get("flight", Path(path).stem.split("_")[0]))
        out[flight] = ds
    return {k: out[k] for k in sorted(out)}


def _choose(flights: Sequence[str] | None, available: Sequence[str]) -> list[str]:
    return list(flights) if flights is not None else default_detail_flights(list(available))


def _minutes(time: np.ndarray) -> np.ndarray:
    t = np.asarray(time).astype("datetime64[ns]")
    return (t - t[0]) / np.timedelta64(60, "s")


def _start_label(time: np.ndarray) -> str:
    t0 = np.datetime64(np.asarray(time)[0], "s")
    return str(np.datetime_as_string(t0, unit="s")).replace("T", " ")


# ----------------------------------------------------------------------------- Fig. 4


def fig04_tke_lag(l2_drone_files: Iterable[PathLike], out_stem: PathLike,
                  xlim: tuple[float, float] = (-1.0, 1.0), ylim: tuple[float, float] = (1.0, 1.1)) -> list[Path]:
    r"""Fig. 4: TKE of the motion-corrected wind vs sonic-INS lag, normalised by its minimum.

    Parameters
    ----------
    l2_drone_files : iterable of path
        L2 drone files (``lag``, ``tke_m2s2``; attrs ``lag_sonic_ins_s``, ``usable``).
    out_stem : str or Path
        Output path without suffix.
    xlim, ylim : (float, float)
        Axis limits (seed 000: -1 to 1 s and 1 to 1.1); the x range widens to include
        every stored lag.

    Returns
    -------
    list of Path
        PNG and PDF.

    Notes
    -----
    Vertical lines at the smallest (dashed) and largest (dash-dot) stored
    ``lag_sonic_ins_s`` of the usable flights: the window holding all minima (seed 000,
    Sect. 3.3: -0.185 s to 0 s).
    """
    products = _open_by_flight(l2_drone_files)
    colours = _flight_colours(list(products))
    fig = _figure(6.5, 4.6)
    ax = fig.add_subplot()
    notes, lags = [], []
    for flight, ds in products.items():
        if "tke_m2s2" not in ds.variables:
            notes.append(f"{flight}: no TKE-vs-lag curve stored.")
            continue
        tke = np.asarray(ds["tke_m2s2"].values, dtype=float)
        lag = np.asarray(ds["lag_s"].values if "lag_s" in ds.variables else ds["lag"].values, dtype=float)
        finite = np.isfinite(tke) & (tke > 0)
        if not finite.any():
            notes.append(f"{flight}: TKE curve all NaN.")
            continue
        norm = tke / np.min(tke[finite])
        usable = bool(int(ds.attrs.get("usable", 1)))
        lag_found = float(ds.attrs.get("lag_sonic_ins_s", math.nan))
        if usable:
            ax.plot(lag, norm, color=colours[flight], lw=1.4, label=flight)
            if np.isfinite(lag_found):
                lags.append(lag_found)
        else:
            ax.plot(lag, norm, color=UNUSABLE_COLOUR, lw=1.0, ls="--", label=f"{flight} (unusable)")
            notes.append(f"{flight}: drone record unusable ({ds.attrs.get('unusable_reason', '') or 'no reason'}); "
                         "curve grey, lag not used for the window.")
    if lags:
        lo, hi = min(lags), max(lags)
        ax.axvline(lo, color="k", ls="--", lw=1.0, label=f"smallest lag {lo:+.3f} s")
        ax.axvline(hi, color="k", ls="-.", lw=1.0, label=f"largest lag {hi:+.3f} s")
        x0, x1 = min(xlim[0], lo - 0.1), max(xlim[1], hi + 0.1)
    else:
        x0, x1 = xlim
        if not products:
            _no_data(ax, "no L2 drone files")
    ax.set_xlim(x0, x1)
    ax.set_ylim(*ylim)
    ax.set_xlabel("lag of the sonic relative to the INS (s)")
    ax.set_ylabel("TKE / min(TKE) (–)")
    ax.grid(alpha=0.3)
    if products:
        _legend(ax, fontsize=7.5, ncol=2, loc="upper center")
    return save_figure(fig, out_stem, _add_notes(fig, notes))


# ----------------------------------------------------------------------------- Fig. 7


def _campaign_content(campaign_json: PathLike) -> dict[str, Any]:
    record = json.loads(Path(campaign_json).read_text("utf-8"))
    return record.get("manifest_content", record)


def _sonics(content: dict[str, Any]) -> dict[str, dict[str, Any]]:
    out = {}
    for mast in content.get("masts") or []:
        for sonic in mast.get("sonics") or []:
            out[sonic["id"]] = {**sonic, "mast_id": mast["id"],
                                "latitude": mast.get("latitude", content["site"]["latitude"]),
                                "longitude": mast.get("longitude", content["site"]["longitude"])}
    return out


def _east_north_m(lat: np.ndarray, lon: np.ndarray, lat0: float, lon0: float) -> tuple[np.ndarray, np.ndarray]:
    """Local equirectangular projection (metres east/north of a point); < 1 mm error over 1 km."""
    east = np.deg2rad(np.asarray(lon) - lon0) * _EARTH_RADIUS_M * np.cos(np.deg2rad(lat0))
    north = np.deg2rad(np.asarray(lat) - lat0) * _EARTH_RADIUS_M
    return east, north


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
    (reference mast's stored ``wind_from_deg``); they have a fixed length and the mast's
    stored ``U_ms`` is written at the head (seed 000 scales them to a 2 m/s reference
    vector, which makes 10 m/s arrows leave the panel).
    """
    content = _campaign_content(campaign_json)
    site_alt = float(content["site"]["altitude_m"])
    sonics = _sonics(content)
    refs = {f["id"]: f.get("reference") for f in content.get("payload_flights") or []}
    drones = _open_by_flight(l2_drone_files)
    l4 = load_l4_products(l4_files)
    colours = _flight_colours(list(drones))
    fig = _figure(11.0, 4.8)
    ax_h, ax_p = fig.subplots(1, 2, width_ratios=[1.2, 1.0])
    notes: list[str] = []
    # mast position: the reference sonic's mast (the first mast if references differ)
    mast_ids = {sonics[r]["mast_id"] for r in refs.values() if r in sonics}
    first = next(iter(sonics.values()), None)
    lat0 = float(first["latitude"]) if first else float(content["site"]["latitude"])
    lon0 = float(first["longitude"]) if first else float(content["site"]["longitude"])
    if len(mast_ids) > 1:
        notes.append(f"several masts ({', '.join(sorted(mast_ids))}); positions relative to {first['mast_id']}.")
    span = [1.0]
    arrows = []
    for flight, ds in drones.items():
        usable = bool(int(ds.attrs.get("usable", 1)))
        colour = colours[flight] if usable else UNUSABLE_COLOUR
        ls = "-" if usable else "--"
        label = flight if usable else f"{flight} (unusable)"
        if not usable:
            notes.append(f"{flight}: drone record unusable ({ds.attrs.get('unusable_reason', '') or 'no reason'}); "
                         "drawn grey, dashed.")
        if "altitude" in ds.variables:
            ax_h.plot(_minutes(ds["time"].values), np.asarray(ds["altitude"].values) - site_alt, color=colour,
                      ls=ls, lw=1.0, label=label, rasterized=True)
        else:
            notes.append(f"{flight}: no GNSS altitude stored.")
        if "precise_lat" in ds.variables and "precise_lon" in ds.variables:
            e, n = _east_north_m(ds["precise_lat"].values, ds["precise_lon"].values, lat0, lon0)
            ax_p.plot(e, n, color=colour, ls=ls, lw=0.6, alpha=0.8, rasterized=True)
            span.append(float(np.nanmax(np.abs(np.concatenate([e, n])))))
        else:
            notes.append(f"{flight}: no GNSS track stored.")
            continue
        if "lat" in ds.variables and "lon" in ds.variables:
            e0, n0 = _east_north_m(np.array(float(ds["lat"])), np.array(float(ds["lon"])), lat0, lon0)
            mast = l4.get(flight, {}).get("mast")
            speed, wfrom = _scalar(mast, "U_ms"), _scalar(mast, "wind_from_deg")
            ax_p.plot(e0, n0, marker="o", ms=4, color=colour)
            if np.isfinite(speed) and np.isfinite(wfrom) and speed > 0:
                arrows.append((float(e0), float(n0), -speed * math.sin(math.radians(wfrom)),
                               -speed * math.cos(math.radians(wfrom)), colour, speed))
            else:
                notes.append(f"{flight}: no wind arrow (mast U_ms or wind_from_deg missing or NaN).")
    heights = sorted({float(s["height_m"]) for s in sonics.values()})
    for h in heights:
        ax_h.axhline(h, color="k", lw=0.8, ls=":")
        ax_h.annotate(f"mast sonic {h:g} m", (0.0, h), xytext=(2, 2), textcoords="offset points", fontsize=7)
    ax_h.set_xlabel("time since start of the hover window (min)")
    ax_h.set_ylabel("payload height above ground (m)")
    ax_h.grid(alpha=0.3)
    if drones:
        _legend(ax_h, fontsize=7, ncol=2)
    else:
        _no_data(ax_h, "no L2 drone files")
    lim = 1.15 * max(span)
    ax_p.plot(0, 0, marker="s", color="k", ms=7, ls="none")
    ax_p.annotate("mast", (0, 0), xytext=(5, 5), textcoords="offset points", fontsize=8)
    lines = []
    for sid, sonic in sonics.items():
        az_deg = float(sonic.get("azimuth_deg", math.nan))
        if np.isfinite(az_deg):
            az = math.radians(az_deg)
            ax_p.plot([0, 0.2 * lim * math.sin(az)], [0, 0.2 * lim * math.cos(az)], color="k", lw=1.0)
            lines.append(f"{sid}: {float(sonic['height_m']):g} m, head towards {az_deg:g}°")
    if lines:
        ax_p.text(0.02, 0.02, "\n".join(lines), transform=ax_p.transAxes, fontsize=7, va="bottom", ha="left",
                  bbox={"facecolor": "w", "edgecolor": "0.7", "alpha": 0.9})
    length = 0.25 * lim  # direction-only arrows of fixed length; the speed is written at the head
    for e0, n0, u, v, colour, speed in arrows:
        ax_p.annotate("", xy=(e0 + length * u / speed, n0 + length * v / speed), xytext=(e0, n0),
                      arrowprops={"arrowstyle": "-|>", "color": colour, "lw": 1.6})
        ax_p.annotate(f"{speed:.1f} m s$^{{-1}}$", (e0 + 1.45 * length * u / speed, n0 + 1.45 * length * v / speed),
                      fontsize=7, color=colour if colour != UNUSABLE_COLOUR else "0.4", ha="center", va="center")
    ax_p.set_xlim(-lim, lim)
    ax_p.set_ylim(-lim, lim)
    ax_p.set_aspect("equal")
    ax_p.set_xlabel("distance east of the mast (m)")
    ax_p.set_ylabel("distance north of the mast (m)")
    ax_p.grid(alpha=0.3)
    return save_figure(fig, out_stem, _add_notes(fig, notes))


# ----------------------------------------------------------------------------- Figs 8, 10 (time series)


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
    l3 = _open_by_flight(l3_files)
    l4 = load_l4_products(l4_files)
    chosen = _choose(flights, list(l3))
    nrow = 3 * max(1, len(chosen))
    fig = _figure(10.0, 1.55 * nrow + 0.6)
    axes = np.atleast_1d(fig.subplots(nrow, 1, sharex=False))
    notes: list[str] = []
    if not chosen:
        _no_data(axes[0], "no L3 files")
    for k, flight in enumerate(chosen):
        sub = axes[3 * k: 3 * k + 3]
        ds = l3.get(flight)
        prod = l4.get(flight, {})
        usable, reason = _drone_usable(prod) if prod else (True, "")
        if ds is None:
            _no_data(sub[1], f"{flight}: no L3 file")
            notes.append(f"{flight}: no L3 file.")
            for ax in (sub[0], sub[2]):
                ax.set_axis_off()
            continue
        t = _minutes(ds["time"].values)
        mast = prod.get("mast")
        z_mast, u_mast = _scalar(mast, "height_m"), _scalar(mast, "U_ms")
        z_drone, u_drone = _scalar(prod.get("drone"), "height_m"), _scalar(prod.get("drone"), "U_ms")
        sensors = [str(s) for s in ds["sensor"].values]
        for ax, comp, name in zip(sub, ("u", "v", "w"), ("u_ms", "v_ms", "w_ms")):
            for sensor, colour in (("drone", DRONE_COLOUR), ("mast", MAST_COLOUR)):
                if sensor not in sensors:
                    continue
                if sensor == "drone" and not usable:
                    continue
                ax.plot(t, ds[name].sel(sensor=sensor).values, color=colour, lw=0.6, label=sensor, rasterized=True)
            ax.set_ylabel(f"{comp} (m s$^{{-1}}$)")
            ax.grid(alpha=0.3)
        title = (f"{flight}: mast z = {z_mast:.0f} m, $\\bar u$ = {u_mast:.1f} m s$^{{-1}}$; "
                 f"drone z = {z_drone:.1f} m, $\\bar u$ = {u_drone:.1f} m s$^{{-1}}$; rotation: "
                 f"{ds.attrs.get('rotation_method', '?')}")
        if not usable:
            title += " — drone unusable, not drawn"
            notes.append(f"{flight}: drone record unusable ({reason or 'no reason'}); only the mast is drawn.")
        sub[0].set_title(title, fontsize=9, loc="left")
        _legend(sub[0], fontsize=7, loc="upper right", ncol=2)
        sub[2].set_xlabel(f"time since {_start_label(ds['time'].values)} UTC (min)")
    return save_figure(fig, out_stem, _add_notes(fig, notes))


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
    l3 = _open_by_flight(l3_files)
    l4 = load_l4_products(l4_files)
    chosen = _choose(flights, list(l3))
    ncol = max(1, len(chosen))
    fig = _figure(5.2 * ncol, 3.6)
    axes = np.atleast_1d(fig.subplots(1, ncol))
    notes: list[str] = []
    if not chosen:
        _no_data(axes[0], "no L3 files")
    for ax, flight in zip(axes, chosen):
        ds, prod = l3.get(flight), l4.get(flight, {})
        if ds is None:
            _no_data(ax, f"{flight}: no L3 file")
            notes.append(f"{flight}: no L3 file.")
            continue
        usable, reason = _drone_usable(prod) if prod else (True, "")
        t = _minutes(ds["time"].values)
        for sensor, colour in (("drone", DRONE_COLOUR), ("mast", MAST_COLOUR)):
            if sensor == "drone" and not usable:
                notes.append(f"{flight}: drone record unusable ({reason or 'no reason'}); only the mast is drawn.")
                continue
            mean = _scalar(prod.get(sensor), "theta_v_mean_k")
            if not np.isfinite(mean):
                notes.append(f"{flight} {sensor}: mean sonic temperature NaN "
                             f"({_status_text(prod.get(sensor), 'temperature')}); not drawn.")
                continue
            ax.plot(t, ds["theta_v_k"].sel(sensor=sensor).values - mean, color=colour, lw=0.6, rasterized=True,
                    label=f"{sensor} ($\\bar\\theta_v$ = {mean:.2f} K, "
                          f"z = {_scalar(prod.get(sensor), 'height_m'):.0f} m)")
        ax.set_title(flight, fontsize=9, loc="left")
        ax.set_xlabel(f"time since {_start_label(ds['time'].values)} UTC (min)")
        ax.set_ylabel("$\\theta_v'$ (K)")
        ax.grid(alpha=0.3)
        _legend(ax, fontsize=7, loc="upper right")
    return save_figure(fig, out_stem, _add_notes(fig, notes))


# ----------------------------------------------------------------------------- spectra (Figs 9, 11, B1, B2)


def _spectrum(ds: Any, name: str) -> tuple[np.ndarray, np.ndarray]:
    f = np.asarray(ds["frequency"].values, dtype=float)
    s = np.asarray(ds[name].values, dtype=float) if name in ds.variables else np.full_like(f, np.nan)
    return f, s


def _spectral_panel(ax: Any, prod: dict[str, Any], name: str, *, log_y: bool, usable: bool, notes: list[str],
                    flight: str, normaliser: str | None = None, model: str | None = None,
                    status: str = "spectra") -> None:
    """Plot f*S (optionally / a stored variance or covariance) for drone and mast."""
    drawn = False
    for sensor, colour in (("drone", DRONE_COLOUR), ("mast", MAST_COLOUR)):
        ds = prod.get(sensor)
        if ds is None or (sensor == "drone" and not usable):
            continue
        f, s = _spectrum(ds, name)
        y = f * s
        if normaliser is not None:
            norm = _scalar(ds, normaliser)
            if not np.isfinite(norm) or norm == 0:
                notes.append(f"{flight} {sensor}: {normaliser} NaN or zero; normalised {name} not drawn.")
                continue
            y = y / norm
        if not np.any(np.isfinite(y)):
            notes.append(f"{flight} {sensor}: {name} not available ({_status_text(ds, status)}).")
            continue
        if log_y:
            y = np.where(y > 0, y, np.nan)
        ax.plot(f, y, color=colour, lw=1.0, label=sensor)
        drawn = True
        if model and sensor == "drone":
            fm, m = _spectrum(ds, model)
            if np.any(np.isfinite(m)):
                ym = fm * m
                ax.plot(fm, np.where(ym > 0, ym, np.nan) if log_y else ym, color="k", lw=1.2, label="drone fit")
            else:
                comp = model.split("_")[1] if model.startswith("S_") else "uw"
                notes.append(f"{flight}: no fitted model for {comp} ({_status_text(ds, f'fit_{comp}')}).")
    ax.set_xscale("log")
    if log_y:
        ax.set_yscale("log")
    else:
        ax.axhline(0.0, color="0.5", lw=0.6)
    ax.grid(alpha=0.3, which="both")
    if not drawn:
        _no_data(ax, "not available")


def _fmt_pair(prod: dict[str, Any], name: str, usable: bool, fmt: str = "{:.2f}") -> str:
    d = _scalar(prod.get("drone"), name) if usable else math.nan
    m = _scalar(prod.get("mast"), name)
    show = (lambda v: fmt.format(v) if np.isfinite(v) else "–")
    return f"drone {show(d)}, mast {show(m)}"


def fig09_velocity_spectra(l4_files: Iterable[PathLike], out_stem: PathLike,
                           flights: Sequence[str] | None = None) -> list[Path]:
    r"""Fig. 9: :math:`fS_u`, :math:`fS_v`, :math:`fS_w` and :math:`f\,\mathrm{Re}(S_{uw})`, drone vs mast.

    Parameters
    ----------
    l4_files : iterable of path
        L4 files (``frequency``, ``S_u``, ``S_v``, ``S_w``, ``Co_uw`` and the drone's
        ``S_*_model``/``Co_uw_model``; ``sigma_*_ms``, ``uw_m2s2`` for the labels).
    out_stem : str or Path
        Output path without suffix.
    flights : sequence of str, optional
        Flights, one row each (default: first and seventh).

    Returns
    -------
    list of Path
        PNG and PDF.

    Notes
    -----
    Auto-spectra on log-log axes; the co-spectrum on a linear y axis (its sign is
    information). The black line is the model fitted to the drone (seed 000, Eqs 4-7:
    blunt for u, v and uw, pointed for w) as stored in L4.
    """
    l4 = load_l4_products(l4_files)
    chosen = _choose(flights, list(l4))
    nrow = max(1, len(chosen))
    fig = _figure(13.0, 3.1 * nrow + 0.3)
    axes = np.atleast_2d(fig.subplots(nrow, 4))
    notes: list[str] = []
    if not chosen:
        _no_data(axes[0, 0], "no L4 files")
    panels = (("S_u", "S_u_model", "sigma_u_ms", "$fS_u$ (m$^2$ s$^{-2}$)", True, "$\\sigma_u$"),
              ("S_v", "S_v_model", "sigma_v_ms", "$fS_v$ (m$^2$ s$^{-2}$)", True, "$\\sigma_v$"),
              ("S_w", "S_w_model", "sigma_w_ms", "$fS_w$ (m$^2$ s$^{-2}$)", True, "$\\sigma_w$"),
              ("Co_uw", "Co_uw_model", "uw_m2s2", "$f\\,\\mathrm{Re}(S_{uw})$ (m$^2$ s$^{-2}$)", False,
               "$\\overline{u'w'}$"))
    for row, flight in zip(axes, chosen):
        prod = l4.get(flight)
        if prod is None:
            for ax in row:
                _no_data(ax, f"{flight}: no L4 files")
            notes.append(f"{flight}: no L4 files.")
            continue
        usable, reason = _drone_usable(prod)
        if not usable:
            notes.append(f"{flight}: drone record unusable ({reason or 'no reason'}); only the mast is drawn.")
        for ax, (name, model, stat, ylabel, log_y, sym) in zip(row, panels):
            _spectral_panel(ax, prod, name, log_y=log_y, usable=usable, notes=notes, flight=flight, model=model)
            unit = "m$^2$ s$^{-2}$" if stat == "uw_m2s2" else "m s$^{-1}$"
            ax.set_title(f"{flight}: {sym} {_fmt_pair(prod, stat, usable, '{:.3f}' if stat == 'uw_m2s2' else '{:.2f}')}"
                         f" {unit}", fontsize=8, loc="left")
            ax.set_xlabel("f (Hz)")
            ax.set_ylabel(ylabel)
        _legend(row[0], fontsize=7, loc="lower left")
    return save_figure(fig, out_stem, _add_notes(fig, notes))


def fig11_temperature_spectra(l4_files: Iterable[PathLike], out_stem: PathLike,
                              flights: Sequence[str] | None = None) -> list[Path]:
    r"""Fig. 11: temperature spectrum and co-spectra with w and u, drone vs mast.

    Parameters
    ----------
    l4_files : iterable of path
        L4 files (``S_T``, ``Co_wT``, ``Co_uT`` on ``frequency``).
    out_stem : str or Path
        Output path without suffix.
    flights : sequence of str, optional
        Flights, one column each (default: first and seventh).

    Returns
    -------
    list of Path
        PNG and PDF.
    """
    l4 = load_l4_products(l4_files)
    chosen = _choose(flights, list(l4))
    ncol = max(1, len(chosen))
    fig = _figure(5.0 * ncol, 8.0)
    axes = np.atleast_2d(fig.subplots(3, ncol)).reshape(3, ncol)
    notes: list[str] = []
    if not chosen:
        _no_data(axes[0, 0], "no L4 files")
    panels = (("S_T", "$fS_{\\theta}$ (K$^2$)", True), ("Co_wT", "$f\\,\\mathrm{Re}(S_{w\\theta_v})$ (K m s$^{-1}$)",
                                                         False),
              ("Co_uT", "$f\\,\\mathrm{Re}(S_{u\\theta_v})$ (K m s$^{-1}$)", False))
    for k, flight in enumerate(chosen):
        prod = l4.get(flight)
        col = axes[:, k]
        if prod is None:
            for ax in col:
                _no_data(ax, f"{flight}: no L4 files")
            notes.append(f"{flight}: no L4 files.")
            continue
        usable, reason = _drone_usable(prod)
        if not usable:
            notes.append(f"{flight}: drone record unusable ({reason or 'no reason'}); only the mast is drawn.")
        z = _scalar(prod.get("mast"), "height_m")
        for ax, (name, ylabel, log_y) in zip(col, panels):
            _spectral_panel(ax, prod, name, log_y=log_y, usable=usable, notes=notes, flight=flight,
                            status="temperature")
            ax.set_ylabel(ylabel)
            ax.set_xlabel("f (Hz)")
        col[0].set_title(f"{flight}: mast z = {z:.0f} m; $\\sigma_\\theta$ "
                         f"{_fmt_pair(prod, 'sigma_T_k', usable)} K", fontsize=8, loc="left")
        col[1].set_title(f"$\\overline{{w'\\theta_v'}}$ {_fmt_pair(prod, 'wT_Kms', usable, '{:.3f}')} K m s$^{{-1}}$",
                         fontsize=8, loc="left")
        col[2].set_title(f"$\\overline{{u'\\theta_v'}}$ {_fmt_pair(prod, 'uT_Kms', usable, '{:.3f}')} K m s$^{{-1}}$",
                         fontsize=8, loc="left")
        _legend(col[0], fontsize=7, loc="lower left")
    return save_figure(fig, out_stem, _add_notes(fig, notes))


def _others(l4: dict[str, Any], flights: Sequence[str] | None) -> list[str]:
    if flights is not None:
        return list(flights)
    detail = set(default_detail_flights(list(l4)))
    rest = [f for f in l4 if f not in detail]
    return rest if rest else list(l4)


def figB1_normalised_velocity_spectra(l4_files: Iterable[PathLike], out_stem: PathLike,
                                      flights: Sequence[str] | None = None) -> list[Path]:
    r"""Fig. B1: normalised spectra :math:`fS_i/\sigma_i^2` and :math:`f\,\mathrm{Re}(S_{uw})/\overline{u'w'}`.

    Parameters
    ----------
    l4_files : iterable of path
        L4 files.
    out_stem : str or Path
        Output path without suffix.
    flights : sequence of str, optional
        Flights, one row each (default: all but the detailed first and seventh; all when
        nothing else is left).

    Returns
    -------
    list of Path
        PNG and PDF.

    Notes
    -----
    Normalisers are the stored ``sigma_*_ms`` squared and ``uw_m2s2`` (seed 000,
    Appendix B: "normalised by the variance or covariance").
    """
    l4 = load_l4_products(l4_files)
    chosen = _others(l4, flights)
    nrow = max(1, len(chosen))
    fig = _figure(13.0, 2.5 * nrow + 0.4)
    axes = np.atleast_2d(fig.subplots(nrow, 4))
    notes: list[str] = []
    if not chosen:
        _no_data(axes[0, 0], "no L4 files")
    panels = (("S_u", "sigma_u_ms", "$fS_u/\\sigma_u^2$", True), ("S_v", "sigma_v_ms", "$fS_v/\\sigma_v^2$", True),
              ("S_w", "sigma_w_ms", "$fS_w/\\sigma_w^2$", True),
              ("Co_uw", "uw_m2s2", "$f\\,\\mathrm{Re}(S_{uw})/\\overline{u'w'}$", False))
    for row, flight in zip(axes, chosen):
        prod = l4.get(flight)
        if prod is None:
            for ax in row:
                _no_data(ax, f"{flight}: no L4 files")
            notes.append(f"{flight}: no L4 files.")
            continue
        usable, reason = _drone_usable(prod)
        if not usable:
            notes.append(f"{flight}: drone record unusable ({reason or 'no reason'}); only the mast is drawn.")
        for ax, (name, norm, ylabel, log_y) in zip(row, panels):
            _normalised_panel(ax, prod, name, norm, log_y, usable, notes, flight)
            ax.set_ylabel(f"{ylabel} (–)")
            ax.set_xlabel("f (Hz)")
        row[0].set_title(flight, fontsize=9, loc="left")
        _legend(row[0], fontsize=7, loc="lower left")
    return save_figure(fig, out_stem, _add_notes(fig, notes))


def _normalised_panel(ax: Any, prod: dict[str, Any], name: str, norm: str, log_y: bool, usable: bool,
                      notes: list[str], flight: str) -> None:
    squared = norm.startswith("sigma_")
    drawn = False
    for sensor, colour in (("drone", DRONE_COLOUR), ("mast", MAST_COLOUR)):
        ds = prod.get(sensor)
        if ds is None or (sensor == "drone" and not usable):
            continue
        value = _scalar(ds, norm)
        value = value**2 if squared else value
        f, s = _spectrum(ds, name)
        if not np.isfinite(value) or value == 0 or not np.any(np.isfinite(s)):
            notes.append(f"{flight} {sensor}: normalised {name} not available "
                         f"({_status_text(ds, 'spectra') if not np.any(np.isfinite(s)) else norm + ' NaN or zero'}).")
            continue
        y = f * s / value
        ax.plot(f, np.where(y > 0, y, np.nan) if log_y else y, color=colour, lw=1.0, label=sensor)
        drawn = True
    ax.set_xscale("log")
    if log_y:
        ax.set_yscale("log")
    else:
        ax.axhline(0.0, color="0.5", lw=0.6)
    ax.grid(alpha=0.3, which="both")
    if not drawn:
        _no_data(ax, "not available")


def figB2_normalised_temperature_spectra(l4_files: Iterable[PathLike], out_stem: PathLike,
                                         flights: Sequence[str] | None = None) -> list[Path]:
    r"""Fig. B2: normalised temperature spectrum and temperature co-spectra, drone vs mast.

    Panels: :math:`fS_\theta/\sigma_\theta^2`,
    :math:`f\,\mathrm{Re}(S_{w\theta})/\overline{w'\theta'}`,
    :math:`f\,\mathrm{Re}(S_{u\theta})/\overline{u'\theta'}`.

    Parameters
    ----------
    l4_files : iterable of path
        L4 files (``S_T``, ``Co_wT``, ``Co_uT``; ``sigma_T_k``, ``wT_Kms``, ``uT_Kms``).
    out_stem : str or Path
        Output path without suffix.
    flights : sequence of str, optional
        Flights, one row each (default as :func:`figB1_normalised_velocity_spectra`).

    Returns
    -------
    list of Path
        PNG and PDF.
    """
    l4 = load_l4_products(l4_files)
    chosen = _others(l4, flights)
    nrow = max(1, len(chosen))
    fig = _figure(11.0, 2.5 * nrow + 0.4)
    axes = np.atleast_2d(fig.subplots(nrow, 3))
    notes: list[str] = []
    if not chosen:
        _no_data(axes[0, 0], "no L4 files")
    panels = (("S_T", "sigma_T_k", "$fS_\\theta/\\sigma_\\theta^2$", True),
              ("Co_wT", "wT_Kms", "$f\\,\\mathrm{Re}(S_{w\\theta_v})/\\overline{w'\\theta_v'}$", False),
              ("Co_uT", "uT_Kms", "$f\\,\\mathrm{Re}(S_{u\\theta_v})/\\overline{u'\\theta_v'}$", False))
    for row, flight in zip(axes, chosen):
        prod = l4.get(flight)
        if prod is None:
            for ax in row:
                _no_data(ax, f"{flight}: no L4 files")
            notes.append(f"{flight}: no L4 files.")
            continue
        usable, reason = _drone_usable(prod)
        if not usable:
            notes.append(f"{flight}: drone record unusable ({reason or 'no reason'}); only the mast is drawn.")
        for ax, (name, norm, ylabel, log_y) in zip(row, panels):
            _normalised_panel(ax, prod, name, norm, log_y, usable, notes, flight)
            ax.set_ylabel(f"{ylabel} (–)")
            ax.set_xlabel("f (Hz)")
        row[0].set_title(flight, fontsize=9, loc="left")
        _legend(row[0], fontsize=7, loc="lower left")
    return save_figure(fig, out_stem, _add_notes(fig, notes))


# ----------------------------------------------------------------------------- scatter figures (12-16)


def _height_markers(l4: dict[str, Any]) -> dict[float, str]:
    heights = sorted({h for prod in l4.values() for h in [_scalar(prod.get("mast"), "height_m")] if np.isfinite(h)})
    return {h: HEIGHT_MARKERS[i % len(HEIGHT_MARKERS)] for i, h in enumerate(heights)}


def _scatter_panels(l4: dict[str, Any], axes: Sequence[Any], quantities: Sequence[tuple[str, str, str]],
                    notes: list[str], symlog: Sequence[str] = (), one_to_one: bool = True) -> None:
    """Drone (y) vs mast (x) for each quantity, one colour per flight, markers per reference height."""
    colours = _flight_colours(list(l4))
    markers = _height_markers(l4)
    skipped_unusable = set()
    for ax, (name, label, unit) in zip(axes, quantities):
        xs, ys = [], []
        for flight, prod in l4.items():
            usable, reason = _drone_usable(prod)
            if not usable:
                if flight not in skipped_unusable:
                    notes.append(f"{flight}: drone record unusable ({reason or 'no reason'}); not drawn.")
                    skipped_unusable.add(flight)
                continue
            d, m = prod.get("drone"), prod.get("mast")
            x, y = _scalar(m, name), _scalar(d, name)
            if not (np.isfinite(x) and np.isfinite(y)):
                why = []
                if not np.isfinite(y):
                    why.append(f"drone {_status_text(d, _status_name(name))}")
                if not np.isfinite(x):
                    why.append(f"mast {_status_text(m, _status_name(name))}")
                notes.append(f"{flight}: {name} not drawn ({'; '.join(why)}).")
                continue
            h = _scalar(m, "height_m")
            ax.plot(x, y, ls="none", marker=markers.get(h, "o"), ms=7, color=colours[flight], mec="k", mew=0.5)
            xs.append(x)
            ys.append(y)
        if xs:
            lo, hi = min(xs + ys), max(xs + ys)
            pad = 0.08 * (hi - lo) if hi > lo else max(abs(hi) * 0.1, 1e-3)
            lo, hi = lo - pad, hi + pad
            if name not in symlog and lo > 0 and lo < 0.3 * hi:
                lo = 0.0
            if one_to_one:
                ax.plot([lo, hi], [lo, hi], color="k", lw=0.8, ls="--")
            ax.set_xlim(lo, hi)
            ax.set_ylim(lo, hi)
            if name in symlog:
                lin = max(1.0, 10 ** math.floor(math.log10(max(min(abs(v) for v in xs + ys), 1e-9))))
                ax.set_xscale("symlog", linthresh=lin)
                ax.set_yscale("symlog", linthresh=lin)
        else:
            _no_data(ax, f"no finite {name}")
        ax.set_xlabel(f"mast {label} ({unit})")
        ax.set_ylabel(f"drone {label} ({unit})")
        ax.grid(alpha=0.3)
        ax.set_aspect("equal", adjustable="box")


def _status_name(name: str) -> str:
    """The L4 status variable that explains a NaN in ``name``."""
    table = {"U_ms": "statistics", "uw_m2s2": "statistics", "vw_m2s2": "statistics", "wT_Kms": "temperature",
             "L_m": "obukhov", "Sw_Su": "Sw_Su", "Sv_Su": "Sv_Su"}
    if name.startswith("sigma_") and name.endswith("_ms"):
        return "statistics"
    if name.startswith("L_") and name.endswith("_m") and name != "L_m":
        return name[:-2]  # L_u_m -> status_L_u
    if name.startswith(("a_", "eps_")):
        return name
    return table.get(name, name)


def _scatter_legend(fig: Figure, l4: dict[str, Any]) -> None:
    colours = _flight_colours(list(l4))
    markers = _height_markers(l4)
    handles = [Line2D([], [], ls="none", marker="o", color=colours[f], mec="k", mew=0.5,
                      label=f if _drone_usable(p)[0] else f"{f} (unusable, not drawn)") for f, p in l4.items()]
    handles += [Line2D([], [], ls="none", marker=mk, color="w", mec="k", label=f"reference {h:g} m")
                for h, mk in markers.items()]
    handles.append(Line2D([], [], color="k", ls="--", lw=0.8, label="1:1"))
    if handles:
        fig.legend(handles=handles, loc="outside right upper", fontsize=7.5, frameon=False)


def _scatter_figure(l4_files: Iterable[PathLike], out_stem: PathLike, quantities: Sequence[tuple[str, str, str]],
                    ncols: int, symlog: Sequence[str] = (), panel_in: float = 3.3) -> list[Path]:
    l4 = load_l4_products(l4_files)
    nrows = math.ceil(len(quantities) / ncols)
    fig = _figure(panel_in * ncols + 1.4, panel_in * nrows + 0.2)
    axes = np.atleast_1d(fig.subplots(nrows, ncols)).ravel()
    notes: list[str] = []
    _scatter_panels(l4, axes, quantities, notes, symlog)
    for ax, letter in zip(axes, "abcdefgh"):
        ax.set_title(f"({letter})", fontsize=9, loc="left")
    _scatter_legend(fig, l4)
    return save_figure(fig, out_stem, _add_notes(fig, notes))


def fig12_mean_and_sigma(l4_files: Iterable[PathLike], out_stem: PathLike) -> list[Path]:
    r"""Fig. 12: drone vs mast :math:`\bar u`, :math:`\sigma_u`, :math:`\sigma_v`, :math:`\sigma_w`.

    Parameters
    ----------
    l4_files : iterable of path
        L4 files (``U_ms``, ``sigma_*_ms``, mast ``height_m``).
    out_stem : str or Path
        Output path without suffix.

    Returns
    -------
    list of Path
        PNG and PDF.
    """
    return _scatter_figure(l4_files, out_stem, (
        ("U_ms", "$\\bar u$", "m s$^{-1}$"), ("sigma_u_ms", "$\\sigma_u$", "m s$^{-1}$"),
        ("sigma_v_ms", "$\\sigma_v$", "m s$^{-1}$"), ("sigma_w_ms", "$\\sigma_w$", "m s$^{-1}$")), ncols=2)


def fig13_fluxes_obukhov(l4_files: Iterable[PathLike], out_stem: PathLike) -> list[Path]:
    r"""Fig. 13: drone vs mast covariances :math:`\overline{u'w'}`, :math:`\overline{v'w'}`,
    :math:`\overline{w'\theta_v'}` and the Obukhov length :math:`L`.

    Parameters
    ----------
    l4_files : iterable of path
        L4 files (``uw_m2s2``, ``vw_m2s2``, ``wT_Kms``, ``L_m``).
    out_stem : str or Path
        Output path without suffix.

    Returns
    -------
    list of Path
        PNG and PDF.

    Notes
    -----
    L on symmetric-log axes (linear within ±10^n m around zero), since it changes sign.
    """
    return _scatter_figure(l4_files, out_stem, (
        ("uw_m2s2", "$\\overline{u'w'}$", "m$^2$ s$^{-2}$"), ("vw_m2s2", "$\\overline{v'w'}$", "m$^2$ s$^{-2}$"),
        ("wT_Kms", "$\\overline{w'\\theta_v'}$", "K m s$^{-1}$"), ("L_m", "$L$", "m")), ncols=2, symlog=("L_m",))


def fig14_length_scales(l4_files: Iterable[PathLike], out_stem: PathLike) -> list[Path]:
    r"""Fig. 14: drone vs mast integral length scales :math:`L_u`, :math:`L_v`, :math:`L_w`.

    Parameters
    ----------
    l4_files : iterable of path
        L4 files (``L_u_m``, ``L_v_m``, ``L_w_m``; NaN where Taylor's hypothesis fails,
        seed 000 Eq. 16, with the reason in ``status_L_*``).
    out_stem : str or Path
        Output path without suffix.

    Returns
    -------
    list of Path
        PNG and PDF.
    """
    return _scatter_figure(l4_files, out_stem, (
        ("L_u_m", "$L_u$", "m"), ("L_v_m", "$L_v$", "m"), ("L_w_m", "$L_w$", "m")), ncols=3)


def fig15_quadrant(l4_files: Iterable[PathLike], out_stem: PathLike, low_speed_ms: float = 2.0) -> list[Path]:
    r"""Fig. 15: quadrant plot of :math:`\langle S_w/S_u\rangle` and :math:`\langle S_v/S_u\rangle`, drone vs mast.

    Parameters
    ----------
    l4_files : iterable of path
        L4 files (``Sw_Su``, ``Sv_Su``, mast ``U_ms``).
    out_stem : str or Path
        Output path without suffix.
    low_speed_ms : float
        Mean speed below which a sample is drawn as a grey triangle [m s-1] (seed 000
        text: 2 m/s; its caption says 1 m/s).

    Returns
    -------
    list of Path
        PNG and PDF.

    Notes
    -----
    Lines at the isotropic value 4/3 split each panel into quadrants (seed 000, Fig. 6);
    colour = the mast's mean wind speed. L4 stores the ratios as NaN (status
    ``low_wind_speed``) when U is below its ``quadrant_min_speed_ms``: such samples are
    listed in the note, since no value is stored to draw.
    """
    from matplotlib import colormaps
    from matplotlib.colors import Normalize

    l4 = load_l4_products(l4_files)
    fig = _figure(10.5, 4.8)
    axes = fig.subplots(1, 2)
    notes: list[str] = []
    speeds = [_scalar(p.get("mast"), "U_ms") for p in l4.values()]
    finite_speeds = [s for s in speeds if np.isfinite(s)]
    norm = Normalize(vmin=min(finite_speeds, default=0.0), vmax=max(finite_speeds + [1e-3], default=1.0))
    cmap = colormaps["viridis"]
    iso = 4.0 / 3.0
    for ax, name, label in zip(axes, ("Sw_Su", "Sv_Su"), ("$\\langle S_w/S_u\\rangle$", "$\\langle S_v/S_u\\rangle$")):
        values = []
        for flight, prod in l4.items():
            usable, reason = _drone_usable(prod)
            if not usable:
                if name == "Sw_Su":
                    notes.append(f"{flight}: drone record unusable ({reason or 'no reason'}); not drawn.")
                continue
            d, m = prod.get("drone"), prod.get("mast")
            x, y, speed = _scalar(m, name), _scalar(d, name), _scalar(m, "U_ms")
            if not (np.isfinite(x) and np.isfinite(y)):
                notes.append(f"{flight}: {name} not drawn (drone {_status_text(d, name)}; "
                             f"mast {_status_text(m, name)}).")
                continue
            if np.isfinite(speed) and speed < low_speed_ms:
                ax.plot(x, y, ls="none", marker="^", ms=8, color="0.6", mec="k", mew=0.5)
            else:
                ax.plot(x, y, ls="none", marker="o", ms=8, color=cmap(norm(speed)), mec="k", mew=0.5)
            ax.annotate(flight, (x, y), xytext=(4, 4), textcoords="offset points", fontsize=7)
            values += [x, y]
        lo = min(values + [0.5])
        hi = max(values + [2.2])
        lo, hi = lo - 0.05 * (hi - lo), hi + 0.05 * (hi - lo)
        ax.axvline(iso, color="k", lw=0.9)
        ax.axhline(iso, color="k", lw=0.9)
        ax.plot([lo, hi], [lo, hi], color="0.5", lw=0.6, ls="--")
        ax.set_xlim(lo, hi)
        ax.set_ylim(lo, hi)
        ax.set_aspect("equal", adjustable="box")
        kw = dict(transform=ax.transAxes, fontsize=7, color="0.35")
        ax.text(0.02, 0.98, "drone > 4/3\nmast < 4/3", va="top", ha="left", **kw)
        ax.text(0.98, 0.98, "both > 4/3", va="top", ha="right", **kw)
        ax.text(0.02, 0.02, "both < 4/3", va="bottom", ha="left", **kw)
        ax.text(0.98, 0.02, "drone < 4/3\nmast > 4/3", va="bottom", ha="right", **kw)
        ax.set_xlabel(f"mast {label} (–)")
        ax.set_ylabel(f"drone {label} (–)")
        ax.grid(alpha=0.3)
    from matplotlib.cm import ScalarMappable

    fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), ax=list(axes), label="mast $\\bar u$ (m s$^{-1}$)",
                 shrink=0.85)
    axes[0].plot([], [], ls="none", marker="^", color="0.6", mec="k",
                 label=f"$\\bar u$ < {low_speed_ms:g} m s$^{{-1}}$")
    _legend(axes[0], fontsize=7, loc="lower center")
    return save_figure(fig, out_stem, _add_notes(fig, notes))


def fig16_uncertainty(l4_files: Iterable[PathLike], out_stem: PathLike, metric: str = "a",
                      threshold: float = 0.5) -> list[Path]:
    r"""Fig. 16: random-uncertainty metrics, drone (y) vs mast (x), with the low-uncertainty patch.

    Parameters
    ----------
    l4_files : iterable of path
        L4 files (``a_sigma_u2`` ... ``a_wT``, or ``eps_*``).
    out_stem : str or Path
        Output path without suffix.
    metric : {"a", "eps"}
        ``"a"``: seed 000 Eqs 10-13 (time scale z/U); ``"eps"``: relative random error
        from the measured integral time scale of the product series.
    threshold : float
        Side of the green low-uncertainty square (seed 000: 0.5).

    Returns
    -------
    list of Path
        PNG and PDF.
    """
    if metric not in ("a", "eps"):
        from dronewind.errors import InputError

        raise InputError("fig16_uncertainty(metric)", f"expected 'a' or 'eps', got {metric!r}")
    names = (("sigma_u2", "$\\sigma_u^2$"), ("sigma_v2", "$\\sigma_v^2$"), ("sigma_w2", "$\\sigma_w^2$"),
             ("uw", "$\\overline{u'w'}$"), ("vw", "$\\overline{v'w'}$"), ("wT", "$\\overline{w'\\theta_v'}$"))
    sym = "a" if metric == "a" else "\\epsilon"
    quantities = [(f"{metric}_{n}", f"${sym}$ of {lab}", "–") for n, lab in names]
    l4 = load_l4_products(l4_files)
    fig = _figure(3.0 * 3 + 1.4, 3.0 * 2 + 0.2)
    axes = np.atleast_1d(fig.subplots(2, 3)).ravel()
    notes: list[str] = []
    _scatter_panels(l4, axes, quantities, notes, one_to_one=False)
    for ax, letter in zip(axes, "abcdef"):
        lo, hi = ax.get_xlim()
        top = max(hi, 1.1 * threshold)
        ax.set_xlim(0.0, top)
        ax.set_ylim(0.0, top)
        ax.fill_between([0.0, threshold], 0.0, threshold, color="tab:green", alpha=0.25, lw=0, zorder=0)
        ax.plot([0.0, top], [0.0, top], color="k", lw=0.8, ls="--")
        ax.set_title(f"({letter})", fontsize=9, loc="left")
    _scatter_legend(fig, l4)
    return save_figure(fig, out_stem, _add_notes(fig, notes))


# ----------------------------------------------------------------------------- registry


def figure_captions() -> dict[str, str]:
    """Captions of the campaign figures, keyed by figure name (= function name = output stem).

    Returns
    -------
    dict of str to str
        Name -> caption (plain text with a few reStructuredText-safe symbols), for the
        Snakemake report.
    """
    return {
        "fig04_tke_lag": "Turbulent kinetic energy of the motion-corrected payload wind versus the lag added to "
        "the sonic clock relative to the INS, one curve per flight, each normalised by its minimum (after "
        "seed 000, Fig. 4). Dashed and dash-dot vertical lines: smallest and largest lag of minimum TKE among "
        "the usable flights. Unusable flights grey, dashed.",
        "fig07_positions": "Left: payload height above ground (GNSS altitude minus site altitude) during the "
        "hover windows, with the mast sonic heights dotted. Right: payload position east/north of the mast, "
        "sonic head azimuths as black lines; coloured arrows from the median position point where the wind "
        "measured by the reference mast sonic blows to, its mean speed written at the head (after seed 000, Fig. 7).",
        "fig08_timeseries": "Streamwise (u), cross-wind (v) and vertical (w) velocity in streamline coordinates "
        "(L3, 8 Hz), drone (blue) and reference mast sonic (orange), for the detailed flights; titles give the "
        "heights and mean speeds from L4 (after seed 000, Fig. 8).",
        "fig09_velocity_spectra": "Frequency-weighted spectra f S_u, f S_v, f S_w (log-log) and co-spectrum "
        "f Re(S_uw) (linear y), drone (blue) and mast (orange), with the blunt/pointed model fitted to the drone "
        "(black, seed 000 Eqs 4-7); standard deviations and u'w' in the panel titles (after seed 000, Fig. 9).",
        "fig10_temperature_series": "Sonic temperature fluctuations (minus the stored mean of each sensor), "
        "drone (blue) and mast (orange), for the detailed flights; the means are in the legend (after seed 000, "
        "Fig. 10).",
        "fig11_temperature_spectra": "Frequency-weighted sonic-temperature spectrum f S_theta (log-log) and "
        "co-spectra f Re(S_w theta) and f Re(S_u theta) (linear y), drone (blue) and mast (orange) (after seed "
        "000, Fig. 11).",
        "fig12_mean_and_sigma": "Drone versus mast mean wind speed and standard deviations of u, v, w, one colour "
        "per flight; circles: reference sonic at the lower height (30 m), triangles: the upper (60 m); dashed: "
        "1:1 (after seed 000, Fig. 12).",
        "fig13_fluxes_obukhov": "Drone versus mast covariances u'w', v'w', w'theta_v' and Obukhov length L "
        "(symmetric-log axes); markers as in Fig. 12 (after seed 000, Fig. 13).",
        "fig14_length_scales": "Drone versus mast integral length scales L_u, L_v, L_w (exponential fit of the "
        "autocovariance and Taylor's hypothesis); flights where I_u >= 0.5 or U <= 1 m/s are left out and listed "
        "(after seed 000, Fig. 14).",
        "fig15_quadrant": "Quadrant analysis of the frequency-averaged spectral ratios <S_w/S_u> (left) and "
        "<S_v/S_u> (right) over 2 < f z/U < 10, drone versus mast, coloured by the mast mean speed; lines at the "
        "isotropic 4/3; grey triangles: mean speed below the low-wind limit (after seed 000, Figs 6 and 15).",
        "fig16_uncertainty": "Normalised random-uncertainty metrics (seed 000 Eqs 10-13) of the variances, "
        "momentum fluxes and buoyancy flux, drone (y) versus mast (x); green: below 0.5, low statistical "
        "uncertainty (after seed 000, Fig. 16).",
        "figB1_normalised_velocity_spectra": "Spectra of u, v, w normalised by their variances, and the u-w "
        "co-spectrum normalised by u'w', drone (blue) and mast (orange), for the flights not shown in detail "
        "(after seed 000, Fig. B1).",
        "figB2_normalised_temperature_spectra": "Sonic-temperature spectrum normalised by its variance and the "
        "w-theta and u-theta co-spectra normalised by their covariances, drone (blue) and mast (orange), for the "
        "flights not shown in detail (after seed 000, Fig. B2).",
    }


#: Figure name -> function (all take the output stem as a keyword ``out_stem``).
FIGURE_FUNCTIONS = {
    "fig04_tke_lag": fig04_tke_lag,
    "fig07_positions": fig07_positions,
    "fig08_timeseries": fig08_timeseries,
    "fig09_velocity_spectra": fig09_velocity_spectra,
    "fig10_temperature_series": fig10_temperature_series,
    "fig11_temperature_spectra": fig11_temperature_spectra,
    "fig12_mean_and_sigma": fig12_mean_and_sigma,
    "fig13_fluxes_obukhov": fig13_fluxes_obukhov,
    "fig14_length_scales": fig14_length_scales,
    "fig15_quadrant": fig15_quadrant,
    "fig16_uncertainty": fig16_uncertainty,
    "figB1_normalised_velocity_spectra": figB1_normalised_velocity_spectra,
    "figB2_normalised_temperature_spectra": figB2_normalised_temperature_spectra,
}


def draw_all(results_dir: PathLike, figures_dir: PathLike, flights: Sequence[str] | None = None) -> list[Path]:
    """Draw every campaign figure from a ``results/<campaign>/`` tree.

    Parameters
    ----------
    results_dir : str or Path
        Campaign results folder (``netcdf/L2``, ``netcdf/L3``, ``netcdf/L4``,
        ``campaign.json``).
    figures_dir : str or Path
        Output folder; files are ``<name>.png`` and ``<name>.pdf`` for every name in
        :func:`figure_captions`.
    flights : sequence of str, optional
        Flights shown in detail (Figs 8-11); default first and seventh.

    Returns
    -------
    list of Path
        All written files.
    """
    root, out = Path(results_dir), Path(figures_dir)
    l2 = sorted((root / "netcdf" / "L2").glob("*_drone.nc"))
    l3 = sorted((root / "netcdf" / "L3").glob("*.nc"))
    l4 = sorted((root / "netcdf" / "L4").glob("*_*.nc"))
    paths: list[Path] = []
    paths += fig04_tke_lag(l2, out / "fig04_tke_lag")
    paths += fig07_positions(l2, l4, root / "campaign.json", out / "fig07_positions")
    paths += fig08_timeseries(l3, l4, out / "fig08_timeseries", flights)
    paths += fig09_velocity_spectra(l4, out / "fig09_velocity_spectra", flights)
    paths += fig10_temperature_series(l3, l4, out / "fig10_temperature_series", flights)
    paths += fig11_temperature_spectra(l4, out / "fig11_temperature_spectra", flights)
    paths += fig12_mean_and_sigma(l4, out / "fig12_mean_and_sigma")
    paths += fig13_fluxes_obukhov(l4, out / "fig13_fluxes_obukhov")
    paths += fig14_length_scales(l4, out / "fig14_length_scales")
    paths += fig15_quadrant(l4, out / "fig15_quadrant")
    paths += fig16_uncertainty(l4, out / "fig16_uncertainty")
    detail = None if flights is None else ([f for f in sorted({Path(p).stem.split("_")[0] for p in l4})
                                            if f not in set(flights)] or None)
    paths += figB1_normalised_velocity_spectra(l4, out / "figB1_normalised_velocity_spectra", detail)
    paths += figB2_normalised_temperature_spectra(l4, out / "figB2_normalised_temperature_spectra", detail)
    return paths
