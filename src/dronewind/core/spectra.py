r"""Spectra, co-spectra, spectral model fits and the quadrant analysis (Ghirardelli et al. (2025), Sect. 4.1, 4.4).

* Welch auto- and cross-spectral densities of linearly detrended series, three segments
  with 50 % overlap (Ghirardelli et al. (2025), Sect. 4.4), one-sided, in unit² Hz-1.
* Bin-averaging over 100 logarithmically spaced frequency bins (Kaimal and Finnigan 1994).
* Least-squares fits of the blunt (Eqs 4-5), pointed (Eq. 6) and co-spectral (Eq. 7)
  models in reduced frequency :math:`f_r = f z/\bar u` (Eq. 8).
* Frequency-averaged spectral ratios :math:`\langle S_w/S_u\rangle`,
  :math:`\langle S_v/S_u\rangle` over :math:`2 < f_r < 10` and the quadrant of Fig. 6.

The paper does not name its window. We use a Hamming window by default (the MATLAB
``pwelch`` default the authors' toolchain most likely used; any standard window is
allowed through ``window``).

References
----------
.. [1] Ghirardelli et al. (2025), Eqs 4-8, Sects. 4.1, 4.4, Figs 6, 9, 11, 15.
.. [2] Welch, P.: IEEE Trans. Audio Electroacoust. 15, 70-73, 1967.
.. [3] Kaimal, J. C., Wyngaard, J. C., Izumi, Y., Cote, O. R.: Q. J. R. Meteorol. Soc. 98,
   563-589, 1972 (starting values of the fits).
.. [4] Olesen, H. R., Larsen, S. E., Hojstrup, J.: Boundary-Layer Meteorol. 29, 285-312, 1984.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.optimize
import scipy.signal
import scipy.special

from dronewind.core.stats import detrend
from dronewind.errors import InputError

__all__ = [
    "ISOTROPIC_RATIO",
    "MODEL_START",
    "BinnedSpectrum",
    "SpectralFit",
    "SpectralRatio",
    "bin_log",
    "binned_dof",
    "blunt_model",
    "cospectrum_model",
    "fit_spectral_model",
    "pointed_model",
    "quadrant",
    "reduced_frequency",
    "segment_length",
    "spectral_ratio",
    "welch_cpsd",
    "welch_dof",
    "welch_psd",
]

#: Local isotropy in the inertial subrange: S_w/S_u = S_v/S_u = 4/3 (Ghirardelli et al. (2025), Sect. 4.1).
ISOTROPIC_RATIO: float = 4.0 / 3.0

ModelName = Literal["blunt", "pointed", "cospectrum"]

#: Starting values (a, b) of the fits: Kaimal et al. (1972) surface-layer spectra
#: (u: 102, 33; v: 17, 9.5; w: 2.1, 5.3; uw: -12, 9.6 with the 7/3 exponent of Eq. 7).
MODEL_START: dict[str, tuple[float, float]] = {
    "u": (102.0, 33.0),
    "v": (17.0, 9.5),
    "w": (2.1, 5.3),
    "uw": (-12.0, 9.6),
}


def segment_length(n_samples: int, n_segments: int = 3, overlap: float = 0.5) -> int:
    r"""Welch segment length that splits a record into ``n_segments`` overlapping segments.

    Parameters
    ----------
    n_samples : int
        Record length [samples].
    n_segments : int, optional
        Number of segments (3 in Ghirardelli et al. (2025), Sect. 4.4).
    overlap : float, optional
        Fractional overlap in [0, 1) (0.5 in the paper).

    Returns
    -------
    int
        Segment length [samples]:
        :math:`\lfloor N / (1 + (K - 1)(1 - o)) \rfloor` (N/2 for K = 3, o = 0.5).
    """
    if n_segments < 1 or not 0 <= overlap < 1:
        raise InputError("segment_length", f"need n_segments >= 1 and 0 <= overlap < 1, got {n_segments}, {overlap}")
    return int(np.floor(n_samples / (1.0 + (n_segments - 1) * (1.0 - overlap))))


def welch_dof(nperseg: int, n_segments: int = 3, overlap: float = 0.5, window: str = "hamming") -> float:
    r"""Equivalent degrees of freedom of one raw Welch estimate.

    Parameters
    ----------
    nperseg : int
        Segment length [samples].
    n_segments : int, optional
        Number of segments.
    overlap : float, optional
        Fractional overlap.
    window : str, optional
        Window name.

    Returns
    -------
    float
        :math:`\nu` [1] (about 5.6 for 3 Hamming segments with 50 % overlap).

    Notes
    -----
    Percival and Walden (1993), Eq. 292b:

    .. math:: \nu = \frac{2K}{1 + 2\sum_{m=1}^{K-1}(1 - m/K)\,\rho^2(m)},\quad
              \rho(m) = \frac{\sum_t w_t w_{t+mD}}{\sum_t w_t^2}

    with K segments shifted by D samples.
    """
    w = scipy.signal.get_window(window, nperseg)
    step = nperseg - int(round(nperseg * overlap))
    total = 0.0
    for m in range(1, n_segments):
        lag = m * step
        if lag < nperseg:
            rho = float(np.sum(w[: nperseg - lag] * w[lag:]) / np.sum(w * w))
            total += (1.0 - m / n_segments) * rho**2
    return 2.0 * n_segments / (1.0 + 2.0 * total)


def binned_dof(
    counts: np.ndarray, nperseg: int, n_segments: int = 3, overlap: float = 0.5, window: str = "hamming"
) -> np.ndarray:
    r"""Equivalent degrees of freedom of log-binned Welch estimates.

    Parameters
    ----------
    counts : array-like of int
        Raw estimates averaged per bin (:attr:`BinnedSpectrum.counts`).
    nperseg : int
        Welch segment length [samples].
    n_segments, overlap, window
        Welch settings (see :func:`welch_dof`).

    Returns
    -------
    numpy.ndarray
        :math:`\nu_\mathrm{bin}` [1] per bin.

    Notes
    -----
    Adjacent raw estimates of a windowed periodogram are correlated (Hamming:
    :math:`r_1 = 0.63`, :math:`r_2 = 0.13`), so c of them are worth

    .. math:: c_\mathrm{eff} = \frac{c}{1 + 2\sum_{k=1}^{c-1}(1 - k/c)\,r_k^2},\quad
              r_k = \frac{|\sum_t w_t^2 e^{-2\pi i k t/M}|}{\sum_t w_t^2}

    independent ones, and :math:`\nu_\mathrm{bin} = \nu\,c_\mathrm{eff}`
    (Percival and Walden 1993, Sect. 6.17, with the overlap ν of :func:`welch_dof`).
    """
    w2 = scipy.signal.get_window(window, nperseg) ** 2
    t = np.arange(nperseg)
    n_max = int(np.max(counts)) if np.size(counts) else 1
    k_max = min(n_max, 8)  # r_k is ~0 beyond a few bins for standard windows
    r2 = np.zeros(n_max)
    for k in range(1, k_max):
        r2[k] = (np.abs(np.sum(w2 * np.exp(-2j * np.pi * k * t / nperseg))) / np.sum(w2)) ** 2
    nu = welch_dof(nperseg, n_segments, overlap, window)
    out = np.empty(np.size(counts))
    for i, c in enumerate(np.asarray(counts, dtype=int).ravel()):
        lags = np.arange(1, c)
        out[i] = nu * c / (1.0 + 2.0 * np.sum((1.0 - lags / c) * r2[lags]))
    return out


@functools.lru_cache(maxsize=16)
def _stft_design(nperseg: int, noverlap: int, fs_hz: float, window: str) -> scipy.signal.ShortTimeFFT:
    """The short-time Fourier transform ``scipy.signal.csd`` designs for these settings, made once.

    ``csd`` designs it anew at every call: the window and its PSD scale (a Python ``sum``
    over the window's samples). The design depends on the settings only, and the transform
    keeps no state between calls but such derived constants, so designing it once per
    setting halves the cost of a forward run's spectra.
    """
    win = scipy.signal.get_window(window, nperseg)
    return scipy.signal.ShortTimeFFT(win, nperseg - noverlap, fs_hz, fft_mode="onesided", mfft=nperseg,
                                     scale_to="psd", phase_shift=None)


def _welch_density(x: np.ndarray, y: np.ndarray, fs_hz: float, nperseg: int, noverlap: int, window: str
                   ) -> tuple[np.ndarray, np.ndarray]:
    """``scipy.signal.csd(x, y, ...)`` (``welch`` when ``y is x``) with its transform's design remembered.

    The same steps as scipy's ``csd`` for one-sided densities without detrending, averaged
    by the mean (scipy 1.17): one spectrogram over the segments, the one-sided bins doubled
    (all but the zero and, for an even segment, the Nyquist bin), the segments' mean. The
    result is scipy's bit for bit (``tests/core/test_spectra.py`` checks it against
    ``scipy.signal.welch`` and ``csd``, so a scipy that computes them differently is
    noticed). Real for ``y is x``, complex otherwise.
    """
    sft = _stft_design(int(nperseg), int(noverlap), float(fs_hz), window)
    n = x.shape[-1]
    pxy = sft.spectrogram(y, x, detr=None, p0=0, p1=(n - noverlap) // sft.hop, k_offset=nperseg // 2, axis=-1)
    pxy[..., 1:-1 if sft.mfft % 2 == 0 else None, :] *= 2
    pxy = pxy.mean(axis=-1) if pxy.shape[-1] > 1 else pxy.reshape(pxy.shape[:-1])
    return sft.f, (pxy.real if y is x else pxy)


def _welch_setup(n: int, n_segments: int, overlap: float, min_segment: int, where: str) -> tuple[int, int]:
    nperseg = segment_length(n, n_segments, overlap)
    if nperseg < min_segment:
        raise InputError(
            where,
            f"record of {n} samples too short for {n_segments} segments with {overlap:.0%} overlap "
            f"(segment {nperseg} < {min_segment} samples)",
        )
    return nperseg, int(round(nperseg * overlap))


def welch_psd(
    x: np.ndarray,
    fs_hz: float,
    n_segments: int = 3,
    overlap: float = 0.5,
    window: str = "hamming",
    min_segment: int = 16,
) -> tuple[np.ndarray, np.ndarray]:
    r"""One-sided auto power spectral density by Welch's method (Ghirardelli et al. (2025), Sect. 4.4).

    Parameters
    ----------
    x : array-like
        Evenly sampled, finite 1-D series [unit].
    fs_hz : float
        Sampling rate [Hz].
    n_segments : int, optional
        Number of segments (3).
    overlap : float, optional
        Fractional overlap (0.5).
    window : str, optional
        Window name for ``scipy.signal.get_window`` (default ``"hamming"``).
    min_segment : int, optional
        Smallest acceptable segment [samples]; shorter records raise.

    Returns
    -------
    f_hz : numpy.ndarray
        Frequencies > 0 [Hz] (the zero frequency is dropped).
    psd : numpy.ndarray
        :math:`S_x(f)` [unit² Hz-1]; :math:`\int_0^{f_s/2} S_x\,df \approx \sigma_x^2`.

    Raises
    ------
    InputError
        Non-finite samples, or a record too short for the requested segments.

    Notes
    -----
    The series is linearly detrended once before segmentation (as in the paper); the
    segments are not detrended again. White noise of variance :math:`\sigma^2` has
    :math:`S = 2\sigma^2/f_s` (one-sided). The numbers are ``scipy.signal.welch``'s bit for
    bit, with the transform's design made once per setting (:func:`_welch_density`).
    """
    arr = np.asarray(x, dtype=float)
    if arr.ndim != 1 or not np.all(np.isfinite(arr)):
        raise InputError("welch_psd(x)", "expected a finite 1-D series (fill or flag NaN first)")
    nperseg, noverlap = _welch_setup(arr.size, n_segments, overlap, min_segment, "welch_psd(x)")
    detrended = detrend(arr)
    f, p = _welch_density(detrended, detrended, fs_hz, nperseg, noverlap, window)
    return f[1:], p[1:]


def welch_cpsd(
    x: np.ndarray,
    y: np.ndarray,
    fs_hz: float,
    n_segments: int = 3,
    overlap: float = 0.5,
    window: str = "hamming",
    min_segment: int = 16,
) -> tuple[np.ndarray, np.ndarray]:
    r"""One-sided cross power spectral density by Welch's method (Ghirardelli et al. (2025), Sect. 4.4).

    Parameters
    ----------
    x, y : array-like
        Evenly sampled, finite 1-D series of equal length [units x, y].
    fs_hz : float
        Sampling rate [Hz].
    n_segments, overlap, window, min_segment
        As in :func:`welch_psd`.

    Returns
    -------
    f_hz : numpy.ndarray
        Frequencies > 0 [Hz].
    cpsd : numpy.ndarray of complex
        :math:`S_{xy}(f)` [unit x × unit y Hz-1]. Its real part is the co-spectrum:
        :math:`\int_0^{f_s/2} \mathrm{Re}\,S_{xy}\,df \approx \overline{x'y'}`.
    """
    a = np.asarray(x, dtype=float)
    b = np.asarray(y, dtype=float)
    if a.ndim != 1 or a.shape != b.shape:
        raise InputError("welch_cpsd(x, y)", f"expected two 1-D series of equal length, got {a.shape}, {b.shape}")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise InputError("welch_cpsd(x, y)", "expected finite series (fill or flag NaN first)")
    nperseg, noverlap = _welch_setup(a.size, n_segments, overlap, min_segment, "welch_cpsd(x, y)")
    f, p = _welch_density(detrend(a), detrend(b), fs_hz, nperseg, noverlap, window)
    return f[1:], p[1:]


@dataclass(frozen=True)
class BinnedSpectrum:
    """Spectrum averaged in logarithmically spaced frequency bins.

    Attributes
    ----------
    f_hz : numpy.ndarray
        Mean frequency of the raw estimates in each non-empty bin [Hz].
    values : numpy.ndarray
        Mean spectral value(s) in each bin; shape (..., n_bins) [unit² Hz-1].
    counts : numpy.ndarray
        Raw estimates per bin.
    n_empty_bins : int
        Bins without any raw estimate (dropped; at low frequency the raw resolution is
        coarser than the bins).
    """

    f_hz: np.ndarray
    values: np.ndarray
    counts: np.ndarray
    n_empty_bins: int


def bin_log(f_hz: np.ndarray, spectra: np.ndarray, n_bins: int = 100) -> BinnedSpectrum:
    r"""Bin-average spectra over logarithmically spaced frequency bins.

    Parameters
    ----------
    f_hz : array-like
        Frequencies > 0 [Hz], increasing.
    spectra : array-like
        Values on ``f_hz`` along the last axis (real or complex) [any unit].
    n_bins : int, optional
        Number of bins between the lowest and highest frequency (100 in Ghirardelli et al. (2025),
        Sect. 4.4).

    Returns
    -------
    BinnedSpectrum
        Non-empty bins only, with counts and the number of empty bins dropped.
    """
    f = np.asarray(f_hz, dtype=float)
    s = np.asarray(spectra)
    if f.ndim != 1 or f.size < 2 or np.any(f <= 0) or np.any(np.diff(f) <= 0):
        raise InputError("bin_log(f_hz)", "expected >= 2 positive, increasing frequencies")
    if s.shape[-1] != f.size:
        raise InputError("bin_log(spectra)", f"last axis {s.shape[-1]} != {f.size} frequencies")
    edges = np.logspace(np.log10(f[0]), np.log10(f[-1]), n_bins + 1)
    idx = np.clip(np.searchsorted(edges, f, side="right") - 1, 0, n_bins - 1)
    counts = np.bincount(idx, minlength=n_bins)
    keep = counts > 0
    f_mean = np.bincount(idx, weights=f, minlength=n_bins)[keep] / counts[keep]
    flat = s.reshape(-1, f.size)
    out = np.empty((flat.shape[0], int(keep.sum())), dtype=flat.dtype)
    for row in range(flat.shape[0]):
        if np.iscomplexobj(flat):
            re = np.bincount(idx, weights=flat[row].real, minlength=n_bins)
            im = np.bincount(idx, weights=flat[row].imag, minlength=n_bins)
            out[row] = (re + 1j * im)[keep] / counts[keep]
        else:
            out[row] = np.bincount(idx, weights=flat[row], minlength=n_bins)[keep] / counts[keep]
    values = out.reshape(s.shape[:-1] + (int(keep.sum()),))
    return BinnedSpectrum(f_mean, values, counts[keep], int((~keep).sum()))


def reduced_frequency(f_hz: np.ndarray, height_m: float, speed_ms: float) -> np.ndarray:
    r"""Reduced frequency :math:`f_r = f z/\bar u` (Ghirardelli et al. (2025), Eq. 8).

    Parameters
    ----------
    f_hz : array-like
        Frequency [Hz].
    height_m : float
        Height above the surface [m].
    speed_ms : float
        Mean wind speed [m s-1] (> 0).

    Returns
    -------
    numpy.ndarray
        :math:`f_r` [1].
    """
    if not (np.isfinite(speed_ms) and speed_ms > 0):
        raise InputError("reduced_frequency(speed_ms)", f"expected a positive mean speed, got {speed_ms}")
    return np.asarray(f_hz, dtype=float) * height_m / speed_ms


def blunt_model(f_r: np.ndarray, a: float, b: float) -> np.ndarray:
    r"""Blunt spectral model, Ghirardelli et al. (2025), Eqs 4-5 (u and v).

    Parameters
    ----------
    f_r : array-like
        Reduced frequency [1].
    a, b : float
        Coefficients [1].

    Returns
    -------
    numpy.ndarray
        :math:`f S(f)/u_*^2` [1].

    Notes
    -----
    .. math:: \frac{f S(f)}{u_*^2} = \frac{a f_r}{(1 + b f_r)^{5/3}}
    """
    fr = np.asarray(f_r, dtype=float)
    return a * fr / (1.0 + b * fr) ** (5.0 / 3.0)


def pointed_model(f_r: np.ndarray, a: float, b: float) -> np.ndarray:
    r"""Pointed spectral model, Ghirardelli et al. (2025), Eq. 6 (w).

    Parameters
    ----------
    f_r : array-like
        Reduced frequency [1].
    a, b : float
        Coefficients [1].

    Returns
    -------
    numpy.ndarray
        :math:`f S_w(f)/u_*^2` [1].

    Notes
    -----
    .. math:: \frac{f S_w(f)}{u_*^2} = \frac{a f_r}{1 + b f_r^{5/3}}
    """
    fr = np.asarray(f_r, dtype=float)
    return a * fr / (1.0 + b * fr ** (5.0 / 3.0))


def cospectrum_model(f_r: np.ndarray, a: float, b: float) -> np.ndarray:
    r"""Co-spectral model, Ghirardelli et al. (2025), Eq. 7 (Re S_uw; a < 0 for a downward momentum flux).

    Parameters
    ----------
    f_r : array-like
        Reduced frequency [1].
    a, b : float
        Coefficients [1].

    Returns
    -------
    numpy.ndarray
        :math:`f\,\mathrm{Re}\,S_{uw}(f)/u_*^2` [1].

    Notes
    -----
    .. math:: \frac{f\,\mathrm{Re}\,S_{uw}(f)}{u_*^2} = \frac{a f_r}{(1 + b f_r)^{7/3}}
    """
    fr = np.asarray(f_r, dtype=float)
    return a * fr / (1.0 + b * fr) ** (7.0 / 3.0)


_MODELS = {"blunt": blunt_model, "pointed": pointed_model, "cospectrum": cospectrum_model}


@dataclass(frozen=True)
class SpectralFit:
    """Result of :func:`fit_spectral_model`.

    Attributes
    ----------
    a, b : float
        Fitted coefficients of Eqs 4-7 [1]; NaN when not converged.
    converged : bool
        True if the optimiser reported success and both values are finite with b > 0.
    rms_residual : float
        RMS of the residual (log10 for auto-spectra, linear scaled by the largest
        magnitude for co-spectra) [1].
    n_points : int
        Binned points used.
    model : str
        ``"blunt"``, ``"pointed"`` or ``"cospectrum"``.
    reason : str
        Empty when converged, else why not.
    """

    a: float
    b: float
    converged: bool
    rms_residual: float
    n_points: int
    model: str
    reason: str = ""


def fit_spectral_model(
    f_hz: np.ndarray,
    spectrum: np.ndarray,
    height_m: float,
    speed_ms: float,
    u_star_ms: float,
    model: ModelName,
    start: tuple[float, float] | None = None,
    bin_dof: np.ndarray | None = None,
    f_max_hz: float | None = None,
) -> SpectralFit:
    r"""Least-squares fit of a spectral model of Ghirardelli et al. (2025), Eqs 4-7, in reduced frequency.

    Parameters
    ----------
    f_hz : array-like
        Frequencies [Hz] (usually log-binned, :func:`bin_log`).
    spectrum : array-like
        :math:`S(f)` [m2 s-2 Hz-1] (real; the real part of a cross-spectrum for
        ``"cospectrum"``).
    height_m : float
        Height :math:`z` [m].
    speed_ms : float
        Mean speed :math:`\bar u` [m s-1].
    u_star_ms : float
        Friction velocity [m s-1], for the normalisation :math:`fS/u_*^2`.
    model : {"blunt", "pointed", "cospectrum"}
        Eqs 4-5, Eq. 6, Eq. 7.
    start : (float, float), optional
        Starting (a, b); default from :data:`MODEL_START` (Kaimal et al. 1972).
    bin_dof : array-like, optional
        Degrees of freedom of each binned value (:func:`binned_dof`). Enables the
        log-bias correction below; without it, bins are treated as exact.
    f_max_hz : float, optional
        Highest frequency fitted [Hz]: the anti-alias passband edge (L3
        ``fir_passband_edge_hz``); the filter's roll-off above it biases b high. Default: all.

    Returns
    -------
    SpectralFit
        Coefficients, convergence flag and reason; never raises for data problems.

    Notes
    -----
    Auto-spectra are fitted to :math:`\log_{10}(fS/u_*^2)` so that every decade of the
    log-binned spectrum (including the inertial subrange the -5/3 check is about)
    weighs equally. A binned value with :math:`\nu_b` degrees of freedom is about a
    :math:`\chi^2_{\nu_b}/\nu_b` variable times the true spectrum, its logarithm biased by
    :math:`\psi(\nu_b/2) - \ln(\nu_b/2)` (about -0.19 in ln for single estimates); this bias is added to
    the model, otherwise the peak (hence a, b) comes out 20-35 % low on synthetic
    spectra. The co-spectrum
    changes sign, so it is fitted in linear space, scaled by its largest magnitude.
    ``scipy.optimize.least_squares`` (trust region reflective) with :math:`b > 0`
    (and :math:`a > 0` for auto-spectra).
    """
    if model not in _MODELS:
        raise InputError("fit_spectral_model(model)", f"expected one of {sorted(_MODELS)}, got {model!r}")
    f = np.asarray(f_hz, dtype=float)
    s = np.real(np.asarray(spectrum))
    if f_max_hz is not None:
        keep = f <= f_max_hz
        f, s = f[keep], s[keep]
        bin_dof = None if bin_dof is None else np.asarray(bin_dof)[keep]
    nan_fit = SpectralFit(np.nan, np.nan, False, np.nan, 0, model)
    if not (np.isfinite(speed_ms) and speed_ms > 0 and np.isfinite(u_star_ms) and u_star_ms > 0):
        return _replace_reason(nan_fit, f"needs positive mean speed and u* (got U={speed_ms}, u*={u_star_ms})")
    fr, y, log_bias = _normalised_spectrum(f, s, height_m, speed_ms, u_star_ms, model, bin_dof)
    if fr.size < 4:
        return _replace_reason(nan_fit, f"only {fr.size} usable spectral points (need 4)")
    if start is None:
        key = {"blunt": "u", "pointed": "w", "cospectrum": "uw"}[model]
        start = MODEL_START[key]
    problem = _fit_problem(model, fr, y, log_bias, start)
    if isinstance(problem, str):
        return _replace_reason(nan_fit, problem)
    residual, x0, (lower, upper) = problem
    try:
        res = scipy.optimize.least_squares(residual, x0=x0, bounds=(lower, upper), method="trf", max_nfev=2000)
    except (ValueError, FloatingPointError) as exc:
        return _replace_reason(nan_fit, f"optimiser error: {exc}")
    return _fit_result(res, int(fr.size), model)


def _normalised_spectrum(f: np.ndarray, s: np.ndarray, height_m: float, speed_ms: float, u_star_ms: float,
                         model: ModelName, bin_dof: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Reduced frequency, normalised spectrum :math:`fS/u_*^2` and log bias of the usable points.

    Parameters
    ----------
    f, s : numpy.ndarray
        Frequencies [Hz] and spectrum (real) [m2 s-2 Hz-1].
    height_m, speed_ms, u_star_ms : float
        :math:`z` [m], :math:`ar u` [m s-1] (positive), :math:`u_*` [m s-1] (positive).
    model : {"blunt", "pointed", "cospectrum"}
        Model; auto-spectra keep only positive values (fitted in log space).
    bin_dof : numpy.ndarray, optional
        Degrees of freedom per bin (:func:`binned_dof`).

    Returns
    -------
    fr, y, log_bias : numpy.ndarray
        :math:`f_r` [1], :math:`fS/u_*^2` [1] and :math:`(\psi(
u_b/2) - \ln(
u_b/2))/\ln 10`
        (0 without ``bin_dof``) at the finite (and, for auto-spectra, positive) points.
    """
    fr = f * height_m / speed_ms
    y = f * s / u_star_ms**2
    if bin_dof is not None:
        dof = np.asarray(bin_dof, dtype=float)
        log_bias = (scipy.special.digamma(dof / 2.0) - np.log(dof / 2.0)) / np.log(10.0)
    else:
        log_bias = np.zeros_like(fr)
    if model == "cospectrum":
        ok = np.isfinite(fr) & np.isfinite(y)
    else:
        ok = np.isfinite(fr) & np.isfinite(y) & (y > 0)
    return fr[ok], y[ok], log_bias[ok]


def _fit_problem(model: ModelName, fr: np.ndarray, y: np.ndarray, log_bias: np.ndarray, start: tuple[float, float],
                 ) -> tuple[Callable[[np.ndarray], np.ndarray], list[float], tuple[list[float], list[float]]] | str:
    r"""Residual function, start and bounds of the least-squares fit (or why there is none).

    The co-spectrum is fitted in linear space scaled by its largest magnitude (the sign of
    ``a`` from the sign of the sum), auto-spectra in :math:`\log_{10}` with the log bias.

    Returns
    -------
    (residual, x0, (lower, upper)) or str
        The problem, or the reason it cannot be posed (a zero co-spectrum).
    """
    func = _MODELS[model]
    a0, b0 = start
    if model == "cospectrum":
        scale = float(np.max(np.abs(y)))
        if scale == 0:
            return "co-spectrum identically zero"
        a0 = abs(a0) * (1.0 if np.sum(y) > 0 else -1.0)

        def residual(p: np.ndarray) -> np.ndarray:
            return (func(fr, p[0], p[1]) - y) / scale

        return residual, [a0, b0], ([-np.inf, 1e-6], [np.inf, np.inf])
    ly = np.log10(y)

    def residual_log(p: np.ndarray) -> np.ndarray:
        return np.log10(np.maximum(func(fr, p[0], p[1]), 1e-300)) + log_bias - ly

    return residual_log, [a0, b0], ([1e-12, 1e-6], [np.inf, np.inf])


def _fit_result(res: scipy.optimize.OptimizeResult, n_points: int, model: ModelName) -> SpectralFit:
    """:class:`SpectralFit` from a ``least_squares`` result: not converged, or ``b`` at a bound."""
    a, b = (float(v) for v in res.x)
    rms = float(np.sqrt(np.mean(res.fun**2)))
    if not res.success or not (np.isfinite(a) and np.isfinite(b) and b > 0):
        return SpectralFit(np.nan, np.nan, False, rms, n_points, model,
                           f"least squares did not converge: {res.message}")
    if b >= 1e6 or b <= 1.001e-6:
        return SpectralFit(np.nan, np.nan, False, rms, n_points, model,
                           f"b={b:.3g} at a bound: spectral peak not resolved")
    return SpectralFit(a, b, True, rms, n_points, model, "")


def _replace_reason(fit: SpectralFit, reason: str) -> SpectralFit:
    return SpectralFit(fit.a, fit.b, fit.converged, fit.rms_residual, fit.n_points, fit.model, reason)


@dataclass(frozen=True)
class SpectralRatio:
    """Frequency-averaged spectral ratio (Ghirardelli et al. (2025), Sect. 4.1, Fig. 15).

    Attributes
    ----------
    value : float
        :math:`\\langle S_a/S_b\\rangle` [1]; NaN when not defined.
    n_bins : int
        Frequency bins averaged.
    f_min_hz, f_max_hz : float
        Frequency band corresponding to the reduced-frequency band [Hz].
    reason : str
        Empty when defined, else why not.
    """

    value: float
    n_bins: int
    f_min_hz: float
    f_max_hz: float
    reason: str = ""


def spectral_ratio(
    f_hz: np.ndarray,
    numerator: np.ndarray,
    denominator: np.ndarray,
    height_m: float,
    speed_ms: float,
    fr_min: float = 2.0,
    fr_max: float = 10.0,
    min_speed_ms: float = 2.0,
) -> SpectralRatio:
    r"""Frequency-averaged spectral ratio, e.g. :math:`\langle S_w/S_u\rangle` (Ghirardelli et al. (2025), Sect. 4.1).

    Parameters
    ----------
    f_hz : array-like
        Frequencies of the (binned) spectra [Hz].
    numerator, denominator : array-like
        Spectra on ``f_hz`` (e.g. S_w and S_u) [same unit].
    height_m : float
        Height :math:`z` [m].
    speed_ms : float
        Mean wind speed [m s-1].
    fr_min, fr_max : float, optional
        Reduced-frequency band (2 < f_r < 10 in the paper; Kaimal et al. 1972).
    min_speed_ms : float, optional
        The analysis is done only for mean speeds above this (2 m s-1 in the paper).

    Returns
    -------
    SpectralRatio
        Mean of the bin-wise ratio over the band, or NaN with a reason (speed too low,
        band outside the resolved frequencies).

    Notes
    -----
    .. math:: \langle S_w/S_u\rangle = \frac{1}{n}\sum_{f_k:\,2 < f_k z/\bar u < 10}
              \frac{S_w(f_k)}{S_u(f_k)}

    In the inertial subrange of locally isotropic turbulence both ratios tend to 4/3.
    """
    f = np.asarray(f_hz, dtype=float)
    num = np.real(np.asarray(numerator))
    den = np.real(np.asarray(denominator))
    if not (np.isfinite(speed_ms) and speed_ms > min_speed_ms):
        return SpectralRatio(np.nan, 0, np.nan, np.nan, f"mean speed {speed_ms:.3g} m/s not above {min_speed_ms} m/s")
    f_lo = fr_min * speed_ms / height_m
    f_hi = fr_max * speed_ms / height_m
    band = (f > f_lo) & (f < f_hi) & np.isfinite(num) & np.isfinite(den) & (den > 0)
    n = int(band.sum())
    if n == 0:
        return SpectralRatio(
            np.nan, 0, f_lo, f_hi,
            f"no spectral bin in {f_lo:.3g}-{f_hi:.3g} Hz ({fr_min} < f_r < {fr_max}); resolved up to {f.max():.3g} Hz",
        )
    reason = ""
    if f_hi > f.max():
        reason = f"band truncated at {f.max():.3g} Hz (f_r up to {f.max() * height_m / speed_ms:.3g})"
    return SpectralRatio(float(np.mean(num[band] / den[band])), n, f_lo, f_hi, reason)


def quadrant(ratio_mast: float, ratio_drone: float, reference: float = ISOTROPIC_RATIO) -> str:
    r"""Quadrant of Fig. 6 of Ghirardelli et al. (2025) for a pair of spectral ratios.

    Parameters
    ----------
    ratio_mast, ratio_drone : float
        :math:`\langle S_w/S_u\rangle` (or S_v/S_u) of the mast and drone sonics [1].
    reference : float, optional
        Isotropic value (4/3).

    Returns
    -------
    str
        ``"drone_over_mast_over"``, ``"drone_over_mast_under"``,
        ``"drone_under_mast_over"``, ``"drone_under_mast_under"`` (over = ratio above
        ``reference``, i.e. the sensor overestimates the vertical/transverse
        fluctuations relative to u), or ``"undefined"`` if either is NaN.
    """
    if not (np.isfinite(ratio_mast) and np.isfinite(ratio_drone)):
        return "undefined"
    d = "over" if ratio_drone > reference else "under"
    m = "over" if ratio_mast > reference else "under"
    return f"drone_{d}_mast_{m}"
