r"""Bootstrap references of the campaign diagnosis: what every statistic does when nothing is wrong.

The campaign diagnosis (:mod:`dronewind.diagnose.campaign`) tests every candidate, the goodness
of fit and the offset and trend of every feature; :mod:`dronewind.diagnose.calibration` estimates
the model discrepancy the tests carry and fits the candidates under it. This module gives the
seed scales the errors are made of and the distributions the statistics are referred to.

Reference distributions
-----------------------
The statistics (the likelihood-ratio statistic of every candidate, the goodness of fit, the
offset and trend tests of every feature) are referred to a parametric bootstrap over seeds
(:func:`null_reference`). Each replicate draws what the campaign drew, under the fitted null:
``n_seeds`` standardised baseline seeds and one standardised "measurement" per flight from
:math:`N(0, K R^* K)` (:math:`K` the seed scale of every feature), and a discrepancy from
:math:`N(0, \tau^2)`; then it repeats every estimate the diagnosis makes from them (the seed
scales, the shrunk correlation, the discrepancy) and every statistic. The reference therefore
holds the sampling error of the measured flight, that of the seeds' mean, the error of the
covariance estimated from the seeds and of the discrepancy estimated from the flights, the
bounds of the parameters and the piecewise-linear responses: none of the :math:`\chi^2`
approximations is needed. The candidates' statistics are computed on every replicate as on
the campaign, the discrepancy profiled under each. Family-wise p-values over candidates (or
features) are Westfall and Young's (1993) single-step min-p: the share of the :math:`B + 1`
draws (the replicates and the observed campaign) whose smallest marginal p-value over the
family is at most the observed one. The marginal p-values are pivotal tails
(:math:`\chi^2_k` of a likelihood-ratio statistic, the normal of a z statistic), so the
family-wise p-value resolves down to :math:`1/(B+1)`; ranks among the replicates alone could
not go below about :math:`m/(B+1)` for :math:`m` tests. Every p-value has the Monte-Carlo
standard error :math:`\sqrt{p(1-p)/(B+1)}` (:func:`mc_standard_error`).

References
----------
Westfall, P. H. and Young, S. S. (1993): Resampling-Based Multiple Testing. Wiley, New York.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from dronewind.diagnose import replicates
from dronewind.diagnose.calibration import discrepancy, null_likelihood, profiled_fit
from dronewind.diagnose.covariance import (
    Whitener,
    flight_correlations,
    inverse_factors,
    nearest_correlation,
    shrunk_correlation,
)
from dronewind.diagnose.fitting import ResponseModel, chi2, fit_parameters

__all__ = ["seed_scale", "flight_seed_scale", "offset_trend_z", "NullReference", "null_reference", "empirical_p",
           "familywise_p", "mc_standard_error", "smallest_p", "check_attainable", "DEFAULT_REPLICATES",
           "replicate_part", "joined_reference", "reference_arrays", "reference_from_arrays"]

#: Bootstrap replicates by default: a family-wise p-value of 0.01 then has a Monte-Carlo
#: standard error of 0.004 (binomial, sqrt(0.01 x 0.99 / 600)).
DEFAULT_REPLICATES = 600


def seed_scale(x: np.ndarray) -> np.ndarray:
    """Pooled within-flight standard deviation of standardised seed runs, per feature.

    Parameters
    ----------
    x : numpy.ndarray
        Baseline runs divided by their analytic errors (n_flights, n_seeds, p); NaN: missing.

    Returns
    -------
    numpy.ndarray
        :math:`k_f = \\sqrt{\\sum_{i,s} (x_{isf} - \\bar x_{if})^2 / \\sum_i (n_{if} - 1)}` (p,);
        NaN where no flight has two finite seeds. This turns a feature's analytic error into
        the seed-to-seed scatter; it is neither floored nor widened.
    """
    dev2, n_i = _seed_deviations(x)
    dof = np.where(n_i >= 2, n_i - 1, 0).sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sqrt(np.where(dof > 0, dev2.sum(axis=0) / np.maximum(dof, 1), np.nan))


def _seed_deviations(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sum of squared deviations from each flight's seed mean and the finite seeds, both (n_flights, p)."""
    finite = np.isfinite(x)
    n_i = finite.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.nansum(np.where(finite, x, 0.0), axis=1) / n_i
    return np.where(finite, (x - mean[:, None, :]) ** 2, 0.0).sum(axis=1), n_i


def flight_seed_scale(x: np.ndarray, min_seeds: int = 30) -> np.ndarray:
    """Per-flight standard deviation of standardised seed runs, per feature.

    Parameters
    ----------
    x : numpy.ndarray
        Baseline runs divided by their analytic errors (n_flights, n_seeds, p); NaN: missing.
    min_seeds : int
        Fewest seeds of one flight whose own scatter is used (29 degrees of freedom: a relative
        standard error of the scale of about 13 %).

    Returns
    -------
    numpy.ndarray
        :math:`k_{if} = \\sqrt{\\sum_s (x_{isf} - \\bar x_{if})^2 / (n_{if} - 1)}` (n_flights, p);
        NaN where the flight has fewer than ``min_seeds`` finite seeds of the feature (the
        bootstrap then uses the pooled :math:`k_f`, :func:`null_reference`).
    """
    dev2, n_i = _seed_deviations(x)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n_i >= max(int(min_seeds), 2), np.sqrt(dev2 / (n_i - 1)), np.nan)


def offset_trend_z(residual: np.ndarray, sigma: np.ndarray, speed_ms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Offset and trend statistics of every feature's residuals, with known variances.

    Parameters
    ----------
    residual, sigma : numpy.ndarray
        Residuals and their total errors (sampling and discrepancy) (n_flights, p).
    speed_ms : numpy.ndarray
        Mean wind speed of every flight (n_flights,) [m s-1].

    Returns
    -------
    mean_z, slope_z : numpy.ndarray
        (p,): the weighted mean residual over its standard error
        :math:`\\sum_i w_i r_i / \\sqrt{\\sum_i w_i}`, and the weighted least-squares slope
        against wind speed over its standard error (offset fitted with it); both standard
        normal when the model and its errors are right. The variances are the model's, not
        re-estimated from the residuals' scatter (a t-test over four flights with two degrees
        of freedom could hardly reject anything). NaN where too few flights.
    """
    r_all = np.asarray(residual, dtype=float)
    s_all = np.asarray(sigma, dtype=float)
    speed = np.asarray(speed_ms, dtype=float)
    p = r_all.shape[1]
    mean_z = np.full(p, np.nan)
    slope_z = np.full(p, np.nan)
    for f in range(p):
        ok = np.isfinite(r_all[:, f]) & np.isfinite(s_all[:, f]) & (s_all[:, f] > 0)
        if ok.sum() < 2:
            continue
        w = 1.0 / s_all[ok, f] ** 2
        mean_z[f] = float(np.sum(w * r_all[ok, f]) / np.sqrt(np.sum(w)))
        ok_s = ok & np.isfinite(speed)
        if ok_s.sum() >= 3 and np.ptp(speed[ok_s]) > 0:
            w = 1.0 / s_all[ok_s, f] ** 2
            u = speed[ok_s] - np.sum(w * speed[ok_s]) / np.sum(w)
            sxx = float(np.sum(w * u * u))
            slope_z[f] = float(np.sum(w * u * r_all[ok_s, f]) / np.sqrt(sxx))
    return mean_z, slope_z


def empirical_p(observed: float, replicates: np.ndarray) -> float:
    """Upper-tail bootstrap p-value :math:`(1 + \\#\\{T^* \\ge T\\}) / (1 + B)` (NaN replicates dropped)."""
    rep = np.asarray(replicates, dtype=float)
    rep = rep[np.isfinite(rep)]
    if not np.isfinite(observed):
        return 1.0
    return float((1 + np.sum(rep >= observed)) / (1 + rep.size))


def mc_standard_error(p: float, n_replicates: int) -> float:
    """Monte-Carlo standard error of a bootstrap p-value: :math:`\\sqrt{p(1-p)/(B+1)}`."""
    return float(np.sqrt(max(p * (1.0 - p), 0.0) / (n_replicates + 1))) if n_replicates > 0 else float("nan")


def smallest_p(n_replicates: int) -> float:
    """Smallest p-value :math:`1/(B+1)` a bootstrap of ``n_replicates`` can give."""
    return 1.0 / (n_replicates + 1)


def check_attainable(alpha: float, n_replicates: int) -> None:
    """Raise ValueError when a level ``alpha`` cannot be reached with ``n_replicates`` (:func:`smallest_p`)."""
    if n_replicates > 0 and smallest_p(n_replicates) >= alpha:
        raise ValueError(f"alpha {alpha:g} is not attainable with {n_replicates} bootstrap replicates "
                         f"(smallest p-value 1/(B+1) = {smallest_p(n_replicates):.4g}): use at least "
                         f"{int(np.ceil(1.0 / alpha))} replicates")


def familywise_p(observed: Mapping[str, float], replicates: Mapping[str, np.ndarray],
                 family: Sequence[str] | None = None,
                 marginal: Mapping[str, Callable[[np.ndarray], np.ndarray]] | None = None) -> dict[str, float]:
    """Westfall-Young single-step family-wise p-values of upper-tail statistics.

    Parameters
    ----------
    observed : mapping
        Test -> observed statistic (larger is more extreme).
    replicates : mapping
        Test -> its bootstrap replicates under the null (B,), the same replicates for every test.
    family : sequence of str, optional
        The tests the family-wise rate is taken over (default: all of ``observed``).
    marginal : mapping, optional
        Test -> a decreasing map of its statistic to an approximate p-value (e.g. the
        :math:`\\chi^2_k` upper tail of a likelihood-ratio statistic). Without it each test's
        marginal p-value is its rank among the observed and the replicates.

    Returns
    -------
    dict
        Test -> :math:`(1 + \\#\\{b: \\min_j u^*_{bj} \\le u_t\\}) / (1 + B)` (Westfall and Young 1993,
        single-step min-p, Algorithm 2.5; with ``marginal`` the min-p over pivotal
        transforms, their Section 2.6), :math:`u_t` the observed test's marginal p-value and
        :math:`u^*_{bj}` that of replicate :math:`b` of test :math:`j`. The marginal p-values
        need not be exact: the joint distribution of their minimum is the bootstrap's. Ranks
        count the observed statistic among the :math:`B + 1` (it is one draw of the null), so a
        replicate's rank p-value is on the observed's scale; the smallest family-wise p-value
        is then about :math:`m/(B+1)` for :math:`m` tests, while the continuous ``marginal``
        reaches :math:`1/(B+1)`.
    """
    names = list(observed if family is None else family)
    if not names:
        return {}
    mat = np.column_stack([np.asarray(replicates[t], dtype=float) for t in names])
    obs = np.array([float(observed[t]) for t in names])
    u = np.ones_like(mat)
    u_obs = np.ones(len(names))
    for j, t in enumerate(names):
        col = mat[:, j]
        ok = np.isfinite(col)
        if marginal is not None and t in marginal:
            u[ok, j] = marginal[t](col[ok])
            u_obs[j] = float(marginal[t](np.array([obs[j]]))[0]) if np.isfinite(obs[j]) else 1.0
            continue
        if not ok.any():
            continue
        srt = np.sort(col[ok])
        # members (replicates and the observed) at least as large as each replicate, itself included
        ge = ok.sum() - np.searchsorted(srt, col[ok], side="left") + (obs[j] >= col[ok]).astype(float)
        u[ok, j] = ge / (ok.sum() + 1)
        u_obs[j] = empirical_p(obs[j], col)
    min_u = np.min(u, axis=1)
    return {t: float((1 + np.sum(min_u <= u_obs[j] * (1 + 1e-12))) / (1 + min_u.size)) for j, t in enumerate(names)}


@dataclass
class NullReference:
    """Bootstrap replicates of every statistic under the fitted null (:func:`null_reference`).

    Attributes
    ----------
    n_replicates, seed : int
        Replicates drawn and the seed of their generator.
    baseline : numpy.ndarray
        The baseline prediction the replicates scatter about (n_flights, p).
    gof : numpy.ndarray
        Baseline misfit against the sampling error alone (B,).
    lr : dict
        Candidate -> conditional likelihood-ratio statistic (B,)
        (:attr:`~dronewind.diagnose.calibration.ProfiledFit.lr_statistic`).
    lr_profile : dict
        Candidate -> profile likelihood-ratio statistic (B,) (:func:`~dronewind.diagnose.calibration.likelihood_ratio`).
    mean_z, slope_z : numpy.ndarray
        Offset and trend statistics of every feature (B, p), as :func:`offset_trend_z`.
    y, sigma, total_sigma : list of numpy.ndarray
        Each replicate's measured features, sampling and total errors (for refits after naming).
    corr, flight_corr : list of numpy.ndarray
        Each replicate's shrunk correlation and per-flight correlations with discrepancy.
    y0, flight_corr0 : list
        The same replicates without the discrepancy (the goodness of fit's null), with their
        total errors and per-flight correlations.
    """

    n_replicates: int
    seed: int
    baseline: np.ndarray
    gof: np.ndarray
    lr: dict[str, np.ndarray] = field(default_factory=dict)
    lr_profile: dict[str, np.ndarray] = field(default_factory=dict)
    mean_z: np.ndarray = field(default_factory=lambda: np.empty((0, 0)))
    slope_z: np.ndarray = field(default_factory=lambda: np.empty((0, 0)))
    y: list[np.ndarray] = field(default_factory=list, repr=False)
    sigma: list[np.ndarray] = field(default_factory=list, repr=False)
    total_sigma: list[np.ndarray] = field(default_factory=list, repr=False)
    corr: list[np.ndarray | None] = field(default_factory=list, repr=False)
    flight_corr: list[np.ndarray] = field(default_factory=list, repr=False)
    y0: list[np.ndarray] = field(default_factory=list, repr=False)
    flight_corr0: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list, repr=False)

    def extended_gof(self, models: Sequence[tuple[ResponseModel, np.ndarray]]) -> np.ndarray:
        """Replicates of the extended model's misfit: the named causes refitted on each replicate without discrepancy.

        Parameters
        ----------
        models : sequence of (ResponseModel, numpy.ndarray)
            The named causes in naming order, with the flights' indices.

        Returns
        -------
        numpy.ndarray
            (B,): each replicate's misfit against the sampling error alone after removing the
            causes' fitted effects in turn, as the diagnosis removes them.
        """
        out = np.empty(self.n_replicates)
        for b in range(self.n_replicates):
            y = self.y0[b].copy()
            total, fcorr = self.flight_corr0[b]
            white_total = Whitener(fcorr)
            for model, idx in models:
                fit = fit_parameters(model, y, total, idx, white_total)
                effect = model.predict(fit.theta, idx) - model.baseline
                y = y - np.where(np.isfinite(effect), effect, 0.0)
            out[b] = float(chi2(y, self.baseline, self.sigma[b], Whitener(self.corr[b])).sum())
        return out


def null_reference(*, baseline: np.ndarray, analytic: np.ndarray, scale: np.ndarray, corr: np.ndarray | None,
                   truth_corr: np.ndarray | None = None, tau: np.ndarray, used: np.ndarray, n_seeds: int,
                   speed_ms: np.ndarray,
                   models: Mapping[str, ResponseModel], n_replicates: int = DEFAULT_REPLICATES,
                   seed: int = 0, progress: object | None = None,
                   flight_scale: np.ndarray | None = None, replicates: range | None = None) -> NullReference:
    """Parametric bootstrap over seeds of every statistic of the diagnosis (module docstring).

    Parameters
    ----------
    baseline : numpy.ndarray
        Mean of the baseline seeds (n_flights, p) [feature units].
    analytic : numpy.ndarray
        Analytic errors of the features (n_flights, p) [feature units].
    scale : numpy.ndarray
        Seed scale :math:`k_f` (p,) (:func:`seed_scale`).
    corr : numpy.ndarray or None
        Shrunk feature correlation :math:`R^*` (p, p).
    truth_corr : numpy.ndarray, optional
        Correlation the replicates are drawn with: the seeds' sample correlation, the unbiased
        estimate of the truth (default ``corr``). Drawing with the shrunk matrix would make the
        replicates' shrinkage act on weaker correlations than the data's, and understate how much
        whitening with a shrunk estimate inflates the misfit (measured on a known Gaussian model:
        mean misfit 32.8 against 30.4 of such replicates for 30 residuals,
        ``tests/diagnose/test_diagnose_calibration.py``). Its eigenvalues are raised to
        :data:`~dronewind.diagnose.covariance.MIN_EIGENVALUE` where needed.
    tau : numpy.ndarray
        Discrepancy standard deviation per feature (p,) [feature units].
    used : numpy.ndarray
        Features measured for every flight (n_flights, p) (bool).
    n_seeds : int
        Baseline seeds per flight.
    speed_ms : numpy.ndarray
        Mean wind speed of every flight (n_flights,) [m s-1].
    models : mapping
        Candidate -> response model (its effects are added to the baseline).
    n_replicates : int
        Bootstrap replicates B.
    seed : int
        Seed of the generator (the reference is reproducible).
    progress : object, optional
        Called with no argument after each replicate (a progress counter).
    flight_scale : numpy.ndarray, optional
        The seeds' own scatter on every flight :math:`k_{if}` (n_flights, p)
        (:func:`flight_seed_scale`): the replicates' seeds and measurement are drawn with it,
        while their errors are estimated with the pooled :math:`k_f` as the data's are. The
        analytic errors give the shape of the sampling error over flights well only for the
        features that are second moments of one series; for the mean-speed, direction and tilt
        differences and the correlations with the payload's rotation the seeds' scatter on one
        flight differs from :math:`k_f s_{if}` by factors of 0.3 to 2.5 within a campaign, which
        widens the distribution of every statistic beyond what pooled Gaussian replicates give.
        Default: :math:`k_f` on every flight.
    replicates : range, optional
        Only these replicates of the ``n_replicates`` (:func:`replicate_part`): the generator
        still draws the random numbers of every earlier one, so the parts of one reference,
        joined in order (:func:`joined_reference`), are the whole reference number for number.
        All by default.

    Returns
    -------
    NullReference
        The replicates asked for, in order (``n_replicates`` of them by default).
    """
    rng = np.random.default_rng(seed)
    n, p = baseline.shape
    k = np.where(np.isfinite(scale) & (scale > 0), scale, 1.0)
    k_draw = k[None, :] if flight_scale is None else np.where(np.isfinite(flight_scale) & (flight_scale > 0),
                                                             flight_scale, k[None, :])
    truth = corr if truth_corr is None else truth_corr
    r = np.eye(p) if truth is None else nearest_correlation(np.asarray(truth, dtype=float))
    chol = np.linalg.cholesky(r)
    tau0 = np.where(np.isfinite(tau), tau, 0.0)
    groups = np.repeat(np.arange(n), n_seeds)
    wanted = range(n_replicates) if replicates is None else replicates
    if wanted.step != 1 or wanted.start < 0 or wanted.stop > n_replicates:
        raise ValueError(f"replicates {wanted}: expected a contiguous range within range({n_replicates})")
    size = len(wanted)
    ref = NullReference(size, seed, baseline, np.empty(size),
                        lr={c: np.empty(size) for c in models},
                        lr_profile={c: np.empty(size) for c in models},
                        mean_z=np.empty((size, p)), slope_z=np.empty((size, p)))
    s = np.where(used, analytic, np.nan)
    chunk = _chunk_size(n, p)
    pending: list[tuple[int, tuple[np.ndarray, float]]] = []  # replicates whose batched fits are due
    for b_all in range(wanted.stop):
        normal = rng.standard_normal((n, n_seeds + 1, p))
        discrepancy_normal = rng.standard_normal((n, p))
        if b_all < wanted.start:
            continue  # an earlier part's replicate: its random numbers drawn, nothing computed
        b = b_all - wanted.start
        draws = (normal @ chol.T) * k_draw[:, None, :]
        seeds = np.where(used[:, None, :], draws[:, 1:, :], np.nan)
        k_b = seed_scale(seeds)
        k_b = np.where(np.isfinite(k_b) & (k_b > 0), k_b, 1.0)
        corr_b = shrunk_correlation(seeds.reshape(n * n_seeds, p), groups).matrix if n_seeds >= 2 else None
        # the goodness of fit's null has no discrepancy; the candidates' and the offset and trend
        # tests' null has the estimated one (a plug-in parametric bootstrap)
        resid0 = s * (draws[:, 0, :] - seeds.mean(axis=1))
        resid = resid0 + tau0[None, :] * discrepancy_normal
        sigma_b = np.sqrt(1.0 + 1.0 / n_seeds) * k_b[None, :] * s
        tau_b = discrepancy(resid, sigma_b, speed_ms, interval=False).tau_or_zero()
        total_b, fcorr_b = flight_correlations(corr_b, sigma_b, tau_b)
        y_b = baseline + resid
        white_plain = Whitener(corr_b)
        ref.gof[b] = float(chi2(baseline + resid0, baseline, sigma_b, white_plain).sum())
        tau0_b = discrepancy(resid0, sigma_b, speed_ms, interval=False).tau_or_zero()
        ref.y0.append(baseline + resid0)
        ref.flight_corr0.append(flight_correlations(corr_b, sigma_b, tau0_b))
        null_b = null_likelihood(y_b, baseline, sigma_b, corr_b, speed_ms)
        ref.mean_z[b], ref.slope_z[b] = (np.abs(a) for a in offset_trend_z(resid, total_b, speed_ms))
        ref.y.append(y_b)
        ref.sigma.append(sigma_b)
        ref.total_sigma.append(total_b)
        ref.corr.append(corr_b)
        ref.flight_corr.append(fcorr_b)
        pending.append((b, null_b))
        if len(pending) == chunk or b_all == wanted.stop - 1:
            _candidate_statistics(ref, pending, models, speed_ms, progress)
            pending = []
    return ref


def _chunk_size(n_flights: int, n_features: int) -> int:
    """Replicates whose candidate fits are made together: up to 100, fewer where a replicate's
    largest array of :func:`dronewind.diagnose.replicates.profiled_discrepancy` (features x flights
    x flights x features) would pass about 2 million numbers (16 MB) for the chunk."""
    per_replicate = max(n_features * n_flights * n_flights * n_features, 1)
    return int(max(1, min(100, 2_000_000 // per_replicate)))


def _candidate_statistics(ref: NullReference, pending: Sequence[tuple[int, tuple[np.ndarray, float]]],
                          models: Mapping[str, ResponseModel], speed_ms: np.ndarray,
                          progress: object | None) -> None:
    """Every candidate's likelihood-ratio statistics on the replicates ``pending`` (index, null likelihood).

    The candidates :func:`dronewind.diagnose.replicates.supported` are fitted on all of them at
    once (:func:`dronewind.diagnose.replicates.profiled_fit`), the others one replicate at a time
    (:func:`~dronewind.diagnose.calibration.profiled_fit`): the statistics are the same either way.
    """
    rows = [b for b, _ in pending]
    y = np.stack([ref.y[b] for b in rows])
    sigma = np.stack([ref.sigma[b] for b in rows])
    try:
        used = replicates.used_features(y, sigma)
    except ValueError:  # replicates of different used features: every candidate one replicate at a time
        used = np.zeros(y.shape[1:], dtype=bool)
    batched = {c: m for c, m in models.items() if used.any() and replicates.supported(m, used)}
    if batched:
        p = y.shape[2]
        corr = np.stack([np.eye(p) if (r := ref.corr[b]) is None else r for b in rows])
        total = np.stack([ref.total_sigma[b] for b in rows])
        start = (total, inverse_factors(np.stack([ref.flight_corr[b] for b in rows]), used, per_row=True))
        plain = (sigma, inverse_factors(corr, used))
        null = (np.stack([nb[0] for _, nb in pending]), np.array([nb[1] for _, nb in pending]))
        for c, model in batched.items():
            ref.lr[c][rows], ref.lr_profile[c][rows] = replicates.profiled_fit(model, y, sigma, corr, speed_ms,
                                                                               start, plain, null)
    single = {c: m for c, m in models.items() if c not in batched}
    for b, null_b in pending:
        if single:
            white_total, white_plain = Whitener(ref.flight_corr[b]), Whitener(ref.corr[b])
        for c, model in single.items():
            prof = profiled_fit(model, ref.y[b], ref.sigma[b], ref.corr[b], speed_ms,
                                (ref.total_sigma[b], white_total), null=null_b, plain=(ref.sigma[b], white_plain))
            ref.lr[c][b], ref.lr_profile[c][b] = prof.lr_statistic, prof.lr_profile
        if progress is not None:
            progress()  # type: ignore[operator]


def replicate_part(n_replicates: int, part: int, parts: int) -> range:
    """The replicates of one of ``parts`` near-equal parts of a bootstrap (``replicates`` of :func:`null_reference`).

    Examples
    --------
    >>> [replicate_part(600, k, 4) for k in range(4)]
    [range(0, 150), range(150, 300), range(300, 450), range(450, 600)]
    """
    if not 0 <= int(part) < int(parts):
        raise ValueError(f"part {part}: expected 0 <= part < {parts}")
    return range(int(part) * int(n_replicates) // int(parts), (int(part) + 1) * int(n_replicates) // int(parts))


def joined_reference(parts: Sequence[NullReference]) -> NullReference:
    """The parts of one bootstrap reference (:func:`null_reference` with ``replicates``), in order, as one.

    Raises
    ------
    ValueError
        No part, or parts of different seeds, baselines or candidates.
    """
    if not parts:
        raise ValueError("no part of a bootstrap reference to join")
    first = parts[0]
    for other in parts[1:]:
        if (other.seed != first.seed or set(other.lr) != set(first.lr)
                or not np.array_equal(other.baseline, first.baseline, equal_nan=True)):
            raise ValueError("the parts come from different bootstrap references (seed, baseline or candidates)")
    return NullReference(
        sum(r.n_replicates for r in parts), first.seed, first.baseline, np.concatenate([r.gof for r in parts]),
        lr={c: np.concatenate([r.lr[c] for r in parts]) for c in first.lr},
        lr_profile={c: np.concatenate([r.lr_profile[c] for r in parts]) for c in first.lr_profile},
        mean_z=np.concatenate([r.mean_z for r in parts]), slope_z=np.concatenate([r.slope_z for r in parts]),
        y=[a for r in parts for a in r.y], sigma=[a for r in parts for a in r.sigma],
        total_sigma=[a for r in parts for a in r.total_sigma], corr=[a for r in parts for a in r.corr],
        flight_corr=[a for r in parts for a in r.flight_corr], y0=[a for r in parts for a in r.y0],
        flight_corr0=[a for r in parts for a in r.flight_corr0])


def reference_arrays(ref: NullReference) -> dict[str, np.ndarray]:
    """A bootstrap reference as named arrays (for ``numpy.savez``; :func:`reference_from_arrays` reads them back).

    The per-replicate lists are stacked along a first axis; a replicate without a shrunk
    correlation (fewer than two seeds) keeps NaN in its place. Candidates' statistics are
    ``lr/<candidate>`` and ``lr_profile/<candidate>``.
    """
    b, (n, p) = ref.n_replicates, ref.baseline.shape

    def stacked(items: Sequence[np.ndarray | None], shape: tuple[int, ...]) -> np.ndarray:
        out = np.full((b, *shape), np.nan)
        for k, a in enumerate(items):
            if a is not None:
                out[k] = a
        return out

    arrays = {"n_replicates": np.array(b), "seed": np.array(ref.seed), "baseline": ref.baseline, "gof": ref.gof,
              "mean_z": ref.mean_z, "slope_z": ref.slope_z, "y": stacked(ref.y, (n, p)),
              "sigma": stacked(ref.sigma, (n, p)), "total_sigma": stacked(ref.total_sigma, (n, p)),
              "corr": stacked(ref.corr, (p, p)), "has_corr": np.array([c is not None for c in ref.corr], dtype=bool),
              "flight_corr": stacked(ref.flight_corr, (n, p, p)), "y0": stacked(ref.y0, (n, p)),
              "total_sigma0": stacked([t for t, _ in ref.flight_corr0], (n, p)),
              "flight_corr0": stacked([f for _, f in ref.flight_corr0], (n, p, p))}
    arrays.update({f"lr/{c}": v for c, v in ref.lr.items()})
    arrays.update({f"lr_profile/{c}": v for c, v in ref.lr_profile.items()})
    return arrays


def reference_from_arrays(arrays: Mapping[str, np.ndarray]) -> NullReference:
    """The bootstrap reference of :func:`reference_arrays`' arrays (e.g. a loaded ``.npz`` file)."""
    b = int(arrays["n_replicates"])
    has_corr = np.asarray(arrays["has_corr"], dtype=bool)
    return NullReference(
        b, int(arrays["seed"]), np.asarray(arrays["baseline"]), np.asarray(arrays["gof"]),
        lr={k.split("/", 1)[1]: np.asarray(v) for k, v in arrays.items() if k.startswith("lr/")},
        lr_profile={k.split("/", 1)[1]: np.asarray(v) for k, v in arrays.items() if k.startswith("lr_profile/")},
        mean_z=np.asarray(arrays["mean_z"]), slope_z=np.asarray(arrays["slope_z"]),
        y=list(np.asarray(arrays["y"])), sigma=list(np.asarray(arrays["sigma"])),
        total_sigma=list(np.asarray(arrays["total_sigma"])),
        corr=[c if ok else None for c, ok in zip(np.asarray(arrays["corr"]), has_corr, strict=True)],
        flight_corr=list(np.asarray(arrays["flight_corr"])), y0=list(np.asarray(arrays["y0"])),
        flight_corr0=list(zip(np.asarray(arrays["total_sigma0"]), np.asarray(arrays["flight_corr0"]), strict=True)))
