"""Snakemake reruns exactly the jobs whose settings changed (each rule's params are its rerun trigger).

A small virtual campaign of two flights is processed once up to flight_stats, the Table 4/5
files and the campaign figures (about a minute on two cores). Dry runs then list the jobs
Snakemake would run (``--summary``, the "update pending" rows):

* a changed ``processing.spectra`` plans the L4 jobs of every flight and sensor and the
  tables and figures built from them, and no simulate, L1, L2 or L3 job;
* a changed ``diagnosis`` setting plans no job of the payload chain;
* one flight's manifest entry edited (its ``target_height_m``) plans jobs of that flight
  only (besides the campaign-level record, tables and figures), and no simulate or mast
  L1 job: the flight's conditions give the simulator its hover height, so the raw files
  do not change.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from tests.small_campaign import SHORT_HOVER, write_small_campaign

REPO = Path(__file__).resolve().parents[2]
BIN = Path(sys.executable).parent
FLIGHTS = ("s01", "s02")
CHAIN_RULES = {"payload_chain", "mast_l1", "l3"}


def snakemake(folder: Path, *args: str, extra: tuple[Path, ...] = ()) -> subprocess.CompletedProcess:
    """Run Snakemake on the small campaign of ``folder`` (results in ``folder/results``)."""
    results = folder / "results" / "smallcamp"
    targets = [results / "tables" / "flight_stats.csv", results / "tables" / "table4_flights.csv",
               results / "figures" / "fig04_tke_lag.png"]
    return subprocess.run(
        [str(BIN / "snakemake"), "--cores", "2", "--configfile", "config/config.yaml", str(folder / "short.yaml"),
         *map(str, extra), "--config", f"campaign={folder / 'smallcamp.yaml'}",
         f"results_dir={folder / 'results'}", *args, "--", *map(str, targets)],
        cwd=REPO, capture_output=True, text=True, timeout=900, check=False,
        env={**os.environ, "PATH": f"{BIN}:{os.environ.get('PATH', '')}"},
    )


def planned_jobs(folder: Path, extra: tuple[Path, ...] = ()) -> set[tuple[str, str]]:
    """(rule, wildcards) of every job a dry run plans, from the table of ``snakemake --summary``.

    The wildcards are read from the job's log file, ``logs/<rule>/<wildcards>.log``
    (``s01``, ``mast30``; ``all`` for campaign-level rules).
    """
    proc = snakemake(folder, "--dry-run", "--summary", extra=extra)
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = proc.stdout.splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("output_file\t"))
    columns = lines[header].split("\t")
    rows = [dict(zip(columns, line.split("\t"), strict=True)) for line in lines[header + 1:] if line.count("\t")]
    return {(row["rule"], Path(row["log-file(s)"]).stem) for row in rows if row["plan"] == "update pending"}


def rules_of(jobs: set[tuple[str, str]]) -> set[str]:
    return {rule for rule, _ in jobs}


def flights_of(jobs: set[tuple[str, str]]) -> set[str]:
    """Flights of the per-flight jobs (the wildcards up to the first underscore)."""
    return {wildcards.split("_")[0] for _, wildcards in jobs if wildcards.split("_")[0] in FLIGHTS}


@pytest.fixture(scope="module")
def processed(tmp_path_factory):
    folder = tmp_path_factory.mktemp("rerun")
    write_small_campaign(folder, n_flights=2)
    (folder / "short.yaml").write_text(SHORT_HOVER)
    proc = snakemake(folder)
    assert proc.returncode == 0, proc.stderr[-4000:]
    assert planned_jobs(folder) == set(), "a finished run plans nothing"
    return folder


def test_changed_spectra_rerun_l4_tables_and_figures_of_every_flight(processed):
    changed = processed / "spectra.yaml"
    changed.write_text("processing:\n  spectra:\n    segments: 4\n")
    jobs = planned_jobs(processed, extra=(changed,))
    assert ("l4", "all") in jobs  # one job makes every flight's L4 (docs/workflow.md, Jobs)
    assert {"flight_stats", "tables", "figures"} <= rules_of(jobs)
    assert not rules_of(jobs) & CHAIN_RULES, jobs
    assert not any(rule.startswith("simulate") for rule in rules_of(jobs)), jobs


def test_changed_diagnosis_setting_reruns_no_processing(processed):
    changed = processed / "alpha.yaml"
    changed.write_text("diagnosis:\n  alpha: 0.02\n")
    jobs = planned_jobs(processed, extra=(changed,))
    assert not rules_of(jobs) & (CHAIN_RULES | {"l4", "flight_stats", "tables"}), jobs


def test_edited_flight_entry_reruns_that_flight_only(processed):
    manifest = processed / "smallcamp.yaml"
    original = manifest.read_text()
    data = yaml.safe_load(original)
    data["payload_flights"][0]["target_height_m"] = 32
    manifest.write_text(yaml.safe_dump(data, sort_keys=False))
    try:
        jobs = planned_jobs(processed)
    finally:
        manifest.write_text(original)
    assert flights_of(jobs) == {"s01"}, jobs
    assert {"payload_chain", "l4"} <= rules_of(jobs)
    assert "mast_l1" not in rules_of(jobs)
    assert not any(rule.startswith("simulate") for rule in rules_of(jobs)), jobs
