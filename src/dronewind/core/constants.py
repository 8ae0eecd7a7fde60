"""Physical constants used across dronewind (one definition each).

Every module that needs one of these imports it from here; values are those the papers use.
"""

from __future__ import annotations

#: von Karman constant [1] (Ghirardelli et al. (2025), Eq. 9).
KARMAN: float = 0.40
#: Gravitational acceleration [m s-2] (Ghirardelli et al. (2025), Sect. 2.3 and Eq. 9; Wetz et al. (2021), Eq. 9).
GRAVITY_MS2: float = 9.81
#: 0 degC in kelvin [K].
ZERO_CELSIUS_K: float = 273.15
#: WGS84 semi-major axis [m].
WGS84_A_M: float = 6378137.0
#: WGS84 first eccentricity squared [1].
WGS84_E2: float = 6.69437999014e-3

__all__ = ["GRAVITY_MS2", "KARMAN", "WGS84_A_M", "WGS84_E2", "ZERO_CELSIUS_K"]


CP_DRY_JKGK = 1004.0
