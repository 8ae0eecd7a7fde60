"""The workflow on a real single-node SLURM (workflow/scripts/setup_slurm.sh) through profiles/slurm.

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

from dronewind.core.cf import atomic_write_text
from dronewind.diagnose.probes import probe_parts
from tests.conftest import SLURM_RUN, is_xdist_worker, shared_tmp, wait_for_file
from tests.small_campaign import SHORT_HOVER, SMALL_SEEDS, write_small_campaign

REPO = Path(__file__).resolve().parents[2]
BIN = Path(sys.executable).parent

pytestmark = [pytest.mark.slurm, pytest.mark.slow]


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


class SlurmRun:
    """The run of this module's test: SLURM set up, then the small campaign's targets through sbatch.

    Most of its wall time is waiting (for the status checks of the SLURM executor, whose
    interval grows by 10 s with every check that finds no job finished), not computing:
    so the session starts it in the background when it collects this module
    (tests/conftest.py, ``pytest_collection_finish``) and the test waits for its end.
    Its end is written to ``state.json`` in ``folder``: with ``remote=True`` (an xdist worker,
    whose controller runs it) :meth:`wait` reads that file instead.
    """

    def __init__(self, folder: Path, remote: bool = False) -> None:
        self.folder, self.results, self.remote = folder, folder / "results", remote
        self.state_file = folder / "state.json"
        self.skip: str | None = None
        self.error: str | None = None
        self.returncode: int | None = None
        self.out = ""
        self.watch = _QueueWatch("diagnose_probe")
        self.done = threading.Event()
        self._proc: subprocess.Popen | None = None
        self._stopped = False
        self._thread = threading.Thread(target=self._run, daemon=True)

    def start(self) -> SlurmRun:
        self._thread.start()
        return self

    def wait(self, timeout: float = 2400) -> None:
        if not self.remote:
            assert self.done.wait(timeout), f"the SLURM run did not end within {timeout} s"
            return
        assert self.folder.is_dir(), f"the session did not start the SLURM run in {self.folder}"
        wait_for_file(self.state_file, "the SLURM run", timeout)
        state = json.loads(self.state_file.read_text())
        self.skip, self.error, self.returncode = state["skip"], state["error"], state["returncode"]
        self.watch.most = state["most_queued"]
        log = self.folder / "snakemake.log"
        self.out = log.read_text(errors="replace") if log.exists() else ""

    def stop(self) -> None:
        """Ends the run if it is still going (Snakemake cancels its SLURM jobs on SIGTERM)."""
        self._stopped = True
        if self._proc is not None and self._proc.poll() is None:
            self._proc.terminate()
            try:
                self._proc.wait(timeout=60)
            except subprocess.TimeoutExpired:
                self._proc.kill()

    def _run(self) -> None:
        try:
            self._setup_and_run()
        except Exception as exc:  # reported by the test
            self.error = f"{type(exc).__name__}: {exc}"
        finally:
            self.watch.done.set()
            atomic_write_text(self.state_file, json.dumps({"skip": self.skip, "error": self.error,
                                                           "returncode": self.returncode,
                                                           "most_queued": self.watch.most}))
            self.done.set()

    def _setup_and_run(self) -> None:
        if os.geteuid() != 0:
            self.skip = "SLURM test needs root to install slurm-wlm/munge and start the daemons"
            return
        proc = subprocess.run(["bash", str(REPO / "workflow/scripts/setup_slurm.sh")], capture_output=True, text=True,
                              timeout=900, check=False)
        if proc.returncode != 0 and shutil.which("slurmctld") is None:
            self.skip = f"SLURM could not be installed on this machine: {proc.stderr[-500:]}"
            return
        if proc.returncode != 0:
            self.error = f"SLURM installed but did not start:\n{proc.stdout}\n{proc.stderr}"
            return
        manifest = write_small_campaign(self.folder)
        extra = self.folder / "short.yaml"
        extra.write_text(SHORT_HOVER)
        results = self.results
        log = self.folder / "snakemake.log"
        self.watch.start()
        with log.open("w") as out:
            if self._stopped:
                return
            self._proc = subprocess.Popen(
                [str(BIN / "snakemake"), "--workflow-profile", "profiles/slurm",
                 "--slurm-init-seconds-before-status-checks", "2", "--seconds-between-status-checks", "2",
                 "--slurm-no-account", "--configfile", "config/config.yaml", str(extra),
                 "--config", f"campaign={manifest}", f"results_dir={results}", "diagnosis={probe_jobs: mechanism}",
                 # the payload chain up to the contract table and one flight's forward model, its
                 # probes spread over one job per mechanism (the rest of the diagnosis DAG: test_e2e)
                 "--", str(results / "smallcamp" / "tables" / "flight_stats.csv"),
                 str(results / "smallcamp" / "campaign.json"),
                 str(results / "smallcamp" / "diagnosis" / "forward" / "s01.json")],
                cwd=REPO, stdout=out, stderr=subprocess.STDOUT, text=True,
                env={**os.environ, "PATH": f"{BIN}:{os.environ.get('PATH', '')}"},
            )
            try:
                self.returncode = self._proc.wait(timeout=1500)
            except subprocess.TimeoutExpired:
                self.stop()
                self.error = "the SLURM run did not end within 1500 s"
        self.watch.done.set()
        self.watch.join()
        self.out = log.read_text(errors="replace")


def start_in_background(config: pytest.Config) -> SlurmRun:
    """The session's SLURM run, started now in the folder ``slurm`` of the session's shared temporary folder."""
    folder = shared_tmp(config) / "slurm"
    folder.mkdir()
    run = SlurmRun(folder).start()
    config.stash[SLURM_RUN] = run
    return run


@pytest.fixture(scope="module")
def slurm_run(request) -> SlurmRun:
    """The SLURM run started with the session, or started now if the session did not (on an xdist
    worker: the controller's run, waited for)."""
    if is_xdist_worker(request.config):
        run = SlurmRun(shared_tmp(request.config) / "slurm", remote=True)
    else:
        run = request.config.stash.get(SLURM_RUN, None) or start_in_background(request.config)
    run.wait()
    if run.skip:
        pytest.skip(run.skip)
    assert run.error is None, f"{run.error}\n{run.out[-3000:]}"
    return run


def test_small_campaign_runs_through_sbatch(slurm_run):
    out, results = slurm_run.out, slurm_run.results
    assert slurm_run.returncode == 0, out[-4000:]
    job_ids = re.findall(r"submitted with SLURM jobid (\d+)", out)
    n_jobs = int(re.search(r"(\d+) of (\d+) steps \(100%\) done", out).group(2))
    # every job went through sbatch (no rule runs locally)
    assert len(job_ids) == n_jobs >= 1, out[-3000:]
    assert (results / "smallcamp" / "campaign.json").is_file()
    assert (results / "smallcamp" / "tables" / "flight_stats.csv").is_file()
    # the flight's probes were in the queue side by side, then joined into its forward runs
    assert slurm_run.watch.most >= 3, f"at most {slurm_run.watch.most} diagnose_probe jobs were queued at once"
    runs = json.loads((results / "smallcamp" / "diagnosis" / "forward" / "s01.json").read_text())
    assert runs["parts"] == list(probe_parts()) and len(runs["baseline"]) == len(SMALL_SEEDS)
    assert runs["probes"]
