"""Jobs of a local run forked from one process that has the libraries imported.

Snakemake's local executor starts a fresh Python for every job. Importing numpy, pandas,
xarray, netCDF4 and scipy costs a job 0.5 to 1.2 CPU-s, more than the work of most jobs:
about a third of the default campaign's CPU time went into the imports of its 267 jobs. For a
local run the workflow therefore starts :func:`serve` (``onstart``, config ``preload``): a
process that imports the libraries once and then forks one child per job. Every script
first calls :func:`delegate`, which hands its job to the server: the script file, its
arguments, environment, working directory and standard streams (as descriptors). The child
runs the script exactly as the job's own process would (``runpy``, ``__main__``) and
reports its exit status, which the job's process then exits with. Nothing is shared between
jobs: each child is forked from the server's state right after the imports.

Without a server (a cluster run, a dry run, ``preload: false``, a job started by hand, a
server not up yet or gone, another Python interpreter) :func:`delegate` returns at once and
the job runs in its own process as before; the outputs are the same bit for bit (tested).

Where the environment has the start-up hook (:func:`install_startup_hook`; ``make`` installs
it into ``.venv``), a job's process hands its job over as the interpreter starts, before
Snakemake's preamble imports Snakemake (:mod:`dronewind.steps.handoff`); the script's own
:func:`delegate` call then finds no server and returns, in the child.

Written here because the standard library's ``multiprocessing.forkserver`` serves only the
``multiprocessing`` processes of its own parent, not the unrelated processes Snakemake starts.

Notes
-----
* A job's process and the child it hands its work to are tied both ways: SIGINT, SIGTERM
  and SIGHUP sent to the job's process (Snakemake stopping a job) are passed on to the child;
  the child ends when the job's process is gone (its socket closes); the job's process exits
  with status 1 and a message if the child ends without a status.
* Snakemake measures a rule's ``benchmark:`` on the job's own processes, which no longer do
  the work. The children write their CPU time, peak memory and wall time, per rule and
  wildcards, to the server's job table (:data:`JOB_TABLE_COLUMNS`), which the benchmark
  scripts add up.
* The server runs the linear-algebra libraries on one thread (``OMP_NUM_THREADS=1`` and
  the like), as Snakemake runs a one-thread job: every rule of this workflow is one.
"""

from __future__ import annotations

import argparse
import contextlib
import gc
import importlib
import json
import os
import resource
import runpy
import select
import signal
import socket
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

# the job side; ACCEPT_TIMEOUT_S and delegate are re-exported (every script calls preload.delegate() first)
from dronewind.steps.handoff import (  # noqa: F401
    ACCEPT_TIMEOUT_S,
    LENGTH,
    PTH_NAME,
    SIGNALS,
    SOCKET_ENV,
    STATUS,
    delegate,
    keep_freed_memory,
    pth_line,
    recv_exact,
)

#: Libraries imported by the server before it serves (all the scripts import some of them);
#: then every module of dronewind (:func:`library_modules`). None of them imports dask.array,
#: pint or pyplot, which would change what a job's process holds (xarray's duck-array checks,
#: :mod:`dronewind.core.duckarrays`; tested).
PRELOAD_MODULES: tuple[str, ...] = (
    "numpy", "pandas", "xarray", "netCDF4", "yaml", "scipy.signal", "scipy.stats", "scipy.optimize",
    "scipy.interpolate", "scipy.linalg", "scipy.special", "matplotlib",
    # xarray imports dask's base package (not dask.array) on a process's first NetCDF write:
    # every job that writes one has it
    "dask",
)
#: Imported too where installed: what the preamble of a Snakemake script imports (the library
#: itself never imports Snakemake).
OPTIONAL_MODULES: tuple[str, ...] = ("snakemake.script",)
#: Environment of the server's linear-algebra libraries (read once, when they are imported).
ONE_THREAD_ENV: dict[str, str] = {key: "1" for key in ("OMP_NUM_THREADS", "GOTO_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                                                        "MKL_NUM_THREADS", "VECLIB_MAXIMUM_THREADS",
                                                        "NUMEXPR_NUM_THREADS")}
#: Columns of the job table (tab separated, one line per job).
JOB_TABLE_COLUMNS: tuple[str, ...] = ("rule", "wildcards", "cpu_s", "wall_s", "max_rss_mb", "exit_status", "script")
#: Name prefix of the private folder that :class:`PreloadServer` makes for the socket; the
#: server removes it when it ends, also when Snakemake was killed and ran no ``onerror``.
FOLDER_PREFIX = "dronewind_preload_"


# ------------------------------------------------------------------------ the server side


def library_modules() -> list[str]:
    """Every module of the dronewind package, sorted."""
    import pkgutil

    import dronewind

    return sorted(m.name for m in pkgutil.walk_packages(dronewind.__path__, "dronewind."))


def preload_libraries() -> None:
    """Import :data:`PRELOAD_MODULES`, the library and :data:`OPTIONAL_MODULES`, then warm xarray up."""
    for name in (*PRELOAD_MODULES, *library_modules()):
        importlib.import_module(name)
    for name in OPTIONAL_MODULES:
        with contextlib.suppress(ImportError):
            importlib.import_module(name)
    _warm_up()


def serve(socket_path: str | Path, job_table: str | Path | None = None, preload: bool = True) -> None:
    """Import the libraries and the library, then fork a child for every job that connects to ``socket_path``.

    Runs until SIGTERM or SIGINT, or until its parent process (Snakemake) is gone; then
    waits for the children still running. Must be started with :data:`ONE_THREAD_ENV`.

    Parameters
    ----------
    socket_path : str or Path
        Unix socket to listen on (created; its folder must exist and be private).
    job_table : str or Path, optional
        Tab-separated table to which every child appends its rule, wildcards, CPU time,
        wall time, peak memory and exit status (:data:`JOB_TABLE_COLUMNS`).
    preload : bool
        Import the libraries first (:func:`preload_libraries`); False serves at once (tests).
    """
    parent = os.getppid()
    if preload:
        preload_libraries()
    # the imported objects go to the collector's permanent generation: a child's collections
    # then do not touch (and copy) the pages it shares with the server
    gc.collect()
    gc.freeze()
    # the children reuse the memory they free (they inherit the allocator's settings)
    keep_freed_memory()
    if threading.active_count() != 1:  # a fork copies only the calling thread
        raise RuntimeError(f"preload: {threading.active_count()} threads after the imports; fork needs one")
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    listener.bind(str(socket_path))
    listener.listen(64)
    stop = threading.Event()  # set by the signal handlers (no threads run in the server)
    for signum in (signal.SIGTERM, signal.SIGINT):
        signal.signal(signum, lambda *_: stop.set())
    children: set[int] = set()
    try:
        while not stop.is_set() and os.getppid() == parent:
            _reap(children)
            try:
                ready, _, _ = select.select([listener], [], [], 0.2)
            except InterruptedError:
                continue
            if ready:
                conn, _ = listener.accept()
                pid = _start_job(conn, listener, job_table)
                if pid:
                    children.add(pid)
    finally:
        listener.close()
        with contextlib.suppress(OSError):
            os.unlink(str(socket_path))
        folder = Path(socket_path).parent
        if folder.name.startswith(FOLDER_PREFIX):  # the private folder PreloadServer made for the socket:
            with contextlib.suppress(OSError):  # removed here too: a killed Snakemake runs no onerror
                folder.rmdir()  # (only if empty)
        for pid in list(children):  # wait (their CPU time is then counted for the server's parent)
            with contextlib.suppress(ChildProcessError):
                os.waitpid(pid, 0)


def _warm_up() -> None:
    """What xarray imports and sets up on its first dataset with a time index (in memory: no
    file is opened, so none is inherited by the children)."""
    import numpy as np
    import pandas as pd
    import xarray as xr

    ds = xr.Dataset({"a": ("time", np.arange(3.0))}, coords={"time": pd.date_range("2020-01-01", periods=3, freq="s")})
    ds.sel(time=slice(ds["time"].values[0], None)).mean()


def _reap(children: set[int]) -> None:
    """Wait for the children that have ended (no zombies; their CPU time is counted)."""
    for pid in list(children):
        try:
            done, _ = os.waitpid(pid, os.WNOHANG)
        except ChildProcessError:
            done = pid
        if done:
            children.discard(pid)


def _start_job(conn: socket.socket, listener: socket.socket, job_table: str | Path | None) -> int:
    """Receive one job's request and fork its child; return the child's pid (0 if none)."""
    fds: list[int] = []
    try:
        conn.settimeout(10.0)
        head, fds, _, _ = socket.recv_fds(conn, LENGTH.size, 3)
        if len(head) < LENGTH.size:
            head += recv_exact(conn, LENGTH.size - len(head))
        request = json.loads(recv_exact(conn, LENGTH.unpack(head)[0]))
        if request.get("executable") != sys.executable or len(fds) != 3:
            conn.sendall(b"R")  # another interpreter (e.g. a conda environment): the job runs itself
            raise EOFError("refused")
    except (OSError, EOFError, ValueError):
        for fd in fds:
            os.close(fd)
        conn.close()
        return 0
    pid = os.fork()
    if pid == 0:  # the child: never returns
        code = 1
        try:
            listener.close()
            code = _run_job(conn, fds, request, job_table)
        finally:
            os._exit(code)
    for fd in fds:
        os.close(fd)
    conn.close()
    return pid


def _run_job(conn: socket.socket, fds: list[int], request: dict[str, Any], job_table: str | Path | None) -> int:
    """In the forked child: become the job's process, run its script, report; return the status."""
    for signum in (*SIGNALS, signal.SIGCHLD):
        signal.signal(signum, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    conn.settimeout(None)
    conn.sendall(b"S")
    if recv_exact(conn, 1) != b"G":
        return 1
    for target, fd in enumerate(fds):
        os.dup2(fd, target)
        os.close(fd)
    os.chdir(request["cwd"])
    os.environ.clear()
    os.environ.update({k: v for k, v in request["env"].items() if k != SOCKET_ENV})
    sys.argv = list(request["argv"])
    sys.path[0] = str(Path(sys.argv[0]).resolve().parent)
    threading.Thread(target=_watch_job_process, args=(conn,), daemon=True).start()
    start = time.perf_counter()
    job: dict[str, Any] = {}
    try:
        job = runpy.run_path(sys.argv[0], run_name="__main__")
        code = 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        if exc.code is not None and not isinstance(exc.code, int):
            print(exc.code, file=sys.stderr)
    except BaseException:  # noqa: BLE001 (reported as the job's own process would: traceback, status 1)
        import traceback

        traceback.print_exc()
        code = 1
    with contextlib.suppress(Exception):
        sys.stdout.flush()
        sys.stderr.flush()
    if job_table is not None:
        _record(job_table, job.get("snakemake"), sys.argv[0], time.perf_counter() - start, code)
    with contextlib.suppress(OSError):
        conn.sendall(STATUS.pack(code))
    return code


def _watch_job_process(conn: socket.socket) -> None:
    """In the child: take the signals the job's process passes on; end when it is gone."""
    while True:
        try:
            data = conn.recv(1)
        except OSError:
            data = b""
        if not data:
            os.kill(os.getpid(), signal.SIGTERM)
            return
        os.kill(os.getpid(), data[0])


def _record(job_table: str | Path, sm: Any, script: str, wall_s: float, code: int) -> None:
    """Append the child's rule, wildcards, CPU, wall time, peak memory and status to the job table."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu_s = own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime
    rule = getattr(sm, "rule", "") or ""
    wildcards = dict(getattr(sm, "wildcards", {}) or {})
    line = "\t".join([str(rule), json.dumps(wildcards, sort_keys=True), f"{cpu_s:.3f}", f"{wall_s:.3f}",
                      f"{max(own.ru_maxrss, kids.ru_maxrss) / 1024:.1f}", str(code), Path(script).name]) + "\n"
    # one write in append mode: the lines of concurrent children do not interleave
    fd = os.open(str(job_table), os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        os.write(fd, line.encode())
    finally:
        os.close(fd)


# ----------------------------------------------------------------------- the workflow side


def install_startup_hook(site_packages: str | Path | None = None) -> Path:
    """Write the start-up hook (:func:`dronewind.steps.handoff.pth_line`) into site-packages.

    Parameters
    ----------
    site_packages : str or Path, optional
        Folder to write it to; by default the running interpreter's ``purelib`` folder
        (the virtual environment's site-packages).

    Returns
    -------
    Path
        The written file (replaced atomically if it was there).
    """
    import sysconfig

    folder = Path(site_packages) if site_packages is not None else Path(sysconfig.get_paths()["purelib"])
    target = folder / PTH_NAME
    tmp = target.with_name(target.name + ".tmp")
    tmp.write_text(pth_line())
    os.replace(tmp, target)
    return target


def supported() -> bool:
    """Whether jobs can be forked from a preloaded process here: Linux only.

    On macOS a process that has loaded the system's frameworks (Accelerate under numpy, for
    one) is not safe to fork without exec, which is why Python's multiprocessing starts
    fresh interpreters there; jobs then import in their own processes as before.
    """
    return sys.platform.startswith("linux") and hasattr(os, "fork") and hasattr(socket, "send_fds")


class PreloadServer:
    """A :func:`serve` process started for one workflow run (Snakefile ``onstart``).

    Parameters
    ----------
    job_table : str or Path
        Job table of the run (:func:`serve`); a header is written when it is new.
    log_file : str or Path
        Where the server's own output goes.

    Examples
    --------
    >>> server = PreloadServer("res/x/benchmarks/jobs.tsv", "res/x/logs/preload.log")  # doctest: +SKIP
    >>> os.environ[SOCKET_ENV] = server.socket_path  # jobs started from now on use it  # doctest: +SKIP
    >>> server.stop()  # doctest: +SKIP
    """

    def __init__(self, job_table: str | Path, log_file: str | Path) -> None:
        import subprocess
        import tempfile

        table = Path(job_table)
        table.parent.mkdir(parents=True, exist_ok=True)
        if not table.exists():
            table.write_text("\t".join(JOB_TABLE_COLUMNS) + "\n")
        Path(log_file).parent.mkdir(parents=True, exist_ok=True)
        self._folder = tempfile.mkdtemp(prefix=FOLDER_PREFIX)  # private (mode 0700)
        self.socket_path = str(Path(self._folder) / "jobs.sock")
        env = {k: v for k, v in os.environ.items() if k != SOCKET_ENV}
        with open(log_file, "ab") as log:
            self._proc = subprocess.Popen(
                [sys.executable, "-m", "dronewind.steps.preload", "--socket", self.socket_path, "--job-table",
                 str(table)], stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT,
                env={**env, **ONE_THREAD_ENV})

    def stop(self, timeout_s: float = 60.0) -> None:
        """End the server after the jobs it runs (SIGTERM, then wait) and remove its folder."""
        import shutil
        import subprocess

        if self._proc.poll() is None:
            self._proc.terminate()
        try:
            self._proc.wait(timeout_s)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()
        shutil.rmtree(self._folder, ignore_errors=True)


def main(argv: Sequence[str] | None = None) -> None:
    """Command line: ``python -m dronewind.steps.preload --socket PATH [--job-table FILE]``."""
    parser = argparse.ArgumentParser(
        prog="python -m dronewind.steps.preload", description=__doc__.split("\n\n")[0],
        epilog="Examples: python -m dronewind.steps.preload --socket /tmp/x/jobs.sock --job-table jobs.tsv "
               "(the workflow starts it itself for a local run; see config key 'preload'); "
               "python -m dronewind.steps.preload --install-hook (make does it when it sets up .venv)")
    parser.add_argument("--socket", help="Unix socket to listen on (required to serve)")
    parser.add_argument("--job-table", help="tab-separated table of the jobs run (CPU, memory, status)")
    parser.add_argument("--install-hook", action="store_true",
                        help=f"write {PTH_NAME} into this interpreter's site-packages and exit "
                             "(jobs then hand themselves over at start-up)")
    args = parser.parse_args(argv)
    if args.install_hook:
        print(f"wrote {install_startup_hook()}")
        return
    if not args.socket:
        parser.error("--socket is required to serve")
    serve(args.socket, args.job_table)


if __name__ == "__main__":
    main()
