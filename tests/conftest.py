"""Session-wide fixtures: runs of the small virtual campaign through the workflow, a headless browser.

Also the session's background workflow runs: the hidden-effect runs and the SLURM run start
as soon as their tests are collected, and those tests run last (BACKGROUND_MODULES).

``make test`` runs the suite on two pytest-xdist workers (``-n 2 --dist loadgroup``). Then
the background runs belong to the controller, the one process that lives for the whole
session: it starts them when the first worker reports its collection and each run writes its
end to a file in the session's shared temporary folder (:func:`shared_tmp`), which the test
reading it waits for on whichever worker runs it. Tests sharing a module- or session-scoped
fixture of this suite run on one worker (:func:`pytest_collection_modifyitems`), so that
every such fixture (the small campaign's run most of all) is made once.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import threading
import time
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

from dronewind import datasets  # noqa: E402
from dronewind.core.cf import atomic_write_text  # noqa: E402
from tests.small_campaign import SHORT_HOVER, write_small_campaign  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent


# --- the real records (dronewind.datasets): found in the data folder, skipped where absent ---

def record_path(name: str, *parts: str) -> Path:
    """Where record ``name`` (or a file of it) lies in the data folder, whether present or not."""
    return datasets.data_dir().joinpath(name, *parts)


def record_skip_reason(name: str) -> str | None:
    """Why the tests of record ``name`` skip (``None`` when every file of it is in the data folder)."""
    if datasets.is_present(name):
        return None
    return (f"real record {name!r} not in the data folder {datasets.data_dir()} "
            f"(set {datasets.ENV_VAR}, or fetch it: python -m dronewind.datasets fetch {name})")


def needs_record(*names: str) -> pytest.MarkDecorator:
    """Mark: skip unless every named record is in the data folder (the message names the fetch command)."""
    reasons = [r for r in map(record_skip_reason, names) if r]
    return pytest.mark.skipif(bool(reasons), reason="; ".join(reasons) or "records present")


@pytest.fixture(scope="session")
def real_record():
    """``real_record(name) -> Path``: the folder of a real record, its files checked against the
    registry's sha256; skips the test with the fetch command where the record is absent."""
    def get(name: str) -> Path:
        reason = record_skip_reason(name)
        if reason:
            pytest.skip(reason)
        return datasets.get_record(name)
    return get


def pytest_report_header(config) -> str:
    """The seed of the hidden-effect draws (tests/diagnose/test_diagnosis_hidden.py): from the commit or the
    environment."""
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


def is_xdist_worker(config: pytest.Config) -> bool:
    """Whether this process is a pytest-xdist worker (it runs tests the controller hands it)."""
    return hasattr(config, "workerinput")


def shared_tmp(config: pytest.Config) -> Path:
    """The session's temporary folder, the same in the pytest-xdist controller and its workers.

    xdist gives each worker the basetemp ``<controller's basetemp>/popen-gwN``; without xdist
    it is the session's own basetemp.
    """
    base = config._tmp_path_factory.getbasetemp()  # the folder of tmp_path_factory
    return base.parent if is_xdist_worker(config) else base


def wait_for_file(path: Path, what: str, timeout: float) -> None:
    """Wait until ``path`` exists (written by another process of the session); fail after ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while not path.exists():
        assert time.monotonic() < deadline, f"{what}: no {path.name} after {timeout:.0f} s"
        time.sleep(1.0)


class WorkflowRun:
    """A Snakemake run in a subprocess (the venv's ``snakemake`` with ``args``, cwd the checkout).

    Started by :class:`BackgroundRuns` (or by :meth:`wait` when nothing started it);
    :meth:`wait` returns its CompletedProcess (output in ``log``, stdout and stderr together).
    Its end is also written to ``<log>.returncode``: with ``remote=True`` (an xdist worker,
    whose controller runs it) :meth:`wait` waits for that file instead of running it.
    """

    def __init__(self, args: list[str], log: Path, timeout: float = 1500, env: dict[str, str] | None = None,
                 remote: bool = False) -> None:
        self.args, self.log, self.timeout, self.env, self.remote = args, log, timeout, env or {}, remote
        self.returncode_file = log.with_name(log.name + ".returncode")
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
        code = None
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
            atomic_write_text(self.returncode_file, "stopped" if code is None else str(code))
            self.done.set()

    def wait(self) -> subprocess.CompletedProcess:
        if self.remote:
            # the controller runs the draws one after another: this one may wait for those before it
            assert self.log.parent.is_dir(), f"the session did not start the run of {self.log.parent}"
            wait_for_file(self.returncode_file, f"the run of {self.log.parent}", timeout=4 * 3600)
            code = self.returncode_file.read_text()
            assert code != "stopped", f"the run was stopped: {self.args}"
            text = self.log.read_text(errors="replace")
            return subprocess.CompletedProcess([str(BIN / "snakemake"), *self.args], int(code), text, text)
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


#: The hidden-effect runs of tests/diagnose/test_diagnosis_hidden.py, started once their tests are collected.
HIDDEN_RUNS: pytest.StashKey = pytest.StashKey()
#: Where the test run keeps the SLURM run of tests/workflow/test_slurm.py (a ``SlurmRun``).
SLURM_RUN: pytest.StashKey = pytest.StashKey()
#: Set once the controller of an xdist session has started the background runs.
_BACKGROUND_STARTED: pytest.StashKey[bool] = pytest.StashKey()


#: Modules whose workflow runs the session starts in the background; their tests run last.
BACKGROUND_MODULES = ("test_diagnosis_hidden.py", "test_slurm.py")


def _fixture_groups(items: list) -> dict[int, str]:
    """The xdist group of each item (by position) that uses a module- or session-scoped fixture of this suite.

    Items linked by such fixtures form one group (union-find over modules and session
    fixtures): every module whose tests use the small campaign's run joins one group, so that
    run is made once, on one worker. Items using none are not grouped (any worker).
    """
    parent: dict[str, str] = {}

    def find(unit: str) -> str:
        while parent.setdefault(unit, unit) != unit:
            unit = parent[unit]
        return unit

    units_of: dict[int, list[str]] = {}
    for k, item in enumerate(items):
        units = [f"mark:{mark.args[0] if mark.args else mark.kwargs.get('name', 'default')}"
                 for mark in item.iter_markers("xdist_group")]
        for name in item.fixturenames:
            defs = item._fixtureinfo.name2fixturedefs.get(name)
            if not defs or not getattr(defs[-1].func, "__module__", "").startswith("tests"):
                continue
            scope = defs[-1].scope
            if scope == "session":
                units.append(f"session:{name}")
            elif scope in ("package", "module", "class"):
                units.append(f"module:{item.path.name}")
        if units:
            units_of[k] = units
            for unit in units[1:]:
                root, other = find(units[0]), find(unit)
                if other.startswith("session:"):  # a group held by a session fixture is named by it
                    root, other = other, root
                if root != other:
                    parent[other] = root
    return {k: find(units[0]) for k, units in units_of.items()}


#: Test packages whose tests run the workflow or read its products (tests/workflow, tests/figures):
#: every test there is ``slow``, outside the fast tier (``make test-fast``: ``-m "not slow"``).
SLOW_PACKAGES = frozenset({"workflow", "figures"})


def pytest_collection_modifyitems(session: pytest.Session, config: pytest.Config, items: list) -> None:
    """The tests of :data:`BACKGROUND_MODULES` last (in their order), so that their runs overlap the others.

    Every test of :data:`SLOW_PACKAGES` is marked ``slow``.

    With ``--dist loadgroup`` (``make test``), an xdist worker also writes the group of every
    test that shares a module- or session-scoped fixture (:func:`_fixture_groups`) to
    :func:`xdist_groups_file`, for the controller's :class:`FixtureGroupScheduling`, and puts
    the groups held together by a session fixture first: run with ``--no-loadscope-reorder``,
    the longest work starts first and the short, ungrouped tests fill the gaps.
    """
    for item in items:
        if item.path.parent.name in SLOW_PACKAGES:
            item.add_marker(pytest.mark.slow)
    if getattr(config.option, "loadgroup", False) and is_xdist_worker(config):
        groups = _fixture_groups(items)
        atomic_write_text(xdist_groups_file(config), json.dumps({items[k].nodeid: g for k, g in groups.items()}))
        rank = [0 if groups.get(k, "").startswith("session:") else 1 if k in groups else 2 for k in range(len(items))]
        items[:] = [items[k] for k in sorted(range(len(items)), key=rank.__getitem__)]
    items.sort(key=lambda item: item.path.name in BACKGROUND_MODULES)


def xdist_groups_file(config: pytest.Config) -> Path:
    """Where the workers of an xdist session write the groups of their tests (in :func:`shared_tmp`)."""
    return shared_tmp(config) / "xdist_groups.json"


@pytest.hookimpl(optionalhook=True, tryfirst=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log):
    """``--dist loadgroup``: :class:`FixtureGroupScheduling` (xdist's own cannot group under pytest 9)."""
    if config.getvalue("dist") != "loadgroup":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class FixtureGroupScheduling(LoadScopeScheduling):
        """xdist's scope scheduling with the scopes the workers wrote to :func:`xdist_groups_file`.

        pytest-xdist 3.8's ``loadgroup`` groups tests by a suffix it appends to the node id in
        the worker (``item._nodeid``); pytest 9 keeps node ids elsewhere, so the suffix never
        reaches the controller and every test is scheduled alone (verified with two tests
        marked ``xdist_group("g1")``: they ran on different workers). Here a test of a group
        is in the group's work unit, every other test in one of its own.
        """

        def __init__(self, config: pytest.Config, log=None) -> None:
            super().__init__(config, log)
            self._groups: dict[str, str] | None = None

        def _split_scope(self, nodeid: str) -> str:
            if self._groups is None:  # written by the workers before they report their collection
                path = xdist_groups_file(self.config)
                self._groups = json.loads(path.read_text()) if path.exists() else {}
            return self._groups.get(nodeid, nodeid)

    return FixtureGroupScheduling(config, log)


def _start_background_runs(config: pytest.Config, nodeids: list[str]) -> None:
    """Start the workflow runs of :data:`BACKGROUND_MODULES` whose tests (``nodeids``) are to run."""
    names = {nodeid.split("@")[0].rsplit("::", 1)[-1] for nodeid in nodeids}
    if any(nodeid.startswith("tests/diagnose/test_diagnosis_hidden.py::") for nodeid in nodeids):
        from tests.diagnose.test_diagnosis_hidden import DRAW_IDS, hidden_runs

        selected = [k for k, draw_id in enumerate(DRAW_IDS) if f"test_hidden_effect_is_found[{draw_id}]" in names]
        if selected:  # the runs of the selected draws, in the tests' order
            runs = hidden_runs(config)
            queue = BackgroundRuns([runs[k] for k in selected])
            config.stash[HIDDEN_RUNS] = queue
            queue.start()
    if any(nodeid.startswith("tests/workflow/test_slurm.py::") for nodeid in nodeids):
        from tests.workflow.test_slurm import start_in_background

        start_in_background(config)


def pytest_collection_finish(session: pytest.Session) -> None:
    """Start the workflow runs of :data:`BACKGROUND_MODULES` whose tests are to run.

    The hidden-effect runs (tests/diagnose/test_diagnosis_hidden.py) compute while the test run goes through
    the tests before them on the other core; the SLURM run (tests/workflow/test_slurm.py) mostly
    waits for SLURM's status checks. Their tests wait for their ends. Not for ``--collect-only``,
    nor on an xdist worker (its controller starts them: :func:`pytest_xdist_node_collection_finished`).
    """
    if session.config.option.collectonly or is_xdist_worker(session.config):
        return
    _start_background_runs(session.config, [item.nodeid for item in session.items])


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_node_collection_finished(node, ids: list[str]) -> None:
    """xdist controller: start the background runs of the tests the first worker collected (all collect the same)."""
    config = node.config
    if not config.stash.get(_BACKGROUND_STARTED, False):
        config.stash[_BACKGROUND_STARTED] = True
        _start_background_runs(config, list(ids))


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
    ``date_created`` is fixed (:data:`SOURCE_DATE_EPOCH`). Run with ``--verbose``; Snakemake's
    output is kept in ``folder/snakemake_a.log``.
    """
    folder = tmp_path_factory.mktemp("e2e")
    manifest = write_small_campaign(folder)
    extra = folder / "short.yaml"
    extra.write_text(SHORT_HOVER)
    proc = run_workflow(manifest, folder / "results_a", extra, "--verbose",
                        env={"SOURCE_DATE_EPOCH": SOURCE_DATE_EPOCH})
    (folder / "snakemake_a.log").write_text(proc.stderr)
    assert proc.returncode == 0, proc.stderr[-4000:]
    return folder, manifest, extra, folder / "results_a" / "smallcamp"


#: Targets of the second run of the small campaign: the payload chain (every NetCDF, L0 to L4,
#: and flight_stats.csv) and the campaign record, none of the diagnosis.
RERUN_TARGETS = ("tables/flight_stats.csv", "campaign.json")


@pytest.fixture(scope="session")
def small_campaign_rerun(small_campaign_run):
    """The same campaign, manifest and config run again into ``results_b`` up to :data:`RERUN_TARGETS`,
    a second, independent run of the same workflow.

    Returns ``results_b/smallcamp``. Compared with ``results_a`` by tests/workflow/test_faults.py
    (every file, byte for byte), which also deletes and rebuilds its ``campaign.json``
    under a held lock.
    """
    folder, manifest, extra, _ = small_campaign_run
    results = folder / "results_b"
    proc = run_workflow(manifest, results, extra, "--",
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
