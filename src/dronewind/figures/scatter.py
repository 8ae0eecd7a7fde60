"""Drone (y) against mast (x) scatter panels of stored L4 statistics (Ghirardelli et al. (2025), Figs 12-14, 16).

One colour per flight, one marker per reference height; a flight whose drone record is
unusable, or a value that is NaN in the product, is left out and named in the note with
the stored status that explains it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from dronewind.core.products import L4Products, drone_usable, load_l4_products, stored_scalar
from dronewind.figures.style import (
    HEIGHT_MARKERS,
    PathLike,
    add_notes,
    flight_colours,
    new_figure,
    no_data,
    save_figure,
    status_text,
)

__all__ = ["Quantity", "scatter_figure", "scatter_legend", "scatter_panels", "symlog_ticks"]

#: A quantity of a scatter panel: (L4 variable, label, unit).
Quantity = tuple[str, str, str]


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


def _height_markers(l4: L4Products) -> dict[float, str]:
    """One marker per stored reference (mast) height, lowest first."""
    heights = sorted({h for prod in l4.values() for h in [stored_scalar(prod.get("mast"), "height_m")]
                      if np.isfinite(h)})
    return {h: HEIGHT_MARKERS[i % len(HEIGHT_MARKERS)] for i, h in enumerate(heights)}


def _scatter_points(ax: Axes, l4: L4Products, name: str, notes: list[str],
                    skipped_unusable: set[str]) -> tuple[list[float], list[float]]:
    """Plot the stored ``name`` of every usable flight, drone against mast; return the drawn x and y."""
    colours = flight_colours(list(l4))
    markers = _height_markers(l4)
    xs, ys = [], []
    for flight, prod in l4.items():
        usable, reason = drone_usable(prod)
        if not usable:
            if flight not in skipped_unusable:
                notes.append(f"{flight}: drone record unusable ({reason or 'no reason'}); not drawn.")
                skipped_unusable.add(flight)
            continue
        d, m = prod.get("drone"), prod.get("mast")
        x, y = stored_scalar(m, name), stored_scalar(d, name)
        if not (np.isfinite(x) and np.isfinite(y)):
            why = []
            if not np.isfinite(y):
                why.append(f"drone {status_text(d, _status_name(name))}")
            if not np.isfinite(x):
                why.append(f"mast {status_text(m, _status_name(name))}")
            notes.append(f"{flight}: {name} not drawn ({'; '.join(why)}).")
            continue
        h = stored_scalar(m, "height_m")
        ax.plot(x, y, ls="none", marker=markers.get(h, "o"), ms=7, color=colours[flight], mec="k", mew=0.5)
        xs.append(x)
        ys.append(y)
    return xs, ys


def symlog_ticks(limit: float, linthresh: float, max_ticks: int = 5) -> list[float]:
    """Ticks of a symmetric-log axis from ``-limit`` to ``limit``: 0 and every n-th decade beyond ``linthresh``.

    Parameters
    ----------
    limit : float
        Largest absolute value on the axis.
    linthresh : float
        Half-width of the linear region (a power of ten).
    max_ticks : int
        Most ticks (the decades are thinned, symmetrically, until they fit).

    Returns
    -------
    list of float
        Tick positions, ascending.
    """
    k0 = round(math.log10(linthresh))
    k1 = math.floor(math.log10(max(limit, linthresh)))
    decades = list(range(k0, k1 + 1))
    step = 1
    while 1 + 2 * len(decades[::step]) > max_ticks and step < len(decades):
        step += 1
    kept = decades[::-1][::step][::-1]  # keep the largest decade
    return sorted([0.0] + [10.0 ** k for k in kept] + [-(10.0 ** k) for k in kept])


def _decade_label(value: float, _pos: int | None = None) -> str:
    """``0``, ``$10^{3}$`` or ``$-10^{3}$``."""
    if value == 0:
        return "0"
    k = round(math.log10(abs(value)))
    return f"${'-' if value < 0 else ''}10^{{{k}}}$"


def _symlog_limits(ax: Axes, values: list[float]) -> None:
    """Symmetric-log scales, limits padded in the transformed (drawn) space, decade ticks."""
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullLocator

    lin = max(1.0, 10 ** math.floor(math.log10(max(min(abs(v) for v in values), 1e-9))))
    ax.set_xscale("symlog", linthresh=lin)
    ax.set_yscale("symlog", linthresh=lin)
    trans = ax.xaxis.get_transform()
    t = trans.transform(np.asarray(values, dtype=float))
    lo, hi = float(np.min(t)), float(np.max(t))
    pad = 0.08 * (hi - lo) if hi > lo else 0.5
    lo_v, hi_v = trans.inverted().transform(np.array([lo - pad, hi + pad]))
    ax.set_xlim(lo_v, hi_v)
    ax.set_ylim(lo_v, hi_v)
    ticks = [v for v in symlog_ticks(max(abs(lo_v), abs(hi_v)), lin) if lo_v <= v <= hi_v]
    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_locator(FixedLocator(ticks))
        axis.set_major_formatter(FuncFormatter(_decade_label))
        axis.set_minor_locator(NullLocator())


def _square_limits(ax: Axes, name: str, values: list[float], symlog: Sequence[str], one_to_one: bool) -> None:
    """Equal padded x and y limits around the drawn values, the 1:1 line, symmetric-log scales if asked."""
    from matplotlib.ticker import MaxNLocator

    if name in symlog:
        _symlog_limits(ax, values)
        lo, hi = ax.get_xlim()
    else:
        lo, hi = min(values), max(values)
        pad = 0.08 * (hi - lo) if hi > lo else max(abs(hi) * 0.1, 1e-3)
        lo, hi = lo - pad, hi + pad
        if lo > 0 and lo < 0.3 * hi:
            lo = 0.0
        ax.set_xlim(lo, hi)
        ax.set_ylim(lo, hi)
        ax.xaxis.set_major_locator(MaxNLocator(nbins=4))  # tick labels never run into each other
        ax.yaxis.set_major_locator(MaxNLocator(nbins=5))
    if one_to_one:
        ax.plot([lo, hi], [lo, hi], color="k", lw=0.8, ls="--", scalex=False, scaley=False)


def scatter_panels(l4: L4Products, axes: Iterable[Axes], quantities: Sequence[Quantity], notes: list[str],
                   symlog: Sequence[str] = (), one_to_one: bool = True) -> None:
    """Drone (y) vs mast (x) for each quantity, one colour per flight, markers per reference height.

    Parameters
    ----------
    l4 : dict
        L4 products (:func:`dronewind.core.products.load_l4_products`).
    axes : iterable of Axes
        One panel per quantity.
    quantities : sequence of (str, str, str)
        L4 variable, label and unit of each panel.
    notes : list of str
        Receives what was not drawn, and why.
    symlog : sequence of str
        Variables drawn on symmetric-log axes (they change sign).
    one_to_one : bool
        Draw the dashed 1:1 line.
    """
    skipped_unusable: set[str] = set()
    for ax, (name, label, unit) in zip(axes, quantities, strict=False):
        xs, ys = _scatter_points(ax, l4, name, notes, skipped_unusable)
        if xs:
            _square_limits(ax, name, xs + ys, symlog, one_to_one)
        else:
            no_data(ax, f"no finite {name}")
        ax.set_xlabel(f"mast {label} ({unit})")
        ax.set_ylabel(f"drone {label} ({unit})")
        ax.grid(alpha=0.3)
        ax.set_aspect("equal", adjustable="box")


def scatter_legend(fig: Figure, l4: L4Products) -> None:
    """Figure legend right of the panels: flights (colours), reference heights (markers), 1:1 line."""
    colours = flight_colours(list(l4))
    markers = _height_markers(l4)
    handles: list[Any] = [Line2D([], [], ls="none", marker="o", color=colours[f], mec="k", mew=0.5,
                                 label=f if drone_usable(p)[0] else f"{f} (unusable, not drawn)")
                          for f, p in l4.items()]
    handles += [Line2D([], [], ls="none", marker=mk, color="w", mec="k", label=f"reference {h:g} m")
                for h, mk in markers.items()]
    handles.append(Line2D([], [], color="k", ls="--", lw=0.8, label="1:1"))
    if handles:
        fig.legend(handles=handles, loc="outside right upper", fontsize=7.5, frameon=False)


def scatter_figure(l4_files: Iterable[PathLike], out_stem: PathLike, quantities: Sequence[Quantity],
                   ncols: int, symlog: Sequence[str] = (), panel_in: float = 3.3) -> list[Path]:
    """A grid of lettered drone-vs-mast panels, one per quantity, with the figure legend.

    Parameters
    ----------
    l4_files : iterable of path
        L4 files.
    out_stem : str or Path
        Output path without suffix.
    quantities : sequence of (str, str, str)
        L4 variable, label and unit of each panel.
    ncols : int
        Panels per row.
    symlog : sequence of str
        Variables on symmetric-log axes.
    panel_in : float
        Panel size [inch].

    Returns
    -------
    list of Path
        PNG and PDF.
    """
    l4 = load_l4_products(l4_files)
    nrows = math.ceil(len(quantities) / ncols)
    fig = new_figure(panel_in * ncols + 1.4, panel_in * nrows + 0.2)
    axes = np.atleast_1d(fig.subplots(nrows, ncols)).ravel()
    notes: list[str] = []
    scatter_panels(l4, axes, quantities, notes, symlog)
    for ax, letter in zip(axes, "abcdefgh", strict=False):
        ax.set_title(f"({letter})", fontsize=9, loc="left")
    scatter_legend(fig, l4)
    return save_figure(fig, out_stem, add_notes(fig, notes))
