r"""Per-flight residual features: how the drone's record differs from the mast's.

Each feature is measured on the processed products of one payload flight (L3: drone and
reference mast aligned, decimated, rotated; L2: the drone's synchronisation and
attitude) and comes with its sampling standard error, so that the diagnosis can weigh
flights and features. The same function runs on measured flights and on the simulated
flights of the forward model, so predicted and measured features are comparable by
construction.

=====================  ========================================================  ===========
feature                definition                                                 sensitive to
=====================  ========================================================  ===========
ln_sigma_ratio_u/v/w   :math:`\ln(\sigma_{drone}/\sigma_{mast})`                  w_gain, noise,
                                                                                  height, mast_w
ln_speed_ratio         :math:`\ln(\bar u_{drone}/\bar u_{mast})`                  height_offset
dir_diff_deg           wind-from direction, drone minus mast (wrapped)            heading_bias,
                                                                                  mount yaw
tilt_diff_deg          streamline pitch angle, drone minus mast                   mount roll/pitch,
                                                                                  downwash
sw_su_drone/_mast      :math:`\langle S_w/S_u\rangle`, :math:`2<f_r<10`           w_gain, mast_w
ln_pendulum_w          :math:`\ln` of drone/mast w power, 0.08-0.17 Hz            attitude_lag,
                                                                                  lever_arm
ln_hf_u/_w             :math:`\ln` of drone/mast power, 1.5-3 Hz                  sonic_noise
lag_sonic_ins_s        the sonic-INS lag found by the chain                       sonic_ins_lag,
                                                                                  attitude_lag
lag_drift_s            lag of the second half minus the first                     clock_drift
corr_wres_pitch_rate   corr(w_drone - w_mast, pitch rate)                         lever_arm,
corr_wres_roll_rate    corr(w_drone - w_mast, roll rate)                          attitude_lag
=====================  ========================================================  ===========

Sampling errors follow Lumley and Panofsky as in Ghirardelli et al. (2025), Eqs 10-13: the relative
random error of a variance over an averaging time :math:`\tau` is
:math:`\epsilon = 2\sqrt{T/\tau}` for a Gaussian series of integral time scale
:math:`T`; means, spectral band powers (Welch degrees of freedom) and correlations
(:math:`1/\sqrt{N_{eff}}`) are treated alike. Drone and mast errors are combined as
independent, which is conservative: the two sensors see partly the same eddies.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from dataclasses import dataclass, field

import numpy as np
import xarray as xr

from dronewind.core import scales, spectra, stats
from dronewind.core.angles import deg2rad, rad2deg
from dronewind.core.reuse import reused
from dronewind.core.timeseries import unwrap_rad

__all__ = ["FEATURES", "FEATURE_STEPS", "PENDULUM_BAND_HZ", "HF_BAND_HZ", "FlightFeatures", "flight_features",
           "binned_spectra"]

#: Feature names in the order of the feature vectors.
FEATURES: tuple[str, ...] = (
    "ln_sigma_ratio_u",
    "ln_sigma_ratio_v",
    "ln_sigma_ratio_w",
    "ln_speed_ratio",
    "dir_diff_deg",
    "tilt_diff_deg",
    "sw_su_drone",
    "sw_su_mast",
    "ln_pendulum_w",
    "ln_hf_u",
    "ln_hf_w",
    "lag_sonic_ins_s",
    "lag_drift_s",
    "corr_wres_pitch_rate",
    "corr_wres_roll_rate",
)

#: Band around the 18 m sling-load pendulum frequency sqrt(g/l)/2pi = 0.117 Hz [Hz].
PENDULUM_BAND_HZ: tuple[float, float] = (0.08, 0.17)
#: High-frequency band below the 8 Hz anti-alias cut-off (3.5 Hz) [Hz].
HF_BAND_HZ: tuple[float, float] = (1.5, 3.0)


@dataclass(frozen=True)
class FlightFeatures:
    """Features of one flight with their sampling standard errors.

    Attributes
    ----------
    values, sigma : dict
        Feature name -> value / standard error (NaN when not measurable).
    conditions : dict
        Mast mean speed, direction, height, Obukhov length and sigmas (for scaling
        residuals with wind speed and for the forward model's settings).
    reasons : dict
        Feature name -> why it is NaN.
    """

    values: dict[str, float]
    sigma: dict[str, float]
    conditions: dict[str, float]
    reasons: dict[str, str]

    def vector(self) -> tuple[np.ndarray, np.ndarray]:
        """Values and errors in :data:`FEATURES` order."""
        return (np.array([self.values.get(f, np.nan) for f in FEATURES]),
                np.array([self.sigma.get(f, np.nan) for f in FEATURES]))


def _time_scale(x: np.ndarray, fs_hz: float) -> float:
    """Integral time scale of a series for the sampling errors [s] (reused within a forward flight).

    Inside a forward flight's runs (:mod:`dronewind.core.reuse`), a series a probe left
    unchanged (most often the mast's) is not fitted again.
    """
    return float(reused("integral time scale", {"x": x}, repr(float(fs_hz)), lambda: _fitted_time_scale(x, fs_hz)))


def _welch(x: np.ndarray, fs_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`dronewind.core.spectra.welch_psd` of a series, read-only (reused within a forward flight)."""
    return reused("welch psd", {"x": x}, repr(float(fs_hz)), lambda: spectra.welch_psd(x, fs_hz))


def _fitted_time_scale(x: np.ndarray, fs_hz: float) -> float:
    result = scales.integral_time_scale(x, fs_hz)
    value = float(result.time_scale_s)
    duration = x.size / fs_hz
    if not np.isfinite(value) or value <= 0:
        return 10.0  # a typical surface-layer scale when the fit fails (conservative)
    return float(min(value, duration / 4))


def _band_power(f_hz: np.ndarray, psd: np.ndarray, band: tuple[float, float]) -> tuple[float, int]:
    sel = (f_hz >= band[0]) & (f_hz <= band[1])
    if sel.sum() < 1:
        return np.nan, 0
    df = np.median(np.diff(f_hz))
    return float(psd[sel].sum() * df), int(sel.sum())


def _wrap180(deg: float) -> float:
    return float((deg + 180.0) % 360.0 - 180.0)


def _smoothed_rates_deg_s(l2: xr.Dataset, fs_out_hz: float) -> tuple[int, np.ndarray, dict[str, np.ndarray]]:
    """Pitch and roll rates of the payload smoothed to the L3 rate, on the L2's own times.

    Returns the first time [ns since 1970], the times [s since it] and the rates [degree s-1].
    """
    t_ns = l2["time"].values.astype("datetime64[ns]").astype(np.int64)
    t_s = (t_ns - t_ns[0]) / 1e9
    fs_in = 1.0 / float(np.median(np.diff(t_s)))
    width = max(int(round(fs_in / fs_out_hz)), 1)
    kernel = np.ones(width) / width
    out = {}
    for name in ("pitch_deg", "roll_deg"):
        angle = unwrap_rad(deg2rad(l2[name].values.astype(float)))
        rate = rad2deg(np.gradient(angle, t_s))
        out[name] = np.convolve(rate, kernel, mode="same")
    return int(t_ns[0]), t_s, out


def _rates_deg_s(l2: xr.Dataset, times: np.ndarray, fs_out_hz: float) -> dict[str, np.ndarray]:
    """Pitch and roll rates of the payload, smoothed to the L3 rate, at ``times``.

    The smoothed rates depend on the L2's attitude only: inside a forward flight's runs
    (:mod:`dronewind.core.reuse`) a sonic or mast probe finds them made and only
    interpolates them at its own L3 times (which move with the drone-mast lag).
    """
    arrays = {"time": l2["time"].values, "pitch_deg": l2["pitch_deg"].values, "roll_deg": l2["roll_deg"].values}
    t0_ns, t_s, smooth = reused("attitude rates", arrays, repr(float(fs_out_hz)),
                                lambda: _smoothed_rates_deg_s(l2, fs_out_hz))
    target = (times.astype("datetime64[ns]").astype(np.int64) - t0_ns) / 1e9
    return {name: np.interp(target, t_s, smooth[name], left=np.nan, right=np.nan) for name in ("pitch_deg", "roll_deg")}


@dataclass(frozen=True)
class _SensorSeries:
    """Drone and mast u, v, w of one L3 flight (gaps removed) with their statistics."""

    fs_hz: float
    #: sensor names in L3 order
    sensors: list[str]
    #: sensor -> component -> series [m s-1]
    series: dict[str, dict[str, np.ndarray]]
    #: samples of the shorter series and its duration [s]
    n: int
    tau_s: float
    height_m: dict[str, float]
    sigma_ms: dict[str, dict[str, float]]
    time_scale_s: dict[str, dict[str, float]]
    mean_u_ms: dict[str, float]


@dataclass
class _Features:
    """Feature values, standard errors and reasons, filled step by step (insertion order kept)."""

    values: dict[str, float] = field(default_factory=dict)
    sigma: dict[str, float] = field(default_factory=dict)
    reasons: dict[str, str] = field(default_factory=dict)

    def set(self, name: str, value: float, sigma: float) -> None:
        """Record one measured feature."""
        self.values[name] = value
        self.sigma[name] = sigma


def _sensor_series(l3: xr.Dataset, time_scales: bool = True) -> _SensorSeries:
    """Finite samples of drone and mast u, v, w; their sigmas, integral time scales (NaN without
    ``time_scales``: only the errors need them) and mean speeds."""
    fs = float(l3.attrs["sampling_rate_hz"])
    sensors = list(l3["sensor"].values)
    series = {}
    for sensor in ("drone", "mast"):
        i = sensors.index(sensor)
        comp = {c: l3[f"{c}_ms"].values[i].astype(float) for c in ("u", "v", "w")}
        ok = np.all([np.isfinite(v) for v in comp.values()], axis=0)
        series[sensor] = {c: v[ok] if ok.sum() < ok.size else v for c, v in comp.items()}
    n = min(series["drone"]["u"].size, series["mast"]["u"].size)
    height = {s: float(l3["height_m"].values[sensors.index(s)]) for s in ("drone", "mast")}
    sig = {s: {c: float(stats.standard_deviation(series[s][c])) for c in ("u", "v", "w")} for s in series}
    tscale = {s: {c: _time_scale(series[s][c], fs) if time_scales else np.nan for c in ("u", "v", "w")}
              for s in series}
    mean_u = {s: float(np.mean(series[s]["u"])) for s in series}
    return _SensorSeries(fs, sensors, series, n, n / fs, height, sig, tscale, mean_u)


def _moment_features(s: _SensorSeries, out: _Features) -> None:
    """ln sigma ratios of u, v, w and the ln mean-speed ratio (Ghirardelli et al. 2025, Eqs 10-13 errors)."""
    sig, tscale, mean_u, tau_s = s.sigma_ms, s.time_scale_s, s.mean_u_ms, s.tau_s
    for c in ("u", "v", "w"):
        out.set(f"ln_sigma_ratio_{c}", float(np.log(sig["drone"][c] / sig["mast"][c])),
                float(np.sqrt(tscale["drone"][c] / tau_s + tscale["mast"][c] / tau_s)))
    if mean_u["drone"] > 0 and mean_u["mast"] > 0:
        out.set("ln_speed_ratio", float(np.log(mean_u["drone"] / mean_u["mast"])),
                float(np.sqrt(sum(2 * tscale[x]["u"] / tau_s * (sig[x]["u"] / mean_u[x]) ** 2 for x in s.series))))
    else:
        out.reasons["ln_speed_ratio"] = "mean speed not positive"


def _angle_error_deg(s: _SensorSeries, component: str) -> float:
    """Sampling error of a flow angle from ``component`` fluctuations about the mean speed [degree]."""
    return float(rad2deg(np.sqrt(sum(
        2 * s.time_scale_s[x][component] / s.tau_s * (s.sigma_ms[x][component] / max(abs(s.mean_u_ms[x]), 0.1)) ** 2
        for x in s.series))))


def _direction_features(l3: xr.Dataset, s: _SensorSeries, out: _Features) -> None:
    """Wind-direction and streamline-tilt differences, drone minus mast."""
    wdir = l3["wind_from_deg"].values.astype(float)
    out.set("dir_diff_deg", _wrap180(wdir[s.sensors.index("drone")] - wdir[s.sensors.index("mast")]),
            _angle_error_deg(s, "v"))
    if "rotation_pitch_deg" in l3:
        pitch = l3["rotation_pitch_deg"].values.astype(float)
        out.set("tilt_diff_deg", float(pitch[s.sensors.index("drone")] - pitch[s.sensors.index("mast")]),
                _angle_error_deg(s, "w"))
    else:
        out.reasons["tilt_diff_deg"] = "no rotation angles in L3"


def _spectral_features(s: _SensorSeries, fr_band: tuple[float, float], min_speed_ms: float,
                       out: _Features) -> None:
    """Isotropy ratios <S_w/S_u> of both sensors; drone/mast power at the pendulum and high frequencies."""
    psd: dict[str, dict[str, np.ndarray]] = {}
    for x in s.series:
        psd[x] = {}
        for c in ("u", "w"):
            f_hz, p = _welch(s.series[x][c][:s.n], s.fs_hz)
            psd[x][c] = p
    dof = spectra.welch_dof(spectra.segment_length(s.n))
    for x in ("drone", "mast"):
        name = f"sw_su_{x}"
        # As in L4 (Ghirardelli et al. 2025, Sect. 4.1): the ratio of the log-bin-smoothed spectra, averaged
        # over the band. The mean of raw Welch-bin ratios would be biased: with ~8 degrees
        # of freedom per raw bin, E[X/Y] of two chi-square estimates is 8/6 times the true
        # ratio (about 1.8 instead of 4/3).
        binned = spectra.bin_log(f_hz[1:], np.vstack([psd[x]["w"][1:], psd[x]["u"][1:]]))
        ratio = spectra.spectral_ratio(binned.f_hz, binned.values[0], binned.values[1], s.height_m[x],
                                       s.mean_u_ms[x], fr_band[0], fr_band[1], min_speed_ms)
        if not np.isfinite(ratio.value):
            out.reasons[name] = ratio.reason or "reduced-frequency band not resolved"
        else:
            raw = int(((f_hz > ratio.f_min_hz) & (f_hz < ratio.f_max_hz)).sum())
            out.set(name, float(ratio.value), float(ratio.value * np.sqrt(4.0 / (dof * max(raw, 1)))))
    for name, comp, band in (("ln_pendulum_w", "w", PENDULUM_BAND_HZ), ("ln_hf_u", "u", HF_BAND_HZ),
                             ("ln_hf_w", "w", HF_BAND_HZ)):
        pd_, m = _band_power(f_hz, psd["drone"][comp], band)
        pm_, _ = _band_power(f_hz, psd["mast"][comp], band)
        if m < 1 or not (pd_ > 0 and pm_ > 0):
            out.reasons[name] = f"band {band} Hz not resolved"
            continue
        out.set(name, float(np.log(pd_ / pm_)), float(np.sqrt(2 * 2.0 / (dof * m))))


def _lag_features(l2_drone: xr.Dataset, lag_halves_s: tuple[float, float] | None, lag_step_s: float,
                  out: _Features) -> None:
    """Sonic-INS lag found by the chain and its drift between the hover halves."""
    lag_sigma = max(lag_step_s / np.sqrt(12.0), 0.005)
    out.set("lag_sonic_ins_s", float(l2_drone.attrs.get("lag_sonic_ins_s", np.nan)), lag_sigma)
    if lag_halves_s is not None and all(np.isfinite(lag_halves_s)):
        out.set("lag_drift_s", float(lag_halves_s[1] - lag_halves_s[0]), float(np.sqrt(2) * lag_sigma))
    else:
        out.reasons["lag_drift_s"] = "lags of the two halves not available"


def _attitude_rate_features(l3: xr.Dataset, l2_drone: xr.Dataset, s: _SensorSeries, out: _Features) -> None:
    """Correlations of the w residual (drone minus mast) with the payload's pitch and roll rates."""
    lag_dm = float(l3.attrs.get("lag_drone_mast_s", 0.0))
    times = l3["time"].values - np.timedelta64(int(round(lag_dm * 1e9)), "ns")
    rates = _rates_deg_s(l2_drone, times, s.fs_hz)
    wres = l3["w_ms"].values[s.sensors.index("drone")] - l3["w_ms"].values[s.sensors.index("mast")]
    n_eff = max(s.tau_s / (2 * max(s.time_scale_s["drone"]["w"], 1.0 / s.fs_hz)), 3.0)
    for name, key in (("corr_wres_pitch_rate", "pitch_deg"), ("corr_wres_roll_rate", "roll_deg")):
        ok = np.isfinite(wres) & np.isfinite(rates[key])
        if ok.sum() < 10 or np.std(rates[key][ok]) == 0:
            out.reasons[name] = "attitude rates not available over the L3 window"
            continue
        out.set(name, float(np.corrcoef(wres[ok], rates[key][ok])[0, 1]), float(1.0 / np.sqrt(n_eff)))


def _flight_conditions(l3: xr.Dataset, s: _SensorSeries) -> dict[str, float]:
    """Mast mean speed, direction, heights, mast sigmas and the record length."""
    wdir = l3["wind_from_deg"].values.astype(float)
    return {
        "U_ms": s.mean_u_ms["mast"],
        "wind_from_deg": float(wdir[s.sensors.index("mast")]),
        "height_m": s.height_m["mast"],
        "drone_height_m": s.height_m["drone"],
        "sigma_u_ms": s.sigma_ms["mast"]["u"],
        "sigma_v_ms": s.sigma_ms["mast"]["v"],
        "sigma_w_ms": s.sigma_ms["mast"]["w"],
        "duration_s": s.tau_s,
    }


#: The features each step of :func:`flight_features` gives (the steps that ``features`` selects).
FEATURE_STEPS: dict[str, tuple[str, ...]] = {
    "moments": ("ln_sigma_ratio_u", "ln_sigma_ratio_v", "ln_sigma_ratio_w", "ln_speed_ratio"),
    "directions": ("dir_diff_deg", "tilt_diff_deg"),
    "spectra": ("sw_su_drone", "sw_su_mast", "ln_pendulum_w", "ln_hf_u", "ln_hf_w"),
    "lags": ("lag_sonic_ins_s", "lag_drift_s"),
    "attitude rates": ("corr_wres_pitch_rate", "corr_wres_roll_rate"),
}


def flight_features(
    l3: xr.Dataset,
    l2_drone: xr.Dataset,
    lag_halves_s: tuple[float, float] | None = None,
    lag_step_s: float = 1.0 / 32.0,
    fr_band: tuple[float, float] = (2.0, 10.0),
    min_speed_ms: float = 2.0,
    *,
    features: Collection[str] | None = None,
    errors: bool = True,
) -> FlightFeatures:
    """Residual features of one flight (drone against its reference mast sonic).

    Parameters
    ----------
    l3 : xarray.Dataset
        L3 flight dataset (``u_ms``, ``v_ms``, ``w_ms`` over ``(sensor, time)``,
        ``wind_from_deg(sensor)``, ``height_m(sensor)``, ``rotation_pitch_deg(sensor)``,
        attrs ``lag_drone_mast_s``, ``sampling_rate_hz``).
    l2_drone : xarray.Dataset
        L2 drone dataset (``pitch_deg``, ``roll_deg`` over ``time``; attr
        ``lag_sonic_ins_s``).
    lag_halves_s : tuple of float, optional
        Sonic-INS lags found on the first and second half of the hover [s]
        (for ``lag_drift_s``); NaN when not given.
    lag_step_s : float
        Step of the lag search [s] (its resolution enters the lag errors).
    fr_band : tuple of float
        Reduced-frequency band of the isotropy ratios (Ghirardelli et al. 2025, Sect. 4.1).
    min_speed_ms : float
        Isotropy ratios only above this mean speed [m s-1].
    features : collection of str, optional
        Only the steps of :data:`FEATURE_STEPS` that give one of these features are run
        (their other features come along); every other feature is NaN with the reason
        ``"not requested"``. All by default.
    errors : bool
        Give the standard errors; without, every error is NaN and the integral time scales
        (the fits they need, most of the cost) are not found. For forward runs whose
        errors nobody reads: the probes (the diagnosis takes the errors from the baseline
        seeds, :mod:`dronewind.diagnose.campaign`).

    Returns
    -------
    FlightFeatures
        Values, standard errors, conditions and reasons.
    """
    wanted = set(FEATURES if features is None else features)
    unknown = sorted(wanted - set(FEATURES))
    if unknown:
        raise ValueError(f"flight_features: unknown feature(s) {unknown}; expected some of {list(FEATURES)}")
    steps = {step for step, names in FEATURE_STEPS.items() if wanted & set(names)}
    s = _sensor_series(l3, time_scales=errors)
    out = _Features()
    if "moments" in steps:
        _moment_features(s, out)
    if "directions" in steps:
        _direction_features(l3, s, out)
    if "spectra" in steps:
        _spectral_features(s, fr_band, min_speed_ms, out)
    if "lags" in steps:
        _lag_features(l2_drone, lag_halves_s, lag_step_s, out)
    if "attitude rates" in steps:
        _attitude_rate_features(l3, l2_drone, s, out)
    for f in FEATURES:
        if f not in out.values:
            out.set(f, np.nan, np.nan)
            out.reasons.setdefault(f, "not measured" if f in wanted else "not requested")
    sigma = out.sigma if errors else dict.fromkeys(out.sigma, np.nan)
    return FlightFeatures(out.values, sigma, _flight_conditions(l3, s), out.reasons)


def features_to_dict(features: FlightFeatures) -> dict[str, dict[str, float | None] | dict[str, str]]:
    """JSON-ready form (NaN as None)."""

    def clean(d: Mapping[str, float]) -> dict[str, float | None]:
        return {k: (None if not np.isfinite(v) else float(v)) for k, v in d.items()}

    return {"values": clean(features.values), "sigma": clean(features.sigma),
            "conditions": clean(features.conditions), "reasons": dict(features.reasons)}


def binned_spectra(l3: xr.Dataset, n_bins: int = 60) -> dict[str, list[float]]:
    """Log-bin-smoothed Welch spectra of u and w of drone and mast (for before/after figures).

    Parameters
    ----------
    l3 : xarray.Dataset
        L3 flight dataset (``u_ms``, ``w_ms`` over ``(sensor, time)``, attr
        ``sampling_rate_hz``).
    n_bins : int
        Logarithmic bins (Ghirardelli et al. 2025 smooths over 100; 60 keep the JSON small).

    Returns
    -------
    dict
        ``f_hz`` and ``drone_u``, ``drone_w``, ``mast_u``, ``mast_w`` [m2 s-2 Hz-1] on it.
    """
    fs = float(l3.attrs["sampling_rate_hz"])
    sensors = list(np.asarray(l3["sensor"].values).astype(str))
    rows: list[np.ndarray] = []
    names: list[str] = []
    f_hz = np.empty(0)
    for sensor in ("drone", "mast"):
        for c in ("u", "w"):
            x = l3[f"{c}_ms"].values[sensors.index(sensor)].astype(float)
            x = x[np.isfinite(x)]
            f_hz, p = spectra.welch_psd(x, fs)
            rows.append(p[1:])
            names.append(f"{sensor}_{c}")
    n = min(r.size for r in rows)
    binned = spectra.bin_log(f_hz[1:1 + n], np.vstack([r[:n] for r in rows]), n_bins=n_bins)
    out = {"f_hz": binned.f_hz.tolist()}
    for name, values in zip(names, binned.values, strict=True):
        out[name] = values.tolist()
    return out
