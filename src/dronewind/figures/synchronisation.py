r"""Sonic-INS synchronisation: TKE of the motion-corrected wind against the lag (Ghirardelli et al. (2025), Fig. 4).

Drawn from the stored L2 drone files: the TKE-vs-lag curve (``lag_s``, ``tke_m2s2``) and
the lag found (attribute ``lag_sonic_ins_s``). The only arithmetic is the normalisation
of each stored curve by its minimum.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np
import xarray as xr
from matplotlib.axes import Axes

from dronewind.core.products import open_by_flight
from dronewind.figures.style import (
    UNUSABLE_COLOUR,
    PathLike,
    add_notes,
    flight_colours,
    new_figure,
    no_data,
    save_figure,
)

__all__ = ["fig04_tke_lag"]


class _Curve(NamedTuple):
    """A drawn TKE curve: lags [s], TKE / min(TKE) [-], the stored lag [s] (NaN if not counted for the window)."""

    lag_s: np.ndarray
    norm: np.ndarray
    stored_lag_s: float


def _tke_curve(ax: Axes, flight: str, ds: xr.Dataset, colour: object, notes: list[str]) -> _Curve | None:
    """Draw one flight's normalised TKE curve and mark its minimum; None when nothing is stored."""
    if "tke_m2s2" not in ds.variables:
        notes.append(f"{flight}: no TKE-vs-lag curve stored.")
        return None
    tke = np.asarray(ds["tke_m2s2"].values, dtype=float)
    lag = np.asarray(ds["lag_s"].values if "lag_s" in ds.variables else ds["lag"].values, dtype=float)
    finite = np.isfinite(tke) & (tke > 0)
    if not finite.any():
        notes.append(f"{flight}: TKE curve all NaN.")
        return None
    norm = tke / np.min(tke[finite])
    k = int(np.nanargmin(np.where(finite, norm, np.nan)))
    stored = float(ds.attrs.get("lag_sonic_ins_s", math.nan))
    if bool(int(ds.attrs.get("usable", 1))):
        ax.plot(lag, norm, color=colour, lw=1.4, label=f"{flight} (lag {stored:+.3f} s)")
        ax.plot(lag[k], norm[k], ls="none", marker="o", ms=4, color=colour, mec="k", mew=0.4)
        return _Curve(lag, norm, stored)
    ax.plot(lag, norm, color=UNUSABLE_COLOUR, lw=1.0, ls="--", label=f"{flight} (unusable)")
    ax.plot(lag[k], norm[k], ls="none", marker="o", ms=4, color=UNUSABLE_COLOUR, mec="k", mew=0.4)
    notes.append(f"{flight}: drone record unusable ({ds.attrs.get('unusable_reason', '') or 'no reason'}); "
                 "curve grey, lag not used for the window.")
    return _Curve(lag, norm, math.nan)


def _y_top(curves: Sequence[_Curve], x0: float, x1: float, top: float, margin_s: float = 0.1) -> float:
    """Upper y limit: at least ``top``, and high enough that every curve is seen around its minimum.

    Around its minimum means within ``margin_s`` of the lag at the minimum (and inside the
    x range), so that no flight's curve is cut off by the limit; capped at 2.
    """
    highest = top
    for c in curves:
        k = int(np.nanargmin(c.norm))
        near = (np.abs(c.lag_s - c.lag_s[k]) <= margin_s) & (c.lag_s >= x0) & (c.lag_s <= x1)
        if near.any():
            highest = max(highest, float(np.nanmax(c.norm[near])))
    return min(2.0, 1.0 + 1.05 * (highest - 1.0))


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
        Axis limits (Ghirardelli et al. (2025): -1 to 1 s and 1 to 1.1); the x range widens
        to include every stored lag, the y range so that every curve is seen within 0.1 s of
        its minimum (marked with a dot).

    Returns
    -------
    list of Path
        PNG and PDF.

    Notes
    -----
    Vertical lines at the smallest (dashed) and largest (dash-dot) stored
    ``lag_sonic_ins_s`` of the usable flights: the window holding all minima (Ghirardelli
    et al. (2025), Sect. 3.3: -0.185 s to 0 s). The legend, with each flight's stored lag,
    is outside the axes.
    """
    products = open_by_flight(l2_drone_files)
    colours = flight_colours(list(products))
    fig = new_figure(8.0, 4.6)
    ax = fig.add_subplot()
    notes: list[str] = []
    curves = [c for flight, ds in products.items()
              if (c := _tke_curve(ax, flight, ds, colours[flight], notes)) is not None]
    lags = [c.stored_lag_s for c in curves if np.isfinite(c.stored_lag_s)]
    if lags:
        x0, x1 = _lag_window(ax, lags, xlim)
    else:
        x0, x1 = xlim
        if not products:
            no_data(ax, "no L2 drone files")
    ax.set_xlim(x0, x1)
    top = _y_top(curves, x0, x1, ylim[1])
    ax.set_ylim(ylim[0] - 0.02 * (top - ylim[0]), top)  # the minima (= 1) sit just above the axis
    ax.set_xlabel("lag of the sonic relative to the INS (s)")
    ax.set_ylabel("TKE / min(TKE) (–)")
    ax.grid(alpha=0.3)
    if products and ax.get_legend_handles_labels()[0]:
        fig.legend(loc="outside right upper", fontsize=7.5, frameon=False)
    return save_figure(fig, out_stem, add_notes(fig, notes))
