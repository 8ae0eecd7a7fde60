r"""Quadrant plot of the spectral ratios :math:`\langle S_w/S_u\rangle` and :math:`\langle S_v/S_u\rangle`.

Drawn from the stored L4 ratios (``Sw_Su``, ``Sv_Su``, averaged over 2 < f z/U < 10 by
the L4 step) and the mast's stored mean speed ``U_ms`` (the colour); Ghirardelli et al. (2025), Fig. 15.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import Colormap, Normalize
from matplotlib.figure import Figure

from dronewind.core.products import L4Products, drone_usable, load_l4_products, stored_scalar
from dronewind.figures.style import (
    UNIT_MS,
    PathLike,
    add_notes,
    new_figure,
    place_labels,
    save_figure,
    status_text,
)

__all__ = ["ISOTROPIC_RATIO", "fig15_quadrant"]

#: Spectral ratio of isotropic turbulence in the inertial subrange (Ghirardelli et al. (2025), Fig. 6).
ISOTROPIC_RATIO = 4.0 / 3.0
#: Panels: (L4 ratio, label).
RATIOS: tuple[tuple[str, str], ...] = (("Sw_Su", "$\\langle S_w/S_u\\rangle$"),
                                      ("Sv_Su", "$\\langle S_v/S_u\\rangle$"))


def _speed_norm(l4: L4Products) -> Normalize:
    """Colour scale over the mast's stored mean speeds [m s-1]."""
    speeds = [stored_scalar(p.get("mast"), "U_ms") for p in l4.values()]
    finite_speeds = [s for s in speeds if np.isfinite(s)]
    return Normalize(vmin=min(finite_speeds, default=0.0), vmax=max(finite_speeds + [1e-3], default=1.0))


def _ratio_points(ax: Axes, l4: L4Products, name: str, norm: Normalize, cmap: Colormap, low_speed_ms: float,
                  notes: list[str]) -> dict[str, tuple[float, float]]:
    """Plot drone against mast ratio ``name`` of every usable flight; return flight -> drawn (mast, drone)."""
    values: dict[str, tuple[float, float]] = {}
    for flight, prod in l4.items():
        usable, reason = drone_usable(prod)
        if not usable:
            if name == "Sw_Su":
                notes.append(f"{flight}: drone record unusable ({reason or 'no reason'}); not drawn.")
            continue
        d, m = prod.get("drone"), prod.get("mast")
        x, y, speed = stored_scalar(m, name), stored_scalar(d, name), stored_scalar(m, "U_ms")
        if not (np.isfinite(x) and np.isfinite(y)):
            notes.append(f"{flight}: {name} not drawn (drone {status_text(d, name)}; "
                         f"mast {status_text(m, name)}).")
            continue
        if np.isfinite(speed) and speed < low_speed_ms:
            ax.plot(x, y, ls="none", marker="^", ms=8, color="0.6", mec="k", mew=0.5)
        else:
            ax.plot(x, y, ls="none", marker="o", ms=8, color=cmap(norm(speed)), mec="k", mew=0.5)
        values[flight] = (x, y)
    return values


def _quadrant_frame(ax: Axes, values: list[float], label: str) -> None:
    """Square limits around the values, the isotropic lines, the 1:1 line and the quadrant names."""
    lo = min(values + [0.5])
    hi = max(values + [2.2])
    lo, hi = lo - 0.05 * (hi - lo), hi + 0.05 * (hi - lo)
    ax.axvline(ISOTROPIC_RATIO, color="k", lw=0.9)
    ax.axhline(ISOTROPIC_RATIO, color="k", lw=0.9)
    ax.plot([lo, hi], [lo, hi], color="0.5", lw=0.6, ls="--")
    ax.set_xlim(lo, hi)
    ax.set_ylim(lo, hi)
    ax.set_aspect("equal", adjustable="box")
    kw: dict[str, Any] = dict(transform=ax.transAxes, fontsize=7, color="0.35")
    ax.text(0.02, 0.98, "drone > 4/3\nmast < 4/3", va="top", ha="left", **kw)
    ax.text(0.98, 0.98, "both > 4/3", va="top", ha="right", **kw)
    ax.text(0.02, 0.02, "both < 4/3", va="bottom", ha="left", **kw)
    ax.text(0.98, 0.02, "drone < 4/3\nmast > 4/3", va="bottom", ha="right", **kw)
    ax.set_xlabel(f"mast {label} (–)")
    ax.set_ylabel(f"drone {label} (–)")
    ax.grid(alpha=0.3)


def _speed_key(fig: Figure, axes: Sequence[Axes], norm: Normalize, cmap: Colormap, low_speed_ms: float) -> None:
    """Colour bar of the mast speed and, outside the panels, the key of the low-wind triangles."""
    from matplotlib.cm import ScalarMappable
    from matplotlib.lines import Line2D

    fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), ax=list(axes), label=f"mast $\\bar u$ ({UNIT_MS})",
                 shrink=0.85)
    key = Line2D([], [], ls="none", marker="^", color="0.6", mec="k",
                 label=f"mast $\\bar u$ < {low_speed_ms:g} {UNIT_MS}")
    fig.legend(handles=[key], loc="outside right lower", fontsize=7, frameon=False)


def fig15_quadrant(l4_files: Iterable[PathLike], out_stem: PathLike, low_speed_ms: float = 2.0) -> list[Path]:
    r"""Fig. 15: quadrant plot of :math:`\langle S_w/S_u\rangle` and :math:`\langle S_v/S_u\rangle`, drone vs mast.

    Parameters
    ----------
    l4_files : iterable of path
        L4 files (``Sw_Su``, ``Sv_Su``, mast ``U_ms``).
    out_stem : str or Path
        Output path without suffix.
    low_speed_ms : float
        Mean speed below which a sample is drawn as a grey triangle [m s-1] (Ghirardelli et al. (2025)
        text: 2 m/s; its caption says 1 m/s).

    Returns
    -------
    list of Path
        PNG and PDF.

    Notes
    -----
    Lines at the isotropic value 4/3 split each panel into quadrants (Ghirardelli et al. (2025), Fig. 6);
    colour = the mast's mean wind speed. L4 stores the ratios as NaN (status
    ``low_wind_speed``) when U is below its ``quadrant_min_speed_ms``: such samples are
    listed in the note, since no value is stored to draw.
    """
    from matplotlib import colormaps

    l4 = load_l4_products(l4_files)
    fig = new_figure(10.5, 4.8)
    axes = fig.subplots(1, 2)
    notes: list[str] = []
    norm = _speed_norm(l4)
    cmap = colormaps["viridis"]
    drawn = []
    for ax, (name, label) in zip(axes, RATIOS, strict=True):
        values = _ratio_points(ax, l4, name, norm, cmap, low_speed_ms, notes)
        _quadrant_frame(ax, [v for xy in values.values() for v in xy], label)
        drawn.append(values)
    _speed_key(fig, axes, norm, cmap, low_speed_ms)
    notes = add_notes(fig, notes)  # the layout is final before the labels are placed
    for ax, values in zip(axes, drawn, strict=True):
        crowded = place_labels(ax, list(values.values()), list(values), marker_size_pt=8.0)
        if crowded:
            ax.set_title(f"not labelled (crowded): {', '.join(crowded)}", fontsize=7, loc="left")
    return save_figure(fig, out_stem, notes)
