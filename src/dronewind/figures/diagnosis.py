"""Figures of the campaign diagnosis: residuals and spectra before and after the named mechanisms.

Drawn from the diagnosis results the workflow step has read (``diagnosis.json``, the
evidence arrays of measured features, forward-model predictions and sampling errors, and
the stored binned spectra). Presentation-only arithmetic: residual = stored measured -
stored predicted, and a spectrum multiplied by its frequency. The feature names and their
labels are passed in, so this module does not import :mod:`dronewind.diagnose`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from matplotlib.axes import Axes

from dronewind.figures.style import UNIT_MS, log_axes, new_figure, save_figure

__all__ = ["RESIDUAL_FEATURES", "Evidence", "residuals_figure", "spectra_figure", "spread_by_speed"]

#: Features shown in the residual figure (3 x 3 panels).
RESIDUAL_FEATURES: tuple[str, ...] = (
    "ln_sigma_ratio_w", "ln_sigma_ratio_u", "sw_su_drone", "sw_su_mast", "dir_diff_deg", "tilt_diff_deg",
    "lag_sonic_ins_s", "ln_pendulum_w", "ln_hf_w",
)


class Evidence(Protocol):
    """What the figures read of the diagnosis evidence (``dronewind.diagnose.campaign.CampaignEvidence``)."""

    flights: list[str]
    y: np.ndarray
    sigma: np.ndarray
    baseline: np.ndarray
    conditions: list[dict[str, Any]]


def _named(diag: Mapping[str, Any]) -> str:
    """The verdict of ``diagnosis.json`` in a few words (for the figure titles)."""
    named = list(diag.get("named_causes") or [])
    if not named:
        return "no mechanism significant"
    return "named cause" + ("s" if len(named) > 1 else "") + ": " + ", ".join(named)


# ----------------------------------------------------------------------------- residuals


def _residual_panel(ax: Axes, ev: Evidence, after: np.ndarray | None, speed_ms: np.ndarray, j: int,
                    label: str) -> None:
    """Measured - predicted of feature column ``j`` against the mast wind speed, before and after."""
    if ev.flights:
        r0 = ev.y[:, j] - ev.baseline[:, j]
        ax.errorbar(speed_ms, r0, yerr=ev.sigma[:, j], fmt="o", color="tab:red", label="baseline", capsize=2)
    if ev.flights and after is not None and np.isfinite(after[:, j]).any():
        r1 = ev.y[:, j] - after[:, j]
        ax.errorbar(speed_ms + 0.1, r1, yerr=ev.sigma[:, j], fmt="s", color="tab:blue", label="extended model",
                    capsize=2)
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xlabel("mast mean wind speed (m s$^{-1}$)")
    ax.set_ylabel("measured − predicted")
    ax.set_title(label, fontsize=9)
    ax.grid(alpha=0.3)


def residuals_figure(ev: Evidence, after: np.ndarray | None, diag: Mapping[str, Any], out_dir: Path, *,
                     features: Sequence[str], labels: Mapping[str, str]) -> list[Path]:
    """Residuals against wind speed, before (baseline) and after (extended model).

    Parameters
    ----------
    ev : Evidence
        Evidence arrays (flights x features, columns in ``features`` order).
    after : numpy.ndarray or None
        Rerun extended-model features (flights x features).
    diag : mapping
        ``diagnosis.json`` content.
    out_dir : Path
        Folder for ``diagnosis_residuals.png``/``.pdf``.
    features : sequence of str
        Feature names of the evidence columns (``dronewind.diagnose.features.FEATURES``).
    labels : mapping
        Feature name -> panel title (``dronewind.diagnose.report.FEATURE_LABELS``).

    Returns
    -------
    list of Path
        Written files.
    """
    speed = np.array([c.get("mean_speed_ms", np.nan) for c in ev.conditions], dtype=float)
    fig = new_figure(12, 10)
    axes = fig.subplots(3, 3)
    for ax, feat in zip(axes.ravel(), RESIDUAL_FEATURES, strict=True):
        _residual_panel(ax, ev, after, speed, list(features).index(feat), labels[feat])
    if ev.flights:
        handles, names = axes[0, 0].get_legend_handles_labels()
        fig.legend(handles, names, loc="outside lower center", ncol=len(names), fontsize=8, frameon=False)
    note = "" if ev.flights else " (no usable flight)"
    fig.suptitle(f"Diagnosis of {diag.get('campaign')}: residuals before and after ({_named(diag)}){note}")
    return save_figure(fig, out_dir / "diagnosis_residuals", [note.strip(" ()")] if note else ())


# ----------------------------------------------------------------------------- spectra


def spread_by_speed(flights: list[str], speed_ms: Mapping[str, float], n_flights: int) -> list[str]:
    """Up to ``n_flights`` flights spread over the wind-speed range (lowest, middle, highest)."""
    flights = sorted(flights, key=lambda f: speed_ms[f])
    if len(flights) > n_flights:
        pick = np.unique(np.linspace(0, len(flights) - 1, n_flights).round().astype(int))
        flights = [flights[i] for i in pick]
    return flights


def _same_model(model: Mapping[str, Any], comp: str) -> bool:
    """Whether the extended model's drone spectrum is the baseline's (nothing named: one curve)."""
    base, ext = model.get("baseline"), model.get("extended")
    if not base or not ext:
        return False
    return bool(np.array_equal(np.asarray(base["f_hz"]), np.asarray(ext["f_hz"]))
                and np.allclose(base[f"drone_{comp}"], ext[f"drone_{comp}"], rtol=1e-9, atol=0.0))


def _spectra_panel(ax: Axes, measured: Mapping[str, Any], model: Mapping[str, Any], comp: str, title: str) -> None:
    """Premultiplied spectra of one component: measured drone and mast, baseline and extended model drone.

    When the extended model is the baseline (nothing named), one model curve is drawn and
    labelled so; otherwise the baseline (dashed) is drawn over the extended model.
    """
    f = np.asarray(measured["f_hz"])
    ax.plot(f, f * np.asarray(measured[f"drone_{comp}"]), color="k", lw=1.4, label="measured drone")
    ax.plot(f, f * np.asarray(measured[f"mast_{comp}"]), color="0.6", lw=1.0, label="measured mast")
    same = _same_model(model, comp)
    styles = {"extended": ("tab:blue", "-", 2, "extended model drone"),
              "baseline": ("tab:red", "--", 3, "baseline model drone")}
    if same:
        styles = {"baseline": ("tab:red", "-", 2, "model drone (baseline = extended: nothing named)")}
    for key, (colour, ls, z, label) in styles.items():
        s = model.get(key)
        if s:
            fm = np.asarray(s["f_hz"])
            ax.plot(fm, fm * np.asarray(s[f"drone_{comp}"]), color=colour, lw=1.0, ls=ls, zorder=z, label=label)
    log_axes(ax)
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("f (Hz)")
    ax.set_ylabel(f"$fS_{comp}$ (m$^2$ s$^{{-2}}$)")
    ax.grid(alpha=0.3, which="both")


def spectra_figure(ev: Evidence, measured: Mapping[str, Mapping[str, Any]], model: Mapping[str, Mapping[str, Any]],
                   diag: Mapping[str, Any], out_dir: Path, n_flights: int = 3) -> list[Path]:
    """Drone and mast spectra of u and w, measured against the model before and after.

    For up to ``n_flights`` flights spread over the wind-speed range (lowest, middle,
    highest mast wind speed): premultiplied spectra :math:`f S(f)` of the measured drone
    and mast and of the forward model without (baseline) and with the named mechanisms
    (extended; the same seed, so the difference is the mechanisms' effect).

    Parameters
    ----------
    ev : Evidence
        Evidence (flights and their conditions, for the mast wind speed).
    measured : mapping
        Flight -> ``binned_spectra`` of the measured flight.
    model : mapping
        Flight -> ``{"baseline": spectra, "extended": spectra}``.
    diag : mapping
        ``diagnosis.json`` content.
    out_dir : Path
        Folder for ``diagnosis_spectra.png``/``.pdf``.
    n_flights : int
        Most flights shown (one row each).

    Returns
    -------
    list of Path
        Written files.
    """
    speed = {f: c.get("mean_speed_ms", np.nan) for f, c in zip(ev.flights, ev.conditions, strict=True)}
    flights = spread_by_speed([f for f in ev.flights if f in measured and f in model], speed, n_flights)
    fig = new_figure(11, 3.4 * max(len(flights), 1))
    axes = np.atleast_2d(fig.subplots(max(len(flights), 1), 2))
    notes = [] if flights else ["no flight with stored spectra"]
    for row, flight in zip(axes, flights, strict=False):
        for ax, comp in zip(row, ("u", "w"), strict=True):
            _spectra_panel(ax, measured[flight], model[flight], comp,
                           f"{flight}, mast $\\bar u$ = {speed[flight]:.1f} {UNIT_MS}: $fS_{comp}$")
    if flights:
        handles, names = axes[0, 0].get_legend_handles_labels()
        fig.legend(handles, names, loc="outside lower center", ncol=len(names), fontsize=7.5, frameon=False)
    fig.suptitle(f"Diagnosis of {diag.get('campaign')}: spectra, measured vs model before/after ({_named(diag)})")
    return save_figure(fig, out_dir / "diagnosis_spectra", notes)
