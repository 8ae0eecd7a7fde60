"""Forward runs of a flight at the probe levels of each mechanism, and their merging.

:func:`probe_runs` runs the baseline seeds and every probe of :mod:`dronewind.diagnose.probes`
through :func:`dronewind.diagnose.forward.run_forward` (common random numbers: the first
baseline seed; the flight's true state simulated once per seed and shared by the probes of
measurement-stage mechanisms, :func:`shares_truth`); :func:`merge_probe_runs` joins runs made
in parts. :func:`simulated_sonic_ins_lag_s` is the sonic-INS lag the simulator gives a flight.
"""

from __future__ import annotations

import logging
from collections.abc import Collection, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import xarray as xr

from dronewind.core.progress import Progress
from dronewind.core.reuse import reusing
from dronewind.diagnose.features import FEATURES
from dronewind.diagnose.forward import ForwardCache, run_forward
from dronewind.diagnose.forward_atmosphere import RECORD_INVERSES, record_through
from dronewind.diagnose.forward_conditions import _measured_lag_s, forward_manifest
from dronewind.diagnose.probes import (
    BASELINE_PART,
    LAG_SETTINGS,
    PROBES,
    TRUTH_MECHANISMS,
    Probe,
    baseline_level,
    parse_seed_part,
    part_seeds,
    probe_parts,
)
from dronewind.errors import InputError
from dronewind.payload.chain import compute_ins_l1, compute_payload_l2, compute_sonic_l1

if TYPE_CHECKING:
    from dronewind.simulate.payload import PayloadTruth

LOG = logging.getLogger("dronewind")

__all__ = [
    "probe_runs",
    "merge_probe_runs",
    "shares_truth",
    "simulated_sonic_ins_lag_s",
]


def _probe_parameters(probe: Probe, level: float) -> dict[str, float]:
    """Parameters of a probe's mechanism at one level: the others fixed or at their baseline."""
    params = {probe.parameter: float(level)}
    for name in _other_parameters(probe.mechanism, probe.parameter):
        params[name] = dict(probe.fixed).get(name, baseline_level(probe.mechanism, name))
    return params


def probe_runs(
    campaign_data: Mapping[str, Any],
    flight_id: str,
    conditions: Mapping[str, Any],
    processing: Mapping[str, Any],
    seeds: tuple[int, ...],
    probes: tuple[Probe, ...] = PROBES,
    parts: Sequence[str] | None = None,
    atmosphere: xr.Dataset | None = None,
    lag_drift: bool = True,
    features: Collection[str] | None = None,
) -> dict[str, Any]:
    """Baseline and probe runs of the forward model for one flight.

    Parameters
    ----------
    campaign_data : mapping
        Manifest content of the measured campaign (or its one-flight view).
    flight_id : str
        Payload flight id.
    conditions : mapping
        Output of :func:`forward_conditions`.
    processing : mapping
        ``processing`` settings (keys of :data:`CHAIN_SETTINGS`).
    seeds : tuple of int
        Baseline seeds (``diagnosis.seeds``); the first one is also used for every probe run
        (common random numbers, so a probe's difference to that baseline is the
        mechanism's effect).
    probes : tuple of Probe
        Probes to run.
    parts : sequence of str, optional
        Run only these parts (:func:`probe_parts`: ``"baseline"`` and mechanism names, or a
        share of the baseline seeds, :func:`~dronewind.diagnose.probes.seed_part`); all by
        default.
    atmosphere : xarray.Dataset, optional
        The reference mast's measured record of the flight (:func:`atmosphere_record`,
        ``diagnosis.atmosphere: measured``); the similarity model's field without it.
    lag_drift : bool
        Compute the ``lag_drift_s`` feature (:func:`process_forward_flight`); when false it
        is NaN in every run and ``lag_drift`` is false in the result.
    features : collection of str, optional
        Only these features (e.g. those a set of published numbers holds); all by default.
        They are listed in the result's ``features``.

    Returns
    -------
    dict
        ``{"baseline": [features per seed], "probes": [{candidate, mechanism,
        parameter, level, fixed, features}]}`` with features as
        :func:`~dronewind.diagnose.features.features_to_dict` dictionaries; probe levels a
        flight cannot take are listed in ``skipped_probes``; ``parts`` names the parts
        run and ``reused_products`` counts the products reused (:class:`ForwardCache`),
        ``reused_steps`` the steps inside them (:attr:`ForwardCache.steps`);
        ``atmosphere`` says which atmosphere was used (``measured`` or ``model``) and
        ``atmosphere_record`` what was used of the measured record;
        ``simulated_sonic_ins_lag_s`` (when the conditions carry the measured lag
        ``sonic_ins_lag_s``) is the processing lag every run simulates
        (:func:`simulated_sonic_ins_lag_s`; a probe of ``sonic_ins_lag`` or
        ``attitude_lag`` adds to it). The probes' features
        are values only (their errors NaN, not computed): the diagnosis takes the errors
        from the baseline seeds (:mod:`dronewind.diagnose.campaign`).

    Notes
    -----
    Every part gives the same numbers alone as in a run of the whole flight: the probes'
    true state is the first seed's, simulated again when the baseline is not in the part.

    With a measured atmosphere the baseline seeds differ in the part of the field not
    determined by the record (the hover point's incoherent part, the instruments' noise,
    the payload's motion) and in the record's spectra, drawn again per seed from their
    sampling distribution, so their scatter is the sampling error of the features across
    independent atmospheres, not only given the mast. The probes take the first seed's
    spectra as well as its remainder (common random numbers: the draws depend on the seed
    and the frequencies only). A probe of a mechanism that acts on the reference mast's record
    (:data:`RECORD_INVERSES`) reads the record through that mechanism: the atmosphere is the
    record with the mechanism undone (the true wind the mast would have measured), and the
    forward mast then measures it with the mechanism, i.e. the measured record again. Such
    probes simulate their own true state.
    """
    from dronewind.diagnose.features import features_to_dict
    from dronewind.simulate.payload import payload_truth

    parts = tuple(probe_parts(probes)) if parts is None else tuple(parts)
    unknown = sorted(set(parts) - set(probe_parts(probes)) - {p for p in parts if _is_seed_part(p)})
    if unknown:
        raise InputError("parts", f"unknown forward-run part(s) {unknown}; expected some of {probe_parts(probes)} "
                         "or seed parts 'baseline:k/n'")
    out: dict[str, Any] = {"flight": flight_id, "conditions": dict(conditions), "seeds": list(seeds),
                           "parts": list(parts), "baseline": [], "probes": [],
                           "atmosphere": "model" if atmosphere is None else "measured", "lag_drift": bool(lag_drift),
                           "features": list(FEATURES) if features is None else [f for f in FEATURES if f in features]}
    levels = [(probe, level) for probe in probes if probe.mechanism in parts for level in probe.levels]
    run_seeds = [seed for part in sorted(parts, key=_seed_part_index) for seed in (part_seeds(part, seeds) or [])]
    progress = Progress("probe", len(run_seeds) + len(levels), "run")
    measured = atmosphere is not None
    cache = ForwardCache()  # the products of the runs, reused where a probe leaves a record unchanged
    # the first seed's true state, reused by every measurement-stage probe (made here when the
    # conditions carry the measured lag, which is reproduced on it)
    base_lag, truth = simulated_sonic_ins_lag_s(campaign_data, flight_id, conditions, processing, seeds[0],
                                                atmosphere, cache=cache)
    if base_lag is not None:
        out["simulated_sonic_ins_lag_s"] = base_lag
        conditions = {**dict(conditions), "sonic_ins_lag_s": base_lag}
    if run_seeds and run_seeds[0] != seeds[0]:
        # a later share of the seeds: the cache keeps the first seed's products (the lag step's),
        # as a whole flight's run keeps those of its first seed; no later seed's are stored
        cache.freeze()
    for seed in run_seeds:
        with progress.item(f"flight {flight_id} baseline seed {seed}"):
            feats, products = run_forward(forward_manifest(campaign_data, flight_id, conditions, None, seed, measured),
                                          flight_id, processing, truth=truth if seed == seeds[0] else None,
                                          cache=cache, atmosphere=atmosphere, lag_drift=lag_drift, features=features)
        if seed == seeds[0]:
            truth = products["truth"]
            cache.freeze()
        # a run's products are not read again: freed before the next run, so that two runs'
        # datasets (and a height offset's own true state) are never held at once
        del products
        out["baseline"].append(features_to_dict(feats))
    if truth is None and any(shares_truth([{"mechanism": probe.mechanism}], measured) for probe, _ in levels):
        truth = payload_truth(forward_manifest(campaign_data, flight_id, conditions, None, seeds[0], measured),
                              flight_id, atmosphere)
    if truth is not None and atmosphere is not None:
        out["atmosphere_record"] = dict(truth.atmosphere_info)
    for probe, level in levels:
        name = f"flight {flight_id} {probe.candidate} {probe.parameter}={level:g}"
        params = _probe_parameters(probe, level)
        mech = [{"mechanism": probe.mechanism, "parameters": params}]
        reuse = truth if shares_truth(mech, measured) else None
        record = None if atmosphere is None else record_through(atmosphere, mech)
        try:
            with progress.item(name):
                feats = run_forward(forward_manifest(campaign_data, flight_id, conditions, mech, seeds[0], measured),
                                    flight_id, processing, truth=reuse, cache=cache, atmosphere=record,
                                    lag_drift=lag_drift, features=features, errors=False)[0]
        except InputError as exc:
            # a level outside what this flight allows (e.g. a height offset deeper than
            # the measured hover height): recorded and left out; the candidate's response
            # for this flight then has fewer levels (NaN where missing)
            progress.skipped(name, str(exc))
            out.setdefault("skipped_probes", []).append({"candidate": probe.candidate,
                                                         "parameter": probe.parameter, "level": float(level),
                                                         "reason": str(exc)})
            continue
        out["probes"].append({"candidate": probe.candidate, "mechanism": probe.mechanism,
                              "parameter": probe.parameter, "level": float(level),
                              "fixed": dict(probe.fixed), "features": features_to_dict(feats)})
    progress.finished()
    out["reused_products"] = {"hits": cache.hits, "misses": cache.misses}
    out["reused_steps"] = {"hits": cache.steps.hits, "misses": cache.steps.misses}
    return out


def simulated_sonic_ins_lag_s(campaign_data: Mapping[str, Any], flight_id: str, conditions: Mapping[str, Any],
                              processing: Mapping[str, Any], seed: int, atmosphere: xr.Dataset | None = None,
                              truth: PayloadTruth | None = None, cache: ForwardCache | None = None
                              ) -> tuple[float | None, PayloadTruth | None]:
    """The sonic-INS processing lag with which the forward chain finds the flight's measured lag.

    The chain's lag of minimum TKE (Ghirardelli et al. 2025, Sect. 3.3) is not the
    processing lag itself: the payload's attitude follows the wind (the drone banks into
    lateral gusts, the payload weathervanes), so shifting the INS against the sonic also
    removes part of the wind's own variance, and the minimum lies below the simulated lag
    (by 0.092 +- 0.033 s, mean and standard deviation over 60 flights of the hidden-effect
    campaign without a mechanism, 3.5-9.5 m s-1). Simulating the measured lag itself would
    shift the forward runs' lag by that much again. One step of a fixed-point iteration
    removes it: the first seed's flight is simulated with the measured lag :math:`\\ell_m`
    and its lag :math:`\\ell_f` found by the chain's lag search (lag only), and the runs take

    .. math:: \\ell_{sim} = \\ell_m - (\\ell_f - \\ell_m).

    On the search grid a whole number of lag steps moves the sonic's stamps and the TKE
    curve alike, so the first seed's baseline finds :math:`\\ell_m` again
    (``tests/diagnose/test_forward_lag.py``); the other seeds differ by their own sampling error.

    Parameters
    ----------
    campaign_data, flight_id, conditions, processing
        As :func:`probe_runs`; the measured lag is ``conditions["sonic_ins_lag_s"]``
        (:func:`forward_conditions`).
    seed : int
        The first baseline seed (the probes' seed).
    atmosphere : xarray.Dataset, optional
        The measured atmosphere record (:func:`atmosphere_record`).
    truth : PayloadTruth, optional
        The seed's true state, if made already.
    cache : ForwardCache, optional
        The flight's cache: the INS L1 and the simulator's steps made here are those of the
        first baseline run, which then reuses them.

    Returns
    -------
    lag_s : float or None
        The processing lag to simulate [s], within the settings' range
        (:data:`dronewind.simulate.defaults.SONIC_INS_LAG_RANGE_S`); None when the conditions
        carry no lag. The measured lag itself when the lag search fails on the simulated flight.
    truth : PayloadTruth or None
        The seed's true state (None when the conditions carry no lag and none was given).
    """
    from dronewind.simulate.defaults import SONIC_INS_LAG_RANGE_S
    from dronewind.simulate.payload import payload_records

    if conditions.get("sonic_ins_lag_s") is None:
        return None, truth
    measured_lag = float(conditions["sonic_ins_lag_s"])
    manifest = forward_manifest(campaign_data, flight_id, conditions, None, seed, atmosphere is not None)
    cache = ForwardCache() if cache is None else cache
    with reusing(cache.steps):
        records, truth = payload_records(manifest, flight_id, truth, atmosphere)
        ins_table, ins_l1 = cache.get("ins_l1", [records[1]], lambda: compute_ins_l1(records[1]))
        sonic_l1 = compute_sonic_l1(records[0], records[1], ins_table, processing["despike"])
        flight = next(f for f in manifest["payload_flights"] if f["id"] == flight_id)
        lag = {key: processing[key] for key in LAG_SETTINGS}
        try:
            l2 = compute_payload_l2(sonic_l1, ins_l1, flight, float(manifest["site"]["altitude_m"]), lag_only=True,
                                    **lag)
        except InputError as exc:
            LOG.warning("flight %s: the forward runs simulate the measured lag %+.5f s (lag search failed: %s)",
                        flight_id, measured_lag, exc)
            return measured_lag, truth
    found = _measured_lag_s(l2)
    if found is None:
        return measured_lag, truth
    lo, hi = SONIC_INS_LAG_RANGE_S
    return float(min(max(2.0 * measured_lag - found, lo), hi)), truth


def shares_truth(mechanisms: Sequence[Mapping[str, Any]], measured: bool) -> bool:
    """Whether a run with these mechanisms has the true state of a run without them (same seed).

    True when every mechanism acts on the measurement only: none moves the hover point
    (:data:`TRUTH_MECHANISMS`) and, with a measured atmosphere, none is undone on the
    reference record (:data:`RECORD_INVERSES`), which constrains the field. Such a run can
    take the other run's :class:`~dronewind.simulate.payload.PayloadTruth` and its
    :class:`ForwardCache` (common random numbers: the records and products it shares are
    bit-identical to those it would make itself).

    Parameters
    ----------
    mechanisms : sequence of mapping
        ``[{"mechanism": name, "parameters": {...}}]``.
    measured : bool
        The runs take the measured atmosphere (``diagnosis.atmosphere: measured``).

    Returns
    -------
    bool
    """
    names = {m["mechanism"] for m in mechanisms}
    return not names & (TRUTH_MECHANISMS | (set(RECORD_INVERSES) if measured else set()))


def merge_probe_runs(parts: Sequence[Mapping[str, Any]], probes: tuple[Probe, ...] = PROBES) -> dict[str, Any]:
    """Join the parts of one flight's forward runs (:func:`probe_runs` with ``parts``) into one.

    Parameters
    ----------
    parts : sequence of dict
        Outputs of :func:`probe_runs` for the same flight, conditions and seeds, each part
        once, together covering :func:`probe_parts`.
    probes : tuple of Probe
        The probes the parts were run with (their order is the order of the result).

    Returns
    -------
    dict
        What :func:`probe_runs` returns for all parts in one run (``reused_products``
        summed over the parts).

    Raises
    ------
    InputError
        Parts of other flights, conditions or seeds, a part twice or a part missing.
    """
    if not parts:
        raise InputError("parts", "no forward-run parts to merge")
    first = parts[0]
    names: list[str] = []
    for part in parts:
        for key in ("flight", "conditions", "seeds", "atmosphere", "lag_drift", "features",
                    "simulated_sonic_ins_lag_s"):
            if part.get(key) != first.get(key):
                raise InputError(f"parts: {key}", f"forward-run parts disagree on {key}: {part.get(key)!r} and "
                                 f"{first.get(key)!r}")
        names += list(part["parts"])
        own = sorted(_seed_part_index(n) for n in part["parts"] if _is_seed_part(n))
        if own and own != list(range(own[0], own[0] + len(own))):
            raise InputError("parts", f"forward-run part with the seed parts {part['parts']}: expected consecutive "
                             "ones (a contiguous share of the seeds)")
    seed_parts = sorted((n for n in names if _is_seed_part(n)), key=_seed_part_index)
    whole = [BASELINE_PART if n == seed_parts[0] else n for n in names if n not in seed_parts[1:]] if seed_parts \
        else names
    shares = [part_seeds(n, first["seeds"]) for n in seed_parts]
    if sorted(whole) != sorted(probe_parts(probes)) or (
            seed_parts and ({_seed_share(n)[1] for n in seed_parts} != {len(seed_parts)}
                            or [s for share in shares for s in (share or [])] != list(first["seeds"]))):
        raise InputError("parts", f"forward-run parts {sorted(names)}; expected each of {list(probe_parts(probes))} "
                         "once (the baseline whole or in every seed part 'baseline:k/n')")
    order = {(p.candidate, p.parameter, float(level)): k for k, (p, level) in
             enumerate((p, level) for p in probes for level in p.levels)}
    out: dict[str, Any] = {"flight": first["flight"], "conditions": first["conditions"], "seeds": first["seeds"],
                           "atmosphere": first.get("atmosphere"), "lag_drift": first.get("lag_drift", True),
                           "features": first.get("features", list(FEATURES)), "parts": list(probe_parts(probes)),
                           "baseline": _joined_baseline(parts, seed_parts),
                           "probes": sorted((r for p in parts for r in p["probes"]),
                                            key=lambda r: order[(r["candidate"], r["parameter"], float(r["level"]))])}
    skipped = sorted((r for p in parts for r in p.get("skipped_probes", [])),
                     key=lambda r: order[(r["candidate"], r["parameter"], float(r["level"]))])
    if skipped:
        out["skipped_probes"] = skipped
    records = [p["atmosphere_record"] for p in parts if "atmosphere_record" in p]
    if records:
        out["atmosphere_record"] = records[0]
    if "simulated_sonic_ins_lag_s" in first:
        out["simulated_sonic_ins_lag_s"] = first["simulated_sonic_ins_lag_s"]
    for key in ("reused_products", "reused_steps"):
        out[key] = {k: sum(int(p.get(key, {}).get(k, 0)) for p in parts) for k in ("hits", "misses")}
    return out


def _seed_share(name: str) -> tuple[int, int]:
    """``(k, n)`` of a seed part ``baseline:k/n`` (:func:`parse_seed_part`); ``(0, 0)`` for any other part."""
    try:
        return parse_seed_part(name) or (0, 0)
    except ValueError:
        return 0, 0


def _is_seed_part(name: str) -> bool:
    """Whether a part name is a share of the baseline seeds (``baseline:k/n``)."""
    return _seed_share(name)[0] > 0


def _seed_part_index(name: str) -> int:
    """``k`` of a seed part ``baseline:k/n`` (0 for any other part)."""
    return _seed_share(name)[0]


def _joined_baseline(parts: Sequence[Mapping[str, Any]], seed_parts: Sequence[str]) -> list[Any]:
    """The baseline runs of the whole seed list: the ``baseline`` part's, or those of the parts that
    hold seed parts, in the order of their shares (each holds a contiguous share, in order)."""
    if not seed_parts:
        return list(next(p["baseline"] for p in parts if BASELINE_PART in p["parts"]))
    holders = [p for p in parts if any(_is_seed_part(n) for n in p["parts"])]
    holders.sort(key=lambda p: min(_seed_part_index(n) for n in p["parts"] if _is_seed_part(n)))
    return [run for p in holders for run in p["baseline"]]


def _other_parameters(mechanism: str, parameter: str) -> list[str]:
    from dronewind.mechanisms import get_mechanism

    return [p for p in get_mechanism(mechanism).parameter_names if p != parameter]
