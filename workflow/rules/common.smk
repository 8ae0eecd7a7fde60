# Configuration, campaign manifest validation, helpers and wildcard constraints.
from pathlib import Path

from snakemake.utils import min_version, validate

from dronewind.figures.payload import figure_captions
from dronewind.figures.quadrotor import QUAD_FIGURES, TUNNEL_FIGURES
from dronewind.manifest import load_campaign
from dronewind.simulate.settings import validate_simulation

min_version("9.0")


validate(config, "../schemas/config.schema.yaml")

# The manifest is validated before any job runs: a bad manifest stops the workflow with
# a message naming the manifest, the key path and what was expected.
CAMPAIGN = load_campaign(config["campaign"])
if CAMPAIGN.simulated:
    # the simulator's settings are checked before any job too (names the setting)
    validate_simulation(CAMPAIGN.data)
RESULTS = Path(config["results_dir"]) / CAMPAIGN.name
# A virtual campaign's raw files are written by the simulator under results/<name>/L0/;
# a measured campaign's raw files are where its manifest says.
L0 = RESULTS / "L0" if CAMPAIGN.simulated else CAMPAIGN.directory
ENV = "../../envs/dronewind.yaml"

PAYLOAD_FLIGHTS = [f["id"] for f in CAMPAIGN.payload_flights]
QUAD_FLIGHTS = [f["id"] for f in CAMPAIGN.quadrotor_flights]
MAST_SONICS = list(CAMPAIGN.mast_sonics())
FIGURES = list(figure_captions())


def _published():
    """The published-results file (validated) and its samples, if it applies to this campaign."""
    path = (config.get("diagnosis") or {}).get("published")
    if not path:
        return None, []
    from dronewind.diagnose.published import load_published

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


def _alternatives(ids):
    """Wildcard constraint matching exactly these ids (never an empty alternation)."""
    return "|".join(map(str, ids)) if ids else "(?!x)x"


wildcard_constraints:
    flight=_alternatives(PAYLOAD_FLIGHTS),
    qflight=_alternatives(QUAD_FLIGHTS),
    sonic=_alternatives(MAST_SONICS),
    sensor="drone|mast",


def log_path(rule_name, *wildcard_names):
    """Log file of a rule, one per wildcard combination."""
    parts = "_".join(f"{{{w}}}" for w in wildcard_names) or "all"
    return str(RESULTS / "logs" / rule_name / f"{parts}.log")


def bench_path(rule_name, *wildcard_names):
    """Benchmark file of a rule, one per wildcard combination."""
    parts = "_".join(f"{{{w}}}" for w in wildcard_names) or "all"
    return str(RESULTS / "benchmarks" / rule_name / f"{parts}.tsv")


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
    if PUBLISHED:
        out.append(str(RESULTS / "published" / "report.md"))
    out += quadrotor_targets() + tunnel_targets()
    return out


def payload_file(kind):
    """Input function: the raw sonic or INS file of a payload flight."""
    return lambda wc: str(L0 / CAMPAIGN.payload_flight(wc.flight)[kind]["file"])


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


def reference_of(wc):
    """L1 file of the mast sonic a payload flight is compared with."""
    ref = CAMPAIGN.payload_flight(wc.flight)["reference"]
    return str(RESULTS / "netcdf" / "L1" / f"mast_{ref}.nc")


def l0_root(wildcards, output):
    """L0 folder of a simulated campaign, inferred from a simulate rule's sonic output."""
    sonic = Path(output.sonic)
    flight = next(
        f for f in CAMPAIGN.payload_flights if L0 / f["sonic"]["file"] == sonic
    )
    depth = len(Path(flight["sonic"]["file"]).parts)
    return str(sonic.parents[depth - 1])


# ----------------------------------------------------------------------------- quadrotor and tunnel
# (SWUF-3D fleet flights, seed 001, and the wind tunnel, seed 002; rules in quadrotor.smk and tunnel.smk)

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
    else (L0 if TUNNEL_SIMULATED else CAMPAIGN.directory) / TUNNEL_RUNS_REL
)


def quad_uavs(flight_id):
    """UAV ids of a quadrotor flight, in manifest order."""
    return [u["id"] for u in CAMPAIGN.quadrotor_flight(flight_id)["uavs"]]


def quad_raw(flight_id):
    """Raw UAV logs of a quadrotor flight (manifest order) and its tower reference."""
    flight = CAMPAIGN.quadrotor_flight(flight_id)
    return [str(L0 / u["file"]) for u in flight["uavs"]], str(L0 / flight["reference"])


def quad_l0_root(wildcards, output):
    """L0 folder of a simulated campaign, inferred from a quadrotor simulate rule's reference output."""
    ref = Path(output.reference)
    flight = next(f for f in CAMPAIGN.quadrotor_flights if L0 / f["reference"] == ref)
    return str(ref.parents[len(Path(flight["reference"]).parts) - 1])


def quad_nc(level, flight_id):
    """L1 or L2 NetCDF files of every UAV of a quadrotor flight (manifest order)."""
    folder = RESULTS / "netcdf" / level / "quadrotor"
    return [str(folder / f"{flight_id}_{u}.nc") for u in quad_uavs(flight_id)]


def quad_timeseries_flight():
    """The quadrotor flight shown as time series (seed 001 Fig. 7): the one with most UAVs."""
    return max(QUAD_FLIGHTS, key=lambda f: (len(quad_uavs(f)), -QUAD_FLIGHTS.index(f)))


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
