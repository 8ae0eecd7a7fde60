"""Session-wide fixtures: runs of the small virtual campaign through the workflow, a headless browser.

Also the session's background workflow runs: the hidden-effect runs and the SLURM run start
as soon as their tests are collected, and those tests run last (BACKGROUND_MODULES).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import threading
from pathlib import Path

import pytest

#: HDF5 locks a file it writes (flock, exclusive). This process forks while it writes NetCDF
#: files: the background threads below start Snakemake runs and poll SLURM's queue. A child
#: holds a copy of the open file, and so the lock, until it closes its inherited descriptors
#: before exec; a read of the just-written file in that window fails with "NetCDF: HDF error"
#: (seen once in CI on a file the products fixture had just written; reproduced by
#: benchmarks/bench_fork_lock.py: 901 of 3000 reads failed with locking, none without).
#: Locking is off in this process only: HDF5 reads HDF5_USE_FILE_LOCKING once, when the
#: library starts, so it is set, the library started, and the environment restored; every
#: process this one starts (Snakemake runs, sbatch jobs) keeps HDF5's default.
_HDF5_LOCKING = os.environ.get("HDF5_USE_FILE_LOCKING")
os.environ["HDF5_USE_FILE_LOCKING"] = "FALSE"
import netCDF4  # noqa: E402

netCDF4.Dataset("hdf5_start.nc", "w", diskless=True, persist=False).close()
if _HDF5_LOCKING is None:
    del os.environ["HDF5_USE_FILE_LOCKING"]
else:
    os.environ["HDF5_USE_FILE_LOCKING"] = _HDF5_LOCKING

from tests.small_campaign import SHORT_HOVER, write_small_campaign  # noqa: E402

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


class WorkflowRun:
    """A Snakemake run in a subprocess (the venv's ``snakemake`` with ``args``, cwd the checkout).

    Started by :class:`BackgroundRuns` (or by :meth:`wait` when nothing started it);
    :meth:`wait` returns its CompletedProcess (output in ``log``, stdout and stderr together).
    """

    def __init__(self, args: list[str], log: Path, timeout: float = 1500, env: dict[str, str] | None = None) -> None:
        self.args, self.log, self.timeout, self.env = args, log, timeout, env or {}
        self.done = threading.Event()
        self.result: subprocess.CompletedProcess | None = None
        self._started = threading.Lock()
        self._proc: subprocess.Popen | None = None
        self._stopped = False

    def run(self) -> None:
        """Run to the end (once; a second call waits for the first)."""
        if not self._started.acquire(blocking=False):
            self.done.wait()
            return
        try:
            if self._stopped:
                return
            self.log.parent.mkdir(parents=True, exist_ok=True)
            with self.log.open("w") as out:
                self._proc = subprocess.Popen([str(BIN / "snakemake"), *self.args], cwd=REPO, stdout=out,
                                              stderr=subprocess.STDOUT, env={**workflow_env(), **self.env})
                try:
                    code = self._proc.wait(timeout=self.timeout)
                except subprocess.TimeoutExpired:
                    self._proc.kill()
                    code = self._proc.wait()
            text = self.log.read_text(errors="replace")
            self.result = subprocess.CompletedProcess(self._proc.args, code, text, text)
        finally:
            self.done.set()

    def wait(self) -> subprocess.CompletedProcess:
        self.run()
        assert self.result is not None, f"the run was stopped: {self.args}"
        return self.result

    def stop(self) -> None:
        self._stopped = True
        if self._proc is not None and self._proc.poll() is None:
            self._proc.terminate()


class BackgroundRuns(threading.Thread):
    """Workflow runs done one after another while the session runs the tests before the ones that read them."""

    def __init__(self, runs: list[WorkflowRun]) -> None:
        super().__init__(daemon=True)
        self.runs = runs

    def run(self) -> None:
        for run in self.runs:
            run.run()

    def stop(self) -> None:
        for run in self.runs:
            run.stop()


#: The hidden-effect runs of tests/test_diagnosis_hidden.py, started when the session has collected them.
HIDDEN_RUNS: pytest.StashKey = pytest.StashKey()
#: Where the session keeps the SLURM run of tests/test_slurm.py (a ``SlurmRun``).
SLURM_RUN: pytest.StashKey = pytest.StashKey()


#: Modules whose workflow runs the session starts in the background; their tests run last.
BACKGROUND_MODULES = ("test_diagnosis_hidden.py", "test_slurm.py")


def pytest_collection_modifyitems(session: pytest.Session, config: pytest.Config, items: list) -> None:
    """The tests of :data:`BACKGROUND_MODULES` last (in their order), so that their runs overlap the others."""
    items.sort(key=lambda item: item.path.name in BACKGROUND_MODULES)


def pytest_collection_finish(session: pytest.Session) -> None:
    """Start the workflow runs of :data:`BACKGROUND_MODULES` whose tests are to run.

    The hidden-effect runs (tests/test_diagnosis_hidden.py) compute while the session runs
    the tests before them on the other core; the SLURM run (tests/test_slurm.py) mostly
    waits for SLURM's status checks. Their tests wait for their ends. Not for ``--collect-only``.
    """
    if session.config.option.collectonly:
        return
    hidden = [item for item in session.items if item.path.name == "test_diagnosis_hidden.py"
              and getattr(item, "originalname", "") == "test_hidden_effect_is_found"]
    if hidden:  # the runs of the selected draws, in the tests' order
        from tests.test_diagnosis_hidden import DRAWS, hidden_runs

        runs = hidden_runs(session.config)
        queue = BackgroundRuns([runs[DRAWS.index(item.callspec.params["truth"])] for item in hidden])
        session.config.stash[HIDDEN_RUNS] = queue
        queue.start()
    if any(item.path.name == "test_slurm.py" for item in session.items):
        from tests.test_slurm import start_in_background

        start_in_background(session.config)


def pytest_sessionfinish(session: pytest.Session) -> None:
    """End the background runs the session did not wait for (interrupted, -x)."""
    for key in (HIDDEN_RUNS, SLURM_RUN):
        run = session.config.stash.get(key, None)
        if run is not None:
            run.stop()


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
    """The same campaign, manifest and config run again into ``results_b`` up to :data:`RERUN_TARGETS`,
    every job in its own process (``preload=false``; the first run forks its jobs from the
    preloaded process, :mod:`dronewind.steps.preload`).

    Returns ``results_b/smallcamp``. Compared with ``results_a`` by tests/test_faults.py
    (every file, byte for byte), which also deletes and rebuilds its ``campaign.json``
    under a held lock.
    """
    folder, manifest, extra, _ = small_campaign_run
    results = folder / "results_b"
    proc = run_workflow(manifest, results, extra, "preload=false", "--",
                        *(str(results / "smallcamp" / t) for t in RERUN_TARGETS),
                        env={"SOURCE_DATE_EPOCH": SOURCE_DATE_EPOCH})
    assert proc.returncode == 0, proc.stderr[-4000:]
    return results / "smallcamp"


@pytest.fixture(scope="session")
def small_campaign_report(small_campaign_run) -> Path:
    """``snakemake --report`` of the session's finished run (``results_a``): the HTML file, built once."""
    folder, manifest, extra, results = small_campaign_run
    page = folder / "report.html"
    proc = run_workflow(manifest, results.parent, extra, "--report", str(page))
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
