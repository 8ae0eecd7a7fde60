r"""Mean wind, standard deviations and integral scales, drone against mast (Ghirardelli et al. 2025, Figs 12, 14).

Drawn from the stored L4 statistics with :func:`dronewind.figures.scatter.scatter_figure`.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from dronewind.figures.scatter import scatter_figure
from dronewind.figures.style import UNIT_MS, PathLike

__all__ = ["fig12_mean_and_sigma", "fig14_length_scales"]


def fig12_mean_and_sigma(l4_files: Iterable[PathLike], out_stem: PathLike) -> list[Path]:
    r"""Fig. 12: drone vs mast :math:`\bar u`, :math:`\sigma_u`, :math:`\sigma_v`, :math:`\sigma_w`.

    Parameters
    ----------
    l4_files : iterable of path
        L4 files (``U_ms``, ``sigma_*_ms``, mast ``height_m``).
    out_stem : str or Path
        Output path without suffix.

    Returns
    -------
    list of Path
        PNG and PDF.
    """
    return scatter_figure(l4_files, out_stem, (
        ("U_ms", "$\\bar u$", UNIT_MS), ("sigma_u_ms", "$\\sigma_u$", UNIT_MS),
        ("sigma_v_ms", "$\\sigma_v$", UNIT_MS), ("sigma_w_ms", "$\\sigma_w$", UNIT_MS)), ncols=2)


def fig14_length_scales(l4_files: Iterable[PathLike], out_stem: PathLike) -> list[Path]:
    r"""Fig. 14: drone vs mast integral length scales :math:`L_u`, :math:`L_v`, :math:`L_w`.

    Parameters
    ----------
    l4_files : iterable of path
        L4 files (``L_u_m``, ``L_v_m``, ``L_w_m``; NaN where Taylor's hypothesis fails,
        Ghirardelli et al. (2025), Eq. 16, with the reason in ``status_L_*``).
    out_stem : str or Path
        Output path without suffix.

    Returns
    -------
    list of Path
        PNG and PDF.
    """
    return scatter_figure(l4_files, out_stem, (
        ("L_u_m", "$L_u$", "m"), ("L_v_m", "$L_v$", "m"), ("L_w_m", "$L_w$", "m")), ncols=3)
