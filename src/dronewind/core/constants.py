"""Physical constants and published coefficients used across dronewind (one definition each).

Every module that needs one of these imports it from here; values are those the papers use.
"""

from __future__ import annotations

from typing import Any

#: von Karman constant [1] (Ghirardelli et al. (2025), Eq. 9).
KARMAN: float = 0.40
#: Gravitational acceleration [m s-2] (Ghirardelli et al. (2025), Sect. 2.3 and Eq. 9; Wetz et al. (2021), Eq. 9).
GRAVITY_MS2: float = 9.81
#: 0 degC in kelvin [K].
ZERO_CELSIUS_K: float = 273.15
#: Specific gas constant of dry air [J kg-1 K-1].
R_DRY_AIR_JKGK: float = 287.05
#: Specific heat of dry air at constant pressure [J kg-1 K-1] (dry-adiabatic lapse rate g/c_p).
CP_DRY_JKGK: float = 1004.0
#: Air density assumed constant in Wetz et al. (2021), Sect. 4.2 [kg m-3].
AIR_DENSITY_KGM3: float = 1.2
#: WGS84 semi-major axis [m].
WGS84_A_M: float = 6378137.0
#: WGS84 first eccentricity squared [1].
WGS84_E2: float = 6.69437999014e-3

#: Take-off mass of the Holybro QAV250 quadrotor, Wetz et al. (2021), Table 1 [kg].
WETZ2021_MASS_KG: float = 0.65
#: Universal aerodynamic parameters of Wetz et al. (2021), Eq. 18: drag area at zero tilt
#: ``cd0a0_m2`` [m2] and its slope on the tilt magnitude ``cp_m2_per_rad`` [m2 rad-1].
WETZ2021_AERO: dict[str, float] = {"cd0a0_m2": 0.03, "cp_m2_per_rad": -0.047}
#: Speed-range coefficients of Kistner et al. (2024), Table 2: upper edges of the
#: longitudinal ranges ``edges_ms`` [m s-1], ``b_x`` [-] and ``c_x`` [m s-1 (m s-2)^-b] per
#: range, lateral ``b_y``, ``c_y``.
KISTNER2024_RANGES: dict[str, Any] = {
    "edges_ms": [4.0, 12.0],
    "b_x": [0.784, 0.882, 0.635],
    "c_x": [6.338, 7.604, 8.600],
    "b_y": 0.860,
    "c_y": 5.600,
}

__all__ = [
    "AIR_DENSITY_KGM3", "CP_DRY_JKGK", "GRAVITY_MS2", "KARMAN", "KISTNER2024_RANGES", "R_DRY_AIR_JKGK",
    "WETZ2021_AERO", "WETZ2021_MASS_KG", "WGS84_A_M", "WGS84_E2", "ZERO_CELSIUS_K",
]
