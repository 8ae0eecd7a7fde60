"""Geodesy: the one local tangent-plane projection of dronewind (WGS84).

Positions of drones, quadrotors and masts are compared as east/north offsets from a
reference point; every module that needs offsets from latitude/longitude (or the inverse)
uses these two functions, so all share one Earth model.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from dronewind.core.angles import deg2rad, rad2deg, wrap_180
from dronewind.core.constants import WGS84_A_M, WGS84_E2

__all__ = ["from_local_tangent_plane", "local_tangent_plane_m", "radii_of_curvature_m"]


def radii_of_curvature_m(lat0_deg: float) -> tuple[float, float]:
    """Meridian and prime-vertical radii of curvature of the WGS84 ellipsoid.

    Parameters
    ----------
    lat0_deg : float
        Latitude [degrees_north].

    Returns
    -------
    m_radius_m, n_radius_m : float
        Meridian radius :math:`M` and prime-vertical radius :math:`N` [m].
    """
    s2 = np.sin(deg2rad(lat0_deg)) ** 2
    m_radius = WGS84_A_M * (1.0 - WGS84_E2) / (1.0 - WGS84_E2 * s2) ** 1.5
    n_radius = WGS84_A_M / np.sqrt(1.0 - WGS84_E2 * s2)
    return float(m_radius), float(n_radius)

def local_tangent_plane_m(
    lat_deg: npt.ArrayLike, lon_deg: npt.ArrayLike, lat0_deg: float, lon0_deg: float
) -> tuple[np.ndarray, np.ndarray]:
    """East and north offsets from a reference point on a local tangent plane.

    Parameters
    ----------
    lat_deg, lon_deg : array_like
        Positions [degrees_north, degrees_east].
    lat0_deg, lon0_deg : float
        Reference point [degrees_north, degrees_east].

    Returns
    -------
    east_m, north_m : numpy.ndarray
        Offsets [m].

    Notes
    -----
    Small-offset approximation on the WGS84 ellipsoid, with meridian radius :math:`M` and
    prime-vertical radius :math:`N` at the reference latitude :math:`\\varphi_0`:

    .. math::

        M = \\frac{a (1 - e^2)}{(1 - e^2 \\sin^2\\varphi_0)^{3/2}}, \\quad
        N = \\frac{a}{(1 - e^2 \\sin^2\\varphi_0)^{1/2}}, \\quad
        \\Delta n = M \\Delta\\varphi, \\quad \\Delta e = N \\cos\\varphi_0 \\, \\Delta\\lambda .

    The relative error is of order (offset / 6400 km), i.e. far below a millimetre for a
    hover window of a few metres.
    """
    lat = np.asarray(lat_deg, dtype=float)
    lon = np.asarray(lon_deg, dtype=float)
    phi0 = deg2rad(lat0_deg)
    m_radius, n_radius = radii_of_curvature_m(lat0_deg)
    dlon = wrap_180(lon - lon0_deg)
    north_m = m_radius * deg2rad(lat - lat0_deg)
    east_m = n_radius * np.cos(phi0) * deg2rad(dlon)
    return east_m, north_m



def from_local_tangent_plane(
    east_m: npt.ArrayLike, north_m: npt.ArrayLike, lat0_deg: float, lon0_deg: float
) -> tuple[np.ndarray, np.ndarray]:
    """Latitude and longitude of east/north offsets from a reference point (inverse of
    :func:`local_tangent_plane_m`).

    Parameters
    ----------
    east_m, north_m : array_like
        Offsets from the reference point [m].
    lat0_deg, lon0_deg : float
        Reference point [degrees_north, degrees_east].

    Returns
    -------
    lat_deg, lon_deg : numpy.ndarray
        Positions [degrees_north, degrees_east]; longitude wrapped to [-180, 180).
    """
    m_radius, n_radius = radii_of_curvature_m(lat0_deg)
    lat = lat0_deg + rad2deg(np.asarray(north_m, dtype=float) / m_radius)
    lon = lon0_deg + rad2deg(np.asarray(east_m, dtype=float) / (n_radius * np.cos(deg2rad(lat0_deg))))
    return lat, wrap_180(lon)
