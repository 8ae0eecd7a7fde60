"""Figure of the tilt-based wind of a multicopter against its autopilot's EKF wind.

:func:`ekf_wind_figure` draws one flight's L3 (:func:`dronewind.quadrotor.ekf_wind.tilt_and_ekf_wind`):
wind speed and direction of the tilt method (from the attitude and from the controller's set
points, Wetz et al. 2021, Eqs. 12-18) and of the EKF, with the height above take-off, and the
statistics of :func:`dronewind.quadrotor.ekf_wind.compare_with_ekf` in the panel titles.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from dronewind.figures.quadrotor import _save

__all__ = ["ekf_wind_figure"]


def ekf_wind_figure(l3: xr.Dataset, stats: pd.DataFrame, path: str | Path, flight: str) -> Path:
    """Time series of tilt wind and EKF wind of one flight (speed, direction, height).

    Parameters
    ----------
    l3 : xarray.Dataset
        :func:`dronewind.quadrotor.ekf_wind.tilt_and_ekf_wind` output.
    stats : pandas.DataFrame
        Its :func:`dronewind.quadrotor.ekf_wind.compare_with_ekf` rows.
    path : str or Path
        PNG to write.
    flight : str
        Flight id (title).

    Returns
    -------
    Path
        The written PNG.
    """
    from matplotlib.dates import DateFormatter
    from matplotlib.figure import Figure
    from matplotlib.layout_engine import ConstrainedLayoutEngine

    fig = Figure(figsize=(7.5, 7.0))
    fig.set_layout_engine(ConstrainedLayoutEngine(rect=(0.0, 0.03, 1.0, 0.97)))  # room for the note under the axes
    ax_s, ax_d, ax_h = fig.subplots(3, 1, sharex=True, height_ratios=[3, 3, 1.4])
    t = l3["time"].to_numpy()
    att = stats.set_index("source").loc["attitude"] if len(stats) else None
    for name, label, style in (("wind_speed_ms", "tilt wind (attitude)", {"color": "tab:red", "lw": 0.9}),
                               ("sp_wind_speed_ms", "tilt wind (set points)", {"color": "tab:orange", "lw": 0.7,
                                                                               "ls": "--"}),
                               ("ekf_wind_speed_ms", "EKF wind (XKF2)", {"color": "k", "lw": 1.3})):
        ax_s.plot(t, l3[name].to_numpy(), label=label, **style)
    for name, label, style in (("wind_from_deg", "tilt wind (attitude)", {"color": "tab:red", "ms": 2}),
                               ("sp_wind_from_deg", "tilt wind (set points)", {"color": "tab:orange", "ms": 1.5}),
                               ("ekf_wind_from_deg", "EKF wind (XKF2)", {"color": "k", "ms": 2})):
        ax_d.plot(t, l3[name].to_numpy(), "o", label=label, **style)
    ax_h.plot(t, l3["height_m"].to_numpy(), color="tab:blue", lw=1.0)
    ax_s.set_ylabel("wind speed (m s$^{-1}$)")
    ax_d.set_ylabel("wind from (degree)")
    ax_d.set_ylim(0, 360)
    ax_d.set_yticks(np.arange(0, 361, 90))
    ax_h.set_ylabel("height (m)")
    ax_h.set_xlabel("time (UTC)")
    ax_h.xaxis.set_major_formatter(DateFormatter("%H:%M:%S"))
    ax_s.legend(fontsize=7, loc="upper right")
    if att is not None:
        ax_s.set_title(f"{flight}: tilt minus EKF speed: bias {att['speed_bias_ms']:+.2f} m/s, RMSE "
                       f"{att['speed_rmse_ms']:.2f} m/s, r = {att['speed_corr']:.2f} (n = {att['n_blocks']:.0f} s)",
                       fontsize=8)
        ax_d.set_title(f"direction: bias {att['direction_bias_deg']:+.0f} deg, RMS difference "
                       f"{att['direction_rmse_deg']:.0f} deg; mean tilt {att['mean_tilt_deg']:.2f} deg", fontsize=8)
    note = (f"drag law: cd0A0 {l3.attrs.get('cd0a0_m2')} m2, cp {l3.attrs.get('cp_m2_per_rad')} m2/rad, mass "
            f"{l3.attrs.get('mass_kg')} kg (not calibrated for this airframe); density {l3.attrs.get('density')}")
    return _save(fig, path, note)
