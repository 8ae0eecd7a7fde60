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
.. [1] Ghirardelli et al. (2025), Figs 4, 7-16 and B1-B2 with their
   captions; Sects. 3.3, 4 and 5, Appendix B.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Sequence
from pathlib import Path

from dronewind.core.products import load_l4_products
from dronewind.core.progress import Progress
from dronewind.figures.fluxes import fig13_fluxes_obukhov, fig16_uncertainty
from dronewind.figures.labels import figure_captions
from dronewind.figures.positions import fig07_positions
from dronewind.figures.quadrant import fig15_quadrant
from dronewind.figures.spectra import (
    fig09_velocity_spectra,
    fig11_temperature_spectra,
    figB1_normalised_velocity_spectra,
    figB2_normalised_temperature_spectra,
)
from dronewind.figures.statistics import fig12_mean_and_sigma, fig14_length_scales
from dronewind.figures.style import PathLike
from dronewind.figures.synchronisation import fig04_tke_lag
from dronewind.figures.timeseries import fig08_timeseries, fig10_temperature_series

__all__ = ["FIGURE_FUNCTIONS", "draw_all", "figure_captions"]

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


def draw_all(results_dir: PathLike, figures_dir: PathLike, flights: Sequence[str] | None = None,
             names: Collection[str] | None = None) -> list[Path]:
    """Draw every campaign figure (or those named) from a ``results/<campaign>/`` tree.

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
    names : collection of str, optional
        Only these figures (keys of :data:`FIGURE_FUNCTIONS`); all by default.

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
    if names is not None:
        unknown = sorted(set(names) - set(FIGURE_FUNCTIONS))
        if unknown:
            raise ValueError(f"unknown campaign figure(s) {unknown}; expected names of {sorted(FIGURE_FUNCTIONS)}")
        drawers = [(name, draw) for name, draw in drawers if name in set(names)]
    progress = Progress("figure", len(drawers), "drawn")
    paths: list[Path] = []
    for name, draw in drawers:
        with progress.item(name):
            paths += draw(out / name)
    progress.finished()
    return paths
