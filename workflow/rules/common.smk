# Configuration, campaign manifest validation, helpers and wildcard constraints.
#
# Each rule receives the settings it uses as params (Snakemake reruns a job when its params
# change), never the whole config: per-flight rules get their flight's manifest entry, its
# reference sonic's entry and the `processing` keys they use; the manifest file is an input
# only of the rules that read all of it (campaign record, campaign diagnosis).
import os
from pathlib import Path

from snakemake.logging import logger
from snakemake.utils import min_version, validate

from dronewind.config import check_config
from dronewind.core.attribution import attribution
from dronewind.diagnose.probes import (
    CHAIN_SETTINGS,
    SCALE_DOF,
    fresh_seeds,
    probe_parts,
    reference_jobs,
    resolved_seeds,
    seed_part,
)
from dronewind.figures.labels import (
    APPENDIX_FIGURES,
    BLOCK_FIGURE,
    QUAD_FIGURES,
    TUNNEL_FIGURES,
    figure_captions,
)
from dronewind.formats import check_campaign_formats
from dronewind.manifest import (
    confined_path,
    is_rigid,
    load_campaign,
    payload_flight_manifest,
)
from dronewind.simulate.settings import simulation_manifest, validate_simulation
from dronewind.steps.blocks import block_settings

min_version("9.0")


# Settings are typed by the schema (a --config value reaches here as text), checked (a range,
# an allowed value, an unknown key with the nearest valid name: before any job runs, so a
# mistyped key never falls back to a default), and missing ones take their defaults from the
# schema, the one place defaults are kept.
config.update(check_config(config, defaults=False))
validate(config, "../schemas/config.schema.yaml")

# The manifest is validated before any job runs: a bad manifest stops the workflow with
# a message naming the manifest, the key path and what was expected.
CAMPAIGN = load_campaign(config["campaign"])
if CAMPAIGN.simulated:
    # the simulator's settings are checked before any job too (names the setting)
    validate_simulation(CAMPAIGN.data)
else:
    # a measured campaign's files are read in their declared formats: each file's first
    # lines are checked against its format before any job (names the file and line); a damaged
    # file of a record whose other files are fine is left out by its reader, with a warning
    for _warning in check_campaign_formats(CAMPAIGN):
        logger.warning(_warning)
RESULTS = Path(config["results_dir"]) / CAMPAIGN.name
# A virtual campaign's raw files are written by the simulator under results/<name>/L0/;
# a measured campaign's raw files are where its manifest says.
L0 = RESULTS / "L0" if CAMPAIGN.simulated else CAMPAIGN.data_root
ENV = "../envs/dronewind.yaml"


# PAYLOAD_FLIGHTS: the sling-load flights (sonic + INS files, a reference mast), which the
# tables, figures and diagnosis cover; RIGID_FLIGHTS: rigid-mount multicopter flights
# (platform: rigid_mount), processed to L4 and flight_stats.csv, against their reference
# mast when they name one (RIGID_MAST_FLIGHTS), else drone only (DRONE_ONLY_FLIGHTS).
PAYLOAD_FLIGHTS = [f["id"] for f in CAMPAIGN.payload_flights if not is_rigid(f)]
RIGID_FLIGHTS = [f["id"] for f in CAMPAIGN.payload_flights if is_rigid(f)]
DRONE_ONLY_FLIGHTS = [
    f["id"] for f in CAMPAIGN.payload_flights if is_rigid(f) and not f.get("reference")
]
RIGID_MAST_FLIGHTS = [f for f in RIGID_FLIGHTS if f not in DRONE_ONLY_FLIGHTS]
# the flights compared with a reference mast sonic (mast L2, L3 and both L4 files)
MAST_FLIGHTS = PAYLOAD_FLIGHTS + RIGID_MAST_FLIGHTS
QUAD_FLIGHTS = [f["id"] for f in CAMPAIGN.quadrotor_flights]
MAST_SONICS = list(CAMPAIGN.mast_sonics())
# Tower- and mast-only campaigns (no payload or rigid-mount flight): the mast sonics are
# analysed in blocks (blocks.smk) by default. In a flight campaign the mast records are the
# flights' references and its outputs stay as they are (no blocks unless asked for by target).
BLOCK_SONICS = MAST_SONICS if not (PAYLOAD_FLIGHTS or RIGID_FLIGHTS) else []
FIGURES = list(figure_captions())
# the campaign figures of the figures_appendix job (the others: the figures job)
MAIN_FIGURES = [name for name in FIGURES if name not in APPENDIX_FIGURES]


def canonical(value):
    """A setting with its mappings' keys sorted.

    Snakemake keeps the repr of each param as the job's rerun trigger: sorted keys make it
    independent of the order in which settings are written or filled in.
    """
    if isinstance(value, dict):
        return {key: canonical(value[key]) for key in sorted(value)}
    if isinstance(value, list):
        return [canonical(v) for v in value]
    return value


PROCESSING = canonical(config["processing"])
DIAGNOSIS = canonical(config["diagnosis"])
# the baseline seeds: as configured, or enough for the campaign's payload flights (probes.baseline_seeds)
DIAGNOSIS["seeds"] = resolved_seeds(DIAGNOSIS["seeds"], len(PAYLOAD_FLIGHTS))
# settings of the chain up to L3 (what a forward-model run depends on)
CHAIN = {key: PROCESSING[key] for key in CHAIN_SETTINGS}
# settings of the block analysis of tower and mast records (rule mast_blocks)
BLOCK_PROCESSING = block_settings(PROCESSING)
SITE = CAMPAIGN.data["site"]
# creator and licence of the products, from the manifest (dronewind.core.attribution)
ATTRIBUTION = attribution(CAMPAIGN.data.get("creator"), CAMPAIGN.data.get("license"))


def _published():
    """The published-results file (validated) and its samples, if it applies to this campaign."""
    path = config["diagnosis"]["published"]
    if not path:
        return None, []
    from dronewind.diagnose.published_file import load_published

    pub = load_published(path)
    if pub["source"].get("campaign") != CAMPAIGN.name:
        return None, []
    missing = [f for f in pub["stationary_flights"] if f not in PAYLOAD_FLIGHTS]
    if missing:
        raise ValueError(
            f"{path}: stationary_flights {missing} are not payload flights of {CAMPAIGN.path}"
        )
    return path, list(pub["stationary_flights"])


PUBLISHED, PUBLISHED_FLIGHTS = _published()
# the published numbers' baseline seeds, enough for their stationary flights (only their
# seed scale is estimated, no feature correlation)
PUBLISHED_SEEDS = resolved_seeds(
    config["diagnosis"]["seeds"], len(PUBLISHED_FLIGHTS), dof=SCALE_DOF
)

# Job priorities (Snakemake picks among ready jobs by priority). The forward-model runs are the
# longest jobs, so the chain that feeds them (simulation, L1-L3, measured features, the tunnel
# runs the quadrotor diagnosis reads) and the short steps that unlock the next ones (diagnosis,
# reruns, calibration, the campaign record) go first. The quadrotor diagnosis and the campaign
# figures, each as long as a forward run and needed by nothing but the report, run among the
# forward runs: left for last, each ran alone at the end of a run while the other core idled.
# The short campaign-level steps fill the cores at the end.
PRIORITY_CHAIN = 20
PRIORITY_FORWARD = 10


#: Wildcard constraint that matches nothing: a rule whose wildcard has it makes no job (the
#: rules of another mode, e.g. the forward runs split by mechanism or not).
NEVER = "(?!x)x"


def _alternatives(ids):
    """Wildcard constraint matching exactly these ids (never an empty alternation)."""
    return "|".join(map(str, ids)) if ids else NEVER


def only_if(condition, ids):
    """Wildcard constraint: these ids when ``condition`` holds, else nothing (the rule makes no job)."""
    return _alternatives(ids) if condition else NEVER


# parts of a flight's forward-model runs when they are one job each (diagnosis.probe_jobs)
PROBE_PARTS = list(probe_parts())
# the parts the diagnosis' bootstrap reference is drawn in by rule diagnose_reference, about 12 s
# of work each, at most diagnosis.bootstrap_jobs
N_REFERENCE = reference_jobs(
    len(PAYLOAD_FLIGHTS), DIAGNOSIS["bootstrap"], DIAGNOSIS["bootstrap_jobs"]
)
REFERENCE_PARTS = [str(k) for k in range(N_REFERENCE)]


wildcard_constraints:
    flight=_alternatives(PAYLOAD_FLIGHTS + RIGID_FLIGHTS),
    part=_alternatives(PROBE_PARTS),
    sonic=_alternatives(MAST_SONICS),


def log_path(rule_name, *wildcard_names):
    """Log file of a rule, one per wildcard combination."""
    parts = "_".join(f"{{{w}}}" for w in wildcard_names) or "all"
    return str(RESULTS / "logs" / rule_name / f"{parts}.log")


def bench_path(rule_name, *wildcard_names):
    """Benchmark file of a rule, one per wildcard combination."""
    parts = "_".join(f"{{{w}}}" for w in wildcard_names) or "all"
    return str(RESULTS / "benchmarks" / rule_name / f"{parts}.tsv")


def report_caption(name):
    """Caption of a figure in the HTML report: written from the data by rule report_pages (report.smk)."""
    return os.path.abspath(RESULTS / "report" / "captions" / f"{name}.rst")


def all_outputs():
    """Everything the default target builds for this campaign."""
    out = [str(RESULTS / "campaign.json")]
    if PAYLOAD_FLIGHTS:
        out.append(str(RESULTS / "tables" / "flight_stats.csv"))
        out += [
            str(RESULTS / "tables" / f"{t}.md")
            for t in ("table4_flights", "table5_statistics")
        ]
        out += [str(RESULTS / "figures" / f"{name}.png") for name in FIGURES]
        out += [
            str(RESULTS / "diagnosis.json"),
            str(RESULTS / "diagnosis" / "report.md"),
        ]
    if RIGID_FLIGHTS and not PAYLOAD_FLIGHTS:
        out.append(str(RESULTS / "tables" / "flight_stats.csv"))
        out.append(str(RESULTS / "diagnosis.json"))
    if BLOCK_SONICS:
        out.append(str(RESULTS / "tables" / "block_stats.csv"))
        out.append(str(RESULTS / "figures" / f"{BLOCK_FIGURE}.png"))
    if PUBLISHED:
        out.append(str(RESULTS / "published" / "report.md"))
    out += quadrotor_targets() + tunnel_targets() + autopilot_targets()
    out.append(str(RESULTS / "report" / "summary.html"))
    return out


# ----------------------------------------------------------------------------- payload flights: files


def payload_file(kind):
    """Input function: the raw sonic or INS file of a payload flight."""
    return lambda wc: str(L0 / CAMPAIGN.payload_flight(wc.flight)[kind]["file"])


def payload_format(kind):
    """Params function: the declared format of a payload flight's sonic or INS file (None: the contract CSV)."""

    def declared(wc):
        fmt = CAMPAIGN.payload_flight(wc.flight)[kind].get("format")
        return None if fmt in (None, "contract_csv", {"name": "contract_csv"}) else fmt

    return declared


def mast_files(sonic_id):
    """Raw TOA5 files of a mast sonic (for a virtual campaign: one per flight)."""
    return [str(p) for p in CAMPAIGN.mast_files(sonic_id, L0)]


def simulated_payload_outputs(flight_id):
    """Raw files the simulator writes for one payload flight (sonic, INS, every mast sonic)."""
    flight = CAMPAIGN.payload_flight(flight_id)
    out = {
        "sonic": str(L0 / flight["sonic"]["file"]),
        "ins": str(L0 / flight["ins"]["file"]),
    }
    for sonic_id, sonic in CAMPAIGN.mast_sonics().items():
        for k, pattern in enumerate(sonic["files"]):
            out[f"{sonic_id}_{k}"] = str(L0 / pattern.replace("*", flight_id))
    return out


def simulated_payload_patterns():
    """Output patterns (wildcard ``flight``) of the payload simulator's files.

    A virtual campaign names each flight's files after its id (``flights/s01/sonic.csv``,
    ``mast/mast30_s01.dat``), so one pattern per file describes every flight: the flight id in
    each path is replaced by ``{flight}``, and every flight must give the same patterns. A
    measured campaign has no simulator: its patterns lie under results/<name>/L0/ and the
    rule's wildcard matches no flight.
    """
    sims = [f for f in PAYLOAD_FLIGHTS if CAMPAIGN.simulated]
    if not sims:
        keys = ["sonic", "ins"] + [
            f"{sonic_id}_{k}"
            for sonic_id, sonic in CAMPAIGN.mast_sonics().items()
            for k in range(len(sonic["files"]))
        ]
        return {key: str(RESULTS / "L0" / "{flight}" / key) for key in keys}
    patterns = {}
    for flight_id in sims:
        for key, path in simulated_payload_outputs(flight_id).items():
            if flight_id not in path:
                raise ValueError(
                    f"{CAMPAIGN.path}: payload flight {flight_id}: simulated file {path} does "
                    "not contain the flight id (a virtual campaign names each flight's files after it)"
                )
            pattern = path.replace(flight_id, "{flight}")
            if patterns.setdefault(key, pattern) != pattern:
                raise ValueError(
                    f"{CAMPAIGN.path}: payload flight {flight_id}: simulated file {path} does not "
                    f"follow the layout of the other flights ({patterns[key]})"
                )
    return patterns


def reference_l1(flight_id):
    """L1 file of the mast sonic a payload flight is compared with."""
    ref = CAMPAIGN.payload_flight(flight_id)["reference"]
    return str(RESULTS / "netcdf" / "L1" / f"mast_{ref}.nc")


def reference_of(wc):
    """Input function: :func:`reference_l1` of the job's flight."""
    return reference_l1(wc.flight)


def l0_root(wildcards, output):
    """L0 folder of a simulated campaign (results/<name>/L0); the rule's outputs lie below it.

    The manifest validation keeps every virtual-campaign path relative and below L0.
    """
    for path in output:
        confined_path(L0, os.path.relpath(path, L0), "simulate output")
    return str(L0)


# ----------------------------------------------------------------------------- payload flights: params


def flight_entry(wc):
    """Params function: a payload flight's manifest entry."""
    return CAMPAIGN.payload_flight(wc.flight)


def target_height(wc):
    """Params function: a payload flight's nominal height above ground [m] (None if not given)."""
    return CAMPAIGN.payload_flight(wc.flight).get("target_height_m")


def mast_sonic(wc):
    """Params function: a mast sonic's manifest entry, with its mast's id and position."""
    return CAMPAIGN.mast_sonics()[wc.sonic]


def rigid_record(wc):
    """Input function: the record of a rigid-mount flight."""
    return str(L0 / CAMPAIGN.payload_flight(wc.flight)["record"]["file"])


def rigid_platform_log(wc):
    """Input function: the vehicle's own log of a rigid-mount flight (``platform_log``), or none."""
    log = CAMPAIGN.payload_flight(wc.flight).get("platform_log")
    return [str(L0 / log["file"])] if log else []


def flight_sensors(flight_id):
    """Sensors of a payload flight's L4: drone and mast, or drone alone without a reference."""
    return ["drone"] if flight_id in DRONE_ONLY_FLIGHTS else ["drone", "mast"]


def reference_sonic_of(flight_id):
    """The manifest entry of a flight's reference sonic."""
    return CAMPAIGN.mast_sonics()[CAMPAIGN.payload_flight(flight_id)["reference"]]


def reference_sonic(wc):
    """Params function: :func:`reference_sonic_of` the job's flight."""
    return reference_sonic_of(wc.flight)


def flight_manifest(wc):
    """Params function: the manifest reduced to a payload flight and its reference sonic."""
    return payload_flight_manifest(CAMPAIGN.data, wc.flight)


def published_manifest_of(flight_id):
    """The one-flight manifest with the flight's simulated atmosphere.

    The published-numbers diagnosis takes the atmosphere settings that the paper does not
    print (roughness length, temperature, boundary-layer depth) from the campaign that
    reconstructs the experiment.
    """
    return payload_flight_manifest(CAMPAIGN.data, flight_id, atmosphere=True)


def published_manifest(wc):
    """Params function: :func:`published_manifest_of` the job's flight."""
    return published_manifest_of(wc.flight)


# what the payload simulator reads of the manifest (its jobs' rerun trigger)
SIMULATION = simulation_manifest(CAMPAIGN.data) if CAMPAIGN.simulated else None


# ----------------------------------------------------------------------------- quadrotor and tunnel
# (SWUF-3D fleet flights, Wetz et al. (2021), and the wind tunnel, Kistner et al. (2024); rules in quadrotor.smk and tunnel.smk)
# Settings: the top-level `quadrotor:` section (defaults in the schema). Per-flight rules get
# what they read of their flight's manifest entry (the windows: the entry; L1 and L2, one job
# for all the flight's UAVs: the UAV ids) and the site as params, never the manifest file.

QUAD = canonical(config["quadrotor"])
QUAD_DIR = RESULTS / "quadrotor"
# The tunnel programme: `tunnel: {runs: tunnel/runs.csv}` in the manifest; a virtual campaign
# with `simulation.tunnel` gets it from the simulator under L0.
TUNNEL_RUNS_REL = (CAMPAIGN.data.get("tunnel") or {}).get("runs")
TUNNEL_SIMULATED = bool(
    CAMPAIGN.simulated and "tunnel" in (CAMPAIGN.data.get("simulation") or {})
)
TUNNEL_RUNS = (
    None
    if not TUNNEL_RUNS_REL
    else (L0 if TUNNEL_SIMULATED else CAMPAIGN.data_root) / TUNNEL_RUNS_REL
)


def quad_uavs(flight_id):
    """UAV ids of a quadrotor flight, in manifest order."""
    return [u["id"] for u in CAMPAIGN.quadrotor_flight(flight_id)["uavs"]]


def quad_raw(flight_id):
    """Raw UAV logs of a quadrotor flight (manifest order) and its tower reference."""
    flight = CAMPAIGN.quadrotor_flight(flight_id)
    uavs = [str(L0 / u["file"]) for u in flight["uavs"]]
    # a reference from the UAV records' own columns: the first record stands for it
    ref = flight["reference"]
    return uavs, str(L0 / ref) if isinstance(ref, str) else uavs[0]


def quad_simulation(flight_id):
    """What the quadrotor simulator reads of `simulation:` for one flight (its rerun trigger).

    The fleet settings, the flight's conditions, the seed and the mechanisms that may act on
    the flight (those without a `flights` list or listing it; the simulator validates them).
    """
    sim = CAMPAIGN.data.get("simulation") or {}
    mechanisms = [
        m
        for m in sim.get("mechanisms") or []
        if not isinstance(m, dict)
        or m.get("flights") is None
        or flight_id in m["flights"]
    ]
    out = {
        "quadrotor": sim.get("quadrotor") or {},
        "quadrotor_flights": {
            flight_id: (sim.get("quadrotor_flights") or {}).get(flight_id)
        },
        "mechanisms": mechanisms,
    }
    if "seed" in sim:
        out["seed"] = sim["seed"]
    return canonical(out)


def quad_l0_root(wildcards, output):
    """L0 folder of a simulated campaign, for the quadrotor fleet rule: its output ``l0`` lies below it (see l0_root)."""
    for path in output.l0:
        confined_path(L0, os.path.relpath(path, L0), "simulate output")
    return str(L0)


def quad_raw_all():
    """Raw UAV logs and tower references of every quadrotor flight (flight order, no repeats)."""
    files = []
    for f in QUAD_FLIGHTS:
        uavs, reference = quad_raw(f)
        files += uavs + [reference]
    return list(dict.fromkeys(files))


def quad_nc_all(level):
    """L1 or L2 NetCDF files of every UAV of every quadrotor flight (flight, then manifest order)."""
    return [path for f in QUAD_FLIGHTS for path in quad_nc(level, f)]


def quad_fleet(flights):
    """Params: per quadrotor flight, what the fleet's L1 and windows steps read of it."""
    return [
        {
            "flight": canonical(CAMPAIGN.quadrotor_flight(f)),
            "uavs": quad_uavs(f),
            "formats": [u.get("format") for u in CAMPAIGN.quadrotor_flight(f)["uavs"]],
            "raw": quad_raw(f)[0],
            "reference": quad_raw(f)[1],
            "l1": quad_nc("L1", f),
            "windows": [quad_windows(kind, [f])[0] for kind in QUAD_WINDOW_KINDS],
        }
        for f in flights
    ]


def quad_nc(level, flight_id):
    """L1 or L2 NetCDF files of every UAV of a quadrotor flight (manifest order)."""
    folder = RESULTS / "netcdf" / level / "quadrotor"
    return [str(folder / f"{flight_id}_{u}.nc") for u in quad_uavs(flight_id)]


def quad_timeseries_flight():
    """The quadrotor flight shown as time series (Wetz et al. 2021 Fig. 7): the one with most UAVs."""
    return max(QUAD_FLIGHTS, key=lambda f: (len(quad_uavs(f)), -QUAD_FLIGHTS.index(f)))


#: Per-flight window tables of the quadrotor chain.
QUAD_WINDOW_KINDS = ("windows", "blocks", "problems")


def quad_windows(kind, flights=None):
    """Per-flight window tables (kind: windows, blocks or problems)."""
    return [
        str(QUAD_DIR / "windows" / f"{f}_{kind}.csv")
        for f in (QUAD_FLIGHTS if flights is None else flights)
    ]


def quadrotor_targets():
    """Default targets of the quadrotor chain (empty without quadrotor flights)."""
    if not QUAD_FLIGHTS:
        return []
    out = [str(RESULTS / "tables" / "quadrotor_calibration.csv")]
    out.append(str(RESULTS / "quadrotor_diagnosis.json"))
    out += [str(RESULTS / "figures" / f"{name}.png") for name in QUAD_FIGURES]
    for f in QUAD_FLIGHTS:
        out += quad_nc("L2", f)
    return out


def tunnel_targets():
    """Default targets of the wind-tunnel chain (empty without a tunnel programme)."""
    if TUNNEL_RUNS is None:
        return []
    return [
        str(RESULTS / "tables" / "tunnel_calibration.csv"),
        str(RESULTS / "quadrotor_diagnosis.json"),
    ] + [str(RESULTS / "figures" / f"{name}.png") for name in TUNNEL_FIGURES]


# ----------------------------------------------------------------------------- autopilot flights
# (tilt wind against the autopilot's EKF wind; rules in autopilot.smk)
AUTOPILOT_FLIGHTS = [f["id"] for f in CAMPAIGN.autopilot_flights]
AUTOPILOT_DIR = RESULTS / "netcdf"


def autopilot_entry(wc):
    """Params function: an autopilot flight's manifest entry."""
    return canonical(CAMPAIGN.autopilot_flight(wc.aflight))


def autopilot_targets():
    """Default targets of the autopilot comparison (empty without autopilot flights)."""
    if not AUTOPILOT_FLIGHTS:
        return []
    return [str(RESULTS / "tables" / "autopilot_ekf_wind.csv")] + [
        str(RESULTS / "figures" / f"autopilot_ekf_wind_{f}.png")
        for f in AUTOPILOT_FLIGHTS
    ]


def figure_outputs(names):
    """The PNG (report items, in report.smk's subcategories) and PDF files of campaign figures."""
    png = [str(RESULTS / "figures" / f"{name}.png") for name in names]
    pdf = [str(RESULTS / "figures" / f"{name}.pdf") for name in names]
    items = [report(path, caption=report_caption(name), category="Payload validation", subcategory=FIGURE_SUBCATEGORIES[name]) for path, name in zip(png, names)]  # fmt: skip
    return {"png": items, "pdf": pdf}


def results_of_l4(wildcards, input):
    """The campaign's results folder, from the path of its first L4 product (results/<name>/netcdf/L4/...)."""
    return str(Path(input.l4[0]).parents[2])
