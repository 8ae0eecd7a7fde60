r"""Virtual wind-tunnel campaign of the SWUF-3D quadrotors (Kistner et al. 2024).

A UAS hovers 2.5 m downstream of an active grid; a constant-temperature anemometer (CTA)
at 5 m measures the reference speed. The simulator writes, for each run, the CTA signal
and the UAS attitude log, plus an index of the runs. The flow blows towards north
(wind from 180 degree); a UAS at angle of sideslip (AoS) :math:`\beta` has yaw
:math:`180^\circ + \beta` (weather-vane mode off, Kistner et al. (2024) Sect. 3.2.2).

File formats (all CSV, header line, ``.`` decimal separator; times in seconds from the
start of the run, on one clock shared by the CTA and the UAS):

``<out_dir>/tunnel/runs.csv`` (the index, one row per run)::

    run_id,kind,uas,aos_deg,v0_ms,vg_ms,vdu_ms,ti_percent,duration_s,fs_cta_hz,fs_uas_hz,
    steps_ms,hold_s,first_event_s,period_s,n_events,cta_file,uas_file

  ``kind`` is ``calibration`` (AoS 0 or +-90, speed steps), ``sideslip``, ``portability``,
  ``gust``, ``step`` or ``turbulence``. ``steps_ms`` lists the preset speeds of a stepped
  run separated by ``;`` (each held ``hold_s``, starting at t = 0; the first step is 0 m/s,
  a calm hover that gives the accelerometer offset). For gusts and velocity steps the
  events start at ``first_event_s + k * period_s``, ``k < n_events``. Empty cells: not
  applicable.

``<out_dir>/tunnel/<run_id>_cta.csv`` (reference)::

    time_s,wind_speed_ms

``<out_dir>/tunnel/<run_id>_<uas>.csv`` (UAS log, 10 Hz by default; the tunnel has no
GNSS, so no velocity columns)::

    time_s,roll_deg,pitch_deg,yaw_deg

Forward model: the flow at the UAS is the CTA flow advected over 2.5 m (the UAS is
upstream of the CTA) plus a slow positional drift (optical-flow hold, Sect. 2.1); the
attitude follows the relative air through a first-order lag ``response_lag_s`` and the
body-axis drag law of Kistner et al. (2024), Eq. 1 (default coefficients: Table 2, per speed range)
inverted by fixed-point iteration (:func:`dronewind.simulate.airframe.attitude_from_relative_air`);
logged attitude = true + per-UAS offsets + white vibration noise ``attitude_noise_deg``
(the noise floor that limits the resolvable turbulence, Sect. 4); the UAS log is a block average to ``fs_uas_hz``.

Gusts: IEC 61400-1 extreme operating gust (Kistner et al. 2024, Eq. 4, duration 10.5 s); velocity
steps: a tanh ramp with 10-90 % time ``step_rise_s`` (Sect. 3.2.4, 40 s repetitions);
statistical turbulence: a Gaussian process with a von Karman spectrum of length scale
``turbulence_length_m`` and intensity ``ti_percent`` (Sect. 3.2.5, Table A4).

References
----------
.. [1] Wind-tunnel calibration and verification of the SWUF-3D quadrotors, Kistner et al. (2024)
  , Sects. 2-3, Eqs. 1-17, Tables 2, A1-A4.
.. [2] IEC 61400-1:2019, Wind energy generation systems - Part 1: Design requirements.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from dronewind.core.cf import atomic_write_text
from dronewind.core.constants import KISTNER2024_RANGES
from dronewind.errors import InputError
from dronewind.simulate.airframe import AirframeDrag, attitude_from_relative_air
from dronewind.simulate.common import first_order_lag, merge_settings, ornstein_uhlenbeck

__all__ = ["TUNNEL_DEFAULTS", "iec_gust", "step_series", "von_karman_series", "tunnel_settings", "simulate_tunnel"]

#: Default ``simulation.tunnel`` settings.
TUNNEL_DEFAULTS: dict[str, Any] = {
    "uas": ["uas06", "uas31", "uas33", "uas34", "uas35"],
    "calibration_uas": "uas06",
    "fs_uas_hz": 10.0,
    "fs_cta_hz": 100.0,            # turbulence runs
    "fs_cta_steady_hz": 20.0,      # all other runs
    "mass_kg": 0.645,
    "drag": {"law": "body_axis", **KISTNER2024_RANGES},
    "uas_settings": {              # truth per UAS: accelerometer offsets, drag scale
        "uas06": {"pitch_offset_deg": 0.8, "roll_offset_deg": -0.3, "drag_scale": 1.00},
        "uas31": {"pitch_offset_deg": -1.2, "roll_offset_deg": 0.4, "drag_scale": 1.03},
        "uas33": {"pitch_offset_deg": 0.3, "roll_offset_deg": 0.2, "drag_scale": 0.97},
        "uas34": {"pitch_offset_deg": 1.5, "roll_offset_deg": -0.5, "drag_scale": 1.02},
        "uas35": {"pitch_offset_deg": -0.6, "roll_offset_deg": 0.1, "drag_scale": 0.99},
    },
    "response_lag_s": 0.15,
    "attitude_noise_deg": 0.25,
    "cta_noise_ms": 0.03,
    "drift_sd_ms": 0.08,
    "drift_timescale_s": 20.0,
    "advection_distance_m": 2.5,
    "calibration": {"v_max_ms": [16.0, 16.0, 18.0], "aos_deg": [0.0, 0.0, 0.0, 90.0, -90.0, 90.0, -90.0],
                    "step_ms": 2.0, "hold_s": 60.0},
    "sideslip": {"aos_deg": [0.0, 10.0, 20.0, 30.0, 60.0, 90.0], "v_max_ms": 16.0, "hold_s": 30.0},
    "portability": {"v_max_ms": 16.0, "hold_s": 30.0},
    "gusts": {"presets": [[4.0, 2.0], [4.0, 3.0], [6.0, 3.5], [6.0, 5.0], [8.0, 4.0], [8.0, 6.0],
                          [10.0, 4.5], [10.0, 7.0]],
              "repetitions": 10, "duration_s": 10.5, "period_s": 30.0},
    "steps": {"presets": [[5.0, 5.0], [5.0, 7.0], [5.0, 10.0]], "repetitions": [20, 10, 10],
              "period_s": 40.0, "step_rise_s": 1.5},
    "turbulence": {"presets": [[5.0, 11.5], [7.0, 11.5], [9.0, 11.5], [11.0, 5.5], [11.0, 11.5],
                               [13.0, 11.5], [15.0, 5.5], [15.0, 11.5], [17.0, 11.5],
                               [0.0, 9.5], [0.0, 15.0]],
                   "duration_s": 600.0, "turbulence_length_m": 1.5,
                   "fan_mean_ms": 8.0, "fan_length_m": 6.0},
}


def iec_gust(t_s: np.ndarray, v0_ms: float, vg_ms: float, duration_s: float = 10.5) -> np.ndarray:
    r"""IEC extreme operating gust (Kistner et al. 2024, Eq. 4).

    Parameters
    ----------
    t_s : array_like
        Time since the gust start [s]; outside [0, duration] the speed is ``v0_ms``.
    v0_ms, vg_ms : float
        Initial speed and gust speed [m s-1].
    duration_s : float
        Gust duration :math:`T = 2T_{peak}` [s] (10.5 s in Kistner et al. (2024)).

    Returns
    -------
    numpy.ndarray
        Speed [m s-1].

    Notes
    -----
    .. math:: V = V_0 - 0.37 V_g \sin\!\Big(\frac{3\pi t}{2T_{peak}}\Big)
              \Big(1-\cos\frac{2\pi t}{2T_{peak}}\Big)

    The peak, :math:`V_0 + 0.74 V_g`, is at :math:`t = T_{peak}`; two dips flank it.
    """
    t = np.asarray(t_s, float)
    inside = (t >= 0) & (t <= duration_s)
    g = v0_ms - 0.37 * vg_ms * np.sin(3 * np.pi * t / duration_s) * (1 - np.cos(2 * np.pi * t / duration_s))
    return np.where(inside, g, v0_ms)


def step_series(t_s: np.ndarray, v_low_ms: float, v_high_ms: float, t_up_s: float, t_down_s: float,
                rise_s: float) -> np.ndarray:
    r"""Up and down velocity step with a tanh ramp (Kistner et al. 2024, Sect. 3.2.4).

    Parameters
    ----------
    t_s : array_like
        Time [s].
    v_low_ms, v_high_ms : float
        Stationary speeds [m s-1].
    t_up_s, t_down_s : float
        Centres of the up and down ramps [s].
    rise_s : float
        10-90 % rise time [s].

    Returns
    -------
    numpy.ndarray

    Notes
    -----
    .. math:: V = V_l + \frac{V_h-V_l}{2}\Big[\tanh\frac{t-t_u}{w} - \tanh\frac{t-t_d}{w}\Big],
              \qquad w = \frac{t_{10-90}}{2\,\operatorname{atanh}0.8}
    """
    t = np.asarray(t_s, float)
    w = rise_s / (2 * np.arctanh(0.8))
    return v_low_ms + 0.5 * (v_high_ms - v_low_ms) * (np.tanh((t - t_up_s) / w) - np.tanh((t - t_down_s) / w))


def von_karman_series(n: int, fs_hz: float, sigma_ms: float, length_m: float, mean_ms: float,
                      rng: np.random.Generator) -> np.ndarray:
    r"""Zero-mean Gaussian series with a von Karman longitudinal spectrum.

    Parameters
    ----------
    n : int
        Number of samples.
    fs_hz : float
        Sampling rate [Hz].
    sigma_ms : float
        Standard deviation [m s-1].
    length_m : float
        Integral length scale [m].
    mean_ms : float
        Advection speed for Taylor's hypothesis [m s-1].
    rng : numpy.random.Generator

    Returns
    -------
    numpy.ndarray

    Notes
    -----
    Spectral synthesis with random phases (one-dimensional series only, which
    pyconturb's spatial generator would overshoot):

    .. math:: S(f) = \frac{4\sigma^2 L/U}{\big(1+70.8\,(fL/U)^2\big)^{5/6}}

    rescaled so the series has exactly ``sigma_ms``.
    """
    f = np.fft.rfftfreq(n, 1.0 / fs_hz)
    lu = length_m / max(mean_ms, 0.5)
    s = 4 * lu / (1 + 70.8 * (f * lu) ** 2) ** (5.0 / 6.0)
    amp = np.sqrt(s)
    amp[0] = 0.0
    spec = amp * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size))
    x = np.fft.irfft(spec, n)
    return x / np.std(x) * sigma_ms


def _write_run(out: Path, run: dict, flow_cta: np.ndarray, fs: float, cfg: dict, law: AirframeDrag,
               rng: np.random.Generator, rows: list) -> list[Path]:
    """Simulate the UAS in ``flow_cta`` (sampled at ``fs``) and write both files."""
    uas = run["uas"]
    us = (cfg["uas_settings"] or {}).get(uas, {})
    n = flow_cta.size
    delay = int(round(cfg["advection_distance_m"] / max(np.mean(flow_cta), 1.0) * fs))
    flow_uas = np.concatenate([flow_cta[delay:], np.full(delay, flow_cta[-1])]) if delay else flow_cta.copy()
    drift = ornstein_uhlenbeck(rng, n, cfg["drift_sd_ms"], cfg["drift_timescale_s"], fs)
    rel_speed = first_order_lag(flow_uas - drift, cfg["response_lag_s"], fs)
    beta = np.radians(run["aos_deg"])
    # air moves towards north; the nose points to 180 + aos: relative air in the heading frame
    af = -rel_speed * np.cos(beta)
    ar = rel_speed * np.sin(beta)
    phi, th = attitude_from_relative_air(af, ar, law, float(us.get("drag_scale", 1.0)))
    fs_u = float(cfg["fs_uas_hz"])
    m = int(round(fs / fs_u))
    nb = n // m

    def block(x):
        return x[: nb * m].reshape(nb, m).mean(axis=1)

    noise = cfg["attitude_noise_deg"]
    roll = block(np.degrees(phi)) + float(us.get("roll_offset_deg", 0.0)) + rng.standard_normal(nb) * noise
    pitch = block(np.degrees(th)) + float(us.get("pitch_offset_deg", 0.0)) + rng.standard_normal(nb) * noise
    yaw = (180.0 + run["aos_deg"] + rng.standard_normal(nb) * noise + 180.0) % 360.0 - 180.0
    t_u = (np.arange(nb) * m + 0.5 * (m - 1)) / fs
    cta = flow_cta + rng.standard_normal(n) * cfg["cta_noise_ms"]
    tdir = out / "tunnel"
    tdir.mkdir(parents=True, exist_ok=True)
    cta_name = f"{run['run_id']}_cta.csv"
    uas_name = f"{run['run_id']}_{uas}.csv"
    atomic_write_text(tdir / cta_name, pd.DataFrame({"time_s": np.round(np.arange(n) / fs, 4),
                                                    "wind_speed_ms": np.round(cta, 4)}).to_csv(index=False))
    atomic_write_text(tdir / uas_name, pd.DataFrame({
        "time_s": np.round(t_u, 4), "roll_deg": np.round(roll, 4), "pitch_deg": np.round(pitch, 4),
        "yaw_deg": np.round(yaw, 4)}).to_csv(index=False))
    rows.append({**run, "duration_s": n / fs, "fs_cta_hz": fs, "fs_uas_hz": fs_u,
                 "cta_file": f"tunnel/{cta_name}", "uas_file": f"tunnel/{uas_name}"})
    return [tdir / cta_name, tdir / uas_name]


def _stepped(v_max: float, step: float, hold_s: float, fs: float) -> tuple[np.ndarray, list[float]]:
    speeds = [0.0] + list(np.arange(2.0, v_max + 1e-9, step))
    n_hold = int(round(hold_s * fs))
    flow = np.concatenate([np.full(n_hold, s) for s in speeds])
    # speed changes take ~2 s in a real tunnel: smooth the staircase (zero phase)
    win = max(1, int(round(2.0 * fs)))
    flow = np.convolve(np.pad(flow, (win // 2, win - 1 - win // 2), mode="edge"), np.ones(win) / win, mode="valid")
    return flow, speeds


#: Columns of ``runs.csv`` that do not apply to every kind, and their empty values.
_RUN_BASE: dict[str, Any] = {"aos_deg": 0.0, "v0_ms": np.nan, "vg_ms": np.nan, "vdu_ms": np.nan,
                             "ti_percent": np.nan, "steps_ms": "", "hold_s": np.nan, "first_event_s": np.nan,
                             "period_s": np.nan, "n_events": np.nan}
#: Columns of ``runs.csv``.
_RUN_COLUMNS = ["run_id", "kind", "uas", "aos_deg", "v0_ms", "vg_ms", "vdu_ms", "ti_percent", "duration_s",
                "fs_cta_hz", "fs_uas_hz", "steps_ms", "hold_s", "first_event_s", "period_s", "n_events", "cta_file",
                "uas_file"]


def _calibration_runs(out: Path, cfg: dict, law: AirframeDrag, rng: np.random.Generator, rows: list,
                      fs: float) -> list[Path]:
    """Stepped runs of the calibration UAS at AoS 0 (up to ``v_max_ms``) and +-90 degree (16 m/s)."""
    c = cfg["calibration"]
    vmax = list(c["v_max_ms"])
    paths = []
    for i, aos in enumerate(c["aos_deg"]):
        flow, speeds = _stepped(vmax[i % len(vmax)] if aos == 0 else 16.0, c["step_ms"], c["hold_s"], fs)
        run = {**_RUN_BASE, "run_id": f"cal{i:02d}", "kind": "calibration", "uas": cfg["calibration_uas"],
               "aos_deg": float(aos), "steps_ms": ";".join(f"{s:g}" for s in speeds), "hold_s": c["hold_s"]}
        paths += _write_run(out, run, flow, fs, cfg, law, rng, rows)
    return paths


def _sideslip_runs(out: Path, cfg: dict, law: AirframeDrag, rng: np.random.Generator, rows: list,
                   fs: float) -> list[Path]:
    """Stepped runs of the calibration UAS at each angle of sideslip (Kistner et al. 2024, Sect. 3.2.2)."""
    c = cfg["sideslip"]
    paths = []
    for i, aos in enumerate(c["aos_deg"]):
        flow, speeds = _stepped(c["v_max_ms"], 2.0, c["hold_s"], fs)
        run = {**_RUN_BASE, "run_id": f"aos{i:02d}", "kind": "sideslip", "uas": cfg["calibration_uas"],
               "aos_deg": float(aos), "steps_ms": ";".join(f"{s:g}" for s in speeds), "hold_s": c["hold_s"]}
        paths += _write_run(out, run, flow, fs, cfg, law, rng, rows)
    return paths


def _portability_runs(out: Path, cfg: dict, law: AirframeDrag, rng: np.random.Generator, rows: list,
                      fs: float) -> list[Path]:
    """One stepped run per UAS at AoS 0 (portability of the calibration, Sect. 3.2.1)."""
    c = cfg["portability"]
    paths = []
    for i, uas in enumerate(cfg["uas"]):
        flow, speeds = _stepped(c["v_max_ms"], 2.0, c["hold_s"], fs)
        run = {**_RUN_BASE, "run_id": f"port{i:02d}", "kind": "portability", "uas": uas,
               "steps_ms": ";".join(f"{s:g}" for s in speeds), "hold_s": c["hold_s"]}
        paths += _write_run(out, run, flow, fs, cfg, law, rng, rows)
    return paths


def _gust_runs(out: Path, cfg: dict, law: AirframeDrag, rng: np.random.Generator, rows: list,
               fs: float) -> list[Path]:
    """Repeated IEC gusts per (V0, Vg) preset, the first at 10 s (Sect. 3.2.3, Table A2)."""
    c = cfg["gusts"]
    paths = []
    for i, (v0, vg) in enumerate(c["presets"]):
        n_ev, period = int(c["repetitions"]), float(c["period_s"])
        t = np.arange(int(round((n_ev * period + 10.0) * fs))) / fs
        flow = np.full(t.size, float(v0))
        for k in range(n_ev):
            flow = np.where((t >= 10 + k * period) & (t <= 10 + k * period + c["duration_s"]),
                            iec_gust(t - 10 - k * period, v0, vg, c["duration_s"]), flow)
        run = {**_RUN_BASE, "run_id": f"gust{i:02d}", "kind": "gust", "uas": cfg["calibration_uas"], "v0_ms": v0,
               "vg_ms": vg, "first_event_s": 10.0, "period_s": period, "n_events": n_ev}
        paths += _write_run(out, run, flow, fs, cfg, law, rng, rows)
    return paths


def _step_runs(out: Path, cfg: dict, law: AirframeDrag, rng: np.random.Generator, rows: list,
               fs: float) -> list[Path]:
    """Repeated up and down velocity steps per (V_l, dV) preset (Sect. 3.2.4, Table A3)."""
    c = cfg["steps"]
    reps = list(np.atleast_1d(c["repetitions"]))
    paths = []
    for i, (v0, vdu) in enumerate(c["presets"]):
        n_ev, period = int(reps[i % len(reps)]), float(c["period_s"])
        t = np.arange(int(round(n_ev * period * fs))) / fs
        flow = np.full(t.size, float(v0))
        for k in range(n_ev):
            t0 = k * period
            seg = (t >= t0) & (t < t0 + period)
            flow[seg] = step_series(t[seg], v0, v0 + vdu, t0 + period / 4, t0 + 3 * period / 4, c["step_rise_s"])
        run = {**_RUN_BASE, "run_id": f"step{i:02d}", "kind": "step", "uas": cfg["calibration_uas"], "v0_ms": v0,
               "vdu_ms": vdu, "first_event_s": 0.0, "period_s": period, "n_events": n_ev}
        paths += _write_run(out, run, flow, fs, cfg, law, rng, rows)
    return paths


def _turbulence_runs(out: Path, cfg: dict, law: AirframeDrag, rng: np.random.Generator, rows: list,
                     fs: float) -> list[Path]:
    """Statistical turbulence per (mean, TI) preset at ``fs_cta_hz`` (Sect. 3.2.5, Table A4); a
    mean of 0 stands for the fan-only flow."""
    c = cfg["turbulence"]
    fs_t = float(cfg["fs_cta_hz"])
    n = int(round(c["duration_s"] * fs_t))
    paths = []
    for i, (v0, ti) in enumerate(c["presets"]):
        fan = v0 <= 0
        mean = c["fan_mean_ms"] if fan else v0
        length = c["fan_length_m"] if fan else c["turbulence_length_m"]
        flow = mean + von_karman_series(n, fs_t, ti / 100 * mean, length, mean, rng)
        run = {**_RUN_BASE, "run_id": f"turb{i:02d}", "kind": "turbulence", "uas": cfg["calibration_uas"],
               "v0_ms": float(mean), "ti_percent": float(ti)}
        paths += _write_run(out, run, np.maximum(flow, 0.3), fs_t, cfg, law, rng, rows)
    return paths


#: Run kinds in the order they are simulated (one random generator for all).
_KINDS: dict[str, Callable[..., list[Path]]] = {
    "calibration": _calibration_runs, "sideslip": _sideslip_runs, "portability": _portability_runs,
    "gust": _gust_runs, "step": _step_runs, "turbulence": _turbulence_runs,
}


def tunnel_settings(settings: dict | None) -> dict[str, Any]:
    """``simulation.tunnel`` merged into :data:`TUNNEL_DEFAULTS`, checked (InputError names the key)."""
    unknown = set(settings or {}) - set(TUNNEL_DEFAULTS) - {"kinds"}
    if unknown:
        raise InputError("simulation.tunnel", f"unknown setting(s) {sorted(unknown)}; expected "
                                              f"{sorted(TUNNEL_DEFAULTS)} or kinds")
    cfg = merge_settings(TUNNEL_DEFAULTS, settings or {})
    if cfg["calibration_uas"] not in cfg["uas"]:
        raise InputError("simulation.tunnel.calibration_uas", f"{cfg['calibration_uas']!r} is not in uas")
    return cfg


def simulate_tunnel(settings: dict, out_dir: Path, seed: int) -> list[Path]:
    """Write a virtual wind-tunnel campaign (Kistner et al. 2024): CTA signals, UAS logs and ``runs.csv``.

    Parameters
    ----------
    settings : dict
        ``simulation.tunnel`` settings (keys of :data:`TUNNEL_DEFAULTS`; ``kinds`` may
        restrict the run kinds, e.g. ``["calibration", "gust"]``).
    out_dir : Path
        Output root; files go to ``out_dir / "tunnel"``.
    seed : int
        Random seed (runs are generated in a fixed order from one generator).

    Returns
    -------
    list of Path
        All files written; ``runs.csv`` last.

    Raises
    ------
    InputError
        Unknown setting, calibration UAS not in ``uas``, or a bad drag law.
    """
    cfg = tunnel_settings(settings)
    kinds = set(cfg.get("kinds") or list(_KINDS))
    law = AirframeDrag.from_settings({**cfg["drag"], "mass_kg": cfg["mass_kg"]})
    rng = np.random.default_rng(seed)
    out = Path(out_dir)
    fs = float(cfg["fs_cta_steady_hz"])
    rows: list[dict] = []
    paths: list[Path] = []
    for kind, simulate_runs in _KINDS.items():
        if kind in kinds:
            paths += simulate_runs(out, cfg, law, rng, rows, fs)
    index = pd.DataFrame(rows, columns=_RUN_COLUMNS)
    (out / "tunnel").mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "tunnel" / "runs.csv", index.to_csv(index=False))
    paths.append(out / "tunnel" / "runs.csv")
    return paths
