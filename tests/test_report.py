"""The HTML report: front page (verdict, tables, figures) written from stored results, rendered in a browser."""

from __future__ import annotations

import html
import json
import re
import subprocess
from pathlib import Path

import pytest

from dronewind.figures.campaign import figure_captions
from dronewind.figures.captions import verdict_sentence
from dronewind.steps.report import REPORT_TABLES, markdown_html, report_pages
from dronewind.tables import table_flight_statistics, table_flights
from tests.products_fixture import write_products

NAMED = {
    "campaign": "demo", "flights": ["s01", "s02", "s03"],
    "baseline": {"metrics": {"chi2": 41.0, "chi2_per_feature": 2.1, "sigma_w_ratio_rmse": 0.2}},
    "candidates": [
        {"mechanism": "w_gain", "variant": None, "estimate": {"gain": 1.21}, "uncertainty": {"gain": 0.03},
         "gain": 0.74, "p_value": 1e-6, "significant": True},
        {"mechanism": "heading_bias", "variant": None, "estimate": {"deg": 0.4}, "uncertainty": {"deg": 0.6},
         "gain": 0.01, "p_value": 0.4, "significant": False},
    ],
    "named_causes": ["w_gain"],
    "named_estimates": {"w_gain": {"estimate": {"gain": 1.21}, "uncertainty": {"gain": 0.03}, "gain": 0.74}},
    "extended": {"prediction_metrics": {"chi2": 19.0, "chi2_per_feature": 0.95, "sigma_w_ratio_rmse": 0.08}},
    "goodness_of_fit": {"chi2": 19.0, "dof": 20, "p_value": 0.52},
    "unexplained": [{"feature": "ln_hf_w", "mean_z": 2.4, "slope_per_ms": 0.1}],
}


def test_verdict_sentence_names_causes_estimates_gains_and_what_remains() -> None:
    text = verdict_sentence(NAMED)
    assert text.startswith("Named cause: w_gain (gain = 1.21 ± 0.03; held-out gain 0.74).")
    assert "p = 0.52" in text and "Still unexplained" in text and "ln_hf_w (offset z +2.4)" in text
    none = verdict_sentence({"named_causes": [], "candidates": NAMED["candidates"][1:], "unexplained": []})
    assert none.startswith("No cause named") and none.endswith("Nothing remains unexplained.")
    assert verdict_sentence({"candidates": [], "note": "1 usable flight(s)"}) == "Not diagnosed: 1 usable flight(s)."


def test_markdown_subset_to_html() -> None:
    out = markdown_html("# Title\n\nSome **bold** and `code` <x>.\n\n| a | b |\n|---|---|\n| 1 | 2 |\n\n- one\n- two\n"
                        "\\* footnote\n")
    assert "<h2>Title</h2>" in out and "<strong>bold</strong>" in out and "<code>code</code>" in out
    assert "&lt;x&gt;" in out and "<th>a</th>" in out and "<td>2</td>" in out and "<li>two</li>" in out
    assert "<p>* footnote</p>" in out


def test_report_pages_from_stored_results(tmp_path: Path) -> None:
    root = write_products(tmp_path / "products")
    l4 = sorted((root / "netcdf" / "L4").glob("*.nc"))
    table_flights(l4, root / "tables" / "table4_flights")
    table_flight_statistics(l4, root / "tables" / "table5_statistics")
    (root / "diagnosis.json").write_text(json.dumps(NAMED))
    (root / "diagnosis").mkdir()
    (root / "diagnosis" / "report.md").write_text("# Diagnosis of demo\n\n| a | b |\n|---|---|\n| 1 | 2 |\n")
    figures = {name: f"results/demo/figures/{name}.png" for name in figure_captions()}
    tables = ["table4_flights", "table5_statistics", "flight_stats", "diagnosis_evidence"]
    written = report_pages(root, root / "report", figures, tables)
    assert len(written) == len(figures) + len(tables) + 1
    summary = (root / "report" / "summary.html").read_text()
    assert "Named cause: w_gain (gain = 1.21 ± 0.03; held-out gain 0.74)" in summary
    assert "Table 4 (dronewind)" in summary and "Table 5 (dronewind)" in summary and summary.count("<table") >= 4
    assert "javascript:app.showResultInfo('results/demo/figures/fig15_quadrant.png')" in summary
    assert "Ghirardelli, M., Kral, S. T." in summary
    caption = (root / "report" / "captions" / "fig12_mean_and_sigma.rst").read_text()
    assert caption.startswith("{% raw %}") and "reference sonic at 60 m" in caption
    for name in tables:
        page = (root / "report" / "tables" / f"{name}.html").read_text()
        assert page.startswith("<!doctype html>") and REPORT_TABLES[name][0] in page and "<table" in page
    with pytest.raises(KeyError, match="no caption for figure 'quadrotor_fig3_individual'"):
        report_pages(root, tmp_path / "other", {"quadrotor_fig3_individual": "x.png"}, [])


def _visible_text(dom: str) -> str:
    app = dom[dom.find('id="app"'):]
    app = re.sub(r"<(script|style)\b.*?</\1>", " ", app, flags=re.S)
    return re.sub(r"\s+", " ", html.unescape(re.sub(r"<[^>]+>", " ", app)))


@pytest.mark.slow
def test_html_report_front_page_in_a_browser(small_campaign_run, small_campaign_report: Path,
                                              chromium: str) -> None:
    *_, results = small_campaign_run
    page = small_campaign_report
    source = page.read_text(errors="replace")
    categories = json.loads(re.search(r"var categories = (\{.*?\});\s*</script>", source, re.S).group(1))
    assert set(categories) == {"Campaign", "Diagnosis", "Payload validation", "Tables"}
    assert all("Other" not in subcats for subcats in categories.values()), categories
    assert "Other" not in categories

    dom = subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu", "--virtual-time-budget=10000",
                          "--dump-dom", page.as_uri()], capture_output=True, text=True, timeout=300, check=True).stdout
    text = _visible_text(dom)
    diag = json.loads((results / "diagnosis.json").read_text())
    assert "Campaign smallcamp" in text
    assert f"Verdict. {verdict_sentence(diag)}" in text  # the front page opens on the verdict
    front = dom[dom.find('id="app"'):]
    assert "Table 4 (dronewind)" in text and "Table 5 (dronewind)" in text and "Flight statistics" in text
    assert front.count("<table") >= 3 and re.search(r"<td>s01</td>\s*<td>mast30</td>", front)
    for name in [*figure_captions(), "diagnosis_residuals", "diagnosis_spectra"]:
        assert f"showResultInfo('{results}/figures/{name}.png')" in front, name
    assert "for s01 (30 m, mast ū" in text  # captions state this campaign's flights and heights
    for category in ("Campaign", "Diagnosis", "Payload validation", "Tables"):
        assert category in text
