r"""Calibrated statistics of the campaign diagnosis: the model discrepancy and the profiled fits.

The campaign diagnosis (:mod:`dronewind.diagnose.campaign`) compares every flight's measured
residual features with the forward model's baseline seeds. Two questions decide whether its
verdicts can be trusted: how large is the misfit that no candidate describes, and what
distribution does each test statistic have when nothing is wrong. This module answers the
first, and fits every candidate under it; :mod:`dronewind.diagnose.reference` the second.

Model discrepancy
-----------------
The residual of feature :math:`f` of flight :math:`i` is

.. math:: r_{if} = y_{if} - \hat y_{if} = x_i^\top \beta_f + \delta_{if} + \varepsilon_{if},
          \qquad \varepsilon_{if} \sim N(0, \sigma_{if}^2), \quad \delta_{if} \sim N(0, \tau_f^2),

with :math:`\sigma_{if}` the sampling error from the seeds, :math:`\delta_{if}` the model
discrepancy (Kennedy and O'Hagan 2001) treated as a random effect across flights, and
:math:`x_i^\top \beta_f` a common offset (and, with four flights or more, a trend with the
mean wind speed) that is removed only to estimate :math:`\tau_f`: offsets and trends are what
the candidates and the ``unexplained`` tests look for, so they must not be absorbed into the
discrepancy (Brynjarsdóttir and O'Hagan 2014 show how a free discrepancy otherwise swallows
the signal). :math:`\tau_f^2` is the method-of-moments estimate of DerSimonian and Laird
(1986) generalised to meta-regression,

.. math:: \hat\tau_f^2 = \max\left(0, \frac{Q_f - (n - q)}
          {\sum_i w_i - \mathrm{tr}\left[(X^\top W X)^{-1} X^\top W^2 X\right]}\right),
          \qquad Q_f = \sum_i w_i e_i^2, \quad w_i = \sigma_{if}^{-2},

(:math:`e_i` the weighted least-squares residuals, :math:`q` the columns of :math:`X`), with a
95 % interval by the Q-profile method (Viechtbauer 2007). The discrepancy enters every test of
a candidate through the residual covariance
:math:`C_i = D_i R^* D_i + \mathrm{diag}(\tau^2)` (:func:`dronewind.diagnose.covariance.flight_correlations`),
so that a cause is named only where its signature across flights stands above it. It is
profiled under each candidate (:func:`profiled_fit`): estimated from the residuals after the
candidate's fit, whose parameters took :math:`h_f` of each feature's degrees of freedom
(:func:`fit_dof`), so that a real mechanism's signature does not inflate the discrepancy its
own test is weighed against.

References
----------
Kennedy, M. C. and O'Hagan, A. (2001): Bayesian calibration of computer models. J. R. Stat.
Soc. B 63(3), 425-464, doi:10.1111/1467-9868.00294.

Brynjarsdóttir, J. and O'Hagan, A. (2014): Learning about physical parameters: the importance
of model discrepancy. Inverse Problems 30(11), 114007, doi:10.1088/0266-5611/30/11/114007.

DerSimonian, R. and Laird, N. (1986): Meta-analysis in clinical trials. Controlled Clinical
Trials 7(3), 177-188, doi:10.1016/0197-2456(86)90046-2.

Viechtbauer, W. (2007): Confidence intervals for the amount of heterogeneity in
meta-analysis. Statistics in Medicine 26(1), 37-52, doi:10.1002/sim.2514.

"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.optimize
import scipy.stats

from dronewind.diagnose.covariance import (
    Whitener,
    flight_correlations,
    log_determinant,
    row_patterns,
)
from dronewind.diagnose.fitting import FitResult, ResponseModel, fit_parameters, standardised_residuals

__all__ = ["Discrepancy", "discrepancy", "fit_dof", "fit_jacobian", "profiled_discrepancy", "ProfiledFit",
           "profiled_fit", "null_likelihood", "likelihood_ratio", "MIN_FLIGHTS_TREND", "MAX_LOST_SHARE",
           "UNEXPLAINED_ALPHA", "TIE_MARGIN", "more_likely", "group_moments"]

#: Flights needed before a trend with wind speed is removed besides the offset when the
#: discrepancy is estimated (two degrees of freedom left). Most mechanisms' effects grow or decay
#: with wind speed (a sonic pitch tilts the flow by an angle whose effect on w grows with U, a
#: downdraft decays with it): estimated about an offset alone, such an effect would be taken for
#: discrepancy and hide itself (a hidden 5.4 degree pitch on four flights was not named).
MIN_FLIGHTS_TREND = 4
#: Largest share of a feature's degrees of freedom :math:`n - q` that a candidate's fit may take
#: when the discrepancy is profiled under it (:func:`discrepancy` with ``lost_dof``): a fit that
#: reproduces one feature of every flight leaves no scatter to estimate, and the estimate then
#: rests on a tenth of a degree of freedom at least.
MAX_LOST_SHARE = 0.9
#: Family-wise false-alarm rate of ``unexplained`` (the offset and trend test of every feature,
#: :func:`dronewind.diagnose.fit_quality.unexplained_features`). A missed feature is reported,
#: not named as a cause, so the conventional 5 % is used. Its power: with known variances the
#: trend statistic of a trend of :math:`c` residual errors per standard deviation of the
#: flights' wind speeds over :math:`n` flights is normal with mean :math:`c\sqrt{n - 1}`, that of
#: a common offset of :math:`c` errors :math:`c\sqrt{n}`; the discrepancy estimated from the
#: same flights widens the errors of both. Measured over 400 Gaussian campaigns of ten flights
#: and 15 features (Bonferroni form): a trend of 1.5 errors per SD is found with probability
#: 0.84 at 5 % (0.71 at 1 %), an offset of 2 errors with 0.99 (0.98); the noise alone reports
#: something in 3.5 % (``tests/diagnose/test_diagnose_fitting.py``).
UNEXPLAINED_ALPHA = 0.05


@dataclass(frozen=True)
class Discrepancy:
    """Model discrepancy per feature (module docstring).

    Attributes
    ----------
    tau : numpy.ndarray
        :math:`\\hat\\tau_f` (p,) [feature units]; NaN where fewer than ``q + 1`` flights have the feature.
    low, high : numpy.ndarray
        95 % Q-profile interval of :math:`\\tau_f` (p,) [feature units].
    q_statistic : numpy.ndarray
        Generalised :math:`Q_f` at :math:`\\tau = 0` (p,).
    dof : numpy.ndarray
        Its degrees of freedom :math:`n - q` (p,).
    trend : numpy.ndarray
        Whether a trend with wind speed was removed with the offset (p,) (bool).
    """

    tau: np.ndarray
    low: np.ndarray
    high: np.ndarray
    q_statistic: np.ndarray
    dof: np.ndarray
    trend: np.ndarray

    def tau_or_zero(self) -> np.ndarray:
        """:attr:`tau` with NaN as 0 (no discrepancy where it cannot be estimated) [feature units]."""
        return np.where(np.isfinite(self.tau), self.tau, 0.0)


def _q_at(tau2: float, r: np.ndarray, v: np.ndarray, x: np.ndarray) -> float:
    return float(_wls_batch(r[None, :], (v + tau2)[None, :], x)[1][0])


def _profile_bound(target: float, r: np.ndarray, v: np.ndarray, x: np.ndarray, scale: float = 1.0) -> float:
    """:math:`\\tau^2` where the generalised Q equals ``target`` (0 when it is below at 0).

    ``scale`` > 1 (a candidate's fit took degrees of freedom) shrinks the discrepancy's share
    of the variances as the moment estimate does: Q is evaluated at :math:`\\tau^2 / scale`.
    """
    if _q_at(0.0, r, v, x) <= target:
        return 0.0
    hi = max(float(np.var(r)), float(np.max(v)), 1e-12)
    while _q_at(hi / scale, r, v, x) > target:
        hi *= 4.0
        if hi > 1e12:
            return float("inf")
    return float(scipy.optimize.brentq(lambda t: _q_at(t / scale, r, v, x) - target, 0.0, hi, xtol=1e-14,
                                       rtol=1e-10))


def _offset_trend_design(speed_ms: np.ndarray) -> tuple[np.ndarray, bool]:
    """Design matrix of the offset (and, with enough flights, the trend with wind speed) of one feature.

    Parameters
    ----------
    speed_ms : numpy.ndarray
        Mean wind speed of the flights that have the feature (n,) [m s-1].

    Returns
    -------
    x : numpy.ndarray
        (n, 1) ones, or (n, 2) ones and the centred speeds when there are at least
        :data:`MIN_FLIGHTS_TREND` flights with finite, differing speeds.
    with_trend : bool
        Whether the trend column is there.
    """
    n = speed_ms.size
    with_trend = bool(n >= MIN_FLIGHTS_TREND and np.all(np.isfinite(speed_ms)) and np.ptp(speed_ms) > 0)
    x = np.ones((n, 1))
    if with_trend:
        x = np.column_stack([x, speed_ms - np.mean(speed_ms)])
    return x, with_trend


def _feature_groups(residual: np.ndarray, sigma: np.ndarray, speed_ms: np.ndarray | None, about_zero: bool = False
                    ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, bool]]:
    """Features that share the flights they are measured on, with their offset-and-trend design.

    Returns
    -------
    list of (features, rows, x, with_trend)
        For every pattern of usable flights (finite residual and error, error > 0) with at
        least one degree of freedom left: the feature indices, the flight indices, the design
        of :func:`_offset_trend_design` on them (no column with ``about_zero``: the moments are
        taken about zero) and whether it has the trend. Features of one
        pattern are worked on in one batch (the bootstrap repeats these moments thousands of
        times; a loop of small calls per feature was most of their cost).
    """
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(residual) & np.isfinite(sigma) & (sigma > 0)
    speed = np.full(ok.shape[0], np.nan) if speed_ms is None else np.asarray(speed_ms, dtype=float)
    groups = []
    for pattern, feats in row_patterns(ok.T):
        rows = np.flatnonzero(pattern)
        x, with_trend = (np.zeros((rows.size, 0)), False) if about_zero else _offset_trend_design(speed[rows])
        if rows.size - x.shape[1] < 1:
            continue
        groups.append((feats, rows, x, with_trend))
    return groups


def _wls_batch(r: np.ndarray, v: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_wls` of several features at once on one design.

    Parameters
    ----------
    r, v : numpy.ndarray
        Residuals and their variances (g, n).
    x : numpy.ndarray
        Design (n, q).

    Returns
    -------
    maker, q, denom : numpy.ndarray
        The weighted residual makers :math:`I - X (X^\top W X)^{+} X^\top W` (g, n, n), Q and the
        DerSimonian-Laird denominator (g,).
    """
    w = 1.0 / v
    if x.shape[1] == 0:  # no design: the moments about zero
        e = np.asarray(r, dtype=float)
        return (np.broadcast_to(np.eye(x.shape[0]), (r.shape[0], x.shape[0], x.shape[0])),
                np.sum(w * e * e, axis=1), np.sum(w, axis=1))
    inv = np.linalg.pinv(np.einsum("ia,gi,ib->gab", x, w, x))
    maker = np.eye(x.shape[0])[None] - np.einsum("ia,gab,jb,gj->gij", x, inv, x, w)
    e = np.einsum("gij,gj->gi", maker, r)
    q = np.sum(w * e * e, axis=1)
    denom = np.sum(w, axis=1) - np.einsum("gab,ib,gi,ia->g", inv, x, w * w, x)
    return maker, q, denom


def discrepancy(residual: np.ndarray, sigma: np.ndarray, speed_ms: np.ndarray | None = None,
                interval: bool = True, lost_dof: np.ndarray | None = None, about_zero: bool = False
                ) -> Discrepancy:
    """Per-feature model discrepancy across flights (DerSimonian-Laird moments, Q-profile interval).

    Parameters
    ----------
    residual : numpy.ndarray
        Measured minus predicted features (n_flights, p) [feature units]; NaN: not used.
    sigma : numpy.ndarray
        Sampling errors of the residuals (n_flights, p) [feature units].
    speed_ms : numpy.ndarray, optional
        Mean wind speed of every flight (n_flights,) [m s-1]: with :data:`MIN_FLIGHTS_TREND`
        flights or more a trend with it is removed besides the offset.
    interval : bool
        Compute the Q-profile interval (the bootstrap replicates need only the estimate).
    lost_dof : numpy.ndarray, optional
        Degrees of freedom :math:`h_f` (p,) that a candidate's fit took from each feature's
        residuals (:func:`fit_dof`): the residuals are those after the fit, whose projection
        removed :math:`h_f` of the :math:`n - q` dimensions the moments rest on.
    about_zero : bool
        Take the moments about zero (no offset or trend removed, :math:`q = 0`): the
        discrepancy of the null hypothesis of the likelihood-ratio statistic
        (:attr:`ProfiledFit.lr_statistic`), under which a common offset is discrepancy too.

    Returns
    -------
    Discrepancy
        See the module docstring (DerSimonian and Laird 1986; Viechtbauer 2007). With
        ``lost_dof`` the moment equation is
        :math:`\\hat\tau_f^2 = \\max(0, (Q_f - k'_f) / (c_f\\,k'_f / k_f))`, :math:`k_f = n - q`,
        :math:`k'_f = k_f - h_f` (``dof``), :math:`c_f` the denominator of the module
        docstring: the fit's projection removes a share :math:`h_f / k_f` of the sampling and
        of the discrepancy part of :math:`E[Q_f]` alike (exact when its leverage is spread
        evenly over the flights). The interval uses :math:`\\chi^2_{k'_f}` quantiles.
    """
    r_all = np.asarray(residual, dtype=float)
    s_all = np.asarray(sigma, dtype=float)
    n, p = r_all.shape
    speed = np.full(n, np.nan) if speed_ms is None else np.asarray(speed_ms, dtype=float)
    tau2 = np.full(p, np.nan)
    low = np.full(p, np.nan)
    high = np.full(p, np.nan)
    q_stat = np.full(p, np.nan)
    dof = np.zeros(p, dtype=float)
    lost = np.zeros(p) if lost_dof is None else np.nan_to_num(np.asarray(lost_dof, dtype=float), nan=0.0)
    trend = np.zeros(p, dtype=bool)
    for feats, rows, x, with_trend in _feature_groups(r_all, s_all, speed, about_zero):
        k = rows.size - x.shape[1]
        r_g, v_g = r_all[np.ix_(rows, feats)].T, s_all[np.ix_(rows, feats)].T ** 2
        _, q_g, denom_g = _wls_batch(r_g, v_g, x)
        k_eff_g = k - np.clip(lost[feats], 0.0, MAX_LOST_SHARE * k)
        denom_g = denom_g * k_eff_g / k
        with np.errstate(invalid="ignore", divide="ignore"):
            tau2[feats] = np.where(denom_g > 0, np.maximum(0.0, (q_g - k_eff_g) / denom_g), 0.0)
        q_stat[feats], dof[feats], trend[feats] = q_g, k_eff_g, with_trend
        if not interval:
            continue
        for f, r, v, k_eff in zip(feats, r_g, v_g, k_eff_g, strict=True):
            scale = k / k_eff  # the interval's Q is read on the fitted residuals' reduced scale
            low[f] = _profile_bound(float(scipy.stats.chi2.ppf(0.975, k_eff)), r, v, x, scale)
            high[f] = _profile_bound(float(scipy.stats.chi2.ppf(0.025, k_eff)), r, v, x, scale)
    return Discrepancy(np.sqrt(tau2), np.sqrt(low), np.sqrt(high), q_stat, dof, trend)


def fit_jacobian(model: ResponseModel, theta: np.ndarray, flights: np.ndarray) -> np.ndarray:
    """Derivative of a candidate's prediction at its fit with respect to its free parameters.

    Parameters
    ----------
    model : ResponseModel
        The candidate's responses.
    theta : numpy.ndarray
        Its fitted parameters.
    flights : numpy.ndarray
        Indices of the fitted flights.

    Returns
    -------
    numpy.ndarray
        (n_flights, p, m): one-sided differences of the piecewise-linear responses (a step of
        1e-3 of the parameter's range, toward the inside); a parameter at a bound (an active
        constraint) is left out (m counts the free parameters; NaN effects are 0).
    """
    theta = np.asarray(theta, dtype=float)
    base = model.predict(theta, flights)
    cols = []
    for k, par in enumerate(model.parameters):
        span = float(par.upper - par.lower)
        if span <= 0 or theta[k] <= par.lower + 1e-6 * span or theta[k] >= par.upper - 1e-6 * span:
            continue  # an active bound
        step = 1e-3 * span * (1.0 if theta[k] + 1e-3 * span <= par.upper else -1.0)
        moved = theta.copy()
        moved[k] += step
        d = (model.predict(moved, flights) - base) / step
        cols.append(np.where(np.isfinite(d), d, 0.0))
    return np.stack(cols, axis=2) if cols else np.zeros((*base.shape, 0))


def fit_dof(model: ResponseModel, theta: np.ndarray, total_sigma: np.ndarray, flights: np.ndarray) -> np.ndarray:
    r"""Leverage of a candidate's free parameters on each feature (the diagonal weights of its fit).

    Returns
    -------
    numpy.ndarray
        :math:`h_f = \sum_i H_{(i,f),(i,f)}` (p,), with :math:`H = A (A^\top A)^{-1} A^\top`,
        :math:`A_{(i,f),j} = \partial \hat y_{if} / \partial\theta_j / \sigma_{if}`
        (:func:`fit_jacobian`); :math:`\sum_f h_f` is the number of free parameters. It is the
        share of each feature's degrees of freedom the fit takes before any offset or trend is
        removed; :func:`profiled_discrepancy` works with the exact moments instead.
    """
    jac = fit_jacobian(model, theta, flights)
    n, p, m = jac.shape
    if m == 0:
        return np.zeros(p)
    s = np.asarray(total_sigma[flights], dtype=float)
    ok = np.isfinite(s) & (s > 0)
    a = np.where(ok[..., None], jac / np.where(ok, s, 1.0)[..., None], 0.0).reshape(n * p, m)
    h = np.einsum("ij,jk,ik->i", a, np.linalg.pinv(a.T @ a), a)
    return h.reshape(n, p).sum(axis=0)


def profiled_discrepancy(residual: np.ndarray, sigma: np.ndarray, speed_ms: np.ndarray | None,
                         jacobian: np.ndarray, fit_sigma: np.ndarray, tau_start: np.ndarray,
                         about_zero: bool = False) -> Discrepancy:
    r"""Model discrepancy per feature of the residuals after a candidate's fit (moments with the fit's projection).

    Parameters
    ----------
    residual : numpy.ndarray
        Measured minus the candidate's fitted prediction (n_flights, p) [feature units].
    sigma : numpy.ndarray
        Sampling errors (n_flights, p) [feature units].
    speed_ms : numpy.ndarray or None
        Mean wind speed of every flight [m s-1] (the trend of :func:`discrepancy`).
    jacobian : numpy.ndarray
        :func:`fit_jacobian` at the fit (n_flights, p, m).
    fit_sigma : numpy.ndarray
        The errors the fit weighed (n_flights, p): :math:`\hat\theta = (A^\top A)^{-1} A^\top z`,
        :math:`A = J / s`, :math:`z = r_0 / s` (linearised, the features' correlation left out).
    tau_start : numpy.ndarray
        Discrepancy of the other features (p,) in the expected misfit they leak into a
        feature through the fit.
    about_zero : bool
        Moments about zero (no offset or trend removed, :func:`discrepancy`).

    Returns
    -------
    Discrepancy
        As :func:`discrepancy` (no interval). For feature :math:`f` the residuals after the fit
        and after the offset (and trend) are :math:`e = B_f r_0`, :math:`B_f = W^{1/2} M (E_f - J_f K)`
        with :math:`M` the weighted residual maker of the offset and trend,
        :math:`K = (A^\top A)^{-1} A^\top S^{-1}` and :math:`E_f` the selection of feature :math:`f`;
        with :math:`r_0` of variances :math:`\sigma^2 + \tau^2`,
        :math:`E[Q_f] = \sum_k (B_f)^2_{\cdot k} \sigma_k^2 + \tau_f^2 \sum_{k \in f} (B_f)^2_{\cdot k}
        + \sum_{k \notin f} (B_f)^2_{\cdot k} \tau_{f(k)}^2`, and the moment equation gives
        :math:`\hat\tau_f^2` (DerSimonian and Laird 1986 with the fit's projection: without a
        fit it is their estimate). ``dof`` is the expected :math:`Q_f` without discrepancy
        (:math:`n - q` less what the fit took), a fit whose signature in a feature is an
        offset or a trend takes nothing from it.
    """
    r_all = np.asarray(residual, dtype=float)
    s_all = np.asarray(sigma, dtype=float)
    n, p = r_all.shape
    m = jacobian.shape[2]
    speed = np.full(n, np.nan) if speed_ms is None else np.asarray(speed_ms, dtype=float)
    fs = np.asarray(fit_sigma, dtype=float)
    used = np.isfinite(fs) & (fs > 0) & np.isfinite(r_all)
    a = np.where(used[..., None], jacobian / np.where(used, fs, 1.0)[..., None], 0.0).reshape(n * p, m)
    k_map = (np.linalg.pinv(a.T @ a) @ a.T) / np.where(used, fs, 1.0).reshape(1, -1) if m else np.zeros((0, n * p))
    k_map = np.where(used.reshape(1, -1), k_map, 0.0)
    var0 = np.where(used, np.where(np.isfinite(s_all), s_all, 0.0) ** 2, 0.0).reshape(-1)
    tau2_other = np.repeat(np.nan_to_num(np.asarray(tau_start, dtype=float), nan=0.0)[None, :] ** 2, n, axis=0)
    tau2_other = np.where(used, tau2_other, 0.0).reshape(-1)
    feature_of = np.tile(np.arange(p), n)
    tau2 = np.full(p, np.nan)
    q_stat = np.full(p, np.nan)
    dof = np.zeros(p)
    trend = np.zeros(p, dtype=bool)
    for feats, rows, x, with_trend in _feature_groups(r_all, s_all, speed, about_zero):
        w = 1.0 / s_all[np.ix_(rows, feats)].T ** 2  # (g, n_ok)
        r_group = r_all[np.ix_(rows, feats)].T
        # d_f = E_f - J_f K: the fitted residuals of feature f as a map of all residuals
        d = (-np.einsum("igm,mk->gik", jacobian[np.ix_(rows, feats)], k_map) if m
             else np.zeros((feats.size, rows.size, n * p)))
        d[np.arange(feats.size)[:, None], np.arange(rows.size)[None, :], rows[None, :] * p + feats[:, None]] += 1.0
        own = feature_of[None, :] == feats[:, None]
        tau2[feats], q_stat[feats], dof[feats] = group_moments(w, r_group, d, x, own, var0, tau2_other)
        trend[feats] = with_trend
    nan = np.full(p, np.nan)
    return Discrepancy(np.sqrt(tau2), nan, nan, q_stat, dof, trend)


def group_moments(w: np.ndarray, r_group: np.ndarray, d: np.ndarray, x: np.ndarray, own: np.ndarray,
                  var0: np.ndarray, tau2_other: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""The moment equation of :func:`profiled_discrepancy` for one group of features sharing their flights.

    Parameters
    ----------
    w, r_group : numpy.ndarray
        Weights :math:`1/\sigma^2` and residuals of the group's features on its flights (..., g, n_ok).
    d : numpy.ndarray
        :math:`E_f - J_f K`: each feature's fitted residuals as a map of all residuals (..., g, n_ok, n p).
    x : numpy.ndarray
        The offset-and-trend design (n_ok, q); no column: the moments about zero.
    own : numpy.ndarray
        Which of the n p residuals belong to each feature (g, n p) (bool).
    var0, tau2_other : numpy.ndarray
        Sampling variances and the other features' discrepancy variances of all residuals (..., n p).

    Leading axes are independent campaigns of one shape (the replicates of a bootstrap,
    :func:`dronewind.diagnose.replicates.profiled_discrepancy`).

    Returns
    -------
    tau2, q, dof : numpy.ndarray
        (..., g): :math:`\hat\tau_f^2`, :math:`Q_f` and the expected :math:`Q_f` without discrepancy.
    """
    if x.shape[1]:
        lead, n_ok = w.shape[:-1], w.shape[-1]
        maker = _wls_batch(r_group.reshape(-1, n_ok), (1.0 / w).reshape(-1, n_ok), x)[0].reshape(*lead, n_ok, n_ok)
        b2 = (np.sqrt(w)[..., None] * np.einsum("...ij,...jk->...ik", maker, d)) ** 2
        e = np.einsum("...ij,...j->...i", maker, r_group)
    else:  # moments about zero: the residual maker is the identity (the likelihood ratio's every call)
        b2 = (np.sqrt(w)[..., None] * d) ** 2
        e = r_group
    col = b2.sum(axis=-2)  # (..., g, n p)
    dof = col @ var0 if var0.ndim == 1 else np.einsum("...gk,...k->...g", col, var0)
    expected0 = dof + np.sum(np.where(own, 0.0, col) * tau2_other[..., None, :], axis=-1)
    c = np.sum(np.where(own, col, 0.0), axis=-1)
    q = np.sum(w * e * e, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        tau2 = np.where(c > 0, np.maximum(0.0, (q - expected0) / c), 0.0)
    return tau2, q, dof


@dataclass(frozen=True)
class ProfiledFit:
    """A candidate's fit with the model discrepancy estimated under it (:func:`profiled_fit`).

    Attributes
    ----------
    fit : FitResult
        The fit under the profiled discrepancy.
    discrepancy : Discrepancy
        :math:`\\hat\\tau_f` of the residuals after the candidate's fit, its lost degrees of
        freedom accounted for.
    total_sigma : numpy.ndarray
        :math:`\\sqrt{\\sigma_{if}^2 + \\hat\\tau_f^2}` (n_flights, p).
    whitener : Whitener
        Whitening of the residual covariance with that discrepancy.
    lost_dof : numpy.ndarray
        Degrees of freedom the fit took from each feature's residuals about their offset
        (and trend) (p,): :math:`n - q` less the ``dof`` of :func:`profiled_discrepancy`.
    lr_profile : float
        The candidate's profile likelihood-ratio statistic (:func:`likelihood_ratio`, at least 0).
    """

    fit: FitResult
    discrepancy: Discrepancy
    total_sigma: np.ndarray
    whitener: Whitener
    lost_dof: np.ndarray
    lr_profile: float

    @property
    def lr_statistic(self) -> float:
        """:math:`\\chi^2(0) - \\chi^2(\\hat\\theta)` under the candidate's discrepancy (at least 0): the
        likelihood ratio given that discrepancy (the conditional statistic)."""
        return max(self.fit.chi2_baseline - self.fit.chi2, 0.0)


def profiled_fit(model: ResponseModel, y: np.ndarray, sigma: np.ndarray, corr: np.ndarray | None,
                 speed_ms: np.ndarray, start: tuple[np.ndarray, Whitener], interval: bool = False,
                 null: tuple[np.ndarray, float] | None = None,
                 plain: tuple[np.ndarray, Whitener] | None = None) -> ProfiledFit:
    """Fit a candidate with the model discrepancy profiled under it.

    A discrepancy estimated from the baseline's residuals holds every real mechanism's
    signature as scatter: it widens the covariance of every candidate's test and hides the
    mechanism it holds. Here the discrepancy is what the candidate leaves: the candidate is
    fitted under the starting covariance, :math:`\\tau_f^2` is estimated from the residuals
    after that fit (DerSimonian and Laird 1986, the fit's projection accounted for in the
    moments, :func:`profiled_discrepancy`), and the candidate is fitted again under
    :math:`C_i = D_i R^* D_i + \\mathrm{diag}(\\hat\\tau^2)` (Kennedy and O'Hagan 2001). One such
    step; :func:`~dronewind.diagnose.reference.null_reference` repeats it on every replicate, so the likelihood-ratio
    statistic keeps a calibrated reference whatever the step does to its distribution.

    The starting discrepancy holds the candidate's own signature where that signature is
    large and varies over the flights (a mount pitch's tilt difference alternates in sign with
    the wind direction): under it the fit weighs the features the candidate moves little and
    may stay at the baseline. With ``plain`` the step is also made from the covariance without
    discrepancy, and the one of larger profile likelihood (:func:`likelihood_ratio`) is kept:
    a maximum-likelihood choice between two starts, repeated on every replicate (the second
    step is completed only where its first fit is already the likelier, by more than rounding:
    :func:`more_likely`).

    Parameters
    ----------
    model : ResponseModel
        The candidate's responses.
    y, sigma : numpy.ndarray
        Measured features and their sampling errors (n_flights, p).
    corr : numpy.ndarray or None
        Shrunk feature correlation :math:`R^*` (p, p).
    speed_ms : numpy.ndarray
        Mean wind speed of every flight (n_flights,) [m s-1].
    start : (numpy.ndarray, Whitener)
        Total errors and whitener of the first fit (those of the discrepancy without the candidate).
    interval : bool
        Compute the discrepancy's Q-profile interval.
    null : (numpy.ndarray, float), optional
        :func:`null_likelihood` of ``y`` (the same for every candidate of a round); computed
        here when not given.
    plain : (numpy.ndarray, Whitener), optional
        A second start without discrepancy: the sampling errors and their whitening by
        :math:`R^*` alone (the goodness of fit's,
        :meth:`~dronewind.diagnose.evidence.CampaignEvidence.sampling_whitener`).

    Returns
    -------
    ProfiledFit
    """
    idx = np.arange(y.shape[0])
    best = _profiled_step(model, y, sigma, corr, speed_ms, start, idx, null)
    if plain is None:
        return best
    first = fit_parameters(model, y, plain[0], idx, plain[1])
    # the second step is completed only where its first fit is already the more likely one
    # (it then moves only to a likelier point): the same rule on every replicate
    if more_likely(likelihood_ratio(model, y, sigma, corr, speed_ms, first.theta, plain[0], null), best.lr_profile):
        other = _profiled_step(model, y, sigma, corr, speed_ms, plain, idx, null, first)
        if more_likely(other.lr_profile, best.lr_profile):
            best = other
    return best


#: Relative margin by which a profile likelihood-ratio statistic must exceed another to count as
#: larger in :func:`profiled_fit`'s choice of step (:func:`more_likely`).
TIE_MARGIN = 1e-9


def more_likely(statistic: float | np.ndarray, than: float | np.ndarray) -> bool | np.ndarray:
    r"""Whether a profile statistic is larger than another by more than rounding.

    :func:`profiled_fit` completes its second step where the first fit from the plain start is
    already the more likely, and keeps that step where it is the more likely. Where the first step
    ends at the plain start's own fit (its profiled discrepancy is zero), the two statistics are
    the same number computed along two routes and differ by rounding (1e-14 relative); comparing
    them as they stand would let that rounding pick the step. A tie, within
    :data:`TIE_MARGIN` x (1 + ``|than|``), counts as not larger, the same way on the campaign and on
    every bootstrap replicate.
    """
    return np.asarray(statistic) > np.asarray(than) + TIE_MARGIN * (1.0 + np.abs(np.asarray(than)))


def _profiled_step(model: ResponseModel, y: np.ndarray, sigma: np.ndarray, corr: np.ndarray | None,
                   speed_ms: np.ndarray, start: tuple[np.ndarray, Whitener], idx: np.ndarray,
                   null: tuple[np.ndarray, float] | None, first: FitResult | None = None) -> ProfiledFit:
    """One step of :func:`profiled_fit` from ``start`` (its first fit when made already): fit,
    discrepancy of what it leaves, fit again."""
    total0, white0 = start
    if first is None:
        first = fit_parameters(model, y, total0, idx, white0)
    resid = y - model.predict(first.theta, idx)
    with np.errstate(invalid="ignore"):
        excess = np.where(np.isfinite(total0) & np.isfinite(sigma), np.maximum(total0**2 - sigma**2, 0.0), 0.0)
    tau_start = np.sqrt(excess.max(axis=0))
    jac = fit_jacobian(model, first.theta, idx)
    disc = profiled_discrepancy(resid, sigma, speed_ms, jac, total0, tau_start)
    plain_dof = np.zeros(resid.shape[1])  # n - q of every feature (discrepancy()'s dof without a fit)
    for feats, rows, x, _ in _feature_groups(resid, sigma, speed_ms):
        plain_dof[feats] = rows.size - x.shape[1]
    lost = np.where(plain_dof > 0, plain_dof - disc.dof, 0.0)
    total, fcorr = flight_correlations(corr, sigma, disc.tau_or_zero())
    white = Whitener(fcorr)
    fit = fit_parameters(model, y, total, idx, white)
    lr = likelihood_ratio(model, y, sigma, corr, speed_ms, fit.theta, total, null)
    return ProfiledFit(fit, disc, total, white, lost, lr)


def _neg2_loglik(y: np.ndarray, prediction: np.ndarray, sigma: np.ndarray, corr: np.ndarray | None,
                 tau: np.ndarray) -> float:
    """:math:`\\chi^2 + \\log|C|` of the residuals under :math:`C_i = D_i R^* D_i + \\mathrm{diag}(\\tau^2)`."""
    total, fcorr = flight_correlations(corr, sigma, tau)
    white = Whitener(fcorr)
    # the used features depend on y and the errors only, so both hypotheses cover the same ones
    z = standardised_residuals(y, prediction, total)
    e = white(z)
    return float(np.nansum(e * e)) + log_determinant(total, white, np.isfinite(z))


def null_likelihood(y: np.ndarray, baseline: np.ndarray, sigma: np.ndarray, corr: np.ndarray | None,
                    speed_ms: np.ndarray | None) -> tuple[np.ndarray, float]:
    r"""The null hypothesis' side of :func:`likelihood_ratio`: its discrepancy and minus twice its log-likelihood.

    Parameters
    ----------
    y, baseline, sigma : numpy.ndarray
        Measured features, the forward baseline and the sampling errors (n_flights, p).
    corr : numpy.ndarray or None
        Shrunk feature correlation :math:`R^*` (p, p).
    speed_ms : numpy.ndarray or None
        Mean wind speed of every flight [m s-1].

    Returns
    -------
    tau : numpy.ndarray
        :math:`\hat\tau_0` of ``y - baseline`` about zero (p,) [feature units].
    neg2_loglik : float
        :math:`\chi^2(0; C_0) + \log|C_0|`.
    """
    tau = discrepancy(y - baseline, sigma, speed_ms, interval=False, about_zero=True).tau_or_zero()
    return tau, _neg2_loglik(y, baseline, sigma, corr, tau)


def likelihood_ratio(model: ResponseModel, y: np.ndarray, sigma: np.ndarray, corr: np.ndarray | None,
                     speed_ms: np.ndarray, theta: np.ndarray, fit_sigma: np.ndarray,
                     null: tuple[np.ndarray, float] | None = None) -> float:
    r"""Likelihood-ratio statistic of a fitted candidate, each hypothesis under the discrepancy it leaves.

    .. math:: \Lambda = \left[\chi^2(0; C_0) + \log|C_0|\right]
              - \left[\chi^2(\hat\theta; C_1) + \log|C_1|\right]

    minus twice the Gaussian log-likelihood of the residuals without the candidate less that
    with its fit, :math:`C_h = D_i R^* D_i + \mathrm{diag}(\hat\tau_h^2)` with the discrepancy
    :math:`\hat\tau_h` of each hypothesis' residuals taken about zero (:func:`discrepancy`,
    :func:`profiled_discrepancy` with ``about_zero``; the fit's degrees of freedom accounted
    for). Under the null hypothesis the discrepancy is the only departure from the model, so
    its moments are taken about zero: a common offset of the residuals is discrepancy unless
    the candidate explains it. The statistic compares the two hypotheses as a likelihood ratio
    does, each under its own covariance; with the misfits alone under the candidate's
    covariance, a candidate that absorbs a feature's flight-to-flight discrepancy would count
    that discrepancy as its signal, and its null distribution
    (:func:`~dronewind.diagnose.reference.null_reference`) would carry a long tail that costs every
    candidate of the family its power.

    Parameters
    ----------
    model, y, sigma, corr, speed_ms
        As :func:`profiled_fit`.
    theta : numpy.ndarray
        The candidate's fitted parameters.
    fit_sigma : numpy.ndarray
        The total errors the fit weighed (n_flights, p) (its projection, :func:`profiled_discrepancy`).
    null : (numpy.ndarray, float), optional
        :func:`null_likelihood` of ``y`` about the candidate's baseline, when already computed.

    Returns
    -------
    float
        :math:`\max(\Lambda, 0)`.
    """
    idx = np.arange(y.shape[0])
    tau0, neg2_null = null if null is not None else null_likelihood(
        y, model.predict(model.baseline_theta(), idx), sigma, corr, speed_ms)
    pred = model.predict(theta, idx)
    if model.n_parameters:
        tau1 = profiled_discrepancy(y - pred, sigma, speed_ms, fit_jacobian(model, theta, idx), fit_sigma, tau0,
                                    about_zero=True).tau_or_zero()
    else:
        tau1 = tau0
    return max(neg2_null - _neg2_loglik(y, pred, sigma, corr, tau1), 0.0)
