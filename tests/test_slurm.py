"""The workflow on a real single-node SLURM (scripts/setup_slurm.sh) through profiles/slurm.

Jobs must really go through sbatch: the Snakemake log names a SLURM job id for every job
and squeue/sinfo answer. Skipped, with the reason, only where this machine cannot run
SLURM (not root, so packages cannot be installed and daemons cannot be started).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from dronewind.diagnose.forward import probe_parts
from dronewind.manifest import default_config
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


class _QueueWatch(threading.Thread):
    """Polls squeue and keeps the largest number of queued or running jobs of one rule."""

    def __init__(self, rule: str) -> None:
        super().__init__(daemon=True)
        self.rule, self.most, self.done = rule, 0, threading.Event()

    def run(self) -> None:
        while not self.done.is_set():
            proc = subprocess.run(["squeue", "-h", "-o", "%k"], capture_output=True, text=True, check=False)
            n = sum(line.startswith(f"rule_{self.rule}_") for line in proc.stdout.splitlines())
            self.most = max(self.most, n)
            time.sleep(0.3)


def test_small_campaign_runs_through_sbatch(slurm, tmp_path):
    manifest = write_small_campaign(tmp_path)
    results = tmp_path / "results"
    extra = tmp_path / "short.yaml"
    extra.write_text(SHORT_HOVER)
    watch = _QueueWatch("diagnose_probe")
    watch.start()
    proc = subprocess.run(
        [str(BIN / "snakemake"), "--workflow-profile", "profiles/slurm",
         "--slurm-init-seconds-before-status-checks", "2", "--seconds-between-status-checks", "2",
         "--slurm-no-account", "--configfile", "config/config.yaml", str(extra),
         "--config", f"campaign={manifest}", f"results_dir={results}", "diagnosis={probe_jobs: mechanism}",
         # the payload chain up to the contract table and one flight's forward model, its
         # probes spread over one job per mechanism (the rest of the diagnosis DAG: test_e2e)
         "--", str(results / "smallcamp" / "tables" / "flight_stats.csv"),
         str(results / "smallcamp" / "campaign.json"),
         str(results / "smallcamp" / "diagnosis" / "forward" / "s01.json")],
        cwd=REPO, capture_output=True, text=True, timeout=1500, check=False,
        env={**os.environ, "PATH": f"{BIN}:{os.environ.get('PATH', '')}"},
    )
    watch.done.set()
    watch.join()
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out[-4000:]
    job_ids = re.findall(r"submitted with SLURM jobid (\d+)", out)
    n_jobs = int(re.search(r"(\d+) of (\d+) steps \(100%\) done", out).group(2))
    # every job went through sbatch (no rule runs locally)
    assert len(job_ids) == n_jobs >= 1, out[-3000:]
    assert (results / "smallcamp" / "campaign.json").is_file()
    assert (results / "smallcamp" / "tables" / "flight_stats.csv").is_file()
    # the flight's probes were in the queue side by side, then joined into its forward runs
    assert watch.most >= 3, f"at most {watch.most} diagnose_probe jobs were queued at once"
    runs = json.loads((results / "smallcamp" / "diagnosis" / "forward" / "s01.json").read_text())
    assert runs["parts"] == list(probe_parts()) and len(runs["baseline"]) == len(default_config()["diagnosis"]["seeds"])
    assert runs["probes"]
