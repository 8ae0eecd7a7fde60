"""The preloaded process that runs a local run's jobs (dronewind.steps.preload).

A job's script calls ``delegate()`` first; with a server named in the environment, the
script runs in a child forked from the server, with the job's arguments, environment,
working directory and standard streams, and the job's process exits with its status.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from dronewind.steps.preload import FOLDER_PREFIX, JOB_TABLE_COLUMNS, SOCKET_ENV, PreloadServer

REPO = Path(__file__).resolve().parents[1]

#: A job script: hands itself over, then prints where and how it runs and exits as asked.
JOB = '''
from dronewind.steps.preload import delegate

delegate()

import os, sys, time

print("pid", os.getpid(), "cwd", os.getcwd(), "x", os.environ.get("JOB_X"), "argv", " ".join(sys.argv[1:]),
      "socket" , os.environ.get("{socket_env}", "-"), flush=True)
print("to stderr", file=sys.stderr, flush=True)
mode = sys.argv[1]
if mode == "raise":
    raise ValueError("the job failed")
if mode == "sleep":
    time.sleep(60)
sys.exit(int(mode))
'''.replace("{socket_env}", SOCKET_ENV)


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    folder = tmp_path_factory.mktemp("preload")
    srv = PreloadServer(folder / "jobs.tsv", folder / "preload.log")
    deadline = time.time() + 120
    while not Path(srv.socket_path).exists():  # the libraries are being imported
        assert time.time() < deadline, (folder / "preload.log").read_text()
        time.sleep(0.1)
    yield srv, folder
    srv.stop()


def _job(tmp_path: Path, server_socket: str | None, *args: str, python: str = sys.executable,
         **kwargs) -> subprocess.Popen:
    script = tmp_path / "job.py"
    script.write_text(JOB)
    env = {**os.environ, "PYTHONPATH": str(REPO / "src"), "JOB_X": "42"}
    env.pop(SOCKET_ENV, None)
    if server_socket:
        env[SOCKET_ENV] = server_socket
    return subprocess.Popen([python, str(script), *args], cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kwargs)


def _fields(out: str) -> dict[str, str]:
    words = out.split()
    return dict(zip(words[::2], words[1::2], strict=False))


def test_the_job_runs_in_a_child_of_the_server_as_it_would_run_itself(server, tmp_path):
    srv, folder = server
    proc = _job(tmp_path, srv.socket_path, "3")
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 3, err
    f = _fields(out)
    assert int(f["pid"]) != proc.pid  # not the job's own process
    assert f["cwd"] == str(tmp_path) and f["x"] == "42" and f["argv"] == "3"
    assert f["socket"] == "-"  # the child does not hand itself over again
    assert "to stderr" in err
    lines = (folder / "jobs.tsv").read_text().splitlines()
    assert lines[0].split("\t") == list(JOB_TABLE_COLUMNS)
    last = dict(zip(JOB_TABLE_COLUMNS, lines[-1].split("\t"), strict=True))
    assert last["exit_status"] == "3" and last["script"] == "job.py" and float(last["cpu_s"]) >= 0


def test_status_zero_and_an_exception_with_its_traceback(server, tmp_path):
    srv, _ = server
    ok = _job(tmp_path, srv.socket_path, "0")
    assert ok.communicate(timeout=60) and ok.returncode == 0
    bad = _job(tmp_path, srv.socket_path, "raise")
    _, err = bad.communicate(timeout=60)
    assert bad.returncode == 1
    assert "Traceback" in err and "ValueError: the job failed" in err


def test_without_a_server_or_with_another_interpreter_the_job_runs_itself(server, tmp_path):
    srv, _ = server
    alone = _job(tmp_path, None, "0")
    out, _ = alone.communicate(timeout=60)
    assert alone.returncode == 0 and int(_fields(out)["pid"]) == alone.pid
    gone = _job(tmp_path, str(tmp_path / "no_such.sock"), "5")
    out, _ = gone.communicate(timeout=60)
    assert gone.returncode == 5 and int(_fields(out)["pid"]) == gone.pid
    other = "/usr/bin/python3"  # the server serves only jobs of its own interpreter (by path)
    if not Path(other).exists():
        pytest.skip(f"no {other} on this machine")
    refused = _job(tmp_path, srv.socket_path, "0", python=other)
    out, err = refused.communicate(timeout=60)
    assert refused.returncode == 0, err
    assert int(_fields(out)["pid"]) == refused.pid  # refused: ran in its own process


@pytest.mark.parametrize("how", ["SIGTERM", "SIGKILL"])
def test_stopping_the_job_stops_its_child(server, tmp_path, how):
    """Snakemake stopping a job (SIGTERM) or the job's process killed: the child ends too."""
    srv, _ = server
    proc = _job(tmp_path, srv.socket_path, "sleep")
    assert proc.stdout is not None
    child = int(_fields(proc.stdout.readline())["pid"])
    os.kill(proc.pid, getattr(signal, how))
    proc.wait(timeout=30)
    assert proc.returncode != 0
    deadline = time.time() + 10
    while time.time() < deadline and Path(f"/proc/{child}").exists() and \
            Path(f"/proc/{child}/stat").read_text().split()[2] != "Z":
        time.sleep(0.05)
    alive = Path(f"/proc/{child}").exists() and Path(f"/proc/{child}/stat").read_text().split()[2] != "Z"
    assert not alive, f"child {child} still runs after the job's process got {how}"


def test_the_server_ends_with_its_parent(tmp_path):
    """A server whose parent (Snakemake) is gone stops serving and removes its socket and its folder."""
    sock = tmp_path / f"{FOLDER_PREFIX}x" / "s.sock"
    sock.parent.mkdir()
    serve = f"from dronewind.steps.preload import serve; serve({str(sock)!r}, preload=False)"
    (tmp_path / "parent.py").write_text(
        f"import subprocess, sys, time\nsubprocess.Popen([sys.executable, '-c', {serve!r}])\ntime.sleep(300)\n")
    parent = subprocess.Popen([sys.executable, str(tmp_path / "parent.py")],
                              env={**os.environ, "PYTHONPATH": str(REPO / "src")})
    try:
        deadline = time.time() + 60
        while not sock.exists():
            assert time.time() < deadline
            time.sleep(0.05)
    finally:
        parent.kill()
        parent.wait()
    deadline = time.time() + 10
    while sock.parent.exists() and time.time() < deadline:
        time.sleep(0.05)
    assert not sock.exists() and not sock.parent.exists()


def test_the_server_imports_the_library_but_not_dask_array():
    """Jobs see the modules a process of their own would have, plus the library: never dask.array (duck arrays)."""
    code = ("import sys\n"
            "from dronewind.steps.preload import library_modules, preload_libraries\n"
            "assert {'dronewind.steps.payload', 'dronewind.compare.long_record', 'dronewind.cli'} <= "
            "set(library_modules())\n"
            "preload_libraries()\n"
            "assert {'dronewind.steps.payload', 'dronewind.cli', 'xarray', 'scipy.signal'} <= set(sys.modules)\n"
            "print(sorted(m for m in ('dask.array', 'pint', 'matplotlib.pyplot') if m in sys.modules))\n")
    proc = subprocess.run([sys.executable, "-c", code], env={**os.environ, "PYTHONPATH": str(REPO / "src")},
                          capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip() == "[]"


# ------------------------------------------------------------------ the start-up hook (handoff)

#: A Snakemake script job: what ran in the job's own process before the hand-over, then where it runs.
SNAKEMAKE_JOB = '''
import os, sys
print("pid", os.getpid(), "first_line_socket", os.environ.get("{socket_env}", "-"), flush=True)
from dronewind.steps.preload import delegate

delegate()
print("after", os.getpid(), flush=True)
sys.exit(int(sys.argv[1]))
'''.replace("{socket_env}", SOCKET_ENV)


def _hook_env(tmp_path: Path) -> dict[str, str]:
    """Environment in which this interpreter's start-up runs the hook: a site folder that holds the .pth file.

    The folder is on ``PYTHONPATH`` with a ``sitecustomize`` that adds it as a site folder
    (``site.addsitedir``), which runs its .pth lines as site-packages' own are run.
    """
    from dronewind.steps.preload import install_startup_hook

    site_dir = tmp_path / "site"
    site_dir.mkdir()
    pth = install_startup_hook(site_dir)
    assert pth.name == "dronewind_preload.pth" and pth.read_text().startswith("import os;")
    (site_dir / "sitecustomize.py").write_text(f"import site\nsite.addsitedir({str(site_dir)!r})\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(site_dir), str(REPO / "src")])}
    env.pop(SOCKET_ENV, None)
    return env


@pytest.mark.parametrize("where", [".snakemake/scripts", "elsewhere"])
def test_the_start_up_hook_hands_over_snakemake_scripts_before_their_first_line(server, tmp_path, where):
    """Installed, the hook hands a Snakemake script job over as the interpreter starts (before the
    preamble's Snakemake import); any other script still runs up to its own ``delegate()``."""
    srv, _ = server
    env = _hook_env(tmp_path)
    script = tmp_path / where / "tmpabc123.job.py"
    script.parent.mkdir(parents=True)
    script.write_text(SNAKEMAKE_JOB)
    proc = subprocess.run([sys.executable, str(script.relative_to(tmp_path)), "4"], cwd=tmp_path,
                          env={**env, SOCKET_ENV: srv.socket_path}, capture_output=True, text=True, timeout=60,
                          check=False)
    assert proc.returncode == 4, proc.stderr
    lines = [line.split() for line in proc.stdout.splitlines()]
    first, after = lines[0], lines[-1]
    if where == ".snakemake/scripts":  # the whole file ran in the server's child, the first line too
        assert first[3] == "-" and len(lines) == 2 and first[1] == after[1]
    else:  # the first line ran in the job's own process, the rest in the child
        assert first[3] == srv.socket_path and len(lines) == 3 and lines[1][1] != first[1]
    # without a server named, the hook does nothing
    alone = subprocess.run([sys.executable, str(script.relative_to(tmp_path)), "0"], cwd=tmp_path, env=env,
                           capture_output=True, text=True, timeout=60, check=False)
    assert alone.returncode == 0 and alone.stdout.split()[1] == alone.stdout.split()[-1]


_FREED_MEMORY_SCRIPT = """
import resource, sys
import numpy as np
if sys.argv[1] == "keep":
    from dronewind.steps.handoff import keep_freed_memory
    assert keep_freed_memory()
def round_():
    arrays = [np.ones(500_000) for _ in range(60)]  # 60 x 4 MB, freed together
    del arrays
round_()
f0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(3):
    round_()
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0)
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_jobs_reuse_the_memory_they_free():
    """keep_freed_memory (the server's children and jobs in their own process): a job that frees
    240 MB of 4 MB arrays and allocates them again takes no new pages; by default glibc hands the
    freed heap back and the next round faults in (and zeroes) about 60,000 pages again per round."""
    faults = {}
    for mode in ("keep", "default"):
        out = subprocess.run([sys.executable, "-c", _FREED_MEMORY_SCRIPT, mode], capture_output=True, text=True,
                             check=True, env={**os.environ, "PYTHONPATH": str(Path(__file__).parents[1] / "src")})
        faults[mode] = int(out.stdout.split()[-1])
    assert faults["keep"] < 1000 < 50_000 < faults["default"], faults
