"""Figure of the published-numbers diagnosis: baseline and extended model against the paper's claims.

Drawn from the stored before/after summary (``before_after.json``, written by
:func:`dronewind.steps.published.published_report`) and the published numbers (Ghirardelli et al. (2025),
Table 5 and the claims of Sects. 5.2 and 6). Presentation-only arithmetic: the stored
linear fit of the σ_w excess evaluated along the wind-speed axis.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from dronewind.figures.style import save_figure

__all__ = ["published_before_after_figure"]

#: Marker style of each model.
MODEL_STYLES: dict[str, dict[str, Any]] = {
    "baseline": dict(marker="o", color="0.5", label="baseline model"),
    "extended": dict(marker="s", color="tab:red", label="extended model"),
}


def _models(a: Axes, b: Axes, summary: Mapping[str, Any]) -> None:
    """Per-flight points of both models: σ_w excess against U (with the stored fit), and the quadrant."""
    for model, style in MODEL_STYLES.items():
        per = summary["claims"][model]["per_flight"]
        u = np.array([v["U_ms"] for v in per.values()])
        d = np.array([v["dsigma_w_ms"] for v in per.values()])
        a.plot(u, d, ls="none", **style)
        fit = summary["dsigma_w"][model]
        xx = np.linspace(0, max(u.max(), 11), 10)
        a.plot(xx, fit["intercept_ms"] + fit["slope_per_ms"] * xx, color=style["color"], lw=0.8)
        b.plot([v["Sw_Su_mast"] for v in per.values()], [v["Sw_Su_drone"] for v in per.values()], ls="none",
               **style)


def _sigma_w_panel(a: Axes, summary: Mapping[str, Any]) -> None:
    """The published Table 5 points (stars) and the labels of the σ_w-excess panel."""
    points = summary["dsigma_w"].get("published_table5", {}).get("points", {})
    for k, (u, d) in points.items():
        a.plot(u, d, marker="*", ms=14, color="k", ls="none", label="Table 5" if k == sorted(points)[0] else None)
        a.annotate(k, (u, d), textcoords="offset points", xytext=(5, 5))
    a.axhline(0, color="k", lw=0.5)
    a.set_xlabel("mean wind speed at the mast, Table 4 (m s$^{-1}$)")
    a.set_ylabel(r"$\sigma_{w,\mathrm{drone}} - \sigma_{w,\mathrm{mast}}$ (m s$^{-1}$)")
    a.set_title("σ_w excess against wind speed (Sect. 5.2)")
    a.legend(fontsize=8)


def _quadrant_panel(b: Axes, claims: Mapping[str, Any]) -> None:
    """Isotropic lines, the published drone maximum and mast minimum (and range) of <S_w/S_u>."""
    iso = 4.0 / 3.0
    b.axhline(iso, color="k", lw=0.6)
    b.axvline(iso, color="k", lw=0.6)
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


def published_before_after_figure(summary: Mapping[str, Any], pub: Mapping[str, Any], png: Path,
                                  pdf: Path) -> list[Path]:
    """σ_w excess against wind speed and the <S_w/S_u> quadrant, baseline and extended model vs the paper.

    Parameters
    ----------
    summary : mapping
        Before/after summary (``dronewind.diagnose.published.rerun_summary``): per-flight
        ``U_ms``, ``dsigma_w_ms``, ``Sw_Su_mast``, ``Sw_Su_drone`` of each model, the
        fitted ``dsigma_w`` lines and the published Table 5 points.
    pub : mapping
        Published numbers (``claims``: ``sw_su_drone_max``, ``sw_su_mast_min``, optional
        ``sw_su_mast_range``).
    png, pdf : Path
        Output files; they must share a stem.

    Returns
    -------
    list of Path
        PNG and PDF.

    Raises
    ------
    ValueError
        ``png`` and ``pdf`` have different stems.
    """
    stem = png.with_suffix("")
    if pdf.with_suffix("") != stem:
        raise ValueError(f"figure outputs must share a stem: {png} and {pdf}")
    fig = Figure(figsize=(10, 4.2))
    FigureCanvasAgg(fig)
    a, b = fig.subplots(1, 2)
    _models(a, b, summary)
    _sigma_w_panel(a, summary)
    _quadrant_panel(b, pub["claims"])
    fig.tight_layout()
    return save_figure(fig, stem)
