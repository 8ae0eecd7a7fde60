r"""The campaign figures of Ghirardelli et al. (2025) as one set: captions, registry and :func:`draw_all`.

Every figure reads stored NetCDF files (L2, L3, L4; opened with
:func:`dronewind.core.products.open_product`) and the campaign record ``campaign.json``,
and draws; none recomputes a statistic, spectrum, fit or scale. Presentation-only
arithmetic is limited to: normalising a stored curve by a stored number (TKE by its
minimum, spectra by the stored variance or covariance), multiplying a stored spectrum by
its frequency, subtracting the stored mean temperature from the stored L3 series,
converting the stored GNSS latitude/longitude to metres east/north of the mast (the one
local tangent-plane projection, :func:`dronewind.core.geo.local_tangent_plane_m`) and the
stored GNSS altitude to height above the site.

Each figure is written as ``<out_stem>.png`` and ``<out_stem>.pdf`` by
:func:`dronewind.figures.style.save_figure` (deterministic bytes, see
:mod:`dronewind.figures.style`). A flight whose drone record is flagged unusable, or a
quantity that is NaN in the product, is never drawn silently: it is left out of the
comparison panels and listed in a note at the bottom of the figure with the stored reason
(the ``status_*`` flag of the quantity, or ``drone_unusable_reason``). Time series and
tracks of unusable flights (Figs 4, 7) are drawn in grey, dashed.

The figures by topic: :mod:`~dronewind.figures.synchronisation` (Fig. 4),
:mod:`~dronewind.figures.positions` (Fig. 7), :mod:`~dronewind.figures.timeseries`
(Figs 8, 10), :mod:`~dronewind.figures.spectra` (Figs 9, 11, B1, B2),
:mod:`~dronewind.figures.statistics` (Figs 12, 14), :mod:`~dronewind.figures.fluxes`
(Figs 13, 16), :mod:`~dronewind.figures.quadrant` (Fig. 15).

References
----------
.. [1] Seed 000 (``../shared/papers/000_*.txt``), Figs 4, 7-16 and B1-B2 with their
   captions; Sects. 3.3, 4 and 5, Appendix B.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

from dronewind.core.products import load_l4_products
from dronewind.core.progress import Progress
from dronewind.figures.fluxes import fig13_fluxes_obukhov, fig16_uncertainty
from dronewind.figures.positions import fig07_positions
from dronewind.figures.quadrant import fig15_quadrant
from dronewind.figures.spectra import (
    fig09_velocity_spectra,
    fig11_temperature_spectra,
    figB1_normalised_velocity_spectra,
    figB2_normalised_temperature_spectra,
)
from dronewind.figures.statistics import fig12_mean_and_sigma, fig14_length_scales
from dronewind.figures.style import PAPERS, PathLike
from dronewind.figures.synchronisation import fig04_tke_lag
from dronewind.figures.timeseries import fig08_timeseries, fig10_temperature_series

__all__ = ["FIGURE_FUNCTIONS", "draw_all", "figure_captions"]

P000 = PAPERS["000"]


def figure_captions() -> dict[str, str]:
    """Captions of the campaign figures, keyed by figure name (= function name = output stem).

    Returns
    -------
    dict of str to str
        Name -> what the figure shows, independent of any campaign (plain text). The
        report's captions say what a campaign's figure shows:
        :func:`dronewind.figures.captions.campaign_captions`.
    """
    return {
        "fig04_tke_lag": "Turbulent kinetic energy of the motion-corrected payload wind versus the lag added to "
        "the sonic clock relative to the INS, one curve per flight, each normalised by its minimum (after "
        f"{P000}, Fig. 4). Dashed and dash-dot vertical lines: smallest and largest lag of minimum TKE among "
        "the usable flights. Unusable flights grey, dashed.",
        "fig07_positions": "Left: payload height above ground (GNSS altitude minus site altitude) during the "
        "hover windows, with the mast sonic heights dotted. Right: payload position east/north of the mast, "
        "sonic head azimuths as black lines; coloured arrows from the median position point where the wind "
        "measured by the reference mast sonic blows to, its mean speed and direction in the legend "
        f"(after {P000}, Fig. 7).",
        "fig08_timeseries": "Streamwise (u), cross-wind (v) and vertical (w) velocity in streamline coordinates "
        "(L3, 8 Hz), drone (blue) and reference mast sonic (orange), for the detailed flights; titles give the "
        f"heights and mean speeds from L4 (after {P000}, Fig. 8).",
        "fig09_velocity_spectra": "Frequency-weighted spectra f S_u, f S_v, f S_w (log-log) and co-spectrum "
        "f Re(S_uw) (linear y), drone (blue) and mast (orange), with the blunt/pointed model fitted to the drone "
        f"(black, {P000} Eqs 4-7); standard deviations and u'w' in the panel titles (after {P000}, Fig. 9).",
        "fig10_temperature_series": "Sonic temperature fluctuations (minus the stored mean of each sensor), "
        f"drone (blue) and mast (orange), for the detailed flights; the means are in the legend (after {P000}, "
        "Fig. 10).",
        "fig11_temperature_spectra": "Frequency-weighted sonic-temperature spectrum f S_theta (log-log) and "
        "co-spectra f Re(S_w theta) and f Re(S_u theta) (linear y), drone (blue) and mast (orange) (after seed "
        "000, Fig. 11).",
        "fig12_mean_and_sigma": "Drone versus mast mean wind speed and standard deviations of u, v, w, one colour "
        "per flight, one marker per reference height (lowest first: circles, triangles, squares); dashed: "
        f"1:1 (after {P000}, Fig. 12).",
        "fig13_fluxes_obukhov": "Drone versus mast covariances u'w', v'w', w'theta_v' and Obukhov length L "
        f"(symmetric-log axes); markers as in Fig. 12 (after {P000}, Fig. 13).",
        "fig14_length_scales": "Drone versus mast integral length scales L_u, L_v, L_w (exponential fit of the "
        "autocovariance and Taylor's hypothesis); flights where I_u >= 0.5 or U <= 1 m s⁻¹ are left out and listed "
        f"(after {P000}, Fig. 14).",
        "fig15_quadrant": "Quadrant analysis of the frequency-averaged spectral ratios <S_w/S_u> (left) and "
        "<S_v/S_u> (right) over 2 < f z/U < 10, drone versus mast, coloured by the mast mean speed; lines at the "
        f"isotropic 4/3; grey triangles: mean speed below the low-wind limit (after {P000}, Figs 6 and 15).",
        "fig16_uncertainty": f"Normalised random-uncertainty metrics ({P000} Eqs 10-13) of the variances, "
        "momentum fluxes and buoyancy flux, drone (y) versus mast (x); green: below 0.5, low statistical "
        f"uncertainty (after {P000}, Fig. 16).",
        "figB1_normalised_velocity_spectra": "Spectra of u, v, w normalised by their variances, and the u-w "
        "co-spectrum normalised by u'w', drone (blue) and mast (orange), for the flights not shown in detail "
        f"(after {P000}, Fig. B1).",
        "figB2_normalised_temperature_spectra": "Sonic-temperature spectrum normalised by its variance and the "
        "w-theta and u-theta co-spectra normalised by their covariances, drone (blue) and mast (orange), for the "
        f"flights not shown in detail (after {P000}, Fig. B2).",
    }


#: Figure name -> function (all take the output stem as a keyword ``out_stem``).
FIGURE_FUNCTIONS = {
    "fig04_tke_lag": fig04_tke_lag,
    "fig07_positions": fig07_positions,
    "fig08_timeseries": fig08_timeseries,
    "fig09_velocity_spectra": fig09_velocity_spectra,
    "fig10_temperature_series": fig10_temperature_series,
    "fig11_temperature_spectra": fig11_temperature_spectra,
    "fig12_mean_and_sigma": fig12_mean_and_sigma,
    "fig13_fluxes_obukhov": fig13_fluxes_obukhov,
    "fig14_length_scales": fig14_length_scales,
    "fig15_quadrant": fig15_quadrant,
    "fig16_uncertainty": fig16_uncertainty,
    "figB1_normalised_velocity_spectra": figB1_normalised_velocity_spectra,
    "figB2_normalised_temperature_spectra": figB2_normalised_temperature_spectra,
}


def draw_all(results_dir: PathLike, figures_dir: PathLike, flights: Sequence[str] | None = None) -> list[Path]:
    """Draw every campaign figure from a ``results/<campaign>/`` tree.

    Parameters
    ----------
    results_dir : str or Path
        Campaign results folder (``netcdf/L2``, ``netcdf/L3``, ``netcdf/L4``,
        ``campaign.json``).
    figures_dir : str or Path
        Output folder; files are ``<name>.png`` and ``<name>.pdf`` for every name in
        :func:`figure_captions`.
    flights : sequence of str, optional
        Flights shown in detail (Figs 8-11); default first and seventh.

    Returns
    -------
    list of Path
        All written files.
    """
    root, out = Path(results_dir), Path(figures_dir)
    l2 = sorted((root / "netcdf" / "L2").glob("*_drone.nc"))
    l3 = sorted((root / "netcdf" / "L3").glob("*.nc"))
    l4_files = sorted((root / "netcdf" / "L4").glob("*_*.nc"))
    detail = None if flights is None else ([f for f in sorted({Path(p).stem.split("_")[0] for p in l4_files})
                                            if f not in set(flights)] or None)
    l4 = load_l4_products(l4_files)  # opened once for all figures (a quarter of this step's time when each opened them)
    drawers: list[tuple[str, Callable[[Path], list[Path]]]] = [
        ("fig04_tke_lag", lambda base: fig04_tke_lag(l2, base)),
        ("fig07_positions", lambda base: fig07_positions(l2, l4, root / "campaign.json", base)),
        ("fig08_timeseries", lambda base: fig08_timeseries(l3, l4, base, flights)),
        ("fig09_velocity_spectra", lambda base: fig09_velocity_spectra(l4, base, flights)),
        ("fig10_temperature_series", lambda base: fig10_temperature_series(l3, l4, base, flights)),
        ("fig11_temperature_spectra", lambda base: fig11_temperature_spectra(l4, base, flights)),
        ("fig12_mean_and_sigma", lambda base: fig12_mean_and_sigma(l4, base)),
        ("fig13_fluxes_obukhov", lambda base: fig13_fluxes_obukhov(l4, base)),
        ("fig14_length_scales", lambda base: fig14_length_scales(l4, base)),
        ("fig15_quadrant", lambda base: fig15_quadrant(l4, base)),
        ("fig16_uncertainty", lambda base: fig16_uncertainty(l4, base)),
        ("figB1_normalised_velocity_spectra", lambda base: figB1_normalised_velocity_spectra(l4, base, detail)),
        ("figB2_normalised_temperature_spectra",
         lambda base: figB2_normalised_temperature_spectra(l4, base, detail)),
    ]
    progress = Progress("figure", len(drawers), "drawn")
    paths: list[Path] = []
    for name, draw in drawers:
        with progress.item(name):
            paths += draw(out / name)
    progress.finished()
    return paths
