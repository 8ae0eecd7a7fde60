r"""L4: statistics, spectra, fits, uncertainties and length scales of one sonic record.

:func:`flight_l4` takes one sensor of an L3 flight dataset (streamline coordinates,
see ``briefs/interfaces.md``) and returns an :class:`xarray.Dataset` with

* scalars (0-d variables): mean speed and direction, height, σ, skewness, kurtosis,
  fluxes, u*, TKE, I_u, mean sonic temperature, Obukhov length L and ζ, spectral
  ratios :math:`\langle S_w/S_u\rangle`, :math:`\langle S_v/S_u\rangle`, fitted spectral
  coefficients, integral time and length scales, and the uncertainty metrics;
* binned spectra and co-spectra (and the fitted model curves) on a ``frequency``
  dimension;
* one integer status variable per quantity group (``status_*``) with CF
  ``flag_values``/``flag_meanings`` and a human-readable ``reason`` attribute.

Bad data never raise here and never give a silent number: a quantity that cannot be
computed is NaN and its status says why (record too short for the requested spectra,
fit not converged, mean speed ≤ 2 m s-1 for the quadrant analysis, Taylor's hypothesis
not valid, ...). Only a dataset that breaks the L3 contract (missing variable or
sensor) raises :class:`~dronewind.errors.InputError`.

References
----------
.. [1] Ghirardelli et al. (2025), Sects. 4.1-4.4, Eqs 4-17, Tables 4-5.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from dronewind.core import scales, spectra, stats, uncertainty
from dronewind.core.cf import variable, variable_attrs
from dronewind.core.constants import GRAVITY_MS2, KARMAN
from dronewind.core.qc import STATUS_FLAG_MEANINGS
from dronewind.errors import InputError

__all__ = ["STATUS_FLAG_MEANINGS", "flight_l4", "record_l4"]

_S = {name: i for i, name in enumerate(STATUS_FLAG_MEANINGS)}

#: Known low bias of the exponential-fit integral scale of u, stored as the ``comment`` of
#: ``T_u_s`` and ``L_u_m`` (measured by tests/core/test_scales.py::test_exponential_fit_low_bias_for_u).
EXPONENTIAL_FIT_BIAS_U: str = (
    "Known low bias: the exponential fit to the autocovariance (up to its first zero crossing, after linear "
    "detrending of a finite record) underestimates the integral scale of u, whose autocovariance decays slowly. "
    "On 28-min von Karman u series the median estimate is 0.99, 0.93, 0.87 and 0.80 of the true time scale for "
    "T = 5, 10, 20 and 40 s (T / record = 0.3 to 2.4 %); read L_u as a lower bound when T_u exceeds about 1 % "
    "of the record."
)

_L3_VARS = ("u_ms", "v_ms", "w_ms", "theta_v_k")


class _Builder:
    """Collects variables, statuses and log lines for one L4 dataset."""

    def __init__(self) -> None:
        self.data_vars: dict[str, xr.Variable] = {}
        self.log: list[str] = []
        self.n_not_ok = 0
        self.n_empty_bins = 0

    def scalar(self, name: str, value: float, units: str, long_name: str | None = None,
               standard_name: str | None = None, **extra: Any) -> None:
        """Add a 0-d float64 variable with CF attributes (:func:`dronewind.core.cf.variable_attrs`)."""
        self.data_vars[name] = variable((), np.float64(value), units, standard_name, long_name, **extra)

    def status(self, name: str, what: str, flag: str, reason: str = "") -> None:
        """Add an int8 ``status_*`` variable (:data:`dronewind.core.qc.STATUS_FLAG_MEANINGS`); log it if not ok."""
        attrs = {
            "long_name": f"status of {what}",
            "standard_name": "status_flag",
            "flag_values": np.arange(len(STATUS_FLAG_MEANINGS), dtype=np.int8),
            "flag_meanings": " ".join(STATUS_FLAG_MEANINGS),
            "reason": reason,
        }
        self.data_vars[name] = xr.Variable((), np.int8(_S[flag]), attrs)
        if flag != "ok":
            self.n_not_ok += 1
            self.log.append(f"{name}: {flag}: {reason}")


@dataclass
class _Moments:
    """One-point statistics of a record (NaN where not computable) and its fluctuations (None then)."""

    speed: float
    su: float
    sv: float
    sw: float
    uw: float
    vw: float
    skew: list[float]
    kurt: list[float]
    ustar: float
    tke: float
    iu: float
    up: np.ndarray | None
    vp: np.ndarray | None
    wp: np.ndarray | None
    thp: np.ndarray | None = None
    wt: float = np.nan
    ut: float = np.nan
    th_mean: float = np.nan
    sT: float = np.nan


def _status_of(ok: bool, bad: str, reason: str) -> tuple[str, str]:
    return ("ok", "") if ok else (bad, reason)


def record_l4(
    u_ms: np.ndarray, v_ms: np.ndarray, w_ms: np.ndarray, theta_v_k: np.ndarray, fs_hz: float, height_m: float,
    wind_from_deg: float = np.nan, *, n_segments: int = 3, overlap: float = 0.5, window: str = "hamming",
    n_bins: int = 100, min_segment_samples: int = 64, min_samples: int = 16, quadrant_min_speed_ms: float = 2.0,
    fr_band: tuple[float, float] = (2.0, 10.0), fit_f_max_hz: float | None = None,
    detrending: str = "linear",
) -> xr.Dataset:
    r"""L4 analysis of one record in streamline coordinates (numpy entry point).

    Parameters
    ----------
    u_ms, v_ms, w_ms : array-like
        Streamwise, cross-wind and vertical velocity [m s-1], evenly sampled, means kept.
    theta_v_k : array-like
        Sonic (virtual) temperature [K].
    fs_hz : float
        Sampling rate [Hz].
    height_m : float
        Measurement height above ground [m].
    wind_from_deg : float, optional
        Mean wind-from direction [degree] (passed through).
    n_segments, overlap, window : optional
        Welch settings (3, 0.5, ``"hamming"``; Ghirardelli et al. (2025), Sect. 4.4).
    n_bins : int, optional
        Logarithmic frequency bins (100).
    min_segment_samples : int, optional
        Shortest Welch segment accepted [samples]; shorter records get
        ``record_too_short`` for the spectra, fits and ratios.
    min_samples : int, optional
        Shortest record for any statistic [samples].
    quadrant_min_speed_ms : float, optional
        Spectral ratios only above this mean speed (2 m s-1, Ghirardelli et al. (2025), Sect. 4.1).
    fr_band : (float, float), optional
        Reduced-frequency band of the ratios (2, 10).
    fit_f_max_hz : float, optional
        Highest frequency of the spectral-model fits (Eqs 4-7) [Hz]: the passband edge of
        the anti-alias filter the record went through (:func:`flight_l4` takes it from the
        L3 attribute ``fir_passband_edge_hz``). Default: every frequency (an unfiltered record).
    detrending : {"linear", "block_mean"}, optional
        Fluctuations about a least-squares line (Ghirardelli et al. (2025)) or the block mean, for every
        statistic (``attrs["detrending"]``).

    Returns
    -------
    xarray.Dataset
        See the module docstring. ``attrs`` hold ``sampling_rate_hz``, ``n_samples``,
        ``n_nonfinite_<var>``, the spectral settings and ``processing_log``.

    Raises
    ------
    InputError
        Unequal lengths, non-positive rate or height; bad *data* never raises (``status_*``).

    Notes
    -----
    Mean speed: :math:`\sqrt{\bar u^2 + \bar v^2}`; Eq. 9 uses the mean sonic temperature [K].
    """
    b = _Builder()
    arrays = _check_record(u_ms, v_ms, w_ms, theta_v_k, fs_hz, height_m)
    n = arrays["u"].size
    nonfinite = {k: int(np.count_nonzero(~np.isfinite(a))) for k, a in arrays.items()}
    duration_s = n / fs_hz
    method = _detrend_method(detrending)
    attrs = _l4_attrs(fs_hz, n, nonfinite, n_segments, overlap, window, n_bins, method)
    attrs["spectral_fit_f_max_hz"] = float(fs_hz / 2.0 if fit_f_max_hz is None else fit_f_max_hz)
    vel_ok, temp_ok, (vel_flag, vel_reason), (temp_flag, temp_reason) = _input_status(n, nonfinite, min_samples)
    m = _moments(arrays, vel_ok, temp_ok, method)
    b.status("status_statistics", "velocity statistics", vel_flag, vel_reason)
    b.status("status_temperature", "temperature statistics and buoyancy flux", temp_flag, temp_reason)
    _moment_part(b, m, wind_from_deg, height_m, duration_s, method)
    _obukhov_part(b, m, height_m, temp_ok, temp_flag, temp_reason)
    _spectral_part(b, m.up, m.vp, m.wp, m.thp, fs_hz, height_m, m.speed, m.ustar, vel_flag, vel_reason, temp_ok,
                   n_segments=n_segments, overlap=overlap, window=window, n_bins=n_bins,
                   min_segment=min_segment_samples, min_speed=quadrant_min_speed_ms, fr_band=fr_band,
                   fit_f_max_hz=fit_f_max_hz)
    _scale_part(b, arrays["u"], arrays["v"], arrays["w"], fs_hz, m.speed, m.su, vel_flag, vel_reason, method)
    _uncertainty_part(b, m.up, m.vp, m.wp, m.thp, fs_hz, height_m, duration_s, m.speed, m.ustar, m.su, m.sv, m.sw,
                      m.wt, vel_flag, vel_reason, temp_ok, temp_flag, temp_reason)
    attrs["processing_log"] = "\n".join(["l4: statistics, spectra, fits, scales, uncertainties computed"] + b.log)
    attrs["n_status_not_ok"] = int(b.n_not_ok)
    attrs["n_empty_frequency_bins"] = int(b.n_empty_bins)
    return xr.Dataset(b.data_vars, attrs=attrs)


def _check_record(u_ms: np.ndarray, v_ms: np.ndarray, w_ms: np.ndarray, theta_v_k: np.ndarray, fs_hz: float,
                  height_m: float) -> dict[str, np.ndarray]:
    """The four series as flat float arrays (keys ``u``, ``v``, ``w``, ``theta``), checked.

    Raises
    ------
    InputError
        Unequal lengths, or a non-positive sampling rate [Hz] or height [m].
    """
    arrays = {name: np.asarray(a, dtype=float).ravel() for name, a in
              zip(("u", "v", "w", "theta"), (u_ms, v_ms, w_ms, theta_v_k), strict=True)}
    n = arrays["u"].size
    if any(a.size != n for a in arrays.values()):
        raise InputError("record_l4(u_ms, v_ms, w_ms, theta_v_k)", "series must have equal length")
    if not (np.isfinite(fs_hz) and fs_hz > 0):
        raise InputError("record_l4(fs_hz)", f"expected a positive sampling rate, got {fs_hz}")
    if not (np.isfinite(height_m) and height_m > 0):
        raise InputError("record_l4(height_m)", f"expected a positive measurement height, got {height_m}")
    return arrays


def _detrend_method(detrending: str) -> stats.Detrend:
    """The :func:`dronewind.core.stats.fluctuation` method of a ``detrending`` setting."""
    methods: dict[str, stats.Detrend] = {"linear": "linear", "block_mean": "constant"}
    if detrending not in methods:
        raise InputError("L4 detrending", f"expected 'linear' or 'block_mean', got {detrending!r}")
    return methods[detrending]


#: Text of the ``detrending`` attribute and the suffix of the standard-deviation long names.
_DETRENDING_TEXT: dict[str, tuple[str, str]] = {
    "linear": ("linear (least squares) before every statistic, spectrum and autocovariance", "linearly detrended"),
    "constant": ("block mean (Reynolds decomposition) removed before every statistic, spectrum and autocovariance",
                 "block mean removed"),
}


def _l4_attrs(fs_hz: float, n: int, nonfinite: dict[str, int], n_segments: int, overlap: float, window: str,
              n_bins: int, method: stats.Detrend = "linear") -> dict[str, Any]:
    """Dataset attributes describing the record and the methods (the log is added at the end)."""
    return {
        "sampling_rate_hz": float(fs_hz),
        "n_samples": int(n),
        **{f"n_nonfinite_{k}": v for k, v in nonfinite.items()},
        "detrending": _DETRENDING_TEXT[method][0],
        "spectral_method": (
            f"Welch, {n_segments} segments, {overlap:.0%} overlap, {window} window, one-sided density; "
            f"{n_bins} logarithmic bins (Ghirardelli et al. (2025), Sect. 4.4)"
        ),
        "obukhov_temperature": "mean sonic temperature theta_v_k [K] as virtual potential temperature "
                               "(Ghirardelli et al. 2025, Eq. 9)",
        "karman_constant": KARMAN,
        "gravity_ms2": GRAVITY_MS2,
    }


def _input_status(n: int, nonfinite: dict[str, int], min_samples: int
                  ) -> tuple[bool, bool, tuple[str, str], tuple[str, str]]:
    """Whether the velocity and temperature statistics can be computed, and their status and reason.

    Returns
    -------
    vel_ok, temp_ok : bool
        Enough finite samples for the velocity (and temperature) statistics.
    (vel_flag, vel_reason), (temp_flag, temp_reason) : tuple of str
        Status names (:data:`dronewind.core.qc.STATUS_FLAG_MEANINGS`) and reasons.
    """
    vel_ok = n >= min_samples and nonfinite["u"] == 0 and nonfinite["v"] == 0 and nonfinite["w"] == 0
    temp_ok = vel_ok and nonfinite["theta"] == 0
    if n < min_samples:
        vel_flag, vel_reason = "record_too_short", f"{n} samples < {min_samples}"
    elif not vel_ok:
        vel_flag = "invalid_input"
        vel_reason = (f"non-finite samples: u {nonfinite['u']}, v {nonfinite['v']}, w {nonfinite['w']} "
                      "(L3 must be gap-filled)")
    else:
        vel_flag, vel_reason = "ok", ""
    temp_flag, temp_reason = (vel_flag, vel_reason) if not vel_ok else _status_of(
        temp_ok, "invalid_input", f"{nonfinite['theta']} non-finite temperature samples")
    return vel_ok, temp_ok, (vel_flag, vel_reason), (temp_flag, temp_reason)


def _moments(arrays: dict[str, np.ndarray], vel_ok: bool, temp_ok: bool,
             method: stats.Detrend = "linear") -> _Moments:
    """Mean speed, standard deviations, skewness, kurtosis, fluxes, u*, TKE, I_u (Ghirardelli et al. 2025, Sect. 4.1).

    Fluctuations about a line or the block mean (``method``); the temperature statistics only
    when ``temp_ok``.
    """
    nan = np.nan
    u, v, w, th = arrays["u"], arrays["v"], arrays["w"], arrays["theta"]
    if vel_ok:
        speed, _ = stats.mean_wind(u, v)
        up, vp, wp = (stats.fluctuation(x, method) for x in (u, v, w))
        su, sv, sw = (float(np.sqrt(np.mean(x * x))) for x in (up, vp, wp))
        uw, vw = float(np.mean(up * wp)), float(np.mean(vp * wp))
        skew = [float(stats.skewness(x, "none")) for x in (up, vp, wp)]
        kurt = [float(stats.kurtosis(x, "none")) for x in (up, vp, wp)]
        ustar = float(stats.friction_velocity(uw, vw))
        tke = float(stats.turbulent_kinetic_energy(su, sv, sw))
        iu = float(stats.turbulence_intensity(su, speed))
        m = _Moments(float(speed), su, sv, sw, uw, vw, skew, kurt, ustar, tke, iu, up, vp, wp)
    else:
        m = _Moments(float(nan), nan, nan, nan, nan, nan, [nan] * 3, [nan] * 3, nan, nan, nan, None, None, None)
    if temp_ok:
        m.thp = stats.fluctuation(th, method)
        m.wt, m.ut = float(np.mean(m.wp * m.thp)), float(np.mean(m.up * m.thp))
        m.th_mean = float(np.mean(th))
        m.sT = float(np.sqrt(np.mean(m.thp * m.thp)))
    return m


def _moment_part(b: _Builder, m: _Moments, wind_from_deg: float, height_m: float, duration_s: float,
                 method: stats.Detrend = "linear") -> None:
    """The scalar variables of the one-point statistics (:func:`_moments`)."""
    b.scalar("U_ms", m.speed, "m s-1", "mean horizontal wind speed (speed of the mean vector)", "wind_speed")
    b.scalar("wind_from_deg", wind_from_deg, "degree", "mean wind-from direction before rotation",
             "wind_from_direction")
    b.scalar("height_m", height_m, "m", "measurement height above ground", "height", positive="up")
    b.scalar("duration_s", duration_s, "s", "averaging time (record length)")
    for comp, s_val in zip("uvw", (m.su, m.sv, m.sw), strict=True):
        b.scalar(f"sigma_{comp}_ms", s_val, "m s-1", f"standard deviation of {comp} ({_DETRENDING_TEXT[method][1]})")
    for comp, g, k in zip("uvw", m.skew, m.kurt, strict=True):
        b.scalar(f"skewness_{comp}", g, "1", f"skewness of {comp}")
        b.scalar(f"kurtosis_{comp}", k, "1", f"kurtosis of {comp} (Pearson, 3 for Gaussian)")
    b.scalar("uw_m2s2", m.uw, "m2 s-2", "kinematic momentum flux u'w' (streamwise)")
    b.scalar("vw_m2s2", m.vw, "m2 s-2", "kinematic momentum flux v'w' (cross-wind)")
    b.scalar("u_star_ms", m.ustar, "m s-1", "friction velocity (u'w'^2 + v'w'^2)^(1/4)")
    b.scalar("tke_m2s2", m.tke, "m2 s-2", None, "specific_turbulent_kinetic_energy_of_air")
    b.scalar("I_u", m.iu, "1", "streamwise turbulence intensity sigma_u/U")
    tdiff = {"units_metadata": "temperature: difference"}
    b.scalar("sigma_T_k", m.sT, "K", "standard deviation of sonic temperature", **tdiff)
    b.scalar("wT_Kms", m.wt, "K m s-1", "kinematic buoyancy flux w'theta_v' (sonic temperature)", **tdiff)
    b.scalar("uT_Kms", m.ut, "K m s-1", "kinematic streamwise heat flux u'theta_v'", **tdiff)
    b.scalar("theta_v_mean_k", m.th_mean, "K", "mean sonic temperature", "virtual_temperature",
             units_metadata="temperature: on_scale")


def _obukhov_part(b: _Builder, m: _Moments, height_m: float, temp_ok: bool, temp_flag: str, temp_reason: str
                  ) -> None:
    """Obukhov length L and stability parameter z/L (Ghirardelli et al. (2025), Eq. 9)."""
    if temp_ok:
        ell = float(stats.obukhov_length(m.ustar, m.wt, m.th_mean)) if m.wt != 0.0 else np.inf
        if not np.isfinite(ell):
            ell = zeta = np.nan
            b.status("status_obukhov", "Obukhov length", "undefined",
                     "zero buoyancy flux or zero u*: L infinite or 0/0")
        else:
            zeta = float(stats.stability_parameter(height_m, ell))
            b.status("status_obukhov", "Obukhov length", "ok")
    else:
        ell = zeta = np.nan
        b.status("status_obukhov", "Obukhov length", temp_flag, temp_reason)
    b.scalar("L_m", ell, "m", None, "atmosphere_obukhov_length")
    b.scalar("zeta", zeta, "1", "stability parameter z/L")


_FITS: dict[str, tuple[spectra.ModelName, str]] = {
    "u": ("blunt", "Ghirardelli et al. 2025, Eq. 4"), "v": ("blunt", "Ghirardelli et al. 2025, Eq. 5"),
    "w": ("pointed", "Ghirardelli et al. 2025, Eq. 6"), "uw": ("cospectrum", "Ghirardelli et al. 2025, Eq. 7")}

_SPECTRUM_VARS = (("S_u", "m2 s-2 Hz-1", "one-sided power spectral density of u"),
                  ("S_v", "m2 s-2 Hz-1", "one-sided power spectral density of v"),
                  ("S_w", "m2 s-2 Hz-1", "one-sided power spectral density of w"),
                  ("Co_uw", "m2 s-2 Hz-1", "co-spectrum of u and w (real part of the one-sided CPSD)"),
                  ("S_T", "K2 Hz-1", "one-sided power spectral density of sonic temperature"),
                  ("Co_wT", "K m s-1 Hz-1", "co-spectrum of w and sonic temperature"),
                  ("Co_uT", "K m s-1 Hz-1", "co-spectrum of u and sonic temperature"))


def _spectral_part(b: _Builder, up: np.ndarray | None, vp: np.ndarray | None, wp: np.ndarray | None,
                   thp: np.ndarray | None, fs_hz: float, height_m: float, speed: float, ustar: float,
                   vel_flag: str, vel_reason: str, temp_ok: bool, *, n_segments: int, overlap: float,
                   window: str, n_bins: int, min_segment: int, min_speed: float,
                   fr_band: tuple[float, float], fit_f_max_hz: float | None = None) -> None:
    """Spectra, co-spectra, model fits and spectral ratios (Ghirardelli et al. (2025), Eqs 4-8)."""
    flag, reason, nperseg = _spectral_status(up, vel_flag, vel_reason, n_segments, overlap, min_segment)
    binned, dof = None, None
    if flag == "ok":
        assert up is not None and vp is not None and wp is not None  # velocity statistics ok
        kw = dict(n_segments=n_segments, overlap=overlap, window=window, min_segment=min_segment)
        binned = _binned_spectra(up, vp, wp, thp, temp_ok, fs_hz, n_bins, kw)
        dof = spectra.binned_dof(binned.counts, nperseg, n_segments, overlap, window)
        b.n_empty_bins = binned.n_empty_bins
        b.log.append(f"spectra: {binned.f_hz.size} non-empty of {n_bins} log bins "
                     f"({binned.n_empty_bins} empty dropped)")
    b.status("status_spectra", "spectra and co-spectra", flag, reason)
    fb, vals, fr = _spectrum_vars(b, binned, height_m, speed)
    _fit_part(b, fb, vals, fr, dof, height_m, speed, ustar, flag, reason, fit_f_max_hz)
    _ratio_part(b, fb, vals, height_m, speed, flag, reason, fr_band, min_speed)


def _spectral_status(up: np.ndarray | None, vel_flag: str, vel_reason: str, n_segments: int, overlap: float,
                     min_segment: int) -> tuple[str, str, int]:
    """Status of the spectra: that of the velocity statistics, or ``record_too_short`` for short segments.

    Returns
    -------
    flag, reason : str
        Status and reason.
    nperseg : int
        Welch segment length [samples] (0 when the statistics are not ok).
    """
    flag, reason, nperseg = vel_flag, vel_reason, 0
    if flag == "ok" and up is not None:
        n = up.size
        nperseg = spectra.segment_length(n, n_segments, overlap)
        if nperseg < min_segment:
            flag = "record_too_short"
            reason = (f"{n} samples give Welch segments of {nperseg} < {min_segment} samples "
                      f"({n_segments} segments, {overlap:.0%} overlap)")
    return flag, reason, nperseg


def _binned_spectra(up: np.ndarray, vp: np.ndarray, wp: np.ndarray, thp: np.ndarray | None, temp_ok: bool,
                    fs_hz: float, n_bins: int, kw: dict[str, Any]) -> spectra.BinnedSpectrum:
    """Welch spectra of u, v, w, co-spectrum uw, and (``temp_ok``) S_T, Co_wT, Co_uT, log-binned.

    Rows in the order of :data:`_SPECTRUM_VARS`; the temperature rows NaN without ``temp_ok``.
    """
    f, s_u = spectra.welch_psd(up, fs_hz, **kw)
    _, s_v = spectra.welch_psd(vp, fs_hz, **kw)
    _, s_w = spectra.welch_psd(wp, fs_hz, **kw)
    _, c_uw = spectra.welch_cpsd(up, wp, fs_hz, **kw)
    rows = [s_u, s_v, s_w, c_uw.real]
    if temp_ok and thp is not None:
        rows += [spectra.welch_psd(thp, fs_hz, **kw)[1],
                 spectra.welch_cpsd(wp, thp, fs_hz, **kw)[1].real,
                 spectra.welch_cpsd(up, thp, fs_hz, **kw)[1].real]
    else:
        rows += [np.full_like(s_u, np.nan)] * 3
    return spectra.bin_log(f, np.vstack(rows), n_bins=n_bins)


def _spectrum_vars(b: _Builder, binned: spectra.BinnedSpectrum | None, height_m: float, speed: float,
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The binned spectra, estimate counts, reduced frequency (Eq. 8) and frequency on ``frequency``.

    Returns
    -------
    fb : numpy.ndarray
        Bin frequencies [Hz] (empty without spectra).
    vals : numpy.ndarray
        (7, n) binned spectra (:data:`_SPECTRUM_VARS`).
    fr : numpy.ndarray
        Reduced frequency f z / U [1] (NaN for a zero or undefined speed).
    """
    dims = ("frequency",)
    fb = binned.f_hz if binned is not None else np.empty(0)
    vals = binned.values if binned is not None else np.empty((7, 0))
    for (name, units, ln), row in zip(_SPECTRUM_VARS, vals, strict=True):
        extra = {"units_metadata": "temperature: difference"} if units.startswith("K") else {}
        b.data_vars[name] = variable(dims, np.asarray(row, dtype=float), units, long_name=ln, **extra)
    b.data_vars["n_estimates"] = variable(
        dims, binned.counts.astype(np.int32) if binned is not None else np.empty(0, np.int32), "1",
        long_name="raw Welch estimates averaged in the bin")
    if np.isfinite(speed) and speed > 0:
        fr = fb * height_m / speed
    else:
        fr = np.full_like(fb, np.nan)
    b.data_vars["f_r"] = variable(dims, fr, "1", long_name="reduced frequency f z / U (Ghirardelli et al. 2025, Eq. 8)")
    b.data_vars["frequency"] = xr.Variable(
        dims, fb, variable_attrs("Hz", long_name="mean frequency of the logarithmic bin"),
        encoding={"_FillValue": None})  # CF: no fill value on coordinates
    return fb, vals, fr


def _fit_part(b: _Builder, fb: np.ndarray, vals: np.ndarray, fr: np.ndarray, dof: np.ndarray | None,
              height_m: float, speed: float, ustar: float, flag: str, reason: str,
              f_max_hz: float | None = None) -> None:
    """Fits of the spectral models, Ghirardelli et al. 2025, Eqs 4-7, within the filter passband (``f_max_hz``), and the
    fitted curves."""
    for comp, row in zip(("u", "v", "w", "uw"), vals[:4], strict=True):
        model, eq = _FITS[comp]
        if flag != "ok":
            fit = spectra.SpectralFit(np.nan, np.nan, False, np.nan, 0, model, reason)
            fstat, freason = flag, reason
        else:
            start = spectra.MODEL_START[comp]
            fit = spectra.fit_spectral_model(fb, row, height_m, speed, ustar, model, start=start,
                                             bin_dof=dof, f_max_hz=f_max_hz)
            fstat, freason = _status_of(fit.converged, "fit_not_converged", fit.reason)
        b.scalar(f"fit_a_{comp}", fit.a, "1",
                 f"coefficient a_{comp} of the {model} model ({eq})")
        b.scalar(f"fit_b_{comp}", fit.b, "1",
                 f"coefficient b_{comp} of the {model} model ({eq})")
        b.scalar(f"fit_rms_{comp}", fit.rms_residual, "1", f"RMS residual of the {model} fit")
        b.status(f"status_fit_{comp}", f"{model} model fit of {comp} ({eq})", fstat, freason)
        key = "Co_uw_model" if comp == "uw" else f"S_{comp}_model"
        if fit.converged:
            mfunc = {"blunt": spectra.blunt_model, "pointed": spectra.pointed_model,
                     "cospectrum": spectra.cospectrum_model}[model]
            curve = mfunc(fr, fit.a, fit.b) * ustar**2 / fb
        else:
            curve = np.full_like(fb, np.nan)
        b.data_vars[key] = variable(("frequency",), curve, "m2 s-2 Hz-1",
                                    long_name=f"fitted {model} model for {comp} ({eq})")


def _ratio_part(b: _Builder, fb: np.ndarray, vals: np.ndarray, height_m: float, speed: float, flag: str,
                reason: str, fr_band: tuple[float, float], min_speed: float) -> None:
    """Spectral ratios <S_w/S_u> and <S_v/S_u> for the quadrant analysis (Ghirardelli et al. (2025), Sect. 4.1)."""
    for name, row in (("Sw_Su", vals[2]), ("Sv_Su", vals[1])):
        if flag != "ok":
            val, qflag, qreason, nb, flo, fhi = np.nan, flag, reason, 0, np.nan, np.nan
        else:
            r = spectra.spectral_ratio(fb, row, vals[0], height_m, speed, fr_band[0], fr_band[1], min_speed)
            val, nb, flo, fhi = r.value, r.n_bins, r.f_min_hz, r.f_max_hz
            if np.isfinite(r.value):
                qflag, qreason = "ok", r.reason
            elif "mean speed" in r.reason:
                qflag, qreason = "low_wind_speed", r.reason
            else:
                qflag, qreason = "band_not_resolved", r.reason
        comp = name[1]
        b.scalar(name, val, "1", f"<S_{comp}/S_u> averaged over {fr_band[0]} < f_r < {fr_band[1]} "
                 "(Ghirardelli et al. 2025, Sect. 4.1)",
                 n_bins=np.int32(nb), f_min_hz=np.float64(flo), f_max_hz=np.float64(fhi), reason=qreason)
        b.status(f"status_{name}", f"spectral ratio {name}", qflag, qreason)


def _scale_part(b: _Builder, u: np.ndarray, v: np.ndarray, w: np.ndarray, fs_hz: float, speed: float, su: float,
                vel_flag: str, vel_reason: str, method: stats.Detrend = "linear") -> None:
    """Integral time and length scales (Ghirardelli et al. (2025), Eqs 14-17)."""
    for comp, x in zip("uvw", (u, v, w), strict=True):
        if vel_flag != "ok":
            t_s, l_m = np.nan, np.nan
            tflag, treason, lflag, lreason = vel_flag, vel_reason, vel_flag, vel_reason
        else:
            # raw series (detrended inside): the zero-variance test is relative to |x|
            its = scales.integral_time_scale(x, fs_hz, method=method)
            t_s = its.time_scale_s
            tflag, treason = _status_of(its.converged, "fit_not_converged", its.reason)
            ls = scales.integral_length_scale(t_s, speed, su)
            l_m = ls.length_scale_m
            if ls.valid:
                lflag, lreason = "ok", ""
            elif not its.converged:
                lflag, lreason = tflag, treason
            else:
                lflag, lreason = "taylor_hypothesis_invalid", ls.reason
        extra = {"comment": EXPONENTIAL_FIT_BIAS_U} if comp == "u" else {}
        b.scalar(f"T_{comp}_s", t_s, "s", f"integral time scale of {comp} (exponential fit, Eqs 14-15)", **extra)
        b.scalar(f"L_{comp}_m", l_m, "m", f"integral length scale of {comp} (Taylor, Eqs 16-17)", **extra)
        b.status(f"status_T_{comp}", f"integral time scale of {comp}", tflag, treason)
        b.status(f"status_L_{comp}", f"integral length scale of {comp}", lflag, lreason)


def _product(x: np.ndarray | None, y: np.ndarray | None) -> np.ndarray:
    """Product series x'y' of two fluctuation series (both present by the caller's status check)."""
    assert x is not None and y is not None
    return x * y


def _uncertainty_part(b: _Builder, up: np.ndarray | None, vp: np.ndarray | None, wp: np.ndarray | None,
                      thp: np.ndarray | None, fs_hz: float, height_m: float, duration_s: float,
                      speed: float, ustar: float, su: float, sv: float, sw: float, wt: float,
                      vel_flag: str, vel_reason: str, temp_ok: bool, temp_flag: str, temp_reason: str) -> None:
    """Uncertainty metrics, Ghirardelli et al. (2025), Eqs 10-13, and the integral-time-scale form."""
    items = [  # name, needs temperature, phi builder, normaliser, variance?, equation
        ("sigma_u2", False, lambda: _product(up, up), lambda: su**2, True, "Eq. 13"),
        ("sigma_v2", False, lambda: _product(vp, vp), lambda: sv**2, True, "Eq. 13"),
        ("sigma_w2", False, lambda: _product(wp, wp), lambda: sw**2, True, "Eq. 13"),
        ("uw", False, lambda: _product(up, wp), lambda: ustar**2, False, "Eq. 10"),
        ("vw", False, lambda: _product(vp, wp), lambda: ustar**2, False, "Eq. 11"),
        ("wT", True, lambda: _product(wp, thp), lambda: wt, False, "Eq. 12"),
    ]
    for name, needs_t, phi_f, norm_f, is_var, eq in items:
        ok = temp_ok if needs_t else vel_flag == "ok"
        if not ok:
            fl, rs = (temp_flag, temp_reason) if needs_t else (vel_flag, vel_reason)
            a = eps = uncertainty.RandomError(np.nan, False, np.nan, rs)
            aflag = eflag = fl
            areason = ereason = rs
        else:
            phi, norm = phi_f(), norm_f()
            a = uncertainty.paper_uncertainty(phi, height_m, duration_s, speed, norm, variance=is_var)
            its = scales.integral_time_scale(phi, fs_hz, method="constant")
            if its.converged:
                eps = uncertainty.relative_random_error(phi, duration_s, its.time_scale_s, normaliser=norm)
            else:
                eps = uncertainty.RandomError(np.nan, False, np.nan, f"product-series time scale: {its.reason}")
            aflag, areason = _unc_status(a)
            eflag, ereason = _unc_status(eps)
        b.scalar(f"a_{name}", a.value, "1",
                 f"normalised random uncertainty of {name} (Ghirardelli et al. 2025, {eq}, time scale z/U)")
        b.status(f"status_a_{name}", f"uncertainty a_{name}", aflag, areason)
        b.scalar(f"eps_{name}", eps.value, "1",
                 f"relative random error of {name} from the measured integral time scale of its product series "
                 "(Lumley and Panofsky 1964)", time_scale_s=np.float64(eps.time_scale_s))
        b.status(f"status_eps_{name}", f"uncertainty eps_{name}", eflag, ereason)


def _unc_status(r: uncertainty.RandomError) -> tuple[str, str]:
    if not np.isfinite(r.value):
        return "undefined", r.reason
    if not r.below_threshold:
        return "above_uncertainty_threshold", f"{r.value:.3g} >= {uncertainty.QUALITY_THRESHOLD}"
    return "ok", ""


def flight_l4(l3: xr.Dataset, sensor: str, **options: Any) -> xr.Dataset:
    r"""L4 analysis of one sensor of an L3 flight dataset.

    Parameters
    ----------
    l3 : xarray.Dataset
        L3 layout of ``briefs/interfaces.md``: ``u_ms``, ``v_ms``, ``w_ms``,
        ``theta_v_k`` over (``sensor``, ``time``) in streamline coordinates (means kept),
        ``height_m(sensor)``, ``wind_from_deg(sensor)``, attr ``sampling_rate_hz``.
    sensor : str
        ``"drone"`` or ``"mast"`` (any value of the ``sensor`` coordinate).
    **options
        Passed to :func:`record_l4` (Welch settings, minimum lengths, ratio band).

    Returns
    -------
    xarray.Dataset
        Scalars, binned spectra on ``frequency``, fits, scales, uncertainties and
        ``status_*`` flags (see :func:`record_l4`); ``attrs["sensor"]`` names the sensor,
        and the L3 attributes ``lag_drone_mast_s``, ``rotation_method`` are carried over
        when present.

    Raises
    ------
    InputError
        If a required variable, the ``sensor`` coordinate value or the sampling rate is
        missing, or the height is not positive (a broken L3 contract, not bad data).
    """
    for name in (*_L3_VARS, "height_m"):
        if name not in l3:
            raise InputError(f"L3 dataset variable {name!r}", "missing (see briefs/interfaces.md, L3 per flight)")
    if "sensor" not in l3.coords and "sensor" not in l3.dims:
        raise InputError("L3 dataset dimension 'sensor'", "missing")
    sensors = [str(s) for s in l3["sensor"].values] if "sensor" in l3.coords else []
    if sensor not in sensors:
        raise InputError(f"L3 dataset sensor {sensor!r}", f"not in sensor coordinate {sensors}")
    fs = l3.attrs.get("sampling_rate_hz")
    if fs is None:
        raise InputError("L3 dataset attribute 'sampling_rate_hz'", "missing")
    sel = l3.sel(sensor=sensor)
    wind_from = float(sel["wind_from_deg"]) if "wind_from_deg" in sel else np.nan
    if "fir_passband_edge_hz" in l3.attrs:
        options.setdefault("fit_f_max_hz", float(l3.attrs["fir_passband_edge_hz"]))
    out = record_l4(
        sel["u_ms"].values, sel["v_ms"].values, sel["w_ms"].values, sel["theta_v_k"].values,
        float(fs), float(sel["height_m"]), wind_from, **options,
    )
    out.attrs["sensor"] = sensor
    if "time" in sel.dims and sel.sizes["time"] > 0:
        out.attrs["time_coverage_start"] = str(np.datetime_as_string(sel["time"].values[0], unit="ms"))
        out.attrs["time_coverage_end"] = str(np.datetime_as_string(sel["time"].values[-1], unit="ms"))
    for key in ("lag_drone_mast_s", "rotation_method"):
        if key in l3.attrs:
            out.attrs[key] = l3.attrs[key]
    return out
