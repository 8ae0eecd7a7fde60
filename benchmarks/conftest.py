"""Inputs of the timing suite (``make bench``): one simulated payload flight processed once, the real records.

The suite runs with pytest-benchmark::

    make bench
    # or: .venv/bin/python -m pytest benchmarks -p no:cacheprovider --benchmark-enable \
    #        --benchmark-only --benchmark-json=bench.json

Inputs that are not timed are made once per run of the suite here: flight ``s10`` of the embedded
default campaign (20 min of hover, sonic and INS at their logger rates, two mast sonics)
simulated to raw files and carried through the payload chain's file steps, so that the
benchmarks of later stages (forward run, diagnosis, compliance, figures) start from real
products. Each benchmark reports its throughput in ``extra_info`` (rows, bytes or flight
time per second of CPU time of one round) next to pytest-benchmark's wall-time statistics.
"""

from __future__ import annotations

import os
import platform
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core per benchmark: numbers comparable between machines

# netCDF4 (and the HDF5 library it links) first, before any module that brings another HDF5 build:
# loaded the other way round, the compliance checker's open of a product crashed the process
import netCDF4  # noqa: E402,F401

REPO = Path(__file__).resolve().parents[1]
DEFAULT_CAMPAIGN = REPO / "config" / "campaigns" / "mosai2023.yaml"
FLIGHT = "s10"


def pytest_benchmark_update_machine_info(config: pytest.Config, machine_info: dict[str, Any]) -> None:
    """The processor model and the load when the suite started, beside pytest-benchmark's machine info."""
    model = ""
    try:
        model = next((line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                      if line.startswith("model name")), "")
    except OSError:
        pass
    machine_info["cpu_model"] = model or platform.processor()
    machine_info["load_average_1min"] = os.getloadavg()[0] if hasattr(os, "getloadavg") else None


def cpu_round(benchmark, fn, *args: Any, rounds: int = 3, **kwargs: Any) -> tuple[Any, float]:
    """Run ``fn`` through ``benchmark.pedantic`` and return its result and the least CPU time of a round [s]."""
    cpu: list[float] = []

    def timed() -> Any:
        c0 = time.process_time()
        out = fn(*args, **kwargs)
        cpu.append(time.process_time() - c0)
        return out

    result = benchmark.pedantic(timed, rounds=rounds, iterations=1, warmup_rounds=0)
    best = min(cpu)
    benchmark.extra_info["cpu_s_per_round"] = round(best, 4)
    return result, best


@pytest.fixture(scope="session")
def real_record():
    """``real_record(name) -> Path``: a real record's folder (dronewind.datasets); skips where it is absent."""
    from dronewind import datasets

    def get(name: str) -> Path:
        if not datasets.is_present(name):
            pytest.skip(f"real record {name!r} not in the data folder {datasets.data_dir()} (set "
                        f"{datasets.ENV_VAR}, or fetch it: python -m dronewind.datasets fetch {name})")
        return datasets.get_record(name)
    return get


@pytest.fixture(scope="session")
def setup() -> dict[str, Any]:
    """The default campaign's manifest content, the default configuration and its processing settings."""
    from dronewind.manifest import default_config, load_campaign

    config = default_config()
    return {"data": load_campaign(DEFAULT_CAMPAIGN).data, "config": config, "processing": config["processing"]}


@dataclass
class Flight:
    """One simulated flight's raw files and, once processed, its products."""

    folder: Path
    campaign: Any
    flight: dict[str, Any]
    sonic: dict[str, Any]
    sonic_id: str
    raw: dict[str, Path]
    products: dict[str, Path] = field(default_factory=dict)

    @property
    def hover_s(self) -> float:
        """Length of the flight's hover window [s] (the flight time the chain processes)."""
        import numpy as np

        start, end = (np.datetime64(self.flight["window"][k].rstrip("Z"), "ms") for k in ("start", "end"))
        return float((end - start) / np.timedelta64(1, "s"))


def run_chain(fl: Flight, processing: dict[str, Any], out: Path) -> dict[str, Path]:
    """Every file step of the payload chain for the flight, as the workflow's rules call them."""
    from dronewind.steps import payload as steps

    out.mkdir(parents=True, exist_ok=True)
    camp, fid, flight, sonic = fl.campaign, FLIGHT, fl.flight, fl.sonic
    site = camp.data["site"]
    mast_l1 = steps.mast_l1([str(p) for p in camp.mast_files(fl.sonic_id, fl.folder)],
                            out / f"mast_{fl.sonic_id}.nc", campaign=camp.name, sonic=sonic,
                            despike=processing["despike"], simulated=False)
    s1, i1 = steps.payload_l1(fl.raw["sonic"], fl.raw["ins"], out / f"{fid}_sonic.nc", out / f"{fid}_ins.nc",
                              campaign=camp.name, flight_id=fid, site=site,
                              target_height_m=flight.get("target_height_m"), despike=processing["despike"],
                              simulated=False)
    l2 = steps.payload_l2(s1, i1, out / f"{fid}_drone.nc", campaign=camp.name, flight_id=fid, flight=flight,
                          site=site, sonic_ins_lag=processing["sonic_ins_lag"], hover=processing["hover"],
                          max_missing_fraction=processing["max_missing_fraction"])
    m2 = steps.mast_l2(mast_l1, l2, out / f"{fid}_mast.nc", campaign=camp.name, flight_id=fid, reference=sonic,
                       drone_mast=processing["drone_mast"])
    l3 = steps.l3(l2, m2, out / f"{fid}_l3.nc", campaign=camp.name, flight_id=fid, flight=flight,
                  reference=sonic, drone_mast=processing["drone_mast"], rotation=processing["rotation"])
    l4 = {sensor: steps.l4(l3, out / f"{fid}_{sensor}_l4.nc", campaign=camp.name, flight_id=fid, sensor=sensor,
                           reference=sonic, spectra=processing["spectra"], quadrant=processing["quadrant"],
                           detrending=processing["detrending"]) for sensor in ("drone", "mast")}
    return {"mast_l1": mast_l1, "sonic_l1": s1, "ins_l1": i1, "l2": l2, "mast_l2": m2, "l3": l3,
            "l4_drone": l4["drone"], "l4_mast": l4["mast"]}


@pytest.fixture(scope="session")
def flight(tmp_path_factory, setup) -> Flight:
    """Flight s10 of the default campaign: raw files written by the simulator, then processed once."""
    import yaml

    from dronewind.manifest import load_campaign
    from dronewind.steps.payload import simulate_payload, simulation_manifest

    folder = tmp_path_factory.mktemp("bench_flight")
    data = setup["data"]
    simulate_payload(simulation_manifest(data), FLIGHT, DEFAULT_CAMPAIGN.parent, folder)
    measured = {k: data[k] for k in ("name", "site", "masts") if k in data}
    measured["payload_flights"] = [f for f in data["payload_flights"] if f["id"] == FLIGHT]
    manifest = folder / "bench.yaml"
    manifest.write_text(yaml.safe_dump(measured, sort_keys=False))
    camp = load_campaign(manifest)
    fl_entry = camp.payload_flight(FLIGHT)
    sonic_id = fl_entry["reference"]
    fl = Flight(folder, camp, fl_entry, camp.mast_sonics()[sonic_id], sonic_id,
                {"sonic": folder / fl_entry["sonic"]["file"], "ins": folder / fl_entry["ins"]["file"]})
    fl.products = run_chain(fl, setup["processing"], folder / "products")
    return fl


@pytest.fixture(scope="session")
def measured_json(flight, setup) -> Path:
    """The flight's measured features and forward conditions (the diagnosis' first job)."""
    from dronewind.manifest import payload_flight_manifest
    from dronewind.steps import diagnosis

    p, proc = flight.products, setup["processing"]
    return diagnosis.measured_features(
        p["sonic_l1"], p["ins_l1"], p["l2"], p["l3"], flight.folder / "measured.json",
        campaign=payload_flight_manifest(setup["data"], FLIGHT), flight_id=FLIGHT,
        sonic_ins_lag=proc["sonic_ins_lag"], hover=proc["hover"], max_missing_fraction=proc["max_missing_fraction"])
