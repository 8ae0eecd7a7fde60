r"""The paper's measured numbers as data: which mechanisms reproduce the published SAMURAI-S results.

The published validation (Ghirardelli et al. 2025) gives no raw records, only numbers: the conditions of
the ten samples (Table 4), the drone and mast statistics of s1 and s7 (Table 5) and a few
quantitative statements (Sect. 5.2 and 6: the drone's :math:`\sigma_w` too high and the
excess rising about linearly with wind speed; the drone's
:math:`\langle S_w/S_u\rangle` up to 63 % above 4/3, the mast's up to 22 % below). This
module treats those numbers as a measured data set and runs the diagnosis on them:

1. The forward model is run at the Table 4 conditions of every stationary sample
   (baseline seeds and every catalog probe, :func:`dronewind.diagnose.probe_runs.probe_runs`),
   exactly as for a measured campaign.
2. The *observations* are grouped:

   * ``table5:<flight>``: :math:`\ln(\sigma_{i,drone}/\sigma_{i,mast})` for
     :math:`i = u, v, w` and :math:`\ln(\bar u_{drone}/\bar u_{mast})`;
   * ``claim:sw_su_drone_max``: the largest drone :math:`\langle S_w/S_u\rangle` over the
     stationary samples, :math:`(1 + 0.63)\cdot 4/3`;
   * ``claim:sw_su_mast_min``: the smallest mast ratio, :math:`(1 - 0.22)\cdot 4/3`.

   A maximum over noisy samples is biased upward; the prediction of an extreme is
   therefore the Monte-Carlo expectation of the extreme of the predicted per-sample values
   with their realisation scatter (fixed draws, so the fit stays deterministic and smooth).
3. Errors: the realisation-to-realisation scatter of each feature (Ghirardelli et al. 2025, Eqs 10-13,
   calibrated by the forward model's baseline seeds, :mod:`dronewind.diagnose.campaign`),
   combined with the printing resolution of the paper (uniform rounding,
   :math:`0.1/\sqrt{12}` for Table 5).
4. Every candidate is fitted (bounded least squares) to all groups and scored by leaving
   one group out (held-out gain) and by a likelihood-ratio test at
   :math:`\alpha/M` (Bonferroni over the mechanisms). Causes are named greedily: the best
   significant single mechanism, then a second one only if adding it is itself
   significant against the first and raises the held-out gain.

The result says what the baseline gets wrong (the observation groups against the baseline
prediction, in standard errors), which mechanisms reproduce the numbers and with which
parameters, and which ones the numbers cannot tell apart.

References
----------
Ghirardelli, M., Kral, S. T., Cheynet, E., and Reuder, J.: SAMURAI-S (Ghirardelli et al. 2025),
Tables 4 and 5, Sect. 5.2 and 6.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.stats
import xarray as xr

from dronewind.core.reuse import read_only
from dronewind.diagnose.campaign import AT_BOUND, CampaignEvidence, assemble, simplest_variant
from dronewind.diagnose.campaign import n_tests as campaign_n_tests
from dronewind.diagnose.features import FEATURES
from dronewind.diagnose.fitting import ParameterResponse, bounded_least_squares
from dronewind.diagnose.published_file import TABLE5_FEATURES, load_published
from dronewind.errors import InputError

__all__ = [
    "TABLE5_FEATURES",
    "OBSERVED_FEATURES",
    "CLAIM_FEATURES",
    "SUMMARY_FEATURES",
    "load_published",
    "table4_conditions",
    "table5_observations",
    "PublishedEvidence",
    "build_evidence",
    "PublishedScore",
    "score_combo",
    "with_heldout",
    "analyse",
    "flight_summary",
    "rerun_summary",
]

ISOTROPY = 4.0 / 3.0
N_DRAWS = 4000
#: Tries of the last naming round reported as not named (best p-values first).
N_NOT_NAMED = 3
#: The isotropy claims (Sect. 6): the feature each is an extreme of, and which extreme.
CLAIM_FEATURES: dict[str, tuple[str, str]] = {"sw_su_drone_max": ("sw_su_drone", "max"),
                                              "sw_su_mast_min": ("sw_su_mast", "min")}
#: The features of the reruns' Table 5-like summaries (:func:`flight_summary`: the isotropy
#: ratios; its moments come from the L3).
SUMMARY_FEATURES: tuple[str, ...] = tuple(feature for feature, _ in CLAIM_FEATURES.values())
#: The features the published numbers hold (Table 5's four, the isotropy claims'): the only
#: ones the forward runs at Table 4 conditions compute.
OBSERVED_FEATURES: tuple[str, ...] = (*TABLE5_FEATURES, *SUMMARY_FEATURES)


def table4_conditions(published: Mapping[str, Any], flight_id: str, campaign_data: Mapping[str, Any]
                      ) -> dict[str, Any]:
    """Forward-model conditions of one sample from Table 4.

    Parameters
    ----------
    published : mapping
        Output of :func:`load_published`.
    flight_id : str
        Sample id (``s01`` ...), also a payload flight of ``campaign_data``.
    campaign_data : mapping
        Manifest of the campaign that reconstructs the experiment (masts, reference
        sonics). Its ``simulation.atmosphere`` and per-flight atmosphere settings
        (roughness length, temperature, boundary-layer depth: not printed in the paper) are
        used where present; the Table 4 numbers always take precedence.

    Returns
    -------
    dict
        Keys of ``simulation.payload_flights.<id>``: wind speed, direction and
        :math:`z/L` at the reference sonic (Table 4, footnote *), hover height (Table 4,
        footnote **), start and duration.
    """
    row = published["table4"][flight_id]
    flight = next((f for f in campaign_data["payload_flights"] if f["id"] == flight_id), None)
    if flight is None:
        raise InputError(f"payload_flights.{flight_id}", "the published sample is not a flight of the campaign")
    z_ref = next(s["height_m"] for m in campaign_data["masts"] for s in m["sonics"] if s["id"] == flight["reference"])
    sim = campaign_data.get("simulation") or {}
    extra = {k: v for k, v in ((sim.get("payload_flights") or {}).get(flight_id) or {}).items()
             if k in ("roughness_length_m", "theta_mean_k", "boundary_layer_height_m")}
    for key in ("roughness_length_m", "theta_mean_k", "boundary_layer_height_m"):
        if key not in extra and key in (sim.get("atmosphere") or {}):
            extra[key] = sim["atmosphere"][key]
    return {
        **extra,
        "mean_speed_ms": float(row["wind_speed_ms"]),
        "wind_from_deg": float(row["wind_from_deg"]) % 360.0,
        "z_over_L": float(row["zeta"]),
        "z_ref_m": float(z_ref),
        "hover_height_m": float(row["payload_height_m"]),
        "start": str(row["start"]),
        "duration_s": float(round(60.0 * float(row["duration_min"]))),
    }


def table5_observations(published: Mapping[str, Any]) -> dict[str, dict[str, tuple[float, float]]]:
    """Table 5 as residual features with their rounding errors.

    Returns
    -------
    dict
        ``{flight: {feature: (value, rounding standard error)}}`` with
        :math:`\\ln(x_{drone}/x_{mast})` and the error of two independently rounded
        numbers, :math:`\\sqrt{(r/x_d)^2 + (r/x_m)^2}`, :math:`r = \\Delta/\\sqrt{12}`.
    """
    r = float(published["table5"]["resolution"]) / math.sqrt(12.0)
    out: dict[str, dict[str, tuple[float, float]]] = {}
    for flight, row in published["table5"].items():
        if flight == "resolution":
            continue
        out[flight] = {}
        for feature, stat in TABLE5_FEATURES.items():
            d, m = float(row["drone"][stat]), float(row["mast"][stat])
            out[flight][feature] = (math.log(d / m), math.hypot(r / d, r / m))
    return out


@dataclass
class PublishedEvidence:
    """Forward model at Table 4 conditions and the published observations."""

    ev: CampaignEvidence
    table5: dict[str, dict[str, tuple[float, float]]]
    claims: dict[str, tuple[float, float]]
    draws: np.ndarray
    groups: list[str]
    #: Error of each claim: spread of the extreme at the baseline (fixed, so the fit's
    #: weights do not move with the parameters) and the printing resolution.
    claim_sigma: dict[str, float]
    #: :meth:`scaled_draws` made so far (the fit evaluates the extremes some 18,000 times).
    _draws_by_sigma: dict[tuple[bytes, bytes], np.ndarray] = field(default_factory=dict, init=False, repr=False,
                                                                   compare=False)
    #: Expected extremes (no spread) found so far, by kind and inputs: a fit whose candidate
    #: leaves a claim's feature alone (every one but mast_w_attenuation for the mast's ratio)
    #: asks for the same extreme at every evaluation (:func:`_extreme`).
    _extremes: dict[tuple[str, bytes, bytes], float] = field(default_factory=dict, init=False, repr=False,
                                                             compare=False)
    #: Fits made so far (:func:`_fit`), by combination and groups: every pair is scored
    #: against the named cause, whose own fits (all groups, and each left out) are the same.
    _fits: dict[tuple[tuple[str, ...], tuple[str, ...]], tuple[np.ndarray, np.ndarray, float]] = field(
        default_factory=dict, init=False, repr=False, compare=False)

    def flight_index(self, flight: str) -> int:
        """Index of a flight in the evidence arrays."""
        return self.ev.flights.index(flight)

    def scaled_draws(self, sigma: np.ndarray, ok: np.ndarray) -> np.ndarray:
        """``sigma[ok] * draws[:, ok]`` transposed, shape ``(ok.sum(), N_DRAWS)``, made once per ``sigma`` and ``ok``.

        Laid out one flight per row, so that the extreme over the flights is a reduction
        across rows (the same numbers as the reduction along the draws' rows, faster).
        """
        key = (sigma.tobytes(), ok.tobytes())
        if key not in self._draws_by_sigma:
            self._draws_by_sigma[key] = np.ascontiguousarray((sigma[ok][None, :] * self.draws[:, ok]).T)
        return self._draws_by_sigma[key]

    @functools.cached_property
    def table5_rows(self) -> list[tuple[str, int, np.ndarray, np.ndarray, np.ndarray]]:
        """Per Table 5 flight: group name, flight index, feature indices, observed values and their errors.

        Made once: the fit's residuals (:func:`_observations`) only take the predictions anew.
        """
        rows = []
        for flight in sorted(self.table5):
            names = list(TABLE5_FEATURES)
            j = np.array([FEATURES.index(f) for f in names])
            i = self.flight_index(flight)
            obs = np.array([self.table5[flight][f][0] for f in names])
            rnd = np.array([self.table5[flight][f][1] for f in names])
            rows.append((f"table5:{flight}", i, j, obs, np.hypot(self.ev.sigma[i, j], rnd)))
        return rows


def build_evidence(published: Mapping[str, Any], forward: Mapping[str, Mapping[str, Any]], seed: int = 0
                   ) -> PublishedEvidence:
    """Assemble the forward runs of the stationary samples and the published observations.

    Parameters
    ----------
    published : mapping
        Output of :func:`load_published`.
    forward : mapping
        Flight id -> output of :func:`~dronewind.diagnose.probe_runs.probe_runs` at the
        Table 4 conditions (:func:`table4_conditions`).
    seed : int
        Seed of the fixed standard-normal draws for the expected extremes.

    Returns
    -------
    PublishedEvidence
    """
    missing = [f for f in published["stationary_flights"] if f not in forward]
    if missing:
        raise InputError("published forward runs", f"missing for flights {missing}")
    for flight in published["stationary_flights"]:
        lacking = [f for f in OBSERVED_FEATURES if f not in forward[flight].get("features", FEATURES)]
        if lacking:
            raise InputError(f"published forward runs of {flight}: features",
                             f"the runs lack {lacking}, which the published numbers hold")
    # The measured side is empty here: assemble() then takes the analytic errors from the
    # forward model's own runs and calibrates them by its seed-to-seed scatter.
    empty = {"values": {f: None for f in FEATURES}, "sigma": {f: None for f in FEATURES}}
    ev = assemble({f: empty for f in published["stationary_flights"]},
                  {f: forward[f] for f in published["stationary_flights"]})
    table5 = table5_observations(published)
    claims = {k: (float(published["claims"][k]["value"]), float(published["claims"][k]["resolution"]))
              for k in CLAIM_FEATURES}
    draws = np.random.default_rng(seed).standard_normal((N_DRAWS, len(ev.flights)))
    groups = [f"table5:{f}" for f in sorted(table5)] + [f"claim:{k}" for k in claims]
    pe = PublishedEvidence(ev, table5, claims, draws, groups, {})
    for claim, (_, resolution) in claims.items():
        feature, kind = CLAIM_FEATURES[claim]
        j = FEATURES.index(feature)
        _, spread0 = _extreme(pe, ev.baseline[:, j], ev.sigma[:, j], kind)
        pe.claim_sigma[claim] = math.hypot(spread0, resolution / math.sqrt(12.0))
    return pe


def _combo_parameters(pe: PublishedEvidence, combo: Sequence[str]) -> list[ParameterResponse]:
    return [p for cand in combo for p in pe.ev.models[cand].parameters]


def _features(pe: PublishedEvidence, combo: Sequence[str], theta: np.ndarray) -> np.ndarray:
    """Predicted features of every stationary flight with the combined mechanisms (effects add)."""
    ev = pe.ev
    idx = np.arange(len(ev.flights))
    out = ev.baseline.copy()
    k = 0
    for cand in combo:
        model = ev.models[cand]
        n = model.n_parameters
        effect = model.predict(theta[k:k + n], idx) - model.baseline
        out = out + np.where(np.isfinite(effect), effect, 0.0)
        k += n
    return out


def _extreme(pe: PublishedEvidence, values: np.ndarray, sigma: np.ndarray, kind: str,
             spread: bool = True) -> tuple[float, float]:
    """Expected extreme (and its spread over the draws, NaN unless ``spread``) of independent
    per-flight realisations.

    Without the spread, the value is remembered per kind and inputs (bit for bit): the same
    inputs give it again without the 4000 draws (:attr:`PublishedEvidence._extremes`).
    """
    if spread:
        ext = _extremes_over_draws(pe, values, sigma, kind)
        return (float("nan"), float("nan")) if ext is None else (float(ext.mean()), float(ext.std(ddof=1)))
    key = (kind, values.tobytes(), sigma.tobytes())
    found = pe._extremes.get(key)
    if found is None:
        ext = _extremes_over_draws(pe, values, sigma, kind)
        found = pe._extremes[key] = float("nan") if ext is None else float(ext.mean())
    return found, float("nan")


def _extremes_over_draws(pe: PublishedEvidence, values: np.ndarray, sigma: np.ndarray, kind: str
                         ) -> np.ndarray | None:
    """The extreme over the flights of every draw (None when no flight has a value and an error)."""
    ok = np.isfinite(values) & np.isfinite(sigma)
    if not ok.any():
        return None
    sample = values[ok][:, None] + pe.scaled_draws(sigma, ok)  # (flights, draws)
    return sample.max(axis=0) if kind == "max" else sample.min(axis=0)


def _observations(pe: PublishedEvidence, feats: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per group: observed, predicted and standard error arrays."""
    ev = pe.ev
    out = {g: (obs, feats[i, j], se) for g, i, j, obs, se in pe.table5_rows}
    for claim, (value, _) in pe.claims.items():
        feature, kind = CLAIM_FEATURES[claim]
        k = FEATURES.index(feature)
        pred, _ = _extreme(pe, feats[:, k], ev.sigma[:, k], kind, spread=False)  # the fit needs no spread
        out[f"claim:{claim}"] = (np.array([value]), np.array([pred]), np.array([pe.claim_sigma[claim]]))
    return out


def _chi2_groups(pe: PublishedEvidence, combo: Sequence[str], theta: np.ndarray) -> dict[str, float]:
    obs = _observations(pe, _features(pe, combo, theta))
    out = {}
    for g, (y, p, s) in obs.items():
        r = (y - p) / s
        out[g] = float(np.sum(np.where(np.isfinite(r), r, 0.0) ** 2))
    return out


def _fit(pe: PublishedEvidence, combo: Sequence[str], groups: Sequence[str]) -> tuple[np.ndarray, np.ndarray, float]:
    """Estimate, standard errors and misfit of ``combo`` fitted to ``groups`` (made once per both; read-only)."""
    key = (tuple(combo), tuple(groups))
    if key not in pe._fits:
        pe._fits[key] = read_only(_fitted(pe, combo, groups))
    return pe._fits[key]


def _fitted(pe: PublishedEvidence, combo: Sequence[str], groups: Sequence[str]
            ) -> tuple[np.ndarray, np.ndarray, float]:
    params = _combo_parameters(pe, combo)
    base = np.array([p.baseline_level for p in params], dtype=float)
    if not params:
        return base, base, sum(_chi2_groups(pe, combo, base)[g] for g in groups)
    def residuals(theta: np.ndarray) -> np.ndarray:
        obs = _observations(pe, _features(pe, combo, theta))
        r = np.concatenate([(obs[g][0] - obs[g][1]) / obs[g][2] for g in groups])
        return np.where(np.isfinite(r), r, 0.0)

    theta, std, value, _, _ = bounded_least_squares(residuals, params)
    return theta, std, value


@dataclass
class PublishedScore:
    """One candidate (or combination) fitted to the published numbers."""

    combo: tuple[str, ...]
    names: tuple[str, ...]
    theta: np.ndarray
    theta_std: np.ndarray
    chi2: float
    chi2_reference: float
    chi2_groups: dict[str, float]
    heldout: dict[str, float]
    heldout_reference: dict[str, float]
    gain: float
    lr_statistic: float
    extra_parameters: int
    p_value: float
    significant: bool
    #: the nested model tested against (``()`` = baseline)
    reference: tuple[str, ...] = ()
    #: the likelihood-ratio test passes at the Bonferroni-corrected level
    lr_passes: bool = False

    def estimate(self) -> dict[str, dict[str, float]]:
        """Fitted parameters per candidate."""
        out: dict[str, dict[str, float]] = {}
        for name, value in zip(self.names, self.theta, strict=True):
            cand, par = name.split(":", 1)
            out.setdefault(cand, {})[par] = float(value)
        return out

    def uncertainty(self) -> dict[str, dict[str, float]]:
        """Standard errors per candidate."""
        out: dict[str, dict[str, float]] = {}
        for name, value in zip(self.names, self.theta_std, strict=True):
            cand, par = name.split(":", 1)
            out.setdefault(cand, {})[par] = float(value)
        return out


def score_combo(pe: PublishedEvidence, combo: Sequence[str], reference: Sequence[str] = (),
                alpha: float = 0.01, n_tests: int = 1, heldout: bool | None = True) -> PublishedScore:
    """Fit a combination of candidates, leave each observation group out in turn, test it.

    Parameters
    ----------
    pe : PublishedEvidence
    combo : sequence of str
        Candidate names (keys of ``pe.ev.models``).
    reference : sequence of str
        The nested model it is tested against (``()`` = baseline).
    alpha : float
        Family-wise false-alarm rate.
    n_tests : int
        Bonferroni divisor.
    heldout : bool or None
        Leave each group out (the held-out gain); with None only where the
        likelihood-ratio test passes, the one case in which the gain decides significance
        (elsewhere the gain is NaN until :func:`with_heldout` adds it).

    Returns
    -------
    PublishedScore
        With the held-out gain
        :math:`G = 1 - \\sum_g \\chi^2_{g,held-out}(combo) / \\sum_g \\chi^2_{g,held-out}(reference)`
        and the likelihood-ratio test :math:`\\chi^2(ref) - \\chi^2(combo) \\sim \\chi^2_k`.
    """
    theta, std, value = _fit(pe, combo, pe.groups)
    _, _, ref_value = _fit(pe, reference, pe.groups)
    k = len(_combo_parameters(pe, combo)) - len(_combo_parameters(pe, reference))
    lr = max(ref_value - value, 0.0)
    p = float(scipy.stats.chi2.sf(lr, k)) if k > 0 else 1.0
    names = tuple(f"{c}:{p.name}" for c in combo for p in pe.ev.models[c].parameters)
    lr_passes = bool(k > 0 and p < alpha / max(n_tests, 1))
    score = PublishedScore(tuple(combo), names, theta, std, value, ref_value, _chi2_groups(pe, combo, theta),
                           {}, {}, float("nan"), lr, k, p, False, tuple(reference), lr_passes)
    return with_heldout(pe, score) if heldout or (heldout is None and lr_passes) else score


def with_heldout(pe: PublishedEvidence, score: PublishedScore) -> PublishedScore:
    """``score`` with its held-out chi-square per group, its gain and its significance (once).

    Each group is left out in turn: the combination and its reference are fitted to the
    others and scored on it (the fits are remembered, :func:`_fit`). Significant: the
    likelihood-ratio test passes and the gain is positive.
    """
    if score.heldout:
        return score
    groups, combo, reference = pe.groups, score.combo, score.reference
    ref_all = _fit(pe, reference, groups)
    for g in groups:
        train = [h for h in groups if h != g]
        t, _, _ = _fit(pe, combo, train)
        score.heldout[g] = _chi2_groups(pe, combo, t)[g]
        tr = _fit(pe, reference, train)[0] if reference else ref_all[0]
        score.heldout_reference[g] = _chi2_groups(pe, reference, tr)[g]
    total_ref = sum(score.heldout_reference.values())
    score.gain = 1.0 - sum(score.heldout.values()) / total_ref if total_ref > 0 else 0.0
    score.significant = bool(score.lr_passes and score.gain > 0)
    return score


def _group_table(pe: PublishedEvidence, combo: Sequence[str], theta: np.ndarray) -> list[dict[str, Any]]:
    rows = []
    obs = _observations(pe, _features(pe, combo, theta))
    for g, (y, p, s) in obs.items():
        names = list(TABLE5_FEATURES) if g.startswith("table5:") else [g.split(":", 1)[1]]
        for name, yy, pp, ss in zip(names, y, p, s, strict=True):
            rows.append({"group": g, "quantity": name, "published": float(yy), "predicted": float(pp),
                         "sigma": float(ss), "z": float((yy - pp) / ss) if ss > 0 else float("nan")})
    return rows


def _at_bound(pe: PublishedEvidence, score: PublishedScore) -> bool:
    """Whether a parameter of ``score``'s fit sits at a catalog bound other than its "off" level."""
    for par, value in zip(_combo_parameters(pe, score.combo), score.theta, strict=True):
        span = par.upper - par.lower
        for bound in (par.lower, par.upper):
            if abs(value - bound) <= AT_BOUND * span and not np.isclose(bound, par.baseline_level):
                return True
    return False


def _name_causes(pe: PublishedEvidence, singles: Mapping[str, PublishedScore], alpha: float,
                 tests: Mapping[str, int], max_causes: int
                 ) -> tuple[tuple[str, ...], PublishedScore | None, list[PublishedScore]]:
    """Greedy naming: the best significant single candidate, then additions significant against it.

    ``tests`` holds each candidate's Bonferroni divisor (:func:`dronewind.diagnose.campaign.n_tests`).

    Returns
    -------
    named : tuple of str
        Named candidates, in naming order.
    current : PublishedScore or None
        Score of the named combination (None if nothing is named).
    rejected : list of PublishedScore
        The tries of the round that named nothing more, best p-value first.
    """
    ev = pe.ev
    named: tuple[str, ...] = ()
    current = None
    rejected: list[PublishedScore] = []  # the tries of the round that named nothing more
    for _ in range(max_causes):
        used = {ev.mechanism_of[c] for c in named}
        options = [c for c in sorted(ev.models) if ev.mechanism_of[c] not in used]
        # an addition's held-out gain is needed where its likelihood-ratio test passes (the gain
        # then decides) and for the best three rejected tries (reported): not for the others
        tries = [singles[c] for c in options] if not named else \
            [score_combo(pe, (*named, c), named, alpha, tests[c], heldout=None) for c in options]
        for s in tries:  # an estimate at a catalog bound is not identified: never named (campaign rule)
            if s.significant and _at_bound(pe, s):
                s.significant = False
        ok = [s for s in tries if s.significant and (current is None or s.gain > 0)]
        if not ok:
            rejected = sorted(tries, key=lambda s: s.p_value)
            rejected[:N_NOT_NAMED] = [with_heldout(pe, s) for s in rejected[:N_NOT_NAMED]]
            break
        top = max(ok, key=lambda s: (s.gain, -s.chi2))
        # the simplest nested variant of the added candidate that fits as well (campaign rule)
        added = {s.combo[-1]: s for s in ok if s.combo[:-1] == top.combo[:-1]}
        best = added[simplest_variant(top.combo[-1], {c: s.chi2 - top.chi2 for c, s in added.items()}, ev, alpha)]
        named, current = best.combo, best
    return named, current, rejected


def _ambiguity_set(pe: PublishedEvidence, singles: Mapping[str, PublishedScore], named: Sequence[str],
                   alpha: float) -> list[str]:
    """Mechanisms the numbers cannot tell from the named first cause.

    Single mechanisms whose best fit is not worse than the named first cause by more than
    the 1 - alpha quantile of chi2_1.
    """
    if not named:
        return []
    first = singles[named[0]]
    limit = float(scipy.stats.chi2.ppf(1.0 - alpha, 1))
    return sorted({pe.ev.mechanism_of[s.combo[0]] for s in singles.values()
                   if s.significant and s.chi2 - first.chi2 < limit})


def _named_estimates(ev: CampaignEvidence, named: Sequence[str], current: PublishedScore | None
                     ) -> tuple[dict[str, dict[str, Any]], list[dict[str, Any]]]:
    """Per named mechanism: candidate, fitted parameters (fixed ones included) and errors; catalog form."""
    estimates: dict[str, dict[str, Any]] = {}
    extended: list[dict[str, Any]] = []
    if current is not None:
        est, unc = current.estimate(), current.uncertainty()
        for cand in named:
            params = {**ev.fixed.get(cand, {}), **est[cand]}
            estimates[ev.mechanism_of[cand]] = {"candidate": cand, "estimate": params, "uncertainty": unc[cand]}
            extended.append({"mechanism": ev.mechanism_of[cand], "parameters": params})
    return estimates, extended


def _candidate_rows(ev: CampaignEvidence, ranked: Sequence[PublishedScore]) -> list[dict[str, Any]]:
    """JSON rows of the single candidates (ranked)."""
    return [{
        "candidate": s.combo[0], "mechanism": ev.mechanism_of[s.combo[0]],
        "estimate": {**ev.fixed.get(s.combo[0], {}), **s.estimate().get(s.combo[0], {})},
        "uncertainty": s.uncertainty().get(s.combo[0], {}), "chi2": s.chi2, "gain": s.gain,
        "p_value": s.p_value, "significant": s.significant,
        "heldout_chi2": s.heldout, "heldout_chi2_baseline": s.heldout_reference,
    } for s in ranked]


def _not_named_rows(ev: CampaignEvidence, rejected: Sequence[PublishedScore], alpha: float,
                    tests: Mapping[str, int]) -> list[dict[str, Any]]:
    """What was tried and not named in the last round (the best :data:`N_NOT_NAMED` by p-value).

    Evidence that is suggestive but does not pass the corrected test is reported, not named.
    """
    return [{"combo": list(s.combo), "added": ev.mechanism_of[s.combo[-1]],
             "estimate": s.estimate(), "chi2": s.chi2, "chi2_reference": s.chi2_reference,
             "p_value": s.p_value, "gain": s.gain, "threshold": alpha / max(tests[s.combo[-1]], 1)}
            for s in rejected[:N_NOT_NAMED]]


def analyse(published: Mapping[str, Any], forward: Mapping[str, Mapping[str, Any]], alpha: float = 0.01,
            max_causes: int = 2) -> dict[str, Any]:
    """Diagnose the published numbers: baseline misfit, candidates, named causes, ambiguity.

    Parameters
    ----------
    published : mapping
        Output of :func:`load_published`.
    forward : mapping
        Forward runs at Table 4 conditions per stationary flight.
    alpha : float
        Family-wise false-alarm rate per naming round.
    max_causes : int
        Largest number of mechanisms named together.

    Returns
    -------
    dict
        JSON-ready: ``baseline`` (per-quantity published vs predicted, z), ``candidates``
        (ranked by held-out gain), ``named_causes``, ``named_estimates``, ``ambiguity_set``,
        ``extended_mechanisms`` (catalog form, for reruns) and ``conditions``.
    """
    pe = build_evidence(published, forward)
    ev = pe.ev
    n_tests = len(sorted({ev.mechanism_of[c] for c in ev.models}))
    tests = campaign_n_tests(ev)  # a mechanism's share of alpha split among its variants
    singles = {c: score_combo(pe, (c,), (), alpha, tests[c]) for c in sorted(ev.models)}
    ranked = sorted(singles.values(), key=lambda s: -s.gain)
    named, current, rejected = _name_causes(pe, singles, alpha, tests, max_causes)
    base_chi2 = sum(_chi2_groups(pe, (), np.zeros(0)).values())
    ambiguity = _ambiguity_set(pe, singles, named, alpha)
    estimates, extended = _named_estimates(ev, named, current)
    after_theta = current.theta if current is not None else np.zeros(0)
    return {
        "source": dict(published["source"]),
        "flights": list(ev.flights),
        "groups": list(pe.groups),
        "baseline": {"chi2": base_chi2, "n_observations": int(sum(len(v) for v in pe.table5.values()) + len(pe.claims)),
                     "quantities": _group_table(pe, (), np.zeros(0))},
        "candidates": _candidate_rows(ev, ranked),
        "named_causes": [ev.mechanism_of[c] for c in named],
        "named_estimates": estimates,
        "named_fit": ({"chi2": current.chi2, "gain": current.gain, "p_value": current.p_value,
                       "quantities": _group_table(pe, named, after_theta)} if current is not None else None),
        "ambiguity_set": ambiguity,
        "not_named": _not_named_rows(ev, rejected, alpha, tests),
        "extended_mechanisms": extended,
        "alpha": alpha,
        "n_tests": n_tests,
        "model_scale": {f: float(k) for f, k in zip(FEATURES, ev.scale, strict=True) if f in OBSERVED_FEATURES},
    }


def flight_summary(l3: xr.Dataset, features: Mapping[str, float]) -> dict[str, float]:
    """Drone and mast statistics of one (simulated) flight, as in Table 5.

    Parameters
    ----------
    l3 : xarray.Dataset
        L3 flight dataset (double-rotated ``u_ms, v_ms, w_ms`` over ``(sensor, time)``).
    features : mapping
        Its residual features (for the isotropy ratios).

    Returns
    -------
    dict
        ``U_ms_<sensor>``, ``sigma_{u,v,w}_ms_<sensor>``, ``Sw_Su_<sensor>`` for
        ``drone`` and ``mast`` [m s-1 and 1].
    """
    sensors = [str(s) for s in np.asarray(l3["sensor"].values).astype(str)]
    out: dict[str, float] = {}
    for sensor in ("drone", "mast"):
        i = sensors.index(sensor)
        for c in ("u", "v", "w"):
            x = np.asarray(l3[f"{c}_ms"].values[i], dtype=float)
            x = x[np.isfinite(x)]
            out[f"sigma_{c}_ms_{sensor}"] = float(np.std(x, ddof=1))
            if c == "u":
                out[f"U_ms_{sensor}"] = float(np.mean(x))
        out[f"Sw_Su_{sensor}"] = float(features.get(f"sw_su_{sensor}", float("nan")))
    return out


def rerun_summary(reruns: Mapping[str, Mapping[str, Any]], published: Mapping[str, Any]) -> dict[str, Any]:
    """Before/after comparison of the reruns with the published numbers.

    Parameters
    ----------
    reruns : mapping
        Flight -> ``{"baseline": [summary per seed], "extended": [summary per seed]}``
        (summaries from :func:`flight_summary`).
    published : mapping
        Output of :func:`load_published`.

    Returns
    -------
    dict
        ``table5`` rows (published, baseline and extended drone/mast values of s1 and s7),
        ``claims`` (drone maximum and mast minimum of S_w/S_u, the mast range, the drone
        ratio above 4/3 for U > 6 m/s) and the slope and correlation of
        :math:`\\sigma_{w,drone} - \\sigma_{w,mast}` against the mast wind speed.
    """
    def mean(flight: str, model: str, key: str) -> float:
        return float(np.nanmean([r[key] for r in reruns[flight][model]]))

    flights = [f for f in published["stationary_flights"] if f in reruns]
    out: dict[str, Any] = {"flights": flights, "table5": [], "claims": {}, "dsigma_w": {}}
    for flight in sorted(f for f in published["table5"] if f != "resolution"):
        if flight not in reruns:
            continue
        for stat in ("U_ms", "sigma_u_ms", "sigma_v_ms", "sigma_w_ms"):
            row = {"flight": flight, "statistic": stat}
            for sensor in ("drone", "mast"):
                row[f"published_{sensor}"] = float(published["table5"][flight][sensor][stat])
                for model in ("baseline", "extended"):
                    row[f"{model}_{sensor}"] = mean(flight, model, f"{stat}_{sensor}")
            out["table5"].append(row)
    speeds = np.array([float(published["table4"][f]["wind_speed_ms"]) for f in flights])
    for model in ("baseline", "extended"):
        drone = np.array([mean(f, model, "Sw_Su_drone") for f in flights])
        mast = np.array([mean(f, model, "Sw_Su_mast") for f in flights])
        dsw = np.array([mean(f, model, "sigma_w_ms_drone") - mean(f, model, "sigma_w_ms_mast") for f in flights])
        fit = np.polyfit(speeds, dsw, 1)
        out["claims"][model] = {
            "sw_su_drone_max": float(np.nanmax(drone)), "sw_su_mast_min": float(np.nanmin(mast)),
            "sw_su_mast_max": float(np.nanmax(mast)),
            "sw_su_drone_min_above_6ms": float(np.nanmin(drone[speeds > 6])) if np.any(speeds > 6) else float("nan"),
            "per_flight": {f: {"U_ms": float(u), "Sw_Su_drone": float(d), "Sw_Su_mast": float(m),
                               "dsigma_w_ms": float(x)}
                           for f, u, d, m, x in zip(flights, speeds, drone, mast, dsw, strict=True)},
        }
        out["dsigma_w"][model] = {"slope_per_ms": float(fit[0]), "intercept_ms": float(fit[1]),
                                  "r": float(np.corrcoef(speeds, dsw)[0, 1]) if np.std(dsw) > 0 else float("nan")}
    t5 = {f: published["table5"][f] for f in published["table5"] if f != "resolution"}
    if len(t5) >= 2:
        u = np.array([t5[f]["mast"]["U_ms"] for f in sorted(t5)], dtype=float)
        d = np.array([t5[f]["drone"]["sigma_w_ms"] - t5[f]["mast"]["sigma_w_ms"] for f in sorted(t5)])
        out["dsigma_w"]["published_table5"] = {"slope_per_ms": float((d[-1] - d[0]) / (u[-1] - u[0])),
                                               "points": {f: [float(a), float(b)] for f, a, b in
                                                          zip(sorted(t5), u, d, strict=True)}}
    return out


