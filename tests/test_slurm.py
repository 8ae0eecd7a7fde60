"""The workflow on a real single-node SLURM (scripts/setup_slurm.sh) through profiles/slurm.

Jobs must really go through sbatch: the Snakemake log names a SLURM job id for every job
and squeue/sinfo answer. Skipped, with the reason, only where this machine cannot run
SLURM (not root, so packages cannot be installed and daemons cannot be started).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.small_campaign import SHORT_HOVER, write_small_campaign

REPO = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent

pytestmark = [pytest.mark.slurm, pytest.mark.slow]


@pytest.fixture(scope="module")
def slurm():
    if os.geteuid() != 0:
        pytest.skip("SLURM test needs root to install slurm-wlm/munge and start the daemons")
    proc = subprocess.run(["bash", str(REPO / "scripts/setup_slurm.sh")], capture_output=True, text=True,
                          timeout=900, check=False)
    if proc.returncode != 0 and shutil.which("slurmctld") is None:
        pytest.skip(f"SLURM could not be installed on this machine: {proc.stderr[-500:]}")
    assert proc.returncode == 0, f"SLURM installed but did not start:\n{proc.stdout}\n{proc.stderr}"
    return True


def test_small_campaign_runs_through_sbatch(slurm, tmp_path):
    manifest = write_small_campaign(tmp_path)
    results = tmp_path / "results"
    extra = tmp_path / "short.yaml"
    extra.write_text(SHORT_HOVER)
    proc = subprocess.run(
        [str(BIN / "snakemake"), "--workflow-profile", "profiles/slurm",
         "--slurm-init-seconds-before-status-checks", "2", "--seconds-between-status-checks", "2",
         "--slurm-no-account", "--configfile", "config/config.yaml", str(extra),
         "--config", f"campaign={manifest}", f"results_dir={results}",
         # the payload chain up to the contract table (the diagnosis DAG is run by test_e2e)
         "--", str(results / "smallcamp" / "tables" / "flight_stats.csv"),
         str(results / "smallcamp" / "campaign.json")],
        cwd=REPO, capture_output=True, text=True, timeout=1500, check=False,
        env={**os.environ, "PATH": f"{BIN}:{os.environ.get('PATH', '')}"},
    )
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out[-4000:]
    job_ids = re.findall(r"submitted with SLURM jobid (\d+)", out)
    n_jobs = int(re.search(r"(\d+) of (\d+) steps \(100%\) done", out).group(2))
    # every job went through sbatch (no rule runs locally)
    assert len(job_ids) == n_jobs >= 1, out[-3000:]
    assert (results / "smallcamp" / "campaign.json").is_file()
    assert (results / "smallcamp" / "tables" / "flight_stats.csv").is_file()
