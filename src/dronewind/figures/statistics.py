r"""Mean wind, standard deviations and integral scales, drone against mast (Ghirardelli et al. 2025, Figs 12, 14).

Drawn from the stored L4 statistics with :func:`dronewind.figures.scatter.scatter_figure`.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from dronewind.figures.scatter import scatter_figure
from dronewind.figures.style import UNIT_MS, PathLike

__all__ = ["drone_spectra_png", "fig12_mean_and_sigma", "fig14_length_scales"]


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


def drone_spectra_png(products: dict, dpi: int = 100) -> bytes:
    r"""PNG of the frequency-weighted spectra :math:`f S_u, f S_v, f S_w` of flights without a reference.

    One panel per flight (at most four), log-log, with a :math:`f^{-2/3}` line through the
    median of :math:`f S_u` in the band :math:`2 < f z/\bar u < 10` (the inertial subrange's slope of
    the weighted spectrum) and that band shaded; from the stored L4 spectra only. Returned as bytes
    for the front page, which embeds it.

    Parameters
    ----------
    products : dict
        ``{flight: xarray.Dataset}``: the drone L4 products.
    dpi : int
        Resolution [dots per inch].

    Returns
    -------
    bytes
        The PNG (empty when no flight has stored spectra).
    """
    import io

    import numpy as np

    from dronewind.figures.style import log_axes, new_figure, panel_letters

    flights = [f for f, ds in products.items() if "S_u" in ds.variables and "frequency" in ds.variables][:4]
    if not flights:
        return b""
    fig = new_figure(4.2 * len(flights), 3.6)
    for k, flight in enumerate(flights):
        ds = products[flight]
        ax = fig.add_subplot(1, len(flights), k + 1)
        f = np.asarray(ds["frequency"].values, dtype=float)
        for comp, colour in (("u", "tab:blue"), ("v", "tab:green"), ("w", "tab:red")):
            s = np.asarray(ds[f"S_{comp}"].values, dtype=float)
            ok = np.isfinite(s) & (s > 0) & (f > 0)
            ax.plot(f[ok], f[ok] * s[ok], color=colour, lw=1.0, label=f"$f\\,S_{comp}$")
        if "f_r" in ds.variables:
            f_r = np.asarray(ds["f_r"].values, dtype=float)
            band = (f_r > 2.0) & (f_r < 10.0) & np.isfinite(f)
            if band.any():
                ax.axvspan(float(f[band].min()), float(f[band].max()), color="0.9", zorder=0,
                           label="$2 < f z/\\bar u < 10$")
                su = np.asarray(ds["S_u"].values, dtype=float)
                mid = float(np.exp(np.mean(np.log(f[band]))))
                level = float(np.nanmedian(f[band] * su[band]))
                x = np.array([f[band].min() / 3.0, f[band].max() * 3.0])
                ax.plot(x, level * (x / mid) ** (-2.0 / 3.0), "k--", lw=0.8, label="$f^{-2/3}$")
        log_axes(ax)
        ax.set(xlabel="frequency f (Hz)", ylabel="f S (m$^2$ s$^{-2}$)", title=f"{flight}, drone")
        ax.legend(fontsize=7, loc="lower left", frameon=False)
    panel_letters(fig)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi, metadata={"Software": None})
    return buffer.getvalue()
