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


def workflow_env() -> dict[str, str]:
    """The environment of a Snakemake subprocess: this one (PYTHONPATH included), the venv first on PATH."""
    return {**os.environ, "PATH": f"{BIN}:{os.environ.get('PATH', '')}"}


def run_workflow(manifest: Path, results: Path, extra_config: Path, *args: str) -> subprocess.CompletedProcess:
    """Run the workflow on ``manifest`` into ``results`` (extra Snakemake arguments appended)."""
    return subprocess.run(
        [str(BIN / "snakemake"), "--cores", "2", "--configfile", "config/config.yaml", str(extra_config),
         "--config", f"campaign={manifest}", f"results_dir={results}", *args],
        cwd=REPO, capture_output=True, text=True, timeout=1200, check=False, env=workflow_env(),
    )


@pytest.fixture(scope="session")
def small_campaign_run(tmp_path_factory):
    """The small virtual campaign (one 8-min flight) run once through the whole workflow.

    Returns (folder, manifest, extra config, ``results_a/smallcamp``); tests may write
    further runs into other folders of ``folder`` but must not change ``results_a``.
    """
    folder = tmp_path_factory.mktemp("e2e")
    manifest = write_small_campaign(folder)
    extra = folder / "short.yaml"
    extra.write_text(SHORT_HOVER)
    proc = run_workflow(manifest, folder / "results_a", extra)
    assert proc.returncode == 0, proc.stderr[-4000:]
    return folder, manifest, extra, folder / "results_a" / "smallcamp"


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
