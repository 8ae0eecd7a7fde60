r"""Scoring fitted catalog mechanisms honestly: held-out prediction, significance, ambiguity.

On top of the fits of :mod:`dronewind.diagnose.fitting`:

* :func:`score_candidate` refits with each flight left out in turn and predicts it: the
  *gain* is the relative reduction of the held-out misfit against the baseline;
* significance combines a likelihood-ratio test on the fitted flights (the misfit drop
  against :math:`\chi^2_k`, :math:`k` the number of parameters, Bonferroni-corrected for
  the number of candidates tried) with a positive held-out gain;
* :func:`ambiguity_sets` groups significant candidates whose held-out predictions the
  data cannot tell apart.

The misfits are those of :mod:`dronewind.diagnose.fitting`, whitened by the feature correlation.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.stats

from dronewind.diagnose.covariance import Whitener
from dronewind.diagnose.fitting import FitResult, ResponseModel, _whitener, chi2, fit_parameters

__all__ = ["CandidateScore", "score_candidate", "ambiguity_sets"]


@dataclass(frozen=True)
class CandidateScore:
    """A fitted and cross-validated candidate mechanism."""

    mechanism: str
    parameter_names: tuple[str, ...]
    fit: FitResult
    heldout_chi2: np.ndarray
    heldout_chi2_baseline: np.ndarray
    heldout_prediction: np.ndarray
    gain: float
    lr_statistic: float
    p_value: float
    significant: bool
    #: The profile likelihood-ratio statistic (:func:`dronewind.diagnose.calibration.likelihood_ratio`),
    #: where the campaign diagnosis computed it.
    lr_profile: float = float("nan")

    def estimate(self) -> dict[str, float]:
        """Fitted parameters by name."""
        return {n: float(v) for n, v in zip(self.parameter_names, self.fit.theta, strict=True)}

    def uncertainty(self) -> dict[str, float]:
        """Standard errors of the fitted parameters by name."""
        return {n: float(v) for n, v in zip(self.parameter_names, self.fit.theta_std, strict=True)}


def score_candidate(
    model: ResponseModel,
    y: np.ndarray,
    sigma: np.ndarray,
    alpha: float = 0.01,
    n_candidates: int = 1,
    corr: np.ndarray | Whitener | None = None,
) -> CandidateScore:
    """Fit a mechanism on all flights and cross-validate it leaving one flight out.

    Parameters
    ----------
    model : ResponseModel
        Tabulated responses.
    y, sigma : numpy.ndarray
        Measured features and their standard errors, ``(n_flights, n_features)``.
    alpha : float
        Family-wise false-alarm rate of the likelihood-ratio test.
    n_candidates : int
        Number of candidates tried (Bonferroni correction: each is tested at
        ``alpha / n_candidates``).
    corr : numpy.ndarray or Whitener, optional
        Feature correlation matrix used in every misfit (module docstring).

    Returns
    -------
    CandidateScore
        The fit on all flights, the held-out misfits, the gain

        .. math:: G = 1 - \\frac{\\sum_i \\chi^2_{i,\\mathrm{held-out}}(m)}{\\sum_i \\chi^2_{i}(0)},

        and significance: the misfit drop on the fitted flights,
        :math:`\\Lambda = \\chi^2(0) - \\chi^2(\\hat\\theta)`, exceeds the
        :math:`1 - \\alpha/M` quantile of :math:`\\chi^2_k`, and :math:`G > 0`.
    """
    n = y.shape[0]
    flights = np.arange(n)
    white = _whitener(corr)
    fit = fit_parameters(model, y, sigma, flights, white)
    held = np.empty(n)
    held_base = np.empty(n)
    prediction = np.empty_like(y, dtype=float)
    base_theta = model.baseline_theta()
    for i in range(n):
        train = flights[flights != i] if n > 1 else flights
        theta = fit_parameters(model, y, sigma, train, white).theta if model.n_parameters else base_theta
        one = np.array([i])
        prediction[i] = model.predict(theta, one)[0]
        held[i] = chi2(y[one], prediction[i:i + 1], sigma[one], white.subset(one))[0]
        held_base[i] = chi2(y[one], model.predict(base_theta, one), sigma[one], white.subset(one))[0]
    total_base = float(held_base.sum())
    gain = 1.0 - float(held.sum()) / total_base if total_base > 0 else 0.0
    lr = max(fit.chi2_baseline - fit.chi2, 0.0)
    k = model.n_parameters
    p_value = float(scipy.stats.chi2.sf(lr, k)) if k else 1.0
    significant = bool(k and p_value < alpha / max(n_candidates, 1) and gain > 0)
    return CandidateScore(
        mechanism=model.mechanism,
        parameter_names=tuple(p.name for p in model.parameters),
        fit=fit,
        heldout_chi2=held,
        heldout_chi2_baseline=held_base,
        heldout_prediction=prediction,
        gain=gain,
        lr_statistic=lr,
        p_value=p_value,
        significant=significant,
    )


def ambiguity_sets(
    scores: Sequence[CandidateScore],
    y: np.ndarray,
    sigma: np.ndarray,
    threshold_chi2: float = 4.0,
    corr: np.ndarray | Whitener | None = None,
) -> list[list[str]]:
    """Group significant candidates the data cannot tell apart.

    Two candidates are indistinguishable when their fitted predictions differ, over all
    flights and features, by less than ``threshold_chi2`` in units of the sampling
    errors (:math:`\\sum ((\\hat y_a - \\hat y_b)/s)^2 <` threshold, 4 ≈ a 2σ difference),
    or when their held-out misfits differ by less than that.

    Parameters
    ----------
    scores : sequence of CandidateScore
        Scored candidates (only significant ones are grouped).
    y, sigma : numpy.ndarray
        Measured features and their standard errors (to mask missing features).
    threshold_chi2 : float
        Distinguishability threshold.
    corr : numpy.ndarray or Whitener, optional
        Feature correlation matrix: the prediction difference is whitened with it.

    Returns
    -------
    list of list of str
        Groups (each of two or more names), best candidate first in each group.
    """
    sig = sorted((s for s in scores if s.significant), key=lambda s: -s.gain)
    groups: list[list[str]] = []
    used: set[str] = set()
    white = _whitener(corr)
    for i, a in enumerate(sig):
        if a.mechanism in used:
            continue
        group = [a.mechanism]
        for b in sig[i + 1:]:
            if b.mechanism in used:
                continue
            # the prediction difference as a "residual": used where y is measured
            diff = a.heldout_prediction - b.heldout_prediction
            d = chi2(np.where(np.isfinite(y), diff, np.nan), np.zeros_like(diff), sigma, white)
            close_predictions = float(np.sum(d)) < threshold_chi2
            close_misfit = abs(float(a.heldout_chi2.sum() - b.heldout_chi2.sum())) < threshold_chi2
            if close_predictions or close_misfit:
                group.append(b.mechanism)
        if len(group) > 1:
            groups.append(group)
            used.update(group)
    return groups
