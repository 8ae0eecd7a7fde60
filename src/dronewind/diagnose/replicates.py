r"""A candidate's profiled fit on many bootstrap replicates of one campaign at once.

The parametric bootstrap of :func:`~dronewind.diagnose.reference.null_reference` repeats
:func:`~dronewind.diagnose.calibration.profiled_fit` for every candidate on every replicate: a
few bounded fits, the discrepancy they leave and two likelihoods each. The replicates of one
campaign share everything that fixes the shape of that work (the flights, the features each
flight uses, the feature groups of the discrepancy's moments, the response tables and their
cells) and differ only in their numbers. Here every step takes arrays with a leading replicate
axis ``B`` and does for all replicates in one numpy call what the single-campaign functions do
for one: the same formulas in the same order, so each replicate's statistics are those of
:func:`~dronewind.diagnose.calibration.profiled_fit` up to rounding (checked to 1e-9 relative in
``tests/diagnose/test_diagnose_replicates.py``).

Written here rather than taken from a library because the work is this project's own
statistic. Done one replicate at a time it is tens of thousands of numpy calls on arrays of a
few dozen numbers, whose call overhead, not their arithmetic, is the cost: on the example
plan's three-flight campaign (twelve candidates) a replicate takes 23 ms that way and 6 ms here.

What the replicates cannot share is solved per replicate: the bounded least squares of a cell
of several parameters (``scipy.optimize.lsq_linear``, :func:`~dronewind.diagnose.fitting.solve_cell`)
on the cells the branch and bound of
:func:`~dronewind.diagnose.fitting.piecewise_linear_least_squares` leaves. A candidate whose
responses lack a used feature (the fit then probes its residual function) is fitted per
replicate (:func:`supported`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from dronewind.diagnose.calibration import _feature_groups, group_moments, more_likely
from dronewind.diagnose.covariance import flight_correlations, inverse_factors
from dronewind.diagnose.fitting import (
    ResponseModel,
    _tabulated_cell_form,
    linear_cells,
    solve_cell,
    standardised_residuals,
    tabulated,
    unbounded_floor,
)

__all__ = ["ReplicateFits", "used_features", "supported", "fit", "fit_jacobian", "profiled_discrepancy",
           "neg2_loglik", "likelihood_ratio", "profiled_fit"]


@dataclass(frozen=True)
class ReplicateFits:
    """Fits of one candidate on B replicates (:func:`fit`).

    Attributes
    ----------
    theta : numpy.ndarray
        Parameters (B, m).
    chi2, chi2_baseline : numpy.ndarray
        Misfit at the fit and at the baseline (B,) (:class:`~dronewind.diagnose.fitting.FitResult`).
    """

    theta: np.ndarray
    chi2: np.ndarray
    chi2_baseline: np.ndarray

    def take(self, rows: np.ndarray) -> ReplicateFits:
        """The fits of the replicates ``rows``."""
        return ReplicateFits(self.theta[rows], self.chi2[rows], self.chi2_baseline[rows])


def used_features(y: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """The features every replicate uses (n, p): finite ``y`` and error > 0, the same in every replicate."""
    with np.errstate(invalid="ignore"):
        use = np.isfinite(y) & np.isfinite(sigma) & (sigma > 0)
    if not (use == use[0]).all():
        raise ValueError("replicates use different features: expected one pattern of used features for all")
    return use[0]


def supported(model: ResponseModel, used: np.ndarray) -> bool:
    """Whether the candidate's fit is made here: its cells are read off the tables, as
    :func:`~dronewind.diagnose.fitting.fit_parameters` reads them (:func:`~dronewind.diagnose.fitting.tabulated`
    on every flight, ``used`` (n, p))."""
    return tabulated(model, np.arange(used.shape[0]), used)


def _whitened_sum(factors: np.ndarray, z: np.ndarray, use: np.ndarray) -> np.ndarray:
    r""":math:`\sum_i |L_i^{-1} z_i|^2` over the used features of every replicate (B,)."""
    e = np.einsum("bipq,biq->bip", factors, np.where(use, z, 0.0))
    return np.einsum("bip,bip->b", e, e)


def fit(model: ResponseModel, y: np.ndarray, sigma: np.ndarray, factors: np.ndarray) -> ReplicateFits:
    """:func:`~dronewind.diagnose.fitting.fit_parameters` of a :func:`supported` candidate on every
    replicate (all flights).

    Parameters
    ----------
    model : ResponseModel
        The candidate's responses.
    y, sigma : numpy.ndarray
        Measured features and the errors the fit weighs (B, n, p).
    factors : numpy.ndarray
        The whitening's inverse Cholesky factors on the used features (B, n, p, p)
        (:func:`~dronewind.diagnose.covariance.inverse_factors`).

    Returns
    -------
    ReplicateFits
    """
    n_rep = y.shape[0]
    mask = used_features(y, sigma)

    def whiten_used(v: np.ndarray) -> np.ndarray:
        """Whitened standardised values, as (B, N) of the used ones."""
        return np.einsum("bipq,biq->bip", factors, v)[:, mask]

    base_theta = np.repeat(model.baseline_theta()[None], n_rep, axis=0)
    z_base = standardised_residuals(y, model.predict_each(base_theta), sigma)
    chi2_base = _whitened_sum(factors, z_base, mask)
    form = _tabulated_cell_form(model, y, sigma, np.arange(y.shape[1]), mask, whiten_used)
    if form is None:
        raise ValueError(f"{model.mechanism}: its cells are not read off the tables (replicates.supported)")
    base = model.baseline_theta()
    cells = linear_cells(model.parameters)
    r0s, jacs = [], []
    for segments, _, _, centre, _ in cells:
        at_zero, jac = form(segments)
        r0s.append(at_zero + jac @ centre)
        jacs.append(jac)
    r0 = np.stack(r0s, axis=1)  # (B, C, N)
    jac = np.stack(jacs, axis=1)  # (B, C, N, m)
    if model.n_parameters == 1:
        theta = _one_parameter_cells(cells, r0, jac[..., 0], float(base[0]))
    else:
        floors = unbounded_floor(r0, jac)  # (B, C)
        theta = np.empty((n_rep, model.n_parameters))
        for b in range(n_rep):  # branch and bound per replicate, as piecewise_linear_least_squares
            best: tuple[float, np.ndarray] | None = None
            for c in np.argsort(floors[b], kind="stable"):
                if best is not None and floors[b, c] > best[0]:
                    break
                _, lo, hi, centre, _ = cells[c]
                t, value = solve_cell(lo, hi, centre, r0[b, c], jac[b, c], base)
                if best is None or value < best[0]:
                    best = (value, t)
            assert best is not None
            theta[b] = best[1]
    z = standardised_residuals(y, model.predict_each(theta), sigma)  # the winner's misfit evaluated
    return ReplicateFits(theta, _whitened_sum(factors, z, mask), chi2_base)


def _one_parameter_cells(cells: Sequence[tuple], r0: np.ndarray, jac: np.ndarray, base: float) -> np.ndarray:
    """:func:`~dronewind.diagnose.fitting.solve_cell` of one parameter on every cell and replicate,
    and the cell of least misfit (the first of equal ones, as the cells are taken in order).

    r0, jac : (B, C, N); returns theta (B, 1).
    """
    lo = np.array([c[1][0] for c in cells])
    hi = np.array([c[2][0] for c in cells])
    centre = np.array([c[3][0] for c in cells])
    norm2 = np.einsum("bcn,bcn->bc", jac, jac)
    moving = np.sqrt(norm2) > 1e-12 * np.maximum(np.sqrt(norm2), 1e-300)
    with np.errstate(invalid="ignore", divide="ignore"):
        d = np.clip(np.einsum("bcn,bcn->bc", jac, -r0) / norm2, lo - centre, hi - centre)
    theta = np.where(moving, np.clip(centre + d, lo, hi), np.clip(base, lo, hi))
    r = r0 + jac * (theta - centre)[..., None]
    best = np.argmin(np.einsum("bcn,bcn->bc", r, r), axis=1)
    return theta[np.arange(theta.shape[0]), best][:, None]


def fit_jacobian(model: ResponseModel, theta: np.ndarray) -> np.ndarray:
    """:func:`~dronewind.diagnose.calibration.fit_jacobian` of every replicate (B, n, p, m).

    A parameter at a bound (an active constraint) has a zero column where the single-campaign
    function leaves it out; every use of the Jacobian here (:func:`profiled_discrepancy`) goes
    through a pseudo-inverse, to which a zero column is the same as none.
    """
    base = model.predict_each(theta)
    cols = []
    for k, par in enumerate(model.parameters):
        span = float(par.upper - par.lower)
        t = theta[:, k]
        free = (span > 0) & (t > par.lower + 1e-6 * span) & (t < par.upper - 1e-6 * span)
        step = 1e-3 * span * np.where(t + 1e-3 * span <= par.upper, 1.0, -1.0)
        moved = theta.copy()
        moved[:, k] += step
        with np.errstate(invalid="ignore", divide="ignore"):
            d = (model.predict_each(moved) - base) / step[:, None, None]
        cols.append(np.where(np.isfinite(d) & free[:, None, None], d, 0.0))
    return np.stack(cols, axis=3)


def profiled_discrepancy(residual: np.ndarray, sigma: np.ndarray, speed_ms: np.ndarray, jacobian: np.ndarray,
                         fit_sigma: np.ndarray, tau_start: np.ndarray, about_zero: bool = False) -> np.ndarray:
    """:func:`~dronewind.diagnose.calibration.profiled_discrepancy` of every replicate: :math:`\\hat\\tau` (B, p).

    Parameters
    ----------
    residual, sigma, fit_sigma : numpy.ndarray
        (B, n, p) [feature units].
    speed_ms : numpy.ndarray
        (n,) [m s-1].
    jacobian : numpy.ndarray
        :func:`fit_jacobian` (B, n, p, m).
    tau_start : numpy.ndarray
        (B, p) [feature units].
    about_zero : bool
        Moments about zero.
    """
    n_rep, n, p = residual.shape
    m = jacobian.shape[3]
    used = used_features(residual, fit_sigma)
    fs = np.where(used, fit_sigma, 1.0)
    a = np.where(used[..., None], jacobian / fs[..., None], 0.0).reshape(n_rep, n * p, m)
    k_map = (np.linalg.pinv(np.einsum("bim,bik->bmk", a, a)) @ a.transpose(0, 2, 1)) / fs.reshape(n_rep, 1, -1)
    k_map = np.where(used.reshape(1, 1, -1), k_map, 0.0)  # (B, m, n p)
    var0 = np.where(used, np.where(np.isfinite(sigma), sigma, 0.0) ** 2, 0.0).reshape(n_rep, -1)
    tau2_other = np.repeat(np.nan_to_num(tau_start, nan=0.0)[:, None, :] ** 2, n, axis=1)
    tau2_other = np.where(used, tau2_other, 0.0).reshape(n_rep, -1)
    used_features(residual, sigma)  # the moments' feature groups below are those of every replicate
    feature_of = np.tile(np.arange(p), n)
    tau2 = np.full((n_rep, p), np.nan)
    for feats, rows, x, _ in _feature_groups(residual[0], sigma[0], speed_ms, about_zero):
        g, nr = feats.size, rows.size
        # contiguous copies: numpy's summation kernels depend on the operands' memory layout, and a
        # replicate's numbers must not depend on how many replicates share the call
        w = np.ascontiguousarray(1.0 / sigma[:, rows][:, :, feats].transpose(0, 2, 1) ** 2)  # (B, g, n_ok)
        r_group = np.ascontiguousarray(residual[:, rows][:, :, feats].transpose(0, 2, 1))
        d = -np.einsum("bigm,bmk->bgik", np.ascontiguousarray(jacobian[:, rows][:, :, feats]), k_map)
        d[:, np.arange(g)[:, None], np.arange(nr)[None, :], rows[None, :] * p + feats[:, None]] += 1.0
        tau2[:, feats] = group_moments(w, r_group, d, x, feature_of[None, :] == feats[:, None], var0, tau2_other)[0]
    return np.sqrt(np.nan_to_num(tau2, nan=0.0))


def neg2_loglik(y: np.ndarray, prediction: np.ndarray, sigma: np.ndarray, corr: np.ndarray,
                tau: np.ndarray) -> np.ndarray:
    """:math:`\\chi^2 + \\log|C|` of every replicate (B,) (``_neg2_loglik`` of :mod:`dronewind.diagnose.calibration`).

    ``corr`` (B, p, p), ``tau`` (B, p), the others (B, n, p).
    """
    total, fcorr = flight_correlations(corr, sigma, tau)
    z = standardised_residuals(y, prediction, total)
    use = used_features(z, total)
    factors = inverse_factors(fcorr, use, per_row=True)
    # log|C| as covariance.log_determinant takes it, summed over each replicate's whole (n, p) block:
    # numpy's sum of the used values along one axis of several replicates is not the same number
    # as that of each replicate alone, which would make a replicate depend on its chunk
    t = np.where(use, total, 1.0)
    diag = np.diagonal(factors, axis1=2, axis2=3)
    log_det = 2.0 * np.sum(np.where(use, np.log(t), 0.0), axis=(1, 2)) - 2.0 * np.sum(
        np.where(use, np.log(np.where(use, diag, 1.0)), 0.0), axis=(1, 2))
    return _whitened_sum(factors, z, use) + log_det


def likelihood_ratio(model: ResponseModel, y: np.ndarray, sigma: np.ndarray, corr: np.ndarray, speed_ms: np.ndarray,
                     theta: np.ndarray, fit_sigma: np.ndarray, null: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """:func:`~dronewind.diagnose.calibration.likelihood_ratio` of every replicate (B,).

    ``null``: the replicates' :func:`~dronewind.diagnose.calibration.null_likelihood`, its
    discrepancy (B, p) and minus twice its log-likelihood (B,).
    """
    tau0, neg2_null = null
    pred = model.predict_each(theta)
    tau1 = profiled_discrepancy(y - pred, sigma, speed_ms, fit_jacobian(model, theta), fit_sigma, tau0,
                                about_zero=True)
    return np.maximum(neg2_null - neg2_loglik(y, pred, sigma, corr, tau1), 0.0)


@dataclass(frozen=True)
class _Step:
    """One profiled step of every replicate: the fit under the discrepancy it leaves and its profile statistic."""

    fit: ReplicateFits
    lr_profile: np.ndarray


def _profiled_step(model: ResponseModel, y: np.ndarray, sigma: np.ndarray, corr: np.ndarray, speed_ms: np.ndarray,
                   start: tuple[np.ndarray, np.ndarray], null: tuple[np.ndarray, np.ndarray],
                   first: ReplicateFits | None = None) -> _Step:
    """``_profiled_step`` of :mod:`dronewind.diagnose.calibration` on every replicate."""
    total0, factors0 = start
    if first is None:
        first = fit(model, y, total0, factors0)
    resid = y - model.predict_each(first.theta)
    with np.errstate(invalid="ignore"):
        excess = np.where(np.isfinite(total0) & np.isfinite(sigma), np.maximum(total0**2 - sigma**2, 0.0), 0.0)
    tau_start = np.sqrt(excess.max(axis=1))
    tau = profiled_discrepancy(resid, sigma, speed_ms, fit_jacobian(model, first.theta), total0, tau_start)
    total, fcorr = flight_correlations(corr, sigma, tau)
    second = fit(model, y, total, inverse_factors(fcorr, used_features(y, total), per_row=True))
    return _Step(second, likelihood_ratio(model, y, sigma, corr, speed_ms, second.theta, total, null))


def profiled_fit(model: ResponseModel, y: np.ndarray, sigma: np.ndarray, corr: np.ndarray, speed_ms: np.ndarray,
                 start: tuple[np.ndarray, np.ndarray], plain: tuple[np.ndarray, np.ndarray],
                 null: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~dronewind.diagnose.calibration.profiled_fit` (with its ``plain`` start) of a
    :func:`supported` candidate on every replicate.

    Parameters
    ----------
    model : ResponseModel
        The candidate's responses.
    y, sigma : numpy.ndarray
        Measured features and sampling errors (B, n, p).
    corr : numpy.ndarray
        Shrunk feature correlation of every replicate (B, p, p).
    speed_ms : numpy.ndarray
        Mean wind speed of every flight (n,) [m s-1].
    start, plain : (numpy.ndarray, numpy.ndarray)
        The total errors (B, n, p) of each start and their whitening's inverse Cholesky factors
        (B, n, p, p).
    null : (numpy.ndarray, numpy.ndarray)
        The replicates' null discrepancy (B, p) and minus twice the null log-likelihood (B,).

    Returns
    -------
    lr_statistic, lr_profile : numpy.ndarray
        (B,): :attr:`~dronewind.diagnose.calibration.ProfiledFit.lr_statistic` and
        :attr:`~dronewind.diagnose.calibration.ProfiledFit.lr_profile` of the kept step.
    """
    best = _profiled_step(model, y, sigma, corr, speed_ms, start, null)
    lr_stat = np.maximum(best.fit.chi2_baseline - best.fit.chi2, 0.0)
    lr_profile = best.lr_profile.copy()
    first = fit(model, y, plain[0], plain[1])
    # the second step is completed only where its first fit is already the more likely one
    ahead = np.flatnonzero(more_likely(likelihood_ratio(model, y, sigma, corr, speed_ms, first.theta, plain[0], null),
                                       lr_profile))
    if ahead.size:
        other = _profiled_step(model, y[ahead], sigma[ahead], corr[ahead], speed_ms,
                               (plain[0][ahead], plain[1][ahead]), (null[0][ahead], null[1][ahead]), first.take(ahead))
        better = more_likely(other.lr_profile, lr_profile[ahead])
        rows = ahead[better]
        lr_stat[rows] = np.maximum(other.fit.chi2_baseline[better] - other.fit.chi2[better], 0.0)
        lr_profile[rows] = other.lr_profile[better]
    return lr_stat, lr_profile
