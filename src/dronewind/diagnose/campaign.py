r"""Campaign-level diagnosis: baseline misfit, candidates, named causes, ambiguity.

Input: for every payload flight, the measured residual features and the forward-model
runs of :func:`dronewind.diagnose.forward.probe_runs`. Output: the ``diagnosis.json``
structure of the data contract (docs/data-contract.md) plus the evidence a report needs.

Sampling errors: every feature has an analytic standard error from
:mod:`dronewind.diagnose.features` (Ghirardelli et al. 2025, Eqs 10-13, and their analogues)
computed on the forward runs. The forward model's baseline seeds calibrate it: for each
feature the scale factor

.. math:: k_f^2 = \frac{\sum_i \sum_s (b_{i,s,f} - \bar b_{i,f})^2 / s_{i,f}^2}
                       {\sum_i (n_{seeds} - 1)}

(deviations of the baseline seeds from their flight's mean, pooled over flights) turns the
analytic error :math:`s_{i,f}` into the realisation-to-realisation scatter of that feature.
The sampling error of a residual is
:math:`\sigma_{i,f}^2 = (1 + 1/n_{seeds})\,k_f^2\,s_{i,f}^2`: one realisation measured, the
mean of :math:`n_{seeds}` predicted. The errors are neither floored nor widened: what the
forward model cannot reproduce is the model discrepancy, estimated and reported as such.

Correlated errors: the same seed deviations, divided by the analytic errors, give the pooled
feature correlation matrix, shrunk toward the identity with the Schäfer-Strimmer analytic
intensity (:mod:`dronewind.diagnose.covariance`). The number of seeds
(:func:`dronewind.diagnose.probes.baseline_seeds`) gives the campaign 640 pooled degrees of
freedom, so that the intensity stays below about 0.3 and real correlations are kept.

Model discrepancy (:mod:`dronewind.diagnose.calibration`): the scatter of every feature's
residuals across flights beyond its sampling error, about a common offset and trend, is
estimated per feature (Kennedy and O'Hagan 2001; DerSimonian and Laird 1986) and added to the
residual covariance, :math:`C_i = D_i R^* D_i + \mathrm{diag}(\tau^2)`. It is profiled under
every candidate: estimated from the residuals the candidate's fit leaves, with the degrees of
freedom the fit took (the leverage of its parameters) accounted for
(:func:`dronewind.diagnose.calibration.profiled_fit`), so that a mechanism's own signature is
not counted as discrepancy against it, and a cause is named only where its signature across
flights stands above the misfit it does not describe. The baseline's discrepancy (no candidate)
is reported in ``error_model``, each candidate's under ``candidates[].discrepancy_sd``.

Test statistic of a candidate: its profile likelihood ratio
(:func:`dronewind.diagnose.calibration.likelihood_ratio`), minus twice the Gaussian
log-likelihood of the residuals without the candidate less that with its fit, each hypothesis
under the discrepancy its own residuals leave (taken about zero: under the null hypothesis a
common offset is discrepancy unless a candidate explains it), the log-determinants of the two
covariances included. The candidate's fit and its held-out gain use the profiled covariance
above. With the misfits alone under the candidate's covariance, the statistic's null
distribution grows a long tail wherever a feature carries a large discrepancy (a candidate's
fit absorbs part of a drawn discrepancy and counts its offset as signal), and in the
family-wise min-p that tail sets every candidate's p-value; the profile statistic's stays
close to :math:`\chi^2_k`. Its price: on few flights without discrepancy, an offset or a
trend of a feature counts for less than in the misfits' difference, since discrepancy could
also have made it.

Reference distributions: the likelihood-ratio statistic of every candidate, the goodness of
fit and the offset and trend tests of ``unexplained`` are referred to a parametric bootstrap
over seeds that repeats every estimate above on each replicate, the profiled discrepancy of
every candidate included (:func:`dronewind.diagnose.reference.null_reference`). Candidates
are tested by the Westfall and Young (1993) single-step min-p over the candidates of a naming
round, each statistic through its :math:`\chi^2_k` tail and the observed campaign counted among
the :math:`B + 1` draws, so that p-values are :math:`(1 + \#\{T^* \ge T\})/(B + 1)`-type and
the smallest is :math:`1/(B+1)`; a level below that is refused. Every bootstrap p-value is
reported with its Monte-Carlo standard error :math:`\sqrt{p(1-p)/(B+1)}` (``p_mc_se``).

The diagnosis is split by what each part holds: the error model and the evidence arrays
(:mod:`dronewind.diagnose.evidence`), the naming rounds (:mod:`dronewind.diagnose.naming`),
goodness of fit and ``unexplained`` (:mod:`dronewind.diagnose.fit_quality`) and the
``diagnosis.json`` record (:mod:`dronewind.diagnose.record`); this module gathers their
public names.

Naming: a significant candidate is named when its held-out gain reaches ``diagnosis.min_gain``;
a further cause only when it raises the held-out gain of the named set by more than that
rise's uncertainty (from the flights' held-out misfits) and by ``diagnosis.min_gain``. A
candidate whose estimate sits at a catalog bound is not identified and never named
(``not_identified``). Ambiguity is computed from the probes' responses: a candidate whose
whitened response over the campaign's flights reproduces a named cause's fitted effect (cosine
of at least :data:`AMBIGUITY_COSINE`) is listed in that cause's ambiguity set.

Measured conditions: a sonic-INS lag that the chain measured for every flight is a condition
of the forward runs (``conditions["sonic_ins_lag_s"]``), not evidence: its feature
``lag_sonic_ins_s`` leaves the misfit and ``sonic_ins_lag`` leaves the candidates
(:data:`CONDITIONED`); ``diagnosis.json`` reports the flights' lags under
``measured_conditions``.
"""

from dronewind.diagnose.evidence import (
    CONDITIONED,
    N_LISTED_CORRELATIONS,
    PARAMETER_SUBSETS,
    CampaignEvidence,
    assemble,
    error_model,
    feature_correlation,
    measured_conditions,
)
from dronewind.diagnose.fit_quality import (
    baseline_metrics,
    goodness_of_fit,
    residual_table,
    summarise,
    unexplained_features,
    wind_speed_slopes,
)
from dronewind.diagnose.naming import (
    AMBIGUITY_COSINE,
    AT_BOUND,
    FEATURE_ALIASES,
    MIN_GAIN,
    SINGLE_FEATURE_SHARE,
    UNCATALOGUED_ALIASES,
    DiagnosisResult,
    Withheld,
    best_variants,
    caveats,
    combined_prediction,
    diagnose,
    feature_shares,
    n_tests,
    named_mechanisms,
    reference_part,
    response_ambiguity,
    simplest_variant,
    single_feature_alias,
)
from dronewind.diagnose.record import to_json, withheld_json

__all__ = ["CampaignEvidence", "assemble", "CONDITIONED", "AMBIGUITY_COSINE", "AT_BOUND", "MIN_GAIN",
           "N_LISTED_CORRELATIONS", "response_ambiguity", "measured_conditions", "diagnose", "DiagnosisResult",
           "goodness_of_fit", "unexplained_features", "UNCATALOGUED_ALIASES", "FEATURE_ALIASES",
           "SINGLE_FEATURE_SHARE", "feature_shares", "single_feature_alias", "caveats", "Withheld", "withheld_json",
           "PARAMETER_SUBSETS", "n_tests", "simplest_variant", "error_model", "feature_correlation", "to_json",
           "best_variants", "baseline_metrics", "residual_table", "wind_speed_slopes", "combined_prediction",
           "named_mechanisms", "summarise", "reference_part"]
