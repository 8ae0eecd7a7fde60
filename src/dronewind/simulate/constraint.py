"""The mast constraint of the simulated field: a measured record reproduced at its point.

:func:`constraint_from_record` turns a mast sonic record into the Fourier coefficients of
its u, v, w and temperature fluctuations in the wind frame; the synthesis
(:func:`dronewind.simulate.atmosphere.field_coefficients`) solves the latents of the
record's point for them (Rinker 2018, Eq. 6), so the field reproduces the record there and
is conditioned on it elsewhere.

Measured amplitudes (``amplitudes="constraint"``): the record's periodogram, divided by the
model spectrum at its point and averaged over log-frequency bins, replaces the model's
spectral level at every point (times the model's height ratio
S_model(z_point, f)/S_model(z_record, f), Kaimal et al. 1972), so another spectral shape or
isotropy measured at the record's point carries to the others. With ``spectral_sampling``
the smoothed spectra are drawn again from their sampling distribution given the record
(:func:`spectral_sampling_factors`), so that fields of different seeds differ also by what
the record's spectra got wrong by chance.

References
----------
Kaimal, J. C., Wyngaard, J. C., Izumi, Y. and Coté, O. R. (1972), QJRMS 98, 563-589.
Rinker, J. M. (2018), PyConTurb, J. Phys.: Conf. Ser. 1037, 062032.
"""

from __future__ import annotations

from typing import TypedDict

import numpy as np
import xarray as xr

from dronewind.errors import InputError
from dronewind.simulate.spectral_model import (
    _PointSpectra,
    _scaled_coherency,
    wind_frame_unit_vectors,
)

__all__ = [
    "constraint_from_record",
    "ConstraintLatents",
    "spectral_sampling_factors",
]


# --------------------------------------------------------------------------------------
# Spectral field
# --------------------------------------------------------------------------------------
class ConstraintLatents(TypedDict):
    """Internal form of a measured record constraining the field (see :func:`simulate_wind`).

    Keys: ``point`` (3,) ENU position [m]; ``coefficients`` (4, n_freq - 1) complex Fourier
    coefficients of the record's wind-frame u, v, w, theta fluctuations at the positive
    constrained frequencies (NaN for a missing theta), scaled as :attr:`FieldSpec.coeffs`;
    ``n_freq`` number of constrained frequencies (the zero frequency included);
    ``n_missing`` samples interpolated over gaps; ``offset`` (4,) the record's mean over the
    period minus its mean over the averaging window (east, north, up [m s-1], temperature
    [K]; zeros when the window is the whole period), added to the mean of every point;
    ``noise_power`` the record's white-noise power per coefficient (:func:`_measured_spectra`).
    The latents are solved from the coefficients by :func:`field_coefficients`, with the
    amplitudes it uses at the constraint point.
    """

    point: np.ndarray
    coefficients: np.ndarray
    n_freq: int
    n_missing: int
    offset: np.ndarray
    #: (4,) expected |c|^2 per coefficient of the record's white measurement noise in u, v, w
    #: [m2 s-2] and theta [K2] (variance / samples), removed from its spectra before they
    #: become amplitudes (zeros: none)
    noise_power: np.ndarray


def _constraint_times_s(constraint: xr.Dataset) -> np.ndarray:
    """Sample times [s] of a constraint record, after checking its variables and attributes."""
    where = "simulate_wind.constraint"
    for var in ("u_east_ms", "v_north_ms", "w_up_ms"):
        if var not in constraint:
            raise InputError(where, f"missing variable {var!r} (L1 mast names expected)")
    if "height_m" not in constraint.attrs:
        raise InputError(where, "missing attribute 'height_m'")
    if "time" in constraint.dims and np.issubdtype(constraint["time"].dtype, np.datetime64):
        return np.asarray((constraint["time"].values - constraint["time"].values[0]) / np.timedelta64(1, "s"))
    if "time_s" in constraint.coords:
        return np.asarray(constraint["time_s"].values, float)
    raise InputError(where, "needs a datetime64 'time' or a 'time_s' coordinate")


def _constraint_series(constraint: xr.Dataset, t_s: np.ndarray, period_s: float, wind_from_deg: float,
                       mean_window_s: tuple[float, float] | None = None
                       ) -> tuple[list[np.ndarray | None], int, int, np.ndarray]:
    """Fluctuations of a record over one period on a regular grid, in the wind frame.

    Parameters
    ----------
    constraint : xarray.Dataset
        The record (see :func:`simulate_wind`).
    t_s : numpy.ndarray
        Its sample times [s].
    period_s : float
        Length to use [s].
    wind_from_deg : float
        Mean wind direction of the field [degree].
    mean_window_s : (float, float), optional
        Times [s] (as ``t_s``) between which the means are taken; the whole period by default.

    Returns
    -------
    series : list
        u, v (wind frame), w [m s-1] and theta [K] (None without a temperature) minus
        their means over ``mean_window_s``, gaps interpolated.
    n_grid : int
        Samples in the period.
    n_missing : int
        Samples interpolated.
    offset : numpy.ndarray
        (4,) mean over the period of the ENU wind and temperature fluctuations (east,
        north, up [m s-1], temperature [K]; 0 without a temperature): zero for the default
        window.
    """
    where = "simulate_wind.constraint"
    dt = np.median(np.diff(t_s))
    fs_c = 1.0 / dt
    n_c = int(round(period_s * fs_c))
    if t_s[-1] - t_s[0] + dt < period_s - 1e-6:
        raise InputError(where, f"record of {t_s[-1] - t_s[0] + dt:.1f} s is shorter than the "
                                f"{period_s:.1f} s to simulate")
    grid = t_s[0] + np.arange(n_c) * dt
    window = np.ones(n_c, bool) if mean_window_s is None else (grid >= mean_window_s[0]) & (grid <= mean_window_s[1])
    if not window.any():
        raise InputError(where, f"averaging window {mean_window_s} s holds no sample of the record")
    e_u, e_v = wind_frame_unit_vectors(wind_from_deg)
    temperature = "t_sonic_k" if "t_sonic_k" in constraint else ("theta_v_k" if "theta_v_k" in constraint else None)
    chans: list[np.ndarray | None] = []
    n_bad = 0
    for var in ("u_east_ms", "v_north_ms", "w_up_ms", temperature):
        if var is None:
            chans.append(None)
            continue
        x = np.asarray(constraint[var].values, float)
        good = np.isfinite(x)
        n_bad += int((~good).sum())
        if good.sum() < 0.98 * x.size:
            raise InputError(f"{where}.{var}", f"{(~good).sum()} of {x.size} samples missing (> 2 %)")
        series_c = np.interp(grid, t_s[good], x[good])
        chans.append(series_c - series_c[window].mean())
    ue, vn, wu, th = chans
    assert ue is not None and vn is not None and wu is not None
    offset = np.array([ue.mean(), vn.mean(), wu.mean(), 0.0 if th is None else th.mean()])
    series = [ue * e_u[0] + vn * e_u[1], ue * e_v[0] + vn * e_v[1], wu, th]
    return series, n_c, n_bad, offset


def _constraint_coefficients(series: list[np.ndarray | None], n_grid: int, period_s: float,
                             fs_hz: float) -> np.ndarray:
    """Fourier coefficients (4, n_freq - 1) of a record's series at the positive constrained frequencies.

    Scaled as :attr:`FieldSpec.coeffs` (x = sum 2 Re(c e^{iwt})); the constrained frequencies
    are those below both the record's and the field's Nyquist frequency; NaN for a missing
    temperature.
    """
    n_freq_c = min((n_grid + 1) // 2, int(np.ceil(period_s * fs_hz / 2.0)))
    obs = np.full((4, n_freq_c), np.nan + 0j)
    for i, x in enumerate(series):
        if x is not None:
            obs[i] = np.fft.rfft(x)[:n_freq_c] / n_grid
    return obs[:, 1:]


def _constraint_latents(coefficients: np.ndarray, point_enu_m: np.ndarray, fpos_hz: np.ndarray,
                        advection_speed_ms: float, e_u: np.ndarray, amplitude: np.ndarray,
                        rho_uw: np.ndarray, rho_wt: np.ndarray) -> list[np.ndarray]:
    """Latents (w, u, theta, v) of a record from its Fourier coefficients and the amplitudes at its point.

    The observed coefficients, freed of the record point's Taylor delay, are divided by the
    amplitudes the field uses at that point (model or measured, :func:`field_coefficients`)
    and the u-w and w-theta coherencies are removed (Rinker 2018, Eq. 6), so that
    :func:`field_coefficients` reproduces the record.

    Parameters
    ----------
    coefficients : numpy.ndarray
        (4, n_c) from :func:`_constraint_coefficients`.
    point_enu_m : numpy.ndarray
        (3,) the record's position [m].
    fpos_hz : numpy.ndarray
        The field's positive frequencies [Hz] (at least n_c).
    advection_speed_ms : float
        Taylor advection speed [m s-1].
    e_u : numpy.ndarray
        Streamwise unit vector (east, north).
    amplitude : numpy.ndarray
        (4, nf) amplitudes of u, v, w, theta at the record's point.
    rho_uw, rho_wt : numpy.ndarray
        (nf,) coherencies at the record's point.

    Returns
    -------
    list of numpy.ndarray
        (w, u, theta, v), each (n_c,) (NaN for a missing temperature).
    """
    n_c = coefficients.shape[1]
    f = fpos_hz[:n_c]
    delay = float(point_enu_m[:2] @ e_u) / advection_speed_ms
    o = coefficients * np.exp(2j * np.pi * f * delay)[None, :]  # the delay is re-applied to all points
    a_u, a_v, a_w, a_t = (amplitude[i, :n_c] for i in range(4))
    r_uw, r_wt = rho_uw[:n_c], rho_wt[:n_c]
    x_w = o[2] / a_w
    x_u = (o[0] / a_u - r_uw * x_w) / np.sqrt(1 - r_uw**2)
    x_t = (o[3] / a_t - r_wt * x_w) / np.sqrt(1 - r_wt**2)
    x_v = o[1] / a_v
    return [x_w, x_u, x_t, x_v]


#: Log-frequency bins per decade of the measured spectra (:func:`_measured_spectra`).
MEASURED_BINS_PER_DECADE = 10


def _log_bins(freq_hz: np.ndarray, bins_per_decade: int) -> tuple[np.ndarray, np.ndarray]:
    """Log-frequency bin of every frequency (0, 1, ... from the lowest) and the number of frequencies per bin."""
    idx = np.floor(np.log10(freq_hz) * bins_per_decade).astype(np.int64)
    _, inverse, counts = np.unique(idx, return_inverse=True, return_counts=True)
    return inverse, counts


def _log_binned_mean(values: np.ndarray, freq_hz: np.ndarray, bins_per_decade: int) -> np.ndarray:
    """Mean of ``values`` over log-frequency bins, given to every frequency of its bin."""
    inverse, counts = _log_bins(freq_hz, bins_per_decade)
    return (np.bincount(inverse, weights=values) / counts)[inverse]


def spectral_sampling_factors(counts: np.ndarray, rng: np.random.Generator, n_components: int = 4) -> np.ndarray:
    r"""Random factors on a log-bin-smoothed periodogram: its sampling error, drawn again.

    A bin of a smoothed spectrum is the mean of ``n`` periodogram ordinates of one record, so
    it is that record's estimate of the spectrum, in error by a chi-square variate with 2n
    degrees of freedom over 2n (Bendat and Piersol 2010, Sect. 8.5.4). The field of a
    measured atmosphere (:func:`field_coefficients` with a constraint and
    ``amplitudes="constraint"``) gives the hover point a remainder drawn with the smoothed
    spectrum; across seeds that remainder scatters as a sensor sampling the smoothed
    spectrum, not as one sampling the true spectrum of which the record's is one estimate.
    The factors multiply each bin's level by a Gamma variate of mean 1 and variance

    .. math:: v(n) = \frac{n - 1}{n^2},

    the variance that a bootstrap resample of the bin's n ordinates gives its mean, relative
    to its square, in expectation for chi-square ordinates (Efron and Tibshirani 1993,
    Sect. 5.2: the plug-in variance (n - 1)/n of an ordinate, over n). A bin of one ordinate
    (the lowest frequencies) holds the record's own coefficient, which already carries its
    sampling error into the remainder's amplitude: v(1) = 0. For many ordinates
    v(n) -> 1/n, the chi-square sampling variance of the bin, which a log band power of the
    drone minus the mast's needs; for a power summed over bins (a variance) the variance
    given the record, :math:`\hat S^2 n (1 + v (n + 1))` per bin with
    :math:`E[\hat S^2] = S^2 (1 + 1/n)`, then exceeds the :math:`2 n S^2` of two independent
    records by at most 31 % in a bin (n = 2), 9 % at n = 10. Measured on the full chain
    (``benchmarks/results/measured_atmosphere_scatter.json``: 100 virtual 12-min flights, 4
    seeds each; 95 % interval of the ratio under a right scatter 0.73-1.40), the seed
    variance (times 1 + 1/K) over the variance of measured minus predicted, without these
    factors and with them: ln sigma ratio u 0.95 and 1.00, v 0.72 and 0.83, w 0.81 and 1.00;
    drone S_w/S_u 0.77 and 1.10; pendulum-band w power 0.75 and 1.05; high-frequency u 0.79
    and 1.12, w 1.01 and 1.42. The mean-wind features (speed ratio 0.79, tilt difference
    0.59), made of the lowest frequencies, do not change.

    Parameters
    ----------
    counts : numpy.ndarray
        Number of periodogram ordinates in each bin (:func:`_log_bins`).
    rng : numpy.random.Generator
        Random generator (one draw per component and bin, in that order, whatever the counts).
    n_components : int
        Number of spectra (u, v, w, theta), each with its own draws.

    Returns
    -------
    numpy.ndarray
        (n_components, n_bins) positive factors, mean 1 (exactly 1 for a bin of one ordinate).

    References
    ----------
    Bendat, J. S. and Piersol, A. G. (2010), Random Data, 4th ed., Wiley, Sect. 8.5.4.
    Efron, B. and Tibshirani, R. J. (1993), An Introduction to the Bootstrap, Chapman & Hall.
    """
    n = np.asarray(counts, float)
    var = (n - 1.0) / n**2
    shape = np.where(var > 0, 1.0 / np.maximum(var, 1e-300), 1.0)
    draws = rng.standard_gamma(np.broadcast_to(shape, (n_components, n.size)))
    return np.where(var > 0, draws * var, 1.0)


def _measured_spectra(spectra: _PointSpectra, coefficients: np.ndarray, fpos_hz: np.ndarray, df_hz: float,
                      noise_power: np.ndarray | None = None,
                      bins_per_decade: int = MEASURED_BINS_PER_DECADE,
                      sampling: np.random.Generator | None = None) -> _PointSpectra:
    """The points' spectra with the amplitudes of a measured record (the constraint, point 0).

    Parameters
    ----------
    spectra : _PointSpectra
        Model spectra of the points (point 0 at the record's position).
    coefficients : numpy.ndarray
        (4, n_c) Fourier coefficients of the record (u, v, w, theta; NaN theta when missing).
    fpos_hz : numpy.ndarray
        Positive frequencies [Hz].
    df_hz : float
        Frequency step [Hz].
    noise_power : numpy.ndarray, optional
        (4,) expected |c|^2 of the record's white measurement noise per coefficient
        (variance / samples), removed from the periodogram (at most 90 % of it); none by
        default.
    bins_per_decade : int
        Log-frequency bins per decade of the smoothing.
    sampling : numpy.random.Generator, optional
        Draw the smoothed spectra again from their sampling distribution given the record
        (each bin times :func:`spectral_sampling_factors`, the same factor at every point);
        the smoothed spectra themselves by default.

    Returns
    -------
    _PointSpectra
        Amplitudes :math:`A_i(z_p, f) = A_i^{model}(z_p, f)\\sqrt{R_i(f)}`, coherencies
        rescaled to the same fluxes with these spectra.

    Notes
    -----
    The record's periodogram is divided by the model spectrum at its point (prewhitened)
    and averaged over log-frequency bins:
    :math:`R_i(f) = \\langle |c_i(f_k)|^2 / A_i^{model}(z_c, f_k)^2\\rangle_{bin}`, so that
    :math:`S_i(z_p, f) = \\hat S_i^{meas}(z_c, f)\\, S_i^{model}(z_p, f) / S_i^{model}(z_c, f)`:
    the measured spectral level, shape and isotropy at the record's height, carried to the
    other heights by the model's height dependence (Kaimal et al. 1972). Above the record's
    Nyquist frequency R holds its mean over the top bin (the measured inertial-subrange
    level). Without a temperature R_theta = 1. The lowest bins hold one coefficient each:
    there the amplitudes are the record's own. The record's own white measurement noise is
    not atmosphere: its expected power is subtracted from the periodogram first (in weak
    turbulence it would otherwise be carried to the other points as high-frequency
    turbulence), keeping at least 10 % of each coefficient's power.

    References
    ----------
    Kaimal et al. (1972); Rinker (2018).
    """
    n_c = coefficients.shape[1]
    f_c = fpos_hz[:n_c]
    top = f_c >= f_c[-1] * 10 ** (-1.0 / bins_per_decade)
    inverse, counts = _log_bins(f_c, bins_per_decade)
    # drawn for every component whether the record has it or not, so that a seed's factors
    # depend on the frequencies only (the probes of a seed share them: common random numbers)
    factors = np.ones((4, counts.size)) if sampling is None else spectral_sampling_factors(counts, sampling)
    amp = spectra.amplitude.copy()
    for i in range(4):
        if not np.all(np.isfinite(coefficients[i])):
            continue
        power = np.abs(coefficients[i]) ** 2
        if noise_power is not None:
            power = np.maximum(power - float(noise_power[i]), 0.1 * power)
        ratio = power / np.maximum(spectra.amplitude[0, i, :n_c] ** 2, 1e-300)
        r = np.full(fpos_hz.size, float(np.mean(ratio[top])) * factors[i, -1])
        r[:n_c] = _log_binned_mean(ratio, f_c, bins_per_decade) * factors[i, inverse]
        amp[:, i] *= np.sqrt(r)[None, :]
    rho_uw = np.empty_like(spectra.rho_uw)
    rho_wt = np.empty_like(spectra.rho_wt)
    for p in range(amp.shape[0]):
        s_u, s_w, s_t = (2 * amp[p, i] ** 2 / df_hz for i in (0, 2, 3))
        sig = spectra.diagnostics["sigmas"][p]
        rho_uw[p] = _scaled_coherency(spectra.co_shape[p], s_u, s_w, df_hz, sig["uw_m2s2"])
        rho_wt[p] = _scaled_coherency(spectra.co_shape[p], s_w, s_t, df_hz, sig["wtheta_kms"])
    return _PointSpectra(amp, rho_uw, rho_wt, spectra.diagnostics, spectra.co_shape)


def constraint_from_record(record: xr.Dataset, period_s: float, fs_hz: float, wind_from_deg: float,
                           mean_window_s: tuple[float, float] | None = None,
                           noise_ms: float = 0.0, temperature_noise_k: float = 0.0) -> ConstraintLatents:
    """The internal constraint of a measured record (the first ``period_s`` of it).

    Parameters
    ----------
    record : xarray.Dataset
        As ``constraint`` of :func:`simulate_wind` (L1 mast names, ``height_m``, optional
        ``x_m, y_m``).
    period_s : float
        Period of the field [s].
    fs_hz : float
        Highest sampling rate of the field [Hz].
    wind_from_deg : float
        Mean wind direction of the field [degree].
    mean_window_s : (float, float), optional
        Seconds from the record's start between which its means are taken (e.g. the hover
        window, so that the field's mean there is the model mean); the whole period by
        default. The record's mean over the period relative to that window becomes the
        ``offset`` of every point's mean.
    noise_ms, temperature_noise_k : float
        Standard deviations of the record's white measurement noise per wind component
        [m s-1] and in temperature [K] (removed from its spectra, :func:`_measured_spectra`).

    Returns
    -------
    ConstraintLatents
    """
    t_s = _constraint_times_s(record)
    series, n_grid, n_missing, offset = _constraint_series(record, t_s, period_s, wind_from_deg,
                                                           None if mean_window_s is None else
                                                           (t_s[0] + mean_window_s[0], t_s[0] + mean_window_s[1]))
    point = np.array([float(record.attrs.get("x_m", 0.0)), float(record.attrs.get("y_m", 0.0)),
                      float(record.attrs["height_m"])])
    coefficients = _constraint_coefficients(series, n_grid, period_s, fs_hz)
    noise = np.array([noise_ms**2, noise_ms**2, noise_ms**2, temperature_noise_k**2], float) / n_grid
    return ConstraintLatents(point=point, coefficients=coefficients, n_freq=coefficients.shape[1] + 1,
                             n_missing=n_missing, offset=offset, noise_power=noise)
