r"""The campaign's error model: evidence arrays, calibrated sampling errors, feature correlation.

Input: for every payload flight, the measured residual features and the forward-model runs of
:func:`dronewind.diagnose.forward.probe_runs`; output: :class:`CampaignEvidence`, the arrays and
response models every test of the diagnosis (:mod:`dronewind.diagnose.naming`) reads, and the
``error_model`` entry of ``diagnosis.json`` that states them. The equations are in
:mod:`dronewind.diagnose.campaign`.
"""

from __future__ import annotations

import warnings
from collections import defaultdict
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from dronewind.diagnose.calibration import MIN_FLIGHTS_TREND, UNEXPLAINED_ALPHA
from dronewind.diagnose.covariance import ShrunkCorrelation, Whitener, flight_correlations, shrunk_correlation
from dronewind.diagnose.features import FEATURES
from dronewind.diagnose.fitting import (
    ParameterResponse,
    ResponseModel,
)
from dronewind.diagnose.probes import MIN_SEEDS, baseline_level
from dronewind.diagnose.reference import flight_seed_scale, seed_scale
from dronewind.mechanisms import get_mechanism

if TYPE_CHECKING:
    from dronewind.diagnose.naming import DiagnosisResult

__all__ = ["CONDITIONED", "PROCESSING_LAG_KEY", "MEASURED_ATMOSPHERE_CONDITIONED",
           "PARAMETER_SUBSETS", "N_LISTED_CORRELATIONS", "CampaignEvidence", "assemble",
           "feature_correlation", "error_model", "measured_conditions", "finite_or_none"]

#: Conditions of the forward runs measured by the chain, which therefore cannot be evidence:
#: condition key -> (the feature it fixes, the mechanism it stands for).
CONDITIONED: dict[str, tuple[str, str]] = {"sonic_ins_lag_s": ("lag_sonic_ins_s", "sonic_ins_lag")}
#: Key of a flight's estimated sonic-INS processing lag [s] in :func:`measured_conditions`: the
#: lag the forward runs simulate (:func:`dronewind.diagnose.probe_runs.simulated_sonic_ins_lag_s`).
PROCESSING_LAG_KEY = "processing_lag_s"
#: Features that the measured atmosphere fixes: with the forward runs constrained by the
#: reference mast's measured record (``atmosphere: measured``) every seed and every probe
#: reproduces that record at the mast, and a mechanism acting on the mast is read through
#: it (:mod:`dronewind.diagnose.forward_atmosphere`), so a feature of the mast alone is the
#: record's own value whatever the candidate. Its residual measures only how exactly the
#: forward chain cuts the record (the 8-Hz L3 of a run may hold a sample or two fewer, as
#: the drone-mast lag falls on the grid), not the sampling error its seed scatter stands for:
#: the band ratio of a 6-min record at 3.5 m/s moves from 1.60 to 1.80 when one sample is cut
#: (its log bins in the band hold two or three Welch ordinates), while its seed scatter is
#: 0.01. It is a condition of the forward runs, like the lag.
MEASURED_ATMOSPHERE_CONDITIONED: tuple[str, ...] = ("sw_su_mast",)
#: Correlations listed in ``error_model`` (the largest in absolute value).
N_LISTED_CORRELATIONS = 8
#: Variants of a candidate that fit only some of its parameters, the others held at their
#: "off" level: variant -> (candidate, fitted parameters). They come from the candidate's own
#: probe runs (no run of their own). A mount misalignment is probed in roll, pitch and yaw,
#: but a roll tilts the sonic across the flow, which no feature sees (roll estimated
#: 1.2 +- 3.4 degree for a hidden -4 degree, ``benchmarks/results/hidden_identifiability.json``):
#: fitting all three angles spends two degrees of freedom of the likelihood-ratio test on
#: angles the data do not constrain, and hidden pitches of 3.5 and 7.8 degree, estimated at
#: 2.8 +- 0.7 and 5.3 +- 1.3 degree, stayed below the test's level (LR 16.3 on 3 degrees of
#: freedom, p = 0.00096). The pitch alone is tested on one.
PARAMETER_SUBSETS: dict[str, tuple[str, tuple[str, ...]]] = {
    "mount_misalignment@roll_deg=0,yaw_deg=0": ("mount_misalignment", ("pitch_deg",)),
}

def _vec(d: Mapping[str, Mapping[str, float | None]], key: str) -> np.ndarray:
    """Feature vector (FEATURES order, NaN for None) of ``d[key]`` (a ``features_to_dict`` part)."""
    values = d[key]
    return np.array([np.nan if (v := values.get(f)) is None else float(v) for f in FEATURES])


@dataclass
class CampaignEvidence:
    """Measured features, forward predictions and errors of all flights (arrays over flights x features).

    ``sigma`` is the sampling error of every residual; ``tau`` the model discrepancy per
    feature (zero until :func:`diagnose` estimates it); ``total_sigma`` and :meth:`whitener`
    combine both (module docstring).
    """

    flights: list[str]
    y: np.ndarray
    sigma: np.ndarray
    analytic_sigma: np.ndarray
    scale: np.ndarray
    baseline: np.ndarray
    baseline_seed0: np.ndarray
    conditions: list[dict[str, Any]]
    models: dict[str, ResponseModel] = field(default_factory=dict)
    fixed: dict[str, dict[str, float]] = field(default_factory=dict)
    mechanism_of: dict[str, str] = field(default_factory=dict)
    correlation: ShrunkCorrelation | None = None
    n_seeds: int = 0
    #: features left out of the evidence because a measured condition fixes them (:data:`CONDITIONED`)
    conditioned: list[str] = field(default_factory=list)
    tau: np.ndarray | None = None
    #: the seeds' own scale on every flight :math:`k_{if}` (n_flights, p), which the bootstrap
    #: draws its replicates with (:func:`~dronewind.diagnose.reference.flight_seed_scale`)
    flight_scale: np.ndarray | None = None
    #: flight -> the sonic-INS processing lag its forward runs simulate [s] (:func:`measured_conditions`)
    processing_lag_s: dict[str, float] = field(default_factory=dict)
    _white: Whitener | None = field(default=None, init=False, repr=False, compare=False)
    _sampling_white: Whitener | None = field(default=None, init=False, repr=False, compare=False)

    @property
    def corr(self) -> np.ndarray | None:
        """Shrunk feature correlation matrix (None: independent errors)."""
        return None if self.correlation is None else self.correlation.matrix

    @property
    def speed_ms(self) -> np.ndarray:
        """Mean wind speed of every flight at the reference mast [m s-1]."""
        return np.array([c.get("mean_speed_ms", np.nan) for c in self.conditions], dtype=float)

    @property
    def total_sigma(self) -> np.ndarray:
        """:math:`\\sqrt{\\sigma_{if}^2 + \\tau_f^2}`: the residual error with the discrepancy [feature units]."""
        if self.tau is None:
            return self.sigma
        return np.sqrt(self.sigma**2 + np.asarray(self.tau)[None, :] ** 2)

    def set_discrepancy(self, tau: np.ndarray | None) -> None:
        """Use ``tau`` (p,) [feature units] as the model discrepancy of every test (None: none)."""
        self.tau = None if tau is None or not np.any(np.asarray(tau) > 0) else np.asarray(tau, dtype=float)
        self._white = None

    def whitener(self) -> Whitener:
        """Whitening of residuals divided by :attr:`total_sigma` (per flight when a discrepancy is set)."""
        if self._white is None:
            if self.tau is None:
                self._white = self.sampling_whitener()
            else:
                self._white = Whitener(flight_correlations(self.corr, self.sigma, self.tau)[1])
        return self._white

    def sampling_whitener(self) -> Whitener:
        """Whitening by :attr:`corr` alone: residuals divided by :attr:`sigma` (the goodness of fit)."""
        if self._sampling_white is None:
            self._sampling_white = Whitener(self.corr)
        return self._sampling_white


def _calibrated_errors(y: np.ndarray, measured_sigma: np.ndarray, runs: np.ndarray,
                       run_sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """Sampling errors of the residuals: the forward runs' analytic errors scaled by the seeds' scatter.

    Parameters
    ----------
    y, measured_sigma : numpy.ndarray
        Measured features and their analytic errors, (n_flights, n_features): the measured
        errors stand in only where the forward runs give none.
    runs, run_sigma : numpy.ndarray
        Baseline forward runs and their analytic errors, (n_flights, n_seeds, n_features).

    Returns
    -------
    sigma : numpy.ndarray
        Error of a residual, :math:`\\sqrt{1 + 1/n_{seeds}}\\,k_f\\,s_{if}` (module docstring).
    analytic : numpy.ndarray
        The analytic errors :math:`s_{if}`: the mean over the seeds of the forward runs'.
    scale : numpy.ndarray
        Per-feature factor :math:`k_f` from analytic to seed scatter (1 with fewer than two seeds).
    flight_scale : numpy.ndarray or None
        The same factor of every flight's own seeds :math:`k_{if}` (NaN with fewer than
        :data:`~dronewind.diagnose.probes.MIN_SEEDS`; None with fewer than two seeds), which the
        bootstrap draws its replicates with.
    """
    n_seeds = runs.shape[1]
    analytic = np.nanmean(run_sigma, axis=1)
    analytic = np.where(np.isfinite(analytic) & (analytic > 0), analytic, measured_sigma)
    flight_scale = None
    if n_seeds >= 2:
        with np.errstate(invalid="ignore", divide="ignore"):
            x = runs / np.where(analytic > 0, analytic, np.nan)[:, None, :]
        scale = seed_scale(x)
        flight_scale = flight_seed_scale(x, MIN_SEEDS)
    else:
        scale = np.ones(y.shape[1])
    scale = np.where(np.isfinite(scale) & (scale > 0), scale, 1.0)
    sigma = np.sqrt(1.0 + 1.0 / max(n_seeds, 1)) * scale[None, :] * analytic
    return sigma, analytic, scale, flight_scale


def _probe_tables(ev: CampaignEvidence, forward: Mapping[str, Mapping[str, Any]]
                  ) -> dict[str, dict[str, dict[float, np.ndarray]]]:
    """Probe features by candidate, parameter and level, (n_flights, n_features) each.

    Also records each candidate's fixed parameters and catalog mechanism in ``ev``.
    """
    grouped: dict[str, dict[str, dict[float, np.ndarray]]] = defaultdict(lambda: defaultdict(dict))
    for i, f in enumerate(ev.flights):
        for probe in forward[f]["probes"]:
            cand, par = probe["candidate"], probe["parameter"]
            table = grouped[cand][par]
            if probe["level"] not in table:
                table[probe["level"]] = np.full((len(ev.flights), len(FEATURES)), np.nan)
            table[probe["level"]][i] = _vec(probe["features"], "values")
            ev.fixed[cand] = dict(probe.get("fixed", {}))
            ev.mechanism_of[cand] = probe["mechanism"]
    for variant, (cand, fitted) in PARAMETER_SUBSETS.items():
        if cand in grouped and all(par in grouped[cand] for par in fitted):
            mech = ev.mechanism_of[cand]
            grouped[variant] = defaultdict(dict, {par: grouped[cand][par] for par in fitted})
            ev.fixed[variant] = {**ev.fixed[cand], **{par: baseline_level(mech, par)
                                                       for par in grouped[cand] if par not in fitted}}
            ev.mechanism_of[variant] = mech
    return grouped


def _response_model(ev: CampaignEvidence, candidate: str, params: Mapping[str, Mapping[float, np.ndarray]]
                     ) -> ResponseModel:
    """One candidate's response tables (baseline level from the first baseline seed), bounded by the
    parameter's physical range in the catalog (:mod:`dronewind.mechanisms`)."""
    mech = get_mechanism(ev.mechanism_of[candidate])
    responses = []
    for par in mech.parameter_names:
        if par not in params:
            continue
        spec = next(p for p in mech.parameters if p.name == par)
        base = baseline_level(mech.name, par)
        levels = sorted(set(params[par]) | {base})
        features = np.stack([ev.baseline_seed0 if np.isclose(lv, base) else params[par][lv] for lv in levels],
                            axis=1)
        responses.append(ParameterResponse(par, np.array(levels, dtype=float), features, base,
                                           float(spec.lower), float(spec.upper)))
    return ResponseModel(candidate, ev.baseline, responses)


def assemble(measured: Mapping[str, Mapping[str, Any]], forward: Mapping[str, Mapping[str, Any]]) -> CampaignEvidence:
    """Build the evidence arrays and one response model per candidate.

    Parameters
    ----------
    measured : mapping
        Flight id -> ``features_to_dict`` of the measured flight.
    forward : mapping
        Flight id -> output of :func:`~dronewind.diagnose.forward.probe_runs`.

    Returns
    -------
    CampaignEvidence
        Arrays and response models; flights in sorted order.
    """
    flights = sorted(measured)
    p = len(FEATURES)
    # shaped arrays also for a campaign without a usable flight (every one left out by the chain)
    y = np.array([_vec(measured[f], "values") for f in flights]).reshape(len(flights), p)
    s_meas = np.array([_vec(measured[f], "sigma") for f in flights]).reshape(len(flights), p)
    base_runs = [[_vec(b, "values") for b in forward[f]["baseline"]] for f in flights]
    base_sig = [[_vec(b, "sigma") for b in forward[f]["baseline"]] for f in flights]
    n_seeds = min((len(r) for r in base_runs), default=0)
    runs = np.array([r[:n_seeds] for r in base_runs]).reshape(len(flights), n_seeds, p)  # (n_flights, n_seeds, p)
    with warnings.catch_warnings():  # a feature no run has (e.g. lag_drift_s without lag_drift) stays NaN
        warnings.simplefilter("ignore", RuntimeWarning)
        sigma, analytic, scale, flight_scale = _calibrated_errors(
            y, s_meas, runs, np.array([s[:n_seeds] for s in base_sig]).reshape(runs.shape))
        mean_runs = np.nanmean(runs, axis=1)
    conditions = [dict(forward[f]["conditions"]) for f in flights]
    # the processing lag the forward runs simulate where the chain measured one (a condition)
    processing_lags = {f: float(forward[f]["simulated_sonic_ins_lag_s"])
                       for f, c in zip(flights, conditions, strict=True)
                       if c.get("sonic_ins_lag_s") is not None
                       and forward[f].get("simulated_sonic_ins_lag_s") is not None}
    conditioned = [feat for key, (feat, _) in CONDITIONED.items()
                   if flights and all(c.get(key) is not None for c in conditions)]
    if flights and all(forward[f].get("atmosphere") == "measured" for f in flights):
        conditioned += [feat for feat in MEASURED_ATMOSPHERE_CONDITIONED if feat not in conditioned]
    used_runs = runs.copy()
    for feat in conditioned:  # a measured condition of the forward runs is not evidence
        y[:, FEATURES.index(feat)] = np.nan
        used_runs[:, :, FEATURES.index(feat)] = np.nan
    seed0 = runs[:, 0, :] if n_seeds else np.full((len(flights), p), np.nan)
    ev = CampaignEvidence(flights, y, sigma, analytic, scale, mean_runs, seed0, conditions,
                          correlation=feature_correlation(used_runs, analytic), n_seeds=n_seeds,
                          conditioned=conditioned, flight_scale=flight_scale, processing_lag_s=processing_lags)
    dropped = {CONDITIONED[key][1] for key in CONDITIONED if CONDITIONED[key][0] in conditioned}
    for cand, params in _probe_tables(ev, forward).items():
        if ev.mechanism_of[cand] not in dropped:
            ev.models[cand] = _response_model(ev, cand, params)
    return ev


def feature_correlation(runs: np.ndarray, analytic: np.ndarray) -> ShrunkCorrelation | None:
    """Shrunk correlation of the features from the baseline seeds (module docstring).

    Parameters
    ----------
    runs : numpy.ndarray
        Baseline forward runs, (n_flights, n_seeds, n_features).
    analytic : numpy.ndarray
        Analytic errors, (n_flights, n_features): the seeds' deviations are divided by them
        so that flights of different conditions pool.

    Returns
    -------
    ShrunkCorrelation or None
        None with fewer than two seeds (no scatter to estimate from: independent errors).
    """
    n_flights, n_seeds, n_feat = runs.shape
    if n_seeds < 2:
        return None
    with np.errstate(invalid="ignore", divide="ignore"):
        x = runs / np.where(analytic > 0, analytic, np.nan)[:, None, :]
    return shrunk_correlation(x.reshape(n_flights * n_seeds, n_feat), np.repeat(np.arange(n_flights), n_seeds))


def error_model(ev: CampaignEvidence, result: DiagnosisResult | None = None) -> dict[str, Any]:
    """The ``error_model`` entry of ``diagnosis.json``: how the residual errors and references were obtained.

    Parameters
    ----------
    ev : CampaignEvidence
        Output of :func:`assemble`.
    result : DiagnosisResult, optional
        The diagnosis: its discrepancy and bootstrap reference are described too.

    Returns
    -------
    dict
        Seeds, pooled degrees of freedom, shrinkage, the seed scale of every feature, the
        discrepancy of every feature with its interval, the features left out as measured
        conditions, the bootstrap's replicates and seed, and ``forward_payload``: the payload
        settings the forward runs simulated (``diagnosis.forward_payload``; empty: the
        simulator's SAMURAI-S defaults).
    """
    from dronewind.diagnose.forward_conditions import split_payload

    out: dict[str, Any] = {
        "forward_payload": next((payload for payload in (split_payload(c)[1] for c in ev.conditions if c) if payload),
                                {}),
        "n_seeds": int(ev.n_seeds),
        "covariance": "shrunk correlation" if ev.correlation is not None else "diagonal",
        "shrinkage_target": "identity (Schaefer and Strimmer 2005, target D)",
        "seed_scale": {f: float(k) for f, k in zip(FEATURES, ev.scale, strict=True)},
        "conditioned_features": list(ev.conditioned),
    }
    c = ev.correlation
    if c is not None:
        iu = np.triu_indices(len(FEATURES), 1)
        order = np.argsort(-np.abs(c.matrix[iu]))[:N_LISTED_CORRELATIONS]
        out.update({
            "dof": c.dof,
            "shrinkage_intensity": c.intensity,
            "largest_correlations": [{"features": [FEATURES[iu[0][k]], FEATURES[iu[1][k]]],
                                      "shrunk": float(c.matrix[iu][k]), "sample": float(c.sample[iu][k])}
                                     for k in order],
            "correlation_matrix": [[round(float(v), 4) for v in row] for row in c.matrix],
        })
    if result is not None:
        d = result.discrepancy
        if d is not None:
            out["discrepancy"] = {
                "method": "DerSimonian-Laird moments about a common offset (and a wind-speed trend from "
                          f"{MIN_FLIGHTS_TREND} flights), 95 % Q-profile interval, of the baseline's residuals "
                          "(listed here); profiled under every candidate (its fit's residuals, the degrees of freedom "
                          "it took accounted for) and added to the covariance of its test",
                "per_feature": {f: {"tau": finite_or_none(d.tau[j]),
                                    "ci95": [finite_or_none(d.low[j]), finite_or_none(d.high[j])],
                                    "q": finite_or_none(d.q_statistic[j]), "dof": float(d.dof[j])}
                                for j, f in enumerate(FEATURES) if d.dof[j] > 0},
            }
        ref = result.reference
        out["reference"] = ({"method": "parametric bootstrap over seeds (every estimate repeated per replicate, "
                                       "the profiled discrepancy included); candidates by Westfall-Young single-step "
                                       "min-p over each naming round (chi-square tails as marginals)",
                             "replicates": ref.n_replicates, "seed": ref.seed,
                             "unexplained": "offset and wind-speed trend of every feature's residuals, Westfall-Young "
                                            "single-step min-p over all features and both tests at a family-wise "
                                            f"{UNEXPLAINED_ALPHA:g}",
                             "smallest_p": 1.0 / (ref.n_replicates + 1)}
                            if ref is not None else
                            {"method": "chi-square, Bonferroni over mechanisms (fewer than two seeds: no bootstrap)"})
    return out


def finite_or_none(x: float) -> float | None:
    """A float for JSON (None for NaN or infinite)."""
    return float(x) if np.isfinite(x) else None


def measured_conditions(ev: CampaignEvidence) -> dict[str, dict[str, float]]:
    """The conditions the chain measured per flight that the forward runs take as given (:data:`CONDITIONED`).

    Returns
    -------
    dict
        Flight -> condition key -> value; empty without such conditions. ``sonic_ins_lag_s`` [s]
        is the lag the chain found (its lag of minimum TKE), ``processing_lag_s`` [s] the
        sonic-INS processing lag the forward runs simulate so that their chain finds that lag
        (:func:`dronewind.diagnose.probe_runs.simulated_sonic_ins_lag_s`): the flight's estimate
        of its processing lag, the chain's bias from the payload's wind-following attitude removed.
    """
    out: dict[str, dict[str, float]] = {}
    for flight, cond in zip(ev.flights, ev.conditions, strict=True):
        values = {key: float(cond[key]) for key in CONDITIONED if cond.get(key) is not None}
        if flight in ev.processing_lag_s:
            values[PROCESSING_LAG_KEY] = ev.processing_lag_s[flight]
        if values:
            out[flight] = values
    return out
