"""Measurement model of a mast CSAT3 sonic (Ghirardelli et al. 2025, Sect. 4: 10 Hz, 30 m and 60 m).

Takes the true ENU wind and sonic temperature at the sensor and returns what the
logger writes to TOA5: CSAT3 components ``Ux, Uy, Uz`` for the sensor's azimuth
(``docs/data-contract.md``, "Frames and signs"), ``Ts`` in degree C, ``diag_csat``, RECORD numbers
(which may skip) and ``NaN`` for bad samples (written as ``"NAN"``).

The flow the sonic sees may be distorted by its tower and boom (:func:`flow_distortion`,
``simulation.mast`` settings ``boom_blockage_deficit``, ``tower_wake_deficit``,
``tower_wake_half_width_deg``, ``streamline_tilt_deg``; all off by default).

References
----------
IEC 61400-12-1 Ed. 1 (2005): Power performance measurements of electricity producing wind
turbines, Annex G (mounting of instruments on the meteorological mast).
McCaffrey, K., Quelet, P. T., Choukulkar, A., Wilczak, J. M., Wolfe, D. E., Oncley, S. P.,
Brewer, W. A., Debnath, M., Ashton, R., Iungo, G. V. and Lundquist, J. K. (2017):
Identification of tower-wake distortions using sonic anemometer and lidar measurements,
Atmos. Meas. Tech. 10, 393-407.
Wyngaard, J. C. (1981): Cup, propeller, vane, and sonic anemometers in turbulence research,
Annu. Rev. Fluid Mech. 13, 399-423.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from dronewind.core.angles import deg2rad, rad2deg, wrap_180
from dronewind.core.constants import ZERO_CELSIUS_K

__all__ = ["CsatRecord", "enu_to_csat3", "flow_distortion", "mast_measurement", "DISTORTION_KEYS"]


@dataclass(frozen=True)
class CsatRecord:
    """What the logger writes for one CSAT3 (output of :func:`mast_measurement`).

    Attributes
    ----------
    keep : numpy.ndarray
        Bool mask of rows written (False where the RECORD number skips).
    record : numpy.ndarray
        RECORD numbers (int64).
    ux_ms, uy_ms, uz_ms : numpy.ndarray
        CSAT3 components [m s-1] (NaN where bad).
    ts_c : numpy.ndarray
        Sonic temperature [degree C] (NaN where bad).
    diag_csat : numpy.ndarray
        Diagnostic word (int64; 0 good, 4096 low amplitude, 61440 values lost).
    n_nan, n_diag, n_skipped : int
        Rows written with NaN, rows written with a warning flag, rows skipped.
    """

    keep: np.ndarray
    record: np.ndarray
    ux_ms: np.ndarray
    uy_ms: np.ndarray
    uz_ms: np.ndarray
    ts_c: np.ndarray
    diag_csat: np.ndarray
    n_nan: int
    n_diag: int
    n_skipped: int


def enu_to_csat3(u_east_ms: np.ndarray, v_north_ms: np.ndarray, w_up_ms: np.ndarray,
                 azimuth_deg: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """CSAT3 components from east, north, up wind.

    Parameters
    ----------
    u_east_ms, v_north_ms, w_up_ms : numpy.ndarray
        Wind [m s-1].
    azimuth_deg : float
        Azimuth the sensor head points to, clockwise from true north [degree].

    Returns
    -------
    ux_ms, uy_ms, uz_ms : numpy.ndarray
        Ux > 0 for wind blowing from the azimuth into the head; right-handed, z up.

    Notes
    -----
    Inverse of the data contract's :math:`u_E = -U_x\\sin\\alpha + U_y\\cos\\alpha`,
    :math:`u_N = -U_x\\cos\\alpha - U_y\\sin\\alpha`:

    .. math:: U_x = -u_E\\sin\\alpha - u_N\\cos\\alpha,\\qquad
              U_y = u_E\\cos\\alpha - u_N\\sin\\alpha,\\qquad U_z = w
    """
    a = deg2rad(azimuth_deg)
    ue, vn = np.asarray(u_east_ms, float), np.asarray(v_north_ms, float)
    return -ue * np.sin(a) - vn * np.cos(a), ue * np.cos(a) - vn * np.sin(a), np.asarray(w_up_ms, float)


#: ``simulation.mast`` settings of :func:`flow_distortion` and their "off" values.
DISTORTION_KEYS: dict[str, float] = {"boom_blockage_deficit": 0.0, "tower_wake_deficit": 0.0,
                                     "streamline_tilt_deg": 0.0}


def flow_distortion(u_east_ms: np.ndarray, v_north_ms: np.ndarray, w_up_ms: np.ndarray, azimuth_deg: float,
                    settings: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The wind at a boom-mounted sonic, distorted by the boom and the tower behind it.

    Parameters
    ----------
    u_east_ms, v_north_ms, w_up_ms : numpy.ndarray
        Undisturbed wind [m s-1].
    azimuth_deg : float
        Azimuth the sensor head (and its boom, away from the tower) points to [degree].
    settings : mapping
        ``boom_blockage_deficit`` B (fractional), ``tower_wake_deficit`` D (fractional),
        ``tower_wake_half_width_deg`` h [degree], ``streamline_tilt_deg`` tau [degree]
        (missing keys: no distortion).

    Returns
    -------
    u_east_ms, v_north_ms, w_up_ms : numpy.ndarray
        Distorted wind [m s-1].

    Notes
    -----
    With :math:`\\gamma` the instantaneous direction the wind comes from relative to the
    boom azimuth (0: wind along the boom into the head, 180: through the tower), the
    horizontal wind is multiplied by

    .. math:: F(\\gamma) = 1 - B\\max(\\cos\\gamma, 0) - D\\cos^2\\left(\\frac{\\pi}{2}
              \\frac{180 - |\\gamma|}{h}\\right)[180 - |\\gamma| < h]

    (upstream blockage of the tower, largest for wind along the boom, IEC 61400-12-1
    Annex G; a cosine-squared tower wake of half-width h, McCaffrey et al. 2017), then
    turned upward by tau in the vertical plane of the instantaneous horizontal wind
    (streamline tilt of the boom and tower, Wyngaard 1981):
    :math:`U_h' = U_h\\cos\\tau - w\\sin\\tau`, :math:`w' = U_h\\sin\\tau + w\\cos\\tau`.

    Unlike the catalog's ``mast_w_attenuation`` (a constant gain on w, whatever the wind
    direction, no effect on the mean wind), this scales the *horizontal* wind - its mean
    and its fluctuations - by a factor that depends on the wind direction, and the tilt
    mixes the horizontal wind into w (a mean w of :math:`U_h\\sin\\tau`, which a tilt
    correction of the mast data removes) instead of scaling w.
    """
    ue, vn, wu = (np.asarray(x, dtype=float) for x in (u_east_ms, v_north_ms, w_up_ms))
    blockage = float(settings.get("boom_blockage_deficit", 0.0))
    wake = float(settings.get("tower_wake_deficit", 0.0))
    half_width = float(settings.get("tower_wake_half_width_deg", 30.0))
    tau = deg2rad(float(settings.get("streamline_tilt_deg", 0.0)))
    wind_from = rad2deg(np.arctan2(-ue, -vn))
    gamma = wrap_180(wind_from - azimuth_deg)
    behind = 180.0 - np.abs(gamma)                              # angle from the tower's wake axis
    factor = 1.0 - blockage * np.maximum(np.cos(deg2rad(gamma)), 0.0)
    factor = factor - wake * np.where(behind < half_width, np.cos(0.5 * np.pi * behind / half_width) ** 2, 0.0)
    ue, vn = factor * ue, factor * vn
    if tau != 0.0:
        speed = np.hypot(ue, vn)
        ratio = np.divide(speed * np.cos(tau) - wu * np.sin(tau), speed, out=np.ones_like(speed), where=speed > 0)
        ue, vn, wu = ratio * ue, ratio * vn, speed * np.sin(tau) + wu * np.cos(tau)
    return ue, vn, wu


def mast_measurement(u_east_ms: np.ndarray, v_north_ms: np.ndarray, w_up_ms: np.ndarray,
                     t_sonic_k: np.ndarray, azimuth_deg: float, settings: Mapping[str, float],
                     rng: np.random.Generator, mechanisms: Mapping[str, Mapping[str, float]] | None = None,
                     first_record: int = 0) -> CsatRecord:
    """Simulate the CSAT3 record written by the logger.

    Parameters
    ----------
    u_east_ms, v_north_ms, w_up_ms : numpy.ndarray
        True wind at the sensor [m s-1].
    t_sonic_k : numpy.ndarray
        True sonic temperature [K].
    azimuth_deg : float
        Sensor azimuth [degree].
    settings : mapping
        ``simulation.mast`` settings (noise_ms, temperature_noise_k,
        temperature_offset_k, nan_rate, diag_rate, record_skip_rate and the optional
        flow distortion of :func:`flow_distortion`, applied to the true wind first).
    rng : numpy.random.Generator
        Random stream of this sensor.
    mechanisms : mapping, optional
        Active mechanisms; ``mast_w_attenuation`` {gain} scales the vertical
        component before noise (tower/head flow distortion).
    first_record : int
        RECORD number of the first sample.

    Returns
    -------
    CsatRecord
        Rows kept, RECORD numbers, components and temperature (NaN where bad), the
        diagnostic word and the counts of bad, flagged and skipped rows.
    """
    mechanisms = mechanisms or {}
    n = np.asarray(u_east_ms).size
    if any(settings.get(key, off) != off for key, off in DISTORTION_KEYS.items()):
        u_east_ms, v_north_ms, w_up_ms = flow_distortion(u_east_ms, v_north_ms, w_up_ms, azimuth_deg, settings)
    ux, uy, uz = enu_to_csat3(u_east_ms, v_north_ms, w_up_ms, azimuth_deg)
    gain = mechanisms.get("mast_w_attenuation", {}).get("gain", 1.0)
    uz = gain * uz
    noise = rng.standard_normal((4, n))
    ux = ux + settings["noise_ms"] * noise[0]
    uy = uy + settings["noise_ms"] * noise[1]
    uz = uz + settings["noise_ms"] * noise[2]
    ts = np.asarray(t_sonic_k, float) - ZERO_CELSIUS_K + settings["temperature_offset_k"] \
        + settings["temperature_noise_k"] * noise[3]
    draws = rng.random((3, n))
    bad = draws[0] < settings["nan_rate"]
    flagged = (draws[1] < settings["diag_rate"]) & ~bad
    skipped = draws[2] < settings["record_skip_rate"]
    diag = np.zeros(n, dtype=np.int64)
    diag[bad] = 61440           # all four CSAT3 warning flags set, values lost
    diag[flagged] = 4096        # low signal amplitude flag, value kept but suspect
    for arr in (ux, uy, uz, ts):
        arr[bad] = np.nan
    keep = ~skipped
    return CsatRecord(keep=keep, record=first_record + np.arange(n, dtype=np.int64),
                      ux_ms=ux, uy_ms=uy, uz_ms=uz, ts_c=ts, diag_csat=diag,
                      n_nan=int(bad[keep].sum()), n_diag=int(flagged[keep].sum()),
                      n_skipped=int(skipped.sum()))
