"""Session-wide fixtures: one run of the small virtual campaign through the workflow, a headless browser."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.small_campaign import SHORT_HOVER, write_small_campaign

REPO = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent


def pytest_report_header(config) -> str:
    """The seed of the hidden-effect draws (tests/test_diagnosis_hidden.py): from the commit unless overridden."""
    from dronewind.diagnose.experiments import DRAW_SEED_ENV, draw_seed

    seed, source = draw_seed(REPO)
    return f"hidden-effect draws: seed {seed} ({source}; set {DRAW_SEED_ENV}=<int> to replay)"


#: Fixed ``date_created`` of the session's runs (reproducible-builds convention,
#: dronewind.core.cf): with it two runs of the same campaign write byte-identical files.
SOURCE_DATE_EPOCH = "1700000000"


def workflow_env() -> dict[str, str]:
    """The environment of a Snakemake subprocess: this one (PYTHONPATH included), the venv first on PATH."""
    return {**os.environ, "PATH": f"{BIN}:{os.environ.get('PATH', '')}"}


def run_workflow(manifest: Path, results: Path, extra_config: Path, *args: str,
                 env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    """Run the workflow on ``manifest`` into ``results`` (extra Snakemake arguments appended)."""
    return subprocess.run(
        [str(BIN / "snakemake"), "--cores", "2", "--configfile", "config/config.yaml", str(extra_config),
         "--config", f"campaign={manifest}", f"results_dir={results}", *args],
        cwd=REPO, capture_output=True, text=True, timeout=1200, check=False, env={**workflow_env(), **(env or {})},
    )


@pytest.fixture(scope="session")
def small_campaign_run(tmp_path_factory):
    """The small virtual campaign (one 8-min flight) run once through the whole workflow.

    Returns (folder, manifest, extra config, ``results_a/smallcamp``); tests may write
    further runs into other folders of ``folder`` but must not change ``results_a``.
    ``date_created`` is fixed (:data:`SOURCE_DATE_EPOCH`).
    """
    folder = tmp_path_factory.mktemp("e2e")
    manifest = write_small_campaign(folder)
    extra = folder / "short.yaml"
    extra.write_text(SHORT_HOVER)
    proc = run_workflow(manifest, folder / "results_a", extra, env={"SOURCE_DATE_EPOCH": SOURCE_DATE_EPOCH})
    assert proc.returncode == 0, proc.stderr[-4000:]
    return folder, manifest, extra, folder / "results_a" / "smallcamp"


#: Targets of the second run of the small campaign: the payload chain (every NetCDF, L0 to L4,
#: and flight_stats.csv) and the campaign record, none of the diagnosis.
RERUN_TARGETS = ("tables/flight_stats.csv", "campaign.json")


@pytest.fixture(scope="session")
def small_campaign_rerun(small_campaign_run):
    """The same campaign, manifest and config run again into ``results_b`` up to :data:`RERUN_TARGETS`.

    Returns ``results_b/smallcamp``. Compared with ``results_a`` by tests/test_e2e.py
    (the data) and tests/test_faults.py (every file, byte for byte); tests/test_faults.py
    also deletes and rebuilds its ``campaign.json`` under a held lock.
    """
    folder, manifest, extra, _ = small_campaign_run
    results = folder / "results_b"
    proc = run_workflow(manifest, results, extra, "--", *(str(results / "smallcamp" / t) for t in RERUN_TARGETS),
                        env={"SOURCE_DATE_EPOCH": SOURCE_DATE_EPOCH})
    assert proc.returncode == 0, proc.stderr[-4000:]
    return results / "smallcamp"


@pytest.fixture(scope="session")
def small_campaign_report(small_campaign_run) -> Path:
    """``snakemake --report`` of the session's finished run (``results_a``): the HTML file, built once."""
    folder, manifest, extra, results = small_campaign_run
    page = folder / "report.html"
    proc = subprocess.run(
        [str(BIN / "snakemake"), "--configfile", "config/config.yaml", str(extra), "--config",
         f"campaign={manifest}", f"results_dir={results.parent}", "--report", str(page)],
        cwd=REPO, capture_output=True, text=True, timeout=600, check=False, env=workflow_env(),
    )
    assert proc.returncode == 0, proc.stderr[-4000:]
    return page


@pytest.fixture(scope="session")
def chromium() -> str:
    """Debian's headless chromium; installed with apt-get when missing and running as root, else skipped."""
    found = shutil.which("chromium") or shutil.which("chromium-browser")
    if found:
        return found
    if os.geteuid() != 0:
        pytest.skip("chromium is not installed and the tests do not run as root (apt-get install -y chromium)")
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    for cmd in (["apt-get", "update"], ["apt-get", "install", "-y", "chromium"]):
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=1200, check=False, env=env)
        if proc.returncode != 0:
            pytest.skip(f"could not install chromium ({' '.join(cmd)}): {proc.stderr[-500:]}")
    found = shutil.which("chromium")
    if not found:
        pytest.skip("apt-get installed chromium but it is not on the PATH")
    return found
