r"""Platform-motion response of a rigid-mount sonic, identified without a mast (``platform_velocity_response``).

The rigid-mount chain (:mod:`dronewind.payload.rigid`) corrects the sonic with
:math:`V_{wind} = R M V_{sensor} + V_{platform}`: it assumes the sonic sees the platform's
whole velocity. If the airframe and rotors make it see :math:`G V_{platform}` instead,
:math:`G = \mathrm{diag}(g_h, g_h, g_v)` (east, north, up; the catalog mechanism
``platform_velocity_response``), the corrected wind is

.. math:: \tilde V = V_{wind} + (I - G)\, V_{platform},

so at the frequencies where the platform moves, the corrected wind responds to the platform
velocity with the transfer function :math:`H = 1 - g`, and :math:`g = 1 - H`.

Estimation (all pure functions of arrays)
-----------------------------------------
* Spectra: Welch estimates on disjoint Hann-windowed segments of ``segment_s`` seconds,
  linear detrend per segment: auto-spectra :math:`S_{xx}` of the platform velocity,
  :math:`S_{yy}` of the corrected wind, cross-spectrum :math:`S_{yx}` [m2 s-2 Hz-1].
* Band (:func:`motion_band`): the platform-motion frequencies, where the platform-velocity
  spectrum (east + north for the horizontal, up for the vertical) stands within a factor
  ``band_factor`` (default 10, i.e. 10 dB) of its peak, above the lowest two bins.
* Transfer function over the band (least squares in the frequency domain; the horizontal
  pools east and north, which share :math:`g_h`):

  .. math:: \hat H = \frac{\sum_{f, c} \mathrm{Re}\, S_{y_c x_c}(f)}{\sum_{f, c} S_{x_c x_c}(f)}, \qquad
            \hat g = 1 - \hat H .

* Uncertainty: the random error of a transfer-function estimate (Bendat and Piersol 2010,
  *Random Data*, 4th ed., Wiley, Sect. 9.2, gain-factor error
  :math:`\varepsilon = \sqrt{1-\gamma^2} / (|\gamma| \sqrt{2 n_d})`), written in the form that
  stays finite at :math:`H = 0`: per bin
  :math:`\mathrm{var}\,\hat H(f) = (1 - \gamma^2) S_{yy} / (2 n_d S_{xx}) = S_{nn}/(2 n_d S_{xx})`,
  :math:`S_{nn}` the part of the wind spectrum not coherent with the platform. Summed over the
  band with weights :math:`S_{xx}/\sum S_{xx}` and multiplied by the Hann window's equivalent
  noise bandwidth (1.5 bins: adjacent bins are not independent):

  .. math:: \sigma^2[\hat g] = 1.5\, \frac{\sum_{f,c} S_{xx} S_{nn}}{2 n_d \left(\sum_{f,c} S_{xx}\right)^2}.

  This is kept as ``uncertainty_coherence``. On simulated records under the present model it
  is too small (z spread 1.3 instead of 1: the band's bins are correlated by leakage from
  the steep low-frequency wind spectrum), so the uncertainty used is the delete-one-segment
  jackknife of :math:`\hat H` (:func:`fit_component`), which needs no such assumption.
* Test: the present model is :math:`g_h = g_v = 1`. :math:`z = (\hat g - 1)/\sigma`
  (Student t, :math:`n_d - 1` degrees of freedom), :math:`T^2 = z_h^2 + z_v^2` and
  :math:`p = P(F_{2, n_d - 1} > T^2/2)`; the mechanism is named only when
  :math:`p < \alpha` (``alpha``, the false-alarm rate per flight, default 0.01). Measured
  on 60 simulated null records (700 s at 5 Hz, 60-s segments): 4 alarms at 0.05, z spread
  1.22 and 1.30 (Student t with 10 degrees of freedom: 1.12); the tests check 20 of them.
* Adequacy (:func:`band_constancy`): the mechanism is a constant gain. When the present model
  is rejected but the per-bin transfer functions of a rejected group differ from the band's
  beyond their errors, the response depends on frequency: no catalog mechanism describes it,
  and the result is reported as model error (``named`` false, ``adequate`` false), never as
  ``platform_velocity_response``.
* Extended correction: :math:`V_{wind} = R M V_{sensor} + G V_{platform} = \tilde V - (I - \hat G) V_{platform}`;
  its gain is measured in the band as the coherence :math:`\gamma^2_{band} = |\sum S_{yx}|^2 /
  (\sum S_{xx} \sum S_{yy})` and the wind power :math:`\sum S_{yy}\, \Delta f` [m2 s-2] and its
  part coherent with the platform, before and after. The power after follows from the band
  sums, :math:`\sum S_{y'y'} = \sum S_{yy} - 2 h \sum \mathrm{Re}\, S_{yx} + h^2 \sum S_{xx}`
  with :math:`h = 1 - \hat g`, so a gain fitted on other flights can be scored on a flight
  left out (:func:`band_power_after`).

Assumption
----------
The wind at the platform-motion frequencies is taken as uncorrelated with the platform
velocity. A position-holding multicopter pushed downwind by gusts breaks it (its velocity
then follows the wind, biasing :math:`\hat H` upward and :math:`\hat g` downward, by about
:math:`\rho\, \sigma_w / \sigma_x`); only a reference (mast) or a vehicle whose motion is
commanded independently of the wind separates the two. The workflow therefore estimates the
gains from commanded motion (:mod:`dronewind.diagnose.platform_commanded`: legs flown both
ways, climbs and descents) and keeps this hover estimate for reference only, labelled as not
used.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.signal
import scipy.stats

from dronewind.errors import InputError

__all__ = ["HANN_ENBW_BINS", "BandSums", "ComponentFit", "spectra", "motion_band", "band_sums", "fit_component",
           "band_power_after", "band_constancy", "diagnose_platform", "pooled_estimate"]

#: Equivalent noise bandwidth of the Hann window [bins].
HANN_ENBW_BINS = 1.5
_GROUPS = {"horizontal": (0, 1), "vertical": (2,)}
_PARAM = {"horizontal": "gain_h", "vertical": "gain_v"}


@dataclass(frozen=True)
class BandSums:
    """Band sums of one component group (enough to score any gain on it).

    Attributes
    ----------
    sxx, syy : float
        :math:`\\sum S_{xx}`, :math:`\\sum S_{yy}` over the band and the group's components
        (segment means) [m2 s-2 Hz-1].
    syx_re, syx_im : float
        :math:`\\sum S_{yx}` real and imaginary parts [m2 s-2 Hz-1].
    sxx_snn : float
        :math:`\\sum S_{xx} S_{nn}` [m4 s-4 Hz-2].
    df_hz : float
        Bin width [Hz].
    n_d : int
        Disjoint segments averaged.
    n_bins : int
        Bins in the band (per component).
    segment_sxx, segment_syx_re : tuple of float
        The same band sums of :math:`S_{xx}` and :math:`\\mathrm{Re}\\, S_{yx}` for each segment
        (the jackknife's pieces).
    """

    sxx: float
    syy: float
    syx_re: float
    syx_im: float
    sxx_snn: float
    df_hz: float
    n_d: int
    n_bins: int
    segment_sxx: tuple[float, ...]
    segment_syx_re: tuple[float, ...]


@dataclass(frozen=True)
class ComponentFit:
    """Fit of one gain (horizontal or vertical).

    Attributes
    ----------
    transfer : float
        :math:`\\hat H` [1] (present model: 0).
    gain, sigma : float
        :math:`\\hat g = 1 - \\hat H` and its standard error (delete-one-segment jackknife) [1].
    sigma_coherence : float
        The standard error from the band coherence (Bendat and Piersol) [1], for comparison.
    coherence : float
        Band coherence :math:`\\gamma^2_{band}` of the corrected wind with the platform velocity [1].
    band_hz : (float, float)
        Lowest and highest band frequency [Hz].
    sums : BandSums
    """

    transfer: float
    gain: float
    sigma: float
    sigma_coherence: float
    coherence: float
    band_hz: tuple[float, float]
    sums: BandSums


def spectra(y: np.ndarray, x: np.ndarray, fs_hz: float, segment_s: float) -> tuple[np.ndarray, ...]:
    """Per-segment periodograms on disjoint Hann-windowed segments (linear detrend per segment).

    Parameters
    ----------
    y, x : numpy.ndarray
        (n, k) corrected wind and platform velocity, same components [m s-1].
    fs_hz : float
        Sampling rate [Hz].
    segment_s : float
        Segment length [s].

    Returns
    -------
    f : numpy.ndarray
        Frequencies (m,) [Hz].
    sxx, syy, syx : numpy.ndarray
        (n_d, m, k) one-sided periodograms of each segment [m2 s-2 Hz-1]; ``syx`` complex,
        :math:`Y X^*` (their mean over segments is the Welch estimate).

    Raises
    ------
    InputError
        Fewer than four segments.
    """
    n = y.shape[0]
    nper = int(round(segment_s * fs_hz))
    n_d = n // max(nper, 1)
    if nper < 16 or n_d < 4:
        raise InputError("segment_s", f"{n} samples at {fs_hz:g} Hz hold {n_d} segments of {segment_s:g} s "
                         f"({nper} samples); expected at least 4 segments of at least 16 samples (a longer steady "
                         "segment or a shorter segment_s)")
    win = scipy.signal.get_window("hann", nper)
    scale = 2.0 / (fs_hz * np.sum(win ** 2))

    def fft(a: np.ndarray) -> np.ndarray:
        seg = a[: n_d * nper].reshape(n_d, nper, a.shape[1])
        seg = scipy.signal.detrend(seg, axis=1, type="linear")
        return np.fft.rfft(seg * win[None, :, None], axis=1)

    fx, fy = fft(x), fft(y)
    sxx, syy, syx = scale * np.abs(fx) ** 2, scale * np.abs(fy) ** 2, scale * fy * np.conj(fx)
    return np.fft.rfftfreq(nper, 1.0 / fs_hz), sxx, syy, syx


def motion_band(f: np.ndarray, sxx_total: np.ndarray, band_factor: float = 10.0) -> np.ndarray:
    """The platform-motion frequencies: bins within ``band_factor`` of the platform spectrum's peak.

    Parameters
    ----------
    f : numpy.ndarray
        Frequencies [Hz] (``f[0] = 0``).
    sxx_total : numpy.ndarray
        Platform-velocity spectrum of the group (summed over its components) [m2 s-2 Hz-1].
    band_factor : float
        Ratio of the peak to the lowest spectrum level inside the band [1] (10: 10 dB).

    Returns
    -------
    numpy.ndarray
        Boolean mask of the band bins; the lowest two bins (mean and trend leakage) are never in it.
    """
    ok = np.arange(f.size) >= 2
    peak = float(np.max(sxx_total[ok]))
    return ok & (sxx_total >= peak / band_factor)


def band_sums(f: np.ndarray, sxx: np.ndarray, syy: np.ndarray, syx: np.ndarray, band: np.ndarray) -> BandSums:
    """Sums over the band and the components, with :math:`S_{nn} = (1 - \\gamma^2) S_{yy}` per bin.

    Parameters
    ----------
    f : numpy.ndarray
        Frequencies [Hz].
    sxx, syy, syx : numpy.ndarray
        (n_d, m, k) per-segment periodograms of the group's components (:func:`spectra`).
    band : numpy.ndarray
        Boolean mask (m,).

    Returns
    -------
    BandSums
    """
    b = band
    mxx, myy, myx = sxx.mean(axis=0)[b], syy.mean(axis=0)[b], syx.mean(axis=0)[b]
    gamma2 = np.abs(myx) ** 2 / np.maximum(mxx * myy, np.finfo(float).tiny)
    snn = (1.0 - np.clip(gamma2, 0.0, 1.0)) * myy
    return BandSums(float(np.sum(mxx)), float(np.sum(myy)), float(np.sum(myx.real)), float(np.sum(myx.imag)),
                    float(np.sum(mxx * snn)), float(f[1] - f[0]), int(sxx.shape[0]), int(b.sum()),
                    tuple(float(v) for v in sxx[:, b].sum(axis=(1, 2))),
                    tuple(float(v) for v in syx[:, b].real.sum(axis=(1, 2))))


def fit_component(s: BandSums, band_hz: tuple[float, float]) -> ComponentFit:
    """:math:`\\hat H`, :math:`\\hat g = 1 - \\hat H`, its standard errors and the band coherence.

    The standard error is the delete-one-segment jackknife of the band transfer function
    (Thomson and Chave 1991, Jackknifed error estimates for spectra, coherences, and transfer
    functions, in *Advances in Spectrum Analysis and Array Processing*, vol. 1, 58-113):
    :math:`\\hat H_{(j)} = (A - a_j)/(B - b_j)` with :math:`a_j, b_j` the band sums of
    :math:`\\mathrm{Re}\\, S_{yx}` and :math:`S_{xx}` of segment j,
    :math:`\\sigma^2 = \\frac{n_d - 1}{n_d} \\sum_j (\\hat H_{(j)} - \\bar H_{(\\cdot)})^2`. It needs
    no assumption on how the band's bins are correlated (Hann leakage from the steep
    low-frequency wind spectrum correlates them). The coherence-based error (Bendat and
    Piersol) is kept as ``sigma_coherence``.

    Parameters
    ----------
    s : BandSums
    band_hz : (float, float)
        Band edges for the record [Hz].

    Returns
    -------
    ComponentFit
    """
    h = s.syx_re / s.sxx
    a, b = np.array(s.segment_syx_re), np.array(s.segment_sxx)
    h_j = (a.sum() - a) / (b.sum() - b)
    var_jk = (s.n_d - 1) / s.n_d * float(np.sum((h_j - h_j.mean()) ** 2))
    var_bp = HANN_ENBW_BINS * s.sxx_snn / (2.0 * s.n_d * s.sxx ** 2)
    coh = (s.syx_re ** 2 + s.syx_im ** 2) / (s.sxx * s.syy)
    return ComponentFit(float(h), float(1.0 - h), float(np.sqrt(var_jk)), float(np.sqrt(var_bp)), float(coh),
                        band_hz, s)


def band_power_after(s: BandSums, gain: float) -> dict[str, float]:
    """Wind power and coherence in the band after the extended correction with ``gain``.

    Parameters
    ----------
    s : BandSums
        Band sums of the corrected wind (present model) and platform velocity.
    gain : float
        :math:`g` applied: :math:`y' = y - (1 - g) x`.

    Returns
    -------
    dict
        ``power_m2s2`` (:math:`\\sum S_{y'y'} \\Delta f`), ``coherent_power_m2s2``
        (:math:`\\gamma'^2` times it) and ``coherence`` :math:`\\gamma'^2` [1].
    """
    h = 1.0 - gain
    syy = s.syy - 2.0 * h * s.syx_re + h * h * s.sxx
    re, im = s.syx_re - h * s.sxx, s.syx_im
    coh = (re * re + im * im) / (s.sxx * syy) if syy > 0 else float("nan")
    return {"power_m2s2": float(syy * s.df_hz), "coherent_power_m2s2": float(coh * syy * s.df_hz),
            "coherence": float(coh)}


def band_constancy(f: np.ndarray, sxx: np.ndarray, syx: np.ndarray, band: np.ndarray, transfer: float
                   ) -> dict[str, Any]:
    r"""Does one gain describe the whole band? Per-bin transfer functions against the band's.

    The mechanism's response is a constant :math:`H = 1 - g` over the platform-motion band.
    Per band bin, :math:`\hat H_f = \sum_c \overline{\mathrm{Re}\, S_{yx}} / \sum_c
    \overline{S_{xx}}` with its delete-one-segment jackknife variance :math:`\sigma_f^2`
    (as :func:`fit_component`), and

    .. math:: t_f = \frac{\hat H_f - \hat H}{\sigma_f}, \quad
              \chi^2 = \frac{1}{b}\sum_f z_f^2, \quad z_f = \Phi^{-1}\left(1 - F_{t, n_d - 1}(|t_f|)\right),
              \qquad \nu = (n_{bins} - 1)/b,

    with :math:`b` = :data:`HANN_ENBW_BINS` (adjacent bins of a Hann window share about 1.5
    bins of information, so the sum counts each independent piece about 1.5 times). A
    p-value below the false-alarm rate says the platform's imprint on the corrected wind
    changes with frequency: then no constant gain (no catalog mechanism) describes it, and
    the result is model error, not a named cause.

    Parameters
    ----------
    f : numpy.ndarray
        Frequencies [Hz].
    sxx, syx : numpy.ndarray
        (n_d, m, k) per-segment periodograms of the group's components (:func:`spectra`).
    band : numpy.ndarray
        Boolean band mask (m,).
    transfer : float
        The band's :math:`\hat H` [1].

    Returns
    -------
    dict
        ``frequencies_hz``, ``transfer`` and ``sigma`` per bin, ``chi2``, ``dof`` and
        ``p_value`` (NaN with fewer than two bins).
    """
    a = syx[:, band].real.sum(axis=2)  # (n_d, n_bins)
    b = sxx[:, band].sum(axis=2)
    n_d = a.shape[0]
    h_f = a.sum(axis=0) / b.sum(axis=0)
    h_j = (a.sum(axis=0)[None, :] - a) / (b.sum(axis=0)[None, :] - b)
    var_f = (n_d - 1) / n_d * np.sum((h_j - h_j.mean(axis=0)) ** 2, axis=0)
    n_bins = int(band.sum())
    out: dict[str, Any] = {"frequencies_hz": [float(v) for v in f[band]], "transfer": [float(v) for v in h_f],
                           "sigma": [float(v) for v in np.sqrt(var_f)]}
    if n_bins < 2 or not np.all(var_f > 0):
        return {**out, "chi2": float("nan"), "dof": 0.0, "p_value": float("nan")}
    # each bin's deviation over its jackknife error is Student t with n_d - 1 degrees of
    # freedom (a few segments make the error itself noisy): mapped to the normal deviate of
    # the same tail probability before squaring, so a noisy error does not fake a rejection
    t_f = (h_f - transfer) / np.sqrt(var_f)
    z_f = scipy.stats.norm.isf(scipy.stats.t.sf(np.abs(t_f), n_d - 1))
    chi2 = float(np.sum(z_f ** 2)) / HANN_ENBW_BINS
    dof = (n_bins - 1) / HANN_ENBW_BINS
    return {**out, "chi2": chi2, "dof": float(dof), "p_value": float(scipy.stats.chi2.sf(chi2, dof))}


def _time_domain(y: np.ndarray, x: np.ndarray) -> dict[str, list[float]]:
    """Correlation and regression slope of each corrected-wind component on its platform velocity."""
    corr, slope = [], []
    for k in range(y.shape[1]):
        xc, yc = x[:, k] - x[:, k].mean(), y[:, k] - y[:, k].mean()
        corr.append(float(np.sum(xc * yc) / np.sqrt(np.sum(xc * xc) * np.sum(yc * yc))))
        slope.append(float(np.sum(xc * yc) / np.sum(xc * xc)))
    return {"correlation": corr, "slope": slope}


def diagnose_platform(wind_enu: np.ndarray, vel_enu: np.ndarray, fs_hz: float, *, segment_s: float = 60.0,
                      band_factor: float = 10.0, alpha: float = 0.01) -> dict[str, Any]:
    """Fit ``platform_velocity_response`` to one rigid-mount flight; test it against the present model.

    Parameters
    ----------
    wind_enu : numpy.ndarray
        (n, 3) motion-corrected wind east, north, up of the L2 [m s-1], regular time axis.
    vel_enu : numpy.ndarray
        (n, 3) platform velocity east, north, up on the same axis [m s-1].
    fs_hz : float
        Sampling rate [Hz].
    segment_s : float
        Spectral segment length [s].
    band_factor : float
        :func:`motion_band`.
    alpha : float
        False-alarm rate of the test against :math:`g_h = g_v = 1` [1].

    Returns
    -------
    dict
        ``estimate`` / ``uncertainty`` (``gain_h``, ``gain_v``), ``test`` (``chi2``, ``dof``,
        ``p_value``, ``alpha``, ``z``), ``significant`` (the present model rejected),
        ``band_constancy`` and ``adequate`` (:func:`band_constancy`: a group whose imprint is
        significant must have one gain across its band), ``named`` (significant and
        adequate: only then is the catalog mechanism the cause), ``present_model`` (per group:
        transfer function, band coherence, band; time-domain correlation and slope per
        component), ``gain`` (per group: coherence, power and coherent power in the band,
        before and after the extended correction), ``band_sums`` (per group) and the
        settings.

    Raises
    ------
    InputError
        Arrays of different shapes, non-finite values, too short a record, or a platform that
        does not move.
    """
    y, x = np.asarray(wind_enu, float), np.asarray(vel_enu, float)
    if y.shape != x.shape or y.ndim != 2 or y.shape[1] != 3:
        raise InputError("platform diagnosis", f"wind {y.shape} and platform velocity {x.shape}; expected two "
                         "(n, 3) arrays (east, north, up) on one time axis")
    if not (np.all(np.isfinite(y)) and np.all(np.isfinite(x))):
        raise InputError("platform diagnosis", "non-finite samples; expected the gap-filled L2 steady segment")
    if not 0.0 < alpha < 1.0:
        raise InputError("alpha", f"{alpha!r}; expected a false-alarm rate in (0, 1)")
    f, sxx, syy, syx = spectra(y, x, fs_hz, segment_s)
    n_d = sxx.shape[0]
    fits: dict[str, ComponentFit] = {}
    constancy: dict[str, dict[str, Any]] = {}
    for group, comps in _GROUPS.items():
        c = list(comps)
        total = sxx.mean(axis=0)[:, c].sum(axis=1)
        if not np.any(total[2:] > 0):
            raise InputError("platform diagnosis", f"the platform's {group} velocity has no power; expected a "
                             "moving platform")
        band = motion_band(f, total, band_factor)
        sums = band_sums(f, sxx[..., c], syy[..., c], syx[..., c], band)
        fits[group] = fit_component(sums, (float(f[band].min()), float(f[band].max())))
        constancy[group] = band_constancy(f, sxx[..., c], syx[..., c], band, fits[group].transfer)
    z = {g: (fit.gain - 1.0) / fit.sigma for g, fit in fits.items()}
    t2 = float(sum(v * v for v in z.values()))
    # each z is t-distributed with n_d - 1 degrees of freedom (jackknife); the pair as an F statistic
    p = float(scipy.stats.f.sf(t2 / len(z), len(z), n_d - 1))
    td = _time_domain(y, x)
    out: dict[str, Any] = {
        "mechanism": "platform_velocity_response",
        "estimate": {_PARAM[g]: fit.gain for g, fit in fits.items()},
        "uncertainty": {_PARAM[g]: fit.sigma for g, fit in fits.items()},
        "uncertainty_coherence": {_PARAM[g]: fit.sigma_coherence for g, fit in fits.items()},
        "test": {"null": "gain_h = gain_v = 1 (the present model)",
                 "statistic": "T2 = z_h^2 + z_v^2, p from F(2, n_d - 1) of T2 / 2",
                 "t2": t2, "dof": [len(z), n_d - 1], "p_value": p,
                 "alpha": float(alpha), "z": {_PARAM[g]: v for g, v in z.items()},
                 "p_value_each": {_PARAM[g]: float(2 * scipy.stats.t.sf(abs(v), n_d - 1)) for g, v in z.items()}},
        "significant": bool(p < alpha),
        # the present model is rejected, but is the mechanism's constant gain adequate? A group
        # whose imprint is significant and changes across the band is model error, not the cause
        "band_constancy": constancy,
        "adequate": bool(all(not (abs(z[g]) > scipy.stats.t.isf(alpha / 2, n_d - 1)
                                  and constancy[g]["p_value"] < alpha) for g in fits)),
        "present_model": {
            g: {"transfer": fit.transfer, "coherence": fit.coherence, "band_hz": list(fit.band_hz),
                "n_bins": fit.sums.n_bins} for g, fit in fits.items()},
        "time_domain": {"components": ["east", "north", "up"], **td},
        "gain": {g: {"before": band_power_after(fit.sums, 1.0), "after": band_power_after(fit.sums, fit.gain)}
                 for g, fit in fits.items()},
        "band_sums": {g: dict(fit.sums.__dict__) for g, fit in fits.items()},
        "settings": {"segment_s": float(segment_s), "band_factor": float(band_factor), "n_segments": int(n_d),
                     "fs_hz": float(fs_hz), "n_samples": int(y.shape[0]), "window": "hann, disjoint segments",
                     "enbw_bins": HANN_ENBW_BINS},
        "extended_correction": "V_wind = R M V_sensor + G V_platform, G = diag(gain_h, gain_h, gain_v) "
                               "(east, north, up)",
    }
    out["named"] = bool(out["significant"] and out["adequate"])
    return out


def pooled_estimate(flights: Sequence[Mapping[str, Any]], leave_out: str | None = None) -> dict[str, Any]:
    """Inverse-variance pooled gains of several flights (optionally leaving one out).

    Parameters
    ----------
    flights : sequence of mapping
        Outputs of :func:`diagnose_platform` with a ``flight`` key.
    leave_out : str, optional
        Flight to leave out.

    Returns
    -------
    dict
        ``estimate`` and ``uncertainty`` (``gain_h``, ``gain_v``), ``flights`` used.
    """
    used = [f for f in flights if f.get("flight") != leave_out]
    if not used:
        raise InputError("platform diagnosis", "no flight left to pool; expected at least one other rigid flight")
    est, unc = {}, {}
    for p in ("gain_h", "gain_v"):
        w = np.array([1.0 / f["uncertainty"][p] ** 2 for f in used])
        g = np.array([f["estimate"][p] for f in used])
        est[p] = float(np.sum(w * g) / np.sum(w))
        unc[p] = float(1.0 / np.sqrt(np.sum(w)))
    return {"estimate": est, "uncertainty": unc, "flights": [f.get("flight") for f in used]}
