"""The job side of the preloaded server (:mod:`dronewind.steps.preload`): hand a job's script to it.

Kept apart from the server, with only light standard-library imports, because it runs in
every job's own process before any work: from a script's first line (:func:`delegate`), or
earlier still, at interpreter start-up (:func:`startup_hook`, from the ``.pth`` file that
``python -m dronewind.steps.preload --install-hook`` puts into the environment's
site-packages; ``make`` does so when it sets up ``.venv``).

Why at start-up: Snakemake runs a ``script:`` job as ``python .snakemake/scripts/tmpXXXX.<name>.py``,
whose preamble unpickles the job's ``snakemake`` object and so imports Snakemake itself, about
0.14 CPU-s before the script's first line can hand the job over; the package imports of
that first line cost another 0.09 (0.04 now that ``dronewind.__version__`` is looked up only
when asked for). With the hook the job's process spends about 0.04 CPU-s in all, and the
server's child runs the whole file, preamble included, with Snakemake already imported.
Both ways run the same file in the same child (the outputs are the same bit for bit;
tested); without the ``.pth`` file, or outside a local workflow run, the hook does nothing.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import struct
import sys

__all__ = ["SOCKET_ENV", "ACCEPT_TIMEOUT_S", "PTH_NAME", "delegate", "is_snakemake_script", "startup_hook",
           "pth_line", "keep_freed_memory", "MMAP_THRESHOLD_BYTES", "TRIM_THRESHOLD_BYTES"]

#: Environment variable naming the server's socket; set by the workflow for its jobs.
SOCKET_ENV = "DRONEWIND_PRELOAD_SOCKET"
#: How long a job waits for the server to take it before it runs on its own [s].
ACCEPT_TIMEOUT_S = 20.0
#: Name of the start-up file in site-packages (:func:`pth_line`).
PTH_NAME = "dronewind_preload.pth"

SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
#: Length prefix of a job's request, and the child's exit status (network byte order).
LENGTH = struct.Struct("!I")
STATUS = struct.Struct("!i")


#: Allocations from this size on get their own pages from the system (glibc's ``M_MMAP_THRESHOLD``)
#: [bytes]: the series of a forward run (up to 1.5 MB per channel) are reused from the heap, a
#: long record's day-long arrays are not kept in it.
MMAP_THRESHOLD_BYTES = 4 * 2**20
#: Free memory at the top of the heap kept for later allocations (glibc's ``M_TRIM_THRESHOLD``) [bytes].
TRIM_THRESHOLD_BYTES = 2**30
#: ``mallopt`` parameter numbers (glibc's malloc.h).
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3


def keep_freed_memory() -> bool:
    """Let this process reuse the memory it frees instead of handing it back to the system (glibc).

    A job allocates and frees arrays of a few MB again and again (a forward run's series,
    spectra and rotation matrices). By default glibc returns the freed top of its heap to
    the system once more than twice the mmap threshold is free, so the next run's arrays
    land on fresh pages that the kernel must zero first: system time, not work. Measured
    on the published-numbers job of sample s01 (36 forward runs, forked from a preloaded
    process; ``benchmarks/bench_freed_memory.py``, ``results/freed_memory_s29.json``): 0.65
    and 0.74 system CPU-s by default, 0.41 and 0.39 with these settings; s05: 0.32 against
    0.17 and 0.18; user time unchanged (5.4-5.5 and 2.7 s). Both parameters are set: setting either one
    turns glibc's dynamic mmap threshold off, and the trim threshold alone would leave every
    array above 128 kB to its own mapping (10 times the system time). What is kept is what
    the job had at its peak, returned when it exits; a long mast record (3 days of 20 Hz
    through L1 to L4) peaked at 614 and 626 MB with these settings and 646 MB without, at 3 %
    more CPU (``results/long_record_s29_freed_memory.json``).

    Returns
    -------
    bool
        True if the C library took both settings (glibc); False elsewhere (another C
        library, another system), where nothing changes.
    """
    try:
        import ctypes

        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError, TypeError):
        return False
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    return bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES) == 1
                and mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES) == 1)


def delegate() -> None:
    """Hand the running job to the workflow's preloaded server, if one serves it; else return.

    Call it first in a script, before its imports. When a server takes the job, this
    function does not return: the job's process exits with the status of the child that
    ran the script. It returns (and the script goes on in its own process) when no server
    is named in the environment, the server cannot be reached or refuses the job (another
    interpreter), or it does not take the job within :data:`ACCEPT_TIMEOUT_S`. A job that runs in
    its own process reuses the memory it frees (:func:`keep_freed_memory`), as the server's
    children do.
    """
    path = os.environ.get(SOCKET_ENV)
    if not path:
        keep_freed_memory()
        return
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        sock.settimeout(ACCEPT_TIMEOUT_S)
        sock.connect(path)
        request = json.dumps({"executable": sys.executable, "argv": sys.argv, "cwd": os.getcwd(),
                              "env": dict(os.environ)}).encode()
        socket.send_fds(sock, [LENGTH.pack(len(request))], [0, 1, 2])
        sock.sendall(request)
        if recv_exact(sock, 1) != b"S":  # refused (another interpreter)
            raise EOFError("refused")
        sock.sendall(b"G")  # committed: from here on the child runs the job
    except Exception:  # noqa: BLE001 (nothing has run yet: the job runs in its own process)
        sock.close()
        keep_freed_memory()
        return
    sock.settimeout(None)
    code = _wait_for_child(sock)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


def _wait_for_child(sock: socket.socket) -> int:
    """Pass signals on to the child until it reports its exit status; return the status."""

    def forward(signum: int, _frame: object) -> None:
        try:
            sock.sendall(bytes([signum]))
        except OSError:
            pass

    for signum in SIGNALS:
        signal.signal(signum, forward)
    try:
        return STATUS.unpack(recv_exact(sock, STATUS.size))[0]
    except (OSError, EOFError):
        print("dronewind.steps.preload: the job's process in the preloaded server ended without an exit status "
              "(killed?)", file=sys.stderr)
        return 1


def recv_exact(sock: socket.socket, n: int) -> bytes:
    """Exactly ``n`` bytes from ``sock``; EOFError when it closes first."""
    data = b""
    while len(data) < n:
        chunk = sock.recv(n - len(data))
        if not chunk:
            raise EOFError("socket closed")
        data += chunk
    return data


def is_snakemake_script(path: str) -> bool:
    """Whether ``path`` is a script Snakemake wrote for a ``script:`` job (``.snakemake/scripts/*.py``)."""
    folder = os.path.dirname(os.path.abspath(path))
    return (path.endswith(".py") and os.path.basename(folder) == "scripts"
            and os.path.basename(os.path.dirname(folder)) == ".snakemake")


def startup_hook() -> None:
    """At interpreter start-up: hand a Snakemake script job to the server before its preamble runs.

    Acts only when :data:`SOCKET_ENV` is set (a local workflow run that started a server)
    and the interpreter was started on a Snakemake script (:func:`is_snakemake_script`);
    otherwise, or when the server does not take the job, start-up goes on as usual.
    """
    if os.environ.get(SOCKET_ENV) and len(sys.argv) > 0 and is_snakemake_script(sys.argv[0]):
        delegate()


def pth_line() -> str:
    """The one line of :data:`PTH_NAME`: the hook, imported only when a workflow run named a server.

    Lines of a ``.pth`` file that begin with ``import`` are run by :mod:`site` at every
    start-up of the environment's interpreter; without :data:`SOCKET_ENV` this one costs a
    dictionary lookup.
    """
    return (f"import os; os.environ.get({SOCKET_ENV!r}) and "
            "__import__('dronewind.steps.handoff', fromlist=['startup_hook']).startup_hook()\n")
