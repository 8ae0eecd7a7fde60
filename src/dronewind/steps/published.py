"""The paper's published numbers as data, from files to files (see :mod:`dronewind.diagnose.published`).

1. :func:`published_forward` (per stationary sample): forward-model baseline and probe
   runs at the Table 4 conditions.
2. :func:`published_diagnosis`: fit every mechanism to Table 5 and the claims; JSON.
3. :func:`published_rerun` (per sample): baseline and extended model rerun with fresh
   seeds; Table 5-like statistics.
4. :func:`published_report`: Markdown report and the before/after figure.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from dronewind.core.cf import atomic_write_text
from dronewind.manifest import load_campaign
from dronewind.steps.common import LOG
from dronewind.steps.diagnosis import write_json

__all__ = ["published_forward", "published_diagnosis", "published_rerun", "published_report"]


def published_forward(published_file: str | Path, manifest: str | Path, flight_id: str, output: str | Path,
                      config: Mapping[str, Any]) -> Path:
    """Forward-model runs (baseline seeds and every probe) of one sample at its Table 4 conditions."""
    from dronewind.diagnose import forward
    from dronewind.diagnose import published as dp

    pub = dp.load_published(published_file)
    campaign = load_campaign(manifest)
    conditions = dp.table4_conditions(pub, flight_id, campaign.data)
    LOG.info("sample %s: Table 4 conditions %s", flight_id, conditions)
    runs = forward.probe_runs(campaign.data, flight_id, conditions, config,
                              seeds=tuple(config.get("diagnosis", {}).get("seeds", (101, 202))))
    return write_json(output, runs)


def published_diagnosis(published_file: str | Path, forward_files: Sequence[str | Path], output: str | Path,
                        config: Mapping[str, Any]) -> Path:
    """Fit and score every mechanism against the published numbers; write JSON."""
    from dronewind.diagnose import published as dp

    pub = dp.load_published(published_file)
    forward = {}
    for path in forward_files:
        run = json.loads(Path(path).read_text())
        forward[run["flight"]] = run
    diag_cfg = config.get("diagnosis", {})
    result = dp.analyse(pub, forward, alpha=float(diag_cfg.get("alpha", 0.01)),
                        max_causes=int(min(diag_cfg.get("max_causes", 2), 2)))
    LOG.info("published numbers: named %s, baseline chi2 %.1f", result["named_causes"], result["baseline"]["chi2"])
    return write_json(output, result)


def published_rerun(published_file: str | Path, manifest: str | Path, flight_id: str, diagnosis_json: str | Path,
                    output: str | Path, config: Mapping[str, Any], seeds: Sequence[int] = (303, 404)) -> Path:
    """Baseline and extended model of one sample at Table 4 conditions (common random numbers per seed)."""
    from dronewind.diagnose import forward
    from dronewind.diagnose import published as dp

    pub = dp.load_published(published_file)
    campaign = load_campaign(manifest)
    diag = json.loads(Path(diagnosis_json).read_text())
    conditions = dp.table4_conditions(pub, flight_id, campaign.data)
    out: dict[str, Any] = {"flight": flight_id, "seeds": list(seeds), "mechanisms": diag["extended_mechanisms"],
                           "baseline": [], "extended": []}
    for seed in seeds:
        for model, mechanisms in (("baseline", []), ("extended", diag["extended_mechanisms"])):
            feats, products = forward.run_forward(
                forward.forward_manifest(campaign.data, flight_id, conditions, mechanisms, seed), flight_id, config)
            out[model].append(dp.flight_summary(products["l3"], feats.values))
        LOG.info("sample %s: seed %d rerun done", flight_id, seed)
    return write_json(output, out)


def published_report(published_file: str | Path, diagnosis_json: str | Path, rerun_files: Sequence[str | Path],
                     output_md: str | Path, output_json: str | Path, figure_png: str | Path,
                     figure_pdf: str | Path) -> list[Path]:
    """Markdown report, before/after numbers (JSON) and the figure of the published-numbers diagnosis."""
    from dronewind.diagnose import published as dp

    pub = dp.load_published(published_file)
    diag = json.loads(Path(diagnosis_json).read_text())
    reruns = {}
    for path in rerun_files:
        r = json.loads(Path(path).read_text())
        reruns[r["flight"]] = r
    summary = dp.rerun_summary(reruns, pub)
    write_json(output_json, summary)
    atomic_write_text(output_md, dp.markdown(diag, summary, pub))
    _figure(summary, pub, Path(figure_png), Path(figure_pdf))
    return [Path(output_md), Path(output_json), Path(figure_png), Path(figure_pdf)]


def _figure(summary: Mapping[str, Any], pub: Mapping[str, Any], png: Path, pdf: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from dronewind.figures.payload import save_figure

    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4.2))
    styles = {"baseline": dict(marker="o", color="0.5", label="baseline model"),
              "extended": dict(marker="s", color="tab:red", label="extended model")}
    for model, style in styles.items():
        per = summary["claims"][model]["per_flight"]
        u = np.array([v["U_ms"] for v in per.values()])
        d = np.array([v["dsigma_w_ms"] for v in per.values()])
        a.plot(u, d, ls="none", **style)
        fit = summary["dsigma_w"][model]
        xx = np.linspace(0, max(u.max(), 11), 10)
        a.plot(xx, fit["intercept_ms"] + fit["slope_per_ms"] * xx, color=style["color"], lw=0.8)
        b.plot([v["Sw_Su_mast"] for v in per.values()], [v["Sw_Su_drone"] for v in per.values()], ls="none",
               **style)
    points = summary["dsigma_w"].get("published_table5", {}).get("points", {})
    for k, (u, d) in points.items():
        a.plot(u, d, marker="*", ms=14, color="k", ls="none", label="Table 5" if k == sorted(points)[0] else None)
        a.annotate(k, (u, d), textcoords="offset points", xytext=(5, 5))
    a.axhline(0, color="k", lw=0.5)
    a.set_xlabel("mean wind speed at the mast, Table 4 [m s$^{-1}$]")
    a.set_ylabel(r"$\sigma_{w,\mathrm{drone}} - \sigma_{w,\mathrm{mast}}$ [m s$^{-1}$]")
    a.set_title("σ_w excess against wind speed (Sect. 5.2)")
    a.legend(fontsize=8)
    iso = 4.0 / 3.0
    b.axhline(iso, color="k", lw=0.6)
    b.axvline(iso, color="k", lw=0.6)
    claims = pub["claims"]
    b.axhline(claims["sw_su_drone_max"]["value"], color="tab:blue", ls="--", lw=0.8, label="drone max (Sect. 6)")
    b.axvline(claims["sw_su_mast_min"]["value"], color="tab:green", ls="--", lw=0.8, label="mast min (Sect. 6)")
    if "sw_su_mast_range" in claims:
        lo, hi = claims["sw_su_mast_range"]["value"]
        b.axvspan(lo, hi, color="tab:green", alpha=0.08, label="mast range (Sect. 5.2)")
    lo_y, hi_y = b.get_ylim()
    b.set_ylim(min(lo_y, 1.2), max(hi_y, claims["sw_su_drone_max"]["value"] + 0.1))
    b.set_xlabel(r"mast $\langle S_w/S_u\rangle$")
    b.set_ylabel(r"drone $\langle S_w/S_u\rangle$")
    b.set_title("quadrants, 2 < f_r < 10 (Fig. 15)")
    b.legend(fontsize=7)
    fig.tight_layout()
    stem = png.with_suffix("")
    if pdf.with_suffix("") != stem:
        raise ValueError(f"figure outputs must share a stem: {png} and {pdf}")
    save_figure(fig, stem)
    plt.close(fig)
