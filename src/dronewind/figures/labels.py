"""Names shared by the figures, their captions and the report, without matplotlib.

The captions and the report pages cite the papers and describe the markers; they import
these names from here, so that a job writing the report does not import matplotlib
(:mod:`dronewind.figures.style` re-exports them for the figures).
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["HEIGHT_MARKERS", "PAPERS", "REFERENCES", "PathLike"]

PathLike = str | Path

#: Markers of the reference heights, lowest first (seed 000: circles 30 m, triangles 60 m).
HEIGHT_MARKERS = ("o", "^", "s", "D", "v", "P")

#: The three papers the project follows (``../shared/papers/000_*``, ``001_*``, ``002_*``), cited by
#: authors and year in captions and reports.
PAPERS = {
    "000": "Ghirardelli et al. (2025)",
    "001": "Wetz et al. (2021)",
    "002": "Kistner et al. (2024)",
}
#: Full references of :data:`PAPERS`, for the report.
REFERENCES = {
    "000": "Ghirardelli, M., Kral, S. T., Cheynet, E., and Reuder, J.: SAMURAI-S: Sonic Anemometer on a "
           "Multi-Rotor drone for Atmospheric turbulence Investigation in a Sling load configuration, "
           "Atmos. Meas. Tech., 2025.",
    "001": "Wetz, T., Wildmann, N., and Beyrich, F.: Distributed wind measurements with multiple quadrotor "
           "unmanned aerial vehicles in the atmospheric boundary layer, Atmos. Meas. Tech., 14, 3795-3814, 2021.",
    "002": "Kistner, J., Neuhaus, L., and Wildmann, N.: High resolution wind speed measurements with quadcopter "
           "UAS: calibration and verification in a wind tunnel with active grid, Atmos. Meas. Tech., 2024.",
}
