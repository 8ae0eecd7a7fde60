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

import html
import json
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any
from urllib.parse import quote

import pandas as pd

from dronewind.core.cf import atomic_write_text
from dronewind.figures.captions import (
    block_captions,
    campaign_captions,
    diagnosis_captions,
    flight_list,
    published_caption,
    quadrotor_captions,
    verdict_sentence,
)
from dronewind.figures.labels import PAPERS, REFERENCES, REPORT_TABLES
from dronewind.steps.common import LOG

__all__ = ["REPORT_TABLES", "csv_html", "markdown_html", "report_pages", "table_page"]

_STYLE = """<style>
.dw-report { font-family: system-ui, sans-serif; font-size: 14px; line-height: 1.45; color: #111; }
.dw-report table { border-collapse: collapse; margin: 0.4em 0 1em 0; font-size: 12px; }
.dw-report th, .dw-report td { border: 1px solid #bbb; padding: 2px 6px; text-align: right; }
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


def csv_html(path: str | Path, columns: Sequence[str] | None = None) -> str:
    """A CSV table as an HTML table (numbers to 4 significant digits, empty cells as "–")."""
    frame = pd.read_csv(path)
    if columns is not None:
        frame = frame[[c for c in columns if c in frame.columns]]
    table = frame.to_html(index=False, border=0, na_rep="–", float_format=lambda v: f"{v:.4g}")
    return f"<div class='dw-scroll'>{table}</div>"


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


def _diagnosis_section(diag: Mapping[str, Any]) -> str:
    rows = []
    for c in (diag.get("candidates") or [])[:6]:
        est = ", ".join(f"{k} = {v:.3g}" for k, v in (c.get("estimate") or {}).items() if isinstance(v, int | float))
        gain, p = c.get("gain"), c.get("p_value")
        rows.append(f"<tr><td><code>{html.escape(str(c.get('variant') or c['mechanism']))}</code></td>"
                    f"<td>{html.escape(est)}</td><td>{gain:.3g}</td><td>{p:.2g}</td>"
                    f"<td>{'yes' if c.get('significant') else 'no'}</td></tr>"
                    if isinstance(gain, int | float) and isinstance(p, int | float) else "")
    flights = list(diag.get("flights") or [])
    before = (diag.get("baseline") or {}).get("metrics") or {}
    after = (diag.get("extended") or {}).get("prediction_metrics") or {}
    metrics = "".join(f"<tr><td>{k}</td><td>{before[k]:.3g}</td><td>{after.get(k, float('nan')):.3g}</td></tr>"
                      for k in ("chi2", "chi2_per_feature", "sigma_w_ratio_rmse") if k in before)
    head = ("<h2>Diagnosis: what the simulation gets wrong</h2>"
            f"<p class='dw-verdict'><strong>Verdict.</strong> {html.escape(verdict_sentence(diag))}</p>")
    if not flights:
        return head
    return (head + f"<p>{len(flights)} payload flights ({html.escape(flight_list(flights))})"
            " were compared with the forward model at the conditions measured by the reference mast. Ranked "
            "candidates (fitted on all flights, scored on flights left out):</p>"
            "<table><thead><tr><th>mechanism</th><th>estimate</th><th>held-out gain</th><th>p-value</th>"
            f"<th>significant</th></tr></thead><tbody>{''.join(rows)}</tbody></table>"
            + ("<p>Misfit before (baseline) and after (extended model rerun with new seeds):</p><table><thead><tr>"
               "<th>metric</th><th>baseline</th><th>extended</th></tr></thead>"
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
            + "".join(f"<p class='dw-verdict'><strong>Verdict.</strong> {html.escape(v)}</p>"
                      for v in rigid.get("verdict") or [])
            + "<table><thead><tr><th>flight</th><th>gain_h</th><th>gain_v</th><th>heading offset [°]</th>"
            "<th>lag [s]</th><th>p (g = 1)</th><th>named</th><th>held-out gain</th>"
            "<th>hover spectral gain_h / gain_v (biased, not used)</th></tr></thead>"
            f"<tbody>{''.join(rows)}</tbody></table>"
            f"<p>Uncertainties: weighted least squares over the segments, weights from the turbulence's sampling "
            f"error of each segment mean and the segment-to-segment scatter beyond it.{extra} Assumption: "
            f"{html.escape(str(first.get('assumption', '')))}.</p>"
            "<p>Segments (time from the record's start [s], speed [m s⁻¹], course [°]):</p>"
            "<table><thead><tr><th>flight</th><th>kind</th><th>time [s]</th><th>speed [m s⁻¹]</th><th>course [°]</th>"
            f"</tr></thead><tbody>{''.join(seg_rows)}</tbody></table>")


def _published_section(diag: Mapping[str, Any]) -> str:
    base = (diag.get("baseline") or {}).get("chi2")
    fit = (diag.get("named_fit") or {}).get("chi2")
    change = (f" Misfit to the published numbers: χ² {base:.1f} (baseline) → {fit:.1f} (with the named causes)."
              if isinstance(base, int | float) and isinstance(fit, int | float) else "")
    return (f"<h2>The paper's published numbers ({html.escape(PAPERS['000'])})</h2>"
            "<p>Tables 4-5 and the claims of Sects 5.2 and 6 fitted with the same forward model, "
            f"at the Table 4 conditions of {html.escape(flight_list(diag.get('flights') or []))}.</p>"
            f"<p class='dw-verdict'><strong>Result.</strong> {html.escape(verdict_sentence(diag) + change)}</p>")


def _quadrotor_section(qdiag: Mapping[str, Any] | None, calibration: Path) -> str:
    parts = [f"<h2>Quadrotor fleet ({html.escape(PAPERS['001'])}; wind tunnel: {html.escape(PAPERS['002'])})</h2>"]
    if qdiag is not None:
        named = list(qdiag.get("named_causes") or [])
        ext = qdiag.get("extended_model") or {}
        speed = ext.get("speed_rmse_ms") or {}
        text = (f"Named causes: {', '.join(named)}." if named else "No mechanism is significant.")
        if speed:
            text += (f" Wind-speed RMSE of the single-law model {speed.get('before', float('nan')):.2f} m s⁻¹ → "
                     f"{speed.get('after', float('nan')):.2f} m s⁻¹ with {', '.join(ext.get('named') or [])} "
                     f"({ext.get('heldout', 'held out')}).")
        parts.append(f"<p class='dw-verdict'><strong>Verdict.</strong> {html.escape(text)}</p>")
    if calibration.exists():
        parts.append("<p>Calibration per UAV:</p>" + csv_html(
            calibration, ["uav", "pitch_offset_deg", "yaw_offset_deg", "rmse_ms", "bias_ms", "n_windows",
                          "n_windows_validation"]))
    return "".join(parts)


def _figure_section(figures: Mapping[str, str], captions: Mapping[str, str]) -> str:
    items = []
    for name, path in figures.items():
        link = f"javascript:app.showResultInfo('{quote(str(Path(path)), safe='/')}')"
        items.append(f"<li><a href=\"{link}\">{html.escape(Path(path).name)}</a>: "
                     f"{html.escape(captions.get(name, ''))}</li>")
    return "<h2>Figures</h2><ul>" + "".join(items) + "</ul>" if items else ""


def _summary(results: Path, campaign: str, figures: Mapping[str, str], captions: Mapping[str, str]) -> str:
    parts = [_FRONT_STYLE, _STYLE, "<div class='dw-report'>", f"<h1>Campaign {html.escape(campaign)}</h1>"]
    record = _read_json(results / "campaign.json") or {}
    content = record.get("manifest_content") or {}
    n_payload, n_quad = len(content.get("payload_flights") or []), len(content.get("quadrotor_flights") or [])
    parts.append(f"<p>{n_payload} payload flights, {n_quad} quadrotor flights"
                 f"{', simulated (virtual campaign)' if record.get('simulated') else ''}; site "
                 f"{html.escape(str((content.get('site') or {}).get('name', '?')))}. dronewind "
                 f"{html.escape(str(record.get('dronewind_version', '')))}, configuration "
                 f"{html.escape(str(record.get('config_sha256', ''))[:12])}.</p>")
    if (diag := _read_json(results / "diagnosis.json")) is not None:
        if diag.get("flights") or not diag.get("rigid_mount"):
            parts.append(_diagnosis_section(diag))
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
        table = pd.read_csv(blocks)
        usable = table["usable"].astype(str).str.lower().isin(("true", "1"))
        parts.append(f"<h2>Tower and mast records in blocks</h2><p>{len(table)} blocks of "
                     f"{table.groupby(['record', 'sensor']).ngroups} sonic(s), {int(usable.sum())} usable; every "
                     "block in the table page <code>block_stats</code> (tables/block_stats.csv).</p>")
    parts.append(_figure_section(figures, captions))
    parts.append("<h2>References</h2><ul>" + "".join(f"<li>{html.escape(r)}</li>" for r in REFERENCES.values())
                 + "</ul></div>")
    return "\n".join(parts) + "\n"


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
    written.append(atomic_write_text(out / "summary.html", _summary(results, campaign, figures, captions)))
    LOG.info("report pages: %d figure captions, %d tables, front page %s", len(figures), len(tables),
             out / "summary.html")
    return written
