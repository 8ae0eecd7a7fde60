r"""The tilt-based wind of a multicopter against its autopilot's own EKF wind estimate.

An ArduPilot vehicle logs the wind its EKF estimates (``XKF2.VWN``/``VWE``,
:mod:`dronewind.quadrotor.ardupilot`) beside the attitude the tilt method reads (Wetz et
al. 2021, Sect. 4.2, Eqs. 12-18). With no anemometer on board or nearby, the two are the
only winds of such a log; this module puts them side by side:

* :func:`airborne_segment`: the longest slow airborne stretch (height above the take-off
  point at least ``min_height_m``, horizontal and vertical speed at most ``max_speed_ms``,
  EKF wind estimated), with what was left out counted per criterion;
* :func:`tilt_and_ekf_wind` (L3): 1-s block means of the attitude and of the controller's
  set points turned into wind by the drag balance (:func:`dronewind.quadrotor.wind.wind_from_attitude`,
  Wetz et al. 2021, Eqs. 12-18, with the vehicle's velocity added), the EKF wind on the same
  blocks, and the air density of the drag balance from the logged pressure and temperature;
* :func:`compare_with_ekf` (L4): bias, RMSE and correlation of speed, components and
  direction of each tilt wind against the EKF's, and the factor the tilt speed would need to
  match the EKF's on average (a least-squares scale through the origin).

What differs between the two by construction: the EKF wind is a slowly varying state
(its process noise lets it change by a few cm s-1 per second) estimated from the mismatch
between GNSS and inertial velocity, with no drag model unless one is configured; the tilt
wind is the attitude through a drag law, fast (1 s) and dependent on the law's parameters,
the mass, the air density and the attitude offsets, none of which an autopilot log calibrates.

References
----------
.. [1] Wetz, T., Wildmann, N., Beyrich, F. (2021): Distributed wind measurements with
   multiple quadrotor unmanned aerial vehicles in the atmospheric boundary layer
   (SWUF-3D), Sect. 4.2, Eqs. 12-18.
.. [2] ArduPilot EKF3 wind estimation, https://ardupilot.org/copter/docs/airspeed-estimation.html
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from dronewind.core.constants import R_DRY_AIR_JKGK, ZERO_CELSIUS_K
from dronewind.errors import InputError
from dronewind.quadrotor.drag import DragLaw, tilt_from_attitude
from dronewind.quadrotor.wind import wind_from_attitude

__all__ = ["air_density_kgm3", "airborne_segment", "tilt_and_ekf_wind", "compare_with_ekf",
           "COMPARISON_COLUMNS"]

def air_density_kgm3(pressure_pa: np.ndarray | float, temperature_degc: np.ndarray | float) -> np.ndarray:
    r"""Density of dry air by the ideal gas law, :math:`\rho = p / (R_d T)`.

    Parameters
    ----------
    pressure_pa : array_like
        Pressure [Pa].
    temperature_degc : array_like
        Temperature [degC].

    Returns
    -------
    numpy.ndarray
        Density [kg m-3] (the :math:`\rho` of the drag balance, Wetz et al. 2021, Eq. 12).
    """
    return np.asarray(pressure_pa, float) / (R_DRY_AIR_JKGK * (np.asarray(temperature_degc, float) + ZERO_CELSIUS_K))


def _longest_run(mask: np.ndarray) -> tuple[int, int]:
    m = np.concatenate([[False], mask, [False]]).astype(np.int8)
    d = np.diff(m)
    starts, stops = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    if starts.size == 0:
        return 0, 0
    k = int(np.argmax(stops - starts))
    return int(starts[k]), int(stops[k])


def airborne_segment(ds: xr.Dataset, min_height_m: float = 3.0, max_speed_ms: float = 1.5,
                     min_duration_s: float = 30.0, where: str = "log") -> tuple[np.ndarray, dict[str, Any]]:
    """The longest slow airborne stretch of a log with an EKF wind estimate.

    Parameters
    ----------
    ds : xarray.Dataset
        :func:`dronewind.quadrotor.ardupilot.read_quadrotor_ardupilot` output.
    min_height_m : float
        Least height above the take-off altitude (the 5th percentile of the altitude) [m].
    max_speed_ms : float
        Largest horizontal and vertical speed [m s-1].
    min_duration_s : float
        Shortest acceptable stretch [s].
    where : str
        Name in messages.

    Returns
    -------
    mask : numpy.ndarray of bool
        Samples of the stretch.
    info : dict
        ``start``, ``end``, ``duration_s``, ``takeoff_alt_m``, ``n_selected`` and the samples
        failing each criterion: ``n_low``, ``n_fast``, ``n_no_ekf_wind``, ``n_outside_run``.

    Raises
    ------
    InputError
        No stretch of ``min_duration_s``.
    """
    t = ds["time"].to_numpy()
    alt = ds["alt_m"].to_numpy()
    finite_alt = alt[np.isfinite(alt)]
    if finite_alt.size == 0:
        raise InputError(where, "no finite altitude: the airborne part cannot be found")
    alt0 = float(np.percentile(finite_alt, 5))
    low = ~(alt - alt0 >= min_height_m)
    fast = ~((np.hypot(ds["vel_n_ms"].to_numpy(), ds["vel_e_ms"].to_numpy()) <= max_speed_ms)
             & (np.abs(ds["vel_d_ms"].to_numpy()) <= max_speed_ms))
    no_ekf = ~(np.isfinite(ds["ekf_wind_n_ms"].to_numpy()) & np.isfinite(ds["ekf_wind_e_ms"].to_numpy()))
    ok = ~low & ~fast & ~no_ekf
    i0, i1 = _longest_run(ok)
    duration = float((t[i1 - 1] - t[i0]).astype("int64") / 1e9) if i1 > i0 else 0.0
    if duration < min_duration_s:
        raise InputError(where, f"no slow airborne stretch of {min_duration_s:.0f} s with an EKF wind estimate "
                                f"(longest {duration:.0f} s; {int(low.sum())} samples below {min_height_m} m above "
                                f"take-off, {int(fast.sum())} faster than {max_speed_ms} m/s, {int(no_ekf.sum())} "
                                "without EKF wind)")
    mask = np.zeros(t.size, dtype=bool)
    mask[i0:i1] = True
    return mask, {"start": t[i0], "end": t[i1 - 1], "duration_s": duration, "takeoff_alt_m": alt0,
                  "n_selected": int(mask.sum()), "n_low": int(low.sum()), "n_fast": int(fast.sum()),
                  "n_no_ekf_wind": int(no_ekf.sum()), "n_outside_run": int((ok & ~mask).sum())}


def _from_deg(u_east: np.ndarray, v_north: np.ndarray) -> np.ndarray:
    """Meteorological direction the wind blows from [degree, 0-360)."""
    return np.degrees(np.arctan2(-u_east, -v_north)) % 360.0


def tilt_and_ekf_wind(ds: xr.Dataset, law: DragLaw | None = None, average_s: float = 1.0,
                      density: str = "logged", segment: Mapping[str, float] | None = None,
                      where: str = "log") -> xr.Dataset:
    r"""Tilt wind (attitude and set points) and EKF wind on common 1-s blocks (L3).

    Parameters
    ----------
    ds : xarray.Dataset
        :func:`dronewind.quadrotor.ardupilot.read_quadrotor_ardupilot` output.
    law : DragLaw, optional
        Drag law (default Wetz et al. 2021, Eq. 18 and the mass of their quadrotor).
    average_s : float
        Block length [s].
    density : {"logged", "law"}
        ``logged``: the air density of each block from the logged pressure and temperature
        (:func:`air_density_kgm3`; blocks without them use the law's); ``law``: the law's.
    segment : mapping, optional
        :func:`airborne_segment` settings.
    where : str
        Name in messages.

    Returns
    -------
    xarray.Dataset
        Dimension ``time`` (block centres): ``tilt_deg``, ``wind_speed_ms``,
        ``wind_from_deg``, ``u_east_ms``, ``v_north_ms`` (from the attitude);
        ``sp_wind_speed_ms``, ``sp_wind_from_deg`` (from the set points DesRoll/DesPitch with
        the logged yaw); ``ekf_wind_speed_ms``, ``ekf_wind_from_deg``, ``ekf_u_east_ms``,
        ``ekf_v_north_ms``; ``rho_kgm3``; ``height_m`` (above take-off). attrs: the segment
        counts, the law, ``density``.

    Notes
    -----
    :math:`V = \mathrm{sgn}\,\gamma\sqrt{2 m g |\sin\gamma| / (\rho\,c_dA(\gamma))}` along the
    lean direction plus the vehicle velocity (Wetz et al. 2021, Eqs. 12-18); the block means
    of the attitude are taken before the drag law, as for the fleet's windows.
    """
    law = law or DragLaw()
    mask, info = airborne_segment(ds, where=where, **dict(segment or {}))
    sub = ds.isel(time=np.flatnonzero(mask))
    t = sub["time"].to_numpy()
    k = (t - t[0]).astype("int64") // int(round(average_s * 1e9))
    names = ["roll_deg", "pitch_deg", "des_roll_deg", "des_pitch_deg", "vel_n_ms", "vel_e_ms", "ekf_wind_n_ms",
             "ekf_wind_e_ms", "pressure_pa", "baro_temp_degc", "alt_m"]
    frame = pd.DataFrame({n: sub[n].to_numpy() for n in names})
    for name in ("yaw_deg", "des_yaw_deg"):
        frame[f"s_{name}"] = np.sin(np.radians(sub[name].to_numpy()))
        frame[f"c_{name}"] = np.cos(np.radians(sub[name].to_numpy()))
    frame["k"] = k
    g = frame.groupby("k").mean()
    yaw = np.degrees(np.arctan2(g["s_yaw_deg"].to_numpy(), g["c_yaw_deg"].to_numpy())) % 360.0
    rho = air_density_kgm3(g["pressure_pa"].to_numpy(), g["baro_temp_degc"].to_numpy())
    if density == "logged":
        rho = np.where(np.isfinite(rho), rho, law.rho_kgm3)
    elif density == "law":
        rho = np.full(len(g), law.rho_kgm3)
    else:
        raise InputError("density", f"{density!r}; expected 'logged' or 'law'")
    vn, ve = g["vel_n_ms"].to_numpy(), g["vel_e_ms"].to_numpy()
    # the drag law takes one density: the speed scales as rho**-1/2 (Eq. 12), applied per block
    scale = np.sqrt(law.rho_kgm3 / rho)
    out: dict[str, np.ndarray] = {}
    for prefix, roll, pitch in (("", "roll_deg", "pitch_deg"), ("sp_", "des_roll_deg", "des_pitch_deg")):
        w = wind_from_attitude(g[roll].to_numpy(), g[pitch].to_numpy(), yaw, 0.0, 0.0, law=law)
        u = w["u_east_ms"] * scale + ve
        v = w["v_north_ms"] * scale + vn
        out[f"{prefix}u_east_ms"], out[f"{prefix}v_north_ms"] = u, v
        out[f"{prefix}wind_speed_ms"], out[f"{prefix}wind_from_deg"] = np.hypot(u, v), _from_deg(u, v)
    tilt, _ = tilt_from_attitude(np.radians(g["roll_deg"].to_numpy()), np.radians(g["pitch_deg"].to_numpy()))
    sp_tilt, _ = tilt_from_attitude(np.radians(g["des_roll_deg"].to_numpy()),
                                    np.radians(g["des_pitch_deg"].to_numpy()))
    eu, ev = g["ekf_wind_e_ms"].to_numpy(), g["ekf_wind_n_ms"].to_numpy()
    time = t[0] + (g.index.to_numpy() * int(round(average_s * 1e9)) + int(round(average_s * 5e8))).astype(
        "timedelta64[ns]")
    attrs = {
        "wind_speed_ms": {"units": "m s-1", "standard_name": "wind_speed", "long_name": "tilt wind speed (attitude)"},
        "wind_from_deg": {"units": "degree", "standard_name": "wind_from_direction",
                          "long_name": "tilt wind direction (attitude)"},
        "u_east_ms": {"units": "m s-1", "standard_name": "eastward_wind", "long_name": "tilt wind, east (attitude)"},
        "v_north_ms": {"units": "m s-1", "standard_name": "northward_wind",
                       "long_name": "tilt wind, north (attitude)"},
        "sp_wind_speed_ms": {"units": "m s-1", "long_name": "tilt wind speed from the controller's set points"},
        "sp_wind_from_deg": {"units": "degree", "long_name": "tilt wind direction from the controller's set points"},
        "sp_u_east_ms": {"units": "m s-1", "long_name": "tilt wind, east, from the set points"},
        "sp_v_north_ms": {"units": "m s-1", "long_name": "tilt wind, north, from the set points"},
        "ekf_wind_speed_ms": {"units": "m s-1", "long_name": "EKF wind speed (XKF2 VWN, VWE)"},
        "ekf_wind_from_deg": {"units": "degree", "long_name": "EKF wind direction (from)"},
        "ekf_u_east_ms": {"units": "m s-1", "long_name": "EKF wind, east component (VWE)"},
        "ekf_v_north_ms": {"units": "m s-1", "long_name": "EKF wind, north component (VWN)"},
        "tilt_deg": {"units": "degree", "long_name": "tilt of the airframe from roll and pitch"},
        "sp_tilt_deg": {"units": "degree", "long_name": "tilt of the controller's roll and pitch set points"},
        "rho_kgm3": {"units": "kg m-3", "standard_name": "air_density",
                     "long_name": "air density of the drag balance"},
        "height_m": {"units": "m", "long_name": "height above the take-off altitude"},
    }
    values = {**out, "ekf_wind_speed_ms": np.hypot(eu, ev), "ekf_wind_from_deg": _from_deg(eu, ev),
              "ekf_u_east_ms": eu, "ekf_v_north_ms": ev, "tilt_deg": np.degrees(tilt),
              "sp_tilt_deg": np.degrees(sp_tilt), "rho_kgm3": rho,
              "height_m": g["alt_m"].to_numpy() - info["takeoff_alt_m"]}
    l3 = xr.Dataset({n: ("time", values[n], attrs[n]) for n in attrs}, coords={"time": time})
    l3.attrs.update({
        "averaging_s": average_s, "density": density, "drag_law": law.law, "cd0a0_m2": law.cd0a0_m2,
        "cp_m2_per_rad": law.cp_m2_per_rad, "mass_kg": law.mass_kg, "law_rho_kgm3": law.rho_kgm3,
        **{f"segment_{k}": v for k, v in info.items() if k not in ("start", "end")},
        **{k: v for k, v in ds.attrs.items() if k.startswith("param_")},
        "processing_log": "\n".join([
            f"segment: {info['n_selected']} samples ({info['duration_s']:.0f} s) airborne and slow; left out: "
            f"{info['n_low']} low, {info['n_fast']} fast, {info['n_no_ekf_wind']} without EKF wind, "
            f"{info['n_outside_run']} in shorter runs",
            f"wind: drag balance ({law.law}; cd0A0 {law.cd0a0_m2} m2, cp {law.cp_m2_per_rad} m2/rad, mass "
            f"{law.mass_kg} kg), density {density}, vehicle velocity added; {len(g)} blocks of {average_s:g} s"]),
    })
    return l3


#: Columns of the comparison table (one row per tilt-wind source).
COMPARISON_COLUMNS: tuple[str, ...] = (
    "flight", "source", "n_blocks", "duration_s", "mean_tilt_deg", "mean_speed_ms", "mean_ekf_speed_ms",
    "speed_bias_ms", "speed_rmse_ms", "speed_corr", "u_bias_ms", "v_bias_ms", "vector_rmse_ms",
    "direction_bias_deg", "direction_rmse_deg", "scale_to_ekf", "mean_rho_kgm3")


def compare_with_ekf(l3: xr.Dataset, flight: str) -> pd.DataFrame:
    r"""Statistics of the tilt winds of an L3 against its EKF wind (L4).

    Parameters
    ----------
    l3 : xarray.Dataset
        :func:`tilt_and_ekf_wind` output.
    flight : str
        Flight id of the rows.

    Returns
    -------
    pandas.DataFrame
        :data:`COMPARISON_COLUMNS`, one row per source (``attitude``, ``set_point``): bias
        (tilt minus EKF) and RMSE of speed and components, Pearson correlation of speed,
        circular mean and RMS of the direction difference (wrapped to [-180, 180)),
        ``scale_to_ekf`` :math:`k = \sum s_{ekf} s / \sum s^2` (the factor on the tilt speed
        that best matches the EKF's).
    """
    ek_s, ek_u, ek_v = (l3[n].to_numpy() for n in ("ekf_wind_speed_ms", "ekf_u_east_ms", "ekf_v_north_ms"))
    rows = []
    for source, prefix in (("attitude", ""), ("set_point", "sp_")):
        s, u, v = (l3[f"{prefix}{n}"].to_numpy() for n in ("wind_speed_ms", "u_east_ms", "v_north_ms"))
        ok = np.isfinite(s) & np.isfinite(ek_s)
        d = (l3[f"{prefix}wind_from_deg"].to_numpy() - l3["ekf_wind_from_deg"].to_numpy() + 180.0) % 360.0 - 180.0
        n = int(ok.sum())
        corr = float(np.corrcoef(s[ok], ek_s[ok])[0, 1]) if n > 2 and np.std(s[ok]) > 0 and np.std(ek_s[ok]) > 0 \
            else float("nan")
        rows.append({
            "flight": flight, "source": source, "n_blocks": n,
            "duration_s": n * float(l3.attrs.get("averaging_s", 1.0)),
            "mean_tilt_deg": float(np.nanmean(l3[f"{prefix}tilt_deg"].to_numpy()[ok])) if n else float("nan"),
            "mean_speed_ms": float(np.mean(s[ok])) if n else float("nan"),
            "mean_ekf_speed_ms": float(np.mean(ek_s[ok])) if n else float("nan"),
            "speed_bias_ms": float(np.mean(s[ok] - ek_s[ok])) if n else float("nan"),
            "speed_rmse_ms": float(np.sqrt(np.mean((s[ok] - ek_s[ok]) ** 2))) if n else float("nan"),
            "speed_corr": corr,
            "u_bias_ms": float(np.mean(u[ok] - ek_u[ok])) if n else float("nan"),
            "v_bias_ms": float(np.mean(v[ok] - ek_v[ok])) if n else float("nan"),
            "vector_rmse_ms": float(np.sqrt(np.mean((u[ok] - ek_u[ok]) ** 2 + (v[ok] - ek_v[ok]) ** 2))) if n
            else float("nan"),
            "direction_bias_deg": float(np.degrees(np.arctan2(np.mean(np.sin(np.radians(d[ok]))),
                                                              np.mean(np.cos(np.radians(d[ok])))))) if n
            else float("nan"),
            "direction_rmse_deg": float(np.sqrt(np.mean(d[ok] ** 2))) if n else float("nan"),
            "scale_to_ekf": float(np.sum(ek_s[ok] * s[ok]) / np.sum(s[ok] ** 2)) if n and np.any(s[ok] > 0)
            else float("nan"),
            "mean_rho_kgm3": float(np.mean(l3["rho_kgm3"].to_numpy()[ok])) if n else float("nan"),
        })
    return pd.DataFrame(rows, columns=list(COMPARISON_COLUMNS))
