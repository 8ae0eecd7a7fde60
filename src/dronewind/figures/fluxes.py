r"""Fluxes, Obukhov length and their random uncertainty, drone against mast (Ghirardelli et al. 2025, Figs 13, 16).

Drawn from the stored L4 covariances, Obukhov length and uncertainty metrics (Ghirardelli et al. (2025),
Eqs 10-13, computed and stored by the L4 step) with the drone-vs-mast scatter panels of
:mod:`dronewind.figures.scatter`.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes

from dronewind.core.products import load_l4_products
from dronewind.errors import InputError
from dronewind.figures.scatter import Quantity, scatter_figure, scatter_legend, scatter_panels
from dronewind.figures.style import UNIT_KMS, UNIT_M2S2, PathLike, add_notes, new_figure, save_figure

__all__ = ["fig13_fluxes_obukhov", "fig16_uncertainty"]

#: Quantities whose uncertainty Fig. 16 shows: (suffix of the L4 metric, label).
UNCERTAINTY_QUANTITIES: tuple[tuple[str, str], ...] = (
    ("sigma_u2", "$\\sigma_u^2$"), ("sigma_v2", "$\\sigma_v^2$"), ("sigma_w2", "$\\sigma_w^2$"),
    ("uw", "$\\overline{u'w'}$"), ("vw", "$\\overline{v'w'}$"), ("wT", "$\\overline{w'\\theta_v'}$"))


def fig13_fluxes_obukhov(l4_files: Iterable[PathLike], out_stem: PathLike) -> list[Path]:
    r"""Fig. 13: drone vs mast covariances :math:`\overline{u'w'}`, :math:`\overline{v'w'}`,
    :math:`\overline{w'\theta_v'}` and the Obukhov length :math:`L`.

    Parameters
    ----------
    l4_files : iterable of path
        L4 files (``uw_m2s2``, ``vw_m2s2``, ``wT_Kms``, ``L_m``).
    out_stem : str or Path
        Output path without suffix.

    Returns
    -------
    list of Path
        PNG and PDF.

    Notes
    -----
    L on symmetric-log axes (linear within ±10^n m around zero), since it changes sign.
    """
    return scatter_figure(l4_files, out_stem, (
        ("uw_m2s2", "$\\overline{u'w'}$", UNIT_M2S2), ("vw_m2s2", "$\\overline{v'w'}$", UNIT_M2S2),
        ("wT_Kms", "$\\overline{w'\\theta_v'}$", UNIT_KMS), ("L_m", "$L$", "m")), ncols=2, symlog=("L_m",))


def _uncertainty_quantities(metric: str) -> list[Quantity]:
    """Panels of Fig. 16 for the metric ``"a"`` or ``"eps"`` (dimensionless)."""
    if metric not in ("a", "eps"):
        raise InputError("fig16_uncertainty(metric)", f"expected 'a' or 'eps', got {metric!r}")
    sym = "a" if metric == "a" else "\\epsilon"
    return [(f"{metric}_{n}", f"${sym}$ of {lab}", "–") for n, lab in UNCERTAINTY_QUANTITIES]


def _low_uncertainty_patch(ax: Axes, threshold: float, letter: str) -> None:
    """Axes from just below 0 (markers at 0 stay whole), the green square below ``threshold``, 1:1, the letter."""
    lo, hi = ax.get_xlim()
    top = max(hi, 1.1 * threshold)
    ax.set_xlim(-0.04 * top, top)
    ax.set_ylim(-0.04 * top, top)
    ax.fill_between([0.0, threshold], 0.0, threshold, color="tab:green", alpha=0.25, lw=0, zorder=0)
    ax.plot([0.0, top], [0.0, top], color="k", lw=0.8, ls="--")
    ax.set_title(f"({letter})", fontsize=9, loc="left")


def fig16_uncertainty(l4_files: Iterable[PathLike], out_stem: PathLike, metric: str = "a",
                      threshold: float = 0.5) -> list[Path]:
    r"""Fig. 16: random-uncertainty metrics, drone (y) vs mast (x), with the low-uncertainty patch.

    Parameters
    ----------
    l4_files : iterable of path
        L4 files (``a_sigma_u2`` ... ``a_wT``, or ``eps_*``).
    out_stem : str or Path
        Output path without suffix.
    metric : {"a", "eps"}
        ``"a"``: Ghirardelli et al. (2025), Eqs 10-13 (time scale z/U); ``"eps"``: relative random error
        from the measured integral time scale of the product series.
    threshold : float
        Side of the green low-uncertainty square (Ghirardelli et al. (2025): 0.5).

    Returns
    -------
    list of Path
        PNG and PDF.

    Raises
    ------
    InputError
        ``metric`` is neither ``"a"`` nor ``"eps"``.
    """
    quantities = _uncertainty_quantities(metric)
    l4 = load_l4_products(l4_files)
    fig = new_figure(3.0 * 3 + 1.4, 3.0 * 2 + 0.2)
    axes = np.atleast_1d(fig.subplots(2, 3)).ravel()
    notes: list[str] = []
    scatter_panels(l4, axes, quantities, notes, one_to_one=False)
    for ax, letter in zip(axes, "abcdef", strict=True):
        _low_uncertainty_patch(ax, threshold, letter)
    scatter_legend(fig, l4)
    return save_figure(fig, out_stem, add_notes(fig, notes))
