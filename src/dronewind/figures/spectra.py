r"""Spectra and co-spectra, drone against mast (Ghirardelli et al. (2025), Figs 9, 11, B1 and B2).

Drawn from the stored L4 spectra (``frequency``; ``S_u``, ``S_v``, ``S_w``, ``S_T``,
``Co_uw``, ``Co_wT``, ``Co_uT`` and the drone's fitted ``*_model``) with the stored
statistics in the titles. Presentation-only arithmetic: the stored spectrum multiplied by
its frequency, and (Figs B1, B2) divided by the stored variance or covariance.

Every figure is a grid with one group of panels (a row, or a column in Fig. 11) per flight,
filled by one loop (:func:`_draw_flights`): a flight without L4 files gets annotated empty
panels, and an unusable drone record is left out and named in the note.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from functools import partial
from pathlib import Path

import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from dronewind.core.products import L4Products, drone_usable, load_l4_products, stored_scalar
from dronewind.figures.style import (
    SENSOR_COLOURS,
    UNIT_KMS,
    UNIT_M2S2,
    UNIT_MS,
    PathLike,
    add_notes,
    chosen_flights,
    figure_legend,
    log_axes,
    new_figure,
    no_data,
    save_figure,
    status_text,
)
from dronewind.tables import default_detail_flights

__all__ = [
    "fig09_velocity_spectra",
    "fig11_temperature_spectra",
    "figB1_normalised_velocity_spectra",
    "figB2_normalised_temperature_spectra",
]

#: Fig. 9 panels: (spectrum, drone model, statistic in the title, y label, log y, title symbol).
VELOCITY_PANELS: tuple[tuple[str, str, str, str, bool, str], ...] = (
    ("S_u", "S_u_model", "sigma_u_ms", f"$fS_u$ ({UNIT_M2S2})", True, "$\\sigma_u$"),
    ("S_v", "S_v_model", "sigma_v_ms", f"$fS_v$ ({UNIT_M2S2})", True, "$\\sigma_v$"),
    ("S_w", "S_w_model", "sigma_w_ms", f"$fS_w$ ({UNIT_M2S2})", True, "$\\sigma_w$"),
    ("Co_uw", "Co_uw_model", "uw_m2s2", f"$f\\,\\mathrm{{Re}}(S_{{uw}})$ ({UNIT_M2S2})", False, "$\\overline{u'w'}$"),
)
#: Fig. 11 panels: (spectrum, y label, log y).
TEMPERATURE_PANELS: tuple[tuple[str, str, bool], ...] = (
    ("S_T", "$fS_{\\theta}$ (K$^2$)", True),
    ("Co_wT", f"$f\\,\\mathrm{{Re}}(S_{{w\\theta_v}})$ ({UNIT_KMS})", False),
    ("Co_uT", f"$f\\,\\mathrm{{Re}}(S_{{u\\theta_v}})$ ({UNIT_KMS})", False),
)
#: Fig. B1 panels: (spectrum, normaliser, y label, log y).
NORMALISED_VELOCITY_PANELS: tuple[tuple[str, str, str, bool], ...] = (
    ("S_u", "sigma_u_ms", "$fS_u/\\sigma_u^2$", True),
    ("S_v", "sigma_v_ms", "$fS_v/\\sigma_v^2$", True),
    ("S_w", "sigma_w_ms", "$fS_w/\\sigma_w^2$", True),
    ("Co_uw", "uw_m2s2", "$f\\,\\mathrm{Re}(S_{uw})/\\overline{u'w'}$", False),
)
#: Fig. B2 panels: (spectrum, normaliser, y label, log y).
NORMALISED_TEMPERATURE_PANELS: tuple[tuple[str, str, str, bool], ...] = (
    ("S_T", "sigma_T_k", "$fS_\\theta/\\sigma_\\theta^2$", True),
    ("Co_wT", "wT_Kms", "$f\\,\\mathrm{Re}(S_{w\\theta_v})/\\overline{w'\\theta_v'}$", False),
    ("Co_uT", "uT_Kms", "$f\\,\\mathrm{Re}(S_{u\\theta_v})/\\overline{u'\\theta_v'}$", False),
)

Products = Mapping[str, xr.Dataset]
#: Draws one flight's panels: (axes, products, drone usable, flight, notes).
FlightDrawer = Callable[[Sequence[Axes], Products, bool, str, list[str]], None]


# ----------------------------------------------------------------------------- the figure loop


def _panel_grid(width_in: float, height_in: float, nrows: int, ncols: int,
                chosen: Sequence[str]) -> tuple[Figure, np.ndarray]:
    """A figure with an ``nrows`` x ``ncols`` array of axes; annotated when no flight is chosen."""
    fig = new_figure(width_in, height_in)
    axes = np.atleast_2d(fig.subplots(nrows, ncols)).reshape(nrows, ncols)
    if not chosen:
        no_data(axes[0, 0], "no L4 files")
    return fig, axes


def _draw_flights(groups: Iterable[Sequence[Axes]], l4: L4Products, chosen: Sequence[str], notes: list[str],
                  draw: FlightDrawer) -> None:
    """One group of panels per chosen flight: empty with a note without L4 files, else ``draw``."""
    for axes, flight in zip(groups, chosen, strict=False):
        prod = l4.get(flight)
        if prod is None:
            for ax in axes:
                no_data(ax, f"{flight}: no L4 files")
            notes.append(f"{flight}: no L4 files.")
            continue
        usable, reason = drone_usable(prod)
        if not usable:
            notes.append(f"{flight}: drone record unusable ({reason or 'no reason'}); only the mast is drawn.")
        draw(axes, prod, usable, flight, notes)


def _other_flights(l4: L4Products, flights: Sequence[str] | None) -> list[str]:
    """Flights of the appendix figures: those asked for, else all but the detailed ones (all if none is left)."""
    if flights is not None:
        return list(flights)
    detail = set(default_detail_flights(list(l4)))
    rest = [f for f in l4 if f not in detail]
    return rest if rest else list(l4)


# ----------------------------------------------------------------------------- panels


def _spectrum(ds: xr.Dataset, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Stored frequency [Hz] and spectrum (NaN when not stored)."""
    f = np.asarray(ds["frequency"].values, dtype=float)
    s = np.asarray(ds[name].values, dtype=float) if name in ds.variables else np.full_like(f, np.nan)
    return f, s


def _finish_spectral_axes(ax: Axes, log_y: bool, drawn: bool) -> None:
    """Log frequency axis; log y, or a zero line for co-spectra; a note when nothing was drawn."""
    log_axes(ax, log_y=log_y)
    if not log_y:
        ax.axhline(0.0, color="0.5", lw=0.6)
    ax.grid(alpha=0.3, which="both")
    if not drawn:
        no_data(ax, "not available")


def _model_curve(ax: Axes, ds: xr.Dataset, model: str, log_y: bool, flight: str, notes: list[str]) -> None:
    """The fitted model stored with the drone spectrum (black), or a note with its fit status."""
    fm, m = _spectrum(ds, model)
    if np.any(np.isfinite(m)):
        ym = fm * m
        ax.plot(fm, np.where(ym > 0, ym, np.nan) if log_y else ym, color="k", lw=1.2, label="drone fit")
    else:
        comp = model.split("_")[1] if model.startswith("S_") else "uw"
        notes.append(f"{flight}: no fitted model for {comp} ({status_text(ds, f'fit_{comp}')}).")


def _spectral_panel(ax: Axes, prod: Products, name: str, *, log_y: bool, usable: bool, notes: list[str],
                    flight: str, normaliser: str | None = None, model: str | None = None,
                    status: str = "spectra") -> None:
    """Plot f*S (optionally / a stored variance or covariance) for drone and mast."""
    drawn = False
    for sensor, colour in SENSOR_COLOURS:
        ds = prod.get(sensor)
        if ds is None or (sensor == "drone" and not usable):
            continue
        f, s = _spectrum(ds, name)
        y = f * s
        if normaliser is not None:
            norm = stored_scalar(ds, normaliser)
            if not np.isfinite(norm) or norm == 0:
                notes.append(f"{flight} {sensor}: {normaliser} NaN or zero; normalised {name} not drawn.")
                continue
            y = y / norm
        if not np.any(np.isfinite(y)):
            notes.append(f"{flight} {sensor}: {name} not available ({status_text(ds, status)}).")
            continue
        if log_y:
            y = np.where(y > 0, y, np.nan)
        ax.plot(f, y, color=colour, lw=1.0, label=sensor)
        drawn = True
        if model and sensor == "drone":
            _model_curve(ax, ds, model, log_y, flight, notes)
    _finish_spectral_axes(ax, log_y, drawn)


def _normalised_panel(ax: Axes, prod: Products, name: str, norm: str, log_y: bool, usable: bool,
                      notes: list[str], flight: str) -> None:
    """Plot f*S / (stored sigma squared, or stored covariance) for drone and mast."""
    squared = norm.startswith("sigma_")
    drawn = False
    for sensor, colour in SENSOR_COLOURS:
        ds = prod.get(sensor)
        if ds is None or (sensor == "drone" and not usable):
            continue
        value = stored_scalar(ds, norm)
        value = value**2 if squared else value
        f, s = _spectrum(ds, name)
        if not np.isfinite(value) or value == 0 or not np.any(np.isfinite(s)):
            notes.append(f"{flight} {sensor}: normalised {name} not available "
                         f"({status_text(ds, 'spectra') if not np.any(np.isfinite(s)) else norm + ' NaN or zero'}).")
            continue
        y = f * s / value
        ax.plot(f, np.where(y > 0, y, np.nan) if log_y else y, color=colour, lw=1.0, label=sensor)
        drawn = True
    _finish_spectral_axes(ax, log_y, drawn)


def _fmt_value(value: float, fmt: str) -> str:
    """``fmt`` applied to a finite value, "–" otherwise."""
    return fmt.format(value) if np.isfinite(value) else "–"


def _fmt_pair(prod: Products, name: str, usable: bool, fmt: str = "{:.2f}") -> str:
    """``"drone <value>, mast <value>"`` of a stored statistic ("–" where NaN or unusable)."""
    d = stored_scalar(prod.get("drone"), name) if usable else math.nan
    m = stored_scalar(prod.get("mast"), name)
    return f"drone {_fmt_value(d, fmt)}, mast {_fmt_value(m, fmt)}"


# ----------------------------------------------------------------------------- Fig. 9


def _velocity_spectra_row(row: Sequence[Axes], prod: Products, usable: bool, flight: str, notes: list[str]) -> None:
    """One flight of Fig. 9: u, v, w spectra and the uw co-spectrum with the drone's fitted model."""
    for ax, (name, model, stat, ylabel, log_y, sym) in zip(row, VELOCITY_PANELS, strict=True):
        _spectral_panel(ax, prod, name, log_y=log_y, usable=usable, notes=notes, flight=flight, model=model)
        unit = UNIT_M2S2 if stat == "uw_m2s2" else UNIT_MS
        ax.set_title(f"{flight}: {sym} {_fmt_pair(prod, stat, usable, '{:.3f}' if stat == 'uw_m2s2' else '{:.2f}')}"
                     f" {unit}", fontsize=8, loc="left")
        ax.set_xlabel("f (Hz)")
        ax.set_ylabel(ylabel)


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
    information). The black line is the model fitted to the drone (Ghirardelli et al. (2025), Eqs 4-7:
    blunt for u, v and uw, pointed for w) as stored in L4.
    """
    l4 = load_l4_products(l4_files)
    chosen = chosen_flights(flights, list(l4))
    nrow = max(1, len(chosen))
    fig, axes = _panel_grid(13.0, 3.1 * nrow + 0.3, nrow, 4, chosen)
    notes: list[str] = []
    _draw_flights(axes, l4, chosen, notes, _velocity_spectra_row)
    figure_legend(fig)
    return save_figure(fig, out_stem, add_notes(fig, notes))


# ----------------------------------------------------------------------------- Fig. 11


def _temperature_spectra_column(col: Sequence[Axes], prod: Products, usable: bool, flight: str,
                                notes: list[str]) -> None:
    """One flight of Fig. 11: temperature spectrum, w-theta and u-theta co-spectra."""
    z = stored_scalar(prod.get("mast"), "height_m")
    for ax, (name, ylabel, log_y) in zip(col, TEMPERATURE_PANELS, strict=True):
        _spectral_panel(ax, prod, name, log_y=log_y, usable=usable, notes=notes, flight=flight,
                        status="temperature")
        ax.set_ylabel(ylabel)
        ax.set_xlabel("f (Hz)")
    col[0].set_title(f"{flight}: mast z = {z:.0f} m; $\\sigma_\\theta$ "
                     f"{_fmt_pair(prod, 'sigma_T_k', usable)} K", fontsize=8, loc="left")
    col[1].set_title(f"$\\overline{{w'\\theta_v'}}$ {_fmt_pair(prod, 'wT_Kms', usable, '{:.3f}')} {UNIT_KMS}",
                     fontsize=8, loc="left")
    col[2].set_title(f"$\\overline{{u'\\theta_v'}}$ {_fmt_pair(prod, 'uT_Kms', usable, '{:.3f}')} {UNIT_KMS}",
                     fontsize=8, loc="left")


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
    chosen = chosen_flights(flights, list(l4))
    ncol = max(1, len(chosen))
    fig, axes = _panel_grid(5.0 * ncol, 8.0, 3, ncol, chosen)
    notes: list[str] = []
    _draw_flights(axes.T, l4, chosen, notes, _temperature_spectra_column)
    figure_legend(fig)
    return save_figure(fig, out_stem, add_notes(fig, notes))


# ----------------------------------------------------------------------------- Figs B1, B2


def _normalised_spectra_row(panels: Sequence[tuple[str, str, str, bool]], row: Sequence[Axes], prod: Products,
                            usable: bool, flight: str, notes: list[str]) -> None:
    """One flight of Fig. B1 or B2: the normalised spectra of ``panels``."""
    for ax, (name, norm, ylabel, log_y) in zip(row, panels, strict=True):
        _normalised_panel(ax, prod, name, norm, log_y, usable, notes, flight)
        ax.set_ylabel(f"{ylabel} (–)")
        ax.set_xlabel("f (Hz)")
    row[0].set_title(flight, fontsize=9, loc="left")


def _normalised_spectra_figure(l4_files: Iterable[PathLike], out_stem: PathLike, flights: Sequence[str] | None,
                               panels: Sequence[tuple[str, str, str, bool]], width_in: float) -> list[Path]:
    """One row of normalised spectra per flight (Figs B1 and B2), panels as given."""
    l4 = load_l4_products(l4_files)
    chosen = _other_flights(l4, flights)
    nrow = max(1, len(chosen))
    fig, axes = _panel_grid(width_in, 2.5 * nrow + 0.4, nrow, len(panels), chosen)
    notes: list[str] = []
    _draw_flights(axes, l4, chosen, notes, partial(_normalised_spectra_row, panels))
    figure_legend(fig)
    return save_figure(fig, out_stem, add_notes(fig, notes))


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
    Normalisers are the stored ``sigma_*_ms`` squared and ``uw_m2s2`` (Ghirardelli et al. (2025),
    Appendix B: "normalised by the variance or covariance").
    """
    return _normalised_spectra_figure(l4_files, out_stem, flights, NORMALISED_VELOCITY_PANELS, 13.0)


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
    return _normalised_spectra_figure(l4_files, out_stem, flights, NORMALISED_TEMPERATURE_PANELS, 11.0)
