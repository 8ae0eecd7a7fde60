r"""Sonic-INS synchronisation: TKE of the motion-corrected wind against the lag (seed 000, Fig. 4).

Drawn from the stored L2 drone files: the TKE-vs-lag curve (``lag_s``, ``tke_m2s2``) and
the lag found (attribute ``lag_sonic_ins_s``). The only arithmetic is the normalisation
of each stored curve by its minimum.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from pathlib import Path

import numpy as np
import xarray as xr
from matplotlib.axes import Axes

from dronewind.core.products import open_by_flight
from dronewind.figures.style import (
    UNUSABLE_COLOUR,
    PathLike,
    add_notes,
    flight_colours,
    legend,
    new_figure,
    no_data,
    save_figure,
)

__all__ = ["fig04_tke_lag"]


def _tke_curve(ax: Axes, flight: str, ds: xr.Dataset, colour: object, notes: list[str]) -> float:
    """Draw one flight's normalised TKE curve; return its stored lag if the flight counts for the window [s]."""
    if "tke_m2s2" not in ds.variables:
        notes.append(f"{flight}: no TKE-vs-lag curve stored.")
        return math.nan
    tke = np.asarray(ds["tke_m2s2"].values, dtype=float)
    lag = np.asarray(ds["lag_s"].values if "lag_s" in ds.variables else ds["lag"].values, dtype=float)
    finite = np.isfinite(tke) & (tke > 0)
    if not finite.any():
        notes.append(f"{flight}: TKE curve all NaN.")
        return math.nan
    norm = tke / np.min(tke[finite])
    if bool(int(ds.attrs.get("usable", 1))):
        ax.plot(lag, norm, color=colour, lw=1.4, label=flight)
        return float(ds.attrs.get("lag_sonic_ins_s", math.nan))
    ax.plot(lag, norm, color=UNUSABLE_COLOUR, lw=1.0, ls="--", label=f"{flight} (unusable)")
    notes.append(f"{flight}: drone record unusable ({ds.attrs.get('unusable_reason', '') or 'no reason'}); "
                 "curve grey, lag not used for the window.")
    return math.nan


def _lag_window(ax: Axes, lags: list[float], xlim: tuple[float, float]) -> tuple[float, float]:
    """Mark the smallest and largest lag; return the x range widened to include them [s]."""
    lo, hi = min(lags), max(lags)
    ax.axvline(lo, color="k", ls="--", lw=1.0, label=f"smallest lag {lo:+.3f} s")
    ax.axvline(hi, color="k", ls="-.", lw=1.0, label=f"largest lag {hi:+.3f} s")
    return min(xlim[0], lo - 0.1), max(xlim[1], hi + 0.1)


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
    products = open_by_flight(l2_drone_files)
    colours = flight_colours(list(products))
    fig = new_figure(6.5, 4.6)
    ax = fig.add_subplot()
    notes: list[str] = []
    lags: list[float] = []
    for flight, ds in products.items():
        lag = _tke_curve(ax, flight, ds, colours[flight], notes)
        if np.isfinite(lag):
            lags.append(lag)
    if lags:
        x0, x1 = _lag_window(ax, lags, xlim)
    else:
        x0, x1 = xlim
        if not products:
            no_data(ax, "no L2 drone files")
    ax.set_xlim(x0, x1)
    ax.set_ylim(*ylim)
    ax.set_xlabel("lag of the sonic relative to the INS (s)")
    ax.set_ylabel("TKE / min(TKE) (–)")
    ax.grid(alpha=0.3)
    if products:
        legend(ax, fontsize=7.5, ncol=2, loc="upper center")
    return save_figure(fig, out_stem, add_notes(fig, notes))
