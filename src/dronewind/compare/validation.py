r"""The validation answer: drone against mast, per statistic, over a campaign's flights.

For each statistic a validation user looks for first (mean wind speed and direction,
:math:`\sigma_{u,v,w}`, :math:`\overline{u'w'}`, :math:`\overline{w'\theta_v'}`, the spectral
ratio :math:`\langle S_w/S_u\rangle` and the inertial-subrange slopes of :math:`S_u` and
:math:`S_w`) over the flights whose drone record is usable and where both sensors have a value:

* bias :math:`b = \overline{d - m}` with its standard error :math:`s_{d-m}/\sqrt{n}`;
* RMSE :math:`\sqrt{\overline{(d - m)^2}}` with its standard error by the delta method,
  :math:`s_{(d-m)^2} / (2\,\mathrm{RMSE}\,\sqrt{n})`;
* slope of the least-squares line drone = a + b mast with its standard error (:math:`n \ge 3`);
* the RMS difference that the sampling errors of both sensors alone produce,
  :math:`\sqrt{\overline{e_d^2 + e_m^2}}`, from the normalised random uncertainties of
  Ghirardelli et al. (2025), Eqs 10-13, stored in L4 (``a_sigma_u2`` ... ``a_wT``):
  :math:`e_\sigma = \sigma\,a_{\sigma^2}/2` (Eq. 13 is the relative error of the variance),
  :math:`e_{u'w'} = a_{uw}\,u_*^2` (Eq. 10), :math:`e_{w'\theta'} = a_{wT}\,|\overline{w'\theta_v'}|`
  (Eq. 12). An RMSE near it means the drone agrees with the mast within sampling error.

Direction differences are wrapped to (-180°, 180°]. The spectral slope is the least-squares
slope of :math:`\log S` against :math:`\log f` over the band of :math:`\langle S_w/S_u\rangle`,
:math:`2 < f z/\bar u < 10` (-5/3 in an inertial subrange), read from the stored L4 spectra.

:func:`plausibility_flags` lists stored values no correct record gives: a spectral ratio far
from the isotropic 4/3 and a large sonic-INS lag.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from dronewind.core.products import L4Products, drone_usable, stored_scalar

__all__ = ["ISOTROPY", "LAG_LIMIT_S", "SW_SU_FACTOR", "STATISTICS", "Statistic", "flight_values",
           "plausibility_flags", "spectral_slope", "validation_rows"]

#: Isotropic ratio S_w/S_u (and S_v/S_u) in the inertial subrange.
ISOTROPY = 4.0 / 3.0
#: S_w/S_u is flagged when it differs from :data:`ISOTROPY` by more than this factor either way.
SW_SU_FACTOR = 2.0
#: A sonic-INS (sonic-platform) lag above this [s] is flagged: one logger's clocks agree to a few samples.
LAG_LIMIT_S = 0.5
#: A spectral slope further than this from -5/3 is flagged.
SLOPE_TOLERANCE = 1.0
#: Band of the spectral slope and of <S_w/S_u> in f z/U.
SLOPE_BAND = (2.0, 10.0)


@dataclass(frozen=True)
class Statistic:
    """One statistic of the validation table.

    Attributes
    ----------
    key : str
        L4 variable (or ``slope_u``/``slope_w``, the spectral slopes).
    label : str
        Name for reading.
    unit : str
        Units as written on the page ("" for dimensionless).
    decimals : int
        Decimals of the bias and RMSE shown for reading.
    """

    key: str
    label: str
    unit: str
    decimals: int


#: The statistics of the validation answer, in reading order.
STATISTICS: tuple[Statistic, ...] = (
    Statistic("U_ms", "mean wind speed U", "m s⁻¹", 2),
    Statistic("wind_from_deg", "wind direction", "°", 1),
    Statistic("sigma_u_ms", "σ_u", "m s⁻¹", 3),
    Statistic("sigma_v_ms", "σ_v", "m s⁻¹", 3),
    Statistic("sigma_w_ms", "σ_w", "m s⁻¹", 3),
    Statistic("uw_m2s2", "u'w'", "m² s⁻²", 4),
    Statistic("wT_Kms", "w'θ_v'", "K m s⁻¹", 4),
    Statistic("Sw_Su", "⟨S_w/S_u⟩ (4/3 isotropic)", "", 2),
    Statistic("slope_u", "spectral slope of S_u (−5/3)", "", 2),
    Statistic("slope_w", "spectral slope of S_w (−5/3)", "", 2),
)


def spectral_slope(ds: xr.Dataset | None, component: str, band: tuple[float, float] = SLOPE_BAND) -> float:
    """Least-squares slope of log S against log f over ``band`` of f z/U (NaN with fewer than 3 bins)."""
    if ds is None or f"S_{component}" not in ds.variables or "f_r" not in ds.variables:
        return math.nan
    f_r = np.asarray(ds["f_r"].values, dtype=float).reshape(-1)
    s = np.asarray(ds[f"S_{component}"].values, dtype=float).reshape(-1)
    f = np.asarray(ds["frequency"].values, dtype=float).reshape(-1) if "frequency" in ds.coords else f_r
    ok = np.isfinite(f_r) & np.isfinite(s) & (s > 0) & (f > 0) & (f_r > band[0]) & (f_r < band[1])
    if ok.sum() < 3:
        return math.nan
    return float(np.polyfit(np.log(f[ok]), np.log(s[ok]), 1)[0])


def flight_values(ds: xr.Dataset | None) -> dict[str, float]:
    """One sensor's values of :data:`STATISTICS` (NaN where not stored)."""
    out = {s.key: stored_scalar(ds, s.key) for s in STATISTICS if not s.key.startswith("slope_")}
    out["slope_u"] = spectral_slope(ds, "u")
    out["slope_w"] = spectral_slope(ds, "w")
    return out


def _sampling_error(ds: xr.Dataset | None, key: str) -> float:
    """One sensor's random error of a statistic from Eqs 10-13 [units of the statistic] (NaN where none applies)."""
    if key.startswith("sigma_"):
        return stored_scalar(ds, key) * stored_scalar(ds, f"a_{key[:7]}2") / 2.0
    if key == "uw_m2s2":
        return stored_scalar(ds, "a_uw") * stored_scalar(ds, "u_star_ms") ** 2
    if key == "wT_Kms":
        return stored_scalar(ds, "a_wT") * abs(stored_scalar(ds, "wT_Kms"))
    return math.nan


def _wrap(deg: np.ndarray) -> np.ndarray:
    return -((-deg + 180.0) % 360.0 - 180.0)


def validation_rows(products: L4Products) -> list[dict[str, Any]]:
    """Bias, RMSE, slope and sampling error of every statistic, drone against mast.

    Parameters
    ----------
    products : L4Products
        ``{flight: {"drone": Dataset, "mast": Dataset}}``
        (:func:`dronewind.core.products.load_l4_products`).

    Returns
    -------
    list of dict
        One row per :data:`STATISTICS` entry: ``statistic``, ``label``, ``unit``, ``n``
        (flights used), ``flights``, ``bias``, ``bias_se``, ``rmse``, ``rmse_se``,
        ``slope``, ``slope_se``, ``intercept``, ``r2`` and ``sampling_rms`` (NaN where not
        defined). Flights whose drone record is unusable or without a mast are left out.
    """
    pairs = {f: (flight_values(p.get("drone")), flight_values(p.get("mast")), p)
             for f, p in products.items() if p.get("mast") is not None and drone_usable(p)[0]}
    rows = []
    for stat in STATISTICS:
        used = [f for f, (d, m, _) in pairs.items() if np.isfinite(d[stat.key]) and np.isfinite(m[stat.key])]
        d = np.array([pairs[f][0][stat.key] for f in used], dtype=float)
        m = np.array([pairs[f][1][stat.key] for f in used], dtype=float)
        if stat.key == "wind_from_deg" and len(used):
            diff = _wrap(d - m)
            centre = float(np.degrees(np.angle(np.mean(np.exp(1j * np.radians(m))))))
            m = centre + _wrap(m - centre)
            d = m + diff
        diff = d - m
        n = len(used)
        err = np.array([math.hypot(_sampling_error(pairs[f][2].get("drone"), stat.key),
                                   _sampling_error(pairs[f][2].get("mast"), stat.key)) for f in used])
        row: dict[str, Any] = {"statistic": stat.key, "label": stat.label, "unit": stat.unit, "n": n,
                               "flights": " ".join(used), "bias": math.nan, "bias_se": math.nan,
                               "rmse": math.nan, "rmse_se": math.nan, "slope": math.nan, "slope_se": math.nan,
                               "intercept": math.nan, "r2": math.nan,
                               "sampling_rms": float(np.sqrt(np.mean(err**2))) if n and np.isfinite(err).all()
                               else math.nan}
        if n:
            row["bias"] = float(diff.mean())
            row["rmse"] = float(np.sqrt(np.mean(diff**2)))
        if n >= 2:
            row["bias_se"] = float(diff.std(ddof=1) / math.sqrt(n))
            if row["rmse"] > 0:
                row["rmse_se"] = float((diff**2).std(ddof=1) / (2.0 * row["rmse"] * math.sqrt(n)))
        if n >= 3 and np.ptp(m) > 0:  # ordinary least squares, standard error with n - 2 degrees of freedom
            sxx = float(((m - m.mean()) ** 2).sum())
            slope = float(((m - m.mean()) * (d - d.mean())).sum() / sxx)
            intercept = float(d.mean() - slope * m.mean())
            sse = float(((d - slope * m - intercept) ** 2).sum())
            ss_tot = float(((d - d.mean()) ** 2).sum())
            row.update(slope=slope, slope_se=math.sqrt(sse / (n - 2) / sxx), intercept=intercept,
                       r2=1.0 - sse / ss_tot if ss_tot > 0 else math.nan)
        rows.append(row)
    return rows


def plausibility_flags(products: L4Products, lags: Mapping[str, float] | None = None) -> list[str]:
    """Stored values no correct record gives, one sentence each.

    Parameters
    ----------
    products : L4Products
        The campaign's L4 products.
    lags : mapping, optional
        Further sonic-platform lags by flight [s] (e.g. the rigid-mount diagnosis').

    Returns
    -------
    list of str
        ``<flight> <sensor>: <what> = <value>, <why implausible>``. A spectral ratio
        :math:`\\langle S_w/S_u\\rangle` further than a factor :data:`SW_SU_FACTOR` from the
        isotropic 4/3, a spectral slope further than :data:`SLOPE_TOLERANCE` from -5/3 and a
        sonic-INS lag above :data:`LAG_LIMIT_S`.
    """
    lo, hi = ISOTROPY / SW_SU_FACTOR, ISOTROPY * SW_SU_FACTOR
    out = []
    for flight, prod in products.items():
        for sensor, ds in prod.items():
            ratio = stored_scalar(ds, "Sw_Su")
            if np.isfinite(ratio) and not lo <= ratio <= hi:
                out.append(f"{flight} {sensor}: ⟨S_w/S_u⟩ = {ratio:.2f}, far from isotropy (4/3 in the inertial "
                           f"subrange; flagged outside {lo:.2f}-{hi:.2f}): the vertical (or streamwise) "
                           "component is damped, amplified or noisy at these frequencies.")
            for comp in ("u", "w"):
                slope = spectral_slope(ds, comp)
                if np.isfinite(slope) and abs(slope + 5.0 / 3.0) > SLOPE_TOLERANCE:
                    out.append(f"{flight} {sensor}: spectral slope of S_{comp} = {slope:+.2f} over 2 < f z/U < 10, "
                               f"more than {SLOPE_TOLERANCE:g} from the −5/3 of an inertial subrange: noise, "
                               "aliasing or damping at these frequencies.")
        drone = prod.get("drone")
        lag = float(drone.attrs.get("lag_sonic_ins_s", math.nan)) if drone is not None else math.nan
        lag = (lags or {}).get(flight, lag) if not np.isfinite(lag) else lag
        if np.isfinite(lag) and abs(lag) > LAG_LIMIT_S:
            out.append(f"{flight} drone: sonic-platform lag = {lag:+.2f} s, above the {LAG_LIMIT_S:g} s a sonic and "
                       "an INS logged together should differ by: check the clocks before trusting the motion "
                       "correction.")
    for flight, lag in (lags or {}).items():
        if flight not in products and np.isfinite(lag) and abs(lag) > LAG_LIMIT_S:
            out.append(f"{flight} drone: sonic-platform lag = {lag:+.2f} s, above the {LAG_LIMIT_S:g} s a sonic and "
                       "an INS logged together should differ by: check the clocks before trusting the motion "
                       "correction.")
    return out
