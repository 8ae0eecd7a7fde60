"""The HTML report: front page (verdict, tables, figures) written from stored results, rendered in a browser."""

from __future__ import annotations

import html
import json
import re
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from dronewind.compare.validation import plausibility_flags, validation_rows
from dronewind.core.products import load_l4_products
from dronewind.core.verdict import verdict, verdict_sentence
from dronewind.diagnose.report import markdown as diagnosis_markdown
from dronewind.figures.campaign import figure_captions
from dronewind.steps.report import (
    REPORT_TABLES,
    column_decimals,
    column_label,
    frame_html,
    front_page_numbers,
    markdown_html,
    report_pages,
)
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
    figures = {name: str(root / "figures" / f"{name}.png") for name in figure_captions()}
    tables = ["table4_flights", "table5_statistics", "flight_stats", "diagnosis_evidence"]
    written = report_pages(root, root / "report", figures, tables)
    assert len(written) == len(figures) + len(tables) + 1
    summary = (root / "report" / "summary.html").read_text()
    assert "Named cause: w_gain (gain = 1.21 ± 0.03; held-out gain 0.74)" in summary
    assert "Table 4 (dronewind)" in summary and "Table 5 (dronewind)" in summary and summary.count("<table") >= 4
    assert "javascript:" not in summary  # the page works as a file: links relative to it
    assert 'href="../figures/fig15_quadrant.png"' in summary
    assert summary.index("Drone against mast") < summary.index("Verdict.")  # the answer first
    assert "site ?" not in summary and "site P2OA Lannemezan" in summary
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
    assert f"Verdict. {verdict_sentence(diag)}" in text  # the verdict follows the validation answer
    assert text.index("Drone against mast") < text.index("Verdict.")
    front = dom[dom.find('id="app"'):]
    assert "Table 4 (dronewind)" in text and "Table 5 (dronewind)" in text and "Flight statistics" in text
    assert front.count("<table") >= 3 and re.search(r"<td>s01</td>\s*<td>mast30</td>", front)
    for name in [*figure_captions(), "diagnosis_residuals", "diagnosis_spectra"]:
        assert f'href="../figures/{name}.png"' in front, name
    assert "for s01 (30 m, mast ū" in text  # captions state this campaign's flights and heights
    for category in ("Campaign", "Diagnosis", "Payload validation", "Tables"):
        assert category in text


AT_BOUND = {
    "campaign": "demo", "flights": ["s01", "s02", "s03"], "named_causes": [],
    "baseline": {"metrics": {"chi2": 79.6, "chi2_per_feature": 0.55, "sigma_w_ratio_rmse": 0.1}},
    "candidates": [{"mechanism": "sling_dz", "variant": None, "estimate": {"dz_m": -20.0}, "uncertainty": {"dz_m": 3},
                    "gain": 0.2, "p_value": 0.001, "significant": False, "at_bound": True}],
    "extended": {"prediction_metrics": {"chi2": 79.6, "chi2_per_feature": 0.55, "sigma_w_ratio_rmse": 0.1}},
    "goodness_of_fit": {"chi2": 79.6, "dof": 144, "p_value": 0.99999},
    "unexplained": [],
}


def _numbers(text: str) -> set[str]:
    return set(re.findall(r"χ² = ([0-9.]+)", text)) | set(re.findall(r"p = ([0-9.e-]+)", text))


@pytest.mark.parametrize("diag", [NAMED, AT_BOUND], ids=["named", "none-named"])
def test_one_source_of_truth_front_page_report_md_and_json(tmp_path: Path, diag: dict) -> None:
    """summary.html, diagnosis/report.md and diagnosis.json state the same verdict and the same misfit numbers."""
    root = tmp_path / "results" / "demo"
    (root / "diagnosis").mkdir(parents=True)
    (root / "diagnosis.json").write_text(json.dumps(diag))
    md = diagnosis_markdown(diag, {"chi2": 70.0}, {"chi2": 72.7}, [])
    (root / "diagnosis" / "report.md").write_text(md)
    report_pages(root, root / "report", {}, [])
    page = html.unescape(re.sub(r"<[^>]+>", "", (root / "report" / "summary.html").read_text()))
    v = verdict(diag)
    gof = diag["goodness_of_fit"]
    for text in (page, md.replace("**", "")):
        assert v.headline.split(":")[0] in text
        assert f"χ² = {gof['chi2']:.3g} for {gof['dof']} residuals" in text
        assert _numbers(text) >= {f"{gof['chi2']:.3g}"}
        # "no cause named" never beside "with the named causes"
        assert not ("No cause named" in text and "with the named cause" in text)
    assert _numbers(page) <= _numbers(md)
    for key, _label, base, after in front_page_numbers(root)["misfit"]:
        assert base == diag["baseline"]["metrics"][key] and after == diag["extended"]["prediction_metrics"][key]
        assert f"{base:.3g}" in page and f"{base:.3g}" in md and f"{after:.3g}" in md
    assert "72.7" not in page  # the rerun check is labelled as such, on the diagnosis page only
    if diag is AT_BOUND:
        assert "overestimated" in page and "conservative" in md  # p ≈ 1 explained
        assert "at a bound: not identified" in page and "at bound: not identified" in md


def test_table_formatting_for_reading() -> None:
    assert column_label("rmse_ms") == "RMSE (m s⁻¹)"
    assert column_label("bias_ms") == "bias (m s⁻¹)"
    assert column_label("pitch_offset_deg") == "pitch offset (°)"
    assert column_label("uw_m2s2") == "u'w' (m² s⁻²)"
    assert column_decimals([21.04, 19.3, 25.0]) == 1 and column_decimals([-4.111e-05, 2e-5]) == 7 - 1
    frame = pd.DataFrame({"flight": ["s01", "s02"], "usable": [1, 0], "U_ms": [21.04, 3.1],
                          "unusable_reason": ["", "hover height 41 m against a target of 60 m " * 3]})
    out = frame_html(frame)
    assert "<td>yes</td>" in out and "<td>no</td>" in out and "True" not in out
    assert "<th>U (m s⁻¹)</th>" in out and "<td>21.0</td>" in out and "<td>3.1</td>" in out
    assert "class='dw-text'" in out  # long text wraps


def test_validation_rows_and_flags(tmp_path: Path) -> None:
    root = write_products(tmp_path / "products")
    products = load_l4_products(sorted((root / "netcdf" / "L4").glob("*.nc")))
    rows = {r["statistic"]: r for r in validation_rows(products)}
    assert set(rows) >= {"U_ms", "wind_from_deg", "sigma_u_ms", "sigma_v_ms", "sigma_w_ms", "uw_m2s2", "wT_Kms",
                         "Sw_Su", "slope_u", "slope_w"}
    s = rows["sigma_w_ms"]
    assert s["n"] == 3 and "s04" not in s["flights"]  # unusable drone record left out
    assert np.isfinite(s["bias"]) and s["rmse"] >= abs(s["bias"]) and np.isfinite(s["sampling_rms"])
    assert np.isfinite(rows["U_ms"]["slope"]) and np.isnan(rows["U_ms"]["sampling_rms"])
    drone = products["s01"]["drone"].copy()
    drone["Sw_Su"] = drone["Sw_Su"] * 0 + 0.42
    drone.attrs["lag_sonic_ins_s"] = -0.6
    flags = plausibility_flags({"x1": {"drone": drone}})
    assert any("⟨S_w/S_u⟩ = 0.42, far from isotropy" in f for f in flags)
    assert any("lag = -0.60 s" in f for f in flags)


def test_tower_and_autopilot_pages(tmp_path: Path) -> None:
    """A campaign without drone records: its own statistics, no "site ?", no drone paper cited."""
    root = tmp_path / "results" / "tower"
    (root / "tables").mkdir(parents=True)
    (root / "campaign.json").write_text(json.dumps({"campaign": "tower", "manifest_content": {
        "site": {"latitude": 38.1, "longitude": -121.6}, "masts": [{"id": "t", "sonics": [{"id": "csat3"}]}]}}))
    pd.DataFrame({"record": ["t", "t"], "sensor": ["csat3", "csat3"], "height_m": [7.11, 7.11],
                  "start_utc": ["2012-06-07T12:45:00Z", "2012-06-07T13:00:00Z"],
                  "end_utc": ["2012-06-07T13:00:00Z", "2012-06-07T13:15:00Z"], "U_ms": [1.47943, 1.57144],
                  "Sw_Su": [0.41, 1.3], "usable": [True, False],
                  "reason": ["", "missing fraction 0.9999 > processing.max_missing_fraction 0.02"]}).to_csv(
        root / "tables" / "block_stats.csv", index=False)
    report_pages(root, root / "report", {}, [])
    page = (root / "report" / "summary.html").read_text()
    assert "site ?" not in page and "1 mast sonic." in page
    assert "Ghirardelli" not in page and "Wetz" not in page and "Kistner" not in page
    assert "<td>1.48</td>" in page and "<td>yes</td>" in page and "<td>no</td>" in page
    assert "far from isotropy" in page and "csat3 2012-06-07T12:45:00Z (0.41)" in page


@pytest.mark.slow
def test_workflow_front_page_report_md_and_json_agree(small_campaign_run) -> None:
    """In a workflow run the three state the same verdict and misfit numbers, written from diagnosis.json."""
    *_, results = small_campaign_run
    diag = json.loads((results / "diagnosis.json").read_text())
    md = (results / "diagnosis" / "report.md").read_text().replace("**", "")
    page = html.unescape(re.sub(r"<[^>]+>", "", (results / "report" / "summary.html").read_text()))
    v = verdict(diag)
    for sentence in v.sentences():
        assert sentence in page, sentence
    assert v.headline.split(":")[0] in md
    if v.fit:
        assert v.fit.split(": ", 1)[1] in md  # the same goodness-of-fit sentence after its label
    for _key, _label, base, after in front_page_numbers(results)["misfit"]:
        assert f"{base:.3g}" in page and f"{base:.3g}" in md
        if after is not None:
            assert f"{after:.3g}" in page and f"{after:.3g}" in md
    assert "Drone against mast" in page and "javascript:" not in page


def test_validation_table_files(tmp_path: Path) -> None:
    from dronewind.steps.report import write_validation_table

    root = write_products(tmp_path / "products")
    csv, md = write_validation_table(sorted((root / "netcdf" / "L4").glob("*.nc")), tmp_path / "validation")
    table = pd.read_csv(csv)
    rows = {r["statistic"]: r for r in validation_rows(load_l4_products(sorted((root / "netcdf" / "L4").glob("*.nc"))))}
    assert table.set_index("statistic").loc["sigma_w_ms", "rmse"] == rows["sigma_w_ms"]["rmse"]  # full precision
    assert "| σ_w (m s⁻¹) | 3 |" in md.read_text()
