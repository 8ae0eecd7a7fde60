r"""The forward model's probes and settings: which mechanisms, parameters and levels it runs.

The names a workflow needs before any job runs (the settings a forward run depends on, the
parts a flight's runs split into, the seeds of the reruns), apart from the forward model
itself (:mod:`dronewind.diagnose.forward`), so that reading them imports no signal
processing or array library: the Snakefile imports them each time Snakemake starts, on a
cluster once per job.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

__all__ = ["CHAIN_SETTINGS", "LAG_SETTINGS", "TRUTH_MECHANISMS", "ATMOSPHERES", "Probe", "MECHANISM_BASELINES",
           "MIN_FLIGHTS", "PROBES", "fresh_seeds", "baseline_level", "BASELINE_PART", "probe_parts", "SEED_DOF",
           "SCALE_DOF", "MIN_SEEDS", "MAX_SEEDS", "baseline_seeds", "resolved_seeds", "seed_part", "part_seeds",
           "parse_seed_part", "reference_jobs"]


#: Keys of ``processing`` that the chain up to L3 uses (what a forward run depends on).
CHAIN_SETTINGS: tuple[str, ...] = ("despike", "max_missing_fraction", "hover", "sonic_ins_lag", "drone_mast",
                                   "rotation")
#: Mechanisms that change the true state of a flight (the hover point in the field), not only
#: its measurement: their probes simulate the flight anew; all others reuse the baseline's
#: true state (:class:`dronewind.simulate.payload.PayloadTruth`).
TRUTH_MECHANISMS: frozenset[str] = frozenset({"height_offset"})
#: Settings of ``diagnosis.atmosphere``: the turbulence of the forward runs is the reference
#: mast's measured record (``measured``: constrained generation with the record's spectra,
#: :func:`dronewind.simulate.payload.measured_constraint`) or the similarity model's at the
#: measured mean conditions (``model``).
ATMOSPHERES: tuple[str, ...] = ("measured", "model")
#: Keys of ``processing`` that the sonic-INS lag feature uses (:func:`measured_features`).
LAG_SETTINGS: tuple[str, ...] = ("sonic_ins_lag", "hover", "max_missing_fraction")


@dataclass(frozen=True)
class Probe:
    """One parameter of one candidate and the levels at which its response is simulated.

    Attributes
    ----------
    candidate : str
        Candidate name (the catalog name, or ``name@setting`` for a variant with a fixed
        second parameter, e.g. ``downwash@u_scale_ms=3``).
    mechanism : str
        Catalog name.
    parameter : str
        The fitted parameter.
    levels : tuple of float
        Probe levels (the baseline level is added automatically).
    fixed : dict
        Parameters held fixed for this candidate.
    """

    candidate: str
    mechanism: str
    parameter: str
    levels: tuple[float, ...]
    fixed: tuple[tuple[str, float], ...] = ()


#: Level of each fitted parameter at which its mechanism is off.
MECHANISM_BASELINES: dict[tuple[str, str], float] = {
    ("w_gain", "gain"): 1.0,
    ("mast_w_attenuation", "gain"): 1.0,
}

#: The probes of every payload/mast mechanism of the catalog (docs/data-contract.md). A parameter that can
#: take either sign about its baseline (a lag, an angle, an offset, a gain about 1) is probed on
#: both sides, so that the response of an even (e.g. quadratic) feature is never extrapolated
#: from one side to the other; the fit bounds are the catalog's physical range
#: (:mod:`dronewind.mechanisms`), not the probe span.
PROBES: tuple[Probe, ...] = (
    Probe("sonic_ins_lag", "sonic_ins_lag", "lag_s", (-0.3, 0.3)),
    Probe("clock_drift", "clock_drift", "ppm", (-300.0, 300.0)),
    Probe("mount_misalignment", "mount_misalignment", "roll_deg", (-4.0, 4.0)),
    Probe("mount_misalignment", "mount_misalignment", "pitch_deg", (-4.0, 4.0)),
    Probe("mount_misalignment", "mount_misalignment", "yaw_deg", (-6.0, 6.0)),
    Probe("heading_bias", "heading_bias", "deg", (-8.0, 8.0)),
    Probe("attitude_lag", "attitude_lag", "lag_s", (0.1, 0.3)),
    Probe("lever_arm", "lever_arm", "x_m", (-0.6, 0.6)),
    Probe("lever_arm", "lever_arm", "y_m", (-0.6, 0.6)),
    Probe("lever_arm", "lever_arm", "z_m", (-0.6, 0.6)),
    Probe("w_gain", "w_gain", "gain", (0.85, 1.2)),
    Probe("sonic_noise", "sonic_noise", "sigma_ms", (0.15, 0.35)),
    Probe("height_offset", "height_offset", "dz_m", (-6.0, 6.0, 15.0)),
    Probe("downwash@u_scale_ms=3", "downwash", "w0_ms", (1.0,), (("u_scale_ms", 3.0),)),
    Probe("downwash@u_scale_ms=8", "downwash", "w0_ms", (1.0,), (("u_scale_ms", 8.0),)),
    Probe("mast_w_attenuation", "mast_w_attenuation", "gain", (0.85, 1.1)),
)


def fresh_seeds(used: Sequence[int], n: int = 2) -> tuple[int, ...]:
    """``n`` campaign seeds for a rerun that none of the ``used`` (baseline) seeds equals.

    The extended-model reruns check the fit on realisations it was not made with; with
    seeds the baseline also ran, the check would reuse the same turbulence. Returns 303 and
    404 (the reruns' historical seeds) where free, else the next multiples of 101 above the
    largest used seed.

    Parameters
    ----------
    used : sequence of int
        ``diagnosis.seeds``.
    n : int
        Number of seeds.

    Returns
    -------
    tuple of int
        ``n`` distinct seeds, none in ``used``.

    Examples
    --------
    >>> fresh_seeds([101, 202])
    (303, 404)
    >>> fresh_seeds([101, 202, 303, 404, 505])
    (606, 707)
    """
    taken = {int(s) for s in used}
    historic = (303, 404)[:n]
    if len(historic) == n and not taken & set(historic):
        return historic
    start = (max(taken, default=0) // 101 + 1) * 101
    return tuple(start + 101 * k for k in range(n))


#: Pooled degrees of freedom of the baseline seeds that the feature covariance is estimated
#: with by default: with 15 features the Schäfer-Strimmer shrinkage intensity falls with the
#: degrees of freedom (measured on null campaigns: 0.28 with 89 seeds on 4 flights, 356 degrees
#: of freedom; 0.31 with 36 seeds on 10 flights, 350; 0.36 with 60 seeds, 236; 0.26 with 41
#: seeds on 10 flights, 400), and a campaign of measured atmospheres, whose seeds vary only the
#: part of the wind the mast does not fix, has weaker correlations (on the default campaign
#: 0.357 at 400 and 0.308 at 520, about as the power -0.56). 640 keep the intensity below 0.3
#: in both, so that real correlations between the features of one w series are kept rather
#: than shrunk away.
SEED_DOF = 640
#: Pooled degrees of freedom of baseline seeds that only scale the errors (no correlation
#: estimated: the published numbers, :mod:`dronewind.diagnose.published`): a seed scale with
#: 200 degrees of freedom has a relative standard error of 1/sqrt(2 x 200) = 5 %; the seven
#: stationary flights of Ghirardelli et al. (2025) then take the fewest seeds per flight
#: (:data:`MIN_SEEDS`), and their fit still names w_gain (benchmarks/results/run_default.json's run).
SCALE_DOF = 200
#: Fewest baseline seeds per flight (the seed scale of every feature then has at least 29
#: degrees of freedom on one flight).
MIN_SEEDS = 30
#: Fewest usable payload flights a campaign diagnosis needs: its held-out gain scores each
#: candidate on a flight left out of the fit. With fewer the campaign is not diagnosed
#: (:func:`dronewind.diagnose.record.not_diagnosed_json`) and draws no bootstrap reference.
MIN_FLIGHTS = 2
#: Most baseline seeds per flight by default: campaigns of one to seven flights stop here
#: (89 to 623 pooled degrees of freedom) instead of paying up to 641 runs per flight.
MAX_SEEDS = 90


def baseline_seeds(n_flights: int, dof: int = SEED_DOF, minimum: int = MIN_SEEDS,
                   maximum: int = MAX_SEEDS) -> list[int]:
    """Baseline seeds of the forward model for a campaign of ``n_flights`` (``diagnosis.seeds: null``).

    Parameters
    ----------
    n_flights : int
        Payload flights whose seeds are pooled.
    dof : int
        Pooled degrees of freedom wanted, :math:`n_{flights}(n_{seeds} - 1)`.
    minimum, maximum : int
        Fewest and most seeds per flight.

    Returns
    -------
    list of int
        ``ceil(dof / n_flights) + 1`` seeds within ``[minimum, maximum]``, the multiples of 101
        from 101.

    Examples
    --------
    >>> len(baseline_seeds(1)), len(baseline_seeds(4)), len(baseline_seeds(6)), len(baseline_seeds(20))
    (90, 90, 90, 33)
    """
    n = min(int(maximum), max(int(minimum), -(-int(dof) // max(int(n_flights), 1)) + 1))
    return [101 * (k + 1) for k in range(n)]


#: CPU seconds of the bootstrap per replicate and payload flight: a diagnose_reference job of the
#: default campaign takes 4.4 CPU-s for 300 replicates of 10 flights, of which 0.5 CPU-s are its
#: start-up and reading of the evidence (its log, ``bench_run.py default``).
REPLICATE_CPU_S_PER_FLIGHT = 0.0013
#: CPU seconds of work a part of the bootstrap reference is sized to (:func:`reference_jobs`): a
#: part stays within the first 15 s of its job, which Snakemake's benchmark samples every 0.5 s.
REFERENCE_JOB_CPU_S = 12.0


def reference_jobs(n_flights: int, replicates: int, most: int) -> int:
    """Jobs the diagnosis' bootstrap reference is drawn in (``diagnosis.bootstrap_jobs`` at most).

    Parts of about :data:`REFERENCE_JOB_CPU_S` of work each: a part costs a job's start-up
    (about 1 CPU-s) besides its replicates, so a campaign whose whole bootstrap is short takes
    fewer, and one without a reference (fewer than two payload flights) one.

    Examples
    --------
    >>> reference_jobs(10, 600, 4), reference_jobs(40, 600, 4), reference_jobs(4, 600, 4)
    (1, 3, 1)
    """
    if int(n_flights) < MIN_FLIGHTS:
        return 1
    work_s = int(n_flights) * int(replicates) * REPLICATE_CPU_S_PER_FLIGHT
    return max(1, min(int(most), -(-int(work_s) // int(REFERENCE_JOB_CPU_S))))


def resolved_seeds(seeds: Sequence[int] | None, n_flights: int, dof: int = SEED_DOF) -> list[int]:
    """``diagnosis.seeds`` as a list: the given seeds, or :func:`baseline_seeds` when null."""
    return [int(s) for s in seeds] if seeds else baseline_seeds(n_flights, dof)


def baseline_level(mechanism: str, parameter: str) -> float:
    """Parameter value at which a mechanism is off."""
    return MECHANISM_BASELINES.get((mechanism, parameter), 0.0)


#: Name of the part of a flight's forward runs that holds the baseline seeds (:func:`probe_parts`).
BASELINE_PART = "baseline"


def probe_parts(probes: tuple[Probe, ...] = PROBES) -> tuple[str, ...]:
    """The parts a flight's forward runs split into: the baseline seeds, then one per mechanism.

    Each part is an independent job of the workflow (``diagnosis.probe_jobs: mechanism``),
    so that a cluster runs a flight's probes in parallel; :func:`dronewind.diagnose.forward.merge_probe_runs` joins
    them into what :func:`dronewind.diagnose.forward.probe_runs` returns for the whole flight.
    """
    return (BASELINE_PART, *dict.fromkeys(p.mechanism for p in probes))


def seed_part(k: int, n_parts: int) -> str:
    """Name of the ``k``-th (from 1) of ``n_parts`` parts of the baseline seeds (:func:`part_seeds`).

    Examples
    --------
    >>> seed_part(1, 2)
    'baseline:1/2'
    """
    if not 1 <= int(k) <= int(n_parts):
        raise ValueError(f"seed part {k} of {n_parts}: expected 1 <= k <= {n_parts}")
    return f"{BASELINE_PART}:{int(k)}/{int(n_parts)}"


def part_seeds(part: str, seeds: Sequence[int]) -> list[int] | None:
    """The baseline seeds a part runs: all for ``baseline``, a contiguous share for a seed part.

    Parameters
    ----------
    part : str
        A part name (:func:`probe_parts`, :func:`seed_part`).
    seeds : sequence of int
        The flight's baseline seeds.

    Returns
    -------
    list of int or None
        The ``k``-th of ``n`` near-equal contiguous shares of ``seeds`` for ``baseline:k/n``
        (their order kept), all of them for ``baseline``; None for a mechanism's part.

    Examples
    --------
    >>> part_seeds("baseline:2/2", [101, 202, 303, 404, 505])
    [303, 404, 505]
    """
    if part == BASELINE_PART:
        return list(seeds)
    share = parse_seed_part(part)
    if share is None:
        return None
    k, n = share
    return list(seeds)[(k - 1) * len(seeds) // n:k * len(seeds) // n]


def parse_seed_part(part: str) -> tuple[int, int] | None:
    """``(k, n)`` of a seed part ``baseline:k/n`` (:func:`seed_part`); None for any other part name.

    Raises
    ------
    ValueError
        A name that starts as a seed part but is not one (``baseline:two``, ``baseline:4/3``).

    Examples
    --------
    >>> parse_seed_part("baseline:2/3"), parse_seed_part("baseline"), parse_seed_part("w_gain")
    ((2, 3), None, None)
    """
    if not part.startswith(BASELINE_PART + ":"):
        return None
    try:
        k, n = (int(x) for x in part.split(":", 1)[1].split("/"))
    except ValueError:
        raise ValueError(f"seed part {part!r}: expected 'baseline:k/n'") from None
    seed_part(k, n)  # validates k and n
    return k, n
