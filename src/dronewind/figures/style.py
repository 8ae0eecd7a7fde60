"""The look shared by the campaign figures: canvas, colours, unit labels, notes, saving.

Every figure is built on :func:`new_figure` (fixed size and resolution, Agg canvas, no
pyplot global state) and written by :func:`save_figure` as ``<out_stem>.png`` and
``<out_stem>.pdf`` (atomic rename, no time stamps in the metadata, so identical inputs give
identical bytes). What a figure leaves out is never dropped silently: :func:`add_notes`
lists it below the axes with the stored reason (:func:`status_text`).
"""

from __future__ import annotations

import math
import os
import tempfile
import textwrap
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.layout_engine import ConstrainedLayoutEngine
from matplotlib.text import Text
from matplotlib.ticker import LogLocator
from matplotlib.transforms import Bbox

from dronewind.core.qc import STATUS_FLAG_MEANINGS
from dronewind.figures.labels import HEIGHT_MARKERS, PAPERS, REFERENCES, PathLike
from dronewind.tables import default_detail_flights

__all__ = [
    "DPI", "DRONE_COLOUR", "HEIGHT_MARKERS", "LOG_MINOR_SUBS", "MAST_COLOUR", "PAPERS", "REFERENCES",
    "SENSOR_COLOURS", "UNIT_KMS", "UNIT_M2S2", "UNIT_MS", "UNUSABLE_COLOUR", "PathLike", "add_notes",
    "chosen_flights", "figure_legend", "flight_colours", "legend", "log_axes", "minutes", "new_figure", "no_data",
    "panel_letters",
    "place_labels", "save_figure", "start_label", "status_text",
]

#: Resolution of the PNG files [dots per inch]; the pixel size is figsize x DPI.
DPI = 120
DRONE_COLOUR = "tab:blue"
MAST_COLOUR = "tab:orange"
UNUSABLE_COLOUR = "0.6"
#: Sensors in drawing order with their colours (drone first, so the mast is drawn on top).
SENSOR_COLOURS: tuple[tuple[str, str], ...] = (("drone", DRONE_COLOUR), ("mast", MAST_COLOUR))

#: Units in axis labels and titles (matplotlib mathtext), one spelling for every figure.
UNIT_MS = "m s$^{-1}$"
UNIT_M2S2 = "m$^2$ s$^{-2}$"
UNIT_KMS = "K m s$^{-1}$"

# ----------------------------------------------------------------------------- canvas and output


def new_figure(width_in: float, height_in: float) -> Figure:
    """An empty figure of fixed size on the Agg canvas, with constrained layout.

    Parameters
    ----------
    width_in, height_in : float
        Size [inch]; the PNG has ``width_in * DPI`` x ``height_in * DPI`` pixels.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = Figure(figsize=(width_in, height_in), dpi=DPI)
    FigureCanvasAgg(fig)
    fig.set_layout_engine(ConstrainedLayoutEngine(h_pad=0.04, w_pad=0.04))
    return fig


def add_notes(fig: Figure, notes: Sequence[str]) -> list[str]:
    """List what was skipped (and why) below the axes; reserve room in the layout.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        Figure made by :func:`new_figure`.
    notes : sequence of str
        One sentence per skipped item; empty strings and repeats are dropped.

    Returns
    -------
    list of str
        The de-duplicated notes (also stored in the file metadata by :func:`save_figure`).
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
    engine = fig.get_layout_engine()
    if isinstance(engine, ConstrainedLayoutEngine):
        engine.set(rect=(0.0, frac, 1.0, 1.0 - frac))
    fig.text(0.01, frac - 0.02 / height_in, "\n".join(lines), ha="left", va="top", fontsize=7.5, color="0.25",
             family="DejaVu Sans")
    return notes


def save_figure(fig: Figure, out_stem: PathLike, notes: Sequence[str] = ()) -> list[Path]:
    """Write PNG and PDF atomically, without time stamps.

    The notes (what was skipped and why) also go into the metadata: PNG text chunk
    ``Description``, PDF ``Subject``; "none" when nothing was skipped.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The drawn figure.
    out_stem : str or Path
        Output path without suffix (folders are created).
    notes : sequence of str
        What was skipped, for the metadata.

    Returns
    -------
    list of Path
        The PNG and the PDF.
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
            if ext == ".png":
                # The PDF takes the positions the layout engine found for the PNG: laying out a
                # figure of many panels again was a fifth of the figure step's time.
                fig.set_layout_engine("none")
            os.chmod(tmp, 0o644)  # mkstemp creates 0600; figures are ordinary readable files
            os.replace(tmp, target)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
        paths.append(target)
    return paths


# ----------------------------------------------------------------------------- panels


#: Minor ticks (and grid lines) of log axes: at 2 and 5 times each power of ten. The default
#: (2, 3, ..., 9) makes four times as many tick artists; laying them out and drawing them was
#: 45 % of the figures step's CPU (Figs 9, 11, B1 and B2 have 12-32 log-log panels).
LOG_MINOR_SUBS: tuple[float, ...] = (2.0, 5.0)


def log_axes(ax: Axes, log_y: bool = True) -> None:
    """Log x (and y) scale with minor ticks at :data:`LOG_MINOR_SUBS` times each power of ten."""
    ax.set_xscale("log")
    ax.xaxis.set_minor_locator(LogLocator(subs=LOG_MINOR_SUBS))
    if log_y:
        ax.set_yscale("log")
        ax.yaxis.set_minor_locator(LogLocator(subs=LOG_MINOR_SUBS))


def legend(ax: Axes, **kwargs: Any) -> None:
    """Legend above the axes, right-aligned, one row: it never covers data (only when something is labelled).

    ``loc`` and ``ncol`` given by a caller are ignored; other keyword arguments (font size)
    pass through. Titles drawn at the left of the same axes stay clear of it.
    """
    handles, labels = ax.get_legend_handles_labels()
    if handles:
        kwargs.pop("loc", None)
        kwargs.pop("ncol", None)
        ax.legend(handles, labels, loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=len(handles),
                  borderaxespad=0.2, frameon=False, columnspacing=1.0, handlelength=1.5, **kwargs)


def panel_letters(fig: Figure, fontsize: float = 9.0) -> None:
    """Letter the panels (a), (b), ... at the top left, outside the axes, when a figure has more than one.

    Axes without a visible frame (legend or colour-bar holders) are not lettered.
    """
    axes = [ax for ax in fig.axes if ax.get_visible() and ax.axison and ax.get_label() != "<colorbar>"]
    if len(axes) < 2:
        return
    for k, ax in enumerate(axes):
        ax.annotate(f"({chr(ord('a') + k)})", xy=(0.0, 1.0), xycoords="axes fraction", xytext=(-4, 4),
                    textcoords="offset points", ha="right", va="bottom", fontsize=fontsize, fontweight="bold")


def figure_legend(fig: Figure) -> None:
    """One legend for the whole figure, above the panels: every label drawn in any axes, once."""
    seen: dict[str, Any] = {}
    for ax in fig.axes:
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            seen.setdefault(label, handle)
    if seen:
        fig.legend(list(seen.values()), list(seen), loc="outside upper center", ncol=len(seen), fontsize=7.5,
                   frameon=False)


def _overlaps(box: Bbox, others: Sequence[Bbox]) -> bool:
    return any(box.overlaps(o) for o in others)


#: Offsets tried for a point label [points], nearest first; the last ring gets a leader line.
_LABEL_OFFSETS: tuple[tuple[float, float], ...] = (
    (5, 5), (5, -5), (-5, 5), (-5, -5), (7, 0), (-7, 0), (0, 8), (0, -8),
    (12, 12), (12, -12), (-12, 12), (-12, -12), (16, 0), (-16, 0), (0, 16), (0, -16),
)
_LEADER_RADII_PT = (22.0, 32.0, 44.0)


def place_labels(ax: Axes, points: Sequence[tuple[float, float]], texts: Sequence[str],
                 marker_size_pt: float = 8.0, fontsize: float = 7.0) -> list[str]:
    """Label data points without any label overlapping another label, a marker or the axes edge.

    Each label is tried at offsets around its point, nearest first, then further out with a
    thin leader line; the first position whose text box (display coordinates, after the
    layout) lies inside the axes and clear of every marker and every label placed so far is
    kept; texts already in the axes are kept clear too. The figure is drawn once first, so
    the layout (and hence the data-to-display transform) is final when boxes are measured.

    Parameters
    ----------
    ax : Axes
        Axes holding the points (limits already set).
    points : sequence of (float, float)
        Data coordinates of the labelled points.
    texts : sequence of str
        One label per point.
    marker_size_pt : float
        Marker size of the points [points]; their boxes are kept clear.
    fontsize : float
        Label size [points].

    Returns
    -------
    list of str
        Labels that found no free place (not drawn; the caller names them elsewhere).
    """
    fig = ax.get_figure()
    assert fig is not None
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    scale = fig.dpi / 72.0
    frame = ax.get_window_extent(renderer)
    half = 0.5 * marker_size_pt * scale
    xy = ax.transData.transform(np.asarray(points, dtype=float).reshape(-1, 2)) if len(points) else np.empty((0, 2))
    taken = [Bbox.from_extents(x - half, y - half, x + half, y + half) for x, y in xy]
    taken += [Text.get_window_extent(t, renderer) for t in ax.texts if t.get_visible() and t.get_text()]
    rings = [(dx, dy, False) for dx, dy in _LABEL_OFFSETS]
    for r in _LEADER_RADII_PT:
        rings += [(r * math.cos(a), r * math.sin(a), True) for a in np.radians(np.arange(0, 360, 30))]
    unplaced = []
    for point, text in zip(points, texts, strict=True):
        for dx, dy, leader in rings:
            ann = ax.annotate(text, point, xytext=(dx, dy), textcoords="offset points", fontsize=fontsize,
                              ha="left" if dx > 0 else "right" if dx < 0 else "center",
                              va="bottom" if dy > 0 else "top" if dy < 0 else "center",
                              arrowprops={"arrowstyle": "-", "lw": 0.5, "color": "0.4", "shrinkA": 0,
                                          "shrinkB": 3} if leader else None)
            ann.update_positions(renderer)
            box = Text.get_window_extent(ann, renderer)  # the text only, without its leader line
            if frame.contains(box.x0, box.y0) and frame.contains(box.x1, box.y1) and not _overlaps(box, taken):
                taken.append(box)
                break
            ann.remove()
        else:
            unplaced.append(text)
    return unplaced


def no_data(ax: Axes, text: str) -> None:
    """Write ``text`` in the middle of an empty panel and remove its ticks."""
    ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes, fontsize=9, color="0.3", wrap=True)
    ax.set_xticks([])
    ax.set_yticks([])


def flight_colours(flights: Sequence[str]) -> dict[str, Any]:
    """One colour per flight (``tab10``, ``tab20`` above ten flights), in sorted flight order."""
    from matplotlib import colormaps

    cmap = colormaps["tab10"] if len(flights) <= 10 else colormaps["tab20"]
    return {f: cmap(i % cmap.N) for i, f in enumerate(sorted(flights))}


def chosen_flights(flights: Sequence[str] | None, available: Sequence[str]) -> list[str]:
    """The flights drawn in detail: those asked for, else the first and seventh available."""
    return list(flights) if flights is not None else default_detail_flights(list(available))


def minutes(time: np.ndarray) -> np.ndarray:
    """Time axis in minutes since the first sample [min]."""
    t = np.asarray(time).astype("datetime64[ns]")
    return (t - t[0]) / np.timedelta64(60, "s")


def start_label(time: np.ndarray) -> str:
    """The first time stamp as ``YYYY-MM-DD hh:mm:ss`` (for axis labels)."""
    t0 = np.datetime64(np.asarray(time)[0], "s")
    return str(np.datetime_as_string(t0, unit="s")).replace("T", " ")


# ----------------------------------------------------------------------------- notes


def status_text(ds: xr.Dataset | None, status: str) -> str:
    """Why a stored quantity is NaN: the meaning and reason of its ``status_<status>`` flag.

    Parameters
    ----------
    ds : xarray.Dataset or None
        The L4 product (None when missing).
    status : str
        Status name (the flag variable is ``status_<status>``).

    Returns
    -------
    str
        Flag meaning and stored reason, or why none is available.
    """
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
