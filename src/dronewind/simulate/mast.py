"""Measurement model of a mast CSAT3 sonic (seed 000, Sect. 4: 10 Hz, 30 m and 60 m).

Takes the true ENU wind and sonic temperature at the sensor and returns what the
logger writes to TOA5: CSAT3 components ``Ux, Uy, Uz`` for the sensor's azimuth
(DESIGN.md, "Frames and signs"), ``Ts`` in degree C, ``diag_csat``, RECORD numbers
(which may skip) and ``NaN`` for bad samples (written as ``"NAN"``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from dronewind.core.constants import ZERO_CELSIUS_K

__all__ = ["CsatRecord", "enu_to_csat3", "mast_measurement"]


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
    Inverse of DESIGN.md's :math:`u_E = -U_x\\sin\\alpha + U_y\\cos\\alpha`,
    :math:`u_N = -U_x\\cos\\alpha - U_y\\sin\\alpha`:

    .. math:: U_x = -u_E\\sin\\alpha - u_N\\cos\\alpha,\\qquad
              U_y = u_E\\cos\\alpha - u_N\\sin\\alpha,\\qquad U_z = w
    """
    a = np.deg2rad(azimuth_deg)
    ue, vn = np.asarray(u_east_ms, float), np.asarray(v_north_ms, float)
    return -ue * np.sin(a) - vn * np.cos(a), ue * np.cos(a) - vn * np.sin(a), np.asarray(w_up_ms, float)


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
        temperature_offset_k, nan_rate, diag_rate, record_skip_rate).
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
