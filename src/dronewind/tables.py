r"""Campaign tables drawn from stored L4 products (Ghirardelli et al. (2025), Tables 4 and 5).

Every number in these tables is read from the L4 NetCDF files written by
:func:`dronewind.steps.l4` (read with :func:`dronewind.core.products.load_l4_products`);
nothing is recomputed. The only derived item is a *label*: the stability class, a binning of the
stored :math:`\zeta = z/L` (:func:`stability_class`).

Each table is written three times next to ``out_stem``: ``.csv`` (full precision, machine
readable, NaN as an empty field), ``.md`` (Markdown, rounded for reading) and ``.tex``
(LaTeX ``table`` with ``booktabs`` rules, rounded). All writes are atomic
(:func:`dronewind.core.cf.atomic_write_text`).

References
----------
.. [1] Ghirardelli et al. (2025), Table 4 (summary of the samples) and
   Table 5 (mean and turbulent flow statistics, drone vs mast).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from dronewind.core.cf import atomic_write_text
from dronewind.core.products import L4Products, drone_usable, load_l4_products, stored_scalar
from dronewind.errors import InputError

__all__ = [
    "STABILITY_BOUNDS",
    "TABLE4_COLUMNS",
    "TABLE5_ROWS",
    "default_detail_flights",
    "stability_class",
    "table_flight_statistics",
    "table_flights",
]

PathLike = str | Path

#: Class boundaries of :func:`stability_class` on zeta = z/L [-].
STABILITY_BOUNDS: tuple[float, float, float] = (-0.1, 0.1, 1.0)

#: Rows of Table 5: (L4 variable, Markdown label, LaTeX label, units, decimals shown).
TABLE5_ROWS: tuple[tuple[str, str, str, str, int], ...] = (
    ("U_ms", "ū", r"$\bar{u}$", "m s-1", 2),
    ("sigma_u_ms", "σ_u", r"$\sigma_u$", "m s-1", 2),
    ("sigma_v_ms", "σ_v", r"$\sigma_v$", "m s-1", 2),
    ("sigma_w_ms", "σ_w", r"$\sigma_w$", "m s-1", 2),
    ("skewness_u", "γ_u", r"$\gamma_u$", "1", 2),
    ("skewness_v", "γ_v", r"$\gamma_v$", "1", 2),
    ("skewness_w", "γ_w", r"$\gamma_w$", "1", 2),
    ("kurtosis_u", "κ_u", r"$\kappa_u$", "1", 2),
    ("kurtosis_v", "κ_v", r"$\kappa_v$", "1", 2),
    ("kurtosis_w", "κ_w", r"$\kappa_w$", "1", 2),
    ("uw_m2s2", "u'w'", r"$\overline{u'w'}$", "m2 s-2", 3),
    ("wT_Kms", "w'θ_v'", r"$\overline{w'\theta_v'}$", "K m s-1", 3),
)

_UNITS_TEX = {"m s-1": r"m\,s$^{-1}$", "m2 s-2": r"m$^2$\,s$^{-2}$", "K m s-1": r"K\,m\,s$^{-1}$",
              "1": "--", "m": "m", "s": "s", "min": "min", "degree": r"$^\circ$", "": ""}
_UNITS_MD = {"m s-1": "m s⁻¹", "m2 s-2": "m² s⁻²", "K m s-1": "K m s⁻¹", "1": "–", "m": "m", "s": "s",
             "min": "min", "degree": "°", "": ""}


# ----------------------------------------------------------------------------- flight choice and labels


def default_detail_flights(flights: Sequence[str]) -> list[str]:
    """The flights shown in detail by default: the first and the seventh (Ghirardelli et al. (2025): s1, s7).

    Parameters
    ----------
    flights : sequence of str
        Flight ids in campaign order.

    Returns
    -------
    list of str
        ``[flights[0], flights[6]]``; with fewer than seven flights the last one replaces the
        seventh; one flight gives one entry, none an empty list.
    """
    flights = list(flights)
    if not flights:
        return []
    second = flights[6] if len(flights) > 6 else flights[-1]
    return list(dict.fromkeys([flights[0], second]))


def stability_class(zeta: float, bounds: tuple[float, float, float] = STABILITY_BOUNDS) -> str:
    r"""Label of the stability parameter :math:`\zeta = z/L`.

    Parameters
    ----------
    zeta : float
        Stability parameter [-] (stored in L4 as ``zeta``).
    bounds : (float, float, float)
        Boundaries :math:`(\zeta_1, \zeta_2, \zeta_3)` [-].

    Returns
    -------
    str
        ``"unstable"`` for :math:`\zeta < \zeta_1`, ``"near-neutral"`` for
        :math:`\zeta_1 \le \zeta < \zeta_2`, ``"stable"`` for
        :math:`\zeta_2 \le \zeta < \zeta_3`, ``"very stable"`` above, ``"undefined"`` for NaN.

    Notes
    -----
    The default (-0.1, 0.1, 1) puts Ghirardelli et al. (2025)'s s1 (ζ = -0.46) in "unstable", s7 (ζ = 0.1)
    in "stable" and s4 (ζ = 1.25) in "very stable", as the paper's text describes them.
    """
    if zeta is None or not np.isfinite(zeta):
        return "undefined"
    z1, z2, z3 = bounds
    if zeta < z1:
        return "unstable"
    if zeta < z2:
        return "near-neutral"
    if zeta < z3:
        return "stable"
    return "very stable"


def _start_utc(ds: xr.Dataset | None) -> str:
    """Start of the analysed record (``time_bnds[0]``, else ``time_coverage_start``) as ``YYYY-MM-DD hh:mm:ss``."""
    if ds is None:
        return ""
    if "time_bnds" in ds.variables:
        t0 = np.asarray(ds["time_bnds"].values).reshape(-1)[0]
        return str(np.datetime_as_string(np.datetime64(t0, "s"), unit="s")).replace("T", " ")
    return str(ds.attrs.get("time_coverage_start", "")).replace("T", " ").rstrip("Z")


# ----------------------------------------------------------------------------- formatting


def _fmt(value: Any, decimals: int) -> str:
    """A number rounded to ``decimals`` for reading ("–" for NaN or None, never "-0.00"); text as is."""
    if isinstance(value, str):
        return value
    if value is None or not np.isfinite(value):
        return "–"
    text = f"{value:.{decimals}f}"
    return "0" + text[2:] if text.startswith("-0") and float(text) == 0 else text  # no "-0.00"


def _derived(value: float, significant: int = 12) -> float:
    """A number computed from a stored one (e.g. minutes from seconds), rounded to the precision that is real.

    ``1680.3 / 60`` is ``28.004999999999995`` in binary floating point; the stored seconds hold
    no more than 12 significant digits, so the CSV gets ``28.005``. Stored values themselves
    are written unchanged (their shortest round-trip representation).
    """
    return float(f"{value:.{significant}g}") if math.isfinite(value) else value


def _tex_escape(text: str) -> str:
    """Escape LaTeX special characters character by character (no double escaping)."""
    table = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#", "_": r"\_",
             "{": r"\{", "}": r"\}", "~": r"\textasciitilde{}", "^": r"\textasciicircum{}",
             "–": "--", "†": r"$^\dagger$"}
    return "".join(table.get(ch, ch) for ch in str(text))


def _markdown(header: list[str], rows: list[list[str]], notes: list[str]) -> str:
    """A Markdown pipe table followed by its notes."""
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join(["---"] * len(header)) + "|"]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    if notes:
        lines += [""] + notes
    return "\n".join(lines) + "\n"


def _latex(caption: str, label: str, header: list[str], rows: list[list[str]], notes: list[str],
           align: str, header_top: str | None = None) -> str:
    """A LaTeX ``table`` with ``booktabs`` rules, the notes in small print below."""
    lines = [r"% written by dronewind.tables; needs \usepackage{booktabs}", r"\begin{table}[htbp]",
             r"\centering", rf"\caption{{{caption}}}", rf"\label{{{label}}}", rf"\begin{{tabular}}{{{align}}}",
             r"\toprule"]
    if header_top:
        lines.append(header_top)
    lines += [" & ".join(header) + r" \\", r"\midrule"]
    lines += [" & ".join(r) + r" \\" for r in rows]
    lines += [r"\bottomrule", r"\end{tabular}"]
    if notes:
        lines.append(r"\par\smallskip{\footnotesize " + r" \\ ".join(_tex_escape(n) for n in notes) + "}")
    lines.append(r"\end{table}")
    return "\n".join(lines) + "\n"


def _csv(table: pd.DataFrame) -> str:
    """A table as CSV text at full precision, NaN as an empty field."""
    return table.to_csv(index=False, na_rep="", lineterminator="\n")


def _write_three(out_stem: PathLike, csv_text: str, md_text: str, tex_text: str) -> list[Path]:
    """Write ``<out_stem>.csv``, ``.md`` and ``.tex`` atomically; return the three paths."""
    stem = Path(out_stem)
    return [atomic_write_text(stem.with_name(stem.name + ext), text)
            for ext, text in ((".csv", csv_text), (".md", md_text), (".tex", tex_text))]


# ----------------------------------------------------------------------------- Table 4

#: Columns of the Table 4 CSV (name, unit).
TABLE4_COLUMNS: tuple[tuple[str, str], ...] = (
    ("flight", ""), ("reference", ""), ("start_utc", ""), ("duration_min", "min"),
    ("payload_height_m", "m"), ("reference_height_m", "m"), ("wind_from_deg", "degree"), ("U_ms", "m s-1"),
    ("zeta", "1"), ("stability_class", ""), ("lag_sonic_ins_s", "s"), ("lag_drone_mast_s", "s"),
    ("usable", ""), ("unusable_reason", ""),
)
#: Table 4 header, Markdown (* = measured by the reference mast sonic).
TABLE4_HEAD_MD: tuple[str, ...] = (
    "Flight", "Reference", "Start (UTC)", "Duration (min)", "Payload height (m)", "Reference height (m)",
    "Wind direction (°)*", "ū (m s⁻¹)*", "ζ (–)*", "Stability*", "Lag sonic–INS (s)", "Lag drone–mast (s)")
#: Table 4 header, LaTeX.
TABLE4_HEAD_TEX: tuple[str, ...] = (
    "Flight", "Reference", "Start (UTC)", "Duration (min)", "Payload $z$ (m)", "Reference $z$ (m)",
    r"Direction ($^\circ$)$^*$", r"$\bar{u}$ (m\,s$^{-1}$)$^*$", r"$\zeta$$^*$", "Stability$^*$",
    r"Lag sonic--INS (s)", r"Lag drone--mast (s)")


def _table4_row(flight: str, prod: Mapping[str, Any], stability_bounds: tuple[float, float, float]) -> dict[str, Any]:
    """One flight's Table 4 values, read from its L4 products (see :func:`table_flights`, Notes)."""
    drone, mast = prod.get("drone"), prod.get("mast")
    ref = mast if mast is not None else drone
    usable, reason = drone_usable(prod)
    zeta = stored_scalar(mast, "zeta")
    lag_si = float(drone.attrs.get("lag_sonic_ins_s", math.nan)) if drone is not None else math.nan
    lag_dm = float(ref.attrs.get("lag_drone_mast_s", math.nan)) if ref is not None else math.nan
    return {
        "flight": flight,
        "reference": str(ref.attrs.get("reference", "")) if ref is not None else "",
        "start_utc": _start_utc(ref),
        "duration_min": _derived(stored_scalar(ref, "duration_s") / 60.0),
        "payload_height_m": stored_scalar(drone, "height_m"),
        "reference_height_m": stored_scalar(mast, "height_m"),
        "wind_from_deg": stored_scalar(mast, "wind_from_deg"),
        "U_ms": stored_scalar(mast, "U_ms"),
        "zeta": zeta,
        "stability_class": stability_class(zeta, stability_bounds),
        "lag_sonic_ins_s": lag_si,
        "lag_drone_mast_s": lag_dm,
        "usable": bool(usable),
        "unusable_reason": reason,
    }


def _table4_cells(row: Mapping[str, Any]) -> list[str]:
    """One Table 4 row as rounded text (an unusable drone record marked †)."""
    mark = "" if row["usable"] else "†"
    return [row["flight"] + mark, row["reference"], row["start_utc"] or "–", _fmt(row["duration_min"], 1),
            _fmt(row["payload_height_m"], 1), _fmt(row["reference_height_m"], 0), _fmt(row["wind_from_deg"], 0),
            _fmt(row["U_ms"], 1), _fmt(row["zeta"], 2), row["stability_class"], _fmt(row["lag_sonic_ins_s"], 3),
            _fmt(row["lag_drone_mast_s"], 2)]


def _table4_notes(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """The footnotes: what * means, and the reason of every unusable drone record (†)."""
    notes = ["\\* measured by the reference mast sonic over the analysed record."]
    for r in rows:
        if not r["usable"]:
            notes.append(f"† {r['flight']}: drone record unusable: {r['unusable_reason'] or 'no reason stored'}.")
    return notes


def _table4_markdown_latex(rows: Sequence[Mapping[str, Any]]) -> tuple[str, str]:
    """Table 4 as Markdown and as a LaTeX ``table``."""
    body = [_table4_cells(r) for r in rows]
    body_tex = [[_tex_escape(c) for c in cells] for cells in body]
    notes = _table4_notes(rows)
    md_text = "Table 4 (dronewind): summary of the payload flights.\n\n" + _markdown(list(TABLE4_HEAD_MD), body, notes)
    tex_notes = [n.replace("\\*", "*") for n in notes]
    tex_text = _latex("Summary of the payload flights (after Ghirardelli et al. (2025), Table 4).", "tab:flights",
                      list(TABLE4_HEAD_TEX), body_tex, tex_notes, "ll" + "l" + "r" * 7 + "l" + "rr")
    return md_text, tex_text


def table_flights(l4_files: Iterable[PathLike], out_stem: PathLike,
                  stability_bounds: tuple[float, float, float] = STABILITY_BOUNDS) -> list[Path]:
    r"""Table 4 equivalent: one row per payload flight (Ghirardelli et al. (2025), Table 4).

    Columns: flight, reference mast sonic, start (UTC) and duration of the analysed
    record, payload height, reference sonic height, wind direction, mean wind speed,
    :math:`\zeta` and its stability class, the sonic-INS and drone-mast lags, and whether
    the drone record is usable (with the reason when not).

    Parameters
    ----------
    l4_files : iterable of path
        L4 files of the campaign (``<flight>_drone.nc`` and ``<flight>_mast.nc``).
    out_stem : str or Path
        Output path without suffix; ``.csv``, ``.md`` and ``.tex`` are written.
    stability_bounds : (float, float, float)
        Boundaries of :func:`stability_class` [-].

    Returns
    -------
    list of Path
        The CSV, Markdown and LaTeX files.

    Notes
    -----
    Sources (all stored): start = ``time_bnds[0]`` and duration = ``duration_s`` of the
    mast L4 file (the drone's if the mast is missing); payload height = drone
    ``height_m`` (the L2 median GNSS height above the site); reference height, wind
    direction, :math:`\bar u` (``U_ms``) and :math:`\zeta` from the mast L4 file, as in the
    paper's Table 4 (values "estimated by the mast-mounted sonic"); lags from the L4
    attributes ``lag_sonic_ins_s`` (drone) and ``lag_drone_mast_s``. A missing quantity is
    NaN in the CSV and "–" in the Markdown/LaTeX text.
    """
    products = load_l4_products(l4_files)
    rows = [_table4_row(flight, prod, stability_bounds) for flight, prod in products.items()]
    table = pd.DataFrame(rows, columns=[c for c, _ in TABLE4_COLUMNS])
    md_text, tex_text = _table4_markdown_latex(rows)
    return _write_three(out_stem, _csv(table), md_text, tex_text)


# ----------------------------------------------------------------------------- Table 5


def _table5_values(products: L4Products, chosen: Sequence[str]) -> dict[str, list[Any]]:
    """Table 5 columns: statistic, units, then ``<flight>_drone`` and ``<flight>_mast`` (stored values)."""
    data: dict[str, list[Any]] = {"statistic": [r[0] for r in TABLE5_ROWS], "units": [r[3] for r in TABLE5_ROWS]}
    for f in chosen:
        for sensor in ("drone", "mast"):
            data[f"{f}_{sensor}"] = [stored_scalar(products[f].get(sensor), r[0]) for r in TABLE5_ROWS]
    return data


def _unusable_marks(products: L4Products, chosen: Sequence[str]) -> tuple[dict[str, str], list[str]]:
    """Flight -> "†" when its drone record is unusable (else ""), and the footnotes with the reasons."""
    notes = []
    marks = {}
    for f in chosen:
        usable, reason = drone_usable(products[f])
        marks[f] = "" if usable else "†"
        if not usable:
            notes.append(f"† {f}: drone record unusable: {reason or 'no reason stored'}.")
    return marks, notes


def _table5_markdown_latex(data: Mapping[str, list[Any]], chosen: Sequence[str], marks: Mapping[str, str],
                           notes: list[str]) -> tuple[str, str]:
    """Table 5 as Markdown and as a LaTeX ``table`` (two columns, drone and mast, per flight)."""
    head_md = ["Statistic", "Units"] + [f"{f}{marks[f]} {s}" for f in chosen for s in ("drone", "mast")]
    body_md, body_tex = [], []
    for i, (_name, md_label, tex_label, units, dec) in enumerate(TABLE5_ROWS):
        vals = [_fmt(data[f"{f}_{s}"][i], dec) for f in chosen for s in ("drone", "mast")]
        body_md.append([md_label, _UNITS_MD.get(units, units)] + vals)
        body_tex.append([tex_label, _UNITS_TEX.get(units, units)] + [v.replace("–", "--") for v in vals])
    md_text = ("Table 5 (dronewind): mean and turbulent flow statistics, drone vs mast.\n\n"
               + _markdown(head_md, body_md, notes))
    top = " & ".join(["", ""] + [rf"\multicolumn{{2}}{{c}}{{Flight {_tex_escape(f + marks[f])}}}" for f in chosen])
    top += r" \\" + "\n" + "".join(rf"\cmidrule(lr){{{3 + 2 * k}-{4 + 2 * k}}}" for k in range(len(chosen)))
    head_tex = ["Statistic", "Units"] + ["Drone", "Mast"] * len(chosen)
    tex_text = _latex(
        r"Mean and turbulent flow statistics for the drone- and mast-mounted sonic anemometers "
        r"(after Ghirardelli et al. 2025, Table 5): standard deviation $\sigma$, skewness $\gamma$, kurtosis $\kappa$, "
        r"momentum flux $\overline{u'w'}$ and buoyancy flux $\overline{w'\theta_v'}$.",
        "tab:statistics", head_tex, body_tex, notes, "ll" + "rr" * len(chosen), header_top=top)
    return md_text, tex_text


def table_flight_statistics(l4_files: Iterable[PathLike], out_stem: PathLike,
                            flights: Sequence[str] | None = None) -> list[Path]:
    r"""Table 5 equivalent: mean and turbulence statistics, drone vs mast (Ghirardelli et al. (2025), Table 5).

    Rows: :math:`\bar u`, :math:`\sigma_{u,v,w}`, skewness :math:`\gamma_{u,v,w}`,
    kurtosis :math:`\kappa_{u,v,w}` (Pearson, 3 for a Gaussian), :math:`\overline{u'w'}`
    and :math:`\overline{w'\theta_v'}`; two columns (drone, mast) per flight.

    Parameters
    ----------
    l4_files : iterable of path
        L4 files of the campaign.
    out_stem : str or Path
        Output path without suffix; ``.csv``, ``.md`` and ``.tex`` are written.
    flights : sequence of str, optional
        Flights to show; default :func:`default_detail_flights` (first and seventh).

    Returns
    -------
    list of Path
        The CSV, Markdown and LaTeX files.

    Raises
    ------
    InputError
        A requested flight has no L4 file.

    Notes
    -----
    CSV columns: ``statistic`` (the L4 variable name), ``units``, then
    ``<flight>_drone`` and ``<flight>_mast`` with the stored values at full precision (NaN
    empty). A flight whose drone record is flagged unusable is still shown, marked †, with
    the reason in a note.
    """
    products = load_l4_products(l4_files)
    chosen = list(flights) if flights is not None else default_detail_flights(list(products))
    for f in chosen:
        if f not in products:
            raise InputError("table_flight_statistics(flights)", f"no L4 file for flight {f!r}; have {list(products)}")
    data = _table5_values(products, chosen)
    marks, notes = _unusable_marks(products, chosen)
    md_text, tex_text = _table5_markdown_latex(data, chosen, marks, notes)
    return _write_three(out_stem, _csv(pd.DataFrame(data)), md_text, tex_text)
