# Configuration, campaign manifest validation, helpers and wildcard constraints.
from pathlib import Path

from snakemake.utils import min_version, validate

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
