r"""The campaign's front page and the pieces of the HTML report (``snakemake --report``).

:func:`report_pages` reads the stored results of a campaign (``diagnosis.json``, the
published-numbers diagnosis, the quadrotor diagnosis, the tables in ``tables/``, the L4
products and ``campaign.json``) and writes, under ``results/<name>/report/``:

* ``summary.html``: the front page. The verdict of the diagnosis (named causes with
  estimates and held-out gains, or that nothing is significant, and what remains
  unexplained), the result on the paper's published numbers where it applies, the quadrotor
  verdict and calibration, Tables 4 and 5, the flight statistics, every figure with its
  caption (links open it in the report) and the references. ``workflow/report/workflow.rst``
  includes it, so the report opens on it.
* ``tables/<table>.html``: each table as a page of the report (Snakemake shows HTML in the
  report; CSV only as a download).
* ``captions/<figure>.rst``: each figure's caption, written from the data it shows
  (:mod:`dronewind.figures.captions`), read by the report when it is built.

Everything here is presentation of stored numbers; nothing is computed.
"""

from __future__ import annotations

import base64
import html
import json
import math
import os
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from dronewind.core.cf import atomic_write_text
from dronewind.core.products import load_l4_products
from dronewind.core.verdict import Verdict, misfit_rows, verdict
from dronewind.core.verdict import number as fmt_number
from dronewind.figures.captions import (
    block_captions,
    campaign_captions,
    diagnosis_captions,
    flight_list,
    published_caption,
    quadrotor_captions,
)
from dronewind.figures.labels import PAPERS, REFERENCES, REPORT_TABLES
from dronewind.steps.common import LOG

__all__ = ["REPORT_TABLES", "column_decimals", "column_label", "csv_html", "frame_html", "front_page_numbers",
           "markdown_html", "report_pages", "table_page", "write_validation_table"]

_STYLE = """<style>
.dw-report { font-family: system-ui, sans-serif; font-size: 14px; line-height: 1.45; color: #111; }
.dw-report table { border-collapse: collapse; margin: 0.4em 0 1em 0; font-size: 12px; }
.dw-report th, .dw-report td { border: 1px solid #bbb; padding: 2px 6px; text-align: right; vertical-align: top; }
.dw-report th { white-space: normal; max-width: 9em; }
.dw-report td { white-space: nowrap; }
.dw-report td.dw-text, .dw-report th.dw-text { text-align: left; white-space: normal; min-width: 8em; max-width: 28em; }
.dw-report .dw-flag { border-left: 4px solid #d97706; background: #fffbeb; padding: 6px 10px; }
.dw-report figure { margin: 0.5em 0; } .dw-report figure img { max-width: 100%; height: auto; }
.dw-report p, .dw-report li { max-width: 60rem; }
.dw-report th { background: #eee; }
.dw-report td:first-child, .dw-report th:first-child { text-align: left; }
.dw-report .dw-scroll { overflow-x: auto; max-width: 100%; }
.dw-report .dw-verdict { border-left: 4px solid #2563eb; background: #eff6ff; padding: 6px 10px; }
.dw-report code { font-size: 12px; }
</style>"""

#: Widens the front page of the report: the workflow description (this page) takes the width
#: and the rule graph moves below it. Only active while the front page is shown.
_FRONT_STYLE = """<style>
#app div.prose.max-w-lg { max-width: 72rem !important; }
#app div.grow.flex.gap-3.p-3.items-start { flex-wrap: wrap !important; }
#app div.grow.flex.items-center.justify-center.h-screen { align-items: flex-start !important;
  justify-content: flex-start !important; }
</style>"""


# ----------------------------------------------------------------------------- HTML pieces


def _inline(text: str) -> str:
    """Escape, then the inline Markdown our reports use: ``code``, **bold**."""
    out = html.escape(text, quote=False)
    out = re.sub(r"`([^`]+)`", r"<code>\1</code>", out)
    out = re.sub(r"\*\*([^*]+)\*\*", r"<strong>\1</strong>", out)
    return re.sub(r"\\([*_|\\])", r"\1", out)  # Markdown escapes


def _md_table(rows: list[str]) -> str:
    cells = [[c.strip() for c in r.strip().strip("|").split("|")] for r in rows]
    head, body = cells[0], cells[2:]
    parts = ["<div class='dw-scroll'><table><thead><tr>", *(f"<th>{_inline(c)}</th>" for c in head),
             "</tr></thead><tbody>"]
    for row in body:
        parts += ["<tr>", *(f"<td>{_inline(c)}</td>" for c in row), "</tr>"]
    parts.append("</tbody></table></div>")
    return "".join(parts)


_BULLET = r"^\s*[-*]\s+"


def markdown_html(text: str, heading_offset: int = 1) -> str:
    """HTML of the Markdown subset the project's reports are written in.

    Headings (``#``), paragraphs, bullet lists (``-``/``*``), pipe tables, ``code`` and
    **bold**; everything else is escaped text.

    Parameters
    ----------
    text : str
        Markdown (``diagnosis/report.md``, ``published/report.md``, ``tables/*.md``).
    heading_offset : int
        Added to the heading level (``#`` becomes ``<h2>`` with 1).

    Returns
    -------
    str
        An HTML fragment.
    """
    out: list[str] = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        if not line.strip():
            i += 1
        elif m := re.match(r"^(#{1,6})\s+(.*)$", line):
            level = min(6, len(m.group(1)) + heading_offset)
            out.append(f"<h{level}>{_inline(m.group(2))}</h{level}>")
            i += 1
        elif line.lstrip().startswith("|"):
            block = []
            while i < len(lines) and lines[i].lstrip().startswith("|"):
                block.append(lines[i])
                i += 1
            out.append(_md_table(block))
        elif re.match(_BULLET, line):
            items = []
            while i < len(lines) and re.match(_BULLET, lines[i]):
                items.append("<li>" + _inline(re.sub(_BULLET, "", lines[i])) + "</li>")
                i += 1
            out.append("<ul>" + "".join(items) + "</ul>")
        else:
            para = []
            while i < len(lines) and lines[i].strip() and not re.match(r"^(#|\||\s*[-*]\s)", lines[i]):
                para.append(lines[i].strip())
                i += 1
            out.append(f"<p>{_inline(' '.join(para))}</p>")
    return "\n".join(out)


#: Units of a column name's suffix, as written on a page (the CSVs keep the names).
_UNIT_SUFFIXES: tuple[tuple[str, str], ...] = (
    ("_m2s2", "m² s⁻²"), ("_Kms", "K m s⁻¹"), ("_kgm3", "kg m⁻³"),
    ("_ms", "m s⁻¹"), ("_deg", "°"), ("_min", "min"), ("_hz", "Hz"),
    ("_Hz", "Hz"), ("_k", "K"), ("_K", "K"), ("_s", "s"), ("_m", "m"), ("_c", "°C"), ("_pa", "Pa"),
)
#: Column names read as words on a page.
_WORDS = {"ekf": "EKF", "rho": "ρ", "corr": "correlation",
          "rmse": "RMSE", "uav": "UAV", "sigma": "σ", "n": "number of", "utc": "(UTC)", "tke": "TKE",
          "zeta": "ζ", "ustar": "u*", "u_star": "u*", "uw": "u'w'", "wt": "w'θ'", "vw": "v'w'"}
#: Columns whose values are yes/no however the CSV writes them.
_BOOLEAN_NAMES = ("usable", "significant", "named", "converged", "identified", "held_out")


#: Whole column names with a reading of their own.
_NAMES = {"Sw_Su": "S_w/S_u", "Sv_Su": "S_v/S_u", "lag_sonic_ins": "lag sonic–INS", "lag_drone_mast": "lag drone–mast",
          "sigma_u": "σ_u", "sigma_v": "σ_v", "sigma_w": "σ_w", "sigma_T": "σ_T", "n_windows": "windows",
          "n_windows_validation": "validation windows", "wind_from": "wind from", "L": "Obukhov length L"}


def column_label(name: str) -> str:
    """A CSV column name as a header for reading: words, and the unit of its suffix in brackets.

    ``rmse_ms`` -> "RMSE (m s⁻¹)", ``pitch_offset_deg`` -> "pitch offset (°)",
    ``uw_m2s2`` -> "u'w' (m² s⁻²)"; a name without a unit suffix keeps its words.
    """
    unit = ""
    for suffix, text in _UNIT_SUFFIXES:
        if name.endswith(suffix) and len(name) > len(suffix):
            name, unit = name[: -len(suffix)], text
            break
    if name in _NAMES:
        words = _NAMES[name]
    elif name in _WORDS:
        words = _WORDS[name]
    else:
        words = " ".join(_WORDS.get(w, _WORDS.get(w.lower(), w)) for w in name.split("_"))
    return f"{words} ({unit})" if unit else words


def _is_boolean(name: str, values: pd.Series) -> bool:
    finite = values.dropna()
    if values.dtype == bool:
        return True
    if not any(name == b or name.startswith(b + "_") or name.endswith("_" + b) for b in _BOOLEAN_NAMES):
        return False
    return bool(finite.astype(str).str.lower().isin(("true", "false", "1", "0", "1.0", "0.0", "yes", "no")).all())


def _yes_no(value: Any) -> str:
    if value is None or (isinstance(value, float) and not np.isfinite(value)):
        return "–"
    return "yes" if str(value).strip().lower() in ("true", "1", "1.0", "yes") else "no"


def column_decimals(values: Sequence[float] | np.ndarray, significant: int = 3, most: int = 6) -> int:
    """Decimals that show a column's typical value (its median magnitude) to ``significant`` digits.

    One number of decimals per column, so that a column reads as one quantity (no
    ``-4.111e-05`` beside ``21.04``); a value much smaller than the typical one shows as 0.
    """
    v = np.abs(np.asarray(values, dtype=float))
    v = v[np.isfinite(v) & (v > 0)]
    if not v.size:
        return 0
    if np.all(np.isclose(v, np.round(v))) and np.median(v) >= 1:
        return 0
    return int(min(most, max(0, significant - 1 - math.floor(math.log10(float(np.median(v)))))))


def _number(value: float, decimals: int) -> str:
    if not np.isfinite(value):
        return "–"
    text = f"{value:,.{decimals}f}".replace(",", " ")
    return text[1:] if text.startswith("-") and float(text.replace(" ", "")) == 0 else text


def frame_html(frame: pd.DataFrame, significant: int = 3) -> str:
    """A table for reading: headers with units, per-column decimals, yes/no, long text wrapped.

    Parameters
    ----------
    frame : pandas.DataFrame
        The table as stored (column names of the CSV).
    significant : int
        Significant digits of each column's typical value (:func:`column_decimals`).

    Returns
    -------
    str
        An HTML ``<table>`` in a scrolling box (the CSV keeps full precision).
    """
    head, cols = [], []
    for name in frame.columns:
        values = frame[name]
        if _is_boolean(str(name), values):
            cols.append([_yes_no(v) for v in values])
            head.append(f"<th>{html.escape(column_label(str(name)))}</th>")
        elif pd.api.types.is_numeric_dtype(values):
            dec = column_decimals(values.to_numpy(dtype=float), significant)
            cols.append([_number(float(v), dec) for v in values.to_numpy(dtype=float)])
            head.append(f"<th>{html.escape(column_label(str(name)))}</th>")
        else:
            cols.append([("–" if v is None or (isinstance(v, float) and not np.isfinite(v)) else str(v))
                         for v in values])
            head.append(f"<th class='dw-text'>{html.escape(column_label(str(name)))}</th>")
    text_cols = {i for i, h in enumerate(head) if "dw-text" in h}
    rows = []
    for r in range(len(frame)):
        cells = "".join((f"<td class='dw-text'>{html.escape(cols[i][r])}</td>" if i in text_cols else
                         f"<td>{html.escape(cols[i][r])}</td>") for i in range(len(cols)))
        rows.append(f"<tr>{cells}</tr>")
    return (f"<div class='dw-scroll'><table><thead><tr>{''.join(head)}</tr></thead>"
            f"<tbody>{''.join(rows)}</tbody></table></div>")


def csv_html(path: str | Path, columns: Sequence[str] | None = None) -> str:
    """A CSV table as an HTML table for reading (:func:`frame_html`; empty cells as "–")."""
    frame = pd.read_csv(path)
    if columns is not None:
        frame = frame[[c for c in columns if c in frame.columns]]
    return frame_html(frame)


def table_page(title: str, body: str) -> str:
    """A standalone HTML page (a report item)."""
    return (f"<!doctype html>\n<html lang='en'><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
            f"{_STYLE}</head><body class='dw-report'><h1>{html.escape(title)}</h1>\n{body}\n</body></html>\n")


def _table_body(source: Path) -> str:
    if source.suffix == ".csv":
        return csv_html(source)
    return markdown_html(source.read_text("utf-8"))


# ----------------------------------------------------------------------------- front page


def _read_json(path: Path) -> dict[str, Any] | None:
    return json.loads(path.read_text("utf-8")) if path.exists() else None


#: Candidates listed on the front page (all of them on the diagnosis page).
FRONT_CANDIDATES = 6


def _pm(value: float, err: float, decimals: int) -> str:
    if not np.isfinite(value):
        return "–"
    text = _number(value, decimals)
    return text + (f" ± {_number(err, decimals)}" if np.isfinite(err) else "")


def front_page_numbers(results: Path) -> dict[str, Any]:
    """The numbers the front page states, from the stored results (one object, for the page and for tests).

    Returns
    -------
    dict
        ``validation``: rows of :func:`dronewind.compare.validation.validation_rows` (no
        rows without payload flights with a mast); ``flags``: the implausible values
        (:func:`dronewind.compare.validation.plausibility_flags`); ``verdict``: the
        :class:`dronewind.core.verdict.Verdict` of ``diagnosis.json`` (None without one);
        ``misfit``: :func:`dronewind.core.verdict.misfit_rows`.
    """
    from dronewind.compare.validation import plausibility_flags, validation_rows

    files = sorted((results / "netcdf" / "L4").glob("*_*.nc")) if (results / "netcdf" / "L4").is_dir() else []
    products = load_l4_products(files) if files else {}
    diag = _read_json(results / "diagnosis.json")
    lags = {}
    for name, d in ((diag or {}).get("rigid_mount") or {}).get("flights", {}).items():
        lag = ((d.get("commanded") or {}).get("lag") or {})
        if lag.get("identified") and isinstance(lag.get("lag_s"), int | float):
            lags[name] = float(lag["lag_s"])
    rows = validation_rows(products) if products else []
    return {"validation": [r for r in rows if r["n"]], "flags": plausibility_flags(products, lags),
            "verdict": verdict(diag) if diag is not None and (diag.get("flights") or diag.get("candidates")
                                                               or diag.get("note")) else None,
            "misfit": misfit_rows(diag) if diag is not None else [], "products": products}


def _r2_decimals(r2: float) -> int:
    """Decimals that tell R² from 1 (3 at least): 0.9995 reads 0.9995, never 1.000."""
    if not np.isfinite(r2) or r2 >= 1.0 or 1.0 - r2 >= 0.001:
        return 3
    return min(6, 1 - math.floor(math.log10(1.0 - r2)))


def _validation_section(numbers: Mapping[str, Any]) -> str:
    """The answer first: drone against mast per statistic, with uncertainties."""
    from dronewind.compare.validation import STATISTICS

    rows = numbers["validation"]
    if not rows:
        return ""
    decimals = {s.key: s.decimals for s in STATISTICS}
    body = []
    for r in rows:
        dec = decimals[r["statistic"]]
        unit = f" ({r['unit']})" if r["unit"] else ""
        cells = [f"{r['label']}{unit}", str(r["n"]), _pm(r["bias"], r["bias_se"], dec),
                 _pm(r["rmse"], r["rmse_se"], dec), _number(r["sampling_rms"], dec),
                 _pm(r["slope"], r["slope_se"], 2), _number(r["r2"], _r2_decimals(r["r2"]))]
        body.append("<tr>" + "".join(f"<td{' class=dw-text' if i == 0 else ''}>{html.escape(c)}</td>"
                                     for i, c in enumerate(cells)) + "</tr>")
    n_max = max(r["n"] for r in rows)
    return ("<h2>Drone against mast</h2>"
            f"<p>Over the {n_max} flights with a usable drone record and a reference mast sonic: bias (drone − mast) "
            "and RMSE of the difference, each ± its standard error over the flights; the RMS difference that the "
            f"random sampling errors of both sensors alone would give ({html.escape(PAPERS['000'])}, Eqs 10-13; "
            "defined for the variances and fluxes); the least-squares slope of drone on mast ± its standard error "
            "(1 for agreement) and R². An RMSE near the sampling-error value means agreement within sampling "
            "error. Direction differences are wrapped to ±180°; spectral slopes are fitted over "
            "2 &lt; f z/ū &lt; 10.</p>"
            "<div class='dw-scroll'><table><thead><tr><th class='dw-text'>statistic</th><th>flights</th>"
            "<th>bias ± s.e.</th><th>RMSE ± s.e.</th><th>sampling error alone (RMS)</th><th>slope ± s.e.</th>"
            f"<th>R²</th></tr></thead><tbody>{''.join(body)}</tbody></table></div>")


def write_validation_table(l4_files: Sequence[str | Path], out_stem: str | Path) -> list[Path]:
    """The validation answer as ``<out_stem>.csv`` (full precision) and ``.md`` (rounded for reading).

    The same rows as the front page's first table
    (:func:`dronewind.compare.validation.validation_rows`), for a rule that writes them beside
    the other tables (``tables/validation.csv``).

    Parameters
    ----------
    l4_files : sequence of path
        The campaign's L4 files (``<flight>_drone.nc``, ``<flight>_mast.nc``).
    out_stem : str or Path
        Output path without suffix.

    Returns
    -------
    list of Path
        The CSV and the Markdown file.
    """
    from dronewind.compare.validation import STATISTICS, validation_rows

    rows = validation_rows(load_l4_products(list(l4_files)))
    frame = pd.DataFrame(rows)
    stem = Path(out_stem)
    csv = atomic_write_text(stem.with_name(stem.name + ".csv"),
                            frame.to_csv(index=False, na_rep="", lineterminator="\n"))
    decimals = {st.key: st.decimals for st in STATISTICS}
    lines = ["Drone against mast: bias and RMSE of drone − mast ± standard error over the flights, RMS difference "
             "from sampling error alone (Ghirardelli et al. 2025, Eqs 10-13), slope of drone on mast ± standard "
             "error, R².",
             "", "| statistic | flights | bias | RMSE | sampling error (RMS) | slope | R² |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        dec = decimals[r["statistic"]]
        unit = f" ({r['unit']})" if r["unit"] else ""
        lines.append(f"| {r['label']}{unit} | {r['n']} | {_pm(r['bias'], r['bias_se'], dec)} | "
                     f"{_pm(r['rmse'], r['rmse_se'], dec)} | {_number(r['sampling_rms'], dec)} | "
                     f"{_pm(r['slope'], r['slope_se'], 2)} | {_number(r['r2'], _r2_decimals(r['r2']))} |")
    md = atomic_write_text(stem.with_name(stem.name + ".md"), "\n".join(lines) + "\n")
    return [csv, md]


def _flags_section(numbers: Mapping[str, Any]) -> str:
    flags = numbers["flags"]
    if not flags:
        return ""
    return ("<h2>Implausible values</h2><div class='dw-flag'><p>Stored values no correct record gives; the "
            "statistics on this page include them as measured:</p><ul>"
            + "".join(f"<li>{html.escape(f)}</li>" for f in flags) + "</ul></div>")


def _verdict_html(v: Verdict, label: str = "Verdict") -> str:
    caveats = "".join(f"<li>{_inline(c)}</li>" for c in v.caveats)
    return (f"<p class='dw-verdict'><strong>{label}.</strong> {_inline(v.text())}</p>"
            + (f"<p>Caveats:</p><ul>{caveats}</ul>" if caveats else ""))


def _diagnosis_section(diag: Mapping[str, Any], v: Verdict, misfit: Sequence[tuple[str, str, Any, Any]]) -> str:
    cands = list(diag.get("candidates") or [])
    rows = []
    for c in cands[:FRONT_CANDIDATES]:
        est = ", ".join(f"{k} = {fmt_number(val)}" for k, val in (c.get("estimate") or {}).items()
                        if isinstance(val, int | float))
        gain, p = c.get("gain"), c.get("p_value")
        sig = "at a bound: not identified" if c.get("at_bound") else ("yes" if c.get("significant") else "no")
        rows.append(f"<tr><td class='dw-text'><code>{html.escape(str(c.get('variant') or c['mechanism']))}</code></td>"
                    f"<td class='dw-text'>{html.escape(est)}</td><td>{fmt_number(gain, 2)}</td>"
                    f"<td>{fmt_number(p, 2)}</td><td>{sig}</td></tr>")
    flights = list(diag.get("flights") or [])
    metrics = "".join(f"<tr><td class='dw-text'>{html.escape(label)}</td><td>{fmt_number(base)}</td>"
                      f"<td>{fmt_number(after)}</td></tr>" for _, label, base, after in misfit)
    head = "<h2>Diagnosis: what the simulation gets wrong</h2>" + _verdict_html(v)
    if not flights:
        return head
    shown = (f"all {len(cands)} candidates" if len(cands) <= FRONT_CANDIDATES else
             f"the {FRONT_CANDIDATES} of {len(cands)} candidates with the best held-out gain (all of them on the "
             "table page “Diagnosis: residuals, candidates, before and after”)")
    return (head + f"<p>{len(flights)} payload flights ({html.escape(flight_list(flights))})"
            " were compared with the forward model at the conditions measured by the reference mast; "
            f"{shown}, fitted on all flights and scored on flights left out:</p>"
            "<div class='dw-scroll'><table><thead><tr><th class='dw-text'>mechanism</th><th class='dw-text'>estimate"
            "</th><th>held-out gain</th><th>family-wise p</th><th>significant</th></tr></thead>"
            f"<tbody>{''.join(rows)}</tbody></table></div>"
            + ("<p>Misfit before (baseline) and after (extended model, as fitted; the same numbers as "
               "<code>diagnosis.json</code> and <code>diagnosis/report.md</code>):</p><table><thead><tr>"
               "<th class='dw-text'>metric</th><th>baseline</th><th>extended</th></tr></thead>"
               f"<tbody>{metrics}</tbody></table>" if metrics else ""))


def _platform_section(diag: Mapping[str, Any]) -> str:
    """Rigid-mount flights: the platform-motion response from commanded motion (``rigid_mount`` of diagnosis.json)."""
    rigid = diag.get("rigid_mount") or {}

    def pm(x: Any, y: Any, spec: str = ".2f") -> str:
        return "n/a" if x is None else f"{x:{spec}} ± {y:{spec}}"

    rows, seg_rows = [], []
    for name, d in (rigid.get("flights") or {}).items():
        c = d.get("commanded") or {}
        est, unc, lag = d["estimate"], d["uncertainty"], c.get("lag") or {}
        hov = (d.get("hover_spectral") or {}).get("estimate") or {}
        held = (c.get("held_out") or {}).get("combined_gain")
        cells = [name, pm(est["gain_h"], unc["gain_h"]), pm(est["gain_v"], unc["gain_v"]),
                 pm(c.get("heading_offset_deg"), c.get("heading_offset_sigma_deg"), ".1f"),
                 pm(lag.get("lag_s"), lag.get("sigma_s")) if lag.get("identified") else "not identified",
                 f"{d['test']['p_value']:.2g}", "yes" if d["significant"] else "no",
                 "n/a" if held is None else f"{held:.2f}",
                 f"{hov.get('gain_h', float('nan')):.2f} / {hov.get('gain_v', float('nan')):.2f}"]
        rows.append("<tr>" + "".join(f"<td>{html.escape(x)}</td>" for x in cells) + "</tr>")
        for sg in c.get("segments") or []:
            vertical = sg["kind"] in ("climb", "descent")
            speed = f"{sg['speed_ms']:+.2f} (vertical)" if vertical else f"{sg['speed_ms']:.2f}"
            cd = sg["course_deg"]
            course = "" if cd is None or cd != cd else f"{cd:.0f}"
            cells = [name, sg["kind"], f"{sg['t_start_s']:.1f}-{sg['t_stop_s']:.1f}", speed, course]
            seg_rows.append("<tr>" + "".join(f"<td>{html.escape(x)}</td>" for x in cells) + "</tr>")
    cand: Mapping[str, Any] = next((c for c in diag.get("candidates") or []
                                    if c.get("mechanism") == "platform_velocity_response"), {})
    extra = (f" Gain of the extended correction: {cand['gain']:.2f} ({html.escape(str(cand.get('gain_kind', '')))}"
             f"; {html.escape(str(cand.get('gain_measure', '')))})."
             if isinstance(cand.get("gain"), int | float) else "")
    first: Mapping[str, Any] = next(iter((rigid.get("flights") or {}).values()), {})
    return ("<h2>Rigid-mount flights: the sonic's response to the platform's own velocity</h2>"
            "<p>The motion correction V<sub>wind</sub> = R M V<sub>sensor</sub> + V<sub>platform</sub> assumes the "
            "sonic sees the platform's whole velocity. If it sees G V<sub>platform</sub> (catalog mechanism "
            "<code>platform_velocity_response</code>, G = diag(g<sub>h</sub>, g<sub>h</sub>, g<sub>v</sub>); present "
            "model G = I), the corrected wind keeps (I − G) V<sub>platform</sub>. The gains are measured from "
            "commanded motion only: segment means of the corrected wind regressed on the segment-mean platform "
            "velocity over straight legs flown both ways (g<sub>h</sub> and the sonic's heading offset on the "
            "airframe) and over climbs and descents (g<sub>v</sub>); the sonic-platform lag from the turnarounds. "
            "Hover drift follows the wind and is not used (its spectral estimate is listed for reference).</p>"
            + "".join(f"<p class='dw-verdict'><strong>Verdict.</strong> {_inline(v)}</p>"
                      for v in rigid.get("verdict") or [])
            + "<table><thead><tr><th>flight</th><th>gain_h</th><th>gain_v</th><th>heading offset [°]</th>"
            "<th>lag [s]</th><th>p (g = 1)</th><th>named</th><th>held-out gain</th>"
            "<th>hover spectral gain_h / gain_v (biased, not used)</th></tr></thead>"
            f"<tbody>{''.join(rows)}</tbody></table>"
            f"<p>Uncertainties: weighted least squares over the segments, weights from the turbulence's sampling "
            f"error of each segment mean and the segment-to-segment scatter beyond it.{extra} Assumption: "
            f"{html.escape(str(first.get('assumption', '')))}.</p>"
            f"<details><summary>The {len(seg_rows)} segments (time from the record's start, speed, course)</summary>"
            "<table><thead><tr><th>flight</th><th>kind</th><th>time (s)</th><th>speed (m s⁻¹)</th><th>course (°)</th>"
            f"</tr></thead><tbody>{''.join(seg_rows)}</tbody></table></details>")


def _published_section(diag: Mapping[str, Any]) -> str:
    base = (diag.get("baseline") or {}).get("chi2")
    fit = (diag.get("named_fit") or {}).get("chi2")
    named = list(diag.get("named_causes") or [])
    change = (f" Misfit to the published numbers: χ² {base:.1f} (baseline) → {fit:.1f} (with the named "
              f"cause{'s' if len(named) > 1 else ''})."
              if named and isinstance(base, int | float) and isinstance(fit, int | float) else
              f" Misfit to the published numbers: χ² {base:.1f} (baseline; nothing named)."
              if isinstance(base, int | float) else "")
    v = verdict(diag)
    v.fit = (v.fit + change) if v.fit else change.strip()
    return (f"<h2>The paper's published numbers ({html.escape(PAPERS['000'])})</h2>"
            "<p>Tables 4-5 and the claims of Sects 5.2 and 6 fitted with the same forward model, "
            f"at the Table 4 conditions of {html.escape(flight_list(diag.get('flights') or []))}.</p>"
            + _verdict_html(v, "Result"))


def _quadrotor_section(qdiag: Mapping[str, Any] | None, calibration: Path) -> str:
    parts = [f"<h2>Quadrotor fleet ({html.escape(PAPERS['001'])}; wind tunnel: {html.escape(PAPERS['002'])})</h2>"]
    if qdiag is not None:
        named = list(qdiag.get("named_causes") or [])
        ext = qdiag.get("extended_model") or {}
        speed = ext.get("speed_rmse_ms") or {}
        text = (f"Named causes: {', '.join(named)}." if named else
                "No cause named: no catalog mechanism explains the drone-tower differences significantly.")
        if speed and named:
            text += (f" Wind-speed RMSE of the single-law model {speed.get('before', float('nan')):.2f} m s⁻¹ → "
                     f"{speed.get('after', float('nan')):.2f} m s⁻¹ with {', '.join(ext.get('named') or named)} "
                     f"({ext.get('heldout', 'held out')}).")
        elif speed:
            text += f" Wind-speed RMSE of the single-law model {speed.get('before', float('nan')):.2f} m s⁻¹."
        parts.append(f"<p class='dw-verdict'><strong>Verdict.</strong> {_inline(text)}</p>")
    if calibration.exists():
        parts.append("<p>Calibration per UAV:</p>" + csv_html(
            calibration, ["uav", "pitch_offset_deg", "yaw_offset_deg", "rmse_ms", "bias_ms", "n_windows",
                          "n_windows_validation"]))
    return "".join(parts)


#: The figure embedded in the front page (as a data URI) when the campaign has it: the validation at a glance.
FRONT_FIGURE = "fig12_mean_and_sigma"


def _figure_section(figures: Mapping[str, str], captions: Mapping[str, str], out: Path) -> str:
    """Every figure with its caption, linked as a file relative to the page.

    The page works opened as a file (the link opens the PNG beside it; a PDF copy lies
    beside each PNG) and inside the Snakemake report (the click opens the figure there).
    """
    items = []
    for name, path in figures.items():
        rel = Path(os.path.relpath(Path(path), out)).as_posix()
        pdf = Path(path).with_suffix(".pdf")
        pdf_link = (f" (<a href=\"{html.escape(Path(os.path.relpath(pdf, out)).as_posix())}\">PDF</a>)"
                    if pdf.exists() else "")
        data = html.escape(json.dumps(str(Path(path))), quote=True)
        items.append(f"<li><a href=\"{html.escape(rel)}\" data-result={data} onclick=\"if (window.app &amp;&amp; "
                     "app.showResultInfo) { app.showResultInfo(JSON.parse(this.dataset.result)); return false; }\">"
                     f"{html.escape(Path(path).name)}</a>{pdf_link}: {html.escape(captions.get(name, ''))}</li>")
    return "<h2>Figures</h2><ul>" + "".join(items) + "</ul>" if items else ""


def _embedded_figure(figures: Mapping[str, str], captions: Mapping[str, str]) -> str:
    path = Path(figures.get(FRONT_FIGURE, ""))
    if FRONT_FIGURE not in figures or not path.is_file():
        return ""
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return (f"<figure><img alt='{html.escape(FRONT_FIGURE)}' src='data:image/png;base64,{data}'>"
            f"<figcaption>{html.escape(captions.get(FRONT_FIGURE, ''))}</figcaption></figure>")


def _campaign_line(record: Mapping[str, Any]) -> str:
    content = record.get("manifest_content") or {}
    counts = [(len(content.get("payload_flights") or []), "payload flight"),
              (len(content.get("quadrotor_flights") or []), "quadrotor flight"),
              (len(content.get("autopilot_flights") or []), "autopilot flight"),
              (sum(len(m.get("sonics") or []) for m in content.get("masts") or []), "mast sonic")]
    what = ", ".join(f"{n} {word}{'s' if n != 1 else ''}" for n, word in counts if n) or "no records"
    site = (content.get("site") or {}).get("name")
    return (f"<p>{what}{', simulated (virtual campaign)' if record.get('simulated') else ''}"
            f"{'; site ' + html.escape(str(site)) if site else ''}. dronewind "
            f"{html.escape(str(record.get('dronewind_version', '')))}, configuration "
            f"{html.escape(str(record.get('config_sha256', ''))[:12])}.</p>")


def _drone_only_section(products: Mapping[str, Any]) -> str:
    """Flights without a reference: the drone's statistics (what the validation table would compare)."""
    from dronewind.compare.validation import STATISTICS, flight_values

    alone = {f: p["drone"] for f, p in products.items() if p.get("mast") is None and p.get("drone") is not None}
    if not alone:
        return ""
    frame = pd.DataFrame([{"flight": f, **flight_values(ds)} for f, ds in alone.items()])
    labels = {s.key: s.label + (f" ({s.unit})" if s.unit else "") for s in STATISTICS}
    head = "".join(f"<th>{html.escape(labels[k])}</th>" for k in labels)
    body = "".join("<tr><td class='dw-text'>" + html.escape(str(r["flight"])) + "</td>" + "".join(
        f"<td>{_number(float(r[s.key]), s.decimals)}</td>" for s in STATISTICS) + "</tr>" for _, r in frame.iterrows())
    from dronewind.figures.statistics import drone_spectra_png

    png = drone_spectra_png(alone)
    figure = (f"<figure><img alt='drone spectra' src='data:image/png;base64,{base64.b64encode(png).decode('ascii')}'>"
              "<figcaption>Frequency-weighted spectra f S_u, f S_v, f S_w of the drone (L4), log-log; shaded: the "
              "band 2 &lt; f z/ū &lt; 10 of the spectral ratio and slopes; dashed: the f^(−2/3) of an inertial "
              "subrange.</figcaption></figure>" if png else "")
    return ("<h2>Drone statistics (no reference sonic)</h2><p>No mast sonic was recorded with these flights, so "
            "nothing is compared; the drone's own statistics over the analysed record:</p>"
            f"<div class='dw-scroll'><table><thead><tr><th class='dw-text'>flight</th>{head}</tr></thead>"
            f"<tbody>{body}</tbody></table></div>{figure}")


def _png_figure(path: Path, caption: str) -> str:
    """A PNG embedded in the page (a data URI: the page stays one file that works anywhere)."""
    if not path.is_file():
        return ""
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return (f"<figure><img alt='{html.escape(path.stem)}' src='data:image/png;base64,{data}'>"
            f"<figcaption>{html.escape(caption)}</figcaption></figure>")


#: Columns of the block table on the front page (all of them in the table page and the CSV).
BLOCK_COLUMNS = ("record", "sensor", "height_m", "start_utc", "U_ms", "wind_from_deg", "sigma_u_ms", "sigma_v_ms",
                 "sigma_w_ms", "ustar_ms", "wT_Kms", "zeta", "Sw_Su", "usable", "reason")


def _blocks_section(blocks: Path, figures: Mapping[str, str], captions: Mapping[str, str]) -> str:
    """Tower and mast records in blocks: the statistics of every block, the block figure, implausible blocks."""
    from dronewind.compare.validation import ISOTROPY, SW_SU_FACTOR

    table = pd.read_csv(blocks)
    usable = table["usable"].astype(str).str.lower().isin(("true", "1"))
    lo, hi = ISOTROPY / SW_SU_FACTOR, ISOTROPY * SW_SU_FACTOR
    ratio = (pd.to_numeric(table["Sw_Su"], errors="coerce") if "Sw_Su" in table.columns
             else pd.Series(np.nan, index=table.index))
    odd = table[usable & ratio.notna() & ((ratio < lo) | (ratio > hi))]
    flags = ("<div class='dw-flag'><p>Implausible values: ⟨S_w/S_u⟩ far from isotropy (4/3 in the inertial "
             f"subrange; flagged outside {lo:.2f}-{hi:.2f}) in {len(odd)} usable block(s): "
             + html.escape(", ".join(f"{r.sensor} {r.start_utc} ({r.Sw_Su:.2f})" for r in odd.itertuples()))
             + ".</p></div>" if len(odd) else "")
    shown = table[[c for c in BLOCK_COLUMNS if c in table.columns]]
    from dronewind.figures.labels import BLOCK_FIGURE

    figure = (_png_figure(Path(figures[BLOCK_FIGURE]), captions.get(BLOCK_FIGURE, ""))
              if BLOCK_FIGURE in figures else "")
    return (f"<h2>Tower and mast records in blocks</h2><p>{len(table)} blocks of "
            f"{table.groupby(['record', 'sensor']).ngroups} sonic(s), {int(usable.sum())} usable (the others with "
            "their reason); every column in the table page <code>block_stats</code> and in "
            "<code>tables/block_stats.csv</code>. No drone was flown: these are the reference's own statistics.</p>"
            + flags + frame_html(shown) + figure)


def _autopilot_section(table: Path, figures_dir: Path, out: Path) -> str:
    """Autopilot logs: the tilt wind against the autopilot's own EKF wind (no anemometer to compare with)."""
    items = sorted(figures_dir.glob("autopilot_ekf_wind_*.png"))
    figs = "".join(_png_figure(p, f"Tilt wind (Wetz et al. 2021, Eqs 12-18) against the autopilot's EKF wind, "
                                  f"flight {p.stem.removeprefix('autopilot_ekf_wind_')}.") for p in items[:3])
    return ("<h2>Autopilot logs: the wind from the tilt against the autopilot's EKF wind</h2><p>No anemometer flew "
            "with these logs: the wind from the airframe's tilt (a drag law not calibrated for this airframe) is "
            "compared with the wind the autopilot's filter estimates, itself a slowly varying state, not a "
            "measurement. Bias and RMSE are tilt minus EKF.</p>" + csv_html(table) + figs)


def _references(results: Path, diag: Mapping[str, Any] | None) -> str:
    """The papers this campaign's page cites: the drone papers only where drone records are shown."""
    keys = []
    if any((results / "netcdf" / "L4").glob("*_drone.nc")) or diag is not None or (results / "published").is_dir():
        keys.append("000")
    if (results / "tables" / "quadrotor_calibration.csv").exists() or any((results / "tables").glob("autopilot*")):
        keys.append("001")
    if (results / "tables" / "tunnel_calibration.csv").exists():
        keys.append("002")
    if not keys:
        return ""
    return "<h2>References</h2><ul>" + "".join(f"<li>{html.escape(REFERENCES[k])}</li>" for k in keys) + "</ul>"


def _summary(results: Path, campaign: str, figures: Mapping[str, str], captions: Mapping[str, str],
             out: Path) -> str:
    numbers = front_page_numbers(results)
    parts = [_FRONT_STYLE, _STYLE, "<div class='dw-report'>", f"<h1>Campaign {html.escape(campaign)}</h1>",
             _campaign_line(_read_json(results / "campaign.json") or {})]
    parts += [_validation_section(numbers), _embedded_figure(figures, captions),
              _drone_only_section(numbers["products"]), _flags_section(numbers)]
    diag = _read_json(results / "diagnosis.json")
    if diag is not None:
        if numbers["verdict"] is not None and (diag.get("flights") or not diag.get("rigid_mount")):
            parts.append(_diagnosis_section(diag, numbers["verdict"], numbers["misfit"]))
        if diag.get("rigid_mount"):
            parts.append(_platform_section(diag))
    if (pub := _read_json(results / "published" / "diagnosis.json")) is not None:
        parts.append(_published_section(pub))
    if (results / "tables" / "quadrotor_calibration.csv").exists():
        parts.append(_quadrotor_section(_read_json(results / "quadrotor_diagnosis.json"),
                                        results / "tables" / "quadrotor_calibration.csv"))
    for name in ("table4_flights", "table5_statistics"):
        if (source := results / REPORT_TABLES[name][1]).exists():
            parts.append(markdown_html(source.read_text("utf-8"), heading_offset=1).replace(
                "<p>Table", "<h2>Table", 1).replace("</p>", "</h2>", 1))
    if (stats := results / "tables" / "flight_stats.csv").exists():
        parts.append("<h2>Flight statistics (drone and mast)</h2>" + csv_html(stats))
    if (blocks := results / "tables" / "block_stats.csv").exists():
        parts.append(_blocks_section(blocks, figures, captions))
    if (autopilot := results / "tables" / "autopilot_ekf_wind.csv").exists():
        parts.append(_autopilot_section(autopilot, results / "figures", out))
    parts.append(_figure_section(figures, captions, out))
    parts.append(_references(results, diag) + "</div>")
    return "\n".join(p for p in parts if p) + "\n"


# ----------------------------------------------------------------------------- the step


def _caption_rst(text: str) -> str:
    """A caption file: literal text for reStructuredText, protected from the report's Jinja pass."""
    return "{% raw %}\n" + text.replace("*", "\\*").replace("`", "\\`").replace("|", "\\|") + "\n{% endraw %}\n"


def report_pages(results_dir: str | Path, out_dir: str | Path, figures: Mapping[str, str],
                 tables: Sequence[str]) -> list[Path]:
    """Write the front page, the table pages and the figure captions of a campaign's report.

    Parameters
    ----------
    results_dir : str or Path
        ``results/<campaign>/`` with the stored results.
    out_dir : str or Path
        Output folder (``results/<campaign>/report``): ``summary.html``,
        ``tables/<name>.html``, ``captions/<figure>.rst``.
    figures : mapping
        Figure name -> PNG path exactly as the workflow names it (the front page links to
        it in the report).
    tables : sequence of str
        Names of :data:`REPORT_TABLES` to write (those the campaign has).

    Returns
    -------
    list of Path
        Written files.
    """
    results, out = Path(results_dir), Path(out_dir)
    captions: dict[str, str] = {}
    if (results / "netcdf" / "L4").is_dir():
        captions.update(campaign_captions(results))
    if (results / "diagnosis.json").exists() and (results / "diagnosis" / "report.md").exists():
        captions.update(diagnosis_captions(results / "diagnosis.json"))
    if (results / "published" / "before_after.json").exists():
        captions["published_before_after"] = published_caption(results / "published" / "before_after.json",
                                                                results / "published" / "diagnosis.json")
    captions.update(quadrotor_captions(results / "tables"))
    captions.update(block_captions(results / "tables"))
    written = []
    for name in figures:
        if name not in captions:
            raise KeyError(f"{results}: no caption for figure {name!r} (its stored results are missing)")
        written.append(atomic_write_text(out / "captions" / f"{name}.rst", _caption_rst(captions[name])))
    for name in tables:
        title, rel = REPORT_TABLES[name]
        written.append(atomic_write_text(out / "tables" / f"{name}.html",
                                         table_page(title, _table_body(results / rel))))
    campaign = str((_read_json(results / "campaign.json") or {}).get("campaign", results.name))
    written.append(atomic_write_text(out / "summary.html", _summary(results, campaign, figures, captions, out)))
    LOG.info("report pages: %d figure captions, %d tables, front page %s", len(figures), len(tables),
             out / "summary.html")
    return written
